"""Benchmark: peak memory of ``tj.route_graph`` (r = 0.3 m) on large maps.

Each case runs in a fresh process: ``import topojax``, one route graph of the bundled
Intel map (the kernels compile), then the case's map is loaded and ``route_graph`` is
measured alone: the peak growth of the resident set over the RSS before the call (sampled
every millisecond, and the kernel's ``VmHWM`` where it can be reset), per map pixel, and
the call's time.  Cases: the PAL office (3.5 Mpx at 0.025 m), the Nav2 warehouse, and the
synthetic floor plans of ``bench_memory.py`` of 4000 and 8000 px a side (0.05 m).

Run from the repository root::

    python bench/bench_route_graph_memory.py                  # all cases, ~4 minutes
    python bench/bench_route_graph_memory.py --cases warehouse floor_4000
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

#: Real maps of the benchmark: name -> file under the data folder.
REAL = {
    "pal_office_7th_floor": "maps/ros/pal_office_7th_floor/map.yaml",
    "warehouse": "maps/simulated/nav2/warehouse.yaml",
}
CASES = (*REAL, "floor_4000", "floor_8000")
RADIUS_M = 0.3


def case_map(name: str, data: Path):
    """The OccupancyMap of a case: a real map file or ``floor_<side px>``."""
    from topojax.maps import load_map

    if name in REAL:
        return load_map(data / REAL[name])
    kind, _, side = name.partition("_")
    if kind != "floor" or not side.isdigit():
        raise SystemExit(
            f"--cases: expected one of {', '.join(REAL)} or floor_<side px>, got {name!r}"
        )
    from bench_memory import make_case_map

    return make_case_map(name, REPO_ROOT, data)


def worker(name: str, data: Path, limit_gb: float) -> None:
    """Measure one case in this (fresh) process; print one JSON line."""
    use_checkout()
    from memory_cases import Measure

    import topojax as tj

    tj.route_graph(
        tj.load_map(REPO_ROOT / "topojax/data/intel.png", resolution_m=0.05),
        robot_radius_m=RADIUS_M,
    )
    occ = case_map(name, data)
    measure = Measure(limit_gb)
    graph, m = measure(lambda: tj.route_graph(occ, robot_radius_m=RADIUS_M))
    measure.stop()
    px = int(occ.shape[0]) * int(occ.shape[1])
    print(
        json.dumps(
            {
                "case": name,
                "shape": list(occ.shape),
                "resolution_m": float(occ.resolution_m),
                "vertices": graph.number_of_nodes(),
                "edges": graph.number_of_edges(),
                "peak_mb": m["peak_mb"],
                "peak_b_px": m["peak_mb"] * 2**20 / px,
                "base_mb": m["base_mb"],
                "s": m["s"],
                "hwm_reset": measure.hwm_ok,
            }
        )
    )


def report(cases: list[dict]) -> str:
    rows = [
        (
            c["case"],
            f"{c['shape'][0]} x {c['shape'][1]}",
            c["vertices"],
            c["edges"],
            c["peak_mb"],
            c["peak_b_px"],
            c["s"],
        )
        for c in cases
    ]
    header = ("map", "pixels", "vertices", "edges", "peak growth MB", "B/px", "s")
    return markdown_table(header, rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), help=f"of {', '.join(CASES)}")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--limit-gb", type=float, default=14.0, help="RSS limit per case (GiB)")
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown table here")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(args.worker, args.data, args.limit_gb)
        return 0
    info = machine_info()
    cases = []
    for name in args.cases:
        res = run_cold_worker(
            Path(__file__),
            ["--worker", name, "--data", str(args.data), "--limit-gb", str(args.limit_gb)],
            timeout_s=1800.0,
        )
        print(f"{name}: {res['peak_mb']:.0f} MB peak growth, {res['s']:.1f} s", flush=True)
        cases.append(res)
    out = args.out or RESULTS_DIR / f"route_graph_memory_{machine_slug(info)}.json"
    write_json(out, {"machine": info, "robot_radius_m": RADIUS_M, "cases": cases})
    table = report(cases)
    print(table)
    if args.markdown:
        write_text(args.markdown, table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
