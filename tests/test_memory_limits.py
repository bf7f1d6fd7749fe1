"""Inputs whose size the library cannot hold are refused before the memory is taken, with
a message that names the limit: images whose header claims more pixels than the memory
available can decode (decompression bombs), and saved arrays whose header claims more data than
their file holds; and a tiled build whose blocks outgrow the memory they were sized for says
so."""

from __future__ import annotations

import io
import json
import struct
import tracemalloc
import warnings
import zipfile
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

import topojax as tj
import topojax._cpus as cpus
from topojax._cpus import MemoryRefusal
from topojax.config import DistanceConfig, PipelineConfig, RidgeConfig
from topojax.maps import pnm
from topojax.outofcore import BYTES_PER_WINDOW_PX

#: A narrow Gaussian and a low ridge threshold: on the office map the thinning of some
#: 64 px blocks is proved exact only with a halo of 160 px, five times the first (32 px).
FAR_THINNING = PipelineConfig(
    distance=DistanceConfig.from_pixels(sigma_px=5.0),
    tile_px=32,
    ridge=RidgeConfig(ksize=3, threshold=4.0),
)


def _png_claiming(path, width: int, height: int) -> None:
    """A PNG of a few hundred bytes whose header gives ``width`` x ``height`` pixels."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    rows = zlib.compress((b"\x00" + b"\xfe" * 1000) * 10)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", rows) + chunk(b"IEND", b"")
    )


def _memory(monkeypatch, available: int | None) -> None:
    """Make ``available`` bytes the memory available to decode a map image."""
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: available)


def test_a_png_claiming_a_huge_image_is_refused_as_too_large_not_as_corrupt(tmp_path, monkeypatch):
    path = tmp_path / "bomb.png"
    _png_claiming(path, 100_000, 100_000)
    _memory(monkeypatch, 8 << 30)
    with pytest.raises(MemoryRefusal) as info:
        tj.load_map(path)
    text = str(info.value)
    assert "100000 x 100000 pixels" in text
    assert "decoding and classifying them (5 bytes a pixel) takes at least 46.6 GiB" in text
    assert "more than the 8.0 GiB of memory available" in text
    assert "binary 8-bit PGM" in text
    assert "corrupt" not in text


def _write(path, image: np.ndarray) -> None:
    if path.suffix in (".tif", ".bmp", ".jpg"):
        Image.fromarray(image).save(path)
    else:
        assert cv2.imwrite(str(path), image)


@pytest.mark.parametrize(
    "name, image",
    [
        ("grey.png", np.full((10, 12), 254, np.uint8)),
        ("colour.png", np.full((10, 12, 3), 254, np.uint8)),
        ("deep.png", np.full((10, 12), 65000, np.uint16)),
        ("deep.pgm", np.full((10, 12), 65000, np.uint16)),
        ("colour.ppm.pgm", np.full((10, 12, 3), 254, np.uint8)),
        ("grey.jpg", np.full((10, 12), 254, np.uint8)),
        ("grey.bmp", np.full((10, 12), 254, np.uint8)),
        ("grey.tif", np.full((10, 12), 254, np.uint8)),
    ],
)
def test_every_decoded_format_is_held_to_the_memory_available_before_decoding(
    tmp_path, monkeypatch, name, image
):
    path = tmp_path / name
    if name == "colour.ppm.pgm":  # a binary PPM (P6), read through the decoders
        ok = cv2.imencode(".ppm", image)[1].tobytes()
        path.write_bytes(ok)
    else:
        _write(path, image)
    _memory(monkeypatch, 120 * pnm.DECODE_BYTES_PER_PIXEL)
    assert tj.load_map(path).shape == (10, 12)  # just fits
    _memory(monkeypatch, 120 * pnm.DECODE_BYTES_PER_PIXEL - 1)
    with pytest.raises(
        MemoryError, match=r"12 x 10 pixels, and decoding and classifying them .* takes at least"
    ) as info:
        tj.load_map(path)
    # a binary PGM needs no converting: the tiled build reads it a window at a time
    tiled = "which reads this binary PGM a window at a time"
    assert (tiled in str(info.value)) == (name == "deep.pgm"), str(info.value)
    _memory(monkeypatch, None)  # unknown (not Linux): decoded as it comes
    assert tj.load_map(path).shape == (10, 12)


def _encoded(fmt: str, image: np.ndarray, **options) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, fmt, **options)
    return buf.getvalue()


def _behind_yaml(tmp_path, name: str, data: bytes):
    """A map YAML whose image is ``name`` holding ``data``: how a map in a format that
    load_map takes from no file name of its own (a WebP, a GIF) is read."""
    (tmp_path / name).write_bytes(data)
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"image: {name}\nresolution: 0.05\norigin: [0, 0, 0]\n")
    return path


_GREY = np.full((10, 12), 254, np.uint8)
_OTHER_FORMATS = [
    ("grey.gif", lambda: _encoded("GIF", _GREY)),
    ("lossy.webp", lambda: _encoded("WEBP", _GREY, lossless=False)),
    ("lossless.webp", lambda: _encoded("WEBP", _GREY, lossless=True)),
    ("extended.webp", lambda: _encoded("WEBP", np.dstack([_GREY] * 4), exif=b"Exif\x00\x00")),
    ("grey.jp2", lambda: _encoded("JPEG2000", _GREY)),
    ("grey.j2k", lambda: _encoded("JPEG2000", _GREY, no_jp2=True)),
    ("grey.tga", lambda: _encoded("TGA", _GREY)),  # its header read by PIL
    ("grey.pbm", lambda: cv2.imencode(".pbm", _GREY)[1].tobytes()),
]


@pytest.mark.parametrize("name, encode", _OTHER_FORMATS, ids=[name for name, _ in _OTHER_FORMATS])
def test_other_decoded_formats_are_held_to_the_memory_available_before_decoding(
    tmp_path, monkeypatch, name, encode
):
    """Formats other than those whose header load_map reads itself (PNG, JPEG, BMP,
    TIFF, PGM / PPM) are held to the memory available before they are decoded, as those
    are, not decoded unchecked."""
    path = _behind_yaml(tmp_path, name, encode())
    _memory(monkeypatch, 120 * pnm.DECODE_BYTES_PER_PIXEL)
    assert tj.load_map(path).shape == (10, 12)  # just fits
    _memory(monkeypatch, 120 * pnm.DECODE_BYTES_PER_PIXEL - 1)
    with pytest.raises(MemoryRefusal, match=rf"^map image .*{name}: its header gives 12 x 10 "):
        tj.load_map(path)
    _memory(monkeypatch, None)
    assert tj.load_map(path).shape == (10, 12)


def _gif_claiming(width: int, height: int) -> bytes:
    data = bytearray(_encoded("GIF", _GREY))
    data[6:10] = struct.pack("<HH", width, height)  # the logical screen
    return bytes(data)


def _webp_claiming(width: int, height: int) -> bytes:
    data = bytearray(_encoded("WEBP", np.dstack([_GREY] * 4), exif=b"Exif\x00\x00"))
    assert data[12:16] == b"VP8X"
    data[24:30] = (width - 1).to_bytes(3, "little") + (height - 1).to_bytes(3, "little")
    return bytes(data)


def _jp2_claiming(width: int, height: int) -> bytes:
    data = bytearray(_encoded("JPEG2000", _GREY))
    at = data.index(b"ihdr") + 4
    data[at : at + 8] = struct.pack(">II", height, width)
    return bytes(data)


def _j2k_claiming(width: int, height: int) -> bytes:
    data = bytearray(_encoded("JPEG2000", _GREY, no_jp2=True))
    assert data[:4] == b"\xff\x4f\xff\x51"  # SOC, SIZ
    data[8:16] = struct.pack(">II", width, height)
    return bytes(data)


@pytest.mark.parametrize(
    "name, claiming, size",
    [
        ("bomb.gif", _gif_claiming, (65_535, 65_535)),
        ("bomb.webp", _webp_claiming, (100_000, 100_000)),
        ("bomb.jp2", _jp2_claiming, (100_000, 100_000)),
        ("bomb.j2k", _j2k_claiming, (100_000, 100_000)),
    ],
)
def test_a_gif_webp_or_jpeg_2000_claiming_a_huge_image_is_refused_before_decoding(
    tmp_path, monkeypatch, name, claiming, size
):
    path = _behind_yaml(tmp_path, name, claiming(*size))
    _memory(monkeypatch, 8 << 30)
    with pytest.raises(MemoryRefusal) as info:
        tj.load_map(path)
    text = str(info.value)
    assert f"map image {tmp_path / name}: its header gives {size[0]} x {size[1]} pixels" in text
    assert "more than the 8.0 GiB of memory available" in text


def test_a_memory_mapped_pgm_is_held_to_the_memory_its_classes_take(tmp_path, monkeypatch):
    """Not decoded, so not held to the 5 bytes a pixel of decoding; but its classes take 4
    bytes a pixel while classified (10^10 pixels: beyond most machines), and those are
    held to the memory available."""
    path = tmp_path / "map.pgm"
    assert cv2.imwrite(str(path), np.full((10, 12), 254, np.uint8))
    _memory(monkeypatch, 120 * 4)
    assert tj.load_map(path).shape == (10, 12)  # just fits
    _memory(monkeypatch, 120 * 4 - 1)
    with pytest.raises(MemoryRefusal) as info:
        tj.load_map(path)
    text = str(info.value)
    assert f"map image {path}: its header gives 12 x 10 pixels" in text
    assert "classifying them (4 bytes a pixel) takes at least 480 bytes" in text
    assert "build_graph_tiled" in text
    yaml = tmp_path / "map.yaml"
    yaml.write_text("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(MemoryRefusal, match="its header gives 12 x 10 pixels"):
        tj.load_map(yaml)
    assert tj.build_graph_tiled(path).graph is not None  # read a window at a time
    _memory(monkeypatch, None)
    assert tj.load_map(path).shape == (10, 12)


@pytest.mark.parametrize("name", ["deep.pgm", "deep.png"])
def test_a_large_map_file_is_refused_from_its_header_before_the_file_is_read(
    tmp_path, monkeypatch, name
):
    """A file larger than the memory available (a 16-bit PGM holds 2 bytes a pixel)
    would end the process as it is read whole: its header is held to the memory
    available first, from the start of the file only."""
    path = tmp_path / name
    rng = np.random.default_rng(0)  # noise: a PNG of it is not compressed to nothing
    image = rng.integers(0, 65535, size=(1024, 1536), dtype=np.uint16)
    assert cv2.imwrite(str(path), image)
    size = path.stat().st_size
    assert size > 1 << 20
    _memory(monkeypatch, 1024 * 1536 * pnm.DECODE_BYTES_PER_PIXEL - 1)
    peak, error = _peak_bytes(lambda: tj.load_map(path, resolution_m=0.05))
    assert isinstance(error, MemoryRefusal)
    assert f"map image {path}: its header gives 1536 x 1024 pixels" in str(error)
    assert peak < size // 2  # the file was not read whole
    _memory(monkeypatch, 1024 * 1536 * pnm.DECODE_BYTES_PER_PIXEL)
    assert tj.load_map(path, resolution_m=0.05).shape == (1024, 1536)


def test_the_limit_reaches_the_command_line(tmp_path, monkeypatch, capsys):
    from topojax.cli import main

    path = tmp_path / "bomb.png"
    _png_claiming(path, 70_000, 50_000)
    _memory(monkeypatch, 8 << 30)
    assert main(["graph", str(path), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert "topojax graph: error: map image" in err
    assert "GiB of memory available; save a map this large as a binary 8-bit PGM" in err
    assert "crop or coarsen" not in err  # the advice for memory that ran out during work
    assert "70000 x 50000 pixels" in err and "Traceback" not in err


# ------------------------------------------------- arrays whose header claims more data


def _claiming(header_rows: int, data: bytes, dtype: str = "<i8") -> bytes:
    """.npy bytes whose header gives ``(header_rows, 2)`` of ``dtype``, followed by
    ``data`` (far fewer bytes)."""
    buf = io.BytesIO()
    header = {"descr": dtype, "fortran_order": False, "shape": (header_rows, 2)}
    np.lib.format.write_array_header_1_0(buf, header)
    return buf.getvalue() + data


#: Rows a doctored header claims: 64 MB of int64 pairs, against a few kB in the file.
CLAIMED_ROWS = 1 << 22


def _peak_bytes(call) -> tuple[int, Exception | None]:
    tracemalloc.start()
    try:
        call()
        error = None
    except (ValueError, MemoryError) as exc:
        error = exc
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak, error


@pytest.mark.parametrize("mmap", [True, False])
def test_a_graph_store_array_claiming_more_than_its_file_is_refused_unallocated(tmp_path, mmap):
    from topojax.graph import GraphStore

    store = GraphStore.from_networkx(tj.build_graph(tj.sample_map("a_scan")).graph)
    folder = tj.save_graph_store(store, tmp_path / "store")
    path = folder / "path_pixels.npy"
    held = np.load(path)
    path.write_bytes(_claiming(CLAIMED_ROWS, held.tobytes(), held.dtype.str))
    doc = json.loads((folder / "graph_store.json").read_text())
    doc["arrays"]["path_pixels"]["shape"] = [CLAIMED_ROWS, 2]
    (folder / "graph_store.json").write_text(json.dumps(doc))
    peak, error = _peak_bytes(lambda: tj.load_graph_store(folder, mmap=mmap))
    assert error is not None
    assert str(error).startswith(f"{path}: expected the {CLAIMED_ROWS * 16:,} bytes")
    assert f"received {held.nbytes:,} bytes after the header" in str(error)
    assert peak < CLAIMED_ROWS  # a sixteenth of the claim: it was never allocated


def test_a_mapper_state_member_claiming_more_than_it_holds_is_refused_unallocated(tmp_path):
    mapper = tj.IncrementalMapper()
    mapper.add_map(tj.sample_map("a_scan"))
    good = mapper.save(tmp_path / "state.npz")
    doctored = tmp_path / "doctored.npz"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(doctored, "w") as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename == "v_pixel.npy":
                data = _claiming(CLAIMED_ROWS, b"\0" * 64)
            dst.writestr(info.filename, data)
    peak, error = _peak_bytes(lambda: tj.IncrementalMapper.load(doctored))
    assert error is not None
    assert "member v_pixel.npy: expected the 67,108,864 bytes" in str(error)
    assert str(error).startswith(f"{doctored}: not a readable mapper state")
    assert peak < CLAIMED_ROWS
    assert tj.IncrementalMapper.load(good).n_scans == mapper.n_scans


def test_a_mapper_state_that_unpacks_past_the_memory_available_is_refused_unread(
    tmp_path, monkeypatch
):
    """A zip bomb (a few kB unpacking to gigabytes, every header true) passes the header
    checks; its unpacked size, from the archive's directory, is held to the memory
    available before any member is read."""
    mapper = tj.IncrementalMapper()
    mapper.add_map(tj.sample_map("a_scan"))
    state = mapper.save(tmp_path / "state.npz")
    with zipfile.ZipFile(state) as z:
        unpacked = sum(i.file_size for i in z.infolist())
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: unpacked - 1)
    peak, error = _peak_bytes(lambda: tj.IncrementalMapper.load(state))
    assert isinstance(error, MemoryRefusal)  # a MemoryError the command line prints as is
    assert str(error).startswith(f"{state}: its arrays unpack to ")
    assert str(error).endswith("MiB of memory available")
    assert peak < unpacked  # refused before the members were read
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: unpacked)
    assert tj.IncrementalMapper.load(state).n_scans == mapper.n_scans
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: None)  # not known
    assert tj.IncrementalMapper.load(state).n_scans == mapper.n_scans


# ------------------------------------------------------- the command line out of memory


@pytest.mark.parametrize(
    "error",
    [
        MemoryError("Unable to allocate 381. MiB for an array with shape (20000, 20000)"),
        cv2.error("(-4:Insufficient memory) Failed to allocate 1593287056 bytes"),
    ],
)
def test_a_command_out_of_memory_says_so_without_a_traceback(tmp_path, monkeypatch, capsys, error):
    import topojax.pipeline
    from topojax.cli import main

    def build_graph(*args, **kwargs):
        raise error

    monkeypatch.setattr(topojax.pipeline, "build_graph", build_graph)
    path = tmp_path / "map.png"
    assert cv2.imwrite(str(path), np.full((20, 20), 254, np.uint8))
    assert main(["graph", str(path), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("topojax graph: error: out of memory (")
    assert str(error).splitlines()[-1] in err and "topojax graph --tiled" in err
    assert "Traceback" not in err


def test_other_opencv_errors_are_not_taken_for_memory(tmp_path, monkeypatch):
    import topojax.pipeline
    from topojax.cli import main

    def build_graph(*args, **kwargs):
        raise cv2.error("(-215:Assertion failed) !_src.empty()")

    monkeypatch.setattr(topojax.pipeline, "build_graph", build_graph)
    path = tmp_path / "map.png"
    assert cv2.imwrite(str(path), np.full((20, 20), 254, np.uint8))
    with pytest.raises(cv2.error, match="Assertion failed"):
        main(["graph", str(path), "-o", str(tmp_path / "out")])


# ----------------------------------------------------- rooms of absurdly fine maps


def test_rooms_of_a_map_far_finer_than_the_doorway_cells_take_the_maps_memory(tmp_path):
    # at 3.3e-5 m per pixel a doorway cell of 0.1 m is 3030 pixels a side, 50 times the
    # map: the cells' padding and pixels must not be held at that size (arrays of 9
    # million cell pixels; 74 GiB at 1e-6 m per pixel)
    grey = np.full((60, 60), 254, np.uint8)
    grey[[0, -1], :] = grey[:, [0, -1]] = grey[30, :40] = 0
    occupancy = tj.OccupancyMap.from_array(grey, resolution_m=3.3e-5, origin=(0.0123, 0.04, 0))
    tj.segment_rooms(tj.OccupancyMap.from_array(grey))  # compiles the kernels
    peak, _ = _peak_bytes(lambda: tj.segment_rooms(occupancy))
    assert peak < 4_000_000  # the map's 3,600 pixels, a few arrays of them
    seg = tj.segment_rooms(occupancy)
    assert seg.labels.shape == (60, 60) and seg.doors == ()


def test_the_out_of_memory_message_is_written_after_the_failed_work_let_go(tmp_path, monkeypatch):
    # the frames of the failed call hold what it allocated: a message written while
    # they are alive can itself run out of memory (and end in a chain of MemoryErrors)
    import sys
    import weakref

    import topojax.pipeline
    from topojax.cli import main

    class Held:
        pass

    refs = []

    def build_graph(*args, **kwargs):
        held = Held()
        refs.append(weakref.ref(held))
        raise MemoryError()

    alive_while_writing = []

    class Stderr(io.StringIO):
        def write(self, text):
            alive_while_writing.append(refs[0]() is not None)
            return super().write(text)

    monkeypatch.setattr(topojax.pipeline, "build_graph", build_graph)
    monkeypatch.setattr(sys, "stderr", Stderr())
    path = tmp_path / "map.png"
    assert cv2.imwrite(str(path), np.full((20, 20), 254, np.uint8))
    assert main(["graph", str(path), "-o", str(tmp_path / "out")]) == 1
    assert "out of memory (MemoryError)" in sys.stderr.getvalue()
    assert alive_while_writing and not any(alive_while_writing)


@pytest.mark.parametrize(
    ("available", "need", "says"),
    [
        (8 * 2**30, 46 * 2**30, "46.0 GiB, more than the 8.0 GiB"),
        (16 * 2**20, 40 * 2**20, "40.0 MiB, more than the 16.0 MiB"),
        (2**30 - 2**20, 5 * 2**30 // 2, "2.5 GiB, more than the 1,023.0 MiB"),
        (1000, 5000, "5,000 bytes, more than the 1,000 bytes"),
    ],
)
def test_a_refusal_gives_sizes_in_units_that_show_them(monkeypatch, available, need, says):
    # small machines and small limits would read "0.0 GiB" in GiB alone
    _memory(monkeypatch, available)
    with pytest.raises(MemoryRefusal, match=rf"^it takes {says} of memory available$"):
        cpus.check_fits_memory(need, "it takes")


def _office_part() -> tj.OccupancyMap:
    """256 x 192 px of the office map, where FAR_THINNING's halos grow to 160 px."""
    grey = cv2.imread(str(Path(tj.__file__).parent / "data" / "office.png"), cv2.IMREAD_GRAYSCALE)
    return tj.OccupancyMap.from_array(grey[448:704, 256:448], resolution_m=0.05)


def _window_mb(window) -> float:
    return BYTES_PER_WINDOW_PX * window[0] * window[1] / 2**20


def test_a_block_whose_halo_outgrows_the_memory_budget_is_warned_of_once():
    """Blocks sized to a budget whose proof needs a wider halo read larger windows than
    the budget holds: one warning names the budget, the largest window (pixels and
    megabytes) and the halo that made it; the graph is build_graph's all the same."""
    m = _office_part()
    with pytest.warns(UserWarning) as caught:
        result = tj.build_graph_tiled(m, config=FAR_THINNING, memory_budget_mb=0.4)
    messages = [str(w.message) for w in caught if "window" in str(w.message)]
    assert len(messages) == 1, messages
    (message,) = messages
    rows, cols = result.largest_window_px
    assert rows * cols * BYTES_PER_WINDOW_PX > 0.4 * 2**20
    assert max(result.halo_px) == 160
    assert "memory_budget_mb=0.4" in message
    assert f"{rows} x {cols} px ({_window_mb(result.largest_window_px):.1f} MB" in message
    assert "halo of 160 px" in message and "first (32 px)" in message
    whole = tj.build_graph(m, config=FAR_THINNING)
    assert np.array_equal(result.skeleton_flat(), np.flatnonzero(whole.skeleton))
    for name in ("node_pixel", "edge_u", "edge_v", "path_offsets", "path_pixels"):
        got, want = getattr(result.graph_store, name), getattr(whole.graph_store, name)
        assert np.array_equal(got, want), name


def test_a_given_block_side_records_its_windows_without_a_warning():
    """With ``block_px`` the budget sizes nothing: the windows are the caller's choice,
    recorded in the result and not warned of."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = tj.build_graph_tiled(_office_part(), config=FAR_THINNING, block_px=64)
    assert max(result.halo_px) == 160
    assert result.largest_window_px == (256, 192)  # 64 + 2 x 160 a side, clipped to the map


def test_windows_within_the_budget_are_not_warned_of():
    """A budget large enough for the grown windows: nothing is said."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = tj.build_graph_tiled(_office_part(), config=FAR_THINNING, memory_budget_mb=4)
    assert result.largest_window_px == (256, 192)


def test_a_networkx_graph_the_memory_cannot_hold_is_refused_before_it_is_built(monkeypatch):
    """A result holds its graph as arrays; the networkx graph made from them on first
    access takes about a kilobyte a vertex and an edge, which is checked first."""
    result = tj.build_graph(_office_part())
    store = result.graph_store
    _memory(monkeypatch, 10_000)
    with pytest.raises(MemoryRefusal) as info:
        result.graph  # noqa: B018 - the first access builds it
    message = str(info.value)
    assert message.startswith(
        f"graph: the networkx graph of {store.n_nodes:,} vertices and {store.n_edges:,} edges"
    )
    assert "more than the 10,000 bytes of memory available" in message
    assert "load_graph_store" in message
    _memory(monkeypatch, 1 << 30)
    assert result.graph.number_of_nodes() == store.n_nodes
