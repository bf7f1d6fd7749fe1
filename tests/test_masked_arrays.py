"""NumPy masked arrays at the public entry points: ``np.asarray`` drops the mask and keeps
the values under it, so each entry point gives a masked entry its meaning (a range or
point with no reading, a map cell unknown) or refuses it naming the argument."""

from __future__ import annotations

import math

import numpy as np
import pytest

import topojax as tj
from topojax.scans import scans_from_arrays

GEOMETRY = {"angle_min": -0.5, "angle_increment": 0.01, "range_max": 10.0}


def _ranges():
    return np.ma.masked_array(np.full(100, 2.0), mask=np.arange(100) < 40)


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.float16, np.uint16])
def test_masked_ranges_are_no_return(dtype):
    ranges = _ranges().astype(dtype)
    for scan in (
        tj.Scan.from_arrays(ranges, (0.0, 0.0, 0.0), **GEOMETRY),
        tj.Scan(ranges, -0.5, 0.01, 0.0, 10.0, (0.0, 0.0, 0.0)),
        next(scans_from_arrays(ranges[None], np.zeros((1, 3)), **GEOMETRY)),
    ):
        assert type(scan.ranges) is np.ndarray
        assert scan.ranges.dtype == (np.float64 if dtype == np.uint16 else dtype)
        assert int(scan.valid_mask().sum()) == 60
        assert np.isnan(scan.ranges[:40]).all()
    assert not ranges.mask[40:].any() and ranges.mask[:40].all()  # the argument unchanged


def test_masked_ranges_are_dropped_and_counted_by_the_mapper():
    mapper = tj.IncrementalMapper(skeleton_every=0, graph_every=0)
    report = mapper.add_scan(tj.Scan.from_arrays(_ranges(), (0.0, 0.0, 0.0), **GEOMETRY))
    assert (report.n_beams, report.n_valid, report.n_dropped) == (100, 60, 40)


def test_masked_poses_or_timestamps_of_a_scan_matrix_are_refused():
    ranges = np.full((2, 5), 2.0)
    poses = np.ma.masked_array(np.zeros((2, 3)), mask=[[0, 0, 0], [0, 1, 0]])
    with pytest.raises(TypeError, match=r"^poses: expected an array without masked entries"):
        scans_from_arrays(ranges, poses, **GEOMETRY)
    stamps = np.ma.masked_array([0.0, 1.0], mask=[0, 1])
    with pytest.raises(TypeError, match=r"^timestamps: expected an array without masked"):
        scans_from_arrays(ranges, np.zeros((2, 3)), timestamps=stamps, **GEOMETRY)
    with pytest.raises(TypeError, match=r"^pose: expected a sequence of 3 finite numbers"):
        tj.Scan.from_arrays(np.ones(5), poses[1], **GEOMETRY)


def test_masked_points_are_dropped_and_counted():
    mapper = tj.IncrementalMapper(skeleton_every=0, graph_every=0)
    points = np.ma.masked_array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]], mask=[[0, 0], [0, 1], [0, 0]])
    report = mapper.add_points(points, origin_xy=(0.0, 0.0))
    assert (report.n_beams, report.n_valid, report.n_dropped) == (3, 2, 1)
    plain = tj.IncrementalMapper(skeleton_every=0, graph_every=0)
    plain.add_points([[1.0, 1.0], [3.0, 3.0]], origin_xy=(0.0, 0.0))
    assert np.array_equal(mapper.occupancy.occupied, plain.occupancy.occupied)


def test_a_masked_origin_or_query_is_refused_naming_it():
    mapper = tj.IncrementalMapper(skeleton_every=0, graph_every=0)
    origin = np.ma.masked_array([0.0, 5.0], mask=[False, True])
    with pytest.raises(TypeError, match=r"^origin_xy: expected two finite numbers"):
        mapper.add_points([[1.0, 1.0]], origin_xy=origin)
    assert mapper.n_scans == 0
    with pytest.raises(TypeError, match=r"^x: expected an array without masked entries"):
        mapper.world_to_pixel(origin[::-1], [0.0, 0.0])


def _classes(occupancy):
    return [int(m.sum()) for m in (occupancy.occupied, occupancy.free, occupancy.unknown)]


@pytest.mark.parametrize(
    ("values", "under_mask"),
    [
        (np.array([[100, 100], [0, 0], [0, -1]], np.int8), 100),  # OccupancyGrid
        (np.array([[1.0, 1.0], [0.0, 0.0], [0.0, 0.5]]), math.nan),  # probabilities
        (np.array([[True, True], [False, False], [False, False]]), True),  # obstacle mask
    ],
)
def test_masked_cells_of_a_grid_are_unknown(values, under_mask):
    grid = np.ma.masked_array(values, mask=np.zeros(values.shape, bool))
    grid.data[1, 0] = under_mask  # the value under the mask is not read (NaN included)
    grid[1, 0] = np.ma.masked
    occupancy = tj.OccupancyMap.from_array(grid)
    unknown = 2 if values.dtype == np.int8 or values.dtype == np.float64 else 1
    assert _classes(occupancy) == [2, 6 - 2 - unknown, unknown]
    assert occupancy.unknown[1, 0]


def test_a_colour_pixel_with_a_masked_channel_is_unknown():
    image = np.ma.masked_array(np.full((2, 3, 3), 254, np.uint8), mask=False)
    image[0, 0] = 0  # black: occupied
    image[1, 2, 1] = np.ma.masked
    assert _classes(tj.OccupancyMap.from_array(image)) == [1, 4, 1]


def test_build_graph_of_a_masked_grid_reads_its_masked_cells_as_unknown():
    grid = np.zeros((40, 40), np.int8)
    grid[[0, -1], :] = 100
    grid[:, [0, -1]] = 100
    masked = np.ma.masked_array(grid, mask=False)
    masked[10:30, 10:30] = np.ma.masked
    result = tj.build_graph(masked)
    assert int(result.map.unknown.sum()) == 400 and result.map.unknown[10:30, 10:30].all()


def test_masks_and_tiled_arrays_with_masked_entries_are_refused():
    mask = np.zeros((4, 4), bool)
    masked = np.ma.masked_array(mask, mask=np.eye(4, dtype=bool))
    with pytest.raises(TypeError, match=r"^OccupancyMap.occupied: expected an array without"):
        tj.OccupancyMap(occupied=masked, free=~mask, unknown=mask)
    occupancy = tj.OccupancyMap(occupied=np.ma.masked_array(mask), free=~mask, unknown=mask)
    assert type(occupancy.occupied) is np.ndarray  # nothing masked: its data
    with pytest.raises(TypeError, match=r"^array: expected an array without masked entries"):
        tj.TiledMap.from_array(masked)


def test_an_obstacle_mask_with_masked_cells_is_refused_naming_it():
    # a masked cell of an obstacle mask is neither an obstacle nor free: no meaning
    mask = np.zeros((8, 8), bool)
    mask[0] = True
    masked = np.ma.masked_array(mask, mask=np.eye(8, dtype=bool))
    for call, name in (
        (tj.distance_map, "obstacles"),
        (tj.ridge_map, "obstacles"),
        (tj.thin, "ridge"),
        (tj.build_graph_tiled, "source"),
    ):
        with pytest.raises(TypeError, match=rf"^{name}: expected an array without masked"):
            call(masked)
    assert tj.distance_map(np.ma.masked_array(mask)).shape == (8, 8)  # nothing masked


def test_a_skeleton_or_clearance_with_masked_cells_is_refused_naming_it():
    """A masked skeleton pixel is neither on nor off, and a masked clearance has no value:
    skeleton_to_graph refuses them, as thin and remove_t_centres do, instead of building
    the graph of the values under the mask."""
    skeleton = np.zeros((5, 7), bool)
    skeleton[2, 1:6] = True
    hidden = np.ma.masked_array(skeleton, mask=skeleton)
    for call in (tj.skeleton_to_graph, tj.remove_t_centres):
        with pytest.raises(TypeError, match=r"^skeleton: expected an array without masked"):
            call(hidden)
    clearance = np.ma.masked_array(np.ones(skeleton.shape), mask=skeleton)
    with pytest.raises(TypeError, match=r"^clearance_px: expected an array without masked"):
        tj.skeleton_to_graph(skeleton, clearance_px=clearance)
    with pytest.raises(TypeError, match=r"^clearance_px: expected an array without masked"):
        tj.skeleton_to_graph(skeleton, clearance_px=lambda flat: clearance.ravel()[flat])
    whole = tj.skeleton_to_graph(np.ma.masked_array(skeleton), clearance_px=np.ma.ones((5, 7)))
    assert whole.number_of_edges() == 1  # nothing masked: the arrays' data
    assert next(iter(whole.edges(data="min_clearance_m")))[2] == 1.0
