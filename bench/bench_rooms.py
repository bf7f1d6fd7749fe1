"""Benchmark: room segmentation on the IPA room-segmentation data set (Bormann et al., ICRA 2016).

The 20 maps of ``../shared/data/maps/ipa`` that have a ``<name>_gt_segmentation.png``, each
without furniture (``<name>.png``, *plain*) and with it (``<name>_furnitures.png``), read
with ``topojax.load_map(path, mode="ipa", resolution_m=0.05)``.  Two segmenters see the
same map:

* **topojax**: ``segment_rooms(map)`` with the default ``RoomConfig``;
* **baseline**, a morphological segmentation from SciPy and scikit-image: erode the free
  space by a disc of radius r (free pixels farther than r from anything not free, the
  map's outside included), label the eroded components (4-connected), drop those under
  ``--min-marker-m2``, and grow the rest back over the free space with
  ``skimage.segmentation.watershed`` on the negated distance transform.  r is chosen once,
  on the seven ``lab_*`` maps (plain and furnitures), from ``--baseline-radii``: the one
  with the best mean of recall and precision; it is then used on every map.

Both are scored by ``rooms_scoring.score_rooms`` (the IPA evaluation's recall and
precision, plus mean IoU and segments per room) against the ground truth, and timed:

* *warm*: median of ``--repeats`` calls per map, after one untimed call on the map; the
  two segmenters alternate call by call and ``gc.collect()`` runs, untimed, before each;
* *cold*: in a fresh process per segmenter, the imports it needs plus its first call
  (JIT compilation and cache loads included), on ``--cold-maps`` (map reading excluded).

The ``lab_*`` maps are where topojax's defaults were chosen; the other 13 (*unseen*) are
averaged apart.  Run from the repository root::

    python bench/bench_rooms.py --markdown /tmp/rooms.md    # all 20 maps, a few minutes
    python bench/bench_rooms.py --quick --out /tmp/rooms.json
    python bench/bench_rooms.py --maps lab_ipa office_e --repeats 3 --no-cold --out /tmp/r.json

Results: ``bench/results/rooms_<machine>.json`` and, with ``--markdown``, the tables.
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    RESULTS_DIR,
    StageSamples,
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

IPA_DIR = "maps/ipa"
RESOLUTION_M = 0.05
#: Maps topojax's room defaults were chosen on.
LAB_MAPS = (
    "lab_a_scan",
    "lab_b_scan",
    "lab_c_scan",
    "lab_d_scan",
    "lab_f_scan",
    "lab_intel",
    "lab_ipa",
)
QUICK_MAPS = ("lab_ipa", "lab_c_scan", "office_d")
VARIANTS = {"plain": "{name}.png", "furnitures": "{name}_furnitures.png"}
METHODS = ("topojax", "baseline")
SETS = ("lab", "unseen", "all")
DEFAULT_RADII_M = (0.5, 0.6, 0.7, 0.8)
#: Targets printed against (never asserted): percent, and warm ms per map.
TARGETS = {
    "plain": {"recall": 97.6, "precision": 95.0},
    "furnitures": {"recall": 92.0, "precision": 95.0},
    "warm_ms": 50.0,
}
#: Published numbers on this data set, quoted (not rerun): method, recall / precision %
#: without and with furniture, time per map.
PUBLISHED = (
    ("ipa Voronoi (Bormann et al., ICRA 2016)", "95.0 / 94.8", "86.6 / 94.5", "12–13 s"),
    ("ROSE² (Luperto et al., RA-L 2022)", "97.6 / 93.3", "91.0 / 93.5", "about 100 s"),
    ("DuDe (as quoted beside the two above)", "86.3 / 94.1", "–", "–"),
)


# ---------------------------------------------------------------------------- maps
def ipa_maps(data: Path) -> list[str]:
    """Names of the IPA maps with a ground truth, sorted."""
    suffix = "_gt_segmentation.png"
    return sorted(p.name[: -len(suffix)] for p in (data / IPA_DIR).glob(f"*{suffix}"))


def map_path(data: Path, name: str, variant: str) -> Path:
    return data / IPA_DIR / VARIANTS[variant].format(name=name)


def load(data: Path, name: str, variant: str, origin_px: tuple[int, int] = (0, 0)):
    """The map, its lower-left corner ``origin_px`` (x, y) pixels from the map frame's
    origin: an odd number puts other pixels together in the doorway search's cells."""
    import topojax as tj

    origin = (origin_px[0] * RESOLUTION_M, origin_px[1] * RESOLUTION_M, 0.0)
    return tj.load_map(
        map_path(data, name, variant), mode="ipa", resolution_m=RESOLUTION_M, origin=origin
    )


def map_set(name: str) -> str:
    return "lab" if name in LAB_MAPS else "unseen"


# ---------------------------------------------------------------------------- segmenters
def morphological_rooms(
    free: np.ndarray, resolution_m: float, *, radius_m: float, min_marker_m2: float
) -> np.ndarray:
    """Baseline room labels (int32 (H, W), 0 = none) of a free-space mask (bool (H, W)).

    Erosion by a disc of ``radius_m``, 4-connected components of what is left (those under
    ``min_marker_m2`` dropped), grown back over ``free`` by a watershed on the negated
    distance transform.  The map's outside counts as not free.
    """
    from scipy import ndimage
    from skimage.segmentation import watershed

    free = np.asarray(free, bool)
    dist = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1]
    markers, _ = ndimage.label(dist > radius_m / resolution_m)
    area = np.bincount(markers.ravel())
    small = area < min_marker_m2 / resolution_m**2
    small[0] = False
    markers[small[markers]] = 0
    return watershed(-dist, markers, mask=free).astype(np.int32)


def run_topojax(occ) -> tuple[float, float, np.ndarray, dict]:
    """(seconds, CPU seconds of the process, labels, stage seconds) of one
    ``segment_rooms`` call."""
    import topojax as tj

    t0, c0 = time.perf_counter(), time.process_time()
    seg = tj.segment_rooms(occ)
    t1, c1 = time.perf_counter(), time.process_time()
    return t1 - t0, c1 - c0, seg.labels, dict(seg.timings_s)


def run_baseline(occ, args) -> tuple[float, float, np.ndarray]:
    """(seconds, CPU seconds of the process, labels) of one baseline call with the chosen
    radius."""
    t0, c0 = time.perf_counter(), time.process_time()
    labels = morphological_rooms(
        occ.free, occ.resolution_m, radius_m=args.baseline_radius, min_marker_m2=args.min_marker_m2
    )
    return time.perf_counter() - t0, time.process_time() - c0, labels


# ---------------------------------------------------------------------------- cold worker
def cold_worker(argv: list[str]) -> int:
    """``--cold-worker METHOD MAP_PATH RADIUS_M MIN_MARKER_M2``: imports and first call in
    this fresh process; prints one JSON line."""
    method, path, radius, min_marker = argv[0], argv[1], float(argv[2]), float(argv[3])
    t0 = time.perf_counter()
    if method == "topojax":
        import topojax

        segment = topojax.segment_rooms
    else:
        from scipy import ndimage  # noqa: F401
        from skimage.segmentation import watershed  # noqa: F401
    t1 = time.perf_counter()
    import topojax as tj  # for the baseline: only to read the map, after the timed imports

    occ = tj.load_map(path, mode="ipa", resolution_m=RESOLUTION_M)
    t2 = time.perf_counter()
    if method == "topojax":
        segment(occ)
    else:
        morphological_rooms(occ.free, occ.resolution_m, radius_m=radius, min_marker_m2=min_marker)
    t3 = time.perf_counter()
    import_s, first_s = t1 - t0, t3 - t2
    print(
        json.dumps(
            {
                "import_ms": ms(import_s),
                "load_ms": ms(t2 - t1),
                "first_call_ms": ms(first_s),
                "cold_ms": ms(import_s + first_s),
            }
        )
    )
    return 0


def cold_runs(args) -> list[dict]:
    rows = []
    for name in args.cold_maps:
        path = map_path(args.data, name, "plain")
        for method in METHODS:
            doc = run_cold_worker(
                Path(__file__),
                [
                    "--cold-worker",
                    method,
                    str(path),
                    repr(args.baseline_radius),
                    repr(args.min_marker_m2),
                ],
            )
            rows.append({"map": name, "method": method, **doc})
            print(
                f"cold {method:<8} {name}: {doc['cold_ms']:.0f} ms "
                f"(imports {doc['import_ms']:.0f} + first call {doc['first_call_ms']:.0f})",
                flush=True,
            )
    return rows


# ---------------------------------------------------------------------------- baseline radius
def choose_radius(args, truths: dict) -> dict:
    """Score every ``--baseline-radii`` on the lab maps (both variants); sets
    ``args.baseline_radius`` to the best mean of recall and precision."""
    from rooms_scoring import score_rooms

    per_radius: dict[str, Any] = {}
    for radius in args.baseline_radii:
        entry: dict[str, Any] = {}
        for variant in VARIANTS:
            scores = []
            for name in LAB_MAPS:
                occ = load(args.data, name, variant)
                labels = morphological_rooms(
                    occ.free, occ.resolution_m, radius_m=radius, min_marker_m2=args.min_marker_m2
                )
                scores.append(score_rooms(labels, truths[name]))
            entry[variant] = {
                "recall": 100 * float(np.mean([s.recall for s in scores])),
                "precision": 100 * float(np.mean([s.precision for s in scores])),
            }
        entry["score"] = float(
            np.mean([(v["recall"] + v["precision"]) / 2 for v in entry.values()])
        )
        per_radius[f"{radius:g}"] = entry
        print(
            f"baseline r = {radius:g} m on the lab maps: "
            + "; ".join(
                f"{v} R {entry[v]['recall']:.1f} P {entry[v]['precision']:.1f}" for v in VARIANTS
            ),
            flush=True,
        )
    best = max(per_radius, key=lambda k: per_radius[k]["score"])
    args.baseline_radius = float(best)
    return {"chosen_m": args.baseline_radius, "by_radius": per_radius}


# ---------------------------------------------------------------------------- one map
def bench_variant(name: str, variant: str, truth: np.ndarray, args) -> dict:
    """Scores and times of both segmenters on one map variant."""
    from rooms_scoring import score_rooms

    occ = load(args.data, name, variant, tuple(args.origin_px))
    first_tj, _, labels_tj, _ = run_topojax(occ)
    first_base, _, labels_base = run_baseline(occ, args)
    times: dict[str, list[float]] = {m: [] for m in METHODS}
    cpu: dict[str, list[float]] = {m: [] for m in METHODS}
    stages = StageSamples()
    same = True
    for _ in range(args.repeats):
        gc.collect()
        t, c, labels, st = run_topojax(occ)
        times["topojax"].append(t)
        cpu["topojax"].append(c)
        stages.add(st)
        same &= bool(np.array_equal(labels, labels_tj))
        gc.collect()
        t, c, _ = run_baseline(occ, args)
        times["baseline"].append(t)
        cpu["baseline"].append(c)
    row: dict[str, Any] = {"shape": list(occ.shape), "free_px": int(np.count_nonzero(occ.free))}
    for method, labels, first in (
        ("topojax", labels_tj, first_tj),
        ("baseline", labels_base, first_base),
    ):
        s = score_rooms(labels, truth).as_dict()
        for key in ("recall", "precision", "mean_iou"):
            s[key] = 100 * s[key]
        row[method] = {
            **s,
            "warm_ms": ms(median(times[method])),
            "warm_min_ms": ms(min(times[method])),
            "warm_cpu_ms": ms(median(cpu[method])),
            "first_ms": ms(first),
        }
    row["topojax"]["stages"] = stages.summary()
    row["topojax"]["same_labels_every_call"] = same
    row["baseline_over_topojax_warm"] = row["baseline"]["warm_ms"] / row["topojax"]["warm_ms"]
    return row


def one_line(name: str, variant: str, row: dict) -> str:
    parts = [f"{name:<17} {variant:<10}"]
    for method in METHODS:
        m = row[method]
        parts.append(
            f"{method} R {m['recall']:5.1f} P {m['precision']:5.1f} IoU {m['mean_iou']:5.1f} "
            f"{m['n_segments']:>2}/{m['n_rooms']:<2} warm {m['warm_ms']:7.1f} ms"
        )
    return " | ".join(parts)


# ---------------------------------------------------------------------------- summaries
def averages(rows: list[dict]) -> dict:
    """``variant -> set -> method -> metric -> mean`` over the maps, with ``n_maps``; warm
    time also as its maximum."""
    out: dict[str, Any] = {}
    keys = ("recall", "precision", "mean_iou", "segments_per_room", "warm_ms", "warm_cpu_ms")
    for variant in VARIANTS:
        out[variant] = {}
        for set_name in SETS:
            sel = [
                r[variant]
                for r in rows
                if variant in r and (set_name == "all" or r["set"] == set_name)
            ]
            if not sel:
                continue
            entry: dict[str, Any] = {"n_maps": len(sel)}
            for method in METHODS:
                entry[method] = {k: float(np.mean([s[method][k] for s in sel])) for k in keys}
                entry[method]["warm_max_ms"] = float(max(s[method]["warm_ms"] for s in sel))
            entry["baseline_over_topojax_warm"] = float(
                np.mean([s["baseline_over_topojax_warm"] for s in sel])
            )
            out[variant][set_name] = entry
    return out


def target_lines(avg: dict, rows: list[dict]) -> list[str]:
    """One line per variant: topojax's means on all maps and the unseen ones against the
    targets, then the maps over the warm-time target."""
    lines = []
    for variant in VARIANTS:
        tgt = TARGETS[variant]
        checks = []
        for set_name in ("all", "unseen"):
            entry = avg.get(variant, {}).get(set_name)
            if not entry:
                continue
            m = entry["topojax"]
            for key in ("recall", "precision"):
                ok = "met" if m[key] >= tgt[key] else "missed"
                checks.append(f"{set_name} {key} {m[key]:.1f} ({ok})")
        lines.append(
            f"Targets {variant} (recall >= {tgt['recall']}, precision >= {tgt['precision']}): "
            + ", ".join(checks)
            + "."
        )
    slow = sorted(
        (r[v]["topojax"]["warm_ms"], f"{r['map']}{'' if v == 'plain' else ' (furn.)'}")
        for r in rows
        for v in VARIANTS
        if v in r
    )
    over = [f for t, f in slow if t > TARGETS["warm_ms"]]
    mean = float(np.mean([t for t, _ in slow])) if slow else float("nan")
    lines.append(
        f"Warm time target <= {TARGETS['warm_ms']:g} ms per map: mean {mean:.1f} ms; met on "
        f"{len(slow) - len(over)} of {len(slow)} map variants"
        + (f" (fastest {slow[0][0]:.0f} ms, slowest {slow[-1][0]:.0f} ms)." if slow else ".")
    )
    return lines


def stage_lines(rows: list[dict]) -> list[str]:
    """topojax's stages (``RoomSegmentation.timings_s``), mean over the maps of each
    stage's warm median, one line per variant."""
    lines = []
    for variant in VARIANTS:
        sel = [r[variant]["topojax"]["stages"] for r in rows if variant in r]
        if not sel:
            continue
        names = list(sel[0])
        lines.append(
            f"topojax stages, {variant}, mean warm ms: "
            + ", ".join(f"{k} {np.mean([s[k]['median_ms'] for s in sel]):.1f}" for k in names)
        )
    return lines


def lowest(rows: list[dict], n: int = 3) -> list[str]:
    """topojax's ``n`` lowest-recall and lowest-precision maps per variant."""
    lines = []
    for variant in VARIANTS:
        sel = [r for r in rows if variant in r]
        for key in ("recall", "precision"):
            worst = sorted(sel, key=lambda r: r[variant]["topojax"][key])[:n]
            lines.append(
                f"lowest {key}, {variant}: "
                + ", ".join(f"{r['map']} {r[variant]['topojax'][key]:.1f}" for r in worst)
            )
    return lines


def summary_table(avg: dict) -> str:
    header = ["maps", "variant", "method", "recall %", "precision %", "IoU %", "segs/room"]
    header += ["warm ms mean", "warm ms max", "warm CPU ms mean"]
    table = []
    for variant, by_set in avg.items():
        for set_name, entry in by_set.items():
            for method in METHODS:
                m = entry[method]
                table.append(
                    [
                        f"{set_name} ({entry['n_maps']})",
                        variant,
                        method,
                        m["recall"],
                        m["precision"],
                        m["mean_iou"],
                        f"{m['segments_per_room']:.2f}",
                        m["warm_ms"],
                        m["warm_max_ms"],
                        m["warm_cpu_ms"],
                    ]
                )
    return markdown_table(header, table)


def per_map_table(rows: list[dict]) -> str:
    header = ["map", "set"]
    for variant in VARIANTS:
        header += [f"{variant} R / P topojax", f"{variant} R / P baseline"]
    header += ["warm ms topojax", "warm ms baseline"]

    def rp(row: dict | None, method: str) -> str:
        if row is None:
            return "–"
        return f"{row[method]['recall']:.1f} / {row[method]['precision']:.1f}"

    def warm(r: dict, method: str) -> str:
        return " / ".join(f"{r[v][method]['warm_ms']:.0f}" for v in VARIANTS if v in r)

    table = []
    for r in rows:
        cells = [r["map"], r["set"]]
        for variant in VARIANTS:
            cells += [rp(r.get(variant), m) for m in METHODS]
        cells += [warm(r, m) for m in METHODS]
        table.append(cells)
    return markdown_table(header, table)


def report_markdown(rows, avg, cold, radius_doc, info, args) -> str:
    parts = [
        f"Rooms on the IPA maps, {info.get('cpu_model', '?')}, {info.get('cpu_count', '?')} "
        f"CPUs (shared with other jobs). topojax `segment_rooms` (default `RoomConfig`) "
        f"against the morphological baseline (disc r = {args.baseline_radius:g} m, chosen on "
        f"the lab maps; markers under {args.min_marker_m2:g} m² dropped). Recall and precision "
        f"as the IPA evaluation (regions over 100 px); IoU per ground-truth room with its best "
        f"segment; warm = median of {args.repeats} calls (CPU: process time, all threads).",
        "",
        summary_table(avg),
        "",
        *target_lines(avg, rows),
        *stage_lines(rows),
        "",
        "Published on this data set (quoted, not rerun; recall / precision %):",
        "",
        markdown_table(
            ["method", "without furniture", "with furniture", "time per map"], PUBLISHED
        ),
        "",
        "Per map (R / P %; warm ms plain / furnitures):",
        "",
        per_map_table(rows),
        "",
        *lowest(rows),
    ]
    if radius_doc:
        parts += [
            "",
            "Baseline radius on the lab maps (mean of recall and precision): "
            + ", ".join(f"{k} m {v['score']:.1f}" for k, v in radius_doc["by_radius"].items()),
        ]
    if cold:
        parts += [
            "",
            "Cold (fresh process: imports + first call, ms): "
            + "; ".join(
                f"{c['method']} on {c['map']} {c['cold_ms']:.0f} (imports {c['import_ms']:.0f})"
                for c in cold
            ),
        ]
    return "\n".join(parts) + "\n"


# ---------------------------------------------------------------------------- main
def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--maps", nargs="+", help="map names (see --list); default: all 20")
    p.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK_MAPS)}")
    p.add_argument("--list", action="store_true", help="list the maps and exit")
    p.add_argument("--repeats", type=int, default=5, help="warm calls per map (median)")
    p.add_argument(
        "--baseline-radii",
        nargs="+",
        type=float,
        default=list(DEFAULT_RADII_M),
        help="erosion radii (m) tried on the lab maps",
    )
    p.add_argument(
        "--baseline-radius", type=float, help="use this radius (m) instead of choosing one"
    )
    p.add_argument("--min-marker-m2", type=float, default=0.5, help="smallest baseline marker")
    p.add_argument("--cold-maps", nargs="+", default=["lab_intel"], help="maps timed cold")
    p.add_argument("--no-cold", action="store_true", help="skip the cold processes")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    p.add_argument(
        "--origin-px",
        nargs=2,
        type=int,
        default=[0, 0],
        metavar=("DX", "DY"),
        help="place each map DX, DY pixels off the map frame's origin (default 0 0)",
    )
    p.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    p.add_argument("--markdown", type=Path, help="also write the markdown report here")
    return p.parse_args(argv)


def select_maps(args) -> list[str]:
    names = ipa_maps(args.data)
    if args.maps:
        unknown = sorted(set(args.maps) - set(names))
        if unknown:
            raise SystemExit(f"unknown maps {unknown}; --list shows the names")
        return [n for n in names if n in args.maps]
    if args.quick:
        return [n for n in names if n in QUICK_MAPS]
    return names


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--cold-worker"]:
        return cold_worker(argv[1:])
    args = parse_args(argv)
    use_checkout()
    if args.list:
        for name in ipa_maps(args.data):
            print(f"{map_set(name):<7} {name}")
        return 0
    from rooms_scoring import read_ground_truth

    import topojax as tj

    names = select_maps(args)
    t_start = time.perf_counter()
    truths = {
        n: read_ground_truth(args.data / IPA_DIR / f"{n}_gt_segmentation.png")
        for n in sorted(set(names) | set(LAB_MAPS))
    }
    radius_doc = None
    if args.baseline_radius is None:
        radius_doc = choose_radius(args, truths)
    cold = [] if args.no_cold else cold_runs(args)
    rows: list[dict] = []
    failures: dict[str, str] = {}
    for name in names:
        row: dict[str, Any] = {"map": name, "set": map_set(name)}
        for variant in VARIANTS:
            try:
                row[variant] = bench_variant(name, variant, truths[name], args)
                print(one_line(name, variant, row[variant]), flush=True)
            except Exception as exc:  # one broken map must not lose the others
                failures[f"{name} {variant}"] = f"{type(exc).__name__}: {exc}"
                print(f"{name} {variant}: FAILED {failures[f'{name} {variant}']}", flush=True)
        rows.append(row)
    info = machine_info()
    avg = averages(rows)
    report = report_markdown(rows, avg, cold, radius_doc, info, args)
    if failures:
        report += "\nFailed: " + "; ".join(f"{k}: {v}" for k, v in failures.items()) + "\n"
    print(report)
    out = args.out or RESULTS_DIR / f"rooms_{machine_slug(info)}.json"
    write_json(
        out,
        {
            "machine": info,
            "notes": [
                "Timings were taken on a shared machine (2 cores shared with other jobs): "
                "absolute times drift between runs; the two segmenters alternate call by "
                "call, so their ratio is the steadier number.",
                "Published numbers (PUBLISHED in the script) are quoted, not rerun.",
                "Scores: IPA evaluation rules (rooms_scoring.py); percentages.",
                "The baseline labels free pixels only; topojax also gives the clutter a room "
                "encloses to that room.",
            ],
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "room_config": {
                k: getattr(tj.RoomConfig(), k) for k in tj.RoomConfig.__dataclass_fields__
            },
            "targets": TARGETS,
            "published": [
                dict(zip(("method", "plain", "furnitures", "time"), p, strict=True))
                for p in PUBLISHED
            ],
            "baseline_radius": radius_doc or {"chosen_m": args.baseline_radius},
            "total_s": time.perf_counter() - t_start,
            "cold": cold,
            "averages": avg,
            "failures": failures,
            "maps": rows,
        },
    )
    if args.markdown:
        write_text(args.markdown, report)
    print(f"wrote {out}")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
