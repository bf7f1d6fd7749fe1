"""The maps of the route-graph benchmark (``bench_route_graph.py``).

Every real occupancy map in the shared data folder's ``maps/`` and the final maps of three
CARMEN log replays:

``ros``
    every ``maps/ros/*/*.yaml`` (PAL office, TU Wien Freihaus, TurtleBot3 office raw and
    refined, Willow Garage 2010) and ``willow-full-0.05.pgm`` (no YAML; 0.05 m/px).
``simulated``
    every ``maps/simulated/**/*.yaml`` (Nav2 depot, warehouse, tb3_sandbox; PAL hospital).
``slam_pgm``
    every ``maps/slam_pgm/*.pgm`` at the resolution its name ends in (``edmonton_0.06``:
    0.06 m/px; the data set's README gives the same, and that file's header gives none).
``ipa``
    the 20 IPA room-segmentation maps, their 20 ``*_furnitures`` variants (the same
    building with furniture drawn in) and the 9 raw maps, read with ``mode="ipa"`` (grey
    >= 250 free, the data set's own rule; the trinary rule would call the raw maps'
    230-grey outside free).  The ``*_gt_segmentation`` files are left out: they are the
    plain maps with artificial lines drawn between rooms, not maps of a building.
``paper``
    the IncrementalTopo paper's three maps (0.05 m/px).
``carmen``
    ``topojax.replay`` of the corrected Intel, FR079 and ACES logs; the map is the
    replay's final ``map.yaml``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["CARMEN_LOGS", "GROUPS", "QUICK_MAPS", "MapSpec", "benchmark_maps", "load_spec"]

#: CARMEN logs replayed for the benchmark: name -> file in ``logs/carmen_corrected``.
CARMEN_LOGS = {
    "carmen_intel": "intel-corrected.log.gz",
    "carmen_fr079": "freiburg-079-corrected.log.gz",
    "carmen_aces": "aces-corrected.log.gz",
}
#: Map groups in the order they are listed.
GROUPS = ("ros", "simulated", "slam_pgm", "ipa", "paper", "carmen")
#: A handful of maps of different kinds for ``--quick``.
QUICK_MAPS = ("tb3_sandbox", "intel_0.05", "office_c", "lab_d_scan", "intel")


@dataclass(frozen=True)
class MapSpec:
    """One benchmark map: ``name`` (unique), ``group``, ``path`` (map file or CARMEN log)
    and ``load_kw`` (keyword arguments of ``topojax.load_map``)."""

    name: str
    group: str
    path: Path
    load_kw: dict[str, Any] = field(default_factory=dict)

    @property
    def is_replay(self) -> bool:
        """Whether the map is the final map of a log replay."""
        return self.group == "carmen"


def _ros(maps: Path) -> list[MapSpec]:
    specs = []
    for yaml in sorted((maps / "ros").glob("*/*.yaml")):
        name = yaml.parent.name if yaml.stem == "map" else yaml.stem
        specs.append(MapSpec(name, "ros", yaml))
    for pgm in sorted((maps / "ros").glob("*/*.pgm")):
        if not pgm.with_suffix(".yaml").exists() and not (pgm.parent / "map.yaml").exists():
            specs.append(MapSpec(pgm.stem, "ros", pgm, {"resolution_m": 0.05}))
    return specs


def _ipa(maps: Path) -> list[MapSpec]:
    files = sorted((maps / "ipa").glob("*.png")) + sorted((maps / "ipa").glob("*.pgm"))
    specs = []
    for f in files:
        if "_gt_segmentation" in f.stem:
            continue
        name = "ipa_map" if f.stem == "map" else f.stem
        specs.append(MapSpec(name, "ipa", f, {"mode": "ipa"}))
    return specs


def _named_resolution(path: Path) -> float:
    """The resolution (m/px) a map's file name ends in: ``aces_0.10.pgm`` -> 0.1."""
    try:
        return float(path.stem.rsplit("_", 1)[1])
    except (IndexError, ValueError):
        raise ValueError(f"{path}: expected a name ending in _<metres per pixel>") from None


def benchmark_maps(data: Path) -> list[MapSpec]:
    """All benchmark maps found under the shared data folder ``data``, by group then name.

    Missing folders or logs are skipped (the list is what exists).
    """
    maps = data / "maps"
    specs = _ros(maps)
    specs += [
        MapSpec(y.stem if y.stem != "map" else y.parent.name, "simulated", y)
        for y in sorted((maps / "simulated").rglob("*.yaml"))
    ]
    specs += [
        MapSpec(p.stem, "slam_pgm", p, {"resolution_m": _named_resolution(p)})
        for p in sorted((maps / "slam_pgm").glob("*.pgm"))
    ]
    specs += _ipa(maps)
    specs += [MapSpec(p.stem, "paper", p) for p in sorted((maps / "paper").glob("*.png"))]
    logs = data / "logs" / "carmen_corrected"
    specs += [
        MapSpec(name, "carmen", logs / file)
        for name, file in CARMEN_LOGS.items()
        if (logs / file).is_file()
    ]
    names = [s.name for s in specs]
    dupes = {n for n in names if names.count(n) > 1}
    if dupes:
        raise RuntimeError(f"benchmark map names are not unique: {sorted(dupes)}")
    return specs


def load_spec(spec: MapSpec, *, replay_dir: Path, max_scans: int | None = None):
    """The ``OccupancyMap`` of ``spec``; a replay writes its outputs under ``replay_dir``.

    A replay already written there (``<replay_dir>/<name>[_<max_scans>]/map.yaml``) is
    reused.  Returns ``(occupancy_map, replay_seconds or None)``.
    """
    import time

    import topojax as tj

    if not spec.is_replay:
        return tj.load_map(spec.path, **spec.load_kw), None
    out = replay_dir / (spec.name if max_scans is None else f"{spec.name}_{max_scans}")
    yaml = out / "map.yaml"
    seconds = None
    if not yaml.is_file():
        t0 = time.perf_counter()
        tj.replay(spec.path, out_dir=out, progress=False, max_scans=max_scans)
        seconds = time.perf_counter() - t0
    return tj.load_map(yaml), seconds
