"""Benchmark: full-map pipeline, topojax vs a naive splat (a) vs off-the-shelf parts (b).

For every map, in one run:

* **topojax** :func:`topojax.build_graph` with ``thinning="guo_hall"`` and ``"zhang"``, per
  stage (``distance_ridges``, ``thinning``, ``t_removal``, ``graph``; ``total`` is the wall
  time of the whole call).
* **(b) off-the-shelf**: ``cv2.distanceTransform(DIST_L2, DIST_MASK_PRECISE)`` ->
  ``H = exp(-d^2 / 2 sigma^2)`` -> ``cv2.Laplacian(255 H, CV_64F, ksize=5)`` ->
  ``cv2.convertScaleAbs`` -> ``> 10`` -> scikit-image ``thin`` (Guo–Hall) or ``skeletonize``
  (Zhang–Suen) -> skan ``Skeleton`` + ``summarize`` (the skeleton-to-graph step).
* **(a) naive**: the paper's per-obstacle-pixel splat in NumPy (for each obstacle pixel,
  max-merge a float64 (2R+1)^2 Gaussian, R = 227) followed by the same ridge, ``thin`` and
  skan steps as (b).  Seconds per map, so it runs once per map and only on the paper maps
  unless ``--naive-all`` is given.
* The distance stage alone: topojax's fused JAX tile kernel (distance + Laplacian +
  threshold, the public :func:`topojax.dense_fields`), topojax's distance kernel alone,
  ``cv2.distanceTransform`` and ``scipy.ndimage.distance_transform_edt``.
* The one-compilation check: :func:`topojax.pipeline.trace_counts` after warming on the
  first map and after all the others (of other sizes).

Warm numbers are the median (and min) of ``--repeats`` runs after one discarded warm-up;
the variants are interleaved run by run so that load from other processes hits them alike.
Cold numbers are the first call in a fresh subprocess (imports and map loading excluded and
reported separately).  Results go to ``bench/results/pipeline_<machine>.json``; a markdown
summary is printed (and written with ``--markdown``).

Run from the repository root::

    python bench/bench_pipeline.py --quick          # paper maps only, < 3 min
    python bench/bench_pipeline.py                  # paper + larger maps, < 15 min
    python bench/bench_pipeline.py --maps intel office_g --repeats 11
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    LARGE_MAPS,
    PAPER_MAPS,
    REPO_ROOT,
    RESULTS_DIR,
    StageSamples,
    load_average,
    machine_info,
    machine_slug,
    markdown_table,
    ms,
    run_cold_worker,
    use_checkout,
    write_json,
)

SIGMA_PX = 64.19283  # effective sigma of the original 455-sample kernel (NOTES.md)
HALF_WIDTH_PX = 227  # R: the original kernel is 455 x 455
LAPLACIAN_SCALE = 255.0
RIDGE_THRESHOLD = 10
THINNINGS = ("guo_hall", "zhang")

TOPOJAX_STAGES = ("distance_ridges", "thinning", "t_removal", "graph", "total")
OFFSHELF_STAGES = ("distance", "ridges", "thinning", "graph", "total")
NAIVE_STAGES = ("splat", "ridges", "thinning", "graph", "total")


# --------------------------------------------------------------------------- pipelines


def topojax_config(thinning: str):
    from topojax.config import PipelineConfig, SkeletonConfig

    return PipelineConfig(skeleton=SkeletonConfig(thinning=thinning))


def run_topojax(occupancy, config) -> tuple[dict[str, float], Any]:
    """One :func:`topojax.build_graph` call with its networkx graph read (built on first
    access), like the peers' pipelines that end in a graph; stage times (s) from
    ``timings_s`` plus ``networkx``, total = wall."""
    from topojax.pipeline import build_graph

    t0 = time.perf_counter()
    result = build_graph(occupancy, config=config)
    t1 = time.perf_counter()
    result.graph  # noqa: B018 - builds the networkx graph
    wall = time.perf_counter() - t0
    stages = {k: v for k, v in result.timings_s.items() if k != "total"}
    stages["networkx"] = wall - (t1 - t0)
    stages["total"] = wall
    return stages, result


def ridges_from_distance_map(h) -> Any:
    """The paper's ridge step on a float distance map in [0, 1] (OpenCV, float64)."""
    import cv2
    import numpy as np

    lap = cv2.Laplacian(LAPLACIAN_SCALE * np.asarray(h, np.float64), cv2.CV_64F, ksize=5)
    return cv2.convertScaleAbs(lap) > RIDGE_THRESHOLD


def thin_offshelf(ridges, thinning: str):
    from skimage.morphology import skeletonize, thin

    return thin(ridges) if thinning == "guo_hall" else skeletonize(ridges)


def graph_offshelf(skeleton) -> Any:
    """skan's skeleton-to-graph step: CSR pixel graph plus the branch table."""
    import skan

    return skan.summarize(skan.csr.Skeleton(skeleton), separator="_")


def run_offshelf(obstacles, thinning: str) -> tuple[dict[str, float], dict[str, Any]]:
    """Pipeline (b); returns stage times (s) and its intermediate results."""
    import cv2
    import numpy as np

    t0 = time.perf_counter()
    edt = cv2.distanceTransform((~obstacles).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    d = edt.astype(np.float64)
    h = np.exp(-(d * d) / (2.0 * SIGMA_PX * SIGMA_PX))
    t1 = time.perf_counter()
    stages, out = offshelf_after_distance(h, thinning)
    return {"distance": t1 - t0, **stages, "total": time.perf_counter() - t0}, out


def offshelf_after_distance(h, thinning: str) -> tuple[dict[str, float], dict[str, Any]]:
    """The steps after the distance map shared by (a) and (b): ridges, thinning, skan."""
    t0 = time.perf_counter()
    ridges = ridges_from_distance_map(h)
    t1 = time.perf_counter()
    skeleton = thin_offshelf(ridges, thinning)
    t2 = time.perf_counter()
    branches = graph_offshelf(skeleton)
    t3 = time.perf_counter()
    stages = {"ridges": t1 - t0, "thinning": t2 - t1, "graph": t3 - t2}
    return stages, {"ridges": ridges, "skeleton": skeleton, "branches": branches}


def naive_splat(obstacles, sigma_px: float = SIGMA_PX, half_width_px: int = HALF_WIDTH_PX):
    """The paper's distance map done literally: one float64 Gaussian max-merge per obstacle.

    For each obstacle pixel ``(y, x)`` the ``(2R+1) x (2R+1)`` kernel
    ``exp(-(dy^2 + dx^2) / (2 sigma^2))`` is max-merged into a canvas padded by ``R``.
    Returns float64 (H, W) in [0, 1].
    """
    import numpy as np

    rows, cols = np.nonzero(obstacles)
    r = int(half_width_px)
    h, w = obstacles.shape
    offsets = np.arange(-r, r + 1, dtype=np.float64)
    sq = offsets[:, None] ** 2 + offsets[None, :] ** 2
    kernel = np.exp(-sq / (2.0 * sigma_px * sigma_px))
    canvas = np.zeros((h + 2 * r, w + 2 * r), np.float64)
    size = 2 * r + 1
    for y, x in zip(rows.tolist(), cols.tolist(), strict=True):
        window = canvas[y : y + size, x : x + size]
        np.maximum(window, kernel, out=window)
    return canvas[r : r + h, r : r + w]


def run_naive(obstacles) -> tuple[dict[str, float], dict[str, Any]]:
    """Pipeline (a): naive splat, then the same steps as (b) with Guo–Hall thinning."""
    t0 = time.perf_counter()
    h = naive_splat(obstacles)
    t1 = time.perf_counter()
    stages, out = offshelf_after_distance(h, "guo_hall")
    total = time.perf_counter() - t0
    return {"splat": t1 - t0, **stages, "total": total}, {
        "distance": h,
        "ridges": out["ridges"],
        "branches": out["branches"],
    }


def topojax_distance_kernel_fn(obstacles) -> Callable[[], Any] | None:
    """A callable running topojax's windowed squared distance alone over a whole map.

    The two passes the pipeline runs (``column_distance_tile`` on each tile's columns,
    assembled, then ``row_sq_distance_tile``), on 256 px tiles, one tile per call, from
    one thread; no Gaussian, Laplacian or threshold.  None if those kernels are not there.
    """
    import jax
    import numpy as np
    from jax import lax

    try:
        from topojax.fields.distance import column_distance_tile, column_dtype, row_sq_distance_tile
        from topojax.fields.tiling import TileGrid
    except ImportError:
        return None
    tile, r = 256, HALF_WIDTH_PX
    grid = TileGrid(obstacles.shape, tile)
    none = np.iinfo(column_dtype(r)).max
    columns_fn = jax.jit(lambda s: lax.map(lambda x: column_distance_tile(x, half_width=r), s))
    rows_fn = jax.jit(lambda c: lax.map(lambda x: row_sq_distance_tile(x, half_width=r), c))
    cells = [(i, j) for i in range(grid.grid_shape[0]) for j in range(grid.grid_shape[1])]

    def run():
        strips = grid.patch_view(obstacles, (r, 0), fill=False)
        columns = grid.assemble(
            np.concatenate([np.asarray(columns_fn(strips[c][None])) for c in cells])
        )
        views = grid.patch_view(columns, (0, r), fill=none)
        return grid.assemble(np.concatenate([np.asarray(rows_fn(views[c][None])) for c in cells]))

    return run


# --------------------------------------------------------------------------- cold worker


def cold_worker(args: argparse.Namespace) -> None:
    """Run in a fresh process: import, load, time the first call, print one JSON line."""
    t_start = time.perf_counter()
    if args.cold_worker == "topojax":
        use_checkout()
        import topojax  # noqa: F401
        from topojax.maps import load_map

        t_import = time.perf_counter()
        occupancy = load_map(args.map)
        t_load = time.perf_counter()
        stages, result = run_topojax(occupancy, topojax_config(args.thinning))
        extra = {"vertices": result.graph.number_of_nodes()}
    else:
        import cv2  # noqa: F401
        import numpy as np
        import skan  # noqa: F401
        import skimage.morphology  # noqa: F401

        t_import = time.perf_counter()
        obstacles = np.load(args.mask)
        t_load = time.perf_counter()
        stages, out = run_offshelf(obstacles, args.thinning)
        extra = {"branches": len(out["branches"])}
    payload = {
        "import_ms": ms(t_import - t_start),
        "load_ms": ms(t_load - t_import),
        "first_call_ms": {k: ms(v) for k, v in stages.items()},
        **extra,
    }
    print(json.dumps(payload))


# --------------------------------------------------------------------------- driver


def resolve_maps(names: list[str] | None, quick: bool, data: Path) -> dict[str, Path]:
    """Map name -> path.  Names from the built-in lists, or paths to map files."""
    known = {**PAPER_MAPS, **LARGE_MAPS}
    if not names:
        names = list(PAPER_MAPS) if quick else list(known)
    out: dict[str, Path] = {}
    for item in names:
        for name in filter(None, item.split(",")):
            if name in known:
                path = data / known[name]
            else:
                path = Path(name)
                name = path.parent.name if path.stem == "map" else path.stem
            if not path.is_file():
                raise FileNotFoundError(
                    f"--maps: map {name!r} expected at {path}, but there is no such file "
                    f"(known names: {', '.join(known)}; or give a path)"
                )
            out[name] = path
    return out


def bench_map(
    name: str,
    path: Path,
    *,
    repeats: int,
    naive: bool,
    data: Path,
    log: Callable[[str], None],
) -> dict[str, Any]:
    """Warm timings, the distance-stage comparison and the naive pipeline on one map."""
    import cv2
    import numpy as np
    from scipy import ndimage

    import topojax
    from topojax.maps import load_map

    occupancy = load_map(path)
    obstacles = np.ascontiguousarray(occupancy.occupied)
    entry: dict[str, Any] = {
        "path": str(path.relative_to(data) if path.is_relative_to(data) else path),
        "shape": list(obstacles.shape),
        "obstacle_px": int(obstacles.sum()),
        "resolution_m": occupancy.resolution_m,
    }
    configs = {t: topojax_config(t) for t in THINNINGS}

    # ---- whole pipelines, interleaved run by run
    variants: dict[str, Callable[[], tuple[dict[str, float], Any]]] = {}
    for t in THINNINGS:
        variants[f"topojax_{t}"] = lambda t=t: run_topojax(occupancy, configs[t])
        variants[f"offshelf_{t}"] = lambda t=t: run_offshelf(obstacles, t)
    samples = {k: StageSamples() for k in variants}
    last: dict[str, Any] = {}
    for key, fn in variants.items():  # warm-up (compiles on the first map)
        _, last[key] = fn()
    for _ in range(repeats):
        for key, fn in variants.items():
            # Collect the previous run's garbage first (untimed), so that a collection it
            # would trigger is not charged to the next variant (all variants alike).
            gc.collect()
            stages, _ = fn()
            samples[key].add(stages)
    entry["warm"] = {k: s.summary() for k, s in samples.items()}

    # ---- sanity: both pipelines find the same ridges; graph sizes
    checks: dict[str, Any] = {}
    for t in THINNINGS:
        tj = last[f"topojax_{t}"]
        b = last[f"offshelf_{t}"]
        checks[t] = {
            "ridge_px": int(tj.ridges.sum()),
            "ridge_diff_vs_offshelf_px": int((tj.ridges != b["ridges"]).sum()),
            "skeleton_px": int(tj.skeleton.sum()),
            "skeleton_diff_vs_offshelf_px": int((tj.skeleton != b["skeleton"]).sum()),
            "vertices": tj.graph.number_of_nodes(),
            "edges": tj.graph.number_of_edges(),
            "skan_branches": len(b["branches"]),
        }
    entry["checks"] = checks

    # ---- distance stage alone
    kernel_only = topojax_distance_kernel_fn(obstacles)
    free_u8 = (~obstacles).astype(np.uint8)
    free_bool = ~obstacles
    dist_fns: dict[str, Callable[[], Any]] = {
        "topojax_fused_distance_ridges": lambda: topojax.dense_fields(obstacles),
        "cv2_distanceTransform": lambda: cv2.distanceTransform(
            free_u8, cv2.DIST_L2, cv2.DIST_MASK_PRECISE
        ),
        "scipy_distance_transform_edt": lambda: ndimage.distance_transform_edt(free_bool),
    }
    if kernel_only is not None:
        dist_fns["topojax_distance_kernel"] = kernel_only
    dist_samples = {k: StageSamples() for k in dist_fns}
    for fn in dist_fns.values():
        fn()
    for _ in range(repeats):
        for key, fn in dist_fns.items():
            gc.collect()
            t0 = time.perf_counter()
            fn()
            dist_samples[key].add({"total": time.perf_counter() - t0})
    entry["distance_stage"] = {k: s.summary()["total"] for k, s in dist_samples.items()}

    # ---- (a) naive splat, once
    if naive:
        log(f"  {name}: naive splat over {entry['obstacle_px']} obstacle pixels ...")
        stages, out = run_naive(obstacles)
        tj = last["topojax_guo_hall"]
        entry["naive"] = {
            "runs": 1,
            "stages_ms": {k: ms(v) for k, v in stages.items()},
            "max_abs_diff_distance_vs_topojax": float(
                np.max(np.abs(out["distance"] - tj.distance.astype(np.float64)))
            ),
            "ridge_diff_vs_topojax_px": int((out["ridges"] != tj.ridges).sum()),
        }
    return entry


def cold_runs(name: str, path: Path, tmpdir: Path, log: Callable[[str], None]) -> dict[str, Any]:
    """Every variant's first call in its own fresh process."""
    import numpy as np

    from topojax.maps import load_map

    mask = tmpdir / f"{name}.npy"
    np.save(mask, np.ascontiguousarray(load_map(path).occupied))
    script = Path(__file__).resolve()
    out = {}
    for kind in ("topojax", "offshelf"):
        for t in THINNINGS:
            args = ["--cold-worker", kind, "--thinning", t, "--map", str(path)]
            if kind == "offshelf":
                args += ["--mask", str(mask)]
            try:
                out[f"{kind}_{t}"] = run_cold_worker(script, args)
            except (RuntimeError, OSError) as exc:  # record, keep going
                log(f"  cold {kind}/{t} on {name} failed: {exc}")
                out[f"{kind}_{t}"] = {"error": str(exc)[-500:]}
    return out


def _get(d: dict[str, Any], *keys: str) -> float:
    for k in keys:
        if not isinstance(d, dict) or k not in d:
            return math.nan
        d = d[k]
    return float(d) if isinstance(d, (int, float)) else math.nan


def _ratio(a: float, b: float) -> float:
    return a / b if b and not math.isnan(a) and not math.isnan(b) else math.nan


def summarise(results: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """Ratios vs targets and the markdown report."""
    maps = results["maps"]
    ratios: dict[str, Any] = {}
    rows_total = []
    for name, e in maps.items():
        w = e["warm"]
        tj = {t: _get(w, f"topojax_{t}", "total", "median_ms") for t in THINNINGS}
        b = {t: _get(w, f"offshelf_{t}", "total", "median_ms") for t in THINNINGS}
        naive = _get(e, "naive", "stages_ms", "total")
        r = {f"topojax_over_offshelf_{t}": round(_ratio(tj[t], b[t]), 3) for t in THINNINGS}
        r["naive_over_topojax_guo_hall"] = round(_ratio(naive, tj["guo_hall"]), 1)
        ratios[name] = r
        rows_total.append(
            [
                name,
                "×".join(map(str, e["shape"])),
                tj["guo_hall"],
                b["guo_hall"],
                r["topojax_over_offshelf_guo_hall"],
                tj["zhang"],
                b["zhang"],
                r["topojax_over_offshelf_zhang"],
                naive / 1e3 if not math.isnan(naive) else math.nan,
                r["naive_over_topojax_guo_hall"],
            ]
        )
    md = [
        f"Machine: {results['machine']['cpu_model']}, {results['machine']['cpu_count']} CPUs; "
        f"repeats = {results['repeats']}; load average at start "
        f"{results['load_average_start']}, end {results['load_average_end']}.",
        "",
        "### Warm end-to-end (median ms)  — targets: topojax/(b) ≤ 0.5, (a)/topojax ≥ 200",
        "",
        markdown_table(
            [
                "map",
                "size",
                "topojax GH",
                "(b) GH",
                "ratio GH",
                "topojax ZS",
                "(b) ZS",
                "ratio ZS",
                "(a) naive s",
                "(a)/topojax",
            ],
            rows_total,
        ),
        "",
        "### Warm per stage (median ms)",
        "",
    ]
    stage_rows = []
    for name, e in maps.items():
        w = e["warm"]
        for t in THINNINGS:
            tj = [_get(w, f"topojax_{t}", s, "median_ms") for s in TOPOJAX_STAGES]
            b = [_get(w, f"offshelf_{t}", s, "median_ms") for s in OFFSHELF_STAGES]
            stage_rows.append([name, "GH" if t == "guo_hall" else "ZS", *tj, *b])
    md.append(
        markdown_table(
            [
                "map",
                "thin",
                "tj dist+ridges",
                "tj thin",
                "tj T-rem",
                "tj graph",
                "tj total",
                "(b) cv2 dist+exp",
                "(b) ridges",
                "(b) thin",
                "(b) skan",
                "(b) total",
            ],
            stage_rows,
        )
    )
    naive_rows = [
        [name, *(_get(e, "naive", "stages_ms", s) for s in NAIVE_STAGES)]
        for name, e in maps.items()
        if "naive" in e
    ]
    if naive_rows:
        md += [
            "",
            "### (a) naive splat pipeline, one run (ms)",
            "",
            markdown_table(["map", *NAIVE_STAGES], naive_rows),
        ]
    md += ["", "### Distance stage alone (warm median ms)", ""]
    dist_keys = [
        "topojax_fused_distance_ridges",
        "topojax_distance_kernel",
        "cv2_distanceTransform",
        "scipy_distance_transform_edt",
    ]
    md.append(
        markdown_table(
            ["map", "topojax dist+ridges", "topojax dist kernel", "cv2 EDT", "scipy EDT"],
            [
                [name, *(_get(e, "distance_stage", k, "median_ms") for k in dist_keys)]
                for name, e in maps.items()
            ],
        )
    )
    cold = results.get("cold") or {}
    if cold:
        md += ["", "### Cold: first call in a fresh process (ms; imports excluded)", ""]
        variants = [f"{k}_{t}" for k in ("topojax", "offshelf") for t in THINNINGS]
        md.append(
            markdown_table(
                [
                    "map",
                    *(v.replace("offshelf", "(b)") for v in variants),
                    "import tj",
                    "import (b)",
                ],
                [
                    [
                        name,
                        *(_get(c, v, "first_call_ms", "total") for v in variants),
                        _get(c, "topojax_guo_hall", "import_ms"),
                        _get(c, "offshelf_guo_hall", "import_ms"),
                    ]
                    for name, c in cold.items()
                ],
            )
        )
    tc = results.get("trace_check", {})
    md += [
        "",
        f"One compilation: trace counts after the first map {tc.get('after_first_map')}, "
        f"after all maps {tc.get('after_all_maps')} -> "
        f"{'no new trace' if tc.get('no_new_trace') else 'NEW TRACES'}.",
    ]
    return ratios, "\n".join(md)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--maps", nargs="+", help="map names (see --list) or paths; default: all known maps"
    )
    parser.add_argument("--quick", action="store_true", help="paper maps only")
    parser.add_argument("--repeats", type=int, default=7, help="warm repeats (default 7)")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--no-cold", action="store_true", help="skip the cold subprocesses")
    parser.add_argument(
        "--naive-all", action="store_true", help="run the naive splat on every map (minutes)"
    )
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown report here")
    parser.add_argument("--list", action="store_true", help="list known maps and exit")
    # internal: one cold measurement in a fresh process
    parser.add_argument("--cold-worker", choices=("topojax", "offshelf"), help=argparse.SUPPRESS)
    parser.add_argument("--thinning", choices=THINNINGS, help=argparse.SUPPRESS)
    parser.add_argument("--map", help=argparse.SUPPRESS)
    parser.add_argument("--mask", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.cold_worker:
        cold_worker(args)
        return 0
    if args.list:
        for name, rel in {**PAPER_MAPS, **LARGE_MAPS}.items():
            print(f"{name:24s} {args.data / rel}")
        return 0
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")

    use_checkout()
    maps = resolve_maps(args.maps, args.quick, args.data)
    t_run = time.perf_counter()

    def log(msg: str) -> None:
        print(f"[{time.perf_counter() - t_run:7.1f} s] {msg}", file=sys.stderr, flush=True)

    info = machine_info()
    results: dict[str, Any] = {
        "benchmark": "pipeline",
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": info,
        "repeats": args.repeats,
        "parameters": {
            "sigma_px": SIGMA_PX,
            "half_width_px": HALF_WIDTH_PX,
            "scale": LAPLACIAN_SCALE,
            "threshold": RIDGE_THRESHOLD,
        },
        "load_average_start": load_average(),
        "maps": {},
    }

    from topojax.pipeline import trace_counts

    trace_after_first: dict[str, int] | None = None
    for name, path in maps.items():
        naive = args.naive_all or name in PAPER_MAPS
        log(f"{name}: warm runs")
        results["maps"][name] = bench_map(
            name, path, repeats=args.repeats, naive=naive, data=args.data.resolve(), log=log
        )
        if trace_after_first is None:
            trace_after_first = trace_counts()
    trace_after_all = trace_counts()
    results["trace_check"] = {
        "after_first_map": trace_after_first,
        "after_all_maps": trace_after_all,
        "map_shapes": [results["maps"][n]["shape"] for n in maps],
        "no_new_trace": trace_after_first == trace_after_all,
    }

    if not args.no_cold:
        pycache = REPO_ROOT / "topojax" / "__pycache__"
        results["numba_cache_files_before_cold"] = len(list(pycache.glob("*.nbi")))
        results["cold"] = {}
        with tempfile.TemporaryDirectory() as tmp:
            for name, path in maps.items():
                log(f"{name}: cold runs (4 fresh processes)")
                results["cold"][name] = cold_runs(name, path, Path(tmp), log)
    results["load_average_end"] = load_average()
    results["elapsed_s"] = round(time.perf_counter() - t_run, 1)
    results["ratios"], report = summarise(results)
    results["notes"] = [
        "warm = median (min) of repeats after one discarded warm-up; variants interleaved",
        "cold = first call in a fresh process; import and map load reported separately",
        "topojax total = wall time of build_graph; (b)/(a) total = sum of their stages",
        "(b) has no T-junction-centre removal (no off-the-shelf part does it)",
        "(a) uses Guo-Hall thinning (skimage thin) and skan, like (b); one run per map",
    ]
    out = args.out or RESULTS_DIR / f"pipeline_{machine_slug(info)}.json"
    write_json(out, results)
    print(report)
    if args.markdown:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(report + "\n")
    log(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
