"""numba's ``njit`` with its on-disk cache, kept in step with the package's sources; and
the count of JAX traces that tests use to guard against recompiles.

numba keeps compiled kernels next to the package (``__pycache__``) or in
``NUMBA_CACHE_DIR``, and checks a cached kernel only against the file that defines it.  A
kernel that calls kernels of other files would keep stale code after those files change,
so on import the cache of the whole package is dropped whenever any of its sources
changed (:func:`purge_stale_kernels`).  In a read-only install with no writable cache
folder, ``njit(cache=True)`` raises at import time; the kernels then compile in every
process instead, and a warning says how to keep them.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from collections import Counter
from pathlib import Path

import numba
from numba.core.caching import UserProvidedCacheLocator

__all__ = ["TRACES", "cached_njit", "purge_stale_kernels", "trace_counts"]

_warned = False

#: Traces (compilations) of each jitted JAX kernel in this process, by kernel name; each
#: kernel counts itself while it is traced.
TRACES: Counter[str] = Counter()
_STAMP = "topojax-sources.sha1"


def _cache_folders(package: Path) -> list[Path]:
    """Where numba keeps the kernels of the source folders of ``package``."""
    folders = sorted({p.parent for p in package.rglob("*.py")})
    if numba.config.CACHE_DIR:
        base = Path(numba.config.CACHE_DIR)
        return [
            base / UserProvidedCacheLocator.get_suitable_cache_subpath(str(f / "x.py"))
            for f in folders
        ]
    return [f / "__pycache__" for f in folders]


def purge_stale_kernels(package: str | Path) -> bool:
    """Delete numba's cached kernels of ``package`` if any of its ``.py`` files changed
    since they were cached; returns True if it deleted them.

    The digest of all sources is kept in the package's own cache folder; where that
    folder cannot be written, nothing is done (numba then cannot cache either)."""
    package = Path(package)
    digest = hashlib.sha1()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    folders = _cache_folders(package)
    stamp = folders[0] / _STAMP if folders else None
    try:
        if stamp is None or (stamp.is_file() and stamp.read_text() == digest.hexdigest()):
            return False
        for folder in folders:
            for cached in (*folder.glob("*.nbi"), *folder.glob("*.nbc")):
                cached.unlink(missing_ok=True)
        stamp.parent.mkdir(parents=True, exist_ok=True)
        tmp = stamp.with_name(f"{_STAMP}.{os.getpid()}.tmp")
        tmp.write_text(digest.hexdigest())
        tmp.replace(stamp)
    except OSError:  # a read-only install: numba falls back to compiling uncached
        return False
    return True


def cached_njit(**options):
    """``numba.njit(cache=True, **options)``, falling back to ``cache=False`` (with one
    warning per process) when numba has no writable place for its cache."""

    def wrap(func):
        global _warned
        try:
            return numba.njit(cache=True, **options)(func)
        except RuntimeError as exc:
            if "cannot cache" not in str(exc):
                raise
            if not _warned:
                _warned = True
                warnings.warn(
                    f"topojax: numba cannot cache its compiled kernels ({exc}); they are "
                    "compiled in every process. Set NUMBA_CACHE_DIR to a writable folder "
                    "to keep them.",
                    RuntimeWarning,
                    stacklevel=3,
                )
            return numba.njit(**options)(func)

    return wrap


purge_stale_kernels(Path(__file__).resolve().parent)


def trace_counts() -> dict[str, int]:
    """How many times each jitted JAX kernel has been traced (compiled) in this process,
    by kernel name."""
    return dict(TRACES)
