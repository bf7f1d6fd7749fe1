"""Graph patch kernels: the region ``Z`` around changed skeleton pixels, the skeleton
pixels near the old edges, and path signatures.
"""

from __future__ import annotations

import time

import numpy as np

from .._jit import cached_njit
from ..graph import KIND_CODES
from ._graph_store import add_paths, drop_paths, edge_paths, reserve
from ._tiles import (
    _U64,
    _around,
    _clear_owned,
    _clear_region,
    _flags,
    _flat,
    _gather_px,
    _locate,
    _log2,
    _scatter_px,
    _unpack,
)
from .reports import GraphUpdate


@cached_njit(nogil=True, inline="always")
def _add_to_z(g, r, c, m, mk, gi, sk, zr, zc, gid, skz):
    """Append the pixel at flat storage offset ``g`` (global ``(r, c)``) to Z unless it is
    there already (``mk`` bit 4); returns the new length."""
    if mk[g] & 4:
        return m
    mk[g] |= 4
    gid[m] = gi[g]
    skz[m] = sk[g]
    zr[m] = r
    zc[m] = c
    return m + 1


@cached_njit(nogil=True)
def _region_z(sr, sc, grid, g0r, g0c, nbr9, t, mark, graph_id, skeleton):
    """The region Z: the *net* changed pixels dilated by one (3 x 3), without repeats,
    with the ``graph_id`` and ``skeleton`` values there.

    The graph covers every pixel of the skeleton it was built from (``graph_id != -1``
    exactly there), so a listed pixel whose skeleton value changed and changed back since
    the last graph update is no change and is skipped.  Pixels of missing tiles read -1 /
    False.  Returns ``zr, zc, gid, skz``.  One tile lookup per changed pixel; its
    neighbours are reached through ``nbr9`` (:meth:`TileManager.neighbour_slots`).

    ``mark`` (scratch uint8 layer) is zero on entry; on exit bit 4 is set on Z, for
    :func:`_near_skeleton`, which clears it (or :func:`_clear_region` on an error in
    between).
    """
    tsh = _log2(t)
    n = sr.shape[0]
    zr = np.empty(9 * n, np.int64)
    zc = np.empty(9 * n, np.int64)
    gid = np.empty(9 * n, np.int32)
    skz = np.empty(9 * n, np.bool_)
    mk = _flat(mark)
    gi = _flat(graph_id)
    sk = _flat(skeleton)
    m = 0
    for i in range(n):
        s0, lr0, lc0 = _locate(grid, g0r, g0c, tsh, sr[i], sc[i])
        if s0 >= 0 and skeleton[s0, lr0, lc0] == (graph_id[s0, lr0, lc0] != -1):
            continue
        if s0 >= 0 and 0 < lr0 < t - 1 and 0 < lc0 < t - 1:
            # the 3 x 3 neighbourhood lies in this tile: flat offsets
            f = _U64((s0 * t + lr0 - 1) * t + lc0 - 1)
            for dr in range(3):
                for dc in range(3):
                    g = f + _U64(dc)
                    r, c = sr[i] + dr - 1, sc[i] + dc - 1
                    m = _add_to_z(g, r, c, m, mk, gi, sk, zr, zc, gid, skz)
                f += _U64(t)
            continue
        for k in range(9):
            s, nr, nc = _around(nbr9, s0, lr0, lc0, k, t)
            if s >= 0:
                g = _U64((s * t + nr) * t + nc)
                r, c = sr[i] + k // 3 - 1, sc[i] + k % 3 - 1
                m = _add_to_z(g, r, c, m, mk, gi, sk, zr, zc, gid, skz)
            else:
                # outside the allocated tiles: only possible one pixel off the bbox;
                # repeats there are harmless
                gid[m] = -1
                skz[m] = False
                zr[m] = sr[i] + k // 3 - 1
                zc[m] = sc[i] + k % 3 - 1
                m += 1
    return zr[:m], zc[:m], gid[:m], skz[:m]


def _interior(off: np.ndarray) -> np.ndarray:
    """Mask of the interior pixels (not first, not last) of CSR paths with offsets ``off``."""
    inner = np.ones(int(off[-1]), bool)
    inner[off[:-1]] = False
    inner[off[1:] - 1] = False
    return inner


def _signatures(paths: np.ndarray, off: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Orientation-free signatures of CSR pixel paths (length, hashed ends, hashed pixel
    sum); equal paths have equal signatures (matches are verified by comparison)."""
    u = paths.astype(np.uint64)
    h = (u[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (u[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F))
    total = np.add.reduceat(h, off[:-1])
    e0 = h[off[:-1]]
    e1 = h[off[1:] - 1]
    return list(
        zip(
            np.diff(off).tolist(),
            np.minimum(e0, e1).tolist(),
            np.maximum(e0, e1).tolist(),
            total.tolist(),
            strict=True,
        )
    )


@cached_njit(nogil=True)
def _near_skeleton(ar, ac, zr, zc, qr, qc, grid, g0r, g0c, nbr9, t, mark, skeleton):
    """The skeleton pixels within one pixel (3 x 3) of the pixels A = ``(ar, ac)``.

    Returns their keys (:func:`_pack`, unsorted, without repeats), whether each lies in A
    and whether it lies in the region Z = ``(zr, zc)``, and whether each query pixel
    ``(qr, qc)`` lies in Z.  Work is proportional to the number of pixels, not to their
    bounding box.  ``mark`` (scratch uint8 layer) holds bit 4 on Z on entry (as
    :func:`_region_z` leaves it) and is zero on exit; bits: 1 collected, 2 in A, 4 in Z.
    """
    tsh = _log2(t)
    n = ar.shape[0]
    for i in range(n):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, ar[i], ac[i])
        if s >= 0:
            mark[s, lr, lc] |= 2
    keys = np.empty(9 * n, np.int64)
    in_a = np.empty(9 * n, np.bool_)
    in_z = np.empty(9 * n, np.bool_)
    m = 0
    for i in range(n):
        s0, lr0, lc0 = _locate(grid, g0r, g0c, tsh, ar[i], ac[i])
        if s0 < 0:
            continue
        for k in range(9):
            s, nr, nc = _around(nbr9, s0, lr0, lc0, k, t)
            if s < 0 or not skeleton[s, nr, nc] or mark[s, nr, nc] & 1:
                continue
            f = mark[s, nr, nc]
            mark[s, nr, nc] = f | 1
            keys[m] = ((ar[i] + k // 3 - 1) << 32) + ac[i] + k % 3 - 1 + (1 << 31)
            in_a[m] = (f & 2) != 0
            in_z[m] = (f & 4) != 0
            m += 1
    q_in_z = np.zeros(qr.shape[0], np.bool_)
    for i in range(qr.shape[0]):
        s, lr, lc = _locate(grid, g0r, g0c, tsh, qr[i], qc[i])
        if s >= 0:
            q_in_z[i] = (mark[s, lr, lc] & 4) != 0
    kr = keys[:m] >> 32  # the collected pixels, from their keys
    _clear_region(kr, keys[:m] - (kr << 32) - (1 << 31), grid, g0r, g0c, t, mark)
    _clear_region(ar, ac, grid, g0r, g0c, t, mark)
    _clear_region(zr, zc, grid, g0r, g0c, t, mark)
    return keys[:m], in_a[:m], in_z[:m], q_in_z


def _old_side(mapper, changed, where, gl, skel):
    """The region Z around the changed skeleton pixels ``changed`` (int64 (n, 2)), the
    old edges R it touches and the skeleton pixels near A (pixels of R plus new skeleton
    pixels in Z), gathered from the tiles.

    Returns ``(zr, zc)``, R (edge ids ``rem``), the vertices it touches (``touched``), R's
    paths (``all_r``, ``lens_r``, ``off_r``) and :func:`_near_skeleton`'s ``keys, in_a,
    in_z, t_in_z`` for the touched vertices.  The scratch marks are clean on return, also
    after an exception.
    """
    grid, g0r, g0c, _, t, mark = where
    # Z: the changed pixels dilated by one (where pixel-graph links can change); it
    # stays flagged in ``mark`` until _near_skeleton has read and cleared it
    zr, zc, gid, skz = _region_z(
        np.ascontiguousarray(changed[:, 0]),
        np.ascontiguousarray(changed[:, 1]),
        *where,
        gl,
        skel,
    )
    try:
        nv, ne = mapper._next_vertex, mapper._next_edge
        e_alive = mapper._e_alive[:ne]
        e_u, e_v = mapper._e_uv[:ne, 0], mapper._e_uv[:ne, 1]
        # R: edges with a pixel in Z or ending at a vertex in Z
        in_vz = np.zeros(nv, bool)
        in_vz[-(gid[gid <= -2].astype(np.int64) + 2)] = True
        rem_flag = e_alive & (in_vz[e_u] | in_vz[e_v])
        rem_flag[gid[gid >= 0]] = True
        rem = np.flatnonzero(rem_flag)
        touched = np.flatnonzero(in_vz | _flags(nv, e_u[rem]) | _flags(nv, e_v[rem]))
        all_r, lens_r = edge_paths(mapper, rem)
        all_r = all_r.astype(np.int64)
        off_r = np.concatenate([[0], np.cumsum(lens_r)])
        # A: pixels of the edges of R and new skeleton pixels in Z.  Every new edge that
        # touches Z lies in A, so the local graph is traced on the skeleton pixels within
        # one pixel of A (their links to A are the same as in the whole map).  Pixels are
        # gathered sparsely: changes spread over a large map cost by their number, not by
        # their bounding box.
        a_px = np.concatenate([all_r, np.stack([zr[skz], zc[skz]], axis=1)])
        t_r, t_c = _unpack(mapper._v_key[touched])
        ar, ac = np.ascontiguousarray(a_px[:, 0]), np.ascontiguousarray(a_px[:, 1])
        near = _near_skeleton(ar, ac, zr, zc, t_r, t_c, *where, skel)
    except BaseException:
        _clear_region(zr, zc, grid, g0r, g0c, t, mark)
        raise
    return zr, zc, rem, touched, all_r, lens_r, off_r, near


def _traced_edges(keys, in_a, in_z):
    """Trace the local graph on the skeleton pixels ``keys`` (packed, unsorted) and keep
    N, the local edges lying in A with a pixel in Z.

    Returns the patch's vertices (sorted keys ``nk_keys``, kind codes ``nk_code``) and
    N's paths: lengths ``lens_k``, offsets ``off_k``, packed pixels ``kk`` and pixels
    ``kp`` (int64 (n, 2)).
    """
    from ..graph import raw_graph

    order = np.argsort(keys)
    keys, in_a, in_z = keys[order], in_a[order], in_z[order]
    if keys.size:
        v_idx, v_kind, _, _, e_off, path = raw_graph(keys, 1 << 32)
    else:
        v_idx, v_kind = np.zeros(0, np.int64), np.zeros(0, np.int8)
        e_off, path = np.zeros(1, np.int64), np.zeros(0, np.int64)
    # N: the local edges lying in A with a pixel in Z (the new edges around Z)
    kept = np.zeros(0, np.int64)
    is_end = np.zeros(keys.shape[0], bool)
    if e_off.shape[0] > 1:
        all_a = np.minimum.reduceat(in_a[path], e_off[:-1])
        any_z = np.maximum.reduceat(in_z[path], e_off[:-1])
        kept = np.flatnonzero(all_a & any_z)
        is_end[path[e_off[kept]]] = True
        is_end[path[e_off[kept + 1] - 1]] = True
    # vertices of the patch: local vertices in Z and the ends of N (sorted keys)
    sel = in_z[v_idx] | is_end[v_idx]
    nk_keys = keys[v_idx[sel]]
    nk_code = v_kind[sel].astype(np.int8)
    lens_k = e_off[kept + 1] - e_off[kept]
    off_k = np.concatenate([[0], np.cumsum(lens_k)])
    take = np.repeat(e_off[kept] - off_k[:-1], lens_k) + np.arange(int(off_k[-1]))
    kk = keys[path[take]]
    kp = np.stack(_unpack(kk), axis=1)
    return nk_keys, nk_code, lens_k, off_k, kk, kp


def _match_unchanged(all_r, off_r, kp, off_k) -> tuple[np.ndarray, np.ndarray]:
    """Which old paths (``all_r``, offsets ``off_r``) come back unchanged among the new
    ones (``kp``, offsets ``off_k``), in either direction: a bool flag per old and per
    new path.  Matched by orientation-free signature, then verified."""
    matched_old = np.zeros(off_r.shape[0] - 1, bool)
    matched_new = np.zeros(off_k.shape[0] - 1, bool)
    if matched_old.size and matched_new.size:
        by_sig: dict[tuple, list[int]] = {}
        for j, sig in enumerate(_signatures(all_r, off_r)):
            by_sig.setdefault(sig, []).append(j)
        kp32 = kp.astype(np.int32)
        for i, sig in enumerate(_signatures(kp, off_k)):
            cands = by_sig.get(sig)
            if not cands:
                continue
            new = kp32[off_k[i] : off_k[i + 1]]
            for j in cands:
                old = all_r[off_r[j] : off_r[j + 1]]
                if not matched_old[j] and (
                    np.array_equal(old, new) or np.array_equal(old, new[::-1])
                ):
                    matched_old[j] = matched_new[i] = True
                    break
    return matched_old, matched_new


def _place_vertices(mapper, nk_keys, nk_code, gl, where) -> tuple[np.ndarray, ...]:
    """Give the patch's vertices ids: an existing vertex keeps its id (its pixel holds
    it), the others get new ones.  Returns the ids (in ``nk_keys`` order), the new ids
    and the old vertices whose kind changed."""
    grid, g0r, g0c, _, t, _ = where
    nv = mapper._next_vertex
    nr, nc = _unpack(nk_keys)
    at = np.empty(nk_keys.shape[0], np.int32)
    _gather_px(gl, grid, g0r, g0c, t, nr, nc, -1, at)
    old_v = at <= -2
    ids = np.where(old_v, -(at.astype(np.int64) + 2), 0)
    n_new = int((~old_v).sum())
    added_v = np.arange(nv, nv + n_new, dtype=np.int64)
    ids[~old_v] = added_v
    reserve(mapper, vertices=nv + n_new)
    mapper._next_vertex = nv + n_new
    mapper._v_key[added_v] = nk_keys[~old_v]
    mapper._v_alive[added_v] = True
    kind_changed = ids[old_v][mapper._v_code[ids[old_v]] != nk_code[old_v]]
    mapper._v_code[ids] = nk_code
    _scatter_px(gl, grid, g0r, g0c, t, nr, nc, -(ids.astype(np.int32) + 2))
    return ids, added_v, kind_changed


def _add_edges(mapper, new_i, traced, ids, gl, where) -> np.ndarray:
    """Add the new edges ``new_i`` of the ``traced`` ones (:func:`_traced_edges`),
    oriented from the smaller vertex id; returns their keys."""
    from ..graph import orient

    grid, g0r, g0c, _, t, _ = where
    nk_keys, _, lens_k, off_k, kk, kp = traced
    ne = mapper._next_edge
    added_e = np.arange(ne, ne + new_i.shape[0], dtype=np.int64)
    if new_i.size:
        ln = lens_k[new_i]
        off_n = np.concatenate([[0], np.cumsum(ln)])
        take = np.repeat(off_k[new_i] - off_n[:-1], ln) + np.arange(int(off_n[-1]))
        nkk = kk[take]
        a_ids = ids[np.searchsorted(nk_keys, nkk[off_n[:-1]])]
        b_ids = ids[np.searchsorted(nk_keys, nkk[off_n[1:] - 1])]
        a_ids, b_ids, npx = orient(a_ids, b_ids, off_n, ln, kp[take])
        npx32 = npx.astype(np.int32)
        reserve(mapper, edges=ne + new_i.shape[0])
        mapper._next_edge = ne + new_i.shape[0]
        mapper._e_uv[added_e, 0] = a_ids
        mapper._e_uv[added_e, 1] = b_ids
        mapper._e_alive[added_e] = True
        add_paths(mapper, added_e, npx32, ln)
        inner = _interior(off_n)
        owner = np.repeat(added_e.astype(np.int32), ln)
        _scatter_px(gl, grid, g0r, g0c, t, npx[inner, 0], npx[inner, 1], owner[inner])
    return added_e


def patch_graph(mapper) -> GraphUpdate:
    """The graph loop: replace the edges around the skeleton pixels changed since the
    last graph update by the ones traced there (see docs/incremental-exactness.md)."""
    t0 = time.perf_counter()
    mapper._since_graph = 0
    mapper._export_cache.clear()
    if not mapper._skel_changed:
        return GraphUpdate(time_s=time.perf_counter() - t0)
    tiles = mapper._tiles
    t = mapper.tile_px
    changed = np.concatenate(mapper._skel_changed).astype(np.int64, copy=False)
    mapper._skel_changed = []
    grid, (g0r, g0c) = tiles.slot_grid
    gl = tiles.layer("graph_id")
    where = (grid, g0r, g0c, tiles.neighbour_slots(), t, tiles.layer("mark"))
    nv = mapper._next_vertex
    zr, _, rem, touched, all_r, lens_r, off_r, near = _old_side(
        mapper, changed, where, gl, tiles.layer("skeleton")
    )
    keys, in_a, in_z, t_in_z = near
    traced = _traced_edges(keys, in_a, in_z)
    nk_keys, nk_code, _, off_k, _, kp = traced
    # ---- edges of R whose path comes back unchanged keep their key (and are not
    # touched)
    matched_old, matched_new = _match_unchanged(all_r, off_r, kp, off_k)
    gone_e = rem[~matched_old]
    # ---- remove the edges that changed
    if gone_e.size:
        keep_px = np.repeat(~matched_old, lens_r)
        inner = _interior(off_r) & keep_px
        owner = np.repeat(rem.astype(np.int32), lens_r)
        _clear_owned(gl, grid, g0r, g0c, t, all_r[inner, 0], all_r[inner, 1], owner[inner])
        mapper._e_alive[gone_e] = False
        drop_paths(mapper, gone_e)
    # ---- vertices: a touched vertex whose pixel is no vertex of the patch goes (outside
    # Z a vertex keeps its degree; only a ring vertex can stop being one)
    t_keys = mapper._v_key[touched]
    stays = np.isin(t_keys, nk_keys, assume_unique=True)
    ring = mapper._v_code[touched] == KIND_CODES["ring"]
    removed_v = touched[~stays & (t_in_z | ring)]
    if removed_v.size:
        vr, vc = _unpack(mapper._v_key[removed_v])
        _clear_owned(gl, grid, g0r, g0c, t, vr, vc, -(removed_v.astype(np.int32) + 2))
        mapper._v_alive[removed_v] = False
    ids, added_v, kind_changed = _place_vertices(mapper, nk_keys, nk_code, gl, where)
    added_e = _add_edges(mapper, np.flatnonzero(~matched_new), traced, ids, gl, where)
    # a vertex changed when its kind or its set of edges did
    changed_v = np.concatenate(
        [kind_changed, mapper._e_uv[gone_e].ravel(), mapper._e_uv[added_e].ravel()]
    )
    changed_v = np.unique(changed_v)
    changed_v = changed_v[mapper._v_alive[changed_v] & (changed_v < nv)]
    return GraphUpdate(
        added_vertices=tuple(added_v.tolist()),
        removed_vertices=tuple(removed_v.tolist()),
        changed_vertices=tuple(changed_v.tolist()),
        added_edges=tuple(added_e.tolist()),
        removed_edges=tuple(gone_e.tolist()),
        region_px=int(zr.shape[0]),
        time_s=time.perf_counter() - t0,
    )
