"""Benchmark: the memory floor of the map-sized stages, per map pixel.

``build_graph``, ``segment_rooms`` and ``route_graph`` (r = 0.3 m) refuse a map whose
need, a floor in bytes per map pixel (``topojax/_stage_memory.py``) times its pixels,
exceeds the memory available.  This script measures what each stage takes: every (map,
stage) pair in a fresh process, after ``import topojax`` and one call of the same stage
on a small floor plan (the kernels compile, the numba caches load), then the case's map
is made and the stage is measured alone: the peak growth of the resident set over the
RSS before the call (sampled every millisecond, and the kernel's ``VmHWM`` where it can
be reset; ``memory_cases.Measure``), per map pixel, and the call's time.  The floor of a
stage is the lowest growth per pixel over the maps; the constants sit below it.

Cases (all of at least 4 Mpx): the largest shared map (``office_g``), shared SLAM maps
upscaled twice each way (``x2_<map>``: every pixel a 2 x 2 block, half the resolution),
the synthetic floor plans and 1 % noise maps of ``bench_memory.py`` (``floor_<side>``,
``noise_<side>``), an empty hall (``hall_<side>``: a wall 3 px thick round a free
square) and a map of unknown space but for one room of 200 px a side in its middle
(``unknown_<side>``).  Results: ``bench/results/stage_floors_<machine>.json`` (a run
replaces the pairs it measures and keeps the others) and a markdown table.

Run from the repository root::

    python bench/bench_stage_floors.py                         # all, ~15 minutes on 2 cores
    python bench/bench_stage_floors.py --cases floor_16000 --stages build_graph
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    REPO_ROOT,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    run_cold_worker,
    use_checkout,
    write_json,
    write_text,
)

STAGES = ("build_graph", "segment_rooms", "route_graph")
#: Shared maps upscaled by 2 (``x2_<name>``; names of ``bench_memory.SHARED``).
UPSCALED = ("aces_0.10", "edmonton_0.06", "DM_0.11", "pal_office_7th_floor")
CASES = (
    "office_g",
    *(f"x2_{name}" for name in UPSCALED),
    "floor_4000",
    "floor_8000",
    "noise_4000",
    "hall_4000",
    "unknown_4000",
)
RADIUS_M = 0.3
WARMUP_SIDE_PX = 600
HALL_WALL_PX = 3
ROOM_PX = 200


def _frozen(a):
    a.setflags(write=False)  # OccupancyMap keeps read-only masks without a copy
    return a


def case_map(name: str, data: Path):
    """The OccupancyMap of a case."""
    import numpy as np
    from bench_memory import make_case_map

    from topojax.maps import OccupancyMap

    if name.startswith("x2_"):
        occ = make_case_map(name[3:], REPO_ROOT, data)

        def up(mask):
            return _frozen(np.repeat(np.repeat(mask, 2, axis=0), 2, axis=1))

        return OccupancyMap(
            occupied=up(occ.occupied),
            free=up(occ.free),
            unknown=up(occ.unknown),
            resolution_m=occ.resolution_m / 2,
            origin=occ.origin,
        )
    if name.startswith("hall_") and name[5:].isdigit():
        side = int(name[5:])
        occ = np.ones((side, side), bool)
        occ[HALL_WALL_PX:-HALL_WALL_PX, HALL_WALL_PX:-HALL_WALL_PX] = False
        return OccupancyMap(
            occupied=_frozen(occ), free=_frozen(~occ), unknown=_frozen(np.zeros_like(occ))
        )
    if name.startswith("unknown_") and name[8:].isdigit():
        return _unknown_with_a_room(int(name[8:]))
    return make_case_map(name, REPO_ROOT, data)


def _unknown_with_a_room(side: int):
    """A map of unknown space but for one room (:data:`ROOM_PX` a side inside a wall of
    :data:`HALL_WALL_PX`) in its middle: the stages' work in the free space is small,
    what they take over the whole map is left."""
    import numpy as np

    from topojax.maps import OccupancyMap

    occ = np.zeros((side, side), bool)
    free = np.zeros((side, side), bool)
    a, b = (side - ROOM_PX) // 2, (side + ROOM_PX) // 2
    occ[a - HALL_WALL_PX : b + HALL_WALL_PX, a - HALL_WALL_PX : b + HALL_WALL_PX] = True
    occ[a:b, a:b] = False
    free[a:b, a:b] = True
    return OccupancyMap(occupied=_frozen(occ), free=_frozen(free), unknown=_frozen(~(occ | free)))


def run_stage(stage: str, occ):
    """Call ``stage`` on ``occ`` the way a user does (defaults; r = 0.3 m)."""
    import topojax as tj

    if stage == "build_graph":
        return tj.build_graph(occ)
    if stage == "segment_rooms":
        return tj.segment_rooms(occ)
    return tj.route_graph(occ, robot_radius_m=RADIUS_M)


def worker(name: str, stage: str, data: Path, limit_gb: float) -> None:
    """Measure one stage on one case in this (fresh) process; print one JSON line."""
    use_checkout()
    import numpy as np
    from bench_memory import floor_plan
    from memory_cases import Measure

    import topojax as tj
    from topojax.maps import OccupancyMap

    if stage not in STAGES:
        raise SystemExit(f"--stages: expected names from {STAGES}, got {stage!r}")
    warm = floor_plan(WARMUP_SIDE_PX, seed=1)
    run_stage(stage, OccupancyMap(occupied=warm, free=~warm, unknown=warm & ~warm))
    del warm
    occ = case_map(name, data)
    measure = Measure(limit_gb)
    _, m = measure(lambda: run_stage(stage, occ))
    measure.stop()
    px = int(occ.shape[0]) * int(occ.shape[1])
    print(
        json.dumps(
            {
                "case": name,
                "stage": stage,
                "shape": list(occ.shape),
                "pixels": px,
                "resolution_m": float(occ.resolution_m),
                "free_share": float(np.count_nonzero(occ.free)) / px,
                "peak_mb": m["peak_mb"],
                "peak_b_px": m["peak_mb"] * 2**20 / px,
                "base_mb": m["base_mb"],
                "s": m["s"],
                "hwm_reset": measure.hwm_ok,
                "topojax_file": tj.__file__,
            }
        )
    )


def report(cases: list[dict]) -> str:
    """A table of peak growth per pixel (map x stage), then the floor of each stage."""
    by_case: dict[str, dict] = {}
    for c in cases:
        by_case.setdefault(c["case"], {"shape": c["shape"]})[c["stage"]] = c
    rows = []
    for name, d in by_case.items():
        row = [name, f"{d['shape'][0]} x {d['shape'][1]}", d["shape"][0] * d["shape"][1] / 1e6]
        row += [d[s]["peak_b_px"] if s in d else None for s in STAGES]
        rows.append(row)
    text = markdown_table(("map", "pixels", "Mpx", *(f"{s} B/px" for s in STAGES)), rows)
    floors = []
    for s in STAGES:
        seen = [c for c in cases if c["stage"] == s]
        if seen:
            low = min(seen, key=lambda c: c["peak_b_px"])
            floors.append([s, low["peak_b_px"], low["case"], len(seen)])
    return text + "\n\n" + markdown_table(("stage", "floor B/px", "on", "maps"), floors)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), help=f"of {', '.join(CASES)}")
    parser.add_argument("--stages", nargs="+", default=list(STAGES), help=f"of {STAGES}")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--limit-gb", type=float, default=14.0, help="RSS limit per case (GiB)")
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown table here")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--stage", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(args.worker, args.stage, args.data, args.limit_gb)
        return 0
    info = machine_info()
    out = args.out or RESULTS_DIR / f"stage_floors_{machine_slug(info)}.json"
    # a run replaces the (map, stage) pairs it measures and keeps the others
    kept = json.loads(out.read_text())["cases"] if out.is_file() else []
    cases = []
    for name in args.cases:
        for stage in args.stages:
            res = run_cold_worker(
                Path(__file__),
                ["--worker", name, "--stage", stage, "--data", str(args.data)]
                + ["--limit-gb", str(args.limit_gb)],
                timeout_s=1800.0,
            )
            print(
                f"{name} {stage}: {res['peak_b_px']:.1f} B/px ({res['peak_mb']:.0f} MB), "
                f"{res['s']:.1f} s",
                flush=True,
            )
            cases.append(res)
    done = {(c["case"], c["stage"]) for c in cases}
    cases = [c for c in kept if (c["case"], c["stage"]) not in done] + cases
    write_json(out, {"machine": info, "robot_radius_m": RADIUS_M, "cases": cases})
    table = report(cases)
    print(table)
    if args.markdown:
        write_text(args.markdown, table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
