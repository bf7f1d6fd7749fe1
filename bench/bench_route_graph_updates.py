"""Benchmark of route-graph updates at 1 Hz while a robot maps (CARMEN logs, corrected poses).

Every log is replayed through :class:`topojax.IncrementalMapper` (default rates). Whenever
at least ``--every-s`` seconds of log time (1 s by default) have passed since the last
update, and after the last scan, the mapper's route graph is recomputed whole:
``mapper.route_graph(robot_radius_m=...)``, which exports the current map and builds its
route graph. For each update the benchmark keeps the time of that call, the time the
mapper spent on the scans since the previous update, the log time the update covers, and
the size of the map and the graph.

An update *keeps up* when mapping its scans plus the route graph took no longer than the
log time it covers: a robot that builds the route graph once a second on this machine
then never falls behind. Before the timed replays a warm-up replays the first 100 scans of
the first log with all of the mapper's loops and one route graph (the mapper's kernels
compile, the route graph's load from numba's cache); its route-graph time is reported as
*first* (cold, imports excluded).

Usage (from the repository root)::

    python bench/bench_route_graph_updates.py                  # intel, aces, fr079: ~10 min
    python bench/bench_route_graph_updates.py --logs intel     # ~3 min

Results: ``bench/results/route_graph_updates_<machine>.json``; the markdown table is
printed and, with ``--markdown FILE``, also written there.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import (  # noqa: E402
    DEFAULT_DATA,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    use_checkout,
    write_json,
    write_text,
)
from maps_route_graph import CARMEN_LOGS  # noqa: E402

use_checkout()

#: Log name -> file in ``logs/carmen_corrected``: the replays of the route-graph benchmark.
LOGS = {name.removeprefix("carmen_"): file for name, file in CARMEN_LOGS.items()}


def replay_with_updates(path: Path, radius_m: float, every_s: float) -> list[dict]:
    """Replay the log at ``path``; one record per route-graph update (see the module
    docstring)."""
    from topojax.incremental import IncrementalMapper
    from topojax.scans import read_carmen

    mapper = IncrementalMapper()
    updates: list[dict] = []
    scans = list(read_carmen(path))
    last_t = scans[0].timestamp
    mapping_s, n_scans = 0.0, 0
    for i, scan in enumerate(scans):
        t0 = time.perf_counter()
        mapper.add_scan(scan)
        mapping_s += time.perf_counter() - t0
        n_scans += 1
        covered = scan.timestamp - last_t
        if covered < every_s and i + 1 < len(scans):
            continue
        t1 = time.perf_counter()
        graph = mapper.route_graph(robot_radius_m=radius_m)
        route_s = time.perf_counter() - t1
        updates.append(
            {
                "scan": i,
                "log_s": covered,
                "scans": n_scans,
                "mapping_s": mapping_s,
                "route_graph_s": route_s,
                "shape": list(graph.graph["shape"]),
                "vertices": graph.number_of_nodes(),
                "edges": graph.number_of_edges(),
            }
        )
        last_t, mapping_s, n_scans = scan.timestamp, 0.0, 0
    return updates


def warm_up(path: Path, radius_m: float, n_scans: int = 100) -> float:
    """Replay the first ``n_scans`` of the log at ``path`` through every loop of the
    mapper, then build one route graph; returns that build's seconds."""
    from topojax.incremental import IncrementalMapper
    from topojax.scans import read_carmen

    mapper = IncrementalMapper()
    for i, scan in enumerate(read_carmen(path)):
        if i == n_scans:
            break
        mapper.add_scan(scan)
    mapper.update_graph()
    t0 = time.perf_counter()
    mapper.route_graph(robot_radius_m=radius_m)
    return time.perf_counter() - t0


def summary(updates: list[dict], every_s: float) -> dict:
    """Statistics of the updates."""
    route = np.array([u["route_graph_s"] for u in updates])
    busy = np.array([u["route_graph_s"] + u["mapping_s"] for u in updates])
    # the last update may cover less than every_s of log time: it is not a 1 Hz tick
    ticks = [u for u in updates if u["log_s"] >= every_s]
    behind = sum(u["route_graph_s"] + u["mapping_s"] > u["log_s"] for u in ticks)
    worst = max(updates, key=lambda u: u["route_graph_s"])
    return {
        "updates": len(updates),
        "route_graph_p50_s": float(np.median(route)),
        "route_graph_p90_s": float(np.percentile(route, 90)),
        "route_graph_max_s": float(route.max()),
        "worst_shape": worst["shape"],
        "busy_p50_s": float(np.median(busy)),
        "busy_max_s": float(busy.max()),
        "updates_behind": int(behind),
        "log_s": float(sum(u["log_s"] for u in updates)),
        "compute_s": float(busy.sum()),
        "final": {k: updates[-1][k] for k in ("shape", "vertices", "edges")},
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    ap.add_argument("--logs", default=",".join(LOGS), help=f"comma list of {sorted(LOGS)}")
    ap.add_argument("--radius", type=float, default=0.3, help="robot radius (m)")
    ap.add_argument("--every-s", type=float, default=1.0, help="log seconds between updates")
    ap.add_argument("--out", type=Path, default=None, help="results JSON path")
    ap.add_argument("--markdown", type=Path, default=None, help="also write the table here")
    args = ap.parse_args(argv)
    names = [n.strip() for n in args.logs.split(",") if n.strip()]
    unknown = sorted(set(names) - set(LOGS))
    if unknown:
        ap.error(f"--logs: unknown {unknown}; expected names from {sorted(LOGS)}")
    if not (args.radius >= 0 and args.every_s > 0):
        ap.error("--radius must be >= 0 and --every-s > 0")

    info = machine_info()
    logs = {name: args.data / "logs" / "carmen_corrected" / LOGS[name] for name in names}
    first_s = warm_up(logs[names[0]], args.radius)
    results = {}
    for name, path in logs.items():
        t0 = time.perf_counter()
        updates = replay_with_updates(path, args.radius, args.every_s)
        results[name] = {"summary": summary(updates, args.every_s), "updates": updates}
        s = results[name]["summary"]
        print(
            f"[{name}] {s['updates']} updates in {time.perf_counter() - t0:.0f} s: route graph "
            f"p50 {s['route_graph_p50_s']:.3f} s, max {s['route_graph_max_s']:.3f} s, "
            f"{s['updates_behind']} behind",
            flush=True,
        )

    header = [
        "log",
        "updates",
        "route graph s (p50)",
        "p90",
        "max",
        "map px at max",
        "mapping + graph s (max)",
        "behind",
        "compute / log time",
        "final V / E",
    ]
    rows = []
    for name, r in results.items():
        s = r["summary"]
        rows.append(
            [
                name,
                s["updates"],
                s["route_graph_p50_s"],
                s["route_graph_p90_s"],
                s["route_graph_max_s"],
                "{} x {}".format(*s["worst_shape"]),
                s["busy_max_s"],
                s["updates_behind"],
                s["compute_s"] / s["log_s"],
                "{} / {}".format(s["final"]["vertices"], s["final"]["edges"]),
            ]
        )
    table = markdown_table(header, rows)
    print(f"first route graph of the process: {first_s:.2f} s\n\n{table}")
    out = args.out or RESULTS_DIR / f"route_graph_updates_{machine_slug(info)}.json"
    write_json(
        out,
        {
            "machine": info,
            "args": {k: str(v) for k, v in vars(args).items()},
            "first_update_s": first_s,
            "logs": results,
        },
    )
    if args.markdown:
        write_text(args.markdown, table + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
