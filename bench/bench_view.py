"""Benchmark: the interactive viewer (``tj.write_view``) on a replay and on large maps.

For each case:

* **write**: ``tj.write_view`` wall time (median of ``--repeats`` after one warm-up; the
  payload is built from the objects in memory, the pipeline is not timed) and the HTML
  file's size;
* **browser** (headless Chromium driven by Selenium, the page opened from disk): time from
  navigation until the page reports ready (every raster's coarsest tiles decoded and
  drawn), the page's own ``first_draw_ms`` (``performance.now()`` from its script's start
  to the end of its first draw), and while panning by 5 CSS px per animation frame for
  ``--frames`` frames, the time between frames (median, p90) and the time the page spends
  drawing each (median, p90): at the whole map in view (``fit``) and zoomed in 4 x.
  Headless Chromium rasterises on the CPU here, so frame times are an upper bound for a
  desktop browser with a GPU.

Cases:

* ``intel_replay``: the Intel CARMEN log (``--max-scans``, default all) through an
  ``IncrementalMapper`` (``graph_every=80``) with a ``tj.Timeline``; the view has the
  timeline of every graph update;
* ``office_g``: the largest map of the shared data (IPA ``office_g``, 4.7 Mpx), full
  pipeline;
* ``edmonton_3x3``: the Edmonton SLAM map tiled 3 x 3 (34 Mpx, about 37,000 edges): a
  synthetic stand-in for the largest maps the viewer is meant for (4-40 Mpx, thousands of
  edges).

Run from the repository root::

    python bench/bench_view.py                        # all cases (about 10 minutes)
    python bench/bench_view.py --cases office_g --max-scans 400
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    LARGE_MAPS,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    median,
    ms,
    use_checkout,
    write_json,
    write_text,
)

CASES = ("intel_replay", "office_g", "edmonton_3x3")


def build_case(name: str, data: Path, max_scans: int | None):
    """``(obj, write_view keyword arguments, description)`` of a case."""
    import topojax as tj

    if name == "intel_replay":
        mapper = tj.IncrementalMapper(graph_every=80)
        timeline = tj.Timeline()
        for i, scan in enumerate(
            tj.read_scans(data / "logs/carmen_corrected/intel-corrected.log.gz")
        ):
            if max_scans is not None and i >= max_scans:
                break
            timeline.record(mapper, mapper.add_scan(scan), scan)
        return (
            mapper,
            {"timeline": timeline},
            {"scans": mapper.n_scans, "updates": timeline.n_frames},
        )
    if name == "office_g":
        occupancy = tj.load_map(data / LARGE_MAPS["office_g"], mode="ipa", resolution_m=0.05)
        return tj.build_graph(occupancy), {}, {}
    if name == "edmonton_3x3":
        m = tj.load_map(data / LARGE_MAPS["edmonton_0.06"])
        tiled = [np.tile(a, (3, 3)) for a in (m.occupied, m.free, m.unknown)]
        occupancy = tj.OccupancyMap(*tiled, resolution_m=m.resolution_m)
        return tj.build_graph(occupancy), {}, {}
    raise ValueError(f"unknown case {name!r}; expected one of {CASES}")


def time_write(obj, kwargs: dict, path: Path, repeats: int) -> dict:
    import topojax as tj

    tj.write_view(obj, path, **kwargs)  # warm-up: imports, numba caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        tj.write_view(obj, path, **kwargs)
        times.append(time.perf_counter() - t0)
    return {"write_ms": ms(median(times)), "html_mb": round(path.stat().st_size / 1e6, 3)}


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    binary = next(
        (
            shutil.which(n)
            for n in ("chromium", "chromium-browser", "google-chrome")
            if shutil.which(n)
        ),
        None,
    )
    if binary is None or shutil.which("chromedriver") is None:
        return None
    options = Options()
    options.binary_location = binary
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        "--window-size=1400,900",
        "--force-device-scale-factor=1",
    ):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    driver.set_script_timeout(300)
    return driver


def _stats(values: list[float]) -> tuple[float, float]:
    v = np.asarray(values, np.float64)
    return round(float(np.median(v)), 2), round(float(np.percentile(v, 90)), 2)


def time_browser(driver, path: Path, frames: int) -> dict:
    t0 = time.perf_counter()
    driver.get(path.resolve().as_uri())
    state = None
    while time.perf_counter() - t0 < 300:
        state = driver.execute_script("return window.topojaxView && window.topojaxView.state")
        if state in ("ready", "error"):
            break
        time.sleep(0.02)
    out = {"ready_ms": ms(time.perf_counter() - t0), "state": state}
    if state != "ready":
        out["error"] = driver.execute_script("return window.topojaxView.error")
        return out
    out["first_draw_ms"] = round(driver.execute_script("return topojaxView.stats.first_draw_ms"), 1)
    for label, zoom in (("fit", 1.0), ("zoom4", 4.0)):
        driver.execute_script(
            "topojaxView.fit(); var v = topojaxView.view(); "
            "topojaxView.zoomAt(arguments[0], v.w / 2, v.h / 2)",
            zoom,
        )
        time.sleep(0.5)  # the tiles in sight decode
        pan = driver.execute_async_script(
            "var done = arguments[1]; topojaxView.benchmarkPan(arguments[0], 5).then(done)", frames
        )
        out[f"{label}_frame_ms"], out[f"{label}_frame_p90_ms"] = _stats(pan["frame_ms"])
        out[f"{label}_draw_ms"], out[f"{label}_draw_p90_ms"] = _stats(pan["draw_ms"])
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES), help=f"of {', '.join(CASES)}")
    parser.add_argument("--max-scans", type=int, help="intel_replay: stop after this many")
    parser.add_argument("--repeats", type=int, default=3, help="timed writes per case")
    parser.add_argument("--frames", type=int, default=90, help="animation frames per pan")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown report here")
    args = parser.parse_args(argv)
    use_checkout()
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    driver = browser()
    if driver is None:
        print("no chromium / chromedriver: browser timings are skipped", flush=True)
    entries = {}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for name in cases:
                obj, kwargs, extra = build_case(name, args.data, args.max_scans)
                path = Path(tmp) / f"{name}.html"
                entry = {**extra, **_graph_size(obj), **time_write(obj, kwargs, path, args.repeats)}
                if driver is not None:
                    entry["browser"] = time_browser(driver, path, args.frames)
                entries[name] = entry
                print(name, entry, flush=True)
    finally:
        if driver is not None:
            driver.quit()
    info = machine_info(with_jax=False)
    rows = []
    for name, e in entries.items():
        b = e.get("browser", {})
        rows.append(
            [
                name,
                f"{e['map_mpx']:.1f}",
                e["edges"],
                e["write_ms"],
                e["html_mb"],
                b.get("ready_ms", "-"),
                b.get("first_draw_ms", "-"),
                f"{b.get('fit_frame_ms', '-')} / {b.get('fit_frame_p90_ms', '-')}",
                f"{b.get('zoom4_frame_ms', '-')} / {b.get('zoom4_frame_p90_ms', '-')}",
            ]
        )
    report = "\n".join(
        [
            f"Machine: {info.get('cpu_model', '?')}, {info.get('cpu_count', '?')} CPUs; "
            "headless Chromium (CPU rasterisation), 1400 x 900 window.",
            "",
            markdown_table(
                [
                    "case",
                    "map Mpx",
                    "edges",
                    "write ms",
                    "HTML MB",
                    "ready ms",
                    "first draw ms",
                    "pan frame ms, whole map (median / p90)",
                    "pan frame ms, zoom 4 x (median / p90)",
                ],
                rows,
            ),
        ]
    )
    print(report)
    out = args.out or RESULTS_DIR / f"view_{machine_slug(info)}.json"
    write_json(
        out,
        {
            "machine": info,
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "cases": entries,
        },
    )
    if args.markdown:
        write_text(args.markdown, report + "\n")
    print(f"wrote {out}")
    return 0


def _graph_size(obj) -> dict:
    result = obj.to_result(update=False) if hasattr(obj, "to_result") else obj
    h, w = result.map.shape
    return {
        "map_px": [h, w],
        "map_mpx": round(h * w / 1e6, 2),
        "vertices": result.graph.number_of_nodes(),
        "edges": result.graph.number_of_edges(),
    }


if __name__ == "__main__":
    raise SystemExit(main())
