"""The masks an OccupancyMap keeps: no caller can change them, and the library's own
maps keep theirs without a copy."""

from __future__ import annotations

import copy
import dataclasses
import pickle
import tracemalloc

import numpy as np
import pytest

import topojax as tj
from topojax.maps import OccupancyMap


def _arrays():
    occupied = np.zeros((4, 5), bool)
    occupied[0] = True
    return occupied, ~occupied, np.zeros((4, 5), bool)


def _read_only_views(arrays):
    views = [a.view() for a in arrays]
    for v in views:
        v.setflags(write=False)
    return views, arrays


def _frozen_with_writeable_views(arrays):
    views = [a[:] for a in arrays]
    for a in arrays:
        a.setflags(write=False)
    return arrays, views


@pytest.mark.parametrize("given", [_read_only_views, _frozen_with_writeable_views])
def test_a_caller_cannot_change_the_map_through_an_array_it_holds(given):
    masks, writeable = given(_arrays())
    m = OccupancyMap(occupied=masks[0], free=masks[1], unknown=masks[2])
    writeable[0][1, 1] = True  # would make pixel (1, 1) both occupied and free
    writeable[1][0, 0] = True
    assert not m.occupied[1, 1] and m.free[1, 1] and not m.free[0, 0]
    assert int(m.occupied.sum()) == 5 and int(m.free.sum()) == 15
    for mask in (m.occupied, m.free, m.unknown):
        assert not mask.flags.writeable
        assert not any(np.shares_memory(mask, w) for w in writeable)


def test_masks_of_a_map_and_read_only_crops_of_them_are_kept_without_a_copy():
    m = OccupancyMap.from_array(np.array([[0, 254, 205], [254, 254, 0]], np.uint8))
    moved = dataclasses.replace(m, origin=(1.0, 2.0, 0.0))
    assert moved.occupied is m.occupied and moved.free is m.free
    crop = OccupancyMap(occupied=m.occupied[:, :2], free=m.free[:, :2], unknown=m.unknown[:, :2])
    assert np.shares_memory(crop.free, m.free)


def _peak_bytes(make):
    make()
    tracemalloc.start()
    try:
        make()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_from_array_and_load_map_make_their_masks_without_a_copy(tmp_path):
    # Classifying takes about 6 bytes per pixel at its peak; a copy of the three masks
    # when the map is made would take it to 8.
    image = np.random.default_rng(0).choice(np.array([0, 205, 254], np.uint8), (600, 700))
    yaml_path = tmp_path / "map.yaml"
    tj.save_map(OccupancyMap.from_array(image), yaml_path)
    for make in (lambda: OccupancyMap.from_array(image), lambda: tj.load_map(yaml_path)):
        assert _peak_bytes(make) < 7 * image.size


@pytest.mark.parametrize("protocol", [2, pickle.HIGHEST_PROTOCOL])
def test_a_pickled_or_deep_copied_map_keeps_read_only_masks(protocol):
    m = OccupancyMap.from_array(np.array([[0, 254, 205], [254, 254, 0]], np.uint8))
    for restored in (pickle.loads(pickle.dumps(m, protocol=protocol)), copy.deepcopy(m)):
        assert np.array_equal(restored.free, m.free) and restored.origin == m.origin
        for name in ("occupied", "free", "unknown"):
            with pytest.raises(ValueError, match="read-only"):
                getattr(restored, name)[0, 0] = True
