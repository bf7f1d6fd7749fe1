"""Plain (ASCII) PGM ``P2`` / PPM ``P3`` files: the chunked array parse of
:mod:`topojax.maps.pnm` against a word-by-word reference, its faults and its memory."""

from __future__ import annotations

import re
import tracemalloc
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from topojax.maps import pnm
from topojax.maps.pnm import read_image

_SPACES = [b" ", b"\t", b"\n", b"\r", b"\r\n", b"\x0b", b"\x0c", b"  \n"]


def reference_plain_pnm(data: bytes) -> np.ndarray:
    """A valid plain PNM file read word by word: comments (``#`` to the end of the line,
    a line feed or a carriage return) blanked, words split at ASCII whitespace, each one
    ``int``."""
    words = re.sub(rb"#[^\r\n]*", b" ", data[2:]).split()
    assert all(w.isdigit() for w in words)
    width, height, maxval = (int(w) for w in words[:3])
    channels = 3 if data[:2] == b"P3" else 1
    values = [int(w) for w in words[3:]]
    assert len(values) == width * height * channels and max(values) <= maxval
    shape = (height, width) if channels == 1 else (height, width, 3)
    return np.array(values, dtype=np.uint8 if maxval < 256 else np.uint16).reshape(shape)


@st.composite
def plain_files(draw) -> bytes:
    """A valid plain PGM/PPM file with random separators: runs of whitespace (CR, LF,
    CRLF, tabs, vertical tabs, form feeds) and comments, glued to numbers or not, and
    numbers with leading zeros."""
    channels = draw(st.sampled_from([1, 3]))
    width, height = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    maxval = draw(st.sampled_from([1, 7, 100, 255, 256, 1000, 65535]))
    n = width * height * channels
    values = draw(st.lists(st.integers(0, maxval), min_size=n, max_size=n))
    body = st.binary(max_size=12).map(lambda b: b.replace(b"\n", b"x").replace(b"\r", b"x"))
    end = st.sampled_from([b"\n", b"\r", b"\r\n"])
    comment = st.tuples(body, end).map(lambda t: b"#" + t[0] + t[1])
    gap = st.lists(st.one_of(st.sampled_from(_SPACES), comment), min_size=1, max_size=3)
    out = [b"P3" if channels == 3 else b"P2"]
    for number in [width, height, maxval, *values]:
        out += draw(gap) + [b"0" * draw(st.integers(0, 2)) + str(number).encode()]
    tail = draw(st.lists(st.one_of(st.sampled_from(_SPACES), comment), max_size=2))
    if draw(st.booleans()):
        tail.append(b"# a last comment without its newline")
    return b"".join(out + tail)


@settings(max_examples=300, deadline=None)
@given(data=plain_files(), chunk=st.sampled_from([8, 9, 13, 32, 1 << 18]))
def test_plain_pnm_matches_a_word_by_word_reference(data: bytes, chunk: int) -> None:
    """The same pixels and dtype as the reference, whatever the chunk boundaries (from
    8 bytes, cutting comments and runs of whitespace anywhere)."""
    with mock.patch.object(pnm, "_PLAIN_CHUNK", chunk):
        got = pnm._read_plain_pnm(data, Path("x.pgm"))
    want = reference_plain_pnm(data)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert np.array_equal(got, want)


def test_plain_pnm_separators_and_comments(tmp_path: Path) -> None:
    """CRLF lines, tabs, a comment inside the header and one glued to a number."""
    text = b"P2\r\n# by hand\r\n3\t2 # width, height\r\n255\r\n1 2 3#c 4\n4\x0b5\x0c006\n"
    (tmp_path / "a.pgm").write_bytes(text)
    pixels, full, comments = read_image(tmp_path / "a.pgm")
    assert pixels.dtype == np.uint8 and pixels.tolist() == [[1, 2, 3], [4, 5, 6]]
    assert full == 255 and comments == ["by hand", "width, height"]
    (tmp_path / "w.ppm").write_bytes(b"P3 1 2 65535 65535 0 00000000001 7 8 9")
    pixels = read_image(tmp_path / "w.ppm")[0]
    assert pixels.dtype == np.uint16 and pixels.tolist() == [[[65535, 0, 1]], [[7, 8, 9]]]


FAULTS = {
    # a word that is not an unsigned decimal integer, named with its place in the file
    "sign.pgm": (b"P2\n2 1\n255\n0 -1\n", r"non-numeric entries: '-1' at byte 13 has a sign"),
    "plus.pgm": (b"P2\n2 1\n255\n+0 1\n", r"non-numeric entries: '\+0' at byte 11 has a sign"),
    "under.pgm": (b"P2\n2 1\n255\n0 1_0\n", r"non-numeric entries: '1_0' at byte 13;"),
    "dot.pgm": (b"P2\n2 1\n255\n0 5.0\n", "non-numeric entries: '5.0'"),
    "head.pgm": (b"P2\n2 x1\n255\n0 0\n", "non-numeric entries: 'x1' at byte 5"),
    "nul.pgm": (b"P2\n2 1\n255\n0 1\x00\n", "non-numeric entries"),
    # ... before any other fault
    "first.pgm": (b"P2\n0 1\n255\n0 1 2 x\n", "non-numeric entries: 'x'"),
    # the header
    "cut.pgm": (b"P2\n3 2", "incomplete plain PNM header: .*received '3 2'"),
    "bare.pgm": (b"P2\n# only a comment\n", "incomplete plain PNM header: .*received ''"),
    "max0.pgm": (b"P2\n2 1\n0\n0 0\n", "received 2 x 1, maxval 0"),
    "max16.pgm": (b"P2\n2 1\n65536\n0 0\n", "received 2 x 1, maxval 65536"),
    "maxlong.pgm": (b"P2\n2 1\n" + b"9" * 30 + b"\n0 0\n", "received 2 x 1, maxval 9{30}$"),
    "maxhuge.pgm": (b"P2\n2 1\n" + b"9" * 200 + b"\n0 0\n", "received a maxval of 200 digits"),
    "wide.pgm": (b"P2\n" + b"9" * 30 + b" 1\n255\n0 0\n", "must hold 9{30} values, found 2"),
    "high.pgm": (b"P2\n1 00" + b"9" * 200 + b"\n255\n0\n", "received a height of 200 digits"),
    # the number of samples, before their values
    "many.pgm": (b"P2\n2 1\n255\n0 1 2\n", "must hold 2 values, found 3"),
    "few.pgm": (b"P2\n2 1\n100\n101\n", "must hold 2 values, found 1"),
    "ppm.pgm": (b"P3\n2 1\n255\n0 1 2 3 4\n", r"2 x 1 pixels must hold 6 values, found 5"),
    "huge.pgm": (b"P2\n100000 100000\n255\n0 0\n", "must hold 10000000000 values, found 2"),
    # values above maxval, however many digits they have: no wrap-around
    "over.pgm": (b"P2\n2 1\n255\n0 256\n", "above its PGM maxval 255"),
    "over16.pgm": (b"P2\n2 1\n65535\n0 65536\n", "above its PGM maxval 65535"),
    "five.pgm": (b"P2\n2 1\n65535\n0 99999\n", "above its PGM maxval 65535"),
    "six.pgm": (b"P2\n2 1\n65535\n0 100000\n", "above its PGM maxval 65535"),
    "zeros.pgm": (b"P2\n2 1\n255\n0 0000000000256\n", "above its PGM maxval 255"),
    "long.pgm": (b"P2\n2 1\n255\n0 " + b"9" * 30 + b"\n", "above its PGM maxval 255"),
    "wrap.pgm": (b"P2\n2 1\n255\n0 " + b"1" + b"0" * 29 + b"\n", "above its PGM maxval 255"),
}


@pytest.mark.parametrize("name", sorted(FAULTS))
def test_plain_pnm_faults_are_named(tmp_path: Path, name: str) -> None:
    data, message = FAULTS[name]
    (tmp_path / name).write_bytes(data)
    with pytest.raises(ValueError, match=message) as err:
        read_image(tmp_path / name)
    assert name in str(err.value)


def test_plain_pnm_entry_longer_than_a_chunk_is_refused(tmp_path: Path) -> None:
    """A word of a whole chunk or more is refused wherever it lies; leading zeros below
    that are read."""
    with mock.patch.object(pnm, "_PLAIN_CHUNK", 64):
        for data in (b"P2\n1 1\n255\n" + b"0" * 70 + b"5", b"P2\n2 1\n255\n" + b"0" * 70 + b" 5"):
            with pytest.raises(ValueError, match="entry of 64 characters or more at byte 11"):
                pnm._read_plain_pnm(data, Path("x.pgm"))
        got = pnm._read_plain_pnm(b"P2\n2 1\n255\n" + b"0" * 60 + b"5 7", Path("x.pgm"))
        assert got.tolist() == [[5, 7]]


def _traced_peak(data: bytes) -> tuple[np.ndarray | None, int]:
    tracemalloc.start()
    try:
        try:
            pixels = pnm._read_plain_pnm(data, Path("x.pgm"))
        except ValueError:
            pixels = None
        return pixels, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_plain_pnm_parse_builds_no_object_per_pixel() -> None:
    """A 1000 x 1000 file (3.6 MB of text) takes the pixels and a scratch space bounded
    by the chunk, not a Python object per number (about 50 bytes each)."""
    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, size=(1000, 1000))
    rows = "\n".join(" ".join(map(str, row)) for row in img.tolist())
    data = f"P2\n# map\n1000 1000\n255\n{rows}\n".encode()
    pixels, peak = _traced_peak(data)
    assert pixels is not None and np.array_equal(pixels, img)
    assert peak < pixels.nbytes + 12 * 2**20, peak
    # a header claiming more pixels than the file can hold allocates none of them
    assert _traced_peak(b"P2\n100000 100000\n255\n" + b"0 " * 1000)[1] < 2**20


def test_a_comment_ends_at_a_carriage_return(tmp_path):
    """Netpbm ends a comment at the next line feed or carriage return: a file with
    classic Mac line ends (CR only) reads, and so does its header's resolution comment."""
    text = b"P2\r# CREATOR: map_saver.cpp 0.050 m/pix\r3 2\r255\r# row 1\r1 2 3\r4 5 6\r"
    path = tmp_path / "cr.pgm"
    path.write_bytes(text)
    pixels, maxval, comments = read_image(path)
    assert np.array_equal(pixels, [[1, 2, 3], [4, 5, 6]]) and maxval == 255
    assert comments == ["CREATOR: map_saver.cpp 0.050 m/pix"]
