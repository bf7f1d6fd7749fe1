"""The tf tree of a bag: planar transforms (which may mirror), their time series and the
lookup of one frame's pose in another."""

from __future__ import annotations

import math
from array import array
from typing import Any

import numpy as np

from .scan import _wrap_angle

# A planar transform that may mirror: p -> R(yaw) @ diag(1, s) @ p + (x, y), s in {+1, -1}.
_Tf = tuple[float, float, float, int]
_IDENTITY_TF: _Tf = (0.0, 0.0, 0.0, 1)


class BadTransform(ValueError):
    """A transform or pose message that is not finite or whose quaternion is zero (a
    localisation glitch): the message is skipped, not the recording refused."""


def _tf_from_msg(translation: Any, rotation: Any) -> _Tf:
    """Planar part of a 3-D transform: translation x, y; heading of the rotated x axis;
    ``s = -1`` when the rotated z axis points down (sensor mounted upside down)."""
    qx, qy, qz, qw = (float(rotation.x), float(rotation.y), float(rotation.z), float(rotation.w))
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not math.isfinite(norm) or norm == 0.0:
        raise BadTransform(f"invalid quaternion ({qx}, {qy}, {qz}, {qw})")
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
    r10 = 2.0 * (qx * qy + qw * qz)
    r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
    x, y = float(translation.x), float(translation.y)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise BadTransform(f"invalid translation ({x}, {y})")
    return (x, y, math.atan2(r10, r00), -1 if r22 < 0.0 else 1)


def _tf_compose(a: _Tf, b: _Tf) -> _Tf:
    c, s = math.cos(a[2]), math.sin(a[2])
    bx, by = b[0], a[3] * b[1]
    return (
        a[0] + c * bx - s * by,
        a[1] + s * bx + c * by,
        _wrap_angle(a[2] + a[3] * b[2]),
        a[3] * b[3],
    )


def _tf_inverse(a: _Tf) -> _Tf:
    yaw = -a[3] * a[2]
    c, s = math.cos(yaw), math.sin(yaw)
    tx, ty = a[0], a[3] * a[1]
    return (-(c * tx - s * ty), -(s * tx + c * ty), _wrap_angle(yaw), a[3])


class _TfSeries:
    """Time series of one transform (parent -> child), linearly interpolated; once a
    static one comes, only static ones, each holding from its stamp on.  Samples are
    kept in typed arrays (33 bytes each, where tuples in a list take about 190: an hour
    of 100 Hz tf is about 12 MB per transform)."""

    def __init__(self) -> None:
        self.t = array("q")  # ns
        self.xyy = array("d")  # x, y, yaw of each sample, in turn
        self.s = array("b")  # +1, or -1 for a mirroring transform
        self.static = False
        self._arr: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def add(self, t_ns: int, tf: _Tf, static: bool) -> None:
        if static and not self.static:  # a static transform replaces the moving one
            self.static = True
            self.t, self.xyy, self.s = array("q"), array("d"), array("b")
        elif self.static and not static:
            return
        self.t.append(t_ns)
        self.xyy.extend(tf[:3])
        self.s.append(tf[3])
        self._arr = None

    def __len__(self) -> int:
        return len(self.t)

    def _arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if self._arr is None:
            t = np.frombuffer(self.t, dtype=np.int64)
            order = np.argsort(t, kind="stable")
            v = np.frombuffer(self.xyy, dtype=np.float64).reshape(-1, 3)[order]
            s = np.frombuffer(self.s, dtype=np.int8)[order].astype(np.float64)
            self._arr = (t[order], v[:, 0], v[:, 1], np.unwrap(v[:, 2]), s)
        return self._arr

    def at(self, t_ns: int, tol_ns: int) -> _Tf | None:
        t, x, y, yaw, s = self._arrays()
        if self.static:  # the latest at or before t_ns holds (the first, before any)
            j = max(int(np.searchsorted(t, t_ns, side="right")) - 1, 0)
            return (float(x[j]), float(y[j]), _wrap_angle(float(yaw[j])), int(s[j]))
        if t_ns < t[0] - tol_ns or t_ns > t[-1] + tol_ns:
            return None
        k = int(np.searchsorted(t, t_ns, side="right"))
        if k == 0:
            return (float(x[0]), float(y[0]), _wrap_angle(float(yaw[0])), int(s[0]))
        if k == len(t) or t[k - 1] == t_ns:
            j = k - 1
            return (float(x[j]), float(y[j]), _wrap_angle(float(yaw[j])), int(s[j]))
        w = float(t_ns - t[k - 1]) / float(t[k] - t[k - 1])
        return (
            float(x[k - 1] + w * (x[k] - x[k - 1])),
            float(y[k - 1] + w * (y[k] - y[k - 1])),
            _wrap_angle(float(yaw[k - 1] + w * (yaw[k] - yaw[k - 1]))),
            int(s[k - 1]),
        )


class _TfTree:
    """The tf tree of a bag: child frame -> (parent frame, series)."""

    def __init__(self) -> None:
        self.edges: dict[str, tuple[str, _TfSeries]] = {}

    def add(self, parent: str, child: str, t_ns: int, tf: _Tf, static: bool) -> None:
        if not parent or not child or parent == child:
            return
        cur = self.edges.get(child)
        if cur is None:
            cur = (parent, _TfSeries())
            self.edges[child] = cur
        elif cur[0] != parent:
            raise ValueError(
                f"tf: frame {child!r} has two parents ({cur[0]!r} and {parent!r}); "
                f"a tf tree must be a tree"
            )
        cur[1].add(t_ns, tf, static)

    @property
    def frames(self) -> set[str]:
        out = set(self.edges)
        out.update(p for p, _ in self.edges.values())
        return out

    def ancestors(self, frame: str) -> list[str]:
        """``frame`` followed by its parents up to the root."""
        chain = [frame]
        seen = {frame}
        while chain[-1] in self.edges:
            parent = self.edges[chain[-1]][0]
            if parent in seen:
                raise ValueError(f"tf: cycle through frame {parent!r}")
            chain.append(parent)
            seen.add(parent)
        return chain

    def connected(self, a: str, b: str) -> bool:
        return self.ancestors(a)[-1] == self.ancestors(b)[-1]

    def _to_root(self, frame: str, t_ns: int, tol_ns: int) -> tuple[str, _Tf] | None:
        tf = _IDENTITY_TF
        cur = frame
        for parent in self.ancestors(frame)[1:]:
            edge = self.edges[cur][1].at(t_ns, tol_ns)
            if edge is None:
                return None
            tf = _tf_compose(edge, tf)
            cur = parent
        return cur, tf

    def lookup(self, target: str, source: str, t_ns: int, tol_ns: int) -> _Tf | None:
        """Transform taking ``source`` coordinates to ``target`` coordinates (pose of
        ``source`` in ``target``), or None if not available at ``t_ns``."""
        a = self._to_root(target, t_ns, tol_ns)
        b = self._to_root(source, t_ns, tol_ns)
        if a is None or b is None:
            return None
        if a[0] != b[0]:
            raise ValueError(f"tf: frames {target!r} and {source!r} are not connected")
        return _tf_compose(_tf_inverse(a[1]), b[1])
