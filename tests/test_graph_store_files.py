"""A GraphStore saved as a folder of arrays (``save_graph_store`` / ``load_graph_store``) and
``build_graph_tiled(out_dir=)``, which leaves its graph there.

Every hand-written store of ``test_graph_store`` comes back array for array, memory-mapped
or read; a tiled build's folder opens as the build's store; a save or build that stops,
a file replaced or cut short, and wrong arguments are refused by name."""

from __future__ import annotations

import json
import math
import os
import stat
from pathlib import Path

import numpy as np
import pytest
from test_graph_store import (
    FIXTURES,
    IDS,
    assert_same_graph,
    assert_same_store,
    plan_map,
    with_waypoints,
)

import topojax as tj
import topojax.io.store as store_files
from topojax.config import DistanceConfig, GraphConfig, PipelineConfig
from topojax.graph import GraphStore

#: A store saved before stores had waypoint arrays: the merged junction cluster of
#: ``test_graph_store`` with the attributes ``origin`` (1.0, 2.0, 0.0) and ``note`` "x".
SAVED_V1 = Path(__file__).parent / "data" / "graph_store_v1"

SMALL = PipelineConfig(distance=DistanceConfig.from_pixels(sigma_px=10.0), tile_px=64)


def mapped(arr: np.ndarray) -> bool:
    while arr is not None and not isinstance(arr, np.memmap):
        arr = arr.base
    return arr is not None


@pytest.mark.parametrize(("name", "skel", "kw", "store"), FIXTURES, ids=IDS)
@pytest.mark.parametrize("mmap", [True, False])
def test_hand_written_stores_come_back_array_for_array(tmp_path, name, skel, kw, store, mmap):
    store = GraphStore(**{**vars(store), "attrs": {"origin": (1.0, 2.0, 0.0), "note": "x"}})
    assert tj.save_graph_store(store, tmp_path / "g") == tmp_path / "g"
    back = tj.load_graph_store(tmp_path / "g", mmap=mmap)
    assert_same_store(back, store)
    assert back.attrs["origin"] == (1.0, 2.0, 0.0)  # a tuple again, not a list
    assert mapped(back.node_pixel) is mmap
    assert_same_graph(back.to_networkx(), store.to_networkx())


def test_non_finite_attributes_are_saved_as_strict_json_and_come_back(tmp_path):
    # JSON has no NaN or infinity: a bare NaN in graph_store.json is refused by strict
    # readers (JavaScript's JSON.parse, jq, Go); the file stays JSON and loads the values.
    attrs = {
        "score": math.nan,
        "bounds": (0.0, math.inf, -math.inf),
        "params": {"sigma": [1.0, math.nan], "name": "NaN"},
        "weights": np.array([[1.0, np.nan], [np.inf, 2.0]]),
        "note": "Infinity",
    }
    store = GraphStore(**{**vars(FIXTURES[0][3]), "attrs": attrs})
    tj.save_graph_store(store, tmp_path / "g")

    def refuse(name):
        raise AssertionError(f"not strict JSON: {name}")

    json.loads((tmp_path / "g" / "graph_store.json").read_text(), parse_constant=refuse)
    back = tj.load_graph_store(tmp_path / "g").attrs
    assert math.isnan(back["score"])
    assert back["bounds"] == (0.0, math.inf, -math.inf)
    assert back["params"]["name"] == "NaN" and back["note"] == "Infinity"
    assert back["params"]["sigma"][0] == 1.0 and math.isnan(back["params"]["sigma"][1])
    assert back["weights"].dtype == np.float64
    np.testing.assert_array_equal(back["weights"], attrs["weights"])
    desc = tmp_path / "g" / "graph_store.json"
    doc = json.loads(desc.read_text())
    doc["non_finite"].append(["note", "NaN"])  # a place that holds no null
    desc.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"non_finite: expected the place of a null.*'note'"):
        tj.load_graph_store(tmp_path / "g")


@pytest.mark.parametrize("mmap", [np.True_, np.False_, np.array(False)])
def test_mmap_takes_a_numpy_bool_as_every_flag_does(tmp_path, mmap):
    """A NumPy bool (from a comparison, or a config read with NumPy) is a bool, as
    the configurations' flags take it; only numbers and other types are refused."""
    store = FIXTURES[0][3]
    tj.save_graph_store(store, tmp_path / "g")
    back = tj.load_graph_store(tmp_path / "g", mmap=mmap)
    assert mapped(back.node_pixel) is bool(mmap)
    assert_same_store(back, store)
    with pytest.raises(TypeError, match=r"^mmap: expected a bool, received int 1"):
        tj.load_graph_store(tmp_path / "g", mmap=1)


def test_a_tiled_build_leaves_its_graph_in_out_dir(tmp_path):
    m = tj.sample_map("office")
    out = tmp_path / "graph"
    res = tj.build_graph_tiled(m, config=SMALL, block_px=128, out_dir=out)
    assert_same_store(tj.load_graph_store(out), res.graph_store)
    assert_same_store(tj.load_graph_store(out, mmap=False), res.graph_store)


def test_the_paths_are_written_once_by_a_tiled_build(tmp_path, monkeypatch):
    """The build writes its two path arrays a block of edges at a time; saving the rest
    of the store writes every other array, those not."""
    names = []
    write = store_files._write_array

    def counted(path, arr):
        names.append(path.stem)
        write(path, arr)

    monkeypatch.setattr(store_files, "_write_array", counted)
    res = tj.build_graph_tiled(
        tj.sample_map("office"), config=SMALL, block_px=128, out_dir=tmp_path
    )
    assert "node_pixel" in names and not {"path_pixels", "path_world"} & set(names)
    assert_same_store(tj.load_graph_store(tmp_path), res.graph_store)


def test_a_store_mapped_from_replaced_files_saves_its_own_arrays(tmp_path):
    """A store opened from a folder keeps its arrays when the folder is saved over: saved
    there again, its arrays go back, in whatever order a view of them takes."""
    a, b = FIXTURES[1][3], FIXTURES[2][3]
    tj.save_graph_store(a, tmp_path)
    opened = tj.load_graph_store(tmp_path)
    tj.save_graph_store(b, tmp_path)
    tj.save_graph_store(opened, tmp_path)
    assert_same_store(tj.load_graph_store(tmp_path), a)
    flipped = GraphStore(**{**vars(opened), "node_pixel": opened.node_pixel[:, ::-1]})
    tj.save_graph_store(flipped, tmp_path)
    assert_same_store(tj.load_graph_store(tmp_path), flipped)


def test_a_pruned_tiled_build_leaves_the_pruned_graph(tmp_path):
    config = PipelineConfig(
        distance=SMALL.distance, graph=GraphConfig(min_spur_m=0.5), tile_px=SMALL.tile_px
    )
    res = tj.build_graph_tiled(
        tj.sample_map("office"), config=config, block_px=128, out_dir=tmp_path
    )
    back = tj.load_graph_store(tmp_path).to_networkx()
    assert back.number_of_edges() == res.graph.number_of_edges()
    assert back.graph["origin"] == res.graph.graph["origin"]
    assert sorted(back.nodes) == sorted(res.graph.nodes)


def test_a_save_that_stops_is_refused_and_old_optional_arrays_go(tmp_path, monkeypatch):
    merged = FIXTURES[-2][3]  # the merged junction cluster: member arrays
    assert merged.member_pixels is not None
    tj.save_graph_store(merged, tmp_path)
    plain = FIXTURES[0][3]
    tj.save_graph_store(plain, tmp_path)
    assert not (tmp_path / "member_pixels.npy").exists()
    assert_same_store(tj.load_graph_store(tmp_path), plain)

    written = []

    def stop_after_one(path, arr):
        if written:
            raise KeyboardInterrupt
        written.append(path)
        np.save(path, arr)

    monkeypatch.setattr(store_files, "_write_array", stop_after_one)
    with pytest.raises(KeyboardInterrupt):
        tj.save_graph_store(merged, tmp_path)
    with pytest.raises(FileNotFoundError, match=r"^folder: expected a saved graph store"):
        tj.load_graph_store(tmp_path)


def test_a_tiled_build_that_stops_leaves_no_store(tmp_path, monkeypatch):
    import topojax.graph.sparse as sparse

    out = tmp_path / "graph"
    tj.build_graph_tiled(tj.sample_map("office"), config=SMALL, block_px=128, out_dir=out)
    tj.load_graph_store(out)

    def fail(*args, **kwargs):
        raise RuntimeError("interrupted")

    monkeypatch.setattr(sparse, "_edge_values", fail)
    with pytest.raises(RuntimeError, match="interrupted"):
        tj.build_graph_tiled(tj.sample_map("intel"), config=SMALL, block_px=128, out_dir=out)
    with pytest.raises(FileNotFoundError, match="graph_store.json"):
        tj.load_graph_store(out)


def test_a_full_disk_while_the_paths_are_written_names_the_file(tmp_path, monkeypatch):
    """The paths go to their files a block of edges at a time; a full disk says which
    file it stopped (as every other file the build writes does), and leaves no part."""
    import errno

    import topojax.graph.sparse as sparse

    class Full:
        def __init__(self, f):
            self.f = f

        def seek(self, offset):
            self.f.seek(offset)

        def write(self, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        def close(self):
            self.f.close()

    monkeypatch.setattr(sparse, "open", lambda *a: Full(open(*a)), raising=False)
    out = tmp_path / "graph"
    with pytest.raises(OSError) as info:
        tj.build_graph_tiled(tj.sample_map("intel"), config=SMALL, block_px=128, out_dir=out)
    assert info.value.errno == errno.ENOSPC
    assert str(info.value) == (
        f"[Errno {errno.ENOSPC}] cannot write {out / 'path_pixels.npy'} (No space left on device)"
    )
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]


def test_files_replaced_or_damaged_are_refused(tmp_path):
    store = FIXTURES[1][3]
    tj.save_graph_store(store, tmp_path)
    desc = json.loads((tmp_path / "graph_store.json").read_text())
    np.save(tmp_path / "edge_u.npy", np.zeros(store.n_edges + 1, np.int64))
    with pytest.raises(ValueError, match=r"edge_u.npy: expected <i8 .*replaced or cut short"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "edge_u.npy").write_bytes(b"not an array")
    # numpy reads a file without the .npy magic as a pickle, and advises loading it unsafely
    with pytest.raises(ValueError) as info:
        tj.load_graph_store(tmp_path)
    assert str(info.value) == (
        f"{tmp_path / 'edge_u.npy'}: not a readable .npy array (expected a file that "
        "begins with the .npy magic string b'\\x93NUMPY', received one that begins with "
        "b'not an')"
    )
    (tmp_path / "edge_u.npy").write_bytes(b"")  # numpy raises a bare EOFError for it
    with pytest.raises(ValueError, match=r"edge_u.npy: not a readable .npy array"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "edge_u.npy").unlink()
    with pytest.raises(FileNotFoundError, match=r"the array file .*edge_u.npy is missing"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "graph_store.json").write_text(json.dumps({**desc, "arrays": {}}))
    with pytest.raises(ValueError, match=r"expected the arrays node_pixel, node_kind, .* listed"):
        tj.load_graph_store(tmp_path)
    np.save(tmp_path / "edge_u.npy", np.asarray(store.edge_u))
    other = {**desc["arrays"], "node_kind": desc["arrays"]["edge_u"]}  # another store's file
    (tmp_path / "graph_store.json").write_text(json.dumps({**desc, "arrays": other}))
    with pytest.raises(ValueError, match=r"the arrays do not make one graph store: node_kind"):
        tj.load_graph_store(tmp_path)
    outside = {**desc["arrays"], "edge_u": {**desc["arrays"]["edge_u"], "file": "../x.npy"}}
    (tmp_path / "graph_store.json").write_text(json.dumps({**desc, "arrays": outside}))
    with pytest.raises(ValueError, match=r"expected a file in the folder, received '../x.npy'"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "graph_store.json").write_text(json.dumps({**desc, "version": 99}))
    with pytest.raises(ValueError, match=r"expected version 1 of the format, received 99"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "graph_store.json").write_text('{"format": "something else"}')
    with pytest.raises(ValueError, match=r"expected a topojax.GraphStore description"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "graph_store.json").write_text("{nope")
    with pytest.raises(ValueError, match=r"not JSON"):
        tj.load_graph_store(tmp_path)
    with pytest.raises(FileNotFoundError, match=r"which does not exist"):
        tj.load_graph_store(tmp_path / "nowhere")


def test_wrong_arguments_are_named(tmp_path):
    with pytest.raises(TypeError, match=r"^store: expected a GraphStore, received MultiGraph"):
        tj.save_graph_store(tj.build_graph(tj.sample_map("office")).graph, tmp_path)
    with pytest.raises(TypeError, match=r"^folder: expected a path"):
        tj.save_graph_store(FIXTURES[0][3], 3)
    (tmp_path / "file").write_text("x")
    with pytest.raises(NotADirectoryError, match=r"^folder: "):
        tj.save_graph_store(FIXTURES[0][3], tmp_path / "file")
    with pytest.raises(TypeError, match=r"^mmap: expected a bool, received str"):
        tj.load_graph_store(tmp_path, mmap="yes")
    store = GraphStore(**{**vars(FIXTURES[0][3]), "attrs": {"bad": object()}})
    with pytest.raises(TypeError, match=r"graph attribute 'bad'"):
        tj.save_graph_store(store, tmp_path / "g")


def test_saved_arrays_get_the_permissions_of_ordinary_new_files(tmp_path):
    old = os.umask(0o022)
    try:
        out = tmp_path / "graph"
        res = tj.build_graph_tiled(tj.sample_map("office"), config=SMALL, block_px=128, out_dir=out)
        tj.save_graph_store(res.graph_store, tmp_path / "copy")
    finally:
        os.umask(old)
    for folder in (out, tmp_path / "copy"):
        modes = {f.name: stat.S_IMODE(f.stat().st_mode) for f in folder.iterdir()}
        assert "path_pixels.npy" in modes and "node_pixel.npy" in modes
        assert modes == dict.fromkeys(modes, 0o644)


# ----------------------------------------------------------------------------------------
# waypoints (route graphs), and the files of stores saved before them
# ----------------------------------------------------------------------------------------


def _without_timings(graph):
    """``graph`` as a saved store gives it back: without ``timings_s``, which is not saved."""
    graph = graph.copy()
    del graph.graph["timings_s"]
    return graph


@pytest.mark.parametrize("mmap", [True, False])
def test_a_route_graph_of_a_literal_map_is_saved_and_loaded(tmp_path, mmap):
    g = tj.route_graph(plan_map(), robot_radius_m=0.3)
    store = GraphStore.from_networkx(g)
    tj.save_graph_store(store, tmp_path / "g")
    desc = json.loads((tmp_path / "g" / "graph_store.json").read_text())
    assert desc["version"] == 1
    assert desc["arrays"]["waypoints"]["dtype"] == "<f8"
    assert desc["arrays"]["waypoint_offsets"]["shape"] == [store.n_edges + 1]
    back = tj.load_graph_store(tmp_path / "g", mmap=mmap)
    assert mapped(back.waypoints) is mmap
    assert_same_store(back, GraphStore(**{**vars(store), "attrs": _without_timings(g).graph}))
    assert_same_graph(back.to_networkx(), _without_timings(g))


def test_a_route_graph_of_a_shared_map_round_trips(tmp_path, shared_data):
    m = tj.load_map(shared_data / "maps/ros/turtlebot3_office/map_office_raw.yaml")
    g = tj.route_graph(m, robot_radius_m=0.3)
    assert g.number_of_edges() > 100
    store = GraphStore.from_networkx(g)
    assert_same_graph(store.to_networkx(), g)
    tj.save_graph_store(store, tmp_path)
    back = tj.load_graph_store(tmp_path).to_networkx()
    assert_same_graph(back, _without_timings(g))
    for (_, _, a), (_, _, b) in zip(
        g.edges(data="waypoints"), back.edges(data="waypoints"), strict=True
    ):
        assert a.tobytes() == b.tobytes()


def test_a_store_and_a_networkx_graph_passed_for_each_other_say_how_to_convert(tmp_path):
    """A loaded store handed to what takes a networkx graph (routing, scoring, saving) and
    a networkx graph handed to save_graph_store are refused naming the conversion, not
    only the type."""
    m = plan_map()
    g = tj.route_graph(m, robot_radius_m=0.3)
    with pytest.raises(TypeError, match=r"GraphStore\.from_networkx\(graph\) holds it"):
        tj.save_graph_store(g, tmp_path / "g")
    tj.save_graph_store(GraphStore.from_networkx(g), tmp_path / "g")
    store = tj.load_graph_store(tmp_path / "g")
    words = r"received GraphStore \(its to_networkx\(\) gives the networkx graph\)$"
    for call in (
        lambda: tj.RoutePlanner(store, occupancy=m),
        lambda: tj.evaluate_route_graph(store, m, 0.3),
        lambda: tj.save_graph(store, tmp_path / "g.json"),
    ):
        with pytest.raises(TypeError, match=words):
            call()
    tj.RoutePlanner(store.to_networkx(), occupancy=m)  # as the message says


def test_a_store_folder_given_as_a_graph_file_names_load_graph_store(tmp_path, capsys):
    """load_graph and topojax route given a saved store's folder say that it is one and
    what reads it; any other folder is refused as before."""
    from topojax.cli import main

    tj.save_graph_store(FIXTURES[0][3], tmp_path / "g_store")
    words = r"received the saved graph store .*g_store \(topojax\.load_graph_store\(folder\)"
    with pytest.raises(ValueError, match=r"^path: expected a graph file .*" + words):
        tj.load_graph(tmp_path / "g_store")
    argv = ["route", str(tmp_path / "g_store"), "--start", "0", "0", "--goal", "1", "1"]
    assert main(argv) == 2
    assert "graph: expected a graph file" in capsys.readouterr().err
    (tmp_path / "other").mkdir()
    with pytest.raises(ValueError, match=r"^path: expected a file, received the folder"):
        tj.load_graph(tmp_path / "other")


def test_a_store_saved_before_waypoints_still_loads_and_saves_the_same_bytes(tmp_path):
    merged = FIXTURES[-2][3]
    want = GraphStore(
        **{**vars(merged), "attrs": {**merged.attrs, "origin": (1.0, 2.0, 0.0), "note": "x"}}
    )
    for mmap in (True, False):
        back = tj.load_graph_store(SAVED_V1, mmap=mmap)
        assert back.waypoints is None and back.waypoint_offsets is None
        assert_same_store(back, want)
    tj.save_graph_store(want, tmp_path)
    saved = sorted(f.name for f in SAVED_V1.iterdir())
    assert sorted(f.name for f in tmp_path.iterdir()) == saved
    for name in saved:
        assert (tmp_path / name).read_bytes() == (SAVED_V1 / name).read_bytes(), name


def test_a_store_without_waypoints_leaves_no_waypoint_files(tmp_path):
    store = GraphStore(**with_waypoints(FIXTURES[1][3]))
    tj.save_graph_store(store, tmp_path)
    assert (tmp_path / "waypoints.npy").is_file() and (tmp_path / "waypoint_offsets.npy").is_file()
    assert_same_store(tj.load_graph_store(tmp_path), store)
    tj.save_graph_store(FIXTURES[1][3], tmp_path)
    assert not (tmp_path / "waypoints.npy").exists()
    assert not (tmp_path / "waypoint_offsets.npy").exists()
    assert "waypoints" not in (tmp_path / "graph_store.json").read_text()
    assert_same_store(tj.load_graph_store(tmp_path), FIXTURES[1][3])


def test_damaged_waypoint_files_are_refused_naming_them(tmp_path):
    store = GraphStore(**with_waypoints(FIXTURES[1][3]))
    tj.save_graph_store(store, tmp_path)
    desc = json.loads((tmp_path / "graph_store.json").read_text())
    offsets = np.asarray(store.waypoint_offsets)
    np.save(tmp_path / "waypoint_offsets.npy", offsets[::-1].copy())
    with pytest.raises(
        ValueError,
        match=r"do not make one graph store: waypoint_offsets: expected non-decreasing offsets",
    ):
        tj.load_graph_store(tmp_path)
    np.save(tmp_path / "waypoint_offsets.npy", offsets)
    np.save(tmp_path / "waypoints.npy", np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"waypoints.npy: expected <f8 \(6, 2\) .*cut short"):
        tj.load_graph_store(tmp_path)
    np.save(tmp_path / "waypoints.npy", np.zeros((6, 2), np.int64))
    with pytest.raises(ValueError, match=r"waypoints.npy: expected <f8 \(6, 2\)"):
        tj.load_graph_store(tmp_path)
    (tmp_path / "waypoints.npy").unlink()
    with pytest.raises(FileNotFoundError, match=r"the array file .*waypoints.npy is missing"):
        tj.load_graph_store(tmp_path)
    np.save(tmp_path / "waypoints.npy", np.asarray(store.waypoints))
    one = {k: v for k, v in desc["arrays"].items() if k != "waypoint_offsets"}
    (tmp_path / "graph_store.json").write_text(json.dumps({**desc, "arrays": one}))
    with pytest.raises(ValueError, match=r"waypoint_offsets, waypoints: expected both or neither"):
        tj.load_graph_store(tmp_path)
    lines = {**desc["arrays"], "waypoints": {**desc["arrays"]["waypoints"], "shape": [6, 3]}}
    np.save(tmp_path / "waypoints.npy", np.zeros((6, 3)))
    (tmp_path / "graph_store.json").write_text(json.dumps({**desc, "arrays": lines}))
    with pytest.raises(ValueError, match=r"one graph store: waypoints: expected shape \(6, 2\)"):
        tj.load_graph_store(tmp_path)


def test_a_key_given_twice_in_the_description_is_refused_naming_it(tmp_path):
    tj.save_graph_store(FIXTURES[1][3], tmp_path)
    desc = tmp_path / "graph_store.json"
    desc.write_text(desc.read_text().rstrip()[:-1] + ', "attrs": {}}')
    with pytest.raises(ValueError) as info:
        tj.load_graph_store(tmp_path)
    assert str(info.value) == (
        f"{desc}: key 'attrs' is given twice in one object; expected each key once"
    )
