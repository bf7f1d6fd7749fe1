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
NOISE_FRACTION = 0.01
#: Side of the warm-up floor plan (more than one 256 px tile each way).
WARMUP_SIDE_PX = 600
SAMPLE_S = 0.001


# --------------------------------------------------------------------------- synthetic maps


def floor_plan(side_px: int, *, seed: int = 0, res_m: float = 0.05):
    """Obstacle mask (bool (side, side)) of a synthetic floor plan.

    A grid of rooms 6 to 10 m on a side (random per row and column of rooms) inside an
    outer wall; walls 0.15 m thick; every wall between two rooms has one door 0.9 m wide
    at a random place along it.  Deterministic for a given ``seed``.
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    wall = max(1, round(0.15 / res_m))
    door = max(2, round(0.9 / res_m))
    lo, hi = round(6.0 / res_m), round(10.0 / res_m)

    def lines() -> list[int]:
        pos, out = 0, [0]
        while True:
            pos += int(rng.integers(lo, hi + 1))
            if pos > side_px - lo:
                return out + [side_px - wall]
            out.append(pos)

    rows, cols = lines(), lines()
    occ = np.zeros((side_px, side_px), bool)
    for r in rows:
        occ[r : r + wall, :] = True
    for c in cols:
        occ[:, c : c + wall] = True
    for r in rows[1:-1]:  # one door in every wall between two rooms
        for a, b in zip(cols[:-1], cols[1:], strict=True):
            s = int(rng.integers(a + wall + 2, b - door - 1))
            occ[r : r + wall, s : s + door] = False
    for c in cols[1:-1]:
        for a, b in zip(rows[:-1], rows[1:], strict=True):
            s = int(rng.integers(a + wall + 2, b - door - 1))
            occ[s : s + door, c : c + wall] = False
    return occ


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
    names = list(PAPER)
    if args.quick:
        return names + ["floor_2000", "noise_2000"]
    names += list(SHARED)
    names += [f"floor_{s}" for s in FLOOR_SIDES + (FLOOR_SIDES_LARGE if args.large else ())]
    return names + [f"noise_{s}" for s in NOISE_SIDES]


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


def rss_bytes() -> int:
    """Resident set size of this process (bytes), from ``/proc/self/statm``."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def hwm_bytes() -> int | None:
    """The kernel's peak RSS of this process (``VmHWM``, bytes), or None."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def reset_hwm() -> bool:
    """Reset ``VmHWM`` to the current RSS (Linux >= 4.0); False where it cannot be."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


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
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--tracemalloc-run", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
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
        results["machine"] = machine_info(with_jax=False)
        run = results.setdefault("runs", {}).setdefault(args.label, {"cases": {}})
        run["git_describe"] = describe(root)
        run["root"] = str(root)
        run["date_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        for name in case_names(args):
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
    text = report(results)
    print(text)
    if args.markdown:
        write_text(args.markdown, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
