"""numba's cache follows the package's sources: a change to any source file drops every
cached kernel, since a kernel keeps the code of the kernels it calls from other files; and
kernels see one memory layout per argument, so that nothing compiles again mid-run."""

from __future__ import annotations

import numba

from topojax._jit import purge_stale_kernels


def _package(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub" / "__pycache__").mkdir(parents=True)
    (pkg / "__pycache__").mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "kernels.py").write_text("x = 1\n")
    return pkg


def _cached(pkg):
    files = [pkg / "__pycache__" / "m.f-1.py311.nbi", pkg / "sub" / "__pycache__" / "k.g-3.nbc"]
    for f in files:
        f.write_bytes(b"kernel")
    return files


def test_first_import_and_source_changes_drop_the_cache(tmp_path, monkeypatch):
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    pkg = _package(tmp_path)
    files = _cached(pkg)
    assert purge_stale_kernels(pkg)  # no stamp yet: whatever is cached may be stale
    assert not any(f.exists() for f in files)
    files = _cached(pkg)
    assert not purge_stale_kernels(pkg)  # sources unchanged: the cache stays
    assert all(f.exists() for f in files)
    (pkg / "sub" / "kernels.py").write_text("x = 2\n")  # a helper another file calls
    assert purge_stale_kernels(pkg)
    assert not any(f.exists() for f in files)
    (pkg / "sub" / "__pycache__" / "keep.pyc").write_bytes(b"")
    (pkg / "__init__.py").write_text("# changed\n")
    assert purge_stale_kernels(pkg)
    assert (pkg / "sub" / "__pycache__" / "keep.pyc").exists()  # only numba's files go


def test_numba_cache_dir_is_followed(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(cache))
    pkg = _package(tmp_path)
    assert purge_stale_kernels(pkg)
    stamps = list(cache.rglob("topojax-sources.sha1"))
    assert len(stamps) == 1 and stamps[0].parent.name.startswith("pkg_")
    assert not list((pkg / "__pycache__").iterdir())


def test_unwritable_cache_is_left_alone(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(blocker))  # a file: no folder there
    assert not purge_stale_kernels(_package(tmp_path))


_LAYOUT_CHECK = """
from collections import Counter
import numba
import numpy as np
import topojax as tj
from topojax.rooms._kernels import label_stats
from topojax.rooms._outline import _crack_length, _trace
from topojax.routegraph._cover import covered
from topojax.routegraph._spanner import see_within

def layouts(f):
    key = Counter(
        tuple((a.dtype, a.ndim) if isinstance(a, numba.types.Array) else a for a in sig)
        for sig in f.signatures
    )
    return max(key.values(), default=0)

# rooms: free space over the whole grid, then free space in a crop of it
walls = np.ones((60, 80), np.uint8) * 254
walls[[0, -1], :] = 0
walls[:, [0, -1]] = 0
walls[:, 40] = 0
walls[28:34, 40] = 254
tj.segment_rooms(tj.OccupancyMap.from_array(walls, resolution_m=0.05))
cropped = np.full((60, 80), 205, np.uint8)
cropped[10:50, 15:65] = walls[10:50, 15:65]
cropped[10, 15:65] = cropped[49, 15:65] = 0
cropped[10:50, 15] = cropped[10:50, 64] = 0
tj.segment_rooms(tj.OccupancyMap.from_array(cropped, resolution_m=0.05))
# route graph coverage: many pixels tested (labelled transform) and a few (row by row)
feasible = np.ones((40, 40), bool)
raster = np.zeros_like(feasible)
raster[20, 5:35] = True
covered(raster, feasible, 3.0)
among = np.zeros_like(feasible)
among[10, 10] = among[30, 30] = True
covered(raster, feasible, 3.0, among=among)
for f in (label_stats, _trace, _crack_length, see_within):
    if layouts(f) > 1:
        print(f.__name__, f.signatures)
"""


def test_room_and_coverage_kernels_see_one_memory_layout():
    """A strided and a contiguous array of the same dtype are two numba variants: a kernel
    that sees both compiles again (about a second, inside a scan's room update or a route
    graph) the first time the other layout comes.  Rooms whose free space spans the whole
    map and rooms in a crop of it, coverage tested densely and at a few pixels, must all
    give each kernel one layout.  Run in a fresh process (no earlier calls)."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _LAYOUT_CHECK], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout == ""
