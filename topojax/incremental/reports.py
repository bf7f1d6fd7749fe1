"""What the mapper reports: :class:`GraphUpdate`, :class:`ScanReport`, the paper's vertex
error metrics and timing statistics of a replay.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import networkx as nx
import numpy as np

from .._validate import finite_numbers, finite_pair, nx_graph, real_number

#: Longest id tuple a report's repr shows whole; a longer one shows its ends and count.
_IDS_SHOWN = 6


def ids_repr(ids: tuple) -> str:
    """``ids`` as a tuple's repr, or its first and last three and their count when longer
    than :data:`_IDS_SHOWN` (a whole map's ids would fill a notebook)."""
    if len(ids) <= _IDS_SHOWN:
        return repr(ids)
    ends = [*ids[:3], "...", *ids[-3:]]
    return f"({', '.join(v if v == '...' else repr(v) for v in ends)}; {len(ids)} ids)"


def report_repr(report: object) -> str:
    """The repr of a frozen report dataclass, its tuples of ids shortened by
    :func:`ids_repr`."""
    parts = []
    for f in fields(report):
        value = getattr(report, f.name)
        shown = ids_repr(value) if isinstance(value, tuple) else repr(value)
        parts.append(f"{f.name}={shown}")
    return f"{type(report).__name__}({', '.join(parts)})"


@dataclass(frozen=True, repr=False)
class GraphUpdate:
    """What one graph update changed.

    Vertex ids and edge keys are stable: a vertex keeps its id as long as a vertex exists at
    its pixel; an edge keeps its key as long as its path is unchanged (edges are never
    modified in place: a changed path is a removal plus an addition).

    Attributes
    ----------
    added_vertices, removed_vertices : tuple of int
        Vertex ids.
    changed_vertices : tuple of int
        Vertices that stay but whose kind or set of incident edges changed.
    added_edges, removed_edges : tuple of int
        Edge keys (unique over the whole graph).
    region_px : int
        Pixels in the patched region ``Z`` (changed skeleton pixels dilated by 1).
    time_s : float
        Wall time of the update in seconds.
    """

    added_vertices: tuple[int, ...] = ()
    removed_vertices: tuple[int, ...] = ()
    changed_vertices: tuple[int, ...] = ()
    added_edges: tuple[int, ...] = ()
    removed_edges: tuple[int, ...] = ()
    region_px: int = 0
    time_s: float = 0.0

    def __repr__(self) -> str:
        return report_repr(self)

    @property
    def empty(self) -> bool:
        """True when nothing changed."""
        return not (
            self.added_vertices
            or self.removed_vertices
            or self.changed_vertices
            or self.added_edges
            or self.removed_edges
        )


@dataclass(frozen=True)
class ScanReport:
    """What :meth:`IncrementalMapper.add_scan` (or :meth:`~IncrementalMapper.add_points`)
    did with one scan (or one frame of points).

    Attributes
    ----------
    index : int
        0-based number of the scan in this mapper (empty scans count).
    n_beams : int
        Beams in the scan (points in the frame).
    n_valid : int
        Beams used (hits): finite, ``range_min <= r < range_max`` (and ``< max_range_m``);
        points used: finite (and nearer than ``max_range_m`` to their origin).
    n_dropped : int
        ``n_beams - n_valid``: NaN, inf, non-positive, below ``range_min``, max-range.
    n_new_obstacles : int
        Obstacle pixels hit for the first time.
    loops : tuple of str
        Loops that ran: ``"distance"`` always; ``"splat"`` when this scan filled the
        pending-point buffer (``max_pending_points``) and the distance loop splatted it
        (otherwise pending points are splatted at the start of the skeleton loop, inside
        its time); ``"skeleton"``; ``"graph"``.
    timings_s : dict of str to float
        Wall time per loop in seconds (``"distance"`` includes ``"splat"``).
    n_tiles : int
        Tiles allocated after this scan.
    graph_update : GraphUpdate or None
        Result of the graph loop if it ran.
    rooms_update : RoomsUpdate or None
        Result of the room update if it ran (loop ``"rooms"``).
    """

    index: int
    n_beams: int
    n_valid: int
    n_dropped: int
    n_new_obstacles: int
    loops: tuple[str, ...]
    timings_s: dict[str, float]
    n_tiles: int
    graph_update: GraphUpdate | None = None
    rooms_update: object | None = None


def vertex_error_metrics(
    graph_a: nx.Graph,
    graph_b: nx.Graph,
    *,
    outlier_px: float = 20.0,
    region: tuple[int, int, int, int] | None = None,
) -> dict[str, float | int]:
    """The paper's vertex error of ``graph_a`` against ``graph_b`` (paper §IV).

    For every vertex of ``graph_a`` the Euclidean distance (pixels) to the nearest vertex
    of ``graph_b`` is taken; distances above ``outlier_px`` are outliers.  The paper
    reports the mean over non-outliers, the number of outliers out of all vertices and the
    share of vertices within 1 px (2.28 px, 5 of 251, 63.0 % for its incremental intel
    run).

    Parameters
    ----------
    graph_a, graph_b : networkx graphs
        Nodes need a ``pixel`` attribute ``(row, col)`` in the same pixel frame (e.g.
        :attr:`IncrementalMapper.graph` and ``build_graph(mapper.occupancy).graph``).
    outlier_px : float
        Outlier threshold in pixels (paper: 20).
    region : (row0, row1, col0, col1), optional
        Only vertices with ``row0 <= row < row1`` and ``col0 <= col < col1`` (in both
        graphs) count, like the paper's "inside room region".

    Returns
    -------
    dict
        ``n_vertices`` (vertices of ``graph_a`` considered), ``n_outliers``,
        ``mean_px`` (mean distance of non-outliers; NaN if none), ``share_within_1px``
        (in [0, 1]; NaN without vertices), ``median_px``, ``max_px`` (over all).
    """
    from scipy.spatial import cKDTree

    nx_graph("graph_a", graph_a, undirected=False)
    nx_graph("graph_b", graph_b, undirected=False)
    outlier_px = real_number("outlier_px", outlier_px, allow_inf=True)
    if not outlier_px > 0:  # inf: no outliers
        raise ValueError(f"outlier_px: expected a number > 0, received {outlier_px!r}")
    if region is not None:
        region = finite_numbers("region", region, 4, "(row0, row1, col0, col1) in pixels")
        if not (region[0] < region[1] and region[2] < region[3]):
            raise ValueError(f"region: expected row0 < row1 and col0 < col1, received {region}")

    def pixels(g: nx.Graph, name: str) -> np.ndarray:
        pts = []
        for n, pix in g.nodes(data="pixel"):
            if pix is None:
                raise ValueError(f"{name}: node {n!r} has no 'pixel' attribute (row, col)")
            pts.append(finite_pair(f"{name}: node {n!r}: 'pixel'", pix, "(row, col)"))
        arr = np.asarray(pts, np.float64).reshape(-1, 2)
        if region is not None:
            r0, r1, c0, c1 = region
            keep = (arr[:, 0] >= r0) & (arr[:, 0] < r1) & (arr[:, 1] >= c0) & (arr[:, 1] < c1)
            arr = arr[keep]
        return arr

    a = pixels(graph_a, "graph_a")
    b = pixels(graph_b, "graph_b")
    if a.shape[0] == 0:
        nan = float("nan")
        return {
            "n_vertices": 0,
            "n_outliers": 0,
            "mean_px": nan,
            "share_within_1px": nan,
            "median_px": nan,
            "max_px": nan,
        }
    if b.shape[0] == 0:
        d = np.full(a.shape[0], np.inf)
    else:
        d, _ = cKDTree(b).query(a)
    inlier = d <= outlier_px
    return {
        "n_vertices": int(a.shape[0]),
        "n_outliers": int((~inlier).sum()),
        "mean_px": float(d[inlier].mean()) if inlier.any() else float("nan"),
        "share_within_1px": float((d <= 1.0).mean()),
        "median_px": float(np.median(d)),
        "max_px": float(d.max()),
    }


def timing_summary(reports: list[ScanReport]) -> dict[str, dict[str, float]]:
    """Per-loop timing statistics of a replay.

    Parameters
    ----------
    reports : list of ScanReport

    Returns
    -------
    dict
        For each loop (``distance``, ``splat``, ``skeleton``, ``graph``) and for
        ``add_scan`` (the sum of the loops of one call): ``count`` (calls that ran it),
        ``mean_ms``, ``p50_ms``, ``p99_ms``, ``max_ms`` (over those calls), ``total_s`` and
        ``per_scan_ms`` (total divided by all scans: the amortised cost).
    """
    n = max(len(reports), 1)
    series: dict[str, list[float]] = {}
    for r in reports:
        for k, v in r.timings_s.items():
            series.setdefault(k, []).append(v)
        series.setdefault("add_scan", []).append(
            sum(v for k, v in r.timings_s.items() if k != "splat")
        )
    out = {}
    for k, v in series.items():
        a = np.asarray(v) * 1e3
        out[k] = {
            "count": len(v),
            "mean_ms": float(a.mean()),
            "p50_ms": float(np.percentile(a, 50)),
            "p99_ms": float(np.percentile(a, 99)),
            "max_ms": float(a.max()),
            "total_s": float(a.sum() / 1e3),
            "per_scan_ms": float(a.sum() / n),
        }
    return out
