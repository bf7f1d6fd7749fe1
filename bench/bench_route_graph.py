"""Benchmark: topojax's route graph against NVIDIA SWAGGER's waypoint graph on real maps.

For every map of ``maps_route_graph.py`` (every real map in ``../shared/data/maps`` and the
final maps of three CARMEN replays) and every robot radius (0.3 m and 0.2 m):

* **SWAGGER** (``../shared/peers/swagger``, default configuration) runs in its own virtual
  environment (``bench/swagger_worker.py``, one process per map and radius) on topojax's
  free mask: 255 where the map is known free, 0 elsewhere (occupied and unknown), so both
  tools see the same free space and SWAGGER, like topojax, treats the map border as a
  wall.  Its build is timed inside the worker: *cold* (first build in the process, numba
  compilation included) and *warm* (the median of ``--warm-runs`` more builds, default 3).
* **topojax**: ``topojax.routegraph.route_graph(map, robot_radius_m=r)`` timed in this
  process: *first* (first call for this map; the first map also pays JIT compilation)
  and *warm* (the median of ``--warm-runs`` more calls).
* Both graphs are scored by ``topojax.routegraph.evaluate.evaluate_route_graph`` with the
  same seed, so both are asked the same start/goal pairs; ``generation_s`` is the warm
  time.

SWAGGER's graph enters the evaluator in topojax's graph schema (``networkx.MultiGraph``):
nodes carry ``pixel`` (row, col), ``world`` (x, y) at the pixel centre in the map's frame
(``OccupancyMap.pixel_to_world``) and ``kind``; each edge is SWAGGER's straight segment,
with ``world`` and ``waypoints`` its two end points (float (2, 2), metres), ``path`` the
8-connected pixels of the segment (int32 (K, 2)) and ``length_m`` SWAGGER's weight.

Run from the repository root (SWAGGER installed as ``../shared/peers/README.md`` says,
``--swagger-venv`` or ``$SWAGGER_VENV``, default ``~/.venvs/swagger``)::

    python bench/bench_route_graph.py --markdown /tmp/rg.md --pictures docs/route-graphs
    python bench/bench_route_graph.py --quick --out /tmp/rg.json      # 5 maps
    python bench/bench_route_graph.py --peers-only --maps warehouse office_c --out /tmp/s.json
    python bench/bench_route_graph.py --self-check     # SWAGGER's frame on an asymmetric map
    python bench/bench_route_graph.py --list

``--peers-only`` skips topojax's route graph (SWAGGER is still scored when the evaluator
can be imported).  Results: ``bench/results/route_graph_<machine>.json`` (per map and
radius, averages per radius and tool) and a markdown table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # for `common`, however this is run

from common import (  # noqa: E402
    DEFAULT_DATA,
    REPO_ROOT,
    RESULTS_DIR,
    machine_info,
    machine_slug,
    markdown_table,
    use_checkout,
    write_json,
    write_text,
)
from maps_route_graph import GROUPS, QUICK_MAPS, MapSpec, benchmark_maps, load_spec  # noqa: E402

PEERS_DIR = REPO_ROOT.parent / "shared" / "peers"
WORKER = Path(__file__).resolve().parent / "swagger_worker.py"
DEFAULT_VENV = Path(os.environ.get("SWAGGER_VENV", Path.home() / ".venvs" / "swagger"))
#: The SWAGGER snapshot in ``../shared/peers`` (its README).
SWAGGER_COMMIT = "e85a7e727756788c117bee91ece57348889433dd"
#: Maps drawn for ``--pictures`` (those present among the maps run).
PICTURE_MAPS = ("warehouse", "pal_office_7th_floor", "office_c", "intel_0.05")
PICTURE_MAX_BYTES = 200_000


# ---------------------------------------------------------------------------- SWAGGER side
def free_image(occupancy) -> np.ndarray:
    """uint8 (H, W): 255 where ``occupancy`` is known free, 0 elsewhere."""
    return np.where(np.asarray(occupancy.free, bool), 255, 0).astype(np.uint8)


def run_swagger(
    occupancy,
    radius_m: float,
    work: Path,
    *,
    venv: Path,
    peers: Path,
    timeout_s: float,
    warm_runs: int,
) -> dict:
    """Build SWAGGER's graph of ``occupancy`` in its venv (once, then ``warm_runs`` more
    times); returns the worker's document."""
    stem = work / f"swagger_{radius_m:g}"
    npz, out = stem.with_suffix(".npz"), stem.with_suffix(".json")
    np.savez(
        npz,
        image=free_image(occupancy),
        resolution_m=float(occupancy.resolution_m),
        robot_radius_m=float(radius_m),
        origin=np.asarray(occupancy.origin, np.float64),
        warm_runs=int(warm_runs),
    )
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(peers / "swagger-cpu-shims"), str(peers / "swagger")])
    t0 = time.perf_counter()
    proc = subprocess.run(
        [str(venv / "bin" / "python"), str(WORKER), str(npz), str(out)],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        env=env,
    )
    process_s = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"SWAGGER worker failed ({proc.returncode}): {proc.stderr[-2000:]}")
    doc = json.loads(out.read_text())
    doc["timing"]["process_s"] = process_s
    return doc


def segment_pixels(p0, p1) -> np.ndarray:
    """8-connected pixels (int32 (K, 2)) of the straight segment from ``p0`` to ``p1``."""
    p0, p1 = np.asarray(p0, np.float64), np.asarray(p1, np.float64)
    n = int(np.max(np.abs(p1 - p0))) + 1
    t = np.linspace(0.0, 1.0, max(n, 2))[:, None]
    pts = np.rint(p0 + t * (p1 - p0)).astype(np.int32)
    keep = np.ones(len(pts), bool)
    keep[1:] = np.any(pts[1:] != pts[:-1], axis=1)
    return pts[keep] if keep.sum() >= 2 else np.stack([pts[0], pts[-1]])


def swagger_graph(doc: dict, occupancy):
    """SWAGGER's graph (worker document) as a ``networkx.MultiGraph`` in topojax's schema.

    Raises if the worker's world coordinates differ from ``occupancy.pixel_to_world``.
    """
    import networkx as nx

    pix = np.asarray(doc["node_pixel"], np.int64).reshape(-1, 2)
    x, y = occupancy.pixel_to_world(pix[:, 0], pix[:, 1])
    world = np.stack([x, y], axis=1)
    if len(pix) and not np.allclose(world, np.asarray(doc["node_world"]), atol=1e-6):
        raise RuntimeError("SWAGGER worker's world coordinates differ from pixel_to_world")
    g = nx.MultiGraph(
        resolution_m=float(occupancy.resolution_m), shape=tuple(occupancy.shape), source="swagger"
    )
    for i, ((r, c), xy) in enumerate(zip(pix.tolist(), world, strict=True)):
        g.add_node(
            i,
            pixel=(r, c),
            world=(float(xy[0]), float(xy[1])),
            kind=doc["node_type"][i] or "waypoint",
        )
    for (u, v, w), kind in zip(doc["edges"], doc["edge_type"], strict=True):
        u, v = sorted((int(u), int(v)))  # topojax's order: u <= v, path from u to v
        ends = np.stack([world[u], world[v]])
        g.add_edge(
            u,
            v,
            path=segment_pixels(pix[u], pix[v]),
            world=ends,
            waypoints=ends.copy(),
            length_m=float(w),
            weight=float(w),
            kind=kind,
        )
    return g


# ---------------------------------------------------------------------------- topojax side
def as_networkx(result):
    """The networkx graph of a route-graph result (the graph itself, or its ``.graph``)."""
    import networkx as nx

    if isinstance(result, nx.Graph):
        return result
    graph = getattr(result, "graph", None)
    if isinstance(graph, nx.Graph):
        return graph
    raise TypeError(f"route_graph returned {type(result).__name__}, not a networkx graph")


def run_topojax(occupancy, radius_m: float, warm_runs: int) -> tuple[float, list, Any]:
    """``route_graph``, once and then ``warm_runs`` more times: (first seconds, the warm
    calls' seconds, networkx graph of the last call)."""
    from topojax.routegraph import route_graph

    t0 = time.perf_counter()
    result = route_graph(occupancy, robot_radius_m=radius_m)
    first_s = time.perf_counter() - t0
    warm = []
    for _ in range(warm_runs):
        t0 = time.perf_counter()
        result = route_graph(occupancy, robot_radius_m=radius_m)
        warm.append(time.perf_counter() - t0)
    return first_s, warm, as_networkx(result)


def evaluator():
    """``evaluate_route_graph``, or None where topojax does not have it yet."""
    try:
        from topojax.routegraph.evaluate import evaluate_route_graph
    except ImportError:
        return None
    return evaluate_route_graph


def score(graph, occupancy, radius_m: float, args, generation_s: float) -> dict | None:
    evaluate = evaluator()
    if evaluate is None:
        return None
    t0 = time.perf_counter()
    report = evaluate(
        graph,
        occupancy,
        radius_m,
        snap_m=args.snap,
        entry=args.entry,
        n_pairs=args.pairs,
        seed=args.seed,
        generation_s=generation_s,
    )
    out = dict(report.as_dict())
    out["evaluate_s"] = time.perf_counter() - t0
    return out


def graph_counts(graph) -> dict:
    """Vertices, edges, connected components and total edge length (m) of ``graph``."""
    import networkx as nx

    length = sum(float(d.get("length_m", 0.0)) for _, _, d in graph.edges(data=True))
    return {
        "vertices": graph.number_of_nodes(),
        "edges": graph.number_of_edges(),
        "components": nx.number_connected_components(graph) if graph.number_of_nodes() else 0,
        "length_m": length,
    }


# ---------------------------------------------------------------------------- one map
def relative(path: Path, root: Path) -> str:
    """``path`` relative to ``root`` where it lies below it, else as given."""
    try:
        return str(path.resolve().relative_to(root.resolve()))
    except ValueError:
        return str(path)


def bench_map(spec: MapSpec, args, work: Path, graphs: dict) -> list[dict]:
    """Rows (one per radius) for one map; keeps the graphs to draw in ``graphs``."""
    occupancy, replay_s = load_spec(spec, replay_dir=args.replay_dir, max_scans=args.max_scans)
    base = {
        "map": spec.name,
        "group": spec.group,
        "file": relative(spec.path, args.data),
        "shape": list(occupancy.shape),
        "resolution_m": occupancy.resolution_m,
        "free_m2": float(np.count_nonzero(occupancy.free)) * occupancy.resolution_m**2,
    }
    if replay_s is not None:
        base["replay_s"] = replay_s
    rows = []
    for radius in args.radius:
        row: dict[str, Any] = {**base, "radius_m": radius}
        doc = run_swagger(
            occupancy,
            radius,
            work,
            venv=args.swagger_venv,
            peers=args.peers,
            timeout_s=args.timeout,
            warm_runs=args.warm_runs,
        )
        sg = swagger_graph(doc, occupancy)
        timing = doc["timing"]
        row["swagger"] = {
            **graph_counts(sg),
            **timing,
            "same_graph_warm": doc["same_graph_warm"],
            "eval": score(sg, occupancy, radius, args, timing["build_warm_s"]),
        }
        if not args.peers_only:
            first_s, warm, tg = run_topojax(occupancy, radius, args.warm_runs)
            warm_s = float(np.median(warm))
            row["topojax"] = {
                **graph_counts(tg),
                "first_s": first_s,
                "warm_s": warm_s,
                "warm_runs_s": warm,
                "eval": score(tg, occupancy, radius, args, warm_s),
            }
            row["ratios"] = ratios(row["topojax"], row["swagger"])
        else:
            tg = None
        if args.pictures and radius == args.radius[0] and spec.name in args.picture_maps:
            graphs[spec.name] = (occupancy, sg, tg)
        rows.append(row)
        print(one_line(row), flush=True)
    return rows


def ratios(tj_row: dict, sw_row: dict) -> dict:
    """topojax / SWAGGER vertices and edges, SWAGGER warm / topojax warm time."""

    def div(a, b):
        return a / b if b else math.nan

    return {
        "vertices": div(tj_row["vertices"], sw_row["vertices"]),
        "edges": div(tj_row["edges"], sw_row["edges"]),
        "speedup_warm": div(sw_row["build_warm_s"], tj_row["warm_s"]),
        "speedup_cold": div(sw_row["build_cold_s"], tj_row["first_s"]),
    }


def one_line(row: dict) -> str:
    sw = row["swagger"]
    text = (
        f"{row['map']:<28} r={row['radius_m']:.2f}  SWAGGER {sw['vertices']:>5} V "
        f"{sw['edges']:>5} E {sw['components']:>3} C  cold {sw['build_cold_s']:.2f} s "
        f"warm {sw['build_warm_s']:.2f} s"
    )
    if "topojax" in row:
        t = row["topojax"]
        text += (
            f" | topojax {t['vertices']:>5} V {t['edges']:>5} E {t['components']:>3} C  "
            f"first {t['first_s']:.2f} s warm {t['warm_s']:.3f} s"
        )
    return text


# ---------------------------------------------------------------------------- summaries
def flatten(d: dict | None, prefix: str = "") -> dict[str, float]:
    """Numeric leaves of a nested dict as ``{"a.b": value}`` (bools and None left out)."""
    out: dict[str, float] = {}
    for key, value in (d or {}).items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
            value, (bool, np.bool_)
        ):
            out[name] = float(value)
    return out


def averages(rows: list[dict]) -> dict:
    """``radius -> tool -> metric -> mean`` over the maps (NaN/None values skipped), with
    ``n_maps``; ratios are averaged too (and their max for vertices/edges, min for speed)."""
    out: dict[str, Any] = {}
    for radius in sorted({r["radius_m"] for r in rows}, reverse=True):
        sel = [r for r in rows if r["radius_m"] == radius]
        entry: dict[str, Any] = {"n_maps": len(sel)}
        for tool in ("swagger", "topojax", "ratios"):
            flat = [flatten(r[tool]) for r in sel if tool in r]
            if not flat:
                continue
            keys = dict.fromkeys(k for f in flat for k in f)
            means = {}
            for k in keys:
                vals = [f[k] for f in flat if k in f and math.isfinite(f[k])]
                means[k] = float(np.mean(vals)) if vals else math.nan
            if tool == "ratios":
                for k, pick in (("vertices", max), ("edges", max), ("speedup_warm", min)):
                    vals = [f[k] for f in flat if math.isfinite(f.get(k, math.nan))]
                    means[f"{k}_worst"] = pick(vals) if vals else math.nan
            entry[tool] = means
        out[f"{radius:g}"] = entry
    return out


#: Table columns taken from the evaluator's report: label -> (tokens all present in the
#: flattened key, tokens absent, format); the first matching key is used.
EVAL_COLUMNS = {
    "success %": (("success",), ("safe", "n_", "count"), "{:.1f}"),
    "stretch med": (("median",), ("snap", "time"), "{:.3f}"),
    "stretch p90": (("p90",), ("snap", "time"), "{:.3f}"),
    "unsafe": (("unsafe",), (), "{:.3g}"),
    "missed": (("missed",), (), "{:g}"),
    "far": (("far",), (), "{:.3g}"),
}
TOOLS = {"swagger": "SWAGGER", "topojax": "topojax"}


def eval_key(flat: dict[str, float], label: str) -> str | None:
    """The key of ``flat`` shown in column ``label`` (None if there is none)."""
    need, avoid, _ = EVAL_COLUMNS[label]
    for key in flat:
        low = key.lower()
        if all(t in low for t in need) and not any(t in low for t in avoid):
            return key
    return None


def fmt(value, spec: str = "{:,.0f}") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return spec.format(value)


def tool_cells(entry: dict, labels: list[str], *, mean: bool = False) -> list[str]:
    """Table cells of one tool's row entry (or of its averages with ``mean``)."""
    flat = entry if mean else flatten(entry.get("eval"))
    cells = [fmt(flat.get(eval_key(flat, lab) or ""), EVAL_COLUMNS[lab][2]) for lab in labels]
    cells += [fmt(entry.get(k)) for k in ("vertices", "edges", "components")]
    warm, cold = ("warm_s", "first_s") if "warm_s" in entry else ("build_warm_s", "build_cold_s")
    return cells + [fmt(entry.get(warm), "{:.3g}"), fmt(entry.get(cold), "{:.3g}")]


def shortfalls(rows: list[dict]) -> str:
    """The maps that miss the per-map targets: topojax's success below SWAGGER's, more
    than 1/3 of SWAGGER's vertices or edges, less than 10x faster (warm)."""
    lists: dict[str, list[str]] = {
        "success below SWAGGER's": [],
        "vertices > 1/3 of SWAGGER's": [],
        "edges > 1/3 of SWAGGER's": [],
        "less than 10x faster": [],
    }
    for r in rows:
        if "topojax" not in r:
            continue
        flats = [flatten(r[t].get("eval")) for t in ("topojax", "swagger")]
        keys = [eval_key(f, "success %") for f in flats]
        if all(keys) and flats[0][keys[0]] < flats[1][keys[1]]:
            lists["success below SWAGGER's"].append(r["map"])
        rat = r["ratios"]
        for key, label in (("vertices", "vertices"), ("edges", "edges")):
            if not rat[key] <= 1 / 3:
                lists[f"{label} > 1/3 of SWAGGER's"].append(r["map"])
        if not rat["speedup_warm"] >= 10:
            lists["less than 10x faster"].append(r["map"])
    return "Maps off target: " + "; ".join(
        f"{label}: {', '.join(names) if names else 'none'}" for label, names in lists.items()
    )


def report_markdown(rows: list[dict], avg: dict, info: dict, args) -> str:
    """Per-map tables (one per radius, a row per map and graph) and the means, as markdown."""
    flat_any: dict[str, float] = {}
    for r in rows:
        for tool in TOOLS:
            flat_any.update(flatten((r.get(tool) or {}).get("eval")))
    labels = [lab for lab in EVAL_COLUMNS if eval_key(flat_any, lab)]
    header = ["map", "graph", *labels, "V", "E", "C", "warm s", "cold s"]
    parts = [
        f"Route graphs, topojax vs SWAGGER ({SWAGGER_COMMIT[:7]}), {info.get('cpu_model', '?')}, "
        f"{info.get('cpu_count', '?')} CPUs; {args.pairs} pairs, seed {args.seed}, snap "
        f"{args.snap:g} m, routes join each graph at the {args.entry} point. V vertices, E edges, C connected components; warm s: median of "
        f"{args.warm_runs} builds after the first in the process; cold s: SWAGGER's first build in a fresh process (numba compilation "
        "included), topojax's first call on the map.",
    ]
    for radius in sorted({r["radius_m"] for r in rows}, reverse=True):
        table = [
            [r["map"], name, *tool_cells(r[tool], labels)]
            for r in rows
            if r["radius_m"] == radius
            for tool, name in TOOLS.items()
            if tool in r
        ]
        entry = avg.get(f"{radius:g}", {})
        table += [
            [f"**mean of {entry['n_maps']}**", name, *tool_cells(entry[tool], labels, mean=True)]
            for tool, name in TOOLS.items()
            if tool in entry
        ]
        parts += ["", f"### robot radius {radius:g} m", "", markdown_table(header, table)]
        ratio = entry.get("ratios")
        if ratio:
            parts += ["", shortfalls([r for r in rows if r["radius_m"] == radius])]
            parts += [
                "",
                f"topojax / SWAGGER: vertices {ratio['vertices']:.2f} (worst map "
                f"{ratio['vertices_worst']:.2f}), edges {ratio['edges']:.2f} (worst "
                f"{ratio['edges_worst']:.2f}); SWAGGER warm / topojax warm time "
                f"{ratio['speedup_warm']:.1f}x (worst map {ratio['speedup_warm_worst']:.1f}x).",
            ]
    return "\n".join(parts) + "\n"


# ---------------------------------------------------------------------------- pictures
def map_background(occupancy, max_px: int = 900) -> tuple[np.ndarray, int]:
    """Grey picture of the map (free white, unknown grey, occupied black), downscaled by an
    integer step so its longer side is at most ``max_px``; returns (image, step)."""
    step = max(1, math.ceil(max(occupancy.shape) / max_px))
    img = np.full(occupancy.shape, 0.75, np.float32)
    img[np.asarray(occupancy.free)] = 1.0
    img[np.asarray(occupancy.occupied)] = 0.0
    return img[::step, ::step], step


def draw_panel(ax, occupancy, graph, title: str, color: str) -> None:
    from matplotlib.collections import LineCollection

    from topojax.plotting import route_graph_lines

    img, _ = map_background(occupancy)
    h, w = occupancy.shape
    ax.imshow(
        img,
        cmap="gray",
        vmin=0,
        vmax=1,
        extent=(-0.5, w - 0.5, h - 0.5, -0.5),
        interpolation="nearest",
    )
    if graph is not None:
        ax.add_collection(
            LineCollection(route_graph_lines(graph, occupancy), colors=color, linewidths=0.6)
        )
        pix = np.array([d["pixel"] for _, d in graph.nodes(data=True)], float).reshape(-1, 2)
        ax.scatter(pix[:, 1], pix[:, 0], s=1.5, c="k", linewidths=0)
        c = graph_counts(graph)
        title += f": {c['vertices']} vertices, {c['edges']} edges"
    ax.set_title(title, fontsize=8)
    ax.set_axis_off()


def save_small_png(fig, path: Path, dpi: int) -> None:
    """Save ``fig`` as a PNG with a 64-colour palette (a third of the size of RGBA)."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    buf.seek(0)
    with Image.open(buf) as img:
        small = img.convert("RGB").quantize(colors=64, method=Image.Quantize.MEDIANCUT)
        small.save(path, optimize=True)


def write_pictures(graphs: dict, folder: Path, names, radius: float) -> list[Path]:
    """One PNG per map (SWAGGER's graph beside topojax's) under ``folder``, each kept under
    ``PICTURE_MAX_BYTES`` by lowering the resolution."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name in names:
        if name not in graphs:
            continue
        occupancy, sg, tg = graphs[name]
        h, w = occupancy.shape
        panels = [("SWAGGER", sg, "tab:red")] + (
            [] if tg is None else [("topojax", tg, "tab:blue")]
        )
        fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 5.5 * h / w + 0.6))
        for ax, (label, g, color) in zip(np.atleast_1d(axes), panels, strict=True):
            draw_panel(ax, occupancy, g, f"{name}, r = {radius:g} m, {label}", color)
        fig.tight_layout()
        path = folder / f"{name}.png"
        dpi = 130
        while True:
            save_small_png(fig, path, dpi)
            if path.stat().st_size <= PICTURE_MAX_BYTES or dpi <= 40:
                break
            dpi = int(dpi * 0.85)
        plt.close(fig)
        written.append(path)
        print(f"wrote {path} ({path.stat().st_size // 1024} KB, {dpi} dpi)")
    return written


# ---------------------------------------------------------------------------- self-check
def self_check(args) -> int:
    """SWAGGER's graph of an asymmetric synthetic map lands on topojax's feasible space.

    The map (non-square, rotated origin) has a large block near its top-left corner and a
    thin wall near its bottom-right; a flipped or transposed frame puts vertices into them.
    Checks: every vertex pixel is feasible, every vertex's world point maps back to its
    pixel, and vertices exist on both sides of the block.
    """
    import topojax as tj
    from topojax.routegraph import feasible_space

    free = np.zeros((160, 260), bool)
    free[4:156, 4:256] = True
    free[10:70, 20:120] = False  # block, top-left
    free[90:156, 200:205] = False  # wall from the bottom, right
    occ = tj.OccupancyMap(
        occupied=~free,
        free=free,
        unknown=np.zeros_like(free),
        resolution_m=0.05,
        origin=(1.5, -2.0, 0.4),
    )
    radius = 0.3
    with tempfile.TemporaryDirectory() as tmp:
        doc = run_swagger(
            occ,
            radius,
            Path(tmp),
            venv=args.swagger_venv,
            peers=args.peers,
            timeout_s=args.timeout,
            warm_runs=1,
        )
    g = swagger_graph(doc, occ)
    fs = feasible_space(occ, radius)
    pix = np.array([d["pixel"] for _, d in g.nodes(data=True)], np.int64)
    bad = int(np.count_nonzero(~fs.feasible[pix[:, 0], pix[:, 1]]))
    flipped = int(np.count_nonzero(~fs.feasible[occ.shape[0] - 1 - pix[:, 0], pix[:, 1]]))
    xy = np.array([d["world"] for _, d in g.nodes(data=True)])
    rows, cols = occ.world_to_pixel(xy[:, 0], xy[:, 1])
    back = float(np.max(np.abs(np.stack([rows, cols], 1) - pix)))
    right = int(np.count_nonzero(pix[:, 1] > 205))
    below = int(np.count_nonzero(pix[:, 0] > 75))
    print(
        f"{len(pix)} vertices, {g.number_of_edges()} edges; infeasible vertices {bad} "
        f"(flipped vertically they would be {flipped}); world->pixel error {back:.2e} px; "
        f"{right} right of the wall, {below} below the block"
    )
    ok = bad == 0 and flipped > 0 and back < 1e-6 and right > 0 and below > 0
    print("self-check", "passed" if ok else "FAILED")
    return 0 if ok else 1


# ---------------------------------------------------------------------------- main
def swagger_info(venv: Path) -> dict:
    """SWAGGER's snapshot commit and the versions of its venv's main packages."""
    code = (
        "import json, importlib.metadata as m, sys\n"
        "names = ['numpy', 'scipy', 'scikit-image', 'skan', 'numba', 'networkx']\n"
        "v = {}\n"
        "for n in names:\n"
        "    try: v[n] = m.version(n)\n"
        "    except m.PackageNotFoundError: v[n] = None\n"
        "print(json.dumps({'python': sys.version.split()[0], 'versions': v}))\n"
    )
    proc = subprocess.run(
        [str(venv / "bin" / "python"), "-c", code], capture_output=True, text=True, timeout=60
    )
    info = json.loads(proc.stdout) if proc.returncode == 0 else {"error": proc.stderr[-500:]}
    return {"commit": SWAGGER_COMMIT, "venv": str(venv), **info}


def select_maps(args) -> list[MapSpec]:
    specs = benchmark_maps(args.data)
    if args.maps:
        by_name = {s.name: s for s in specs}
        unknown = [n for n in args.maps if n not in by_name]
        if unknown:
            raise SystemExit(f"unknown maps {unknown}; --list shows the names")
        return [by_name[n] for n in args.maps]
    if args.groups:
        specs = [s for s in specs if s.group in args.groups]
    if args.quick:
        specs = [s for s in specs if s.name in QUICK_MAPS]
    return specs


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, received {text!r}")
    return value


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--maps", nargs="+", help="map names (see --list); default: all")
    p.add_argument("--groups", nargs="+", choices=GROUPS, help="only these map groups")
    p.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK_MAPS)}")
    p.add_argument("--list", action="store_true", help="list the maps and exit")
    p.add_argument(
        "--radius",
        nargs="+",
        type=float,
        default=[0.3, 0.2],
        help="robot radii in metres (default 0.3 0.2); pictures use the first",
    )
    p.add_argument("--pairs", type=int, default=300, help="start/goal pairs per graph")
    p.add_argument(
        "--warm-runs",
        type=_positive_int,
        default=3,
        help="warm builds per tool, map and radius (median)",
    )
    p.add_argument("--seed", type=int, default=0, help="evaluator seed (same for both tools)")
    p.add_argument("--snap", type=float, default=1.0, help="evaluator snap limit (m)")
    p.add_argument(
        "--entry",
        choices=("nearest", "best"),
        default="nearest",
        help="where routes join each graph (evaluate_route_graph's entry; default nearest)",
    )
    p.add_argument("--peers-only", action="store_true", help="skip topojax's route graph")
    p.add_argument("--max-scans", type=int, help="shorten the CARMEN replays to N scans")
    p.add_argument(
        "--replay-dir",
        type=Path,
        help="where replays are written and reused (default: a temporary folder)",
    )
    p.add_argument("--swagger-venv", type=Path, default=DEFAULT_VENV)
    p.add_argument("--peers", type=Path, default=PEERS_DIR, help="the shared peers folder")
    p.add_argument("--timeout", type=float, default=900.0, help="SWAGGER worker timeout (s)")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    p.add_argument("--out", type=Path, help="JSON path (default bench/results/...)")
    p.add_argument("--markdown", type=Path, help="also write the markdown report here")
    p.add_argument("--pictures", type=Path, help="write PNGs of both graphs into this folder")
    p.add_argument("--picture-maps", nargs="+", default=list(PICTURE_MAPS))
    p.add_argument(
        "--self-check",
        action="store_true",
        help="check SWAGGER's frame on an asymmetric synthetic map and exit",
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    use_checkout()
    if args.list:
        for s in benchmark_maps(args.data):
            print(f"{s.group:<10} {s.name:<32} {s.path}")
        return 0
    if not (args.swagger_venv / "bin" / "python").exists():
        raise SystemExit(f"no SWAGGER venv at {args.swagger_venv}: see {PEERS_DIR}/README.md")
    if args.self_check:
        return self_check(args)
    if evaluator() is None:
        print("topojax.routegraph.evaluate is not importable: graphs are not scored")
    specs = select_maps(args)
    rows: list[dict] = []
    failures: dict[str, str] = {}
    graphs: dict = {}
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if args.replay_dir is None:
            args.replay_dir = work / "replays"
        for spec in specs:
            try:
                rows += bench_map(spec, args, work, graphs)
            except Exception as exc:  # one broken map must not lose the others
                failures[spec.name] = f"{type(exc).__name__}: {exc}"
                print(f"{spec.name}: FAILED {failures[spec.name]}", flush=True)
        if args.pictures:
            write_pictures(graphs, args.pictures, args.picture_maps, args.radius[0])
    info = machine_info()
    avg = averages(rows)
    report = report_markdown(rows, avg, info, args)
    if failures:
        report += "\nFailed: " + "; ".join(f"{k}: {v}" for k, v in failures.items()) + "\n"
    print(report)
    out = args.out or RESULTS_DIR / f"route_graph_{machine_slug(info)}.json"
    write_json(
        out,
        {
            "machine": info,
            "swagger": swagger_info(args.swagger_venv),
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "total_s": time.perf_counter() - t_start,
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
