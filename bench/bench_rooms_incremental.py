"""Benchmark: rooms kept by the incremental mapper on real CARMEN logs, whole and local.

For each log (Intel, FR079, ACES; corrected poses) and each room update rate
(``--rooms-every``: 80 scans, with the graph loop, and 10) two mappers replay every scan
with the graph loop every ``--graph-every`` scans and rooms at that rate: one
segments the whole map at each room update (``rooms_local=False``), the other only
around the free space changed since its last room update (``rooms_local=True``).  Both
build the same map.  At every room update:

* the whole mapper's labels are checked equal to ``segment_rooms(mapper.occupancy)`` up
  to a one-to-one renaming of the ids (what the mapper documents);
* the local mapper's labels are compared with that from-scratch segmentation: equal up to
  ids or not; the share of the pixels labelled by either whose room differs after the
  best one-to-one matching of the ids (largest total overlap); the difference in the
  number of rooms; and the IPA benchmark's recall and precision (``rooms_scoring``) with
  the from-scratch rooms as the ground truth;
* the time of both updates and the share of the map the local update segmented (1 when
  it fell back to the whole map).

It reports the times (median, p90, max; warm: the segmentation kernels are compiled
first), the rooms at the end, and how stable the ids are: per update, the share of the
rooms before it that keep their id with unchanged pixels.

    python bench/bench_rooms_incremental.py                 # the three logs, a few minutes
    python bench/bench_rooms_incremental.py --max-scans 300 --markdown out.md
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
    provenance,
    write_json,
    write_text,
)
from rooms_scoring import score_rooms  # noqa: E402

LOGS = {
    "intel": "intel-corrected.log.gz",
    "fr079": "freiburg-079-corrected.log.gz",
    "aces": "aces-corrected.log.gz",
}


def _same_up_to_ids(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal up to a one-to-one renaming of the positive ids."""
    if a.shape != b.shape or not np.array_equal(a > 0, b > 0):
        return False
    pairs = np.unique(np.stack([a[a > 0], b[b > 0]], axis=1), axis=0)
    return len(np.unique(pairs[:, 0])) == len(pairs) == len(np.unique(pairs[:, 1]))


def differing_share(a: np.ndarray, b: np.ndarray) -> float:
    """Share of the pixels labelled in ``a`` or ``b`` whose label differs after the
    one-to-one matching of the ids with the largest total overlap."""
    from scipy.optimize import linear_sum_assignment

    either = (a > 0) | (b > 0)
    if not either.any():
        return 0.0
    ia, ra = np.unique(a[either], return_inverse=True)
    ib, rb = np.unique(b[either], return_inverse=True)
    overlap = np.zeros((ia.size, ib.size), np.int64)
    np.add.at(overlap, (ra, rb), 1)
    overlap[ia == 0, :] = 0
    overlap[:, ib == 0] = 0
    rows, cols = linear_sum_assignment(-overlap)
    same = overlap[rows, cols].sum() + np.count_nonzero((a[either] == 0) & (b[either] == 0))
    return 1.0 - same / np.count_nonzero(either)


def _kept(before: int, up) -> float | None:
    return (before - len(up.removed) - len(up.changed)) / before if before else None


def _stats(values) -> tuple[float, float, float]:
    v = np.asarray(values, np.float64)
    if v.size == 0:
        return (np.nan, np.nan, np.nan)
    return float(np.median(v)), float(np.percentile(v, 90)), float(v.max())


def run_log(path: Path, graph_every: int, rooms_every: int, max_scans: int | None) -> dict:
    import topojax as tj

    kw = {"graph_every": graph_every, "rooms_every": rooms_every}
    whole = tj.IncrementalMapper(**kw, rooms_local=False)
    local = tj.IncrementalMapper(**kw, rooms_local=True)
    updates = []
    t0 = time.perf_counter()
    n = 0
    for i, scan in enumerate(tj.read_scans(path)):
        if max_scans is not None and i >= max_scans:
            break
        n = i + 1
        up_w = whole.add_scan(scan).rooms_update
        up_l = local.add_scan(scan).rooms_update
        if up_w is None:
            continue
        seg_w, seg_l = whole.rooms, local.rooms
        scratch = tj.segment_rooms(whole.occupancy).labels
        scores = score_rooms(seg_l.labels, scratch)
        before = updates[-1] if updates else None
        updates.append(
            {
                "scan": i,
                "map_px": int(scratch.size),
                "whole": {
                    "n_rooms": up_w.n_rooms,
                    "added": len(up_w.added),
                    "removed": len(up_w.removed),
                    "changed": len(up_w.changed),
                    "kept_share": _kept(before and before["whole"]["n_rooms"], up_w),
                    "time_ms": up_w.time_s * 1e3,
                    "identical": bool(_same_up_to_ids(seg_w.labels, scratch)),
                },
                "local": {
                    "n_rooms": up_l.n_rooms,
                    "added": len(up_l.added),
                    "removed": len(up_l.removed),
                    "changed": len(up_l.changed),
                    "kept_share": _kept(before and before["local"]["n_rooms"], up_l),
                    "time_ms": up_l.time_s * 1e3,
                    "segmented_share": up_l.segmented_px / scratch.size,
                    "identical": bool(_same_up_to_ids(seg_l.labels, scratch)),
                    "differing_px_share": differing_share(seg_l.labels, scratch),
                    "rooms_minus_scratch": up_l.n_rooms - up_w.n_rooms,
                    "recall": scores.recall,
                    "precision": scores.precision,
                },
            }
        )
    wall = time.perf_counter() - t0
    out = {
        "log": path.name,
        "rooms_every": rooms_every,
        "scans": n,
        "updates": len(updates),
        "wall_s": wall,
    }
    for mode in ("whole", "local"):
        rows = [u[mode] for u in updates]
        p50, p90, mx = _stats([r["time_ms"] for r in rows[1:]])
        kept = [r["kept_share"] for r in rows if r["kept_share"] is not None]
        out[mode] = {
            "identical_updates": sum(r["identical"] for r in rows),
            "rooms_final": rows[-1]["n_rooms"] if rows else 0,
            "time_ms_median": p50,
            "time_ms_p90": p90,
            "time_ms_max": mx,
            "kept_share_median": float(np.median(kept)) if kept else None,
        }
    rows = [u["local"] for u in updates]
    later = updates[1:]  # the first update of both is the whole map
    done = [u for u in later if u["local"]["segmented_share"] < 1.0]
    back = [u for u in later if u["local"]["segmented_share"] >= 1.0]

    def med(us, mode):
        return float(np.median([u[mode]["time_ms"] for u in us])) if us else None

    out["local"].update(
        {
            "local_updates": len(done),
            "window_share_median": float(np.median([u["local"]["segmented_share"] for u in done]))
            if done
            else None,
            "time_ms_median_local": med(done, "local"),
            "whole_time_ms_median_local": med(done, "whole"),
            "time_ms_median_fallback": med(back, "local"),
            "whole_time_ms_median_fallback": med(back, "whole"),
            "total_s": sum(u["local"]["time_ms"] for u in later) / 1e3,
            "whole_total_s": sum(u["whole"]["time_ms"] for u in later) / 1e3,
            "differing_px_share_mean": float(np.mean([r["differing_px_share"] for r in rows])),
            "differing_px_share_max": float(np.max([r["differing_px_share"] for r in rows])),
            "rooms_minus_scratch_max_abs": int(
                np.max(np.abs([r["rooms_minus_scratch"] for r in rows]))
            ),
            "recall_mean": float(np.mean([r["recall"] for r in rows])),
            "recall_min": float(np.min([r["recall"] for r in rows])),
            "precision_mean": float(np.mean([r["precision"] for r in rows])),
            "precision_min": float(np.min([r["precision"] for r in rows])),
        }
    )
    out["final_map_px"] = updates[-1]["map_px"] if updates else 0
    out["per_update"] = updates
    return out


def _row(name: str, res: dict) -> list:
    w, loc = res["whole"], res["local"]
    u = res["updates"]

    def ms(a, b):
        return "-" if a is None else f"{a:.0f} ({b:.0f})"

    def kept(m):
        return "-" if m["kept_share_median"] is None else f"{100 * m['kept_share_median']:.0f}"

    return [
        name,
        res["rooms_every"],
        f"{res['scans']:,}",
        u,
        f"{res['final_map_px'] / 1e6:.2f}",
        f"{w['identical_updates']} / {u}",
        f"{w['time_ms_median']:.0f} / {w['time_ms_max']:.0f}",
        f"{loc['local_updates']} / {u - 1}",
        ms(loc["time_ms_median_local"], loc["whole_time_ms_median_local"]),
        ms(loc["time_ms_median_fallback"], loc["whole_time_ms_median_fallback"]),
        f"{loc['total_s']:.1f} ({loc['whole_total_s']:.1f})",
        f"{loc['identical_updates']} / {u}",
        f"{100 * loc['differing_px_share_mean']:.3f} / {100 * loc['differing_px_share_max']:.2f} %",
        loc["rooms_minus_scratch_max_abs"],
        f"{100 * loc['recall_min']:.1f} / {100 * loc['precision_min']:.1f}",
        f"{kept(w)} / {kept(loc)} %",
    ]


HEADER = [
    "log",
    "rooms every",
    "scans",
    "room updates",
    "map Mpx",
    "whole = scratch",
    "whole ms p50 / max",
    "local: done locally",
    "local ms p50 there (whole)",
    "local ms p50 on fall-back (whole)",
    "local total s (whole)",
    "local = scratch",
    "local px differing mean / max",
    "local rooms off",
    "local recall / precision, min",
    "ids kept whole / local",
]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--logs", nargs="+", choices=sorted(LOGS), default=list(LOGS))
    ap.add_argument("--graph-every", type=int, default=80)
    ap.add_argument(
        "--rooms-every",
        type=int,
        nargs="+",
        default=[80, 10],
        help="room update rates (scans) to run, each with both mappers",
    )
    ap.add_argument("--max-scans", type=int)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args(argv)
    import topojax as tj

    # compile the segmentation kernels once, outside the timed updates
    tj.segment_rooms(tj.load_map(Path(tj.__file__).parent / "data" / "intel.png"))
    rows, results = [], []
    for every in args.rooms_every:
        for name in args.logs:
            path = args.data / "logs" / "carmen_corrected" / LOGS[name]
            res = run_log(path, args.graph_every, every, args.max_scans)
            results.append(res)
            rows.append(_row(name, res))
            print(rows[-1], flush=True)
    info = machine_info()
    out = args.out or RESULTS_DIR / f"rooms_incremental_{machine_slug(info)}.json"
    write_json(
        out,
        {
            **provenance(),
            "machine": info,
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "logs": results,
        },
    )
    table = markdown_table(HEADER, rows)
    print(table)
    if args.markdown:
        write_text(args.markdown, table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
