"""Shared helpers for the topojax benchmark scripts.

Machine description, wall-clock timing with a clear split between *cold* (first call in a
fresh process) and *warm* (steady state, median of repeats), small JSON output and
markdown tables.  Every time is measured with :func:`time.perf_counter` and stored in
milliseconds.

Definitions used by every script in ``bench/``:

cold
    The first call of a pipeline in a new Python process, after its imports and after
    loading the map, so it includes JIT compilation (JAX tracing + XLA compile, numba
    compile or numba cache load) and first-touch allocation.  Each cold sample runs in its
    own subprocess (:func:`run_cold_worker`), so one measurement cannot warm another.
warm
    Later calls in a process that has already run the same call once: median (and min)
    over ``repeats`` runs, after one discarded warm-up call.
"""

from __future__ import annotations

import json
import math
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

__all__ = [
    "BENCH_DIR",
    "DEFAULT_DATA",
    "LARGE_MAPS",
    "PAPER_MAPS",
    "REPO_ROOT",
    "RESULTS_DIR",
    "StageSamples",
    "cpu_model",
    "git_describe",
    "load_average",
    "machine_info",
    "machine_slug",
    "markdown_table",
    "paper_obstacles",
    "median",
    "provenance",
    "ms",
    "run_cold_worker",
    "time_call",
    "use_checkout",
    "write_json",
]

BENCH_DIR = Path(__file__).resolve().parent
REPO_ROOT = BENCH_DIR.parent
RESULTS_DIR = BENCH_DIR / "results"
#: The shared data folder beside the repository (``--data`` overrides it).
DEFAULT_DATA = REPO_ROOT.parent / "shared" / "data"
#: The paper's three maps and the larger real maps, relative to the data folder.
PAPER_MAPS = {
    "intel": "maps/paper/intel.png",
    "office": "maps/paper/office.png",
    "a_scan": "maps/paper/a_scan.png",
}
LARGE_MAPS = {
    "office_g": "maps/ipa/office_g.png",
    "office_i": "maps/ipa/office_i.png",
    "DM_0.11": "maps/slam_pgm/DM_0.11.pgm",
    "aces_0.10": "maps/slam_pgm/aces_0.10.pgm",
    "edmonton_0.06": "maps/slam_pgm/edmonton_0.06.pgm",
    "pal_office_7th_floor": "maps/ros/pal_office_7th_floor/map.yaml",
    "warehouse": "maps/simulated/nav2/warehouse.yaml",
}

_PACKAGES = (
    "topojax",
    "jax",
    "jaxlib",
    "numpy",
    "scipy",
    "opencv-python-headless",
    "scikit-image",
    "skan",
    "numba",
    "networkx",
)


def use_checkout() -> None:
    """Put the repository root first on ``sys.path`` so the checkout is what gets measured."""
    root = str(REPO_ROOT)
    if root not in sys.path:
        sys.path.insert(0, root)


def _lscpu() -> dict[str, str]:
    try:
        out = subprocess.run(
            ["lscpu"], capture_output=True, text=True, check=True, timeout=10
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return {}
    info = {}
    for line in out.splitlines():
        key, sep, value = line.partition(":")
        if sep:
            info[key.strip()] = value.strip()
    return info


def cpu_model() -> str:
    """CPU model name from ``lscpu`` (falls back to :func:`platform.processor`)."""
    return _lscpu().get("Model name") or platform.processor() or "unknown-cpu"


def load_average() -> tuple[float, float, float] | None:
    """1, 5 and 15 minute load averages, or None where the OS does not report them."""
    try:
        return tuple(round(v, 2) for v in os.getloadavg())  # type: ignore[return-value]
    except OSError:
        return None


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def machine_info(*, with_jax: bool = True) -> dict[str, Any]:
    """Describe the machine and software the benchmark ran on.

    Parameters
    ----------
    with_jax : bool
        Also import jax and list its devices (costs the jax import time, about 1 s).

    Returns
    -------
    dict
        ``cpu_model``, ``cpu_count`` (logical CPUs usable by this process),
        ``cores_per_socket``/``threads_per_core``/``sockets`` from lscpu, ``platform``,
        ``python``, ``versions`` (package -> version), ``jax_devices`` and
        ``load_average`` (1/5/15 min) at the time of the call.
    """
    lscpu = _lscpu()
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count() or 0
    info: dict[str, Any] = {
        "cpu_model": lscpu.get("Model name") or platform.processor() or "unknown",
        "cpu_count": usable,
        "cores_per_socket": lscpu.get("Core(s) per socket"),
        "threads_per_core": lscpu.get("Thread(s) per core"),
        "sockets": lscpu.get("Socket(s)"),
        "hypervisor": lscpu.get("Hypervisor vendor"),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "versions": {name: _version(name) for name in _PACKAGES},
        "load_average": load_average(),
    }
    if with_jax:
        import jax

        info["jax_devices"] = [str(d) for d in jax.devices()]
    return info


def machine_slug(info: Mapping[str, Any] | None = None) -> str:
    """Short file-name-safe machine name, e.g. ``amd-epyc-2cpu``.

    The environment variable ``TOPOJAX_BENCH_MACHINE`` overrides it.
    """
    override = os.environ.get("TOPOJAX_BENCH_MACHINE")
    if override:
        return re.sub(r"[^a-z0-9._-]+", "-", override.lower()).strip("-")
    info = info or {"cpu_model": cpu_model(), "cpu_count": os.cpu_count() or 0}
    model = str(info.get("cpu_model", "cpu")).lower()
    model = re.sub(r"\((r|tm)\)|cpu|processor|@.*$|\d+-core", " ", model)
    model = re.sub(r"[^a-z0-9]+", "-", model).strip("-") or "cpu"
    return f"{model}-{info.get('cpu_count', 0)}cpu"


def paper_obstacles(data: Path) -> dict[str, Any]:
    """The paper maps' obstacle masks (bool (H, W) arrays) from the data folder ``data``."""
    import topojax as tj

    return {name: tj.load_map(data / rel).occupied for name, rel in PAPER_MAPS.items()}


def ms(seconds: float) -> float:
    """Seconds to milliseconds, rounded to 0.01 ms (keeps the JSON small)."""
    return round(seconds * 1e3, 2)


def median(values: Iterable[float]) -> float:
    """Median of a non-empty sequence (NaN if empty)."""
    vals = list(values)
    return statistics.median(vals) if vals else math.nan


def time_call(fn: Callable[[], Any]) -> tuple[float, Any]:
    """Run ``fn()`` once; return (seconds, its result)."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


class StageSamples:
    """Collects per-stage times (seconds) of repeated runs and summarises them in ms.

    Stage names keep their first-seen order.
    """

    def __init__(self) -> None:
        self._samples: dict[str, list[float]] = {}

    def add(self, stages: Mapping[str, float]) -> None:
        """Record one run: ``stage name -> seconds``."""
        for name, value in stages.items():
            self._samples.setdefault(name, []).append(float(value))

    def __len__(self) -> int:
        return max((len(v) for v in self._samples.values()), default=0)

    def summary(self) -> dict[str, dict[str, float]]:
        """``stage -> {"median_ms", "min_ms"}`` over the recorded runs."""
        return {
            name: {"median_ms": ms(median(v)), "min_ms": ms(min(v))}
            for name, v in self._samples.items()
        }

    def median_ms(self, stage: str) -> float:
        """Median of one stage in ms (NaN if the stage was never recorded)."""
        vals = self._samples.get(stage, [])
        return ms(median(vals)) if vals else math.nan


def run_cold_worker(
    script: Path, args: Sequence[str], *, timeout_s: float = 600.0
) -> dict[str, Any]:
    """Run ``python script *args`` in a fresh process and parse its last stdout line as JSON.

    The worker is expected to print exactly one JSON object on its last line.  The
    process's own wall time (interpreter start to exit) is added as ``process_ms``.

    Raises
    ------
    RuntimeError
        If the worker exits with a non-zero status or prints no JSON; the message quotes
        the end of its stderr.
    """
    cmd = [sys.executable, str(script), *args]
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT), env.get("PYTHONPATH")]))
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env)
    elapsed = time.perf_counter() - t0
    lines = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(
            f"cold worker {' '.join(args)!r} failed with exit status {proc.returncode}: "
            f"{proc.stderr[-2000:]}"
        )
    try:
        result = json.loads(lines[-1])
    except json.JSONDecodeError as exc:
        raise RuntimeError(
            f"cold worker {' '.join(args)!r} printed no JSON on its last line: {lines[-1]!r}"
        ) from exc
    result["process_ms"] = ms(elapsed)
    return result


def _round_floats(obj: Any, digits: int = 7) -> Any:
    if isinstance(obj, float):
        if math.isnan(obj) or math.isinf(obj):
            return None
        return float(f"{obj:.{digits}g}")
    if isinstance(obj, dict):
        return {str(k): _round_floats(v, digits) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_round_floats(v, digits) for v in obj]
    return obj


def _one_line(match: re.Match[str]) -> str:
    return re.sub(r"\s*\n\s*", " ", match.group(0))


def write_text(path: str | Path, text: str) -> Path:
    """Write a report (e.g. ``--markdown``), creating its folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def git_describe() -> str | None:
    """``git describe --always --dirty`` of the checkout being measured, or None."""
    try:
        out = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return out or None


def provenance() -> dict[str, Any]:
    """``git_describe`` of the checkout and ``date_utc`` (ISO 8601) for a results file."""
    return {
        "git_describe": git_describe(),
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def write_json(path: Path, data: Mapping[str, Any]) -> Path:
    """Write ``data`` as indented JSON; returns the path.

    The file starts with ``git_describe`` and ``date_utc`` (:func:`provenance`) unless
    ``data`` already has them.  Floats keep 7 significant digits, NaN and infinities become
    null, and innermost objects and lists are written on one line.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    data = {**provenance(), **dict(data)}
    text = json.dumps(_round_floats(data), indent=1)
    # innermost objects and lists of numbers on one line each: small and still readable
    text = re.sub(r"[{\[][^{}\[\]\"]*(\"[^\"]*\"[^{}\[\]\"]*)*[}\]]", _one_line, text)
    tmp.write_text(text + "\n")
    tmp.replace(path)
    return path


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """Format a GitHub markdown table; floats get 1 decimal (3 significant digits if < 1)."""

    def cell(v: Any) -> str:
        if isinstance(v, float):
            if math.isnan(v):
                return "–"
            return f"{v:.3g}" if abs(v) < 1 else f"{v:,.1f}"
        return "–" if v is None else str(v)

    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)
