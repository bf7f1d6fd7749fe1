"""``topojax graph --tiled``: the topology graph of a map read block by block from disk,
the same graph as ``topojax graph`` writes, a stopped build resumed, the options only
``--tiled`` takes, and those it refuses."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from test_tiled_resume import stop_after

import topojax as tj
from topojax.cli import main


@pytest.fixture(scope="module")
def office_yaml(tmp_path_factory):
    """The bundled office map as a map_server YAML and binary PGM (read a window at a
    time)."""
    path = tmp_path_factory.mktemp("map") / "office.yaml"
    tj.save_map(tj.sample_map("office"), path)
    return path


def _graph(folder, stem="office") -> dict:
    return json.loads((folder / f"{stem}.json").read_text())


def test_tiled_graph_files_equal_the_whole_map_build(office_yaml, tmp_path, capsys):
    assert main(["graph", str(office_yaml), "-o", str(tmp_path / "whole")]) == 0
    tiled = tmp_path / "tiled"
    argv = ["graph", str(office_yaml), "-o", str(tiled), "--tiled", "--memory-budget-mb", "14"]
    assert main([*argv, "--nav2"]) == 0
    out = capsys.readouterr().out
    assert "blocks     15, memory budget 14 MB" in out
    assert _graph(tiled) == _graph(tmp_path / "whole")
    store = tj.load_graph_store(tiled / "office_store")
    assert store.n_edges == len(_graph(tiled)["edges"])
    assert (tiled / "office_nav2.geojson").is_file()
    assert (tiled / "office.graphml").is_file() and (tiled / "office.geojson").is_file()


def test_a_stopped_tiled_build_is_resumed(office_yaml, tmp_path, monkeypatch, capsys):
    argv = ["graph", str(office_yaml), "-o", str(tmp_path), "--tiled", "--memory-budget-mb", "14"]
    stop_after(monkeypatch, 6)
    assert main(argv) == 130  # Ctrl-C, after the command's clean-up
    monkeypatch.undo()
    assert not (tmp_path / "office.json").exists()
    computed = stop_after(monkeypatch, 10**6)
    assert main([*argv, "--resume"]) == 0
    assert "blocks     15 (6 reused)" in capsys.readouterr().out
    assert len(computed) == 9
    assert main(["graph", str(office_yaml), "-o", str(tmp_path / "whole")]) == 0
    assert _graph(tmp_path) == _graph(tmp_path / "whole")


def test_a_resume_of_another_build_names_the_options(office_yaml, tmp_path, monkeypatch, capsys):
    """The kept blocks of a build with another budget (another block side) or another
    Gaussian are refused in the command's words, not the library's parameters."""
    argv = ["graph", str(office_yaml), "-o", str(tmp_path), "--tiled", "--memory-budget-mb", "14"]
    stop_after(monkeypatch, 2)
    assert main(argv) == 130
    monkeypatch.undo()
    capsys.readouterr()
    assert main([*argv[:-1], "64", "--resume"]) == 2
    err = capsys.readouterr().err
    assert "--resume: the blocks in " in err
    assert "(block side from --memory-budget-mb: 256, here 1024); run without --resume" in err
    assert "resume=" not in err and "block_px" not in err
    assert main([*argv, "--sigma-px", "6", "--resume"]) == 2
    assert "another build (--sigma-px or --sigma-m: {" in capsys.readouterr().err


def test_a_budget_above_the_memory_available_is_warned_of_once_naming_the_option(
    office_yaml, tmp_path, monkeypatch, capsys
):
    import topojax.outofcore.build as build

    monkeypatch.setattr(build, "available_memory_bytes", lambda: 10 * 2**20)
    argv = ["graph", str(office_yaml), "-o", str(tmp_path), "--tiled", "--memory-budget-mb", "14"]
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main(argv) == 0
    err = capsys.readouterr().err
    assert [line for line in err.splitlines() if "memory" in line] == [
        "topojax graph: warning: --memory-budget-mb: 14 MB (14.0 MiB) is more than the "
        "10.0 MiB of memory available; blocks sized to it may not fit (a smaller budget "
        "gives smaller blocks)"
    ]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--resume"], "--resume: only used with --tiled, which was not given"),
        (["--memory-budget-mb", "64"], "--memory-budget-mb: only used with --tiled"),
        (["--tiled", "--plot"], "--plot: not with --tiled, which never holds the whole map"),
        (["--tiled", "--rooms"], "--rooms: not with --tiled"),
        (["--tiled", "--view"], "--view: not with --tiled"),
        (["--tiled", "--stages"], "--stages: not with --tiled"),
        (["--tiled", "--mcap", "x.mcap"], "--mcap: not with --tiled"),
        (["--tiled", "--memory-budget-mb", "0"], "--memory-budget-mb: expected a finite number"),
        (["--tiled", "--memory-budget-mb", "nan"], "--memory-budget-mb: expected a finite"),
        (["--tiled", "--memory-budget-mb", "1"], "--memory-budget-mb: expected at least "),
        (["--tiled", "--min-room-m2", "3"], "--min-room-m2: only used with --rooms"),
    ],
)
def test_tiled_options_are_checked_before_any_work(office_yaml, tmp_path, capsys, extra, message):
    assert main(["graph", str(office_yaml), "-o", str(tmp_path), *extra]) == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_a_file_in_place_of_the_output_folder_is_named_as_the_option(office_yaml, tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    argv = ["graph", str(office_yaml), "-o", str(tmp_path / "afile"), "--tiled"]
    assert main(argv) == 2
    assert "--out: expected a folder to write into" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("occupied", "unknown", "says"),
    [
        (False, False, "the map has no occupied pixel as classified (0 occupied, 4096 free, 0"),
        (False, True, "the map has no occupied pixel as classified (0 occupied, 0 free, 4096"),
        (True, False, "the map has nothing but occupied pixels as classified (4096 occupied"),
    ],
    ids=["all-free", "all-unknown", "all-occupied"],
)
def test_an_empty_tiled_graph_says_what_the_map_holds(tmp_path, capsys, occupied, unknown, says):
    """As with the whole map, the note of an empty tiled graph says which class the map
    lacks, counted window by window (not "no corridor between the obstacles" on a map
    with none)."""
    codes = np.full((64, 64), 205 if unknown else (0 if occupied else 254), np.uint8)
    path = tmp_path / "m.pgm"
    path.write_bytes(b"P5\n64 64\n255\n" + codes.tobytes())
    argv = ["graph", str(path), "-o", str(tmp_path / "o"), "--tiled", "--resolution", "0.05"]
    argv += ["--memory-budget-mb", "14"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "graph      0 vertices" in out and f"note       {says}" in out


def test_an_empty_tiled_graph_counts_a_last_band_of_one_row(tmp_path, capsys):
    """The pixels of an empty graph's map are counted in bands of rows; a map whose last
    band would be one row (too few for a window) is counted all the same."""
    from topojax.outofcore.build import block_px_for_budget
    from topojax.pipeline import PipelineConfig

    side = block_px_for_budget(14, PipelineConfig())  # the bands: side * side pixels
    codes = np.full((side + 1, side), 254, np.uint8)
    path = tmp_path / "m.pgm"
    path.write_bytes(f"P5\n{side} {side + 1}\n255\n".encode() + codes.tobytes())
    argv = ["graph", str(path), "-o", str(tmp_path / "o"), "--tiled", "--resolution", "0.05"]
    assert main([*argv, "--memory-budget-mb", "14"]) == 0
    out = capsys.readouterr().out
    assert f"(0 occupied, {side * (side + 1)} free, 0 unknown)" in out


@pytest.mark.parametrize("max_pixels", [1, 40 * 3, 40 * 7, 40 * 60])
def test_the_census_of_a_tiled_map_equals_the_whole_maps(tmp_path, max_pixels):
    """Class counts and wall share read in bands of rows (each with a row more on either
    side) are those of the whole map, whatever the bands."""
    from topojax.cli.tiled import _census
    from topojax.maps.classify import wall_share
    from topojax.outofcore.build import tiled_source

    rng = np.random.default_rng(7)
    codes = rng.choice(np.array([0, 205, 254], np.uint8), size=(59, 40), p=[0.2, 0.3, 0.5])
    path = tmp_path / "m.pgm"
    path.write_bytes(b"P5\n40 59\n255\n" + codes.tobytes())
    whole = tj.load_map(path, resolution_m=0.05)
    counts, share = _census(tiled_source(path, resolution_m=0.05), max_pixels)
    assert counts == tuple(int(m.sum()) for m in (whole.occupied, whole.free, whole.unknown))
    assert share == pytest.approx(wall_share(whole.occupied, whole.free), abs=1e-15)


def test_tiled_grey_walls_are_flagged_as_the_whole_maps_are(tmp_path, capsys):
    """A map whose walls read as unknown gets the whole-map build's warning."""
    codes = np.full((80, 96), 205, np.uint8)  # grey walls and outside: unknown
    codes[10:70, 10:86] = 254
    codes[30:50, 40:50] = 0  # one obstacle, so that the map has both classes
    path = tmp_path / "m.pgm"
    path.write_bytes(b"P5\n96 80\n255\n" + codes.tobytes())
    argv = ["graph", str(path), "--resolution", "0.05"]
    assert main([*argv, "-o", str(tmp_path / "whole")]) == 0
    whole = capsys.readouterr().out
    assert main([*argv, "-o", str(tmp_path / "t"), "--tiled", "--memory-budget-mb", "14"]) == 0
    tiled = capsys.readouterr().out
    warning = "are the walls drawn in grey? check --occupied-thresh, --free-thresh or --mode"
    note = [line for line in whole.splitlines() if warning in line]
    assert note and note[0] in tiled.splitlines()


def test_a_tile_folder_with_a_dot_in_its_name_names_the_outputs_whole(
    tmp_path, capsys, monkeypatch
):
    """A tile folder is named whole (``floor.v2``, not ``floor``); a map file loses its
    suffix; ``.`` is named as the folder it is, a link to a folder by its own name."""
    from topojax.cli._outputs import output_stem

    folder = tj.save_tiled_map(tj.sample_map("office"), tmp_path / "floor.v2", tile_px=256)
    argv = ["graph", str(folder), "-o", str(tmp_path / "o"), "--tiled", "--resolution", "0.05"]
    assert main(argv) == 0
    written = {p.name for p in (tmp_path / "o").iterdir()}
    assert {"floor.v2.json", "floor.v2.graphml", "floor.v2_store"} <= written
    assert not any(name.startswith("floor.") and ".v2" not in name for name in written)
    assert output_stem(tmp_path / "floor.v2.yaml") == "floor.v2"
    monkeypatch.chdir(folder)
    assert output_stem(".") == "floor.v2"
    (tmp_path / "level_2").symlink_to(folder)  # a link is named as the user named it
    assert output_stem("../level_2") == "level_2"


def test_graph_files_too_large_for_the_memory_are_refused_with_the_store_kept(
    office_yaml, tmp_path, monkeypatch, capsys
):
    """The graph files are written from a networkx graph, about 1 kB a vertex and an
    edge, which the block budget does not bound: where the memory available cannot hold
    it, the command says so (status 1, not killed) once the store is saved, and names
    the store that holds the graph."""
    import topojax._cpus as cpus
    from topojax.graph.store import NX_BYTES_PER_ELEMENT

    out = tmp_path / "out"
    argv = ["graph", str(office_yaml), "-o", str(out), "--tiled", "--memory-budget-mb", "14"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the budget is more than the memory here
        monkeypatch.setattr(cpus, "available_memory_bytes", lambda: 10_000)
        assert main(argv) == 1
    err = capsys.readouterr().err
    store = tj.load_graph_store(out / "office_store")
    assert "Traceback" not in err
    assert (
        "--tiled: to write the graph files, the networkx graph of "
        f"{store.n_nodes:,} vertices and {store.n_edges:,} edges ("
    ) in err
    assert f"{NX_BYTES_PER_ELEMENT} bytes a vertex and an edge" in err
    assert "more than the 10,000 bytes of memory available" in err
    assert str(out / "office_store") in err and "load_graph_store" in err
    assert not (out / "office.json").exists()
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: None)
    assert main(argv) == 0
    assert (out / "office.json").is_file()
