"""Benchmark: rooms kept by the incremental mapper on real CARMEN logs.

For each log (Intel, FR079, ACES; corrected poses) the mapper replays every scan with the
graph loop every ``--graph-every`` scans and a room update after each graph update.  At
every room update it checks the relation the mapper documents: its labels equal
``segment_rooms(mapper.occupancy)`` up to a one-to-one renaming of the ids.  It reports
the time per room update (median, p90, max; warm: the segmentation kernels are compiled
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


def run_log(path: Path, graph_every: int, max_scans: int | None) -> dict:
    import topojax as tj

    mapper = tj.IncrementalMapper(graph_every=graph_every, rooms_every=graph_every)
    updates = []
    identical = 0
    t0 = time.perf_counter()
    for i, scan in enumerate(tj.read_scans(path)):
        if max_scans is not None and i >= max_scans:
            break
        report = mapper.add_scan(scan)
        up = report.rooms_update
        if up is None:
            continue
        seg = mapper.rooms
        before = len(updates) and updates[-1]["n_rooms"]
        scratch = tj.segment_rooms(mapper.occupancy)
        same = _same_up_to_ids(seg.labels, scratch.labels)
        identical += same
        kept = before - len(up.removed) - len(up.changed) if before else 0
        updates.append(
            {
                "scan": i,
                "n_rooms": up.n_rooms,
                "added": len(up.added),
                "removed": len(up.removed),
                "changed": len(up.changed),
                "kept_share": kept / before if before else None,
                "time_ms": up.time_s * 1e3,
                "map_px": int(seg.labels.size),
                "identical": bool(same),
            }
        )
    wall = time.perf_counter() - t0
    times = np.array([u["time_ms"] for u in updates[1:]] or [np.nan])
    kept = [u["kept_share"] for u in updates if u["kept_share"] is not None]
    return {
        "log": path.name,
        "scans": i + 1 if max_scans is None else min(i + 1, max_scans),
        "updates": len(updates),
        "identical_updates": identical,
        "rooms_final": updates[-1]["n_rooms"] if updates else 0,
        "time_ms_median": float(np.nanmedian(times)),
        "time_ms_p90": float(np.nanpercentile(times, 90)),
        "time_ms_max": float(np.nanmax(times)),
        "final_map_px": updates[-1]["map_px"] if updates else 0,
        "kept_share_median": float(np.median(kept)) if kept else None,
        "wall_s": wall,
        "per_update": updates,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--logs", nargs="+", choices=sorted(LOGS), default=list(LOGS))
    ap.add_argument("--graph-every", type=int, default=80)
    ap.add_argument("--max-scans", type=int)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args(argv)
    import topojax as tj

    # compile the segmentation kernels once, outside the timed updates
    tj.segment_rooms(tj.load_map(Path(tj.__file__).parent / "data" / "intel.png"))
    rows, results = [], []
    for name in args.logs:
        path = args.data / "logs" / "carmen_corrected" / LOGS[name]
        res = run_log(path, args.graph_every, args.max_scans)
        results.append(res)
        rows.append(
            [
                name,
                res["scans"],
                res["updates"],
                f"{res['identical_updates']}/{res['updates']}",
                res["rooms_final"],
                f"{res['final_map_px'] / 1e6:.2f}",
                f"{res['time_ms_median']:.0f} / {res['time_ms_p90']:.0f} / "
                f"{res['time_ms_max']:.0f}",
                "-" if res["kept_share_median"] is None else f"{res['kept_share_median']:.2f}",
            ]
        )
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
    table = markdown_table(
        [
            "log",
            "scans",
            "room updates",
            "= from scratch",
            "rooms (end)",
            "map Mpx (end)",
            "update ms p50 / p90 / max",
            "ids kept (median share)",
        ],
        rows,
    )
    print(table)
    if args.markdown:
        write_text(args.markdown, table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
