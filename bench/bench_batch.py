"""Benchmark: batch throughput of :func:`topojax.batch.build_graphs` vs a sequential loop.

The job is every map under ``--maps-dir`` (default ``../shared/data/maps``, expanded like
``topojax batch`` does: folders searched recursively, an image referenced by a YAML counted
once) plus the three paper maps repeated until there are at least ``--min-maps`` maps
(default 100).  Maps that fail to load are excluded and listed.  The same job runs in
several *modes*, each in its own fresh subprocess so that one cannot warm another, all in
the same invocation and one after the other (so load from other processes hits them alike):

``sequential``
    ``for p in paths: build_graph(load_map(p))`` in one process: the baseline.
``batch-1`` / ``batch-2``
    ``build_graphs(paths, workers=W)``: kernels batched in the parent (``kernel_threads``
    default = cores), thinning and graphs in ``W`` worker processes (the default executor).
``batch-0``
    ``build_graphs(paths, workers=0)``: the same, CPU stages in the parent's main thread
    (no worker processes; shows what the processes cost).
``per-worker-2``
    The alternative design: two worker processes, each running the whole ``load_map`` +
    ``build_graph`` for its share of the maps (each worker imports JAX and compiles its own
    kernel).

In each subprocess the job runs twice: **cold** (first run after the imports: includes JAX
compilation, the start of the worker pool / fork server, numba cache loads) and **warm**
(the same job again in the same process).  For each run we record wall time, maps/s and
megapixels/s, the CPU seconds of the process tree (psutil; shows the overheads independently
of the load other processes put on the machine), and ``trace_counts()`` before and after (a
batch run that traces the kernel more than once per bucket fails the benchmark).  Every mode
must produce the same per-map vertex/edge counts and total lengths as ``sequential``.

Kernel scaling (full run, or ``--modes kernels-...``): the JAX stage alone
(``dense_fields_many`` over groups of 4 maps, maps loaded beforehand, warm) dispatched from
one thread (``kernels-1thread``), from two threads at once (``kernels-2threads``), and from
one thread in a process pinned to a single core (``kernels-1core``).  CPU seconds over wall
seconds of ``kernels-1thread`` show how much XLA already parallelises one kernel call
across cores on its own, which bounds what batching can add on a CPU.

With ``--outputs`` the job also writes the graph files (GraphML, JSON, GeoJSON) of every map
to a temporary folder: ``sequential+out`` (``save_graph`` x 3 after each ``build_graph``) vs
``batch-2+out``.

With ``--route`` the job is the route graphs of every map for a robot of radius 0.3 m
(:func:`topojax.route_graph`), written as GraphML, JSON and GeoJSON, instead:
``sequential+route`` (``route_graph(load_map(p))`` and ``save_graph`` x 3 per map) vs
``batch-2+route`` (``build_graphs(paths, workers=2, formats="route")``, which builds the
paper's graph of every map too).  Every map's route-graph vertex and edge counts must
match.

Results go to ``bench/results/batch_<machine>.json`` (``batch_route_<machine>.json``
with ``--route``); a markdown summary is printed.

Run from the repository root::

    python bench/bench_batch.py --quick      # 30 maps, cold+warm, no outputs; ~2 min
    python bench/bench_batch.py              # >= 100 maps, all modes + outputs; < 10 min
    python bench/bench_batch.py --route      # >= 100 maps, route graphs; ~5 min
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    RESULTS_DIR,
    load_average,
    machine_info,
    machine_slug,
    markdown_table,
    run_cold_worker,
    use_checkout,
    write_json,
)

SCRIPT = Path(__file__).resolve()
DEFAULT_MAPS = DEFAULT_DATA / "maps"
MODES = ("sequential", "batch-1", "batch-2", "batch-0", "per-worker-2")
OUTPUT_MODES = ("sequential+out", "batch-2+out")
ROUTE_MODES = ("sequential+route", "batch-2+route")
#: Robot radius of the route modes (m).
ROUTE_RADIUS_M = 0.3
KERNEL_MODES = ("kernels-1thread", "kernels-2threads", "kernels-1core")


# ------------------------------------------------------------------------------ helpers


class TreeCpu:
    """Approximate CPU seconds (user + system) of this process and all its descendants.

    Descendants (worker processes, the fork server) are sampled every 0.1 s while
    :meth:`running`; each process counts with its last sample, so one that exits loses at
    most its last 0.1 s.  (``children_*`` times and ``RUSAGE_CHILDREN`` are not added: they
    would count the sampled workers a second time once they are reaped.)
    """

    def __init__(self) -> None:
        import psutil

        self._psutil = psutil
        self._me = psutil.Process()
        self._seen: dict[int, float] = {}
        self._lock = threading.Lock()

    def _sample(self) -> None:
        for proc in self._me.children(recursive=True):
            try:
                t = proc.cpu_times()
            except self._psutil.Error:
                continue
            with self._lock:
                self._seen[proc.pid] = t.user + t.system

    def total(self) -> float:
        self._sample()
        me = self._me.cpu_times()
        with self._lock:
            kids = sum(self._seen.values())
        return me.user + me.system + kids

    def running(self):
        stop = threading.Event()

        def loop() -> None:
            while not stop.wait(0.1):
                self._sample()

        thread = threading.Thread(target=loop, daemon=True)
        thread.start()
        return stop, thread


def _per_worker_task(index: int, path: str, out_dir: str | None) -> tuple[int, int, float]:
    """Alternative design: one whole build_graph (JAX included) inside a worker."""
    from topojax.graph import graph_summary
    from topojax.maps import load_map
    from topojax.pipeline import build_graph

    result = build_graph(load_map(path))
    if out_dir is not None:
        _save_all(result.graph, out_dir, index, path)
    s = graph_summary(result.graph)
    return int(s["n_vertices"]), int(s["n_edges"]), float(s["total_length_m"])


def _save_all(graph: Any, out_dir: str, index: int, path: str) -> None:
    from topojax.io import save_graph

    stem = Path(out_dir) / f"{index:04d}_{Path(path).stem}"
    for suffix in (".graphml", ".json", ".geojson"):
        save_graph(graph, f"{stem}{suffix}")


def _kernel_job(mode: str, paths: list[str], tiles_per_call: int) -> list[list[Any]]:
    """JAX stage only, over groups of 4 preloaded maps; returns per-map ridge pixel counts."""
    import concurrent.futures as cf

    from topojax.maps import load_map
    from topojax.pipeline import dense_fields_many

    obstacles = [load_map(p).occupied for p in paths]
    groups = [obstacles[i : i + 4] for i in range(0, len(obstacles), 4)]

    def run(group: list[Any]) -> list[int]:
        fields = dense_fields_many(group, tiles_per_call=tiles_per_call)
        return [int(f.ridges.sum()) for f in fields]

    run(groups[0])  # compile + warm outside the timing
    threads = 2 if mode == "kernels-2threads" else 1
    c0, t0 = time.process_time(), time.perf_counter()
    with cf.ThreadPoolExecutor(threads) as ex:
        counts = [c for group in ex.map(run, groups) for c in group]
    _KERNEL_TIMES.append((time.perf_counter() - t0, time.process_time() - c0))
    return [[c] for c in counts]


_KERNEL_TIMES: list[tuple[float, float]] = []  # (wall s, process CPU s) of kernel jobs


def _run_job(
    mode: str, paths: list[str], out_dir: str | None, tiles_per_call: int | None
) -> list[list[Any]]:
    """Run one mode over all paths; return per-map [vertices, edges, total_length_m]."""
    if mode.startswith("kernels-"):
        return _kernel_job(mode, paths, tiles_per_call or 16)
    if mode in ROUTE_MODES:
        return _route_job(mode, paths, out_dir, tiles_per_call)
    base = mode.removesuffix("+out")
    if base == "sequential":
        from topojax.graph import graph_summary
        from topojax.maps import load_map
        from topojax.pipeline import build_graph

        rows = []
        for i, p in enumerate(paths):
            result = build_graph(load_map(p))
            if out_dir is not None:
                _save_all(result.graph, out_dir, i, p)
            s = graph_summary(result.graph)
            rows.append([s["n_vertices"], s["n_edges"], s["total_length_m"]])
        return rows
    if base.startswith("batch-"):
        from topojax.batch import build_graphs

        workers = int(base.split("-")[1])
        records = build_graphs(
            paths,
            workers=workers,
            out_dir=out_dir,
            progress=False,
            keep_graphs=False,
            tiles_per_call=tiles_per_call,
        )
        # a map without an occupied pixel has an empty graph (status "empty"), in every mode
        bad = [f"{r.map}: {r.message}" for r in records if r.status not in ("ok", "empty")]
        if bad:
            raise RuntimeError(f"batch mode {mode} had failures: {bad[:5]}")
        return [[r.vertices or 0, r.edges or 0, r.total_length_m or 0.0] for r in records]
    if base.startswith("per-worker-"):
        import concurrent.futures as cf

        from topojax.batch import worker_context

        workers = int(base.split("-")[2])
        # same start method as the batch workers (fork server that has imported topojax)
        with cf.ProcessPoolExecutor(workers, mp_context=worker_context()) as ex:
            futures = [ex.submit(_per_worker_task, i, p, out_dir) for i, p in enumerate(paths)]
            return [list(f.result()) for f in futures]
    raise ValueError(f"unknown mode {mode!r}")


def _route_job(
    mode: str, paths: list[str], out_dir: str | None, tiles_per_call: int | None
) -> list[list[Any]]:
    """The route graphs of all paths, written to ``out_dir``; per-map [vertices, edges]."""
    assert out_dir is not None
    if mode == "sequential+route":
        from topojax.io import save_graph
        from topojax.maps import load_map
        from topojax.routegraph import route_graph

        rows = []
        for i, p in enumerate(paths):
            graph = route_graph(load_map(p), robot_radius_m=ROUTE_RADIUS_M)
            stem = Path(out_dir) / f"{i:04d}_{Path(p).stem}_route"
            for suffix in (".graphml", ".json", ".geojson"):
                save_graph(graph, f"{stem}{suffix}")
            rows.append([graph.number_of_nodes(), graph.number_of_edges()])
        return rows
    from topojax.batch import build_graphs
    from topojax.routegraph import RouteGraphConfig

    records = build_graphs(
        paths,
        workers=2,
        out_dir=out_dir,
        formats="route",
        route_config=RouteGraphConfig(robot_radius_m=ROUTE_RADIUS_M),
        progress=False,
        keep_graphs=False,
        tiles_per_call=tiles_per_call,
    )
    bad = [f"{r.map}: {r.message}" for r in records if r.status not in ("ok", "empty")]
    if bad:
        raise RuntimeError(f"batch mode {mode} had failures: {bad[:5]}")
    return [[r.route_vertices, r.route_edges] for r in records]


def _worker_main(args: argparse.Namespace) -> None:
    """Subprocess side: run the job cold, then warm; print one JSON line."""
    if args.mode == "kernels-1core":
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # before JAX starts
    use_checkout()
    import jax

    from topojax.pipeline import trace_counts

    paths = json.loads(Path(args.list).read_text())
    megapixels = float(args.megapixels)
    tree = TreeCpu()
    runs = []
    rows = None
    for label in ("cold", "warm")[: args.runs]:
        writes = args.mode.endswith(("+out", "+route"))
        out_dir = tempfile.mkdtemp(prefix="topojax-bench-") if writes else None
        before = trace_counts()
        stop, thread = tree.running()
        cpu0 = tree.total()
        t0 = time.perf_counter()
        rows = _run_job(args.mode, paths, out_dir, args.tiles_per_call)
        wall = time.perf_counter() - t0
        cpu = tree.total() - cpu0
        if args.mode.startswith("kernels-"):  # loading excluded: time the kernels only
            wall, cpu = _KERNEL_TIMES[-1]
        stop.set()
        thread.join()
        after = trace_counts()
        runs.append(
            {
                "run": label,
                "wall_s": wall,
                "cpu_s": cpu,
                "maps_per_s": len(paths) / wall,
                "megapixels_per_s": megapixels / wall,
                "traces_before": before,
                "traces_after": after,
                "load_average_end": load_average(),
            }
        )
        if out_dir is not None:
            import shutil

            shutil.rmtree(out_dir, ignore_errors=True)
    print(
        json.dumps(
            {
                "mode": args.mode,
                "runs": runs,
                "rows": rows,
                "jax_devices": [str(d) for d in jax.devices()],
            }
        )
    )


def _probe(paths: list[str]) -> tuple[list[str], list[dict[str, str]], float]:
    """Load every map once: keep the loadable ones, list the failures, count megapixels."""
    from topojax.maps import load_map

    good, failed, mp = [], [], 0.0
    for p in paths:
        try:
            m = load_map(p)
        except Exception as exc:  # a benchmark input that cannot be read is listed
            failed.append({"path": p, "error": f"{type(exc).__name__}: {exc}"})
            continue
        good.append(p)
        mp += m.shape[0] * m.shape[1] / 1e6
    return good, failed, mp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="30 maps, no outputs, fewer modes")
    parser.add_argument("--maps-dir", type=Path, default=DEFAULT_MAPS)
    parser.add_argument("--min-maps", type=int, default=None, help="pad with paper maps")
    parser.add_argument("--outputs", action=argparse.BooleanOptionalAction, default=None)
    parser.add_argument(
        "--modes",
        nargs="+",
        default=None,
        choices=MODES + OUTPUT_MODES + KERNEL_MODES + ROUTE_MODES,
    )
    parser.add_argument("--route", action="store_true", help="route graphs (ROUTE_MODES)")
    parser.add_argument("--runs", type=int, default=2, choices=(1, 2), help="cold [+ warm]")
    parser.add_argument("--json", type=Path, default=None, help="results file")
    parser.add_argument(
        "--tiles-per-call", type=int, default=None, help="kernel bucket (e.g. 64 on a GPU)"
    )
    # subprocess side
    parser.add_argument("--mode", help=argparse.SUPPRESS)
    parser.add_argument("--list", help=argparse.SUPPRESS)
    parser.add_argument("--megapixels", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.mode:
        _worker_main(args)
        return

    use_checkout()
    from topojax.batch import expand_map_inputs

    t_start = time.perf_counter()
    info = machine_info()
    all_paths = [str(p) for p in expand_map_inputs([args.maps_dir])]
    paper = [p for p in all_paths if Path(p).parent.name == "paper"]
    min_maps = args.min_maps if args.min_maps is not None else (30 if args.quick else 100)
    if args.quick:
        # a mix: the paper maps plus every third other map, up to min_maps
        others = [p for p in all_paths if p not in paper][::3]
        all_paths = (paper + others)[:min_maps]
    for p in itertools.cycle(paper or all_paths):
        if len(all_paths) >= min_maps:
            break
        all_paths.append(p)
    paths, failed, megapixels = _probe(all_paths)
    if args.modes:
        modes = list(args.modes)
    elif args.route:
        modes = list(ROUTE_MODES)
    else:
        modes = list(MODES[:3] if args.quick else MODES)
        if args.outputs if args.outputs is not None else not args.quick:
            modes += list(OUTPUT_MODES)
        if not args.quick:
            modes += list(KERNEL_MODES)

    with tempfile.TemporaryDirectory() as tmp:
        list_file = Path(tmp) / "paths.json"
        list_file.write_text(json.dumps(paths))
        results: dict[str, Any] = {}
        for mode in modes:
            print(f"[bench_batch] {mode} ...", file=sys.stderr, flush=True)
            extra = ["--tiles-per-call", str(args.tiles_per_call)] if args.tiles_per_call else []
            runs = 1 if mode in KERNEL_MODES else args.runs
            results[mode] = run_cold_worker(
                SCRIPT,
                [
                    "--mode",
                    mode,
                    "--list",
                    str(list_file),
                    "--megapixels",
                    repr(megapixels),
                    "--runs",
                    str(runs),
                    *extra,
                ],
                timeout_s=600,
            )

    def family(mode: str) -> str:
        if mode in KERNEL_MODES:
            return "kernels-1thread"
        if mode in ROUTE_MODES:
            return "sequential+route"
        return "sequential+out" if mode.endswith("+out") else "sequential"

    # correctness: every mode equals its family's reference, map by map
    mismatches = {}
    for mode, res in results.items():
        reference = results.get(family(mode), {}).get("rows")
        if reference is not None and res["rows"] != reference:
            diff = [
                i for i, (a, b) in enumerate(zip(res["rows"], reference, strict=True)) if a != b
            ]
            mismatches[mode] = [paths[i] for i in diff[:10]]
    # no recompilation after the first batch of the bucket (cold: one trace, warm: none)
    recompiled = {}
    for mode, res in results.items():
        if mode.startswith("batch"):
            for run in res["runs"]:
                grew = {
                    k: v - run["traces_before"].get(k, 0)
                    for k, v in run["traces_after"].items()
                    if v - run["traces_before"].get(k, 0) > (1 if run["run"] == "cold" else 0)
                }
                if grew:
                    recompiled[f"{mode}/{run['run']}"] = grew

    def find(mode: str, run: str) -> dict[str, Any] | None:
        for r in results.get(mode, {}).get("runs", []):
            if r["run"] == run:
                return r
        return None

    summary_rows = []
    speedups: dict[str, dict[str, float]] = {}
    for mode in modes:
        for r in results[mode]["runs"]:
            ref = find(family(mode), "cold" if mode in KERNEL_MODES else r["run"])
            speed = ref["wall_s"] / r["wall_s"] if ref else float("nan")
            label = "warm (kernels only)" if mode in KERNEL_MODES else r["run"]
            speedups.setdefault(label, {})[mode] = speed
            summary_rows.append(
                [
                    label,
                    mode,
                    r["wall_s"],
                    r["maps_per_s"],
                    r["megapixels_per_s"],
                    r["cpu_s"],
                    r["cpu_s"] / r["wall_s"],
                    f"{speed:.2f} x {family(mode)}",
                ]
            )
    summary_rows.sort(
        key=lambda row: ("cold", "warm").index(row[0]) if row[0] in ("cold", "warm") else 2
    )
    table = markdown_table(
        ["run", "mode", "wall s", "maps/s", "Mpx/s", "CPU s", "cores busy", "speed-up"],
        summary_rows,
    )
    data = {
        "benchmark": "batch",
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": info,
        "quick": bool(args.quick),
        "n_maps": len(paths),
        "megapixels": megapixels,
        "maps": paths,
        "load_failures": failed,
        "modes": {m: {k: v for k, v in r.items() if k != "rows"} for m, r in results.items()},
        "speedup": speedups,
        "mismatches": mismatches,
        "recompilations": recompiled,
        "bench_wall_s": time.perf_counter() - t_start,
    }
    out = (
        args.json
        or RESULTS_DIR
        / f"batch{'_route' if args.route else ''}_{machine_slug(info)}{'_quick' if args.quick else ''}.json"
    )
    write_json(out, data)
    print(
        f"{len(paths)} maps, {megapixels:.1f} Mpx ({len(failed)} load failures); "
        f"jax devices {info.get('jax_devices')}; load average {info.get('load_average')}"
    )
    print(table)
    if mismatches:
        print(f"MISMATCH vs the reference mode: {mismatches}")
    if recompiled:
        print(f"RECOMPILED after the first batch: {recompiled}")
    print(f"wrote {out} ({time.perf_counter() - t_start:.0f} s)")
    if mismatches or recompiled:
        sys.exit(1)


if __name__ == "__main__":
    main()
