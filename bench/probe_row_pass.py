"""Probe: what the distance stage's row pass costs, and what skipping its offsets could save.

Two measurements on the paper maps (``docs/performance-notes.md``, "Row pass"):

``floor``
    :func:`topojax.dense_fields` as shipped, alternating with the same code whose row pass
    stops before its first offset (each band keeps its column-pass values: wrong
    distances, but the cost of everything else: kernel 1, the rest of kernel 2, the
    host's copies).  The difference is what the offset loop costs end to end.
``skip``
    Simulated (NumPy, exact integers) count of the row pass's steps of 16 offsets with the
    shipped exit rule, against a rule that also skips a step when no unfinished needed
    pixel has a column with an obstacle within R rows at that step's offsets (tested row
    by row, so the best any such skipping could do).

Run from the repository root::

    python bench/probe_row_pass.py floor --repeats 21 --rounds 3
    python bench/probe_row_pass.py skip
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import DEFAULT_DATA, machine_info, paper_obstacles, use_checkout, write_json  # noqa: E402

# ------------------------------------------------------------------------------- floor


def floor(maps: dict[str, np.ndarray], repeats: int, rounds: int) -> dict:
    import jax

    from topojax import pipeline
    from topojax.fields import distance

    shipped = distance._band_min

    def no_offsets(gb, mb, *, half_width, width):
        return gb[:, half_width : half_width + width]

    def timed() -> dict[str, float]:
        for obstacles in maps.values():
            pipeline.dense_fields(obstacles)
        samples: dict[str, list[float]] = {name: [] for name in maps}
        for _ in range(repeats):
            for name, obstacles in maps.items():
                gc.collect()
                t0 = time.perf_counter()
                pipeline.dense_fields(obstacles)
                samples[name].append((time.perf_counter() - t0) * 1e3)
        return {name: round(statistics.median(v), 2) for name, v in samples.items()}

    out: dict[str, list] = {"shipped": [], "no_offsets": []}
    try:
        for _ in range(rounds):
            for label, band_min in (("shipped", shipped), ("no_offsets", no_offsets)):
                distance._band_min = band_min
                jax.clear_caches()  # the kernels are traced again with this row pass
                out[label].append(timed())
                print(
                    f"{label:10s}", "  ".join(f"{k} {v:6.2f} ms" for k, v in out[label][-1].items())
                )
    finally:
        distance._band_min = shipped
        jax.clear_caches()
    return out


# -------------------------------------------------------------------------------- skip


def column_pass(obstacles: np.ndarray, r: int) -> np.ndarray:
    """Distance along each column to the nearest obstacle within ``r`` rows; -1 if none."""
    h, w = obstacles.shape
    out = np.full((h, w), -1, np.int64)
    rows = np.arange(h)
    for c in range(w):
        hits = np.flatnonzero(obstacles[:, c])
        if hits.size == 0:
            continue
        i = np.searchsorted(hits, rows)
        below = np.where(i < hits.size, hits[np.minimum(i, hits.size - 1)] - rows, h + r)
        above = np.where(i > 0, rows - hits[np.maximum(i - 1, 0)], h + r)
        d = np.minimum(below, above)
        out[:, c] = np.where(d <= r, d, -1)
    return out


def offset_step(g, best, k, r, n, unroll):
    """Offsets ``k .. k + unroll - 1`` (at most ``r``) of the row pass on one band."""
    for kk in range(k, min(k + unroll, r + 1)):
        right, left = g[:, r + kk : r + kk + n], g[:, r - kk : r - kk + n]
        best = np.minimum(best, np.minimum(left, right) + kk * kk)
    return best


def skip_counts(obstacles: np.ndarray) -> dict[str, int]:
    from topojax.fields.distance import _BAND_ROWS, _UNROLL
    from topojax.fields.filters import HALO_PX

    r, tile = 227, 256
    h, w = obstacles.shape
    none = np.iinfo(np.int64).max // 4
    v = column_pass(obstacles, r)
    pad = r + tile + 2 * HALO_PX
    sq = np.full((h + 2 * pad, w + 2 * pad), none, np.int64)
    sq[pad : pad + h, pad : pad + w] = np.where(v >= 0, v * v, none)
    n = tile + 2 * HALO_PX
    counts = {"shipped": 0, "skip": 0}
    for r0 in range(-HALO_PX, h - HALO_PX, tile):
        for c0 in range(-HALO_PX, w - HALO_PX, tile):
            cols = np.arange(c0, c0 + n)
            for b0 in range(r0, r0 + n, _BAND_ROWS):
                rows = np.arange(b0, b0 + _BAND_ROWS)
                g = sq[pad + rows][:, pad + c0 - r : pad + c0 + n + r]
                near = g < none
                inside = ((rows >= 0) & (rows < h))[:, None] & ((cols >= 0) & (cols < w))
                reach = near.any(0)
                window = np.convolve(reach, np.ones(2 * r + 1), "valid") > 0
                mask = inside & window[None, :]
                if not mask.any():
                    continue
                start = g[:, r : r + n]

                best, k = start, 1
                while k <= r and (mask & (best > k * k)).any():
                    best, k = offset_step(g, best, k, r, n, _UNROLL), k + _UNROLL
                    counts["shipped"] += 1
                best = start
                for k in range(1, r + 1, _UNROLL):
                    ks = range(k, min(k + _UNROLL, r + 1))
                    has_near = np.zeros(mask.shape, bool)
                    for kk in ks:
                        has_near |= near[:, r + kk : r + kk + n] | near[:, r - kk : r - kk + n]
                    if (mask & (best > k * k) & has_near).any():
                        best = offset_step(g, best, k, r, n, _UNROLL)
                        counts["skip"] += 1
    return counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("probe", choices=("floor", "skip"))
    parser.add_argument("--repeats", type=int, default=21, help="calls per map per round")
    parser.add_argument("--rounds", type=int, default=3, help="alternations (floor)")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--out", type=Path, help="also write the results as JSON here")
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.rounds < 1:
        parser.error(f"--repeats and --rounds must be >= 1, got {args.repeats}, {args.rounds}")
    use_checkout()
    maps = paper_obstacles(args.data)
    if args.probe == "floor":
        results = floor(maps, args.repeats, args.rounds)
    else:
        results = {}
        for name, obstacles in maps.items():
            results[name] = skip_counts(obstacles)
            c = results[name]
            print(
                f"{name:8s} steps shipped {c['shipped']:5d}  skip {c['skip']:5d}  "
                f"ratio {c['skip'] / c['shipped']:.3f}"
            )
    if args.out:
        write_json(args.out, {"machine": machine_info(), "probe": args.probe, "results": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
