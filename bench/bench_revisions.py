"""Benchmark: two checkouts of topojax side by side, to show a change keeps its speed.

Each round starts one fresh process per checkout (alternating which goes first), so both
meet the same machine load.  In each process:

* **pipeline**: :func:`topojax.build_graph` on the three bundled paper maps, one warm-up
  call, then ``--repeats`` timed calls (wall time of the call and its per-stage
  ``timings_s``); the graph's size and a hash of its skeleton check the outputs agree;
* **incremental**: :func:`topojax.replay` of a CARMEN log (default the Intel log of the
  shared data, ``--max-scans`` scans), reporting the mapper's amortised milliseconds per
  scan and the final graph's size.

Medians are over all rounds' samples.  Results go to ``bench/results/revisions_<machine>.json``
with ``git describe`` of both checkouts; a markdown table is printed.

Run from the repository root, with the base revision checked out somewhere else::

    git worktree add --detach /tmp/topojax-base <revision>
    python bench/bench_revisions.py --base /tmp/topojax-base --rounds 3
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    REPO_ROOT,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    median,
    ms,
    write_json,
)

MAPS = ("intel", "office", "a_scan")


def git_describe(checkout: Path) -> str:
    """``git describe --always --dirty --tags`` of ``checkout`` ("unknown" outside git)."""
    try:
        return subprocess.run(
            ["git", "-C", str(checkout), "describe", "--always", "--dirty", "--tags"],
            capture_output=True,
            text=True,
            check=True,
            timeout=30,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def worker(args: argparse.Namespace) -> None:
    """Measure the checkout first on ``sys.path``; print one JSON line."""
    import topojax as tj

    out: dict = {"topojax_file": tj.__file__, "pipeline": {}, "incremental": None}
    data = Path(tj.__file__).parent / "data"
    for name in MAPS:
        occupancy = tj.load_map(data / f"{name}.png")
        first = tj.build_graph(occupancy)  # compiles and warms
        totals, stages = [], {}
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            res = tj.build_graph(occupancy)
            res.graph  # noqa: B018 - a networkx graph in every revision (built lazily in newer ones)
            totals.append(time.perf_counter() - t0)
            for stage, seconds in res.timings_s.items():
                stages.setdefault(stage, []).append(seconds)
        out["pipeline"][name] = {
            "total_s": totals,
            "stages_s": stages,
            "vertices": first.graph.number_of_nodes(),
            "edges": first.graph.number_of_edges(),
            "skeleton_sha1": hashlib.sha1(first.skeleton.tobytes()).hexdigest(),
        }
    if args.log:
        with tempfile.TemporaryDirectory() as tmp:
            summary = tj.replay(
                args.log, out_dir=tmp, progress=False, max_scans=args.max_scans or None
            )
        out["incremental"] = {
            "n_scans": summary["n_scans"],
            "wall_s": summary["wall_s"],
            "add_scan_ms_per_scan": summary["timings"]["add_scan"]["per_scan_ms"],
            "vertices": summary["vertices"],
            "edges": summary["edges"],
        }
    print(json.dumps(out))


def run_worker(checkout: Path, args: argparse.Namespace) -> dict:
    cmd = [
        sys.executable,
        str(Path(__file__).resolve()),
        "--worker",
        "--repeats",
        str(args.repeats),
    ]
    cmd += ["--log", str(args.log) if args.log else "", "--max-scans", str(args.max_scans)]
    env = dict(os.environ, PYTHONPATH=str(checkout))
    proc = subprocess.run(
        cmd, capture_output=True, text=True, env=env, cwd=str(checkout), timeout=3600
    )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"worker in {checkout} failed: {proc.stderr[-3000:]}")
    result = json.loads(lines[-1])
    if not Path(result["topojax_file"]).resolve().is_relative_to(checkout.resolve()):
        raise RuntimeError(f"worker in {checkout} imported {result['topojax_file']}")
    return result


def summarise(runs: list[dict]) -> dict:
    pipeline = {}
    for name in MAPS:
        per = [r["pipeline"][name] for r in runs]
        stages: dict[str, list[float]] = {}
        for p in per:
            for stage, values in p["stages_s"].items():
                stages.setdefault(stage, []).extend(values)
        pipeline[name] = {
            "total_ms": ms(median(v for p in per for v in p["total_s"])),
            "stages_ms": {k: ms(median(v)) for k, v in stages.items()},
            "vertices": per[0]["vertices"],
            "edges": per[0]["edges"],
            "skeleton_sha1": per[0]["skeleton_sha1"],
        }
    out = {"pipeline": pipeline}
    inc = [r["incremental"] for r in runs if r["incremental"]]
    if inc:
        out["incremental"] = {
            "n_scans": inc[0]["n_scans"],
            "ms_per_scan": round(median(r["add_scan_ms_per_scan"] for r in inc), 4),
            "samples_ms_per_scan": [r["add_scan_ms_per_scan"] for r in inc],
            "vertices": inc[0]["vertices"],
            "edges": inc[0]["edges"],
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", type=Path, help="checkout of the base revision")
    parser.add_argument("--rounds", type=int, default=3, help="fresh processes per checkout")
    parser.add_argument("--repeats", type=int, default=7, help="warm calls per map and process")
    parser.add_argument(
        "--log",
        type=lambda text: Path(text) if text else None,
        default=DEFAULT_DATA / "logs" / "carmen_corrected" / "intel-corrected.log.gz",
        help="log replayed for the incremental numbers ('' to skip)",
    )
    parser.add_argument("--max-scans", type=int, default=0, help="0 = the whole log")
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    if args.base is None:
        parser.error("--base: expected the folder of a checkout of the base revision")
    checkouts = {"base": args.base.resolve(), "new": REPO_ROOT}
    runs: dict[str, list[dict]] = {k: [] for k in checkouts}
    for i in range(args.rounds):
        order = list(checkouts) if i % 2 == 0 else list(reversed(checkouts))
        for key in order:
            runs[key].append(run_worker(checkouts[key], args))
            print(f"round {i + 1}/{args.rounds}: {key} done", file=sys.stderr)
    info = machine_info(with_jax=False)
    result = {
        "benchmark": "revisions",
        "date": time.strftime("%Y-%m-%d"),
        "machine": info,
        "rounds": args.rounds,
        "repeats": args.repeats,
        "log": str(args.log) if args.log else None,
        "checkouts": {k: {"git_describe": git_describe(p)} for k, p in checkouts.items()},
        "results": {k: summarise(v) for k, v in runs.items()},
    }
    base, new = result["results"]["base"], result["results"]["new"]
    rows = []
    for name in MAPS:
        b, n = base["pipeline"][name], new["pipeline"][name]
        same = b["skeleton_sha1"] == n["skeleton_sha1"] and b["edges"] == n["edges"]
        rows.append(
            [
                f"build_graph {name} (ms)",
                b["total_ms"],
                n["total_ms"],
                n["total_ms"] / b["total_ms"],
                same,
            ]
        )
    if "incremental" in base:
        b, n = base["incremental"], new["incremental"]
        rows.append(
            [
                f"replay {b['n_scans']} scans (ms/scan)",
                b["ms_per_scan"],
                n["ms_per_scan"],
                n["ms_per_scan"] / b["ms_per_scan"],
                b["edges"] == n["edges"] and b["vertices"] == n["vertices"],
            ]
        )
    print(markdown_table(["measure", "base", "new", "new/base", "same output"], rows))
    path = args.out or RESULTS_DIR / f"revisions_{machine_slug(info)}.json"
    write_json(path, result)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
