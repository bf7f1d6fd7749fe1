"""The command line: start-up cost (what ``import topojax`` and the parser load),
``--version``, and output folders shared by several commands or inputs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import pytest

import topojax
from topojax.cli import build_parser, main
from topojax.cli.rooms import room_files

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("jax", "numba", "matplotlib", "scipy", "networkx", "PIL", "yaml")


def _python(code: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    return out.stdout.strip()


def _loaded_after(statement: str) -> list[str]:
    code = f"import sys; {statement}; print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    return _python(code).split()


def test_import_topojax_loads_no_heavy_module():
    assert _loaded_after("import topojax") == []


def test_building_the_parser_loads_no_heavy_module():
    assert _loaded_after("from topojax.cli import build_parser; build_parser()") == []


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (
            ["--robot-radius", "0.3", "--snapm", "1"],
            "unrecognized arguments: --snapm 1 (--snapm: did you mean --snap-m?)",
        ),
        (
            ["--plott", "--robot-radus=0.3"],
            "unrecognized arguments: --plott --robot-radus=0.3 (--plott: did you mean "
            "--plot?; --robot-radus: did you mean --robot-radius?)",
        ),
        (["--zzzzz"], "unrecognized arguments: --zzzzz"),  # nothing close: no guess
    ],
)
def test_an_unknown_option_is_the_commands_error(capsys, argv, error):
    """A mistyped option is refused under the command's usage line and name, not the
    ``topojax`` ones (which list no option of the command), with its closest option."""
    with pytest.raises(SystemExit) as stop:
        main(["route-graph", "map.png", *argv])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: topojax route-graph [-h]")
    assert err.rstrip().endswith(f"topojax route-graph: error: {error}")


def test_every_option_of_every_command_has_help(capsys):
    """``topojax COMMAND --help`` says what each option does; demo's ``--map`` also
    names its default, the map a plain ``topojax demo`` runs on."""
    import argparse

    parser = build_parser()
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    bare = [
        f"{name} {action.option_strings or action.dest}"
        for name, sub in commands.choices.items()
        for action in sub._actions
        if action.help is None
    ]
    assert bare == []
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    assert "(default: intel)" in " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize(
    "argv, option",
    [
        (["graph", "", "-o", "{tmp}"], "map"),
        (["graph", "{map}", "-o", ""], "-o/--out"),
        (["route-graph", "{map}", "-o", ""], "-o/--out"),
        (["route", "{graph}", "--start", "0", "0", "--goal", "1", "1", "-o", ""], "-o/--out"),
        (["route", "{graph}", "--start", "0", "0", "--goal", "1", "1", "--map", ""], "--map"),
        (["view", ""], "OUT_DIR"),
    ],
)
def test_an_empty_path_is_refused_naming_its_option(tmp_path, capsys, monkeypatch, argv, option):
    """An empty word where a path goes is refused before any work, naming the option:
    ``-o ""`` wrote into the current folder (``graph``, ``route-graph``) or wrote no
    route at all with status 0 (``route``), ``route --map ""`` routed without the map
    and ``view ""`` read the current folder."""
    monkeypatch.chdir(tmp_path)
    names = {"tmp": str(tmp_path), "map": "map.png", "graph": "g.json"}
    with pytest.raises(SystemExit) as stop:
        main([word.format(**names) for word in argv])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"error: argument {option}: expected a path, received an empty one ('')" in err
    assert list(tmp_path.iterdir()) == []


def test_names_load_on_first_use():
    code = (
        "import sys, topojax; from topojax import OccupancyMap, GraphConfig; "
        "print('jax' in sys.modules, OccupancyMap.__module__, GraphConfig.__module__)"
    )
    assert _python(code) == "False topojax.maps.occupancy topojax.config"
    assert set(topojax.__all__) <= set(dir(topojax))
    assert topojax.pipeline.build_graph is topojax.build_graph


def test_version():
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    version = re.search(r'^version = "([^"]+)"', pyproject, re.M).group(1)
    assert topojax.__version__ == version
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-m", "topojax.cli", "--version"],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    )
    assert out.stdout.strip() == f"topojax {version}"
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["--version"])
    assert exit_.value.code == 0


def test_parser_constants_match_their_modules():
    from topojax._constants import MODES, STRATEGIES
    from topojax.incremental import STRATEGIES as incremental_strategies
    from topojax.maps import MODES as maps_modes

    assert MODES == maps_modes
    assert STRATEGIES == incremental_strategies


# ---------------------------------------------------------------------- shared output folders


def _ros_map(folder: Path, *, wall_col: int) -> Path:
    """A small map_server map ``folder/map.yaml`` (+ ``map.pgm``): a room with one wall."""
    import numpy as np

    from topojax.maps import OccupancyMap, save_map

    occupied = np.zeros((40, 48), bool)
    occupied[[0, -1], :] = True
    occupied[:, [0, -1]] = True
    occupied[5:30, wall_col] = True
    occ = OccupancyMap(occupied=occupied, free=~occupied, unknown=np.zeros_like(occupied))
    folder.mkdir(parents=True)
    save_map(occ, folder / "map.yaml")
    return folder / "map.yaml"


def _bytes(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_outputs_of_another_input_are_not_overwritten(tmp_path, capsys):
    from topojax.cli import main

    a = _ros_map(tmp_path / "a", wall_col=20)
    b = _ros_map(tmp_path / "b", wall_col=30)
    out = tmp_path / "out"
    assert main(["graph", str(a), "-o", str(out)]) == 0
    assert main(["graph", str(a), "-o", str(out)]) == 0  # the same command again: fine
    capsys.readouterr()
    before = _bytes(out)
    assert main(["graph", str(b), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "-o/--out" in err and str(out / "map.graphml") in err and str(a.resolve()) in err
    assert "another folder" in err and str(b.resolve()) in err
    assert _bytes(out) == before, "nothing was written"
    # another command on the same input may not overwrite them either
    argv = ["batch", str(a), "-o", str(out), "--workers", "0", "--no-progress"]
    assert main(argv) == 2
    assert "'topojax graph'" in capsys.readouterr().err
    assert _bytes(out) == before
    # a folder of its own works
    assert main(["graph", str(b), "-o", str(out / "b")]) == 0


def test_graph_says_when_the_resolution_is_assumed(tmp_path, capsys):
    """A PNG states no resolution: the map line says the 0.05 m/px is assumed (the graph's
    lengths and world points rest on it) until --resolution gives one; a YAML map's own
    resolution gets no remark, one that --resolution replaces is named."""
    from topojax.datasets import sample_map_path

    png = tmp_path / "office.png"
    png.write_bytes(sample_map_path("office").read_bytes())
    assert main(["graph", str(png), "-o", str(tmp_path / "a")]) == 0
    assert "0.05 m/px, assumed: the file states none" in capsys.readouterr().out
    assert main(["graph", str(png), "-o", str(tmp_path / "b"), "--resolution", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "0.1 m/px)" in out and "assumed" not in out
    yaml = _ros_map(tmp_path / "c", wall_col=20)
    assert main(["graph", str(yaml), "-o", str(tmp_path / "c")]) == 0
    assert "assumed" not in capsys.readouterr().out
    # --resolution that replaces the file's own says so: every length and area scales
    for command in ("graph", "rooms"):
        argv = [command, str(yaml), "-o", str(tmp_path / command), "--resolution", "0.1"]
        assert main(argv) == 0
        assert "0.1 m/px, from --resolution: the file states 0.05)" in capsys.readouterr().out
    assert main(["graph", str(yaml), "-o", str(tmp_path / "d"), "--resolution", "0.05"]) == 0
    assert "0.05 m/px)" in capsys.readouterr().out  # the same as the file's: no remark


@pytest.mark.parametrize("command", [["graph"], ["graph", "--tiled"], ["rooms"], ["route-graph"]])
def test_an_assumed_resolution_is_said_once_in_the_map_line(tmp_path, capsys, command):
    """load_map warns of a resolution it assumes; a command that says so in its map line
    does not show the warning as well."""
    from room_maps import three_rooms_png

    png = three_rooms_png(tmp_path / "rooms.png")
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main([*command, str(png), "-o", str(tmp_path / "out")]) == 0
    out, err = capsys.readouterr()
    assert "states no resolution" not in err
    assert out.count("0.05 m/px, assumed: the file states none") == 1


def test_route_with_a_map_notes_a_graph_that_records_no_map_to_check(tmp_path, capsys):
    """``route --map`` checks the map against the shape, resolution and origin the graph
    records; a graph that records none of them (made by another tool, or its attributes
    dropped) is routed as before, with a note that the map could not be checked."""
    from room_maps import three_rooms_png

    png = three_rooms_png(tmp_path / "rooms.png")
    assert main(["route-graph", str(png), "--robot-radius", "0.2", "-o", str(tmp_path)]) == 0
    graph = topojax.load_graph(tmp_path / "rooms_route.json")
    for name in ("shape", "resolution_m", "origin"):
        del graph.graph[name]
    topojax.save_graph(graph, tmp_path / "bare.json")
    argv = ["--pixel", "--start", "7", "42", "--goal", "8", "92", "--map", str(png)]
    note = "note       the graph records no shape, resolution_m or origin: --map cannot be"
    for name, noted in (("rooms_route.json", False), ("bare.json", True)):
        capsys.readouterr()
        assert main(["route", str(tmp_path / name), *argv, "--resolution", "0.05"]) == 0
        out, err = capsys.readouterr()
        assert (note in out) is noted and "records no" not in err  # said once, as a note


def test_route_with_a_map_says_an_assumed_resolution_once_in_its_map_line(tmp_path, capsys):
    """``route --map`` of a PNG says the assumed resolution in a map line, in its
    options' words, as ``graph`` does, not as load_map's raw warning with its source
    line and ``resolution_m=``."""
    from room_maps import three_rooms_png

    png = three_rooms_png(tmp_path / "rooms.png")
    assert main(["route-graph", str(png), "--robot-radius", "0.2", "-o", str(tmp_path)]) == 0
    capsys.readouterr()
    graph = tmp_path / "rooms_route.json"
    argv = ["route", str(graph), "--pixel", "--start", "7", "42", "--goal", "8", "92"]
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main([*argv, "--map", str(png)]) == 0
    out, err = capsys.readouterr()
    assert "states no resolution" not in err
    note = "0.05 m/px, assumed: the file states none; --resolution sets it)"
    assert out.count(note) == 1 and out.startswith(f"map        {png}  (150 x 60 px (w x h), ")
    assert main([*argv, "--map", str(png), "--resolution", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "0.05 m/px)" in out and "assumed" not in out


def test_the_map_line_gives_the_size_as_width_by_height(tmp_path, capsys):
    """Image sizes are read width x height: the map line of ``graph``, ``rooms``,
    ``route-graph`` and ``route`` gives the 150 px wide, 60 px high map as 150 x 60 and
    says which is which (it gave rows x columns, 60 x 150)."""
    from room_maps import three_rooms_png

    png = three_rooms_png(tmp_path / "rooms.png")
    line = f"map        {png}  (150 x 60 px (w x h), 0.05 m/px)"
    res = ["--resolution", "0.05"]
    graph = tmp_path / "rooms_route.json"
    for argv in (
        ["graph", str(png), "-o", str(tmp_path / "g"), *res],
        ["rooms", str(png), "-o", str(tmp_path / "r"), "--mode", "ipa", *res],
        ["route-graph", str(png), "--robot-radius", "0.2", "-o", str(tmp_path), *res],
        ["route", str(graph), "--pixel", "--start", "7", "42", "--goal", "8", "92"]
        + ["--map", str(png), *res],
    ):
        assert main(argv) == 0
        assert line in capsys.readouterr().out.splitlines(), argv[0]


def test_a_map_yaml_without_origin_says_how_to_give_one_on_the_command_line(tmp_path, capsys):
    """The command has no --origin: the hint is the file's key, and origin= is Python's."""
    yaml = _ros_map(tmp_path / "m", wall_col=20)
    text = yaml.read_text()
    yaml.write_text("".join(line for line in text.splitlines(True) if "origin" not in line))
    assert main(["graph", str(yaml), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"map YAML {yaml} is missing the required key 'origin'" in err
    assert "add 'origin: [x, y, yaw]'" in err and "in Python give it with load_map's origin=" in err


def test_batch_outputs_are_guarded_by_their_manifests(tmp_path, capsys):
    from topojax.cli import main

    a = _ros_map(tmp_path / "a", wall_col=20)
    b = _ros_map(tmp_path / "b", wall_col=30)
    out = tmp_path / "out"
    base = ["-o", str(out), "--workers", "0", "--no-progress", "--formats", "json"]
    assert main(["batch", str(a), *base]) == 0
    assert main(["batch", str(a), *base]) == 0  # rerun: its own outputs
    capsys.readouterr()
    before = _bytes(out)
    assert main(["batch", str(b), *base]) == 2
    err = capsys.readouterr().err
    assert str(out / "map.json") in err and str(a.resolve()) in err
    assert main(["graph", str(a), "-o", str(out)]) == 2
    assert "'topojax batch'" in capsys.readouterr().err
    assert _bytes(out) == before


def test_route_and_unrecorded_files(tmp_path, capsys):
    from topojax.cli import main

    a = _ros_map(tmp_path / "a", wall_col=20)
    out = tmp_path / "out"
    (out).mkdir()
    (out / "map.json").write_text("written by hand")  # not recorded: replaced as before
    assert main(["graph", str(a), "-o", str(out)]) == 0
    assert (out / "map.json").read_text() != "written by hand"
    capsys.readouterr()
    route = ["route", str(out / "map.json"), "--start", "0.3", "0.3", "--goal", "0.3", "1.5"]
    assert main([*route, "-o", str(out / "map.geojson")]) == 2
    assert "would overwrite" in capsys.readouterr().err
    assert main([*route, "-o", str(out / "route.geojson")]) == 0
    assert main([*route, "-o", str(out / "route.geojson")]) == 0  # its own file again
    (out / "folder.geojson").mkdir()
    capsys.readouterr()
    assert main([*route, "-o", str(out / "folder.geojson")]) == 2
    assert "-o: expected a file name, received the folder" in capsys.readouterr().err
    assert not list(out.glob(".*.tmp"))


def test_an_option_naming_a_file_of_another_input_suggests_a_file_it_takes(tmp_path, capsys):
    """``route -o FILE`` and ``--mcap FILE.mcap`` name a file, not a folder: where that
    file belongs to another input, the error's example is such a file in another folder
    (it suggested ``--mcap out/a``, which the option refuses as not an .mcap file), and
    the suggestion given works."""
    import re

    from topojax.cli import main

    a = _ros_map(tmp_path / "a", wall_col=20)
    b = _ros_map(tmp_path / "b", wall_col=30)
    out = tmp_path / "out"
    assert main(["graph", str(a), "-o", str(out), "--mcap", str(out / "run.mcap")]) == 0
    route = ["route", str(out / "map.json"), "--start", "0.3", "0.3", "--goal", "0.3", "1.5"]
    for argv, option in (
        (
            ["graph", str(b), "-o", str(tmp_path / "out_b"), "--mcap", str(out / "run.mcap")],
            "--mcap",
        ),
        ([*route, "-o", str(out / "map.geojson")], "-o"),
    ):
        capsys.readouterr()
        assert main(argv) == 2
        err = capsys.readouterr().err
        hint = re.search(rf"\(e\.g\. {option} (\S+)\)", err)
        assert hint is not None, err
        suggested = Path(hint.group(1))
        assert suggested.name == ("run.mcap" if option == "--mcap" else "map.geojson")
        assert suggested.parent != out
        assert main([*argv[:-1], str(suggested)]) == 0, capsys.readouterr().err
        assert suggested.is_file()


@pytest.mark.parametrize(
    "command, name",
    [("graph", "map.json"), ("route-graph", "map_route.json"), ("rooms", "map_rooms.png")],
)
def test_a_folder_named_as_an_output_file_is_refused_before_any_is_written(
    tmp_path, capsys, command, name
):
    """A folder in ``-o`` under the name of a file the command writes was found only when
    that file's turn came: the files before it were written, and the error named no
    option and suggested a path inside that folder."""
    from topojax.cli import main

    a = _ros_map(tmp_path / "a", wall_col=20)
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    assert main([command, str(a), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"-o/--out: expected to write the file {out / name}, received a folder" in err
    assert sorted(p.name for p in out.iterdir()) == [name]


@pytest.mark.parametrize(
    "command, name",
    [("graph", "map.json"), ("route-graph", "map_route.json"), ("rooms", "map_rooms.png")],
)
def test_a_fifo_named_as_an_output_file_is_refused_before_any_is_written(
    tmp_path, capsys, command, name
):
    """A FIFO in ``-o`` under the name of a file the command writes was found only when
    that file's turn came, after the files before it were written, and the error named
    the library's ``path``, not the option."""
    from topojax.cli import main

    a = _ros_map(tmp_path / "a", wall_col=20)
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / name)
    assert main([command, str(a), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"-o/--out: expected to write the file {out / name}, received the FIFO" in err
    assert sorted(p.name for p in out.iterdir()) == [name]


def test_a_route_file_that_cannot_be_written_is_refused_before_the_route(
    tmp_path, capsys, read_only_folder
):
    """``route -o`` below a file or in a folder that takes no file is refused naming the
    option before the route is planned, not when the route is written, with the system's
    message (``[Errno 17] File exists: 'afile'``, ``Read-only file system:
    '.../.r.geojson.x.tmp'``), which names no option."""
    a = _ros_map(tmp_path / "a", wall_col=20)
    out = tmp_path / "out"
    assert main(["graph", str(a), "-o", str(out)]) == 0
    (tmp_path / "afile").write_text("")
    route = ["route", str(out / "map.json"), "--start", "0.3", "0.3", "--goal", "0.3", "1.5"]
    ro, sub = read_only_folder / "r.geojson", read_only_folder / "sub" / "r.geojson"
    for target, message in (
        (ro, f"{ro}: no file can be made in the folder {read_only_folder} (Read-only"),
        (sub, f"{sub}: its folder {sub.parent} cannot be made in {read_only_folder} (Read-"),
    ):
        capsys.readouterr()
        assert main([*route, "-o", str(target)]) == 2
        captured = capsys.readouterr()
        assert captured.err.startswith(f"topojax route: error: -o: cannot write {message}")
        assert captured.out == ""  # refused before the route
    assert main([*route, "-o", str(tmp_path / "afile" / "r.geojson")]) == 2
    captured = capsys.readouterr()
    assert "topojax route: error: -o: " in captured.err and "is a file, not a" in captured.err
    assert captured.out == ""
    assert list(read_only_folder.iterdir()) == []


@pytest.mark.parametrize(
    ("command", "first", "then", "left", "gone"),
    [
        (
            ["graph"],
            ["--plot", "--stages", "--nav2", "--rooms"],
            ["--nav2"],
            ["rooms.json", "rooms_nav2.geojson"],
            ["rooms.png", "rooms_stages.png", *room_files("rooms")],
        ),
        (["graph", "--tiled"], [], [], ["rooms.json"], []),  # after the plain graph's run
        (["rooms"], ["--plot"], [], ["rooms_rooms.geojson"], ["rooms_rooms_plot.png"]),
        (
            ["route-graph", "--robot-radius", "0.2"],
            ["--plot", "--nav2", "--evaluate"],
            ["--nav2"],
            ["rooms_route.json", "rooms_route_nav2.geojson"],
            ["rooms_route.png", "rooms_route_report.json"],
        ),
    ],
)
def test_a_rerun_removes_the_optional_files_of_its_earlier_run_it_did_not_write(
    tmp_path, capsys, command, first, then, left, gone
):
    """A command run again from the same map into the same folder leaves its own files
    only: an earlier run's picture, Nav2 graph, rooms or report that this run did not write
    would no longer match the files beside them (and ``topojax view`` would show them
    together), so they are removed, each said; a file of the same name that no run
    recorded (made by hand) stays."""
    from room_maps import three_rooms_png

    png = three_rooms_png(tmp_path / "rooms.png")
    out = tmp_path / "out"
    base = [*command[:1], str(png), *command[1:], "-o", str(out), "--resolution", "0.05"]
    if command == ["graph", "--tiled"]:  # the whole-map run writes every optional file
        first = ["--plot", "--stages", "--nav2", "--rooms"]
        gone = ["rooms.png", "rooms_stages.png", "rooms_nav2.geojson", *room_files("rooms")]
        assert main(["graph", str(png), "-o", str(out), "--resolution", "0.05", *first]) == 0
    else:
        assert main([*base, *first]) == 0
    assert all((out / name).is_file() for name in gone)
    (out / "rooms_unrecorded.png").write_text("by hand")
    capsys.readouterr()
    assert main([*base, *then]) == 0
    printed = capsys.readouterr().out
    for name in gone:
        assert not (out / name).exists()
        assert f"removed    {out / name}, written by an earlier run from this map" in printed
    assert all((out / name).is_file() for name in left)
    assert (out / "rooms_unrecorded.png").read_text() == "by hand"
    assert printed.count("removed    ") == len(gone)
    from topojax.cli._outputs import read_record

    assert not set(gone) & set(read_record(out))  # the record lists the files there


def test_output_record_rules(tmp_path):
    from topojax.cli._outputs import RECORD_NAME, check_outputs, planned, record_outputs

    files = [tmp_path / "x.json", tmp_path / "sub" / "y.json"]
    (tmp_path / "sub").mkdir()
    for f in files:
        f.write_text("1")
    record_outputs(planned(files, "in/a.yaml"), command="graph")
    assert (tmp_path / RECORD_NAME).is_file() and (tmp_path / "sub" / RECORD_NAME).is_file()
    check_outputs(planned(files, "in/a.yaml"), command="graph", option="-o/--out")
    for command, source in (("graph", "in/b.yaml"), ("replay", "in/a.yaml")):
        with pytest.raises(ValueError, match="would overwrite"):
            check_outputs(planned(files, source), command=command, option="-o/--out")
    files[0].unlink()  # a recorded file that is gone no longer counts
    check_outputs(planned(files[:1], "in/b.yaml"), command="graph", option="-o/--out")


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--route-graph", "-1"], "--route-graph: expected a finite number of metres > 0"),
        (["--max-scans", "-5"], "--max-scans: expected an int >= 1"),
        (["--graph-every", "-1"], "--graph-every: expected an int >= 0"),
        (["--resolution", "0"], "--resolution: expected a finite number of metres > 0"),
        (["--resolution", "1e-7"], "--resolution: expected 1e-06 to 10000 metres per pixel"),
        (["--max-extent-m", "-3"], "--max-extent-m: expected a finite number of metres > 0"),
        (["--max-range", "-1"], "--max-range: expected a number of metres > 0"),
        (["--max-range", "nan"], "--max-range: expected a number of metres > 0"),
    ],
)
def test_replay_names_its_options_in_errors(tmp_path, capsys, argv, message):
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    assert main(["replay", str(log), "-o", str(tmp_path / "out"), *argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_replay_option_names_leave_the_paths_in_its_errors_as_they_are(tmp_path, capsys):
    """A folder or file named like a parameter (``resume``, ``animate.gif``) stays as it
    is in the error, not ``.../--resume/mapper_state.npz`` or ``.../--animate.gif``: the
    words that name options are not rewritten inside paths."""
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = tmp_path / "resume"
    assert main(["replay", str(log), "-o", str(out), "--resume"]) != 0
    err = capsys.readouterr().err
    assert f"error: --resume: no saved state {out / 'mapper_state.npz'} " in err
    assert "replay without --resume" in err  # the parameter in prose is still the option
    (tmp_path / "file").write_text("")
    gif = tmp_path / "file" / "animate.gif"
    assert main(["replay", str(log), "-o", str(tmp_path / "o"), "--animate", str(gif)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("topojax replay: error: --animate: ") and str(gif) in err


def test_replay_refusals_name_the_options_of_the_command(tmp_path, capsys):
    """A scan refused as beyond the mapped area's bound is named in the command's words
    (``--max-extent-m``, ``--sigma-m``), never as the mapper's ``max_extent_m`` or
    ``sigma``, nor its ``tile_px`` the command has no option for: in the error of a log
    whose every scan is refused, and for a skipped scan in the printed summary."""
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = str(tmp_path / "out")
    assert main(["replay", str(log), "-o", out, "--max-extent-m", "12", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "all 40 scans were refused" in err and "beyond --max-extent-m=12 m" in err
    assert err.rstrip().endswith("give a smaller --max-range, or a larger --max-extent-m)")
    for word in ("max_extent_m", "max_range_m", "tile_px", " sigma", "make the mapper"):
        assert word not in err
    assert main(["replay", str(log), "-o", out, "--max-extent-m", "46", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert (
        "skipped 27 of 40 scans, each refused as beyond the mapper's bounds (--max-extent-m)"
        in (printed)
    )
    assert "beyond --max-extent-m=46 m" in printed and "give a larger --max-extent-m)" in printed
    assert "max_extent_m" not in printed and "make the mapper" not in printed


def test_a_replay_graph_pruned_away_is_said_so_naming_the_pruning_setting(tmp_path, capsys):
    """A replay whose map gives corridors, all of them removed by the pruning settings,
    says so (the keyword in :func:`topojax.replay`'s messages, the option in the
    command's), as ``topojax graph`` does, instead of a bare "0 vertices"."""
    from topojax.config import GraphConfig
    from topojax.playback import replay

    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    why = "removed every corridor the map gave; give a smaller value to keep some"
    summary = replay(
        log,
        out_dir=tmp_path / "api",
        progress=False,
        graph_every=20,
        graph_config=GraphConfig(min_component_m=1e6),
    )
    assert summary["vertices"] == 0
    assert f"the graph is empty: min_component_m=1e+06 {why}" in summary["messages"]
    argv = ["replay", str(log), "-o", str(tmp_path / "cli"), "--no-progress"]
    assert main([*argv, "--graph-every", "20", "--min-component-m", "1e6"]) == 0
    printed = capsys.readouterr().out
    assert f"the graph is empty: --min-component-m=1e+06 {why}" in printed
    assert "min_component_m" not in printed


def test_a_graph_emptied_by_free_only_says_its_corridors_run_through_unknown_space(
    tmp_path, capsys
):
    """``topojax graph --free-only`` on a map whose corridors all run through unknown
    space gives no graph: the note says that --free-only left them out, as the batch's
    reason does, not that no corridor was found and the thresholds need checking."""
    import cv2
    import numpy as np

    pixels = np.full((100, 120), 205, np.uint8)  # unknown, but for walls and a free corner
    pixels[[0, -1], :] = pixels[:, [0, -1]] = pixels[50, 10:110] = 0
    pixels[2:6, 2:6] = 254
    cv2.imwrite(str(tmp_path / "hall.png"), pixels)
    argv = ["graph", str(tmp_path / "hall.png"), "-o", str(tmp_path / "out"), "--free-only"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert (
        "note       the graph is empty: every corridor the map gave runs through unknown "
        "space, which --free-only leaves out" in out
    )
    assert "no corridor was found" not in out and "free_space_only" not in out


def test_replay_aligns_its_removed_lines_as_the_other_commands_do(tmp_path, capsys):
    """The files a replay removes are said in lines whose label takes the column the
    other commands' ``removed`` lines and the summary's own labels take."""
    from topojax.playback import summary_text

    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = tmp_path / "out"
    argv = ["replay", str(log), "-o", str(out), "--no-progress", "--graph-every", "20"]
    assert main([*argv, "--nav2"]) == 0
    capsys.readouterr()
    assert main(argv) == 0  # no Nav2 file this time: the earlier one goes
    removed = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("removed")]
    nav2 = out / "graph_nav2.geojson"
    assert removed == [f"removed    {nav2}, written by an earlier replay"]
    summary = {"n_scans": 1, "source": "log", "wall_s": 1.0, "map_shape": (10, 10)}
    summary.update({"n_tiles": 1, "vertices": 0, "edges": 0, "timings": {}})
    state = out / "mapper_state.npz"
    text = summary_text({**summary, "messages": [f"removed {state}: the replay has finished"]})
    assert text.splitlines()[-1] == f"removed    {state}: the replay has finished"


def test_replay_prints_its_summary_in_its_own_words_with_the_progress_bar(tmp_path, capsys):
    """With the progress bar (no ``--no-progress``) the command prints the summary once,
    in its options' words, as without it, not the library's summary in its parameters'
    words ("make the mapper with a larger max_extent_m")."""
    log = Path(__file__).parent / "data" / "intel_first40.log.gz"
    out = str(tmp_path / "out")
    assert main(["replay", str(log), "-o", out, "--max-extent-m", "46"]) == 0
    printed = capsys.readouterr().out
    assert printed.count("skipped 27 of 40 scans") == 1 and printed.count("replayed ") == 1
    assert "beyond --max-extent-m=46 m" in printed and "give a larger --max-extent-m)" in printed
    assert "max_extent_m" not in printed and "make the mapper" not in printed


def test_replay_names_its_source_argument_when_the_log_is_missing(tmp_path, capsys):
    """A missing log is reported under the command's argument ``source``, not the
    reader's parameter ``path``."""
    missing = tmp_path / "none.log"
    assert main(["replay", str(missing), "-o", str(tmp_path / "out")]) == 2
    assert f"source: no log file or bag there: {missing}" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("command", "argv", "message"),
    [
        ("graph", ["--min-spur-m", "-1"], "--min-spur-m: expected a finite number of metres"),
        ("graph", ["--sigma-m", "0"], "--sigma-m: expected a finite number of metres > 0"),
        ("graph", ["--sigma-px", "-3"], "--sigma-px: expected a finite number of pixels > 0"),
        ("demo", ["--min-clearance-m", "-1"], "--min-clearance-m: expected a finite number"),
        ("demo", ["--tile-px", "5000"], "--tile-px: expected an int in [8, 4096]"),
        ("replay", ["--min-component-m", "nan"], "--min-component-m: expected a finite"),
        # the laser's pose, as the readers check it, but under the option's name
        ("replay", ["--sensor-offset", "nan", "0", "0"], "--sensor-offset: expected a sequ"),
        ("replay", ["--sensor-offset", "0", "0", "1e10"], "--sensor-offset: expected a sequ"),
        ("replay", ["--sensor-offset", "0", "1e5", "0"], "--sensor-offset: expected a sensor's"),
        ("batch", ["--min-spur-m", "-1"], "--min-spur-m: expected a finite number of metres"),
        ("batch", ["--sigma-m", "-1"], "--sigma-m: expected a finite number of metres > 0"),
        ("batch", ["--workers", "-1"], "--workers: expected an int >= 0"),
        ("batch", ["--tiles-per-call", "0"], "--tiles-per-call: expected an int >= 1"),
        ("batch", ["--tiles-per-call", "100000"], "--tiles-per-call: expected an int from 1 to"),
        ("batch", ["--kernel-threads", "0"], "--kernel-threads: expected an int >= 1"),
        ("batch", ["--formats", "xml"], "--formats: expected names from ('graphml'"),
        ("batch", ["--connect-timeout", "nan"], "--connect-timeout: expected a finite number"),
        ("batch", ["--connect-timeout", "-1"], "--connect-timeout: expected a finite number"),
        # an unset $SCHEDULER must not run the batch on this machine instead
        ("batch", ["--scheduler", ""], "--scheduler: expected the address of a running Dask"),
        ("batch", ["--scheduler", " "], "received ' '"),
    ],
)
def test_pipeline_and_batch_options_are_named_in_errors(tmp_path, capsys, command, argv, message):
    """A value out of range is refused under the command's option name, not the
    configuration field it sets (``min_spur_m``, ``tile_px``, ``workers``)."""
    map_file = ROOT / "topojax" / "data" / "a_scan.png"
    source = {
        "graph": [str(map_file)],
        "demo": [],
        "replay": [str(Path(__file__).parent / "data" / "intel_first40.log.gz")],
        "batch": [str(map_file)],
    }[command]
    assert main([command, *source, "-o", str(tmp_path / "out"), *argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_python_m_topojax_is_the_command():
    done = subprocess.run(
        [sys.executable, "-m", "topojax", "--version"], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0 and topojax.__version__ in done.stdout + done.stderr


def test_library_modules_do_not_import_the_command_line():
    """Only the command line (``topojax.cli``, ``python -m topojax``) imports it."""
    import ast

    root = Path(topojax.__file__).parent
    offenders = []
    for path in root.rglob("*.py"):
        rel = path.relative_to(root)
        if rel.parts[0] == "cli" or rel.name == "__main__.py":
            continue
        package = ["topojax", *rel.parts[:-1]]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = package[: len(package) - node.level + 1] if node.level else []
                names = [".".join([*base, node.module or ""]).strip(".")]
                names += [f"{names[0]}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            if any(n == "topojax.cli" or n.startswith("topojax.cli.") for n in names):
                offenders.append(str(rel))
    assert offenders == []


def test_ctrl_c_ends_a_command_with_one_line_not_a_traceback(tmp_path, monkeypatch, capsys):
    """A batch stopped by Ctrl-C ends with one line, not a traceback through
    concurrent.futures and threading, and status 130: how many of its maps it finished,
    and how to do the others."""
    import topojax.batch.driver

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(topojax.batch.driver, "run_batch", interrupted)
    src = Path(topojax.__file__).parent / "data" / "office.png"
    out = tmp_path / "out"
    assert main(["batch", str(src), "-o", str(out), "--no-progress"]) == 130
    assert capsys.readouterr().err.strip() == (
        f"topojax batch: interrupted (Ctrl-C); this run finished 0 of 1 map (their files "
        f"and manifests are in {out}; summary.csv is written only by a run that ends); the "
        "same command with --resume does the others"
    )


def test_sigterm_ends_a_batch_with_the_maps_it_finished(tmp_path, monkeypatch, capsys):
    """SIGTERM (``kill``, ``timeout``) ends ``topojax batch`` as Ctrl-C does, with status
    143 and one line that counts the maps this run finished (a manifest left by an
    earlier run is not one) and says how to go on."""
    import signal

    import topojax.batch.driver

    data = Path(topojax.__file__).parent / "data"
    out = tmp_path / "out"
    out.mkdir()
    (out / "intel.manifest.json").write_text("{}")  # an earlier run's

    def stopped_after_one_map(*args, **kwargs):
        (out / "office.manifest.json").write_text("{}")
        signal.raise_signal(signal.SIGTERM)
        raise AssertionError("SIGTERM did not stop the batch")

    monkeypatch.setattr(topojax.batch.driver, "run_batch", stopped_after_one_map)
    handler = signal.getsignal(signal.SIGTERM)
    srcs = [str(data / "office.png"), str(data / "intel.png"), str(data / "a_scan.png")]
    assert main(["batch", *srcs, "-o", str(out), "--no-progress"]) == 143
    assert capsys.readouterr().err.strip() == (
        f"topojax batch: stopped by SIGTERM; this run finished 1 of 3 maps (their files "
        f"and manifests are in {out}; summary.csv is written only by a run that ends); the "
        "same command with --resume does the others"
    )
    assert signal.getsignal(signal.SIGTERM) is handler


@pytest.mark.parametrize(
    ("signame", "status", "said"),
    [("SIGTERM", 143, "stopped by SIGTERM"), ("SIGINT", 130, "interrupted (Ctrl-C)")],
)
def test_a_stop_python_keeps_dropping_still_stops_the_command(
    tmp_path, monkeypatch, capsys, signame, status, said
):
    """A SIGTERM or Ctrl-C whose KeyboardInterrupt is raised where Python drops exceptions
    (a garbage-collector callback, as JAX's are while its extension modules initialise
    for a second, or a ``__del__``) is sent again until it stops the command: none is
    lost, and none is reported as an ignored exception."""
    import signal
    import sys
    import time

    import topojax.batch.driver

    class Slow:
        def __del__(self):  # a stop is handled here, and dropped, most of the time
            time.sleep(0.002)

    class Stops:
        def __del__(self):
            signal.raise_signal(getattr(signal, signame))

    def drops_for_a_second(*args, **kwargs):
        Stops()  # deleted at once: the handler runs in its __del__
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            Slow()
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            time.sleep(0.01)
        raise AssertionError(f"{signame} did not stop the batch")

    monkeypatch.setattr(topojax.batch.driver, "run_batch", drops_for_a_second)
    hook = sys.unraisablehook
    data = Path(topojax.__file__).parent / "data"
    assert main(["batch", str(data / "office.png"), "-o", str(tmp_path), "--no-progress"]) == status
    err = capsys.readouterr().err
    assert said in err and "Exception ignored" not in err
    assert sys.unraisablehook is hook


def test_a_ctrl_c_while_jax_is_imported_ends_the_command_with_one_line(monkeypatch, capsys):
    """The command imports JAX (seconds, on a slow disk) where Ctrl-C is taken as in the
    rest of the command: one line and status 130, no traceback."""
    import topojax.cli

    def importing(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(topojax.cli, "_use_compilation_cache", importing)
    data = Path(topojax.__file__).parent / "data"
    assert main(["graph", str(data / "office.png")]) == 130
    assert capsys.readouterr().err.strip() == "topojax graph: interrupted (Ctrl-C)"


def test_a_stop_dropped_as_a_command_ends_stands_and_is_not_sent_later():
    """A dropped stop whose re-sending is still due when the block ends raises
    KeyboardInterrupt there, and no SIGTERM is sent after the handler is restored (it
    would kill the caller of ``main``)."""
    import signal
    import time

    from topojax.cli._signals import sigterm_stops

    class DropsTheStop:
        def __del__(self):
            signal.raise_signal(signal.SIGTERM)

    caught: list = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: caught.append(signum))
    try:
        stopped: list = []
        with pytest.raises(KeyboardInterrupt), sigterm_stops(stopped):
            DropsTheStop()  # the block ends within the re-sending's delay
        time.sleep(0.2)
        assert stopped == [signal.SIGTERM] and caught == []
        assert signal.getsignal(signal.SIGTERM) is not None
    finally:
        signal.signal(signal.SIGTERM, previous)


class _FiresAsCancelled:
    """A timer that has not fired when the block ends and fires as it is cancelled."""

    def __init__(self, interval, function, args=(), kwargs=None):
        self.function, self.args, self.kwargs = function, args, kwargs or {}
        self.daemon = True

    def start(self):
        pass

    def cancel(self):
        self.function(*self.args, **self.kwargs)

    def is_alive(self):
        return False

    def join(self, timeout=None):
        pass


@pytest.mark.parametrize("signame", ["SIGTERM", "SIGINT"])
def test_a_dropped_stop_sent_again_as_the_block_ends_stands(monkeypatch, signame):
    """A dropped stop whose re-sending comes just as the block ends is not lost, nor
    raised part way through the clean-up: KeyboardInterrupt once the handlers and hook
    are restored."""
    import signal
    import sys

    from topojax.cli import _signals

    class DropsTheStop:
        def __del__(self):
            signal.raise_signal(getattr(signal, signame))

    monkeypatch.setattr(_signals.threading, "Timer", _FiresAsCancelled)
    before = signal.getsignal(signal.SIGTERM), sys.unraisablehook
    stopped: list = []
    with pytest.raises(KeyboardInterrupt):
        with _signals.sigterm_stops(stopped):
            DropsTheStop()
    assert (signal.getsignal(signal.SIGTERM), sys.unraisablehook) == before


def test_a_ctrl_c_during_the_clean_up_stands_and_the_handlers_are_restored(monkeypatch):
    """A Ctrl-C that comes while the block's clean-up runs (a second one, say) lets the
    clean-up finish, then raises KeyboardInterrupt."""
    import os
    import signal
    import sys

    from topojax.cli import _signals

    class CtrlCAsCancelled(_FiresAsCancelled):
        def cancel(self):  # once: a Ctrl-C while the first timer is cancelled
            if not sent:
                sent.append(os.kill(os.getpid(), signal.SIGINT))

    sent: list = []

    class DropsTheStop:
        def __del__(self):
            signal.raise_signal(signal.SIGTERM)

    monkeypatch.setattr(_signals.threading, "Timer", CtrlCAsCancelled)
    before = signal.getsignal(signal.SIGTERM), sys.unraisablehook
    with pytest.raises(KeyboardInterrupt):
        with _signals.sigterm_stops([]):
            DropsTheStop()
    assert (signal.getsignal(signal.SIGTERM), sys.unraisablehook) == before


_SIGTERM_IN_A_WRITE = """
import os, signal, sys
import topojax._fs as fs
from topojax.cli import main

class Os:  # the file system calls of atomic writes, SIGTERM arriving in the first fsync
    def __getattr__(self, name):
        return getattr(os, name)

    @staticmethod
    def fsync(fd):
        signal.raise_signal(signal.SIGTERM)
        return os.fsync(fd)

fs.os = Os()
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("command", ["graph", "route-graph"])
def test_sigterm_in_a_write_leaves_no_temporary_file(tmp_path, command):
    """SIGTERM (``kill``, ``timeout``) of a command while it writes a file ends it as
    Ctrl-C does: no temporary copy of the file left in the output folder, one line,
    status 143."""
    out = tmp_path / "out"
    src = Path(topojax.__file__).parent / "data" / "office.png"
    done = subprocess.run(
        [sys.executable, "-c", _SIGTERM_IN_A_WRITE, command, str(src), "-o", str(out)],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=300,
    )
    assert done.returncode == 143, done.stderr
    assert done.stderr.strip() == f"topojax {command}: stopped by SIGTERM"
    assert out.is_dir() and not [p.name for p in out.iterdir() if p.suffix == ".tmp"]


@pytest.mark.parametrize("code", ["ENOSPC", "EDQUOT", "EFBIG", "EIO"])
def test_a_full_disk_ends_a_command_with_status_1_not_the_usage_status(
    tmp_path, monkeypatch, capsys, code
):
    """Status 2 says the command line was wrong; a disk that fills (or fails) while the
    command writes is no fault of its arguments: status 1, as out of memory, with the
    file named."""
    import errno

    import topojax._fs as fs

    number = getattr(errno, code)

    class Os:  # the file system calls of atomic writes, the disk full at the first fsync
        def __getattr__(self, name):
            return getattr(os, name)

        @staticmethod
        def fsync(fd):
            raise OSError(number, os.strerror(number))

    monkeypatch.setattr(fs, "os", Os())
    src = Path(topojax.__file__).parent / "data" / "office.png"
    assert main(["graph", str(src), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("topojax graph: error: cannot write ")
    assert err.rstrip().endswith(f"({os.strerror(number)})")


def test_summaries_count_one_in_the_singular():
    """The summary lines of ``graph`` and ``replay`` say "1 vertex", "1 edge", "1
    component", "1 scan" and "1 tile", and more of them in the plural."""
    import networkx as nx

    from topojax.cli._graph_out import summary_lines
    from topojax.playback import summary_text

    summary = {
        "n_scans": 1,
        "source": "log",
        "wall_s": 1.0,
        "map_shape": (10, 10),
        "n_tiles": 1,
        "vertices": 1,
        "edges": 1,
        "route_graph": {"vertices": 1, "edges": 1, "components": 1, "robot_radius_m": 0.3},
        "timings": {},
    }
    assert summary_text(summary).splitlines()[:3] == [
        "replayed   1 scan of log in 1.00 s; map 10 x 10 px (w x h) in 1 tile",
        "graph      1 vertex, 1 edge",
        "route graph 1 vertex, 1 edge, 1 component, robot radius 0.3 m",
    ]
    more = summary_text({**summary, "n_scans": 2, "n_tiles": 3, "vertices": 2, "edges": 0})
    assert more.splitlines()[:2] == [
        "replayed   2 scans of log in 1.00 s; map 10 x 10 px (w x h) in 3 tiles",
        "graph      2 vertices, 0 edges",
    ]
    graph = nx.MultiGraph()
    graph.add_node(0, kind="end", pixel=(1, 1))
    graph.add_node(1, kind="end", pixel=(1, 4))
    graph.add_edge(0, 1, length_m=0.3)
    result = SimpleNamespace(
        graph=graph,
        map=SimpleNamespace(shape=(5, 5), resolution_m=0.05),
        timings_s={"total": 0.001},
    )
    assert summary_lines("m", result)[1] == (
        "graph      2 vertices (0 junctions, 2 ends), 1 edge, 0.3 m of corridors, 1 component"
    )
    # every vertex is counted in the parentheses: rings and isolated ones where there are
    graph.add_node(2, kind="isolated", pixel=(3, 1))
    graph.add_node(3, kind="isolated", pixel=(3, 3))
    graph.add_node(4, kind="ring", pixel=(4, 4))
    graph.add_edge(4, 4, length_m=0.4)
    assert summary_lines("m", result)[1] == (
        "graph      5 vertices (0 junctions, 2 ends, 1 ring, 2 isolated), 2 edges, 0.7 m of "
        "corridors, 4 components"
    )


_MAP_OPTION_ERRORS = [
    (["--resolution", "0"], "--resolution: expected a finite number of metres > 0"),
    (["--resolution", "nan"], "--resolution: expected a finite number of metres > 0"),
    (["--resolution", "1e-7"], "--resolution: expected 1e-06 to 10000 metres per pixel"),
    (["--resolution", "2e4"], "--resolution: expected 1e-06 to 10000 metres per pixel"),
    (["--occupied-thresh", "2"], "--occupied-thresh: expected a share from 0 to 1"),
    (["--free-thresh", "-0.1"], "--free-thresh: expected a share from 0 to 1"),
    (
        ["--free-thresh", "0.7", "--occupied-thresh", "0.6"],
        "--free-thresh: expected less than --occupied-thresh (0.6), received 0.7",
    ),
]


@pytest.mark.parametrize(
    ("command", "argv", "message"),
    [(c, a, m) for c in ("graph", "rooms", "route-graph", "batch") for a, m in _MAP_OPTION_ERRORS],
)
def test_map_reading_options_are_named_in_errors(tmp_path, capsys, command, argv, message):
    """How a map file is read is refused under the command's option, not ``load_map``'s
    parameter (``resolution_m``, ``occupied_thresh``)."""
    map_file = ROOT / "topojax" / "data" / "a_scan.png"
    assert main([command, str(map_file), "-o", str(tmp_path / "out"), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert "resolution_m" not in err and "occupied_thresh" not in err


@pytest.mark.parametrize("command", ["graph", "rooms", "route-graph", "route", "batch"])
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--free-thresh", "0.7"],
            "--free-thresh: expected less than --occupied-thresh (0.65, map_server's default: map ",
        ),
        (
            ["--occupied-thresh", "0.1"],
            "--occupied-thresh: expected more than --free-thresh (0.196, map_server's default: "
            "map ",
        ),
    ],
)
def test_a_threshold_option_against_the_map_s_other_is_named_as_options(
    tmp_path, capsys, command, argv, message
):
    """A threshold option that the map's other threshold (here map_server's default, the
    map having no YAML) refuses is named as the option, the other as the option that
    would set it; a batch fails the map (status 1), the others the command (2)."""
    map_file = ROOT / "topojax" / "data" / "a_scan.png"
    given = [command, str(map_file), "-o", str(tmp_path / "out"), *argv]
    if command == "route":
        assert main(["graph", str(map_file), "-o", str(tmp_path / "g")]) == 0
        graph = tmp_path / "g" / "a_scan.json"
        given = ["route", str(graph), "--map", str(map_file), "--start", "5", "5"]
        given += ["--goal", "10", "10", "-o", str(tmp_path / "r.geojson"), *argv]
    assert main(given) == (1 if command == "batch" else 2)
    err = capsys.readouterr().err
    assert message in err and "_thresh" not in err


@pytest.mark.parametrize("command", ["graph", "route-graph", "batch", "replay"])
def test_an_output_folder_under_a_file_is_named_as_the_option(tmp_path, capsys, command):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    source = ROOT / "topojax" / "data" / "a_scan.png"
    if command == "replay":  # named out_dir, the parameter of topojax.replay
        source = Path(__file__).parent / "data" / "intel_first40.log.gz"
    assert main([command, str(source), "-o", str(a_file / "out")]) == 2
    err = capsys.readouterr().err
    assert f"--out: expected a folder to write into, but {a_file / 'out'}" in err


@pytest.mark.parametrize("command", ["graph", "replay"])
def test_an_output_folder_that_takes_no_file_is_named_without_an_error_number(
    tmp_path, capsys, read_only_folder, command
):
    """The error starts with the option (the replay's too, not with ``out_dir``, the
    parameter of topojax.replay), not with an error number as in
    ``error: [Errno 30] --out: cannot write ...``."""
    source = ROOT / "topojax" / "data" / "a_scan.png"
    if command == "replay":
        source = Path(__file__).parent / "data" / "intel_first40.log.gz"
    argv = [command, str(source), "-o", str(read_only_folder)]
    if command == "replay":
        argv += ["--max-scans", "2", "--no-progress"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"topojax {command}: error: --out: cannot write into the folder {read_only_folder} "
        "(Read-only file system)"
    )


@pytest.mark.parametrize(
    ("command", "option", "name"),
    [
        ("graph", "--mcap", "x.mcap"),
        ("route-graph", "--mcap", "x.mcap"),
        ("replay", "--mcap", "x.mcap"),
        ("replay", "--animate", "x.gif"),
    ],
)
def test_an_output_file_that_cannot_be_written_is_refused_before_the_work(
    tmp_path, capsys, read_only_folder, command, option, name
):
    """An ``--mcap`` or ``--animate`` file in a folder that takes no file is refused
    naming the option before the work, not found out when it is written: after the whole
    run (the graph files written, a replay's state kept), with the system's message
    about a temporary file."""
    source = ROOT / "topojax" / "data" / "a_scan.png"
    extra = []
    if command == "replay":
        source = Path(__file__).parent / "data" / "intel_first40.log.gz"
        extra = ["--max-scans", "3", "--no-progress"]
    target = read_only_folder / name
    out = tmp_path / "out"
    assert main([command, str(source), "-o", str(out), option, str(target), *extra]) == 2
    assert capsys.readouterr().err.startswith(
        f"topojax {command}: error: {option}: cannot write {target}: no file can be made in "
        f"the folder {read_only_folder} (Read-only file system)"
    )
    assert not out.exists()


@pytest.mark.parametrize(
    "word, value",
    [("-1e-05", -1e-05), ("-3e5", -3e5), ("-1.5E+06", -1.5e6), ("-5.", -5.0), ("-2.5", -2.5)],
)
def test_a_negative_number_in_any_notation_is_a_value_not_an_option(word, value):
    """argparse takes ``-1e-05`` (Python's own str of -0.00001), ``-3e5`` or ``-5.`` for
    an option, so ``route --start -1e-05 2`` failed with ``expected 2 arguments``; every
    form of a negative number is read as the number it writes."""
    args = build_parser().parse_args(["route", "g.json", "--start", word, "2", "--goal", "1", word])
    assert args.start == [value, 2.0] and args.goal == [1.0, value]
    args = build_parser().parse_args(["view", "out", "--window", word, word, "1", "1"])
    assert args.window[:2] == [value, value]


@pytest.mark.parametrize("word, value", [("-1e-999999999", -0.0), ("-1e500", -float("inf"))])
def test_a_negative_number_beyond_floats_is_read_as_float_reads_it(word, value):
    """An exponent too large for a float is a value, read as ``float`` reads it (then
    refused as not finite where a finite number is expected), not an unknown option that
    leaves ``--start`` with ``expected 2 arguments``."""
    args = build_parser().parse_args(["route", "g.json", "--start", word, "2", "--goal", "1", "2"])
    assert args.start == [value, 2.0]


@pytest.mark.parametrize("word", ["-inf", "-Infinity", "-nan"])
def test_a_negative_infinity_or_nan_is_refused_naming_the_option(word, tmp_path, capsys):
    """``--sigma-m -inf`` is a value that the option refuses as not finite, not a missing
    argument (``argument --sigma-m: expected one argument``)."""
    map_file = ROOT / "topojax" / "data" / "a_scan.png"
    assert main(["graph", str(map_file), "-o", str(tmp_path), "--sigma-m", word]) == 2
    err = capsys.readouterr().err
    assert err.startswith("topojax graph: error: --sigma-m: expected a finite number")


def test_a_path_that_looks_like_a_negative_number_is_taken_as_written():
    """A word is read verbatim: ``-o -1e2`` is the folder ``-1e2`` and ``-- -5.`` the map
    file ``-5.``, not ``-100`` and ``-5`` (a number's plain form)."""
    args = build_parser().parse_args(["graph", "-o", "-1e2", "--", "-5."])
    assert (args.out, args.map) == ("-1e2", "-5.")
    args = build_parser().parse_args(["batch", "-o", "out", "--", "-5.", "-1e3"])
    assert args.inputs == ["-5.", "-1e3"]
    args = build_parser().parse_args(["replay", "x.log", "--scan-topic", "-1e1"])
    assert args.scan_topic == "-1e1"


@pytest.mark.parametrize("tiled", [[], ["--tiled"]])
def test_a_graph_pruned_away_is_said_so_naming_the_pruning_option(tiled, tmp_path, capsys):
    """A map that gives corridors, all of them removed by ``--min-component-m``, gets a
    note naming that option, not one that no corridor was found and that the map's
    thresholds or pixel convention may not fit the file; built in blocks as well."""
    map_file = ROOT / "topojax" / "data" / "a_scan.png"
    argv = ["graph", str(map_file), "-o", str(tmp_path), "--min-component-m", "1e6", *tiled]
    assert main(argv) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if line.startswith("note")]
    assert len(notes) == 1
    assert "--min-component-m removed every corridor the map gave" in notes[0]
    assert "--occupied-thresh" not in notes[0]


@pytest.mark.parametrize(
    "command, option, says",
    [
        ("graph", "--tile-px", "(default 256)"),
        ("demo", "--tile-px", "(default 256)"),
        ("batch", "--tile-px", "(default 256)"),
        ("batch", "--connect-timeout", "(default 30)"),
        ("batch", "--tiles-per-call", "default 16)"),
        ("batch", "--kernel-threads", "(default: the cores this process may use, at most 8"),
        ("graph", "--occupied-thresh", "from 0 to 1 (default: the YAML's, else 0.65)"),
        ("rooms", "--free-thresh", "from 0 to 1 (default: the YAML's, else 0.196)"),
    ],
)
def test_the_help_of_an_option_says_its_default(command, option, says):
    """An option's --help says the value it takes when not given (and, for a threshold,
    what it is), as docs/command-line.md does; 'override occupied_thresh' named a YAML key."""
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    action = sub.choices[command]._option_string_actions[option]
    assert says in " ".join(action.help.split())


def test_a_map_without_a_usable_resolution_names_the_keyword_or_the_option(tmp_path, capsys):
    """A PGM whose comment gives no usable resolution and a YAML without one are refused
    with how to give it: ``resolution_m`` to ``load_map``, ``--resolution`` to the
    commands that read maps (one map or a batch), never both in one message."""
    pgm = tmp_path / "bad.pgm"
    pgm.write_bytes(b"P5\n# resolution -2 m/pix\n4 4\n255\n" + bytes([254] * 16))
    yaml = tmp_path / "nores.yaml"
    yaml.write_text("image: bad.pgm\norigin: [0, 0, 0]\n")
    for path, advice in ((pgm, "pass resolution_m to set it"), (yaml, "load_map's resolution_m=")):
        with pytest.raises(ValueError, match=re.escape(advice)) as info:
            topojax.load_map(path)
        assert "--" not in str(info.value) and "command line" not in str(info.value)
    for path, advice in ((pgm, "give --resolution to set it"), (yaml, "give it with --resolution")):
        assert main(["graph", str(path), "-o", str(tmp_path / "g")]) == 2
        err = capsys.readouterr().err
        assert advice in err and "resolution_m" not in err and "load_map" not in err
    argv = ["batch", str(yaml), "-o", str(tmp_path / "b"), "--workers", "0", "--no-progress"]
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "give it with --resolution" in err and "resolution_m" not in err


def test_the_help_of_replay_view_names_every_file_it_writes():
    """``topojax replay --view`` writes view.html and timeline.json.gz (from which
    ``topojax view`` makes the page again): its --help names both, as
    docs/command-line.md does."""
    from topojax.playback import output_names

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    text = " ".join(sub.choices["replay"]._option_string_actions["--view"].help.split())
    added = set(output_names(view=True)) - set(output_names())
    assert added == {"view.html", "timeline.json.gz"}
    assert all(name in text for name in added)


@pytest.mark.parametrize("value", ["-1", "nan", "-inf"])
def test_route_refuses_a_bad_max_snap_m_saying_none_and_inf_are_taken(value, tmp_path, capsys):
    """``--max-snap-m`` takes ``none`` or ``inf`` for no limit: its refusal of a negative
    or NaN value says so, not that a finite number was expected."""
    argv = ["route", str(tmp_path / "g.json"), "--start", "0", "0", "--goal", "1", "1"]
    assert main([*argv, "--max-snap-m", value]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "topojax route: error: --max-snap-m: expected a number of metres >= 0, or none or inf "
        "for no limit, received "
    )
