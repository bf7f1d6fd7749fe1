"""Build NVIDIA SWAGGER's waypoint graph for one map and write it as JSON.

Runs inside SWAGGER's own virtual environment (see ``../shared/peers/README.md``), never
in topojax's: it imports neither topojax nor the other ``bench`` modules.  Run as::

    PYTHONPATH=../shared/peers/swagger-cpu-shims:../shared/peers/swagger \\
        ~/.venvs/swagger/bin/python bench/swagger_worker.py MAP.npz GRAPH.json

Input ``MAP.npz`` holds

* ``image``: uint8 (H, W), 255 where the map is known free, 0 elsewhere (occupied,
  unknown);
* ``resolution_m``: float, metres per pixel;
* ``robot_radius_m``: float, SWAGGER's ``safety_distance``;
* ``origin``: float (3,), ``(x, y, yaw)`` of the map (ROS ``map_server`` convention, as
  topojax's ``OccupancyMap.origin``).

SWAGGER is built in this process with its default configuration: a first build (*cold*:
numba compilation and first-touch costs included), then ``warm_runs`` more (an optional
int in ``MAP.npz``, default 1); *warm* is their median.  The graph of the first build is
written.

Coordinates.  SWAGGER's nodes are integer pixels ``(row, col)`` of the image (row 0 at
the top).  Its own world frame puts pixel ``(row, col)`` at ``x = col * res``,
``y = (H - row) * res`` (the pixel's corner, not its centre) before its offset and
rotation.  The worker calls SWAGGER with zero offset and rotation and writes each node's
pixel and its world position in topojax's frame, the pixel *centre*:
``x' = (col + 0.5) * res``, ``y' = (H - row - 0.5) * res``, rotated by ``yaw`` and moved
by ``(x, y)`` (``OccupancyMap.pixel_to_world``).  It also checks that SWAGGER's own world
coordinates are the pixel's corner as above, so a change of SWAGGER's convention fails
loudly.

Output ``GRAPH.json``: ``shape``, ``resolution_m``, ``robot_radius_m``, ``origin``,
``node_pixel`` ([row, col] per node), ``node_world`` ([x, y]), ``node_type``,
``edges`` ([u, v, weight_m] per edge, straight segments), ``edge_type``, ``timing``
(``import_s``, ``build_cold_s``, ``build_warm_s``, ``build_warm_runs_s``) and
``same_graph_warm`` (whether every warm build gave the first build's vertices and edges).  The last stdout line is a JSON summary
(counts and times, no graph).
"""

from __future__ import annotations

import json
import logging
import math
import sys
import time
from pathlib import Path

T_START = time.perf_counter()

import numpy as np  # noqa: E402


def topojax_world(rows, cols, shape, resolution_m, origin):
    """World ``(x, y)`` of pixel centres, exactly as ``OccupancyMap.pixel_to_world``."""
    r = np.asarray(rows, np.float64)
    c = np.asarray(cols, np.float64)
    ox, oy, yaw = (float(v) for v in origin)
    xm = (c + 0.5) * resolution_m
    ym = (shape[0] - r - 0.5) * resolution_m
    cos_t, sin_t = math.cos(yaw), math.sin(yaw)
    return ox + cos_t * xm - sin_t * ym, oy + sin_t * xm + cos_t * ym


def build(image: np.ndarray, resolution_m: float, radius_m: float):
    """One SWAGGER build with its default configuration; returns (seconds, graph)."""
    from swagger import WaypointGraphGenerator, WaypointGraphGeneratorConfig

    t0 = time.perf_counter()
    gen = WaypointGraphGenerator(
        config=WaypointGraphGeneratorConfig(), logger_level=logging.WARNING
    )
    graph = gen.build_graph_from_grid_map(
        image=image,
        resolution=resolution_m,
        safety_distance=radius_m,
        occupancy_threshold=127,
    )
    return time.perf_counter() - t0, graph


def graph_signature(graph) -> tuple:
    """Vertex pixels and edges by pixel, to compare two builds."""
    pix = dict(graph.nodes(data="pixel"))
    edges = sorted(tuple(sorted((pix[u], pix[v]))) for u, v in graph.edges())
    return tuple(sorted(pix.values())), tuple(edges)


def check_swagger_frame(graph, shape, resolution_m: float) -> None:
    """Raise if SWAGGER's world coordinates are not ``(col * res, (H - row) * res)``."""
    for _, data in graph.nodes(data=True):
        row, col = data["pixel"]
        x, y = data["world"][:2]
        if abs(x - col * resolution_m) > 1e-6 or abs(y - (shape[0] - row) * resolution_m) > 1e-6:
            raise RuntimeError(
                f"SWAGGER's pixel/world convention changed: pixel {(row, col)} -> world "
                f"{(x, y)}, expected {(col * resolution_m, (shape[0] - row) * resolution_m)}"
            )


def graph_document(graph, shape, resolution_m, radius_m, origin) -> dict:
    """The JSON document of a SWAGGER graph (nodes renumbered 0..N-1)."""
    ids = {n: i for i, n in enumerate(graph.nodes())}
    pixels = np.array([graph.nodes[n]["pixel"] for n in graph.nodes()], np.int64).reshape(-1, 2)
    x, y = topojax_world(pixels[:, 0], pixels[:, 1], shape, resolution_m, origin)
    edges, edge_type = [], []
    for u, v, data in graph.edges(data=True):
        edges.append([ids[u], ids[v], float(data.get("weight", math.nan))])
        edge_type.append(str(data.get("edge_type", "")))
    return {
        "shape": [int(shape[0]), int(shape[1])],
        "resolution_m": resolution_m,
        "robot_radius_m": radius_m,
        "origin": [float(v) for v in origin],
        "node_pixel": pixels.tolist(),
        "node_world": np.stack([x, y], axis=1).tolist() if len(pixels) else [],
        "node_type": [str(graph.nodes[n].get("node_type", "")) for n in graph.nodes()],
        "edges": edges,
        "edge_type": edge_type,
    }


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    src, dst = Path(argv[0]), Path(argv[1])
    with np.load(src) as npz:
        image = np.ascontiguousarray(npz["image"], dtype=np.uint8)
        res = float(npz["resolution_m"])
        radius = float(npz["robot_radius_m"])
        origin = [float(v) for v in npz["origin"]]
        warm_runs = int(npz["warm_runs"]) if "warm_runs" in npz.files else 1
    if warm_runs < 1:
        raise SystemExit(f"warm_runs: expected an integer >= 1, received {warm_runs}")
    t0 = time.perf_counter()
    import swagger  # noqa: F401  (its import, numba and scikit-image included)

    import_s = time.perf_counter() - t0
    cold_s, graph = build(image, res, radius)
    first = graph_signature(graph)
    warm_times, same = [], True
    for _ in range(warm_runs):  # each warm graph is compared, not kept
        t, g = build(image, res, radius)
        warm_times.append(t)
        same = same and graph_signature(g) == first
    warm_s = float(np.median(warm_times))
    check_swagger_frame(graph, image.shape, res)
    doc = graph_document(graph, image.shape, res, radius, origin)
    doc["timing"] = {
        "startup_s": t0 - T_START,
        "import_s": import_s,
        "build_cold_s": cold_s,
        "build_warm_s": warm_s,
        "build_warm_runs_s": warm_times,
    }
    doc["same_graph_warm"] = same
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text(json.dumps(doc))
    summary = {
        "vertices": graph.number_of_nodes(),
        "edges": graph.number_of_edges(),
        **doc["timing"],
        "same_graph_warm": doc["same_graph_warm"],
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
