"""2-D laser scans with poses, and readers for CARMEN logs, Octave text files and ROS bags.

A :class:`Scan` is one planar laser scan together with the pose of the robot in the map frame
and the mounting pose of the sensor on the robot. The readers in this package are generators:
they yield one :class:`Scan` at a time and never hold a whole log's ranges in memory (except
:func:`read_octave_laser`, whose file format stores every scan's ranges in one block).

Conventions
-----------
* Poses are ``(x_m, y_m, yaw_rad)``; yaw is counter-clockwise from the map ``x`` axis.
* Beam ``i`` of a scan points at ``angle_min + i * angle_increment`` (radians) in the sensor
  frame, counter-clockwise from the sensor's ``x`` axis.
* A reading is a *hit* (see :meth:`Scan.valid_mask`) when it is finite, positive,
  ``>= range_min`` and strictly ``< range_max``. Readings at or beyond ``range_max`` are
  "no return" (max-range) readings; NaN, +-inf, zero and negative values are no-returns too.
  Float32 readings are compared with the limits rounded to float32.

Modules: ``scan`` (:class:`Scan`, :func:`scans_from_arrays`), ``carmen``, ``octave`` and
``bag`` (one reader per format, with ``_ros1`` and ``_tf`` behind the bag reader),
``_dispatch`` (:func:`read_scans`).
"""

from __future__ import annotations

from ._dispatch import ReaderOptionError, read_scans
from .bag import read_bag
from .carmen import CARMEN_NO_RETURN_MARGIN_M, read_carmen
from .octave import read_octave_laser
from .scan import Scan, scans_from_arrays

__all__ = [
    "CARMEN_NO_RETURN_MARGIN_M",
    "ReaderOptionError",
    "Scan",
    "read_bag",
    "read_carmen",
    "read_octave_laser",
    "read_scans",
    "scans_from_arrays",
]
