"""The incremental mapper's guard rails for a robot's bad moments: wrong input types
and hand-edited or corrupted saved states."""

from __future__ import annotations

import numpy as np
import pytest

from topojax.incremental import IncrementalMapper

KW = {"skeleton_every": 0, "graph_every": 0}
EXPECTED = r"^points_xy: expected an \(N, 2\) array of \(x, y\) in metres"


@pytest.mark.parametrize(
    ("points", "received"),
    [
        ([["a", "b"], ["c", "d"]], "list of dtype <U1"),
        ({"x": 1.0, "y": 2.0}, "dict of dtype object"),
        (None, "NoneType of dtype object"),  # NumPy would take it as NaN: a dropped point
        (np.array([[1.0 + 2.0j, 0.0]]), "ndarray of dtype complex128"),  # or the real part
        ([[1.0, None]], "list of dtype object"),
        (b"12", "bytes of dtype"),
        (np.ones((2, 2), bool), "ndarray of dtype bool .a mask\\? for a finished map use add_map"),
        ([[1.0, 2.0], [3.0]], "list that makes no array .rows of different lengths"),
    ],
)
def test_add_points_of_the_wrong_type_is_a_type_error(points, received):
    mapper = IncrementalMapper(**KW)
    with pytest.raises(TypeError, match=EXPECTED + ".*received " + received):
        mapper.add_points(points)
    assert mapper.n_scans == 0 and mapper.n_tiles == 0


@pytest.mark.parametrize(
    ("points", "shape"),
    [(np.ones((4, 3)), r"\(4, 3\)"), (np.ones(4), r"\(4,\)"), (np.ones((1, 2, 2)), r"\(1, 2, 2\)")],
)
def test_add_points_of_another_shape_is_a_value_error(points, shape):
    mapper = IncrementalMapper(**KW)
    with pytest.raises(ValueError, match=EXPECTED + ", received ndarray of shape " + shape):
        mapper.add_points(points)
    assert mapper.n_scans == 0


def test_add_points_of_an_empty_list_is_a_frame_without_points():
    """A depth camera that saw nothing gives ``[]``: a scan without valid readings, as
    ``np.zeros((0, 2))`` is, not an error that stops the robot's callback."""
    mapper = IncrementalMapper(**KW)
    report = mapper.add_points([], origin_xy=(0.0, 0.0))
    assert (report.n_beams, report.n_valid, mapper.n_scans, mapper.n_tiles) == (0, 0, 1, 0)
