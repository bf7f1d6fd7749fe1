"""Pictures of what each ``RouteGraphConfig`` option does, for docs/route-graphs.md.

    python docs/figures/route_graph_options.py [--out docs/route-graphs/options]

Each picture puts the route graph built with one option (or one group of options) changed
beside the graph with the defaults, on a synthetic map made here or a crop of a bundled
map, and titles each panel with its vertex and edge counts and its stretch (median / p90
of :func:`topojax.evaluate_route_graph`, routes joining at the nearest graph point).
"""

from __future__ import annotations

import argparse
import io
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

import topojax as tj  # noqa: E402
from topojax.maps.occupancy import OccupancyMap  # noqa: E402
from topojax.plotting import plot_route_graph  # noqa: E402

RES = 0.05  # m/px of the synthetic maps
OUT = Path(__file__).resolve().parents[1] / "route-graphs" / "options"


def px(m: float) -> int:
    return int(round(m / RES))


def synthetic(free: np.ndarray) -> OccupancyMap:
    """A map whose pixels are free or occupied (nothing unknown), 0.05 m/px."""
    free = np.asarray(free, bool)
    return OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=RES)


def room(h_m: float, w_m: float) -> np.ndarray:
    """A free rectangle inside a one-pixel wall."""
    free = np.zeros((px(h_m), px(w_m)), bool)
    free[1:-1, 1:-1] = True
    return free


def wall(free: np.ndarray, col_m: float, door_rows_m=()) -> None:
    """A 0.2 m wall across ``free`` at column ``col_m``, open at each (row0, row1) door."""
    cols = slice(px(col_m) - 2, px(col_m) + 2)
    free[:, cols] = False
    for r0, r1 in door_rows_m:
        free[px(r0) : px(r1), cols] = True


def three_rooms() -> OccupancyMap:
    """Three 6 x 6 m rooms in a row; the doors are 0.8 m and 1.4 m wide."""
    free = room(6, 18)
    wall(free, 6, [(2.6, 3.4)])
    wall(free, 12, [(2.3, 3.7)])
    return synthetic(free)


def hall() -> OccupancyMap:
    """An empty 12 x 18 m hall."""
    return synthetic(room(12, 18))


def pillar_room() -> OccupancyMap:
    """A 10 x 10 m room with 0.8 m pillars on a 2.5 m grid."""
    free = room(10, 10)
    for r in (2.5, 5.0, 7.5):
        for c in (2.5, 5.0, 7.5):
            free[px(r - 0.4) : px(r + 0.4), px(c - 0.4) : px(c + 0.4)] = False
    return synthetic(free)


def corridor_with_rooms() -> OccupancyMap:
    """Three 4.5 x 4 m rooms above a 2 m corridor, each through a 1 m door; the walls
    have seeded random notches up to 0.3 m deep, as walls in a scan do."""
    free = room(6.2, 14)
    free[px(4) : px(4.2), :] = False  # between the rooms and the corridor
    for c in (4.6, 9.3):  # between the rooms
        free[: px(4), px(c) : px(c) + 4] = False
    for c in (1.8, 6.5, 11.2):  # the doors
        free[px(4) : px(4.2), px(c) : px(c + 1)] = True
    rng = np.random.default_rng(3)
    walls = np.argwhere(~free)
    for r, c in walls[rng.choice(len(walls), size=60, replace=False)]:
        h, w = rng.integers(2, 7, size=2)  # 0.1-0.3 m
        r0, c0 = max(r - h // 2, 0), max(c - w // 2, 0)
        free[r0 : r0 + h, c0 : c0 + w] = False
    return synthetic(free)


def wall_ends() -> OccupancyMap:
    """A 10 x 16 m room with two walls from opposite sides: an S-shaped space."""
    free = room(10, 16)
    free[: px(7), px(5.4) : px(5.6)] = False
    free[px(3) :, px(10.4) : px(10.6)] = False
    return synthetic(free)


def closets() -> OccupancyMap:
    """An 8 x 12 m room beside two closed closets (1.6 x 1.6 m and 3 x 3 m inside)."""
    free = room(8, 17)
    free[:, px(12) :] = False
    free[px(0.8) : px(2.4), px(12.8) : px(14.4)] = True
    free[px(4) : px(7), px(13) : px(16)] = True
    return synthetic(free)


def ring_corridor() -> OccupancyMap:
    """A 2 m wide corridor round a round block: radii 3 m and 5 m."""
    n = px(10.4)
    rr, cc = np.mgrid[:n, :n]
    d = np.hypot(rr - (n - 1) / 2, cc - (n - 1) / 2) * RES
    return synthetic((d >= 3.0) & (d <= 5.0))


def bundled_crop(name: str, rows: tuple[int, int], cols: tuple[int, int]) -> OccupancyMap:
    """A crop of a bundled map (``topojax.sample_map``), its border a wall."""
    m = tj.sample_map(name)
    sl = (slice(*rows), slice(*cols))
    return OccupancyMap(
        occupied=np.asarray(m.occupied)[sl],
        free=np.asarray(m.free)[sl],
        unknown=np.asarray(m.unknown)[sl],
        resolution_m=m.resolution_m,
        source=f"{name}, rows {rows[0]}-{rows[1]}, cols {cols[0]}-{cols[1]}",
    )


@dataclass(frozen=True)
class Figure:
    """One picture: ``panels`` are (label, RouteGraphConfig options) drawn left to right."""

    name: str
    occupancy: OccupancyMap
    panels: tuple[tuple[str, dict], ...]
    pixel_paths: bool = False


def figures() -> list[Figure]:
    no_shortcuts = {"shortcut_radius_m": 0.0}
    intel = bundled_crop("intel", (0, 330), (380, 763))
    return [
        Figure(
            "robot_radius",
            three_rooms(),
            (("robot_radius_m=0.5", {"robot_radius_m": 0.5}), ("default (0.3)", {})),
        ),
        Figure("snap", hall(), (("snap_m=1.6", {"snap_m": 1.6}), ("default (1.0)", {}))),
        Figure(
            "loops",
            pillar_room(),
            (
                (
                    "loop rules off, no shortcuts",
                    {"small_obstacle_m": 0.0, "loop_m": 0.0, "loop_clearance_factor": 0.0}
                    | no_shortcuts,
                ),
                ("defaults, no shortcuts", no_shortcuts),
            ),
        ),
        Figure(
            "spurs",
            corridor_with_rooms(),
            (
                (
                    "spur rules off, no shortcuts",
                    {"spur_m": 0.0, "spur_clearance_factor": 0.0} | no_shortcuts,
                ),
                ("defaults, no shortcuts", no_shortcuts),
            ),
        ),
        Figure(
            "shortcuts",
            intel,
            (
                ("shortcut_radius_m=0", no_shortcuts),
                (
                    "shortcut_stretch=1.5, shortcut_spacing_m=2",
                    {"shortcut_stretch": 1.5, "shortcut_spacing_m": 2.0},
                ),
                ("defaults", {}),
            ),
        ),
        Figure(
            "round_corners",
            wall_ends(),
            (
                ("shortcuts_round_corners=False", {"shortcuts_round_corners": False}),
                ("default (True)", {}),
            ),
        ),
        Figure(
            "dead_ends",
            bundled_crop("a_scan", (0, 300), (0, 520)),
            (
                ("shortcuts_from_dead_ends=False", {"shortcuts_from_dead_ends": False}),
                ("default (True)", {}),
            ),
        ),
        Figure(
            "waypoints",
            ring_corridor(),
            (("waypoint_tolerance_m=0.3", {"waypoint_tolerance_m": 0.3}), ("default (0.1)", {})),
            pixel_paths=True,
        ),
        Figure(
            "min_region",
            closets(),
            (("min_region_m2=4", {"min_region_m2": 4.0}), ("default (1.0)", {})),
        ),
    ]


def draw(fig_spec: Figure, out: Path, dpi: int) -> Path:
    occ = fig_spec.occupancy
    h, w = occ.shape
    n = len(fig_spec.panels)
    width = 4.6 if n == 2 else 3.6
    fig, axes = plt.subplots(1, n, figsize=(width * n, width * h / w + 0.9))
    for ax, (label, options) in zip(np.atleast_1d(axes), fig_spec.panels, strict=True):
        cfg = tj.RouteGraphConfig(**options)
        g = tj.route_graph(occ, config=cfg)
        report = tj.evaluate_route_graph(g, occ, robot_radius_m=cfg.robot_radius_m)
        title = (
            f"{label}\n{g.number_of_nodes()} vertices, {g.number_of_edges()} edges, "
            f"stretch {report.stretch_median:.2f} / {report.stretch_p90:.2f}"
        )
        plot_route_graph(g, occ, ax=ax, linewidth=1.2, node_size=9, title=title)
        ax.title.set_fontsize(8)
        if fig_spec.pixel_paths:
            for _, _, d in g.edges(data=True):
                p = np.asarray(d["path"], float)
                ax.plot(p[:, 1], p[:, 0], color="0.35", linewidth=0.5, zorder=2.5)
                wp = np.asarray(d["waypoints"], float)
                r, c = occ.world_to_pixel(wp[:, 0], wp[:, 1])
                ax.scatter(c, r, s=5, c="k", zorder=2.6, linewidths=0)
        legend = ax.get_legend()
        if legend is not None:
            legend.remove()
    fig.tight_layout()
    path = out / f"{fig_spec.name}.png"
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    plt.close(fig)
    buf.seek(0)
    with Image.open(buf) as img:
        img.convert("RGB").quantize(colors=48, method=Image.Quantize.MEDIANCUT).save(
            path, optimize=True
        )
    return path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=OUT, help=f"folder (default {OUT})")
    p.add_argument("--dpi", type=int, default=90)
    p.add_argument("--only", nargs="*", help="names of the pictures to draw (default all)")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for spec in figures():
        if args.only and spec.name not in args.only:
            continue
        path = draw(spec, args.out, args.dpi)
        print(f"wrote {path} ({path.stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
