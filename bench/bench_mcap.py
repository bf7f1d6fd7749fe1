"""Benchmark: writing ROS 2 MCAP recordings.

Two cases: the corrected Intel log replayed with and without ``mcap=`` (the recording's
cost is the difference of the two wall times; every scan on /scan and /tf, the map and
graph at every graph update), and ``save_mcap`` of the largest shared map's full-map
result (one /map, one /topology).  Medians of ``--repeats`` runs (warm: the kernels are
compiled by a first run that is not counted); file sizes in MB.

    python bench/bench_mcap.py                  # about 2 minutes
    python bench/bench_mcap.py --max-scans 300 --markdown out.md
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

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

INTEL = "logs/carmen_corrected/intel-corrected.log.gz"
LARGEST = "maps/ipa/office_g.png"  # 2314 x 2050 px, the largest shared map


def _replay_s(log: Path, out: Path, mcap: Path | None, max_scans: int | None) -> float:
    import topojax as tj

    t0 = time.perf_counter()
    tj.replay(log, out_dir=out, progress=False, max_scans=max_scans, mcap=mcap)
    return time.perf_counter() - t0


def replay_case(data: Path, repeats: int, max_scans: int | None) -> dict:
    log = data / INTEL
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        _replay_s(log, tmp / "warm", None, 50)  # compile
        plain, recorded, size = [], [], 0.0
        for k in range(repeats):
            plain.append(_replay_s(log, tmp / f"p{k}", None, max_scans))
            path = tmp / f"r{k}.mcap"
            recorded.append(_replay_s(log, tmp / f"r{k}", path, max_scans))
            size = path.stat().st_size / 1e6
    return {
        "replay_s": statistics.median(plain),
        "replay_with_mcap_s": statistics.median(recorded),
        "mcap_s": statistics.median(recorded) - statistics.median(plain),
        "mcap_mb": size,
    }


def map_case(data: Path, repeats: int) -> dict:
    import topojax as tj

    occ = tj.load_map(data / LARGEST, mode="ipa", resolution_m=0.05)
    result = tj.build_graph(occ)
    rooms = tj.segment_rooms(result)
    times, size = [], 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(repeats + 1):
            path = Path(tmp) / f"m{k}.mcap"
            t0 = time.perf_counter()
            tj.save_mcap(result, path, rooms=rooms)
            if k:  # the first call imports the writer
                times.append(time.perf_counter() - t0)
            size = path.stat().st_size / 1e6
    return {
        "map_px": list(occ.shape),
        "vertices": result.graph.number_of_nodes(),
        "edges": result.graph.number_of_edges(),
        "rooms": rooms.n_rooms,
        "save_mcap_s": statistics.median(times),
        "mcap_mb": size,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-scans", type=int)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args(argv)
    replay = replay_case(args.data, args.repeats, args.max_scans)
    full = map_case(args.data, args.repeats)
    info = machine_info()
    out = args.out or RESULTS_DIR / f"mcap_{machine_slug(info)}.json"
    write_json(
        out,
        {
            **provenance(),
            "machine": info,
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "intel_replay": replay,
            "largest_map": full,
        },
    )
    table = markdown_table(
        ["case", "what is written", "write s", "MCAP MB"],
        [
            [
                "Intel replay (910 scans)",
                "every scan on /scan and /tf, map and graph at each graph update",
                f"{replay['mcap_s']:.2f} (replay {replay['replay_s']:.2f})",
                f"{replay['mcap_mb']:.1f}",
            ],
            [
                f"`office_g` ({full['map_px'][0]} x {full['map_px'][1]} px)",
                f"/map, /topology ({full['edges']} edges), /rooms ({full['rooms']})",
                f"{full['save_mcap_s']:.2f}",
                f"{full['mcap_mb']:.1f}",
            ],
        ],
    )
    print(table)
    if args.markdown:
        write_text(args.markdown, table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
