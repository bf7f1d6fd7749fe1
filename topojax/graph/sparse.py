"""The topology graph of a skeleton held as its pixels' columns row by row, built with
memory proportional to the skeleton and the output written a block of paths at a time.

:func:`row_skeleton_graph_store` gives the :class:`GraphStore` that
:func:`skeleton_graph_store` gives for the same skeleton image (without junction-cluster
merging), array for array, but holds no neighbour table: it keeps 2 bytes per skeleton
pixel (link mask and state) beside the skeleton (4 bytes of column per pixel, one offset
per row) and the clearances, and finds neighbours by binary search in the rows above and
below.  It traces the edges as :func:`topojax.graph.raw_graph` does (vertices in raster
order, each one's links in direction order, then the rings from the last pixel in raster
order), first recording only each edge's first vertex, first direction, last vertex and
pixel count; then, with the edges in the store's order, it traces each path again and
writes the paths, their world coordinates, lengths and clearances a block of edges at a
time, into memory or into ``.npy`` files.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np

from .._fs import default_file_mode, naming_file, output_folder
from .._jit import cached_njit
from .build import _edge_values, _world_of
from .store import KIND_JUNCTION, KIND_RING, GraphStore
from .trace import _DC, _DR, _POPCOUNT, link_mask

__all__ = ["grown", "row_skeleton_graph_store"]

#: Path pixels written per block of edges.
_CHUNK_PX = 1 << 18


@cached_njit(nogil=True)
def _first_at_least(cols, lo, hi, c):
    """First index in ``[lo, hi)`` whose column is >= ``c`` (``hi`` if none)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if cols[mid] < c:
            lo = mid + 1
        else:
            hi = mid
    return lo


@cached_njit(nogil=True)
def _neighbour(row_start, cols, h, w, r, c, i, k):
    """Index of pixel ``i``'s (at ``(r, c)``) neighbour in direction ``k``, or -1."""
    rr = r + _DR[k]
    cc = c + _DC[k]
    if rr < 0 or rr >= h or cc < 0 or cc >= w:
        return -1
    if rr == r:
        j = i + _DC[k]
        if row_start[r] <= j < row_start[r + 1] and cols[j] == cc:
            return j
        return -1
    hi = row_start[rr + 1]
    j = _first_at_least(cols, row_start[rr], hi, cc)
    if j < hi and cols[j] == cc:
        return j
    return -1


@cached_njit(nogil=True)
def _link_masks(row_start, cols, h, w):
    """Link mask of every pixel (bit ``k``: linked in direction ``k``), as
    :func:`topojax.graph.trace._link_table` gives them."""
    n = cols.shape[0]
    masks = np.zeros(n, np.uint8)
    for r in range(h):
        for i in range(row_start[r], row_start[r + 1]):
            c = cols[i]
            masks[i] = link_mask(
                _neighbour(row_start, cols, h, w, r, c, i, 0) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 1) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 2) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 3) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 4) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 5) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 6) >= 0,
                _neighbour(row_start, cols, h, w, r, c, i, 7) >= 0,
            )
    return masks


@cached_njit(nogil=True)
def _is_vertex(masks, state, j):
    return _POPCOUNT[masks[j]] != 2 or (state[j] & 2) != 0


@cached_njit(nogil=True)
def _walk(row_start, cols, masks, state, h, w, start, r, c, k, mark, out_idx, out_r, out_c, at):
    """Follow the chain leaving pixel ``start`` (at ``(r, c)``) in direction ``k`` to the
    next vertex.  Returns ``(end pixel, pixel count)``, the count including both ends.
    With ``mark`` the chain's pixels are marked visited; with ``at >= 0`` the path is
    written to ``out_*[at:]``."""
    prev = start
    cur = _neighbour(row_start, cols, h, w, r, c, start, k)
    cr = r + _DR[k]
    cc = c + _DC[k]
    length = 1
    if at >= 0:
        out_idx[at] = start
        out_r[at] = r
        out_c[at] = c
    while True:
        if at >= 0:
            out_idx[at + length] = cur
            out_r[at + length] = cr
            out_c[at + length] = cc
        length += 1
        if _is_vertex(masks, state, cur):
            return cur, length
        if mark:
            state[cur] |= 1
        m = masks[cur]
        nxt = -1
        nk = 0
        for kk in range(8):
            if (m >> kk) & 1:
                cand = _neighbour(row_start, cols, h, w, cr, cc, cur, kk)
                if cand != prev:
                    nxt = cand
                    nk = kk
                    break
        prev = cur
        cur = nxt
        cr += _DR[nk]
        cc += _DC[nk]


@cached_njit(nogil=True)
def grown(arr, n):
    """``arr`` if index ``n`` fits in it, else a copy in an array about twice its size
    (the entries past the old end uninitialised)."""
    if n < arr.shape[0]:
        return arr
    out = np.empty(2 * arr.shape[0] + 16, arr.dtype)
    out[: arr.shape[0]] = arr
    return out


@cached_njit(nogil=True)
def _trace_edges(row_start, cols, masks, state, h, w):
    """Every edge as ``(first vertex, first direction, last vertex, pixel count)`` in
    :func:`topojax.graph.raw_graph`'s tracing order, and the ring vertices (marked in
    ``state`` bit 1)."""
    none = np.zeros(0, np.int64)
    cap = 1024
    eu = np.empty(cap, np.int64)
    ek = np.empty(cap, np.int64)
    ev = np.empty(cap, np.int64)
    el = np.empty(cap, np.int64)
    rings = np.empty(16, np.int64)
    n_e = 0
    n_r = 0
    for phase in range(2):
        for step in range(h):
            r = step if phase == 0 else h - 1 - step
            lo, hi = row_start[r], row_start[r + 1]
            for s in range(hi - lo):
                i = lo + s if phase == 0 else hi - 1 - s
                if phase == 0:
                    if _POPCOUNT[masks[i]] == 2:
                        continue
                else:
                    if _POPCOUNT[masks[i]] != 2 or state[i] & 1:
                        continue
                    state[i] |= 2
                    rings = grown(rings, n_r)
                    rings[n_r] = i
                    n_r += 1
                c = cols[i]
                m = masks[i]
                for k in range(8):
                    if not (m >> k) & 1:
                        continue
                    nb = _neighbour(row_start, cols, h, w, r, c, i, k)
                    if _is_vertex(masks, state, nb):
                        if i >= nb:
                            continue
                        end, length = nb, 2
                    elif state[nb] & 1:
                        continue
                    else:
                        end, length = _walk(
                            row_start, cols, masks, state, h, w, i, r, c, k, True,
                            none, none, none, -1,
                        )  # fmt: skip
                    eu = grown(eu, n_e)
                    ek = grown(ek, n_e)
                    ev = grown(ev, n_e)
                    el = grown(el, n_e)
                    eu[n_e], ek[n_e], ev[n_e], el[n_e] = i, k, end, length
                    n_e += 1
                if phase == 1:
                    state[i] |= 1
    return eu[:n_e].copy(), ek[:n_e].copy(), ev[:n_e].copy(), el[:n_e].copy(), rings[:n_r].copy()


@cached_njit(nogil=True)
def _write_paths(row_start, cols, masks, state, h, w, eu, ek, urow, el, out_idx, out_r, out_c):
    """The paths of the edges ``(eu, ek)`` (first rows ``urow``, counts ``el``) one after
    another into ``out_*``."""
    at = 0
    for e in range(eu.shape[0]):
        i, r, k = eu[e], urow[e], ek[e]
        if el[e] == 2:  # two adjacent vertices (a chain holds at least three pixels)
            out_idx[at], out_r[at], out_c[at] = i, r, cols[i]
            out_idx[at + 1] = _neighbour(row_start, cols, h, w, r, cols[i], i, k)
            out_r[at + 1] = r + _DR[k]
            out_c[at + 1] = cols[i] + _DC[k]
        else:
            _walk(
                row_start, cols, masks, state, h, w, i, r, cols[i], k, False,
                out_idx, out_r, out_c, at,
            )  # fmt: skip
        at += el[e]


class _Output:
    """The store's two path arrays, in memory or as ``.npy`` files written in order."""

    def __init__(self, n_path: int, out_dir: Path | None) -> None:
        self.out_dir = out_dir
        self.at = 0
        if out_dir is None:
            self.arrays = {
                "path_pixels": np.empty((n_path, 2), np.int64),
                "path_world": np.empty((n_path, 2), np.float64),
            }
            return
        # written under temporary names and renamed when complete: the files of an
        # earlier store in the same folder, which may still be memory-mapped, are
        # replaced, never rewritten in place (a mapped file cut short crashes its reader)
        self.files, self.tmp = {}, {}
        for name, dtype in (("path_pixels", np.int64), ("path_world", np.float64)):
            fd, tmp = tempfile.mkstemp(suffix=".tmp", prefix=f".{name}.npy.", dir=out_dir)
            os.fchmod(fd, default_file_mode())  # mkstemp's 0600 would stay after renaming
            os.close(fd)
            self.tmp[name] = tmp
            mm = np.lib.format.open_memmap(tmp, mode="w+", dtype=dtype, shape=(n_path, 2))
            offset = mm.offset
            del mm
            f = open(tmp, "r+b")  # noqa: SIM115 - closed in finish() or discard()
            f.seek(offset)
            self.files[name] = f

    def write(self, name: str, values: np.ndarray) -> None:
        if self.out_dir is None:
            self.arrays[name][self.at : self.at + values.shape[0]] = values
        else:
            with naming_file(self.out_dir / f"{name}.npy"):
                self.files[name].write(np.ascontiguousarray(values).tobytes())

    def advance(self, n: int) -> None:
        self.at += n

    def finish(self) -> dict[str, np.ndarray]:
        if self.out_dir is None:
            return self.arrays
        try:
            for name, f in self.files.items():
                with naming_file(self.out_dir / f"{name}.npy"):
                    f.close()  # writes what the file's buffer still holds
                os.replace(self.tmp[name], self.out_dir / f"{name}.npy")
        except BaseException:
            self.discard()
            raise
        return {n: np.load(self.out_dir / f"{n}.npy", mmap_mode="r") for n in self.files}

    def discard(self) -> None:
        """Close and remove the unfinished files (the folder's earlier ones stay)."""
        if self.out_dir is None:
            return
        for name, f in self.files.items():
            with contextlib.suppress(OSError):  # its unwritten buffer, on a full disk
                f.close()
            Path(self.tmp[name]).unlink(missing_ok=True)


def write_path_files(out_dir, path_pixels: np.ndarray, path_world: np.ndarray) -> dict:
    """Write a store's ``path_pixels`` (int64 (n, 2)) and ``path_world`` (float64 (n, 2))
    to ``out_dir`` as ``.npy`` files, replacing earlier ones whole; returns them
    memory-mapped by name."""
    out = _Output(path_pixels.shape[0], output_folder(out_dir))
    try:
        out.write("path_pixels", np.asarray(path_pixels, np.int64))
        out.write("path_world", np.asarray(path_world, np.float64))
    except BaseException:
        out.discard()
        raise
    return out.finish()


def _rows_of(row_start: np.ndarray, idx: np.ndarray) -> np.ndarray:
    return np.searchsorted(row_start, idx, side="right") - 1


def row_skeleton_graph_store(
    shape: tuple[int, int],
    row_start: np.ndarray,
    cols: np.ndarray,
    *,
    clearance_px: np.ndarray | None = None,
    resolution_m: float = 1.0,
    pixel_to_world=None,
    out_dir=None,
) -> GraphStore:
    """The :class:`GraphStore` of a skeleton given row by row.

    Parameters
    ----------
    shape : (H, W)
    row_start : int64 (H + 1,)
        Row ``r``'s pixels are ``cols[row_start[r]:row_start[r + 1]]``.
    cols : int32 (n,)
        Their columns, increasing within each row.
    clearance_px : float32 or float64 (n,), optional
        Clearance in pixels at each pixel (checked by the caller: >= 0, not NaN).
    resolution_m, pixel_to_world
        As for :func:`topojax.graph.skeleton_to_graph`.
    out_dir : str or Path, optional
        Write ``path_pixels.npy`` and ``path_world.npy`` (the two arrays the size of the
        skeleton) there and give the store them memory-mapped.

    Returns
    -------
    GraphStore
        Equal to :func:`skeleton_graph_store` of the skeleton image (no cluster merging).
    """
    h, w = int(shape[0]), int(shape[1])
    res = float(resolution_m)
    attrs = {"resolution_m": res, "shape": (h, w), "merge_junction_clusters": False}
    row_start = np.ascontiguousarray(row_start, np.int64)
    cols = np.ascontiguousarray(cols, np.int32)
    if cols.size == 0:
        if out_dir is not None:  # the folder's arrays are this store's: empty
            write_path_files(out_dir, np.empty((0, 2), np.int64), np.empty((0, 2)))
        return GraphStore.empty(attrs)
    masks = _link_masks(row_start, cols, h, w)
    state = np.zeros(cols.shape[0], np.uint8)
    eu, ek, ev, el, rings = _trace_edges(row_start, cols, masks, state, h, w)
    deg = _POPCOUNT[masks]
    v_pix = np.flatnonzero(deg != 2)
    v_kind = np.minimum(deg[v_pix], KIND_JUNCTION).astype(np.int8)
    del deg
    if rings.size:
        v_pix = np.concatenate([v_pix, rings])
        v_kind = np.concatenate([v_kind, np.full(rings.size, KIND_RING, np.int8)])
        order = np.argsort(v_pix, kind="stable")
        v_pix, v_kind = v_pix[order], v_kind[order]
    u_id = np.searchsorted(v_pix, eu)
    v_id = np.searchsorted(v_pix, ev)
    order = np.lexsort((np.arange(eu.size), v_id, u_id))
    eu, ek, el = eu[order], ek[order], el[order]
    clear = None if clearance_px is None else np.asarray(clearance_px)
    vr = _rows_of(row_start, v_pix)
    vc = cols[v_pix].astype(np.int64)
    offsets = np.concatenate([[0], np.cumsum(el)])
    out = _Output(int(offsets[-1]), None if out_dir is None else output_folder(out_dir))
    lengths, min_c, mean_c = (np.empty(eu.size) for _ in range(3))
    try:
        first = 0
        while first < eu.size:
            last = int(np.searchsorted(offsets, offsets[first] + _CHUNK_PX, side="right")) - 1
            last = max(last, first + 1)
            sel = slice(first, last)
            n_px = int(offsets[last] - offsets[first])
            idx, rr, cc = (np.empty(n_px, np.int64) for _ in range(3))
            _write_paths(
                row_start, cols, masks, state, h, w, eu[sel], ek[sel],
                _rows_of(row_start, eu[sel]), el[sel], idx, rr, cc,
            )  # fmt: skip
            path_rc = np.stack([rr, cc], axis=1)
            del rr, cc
            local = offsets[first : last + 1] - offsets[first]
            part = None if clear is None else clear[idx].astype(np.float64)
            lengths[sel], min_c[sel], mean_c[sel] = _edge_values(
                path_rc, np.arange(n_px), local, el[sel], part, res
            )
            world = _world_of(path_rc, vr[:0], vc[:0], (h, w), res, pixel_to_world)
            out.write("path_pixels", path_rc)
            out.write("path_world", world)
            out.advance(n_px)
            first = last
    except BaseException:
        out.discard()
        raise
    node_clear = (
        np.full(v_pix.size, np.nan) if clear is None else clear[v_pix].astype(np.float64) * res
    )
    node_world = _world_of(np.zeros((0, 2), np.int64), vr, vc, (h, w), res, pixel_to_world)
    paths = out.finish()
    return GraphStore(
        node_pixel=np.stack([vr, vc], axis=1),
        node_kind=v_kind,
        node_world=node_world,
        node_clearance_m=node_clear,
        edge_u=u_id[order],
        edge_v=v_id[order],
        path_offsets=offsets,
        path_pixels=paths["path_pixels"],
        path_world=paths["path_world"],
        edge_length_m=lengths,
        edge_min_clearance_m=min_c,
        edge_mean_clearance_m=mean_c,
        attrs=attrs,
    )
