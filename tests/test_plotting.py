"""Plot helpers draw what the result holds."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

import topojax as tj  # noqa: E402
from topojax.datasets import sample_map  # noqa: E402
from topojax.plotting import plot_graph, plot_stages  # noqa: E402


@pytest.fixture(scope="module")
def result():
    return tj.build_graph(sample_map("a_scan"))


def test_plot_overlay_draws_every_edge_and_vertex(result):
    ax = tj.plot(result)
    lines = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(lines) == 1
    assert len(lines[0].get_segments()) == result.graph.number_of_edges()
    n_points = sum(
        len(c.get_offsets()) for c in ax.collections if not isinstance(c, LineCollection)
    )
    assert n_points == result.graph.number_of_nodes()
    # the map image is drawn in pixel coordinates
    assert ax.images[0].get_array().shape == result.map.shape
    plt.close(ax.figure)


def test_edge_segments_follow_pixel_paths(result):
    ax = plot_graph(result.graph)
    seg = ax.collections[0].get_segments()[0]
    first = next(iter(result.graph.edges(data=True)))[2]["path"]
    np.testing.assert_array_equal(seg, first[:, ::-1].astype(float))  # (x=col, y=row)
    plt.close(ax.figure)


def test_graph_without_map_size_is_drawn_in_image_order(result):
    g = result.graph.copy()
    del g.graph["shape"]
    ax = plot_graph(g)
    bottom, top = ax.get_ylim()
    assert bottom > top  # row 0 at the top, as with the map's size
    rows = [d["pixel"][0] for _, d in g.nodes(data=True)]
    assert top <= min(rows) and max(rows) <= bottom
    plt.close(ax.figure)
    fig = tj.plot_stages(result)  # also at the top level
    assert len(fig.axes) >= 6
    plt.close(fig)


def test_stage_figure_and_saving(result, tmp_path):
    fig = plot_stages(result)
    assert len(fig.axes) >= 6
    path = tmp_path / "stages.png"
    fig.savefig(path)
    assert path.stat().st_size > 10_000
    plt.close(fig)


def test_plot_empty_graph():
    res = tj.build_graph(np.zeros((20, 20), bool))
    ax = tj.plot(res)
    assert "0 vertices" in ax.get_title()
    plt.close(ax.figure)


def test_titles_count_one_edge_and_one_vertex_in_the_singular():
    corridor = np.zeros((12, 200), bool)
    corridor[[0, -1], :] = True  # open at both ends: one centre line, end to end
    res = tj.build_graph(corridor)
    assert (res.graph.number_of_nodes(), res.graph.number_of_edges()) == (2, 1)
    ax = tj.plot(res)
    assert ax.get_title() == "2 vertices, 1 edge"
    plt.close(ax.figure)
    fig = plot_stages(res)
    assert "graph (2 vertices, 1 edge)" in [a.get_title() for a in fig.axes]
    plt.close(fig)
    lone = nx.MultiGraph()
    lone.add_node(0, pixel=(6, 100), kind="isolated")
    ax = tj.plot_route_graph(lone, res.map, robot_radius_m=0.1)
    assert ax.get_title().endswith("1 vertex, 0 edges")
    plt.close(ax.figure)


def test_route_overlay_follows_the_route_pixels(result):
    g = result.graph
    path = max((d["path"] for _, _, d in g.edges(data=True)), key=len)
    route = tj.plan_route(g, path[0], path[-1], frame="pixel")
    assert len(route.pixels) >= 2
    ax = tj.plot(result, route=route)
    line = next(ln for ln in ax.lines if ln.get_label() == "route")
    np.testing.assert_array_equal(line.get_xydata(), route.pixels[:, ::-1].astype(float))
    plt.close(ax.figure)


def test_plot_takes_an_incremental_mapper_and_rejects_other_objects():
    mapper = tj.IncrementalMapper(
        resolution_m=0.1, distance=tj.DistanceConfig(sigma_px=4.0, half_width_px=10), tile_px=16
    )
    ranges = np.full(90, 3.0)
    for x in (0.0, 0.5, 1.0):
        mapper.add_scan(
            tj.Scan.from_arrays(ranges, (x, 0.0, 0.0), angle_min=-np.pi, angle_increment=0.07)
        )
    expected = mapper.to_result()
    ax = tj.plot(mapper)
    assert ax.images[0].get_array().shape == expected.map.shape
    n_points = sum(
        len(c.get_offsets()) for c in ax.collections if not isinstance(c, LineCollection)
    )
    assert n_points == expected.graph.number_of_nodes() > 0
    plt.close(ax.figure)
    plt.close(plot_stages(mapper))
    for bad in (42, expected.graph, np.zeros((4, 4), bool)):
        with pytest.raises(TypeError, match="result: expected a TopologyResult"):
            tj.plot(bad)
        with pytest.raises(TypeError, match="result: expected a TopologyResult"):
            plot_stages(bad)


def test_a_mapper_without_a_map_is_refused_naming_the_argument():
    mapper = tj.IncrementalMapper(resolution_m=0.1, tile_px=16)
    for draw in (tj.plot, plot_stages):
        with pytest.raises(ValueError, match=r"result: the mapper has no map yet \(add scans"):
            draw(mapper)


@pytest.mark.parametrize(
    ("edit", "exc", "words"),
    [
        (lambda g, e: g.edges[e].pop("path"), ValueError, r"edge 0-\d+ has no pixel 'path'"),
        (lambda g, e: g.edges[e].__setitem__("path", "ab"), TypeError, r"edge 0-\d+: 'path'"),
        (lambda g, e: g.nodes[0].pop("pixel"), ValueError, r"vertex 0 has no 'pixel'"),
        (lambda g, e: g.nodes[0].__setitem__("pixel", (1.5, 2)), ValueError, "vertex 0: 'pixel'"),
        (lambda g, e: g.add_node("new"), ValueError, r"vertex 'new' has no 'pixel'"),
    ],
)
def test_a_result_whose_graph_was_edited_is_refused_before_drawing(edit, exc, words):
    """A graph edited with networkx (an edge without its path, a vertex without its
    pixel) is refused naming what is missing before anything is drawn, not with a bare
    KeyError or inside NumPy after the map is drawn."""
    res = tj.build_graph(sample_map("a_scan"))
    edit(res.graph, next(iter(res.graph.edges(keys=True))))
    before = plt.get_fignums()
    for draw in (tj.plot, plot_stages):
        with pytest.raises(exc, match=rf"^graph: {words}"):
            draw(res)
    assert plt.get_fignums() == before, "no figure opened"


def test_full_map_plotting_does_not_load_the_incremental_module():
    """The incremental mapper and the batch runner load on first use only; plotting a
    full-map result (as batch workers do) must not pull them in."""
    import subprocess
    import sys

    code = (
        "import sys, matplotlib; matplotlib.use('Agg'); import topojax as tj; "
        "from topojax.plotting import plot_stages; "
        "r = tj.build_graph(tj.sample_map('a_scan')); tj.plot(r); plot_stages(r); "
        "print(sorted(m for m in ('topojax.incremental', 'topojax.batch') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# ---------------------------------------------------------------------- paper style


def _components(mask: np.ndarray) -> int:
    from scipy import ndimage

    return int(ndimage.label(mask, structure=np.ones((3, 3), bool))[1])


def _dark_pixels_in(ax) -> np.ndarray:
    """The rendered pixels of ``ax`` (inside its box) that are dark."""
    fig = ax.figure
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    box = ax.get_window_extent()
    h = rgba.shape[0]
    rows = slice(int(h - box.y1) + 1, int(h - box.y0) - 1)
    cols = slice(int(box.x0) + 1, int(box.x1) - 1)
    return rgba[rows, cols, :3].max(axis=-1) < 128


def _cross(n: int = 1200) -> np.ndarray:
    """A one-pixel diagonal and a one-pixel row crossing it: one 8-connected line."""
    skel = np.zeros((n, n), bool)
    idx = np.arange(100, n - 100)
    skel[idx, idx] = True
    skel[n // 2, 100 : n - 100] = True
    return skel


def test_overlay_names_the_map_and_puts_scale_bar_and_legend_under_it(result):
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    ax = tj.plot(result)
    assert ax.get_title().startswith("a_scan: ")  # the map's file name
    bars = [a for a in ax.artists if isinstance(a, AnchoredSizeBar)]
    assert len(bars) == 1
    label = bars[0].txt_label.get_text()
    length_m = float(label.removesuffix(" m"))
    assert label.endswith(" m") and length_m in (1, 2, 5, 10, 20, 50)
    res = result.map.resolution_m
    (rect,) = bars[0].size_bar.get_children()
    assert rect.get_width() == pytest.approx(length_m / res)  # in pixels of the map
    width_m = result.map.shape[1] * res
    assert 0.1 * width_m < length_m <= 0.25 * width_m
    legend = ax.get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    assert {"edges", "junction", "end"} <= set(texts)
    ax.figure.canvas.draw()
    renderer = ax.figure.canvas.get_renderer()
    map_box = ax.get_window_extent()
    for artist in (legend, bars[0]):  # both cover nothing of the map
        assert artist.get_window_extent(renderer).y1 <= map_box.y0 + 1
    plt.close(ax.figure)


def test_downscaled_skeleton_keeps_a_one_pixel_line_unbroken():
    skel = _cross()
    assert _components(skel) == 1
    fig, ax = plt.subplots(figsize=(3, 3), dpi=100)  # ~230 screen pixels for 1200
    tj.plotting.plot_skeleton(skel, ax=ax, color="#000000")
    shown = ax.images[0].get_array()
    assert shown.shape[0] < skel.shape[0]  # max-pooled for the axes
    assert (ax.get_xlim(), ax.get_ylim()) == ((-0.5, 1199.5), (1199.5, -0.5))
    assert _components(_dark_pixels_in(ax)) == 1
    plt.close(fig)
    # the same layer shown whole, shrunk by the renderer, is no unbroken line (pieces of
    # it or nothing at all)
    fig, ax = plt.subplots(figsize=(3, 3), dpi=100)
    ax.imshow(~skel, cmap="gray", interpolation="nearest")
    ax.set_axis_off()
    assert _components(_dark_pixels_in(ax)) != 1
    plt.close(fig)


def test_max_pool_and_map_image_keep_thin_lines():
    from topojax.plotting import map_image, max_pool

    skel = _cross(403)
    pooled = max_pool(skel, 4)
    assert pooled.shape == (101, 101) and pooled.dtype == bool
    assert _components(pooled) == 1 and pooled.sum() >= 2 * 200 // 4
    assert max_pool(skel, 1) is skel
    values = np.arange(12.0).reshape(3, 4)
    np.testing.assert_array_equal(max_pool(values, 2), [[5.0, 7.0], [9.0, 11.0]])
    # a one-pixel wall stays a whole black line in the shrunk map (occupied wins)
    occ = np.zeros((400, 400), bool)
    occ[200, :] = True
    img = map_image(tj.OccupancyMap.from_array(occ, resolution_m=0.05), 3)
    assert img.shape == (134, 134)
    assert np.count_nonzero(img == 0.0) == 134 and (img[66] == 0.0).all()


def test_a_map_larger_than_any_picture_is_shrunk_before_matplotlib_draws_it():
    # matplotlib resamples a shown image through several full-size float copies (some
    # 60 bytes per pixel: 4 GB for an 8000 x 8000 map), so the map layer of plot_map
    # is shrunk to at most MAX_SHOWN_PX pixels, keeping one-pixel walls
    from topojax.plotting import MAX_SHOWN_PX, plot_map

    side = 3000
    occ = np.zeros((side, side), bool)
    occ[1501, :] = True
    m = tj.OccupancyMap.from_array(occ, resolution_m=0.05)
    ax = plot_map(m)
    shown = ax.images[0].get_array()
    assert shown.size <= MAX_SHOWN_PX < side * side
    assert (np.asarray(shown) == 0.0).all(axis=1).sum() == 1  # the wall, whole
    assert ax.get_xlim() == (-0.5, side - 0.5)  # still drawn in the map's pixels
    plt.close(ax.figure)


@pytest.mark.parametrize("shape", [(5000, 3), (3, 5000), (700, 800)])
def test_the_picture_of_a_strip_map_keeps_a_bounded_canvas(shape):
    # a 5000 x 3 map on a figure as tall as its aspect asks is 15000 inches tall: some
    # 7 GB of canvas at the PNGs' 150 dpi; it is drawn narrower on a figure at most
    # MAX_FIGURE_ASPECT widths tall, and an ordinary map keeps its aspect
    from topojax.plotting.png import MAX_FIGURE_ASPECT, map_figure

    fig, _ = map_figure(shape, 9.0)
    width_in, height_in = fig.get_size_inches()
    assert width_in == 9.0
    assert height_in == pytest.approx(9.0 * min(shape[0] / shape[1], MAX_FIGURE_ASPECT))
    assert height_in <= 72.0


def test_a_distance_map_larger_than_any_picture_is_sampled_before_it_is_drawn():
    from topojax.plotting import MAX_SHOWN_PX, plot_distance

    side = 3000
    distance = np.linspace(0.0, 1.0, side * side, dtype=np.float32).reshape(side, side)
    ax = plot_distance(distance)
    shown = ax.images[0].get_array()
    assert shown.size <= MAX_SHOWN_PX < side * side
    assert shown[0, 0] == distance[0, 0]
    assert ax.get_xlim() == (-0.5, side - 0.5) and ax.get_ylim() == (side - 0.5, -0.5)
    plt.close(ax.figure)


def test_a_route_graph_picture_of_a_map_larger_than_any_picture_is_shrunk():
    # the margin layer too: shrunk to at most MAX_SHOWN_PX pixels, margin colour only
    # where a whole block is margin, so a feasible band one pixel wide stays clear
    from topojax.maps.occupancy import OccupancyMap
    from topojax.plotting import MAX_SHOWN_PX, plot_route_graph

    side = 3000
    free = np.zeros((side, side), bool)
    free[1:-1, 1:-1] = True
    occ = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05)
    g = nx.MultiGraph(shape=(side, side), resolution_m=0.05, origin=(0.0, 0.0, 0.0))
    ax = plot_route_graph(g, occ, robot_radius_m=0.3)
    margin = np.asarray(ax.images[1].get_array())
    assert margin.shape[0] * margin.shape[1] <= MAX_SHOWN_PX
    assert margin[2, margin.shape[1] // 2, 3] == 255  # rows 4-5: in the 6 px margin band
    assert margin[margin.shape[0] // 2, margin.shape[1] // 2, 3] == 0  # feasible
    plt.close(ax.figure)


def test_map_name_from_the_source():
    from topojax.plotting import map_name

    assert map_name("maps/intel.png") == "intel"
    assert map_name("maps/pal_office/map.yaml") == "pal_office"
    assert map_name(None) is None


def test_stage_panels_are_pooled_under_the_map_name(result):
    fig = plot_stages(result, figsize=(9, 6))
    assert fig.get_suptitle() == "a_scan"
    skeleton_panel = fig.axes[4]
    assert skeleton_panel.get_title() == "skeleton"
    shown = skeleton_panel.images[-1].get_array()
    assert shown.shape[0] < result.skeleton.shape[0]
    drawn = shown[..., 3] > 0  # the pooled skeleton pixels
    assert _components(drawn) <= _components(result.skeleton)
    plt.close(fig)
    assert plot_stages(result, title="x").get_suptitle() == "x"
    plt.close("all")


def test_route_graph_picture_shows_the_feasible_space_and_the_waypoints():
    from topojax.maps.occupancy import OccupancyMap
    from topojax.plotting import plot_route_graph

    free = np.zeros((60, 100), bool)
    free[1:-1, 1:-1] = True
    occ = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05)
    g = tj.route_graph(occ, robot_radius_m=0.3)
    ax = plot_route_graph(g, occ)
    lines = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(lines[0].get_segments()) == g.number_of_edges()
    _, _, first = next(iter(g.edges(data=True)))
    rows, cols = occ.world_to_pixel(first["waypoints"][:, 0], first["waypoints"][:, 1])
    np.testing.assert_allclose(lines[0].get_segments()[0], np.stack([cols, rows], 1))
    # the margin layer: tan on free pixels closer than the radius (6 px), clear elsewhere
    margin = ax.images[1].get_array()
    assert margin.shape == (60, 100, 4)
    assert margin[3, 50, 3] == 255 and margin[30, 50, 3] == 0 and margin[0, 50, 3] == 0
    assert "r = 0.3 m" in ax.get_title()
    plt.close(ax.figure)
    with pytest.raises(ValueError, match="occupancy: expected the graph's map of shape"):
        plot_route_graph(g, tj.sample_map("intel"))
    moved = OccupancyMap(occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.1)
    with pytest.raises(ValueError, match="occupancy: expected the graph's map at 0.05 m/px"):
        plot_route_graph(g, moved)
    with pytest.raises(TypeError, match="occupancy: expected an OccupancyMap"):
        plot_route_graph(g, None)
    with pytest.raises(TypeError, match="graph: expected a networkx graph, received NoneType"):
        plot_route_graph(None, occ)
    with pytest.raises(TypeError, match="ax: expected matplotlib Axes or None, received int"):
        plot_route_graph(g, occ, ax=5)
    g.graph.pop("robot_radius_m")
    with pytest.raises(ValueError, match="robot_radius_m"):
        plot_route_graph(g, occ)
    plt.close("all")


def test_route_graph_picture_of_any_graph_the_evaluator_scores():
    """A graph of another generator (SWAGGER's: world vertices, bare edges) is drawn as the
    evaluator reads it: straight segments between the vertices' world positions."""
    import networkx as nx

    from topojax.plotting import plot_route_graph

    occ = tj.sample_map("intel")
    g = nx.Graph()
    g.add_node("a", world=(5.0, 5.0))
    g.add_node("b", world=(10.0, 6.0))
    g.add_node("c", pixel=(100, 100))
    g.add_edge("a", "b")
    g.add_edge("b", "c", world=np.array([[10.0, 6.0], [8.0, 20.0]]))
    ax = plot_route_graph(g, occ, robot_radius_m=0.3)
    segments = [c for c in ax.collections if isinstance(c, LineCollection)][0].get_segments()
    rows, cols = occ.world_to_pixel(np.array([5.0, 10.0]), np.array([5.0, 6.0]))
    np.testing.assert_allclose(segments[0], np.stack([cols, rows], 1))
    assert len(segments[1]) == 2
    plt.close(ax.figure)
    g.add_node("d")
    with pytest.raises(
        ValueError, match=r"^graph: expected every vertex to carry a 'world' .* or 'pixel'"
    ):
        plot_route_graph(g, occ, robot_radius_m=0.3)
    plt.close("all")


def test_drawing_options_name_themselves(result):
    """Wrong drawing options are refused naming the option, neither left to fail inside
    matplotlib naming none ("s must be float", "figure size must be positive finite")
    nor drawn anyway (a NaN or negative line width, skeleton="no" taken as True, a str
    route failing with an AttributeError)."""
    occ = tj.OccupancyMap.from_array(np.pad(np.zeros((20, 20), bool), 2, constant_values=True))
    with pytest.warns(UserWarning, match="empty route graph"):  # a 1 m room: too small
        routes = tj.route_graph(occ, robot_radius_m=0.1)
    bad = [
        (dict(linewidth=np.nan), ValueError, "^linewidth: expected a finite number of points"),
        (dict(linewidth=-1.0), ValueError, "^linewidth: expected a finite number of points"),
        (dict(node_size="big"), TypeError, "^node_size: expected a real number of points"),
        (dict(edge_color="#ff7f0"), ValueError, "^edge_color: expected a matplotlib colour"),
    ]
    for kwargs, exc, match in bad:
        with pytest.raises(exc, match=match):
            tj.plot_route_graph(routes, occ, **kwargs)
        with pytest.raises(exc, match=match):
            plot_graph(result.graph, **kwargs)
    with pytest.raises(TypeError, match="^skeleton: expected a bool, received str"):
        tj.plot(result, skeleton="no")
    with pytest.raises(TypeError, match="^route: expected a Route, received str"):
        tj.plot(result, route="route.json")
    with pytest.raises(ValueError, match=r"^figsize: expected \(width, height\) in inches > 0"):
        plot_stages(result, figsize=(-1, 5))
    with pytest.raises(ValueError, match="^figsize: expected two finite numbers"):
        plot_stages(result, figsize=(5,))
    seg = tj.segment_rooms(occ)
    for name in ("doors", "labels"):
        with pytest.raises(TypeError, match=f"^{name}: expected a bool, received str 'no'"):
            tj.plot_rooms(seg, **{name: "no"})
    # a title that is not a str is refused, not drawn as its str(): "True",
    # "<object object at ...>"
    drawings = [
        lambda t: tj.plot(result, title=t),
        lambda t: tj.plot_rooms(seg, title=t),
        lambda t: tj.plot_route_graph(routes, occ, title=t),
        lambda t: plot_stages(result, title=t),
        lambda t: plot_graph(result.graph, title=t),
    ]
    for draw in drawings:
        for title in (True, 3.5, ["a"], object()):
            with pytest.raises(TypeError, match="^title: expected a str or None, received "):
                draw(title)
    corridors = tj.route_graph(result.map, robot_radius_m=0.2)
    u, v, k = next(iter(corridors.edges(keys=True)))
    corridors.edges[u, v, k]["waypoints"] = "corridor"  # named, not left to fail inside NumPy
    with pytest.raises(
        ValueError, match=rf"^graph: edge {u}-{v}: 'waypoints': expected finite \(x, y\) points"
    ):
        tj.plot_route_graph(corridors, result.map)
    plt.close("all")


def test_a_title_that_is_not_a_str_is_refused_before_anything_is_drawn(result):
    """Every helper that takes a title takes a str or None, and names ``title``
    otherwise: ``title=3`` is not drawn as "3" (nor ``plot_stages(title=0)`` as no
    title)."""
    from topojax.plotting import (
        plot_distance,
        plot_map,
        plot_ridges,
        plot_route,
        plot_skeleton,
        result_png,
        route_graph_png,
        stages_png,
    )

    occ = tj.OccupancyMap.from_array(np.pad(np.zeros((20, 20), bool), 2, constant_values=True))
    with pytest.warns(UserWarning, match="empty route graph"):  # a 1 m room: too small
        routes = tj.route_graph(occ, robot_radius_m=0.1)
    g = result.graph
    u, v = next((a, b) for a, b in g.edges() if a != b)
    route = tj.plan_route(g, g.nodes[u]["pixel"], g.nodes[v]["pixel"], frame="pixel")
    draws = [
        lambda **kw: plot_map(result.map, **kw),
        lambda **kw: plot_distance(result.distance, **kw),
        lambda **kw: plot_ridges(result.ridges, **kw),
        lambda **kw: plot_skeleton(result.skeleton, **kw),
        lambda **kw: plot_graph(g, **kw),
        lambda **kw: plot_route(route, **kw),
        lambda **kw: tj.plot_route_graph(routes, occ, **kw),
        lambda **kw: tj.plot_rooms(tj.segment_rooms(occ), **kw),
        lambda **kw: tj.plot(result, **kw),
        lambda **kw: plot_stages(result, **kw),
        lambda **kw: result_png(result, **kw),
        lambda **kw: stages_png(result, **kw),
        lambda **kw: route_graph_png(routes, occ, **kw),
    ]
    plt.close("all")
    for draw in draws:
        for title in (3, 0, b"map", ["map"]):
            with pytest.raises(TypeError, match="^title: expected a str or None, received "):
                draw(title=title)
        assert not plt.get_fignums()  # refused before a figure was made
    ax = tj.plot(result, title="x")
    assert ax.get_title() == "x"
    plt.close("all")


def test_vertices_of_other_kinds_are_drawn_not_dropped():
    """A graph made by another tool (no ``kind``, or one topojax does not use) shows every
    vertex: those of other kinds as "other", in the viewer's and the MCAP markers' brown."""
    from matplotlib.colors import to_hex

    from topojax._constants import OTHER_VERTEX_COLOUR

    g = tj.build_graph(sample_map("a_scan")).graph.copy()
    nodes = list(g.nodes)
    del g.nodes[nodes[0]]["kind"]
    g.nodes[nodes[1]]["kind"] = "door"
    ax = plot_graph(g)
    drawn = {c.get_label(): c for c in ax.collections if not isinstance(c, LineCollection)}
    assert sum(len(c.get_offsets()) for c in drawn.values()) == g.number_of_nodes()
    assert len(drawn["other"].get_offsets()) == 2
    assert to_hex(drawn["other"].get_facecolor()[0]) == OTHER_VERTEX_COLOUR
    assert "other" in [t.get_text() for t in ax.get_legend().get_texts()]
    plt.close(ax.figure)
