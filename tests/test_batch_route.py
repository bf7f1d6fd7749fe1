"""Route graphs in batches: the ``route`` and ``route_nav2`` formats of
:func:`topojax.build_graphs` and ``topojax batch``."""

from __future__ import annotations

import csv
import json
import warnings

import numpy as np
import pytest

import topojax as tj
from topojax.batch import build_graphs
from topojax.io import load_graph
from topojax.routegraph import RouteGraphConfig


def _walled(free: np.ndarray, name: str) -> tj.OccupancyMap:
    """A map of ``free`` (bool) with everything else occupied, 0.05 m per pixel."""
    return tj.OccupancyMap(
        occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05, source=name
    )


def _two_rooms() -> tj.OccupancyMap:
    """Two 3 x 3 m rooms joined by a 1.2 m door."""
    free = np.zeros((80, 140), bool)
    free[10:70, 10:70] = True
    free[10:70, 76:136] = True
    free[28:52, 70:76] = True
    return _walled(free, "two_rooms")


def _narrow() -> tj.OccupancyMap:
    """A corridor 0.5 m wide: a robot of radius 0.3 m fits nowhere."""
    free = np.zeros((40, 200), bool)
    free[15:25, 10:190] = True
    return _walled(free, "narrow")


def _edges_by_path(graph) -> list[bytes]:
    out = []
    for *_, p in graph.edges(data="path"):
        p = np.ascontiguousarray(p, np.int64)
        out.append(min(p.tobytes(), p[::-1].copy().tobytes()))
    return sorted(out)


def test_route_formats_write_each_maps_route_graph(tmp_path):
    maps = [_two_rooms(), _narrow()]
    out = tmp_path / "out"
    records = build_graphs(  # in worker processes
        maps, workers=2, progress=False, out_dir=out, formats="json,route,route_nav2"
    )
    rooms, narrow = records
    want = tj.route_graph(maps[0], robot_radius_m=0.3)
    assert want.number_of_edges() > 0
    assert rooms.status == "ok" and rooms.message == ""
    assert (rooms.route_vertices, rooms.route_edges, rooms.route_components) == (
        want.number_of_nodes(),
        want.number_of_edges(),
        1,
    )
    for suffix in ("_route.graphml", "_route.json", "_route.geojson", "_route_nav2.geojson"):
        assert f"two_rooms{suffix}" in rooms.outputs
    got = load_graph(out / "two_rooms_route.json")
    assert _edges_by_path(got) == _edges_by_path(want)
    nav2 = json.loads((out / "two_rooms_route_nav2.geojson").read_text())
    assert nav2["type"] == "FeatureCollection" and nav2["features"]

    # the paper's graph of the corridor has an edge, its route graph none: empty, and why
    assert narrow.edges > 0
    assert (narrow.route_vertices, narrow.route_edges, narrow.route_components) == (0, 0, 0)
    assert narrow.status == "empty"
    assert "empty route graph" in narrow.message and "radius 0.3 m" in narrow.message
    assert "0.25 m" in narrow.message  # the most clearance in the 0.5 m corridor
    assert load_graph(out / "narrow_route.json").number_of_nodes() == 0

    with open(out / "summary.csv", newline="") as fh:
        rows = {r["map"]: r for r in csv.DictReader(fh)}
    assert rows["two_rooms"]["route_edges"] == str(want.number_of_edges())
    assert rows["narrow"]["status"] == "empty"


def test_kept_graphs_hold_the_route_graph_too(tmp_path):
    """With ``keep_graphs`` a record holds the map's route graph beside the paper's graph
    (the graph written to its route files); without a route format, or without
    ``keep_graphs``, none."""
    kw = {"progress": False, "out_dir": tmp_path / "out"}
    for n in (0, 1):  # in this process and from a worker process
        (rec,) = build_graphs(
            [_two_rooms()], formats="route", keep_graphs=True, workers=n, resume=False, **kw
        )
        assert rec.graph is not None and rec.graph.graph.get("kind") != "route_graph"
        want = load_graph(tmp_path / "out" / "two_rooms_route.json")
        assert rec.route_graph.graph["kind"] == "route_graph"
        assert _edges_by_path(rec.route_graph) == _edges_by_path(want)
    (rec,) = build_graphs([_two_rooms()], formats="json", keep_graphs=True, workers=0, **kw)
    assert rec.graph is not None and rec.route_graph is None
    (rec,) = build_graphs([_two_rooms()], formats="route", workers=0, **kw)
    assert rec.graph is None and rec.route_graph is None


def test_route_files_of_a_rerun_are_byte_identical(tmp_path):
    kw = {"workers": 0, "progress": False, "formats": "route,route_nav2"}
    first = build_graphs([_two_rooms()], out_dir=tmp_path / "a", **kw)
    again = build_graphs([_two_rooms()], out_dir=tmp_path / "b", **kw)
    assert first[0].outputs == again[0].outputs and first[0].outputs
    for name in first[0].outputs:
        a, b = (tmp_path / "a" / name).read_bytes(), (tmp_path / "b" / name).read_bytes()
        if name.endswith(".manifest.json"):  # the same but for the stage times it records
            a, b = (_untimed(json.loads(x)) for x in (a, b))
        assert a == b, name


def _untimed(manifest: dict) -> dict:
    record = {k: v for k, v in manifest["record"].items() if not k.startswith("t_")}
    return {**manifest, "record": record}


def test_without_a_route_format_there_is_no_route_graph(tmp_path):
    (rec,) = build_graphs([_two_rooms()], workers=0, progress=False, out_dir=tmp_path)
    assert rec.status == "ok" and rec.edges > 0
    assert (rec.route_vertices, rec.route_edges, rec.route_components) == (None, None, None)
    assert not list(tmp_path.glob("*route*"))


def test_resume_redoes_a_map_for_another_robot(tmp_path):
    maps = [_two_rooms(), _narrow()]
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "formats": "route,route_nav2"}
    first = build_graphs(maps, **kw)
    assert [r.status for r in first] == ["ok", "empty"]
    again = build_graphs(maps, resume=True, **kw)  # the corridor has no Nav2 file: complete
    assert [r.status for r in again] == ["skipped", "skipped"]
    assert [r.route_edges for r in again] == [r.route_edges for r in first]
    small = RouteGraphConfig(robot_radius_m=0.1)
    other, narrow = build_graphs(maps, resume=True, route_config=small, **kw)
    assert other.status == narrow.status == "ok" and narrow.route_edges > 0
    want = tj.route_graph(maps[0], robot_radius_m=0.1)
    assert other.route_edges == want.number_of_edges()
    assert _edges_by_path(load_graph(tmp_path / "two_rooms_route.json")) == _edges_by_path(want)


def test_route_options_are_checked(tmp_path):
    kw = {"workers": 0, "progress": False}
    with pytest.raises(TypeError, match="route_config: expected a RouteGraphConfig"):
        build_graphs([_two_rooms()], out_dir=tmp_path, formats="route", route_config=0.3, **kw)
    with pytest.raises(ValueError, match="route_config: only used with the formats"):
        build_graphs([_two_rooms()], out_dir=tmp_path, route_config=RouteGraphConfig(), **kw)
    with pytest.raises(
        ValueError, match=r"out_dir: expected a folder \(the formats \['route'\] need one\)"
    ):
        build_graphs([_two_rooms()], formats="json,route", **kw)


def test_a_robot_that_no_longer_fits_leaves_no_nav2_file(tmp_path):
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "formats": "route,route_nav2"}
    nav2 = tmp_path / "narrow_route_nav2.geojson"
    (small,) = build_graphs([_narrow()], route_config=RouteGraphConfig(robot_radius_m=0.1), **kw)
    assert small.status == "ok" and nav2.is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the note is the record's, not a warning too
        (large,) = build_graphs([_narrow()], **kw)
    assert large.status == "empty" and "no Nav2 file" in large.message
    assert not nav2.exists()


def test_a_route_graph_without_an_edge_is_a_warning(tmp_path):
    free = np.zeros((40, 40), bool)
    free[5:21, 5:21] = True  # 0.8 m square: room for the robot at its centre only
    config = RouteGraphConfig(robot_radius_m=0.3, min_region_m2=0.0)
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "route_config": config}
    (rec,) = build_graphs([_walled(free, "square")], formats="route,route_nav2", **kw)
    assert (rec.route_vertices, rec.route_edges) == (1, 0)
    assert rec.status == "ok" and rec.message.startswith("warning: the route graph has 1 vertex")
    assert not (tmp_path / "square_route_nav2.geojson").exists()


def test_only_route_graphs_asked_for_ignore_the_papers_graph(tmp_path):
    free = np.ones((60, 60), bool)  # no obstacle: the paper's graph is empty
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path}
    (route_only,) = build_graphs([_walled(free, "hall")], formats="route", **kw)
    assert route_only.vertices == 0 and route_only.route_edges > 0
    assert route_only.status == "ok" and route_only.message == ""
    (both,) = build_graphs([_walled(free, "hall")], formats="json,route", **kw)
    assert both.status == "empty" and "no occupied pixel" in both.message


def test_summary_parquet_types_route_counts_as_integers():
    from types import SimpleNamespace

    from topojax.batch.records import ROOM_COLUMNS, SUMMARY_COLUMNS, _arrow_schema

    pa = SimpleNamespace(string=lambda: "str", int64=lambda: "int", float64=lambda: "float")
    pa.schema = dict
    types = _arrow_schema(pa, (*SUMMARY_COLUMNS, *ROOM_COLUMNS))
    counts = ("vertices", "route_vertices", "route_edges", "route_components", *ROOM_COLUMNS)
    assert {types[c] for c in counts} == {"int"}
    assert types["t_total_s"] == "float"


def _batch_of_two_rooms(tmp_path):
    """The two rooms saved as ``maps/rooms.yaml`` under ``tmp_path``; that file, the
    output folder and the arguments of ``topojax batch`` for them, formats to add."""
    yaml = tmp_path / "maps" / "rooms.yaml"
    yaml.parent.mkdir()
    tj.save_map(_two_rooms(), yaml)
    out = tmp_path / "out"
    return yaml, out, ["batch", str(yaml), "-o", str(out), "--workers", "0", "--no-progress"]


def test_batch_command_writes_route_graphs_for_the_robot_radius(tmp_path, capsys):
    from topojax.cli import main

    yaml, out, argv = _batch_of_two_rooms(tmp_path)
    assert main([*argv, "--formats", "route", "--robot-radius", "0.2"]) == 0
    want = tj.route_graph(tj.load_map(yaml), robot_radius_m=0.2)
    assert _edges_by_path(load_graph(out / "rooms_route.json")) == _edges_by_path(want)
    capsys.readouterr()
    assert main([*argv, "--formats", "route", "--robot-radius", "-1"]) == 2
    assert "--robot-radius" in capsys.readouterr().err
    assert main([*argv, "--formats", "json", "--robot-radius", "0.2"]) == 2
    assert "--robot-radius: only used with the formats" in capsys.readouterr().err


def test_batch_command_builds_route_graphs_at_the_snap_distance(tmp_path, capsys):
    """``--snap-m`` is ``topojax route-graph``'s: the route graphs of a batch cover the
    feasible space within it (the same graph as the API's), checked as that command
    checks it, and refused without a route format."""
    from topojax.cli import main

    yaml, out, argv = _batch_of_two_rooms(tmp_path)
    assert main([*argv, "--formats", "route", "--snap-m", "2"]) == 0
    config = tj.RouteGraphConfig(robot_radius_m=0.3, snap_m=2.0)
    want = tj.route_graph(tj.load_map(yaml), config=config)
    got = load_graph(out / "rooms_route.json")
    assert got.graph["snap_m"] == 2.0
    assert _edges_by_path(got) == _edges_by_path(want)
    capsys.readouterr()
    for bad, words in (("0.1", "expected 0.2 to 5 m"), ("nan", "expected a finite number")):
        assert main([*argv, "--formats", "route", "--snap-m", bad]) == 2
        assert f"--snap-m: {words}" in capsys.readouterr().err
    assert main([*argv, "--formats", "json", "--snap-m", "2"]) == 2
    assert "--snap-m: only used with the formats" in capsys.readouterr().err


def test_batch_command_names_the_option_of_a_radius_too_small_for_a_map(tmp_path, capsys):
    """A radius too small for a map's resolution fails that map; its message, printed and
    in the summary table, names the option ``--robot-radius``, not the library's
    ``robot_radius_m``."""
    from topojax.cli import main

    _, out, argv = _batch_of_two_rooms(tmp_path)
    assert main([*argv, "--formats", "route", "--robot-radius", "0.001"]) == 1
    captured = capsys.readouterr()
    assert "1 map in " in captured.out and "1 error," in captured.out
    (row,) = csv.DictReader((out / "summary.csv").read_text().splitlines())
    for message in (captured.err, row["message"]):
        assert "ValueError: --robot-radius: expected at least 1.5 pixels" in message
        assert "robot_radius_m" not in message


def test_view_of_a_route_only_batch_draws_the_route_graph_over_its_map(tmp_path, capsys):
    from view_cases import payload_of

    from topojax.cli import main

    yaml, out, argv = _batch_of_two_rooms(tmp_path)
    assert main([*argv, "--formats", "route"]) == 0
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    text = capsys.readouterr().out
    assert "rooms_route.json" in text and f"map {yaml}" in text
    data = payload_of((out / "view.html").read_text())
    assert data["rasters"][0]["name"] == "map" and data["graphs"][0]["n_edges"] > 0


def test_plot_with_a_route_format_draws_the_route_graph_too(tmp_path):
    """``--plot`` with a route format also writes the route graph's picture, the one
    ``topojax route-graph --plot`` draws, and ``resume`` expects it."""
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "plot": True}
    (rec,) = build_graphs([_two_rooms()], formats="json,route", **kw)
    assert rec.status == "ok"
    for name in ("two_rooms_graph.png", "two_rooms_route.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (again,) = build_graphs([_two_rooms()], formats="json,route", resume=True, **kw)
    assert again.status == "skipped"
    (tmp_path / "two_rooms_route.png").unlink()
    (redo,) = build_graphs([_two_rooms()], formats="json,route", resume=True, **kw)
    assert redo.status == "ok" and (tmp_path / "two_rooms_route.png").is_file()
    (plain,) = build_graphs(
        [_two_rooms()], formats="json", out_dir=tmp_path / "p", plot=True, workers=0, progress=False
    )
    assert not (tmp_path / "p" / "two_rooms_route.png").exists()


def test_batch_help_says_plot_draws_the_route_graph_too(capsys):
    """``topojax batch --help`` says what ``--plot`` writes with a route format as well."""
    from topojax.cli import main

    with pytest.raises(SystemExit):
        main(["batch", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "also write <name>_graph.png per map (and <name>_route.png with a route" in text
