"""numba's cache follows the package's sources: a change to any source file drops every
cached kernel, since a kernel keeps the code of the kernels it calls from other files."""

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
