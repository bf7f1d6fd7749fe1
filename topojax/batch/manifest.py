"""Per-map manifests: the input's fingerprint, the settings and the output files' hashes,
written last; ``resume`` skips a map whose manifest still matches."""

from __future__ import annotations

import glob as _glob
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .._fs import atomic_write_bytes, yaml_image
from ..maps import YAML_SUFFIXES
from .inputs import (
    _FORMAT_FILES,
    _MANIFEST_SUFFIX,
    _PICTURES,
    _format_suffixes,
    _Item,
    batch_input,
    picture_suffixes,
)
from .records import ROOM_COLUMNS, SUMMARY_COLUMNS, MapRecord

__all__ = ["RESUMED", "batch_input"]

_MANIFEST_VERSION = 1


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _fingerprint(item: _Item) -> dict[str, Any] | None:
    """Identity of a map's input for resume: file hashes, or a hash of the masks."""
    if item.occupancy is not None:
        occ = item.occupancy
        h = hashlib.sha256()
        h.update(np.asarray(occ.shape, np.int64).tobytes())
        h.update(np.packbits(occ.occupied).tobytes())
        h.update(np.packbits(occ.free).tobytes())
        h.update(repr((occ.resolution_m, occ.origin)).encode())
        return {"masks_sha256": h.hexdigest()}
    assert item.path is not None
    if not item.path.is_file():  # missing, or a FIFO whose reading would never end
        return None
    try:
        files = {item.path.name: _sha256_file(item.path)}
        if item.path.suffix.lower() in YAML_SUFFIXES:
            img = yaml_image(item.path)
            if img is not None and img.is_file():
                files["image:" + img.name] = _sha256_file(img)
    except OSError:
        return None
    return {"files_sha256": files}


def _normalise(value: Any) -> Any:
    return json.loads(json.dumps(value))


def _manifest_path(out_dir: Path, name: str) -> Path:
    return out_dir / f"{name}{_MANIFEST_SUFFIX}"


def _resume_record(
    item: _Item,
    *,
    out_dir: Path | None,
    fingerprint: dict[str, Any] | None,
    request: dict[str, Any],
    formats: tuple[str, ...],
    plot: bool,
) -> MapRecord | None:
    """The recorded result of ``item`` if its outputs under ``out_dir`` are complete and
    valid for the input ``fingerprint`` and the settings ``request``, else None."""
    if out_dir is None or fingerprint is None:
        return None
    path = _manifest_path(out_dir, item.name)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict) or doc.get("version") != _MANIFEST_VERSION:
        return None
    if doc.get("map") != item.name or doc.get("input") != _normalise(fingerprint):
        return None
    if doc.get("request") != request:
        return None
    files = doc.get("files")
    if not isinstance(files, dict):
        return None
    row = _recorded_row(doc.get("record"), formats)
    if row is None:
        return None
    # a graph (route graph) without an edge has no Nav2 file
    nav2_less = {"nav2": row.get("edges") == 0, "route_nav2": row.get("route_edges") == 0}
    expected = {
        f"{item.name}{suffix}"
        for fmt in formats
        if not nav2_less.get(fmt)
        for suffix in _format_suffixes([fmt])
    }
    expected.update(f"{item.name}{suffix}" for suffix in picture_suffixes(formats, plot))
    if set(files) != expected:
        return None
    for rel, meta in files.items():
        p = out_dir / rel
        try:
            if p.stat().st_size != meta["bytes"] or _sha256_file(p) != meta["sha256"]:
                return None
        except (OSError, KeyError, TypeError):
            return None
    return MapRecord(
        map=item.name,
        path=item.label,
        **row,
        status="skipped",
        message=_resumed_message(doc.get("status"), doc.get("message")),
        outputs=(*sorted(files), path.relative_to(out_dir).as_posix()),
    )


#: Columns of the summary table whose values are counts (int, or None where not made).
_COUNT_COLUMNS = frozenset(
    ("height", "width", "vertices", "edges", "components", *ROOM_COLUMNS)
    + tuple(name for name in SUMMARY_COLUMNS if name.startswith("route_"))
)


def _recorded_row(row: Any, formats: tuple[str, ...]) -> dict[str, Any] | None:
    """The table values a manifest's ``record`` holds for a map skipped by resume, or
    None (the map is redone) where one this run's table has is missing, as in a manifest
    written before the table had that column, or is not of the column's type (a
    damaged manifest: its row would break the table's sums and its Parquet types)."""
    if not isinstance(row, dict):
        return None
    names = [n for n in SUMMARY_COLUMNS if n not in ("map", "path", "status", "message")]
    needed = set(names) | (set(ROOM_COLUMNS) if "rooms" in formats else set())
    out = {}
    for name in (*names, *ROOM_COLUMNS):
        if name not in row:
            if name in needed:
                return None
            continue
        value = row[name]
        if isinstance(value, bool):
            return None
        if name.startswith("t_"):  # seconds, summed into t_total_s
            ok = isinstance(value, (int, float)) and math.isfinite(value) and value >= 0
        elif name in _COUNT_COLUMNS:
            ok = value is None or isinstance(value, int)
        else:  # resolution, total length
            ok = value is None or isinstance(value, (int, float))
        if not ok:
            return None
        out[name] = value
    return out


#: How the message of a map skipped by resume begins; ``"; "`` and the warning of the run
#: that wrote its outputs follow where it had one.
RESUMED = "outputs complete (resume)"


def _resumed_message(status: Any, message: Any) -> str:
    """The message of a map skipped by resume: that its outputs are complete, and the
    status and message its manifest recorded where they said more than ``ok`` (an empty
    graph and why, a warning), so that the summary of a resumed run keeps them."""
    text = RESUMED
    note = message if isinstance(message, str) else ""
    if status == "empty":
        return f"{text} of an empty map: {note}" if note else f"{text} of an empty map"
    return f"{text}; {note}" if note else text


def _write_manifest(
    item: _Item,
    rec: MapRecord,
    files: dict[str, Any],
    *,
    out_dir: Path,
    fingerprint: dict[str, Any] | None,
    request: dict[str, Any],
) -> str:
    """Write the manifest of ``item`` (last of its files); its path relative to
    ``out_dir``."""
    doc = {
        "version": _MANIFEST_VERSION,
        "map": item.name,
        # absolute, so that the map is found again from any working directory (that of a
        # map object loaded from a file too: a later batch is checked against it)
        "path": item.file or item.label,
        "input": _normalise(fingerprint),
        "request": request,
        "files": files,
        "record": {k: v for k, v in rec.row().items() if k not in ("status", "message")},
        # reported again by resume, which skips the map
        "status": rec.status,
        "message": rec.message,
    }
    path = _manifest_path(out_dir, item.name)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, json.dumps(doc, indent=1).encode("utf-8"))
    return path.relative_to(out_dir).as_posix()


def _remove_file(path: Path) -> None:
    """Remove ``path`` unless it is a folder: one that has an output's name is no output
    of a batch; the map's writing into it fails and its row names it."""
    if not path.is_dir():
        path.unlink(missing_ok=True)


def _drop_outputs(item: _Item, *, out_dir: Path, formats: tuple[str, ...], plot: bool) -> None:
    """Remove the files ``item`` writes for ``formats`` and ``plot``: those of a map that
    failed part-way through writing them (no manifest lists them, and left, they would
    pass for the outputs of a map whose row says it has none)."""
    for suffix in (*_format_suffixes(formats), *picture_suffixes(formats, plot)):
        _remove_file(out_dir / f"{item.name}{suffix}")


def _forget_outputs(
    item: _Item, *, out_dir: Path | None, formats: tuple[str, ...], plot: bool
) -> None:
    """Before redoing a map: drop its manifest, the files it listed that this run will
    not write again (formats or pictures no longer asked for: left, they would be taken
    for this run's), and stale temporary files."""
    if out_dir is None:
        return
    manifest = _manifest_path(out_dir, item.name)
    try:
        listed = json.loads(manifest.read_text(encoding="utf-8")).get("files")
    except (OSError, ValueError, AttributeError):
        listed = None
    _remove_file(manifest)
    if isinstance(listed, dict):
        own = {f"{item.name}{s}" for s in (*_format_suffixes(_FORMAT_FILES), *_PICTURES)}
        again = {
            f"{item.name}{s}"
            for s in (*_format_suffixes(formats), *picture_suffixes(formats, plot))
        }
        for rel in listed:  # only names this map's outputs can have
            if rel in own and rel not in again:
                _remove_file(out_dir / rel)
    folder = manifest.parent
    if folder.is_dir():
        base = Path(item.name).name
        suffixes = _format_suffixes(formats) + [*_PICTURES, _MANIFEST_SUFFIX]
        for suffix in suffixes:  # leftovers of atomic writes killed mid-way
            for tmp in folder.glob(f".{_glob.escape(base + suffix)}.*.tmp"):
                tmp.unlink(missing_ok=True)
