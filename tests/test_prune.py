"""Tests for topojax.prune_graph (short spurs and small components).

The independent reference prunes *pixels*: it deletes each short spur's pixels (all but
the junction's) from the skeleton and builds the graph again with skeleton_to_graph,
round after round, then drops small components.  prune_graph works on the graph alone
(joining edges where a junction is left with two), so agreeing with the reference checks
its joins, kinds, lengths and clearances.
"""

from __future__ import annotations

import math
from collections import Counter

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from skimage.morphology import skeletonize

import topojax as tj
from topojax.graph import prune_graph, skeleton_to_graph
from topojax.pipeline import build_graph

SQRT2 = math.sqrt(2.0)


def art(text: str) -> np.ndarray:
    """'#' = skeleton pixel, '.' = background."""
    rows = [line.strip() for line in text.strip().splitlines()]
    return np.array([[ch == "#" for ch in r] for r in rows], dtype=bool)


def _spurs(g: nx.MultiGraph, min_spur_m: float):
    return [
        (u, v, d)
        for u, v, d in g.edges(data=True)
        if u != v
        and d["length_m"] < min_spur_m
        and min(g.degree(u), g.degree(v)) == 1
        and max(g.degree(u), g.degree(v)) >= 3
    ]


def reference_prune(skeleton, build, min_spur_m, min_component_m) -> nx.MultiGraph:
    """Pixel-level pruning: delete short spurs' pixels, rebuild, repeat; then components."""
    skel = np.array(skeleton, bool)
    g = build(skel)
    while spurs := _spurs(g, min_spur_m):
        for u, v, d in spurs:
            hub = g.nodes[v if g.degree(u) == 1 else u]["pixel"]
            for r, c in d["path"].tolist():
                if (r, c) != tuple(hub):
                    skel[r, c] = False
        g = build(skel)
    for nodes in list(nx.connected_components(g)):
        if math.fsum(d for _, _, d in g.edges(nodes, data="length_m")) < min_component_m:
            g.remove_nodes_from(nodes)
    return g


def pixel_set(g) -> set[tuple[int, int]]:
    out = {tuple(map(int, d["pixel"])) for _, d in g.nodes(data=True)}
    for _, _, d in g.edges(data=True):
        out.update(map(tuple, d["path"].tolist()))
    return out


def edges_by_pixels(g) -> dict[frozenset, dict]:
    """Edges keyed by their pixel sets.  A self-loop's path holds its vertex pixel twice,
    so its mean clearance depends on where the loop is anchored: ``mean_clearance_m`` is
    replaced by the mean over its distinct pixels."""
    out = {}
    for u, v, d in g.edges(data=True):
        key = frozenset(map(tuple, d["path"].tolist()))
        assert key not in out
        out[key] = dict(d)
        if u == v:
            k = len(d["path"])
            c = g.nodes[u]["clearance_m"]
            out[key]["mean_clearance_m"] = (d["mean_clearance_m"] * k - c) / (k - 1)
    return out


def assert_same_as_reference(got: nx.MultiGraph, ref: nx.MultiGraph) -> None:
    assert pixel_set(got) == pixel_set(ref)
    # vertices (a ring keeps its junction's pixel here; the rebuild anchors it elsewhere)
    gv = {tuple(d["pixel"]): d for _, d in got.nodes(data=True) if d["kind"] != "ring"}
    rv = {tuple(d["pixel"]): d for _, d in ref.nodes(data=True) if d["kind"] != "ring"}
    assert gv.keys() == rv.keys()
    for p, d in gv.items():
        assert d["kind"] == rv[p]["kind"]
        assert d["world"] == pytest.approx(rv[p]["world"])
        assert d["clearance_m"] == pytest.approx(rv[p]["clearance_m"], nan_ok=True)
    assert sum(d["kind"] == "ring" for _, d in got.nodes(data=True)) == sum(
        d["kind"] == "ring" for _, d in ref.nodes(data=True)
    )
    ge, re_ = edges_by_pixels(got), edges_by_pixels(ref)
    assert ge.keys() == re_.keys()
    for key, d in ge.items():
        r = re_[key]
        assert len(d["path"]) == len(r["path"])
        for name in ("length_m", "min_clearance_m", "mean_clearance_m"):
            assert d[name] == pytest.approx(r[name], rel=1e-9, abs=1e-12, nan_ok=True)
    check_structure(got)


def check_structure(g: nx.MultiGraph) -> None:
    """Numbering, kinds, orientation, world polylines and the pixel partition."""
    pixels = [tuple(g.nodes[n]["pixel"]) for n in range(g.number_of_nodes())]
    assert sorted(g.nodes) == list(range(len(pixels)))
    assert pixels == sorted(pixels)
    seen = set(pixels)
    for n in g.nodes:
        deg, loops = g.degree(n), g.number_of_edges(n, n)
        kind = g.nodes[n]["kind"]
        expect = "ring" if deg == 2 and loops else {0: "isolated", 1: "end"}.get(deg, "junction")
        assert kind == expect and deg != 2 or kind == "ring"
    for u, v, d in g.edges(data=True):
        assert u <= v
        path = [tuple(p) for p in d["path"].tolist()]
        assert path[0] == pixels[u] and path[-1] == pixels[v]
        steps = np.abs(np.diff(d["path"], axis=0))
        assert steps.max() <= 1 and (steps.sum(axis=1) > 0).all()  # 8-connected
        interior = path[1:-1]
        assert not seen & set(interior) and len(set(interior)) == len(interior)
        seen.update(interior)
        res = g.graph["resolution_m"]
        length = (np.where(steps.sum(axis=1) == 2, SQRT2, 1.0)).sum() * res
        assert d["length_m"] == pytest.approx(length)
        if "world" in d:
            assert d["world"].shape == (len(path), 2)


# --------------------------------------------------------------------- literal fixtures


def graph_of(text: str, *, clearance=None) -> nx.MultiGraph:
    skel = art(text)
    if clearance is None:
        clearance = np.arange(skel.size, dtype=float).reshape(skel.shape) % 7 + 1
    return skeleton_to_graph(skel, clearance_px=clearance)


def test_short_spur_goes_and_its_junction_is_joined():
    g = graph_of(
        """
        .........
        ####.####
        ....#....
        ....#....
        """
    )
    assert tj.graph_summary(g)["n_junctions"] == 1
    out = prune_graph(g, min_spur_m=2.5)
    assert tj.graph_summary(out)["n_vertices"] == 2
    assert out.number_of_edges() == 1
    ((u, v, d),) = out.edges(data=True)
    assert [tuple(p) for p in d["path"].tolist()] == [(1, c) for c in range(4)] + [(2, 4)] + [
        (1, c) for c in range(5, 9)
    ]
    assert {out.nodes[n]["kind"] for n in out} == {"end"}
    skel = art(
        """
        .........
        ####.####
        ....#....
        ....#....
        """
    )
    clearance = np.arange(skel.size, dtype=float).reshape(skel.shape) % 7 + 1
    want = np.array([clearance[r, c] for r, c in d["path"].tolist()])
    assert d["mean_clearance_m"] == pytest.approx(want.mean())
    assert d["min_clearance_m"] == want.min()
    # the spur is one step (1 m) long: "shorter than" 1 m keeps it; the arms (3 + sqrt 2)
    # are spurs too but long enough
    assert prune_graph(g, min_spur_m=1.0).number_of_edges() == 3
    assert prune_graph(g, min_spur_m=3 + SQRT2).number_of_edges() == 1


def test_loop_with_a_short_spur_becomes_a_ring_at_the_junction():
    g = graph_of(
        """
        .......
        ..###..
        .#...#.
        .#...#.
        ..###..
        ...#...
        ...#...
        """
    )
    out = prune_graph(g, min_spur_m=5)
    assert out.number_of_nodes() == 1 and out.number_of_edges() == 1
    assert out.nodes[0]["kind"] == "ring" and out.nodes[0]["pixel"] == (4, 3)
    ((_, _, d),) = out.edges(data=True)
    assert tuple(d["path"][0]) == tuple(d["path"][-1]) == (4, 3)
    assert len(d["path"]) == 11  # 10 ring pixels, the start twice


def test_tree_of_short_branches_is_eaten_from_the_tips():
    # a trunk with a side branch that itself forks: the fork's two tips go in the first
    # round, then the branch (now a spur) in the second
    g = graph_of(
        """
        ###########
        .....#.....
        .....#.....
        .....##....
        .....#.#...
        .....#..#..
        """
    )
    ref = reference_prune(
        art(
            """
        ###########
        .....#.....
        .....#.....
        .....##....
        .....#.#...
        .....#..#..
        """
        ),
        skeleton_to_graph,
        4.0,
        0.0,
    )
    out = prune_graph(g, min_spur_m=4.0)
    assert out.number_of_edges() == 1 and tj.graph_summary(out)["n_ends"] == 2
    assert pixel_set(out) == pixel_set(ref) == {(0, c) for c in range(11)}


def test_star_of_short_spurs_shrinks_to_a_point_then_goes_with_components():
    text = """
        #...#
        .#.#.
        ..#..
        ..#..
        """
    out = prune_graph(graph_of(text), min_spur_m=5)
    assert out.number_of_nodes() == 1 and out.number_of_edges() == 0
    assert out.nodes[0]["kind"] == "isolated"
    assert prune_graph(graph_of(text), min_spur_m=5, min_component_m=0.1).number_of_nodes() == 0


def test_parallel_edges_joined_through_a_junction_become_a_self_loop():
    # two corridors between the same pair of junctions; a short spur on the left junction
    text = """
        ..#####..
        .#.....#.
        ##.....##
        .#.....#.
        ..#####..
        """
    g = graph_of(text)
    out = prune_graph(g, min_spur_m=1.5)
    ref = reference_prune(
        art(text),
        lambda s: skeleton_to_graph(
            s, clearance_px=np.arange(s.size, dtype=float).reshape(s.shape) % 7 + 1
        ),
        1.5,
        0.0,
    )
    assert_same_as_reference(out, ref)


def test_small_components_and_isolated_pixels_go():
    text = """
        ##########....
        ..............
        .........#....
        ..##.....#....
        .........#....
        #.............
        """
    g = graph_of(text)
    assert nx.number_connected_components(g) == 4
    out = prune_graph(g, min_component_m=1.5)  # keeps the 9-step line and the 2-step one
    assert nx.number_connected_components(out) == 2
    assert sorted(d["length_m"] for _, _, d in out.edges(data=True)) == [2.0, 9.0]
    assert prune_graph(g, min_component_m=2.0 + 1e-9).number_of_edges() == 1


def test_defaults_keep_everything_and_the_input_is_untouched():
    res = build_graph(tj.sample_map("intel"))
    before = tj.graph_summary(res.graph)
    paths = {
        k: d["path"].copy() for *k, d in res.graph.edges(keys=True, data=True) for k in [tuple(k)]
    }
    out = prune_graph(res.graph)
    assert tj.graph_summary(out) == before
    assert out.graph["pruned_min_spur_m"] == 0.0 and out.graph["pruned_min_component_m"] == 0.0
    assert pixel_set(out) == pixel_set(res.graph)
    prune_graph(res.graph, min_spur_m=2.0, min_component_m=5.0)
    assert tj.graph_summary(res.graph) == before
    for u, v, k, d in res.graph.edges(keys=True, data=True):
        np.testing.assert_array_equal(d["path"], paths[(u, v, k)])


# ------------------------------------------------------------------ real maps, property


@pytest.mark.parametrize("name", ["intel", "office", "a_scan"])
@pytest.mark.parametrize("spur, component", [(0.5, 0.0), (3.0, 10.0), (0.0, 5.0)])
def test_equals_pixel_level_pruning_on_the_paper_maps(name, spur, component):
    res = build_graph(tj.sample_map(name))
    m = res.map

    def build(skel):
        return skeleton_to_graph(
            skel,
            clearance_px=res.clearance_px,
            resolution_m=m.resolution_m,
            pixel_to_world=m.pixel_to_world,
        )

    got = prune_graph(res.graph, min_spur_m=spur, min_component_m=component)
    ref = reference_prune(res.skeleton, build, spur, component)
    assert_same_as_reference(got, ref)
    if spur:
        assert not _spurs(got, spur)
    for nodes in nx.connected_components(got):
        assert math.fsum(d for _, _, d in got.edges(nodes, data="length_m")) >= component
    # world polylines follow the paths
    for _, _, d in got.edges(data=True):
        x, y = m.pixel_to_world(d["path"][:, 0].astype(float), d["path"][:, 1].astype(float))
        np.testing.assert_allclose(d["world"], np.stack([x, y], axis=1))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    spur=st.sampled_from([0.0, 1.5, 3.0, 6.0, 12.0]),
    component=st.sampled_from([0.0, 2.0, 8.0, 30.0]),
)
def test_equals_pixel_level_pruning_on_random_skeletons(seed, spur, component):
    rng = np.random.default_rng(seed)
    blobs = rng.random((24, 30)) < 0.55
    skel = skeletonize(blobs)
    clearance = rng.random(skel.shape) * 5

    def build(s):
        return skeleton_to_graph(s, clearance_px=clearance, resolution_m=0.5)

    got = prune_graph(build(skel), min_spur_m=spur, min_component_m=component)
    assert_same_as_reference(got, reference_prune(skel, build, spur, component))


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "kwargs, exc, words",
    [
        ({"min_spur_m": -1.0}, ValueError, ["min_spur_m", ">= 0", "-1.0"]),
        ({"min_spur_m": float("nan")}, ValueError, ["min_spur_m", "nan"]),
        ({"min_component_m": float("inf")}, ValueError, ["min_component_m", "inf"]),
        ({"min_spur_m": True}, TypeError, ["min_spur_m", "True"]),
        ({"min_component_m": "2"}, TypeError, ["min_component_m", "'2'"]),
    ],
)
def test_bad_thresholds_raise_clear_errors(kwargs, exc, words):
    g = graph_of("###")
    with pytest.raises(exc) as info:
        prune_graph(g, **kwargs)
    for word in words:
        assert word in str(info.value)


def _members(data: dict) -> set[tuple[int, int]]:
    pixels = data.get("pixels")
    pixels = [data["pixel"]] if pixels is None or len(pixels) == 0 else pixels
    return {(int(r), int(c)) for r, c in np.asarray(pixels).tolist()}


@pytest.mark.parametrize("seed", range(6))
def test_paths_run_from_u_to_v_after_pruning_merged_graphs(seed):
    """Edges stay ``(u, v)`` with ``u <= v`` and the path from a pixel of ``u`` to a
    pixel of ``v``; with merged junction clusters a path may end at any member pixel (an
    orientation test that looks at the representative pixel only reverses them)."""
    rng = np.random.default_rng(seed)
    blobs = rng.random((60, 60)) < 0.45
    skel = skeletonize(blobs)
    g = skeleton_to_graph(skel, merge_junction_clusters=True)
    assert any(len(_members(d)) > 1 for _, d in g.nodes(data=True))
    for pruned in (prune_graph(g), prune_graph(g, min_component_m=5.0)):
        for u, v, d in pruned.edges(data=True):
            assert u <= v
            path = np.asarray(d["path"])
            assert tuple(path[0]) in _members(pruned.nodes[u])
            assert tuple(path[-1]) in _members(pruned.nodes[v])
    s = art("#..#\n.##.\n#..#")  # the smallest case: a path ending off the representative
    pruned = prune_graph(skeleton_to_graph(s, merge_junction_clusters=True))
    for u, _v, d in pruned.edges(data=True):
        assert tuple(d["path"][0]) in _members(pruned.nodes[u])


def test_bad_graphs_raise_clear_errors():
    with pytest.raises(TypeError, match="graph: expected an undirected networkx.MultiGraph"):
        prune_graph(nx.Graph())
    with pytest.raises(TypeError, match="MultiDiGraph"):
        prune_graph(nx.MultiDiGraph())
    merged = skeleton_to_graph(art("###\n.#.\n###"), merge_junction_clusters=True)
    with pytest.raises(ValueError, match="merge_junction_clusters=False"):
        prune_graph(merged, min_spur_m=1)
    g = nx.MultiGraph()
    g.add_node(0, kind="end")
    with pytest.raises(ValueError, match="'pixel'"):
        prune_graph(g)
    g.nodes[0]["pixel"] = "here"
    with pytest.raises(TypeError, match=r"^graph: vertex 0: 'pixel': expected \(row, col\)"):
        prune_graph(g)
    tee = skeleton_to_graph(art("#####\n..#..\n..#.."), resolution_m=1.0)
    u, v, k = next(iter(tee.edges(keys=True)))
    for attr, value, exc, words in (
        ("length_m", "2", TypeError, "'length_m': expected a real number of metres >= 0"),
        ("length_m", -2.0, ValueError, "'length_m': expected a finite number of metres >= 0"),
        ("length_m", float("nan"), ValueError, "'length_m': expected a finite number"),
        ("min_clearance_m", "0.1", TypeError, "'min_clearance_m': expected a real number"),
    ):
        edited = tee.copy()
        edited.edges[u, v, k][attr] = value
        with pytest.raises(exc, match=rf"^graph: edge {u}-{v}: {words}"):
            prune_graph(edited, min_clearance_m=1.0, min_spur_m=1.0)


# ------------------------------------------------------------------ in the pipeline


def test_graph_config_prunes_in_build_graph_as_prune_graph_does():
    occ = tj.sample_map("a_scan")
    plain = build_graph(occ)
    config = tj.PipelineConfig(graph=tj.GraphConfig(min_spur_m=1.0, min_component_m=4.0))
    pruned = build_graph(occ, config=config)
    want = prune_graph(plain.graph, min_spur_m=1.0, min_component_m=4.0)
    assert tj.graph_summary(pruned.graph) == tj.graph_summary(want)
    assert_same_as_reference(pruned.graph, want)
    np.testing.assert_array_equal(pruned.skeleton, plain.skeleton)
    assert pruned.graph.graph["pruned_min_spur_m"] == 1.0
    assert pruned.graph.graph["thinning"] == "guo_hall" and "origin" in pruned.graph.graph


def test_free_space_only_keeps_the_graph_in_known_free_space(shared_data):
    from topojax.graph import skeleton_to_graph
    from topojax.skeleton import remove_t_centres, thin

    occ = tj.load_map(shared_data / "maps/ros/turtlebot3_office/map_office_raw.yaml")
    plain = build_graph(occ)
    config = tj.PipelineConfig(graph=tj.GraphConfig(free_space_only=True))
    res = build_graph(occ, config=config)
    assert (plain.skeleton & occ.unknown).any()  # the test means something
    assert not (res.skeleton & ~occ.free).any()
    assert pixel_set(res.graph) == {tuple(p) for p in np.argwhere(res.skeleton).tolist()}
    # the same as thinning the ridges in free space by hand
    skel = remove_t_centres(thin(plain.ridges & occ.free))
    np.testing.assert_array_equal(res.skeleton, skel)
    want = skeleton_to_graph(
        skel,
        clearance_px=plain.clearance_px,
        resolution_m=occ.resolution_m,
        pixel_to_world=occ.pixel_to_world,
    )
    assert_same_as_reference(res.graph, want)


def test_graph_from_ridges_needs_the_free_mask_for_free_space_only():
    from topojax.pipeline import graph_from_ridges

    config = tj.PipelineConfig(graph=tj.GraphConfig(free_space_only=True))
    ridges = np.zeros((6, 7), bool)
    kw = dict(clearance_px=None, resolution_m=1.0, origin=(0, 0, 0), pixel_to_world=None)
    with pytest.raises(ValueError, match=r"free: .* bool array of shape \(6, 7\), received None"):
        graph_from_ridges(ridges, config=config, **kw)
    with pytest.raises(ValueError, match=r"received uint8 \(6, 7\)"):
        graph_from_ridges(ridges, config=config, free=np.ones((6, 7), np.uint8), **kw)


@pytest.mark.parametrize(
    "kwargs, exc, words",
    [
        ({"min_spur_m": -0.5}, ValueError, ["min_spur_m", ">= 0", "-0.5"]),
        ({"min_component_m": float("nan")}, ValueError, ["min_component_m", "nan"]),
        ({"min_spur_m": "1"}, TypeError, ["min_spur_m", "str"]),
        ({"free_space_only": 1}, TypeError, ["free_space_only", "bool", "1"]),
        (
            {"merge_junction_clusters": True, "min_clearance_m": 0.2},
            ValueError,
            ["min_spur_m and min_clearance_m > 0", "merge_junction_clusters=False"],
        ),
    ],
)
def test_graph_config_rejects_bad_values(kwargs, exc, words):
    with pytest.raises(exc) as info:
        tj.GraphConfig(**kwargs)
    for word in words:
        assert word in str(info.value)


def test_components_alone_may_be_pruned_from_merged_cluster_graphs():
    g = skeleton_to_graph(art("###....\n.#.....\n###...#"), merge_junction_clusters=True)
    out = prune_graph(g, min_component_m=1.0)
    assert out.number_of_nodes() == g.number_of_nodes() - 1


@pytest.mark.parametrize(
    "graph",
    [
        {"free_space_only": True},
        {"min_clearance_m": 0.3},
        {"min_spur_m": 0.5},
        {"min_component_m": 2.0},
    ],
)
def test_incremental_mapper_rejects_graph_keeping_options(graph):
    config = tj.PipelineConfig(graph=tj.GraphConfig(**graph))
    with pytest.raises(ValueError, match="not supported incrementally.*prune_graph"):
        tj.IncrementalMapper(resolution_m=0.05, config=config)


def test_cli_graph_keeping_options(tmp_path, capsys, shared_data):
    from topojax.cli import main

    yaml = shared_data / "maps/ros/turtlebot3_office/map_office_raw.yaml"
    argv = ["graph", str(yaml), "-o", str(tmp_path)]
    assert main(argv) == 0
    plain = tj.load_graph(tmp_path / "map_office_raw.json")
    assert main([*argv, "--free-only", "--min-spur-m", "0.4", "--min-component-m", "1.5"]) == 0
    pruned = tj.load_graph(tmp_path / "map_office_raw.json")
    assert pruned.number_of_nodes() < plain.number_of_nodes()
    assert pruned.graph["pruned_min_spur_m"] == 0.4
    capsys.readouterr()
    assert main([*argv, "--min-spur-m", "-1"]) == 2
    assert "--min-spur-m: expected a finite number of metres >= 0, received -1.0" in (
        capsys.readouterr().err
    )


def test_result_shares_no_arrays_and_keeps_agreeing_extra_attributes():
    g = graph_of(
        """
        ####.####
        ....#....
        ....#....
        """
    )
    for u, v, k in g.edges(keys=True):
        g.edges[u, v, k]["corridor"] = "A"
        g.edges[u, v, k]["tags"] = np.array([1, 2])
        g.edges[u, v, k]["uid"] = (u, v)  # differs between the joined edges
    out = prune_graph(g)
    for _, _, d in out.edges(data=True):
        d["path"][:] = -1
    assert all((d["path"] >= 0).all() for _, _, d in g.edges(data=True))
    ((_, _, d),) = prune_graph(g, min_spur_m=1.5).edges(data=True)
    assert d["corridor"] == "A" and d["tags"].tolist() == [1, 2] and "uid" not in d
    bad = nx.MultiGraph()
    bad.add_node(0, pixel=(0, 0))
    bad.add_node(1, pixel=(0, 1))
    bad.add_edge(0, 1, path=np.array([[0, 0], [0, 1]]))
    with pytest.raises(ValueError, match="'length_m', edge 0-1 has none"):
        prune_graph(bad)


@pytest.mark.parametrize("suffix", [".json", ".graphml", ".geojson"])
def test_graphs_loaded_from_files_prune_alike(tmp_path, suffix):
    res = build_graph(tj.sample_map("intel"))
    loaded = tj.load_graph(tj.save_graph(res.graph, tmp_path / f"g{suffix}"))
    got = prune_graph(loaded, min_spur_m=0.5, min_component_m=2.0)
    want = prune_graph(res.graph, min_spur_m=0.5, min_component_m=2.0)
    assert tj.graph_summary(got) == tj.graph_summary(want)
    assert edges_by_pixels(got).keys() == edges_by_pixels(want).keys()


# ------------------------------------------------------------------ narrow corridors


def expected_after_narrow_edges(g: nx.MultiGraph, min_clearance_m: float):
    """Independent reference for step 1: the surviving edges (clearance >= threshold),
    chained through every vertex left with exactly two edge ends and no loop; returns the
    chains' pixel sets and the pixels of the vertices that stay (rings excluded)."""
    keep = [
        (u, v, k)
        for u, v, k, c in g.edges(keys=True, data="min_clearance_m")
        if not c < min_clearance_m
    ]
    ends = Counter()
    loops = set()
    for u, v, _ in keep:
        ends[u] += 1
        ends[v] += 1
        if u == v:
            loops.add(u)
    parent = list(range(len(keep)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    at = {}
    for i, (u, v, _) in enumerate(keep):
        for n in {u, v}:
            at.setdefault(n, []).append(i)
    for n, ids in at.items():
        if ends[n] == 2 and n not in loops:
            a, b = ids
            parent[find(a)] = find(b)
    chains = {}
    for i, (u, v, k) in enumerate(keep):
        chains.setdefault(find(i), set()).update(map(tuple, g.edges[u, v, k]["path"].tolist()))
    stay = {
        tuple(g.nodes[n]["pixel"])
        for n in g.nodes
        if not (ends[n] == 2 and n not in loops) and not (ends[n] == 2 and n in loops)
    }
    return {frozenset(c) for c in chains.values()}, stay


def test_narrow_edge_goes_and_its_ends_are_joined():
    text = """
        #########
        ....#....
        ....#....
        """
    skel = art(text)
    clearance = np.full(skel.shape, 3.0)
    clearance[0, 6] = 0.5  # the right arm has a narrow spot
    g = skeleton_to_graph(skel, clearance_px=clearance)
    out = prune_graph(g, min_clearance_m=1.0)
    # the right arm goes (its dead end stays, isolated); the junction, left with the
    # left arm and the stem, is joined
    assert out.number_of_edges() == 1 and out.number_of_nodes() == 3
    kinds = sorted(d["kind"] for _, d in out.nodes(data=True))
    assert kinds == ["end", "end", "isolated"]
    assert prune_graph(g, min_clearance_m=1.0, min_component_m=0.1).number_of_nodes() == 2
    ((_, _, d),) = out.edges(data=True)
    assert {tuple(p) for p in d["path"].tolist()} == {(0, c) for c in range(5)} | {
        (1, 4),
        (2, 4),
    }
    assert d["min_clearance_m"] == 3.0
    # without clearances nothing is narrow
    assert prune_graph(skeleton_to_graph(skel), min_clearance_m=1.0).number_of_edges() == 3


@pytest.mark.parametrize("name", ["intel", "office", "a_scan"])
@pytest.mark.parametrize("quantile", [0.1, 0.5])
def test_narrow_edges_on_the_paper_maps(name, quantile):
    res = build_graph(tj.sample_map(name))
    widths = np.unique([c for _, _, c in res.graph.edges(data="min_clearance_m")])
    clearance = float(widths[max(1, int(quantile * len(widths)))])  # some edges are below
    got = prune_graph(res.graph, min_clearance_m=clearance)
    chains, stay = expected_after_narrow_edges(res.graph, clearance)
    assert {frozenset(map(tuple, d["path"].tolist())) for _, _, d in got.edges(data=True)} == (
        chains
    )
    assert {tuple(d["pixel"]) for _, d in got.nodes(data=True) if d["kind"] != "ring"} == stay
    assert all(c >= clearance for _, _, c in got.edges(data="min_clearance_m"))
    assert got.number_of_edges() < res.graph.number_of_edges()
    check_structure(got)
    # every step together, as GraphConfig runs them
    both = prune_graph(res.graph, min_clearance_m=clearance, min_spur_m=1.0, min_component_m=3.0)
    again = prune_graph(got, min_spur_m=1.0, min_component_m=3.0)
    assert_same_as_reference(both, again)
    config = tj.PipelineConfig(
        graph=tj.GraphConfig(min_clearance_m=clearance, min_spur_m=1.0, min_component_m=3.0)
    )
    assert_same_as_reference(build_graph(tj.sample_map(name), config=config).graph, both)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), clearance=st.sampled_from([0.5, 1.0, 2.0, 3.0]))
def test_narrow_edges_on_random_skeletons(seed, clearance):
    rng = np.random.default_rng(seed)
    skel = skeletonize(rng.random((24, 30)) < 0.55) if seed % 2 else rng.random((20, 20)) < 0.3
    g = skeleton_to_graph(skel, clearance_px=rng.random(skel.shape) * 8, resolution_m=0.5)
    got = prune_graph(g, min_clearance_m=clearance)
    chains, stay = expected_after_narrow_edges(g, clearance)
    assert {frozenset(map(tuple, d["path"].tolist())) for _, _, d in got.edges(data=True)} == (
        chains
    )
    assert {tuple(d["pixel"]) for _, d in got.nodes(data=True) if d["kind"] != "ring"} == stay
    check_structure(got)


def test_an_edge_exactly_as_wide_as_the_limit_is_kept_whatever_its_rounding():
    skel = art("""
        #####
        """)
    g = skeleton_to_graph(skel, clearance_px=np.full(skel.shape, 11.0), resolution_m=0.03)
    ((_, _, width),) = g.edges(data="min_clearance_m")
    assert width < 0.33  # 11 x 0.03 in float64
    assert prune_graph(g, min_clearance_m=0.33).number_of_edges() == 1
    assert prune_graph(g, min_clearance_m=0.3301).number_of_edges() == 0


def test_a_topology_result_passed_as_the_graph_says_where_its_graph_is():
    """build_graph returns a TopologyResult, whose ``.graph`` is the networkx graph: the
    functions that take a graph, given the result, say so rather than only refusing it."""
    occ = np.ones((40, 60), bool)
    occ[5:35, 5:55] = False
    m = tj.OccupancyMap.from_array(occ, resolution_m=0.05)
    result = build_graph(m)
    hint = r"received TopologyResult \(its \.graph is the networkx graph\)$"
    with pytest.raises(TypeError, match=rf"^graph: expected .*, {hint}"):
        prune_graph(result, min_spur_m=0.5)
    with pytest.raises(TypeError, match=rf"^graph: expected .*, {hint}"):
        tj.evaluate_route_graph(result, m, 0.1)
    with pytest.raises(TypeError, match=rf"^graph: expected .*, {hint}"):
        tj.plan_route(result, (0.5, 0.5), (2.0, 1.0))
    with pytest.raises(TypeError, match=r"received DiGraph$"):  # a graph's .graph is a dict
        prune_graph(nx.DiGraph(), min_spur_m=0.5)
