"""Finished blocks of :func:`topojax.build_graph_tiled` kept in its ``out_dir``, so that a
build that stopped (killed, out of time, Ctrl-C) goes on where it was with
``resume=True`` instead of computing every block again.

Each finished block is one ``.npz`` file in ``out_dir/topojax_blocks/`` (its skeleton
pixels and squared distances, 12 bytes per pixel, a digest of the map window it read and
one of its build); ``build.json`` there describes the build (the map's shape, resolution
and origin, the options a block depends on, the block side, topojax's version).  A kept
block is used again only when it is of the same build and the window it read still holds
the same pixels; the folder is removed once the graph is written.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from .._constants import VERSION
from .._fs import atomic_write, atomic_write_bytes
from .._npy import check_npz_sizes
from ..config import PipelineConfig
from ..maps.tiled import TiledMap
from .blocks import BlockPiece, window_box, window_digest

__all__ = ["BLOCKS_FOLDER", "BlockCheckpoints"]

#: Folder of ``out_dir`` that holds the finished blocks while a build runs.
BLOCKS_FOLDER = "topojax_blocks"
_BUILD_FILE = "build.json"
#: The names of the files this module writes into the folder (blocks, the description and
#: their temporary files while written).
_TEMPORARY = (".block_*.tmp", f".{_BUILD_FILE}.*.tmp")
_NAMES = ("block_*.npz", _BUILD_FILE, *_TEMPORARY)
_FORMAT = "topojax-tiled-blocks"
_VERSION = 1
_ARRAYS = (
    "box",
    "flat",
    "sq_distance_px",
    "occupied_px",
    "halo_px",
    "sub_iterations",
    "digest",
    "build",
)


def _description(tiled: TiledMap, config: PipelineConfig, block_px: int) -> dict[str, Any]:
    """What makes two builds' blocks the same (JSON types only): the map's extent, the
    options a block's pixels depend on, the block side and topojax's version."""
    desc = {
        "format": _FORMAT,
        "version": _VERSION,
        "topojax": VERSION,
        "shape": [int(s) for s in tiled.shape],
        "resolution_m": float(tiled.resolution_m),
        "origin": [float(v) for v in tiled.origin],
        "block_px": int(block_px),
        "distance": dataclasses.asdict(config.distance),
        "ridge": dataclasses.asdict(config.ridge),
        "skeleton": dataclasses.asdict(config.skeleton),
        "tile_px": int(config.tile_px),
        "free_space_only": bool(config.graph.free_space_only),
    }
    return json.loads(json.dumps(desc))


def _build_digest(desc: dict[str, Any]) -> np.ndarray:
    """16 bytes (uint8) naming the build ``desc``, kept in each of its block files."""
    text = json.dumps(desc, sort_keys=True).encode()
    return np.frombuffer(hashlib.blake2b(text, digest_size=16).digest(), np.uint8)


class BlockCheckpoints:
    """The finished blocks of one build in ``out_dir/blocks``.

    ``resume=False`` removes the blocks of any earlier build; ``resume=True`` keeps them
    when they belong to the same build and refuses (ValueError naming ``resume``) blocks
    of another one.
    """

    def __init__(
        self,
        out_dir: Path,
        tiled: TiledMap,
        config: PipelineConfig,
        block_px: int,
        *,
        resume: bool,
    ) -> None:
        self.folder = out_dir / BLOCKS_FOLDER
        self.tiled = tiled
        desc = _description(tiled, config, block_px)
        self.build = _build_digest(desc)
        self._checked: dict[tuple, bytes] = {}  # window digests of the blocks usable()
        build_file = self.folder / _BUILD_FILE
        if self.folder.exists() and not self.folder.is_dir():
            raise NotADirectoryError(
                f"out_dir: expected {self.folder} to be free for the finished blocks, but "
                "it is a file; remove it or choose another out_dir"
            )
        if resume and build_file.is_file():
            _check_same_build(build_file, desc)
            return
        if resume and self.folder.is_dir() and _only_block_files(self.folder):
            # the description is gone, the blocks are not: each block carries its build's
            # digest and is used only when it matches
            atomic_write_bytes(build_file, json.dumps(desc, indent=1).encode())
            return
        self.remove()
        self.folder.mkdir(exist_ok=True)
        atomic_write_bytes(build_file, json.dumps(desc, indent=1).encode())

    def _path(self, box) -> Path:
        return self.folder / f"block_{box[0]}_{box[2]}.npz"

    def usable(self, box) -> bool:
        """Whether block ``box`` was finished and the window it read is unchanged."""
        arrays = _read_block(self._path(box))
        if arrays is None:  # missing, cut short or damaged: computed again
            return False
        saved_box = tuple(int(v) for v in arrays["box"])
        same_build = np.array_equal(arrays["build"], self.build)
        if saved_box != tuple(box) or not same_build:  # e.g. a build sharing the folder
            return False
        r0, r1, c0, c1 = window_box(box, int(arrays["halo_px"]), self.tiled.shape)
        digest = arrays["digest"].tobytes()
        if window_digest(self.tiled.codes(r0, r1, c0, c1)) != digest:
            return False
        self._checked[tuple(box)] = digest
        return True

    def load(self, box) -> BlockPiece:
        """The kept piece of block ``box`` (checked with :meth:`usable`); a ValueError
        naming ``out_dir`` if its file changed since (another build writing there)."""
        path = self._path(box)
        arrays = _read_block(path)
        if (
            arrays is None
            or not np.array_equal(arrays["build"], self.build)
            or tuple(int(v) for v in arrays["box"]) != tuple(box)
            or arrays["digest"].tobytes() != self._checked.get(tuple(box))
        ):
            raise ValueError(
                f"out_dir: expected the kept block {path} that this build checked, but it "
                "was removed or replaced since (another build writing into the same "
                "out_dir?); give each build its own out_dir and build again with resume=True"
            )
        return BlockPiece(
            box=tuple(int(v) for v in arrays["box"]),
            flat=arrays["flat"],
            sq_distance_px=arrays["sq_distance_px"],
            occupied_px=int(arrays["occupied_px"]),
            halo_px=int(arrays["halo_px"]),
            sub_iterations=int(arrays["sub_iterations"]),
        )

    def save(self, piece: BlockPiece) -> None:
        """Keep a finished block, computed with its window's digest (written whole or
        not at all)."""
        arrays = {
            "box": np.asarray(piece.box, np.int64),
            "flat": piece.flat,
            "sq_distance_px": piece.sq_distance_px,
            "occupied_px": np.int64(piece.occupied_px),
            "halo_px": np.int64(piece.halo_px),
            "sub_iterations": np.int64(piece.sub_iterations),
            "digest": np.frombuffer(piece.window_digest, np.uint8),
            "build": self.build,
        }
        atomic_write(self._path(piece.box), lambda fh: np.savez(fh, **arrays))

    def remove(self) -> None:
        """Remove the kept blocks, and the folder when nothing else is in it (only files
        of this module's names, and only in a folder whose ``build.json`` it wrote)."""
        if not self.folder.is_dir():
            return
        ours = _ours(self.folder / _BUILD_FILE) or _only_block_files(self.folder)
        if not ours and any(self.folder.iterdir()):
            raise ValueError(
                f"out_dir: {self.folder} holds files that no tiled build of topojax "
                "wrote; remove them or choose another out_dir"
            )
        for pattern in _NAMES:
            for path in self.folder.glob(pattern):
                path.unlink(missing_ok=True)
        with contextlib.suppress(OSError):  # not empty: another program's files
            self.folder.rmdir()


def _read_block(path: Path) -> dict[str, np.ndarray] | None:
    """The arrays of the block file ``path``, or None when it is missing or is not a
    whole block file (cut short, damaged, or of another kind)."""
    if not path.is_file() or not zipfile.is_zipfile(path):  # np.load would read a .npy
        return None
    size = path.stat().st_size
    try:
        with np.load(path, allow_pickle=False) as f:
            # np.savez stores its members: none is larger than the file, and none holds
            # less than its header claims (read first: f[name] allocates the claim)
            if any(i.file_size > size for i in f.zip.infolist()):
                return None
            check_npz_sizes(f)
            return {name: f[name] for name in _ARRAYS}  # read whole: checksums
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None


def _only_block_files(folder: Path) -> bool:
    """Whether ``folder`` holds block files and nothing else but this module's temporary
    files (a folder of blocks whose ``build.json`` was removed)."""
    entries = list(folder.iterdir())
    blocks = [e for e in entries if e.match("block_*.npz")]
    temporary = [e for e in entries if any(e.match(p) for p in _TEMPORARY)]
    return (
        bool(blocks)
        and len(blocks) + len(temporary) == len(entries)
        and all(e.is_file() for e in entries)
        and all(_is_block_file(e) for e in blocks)
    )


def _is_block_file(path: Path) -> bool:
    """Whether ``path`` is a zip of exactly the arrays of a block (its members' names;
    not read)."""
    try:
        with zipfile.ZipFile(path) as z:
            return sorted(z.namelist()) == sorted(f"{name}.npy" for name in _ARRAYS)
    except (OSError, zipfile.BadZipFile):
        return False


def _ours(build_file: Path) -> bool:
    """Whether ``build_file`` is a build description this module wrote."""
    try:
        return json.loads(build_file.read_text(encoding="utf-8")).get("format") == _FORMAT
    except (OSError, ValueError, AttributeError):
        return False


def _check_same_build(build_file: Path, desc: dict[str, Any]) -> None:
    """Refuse kept blocks of a build other than ``desc``, naming the first difference."""
    try:
        kept = json.loads(build_file.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ValueError(
            f"resume: cannot read {build_file} ({exc}); remove {build_file.parent} or "
            "choose another out_dir"
        ) from None
    if not isinstance(kept, dict):
        raise ValueError(
            f"resume: expected {build_file} to hold a build description (a JSON object), "
            f"received a JSON {type(kept).__name__}; remove {build_file.parent} or choose "
            "another out_dir"
        )
    for key, value in desc.items():
        if kept.get(key) != value:
            raise ValueError(
                f"resume: the blocks in {build_file.parent} belong to another build ({key}: "
                f"{_short(kept.get(key))}, here {_short(value)}); build with resume=False to "
                "start over"
            )


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 80 else text[:77] + "..."
