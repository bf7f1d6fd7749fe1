"""Probe: XLA compiler options for the distance stage's two kernels only.

``jax.jit(..., compiler_options=...)`` sets XLA's debug options for one executable, so a
library could tune its own kernels without touching its users' other JAX work (unlike
``XLA_FLAGS`` or ``NPROC``, which are process-wide).  For each option set this script
compiles the two kernels of :func:`topojax.dense_fields` (the column pass and everything
after it) with and without the options, checks that all four outputs are identical on
the paper maps, and times ``dense_fields`` with the two variants alternating in one
process (medians; ``docs/performance-notes.md``, "XLA compiler options").

Run from the repository root::

    python bench/probe_compiler_options.py --repeats 15
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    machine_info,
    median,
    ms,
    paper_obstacles,
    use_checkout,
    write_json,
)

#: Option sets tried (each against the defaults).  Names are XLA's debug options.
OPTION_SETS = [
    {"xla_cpu_enable_fast_min_max": True},
    {"xla_cpu_use_xnnpack": True},
    {"xla_cpu_multi_thread_eigen": False},
    {"xla_cpu_enable_concurrency_optimized_scheduler": True},
    {"xla_cpu_prefer_vector_width": 512},
    {"xla_cpu_max_isa": "AVX2"},
    {"xla_cpu_use_fusion_emitters": False},
    {"xla_cpu_enable_fast_math": True},
]


def kernels(options: dict):
    """The two jitted kernels of ``dense_fields`` (the library's own functions, not
    copies), compiled with ``options``."""
    import jax

    from topojax.fields import dense as pipeline

    column_tiles = jax.jit(
        pipeline._column_tiles.__wrapped__,
        static_argnames=("half_width",),
        compiler_options=options,
    )
    forward_tiles = jax.jit(
        pipeline._forward_tiles.__wrapped__,
        static_argnames=("tile_px", "half_width", "ksize"),
        compiler_options=options,
    )
    return column_tiles, forward_tiles


def compare(maps: dict[str, np.ndarray], options: dict, repeats: int) -> dict:
    from topojax.fields import dense as pipeline

    shipped = (pipeline._column_tiles, pipeline._forward_tiles)
    variants = {"default": shipped, "options": kernels(options)}
    out: dict = {"options": options}
    try:
        first = {}
        for col, fwd in variants.values():
            pipeline._column_tiles, pipeline._forward_tiles = col, fwd
            for name, obstacles in maps.items():
                fields = pipeline.dense_fields(obstacles)
                arrays = (fields.sq_distance_px, fields.distance, fields.lap_abs, fields.ridges)
                if name not in first:
                    first[name] = arrays
                elif not all(
                    np.array_equal(a, b) for a, b in zip(first[name], arrays, strict=True)
                ):
                    out["identical"] = False
                    return out  # a different result is not a candidate, however fast
        out["identical"] = True
        samples: dict = {label: {name: [] for name in maps} for label in variants}
        order = list(variants.items())
        for i in range(repeats):
            for label, (col, fwd) in order if i % 2 == 0 else order[::-1]:
                pipeline._column_tiles, pipeline._forward_tiles = col, fwd
                for name, obstacles in maps.items():
                    gc.collect()
                    t0 = time.perf_counter()
                    pipeline.dense_fields(obstacles)
                    samples[label][name].append(time.perf_counter() - t0)
        for label in variants:
            out[f"{label}_ms"] = {n: ms(median(v)) for n, v in samples[label].items()}
        out["ratio"] = {n: round(out["options_ms"][n] / out["default_ms"][n], 3) for n in maps}
    finally:
        pipeline._column_tiles, pipeline._forward_tiles = shipped
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=15, help="alternations per option set")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument(
        "--options", type=json.loads, action="append", help="one option set as JSON (repeatable)"
    )
    parser.add_argument("--out", type=Path, help="also write the results as JSON here")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    use_checkout()

    maps = paper_obstacles(args.data)
    results = []
    for options in args.options or OPTION_SETS:
        r = compare(maps, options, args.repeats)
        results.append(r)
        if r["identical"]:
            print(f"{json.dumps(options)}: options / default {r['ratio']}  ({r['default_ms']} ms)")
        else:
            print(f"{json.dumps(options)}: outputs differ from the default kernels")
    if args.out:
        write_json(
            args.out, {"machine": machine_info(), "repeats": args.repeats, "results": results}
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
