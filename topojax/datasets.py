"""Sample maps shipped with topojax.

The three maps of the paper (``intel``, ``office``, ``a_scan``) come from
STAR-Center/IncrementalTopo (MIT licence, commit befbcd55), files
``test_im/<name>/clean.png``; they are cleaned versions of IPA room-segmentation
benchmark maps (0.05 m per pixel).  Black walls on white; the outside of the building
is white (free) too.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ._validate import one_of

__all__ = ["SAMPLE_MAPS", "sample_map", "sample_map_path"]

SAMPLE_MAPS = ("intel", "office", "a_scan")


def sample_map_path(name: str = "intel") -> Path:
    """Path of a bundled sample map image.

    Parameters
    ----------
    name : {"intel", "office", "a_scan"}
        One of :data:`SAMPLE_MAPS`.

    Returns
    -------
    Path
        A PNG, black walls on white.
    """
    one_of("name", name, SAMPLE_MAPS)
    return Path(str(resources.files("topojax") / "data" / f"{name}.png"))


def sample_map(name: str = "intel"):
    """Load a bundled sample map.

    Parameters
    ----------
    name : {"intel", "office", "a_scan"}
        One of :data:`SAMPLE_MAPS`.

    Returns
    -------
    OccupancyMap
        At the paper's 0.05 m per pixel, origin (0, 0).
    """
    from .maps import load_map

    return load_map(sample_map_path(name), resolution_m=0.05)
