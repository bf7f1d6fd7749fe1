"""How mapper states (``IncrementalMapper.save``, a replay's stops and checkpoints) are
compressed: at a fast zlib level, and those saved at numpy's default level still load."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from topojax.incremental import IncrementalMapper
from topojax.incremental.state import STATE_ZLIB_LEVEL
from topojax.scans import read_scans

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"


def mapped(n: int) -> IncrementalMapper:
    mapper = IncrementalMapper(skeleton_every=3, graph_every=7)
    for i, scan in enumerate(read_scans(INTEL_EXCERPT)):
        if i == n:
            break
        mapper.add_scan(scan)
    return mapper


def test_a_state_is_deflated_at_the_fast_level(tmp_path, monkeypatch):
    """Deflating the tiles at numpy's default level 6 was nearly all of a checkpoint's
    time; every member is now deflated at :data:`STATE_ZLIB_LEVEL` (3)."""
    mapper, levels = IncrementalMapper(), []  # no scan: no compiling
    real = zlib.compressobj

    def compressobj(level=-1, *args, **kwargs):
        levels.append(level)
        return real(level, *args, **kwargs)

    monkeypatch.setattr(zlib, "compressobj", compressobj)
    mapper.save(tmp_path / "state.npz")
    monkeypatch.undo()
    assert STATE_ZLIB_LEVEL == 3 and levels and set(levels) == {3}


def test_a_state_saved_at_numpy_s_default_level_still_loads(tmp_path):
    """A state written by ``numpy.savez_compressed`` (level 6), as topojax saved states
    before, loads as the one saved now does."""
    mapper = mapped(5)
    path = mapper.save(tmp_path / "state.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    np.savez_compressed(tmp_path / "old.npz", **arrays)
    new, old = IncrementalMapper.load(path), IncrementalMapper.load(tmp_path / "old.npz")
    assert old.n_scans == new.n_scans == 5
    a, b = new.tiles.state(), old.tiles.state()
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
