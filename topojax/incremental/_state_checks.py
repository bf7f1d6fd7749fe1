"""Checks of a saved mapper state's counters, pixels and graph tables, made before
the mapper allocates anything from them: a hand-edited or corrupted state (a counter of
10**15, a pixel far off its tiles) is refused with a ValueError naming the file and
the field, not a MemoryError or a failure at a later scan."""

from __future__ import annotations

import numpy as np

from .._constants import MAX_LOG_SCANS
from .._cpus import available_memory_bytes, byte_size

#: Vertex and edge ids are stored in the int32 tile layer ``graph_id`` (an edge as its
#: id, a vertex as ``-(id + 2)``), and room ids in int32 labels: ids stay below this.
MAX_IDS = 2**31 - 1

#: Bytes a live mapper holds per vertex id (pixel key, kind, liveness), per edge id
#: (ends, liveness, path start and length) and per room id (id matching tables).
_BYTES_PER_ID = {"vertex": 10, "edge": 33, "room": 24}

_COUNTERS = (
    "n_scans",
    "since_skeleton",
    "since_graph",
    "next_vertex",
    "next_edge",
    "n_ridge",
)
_ROOM_COUNTERS = ("next_room_id", "rooms_active", "since_rooms")


def _ints(data, key: str, n: int) -> list[int]:
    """The ``n`` integers of field ``key``; a ValueError naming it otherwise."""
    arr = np.asarray(data[key])
    if arr.shape != (n,) or arr.dtype.kind not in "iu":
        raise ValueError(f"{key}: expected {n} integers, received {arr.dtype} {arr.shape}")
    return [int(v) for v in arr]


def _counter(key: str, name: str, value: int, lo: int, hi: int, why: str) -> None:
    if not lo <= value <= hi:
        raise ValueError(
            f"{key} ({name}): expected an integer from {lo} to {hi} ({why}), received {value}"
        )


def _fits(key: str, name: str, n: int, what: str) -> None:
    """A ValueError unless the tables of ``n`` ids of ``what`` fit the memory available."""
    need = n * _BYTES_PER_ID[what]
    available = available_memory_bytes()
    if available is not None and need > available:
        raise ValueError(
            f"{key} ({name}): {n} {what} ids take {byte_size(need)}, more than the "
            f"{byte_size(available)} of memory available (a corrupt counter, or the state "
            "of a far larger map)"
        )


def check_counters(data, n_tiles: int, tile_px: int) -> None:
    """Check the ``counters`` and ``rooms_counters`` fields of a state whose tiles number
    ``n_tiles`` of ``tile_px`` pixels: none negative, the scans at most
    :data:`~topojax._constants.MAX_LOG_SCANS` (as a replay's resume checks them), the
    scans since an update at most the scans, the ridge pixels at most the tiles' pixels,
    the next ids within int32 (:data:`MAX_IDS`) and their tables within the memory
    available."""
    c = dict(zip(_COUNTERS, _ints(data, "counters", len(_COUNTERS)), strict=True))
    n = c["n_scans"]
    why = "scans added; more would be 800 years of a laser at 40 scans/s"
    _counter("counters", "n_scans", n, 0, MAX_LOG_SCANS, why)
    for name in ("since_skeleton", "since_graph"):
        _counter("counters", name, c[name], 0, n, "scans since that update, at most n_scans")
    _counter("counters", "n_ridge", c["n_ridge"], 0, n_tiles * tile_px**2, "ridge pixels")
    for name, what in (("next_vertex", "vertex"), ("next_edge", "edge")):
        _counter("counters", name, c[name], 0, MAX_IDS, f"{what} ids are int32")
        _fits("counters", name, c[name], what)
    if "rooms_counters" not in data:
        return
    r = dict(zip(_ROOM_COUNTERS, _ints(data, "rooms_counters", 3), strict=True))
    _counter("rooms_counters", "next_room_id", r["next_room_id"], 1, MAX_IDS, "room ids are int32")
    _fits("rooms_counters", "next_room_id", r["next_room_id"], "room")
    _counter("rooms_counters", "rooms_active", r["rooms_active"], 0, 1, "a flag")
    _counter("rooms_counters", "since_rooms", r["since_rooms"], 0, n, "at most n_scans")


def check_pixels(data, keys: np.ndarray, tile_px: int, pixel_bbox) -> None:
    """Check that the pixels the state keeps (pending splats, skeleton changes, vertices,
    edge paths) lie on its tiles (``keys``: int64 (n, 2) tile coordinates) and that the
    ridge box lies within their pixel box ``pixel_bbox`` (None without tiles)."""
    shift = int(tile_px).bit_length() - 1
    allocated = np.sort((keys[:, 0] << 32) + keys[:, 1]) if keys.size else np.zeros(0, np.int64)
    for key in ("pending", "skel_changed", "v_pixel", "e_path"):
        px = np.asarray(data[key])
        if px.dtype.kind not in "iu" or px.size % 2:
            raise ValueError(
                f"{key}: expected (n, 2) integer pixels, received {px.dtype} {px.shape}"
            )
        px = px.astype(np.int64).reshape(-1, 2)
        if not px.size:
            continue
        near = (np.abs(px) < 2**40).all(axis=1)  # farther: off any tile, and no overflow
        tk = ((np.where(near, px[:, 0], 0) >> shift) << 32) + (np.where(near, px[:, 1], 0) >> shift)
        at = np.minimum(np.searchsorted(allocated, tk), max(len(allocated) - 1, 0))
        on = near & (allocated[at] == tk) if allocated.size else np.zeros(len(px), bool)
        if not on.all():
            bad = tuple(int(v) for v in px[np.argmin(on)])
            raise ValueError(
                f"{key}: expected (row, col) pixels on the state's tiles, received {bad} "
                f"off them ({int((~on).sum())} of {len(px)} off)"
            )
    if bool(data["has_ridge_bbox"]):
        box = _ints(data, "ridge_bbox", 4)
        b = pixel_bbox
        if b is None or not (b[0] <= box[0] <= box[2] <= b[2] and b[1] <= box[1] <= box[3] <= b[3]):
            raise ValueError(
                f"ridge_bbox: expected a box within the tiles' pixel box {b}, received {tuple(box)}"
            )


def _rows(key: str, arr: np.ndarray, n: int, what: str) -> None:
    if arr.shape[0] != n:
        raise ValueError(f"{key}: expected one {what} ({n}), received {arr.shape[0]}")


def check_graph_tables(data, kinds) -> None:
    """Check that the graph's tables hold together: distinct vertex and edge ids, one
    pixel and one kind (among the codes ``kinds``) per vertex id, one pair of ends (ids
    of stored vertices) and one path length (>= 1) per edge id, the lengths adding up to
    the stored path pixels."""
    for key in ("v_id", "e_id"):
        ids, counts = np.unique(np.asarray(data[key]).reshape(-1), return_counts=True)
        if (counts > 1).any():
            raise ValueError(
                f"{key}: expected distinct ids, received {int(ids[counts > 1][0])} "
                f"{int(counts.max())} times"
            )
    n_v = np.asarray(data["v_id"]).reshape(-1).shape[0]
    n_e = np.asarray(data["e_id"]).reshape(-1).shape[0]
    _rows("v_pixel", np.asarray(data["v_pixel"]).reshape(-1, 2), n_v, "(row, col) per vertex id")
    codes = np.asarray(data["v_kind"]).reshape(-1)
    _rows("v_kind", codes, n_v, "kind code per vertex id")
    if not set(codes.tolist()) <= set(kinds):
        raise ValueError(
            f"v_kind: expected kind codes among {sorted(kinds)}, received "
            f"{sorted(set(codes.tolist()) - set(kinds))}"
        )
    ends = np.asarray(data["e_uv"]).reshape(-1, 2)
    _rows("e_uv", ends, n_e, "(u, v) per edge id")
    stored = np.asarray(data["v_id"], np.int64).reshape(-1)
    off = ~np.isin(ends, stored)
    if off.any():
        raise ValueError(
            f"e_uv: expected the ids of stored vertices, received {int(ends[off][0])} "
            f"({int(off.sum())} of {ends.size} ends off them)"
        )
    lengths = np.asarray(data["e_len"]).reshape(-1)
    _rows("e_len", lengths, n_e, "path length per edge id")
    if (lengths < 1).any():
        raise ValueError(f"e_len: expected path lengths >= 1, received {int(lengths.min())}")
    n_px = np.asarray(data["e_path"]).reshape(-1, 2).shape[0]
    if int(lengths.sum()) != n_px:
        raise ValueError(
            f"e_len: expected lengths adding up to the {n_px} pixels of e_path, received "
            f"lengths adding up to {int(lengths.sum())}"
        )
