"""Inputs whose size the library cannot hold are refused before the memory is taken, with
a message that names the limit: images whose header claims more pixels than are decoded
into memory (decompression bombs)."""

from __future__ import annotations

import struct
import zlib

import cv2
import numpy as np
import pytest
from PIL import Image

import topojax as tj
from topojax.maps import pnm


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


def test_a_png_claiming_a_huge_image_is_refused_as_too_large_not_as_corrupt(tmp_path):
    path = tmp_path / "bomb.png"
    _png_claiming(path, 100_000, 100_000)
    with pytest.raises(ValueError) as info:
        tj.load_map(path)
    text = str(info.value)
    assert "100000 x 100000 pixels" in text
    assert "MAX_IMAGE_PIXELS" in text and "topojax.maps.pnm.MAX_IMAGE_PIXELS" in text
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
def test_every_decoded_format_is_held_to_the_limit_before_decoding(
    tmp_path, monkeypatch, name, image
):
    path = tmp_path / name
    if name == "colour.ppm.pgm":  # a binary PPM (P6), read through the decoders
        ok = cv2.imencode(".ppm", image)[1].tobytes()
        path.write_bytes(ok)
    else:
        _write(path, image)
    monkeypatch.setattr(pnm, "MAX_IMAGE_PIXELS", 120)
    assert tj.load_map(path).shape == (10, 12)  # at the limit
    monkeypatch.setattr(pnm, "MAX_IMAGE_PIXELS", 119)
    with pytest.raises(ValueError, match=r"12 x 10 pixels .*MAX_IMAGE_PIXELS = 119"):
        tj.load_map(path)


def test_a_memory_mapped_pgm_is_not_decoded_and_not_limited(tmp_path, monkeypatch):
    path = tmp_path / "map.pgm"
    assert cv2.imwrite(str(path), np.full((10, 12), 254, np.uint8))
    monkeypatch.setattr(pnm, "MAX_IMAGE_PIXELS", 1)
    assert tj.load_map(path).shape == (10, 12)


def test_the_limit_reaches_the_command_line(tmp_path, monkeypatch, capsys):
    from topojax.cli import main

    path = tmp_path / "bomb.png"
    _png_claiming(path, 70_000, 50_000)
    assert main(["graph", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "topojax graph: error: map image" in err and "70000 x 50000 pixels" in err
