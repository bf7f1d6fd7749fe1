"""Pixel-path geometry shared by the graph builders, pruning, routing and export: path
lengths counted in integer straight / diagonal steps, cumulative lengths, path
orientation in CSR layout, vertex-pixel membership, Douglas–Peucker simplification, and
the check that a graph's edges are corridors."""

from __future__ import annotations

import math
import numbers

import numpy as np

from .._validate import pixel_rows, plain_int_pair
from .._words import graphml_text


def _steps_length(n_straight, n_diagonal, res: float):
    """Length in metres of a path with these numbers of straight and diagonal steps."""
    return (n_straight + n_diagonal * math.sqrt(2.0)) * res


def _running_diagonals(pixels: np.ndarray) -> np.ndarray:
    """Diagonal steps before each pixel of ``pixels`` (K, 2), an integer running count
    (length K).  Paths stored one after another subtract the count at their own first
    pixel, so the step from one path's last pixel to the next one's first is never
    counted and a path's length is a function of the path alone, not of where it sits
    among the others."""
    pixels = np.asarray(pixels, np.int64)
    if pixels.shape[0] == 0:
        return np.zeros(1, np.int64)
    diagonal = np.diff(pixels[:, 0]) != 0
    diagonal &= np.diff(pixels[:, 1]) != 0
    out = np.zeros(pixels.shape[0], np.int64)
    np.cumsum(diagonal, out=out[1:])
    return out


def path_lengths_m(pixels: np.ndarray, starts, sizes, res: float) -> np.ndarray:
    """``length_m`` of each path stored in ``pixels`` (path ``i``: ``sizes[i]`` rows from
    ``starts[i]``): its straight and diagonal steps, counted as integers."""
    starts = np.asarray(starts, np.int64)
    sizes = np.asarray(sizes, np.int64)
    n_diag = _running_diagonals(pixels)
    diagonal = n_diag[starts + sizes - 1] - n_diag[starts]
    return _steps_length(sizes - 1 - diagonal, diagonal, res)


def cumulative_length_m(pixels: np.ndarray, starts, sizes, res: float) -> np.ndarray:
    """Length in metres from its own path's first pixel to every pixel, counted as
    :func:`path_lengths_m` does (the last pixel of a path has the path's length)."""
    n_diag = _running_diagonals(pixels)
    first = np.repeat(np.asarray(starts, np.int64), sizes)
    steps = np.arange(len(first)) - first
    diagonal = n_diag - n_diag[first]
    return _steps_length(steps - diagonal, diagonal, res)


def scaled_cumulative(cum: np.ndarray, starts, sizes, lengths) -> np.ndarray:
    """``cum`` (running lengths along paths stored one after another, as
    :func:`cumulative_length_m` gives) rescaled per path so that its last entry is the
    path's entry of ``lengths`` and every other keeps its share of it (a path of length 0
    keeps its zeros).  Where the factor overflows (a huge ``length_m`` on a short path),
    the share is taken first, so finite lengths give finite results."""
    sizes = np.asarray(sizes, np.int64)
    ends = np.asarray(starts, np.int64) + sizes - 1
    lengths = np.asarray(lengths, np.float64)
    steps = cum[ends]
    with np.errstate(over="ignore"):
        scale = np.divide(lengths, steps, out=np.ones_like(steps), where=steps > 0)
    huge = ~np.isfinite(scale)
    out = cum * np.repeat(np.where(huge, 1.0, scale), sizes)
    if huge.any():
        at = np.repeat(huge, sizes)
        out[at] = cum[at] / np.repeat(steps, sizes)[at] * np.repeat(lengths, sizes)[at]
    out[ends] = lengths
    return out


def _path_length_m(path: np.ndarray, res: float) -> float:
    """``length_m`` of a ``(K, 2)`` pixel path, exactly as :func:`skeleton_to_graph`."""
    return float(path_lengths_m(path, [0], [len(path)], res)[0])


def holds(node: dict, pixel, name: str = "graph: a vertex") -> bool:
    """Is ``pixel`` one of the vertex's pixels (its ``pixel``, or any of a merged junction
    cluster's ``pixels``)?  False for a vertex with neither; a ``TypeError`` or
    ``ValueError`` naming ``name`` (the vertex) for ones that are not integer pixels."""
    r, c = int(pixel[0]), int(pixel[1])
    own = node.get("pixel")
    if own is not None:
        if not plain_int_pair(own):
            own = pixel_rows(f"{name}: 'pixel'", own, one=True)  # not the builders' int pair
        if own[0] == r and own[1] == c:
            return True
    members = node.get("pixels")
    if members is None or (isinstance(members, (list, tuple, np.ndarray)) and not len(members)):
        return False
    members = pixel_rows(f"{name}: 'pixels'", members)
    return bool(np.any((members[:, 0] == r) & (members[:, 1] == c)))


def pixel_less(graph, nodes) -> str:
    """A note naming the first of ``nodes`` (vertices of ``graph``) with neither a
    ``pixel`` nor ``pixels`` attribute (a hand-edited file, say), for an error that its
    edge's path ends elsewhere; ``""`` when each has one."""
    for n in nodes:
        data = graph.nodes[n]
        if data.get("pixel") is None and data.get("pixels") is None:
            return f" (vertex {n!r} has no 'pixel' or 'pixels' attribute)"
    return ""


def _ends_at(path: np.ndarray, pixel) -> bool:
    """Is ``pixel`` the last pixel of ``path``?"""
    return int(path[-1, 0]) == int(pixel[0]) and int(path[-1, 1]) == int(pixel[1])


def orient(
    u: np.ndarray, v: np.ndarray, off: np.ndarray, lens: np.ndarray, paths: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Swap ``u``/``v`` where ``u > v`` and reverse those edges' paths (CSR ``off``)."""
    flip = u > v
    if not flip.any():
        return u, v, paths
    flipped = np.flatnonzero(flip)
    pos = _edge_pixel_index(off, flipped)  # the pixels that move, edge by edge
    edge_of = np.repeat(flipped, lens[flipped])
    out = paths.copy()
    out[pos] = paths[2 * off[edge_of] + lens[edge_of] - 1 - pos]
    return np.where(flip, v, u), np.where(flip, u, v), out


def _edge_pixel_index(off: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Indices into the concatenated paths of the pixels of the edges ``keep``."""
    lens = off[keep + 1] - off[keep]
    base = np.concatenate([[0], np.cumsum(lens)[:-1]])
    return np.repeat(off[keep] - base, lens) + np.arange(int(lens.sum()))


def polyline_keep(xy: np.ndarray, tol: float) -> np.ndarray:
    """Douglas–Peucker: indices of the points of polyline ``xy`` (K, 2) to keep (first and
    last included) so that every point lies within ``tol`` of the kept chain's segment
    between its neighbours."""
    n = len(xy)
    keep = np.zeros(n, dtype=bool)
    keep[[0, n - 1]] = True
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        dist = _distances(xy[i + 1 : j], xy[i], xy[j])
        m = int(np.argmax(dist))
        if dist[m] > tol:
            m += i + 1
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep)


def _distances(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The distance of each point of ``pts`` (K, 2) from the segment ``a``-``b``; where
    the coordinates are too large to square in float64, computed in units of the
    largest offset from ``a`` (unscaled, the distances would come out NaN)."""
    ab = b - a
    with np.errstate(over="ignore", invalid="ignore"):  # told apart just below
        span = float(ab @ ab)
        proj = (pts - a) @ ab
    if not math.isfinite(span) or not np.all(np.isfinite(proj)):
        unit = float(np.abs(np.vstack([pts - a, ab[None]])).max())
        if 1 < unit < math.inf:  # scaled, every offset is at most 1: none overflows
            return _distances(pts / unit, a / unit, b / unit) * unit
    t = np.zeros(len(pts)) if span == 0 else np.clip(proj / span, 0.0, 1.0)
    return np.hypot(*(pts - (a + t[:, None] * ab)).T)


def graph_resolution_m(graph) -> float | None:
    """The ``resolution_m`` a graph records (metres per pixel), or None where it records
    none that is a finite number > 0."""
    res = graph.graph.get("resolution_m")
    ok = isinstance(res, numbers.Real) and not isinstance(res, bool)
    return float(res) if ok and math.isfinite(res) and res > 0 else None


def why_empty(graph) -> str:
    """`` (NOTE)`` with the ``note`` a graph records (a route graph without edges says why
    it has none), or ``""``: for errors about a graph with nothing on it."""
    note = graph.graph.get("note")
    return f" ({note})" if isinstance(note, str) and note else ""


_ROOM_GRAPH = "a room graph (rooms as nodes, doors as edges: save_room_graph, topojax rooms)"


def check_corridor_graph(graph) -> None:
    """A ValueError naming the parameter ``graph`` unless each edge of the multigraph
    ``graph`` is a corridor, with ``path``, ``world`` and ``length_m`` (a topology or
    route graph); a room graph (:func:`topojax.save_room_graph`'s, with its graph
    attribute ``n_rooms``, or one whose edges are doors) is named as one."""
    received = _ROOM_GRAPH if "n_rooms" in graph.graph else None
    for a, b, key, data in graph.edges(keys=True, data=True):
        missing = [name for name in ("path", "world", "length_m") if name not in data]
        edge = f"edge ({a!r}, {b!r}, {key!r})"
        if received is None and missing:
            lacks = f"a graph whose {edge} has no {missing[0]!r} attribute"
            received = _ROOM_GRAPH if "doors" in data else lacks
        elif received is None and graphml_text(data["path"]):
            received = f"a graph whose {edge} has a 'path'{graphml_text(data['path'])}"
    if received is not None:
        raise ValueError(
            "graph: expected a topology graph (build_graph, topojax graph) or a route graph "
            "(route_graph, topojax route-graph), whose edges carry the corridors' 'path', "
            f"'world' and 'length_m'; received {received}"
        )
