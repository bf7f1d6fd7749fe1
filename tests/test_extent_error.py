"""The mapper's refusals (:class:`ExtentError`) say in fields what their messages say in
words: the bound met, and what was refused as the message names it first (with the
scan's index); each place that refuses sets them, and they survive pickling."""

from __future__ import annotations

import pickle
import re

import numpy as np
import pytest

from topojax.config import DistanceConfig
from topojax.incremental import ExtentError, IncrementalMapper
from topojax.maps import OccupancyMap
from topojax.scans import Scan

SMALL_KW = {
    "resolution_m": 0.1,
    "distance": DistanceConfig(sigma_px=4.0, half_width_px=10),
    "tile_px": 16,
    "block_px": 8,
    "skeleton_every": 0,
    "graph_every": 0,
}
TILE_BYTES = IncrementalMapper(**SMALL_KW).tiles.tile_nbytes
#: How each bound is named in the messages.
WORDS = {
    "max_extent_m": "beyond max_extent_m=",
    "max_grid_cells": "(max_grid_cells)",
    "max_tile_bytes": "beyond max_tile_bytes=",
    "max_abs_pixel": "beyond 1073741824 px",
}


def _scan(ranges, pose=(0.0, 0.0, 0.0)) -> Scan:
    """Beams 0.3 rad apart, closer where that would sweep more than one turn."""
    r = np.asarray(ranges, float)
    inc = min(0.3, 2 * np.pi / r.size)
    return Scan.from_arrays(r, pose, angle_min=0, angle_increment=inc)


def _map(shape, origin, *, free: bool = False) -> OccupancyMap:
    occupied = np.zeros(shape, bool)
    if not free:
        occupied[::50, ::5] = True
    return OccupancyMap(
        occupied=occupied,
        free=~occupied if free else np.zeros_like(occupied),
        unknown=occupied if free else ~occupied,
        resolution_m=0.1,
        origin=origin,
    )


def _mapper(**kw) -> IncrementalMapper:
    """A mapper that has mapped one scan near the origin."""
    mapper = IncrementalMapper(**SMALL_KW, **kw)
    mapper.add_scan(_scan(np.full(5, 2.0)))
    return mapper


far_points = np.stack([np.linspace(-60, 60, 200), np.full(200, 30.0)], 1)
#: (case, mapper settings, call, bound, subject, scan): every place the mapper refuses.
CASES = [
    ("scan pose", {"max_extent_m": 20.0}, lambda m: m.add_scan(_scan(np.ones(3), (30, 0, 0))),
     "max_extent_m", "scan 1", 1),
    ("scan readings", {}, lambda m: m.add_scan(_scan(np.full(5, 1e30))),
     "max_abs_pixel", "scan 1", 1),
    ("scan sensor", {}, lambda m: m.add_scan(_scan(np.full(5, np.nan), (1e12, 0, 0))),
     "max_abs_pixel", "scan 1", 1),
    ("scan tiles", {"max_grid_cells": 50}, lambda m: m.add_scan(_scan(np.full(5, 50.0))),
     "max_grid_cells", "scan 1", 1),
    ("scan memory", {"max_tile_bytes": 60 * TILE_BYTES},
     lambda m: m.add_scan(_scan(np.full(40, 80.0))), "max_tile_bytes", "scan 1", 1),
    ("points", {"max_extent_m": 20.0}, lambda m: m.add_points(np.array([[40.0, 0.0]])),
     "max_extent_m", "points_xy: the points (scan 1)", 1),
    ("points far", {}, lambda m: m.add_points(np.array([[1e12, 0.0]])),
     "max_abs_pixel", "points_xy: the points (scan 1)", 1),
    ("points origin", {}, lambda m: m.add_points(np.ones((1, 2)), origin_xy=(1e12, 0.0)),
     "max_abs_pixel", "origin_xy: the points (scan 1)", 1),
    ("points origin extent", {"max_extent_m": 20.0},
     lambda m: m.add_points(np.ones((1, 2)), origin_xy=(40.0, 0.0)),
     "max_extent_m", "origin_xy: the points (scan 1)", 1),
    ("points origin tiles", {"max_grid_cells": 50},
     lambda m: m.add_points(np.ones((1, 2)), origin_xy=(50.0, 0.0)),
     "max_grid_cells", "origin_xy: the points (scan 1)", 1),
    ("points origin memory", {"max_tile_bytes": 60 * TILE_BYTES},
     lambda m: m.add_points(np.ones((1, 2)), origin_xy=(300.0, 0.0)),
     "max_tile_bytes", "origin_xy: the points (scan 1)", 1),
    ("points memory", {"max_tile_bytes": 60 * TILE_BYTES}, lambda m: m.add_points(far_points),
     "max_tile_bytes", "points_xy: the points (scan 1)", 1),
    ("map", {"max_extent_m": 20.0}, lambda m: m.add_map(_map((400, 20), (0.0, 0.0, 0.0))),
     "max_extent_m", "occupancy: the map at (0.0, 0.0, 0.0)", None),
    ("map far", {}, lambda m: m.add_map(_map((20, 20), (5e8, 0.0, 0.0))),
     "max_abs_pixel", "occupancy: the map at (500000000.0, 0.0, 0.0)", None),
    ("map tiles", {"max_grid_cells": 50}, lambda m: m.add_map(_map((400, 20), (0.0, 0.0, 0.0))),
     "max_grid_cells", "occupancy: the map at (0.0, 0.0, 0.0)", None),
    ("map memory", {"max_tile_bytes": 60 * TILE_BYTES},
     lambda m: m.add_map(_map((600, 600), (-30.0, -30.0, 0.0), free=True)),
     "max_tile_bytes", "occupancy: the map at (-30.0, -30.0, 0.0)", None),
]  # fmt: skip


@pytest.mark.parametrize(
    ("settings", "call", "bound", "subject", "scan"),
    [case[1:] for case in CASES],
    ids=[case[0] for case in CASES],
)
def test_each_refusal_says_the_bound_met_and_what_was_refused(settings, call, bound, subject, scan):
    mapper = _mapper(**settings)
    with pytest.raises(ExtentError) as info:
        call(mapper)
    exc = info.value
    assert isinstance(exc, ValueError)
    assert (exc.bound, exc.subject, exc.scan) == (bound, subject, scan)
    message = str(exc)
    assert message.startswith(subject) and WORDS[bound] in message  # the words agree
    assert mapper.n_scans == 1  # nothing was added
    # renamed: the message with the subject alone replaced
    assert exc.renamed("it") == "it" + message[len(subject) :]
    # through a process boundary (a pickle) with its fields
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is ExtentError and str(back) == message
    assert (back.bound, back.subject, back.scan) == (bound, subject, scan)


def test_an_extent_error_is_made_with_a_known_bound_and_its_message_s_subject():
    exc = ExtentError("scan 3 (t): too far", bound="max_extent_m", subject="scan 3", scan=3)
    assert exc.renamed("scan 9 of the log") == "scan 9 of the log (t): too far"
    with pytest.raises(ValueError, match=r"^bound: expected one of .*received 'far'"):
        ExtentError("scan 3: too far", bound="far")
    with pytest.raises(ValueError, match=r"^subject: expected the start of the message"):
        ExtentError("scan 3: too far", bound="max_extent_m", subject="scan 4")


def test_a_map_s_refusal_while_adding_it_is_an_extent_error(monkeypatch):
    """The checks made as the map's pixels go in (after those of the whole map, which
    they repeat) refuse with an :class:`ExtentError` too, which leaves the mapper whole;
    here the whole map's tile count is made to pass so that they meet the budget."""
    from topojax.incremental import _rays

    monkeypatch.setattr(_rays, "_map_tiles", lambda *args: 0)
    mapper = _mapper(max_tile_bytes=60 * TILE_BYTES)
    with pytest.raises(ExtentError) as info:
        mapper.add_map(_map((600, 600), (-30.0, -30.0, 0.0)))
    assert (info.value.bound, info.value.subject, info.value.scan) == (
        "max_tile_bytes",
        "occupancy: the map",
        None,
    )
    mapper.add_scan(_scan(np.full(5, 2.0)))  # not left half updated


def test_a_tile_budget_under_a_mib_is_said_in_bytes():
    # the need of a refusal under 1 MiB in bytes, not "0 MiB in all"
    mapper = IncrementalMapper(**SMALL_KW, max_tile_bytes=60 * TILE_BYTES)
    with pytest.raises(ExtentError) as refused:
        mapper.add_scan(_scan(np.full(40, 80.0)))
    assert 60 * TILE_BYTES < 2**20
    assert re.search(r"\d[\d,]* bytes in all, beyond max_tile_bytes=", str(refused.value))
    assert "MiB" not in str(refused.value)


@pytest.mark.parametrize("first", [False, True])
def test_points_refused_with_their_origin_name_whichever_lies_far_out(first):
    """Points and their origin apart by more than max_extent_m: the one farther from the
    mapped area (from (0, 0) for the first points) is named, the other not blamed."""
    near, far = (1.0, 1.0), (1e4, 0.0)
    for points, origin, subject in ((near, far, "origin_xy"), (far, near, "points_xy")):
        mapper = IncrementalMapper(**SMALL_KW) if first else _mapper()
        with pytest.raises(ExtentError, match=rf"^{subject}: the points \(scan") as info:
            mapper.add_points(np.array([points]), origin_xy=origin)
        assert info.value.bound == "max_extent_m" and info.value.subject.startswith(subject)
        assert mapper.n_scans == (0 if first else 1)  # nothing was added


@pytest.mark.parametrize("ranges", [[1e6, 2.0], [2.0, 2500.0]])
@pytest.mark.parametrize("first", [True, False])
def test_a_scan_whose_readings_reach_too_far_is_told_so(ranges, first):
    """A scan at the origin refused for a reading far off points at the readings (the
    scan's range_max, the mapper's max_range_m): not, as the first scan of a mapper
    whose tiles and distance window fit ``max_extent_m`` many times over, at the tile
    size or sigma, nor, as a later one, at its pose."""
    mapper = IncrementalMapper(**SMALL_KW)
    if not first:
        mapper.add_scan(_scan([1.0, 2.0]))
    box = mapper.pixel_bbox
    with pytest.raises(ExtentError, match="max_extent_m") as info:
        mapper.add_scan(_scan(ranges))
    message = str(info.value)
    assert "range_max" in message and "max_range_m" in message, message
    assert "tile_px" not in message and "sigma" not in message, message
    assert "check the pose" not in message, message
    assert mapper.pixel_bbox == box and mapper.n_scans == (0 if first else 1)


def test_a_map_wider_than_the_limit_is_told_so():
    occupied = np.zeros((4, 30), bool)
    occupied[:, [0, -1]] = True
    occ = OccupancyMap(
        occupied=occupied,
        free=~occupied,
        unknown=np.zeros_like(occupied),
        resolution_m=0.1,
    )
    mapper = IncrementalMapper(**{**SMALL_KW, "max_extent_m": 2.5})
    with pytest.raises(ExtentError, match=r"the map alone spans [\d.]+ m: make the mapper with a"):
        mapper.add_map(occ)


def test_a_first_scan_refused_for_tiles_wider_than_the_limit_says_so():
    """Where one pixel's tiles and distance window alone are wider than
    ``max_extent_m``, every scan is refused: the message says to shrink them."""
    mapper = IncrementalMapper(**{**SMALL_KW, "max_extent_m": 3.0})
    with pytest.raises(ExtentError, match="smaller tile_px or sigma"):
        mapper.add_scan(_scan([1.0, 1.0]))
