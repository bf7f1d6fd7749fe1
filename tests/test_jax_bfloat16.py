"""JAX's bfloat16 arrays, where the library takes real numbers: scan ranges, points,
float grids."""

from __future__ import annotations

import math

import numpy as np
import pytest

import topojax as tj

jnp = pytest.importorskip("jax.numpy")


def _bf16(values):
    return jnp.asarray(np.asarray(values, np.float32), jnp.bfloat16)


def test_a_scan_keeps_bfloat16_ranges_as_float32():
    scan = tj.Scan(
        ranges=_bf16([1.0, 2.5, math.inf, math.nan]),
        angle_min=0.0,
        angle_increment=0.1,
        range_min=0.0,
        range_max=10.0,
        pose=(0.0, 0.0, 0.0),
    )
    assert scan.ranges.dtype == np.float32
    assert scan.ranges[:3].tolist() == [1.0, 2.5, math.inf] and math.isnan(scan.ranges[3])


def test_from_array_reads_a_bfloat16_grid_as_probabilities():
    grid = [[0.0, 1.0, 0.5], [0.0, 0.0, 1.0]]
    m = tj.OccupancyMap.from_array(_bf16(grid))
    expected = tj.OccupancyMap.from_array(np.array(grid))
    for name in ("occupied", "free", "unknown"):
        assert np.array_equal(getattr(m, name), getattr(expected, name))
    with pytest.raises(ValueError, match="array"):
        tj.OccupancyMap.from_array(_bf16([[0.0, 2.0], [0.0, 0.0]]))


def test_a_mapper_and_a_map_take_bfloat16_points():
    points = [[1.0, 0.0], [1.0, 0.5]]
    report = tj.IncrementalMapper().add_points(_bf16(points), origin_xy=(0.0, 0.0))
    expected = tj.IncrementalMapper().add_points(np.array(points), origin_xy=(0.0, 0.0))
    assert (report.n_valid, report.n_new_obstacles) == (expected.n_valid, expected.n_new_obstacles)
    assert report.n_valid == 2
    m = tj.OccupancyMap.from_array(np.zeros((3, 3)))
    x, y = m.pixel_to_world(_bf16([1.0]), _bf16([2.0]))
    expected_x, expected_y = m.pixel_to_world(np.array([1.0]), np.array([2.0]))
    assert np.array_equal(x, expected_x) and np.array_equal(y, expected_y)
