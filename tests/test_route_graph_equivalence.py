"""The faster forms of route-graph passes give exactly what the plain forms give."""

from __future__ import annotations

import numpy as np
import pytest

from topojax.maps.occupancy import OccupancyMap
from topojax.routegraph.build import RouteGraphConfig
from topojax.routegraph.feasible import feasible_space

RES = 0.05


def _map(free: np.ndarray) -> OccupancyMap:
    free = np.asarray(free, bool)
    return OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=RES)


def _plain_window(occ: OccupancyMap, cfg: RouteGraphConfig):
    """The window of the kept regions cut from the whole map's feasible space."""
    import topojax.routegraph.build as build

    space = feasible_space(occ, cfg.robot_radius_m)
    kept = build._kept_regions(space, cfg.min_region_m2)
    origin, size = build._window(kept, margin=2)
    crop = build._crop
    return origin, [
        crop(kept, origin, size),
        crop(space.feasible, origin, size),
        crop(space.free, origin, size),
        crop(space.clearance_m, origin, size),
    ]


def _plans() -> dict[str, np.ndarray]:
    plans = {}
    free = np.zeros((300, 260), bool)
    free[60:200, 90:230] = True  # a room off the map's corner
    free[100:150, 150:160] = False  # a pillar
    free[230:250, 20:40] = True  # a region too small to keep
    plans["inner"] = free
    edge = np.zeros((200, 180), bool)
    edge[0:120, 40:180] = True  # free to the map's border: the border is a wall
    edge[150:199, 0:30] = True
    plans["border"] = edge
    tiny = np.zeros((120, 100), bool)
    tiny[50:60, 40:52] = True  # no region the robot fits: the window is the whole map
    plans["none kept"] = tiny
    plans["no free pixel"] = np.zeros((40, 30), bool)
    return plans


@pytest.mark.parametrize("name", list(_plans()))
@pytest.mark.parametrize("radius", [0.2, 0.3])
def test_window_from_the_free_pixels_box_is_the_whole_map_s(name, radius):
    """The feasible space found in the bounding box of the known-free pixels gives the
    window, its feasible pixels, free pixels and clearance that the whole map's gives."""
    import topojax.routegraph.build as build

    occ = _map(_plans()[name])
    cfg = RouteGraphConfig(robot_radius_m=radius)
    origin, expected = _plain_window(occ, cfg)
    win, free, clearance = build._windowed_space(occ, cfg)
    assert win.origin == origin
    assert win.map_shape == occ.free.shape
    for got, want in zip([win.feasible, win.any_feasible, free, clearance], expected, strict=True):
        assert got.dtype == want.dtype
        assert np.array_equal(got, want)


def test_raster_grown_by_what_was_made_since_is_the_graph_s_raster():
    """The coverage rounds add to the previous raster the pixels of the vertices and
    edges made since (an edge split into pieces keeps its pixels; a vertex made and left
    without edges is dead): the sum is the raster drawn from the whole graph."""
    from topojax.graph.work import WorkGraph, line_pixels
    from topojax.routegraph._cover import _grown_raster, graph_raster
    from topojax.routegraph._joins import attach_points

    shape = (40, 40)
    work = WorkGraph()
    for p in [(2, 2), (2, 30), (30, 30)]:
        work.add_vertex(p)
    work.add_edge(0, 1, line_pixels((2, 2), (2, 30)))
    work.add_edge(1, 2, line_pixels((2, 30), (30, 30)))
    raster, seen = _grown_raster(work, shape, (0, 0))
    assert np.array_equal(raster, graph_raster(work, shape))
    # a round: an edge split, a new vertex joined to the split, one left dead
    (mid,) = attach_points(work, [(2, 16)], shape)
    far = work.add_vertex((20, 10))
    work.add_edge(mid, far, line_pixels((2, 16), (20, 10)))
    work.dead.add(work.add_vertex((35, 5)))
    added, seen = _grown_raster(work, shape, seen)
    assert np.array_equal(raster | added, graph_raster(work, shape))
    assert not added[35, 5] and added[20, 10]
    # nothing made since: nothing added
    added, _ = _grown_raster(work, shape, seen)
    assert not added.any()


def test_feasible_pixels_round_corners_are_counted_as_by_the_box():
    """The corner test's count of feasible pixels in the box round each point is the
    box's sum, the part past the image's edge counting none (points on and past the edge
    among them)."""
    from topojax.routegraph._corners import _WINDOW, _feasible_around

    rng = np.random.default_rng(5)
    feasible = rng.random((30, 40)) < 0.6
    rows = rng.integers(-5, 35, 200)
    cols = rng.integers(-5, 45, 200)
    padded = np.zeros((30 + 2 * 50, 40 + 2 * 50), np.int64)
    padded[50:80, 50:90] = feasible
    want = [
        padded[r + 50 - _WINDOW : r + 51 + _WINDOW, c + 50 - _WINDOW : c + 51 + _WINDOW].sum()
        for r, c in zip(rows.tolist(), cols.tolist(), strict=True)
    ]
    assert _feasible_around(feasible, rows, cols).tolist() == want
