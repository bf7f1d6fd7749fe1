"""Routes on graphs a user edited by hand (topojax.routing): re-weighted, relabelled or
cut down graphs route correctly or are refused naming what is wrong."""

from __future__ import annotations

import numpy as np
import pytest

from topojax._validate import MAX_TOTAL_LENGTH_M
from topojax.graph import skeleton_to_graph
from topojax.routing import RoutePlanner, plan_route

# A tee: vertices 0 (0, 0), 1 (0, 4), 2 (0, 8) and 3 (2, 4); edges (0, 1), (1, 2) of four
# pixels' steps and (1, 3) of two.
TEE = ["#########", "....#....", "....#...."]


def tee(resolution_m: float = 1.0):
    skeleton = np.array([[ch == "#" for ch in row] for row in TEE])
    return skeleton_to_graph(skeleton, resolution_m=resolution_m)


def test_a_huge_length_m_on_a_short_edge_is_charged_in_proportion_not_overflowed():
    """A length_m far beyond the path's steps (an edge a user made costly) scales the
    steps by a factor past float range on a short path: partial traversals still cost
    their share of it, and routes elsewhere are unchanged."""
    g = tee(resolution_m=0.01)
    g.edges[0, 1, 0]["length_m"] = 1e307  # 1e307 / 0.04 m of steps overflows
    planner = RoutePlanner(g)
    half = planner.route((0, 1), (0, 3), frame="pixel")
    across = planner.route((0, 0), (2, 4), frame="pixel")
    beside = planner.route((0, 6), (2, 4), frame="pixel")
    assert half.length_m == pytest.approx(0.5e307)
    assert half.edges == ((0, 1, 0),)
    assert across.length_m == pytest.approx(1e307)
    assert across.edges == ((0, 1, 0), (1, 3, 0))
    assert beside.length_m == pytest.approx(0.04)


def test_lengths_whose_sum_would_overflow_are_refused_naming_length_m():
    """Two edges of 1e308 m make a route of inf m: the planner refuses the graph, rather
    than report the connected start and goal as in different components."""
    g = tee()
    g.edges[0, 1, 0]["length_m"] = 1e308
    g.edges[1, 3, 0]["length_m"] = 1e308
    with pytest.raises(
        ValueError, match=r"^graph: the edges' 'length_m': expected lengths that add up to at most"
    ):
        plan_route(g, (0, 0), (2, 4), frame="pixel")
    g.edges[1, 3, 0]["length_m"] = 2.0
    g.edges[0, 1, 0]["length_m"] = MAX_TOTAL_LENGTH_M * 0.9  # the most, less the others
    route = plan_route(g, (0, 0), (2, 4), frame="pixel")
    assert route.length_m == pytest.approx(MAX_TOTAL_LENGTH_M * 0.9)
    assert np.isfinite(route.length_m)


def test_a_vertex_without_its_pixel_is_named_as_the_reason_its_edge_is_refused():
    """A vertex whose 'pixel' and 'pixels' a user dropped from a file: the error that its
    edge's path ends elsewhere names the vertex and the missing attribute."""
    g = tee()
    del g.nodes[3]["pixel"]  # its 'pixels' (a cluster's, here of one pixel) still place it
    assert plan_route(g, (0, 0), (2, 4), frame="pixel").length_m == pytest.approx(6.0)
    del g.nodes[3]["pixels"]
    with pytest.raises(
        ValueError,
        match=r"^graph: the path of edge \(1, 3, 0\) runs from \(0, 4\) to \(2, 4\), which are "
        r"not the pixels of its vertices \(vertex 3 has no 'pixel' or 'pixels' attribute\)$",
    ):
        RoutePlanner(g)
