"""numba's ``njit`` with its on-disk cache, or without it where no cache can be written.

numba keeps compiled kernels next to the package (``__pycache__``) or in
``NUMBA_CACHE_DIR``.  In a read-only install (a system, container or Nix package) with no
writable cache folder, ``njit(cache=True)`` raises at import time; the kernels then compile
in every process instead (a few seconds), and a warning says how to keep them.
"""

from __future__ import annotations

import warnings

import numba

_warned = False


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
