"""Probe: NumPy's huge-page advice and the pipeline's time on large maps.

NumPy asks Linux for transparent huge pages (``madvise(MADV_HUGEPAGE)``) on every array of
4 MiB or more.  Where the kernel's THP ``defrag`` setting is ``madvise`` (a common
default), a page fault in such an array may make the kernel compact memory on the spot
to find a free 2 MiB page, which shows up as system time in whatever stage allocated the
array.  This script times :func:`topojax.build_graph` with NumPy's advice on and off,
alternating in one process (``numpy._core.multiarray._set_madvise_hugepage``, the switch
behind the ``NUMPY_MADVISE_HUGEPAGE`` environment variable), on the shared maps named
with ``--maps`` and on synthetic maps of ``--synthetic`` megapixels (random walls,
reproducible), and reports the medians and the worst call of each (``docs/performance-notes.md``,
"Huge pages").

Run from the repository root::

    python bench/probe_hugepages.py --repeats 10 --out bench/results/probe_hugepages_<machine>.json
"""

from __future__ import annotations

import argparse
import gc
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    LARGE_MAPS,
    PAPER_MAPS,
    machine_info,
    markdown_table,
    median,
    use_checkout,
    write_json,
)


def thp_settings() -> dict[str, str | None]:
    """The kernel's transparent huge page settings (the bracketed choice), if readable."""
    out: dict[str, str | None] = {}
    for name in ("enabled", "defrag"):
        try:
            text = Path(f"/sys/kernel/mm/transparent_hugepage/{name}").read_text()
            out[name] = text.split("[", 1)[1].split("]", 1)[0]
        except (OSError, IndexError):
            out[name] = None
    return out


def synthetic_walls(megapixels: float, seed: int = 0) -> np.ndarray:
    """A (3 : 4) map of ``megapixels`` with a border and random straight walls."""
    rows = int(round((megapixels * 1e6 * 3 / 4) ** 0.5))
    cols = int(round(rows * 4 / 3))
    rng = np.random.default_rng(seed)
    walls = np.zeros((rows, cols), bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    for _ in range(int(15 * megapixels)):
        r, c = int(rng.integers(0, rows)), int(rng.integers(0, cols))
        length = int(rng.integers(rows // 80, rows // 5))
        if rng.random() < 0.5:
            walls[r, c : c + length] = True
        else:
            walls[r : r + length, c] = True
    return walls


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--maps", default="office,office_g,pal_office_7th_floor")
    p.add_argument("--synthetic", default="20", help="comma-separated megapixels ('' for none)")
    p.add_argument(
        "--repeats", type=int, default=10, help="alternations (calls per setting; default 10)"
    )
    p.add_argument("--data", type=Path, default=DEFAULT_DATA)
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    use_checkout()

    from numpy._core import multiarray

    import topojax as tj

    known = {**PAPER_MAPS, **LARGE_MAPS}
    maps: dict[str, object] = {}
    for name in filter(None, args.maps.split(",")):
        if name not in known:
            p.error(f"--maps: unknown map {name!r}; known: {sorted(known)}")
        maps[name] = tj.load_map(args.data / known[name]).occupied
    for mpx in filter(None, args.synthetic.split(",")):
        maps[f"synthetic_{mpx}Mpx"] = synthetic_walls(float(mpx))

    initial = multiarray._get_madvise_hugepage()
    results = {}
    try:
        for name, obstacles in maps.items():
            tj.build_graph(obstacles)  # compile, load numba's cache
            calls: dict[str, list[tuple[float, float]]] = {"advice on": [], "advice off": []}
            for _ in range(args.repeats):
                for label, flag in (("advice on", True), ("advice off", False)):
                    multiarray._set_madvise_hugepage(flag)
                    gc.collect()
                    r0 = resource.getrusage(resource.RUSAGE_SELF)
                    t0 = time.perf_counter()
                    res = tj.build_graph(obstacles)
                    wall = time.perf_counter() - t0
                    r1 = resource.getrusage(resource.RUSAGE_SELF)
                    calls[label].append((wall * 1e3, (r1.ru_stime - r0.ru_stime) * 1e3))
                    del res
            results[name] = {
                "shape": list(np.shape(obstacles)),
                **{
                    label: {
                        "median_ms": median(w for w, _ in v),
                        "max_ms": max(w for w, _ in v),
                        "median_system_ms": median(s for _, s in v),
                        "max_system_ms": max(s for _, s in v),
                        "calls_ms": [round(w, 1) for w, _ in v],
                    }
                    for label, v in calls.items()
                },
            }
    finally:
        multiarray._set_madvise_hugepage(initial)

    rows = []
    for name, r in results.items():
        on, off = r["advice on"], r["advice off"]
        rows.append(
            [
                name,
                "×".join(map(str, r["shape"])),
                f"{on['median_ms']:.1f}",
                f"{on['max_ms']:.1f}",
                f"{on['median_system_ms']:.1f}",
                f"{off['median_ms']:.1f}",
                f"{off['max_ms']:.1f}",
                f"{off['median_system_ms']:.1f}",
            ]
        )
    header = [
        "map",
        "size",
        "on: median ms",
        "on: worst ms",
        "on: system ms",
        "off: median ms",
        "off: worst ms",
        "off: system ms",
    ]
    print(f"THP {thp_settings()}; build_graph, {args.repeats} calls per setting, alternating")
    print(markdown_table(header, rows))
    if args.out is not None:
        write_json(
            args.out,
            {
                "machine": machine_info(),
                "thp": thp_settings(),
                "repeats": args.repeats,
                "results": results,
            },
        )
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
