"""Map images in less common formats and damaged files, as :func:`topojax.load_map` reads
them: a map where the format says what the pixels are, an error naming the file where it
does not, and nothing from the C decoders on standard error."""

from __future__ import annotations

import io
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

from topojax.maps import OccupancyMap, load_map

#: A map_saver map: 0 occupied, 205 unknown, 254 free.
GREY = np.full((20, 30), 254, np.uint8)
GREY[5:15, 10:20] = 0
GREY[:, :4] = 205


def _assert_grey_map(m) -> None:
    assert np.array_equal(m.occupied, GREY == 0)
    assert np.array_equal(m.unknown, GREY == 205)
    assert np.array_equal(m.free, GREY == 254)


def _chunk(kind: bytes, body: bytes) -> bytes:
    crc = zlib.crc32(kind + body) & 0xFFFFFFFF
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)


def _png(extra: bytes = b"", image: np.ndarray = GREY) -> bytes:
    """An 8-bit grey PNG of ``image``, with the chunks ``extra`` before its data."""
    h, w = image.shape
    header = _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
    rows = b"".join(b"\0" + row.tobytes() for row in image)
    return (
        b"\x89PNG\r\n\x1a\n"
        + header
        + extra
        + _chunk(b"IDAT", zlib.compress(rows))
        + _chunk(b"IEND", b"")
    )


def test_formats_with_a_clear_meaning_are_read_as_that_map(tmp_path: Path):
    """16-bit grey on its full scale, 1-bit, palette with a transparent entry, CMYK TIFF."""
    deep = (GREY.astype(np.uint32) * 257).astype(np.uint16)
    Image.fromarray(deep).save(tmp_path / "deep.png")
    assert Image.open(tmp_path / "deep.png").mode == "I;16"
    Image.fromarray(GREY).convert("P").save(tmp_path / "palette.png", transparency=0)
    Image.fromarray(GREY).convert("CMYK").save(tmp_path / "cmyk.tif")
    for name in ("deep.png", "palette.png", "cmyk.tif"):
        _assert_grey_map(load_map(tmp_path / name, resolution_m=0.05))
    binary = GREY > 128
    Image.fromarray(binary).save(tmp_path / "bits.png")
    assert Image.open(tmp_path / "bits.png").mode == "1"
    m = load_map(tmp_path / "bits.png")
    assert np.array_equal(m.occupied, ~binary) and np.array_equal(m.free, binary)


def test_a_cmyk_jpeg_keeps_its_grey_levels(tmp_path: Path):
    """OpenCV converts CMYK a level too light (the unknown 205 would come out a free
    206): a CMYK JPEG keeps its grey levels."""
    path = tmp_path / "cmyk.jpg"
    Image.fromarray(np.dstack([GREY] * 3)).convert("CMYK").save(path, quality=100)
    _assert_grey_map(load_map(path, resolution_m=0.05))


def test_an_image_of_several_pages_or_frames_is_refused(tmp_path: Path):
    black = Image.fromarray(np.zeros_like(GREY))
    Image.fromarray(GREY).save(tmp_path / "pages.tif", save_all=True, append_images=[black])
    Image.fromarray(GREY).save(tmp_path / "anim.png", save_all=True, append_images=[black])
    gif = tmp_path / "anim.gif"
    Image.fromarray(GREY).convert("P").save(gif, save_all=True, append_images=[black])
    (tmp_path / "gif.yaml").write_text("image: anim.gif\nresolution: 0.05\norigin: [0, 0, 0]\n")
    for name, what in (
        ("pages.tif", "2 pages (a multi-page TIFF)"),
        ("anim.png", "2 frames (an animated PNG)"),
        ("gif.yaml", "2 frames (an animation)"),
    ):
        with pytest.raises(ValueError) as err:
            load_map(tmp_path / name, resolution_m=0.05)
        image = tmp_path / name.replace("gif.yaml", "anim.gif")
        assert str(err.value).startswith(f"map image {image} holds {what}; expected a single")


def test_a_tiff_with_a_reduced_resolution_copy_is_one_image(tmp_path: Path):
    """A thumbnail or overview page (NewSubfileType 1) is not a second map."""
    path = tmp_path / "overview.tif"
    small = Image.fromarray(GREY[::2, ::2])
    small.encoderinfo = {"tiffinfo": {254: 1}}
    Image.fromarray(GREY).save(path, save_all=True, append_images=[small])
    with Image.open(path) as im:
        assert im.n_frames == 2
    _assert_grey_map(load_map(path, resolution_m=0.05))


def test_damaged_pngs_are_refused_with_libpngs_reason_and_nothing_on_stderr(tmp_path: Path, capfd):
    good = _png()
    idat = good.index(b"IDAT")
    bad_crc = bytearray(good)
    bad_crc[idat + 4 + struct.unpack(">I", good[idat - 4 : idat])[0]] ^= 0xFF
    cases = {
        "crc.png": (bytes(bad_crc), "IDAT: CRC error"),
        "no_end.png": (good[:-12], "PNG input buffer is incomplete"),
    }
    for name, (data, reason) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(ValueError) as err:
            load_map(path, resolution_m=0.05)
        assert str(err.value).startswith(f"could not decode map image {path}: its PNG data is")
        assert f"(libpng: {reason})" in str(err.value)
    assert capfd.readouterr().err == ""


def test_libpng_warnings_on_a_readable_png_stay_off_stderr(tmp_path: Path, capfd):
    """An ancillary chunk libpng complains about (a colour profile, a damaged comment)
    says nothing about the pixels."""
    bad_text = bytearray(_chunk(b"tEXt", b"Comment\0map"))
    bad_text[-1] ^= 0xFF
    short_profile = _chunk(b"iCCP", b"sRGB\0\0" + zlib.compress(b"not a profile"))
    for name, extra in (("text.png", bytes(bad_text)), ("icc.png", short_profile)):
        (tmp_path / name).write_bytes(_png(extra))
        _assert_grey_map(load_map(tmp_path / name, resolution_m=0.05))
    assert capfd.readouterr().err == ""


def _jpeg() -> bytes:
    buf = io.BytesIO()
    Image.fromarray(np.tile(GREY, (4, 4))).save(buf, "JPEG", quality=95)
    return buf.getvalue()


def test_a_jpeg_the_decoder_calls_corrupt_is_refused(tmp_path: Path, capfd):
    """48 one bits in the compressed data are no Huffman code; libjpeg fills in the rest
    of the image. libjpeg-turbo says so only on its careful path, which it takes in the
    last 512 bytes of the data (its fast one makes up the pixels without a word)."""
    data = _jpeg()
    at = len(data) - 100
    while data[at - 1] == 0xFF:  # not the second byte of a stuffed 0xFF 0x00
        at -= 1
    path = tmp_path / "corrupt.jpg"
    path.write_bytes(data[:at] + b"\xff\x00" * 6 + data[at + 12 :])
    with pytest.raises(ValueError) as err:
        load_map(path, resolution_m=0.05)
    assert str(err.value).startswith(f"map image {path}: its JPEG data is damaged")
    assert "Corrupt JPEG data: bad Huffman code" in str(err.value)
    assert capfd.readouterr().err == ""


def test_zero_bytes_before_a_jpegs_end_are_padding_and_other_bytes_damage(tmp_path: Path, capfd):
    """libjpeg says the same of both, "N extraneous bytes before marker 0xd9": zeros some
    writers pad a file with change no pixel; the other bytes are compressed data left over
    where the decoder lost its place, as it does for most damage within the data."""
    data = _jpeg()
    (tmp_path / "plain.jpg").write_bytes(data)
    (tmp_path / "padded.jpg").write_bytes(data[:-2] + b"\0" * 40 + data[-2:])
    (tmp_path / "junk.jpg").write_bytes(data[:-2] + b"junk" * 10 + data[-2:])
    plain = load_map(tmp_path / "plain.jpg", resolution_m=0.05)
    padded = load_map(tmp_path / "padded.jpg", resolution_m=0.05)
    for layer in ("occupied", "free", "unknown"):
        assert np.array_equal(getattr(padded, layer), getattr(plain, layer))
    with pytest.raises(ValueError, match="extraneous bytes before marker 0xd9"):
        load_map(tmp_path / "junk.jpg", resolution_m=0.05)
    assert capfd.readouterr().err == ""


def test_other_output_on_stderr_during_a_decode_is_kept(tmp_path: Path, capfd, monkeypatch):
    """Standard error is the process's: a line another thread writes while a map decodes
    reaches it; the decoder's lines do not."""
    decode = cv2.imdecode

    def imdecode(buf, flags):
        import os

        os.write(2, b"another thread\nlibpng warning: iCCP: known incorrect sRGB profile\n")
        return decode(buf, flags)

    monkeypatch.setattr(cv2, "imdecode", imdecode)
    (tmp_path / "m.png").write_bytes(_png())
    _assert_grey_map(load_map(tmp_path / "m.png", resolution_m=0.05))
    assert capfd.readouterr().err == "another thread\n"


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="counts /proc/self/fd")
def test_a_map_decodes_without_a_temporary_file_to_hear_the_decoder(tmp_path: Path, monkeypatch):
    """No writable temporary folder (or a full disk): the decoder's lines reach stderr,
    the map loads, and no file descriptor is left open."""
    import os

    from topojax.maps import _decode

    def no_file():
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_decode.tempfile, "TemporaryFile", no_file)
    (tmp_path / "m.png").write_bytes(_png())
    before = len(os.listdir("/proc/self/fd"))
    for _ in range(5):
        _assert_grey_map(load_map(tmp_path / "m.png", resolution_m=0.05))
    assert len(os.listdir("/proc/self/fd")) == before


def test_files_without_pixels_say_what_they_are(tmp_path: Path, capfd):
    empty = _chunk(b"IHDR", struct.pack(">IIBBBBB", 0, 0, 8, 0, 0, 0, 0))
    (tmp_path / "empty.png").write_bytes(
        b"\x89PNG\r\n\x1a\n" + empty + _chunk(b"IDAT", zlib.compress(b"")) + _chunk(b"IEND", b"")
    )
    (tmp_path / "notes.png").write_text("this is a text file\n")
    (tmp_path / "cut.png").write_bytes(_png()[:60])
    cases = {
        "empty.png": ": its header gives 0 x 0 pixels; expected an image of at least 2 x 2",
        "notes.png": ", received a file that is none (it starts with b'this is a text f')",
        "cut.png": ", received one PIL does not decode: image file is truncated",
    }
    for name, needle in cases.items():
        with pytest.raises(ValueError) as err:
            load_map(tmp_path / name, resolution_m=0.05)
        assert str(tmp_path / name) in str(err.value)
        assert needle in str(err.value)
    assert capfd.readouterr().err == ""


def test_the_command_line_names_a_damaged_image_without_decoder_lines(tmp_path: Path, capfd):
    from topojax.cli import main

    path = tmp_path / "no_end.png"
    path.write_bytes(_png()[:-12])
    assert main(["graph", str(path), "--resolution", "0.05", "-o", str(tmp_path / "out")]) == 2
    err = capfd.readouterr().err
    assert f"topojax graph: error: could not decode map image {path}: its PNG data" in err
    assert "libpng error" not in err and "Traceback" not in err


@pytest.mark.parametrize("shape", [(1, 50), (50, 1)])
def test_an_image_of_one_row_or_column_is_refused_naming_the_file_once(tmp_path, shape):
    path = tmp_path / "strip.png"
    cv2.imwrite(str(path), np.full(shape, 254, np.uint8))
    with pytest.raises(ValueError) as info:
        load_map(path, resolution_m=0.05)
    message = str(info.value)
    assert message == f"map {path}: expected at least 2x2 pixels, received shape {shape}"


def test_an_array_of_one_row_is_refused_naming_the_array():
    with pytest.raises(ValueError, match=r"^array: expected at least 2x2 pixels"):
        OccupancyMap.from_array(np.zeros((1, 5)), resolution_m=0.05)


def test_an_image_larger_than_the_decoders_read_is_named_as_such(tmp_path: Path, monkeypatch):
    """A PNG of 2^30 pixels and more, which OpenCV refuses and PIL takes for a
    decompression bomb, is refused as too large for them (with what to save it as), not
    as a damaged file, also on a computer with the memory to decode it."""
    from topojax import _cpus

    monkeypatch.setattr(_cpus, "available_memory_bytes", lambda: 1 << 50)
    side = 40_000  # 1.6e9 pixels
    row = b"\x00" + b"\xfe" * side
    (tmp_path / "huge.png").write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0))
        + _chunk(b"IDAT", zlib.compress(row * 4))
        + _chunk(b"IEND", b"")
    )
    with pytest.raises(ValueError) as err:
        load_map(tmp_path / "huge.png", resolution_m=0.05)
    message = str(err.value)
    assert "expected an image of at most" in message
    assert "received one of 40000 x 40000 pixels" in message
    assert "binary 8-bit PGM" in message
    assert "expected a complete image file" not in message


def test_an_image_too_wide_for_opencv_is_refused_by_the_side_it_exceeds(
    tmp_path: Path, monkeypatch
):
    """A PNG wider than OpenCV decodes (2^20 a side) with more pixels than PIL decodes,
    though fewer than OpenCV's 2^30: the refusal names the side, not only a count of
    pixels the image is under."""
    from PIL import Image

    from topojax import _cpus

    monkeypatch.setattr(_cpus, "available_memory_bytes", lambda: 1 << 50)
    width, height = (1 << 20) + 1, 200
    assert 2 * Image.MAX_IMAGE_PIXELS < width * height < 1 << 30
    (tmp_path / "wide.png").write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
        + _chunk(b"IDAT", zlib.compress(b"\x00" * 64))
        + _chunk(b"IEND", b"")
    )
    with pytest.raises(ValueError) as err:
        load_map(tmp_path / "wide.png", resolution_m=0.05)
    message = str(err.value)
    assert f"received one of {width} x {height} pixels" in message
    assert "1,048,576 pixels a side" in message
    assert f"{2 * Image.MAX_IMAGE_PIXELS:,} pixels" in message
