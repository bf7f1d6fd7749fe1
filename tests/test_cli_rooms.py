"""Rooms on the command line and in batches: ``topojax rooms``, ``topojax graph --rooms``
and ``--formats rooms``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from room_maps import three_rooms_png

import topojax as tj
from topojax.batch import build_graphs
from topojax.cli import build_parser, main
from topojax.cli._options import room_config
from topojax.datasets import sample_map, sample_map_path
from topojax.io import ROOM_FILE_SUFFIXES


@pytest.fixture(scope="module")
def png(tmp_path_factory) -> Path:
    """Three rooms in a row as an IPA-style PNG (free 255, everything else 0)."""
    return three_rooms_png(tmp_path_factory.mktemp("maps") / "three.png")


def _names(stem: str) -> list[str]:
    return [f"{stem}{s}" for s in ROOM_FILE_SUFFIXES]


# ---------------------------------------------------------------------- topojax rooms


def test_rooms_command_on_a_bundled_map(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["rooms", str(sample_map_path("a_scan")), "-o", str(out), "--plot"]) == 0
    printed = capsys.readouterr().out
    for name in [*_names("a_scan"), "a_scan_rooms_plot.png"]:
        assert (out / name).is_file(), name
    seg = tj.segment_rooms(sample_map("a_scan"))  # what the library gives
    rooms, doors = tj.load_rooms(out / "a_scan_rooms.geojson")
    assert [r.area_m2 for r in rooms] == [r.area_m2 for r in seg.rooms]
    assert [d.rooms for d in doors] == [d.rooms for d in seg.doors]
    assert f"rooms      {seg.n_rooms} rooms (" in printed
    assert f", {len(seg.doors)} doors (" in printed
    assert "time (ms)  fields " in printed and "; total " in printed
    assert "wrote      " + str(out / "a_scan_rooms.geojson") in printed
    picture = cv2.imread(str(out / "a_scan_rooms.png"))
    assert picture.shape == (*seg.labels.shape, 3)


def test_rooms_command_on_an_ipa_png(png, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["rooms", str(png), "-o", str(out), "--mode", "ipa", "--resolution", "0.05"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "map        " + str(png) + "  (150 x 60 px (w x h), 0.05 m/px)" in printed
    assert "rooms      3 rooms (" in printed and ", 2 doors (0.80-0.80 m wide)" in printed
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [*_names("three"), ".topojax-outputs.json"]
    )
    rooms, doors = tj.load_rooms(out / "three_rooms.geojson")
    assert [r.id for r in rooms] == [1, 2, 3] and [d.rooms for d in doors] == [(1, 2), (2, 3)]
    g = tj.load_graph(out / "three_rooms.graphml")
    assert sorted(g.edges()) == [(1, 2), (2, 3)]
    record = json.loads((out / ".topojax-outputs.json").read_text())["files"]
    assert record["three_rooms.json"]["command"] == "rooms"
    assert main(argv) == 0, "running it again updates its own files"


def test_rooms_command_says_when_the_resolution_is_assumed(png, tmp_path, capsys):
    """Areas and door widths are in metres: a PNG states no resolution, so the map line
    says the 0.05 m/px is assumed, as ``graph`` does; given, it is not."""
    base = ["rooms", str(png), "--mode", "ipa"]
    assert main([*base, "-o", str(tmp_path / "a")]) == 0
    assert (
        "(150 x 60 px (w x h), 0.05 m/px, assumed: the file states none" in capsys.readouterr().out
    )
    assert main([*base, "-o", str(tmp_path / "b"), "--resolution", "0.05"]) == 0
    assert "assumed" not in capsys.readouterr().out


def test_rooms_command_says_its_time_includes_the_first_call(png, tmp_path, capsys):
    """The command segments once, in a fresh process: its stage times include loading the
    compiled kernels (hundreds of ms on a tiny map), and the time line says so."""
    assert main(["rooms", str(png), "--mode", "ipa", "-o", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert re.search(
        r"^time \(ms\)  fields .*; total \d+\.\d \(the process's first call: it includes "
        r"loading or compiling the kernels\)$",
        printed,
        re.M,
    )


def test_summary_lines_count_one_room_and_one_door_in_the_singular():
    from types import SimpleNamespace

    from topojax.cli.rooms import room_lines
    from topojax.playback import summary_text

    seg = SimpleNamespace(
        rooms=[SimpleNamespace(area_m2=7.0)], doors=[SimpleNamespace(width_m=0.8)], timings_s={}
    )
    line = room_lines(seg, None, seconds=0.01)[0]
    assert line == "rooms      1 room (7.0 m2), 1 door (0.80 m wide)"
    seg = SimpleNamespace(rooms=seg.rooms * 2, doors=seg.doors * 2, timings_s={})
    assert room_lines(seg, None, seconds=0.01)[0].startswith(
        "rooms      2 rooms (14.0 m2 in all, 7.0-7.0 m2 each), 2 doors (0.80-0.80 m wide)"
    )
    summary = {
        "n_scans": 3,
        "source": "log",
        "wall_s": 1.0,
        "map_shape": (10, 10),
        "n_tiles": 1,
        "vertices": 4,
        "edges": 3,
        "rooms": 1,
        "timings": {},
    }
    assert "\nrooms      1 room\n" in summary_text(summary)
    assert "\nrooms      2 rooms\n" in summary_text({**summary, "rooms": 2})
    with_doors = summary_text({**summary, "rooms": 2, "doors": 1})
    assert "\nrooms      2 rooms, 1 door\n" in with_doors, "as the rooms command counts them"


def test_room_options_reach_the_segmentation(png, tmp_path, capsys):
    base = ["rooms", str(png), "--mode", "ipa"]
    assert main([*base, "-o", str(tmp_path / "a"), "--max-door-width-m", "0.6"]) == 0
    printed = capsys.readouterr().out
    assert "rooms      1 room (" in printed and ", 0 doors" in printed, "0.8 m gaps are no doors"
    assert main([*base, "-o", str(tmp_path / "b"), "--min-room-m2", "10"]) == 0
    assert "rooms      1 room (" in capsys.readouterr().out, "7 m2 rooms merge"
    assert len(tj.load_rooms(tmp_path / "b" / "three_rooms.geojson")[0]) == 1


def test_room_option_defaults_are_room_configs():
    args = build_parser().parse_args(["rooms", "map.png"])
    assert room_config(args) == tj.RoomConfig()
    args = build_parser().parse_args(["graph", "map.png"])
    assert not args.rooms and room_config(args) == tj.RoomConfig()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            ["--max-door-width-m", "0.1"],
            "--min-door-width-m, --max-door-width-m: expected --min-door-width-m <= "
            "--max-door-width-m, received 0.5 and 0.1 m",
        ),
        (  # the default maximum is the one below: both are named
            ["--min-door-width-m", "3"],
            "--min-door-width-m, --max-door-width-m: expected --min-door-width-m <= "
            "--max-door-width-m, received 3.0 and 2.2 m",
        ),
        (["--min-room-m2", "-1"], "--min-room-m2: expected a finite number"),
        (["--door-ratio", "0"], "--door-ratio: expected"),
    ],
)
def test_room_option_errors_name_the_option(png, tmp_path, capsys, options, message):
    out = tmp_path / "out"
    assert main(["rooms", str(png), "-o", str(out), *options]) == 2
    assert capsys.readouterr().err.startswith(f"topojax rooms: error: {message}")
    assert main(["graph", str(png), "-o", str(out), "--rooms", *options]) == 2
    assert capsys.readouterr().err.startswith(f"topojax graph: error: {message}")
    assert not out.exists(), "nothing written"


@pytest.mark.parametrize("command", ["graph", "replay"])
def test_room_options_without_rooms_are_refused(png, tmp_path, capsys, command):
    # refused, not ignored (no rooms, not a word, a bad value unchecked), as
    # --nav2-tolerance-m without --nav2 is refused
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    source = str(png) if command == "graph" else str(log)
    out = tmp_path / "out"
    options = ["--min-door-width-m", "1", "--door-ratio", "-3"]
    assert main([command, source, "-o", str(out), *options]) == 2
    assert capsys.readouterr().err.startswith(
        f"topojax {command}: error: --min-door-width-m, --door-ratio: only used with "
        "--rooms, which was not given"
    )
    assert not out.exists()


def test_rooms_command_bad_inputs(tmp_path, capsys):
    out = tmp_path / "out"
    missing = tmp_path / "nothing.png"
    assert main(["rooms", str(missing), "-o", str(out)]) == 2
    assert capsys.readouterr().err == f"topojax rooms: error: map file not found: {missing}\n"
    notes = tmp_path / "notes.txt"
    notes.write_text("not a map")
    assert main(["rooms", str(notes), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("topojax rooms: error: ") and "unsupported suffix '.txt'" in err
    assert not out.exists()


def test_a_map_without_free_space_says_why(tmp_path, capsys):
    dark = tmp_path / "dark.png"
    cv2.imwrite(str(dark), np.full((30, 40), 200, np.uint8))  # nothing >= 250: ipa, no free
    assert main(["rooms", str(dark), "-o", str(tmp_path / "out"), "--mode", "ipa"]) == 0
    printed = capsys.readouterr().out
    assert "rooms      0 rooms, 0 doors" in printed
    assert re.search(r"^time \(ms\)  total \d+\.\d$", printed, re.M), "not 'time (ms)  ; total'"
    assert "note       no room found: the map has 0 free pixels as classified" in printed
    assert "inaccessible) or --min-isolated-room-m2\n" in printed
    assert tj.load_rooms(tmp_path / "out" / "dark_rooms.geojson") == ((), ())


def test_rooms_files_of_another_command_are_not_overwritten(png, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["rooms", str(png), "-o", str(out), "--mode", "ipa"]) == 0
    capsys.readouterr()
    before = (out / "three_rooms.geojson").read_bytes()
    assert main(["graph", str(png), "-o", str(out), "--mode", "ipa", "--rooms"]) == 2
    err = capsys.readouterr().err
    assert "three_rooms" in err and "'topojax rooms'" in err and "another folder" in err
    assert (out / "three_rooms.geojson").read_bytes() == before
    assert not (out / "three.json").exists()


# ---------------------------------------------------------------------- topojax graph --rooms


def test_graph_with_rooms_carries_them_to_the_graph_files_and_nav2(png, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["graph", str(png), "-o", str(out), "--mode", "ipa", "--rooms", "--nav2", "--plot"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "rooms      3 rooms (" in printed and "rooms (ms) fields " in printed
    for name in ["three.json", "three.png", "three_nav2.geojson", *_names("three")]:
        assert (out / name).is_file(), name
    g = tj.load_graph(out / "three.json")
    assert g.graph["rooms"] == 3
    assert {d["room"] for _, d in g.nodes(data=True)} == {1, 2, 3}
    crossing = [d for *_, d in g.edges(data=True) if d["doors"]]
    assert sorted(d["doors"] for d in crossing) == [[1], [2]], "one corridor through each door"
    assert all(len(d["rooms"]) == 2 for d in crossing)
    nav2 = json.loads((out / "three_nav2.geojson").read_text())
    nodes = [f["properties"] for f in nav2["features"] if f["geometry"]["type"] == "Point"]
    assert nodes and {n["metadata"]["room"] for n in nodes} == {1, 2, 3}
    for n in nodes:  # each Nav2 node is in the room of its topology vertex
        assert n["metadata"]["room"] == g.nodes[n["metadata"]["vertex"]]["room"]


def test_graph_without_rooms_writes_none(png, tmp_path):
    out = tmp_path / "out"
    assert main(["graph", str(png), "-o", str(out), "--mode", "ipa"]) == 0
    assert not any("_rooms" in p.name for p in out.iterdir())
    g = tj.load_graph(out / "three.json")
    assert all("room" not in d for _, d in g.nodes(data=True))


# ---------------------------------------------------------------------- batch


def test_batch_formats_rooms(png, tmp_path, capsys):
    out = tmp_path / "out"
    base = ["batch", str(png), "-o", str(out), "--workers", "0", "--no-progress", "--mode", "ipa"]
    assert main([*base, "--formats", "json,rooms"]) == 0
    manifest = json.loads((out / "three.manifest.json").read_text())
    assert sorted(manifest["files"]) == sorted(["three.json", *_names("three")])
    assert manifest["request"]["rooms"]["min_room_m2"] == tj.RoomConfig().min_room_m2
    rooms, doors = tj.load_rooms(out / "three_rooms.geojson")
    assert len(rooms) == 3 and len(doors) == 2
    g = tj.load_graph(out / "three.json")
    assert {d["room"] for _, d in g.nodes(data=True)} == {1, 2, 3}, "the graph carries rooms"
    capsys.readouterr()
    assert main([*base, "--formats", "json,rooms", "--resume"]) == 0
    assert "1 skipped" in capsys.readouterr().out
    # a room file of the batch is guarded by its manifest
    assert main(["rooms", str(png), "-o", str(out), "--mode", "ipa"]) == 2
    assert "'topojax batch'" in capsys.readouterr().err


def test_build_graphs_rooms_only_and_names(png, tmp_path):
    from topojax.batch.inputs import planned_outputs

    records = build_graphs(
        [png], out_dir=tmp_path, formats="rooms", workers=0, progress=False, map_mode="ipa"
    )
    (rec,) = records
    assert rec.status == "ok" and rec.outputs == (*_names("three"), "three.manifest.json")
    # names leave room for every map's room files, whatever the formats
    planned = planned_outputs(["maps/m.png", "maps/m_rooms.png"], formats="json", plot=False)
    assert sorted(planned) == [
        "m.json",
        "m.manifest.json",
        "m_rooms_2.json",
        "m_rooms_2.manifest.json",
    ]
    with pytest.raises(
        ValueError, match=r"formats: expected names from \(.*'rooms', 'route', 'route_nav2'\)"
    ):
        build_graphs([png], formats="rooms,svg", workers=0, progress=False)


def test_replay_rooms_writes_room_files_and_checks_room_options_first(tmp_path, capsys):
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = tmp_path / "rep"
    assert main(["replay", str(log), "-o", str(out), "--rooms", "--door-ratio", "0"]) == 2
    assert "--door-ratio" in capsys.readouterr().err
    assert not out.exists()  # refused before the replay
    code = main(
        ["replay", str(log), "-o", str(out), "--rooms", "--no-progress", "--graph-every", "20"]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "rooms" in text
    for name in ("map_rooms.geojson", "map_rooms.png", "map_rooms.graphml", "map_rooms.json"):
        assert (out / name).is_file()


def test_replay_rooms_plot_draws_the_final_rooms_on_graph_png(tmp_path, monkeypatch, capsys):
    """As ``topojax graph --rooms --plot`` draws its rooms on its picture, once, at the
    end."""
    import topojax.plotting

    drawn = []
    real = topojax.plotting.result_png

    def spy(result, **kw):
        drawn.append(kw)
        return real(result, **kw)

    monkeypatch.setattr(topojax.plotting, "result_png", spy)
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = tmp_path / "rep"
    argv = ["replay", str(log), "-o", str(out), "--rooms", "--plot", "--no-progress"]
    assert main([*argv, "--graph-every", "20"]) == 0
    capsys.readouterr()
    (kw,) = drawn
    seg = kw["rooms"]
    rooms, doors = tj.load_rooms(out / "map_rooms.geojson")
    assert isinstance(seg, tj.RoomSegmentation) and seg.n_rooms == len(rooms) > 0
    assert len(seg.doors) == len(doors)
    assert kw["title"].endswith(f", {seg.n_rooms} room" + "s" * (seg.n_rooms != 1))
    assert (out / "graph.png").read_bytes().startswith(b"\x89PNG")
