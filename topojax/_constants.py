"""Small constants that the command line needs to build its parser, in a module that
imports nothing (the modules that use them import JAX, numba or the map readers).

:mod:`topojax.maps` and :mod:`topojax.incremental` import them from here and export them
under the same names.
"""

from __future__ import annotations

__all__ = ["MODES", "STRATEGIES"]

#: Pixel conventions of :func:`topojax.load_map` (``mode``); :data:`topojax.maps.MODES`.
MODES = ("trinary", "scale", "raw", "ipa")
#: Skeleton update strategies of :class:`topojax.IncrementalMapper`;
#: :data:`topojax.incremental.STRATEGIES`.
STRATEGIES = ("exact", "paper")
