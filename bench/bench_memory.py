"""Benchmark: peak memory of :func:`topojax.build_graph` per map pixel.

Each case runs in fresh processes (:func:`run_case`), so no measurement inherits another's
heap.  In the process: imports, one warm-up ``build_graph`` on a small floor plan (the JAX
kernels compile and the numba caches load there, not in the measurement), then the case's
map is made; the resident set size (RSS) at that point is the baseline.  Then:

* **build**: ``build_graph(map)``; the peak RSS growth over the baseline, from the kernel's
  high-water mark (``VmHWM``, reset through ``/proc/self/clear_refs`` just before the call)
  and from a thread sampling ``/proc/self/statm`` every millisecond; the wall time; the peak
  growth inside each stage of ``timings_s`` (the sampled timeline cut at the stage times).
* **+ networkx**: then ``result.graph`` (built on first access where the result builds it
  lazily): the peak over both, and what stays resident with the result alive.
* **tracemalloc**: a second process runs the same with :mod:`tracemalloc` on (NumPy's
  buffers are traced; numba's and XLA's are not), reporting the traced peak per pixel.

Cases: the paper maps (``topojax/data``), the largest shared maps, synthetic floor plans (a
grid of rooms of 6 to 10 m, walls of 0.15 m, one door of 0.9 m in every wall between two
rooms; :func:`floor_plan`) and maps of 1 % random obstacle pixels (:func:`noise_map`).
Tiled cases (``--tiled``, ``--huge``): :func:`topojax.build_graph_tiled` on a map stored as
a tile folder under ``--tiles-dir`` (written once by the driver: a real map cut into
tiles of 256 px, or a floor plan drawn band by band, :class:`FloorPlanLayout`), the
graph's paths written to disk; the peak RSS growth as above (in MB and per map pixel),
the time, and whether :func:`topojax.build_graph` of the whole map gives the same graph
(maps up to 100 Mpx).  They go under ``tiled`` in the JSON.

Replay cases (``--replay``, ``replay_<log>``): a CARMEN log replayed into an
:class:`topojax.IncrementalMapper` with its defaults, then each of the mapper's dense
exports (``occupancy``, ``occupancy_window``, the fields, ``graph``, ``to_result``,
``route_graph``, ``save``) one at a time; batch cases (``--batch``, ``batch_<map>``,
``batch_pool2``): :func:`topojax.build_graphs` of one shared map in the process, and of all
of them with two worker processes.  Both are described in ``memory_cases.py``; they go
under ``replay`` and ``batch`` in the JSON.

Results go to ``bench/results/memory_<machine>.json`` under a label (``--label``, default
``after``), so the numbers of another checkout (``--root``, e.g. the base revision exported
with ``git archive``) sit beside them as ``before``; a markdown report is printed (and
written with ``--markdown``).

Run from the repository root::

    python bench/bench_memory.py --quick                    # paper maps, 2000 px plans, ~2 min
    python bench/bench_memory.py                            # + shared maps, plans to 8000 px
    python bench/bench_memory.py --large                    # + floor plans of 12000..20000 px
    python bench/bench_memory.py --cases floor_20000 --no-tracemalloc
    python bench/bench_memory.py --root /tmp/base --label before   # another checkout
    python bench/bench_memory.py --cases tiled_floor_40000 --budget-mb 256  # 1.6 GB on disk
    python bench/bench_memory.py --replay --batch            # replays and batches, ~2 min
    python bench/bench_memory.py --cases replay_intel batch_office_g
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    REPO_ROOT,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    ms,
    write_json,
    write_text,
)
from memory_cases import (  # noqa: E402
    BATCH_CASES,
    REPLAY_CASES,
    batch_map_worker,
    batch_pool_worker,
    batch_report,
    hwm_bytes,
    replay_report,
    replay_worker,
    reset_hwm,
    rss_bytes,
)

PAPER = {name: f"topojax/data/{name}.png" for name in ("intel", "office", "a_scan")}
#: The largest shared maps (relative to the data folder) and their load_map mode.
SHARED = {
    "office_g": ("maps/ipa/office_g.png", "ipa"),
    "DM_0.11": ("maps/slam_pgm/DM_0.11.pgm", None),
    "aces_0.10": ("maps/slam_pgm/aces_0.10.pgm", None),
    "edmonton_0.06": ("maps/slam_pgm/edmonton_0.06.pgm", None),
    "pal_office_7th_floor": ("maps/ros/pal_office_7th_floor/map.yaml", None),
}
FLOOR_SIDES = (2000, 4000, 8000)
FLOOR_SIDES_LARGE = (12000, 16000, 20000)
NOISE_SIDES = (2000, 4000, 8000)
#: Maps read block by block from tile folders (``--tiled``): real maps cut into tiles of
#: 256 px and read in blocks of 256 px (compared with build_graph's graph), and floor plans
#: (``--huge``: also the 40000 px one, 1.6 GB as uint8).
TILED_CASES = ("tiled_intel", "tiled_edmonton_0.06", "tiled_floor_8000")
TILED_HUGE = ("tiled_floor_40000",)
#: Pixel count up to which a tiled case is also run in memory and compared.
COMPARE_MAX_PX = 100_000_000
NOISE_FRACTION = 0.01
#: Side of the warm-up floor plan (more than one 256 px tile each way).
WARMUP_SIDE_PX = 600
SAMPLE_S = 0.001


# --------------------------------------------------------------------------- synthetic maps


class FloorPlanLayout:
    """The walls and doors of :func:`floor_plan`, drawn a window at a time (a plan larger
    than memory is written to disk band by band); also a reader of
    :class:`topojax.TiledMap` (``shape``, ``dtype``, ``read``) giving its grey image (0
    occupied, 254 free)."""

    def __init__(self, side_px: int, *, seed: int = 0, res_m: float = 0.05) -> None:
        import numpy as np

        rng = np.random.default_rng(seed)
        self.wall = wall = max(1, round(0.15 / res_m))
        door = max(2, round(0.9 / res_m))
        lo, hi = round(6.0 / res_m), round(10.0 / res_m)

        def lines() -> list[int]:
            pos, out = 0, [0]
            while True:
                pos += int(rng.integers(lo, hi + 1))
                if pos > side_px - lo:
                    return out + [side_px - wall]
                out.append(pos)

        self.rows, self.cols = rows, cols = lines(), lines()
        # (wall row, first door col) for every wall between two rooms, then (col, row)
        self.row_doors = [
            (r, int(rng.integers(a + wall + 2, b - door - 1)))
            for r in rows[1:-1]
            for a, b in zip(cols[:-1], cols[1:], strict=True)
        ]
        self.col_doors = [
            (c, int(rng.integers(a + wall + 2, b - door - 1)))
            for c in cols[1:-1]
            for a, b in zip(rows[:-1], rows[1:], strict=True)
        ]
        self.door = door
        self.shape = (side_px, side_px)
        self.dtype = np.dtype(np.uint8)

    def occupied(self, r0: int, r1: int, c0: int, c1: int):
        """Obstacle mask (bool) of the window ``[r0:r1, c0:c1]``."""
        import numpy as np

        occ = np.zeros((r1 - r0, c1 - c0), bool)
        wall, door = self.wall, self.door

        def span(a: int, n: int, lo: int, hi: int) -> slice:
            return slice(max(a, lo) - lo, max(lo, min(a + n, hi)) - lo)

        for r in self.rows:
            occ[span(r, wall, r0, r1), :] = True
        for c in self.cols:
            occ[:, span(c, wall, c0, c1)] = True
        for r, s in self.row_doors:
            occ[span(r, wall, r0, r1), span(s, door, c0, c1)] = False
        for c, s in self.col_doors:
            occ[span(s, door, r0, r1), span(c, wall, c0, c1)] = False
        return occ

    def read(self, r0: int, r1: int, c0: int, c1: int):
        import numpy as np

        return np.where(self.occupied(r0, r1, c0, c1), np.uint8(0), np.uint8(254))


def floor_plan(side_px: int, *, seed: int = 0, res_m: float = 0.05):
    """Obstacle mask (bool (side, side)) of a synthetic floor plan.

    A grid of rooms 6 to 10 m on a side (random per row and column of rooms) inside an
    outer wall; walls 0.15 m thick; every wall between two rooms has one door 0.9 m wide
    at a random place along it.  Deterministic for a given ``seed``.
    """
    return FloorPlanLayout(side_px, seed=seed, res_m=res_m).occupied(0, side_px, 0, side_px)


def noise_map(side_px: int, *, fraction: float = NOISE_FRACTION, seed: int = 0):
    """Obstacle mask (bool (side, side)) with each pixel an obstacle with probability
    ``fraction`` (made a band of rows at a time)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    occ = np.empty((side_px, side_px), bool)
    band = max(1, (1 << 22) // side_px)
    for r in range(0, side_px, band):
        n = min(band, side_px - r)
        occ[r : r + n] = rng.random((n, side_px), dtype=np.float32) < fraction
    return occ


def case_names(args: argparse.Namespace) -> list[str]:
    """The cases a run measures, in order."""
    if args.cases:
        return [c for item in args.cases for c in item.split(",") if c]
    if args.replay or args.batch:
        return list(REPLAY_CASES if args.replay else ()) + list(BATCH_CASES if args.batch else ())
    tiled = list(TILED_CASES if args.tiled or args.huge else ()) + list(
        TILED_HUGE if args.huge else ()
    )
    names = list(PAPER)
    if args.quick:
        return names + ["floor_2000", "noise_2000"] + tiled
    names += list(SHARED)
    names += [f"floor_{s}" for s in FLOOR_SIDES + (FLOOR_SIDES_LARGE if args.large else ())]
    return names + [f"noise_{s}" for s in NOISE_SIDES] + tiled


def case_class(name: str) -> str:
    if name in PAPER:
        return "paper"
    if name in SHARED:
        return "shared"
    return name.split("_")[0]


def make_case_map(name: str, root: Path, data: Path):
    """The OccupancyMap of a case."""
    from topojax.maps import OccupancyMap, load_map

    if name in PAPER:
        return load_map(root / PAPER[name], resolution_m=0.05)
    if name in SHARED:
        rel, mode = SHARED[name]
        return load_map(data / rel, mode=mode) if mode else load_map(data / rel)
    kind, _, side = name.partition("_")
    if kind not in ("floor", "noise") or not side.isdigit():
        raise ValueError(
            f"case {name!r}: expected a paper map {tuple(PAPER)}, a shared map "
            f"{tuple(SHARED)}, floor_<side px> or noise_<side px>"
        )
    occ = floor_plan(int(side)) if kind == "floor" else noise_map(int(side))
    # From masks directly: from_array would hold an image-sized copy on the way.
    return OccupancyMap(occupied=occ, free=~occ, unknown=_readonly_zeros(occ.shape))


def _readonly_zeros(shape):
    import numpy as np

    z = np.zeros(shape, bool)
    z.setflags(write=False)
    return z


# --------------------------------------------------------------------------- worker


class Sampler(threading.Thread):
    """Samples ``probe()`` every :data:`SAMPLE_S` seconds into a timeline; ends the process
    (exit status 3, one JSON line) when it exceeds ``limit``."""

    def __init__(self, probe, limit: float) -> None:
        super().__init__(daemon=True)
        self.probe, self.limit = probe, limit
        self.times: list[float] = []
        self.values: list[int] = []
        self.running = True

    def run(self) -> None:
        while self.running:
            v = self.probe()
            self.times.append(time.perf_counter())
            self.values.append(v)
            if v > self.limit:
                print(json.dumps({"error": f"memory limit {self.limit / 2**30:.1f} GiB passed"}))
                sys.stdout.flush()
                os._exit(3)
            time.sleep(SAMPLE_S)

    def peak(self, t0: float, t1: float) -> int:
        vals = [v for t, v in zip(self.times, self.values, strict=True) if t0 <= t <= t1]
        return max(vals) if vals else self.probe()


def stage_peaks(sampler: Sampler, t0: float, t1: float, timings: dict, base: int, px: int):
    """Peak growth (bytes per pixel) inside each stage of ``timings`` (run one after
    another from ``t0``; the last one ends at ``t1``) and the growth at its end."""
    out = {}
    names = [k for k in timings if k != "total"]
    start = t0
    for i, name in enumerate(names):
        end = t1 if i == len(names) - 1 else start + float(timings[name])
        after = sampler.peak(end, end + 0.01) if i < len(names) - 1 else sampler.peak(t1, t1)
        out[name] = {
            "peak_b_px": (sampler.peak(start, end) - base) / px,
            "end_b_px": (after - base) / px,
            "s": float(timings[name]),
        }
        start = end
    return out


def worker(args: argparse.Namespace) -> None:
    """One case in this fresh process; prints one JSON line."""
    root = Path(args.root).resolve() if args.root else REPO_ROOT
    sys.path.insert(0, str(root))
    t_start = time.perf_counter()
    import numpy as np

    import topojax
    from topojax.maps import OccupancyMap
    from topojax.pipeline import build_graph

    t_import = time.perf_counter()
    warm = floor_plan(WARMUP_SIDE_PX, seed=1)
    warm_map = OccupancyMap(occupied=warm, free=~warm, unknown=np.zeros_like(warm))
    build_graph(warm_map).graph.number_of_nodes()
    del warm, warm_map
    t_warm = time.perf_counter()
    occupancy = make_case_map(args.worker, root, Path(args.data))
    px = int(occupancy.occupied.size)
    gc.collect()
    t_map = time.perf_counter()

    traced = args.tracemalloc_run
    if traced:
        import tracemalloc

        tracemalloc.start()

        def probe() -> int:
            return tracemalloc.get_traced_memory()[0]
    else:
        probe = rss_bytes
    base = probe()
    limit = base + args.limit_gb * 2**30 if traced else args.limit_gb * 2**30
    hwm_ok = not traced and reset_hwm()
    sampler = Sampler(probe, limit)
    sampler.start()
    t0 = time.perf_counter()
    result = build_graph(occupancy)
    t1 = time.perf_counter()
    if traced:
        peak_build = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
    else:
        peak_build = max(sampler.peak(t0, t1), hwm_bytes() if hwm_ok else 0)
    graph = result.graph
    n_v, n_e = graph.number_of_nodes(), graph.number_of_edges()
    t2 = time.perf_counter()
    if traced:
        peak_all = max(peak_build, tracemalloc.get_traced_memory()[1])
    else:
        peak_all = max(sampler.peak(t0, t2), hwm_bytes() if hwm_ok else 0)
    resident = probe()
    sampler.running = False
    sampler.join()
    payload: dict[str, Any] = {
        "case": args.worker,
        "class": case_class(args.worker),
        "shape": list(occupancy.shape),
        "pixels": px,
        "vertices": n_v,
        "edges": n_e,
        "probe": "tracemalloc" if traced else "rss",
        "baseline_mb": round(base / 2**20, 1),
        "build_peak_b_px": (peak_build - base) / px,
        "with_networkx_peak_b_px": (peak_all - base) / px,
        "resident_b_px": (resident - base) / px,
        "build_s": t1 - t0,
        "networkx_s": t2 - t1,
        "timings_ms": {k: ms(v) for k, v in result.timings_s.items()},
        "stages": stage_peaks(sampler, t0, t1, result.timings_s, base, px),
        "import_s": t_import - t_start,
        "warmup_s": t_warm - t_import,
        "map_s": t_map - t_warm,
        "hwm_reset": hwm_ok,
        "topojax_file": topojax.__file__,
    }
    print(json.dumps(payload))


# --------------------------------------------------------------------------- tiled cases


def tiled_folder(name: str, args: argparse.Namespace) -> Path:
    """The tile folder of a tiled case, written (once) under ``--tiles-dir``: a floor plan
    drawn band by band, or a real map's grey image cut into 256 px tiles."""
    from topojax.maps.tiled import TILE_INDEX, TiledMap, save_tiled_map

    folder = Path(args.tiles_dir) / name
    if (folder / TILE_INDEX).is_file():
        return folder
    inner = name.removeprefix("tiled_")
    root = Path(args.root).resolve() if args.root else REPO_ROOT
    if inner.startswith("floor_"):
        source = TiledMap(FloorPlanLayout(int(inner.split("_")[1])))
        save_tiled_map(source, folder, tile_px=2048)
    else:
        save_tiled_map(make_case_map(inner, root, Path(args.data)), folder, tile_px=256)
    return folder


def tiled_worker(args: argparse.Namespace) -> None:
    """One tiled case in this fresh process: build_graph_tiled from its tile folder, the
    graph's paths written to disk; prints one JSON line."""
    import shutil
    import tempfile

    root = Path(args.root).resolve() if args.root else REPO_ROOT
    sys.path.insert(0, str(root))
    import numpy as np

    import topojax
    from topojax.maps.tiled import TiledMap
    from topojax.outofcore import build_graph_tiled

    warm = FloorPlanLayout(WARMUP_SIDE_PX, seed=1)
    build_graph_tiled(TiledMap(warm), block_px=256)
    del warm
    real = not args.worker.startswith("tiled_floor_")
    block_px = args.block_px or (256 if real else None)
    graph_dir = Path(tempfile.mkdtemp(prefix="topojax_graph_", dir=args.tiles_dir))
    gc.collect()
    base = rss_bytes()
    hwm_ok = reset_hwm()
    sampler = Sampler(rss_bytes, args.limit_gb * 2**30)
    sampler.start()
    t0 = time.perf_counter()
    result = build_graph_tiled(
        args.tiles, memory_budget_mb=args.budget_mb, block_px=block_px, out_dir=graph_dir
    )
    t1 = time.perf_counter()
    peak = max(sampler.peak(t0, t1), hwm_bytes() if hwm_ok else 0)
    sampler.running = False
    sampler.join()
    store = result.graph_store
    h, w = result.map.shape
    payload: dict[str, Any] = {
        "case": args.worker,
        "class": "tiled",
        "shape": [h, w],
        "pixels": h * w,
        "dense_uint8_mb": h * w / 2**20,
        "vertices": int(store.node_pixel.shape[0]),
        "edges": int(store.edge_u.shape[0]),
        "skeleton_px": int(result.cols.size),
        "blocks": result.blocks,
        "block_px": block_px,
        "halo_px": list(result.halo_px),
        "budget_mb": None if block_px else args.budget_mb,
        "baseline_mb": round(base / 2**20, 1),
        "build_peak_mb": (peak - base) / 2**20,
        "build_peak_b_px": (peak - base) / (h * w),
        "build_s": t1 - t0,
        "timings_ms": {k: ms(v) for k, v in result.timings_s.items()},
        "graph_on_disk_mb": sum(f.stat().st_size for f in graph_dir.iterdir()) / 2**20,
        "hwm_reset": hwm_ok,
        "topojax_file": topojax.__file__,
    }
    if h * w <= COMPARE_MAX_PX:
        payload["equal_in_memory"] = _same_as_in_memory(result, args, root, np)
    shutil.rmtree(graph_dir, ignore_errors=True)
    print(json.dumps(payload))


def _same_as_in_memory(result, args: argparse.Namespace, root: Path, np) -> bool:
    """Whether build_graph of the whole map (as the tiles hold it) gives the same graph."""
    from topojax.pipeline import build_graph

    inner = args.worker.removeprefix("tiled_")
    if inner.startswith("floor_"):
        occ = floor_plan(int(inner.split("_")[1]))
        from topojax.maps import OccupancyMap

        whole = OccupancyMap(occupied=occ, free=~occ, unknown=_readonly_zeros(occ.shape))
        del occ
    else:
        whole = result.map.occupancy()
    a, b = result.graph_store, build_graph(whole).graph_store
    fields = ("node_pixel", "node_kind", "node_world", "node_clearance_m", "edge_u", "edge_v")
    fields += ("path_offsets", "path_pixels", "path_world", "edge_length_m")
    fields += ("edge_min_clearance_m", "edge_mean_clearance_m")
    return all(np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True) for f in fields) and {
        k: v for k, v in a.attrs.items() if k != "source"
    } == {k: v for k, v in b.attrs.items() if k != "source"}


def tiled_report(results: dict[str, Any]) -> str:
    """Markdown table of the tiled cases."""
    cases = results.get("tiled", {}).get("cases", {})
    header = ["case", "Mpx", "uint8 map MB", "V", "E", "blocks", "block px", "halo px"]
    header += ["peak MB", "peak B/px", "s", "= build_graph"]
    rows = []
    for c, e in cases.items():
        if "error" in e:
            rows.append([c, e["error"]] + [""] * (len(header) - 2))
            continue
        eq = e.get("equal_in_memory")
        rows.append(
            [
                c,
                e["pixels"] / 1e6,
                e["dense_uint8_mb"],
                e["vertices"],
                e["edges"],
                e["blocks"],
                e["block_px"] or f"budget {e['budget_mb']:g} MB",
                ", ".join(str(v) for v in e["halo_px"]),
                e["build_peak_mb"],
                e["build_peak_b_px"],
                e["build_s"],
                "not run" if eq is None else ("yes" if eq else "NO"),
            ]
        )
    return markdown_table(header, rows)


# --------------------------------------------------------------------------- driver


def run_case(
    name: str, args: argparse.Namespace, *, traced: bool, timeout_s: float
) -> dict[str, Any]:
    """Run one case in a fresh ``nice``d process and return its JSON (or ``error``)."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", name]
    cmd += ["--data", str(args.data), "--limit-gb", str(args.limit_gb)]
    if args.root:
        cmd += ["--root", str(args.root)]
    if traced:
        cmd.append("--tracemalloc-run")
    if name.startswith("tiled_"):
        cmd += ["--tiles", str(tiled_folder(name, args)), "--tiles-dir", str(args.tiles_dir)]
        cmd += ["--budget-mb", str(args.budget_mb)]
        if args.block_px:
            cmd += ["--block-px", str(args.block_px)]
    env = dict(os.environ)
    root = str(Path(args.root).resolve()) if args.root else str(REPO_ROOT)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))
    try:
        proc = subprocess.run(
            ["nice", "-n", str(args.nice), *cmd],
            capture_output=True,
            text=True,
            timeout=timeout_s,
            env=env,
        )
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout_s:.0f} s"}
    lines = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    try:
        out = json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError):
        return {"error": f"exit status {proc.returncode}: {proc.stderr[-1500:]}"}
    if proc.returncode != 0 and "error" not in out:
        out["error"] = f"exit status {proc.returncode}"
    return out


def describe(root: Path) -> str | None:
    try:
        return subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def _num(entry: dict | None, key: str) -> float:
    if not entry or entry.get(key) is None:
        return float("nan")
    return float(entry[key])


def report(results: dict[str, Any]) -> str:
    """Markdown: per case before / after, per class worst case, stages of the last run."""
    runs = results.get("runs", {})
    labels = [lb for lb in ("before", "after") if lb in runs] + [
        lb for lb in runs if lb not in ("before", "after")
    ]
    cases: list[str] = []
    for lb in labels:
        cases += [c for c in runs[lb]["cases"] if c not in cases]
    header = ["case", "Mpx", "V", "E"]
    for lb in labels:
        header += [f"{lb} B/px", f"{lb} +nx B/px", f"{lb} traced B/px", f"{lb} s", f"{lb} +nx s"]
    rows = []
    for c in cases:
        first = next(
            runs[lb]["cases"][c].get("rss") or {} for lb in labels if c in runs[lb]["cases"]
        )
        row: list[Any] = [
            c,
            first.get("pixels", 0) / 1e6,
            first.get("vertices"),
            first.get("edges"),
        ]
        for lb in labels:
            e = runs[lb]["cases"].get(c, {})
            rss, tm = e.get("rss"), e.get("tracemalloc")
            row += [
                _num(rss, "build_peak_b_px"),
                _num(rss, "with_networkx_peak_b_px"),
                _num(tm, "build_peak_b_px"),
                _num(rss, "build_s"),
                _num(rss, "build_s") + _num(rss, "networkx_s"),
            ]
        rows.append(row)
    text = ["### Peak RSS growth of build_graph per map pixel", ""]
    text.append(markdown_table(header, rows))
    text += ["", "### Worst case per class (build peak, B/px)", ""]
    classes: dict[str, dict[str, float]] = {}
    for lb in labels:
        for c, e in runs[lb]["cases"].items():
            v = _num(e.get("rss"), "build_peak_b_px")
            d = classes.setdefault(case_class(c), {})
            d[lb] = max(d.get(lb, float("-inf")), v)
    text.append(
        markdown_table(
            ["class", *labels], [[k, *(d.get(lb) for lb in labels)] for k, d in classes.items()]
        )
    )
    for lb in labels:
        text += ["", f"### Peak growth inside each stage ({lb}, B/px)", ""]
        text.append(_stage_table(runs[lb]["cases"]))
    errors = [
        f"- {lb} {c}: {e[k]['error']}"
        for lb in labels
        for c, e in runs[lb]["cases"].items()
        for k in ("rss", "tracemalloc")
        if isinstance(e.get(k), dict) and "error" in e[k]
    ]
    if errors:
        text += ["", "Errors:", *errors]
    return "\n".join(text) + "\n"


def _stage_table(cases: dict) -> str:
    """Peak growth inside each stage of ``timings_s``, then with networkx, and what stays."""
    names: list[str] = []
    for e in cases.values():
        names += [s for s in (e.get("rss") or {}).get("stages", {}) if s not in names]
    rows = []
    for c, e in cases.items():
        rss = e.get("rss") or {}
        st = rss.get("stages", {})
        rows.append(
            [c, *(_num(st.get(s), "peak_b_px") for s in names)]
            + [_num(rss, "with_networkx_peak_b_px"), _num(rss, "resident_b_px")]
        )
    return markdown_table(["case", *names, "+ networkx", "resident"], rows)


def section_of(name: str) -> str:
    """The key of the JSON a case's results go under (``runs``: the build cases)."""
    for prefix in ("tiled", "replay", "batch"):
        if name.startswith(prefix + "_"):
            return prefix
    return "runs"


def run_in_section(results: dict[str, Any], name: str, args: argparse.Namespace, root, log):
    """Run a tiled, replay or batch case and put its JSON under its section (the other
    sections and cases are kept)."""
    key = section_of(name)
    section = results.setdefault(key, {"cases": {}})
    section["git_describe"] = describe(root)
    section["date_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    if key != "tiled":
        section["machine"] = machine_info(with_jax=False)
    log(f"{key} {name}")
    e = run_case(name, args, traced=False, timeout_s=args.timeout)
    e["git_describe"] = section["git_describe"]
    section["cases"][name] = e
    peak = e.get("build_peak_mb") or e.get("peak_mb") or e.get("replay", e.get("parent", {}))
    peak = peak.get("peak_mb") if isinstance(peak, dict) else peak
    log(f"  {peak if peak is not None else float('nan'):.0f} MB {e.get('error', '')}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="paper maps and 2000 px plans only")
    parser.add_argument("--large", action="store_true", help="add floor plans of 12000..20000 px")
    parser.add_argument("--cases", nargs="+", help="case names (e.g. intel floor_4000 noise_2000)")
    parser.add_argument("--root", type=Path, help="checkout to measure (default this one)")
    parser.add_argument("--label", default="after", help="results label (default 'after')")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--no-tracemalloc", action="store_true", help="skip the traced runs")
    parser.add_argument("--limit-gb", type=float, default=14.0, help="RSS limit per case (GiB)")
    parser.add_argument("--nice", type=int, default=10, help="niceness of the case processes")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds per process")
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown report here")
    parser.add_argument(
        "--render", action="store_true", help="print the report of --out; run nothing"
    )
    parser.add_argument(
        "--tiled", action="store_true", help="add the tiled cases (real maps, 8000 px plan)"
    )
    parser.add_argument("--huge", action="store_true", help="--tiled and the 40000 px plan")
    parser.add_argument(
        "--tiles-dir", type=Path, default=Path("/tmp/topojax_bench_tiles"), help="tile folders"
    )
    parser.add_argument(
        "--budget-mb", type=float, default=256.0, help="memory budget of the tiled floor plans"
    )
    parser.add_argument("--block-px", type=int, help="block side of the tiled cases")
    parser.add_argument(
        "--replay", action="store_true", help="the replay cases only (with --batch: both)"
    )
    parser.add_argument(
        "--batch", action="store_true", help="the batch cases only (with --replay: both)"
    )
    parser.add_argument("--tiles", help=argparse.SUPPRESS)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--tracemalloc-run", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        root = Path(args.root).resolve() if args.root else REPO_ROOT
        sys.path.insert(0, str(root))
        if args.worker.startswith("tiled_"):
            tiled_worker(args)
        elif args.worker.startswith("replay_"):
            replay_worker(args)
        elif args.worker == "batch_pool2":
            batch_pool_worker(args, root)
        elif args.worker.startswith("batch_"):
            batch_map_worker(args, root)
        else:
            worker(args)
        return 0
    out = args.out or RESULTS_DIR / f"memory_{machine_slug()}.json"
    results: dict[str, Any] = json.loads(out.read_text()) if out.is_file() else {}
    if not args.render:
        t_run = time.perf_counter()

        def log(msg: str) -> None:
            print(f"[{time.perf_counter() - t_run:7.1f} s] {msg}", file=sys.stderr, flush=True)

        root = Path(args.root).resolve() if args.root else REPO_ROOT
        results.setdefault("benchmark", "memory")
        for key in ("git_describe", "date_utc"):  # the file's: this run's (each section
            results.pop(key, None)  # keeps its own)
        names = case_names(args)
        if any(section_of(n) == "runs" for n in names):
            results["machine"] = machine_info(with_jax=False)
            run = results.setdefault("runs", {}).setdefault(args.label, {"cases": {}})
            run["git_describe"] = describe(root)
            run["root"] = str(root)
            run["date_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        for name in names:
            if section_of(name) != "runs":
                run_in_section(results, name, args, root, log)
                write_json(out, results)
                continue
            entry: dict[str, Any] = {}
            log(f"{args.label} {name}: rss")
            entry["rss"] = run_case(name, args, traced=False, timeout_s=args.timeout)
            if not args.no_tracemalloc:
                log(f"{args.label} {name}: tracemalloc")
                entry["tracemalloc"] = run_case(name, args, traced=True, timeout_s=args.timeout)
            elif name in run["cases"] and "tracemalloc" in run["cases"][name]:
                entry["tracemalloc"] = run["cases"][name]["tracemalloc"]
            run["cases"][name] = entry
            r = entry["rss"]
            log(
                f"  {r.get('build_peak_b_px', float('nan')):.1f} B/px "
                f"(+nx {r.get('with_networkx_peak_b_px', float('nan')):.1f}), "
                f"{r.get('build_s', float('nan')):.1f} s {r.get('error', '')}"
            )
            write_json(out, results)  # after every case: a long run keeps what it measured
        log(f"wrote {out}")
    text = report(results) if results.get("runs") else ""
    if results.get("tiled"):
        text += "\n### Maps read block by block (build_graph_tiled)\n\n" + tiled_report(results)
    if results.get("replay"):
        text += "\n### Replays and the mapper's exports\n\n" + replay_report(results)
    if results.get("batch"):
        text += "\n### Batch (build_graphs)\n\n" + batch_report(results)
    print(text)
    if args.markdown:
        write_text(args.markdown, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
