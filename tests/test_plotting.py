"""Plot helpers draw what the result holds."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
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
