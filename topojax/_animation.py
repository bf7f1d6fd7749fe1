"""A replay's animation: a small snapshot of the mapper at each update, the GIF of them,
and the snapshots written to a file and read back (a stopped replay keeps them for the
resumed one)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .incremental import current_room_labels

__all__ = ["animation_frame", "load_frames", "save_frames", "write_animation"]


def animation_frame(mapper, max_px: int = 500) -> dict:
    """A small snapshot for the animation: the map image shrunk to at most ``max_px``
    pixels a side (walls kept, :func:`topojax.plotting.map_image`), its world extent, the
    edges' world polylines and the vertices' world positions by kind."""
    from .plotting import map_image

    occ = mapper.occupancy
    h, w = occ.shape
    step = max(1, -(-max(h, w) // max_px))
    img = map_image(occ, step)
    ox, oy, _ = occ.origin
    res = occ.resolution_m
    top = oy + h * res
    g = mapper.graph
    labels = current_room_labels(mapper)
    rooms = None if labels is None else labels[::step, ::step].copy()
    vertices: dict[str, list] = {}
    for _, d in g.nodes(data=True):
        vertices.setdefault(d["kind"], []).append(d["world"])
    return {
        "image": img,
        "extent": (ox, ox + img.shape[1] * step * res, top - img.shape[0] * step * res, top),
        "edges": [d for *_, d in g.edges(data="world")],
        "vertices": {k: np.asarray(v, np.float64) for k, v in vertices.items()},
        "n_vertices": g.number_of_nodes(),
        "scan": mapper.n_scans,
        "rooms": rooms,
    }


def write_animation(frames: list[dict], path: Path, name: str | None = None) -> None:
    """The frames as a GIF in the style of the still pictures (:mod:`topojax.plotting`):
    map, rooms, graph, a scale bar and the legend under the map, the log's name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    from .plotting import add_legend, add_scale_bar, draw_graph_lines, room_layer

    last = frames[-1]["extent"]
    fig, ax = plt.subplots(figsize=(7, 7.5))
    fig.subplots_adjust(left=0.02, right=0.98, top=0.94, bottom=0.1)

    def draw(i: int):
        f = frames[i]
        ax.clear()
        ax.imshow(f["image"], cmap="gray", vmin=0, vmax=1, extent=f["extent"])
        if f.get("rooms") is not None:
            ax.imshow(room_layer(f["rooms"], 0.45), extent=f["extent"], interpolation="nearest")
        draw_graph_lines(ax, f["edges"], f["vertices"], linewidth=1.0, node_size=6.0)
        ax.set_xlim(last[0], last[1])
        ax.set_ylim(last[2], last[3])
        ax.set_aspect("equal")
        ax.set_axis_off()
        add_scale_bar(ax, 1.0)
        add_legend(ax)
        text = f"scan {f['scan']}: {f['n_vertices']} vertices, {len(f['edges'])} edges"
        ax.set_title(f"{name}: {text}" if name else text)
        return []

    anim = FuncAnimation(fig, draw, frames=len(frames), blit=False)
    tmp = path.with_name(f".{path.name}.tmp.gif")
    try:
        anim.save(tmp, writer=PillowWriter(fps=3))
        tmp.replace(path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)


def save_frames(frames: list[dict], path: Path) -> None:
    """Write animation frames (:func:`animation_frame`'s) to an ``.npz`` file, no
    pickles (a stopped replay's, for the resumed one)."""
    arrays: dict[str, np.ndarray] = {"n_frames": np.array(len(frames))}
    for i, f in enumerate(frames):
        arrays[f"{i}/image"] = f["image"]
        arrays[f"{i}/extent"] = np.asarray(f["extent"], np.float64)
        arrays[f"{i}/counts"] = np.array([f["n_vertices"], f["scan"]], np.int64)
        edges = f["edges"]
        arrays[f"{i}/edge_sizes"] = np.array([len(e) for e in edges], np.int64)
        arrays[f"{i}/edges"] = np.concatenate(edges) if edges else np.zeros((0, 2))
        for kind, xy in f["vertices"].items():
            arrays[f"{i}/vertices/{kind}"] = xy
        if f["rooms"] is not None:
            arrays[f"{i}/rooms"] = f["rooms"]
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def load_frames(path: Path) -> list[dict]:
    """Read frames written by :func:`save_frames`."""
    with np.load(path, allow_pickle=False) as data:
        frames = []
        for i in range(int(data["n_frames"])):
            sizes = data[f"{i}/edge_sizes"]
            n_vertices, scan = data[f"{i}/counts"].tolist()
            prefix = f"{i}/vertices/"
            frames.append(
                {
                    "image": data[f"{i}/image"],
                    "extent": tuple(data[f"{i}/extent"].tolist()),
                    "edges": np.split(data[f"{i}/edges"], np.cumsum(sizes)[:-1])
                    if sizes.size
                    else [],
                    "vertices": {
                        k[len(prefix) :]: data[k] for k in data.files if k.startswith(prefix)
                    },
                    "n_vertices": n_vertices,
                    "scan": scan,
                    "rooms": data[f"{i}/rooms"] if f"{i}/rooms" in data.files else None,
                }
            )
    return frames
