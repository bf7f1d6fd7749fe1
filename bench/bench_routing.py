"""Benchmark: route queries on topology graphs (``tj.RoutePlanner`` and its ``route``, which
``tj.plan_route`` wraps).

For each map, on its full graph (the paper's), on that graph pruned of spurs under 0.5 m
and pieces under 2 m (``tj.prune_graph``), and on its route graph for a robot of radius
0.3 m (``tj.route_graph``) with a planner that knows only the graph and one given the map
(``RoutePlanner(graph, occupancy=map)``: each end may join the graph at the nearest point
of any edge in sight within 1 m):

* **build**: ``RoutePlanner(graph)`` plus its k-d tree (the first query's extra cost),
  and with the map the robot's feasible space, warm median over ``--repeats`` builds;
* **query**: one ``planner.route(start, goal)`` between two random points near the
  graph's corridors (up to 1 m off, off the map's obstacles), warm median and 90th percentile over ``--queries``
  pairs, with the share of pairs that have a route (the others raise ``NoRouteError``,
  or, with the map, ``ValueError`` for an end that sees no edge off the obstacles: timed
  too, and the share of the latter), and the median length of the routes (straight legs
  to and from the graph included);
* **cold**: in a fresh process, ``import topojax``, read the graph from JSON, build the
  planner and answer one query (SciPy's k-d tree module is imported on first use).

Run from the repository root::

    python bench/bench_routing.py                 # paper maps + the larger maps
    python bench/bench_routing.py --quick         # paper maps only
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    LARGE_MAPS,
    PAPER_MAPS,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    median,
    ms,
    run_cold_worker,
    use_checkout,
    write_json,
    write_text,
)

#: The larger maps timed here (of the pipeline benchmark's): two large ROS maps, one
#: simulated warehouse.
ROUTING_MAPS = ("edmonton_0.06", "pal_office_7th_floor", "warehouse")
#: The graphs timed per map, in table order.
LABELS = ("full", "pruned", "route graph", "route graph + map")


def graph_rows(full, pruned, rg):
    """``(label, graph, planner given the map)`` per row of :data:`LABELS`."""
    return zip(LABELS, (full, pruned, rg, rg), (False, False, False, True), strict=True)


def query_pairs(graph, n: int, seed: int, occupancy) -> np.ndarray:
    """``n`` (start, goal) world points: random corridor pixels moved up to 1 m, off the
    map's obstacles (a planner given the map refuses a point on one)."""
    rng = np.random.default_rng(seed)
    xy = np.concatenate([d["world"] for _, _, d in graph.edges(data=True)])
    occupied = occupancy.occupied
    out = np.empty((0, 2, 2))
    while len(out) < n:
        picks = xy[rng.integers(len(xy), size=(n, 2))]
        picks = picks + rng.uniform(-1.0, 1.0, size=picks.shape)
        r, c = (
            np.floor(v + 0.5).astype(np.int64)
            for v in occupancy.world_to_pixel(picks[..., 0], picks[..., 1])
        )
        inside = (r >= 0) & (r < occupied.shape[0]) & (c >= 0) & (c < occupied.shape[1])
        on_wall = np.zeros(r.shape, bool)
        on_wall[inside] = occupied[r[inside], c[inside]]
        out = np.concatenate([out, picks[~on_wall.any(axis=1)]])
    return out[:n]


def bench_graph(graph, occupancy, *, repeats: int, queries: int, with_map: bool) -> dict:
    import topojax as tj

    builds = []
    for _ in range(repeats + 1):
        t0 = time.perf_counter()
        planner = tj.RoutePlanner(graph, occupancy=occupancy if with_map else None)
        planner._tree("world")  # the k-d tree the first query builds
        builds.append(time.perf_counter() - t0)
    times, lengths, refused = [], [], 0
    for start, goal in query_pairs(graph, queries + 1, graph.number_of_edges(), occupancy):
        t0 = time.perf_counter()
        try:
            r = planner.route(start, goal)
            lengths.append(r.start_snap_m + r.length_m + r.goal_snap_m)
        except tj.NoRouteError:
            pass
        except ValueError:  # with the map: an end in a pocket the graph does not reach
            if not with_map:
                raise
            refused += 1
        times.append(time.perf_counter() - t0)
    n_routed = len(lengths)
    n_all = len(times)
    times = times[1:]  # the first query warms Python's caches
    return {
        "vertices": graph.number_of_nodes(),
        "edges": graph.number_of_edges(),
        "corridor_px": int(sum(len(d["path"]) for _, _, d in graph.edges(data=True))),
        "build_ms": ms(median(builds[1:])),
        "query_median_ms": ms(median(times)),
        "query_p90_ms": ms(float(np.percentile(times, 90))),
        "routed_share": round(n_routed / n_all, 3),
        "refused_share": round(refused / n_all, 3),
        "route_median_m": round(median(lengths), 3) if lengths else None,
    }


def cold_worker(graph_file: str, map_file: str, with_map: bool) -> None:
    t0 = time.perf_counter()
    import topojax as tj

    t1 = time.perf_counter()
    graph = tj.load_graph(graph_file)
    occupancy = tj.load_map(map_file) if with_map else None
    load = time.perf_counter() - t1
    pairs = query_pairs(graph, 1, 0, occupancy or tj.load_map(map_file))  # not timed
    start, goal = pairs[0]
    t2 = time.perf_counter()
    planner = tj.RoutePlanner(graph, occupancy=occupancy)
    try:
        planner.route(start, goal)
    except (tj.NoRouteError, ValueError):  # no route, or (with the map) an end in a pocket
        pass
    t3 = time.perf_counter()
    print(json.dumps({"import_ms": ms(t1 - t0), "load_ms": ms(load), "first_ms": ms(t3 - t2)}))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="paper maps only")
    parser.add_argument("--repeats", type=int, default=9, help="planner builds per graph")
    parser.add_argument("--queries", type=int, default=200, help="route queries per graph")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown report here")
    parser.add_argument("--cold-worker", help=argparse.SUPPRESS)
    parser.add_argument("--cold-map", help=argparse.SUPPRESS)
    parser.add_argument("--cold-with-map", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.cold_worker:
        cold_worker(args.cold_worker, args.cold_map, args.cold_with_map)
        return 0
    if args.repeats < 1 or args.queries < 1:
        parser.error(f"--repeats and --queries must be >= 1, got {args.repeats}, {args.queries}")
    use_checkout()
    import topojax as tj

    maps = dict(PAPER_MAPS)
    if not args.quick:
        maps.update({name: LARGE_MAPS[name] for name in ROUTING_MAPS})
    entries = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, rel in maps.items():
            occupancy = tj.load_map(args.data / rel)
            full = tj.build_graph(occupancy).graph
            pruned = tj.prune_graph(full, min_spur_m=0.5, min_component_m=2.0)
            rg = tj.route_graph(occupancy, robot_radius_m=0.3)
            entry = {}
            for label, graph, with_map in graph_rows(full, pruned, rg):
                entry[label] = bench_graph(
                    graph, occupancy, repeats=args.repeats, queries=args.queries, with_map=with_map
                )
                path = tj.save_graph(graph, Path(tmp) / f"{name}_{label}.json")
                script = Path(__file__).resolve()
                extra = ["--cold-map", str(args.data / rel)] + ["--cold-with-map"] * with_map
                entry[label]["cold"] = run_cold_worker(script, ["--cold-worker", str(path), *extra])
                print(name, label, entry[label], flush=True)
            entries[name] = entry
    rows = [
        [
            name,
            label,
            e[label]["vertices"],
            e[label]["edges"],
            e[label]["build_ms"],
            e[label]["query_median_ms"],
            e[label]["query_p90_ms"],
            e[label]["routed_share"],
            e[label]["refused_share"],
            e[label]["route_median_m"],
            e[label]["cold"]["first_ms"],
        ]
        for name, e in entries.items()
        for label in LABELS
    ]
    info = machine_info()
    report = "\n".join(
        [
            f"Machine: {info.get('cpu_model', '?')}, {info.get('cpu_count', '?')} CPUs; "
            f"{args.repeats} builds and {args.queries} queries per graph.",
            "",
            markdown_table(
                [
                    "map",
                    "graph",
                    "vertices",
                    "edges",
                    "build ms",
                    "query ms (median)",
                    "query ms (p90)",
                    "routed",
                    "refused",
                    "route m (median)",
                    "cold: planner + first query ms",
                ],
                rows,
            ),
        ]
    )
    print(report)
    out = args.out or RESULTS_DIR / f"routing_{machine_slug(info)}.json"
    write_json(
        out,
        {
            "machine": info,
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "maps": entries,
        },
    )
    if args.markdown:
        write_text(args.markdown, report + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
