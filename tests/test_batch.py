"""Tests for topojax.batch: batched kernels, worker processes, outputs, faults, resume, Dask.

The reference for every graph is :func:`topojax.build_graph` run on the map alone; graphs
are compared exactly (node ids and order, every attribute, numpy arrays bit for bit).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from topojax.batch import (
    SUMMARY_COLUMNS,
    MapRecord,
    build_graphs,
    expand_braces,
    expand_map_inputs,
)
from topojax.config import GraphConfig, PipelineConfig, SkeletonConfig
from topojax.graph import graph_summary
from topojax.io import load_graph
from topojax.maps import OccupancyMap, load_map
from topojax.pipeline import build_graph, trace_counts

PAPER = Path(__file__).resolve().parents[1] / "topojax" / "data"
PAPER_MAPS = [PAPER / f"{name}.png" for name in ("intel", "office", "a_scan")]
SMALL_SHARED = (
    "maps/simulated/nav2/depot.yaml",
    "maps/simulated/nav2/tb3_sandbox.yaml",
    "maps/ros/turtlebot3_office/map_office_raw.yaml",
)


# ---------------------------------------------------------------------- helpers


def _values_equal(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


def assert_attrs_equal(a: dict, b: dict, where: str) -> None:
    assert a.keys() == b.keys(), f"{where}: attribute names differ"
    for k in a:
        assert _values_equal(a[k], b[k]), f"{where}: attribute {k!r} differs"


def assert_graphs_equal(got: nx.MultiGraph, want: nx.MultiGraph, where: str = "") -> None:
    assert isinstance(got, nx.MultiGraph)
    assert_attrs_equal(got.graph, want.graph, f"{where} graph")
    assert list(got.nodes) == list(want.nodes), f"{where}: node ids/order differ"
    for n in want.nodes:
        assert_attrs_equal(got.nodes[n], want.nodes[n], f"{where} node {n}")
    ge = list(got.edges(keys=True, data=True))
    we = list(want.edges(keys=True, data=True))
    assert [e[:3] for e in ge] == [e[:3] for e in we], f"{where}: edges differ"
    for (u, v, k, da), (_, _, _, db) in zip(ge, we, strict=True):
        assert_attrs_equal(da, db, f"{where} edge {(u, v, k)}")


def _small_shared(shared_data: Path) -> list[Path]:
    paths = [shared_data / rel for rel in SMALL_SHARED]
    missing = [p for p in paths if not p.is_file()]
    if missing:
        pytest.skip(f"shared maps missing: {missing}")
    return paths


def _synthetic(shape, seed, *, yaw=0.0, source=None) -> OccupancyMap:
    """Rooms with random walls: a few rectangles of obstacles inside a frame."""
    rng = np.random.default_rng(seed)
    occ = np.zeros(shape, bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    for _ in range(6):
        r, c = rng.integers(0, shape[0]), rng.integers(0, shape[1])
        if rng.random() < 0.5:
            occ[r, max(0, c - 40) : c + 40] = True
        else:
            occ[max(0, r - 40) : r + 40, c] = True
    free = ~occ
    return OccupancyMap(
        occupied=occ,
        free=free,
        unknown=np.zeros(shape, bool),
        resolution_m=0.07,
        origin=(3.0, -1.5, yaw),
        source=source,
    )


def _file_bytes(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


# ---------------------------------------------------------------------- identity


def test_identity_with_build_graph_in_worker_processes(shared_data):
    """Worker processes (default executor) give exactly build_graph's graphs, map by map."""
    empty = OccupancyMap(
        occupied=np.zeros((50, 60), bool),
        free=np.ones((50, 60), bool),
        unknown=np.zeros((50, 60), bool),
    )
    rotated = _synthetic((300, 420), 1, yaw=0.6, source="synthetic/rotated")
    inputs = [*PAPER_MAPS, *_small_shared(shared_data), rotated, empty]
    records = build_graphs(inputs, workers=2, progress=False)
    want_status = ["ok"] * (len(inputs) - 1) + ["empty"]  # no obstacle: no corridor
    assert [r.status for r in records] == want_status, [r.message for r in records]
    assert "no occupied pixel" in records[-1].message
    for inp, rec in zip(inputs, records, strict=True):
        occ = inp if isinstance(inp, OccupancyMap) else load_map(inp)
        want = build_graph(occ).graph
        assert_graphs_equal(rec.graph, want, where=rec.map)
        s = graph_summary(want)
        assert (rec.vertices, rec.edges, rec.components) == (
            s["n_vertices"],
            s["n_edges"],
            s["n_components"],
        )
        assert rec.total_length_m == s["total_length_m"]
        assert (rec.height, rec.width) == occ.shape
        assert rec.resolution_m == occ.resolution_m
    assert records[-1].vertices == 0  # no obstacle: empty graph, like build_graph
    assert records[0].vertices > 100  # the intel map has a real graph
    # names: relative to the common folder of the files, objects by source or position
    names = [r.map for r in records]
    assert len(set(names)) == len(names)
    assert names[-1] == "map_0007"
    assert names[0].endswith("topojax/data/intel")


def test_zhang_thinning_and_options_pass_through():
    config = PipelineConfig(skeleton=SkeletonConfig(thinning="zhang", remove_t=False))
    occ = load_map(PAPER_MAPS[1])
    (rec,) = build_graphs([occ], workers=0, config=config, progress=False)
    assert_graphs_equal(rec.graph, build_graph(occ, config=config).graph, "office/zhang")
    assert rec.graph.graph["thinning"] == "zhang"


def test_graph_keeping_options_pass_through(shared_data):
    """free_space_only and pruning run in the workers exactly as in build_graph."""
    from topojax.config import GraphConfig

    config = PipelineConfig(
        graph=GraphConfig(free_space_only=True, min_spur_m=0.4, min_component_m=1.5)
    )
    occ = load_map(shared_data / "maps/ros/turtlebot3_office/map_office_raw.yaml")
    assert occ.unknown.any()
    (rec,) = build_graphs([occ], workers=1, config=config, progress=False)
    want = build_graph(occ, config=config).graph
    assert_graphs_equal(rec.graph, want, "turtlebot3_office/pruned")
    assert want.number_of_nodes() < build_graph(occ).graph.number_of_nodes()


def test_mixed_sizes_share_one_compiled_kernel():
    """Maps of very different sizes in one batch: one trace for the bucket, none after."""
    maps = [
        _synthetic((40, 300), 2),
        _synthetic((257, 513), 3),
        _synthetic((600, 100), 4),
        _synthetic((130, 130), 5),
    ]
    # a bucket (tile_px, tiles_per_call) no other test uses, so the first batch must trace it
    config = PipelineConfig(tile_px=200, tiles_per_call=5)
    kw = {"workers": 0, "config": config, "tiles_per_call": 5, "progress": False}
    before = trace_counts().get("forward_tiles", 0)
    records = build_graphs(maps, batch_tiles=7, **kw)
    after_first = trace_counts().get("forward_tiles", 0)
    assert after_first - before == 1
    again = build_graphs(maps[::-1], **kw)
    assert trace_counts().get("forward_tiles", 0) == after_first
    # results do not depend on the tiling: compare with build_graph's default 256-px tiles
    for m, rec in zip(maps, records, strict=True):
        assert_graphs_equal(rec.graph, build_graph(m).graph, f"synthetic {m.shape}")
    for m, rec in zip(maps[::-1], again, strict=True):
        assert_graphs_equal(rec.graph, build_graph(m).graph, f"reversed {m.shape}")


# ---------------------------------------------------------------------- outputs and faults


#: The note of a map read from a file that states no resolution (a PNG).
ASSUMED = (
    "0.05 m/px assumed: the file states none; "
    "a map given as load_map(path, resolution_m=...) sets it"
)


def _read_summary(out: Path) -> list[dict[str, str]]:
    with open(out / "summary.csv", newline="") as fh:
        reader = csv.DictReader(fh)
        assert tuple(reader.fieldnames or ()) == SUMMARY_COLUMNS
        return list(reader)


@pytest.mark.parametrize("workers", [0, 2])  # files read by threads here / by the workers
def test_corrupt_and_missing_maps_become_error_rows(tmp_path, shared_data, workers):
    bad_png = tmp_path / "in" / "corrupt.png"
    bad_png.parent.mkdir()
    bad_png.write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(200))
    bad_yaml = tmp_path / "in" / "noimage.yaml"
    bad_yaml.write_text("image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    missing = tmp_path / "in" / "missing.pgm"
    good = [PAPER_MAPS[2], _small_shared(shared_data)[0]]
    out = tmp_path / "out"
    records = build_graphs(
        [good[0], bad_png, bad_yaml, missing, good[1]], out_dir=out, workers=workers
    )
    status = [r.status for r in records]
    assert status == ["ok", "error", "error", "error", "ok"]
    assert "corrupt.png" in records[1].message
    assert "nowhere.pgm" in records[2].message and "FileNotFoundError" in records[2].message
    assert "missing.pgm" in records[3].message
    for rec in records[1:4]:
        assert rec.height is None and rec.vertices is None
        assert not list(out.rglob(f"{rec.map}.*")), "no outputs for a failed map"
    rows = _read_summary(out)
    assert [r["status"] for r in rows] == status
    assert [r["map"] for r in rows] == [r.map for r in records]
    for rec, row in zip(records, rows, strict=True):
        assert row["path"] == str(rec.path)
        if rec.status == "ok":
            assert int(row["vertices"]) == rec.vertices > 0
            assert int(row["edges"]) == rec.edges
            assert float(row["total_length_m"]) == rec.total_length_m
            assert int(row["height"]) == rec.height and float(row["resolution_m"]) > 0
            assert float(row["t_total_s"]) >= float(row["t_distance_s"]) > 0
            # a PNG states no resolution: the record says 0.05 m/px was assumed
            png = Path(rec.path).suffix == ".png"
            assert row["message"] == (ASSUMED if png else "")
            # the graph files load back equal to build_graph's graph
            want = build_graph(load_map(rec.path)).graph
            for suffix in (".graphml", ".json", ".geojson"):
                got = load_graph(out / f"{rec.map}{suffix}")
                assert got.number_of_nodes() == rec.vertices
                assert got.number_of_edges() == rec.edges
            assert_graphs_equal(load_graph(out / f"{rec.map}.json"), want, rec.map)
        else:
            assert row["vertices"] == "" and row["message"] == rec.message


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("workers", [0, 2])
def test_a_named_pipe_among_the_inputs_is_an_error_row_not_a_hang(tmp_path, workers):
    """Reading a FIFO waits for a writer that never comes: a pipe named like a map (as
    a folder search finds it) becomes an error row, and the other maps are built."""
    import threading

    src = tmp_path / "in"
    src.mkdir()
    (src / "good.png").write_bytes(PAPER_MAPS[2].read_bytes())
    pipes = [src / "pipe.pgm", src / "pipe.yaml"]
    for pipe in pipes:
        os.mkfifo(pipe)
    paths = expand_map_inputs([src])
    assert sorted(p.name for p in paths) == ["good.png", "pipe.pgm", "pipe.yaml"]
    result: list = []
    run = threading.Thread(
        target=lambda: result.extend(
            build_graphs(paths, out_dir=tmp_path / "out", workers=workers, progress=False)
        ),
        daemon=True,
    )
    run.start()
    run.join(timeout=120)
    hung = run.is_alive()
    for pipe in pipes:  # release a reader blocked on a pipe (a batch that hung)
        try:
            os.close(os.open(pipe, os.O_WRONLY | os.O_NONBLOCK))
        except OSError:
            pass
    assert not hung, "the batch waited on a named pipe"
    by_name = {r.map: r for r in result}
    assert by_name["good"].status == "ok"
    for name in ("pipe_pgm", "pipe_yaml"):
        assert by_name[name].status == "error"
        assert "not a regular file" in by_name[name].message


def test_kernel_failure_of_one_map_spares_its_group(monkeypatch):
    """A kernel call that fails for one map: that map errors, its group-mates finish."""
    import topojax.fields

    real = topojax.fields.ridge_fields_many
    bad_shape = (131, 257)

    calls = []

    def flaky(obstacle_maps, **kwargs):
        calls.append(len(obstacle_maps))
        if any(np.shape(m) == bad_shape for m in obstacle_maps):
            raise MemoryError("kernel out of memory (injected)")
        return real(obstacle_maps, **kwargs)

    monkeypatch.setattr(topojax.fields, "ridge_fields_many", flaky)
    maps = [_synthetic((90, 200), 7), _synthetic(bad_shape, 8), _synthetic((200, 90), 9)]
    before = build_graphs(maps[:1], workers=0, progress=False)  # compile outside the group
    assert before[0].status == "ok"
    calls.clear()
    records = build_graphs(maps, workers=0, progress=False, batch_tiles=1000)
    assert calls == [3, 1, 1, 1]  # the group of three, then each map alone
    assert [r.status for r in records] == ["ok", "error", "ok"]
    assert records[1].message == "MemoryError: kernel out of memory (injected)"
    assert records[1].height == bad_shape[0] and records[1].vertices is None
    for i in (0, 2):
        assert_graphs_equal(records[i].graph, build_graph(maps[i]).graph, f"map {i}")


def test_a_manifest_record_missing_a_value_or_of_another_type_is_redone(tmp_path):
    """A manifest record with a value of another type or a missing one is redone, not
    copied into the resumed row as it stands: there a time of another type (a string,
    null) would break the table's sum with a TypeError that ends the batch, a count of
    another type would go into the table, and a missing count would leave it empty."""
    out = tmp_path / "out"
    kw = {"out_dir": out, "workers": 0, "progress": False, "formats": "json"}
    (first,) = build_graphs([PAPER_MAPS[2]], **kw)
    manifest = out / "a_scan.manifest.json"
    clean = json.loads(manifest.read_text())
    for key, value in (
        ("t_load_s", "0.1"),
        ("t_graph_s", None),
        ("t_write_s", -1.0),
        ("vertices", "many"),
        ("height", [1, 2]),
        ("edges", True),
        ("resolution_m", "0.05"),
        ("vertices", ...),  # missing
    ):
        doc = json.loads(json.dumps(clean))
        if value is ...:
            del doc["record"][key]
        else:
            doc["record"][key] = value
        manifest.write_text(json.dumps(doc))
        (again,) = build_graphs([PAPER_MAPS[2]], resume=True, **kw)
        assert (again.status, again.vertices) == ("ok", first.vertices), key
    doc = json.loads(json.dumps(clean))
    doc["record"]["future_column"] = "x"  # a value no column of this table takes
    manifest.write_text(json.dumps(doc))
    (again,) = build_graphs([PAPER_MAPS[2]], resume=True, **kw)
    assert (again.status, again.vertices, again.edges) == ("skipped", first.vertices, first.edges)


def test_a_folder_with_an_outputs_name_makes_an_error_row(tmp_path):
    """A folder where a map's output file or manifest goes, met when a failed map's
    files (or the manifest of a map about to be redone) are removed, makes that map an
    error row naming the folder, which stays; it does not end the batch (an
    IsADirectoryError) without its table."""
    maps = [PAPER_MAPS[0], PAPER_MAPS[2]]
    for folder in ("intel.json", "intel.manifest.json"):
        out = tmp_path / folder / "out"
        (out / folder).mkdir(parents=True)
        for resume in (False, True):
            records = build_graphs(
                maps, out_dir=out, workers=0, progress=False, formats="json", resume=resume
            )
            assert [r.status for r in records] == ["error", "skipped" if resume else "ok"]
            assert f"output file {out / folder} is a folder" in records[0].message
            assert (out / folder).is_dir()
            assert sorted(p.name for p in out.iterdir() if p.name.startswith("intel")) == [folder]
            assert [r["status"] for r in _read_summary(out)][0] == "error"


def test_write_failure_leaves_no_manifest_and_resume_redoes(tmp_path, monkeypatch):
    """A fault while writing a map's files: error row, no manifest, none of its files
    (neither those written before the fault nor an earlier run's); resume redoes it."""
    import topojax.io

    out = tmp_path / "out"
    maps = [PAPER_MAPS[0], PAPER_MAPS[2]]
    real_save = topojax.io.save_graph

    def failing_save(graph, path, *, format=None):
        if str(path).endswith("a_scan.json"):
            raise OSError("disk full (injected)")
        return real_save(graph, path, format=format)

    build_graphs(maps[1:], out_dir=out, workers=0, progress=False)  # an earlier run
    assert (out / "a_scan.json").exists()
    monkeypatch.setattr(topojax.io, "save_graph", failing_save)
    first = build_graphs(maps, out_dir=out, workers=0, progress=False, plot=True)
    assert [r.status for r in first] == ["ok", "error"]
    assert "disk full (injected)" in first[1].message
    assert (out / "intel.manifest.json").exists()
    # a_scan.graphml was written before the fault, a_scan.json by the earlier run
    assert not list(out.glob("a_scan*"))

    monkeypatch.setattr(topojax.io, "save_graph", real_save)
    second = build_graphs(maps, out_dir=out, workers=0, resume=True, progress=False, plot=True)
    assert [r.status for r in second] == ["skipped", "ok"]
    assert second[0].vertices == first[0].vertices
    assert (out / "a_scan.manifest.json").exists()
    assert load_graph(out / "a_scan.json").number_of_edges() == second[1].edges


def test_a_map_redone_with_fewer_outputs_leaves_none_of_the_earlier_ones(tmp_path):
    """Files of formats (or pictures) a map's earlier run wrote and this one does not
    are removed with its manifest: left, ``topojax view`` would show the earlier
    settings' graph beside this run's manifest."""
    out = tmp_path / "out"
    src = PAPER_MAPS[2]
    stem = src.stem
    build_graphs([src], out_dir=out, formats="graphml,json,nav2", plot=True, workers=0)
    assert {f"{stem}.json", f"{stem}_nav2.geojson", f"{stem}_graph.png"} <= {
        p.name for p in out.iterdir()
    }
    (out / "notes.txt").write_text("mine")
    cfg = PipelineConfig(graph=GraphConfig(min_spur_m=0.5))
    for resume in (True, False):
        build_graphs([src], out_dir=out, formats="graphml", workers=0, config=cfg, resume=resume)
        names = {p.name for p in out.iterdir()}
        assert f"{stem}.graphml" in names and "notes.txt" in names
        assert not names & {f"{stem}.json", f"{stem}_nav2.geojson", f"{stem}_graph.png"}
        cfg = PipelineConfig()


def test_a_map_that_fails_when_redone_keeps_no_earlier_files(tmp_path):
    """A map that fails this run (here: its file was damaged since) loses the manifest
    and files of its earlier run, which, left, would be attributed to a map whose input
    is no longer theirs (``topojax view`` would show them as its graph); other files
    stay."""
    out = tmp_path / "out"
    src = tmp_path / "m.png"
    src.write_bytes(PAPER_MAPS[2].read_bytes())
    first = build_graphs([src], out_dir=out, formats="graphml,json", plot=True, workers=0)
    assert [r.status for r in first] == ["ok"]
    (out / "notes.txt").write_text("mine")
    src.write_bytes(b"not an image")
    for resume in (True, False):
        again = build_graphs([src], out_dir=out, formats="graphml", workers=0, resume=resume)
        assert [r.status for r in again] == ["error"]
        assert {p.name for p in out.iterdir()} <= {"notes.txt", "summary.csv", "summary.parquet"}
        assert "notes.txt" in {p.name for p in out.iterdir()}


def test_resume_skips_complete_and_redoes_damaged(tmp_path, shared_data):
    src = tmp_path / "maps"
    src.mkdir()
    inputs = []
    for p in [*PAPER_MAPS, _small_shared(shared_data)[1]]:
        if p.suffix == ".yaml":  # copy the YAML with its image
            doc = p.read_text()
            (src / p.name).write_text(doc)
            for line in doc.splitlines():
                if line.startswith("image:"):
                    name = line.split(":", 1)[1].strip()
                    (src / name).write_bytes((p.parent / name).read_bytes())
        else:
            (src / p.name).write_bytes(p.read_bytes())
        inputs.append(src / p.name)
    out = tmp_path / "out"
    first = build_graphs(inputs, out_dir=out, workers=0, plot=True, progress=False)
    assert all(r.status == "ok" for r in first), [r.message for r in first]
    clean = _file_bytes(out)
    for rec in first:
        for suffix in (".graphml", ".json", ".geojson", "_graph.png", ".manifest.json"):
            assert f"{rec.map}{suffix}" in clean
        assert clean[f"{rec.map}_graph.png"].startswith(b"\x89PNG")
    mtimes = {p: p.stat().st_mtime_ns for p in out.iterdir()}

    again = build_graphs(inputs, out_dir=out, workers=0, plot=True, resume=True, progress=False)
    assert [r.status for r in again] == ["skipped"] * 4
    assert [r.vertices for r in again] == [r.vertices for r in first]
    assert [r.edges for r in again] == [r.edges for r in first]
    assert {p: p.stat().st_mtime_ns for p in out.iterdir() if p.name != "summary.csv"} == {
        p: t for p, t in mtimes.items() if p.name != "summary.csv"
    }
    assert [r["status"] for r in _read_summary(out)] == ["skipped"] * 4

    # damage: truncate one file, delete another, corrupt a third's manifest
    names = [r.map for r in first]
    graphml = out / f"{names[0]}.graphml"
    graphml.write_bytes(graphml.read_bytes()[:100])
    (out / f"{names[1]}.geojson").unlink()
    (out / f"{names[2]}.manifest.json").write_text("{not json")
    with warnings.catch_warnings():  # a damaged manifest's files are a batch's: no warning
        warnings.simplefilter("error")
        third = build_graphs(inputs, out_dir=out, workers=0, plot=True, resume=True, progress=False)
    assert [r.status for r in third] == ["ok", "ok", "ok", "skipped"]
    repaired = _file_bytes(out)
    for key in clean:
        if key != "summary.csv" and not key.endswith(".png"):
            assert repaired[key] == clean[key] or key.endswith(".manifest.json"), key
    for name in names:
        manifest = json.loads((out / f"{name}.manifest.json").read_text())
        for rel, meta in manifest["files"].items():
            assert (out / rel).stat().st_size == meta["bytes"]

    # another setting (thinning) or a changed input: redone, not skipped
    zhang = PipelineConfig(skeleton=SkeletonConfig(thinning="zhang"))
    fourth = build_graphs(
        inputs, out_dir=out, workers=0, plot=True, resume=True, config=zhang, progress=False
    )
    assert [r.status for r in fourth] == ["ok"] * 4
    img = inputs[0]
    arr = load_map(img).to_image()
    arr[300:310, 300:500] = 0  # a new wall
    from PIL import Image

    Image.fromarray(arr).save(img)
    fifth = build_graphs(
        inputs, out_dir=out, workers=0, plot=True, resume=True, config=zhang, progress=False
    )
    assert [r.status for r in fifth] == ["ok", "skipped", "skipped", "skipped"]


_KILL_SCRIPT = """
import sys
from topojax.batch import build_graphs
paths = sys.argv[2:]
build_graphs(paths, out_dir=sys.argv[1], workers=0, progress=False)
"""


_UNGUARDED_SCRIPT = """
import sys
from topojax.batch import build_graphs
records = build_graphs(sys.argv[2:], out_dir=sys.argv[1], workers=1, progress=False)
print("MESSAGES", *[r.status + ": " + r.message for r in records], sep="\\n")
"""


def test_workers_that_cannot_start_say_so_not_killed_for_memory(tmp_path):
    """A script that calls build_graphs without the ``__main__`` guard: its workers fail
    while importing it, and each map's row says so instead of blaming memory."""
    script = tmp_path / "unguarded.py"
    script.write_text(_UNGUARDED_SCRIPT)
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path / "out"), str(PAPER_MAPS[1])],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    lines = done.stdout.split("MESSAGES")[-1].strip().splitlines()
    assert lines and all(line.startswith("error: ") for line in lines), done.stdout
    assert all("the worker processes failed to start" in line for line in lines)
    assert not any("killed for memory" in line for line in lines)
    # each worker's own error (printed above) names the cause, not a lock held by its parent
    assert "another topojax process" not in done.stderr, done.stderr[-2000:]
    assert 'if __name__ == "__main__":' in done.stderr, done.stderr[-2000:]


def test_a_run_cut_short_leaves_no_earlier_summary(tmp_path, monkeypatch):
    from topojax.batch import driver

    out = tmp_path / "out"
    build_graphs(PAPER_MAPS[:1], out_dir=out, workers=0, progress=False)
    assert (out / "summary.csv").is_file()
    (out / "summary.parquet").write_bytes(b"an earlier run's")

    def interrupted(self):
        raise KeyboardInterrupt

    monkeypatch.setattr(driver._BatchRun, "run", interrupted)
    with pytest.raises(KeyboardInterrupt):
        build_graphs(PAPER_MAPS[:1], out_dir=out, workers=0, progress=False)
    assert not (out / "summary.csv").exists()
    assert not (out / "summary.parquet").exists()


def test_the_summary_holds_the_maps_of_the_last_run_and_the_manifests_every_one(tmp_path):
    """As documented: ``summary.csv`` is the table of the run that wrote it, so a later run
    of other maps into the folder replaces it with theirs; the earlier maps' files stay,
    and their manifests keep their rows."""
    out = tmp_path / "out"
    kw = {"out_dir": out, "workers": 0, "progress": False, "formats": "json"}
    (first,) = build_graphs([_synthetic((60, 80), 1, source="first")], **kw)
    (second,) = build_graphs([_synthetic((60, 80), 2, source="second")], **kw)
    assert [row["map"] for row in _read_summary(out)] == ["second"]
    manifest = json.loads((out / "first.manifest.json").read_text())
    assert manifest["status"] == first.status and manifest["record"]["map"] == "first"
    assert manifest["record"]["vertices"] == first.vertices and (out / "first.json").is_file()


@pytest.mark.parametrize("name", ["summary.csv", "summary.parquet"])
def test_a_folder_in_place_of_the_summary_is_refused_before_any_map(tmp_path, capsys, name):
    """A folder where the summary table goes is refused naming the output folder and the
    table's file, before any map runs (not an OSError of its removal, naming no option)."""
    from topojax.cli import main

    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    with pytest.raises(ValueError, match=rf"^out_dir: .*{name} is a folder, expected"):
        build_graphs(PAPER_MAPS[:1], out_dir=out, workers=0, progress=False)
    argv = ["batch", str(PAPER_MAPS[0]), "-o", str(out), "--workers", "0", "--no-progress"]
    assert main(argv) == 2
    assert f"error: -o/--out: {out / name} is a folder" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [name]  # no map ran


def test_killed_run_leaves_only_complete_files(tmp_path):
    """SIGKILL a run mid-way: every file under a final name is complete, resume finishes."""
    src = tmp_path / "in"
    src.mkdir()
    inputs = []
    for i in range(12):  # distinct files, so every map has its own outputs
        dest = src / f"m{i:02d}.png"
        dest.write_bytes(PAPER_MAPS[i % 3].read_bytes())
        inputs.append(str(dest))
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILL_SCRIPT, str(out), *inputs],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline and proc.poll() is None:
        if any(out.glob("*.manifest.json")):
            break
        time.sleep(0.01)
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert out.is_dir()
    finals = [p for p in out.iterdir() if not p.name.startswith(".")]
    assert finals, "the run was killed before writing anything"
    for p in finals:
        if p.name.endswith(".manifest.json"):
            doc = json.loads(p.read_text())
            for rel, meta in doc["files"].items():
                assert (out / rel).stat().st_size == meta["bytes"]
        elif p.suffix in (".graphml", ".json", ".geojson"):
            load_graph(p)  # parses completely, or raises
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        done = build_graphs(inputs, out_dir=out, workers=0, resume=True, progress=False)
    # a map killed between its files and its manifest leaves files no manifest lists:
    # named before they are replaced, the only warning a resume after a kill may give
    assert all("no batch manifest lists" in str(w.message) for w in caught)
    assert all(r.status in ("ok", "skipped") for r in done)
    assert any(r.status == "skipped" for r in done)
    assert not list(out.glob(".*.tmp")), "stale temporary files of redone maps are removed"
    for r, inp in zip(done, inputs, strict=True):
        assert r.edges == build_graph(load_map(inp)).graph.number_of_edges()


def _live_processes(field: int, value: int) -> list[int]:
    """Live processes (zombies excluded) whose /proc stat ``field`` (after the name: 0
    state, 1 ppid, 2 pgrp, 3 session) is ``value``."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[field]) == value and fields[0] != "Z":
            found.append(int(stat.parent.name))
    return found


def _session_processes(sid: int) -> list[int]:
    """Live processes of session ``sid``."""
    return _live_processes(3, sid)


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs /proc")
@pytest.mark.parametrize("background", [False, True], ids=["foreground", "script-job"])
def test_sigterm_stops_the_worker_processes(tmp_path, background):
    """``kill`` (SIGTERM) of a batch with workers ends it without leaving them behind or
    temporary files, and says in one line how many maps it finished and how to do the
    others; as well as a background job of a script, where SIGINT is ignored."""
    if background and shutil.which("bash") is None:
        pytest.skip("needs bash")
    src = tmp_path / "in"
    src.mkdir()
    for i in range(12):
        (src / f"m{i:02d}.png").write_bytes(PAPER_MAPS[i % 3].read_bytes())
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "topojax", "batch", str(src), "-o", str(out)]
    cmd += ["--workers", "2", "--no-progress"]
    if background:  # a shell without job control starts it with SIGINT ignored
        cmd = ["bash", "-c", '"$@" & echo $!; wait $!', "bash", *cmd]
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE if background else subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,
        text=True,
    )
    pid = int(proc.stdout.readline()) if background else proc.pid
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if any(out.glob("*.manifest.json")):
            break
        time.sleep(0.01)
    assert proc.poll() is None, "the batch ended before it could be stopped"
    os.kill(pid, signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    deadline = time.monotonic() + 10
    while _session_processes(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = _session_processes(proc.pid)
    for pid in left:  # do not leave them to the next test
        os.kill(pid, signal.SIGKILL)
    assert not left, "worker processes outlived the batch"
    assert proc.returncode == 128 + signal.SIGTERM
    done = len(list(out.glob("*.manifest.json")))
    assert err.strip().splitlines()[-1] == (
        f"topojax batch: stopped by SIGTERM; this run finished {done} of 12 maps (their "
        f"files and manifests are in {out}; summary.csv is written only by a run that "
        "ends); the same command with --resume does the others"
    )
    assert not list(out.glob(".*.tmp"))


def test_a_run_stopped_after_its_last_map_says_only_the_summary_is_missing(tmp_path):
    """A stop that comes after every map's manifest (while the table is written) says
    so: --resume then skips every map and writes summary.csv; it has no others to do."""
    from topojax.cli.batch import _stopped_text

    manifests = {tmp_path / f"{name}.manifest.json": None for name in ("a", "b")}
    for path in manifests:
        path.write_text("{}", encoding="utf-8")
    assert _stopped_text(signal.SIGINT, tmp_path, manifests) == (
        "topojax batch: interrupted (Ctrl-C) after it finished all 2 maps (their files and "
        f"manifests are in {tmp_path}), before it wrote summary.csv; the same command with "
        "--resume writes it"
    )


_INTERRUPTED_WHILE_WAITING = """
import concurrent.futures._base as base
import os, signal, sys
from topojax.batch import build_graphs

enter = base._AcquireFutures.__enter__

def interrupted(self):  # the signal comes while wait() takes the futures' locks
    running = [f for f in self.futures if f.running()]  # another thread completes it
    if not running or sys.argv[3] == "sent":
        return enter(self)
    sys.argv[3] = "sent"
    running[0]._condition.acquire()
    os.kill(os.getpid(), signal.SIGINT)
    for f in self.futures:
        if f is not running[0]:
            f._condition.acquire()

if __name__ == "__main__":
    base._AcquireFutures.__enter__ = interrupted
    maps = sys.argv[1].split(os.pathsep)
    try:
        build_graphs(maps, out_dir=sys.argv[2], workers=2, progress=False)
    except KeyboardInterrupt:
        print("interrupted")
"""


def test_an_interrupt_while_the_batch_waits_ends_it(tmp_path):
    """Ctrl-C that comes while the main loop waits for its futures (Python's
    ``concurrent.futures.wait`` takes each future's lock in turn) stops the batch: it is
    held until the wait has taken and given back the locks, where raised at once it left
    a lock taken that the pool's thread needed, and the batch never ended."""
    import concurrent.futures._base as base

    if not hasattr(base, "_AcquireFutures"):
        pytest.skip("concurrent.futures.wait takes the futures' locks otherwise here")
    script = tmp_path / "interrupted.py"
    script.write_text(_INTERRUPTED_WHILE_WAITING)
    maps = os.pathsep.join(map(str, PAPER_MAPS * 2))
    cmd = [sys.executable, str(script), maps, str(tmp_path / "out"), "not sent"]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        out, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("the interrupted batch did not end")
    assert out.strip() == "interrupted", err
    assert proc.returncode == 0


def test_an_interrupt_in_a_map_run_by_the_calling_thread_stops_it_at_once(tmp_path, monkeypatch):
    """With ``workers=0`` the main thread runs each map's CPU stage itself: Ctrl-C stops
    the map where it is rather than waiting for it to end, and the handlers are the
    caller's again after the batch."""
    from topojax.batch import driver

    reached = []

    def slow_stage(job):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(30)
        reached.append(job)

    monkeypatch.setattr(driver, "_cpu_stage", slow_stage)
    handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        build_graphs(PAPER_MAPS[:1], out_dir=tmp_path / "out", workers=0, progress=False)
    assert not reached
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == handlers


def test_a_stopped_batch_removes_the_temporary_files_of_the_maps_in_flight(tmp_path, monkeypatch):
    """The worker processes of a stopped batch are terminated, not left to finish, and
    the temporary files of the maps they were writing are removed with them."""
    from topojax.batch import driver

    out = tmp_path / "out"
    planted: list[Path] = []

    def interrupt(self, fut):  # Ctrl-C as the first map's CPU stage ends
        for item, _, _ in self._cpu.values():  # as a killed write leaves them
            planted.append(out / f".{item.name}.graphml.k1ll3d.tmp")
            planted[-1].write_bytes(b"cut short")
        raise KeyboardInterrupt

    monkeypatch.setattr(driver._BatchRun, "_on_cpu_done", interrupt)
    with pytest.raises(KeyboardInterrupt):
        build_graphs(PAPER_MAPS, out_dir=out, workers=2, progress=False)
    assert planted
    assert not any(p.exists() for p in planted)


def test_an_interrupted_batch_ends_its_worker_processes_instead_of_waiting(tmp_path, monkeypatch):
    """Ctrl-C in the batch (KeyboardInterrupt) terminates the own worker processes: the
    maps they are building would get no manifest, and waiting for them made an interrupt
    take as long as the slowest map in flight."""
    from topojax.batch import driver

    stopped: list = []

    def interrupt(self, fut):  # Ctrl-C as the first map's CPU stage ends
        stopped.extend(w.process for w in self.executor._workers)
        raise KeyboardInterrupt

    monkeypatch.setattr(driver._BatchRun, "_on_cpu_done", interrupt)
    with pytest.raises(KeyboardInterrupt):
        build_graphs(PAPER_MAPS * 2, out_dir=tmp_path / "out", workers=2, progress=False)
    assert len(stopped) == 2
    # terminated (not left to finish their maps and exit on their own, exit code 0)
    assert [p.exitcode for p in stopped] == [-signal.SIGTERM] * 2


def test_a_task_cancelled_with_a_broken_pool_runs_again(tmp_path, monkeypatch):
    """A pool shut down after it broke cancels the tasks it had not failed yet: they are
    lost as the failed ones are, and run again."""
    import concurrent.futures as cf

    from topojax.batch import driver

    submit = driver._BatchRun._submit
    cancelled = []

    def cancel_first_cpu_stage(self, fn, *args):
        if fn is driver._cpu_stage and not cancelled:
            fut = cf.Future()
            fut.cancel()
            fut.set_running_or_notify_cancel()
            cancelled.append(fut)
            return fut
        return submit(self, fn, *args)

    monkeypatch.setattr(driver._BatchRun, "_submit", cancel_first_cpu_stage)
    records = build_graphs(PAPER_MAPS[:2], out_dir=tmp_path, workers=0, progress=False)
    assert cancelled
    assert [r.status for r in records] == ["ok", "ok"]


def test_a_pool_that_keeps_breaking_gives_error_rows_and_a_summary(tmp_path, monkeypatch):
    """Once the pool has been replaced as often as it may be, the maps left become error
    rows that say why: the batch still ends with one record per map and its table."""
    import concurrent.futures as cf
    from concurrent.futures.process import BrokenProcessPool

    from topojax.batch import driver

    class BreaksAtOnce(cf.Executor):
        """A pool whose worker dies with the first task: it fails, later submits raise."""

        def __init__(self):
            self.broken = False

        def submit(self, fn, /, *args, **kwargs):
            if self.broken:
                raise BrokenProcessPool("A child process terminated abruptly")
            self.broken = True
            fut = cf.Future()
            fut.set_exception(BrokenProcessPool("A child process terminated abruptly"))
            return fut

    def started_pool(self):  # its processes started (warmed up), then died with a task
        self._started = True
        return BreaksAtOnce()

    monkeypatch.setattr(driver._BatchRun, "_new_executor", started_pool)
    records = build_graphs(PAPER_MAPS, out_dir=tmp_path, workers=2, progress=False)
    assert [r.status for r in records] == ["error"] * len(PAPER_MAPS)
    assert all("worker process died" in r.message for r in records), records
    rows = list(csv.DictReader((tmp_path / "summary.csv").open(encoding="utf-8")))
    assert [row["status"] for row in rows] == ["error"] * len(PAPER_MAPS)


def test_a_pool_that_breaks_now_and_then_is_replaced_as_often_as_maps_get_done(
    tmp_path, monkeypatch
):
    """Worker processes killed now and then over a long batch (for memory, say) do not
    add up to the end of it: the count of breaks starts again once a task is done."""
    import concurrent.futures as cf
    from concurrent.futures.process import BrokenProcessPool

    from topojax.batch import driver

    lost: set[str] = set()  # maps whose task a break lost: each once

    class BreaksAfterATask(driver.InlineExecutor):
        """Runs tasks at once; its worker dies with the task of a map not lost before, once
        it has done one."""

        def __init__(self):
            self.done = 0
            self.broken = False

        def submit(self, fn, /, *args, **kwargs):
            if self.broken:
                raise BrokenProcessPool("A child process terminated abruptly")
            name = args[0].name if fn is driver._cpu_stage else Path(args[0]).stem
            if self.done and name not in lost:
                lost.add(name)
                self.broken = True
                fut = cf.Future()
                fut.set_exception(BrokenProcessPool("A child process terminated abruptly"))
                return fut
            self.done += 1
            return super().submit(fn, *args, **kwargs)

    src = tmp_path / "in"
    src.mkdir()
    inputs = []
    for i in range(6):
        inputs.append(src / f"m{i}.png")
        inputs[-1].write_bytes(PAPER_MAPS[i % 3].read_bytes())
    monkeypatch.setattr(driver._BatchRun, "_new_executor", lambda self: BreaksAfterATask())
    records = build_graphs(inputs, out_dir=tmp_path / "out", workers=2, progress=False)
    assert [r.status for r in records] == ["ok"] * len(inputs), records
    assert len(lost) > driver._POOL_RESTARTS + 1  # more breaks than replacements in a row


def test_a_map_lost_with_its_worker_says_how_to_run_it_again_in_its_callers_words(tmp_path):
    """The message of a map whose worker process died says that resuming runs it
    again: resume=True to build_graphs, --resume on the command line."""
    from concurrent.futures.process import BrokenProcessPool
    from types import SimpleNamespace

    from topojax.batch.failures import _lost_text
    from topojax.batch.pool import WorkerDied
    from topojax.batch.records import MapRecord
    from topojax.cli.batch import _as_printed

    died = _lost_text(WorkerDied("the worker process of m died (exit code -9)"))
    assert died.endswith("(killed for memory?; resume=True runs it again)")
    queued = _lost_text(BrokenProcessPool("A child process terminated abruptly"))
    assert queued.endswith("running, killed for memory?; resume=True runs it again)")
    records = [MapRecord(map="m", path="m.png", status="error", message=m) for m in (died, queued)]
    args = SimpleNamespace(resolution_m=None, occupied_thresh=None, free_thresh=None)
    args = SimpleNamespace(**vars(args), negate=None, mode=None, out=tmp_path)
    for printed in _as_printed(records, args):
        assert printed.message.endswith("killed for memory?; --resume runs it again)")


def pool_sizes(monkeypatch) -> list:
    """The ``max_workers`` of every process pool made from now on, in order."""
    from topojax.batch import driver

    sizes: list = []

    class Counted(driver.WorkerPool):
        def __init__(self, max_workers, **kwargs):
            sizes.append(max_workers)
            super().__init__(max_workers, **kwargs)

    monkeypatch.setattr(driver, "WorkerPool", Counted)
    return sizes


def test_no_more_worker_processes_than_maps_to_run(tmp_path, monkeypatch):
    sizes = pool_sizes(monkeypatch)
    out = tmp_path / "out"
    first = build_graphs(PAPER_MAPS[:1], out_dir=out, workers=4, progress=False)
    assert [r.status for r in first] == ["ok"]
    again = build_graphs(PAPER_MAPS[:2], out_dir=out, workers=4, progress=False, resume=True)
    assert [r.status for r in again] == ["skipped", "ok"]
    assert sizes == [1, 1]  # one map to run each time: one process, not four


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="needs CPU affinity")
@pytest.mark.parametrize("command_line", [False, True])
def test_default_workers_are_the_cpus_this_process_may_use(tmp_path, monkeypatch, command_line):
    """On a node of many cores where taskset, a container or a job scheduler allows one,
    the default is one worker process, not one per core of the machine."""
    from topojax.cli import main

    sizes = pool_sizes(monkeypatch)
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    out = tmp_path / "out"
    if command_line:
        argv = ["batch", *map(str, PAPER_MAPS[:2]), "-o", str(out), "--no-progress"]
        assert main([*argv, "--formats", "json"]) == 0
    else:
        records = build_graphs(PAPER_MAPS[:2], out_dir=out, formats="json", progress=False)
        assert [r.status for r in records] == ["ok", "ok"]
    assert sizes == [1]


def _memory_for(monkeypatch, n_workers: float) -> None:
    """Make the memory available hold ``n_workers`` batch worker processes."""
    from topojax.batch import arguments

    free = int(n_workers * arguments.WORKER_MEMORY_BYTES)
    monkeypatch.setattr(arguments, "available_memory_bytes", lambda: free)


@pytest.mark.parametrize("command_line", [False, True])
def test_more_workers_than_the_memory_holds_are_refused_before_any_map(
    tmp_path, monkeypatch, capsys, command_line
):
    """Each worker process holds a few hundred MB before its first map: a count the
    memory cannot hold is an error naming the option, not a machine swapping or the
    kernel killing workers one after another."""
    from topojax.cli import main

    sizes = pool_sizes(monkeypatch)
    _memory_for(monkeypatch, 1.5)
    out = tmp_path / "out"
    if command_line:
        argv = ["batch", *map(str, PAPER_MAPS[:2]), "-o", str(out), "--no-progress"]
        assert main([*argv, "--workers", "1000"]) == 2
        err = capsys.readouterr().err
        assert "--workers: expected at most 1 worker processes" in err
        assert "received 1000 (2 for the maps to run)" in err
    else:
        with pytest.raises(ValueError, match=r"^workers: expected at most 1 worker .*received 3"):
            build_graphs(PAPER_MAPS, out_dir=out, workers=3, progress=False)
    assert sizes == []
    assert not any(p.suffix == ".json" for p in out.iterdir())


def test_default_workers_are_as_many_as_the_memory_holds(tmp_path, monkeypatch):
    sizes = pool_sizes(monkeypatch)
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    if hasattr(os, "sched_getaffinity"):
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(64)))
    _memory_for(monkeypatch, 2.5)
    records = build_graphs(PAPER_MAPS, out_dir=tmp_path, formats="json", progress=False)
    assert [r.status for r in records] == ["ok"] * 3
    assert sizes == [2]


def test_worker_count_within_memory():
    """``workers_for_memory``: every worker where the memory holds them (or cannot be
    read), else as many as it holds for a default count and an error for a given one."""
    from topojax.batch import arguments

    per = arguments.WORKER_MEMORY_BYTES
    for free, wanted, asked, expected in [
        (None, 8, 8, 8),
        (8 * per, 8, 8, 8),
        (8 * per - 1, 8, None, 7),
        (per // 2, 8, None, 1),
        (per // 2, 1, 1, 1),  # one worker whatever the memory
    ]:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(arguments, "available_memory_bytes", lambda free=free: free)
            assert arguments.workers_for_memory(wanted, asked=asked) == expected
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(arguments, "available_memory_bytes", lambda: 8 * per - 1)
        with pytest.raises(ValueError, match=r"workers: expected at most 7 .*received 20 \(8 "):
            arguments.workers_for_memory(8, asked=20)


def _write_tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)


GIB = 2**30


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        # no cgroup limit: the kernel's estimate
        ({"cgroup": "0::/\n", "fs/memory.max": "max\n"}, 20 * GIB),
        # v2: the limit less the usage, inactive page cache counted as free
        (
            {
                "cgroup": "0::/job/step\n",
                "fs/job/step/memory.max": f"{4 * GIB}\n",
                "fs/job/step/memory.current": f"{3 * GIB}\n",
                "fs/job/step/memory.stat": f"anon 5\ninactive_file {GIB}\nactive_file 7\n",
            },
            2 * GIB,
        ),
        # v2: a parent's limit is tighter
        (
            {
                "cgroup": "0::/job/step\n",
                "fs/job/step/memory.max": "max\n",
                "fs/job/memory.max": f"{2 * GIB}\n",
                "fs/job/memory.current": f"{GIB}\n",
            },
            GIB,
        ),
        # v1: the memory controller's hierarchy; the kernel's "unlimited" is no limit
        (
            {
                "cgroup": "9:cpu,cpuacct:/x\n4:memory:/box\n",
                "fs/memory/memory.limit_in_bytes": "9223372036854771712\n",
                "fs/memory/box/memory.limit_in_bytes": f"{8 * GIB}\n",
                "fs/memory/box/memory.usage_in_bytes": f"{7 * GIB}\n",
                "fs/memory/box/memory.stat": f"inactive_file 1\ntotal_inactive_file {GIB}\n",
            },
            2 * GIB,
        ),
        # unreadable or odd files are no limit
        (
            {
                "cgroup": "0::/a\n",
                "fs/a/memory.max": "lots\n",
                "fs/memory.max": f"{GIB}\n",
                "fs/memory.current": "?\n",
            },
            20 * GIB,
        ),
    ],
)
def test_available_memory_is_the_tightest_of_the_kernel_and_the_cgroups(tmp_path, files, expected):
    _write_tree(
        tmp_path, {"meminfo": f"MemTotal: 1 kB\nMemAvailable: {20 * GIB // 1024} kB\n", **files}
    )
    from topojax._cpus import available_memory_bytes

    got = available_memory_bytes(
        meminfo=str(tmp_path / "meminfo"),
        cgroups=str(tmp_path / "cgroup"),
        root=str(tmp_path / "fs"),
    )
    assert got == expected


def test_available_memory_is_unknown_without_proc(tmp_path):
    from topojax._cpus import available_memory_bytes

    nowhere = str(tmp_path / "missing")
    assert available_memory_bytes(meminfo=nowhere, cgroups=nowhere, root=nowhere) is None


def _children(pid: int) -> list[int]:
    """Live child processes of ``pid``."""
    return _live_processes(1, pid)


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs /proc")
def test_a_worker_that_dies_costs_no_other_map(tmp_path):
    """A worker process killed (e.g. for memory) at any moment, while it writes its result
    too, loses only the map it ran, which runs again on a new process."""
    import threading

    src = tmp_path / "in"
    src.mkdir()
    inputs = []
    for i in range(12):
        dest = src / f"m{i:02d}.png"
        dest.write_bytes(PAPER_MAPS[i % 3].read_bytes())
        inputs.append(str(dest))
    out = tmp_path / "out"
    killed: list[int] = []

    def kill_a_worker() -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not any(out.glob("*.manifest.json")):
            time.sleep(0.01)
        while time.monotonic() < deadline and not killed:
            # the pool's processes are the children of the forkserver, a child of this one
            for w in (w for c in _children(os.getpid()) for w in _children(c)):
                os.kill(w, signal.SIGKILL)
                killed.append(w)
                break
            time.sleep(0.005)

    watcher = threading.Thread(target=kill_a_worker)
    watcher.start()
    try:
        records = build_graphs(inputs, out_dir=out, workers=2, progress=False)
    finally:
        watcher.join()
    assert killed, "no worker was running to be killed"
    assert [r.status for r in records] == ["ok"] * len(inputs), [r.message for r in records]


# ---------------------------------------------------------------------- inputs and CLI


def test_expand_braces():
    assert expand_braces("maps/**/*.{yaml,png,pgm}") == [
        "maps/**/*.yaml",
        "maps/**/*.png",
        "maps/**/*.pgm",
    ]
    assert expand_braces("a{b,c{d,e}}f") == ["abf", "acdf", "acef"]
    assert expand_braces("{x,y}{1,2}") == ["x1", "x2", "y1", "y2"]
    assert expand_braces("{a}b") == ["{a}b"]  # no comma: literal, as in bash
    assert expand_braces("a{b") == ["a{b"]
    assert expand_braces("a{b{c,d}") == ["a{bc", "a{bd"]
    assert expand_braces("{,x}y") == ["y", "xy"]
    with pytest.raises(TypeError, match="pattern"):
        expand_braces(3)  # type: ignore[arg-type]


def test_expand_map_inputs(tmp_path):
    root = tmp_path / "maps"
    (root / "sub").mkdir(parents=True)
    (root / ".hidden").mkdir()
    png = PAPER_MAPS[2].read_bytes()
    (root / "a.pgm").write_bytes(b"P5\n2 2\n255\n\x00\xfe\xfe\xfe")
    (root / "a.yaml").write_text("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    (root / "sub" / "b.png").write_bytes(png)
    (root / "sub" / "c.PGM").write_bytes(b"P5\n2 2\n255\n\x00\xfe\xfe\xfe")
    (root / "sub" / "notes.txt").write_text("not a map")
    (root / ".hidden" / "d.png").write_bytes(png)
    want = [root / "a.yaml", root / "sub" / "b.png", root / "sub" / "c.PGM"]
    assert expand_map_inputs([root]) == want
    got = expand_map_inputs([f"{root}/**/*.{{yaml,png,pgm,PGM}}"])
    assert sorted(got) == sorted(want)  # the YAML's image a.pgm is not listed twice
    assert expand_map_inputs([str(root / "sub" / "*.png"), root / "sub"]) == [
        root / "sub" / "b.png",
        root / "sub" / "c.PGM",
    ]
    literal = tmp_path / "nope.png"
    assert expand_map_inputs([literal]) == [literal]  # reported later as an error row
    with pytest.raises(ValueError, match="none found"):
        expand_map_inputs([str(tmp_path / "*.yaml")])


def test_pictures_of_a_batch_into_its_input_folder_are_not_maps(tmp_path):
    """``topojax batch maps/ -o maps/ --plot`` run again: its pictures are not inputs."""
    root = tmp_path / "maps"
    root.mkdir()
    (root / "m.png").write_bytes(PAPER_MAPS[2].read_bytes())
    first = build_graphs(
        [root / "m.png"], out_dir=root, workers=0, progress=False, plot=True, formats="json,rooms"
    )
    assert first[0].status == "ok"
    assert {"m_graph.png", "m_rooms.png"} <= {p.name for p in root.iterdir()}
    assert expand_map_inputs([root]) == [root / "m.png"]
    assert expand_map_inputs([f"{root}/*.png"]) == [root / "m.png"]
    (root / "other_graph.png").write_bytes(PAPER_MAPS[0].read_bytes())  # no manifest
    assert expand_map_inputs([root]) == [root / "m.png", root / "other_graph.png"]
    assert expand_map_inputs([root / "m_graph.png"]) == [root / "m_graph.png"]  # named


def test_an_empty_input_is_refused_not_taken_for_the_working_folder(tmp_path, monkeypatch):
    """``topojax batch "$MAPS"`` with MAPS unset must not batch the folder it runs in."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "m.png").write_bytes(PAPER_MAPS[0].read_bytes())
    monkeypatch.chdir(tmp_path)
    for inputs in ("", [" "], ["sub", ""]):
        with pytest.raises(ValueError, match="inputs: .* received an empty string"):
            expand_map_inputs(inputs)
    assert expand_map_inputs(["sub"]) == [Path("sub/m.png")]


def test_expand_map_inputs_skips_the_excluded_folder(tmp_path):
    root = tmp_path / "maps"
    (root / "out").mkdir(parents=True)
    png = PAPER_MAPS[2].read_bytes()
    (root / "a.png").write_bytes(png)
    (root / "out" / "a_graph.png").write_bytes(png)  # a picture of an earlier run
    assert expand_map_inputs([root]) == [root / "a.png", root / "out" / "a_graph.png"]
    assert expand_map_inputs([root], exclude=root / "out") == [root / "a.png"]
    assert expand_map_inputs([f"{root}/**/*.png"], exclude=root / "out") == [root / "a.png"]
    # a file named explicitly is kept, and so is a search of the excluded folder itself
    named = root / "out" / "a_graph.png"
    assert expand_map_inputs([named], exclude=root / "out") == [named]
    assert expand_map_inputs([root / "out"], exclude=root / "out") == [named]
    # an output folder that is the input folder or above it hides nothing (else every map
    # of `topojax batch maps -o .` would be lost)
    both = [root / "a.png", named]
    for out in (root, tmp_path, tmp_path.parent):
        assert expand_map_inputs([root], exclude=out) == both
        assert expand_map_inputs([f"{root}/**/*.png"], exclude=out) == both


def test_a_later_batch_does_not_replace_another_maps_file(tmp_path):
    """Across runs into one folder, map ``x_nav2`` would replace ``x_nav2.geojson``, the
    Nav2 graph an earlier batch wrote for map ``x`` (whose manifest still lists it), and
    the other way round: refused before any work, naming the file and the other map."""
    src = tmp_path / "maps"
    src.mkdir()
    x, x_nav2 = src / "x.png", src / "x_nav2.png"
    x.write_bytes(PAPER_MAPS[0].read_bytes())
    x_nav2.write_bytes(PAPER_MAPS[2].read_bytes())
    kw = {"workers": 0, "progress": False}
    for first, then, formats in ((x, x_nav2, "geojson"), (x_nav2, x, "json,nav2")):
        out = tmp_path / f"out_{first.stem}"
        build_graphs([first], out_dir=out, formats="json,nav2,geojson", **kw)
        before = (out / "x_nav2.geojson").read_bytes()
        with pytest.raises(ValueError, match="out_dir: .*x_nav2.geojson was written for") as e:
            build_graphs([then], out_dir=out, formats=formats, **kw)
        assert str(first) in str(e.value) and f"map '{then.stem}'" in str(e.value)
        assert (out / "x_nav2.geojson").read_bytes() == before
    # a map's own files of an earlier run are its own to replace
    (rec,) = build_graphs([x], out_dir=tmp_path / "out_x", formats="json,nav2", **kw)
    assert rec.status == "ok"


def test_output_names_never_share_a_file(tmp_path, capsys):
    """A map ``x_nav2`` beside a map ``x`` would write ``x_nav2.geojson``, the Nav2 graph of
    ``x``: both maps reported ok while one file replaced the other, and every resume redid
    one of them.  Each map must get files of its own."""
    from topojax.batch.inputs import _assign_names, _output_files
    from topojax.cli import main

    names = _assign_names([Path("m/x.png"), Path("m/x_nav2.png"), Path("m/y_graph.png")])
    names += _assign_names([Path("m/y.png"), Path("m/y.manifest.png")])
    files = [f for n in names for f in _output_files(n)]
    assert len(files) == len(set(files)), names

    src = tmp_path / "maps"
    src.mkdir()
    (src / "x.png").write_bytes(PAPER_MAPS[0].read_bytes())
    (src / "x_nav2.png").write_bytes(PAPER_MAPS[2].read_bytes())
    out = src / "out"  # inside the input folder, with pictures
    argv = ["batch", str(src), "-o", str(out), "--workers", "0", "--no-progress", "--plot"]
    argv += ["--formats", "geojson,nav2"]
    assert main(argv) == 0
    rows = {r["map"]: r for r in csv.DictReader((out / "summary.csv").open())}
    assert sorted(rows) == ["x", "x_nav2_2"]
    nav2 = json.loads((out / "x_nav2.geojson").read_text())
    assert nav2["features"][0]["properties"].get("frame") is not None  # a Nav2 graph
    plain = load_graph(out / "x_nav2_2.geojson")
    assert plain.number_of_nodes() == int(rows["x_nav2_2"]["vertices"])
    capsys.readouterr()
    # a second run sees neither its own pictures as maps nor anything to redo
    assert main([*argv, "--resume"]) == 0
    assert "2 skipped" in capsys.readouterr().out


def test_cli_batch(tmp_path, capsys):
    from topojax.cli import main

    src = tmp_path / "maps"
    src.mkdir()
    for p in PAPER_MAPS[1:]:
        (src / p.name).write_bytes(p.read_bytes())
    out = tmp_path / "out"
    argv = ["batch", f"{src}/*.{{png,pgm}}", "-o", str(out), "--workers", "0", "--no-progress"]
    assert main([*argv, "--formats", "json"]) == 0
    captured = capsys.readouterr()
    assert "2 maps" in captured.out and "2 with a warning" in captured.out  # no resolution
    assert sorted(p.name for p in out.iterdir()) == [
        "a_scan.json",
        "a_scan.manifest.json",
        "office.json",
        "office.manifest.json",
        "summary.csv",
    ]
    assert main([*argv, "--formats", "json", "--resume"]) == 0
    captured = capsys.readouterr()
    # the warnings of the run that wrote the outputs are counted and shown again
    assert "2 skipped" in captured.out and "2 with a warning" in captured.out
    assert captured.err.count("skipped  ") == 2 and "m/px assumed" in captured.err
    (src / "broken.png").write_bytes(b"not an image")
    assert main([*argv, "--formats", "json", "--resume"]) == 1
    captured = capsys.readouterr()
    assert "1 error," in captured.out and "broken" in captured.err


def test_nav2_format_is_written_and_resumed(tmp_path, capsys):
    from topojax.cli import main

    out = tmp_path / "out"
    argv = [
        "batch",
        str(PAPER_MAPS[0]),
        "-o",
        str(out),
        "--workers",
        "0",
        "--no-progress",
        "--formats",
        "json,nav2",
    ]
    assert main(argv) == 0
    name = PAPER_MAPS[0].stem
    doc = json.loads((out / f"{name}_nav2.geojson").read_text())
    graph = load_graph(out / f"{name}.json")
    points = [f for f in doc["features"] if f["geometry"]["type"] == "Point"]
    linked = [n for n in graph.nodes if graph.degree(n)]  # vertices without edges: none
    assert [f["properties"]["metadata"].get("vertex") for f in points[: len(linked)]] == linked
    manifest = json.loads((out / f"{name}.manifest.json").read_text())
    assert set(manifest["files"]) == {f"{name}.json", f"{name}_nav2.geojson"}
    assert main([*argv, "--resume"]) == 0
    assert "1 skipped" in capsys.readouterr().out


def test_map_mode_classifies_every_file(tmp_path, capsys):
    """``map_mode`` (``--mode``) loads every file with that pixel convention, exactly as
    ``load_map(path, mode=...)`` then ``build_graph``; it is part of the resume request."""
    import cv2

    from topojax.cli import main

    img = np.full((60, 80), 153, np.uint8)  # IPA style: grey outside, white rooms, no walls
    img[10:50, 10:35] = 255
    img[10:50, 40:70] = 255
    img[28:32, 35:40] = 255
    png = tmp_path / "rooms.png"
    cv2.imwrite(str(png), img)
    (rec,) = build_graphs([png], workers=0, progress=False, map_mode="ipa")
    assert_graphs_equal(rec.graph, build_graph(load_map(png, mode="ipa")).graph)
    assert rec.edges > 0
    (plain,) = build_graphs([png], workers=0, progress=False)
    assert plain.edges == 0  # grey is unknown by default: no obstacle at all
    with pytest.raises(ValueError, match="map_mode: expected one of"):
        build_graphs([png], workers=0, progress=False, map_mode="grey")
    out = tmp_path / "out"
    argv = ["batch", str(png), "-o", str(out), "--workers", "0", "--no-progress"]
    assert main([*argv, "--formats", "json", "--mode", "ipa"]) == 0
    assert main([*argv, "--formats", "json", "--mode", "ipa", "--resume"]) == 0
    assert "1 skipped" in capsys.readouterr().out
    assert main([*argv, "--formats", "json", "--resume"]) == 0  # another convention: redone
    assert "0 skipped" in capsys.readouterr().out
    assert load_graph(out / "rooms.json").number_of_edges() == 0


def test_sigma_in_metres_goes_through_each_map_resolution(tmp_path, capsys):
    """``sigma_m`` (``--sigma-m``) gives each map build_graph's result with
    ``DistanceConfig.from_metres(sigma_m, its resolution)``: maps of two resolutions in
    one batch run in kernel calls of their own.  A map whose setting is impossible
    becomes an error row; ``--sigma-px`` sets one pixel sigma for all."""
    from topojax.cli import main
    from topojax.config import DistanceConfig

    fine = _synthetic((160, 220), 3)  # 0.07 m/px
    coarse = dataclasses.replace(_synthetic((120, 150), 4), resolution_m=0.14)
    fine2 = _synthetic((140, 260), 5)
    tiny = dataclasses.replace(_synthetic((60, 60), 6), resolution_m=0.0001)  # R > 4096
    build_graphs([fine, coarse], workers=0, progress=False, sigma_m=0.7)  # compiles both
    # compiled kernels take groups of many maps: maps of the two settings must not share
    records = build_graphs([fine, coarse, fine2, tiny], workers=0, progress=False, sigma_m=0.7)
    assert [r.status for r in records] == ["ok", "ok", "ok", "error"]
    assert "sigma_m: 0.7 m at 0.0001 m/px is 7000 px" in records[3].message
    for occ, rec in zip((fine, coarse, fine2), records[:3], strict=True):
        distance = DistanceConfig.from_metres(sigma_m=0.7, resolution_m=occ.resolution_m)
        want = build_graph(occ, config=PipelineConfig(distance=distance)).graph
        assert_graphs_equal(rec.graph, want, rec.map)
    # different pixel settings: 10 px (R 35) on the 0.07 m maps, 5 px (R 18) on the other
    assert DistanceConfig.from_metres(sigma_m=0.7, resolution_m=0.07).half_width_px == 35
    with pytest.raises(ValueError, match="sigma_m"):
        build_graphs([fine], workers=0, progress=False, sigma_m=-1.0)

    import cv2

    folder = tmp_path / "maps"
    folder.mkdir()
    for name, occ in (("a", fine), ("b", coarse)):
        cv2.imwrite(str(folder / f"{name}.pgm"), np.where(occ.occupied, 0, 254).astype(np.uint8))
        (folder / f"{name}.yaml").write_text(
            f"image: {name}.pgm\nresolution: {occ.resolution_m}\norigin: [0.0, 0.0, 0.0]\n"
        )
    argv = ["batch", f"{folder}/*.yaml", "--workers", "0", "--no-progress", "--formats", "json"]
    for option, value, distance_of in (
        ("--sigma-m", "0.7", lambda m: DistanceConfig.from_metres(sigma_m=0.7, resolution_m=m)),
        ("--sigma-px", "9", lambda m: DistanceConfig.from_pixels(sigma_px=9.0)),
    ):
        out = tmp_path / option.strip("-")
        assert main([*argv, "-o", str(out), option, value]) == 0
        for name in ("a", "b"):
            occ = load_map(folder / f"{name}.yaml")
            config = PipelineConfig(distance=distance_of(occ.resolution_m))
            want = build_graph(occ, config=config).graph
            got = load_graph(out / f"{name}.json")
            assert (got.number_of_nodes(), got.number_of_edges()) == (
                want.number_of_nodes(),
                want.number_of_edges(),
            )
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main([*argv, "--sigma-m", "1", "--sigma-px", "9"])
    assert "not allowed with argument" in capsys.readouterr().err


def test_argument_errors(tmp_path):
    with pytest.raises(ValueError, match="formats"):
        build_graphs([PAPER_MAPS[0]], formats=("graphml", "svg"), workers=0)
    with pytest.raises(TypeError, match=r"maps\[1\]"):
        build_graphs([PAPER_MAPS[0], 3], workers=0)  # type: ignore[list-item]
    with pytest.raises(ValueError, match="out_dir"):
        build_graphs([PAPER_MAPS[0]], plot=True, workers=0)
    with pytest.raises(TypeError, match="executor"):
        build_graphs([PAPER_MAPS[0]], executor=object(), workers=0)
    with pytest.raises(ValueError, match="workers"):
        build_graphs([PAPER_MAPS[0]], workers=-1)
    with pytest.raises(TypeError, match="config"):
        build_graphs([PAPER_MAPS[0]], config={"tile_px": 64}, workers=0)  # type: ignore[arg-type]
    # writing into the input folder would overwrite an input: refused
    src = tmp_path / "x"
    src.mkdir()
    (src / "m.png").write_bytes(PAPER_MAPS[0].read_bytes())
    (src / "m_graph.png").write_bytes(PAPER_MAPS[0].read_bytes())
    with pytest.raises(ValueError, match="overwrite an input"):
        build_graphs([src / "m.png", src / "m_graph.png"], out_dir=src, plot=True, workers=0)


def test_a_rooms_batch_counts_rooms_and_doors_in_its_table_and_keeps_them_on_resume(tmp_path):
    from room_maps import three_rooms_png

    from topojax.batch.records import ROOM_COLUMNS, summary_columns

    png = three_rooms_png(tmp_path / "in" / "three.png")
    out = tmp_path / "out"
    kw = dict(out_dir=out, workers=0, progress=False, map_mode="ipa")
    both = [png, PAPER_MAPS[2]]
    (rooms, plain) = build_graphs(both[:1], formats="json,rooms", **kw) + build_graphs(
        both[1:], formats="json", out_dir=tmp_path / "plain", workers=0, progress=False
    )
    assert (rooms.rooms, rooms.doors) == (3, 2) and (plain.rooms, plain.doors) == (None, None)
    columns = summary_columns([rooms])
    at = SUMMARY_COLUMNS.index("route_components") + 1
    assert columns == (*SUMMARY_COLUMNS[:at], *ROOM_COLUMNS, *SUMMARY_COLUMNS[at:])
    assert summary_columns([plain]) == SUMMARY_COLUMNS, "no room columns without rooms"

    def table() -> list[dict]:
        with open(out / "summary.csv", newline="") as fh:
            reader = csv.DictReader(fh)
            assert tuple(reader.fieldnames or ()) == columns
            return list(reader)

    (row,) = table()
    assert (row["rooms"], row["doors"]) == ("3", "2")
    (again,) = build_graphs([png], formats="json,rooms", resume=True, **kw)
    assert again.status == "skipped" and (again.rooms, again.doors) == (3, 2)
    (row,) = table()
    assert (row["rooms"], row["doors"], row["status"]) == ("3", "2", "skipped")
    # a manifest written before the table counted rooms: the map is redone, not skipped
    manifest = out / "three.manifest.json"
    doc = json.loads(manifest.read_text())
    for name in ROOM_COLUMNS:
        del doc["record"][name]
    manifest.write_text(json.dumps(doc))
    (redone,) = build_graphs([png], formats="json,rooms", resume=True, **kw)
    assert redone.status == "ok" and (redone.rooms, redone.doors) == (3, 2)
    (row,) = table()
    assert (row["rooms"], row["status"]) == ("3", "ok")


def test_record_row_has_summary_columns():
    rec = MapRecord(map="m", path=None)
    assert tuple(rec.row()) == SUMMARY_COLUMNS


def test_records_are_frozen_and_named():
    """A returned record cannot drift from the summary table written beside it."""
    import dataclasses

    rec = MapRecord(map="m", path=None)
    with pytest.raises(dataclasses.FrozenInstanceError):
        rec.status = "error"
    with pytest.raises(TypeError):
        MapRecord("m", None)


def test_parquet_summary_when_pyarrow_is_installed(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    out = tmp_path / "out"
    records = build_graphs([PAPER_MAPS[2]], out_dir=out, workers=0, progress=False)
    table = pq.read_table(out / "summary.parquet").to_pylist()
    assert [r["map"] for r in table] == [r.map for r in records]
    assert table[0]["edges"] == records[0].edges


# ---------------------------------------------------------------------- Dask


def _local_cluster(distributed, tries: int = 3, **kw):
    """``distributed.LocalCluster(**kw)``, tried again where its event loop did not start:
    distributed waits 10 s for the loop's thread, which a loaded 2-core machine can
    exceed while an earlier cluster's processes shut down (an AssertionError in
    ``LoopRunner``, before any topojax code runs)."""
    for _ in range(tries - 1):
        try:
            return distributed.LocalCluster(**kw)
        except AssertionError:
            time.sleep(1.0)
    return distributed.LocalCluster(**kw)  # the last try's error is the test's


def test_dask_local_cluster_matches_local_run(tmp_path, shared_data):
    distributed = pytest.importorskip("distributed")
    inputs = [*PAPER_MAPS, *_small_shared(shared_data)[:2]]
    local = build_graphs(inputs, out_dir=tmp_path / "local", workers=0, progress=False)
    with (
        _local_cluster(
            distributed,
            n_workers=2,
            processes=True,
            threads_per_worker=1,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = build_graphs(inputs, executor=client, out_dir=tmp_path / "dask", progress=False)
        # the executor interface directly, graphs returned
        in_memory = build_graphs(inputs[:2], executor=client.get_executor(), progress=False)
        worker_pids = set(client.run(os.getpid).values())
    assert len(worker_pids) == 2 and os.getpid() not in worker_pids
    assert [r.status for r in remote] == ["ok"] * len(inputs)
    for a, b in zip(local, remote, strict=True):
        assert (a.map, a.vertices, a.edges, a.total_length_m, a.components) == (
            b.map,
            b.vertices,
            b.edges,
            b.total_length_m,
            b.components,
        )
    want = _file_bytes(tmp_path / "local")
    got = _file_bytes(tmp_path / "dask")
    assert want.keys() == got.keys()
    for key in want:
        if key.endswith((".graphml", ".json", ".geojson")) and ".manifest" not in key:
            assert got[key] == want[key], key
    for rec, inp in zip(in_memory, inputs[:2], strict=True):
        assert_graphs_equal(rec.graph, build_graph(load_map(inp)).graph, rec.map)


def test_a_scheduler_that_cannot_be_reached_is_named_and_leaves_no_folder(tmp_path, capsys):
    """A bad ``--scheduler`` address is refused naming the option, before ``-o`` is
    made, not with the Dask client's own message (``missing port number in address
    'garbage'``), which names no option."""
    pytest.importorskip("distributed")
    from topojax.cli import main

    out = tmp_path / "out"
    argv = ["batch", str(PAPER_MAPS[0]), "-o", str(out), "--no-progress", "--workers", "0"]
    assert main([*argv, "--scheduler", "garbage", "--connect-timeout", "1"]) == 2
    assert capsys.readouterr().err.startswith(
        "topojax batch: error: --scheduler: expected the address of a running Dask scheduler "
        "(e.g. tcp://host:8786), received 'garbage': "
    )
    assert not out.exists()


def test_a_connect_timeout_without_a_scheduler_is_refused(tmp_path, capsys):
    """``--connect-timeout`` does nothing without ``--scheduler``: refused naming both, as
    the route and room options are without their formats, before ``-o`` is made."""
    from topojax.cli import main

    out = tmp_path / "out"
    argv = ["batch", str(PAPER_MAPS[0]), "-o", str(out), "--no-progress", "--workers", "0"]
    assert main([*argv, "--connect-timeout", "5"]) == 2
    assert capsys.readouterr().err.startswith(
        "topojax batch: error: --connect-timeout: only used with --scheduler; expected "
        "--scheduler ADDRESS beside it, received none"
    )
    assert not out.exists()


def test_workers_beside_a_scheduler_are_said_to_be_unused(tmp_path, capsys):
    """``--workers`` does nothing with ``--scheduler`` (the cluster's workers run the
    maps): a warning says so rather than let it seem to bound the cluster."""
    distributed = pytest.importorskip("distributed")
    from topojax.cli import main

    with _local_cluster(
        distributed,
        n_workers=1,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        argv = ["batch", str(PAPER_MAPS[0]), "-o", str(tmp_path / "o"), "--no-progress"]
        assert main([*argv, "--scheduler", cluster.scheduler_address, "--workers", "3"]) == 0
    err = capsys.readouterr().err
    assert "topojax batch: warning: --workers: not used with --scheduler (received 3)" in err
    assert (tmp_path / "o" / f"{PAPER_MAPS[0].stem}.json").is_file()


def test_all_occupied_maps_give_empty_graphs_as_in_build_graph():
    maps = [OccupancyMap.from_array(np.ones(shape, bool)) for shape in ((2, 2), (2, 9), (40, 30))]
    maps.append(load_map(PAPER_MAPS[0]))
    records = build_graphs(maps, keep_graphs=True, progress=False)
    for m, rec in zip(maps, records, strict=True):
        assert rec.status == ("empty" if rec.vertices == 0 else "ok")
        want = build_graph(m).graph
        assert rec.vertices == want.number_of_nodes()
        assert rec.graph.number_of_edges() == want.number_of_edges()
    assert [r.vertices for r in records[:3]] == [0, 0, 0]


def test_outputs_never_replace_an_input_map_or_its_yaml_image(tmp_path, capsys):
    from topojax.cli import main

    src = tmp_path / "m"
    src.mkdir()
    png = PAPER_MAPS[2].read_bytes()
    (src / "m_graph.png").write_bytes(png)  # a YAML whose image has a picture's name
    (src / "m.yaml").write_text("image: m_graph.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match="would overwrite an input map"):
        build_graphs([src / "m.yaml"], out_dir=src, plot=True, workers=0, progress=False)
    # topojax batch names its own option, not the library's parameter
    argv = ["batch", str(src / "m.yaml"), "-o", str(src), "--plot", "--workers", "0"]
    assert main([*argv, "--no-progress"]) == 2
    assert "error: -o/--out: writing" in capsys.readouterr().err
    # topojax graph with -o the map's own folder: --plot would write <stem>.png
    (src / "a.png").write_bytes(png)
    (src / "b.yaml").write_text("image: b.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    (src / "b.png").write_bytes(png)
    for name in ("a.png", "b.yaml"):
        assert main(["graph", str(src / name), "-o", str(src), "--plot"]) == 2
        assert "--out: writing" in capsys.readouterr().err
    assert all((src / f).read_bytes() == png for f in ("m_graph.png", "a.png", "b.png"))
    assert main(["graph", str(src / "a.png"), "-o", str(src)]) == 0  # no picture: fine
    # a route written over its own graph file
    capsys.readouterr()
    graph = src / "a.json"
    argv = ["route", str(graph), "--start", "5", "5", "--goal", "20", "20", "-o", str(graph)]
    assert main(argv) == 2
    assert "would overwrite the graph file" in capsys.readouterr().err


def test_a_file_no_batch_wrote_under_an_output_name_is_warned_of_by_name(tmp_path, capsys):
    """A file in the output folder with the name of a map's output that no batch manifest
    lists (written by hand, or by another program) is named in a warning before any map
    runs: it is replaced (removed, should the map fail) by the batch; files a batch wrote
    and lists are replaced without a word."""
    import cv2

    from topojax.cli import main

    occ = _synthetic((80, 100), 5)
    cv2.imwrite(str(tmp_path / "rooms.png"), np.where(occ.occupied, 0, 255).astype(np.uint8))
    out = tmp_path / "out"
    out.mkdir()
    (out / "rooms.json").write_text("my own notes\n")
    kw = {"out_dir": out, "workers": 0, "progress": False, "formats": "json"}
    with pytest.warns(UserWarning, match=r"out_dir: .*rooms\.json") as caught:
        (rec,) = build_graphs([tmp_path / "rooms.png"], **kw)
    assert rec.status == "ok" and [w.filename for w in caught] == [__file__]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # its own files now: no warning
        build_graphs([tmp_path / "rooms.png"], **kw)
    (out / "rooms.manifest.json").unlink()
    argv = ["batch", str(tmp_path / "rooms.png"), "-o", str(out), "--formats", "json"]
    assert main([*argv, "--no-progress", "--workers", "0"]) == 0
    err = capsys.readouterr().err
    assert f"topojax batch: warning: --out: {out / 'rooms.json'}" in err and "out_dir" not in err


def test_a_map_file_of_the_same_name_from_another_folder_is_refused(tmp_path):
    """Two batches into one folder: ``b/m.png`` after ``a/m.png`` would replace its
    outputs without a word, and the library refuses it as the command line does; the
    same file again, or a resume, is fine."""
    png = PAPER_MAPS[2].read_bytes()
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "m.png").write_bytes(png)
    out = tmp_path / "out"
    kw = dict(out_dir=out, formats="json", workers=0, progress=False)
    assert build_graphs([tmp_path / "a" / "m.png"], **kw)[0].status == "ok"
    before = (out / "m.json").read_bytes()
    with pytest.raises(
        ValueError,
        match=r"^out_dir: .*m\.manifest\.json and the files it "
        r"lists were written from .*a/m\.png; .*b/m\.png would replace them",
    ):
        build_graphs([tmp_path / "b" / "m.png"], **kw)
    assert (out / "m.json").read_bytes() == before
    assert build_graphs([tmp_path / "a" / "m.png"], resume=True, **kw)[0].status == "skipped"
    assert build_graphs([tmp_path / "a" / "m.png"], **kw)[0].status == "ok"


def test_a_loaded_map_of_the_same_name_from_another_file_is_refused(tmp_path, monkeypatch):
    """A map loaded from ``b/m.png`` (its ``source``) would replace the outputs written
    from ``a/m.png`` just as the file itself would; the manifest of a loaded map names its
    file by its absolute path, so a later batch from any folder is checked against it."""
    png = PAPER_MAPS[2].read_bytes()
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "m.png").write_bytes(png)
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out"
    kw = dict(out_dir=out, formats="json", workers=0, progress=False)
    assert build_graphs([load_map("a/m.png")], **kw)[0].status == "ok"
    before = (out / "m.json").read_bytes()
    for other in (load_map("b/m.png"), Path("b/m.png")):
        with pytest.raises(
            ValueError, match=r"^out_dir: .*written from .*a/m\.png; .*b/m\.png would replace"
        ):
            build_graphs([other], **kw)
    assert (out / "m.json").read_bytes() == before
    assert build_graphs([load_map("a/m.png")], **kw)[0].status == "ok"
    assert build_graphs([Path("a/m.png")], **kw)[0].status == "ok"
    assert build_graphs([load_map("a/m.png")], **kw)[0].status == "ok"


def test_batch_argument_checks_for_flags_formats_and_folders(tmp_path):
    occ = load_map(PAPER_MAPS[0])
    with pytest.raises(TypeError, match="keep_graphs: expected a bool"):
        build_graphs([occ], keep_graphs="no", workers=0, progress=False)
    for formats in ("", [], ","):
        with pytest.raises(ValueError, match="formats: expected at least one"):
            build_graphs([occ], out_dir=tmp_path, formats=formats, workers=0, progress=False)
    # a format that is no name is refused as what it is, not as its str() ("3", "106")
    for formats, received in ((["json", 3], "int 3"), (b"json", "int 106"), ([None], "None")):
        with pytest.raises(TypeError, match=rf"^formats: expected format names .*{received}"):
            build_graphs([occ], formats=formats, workers=0, progress=False)
    rec = build_graphs([tmp_path], workers=0, progress=False)[0]
    assert rec.status == "error" and "is a folder" in rec.message
    assert "expand_map_inputs" in rec.message


def test_empty_graphs_are_reported_with_a_reason(tmp_path, capsys):
    """A map whose graph is empty (here: an IPA-style raw map read without --mode ipa, so
    nothing counts as an obstacle) is reported ``empty`` with what to check, not ``ok``."""
    import cv2

    from topojax.cli import main

    raw = np.full((40, 50), 200, np.uint8)  # grey everywhere: unknown in trinary mode
    raw[10:30, 10:40] = 255
    cv2.imwrite(str(tmp_path / "raw.png"), raw)
    records = build_graphs([tmp_path / "raw.png"], progress=False, workers=0)
    assert records[0].status == "empty" and records[0].vertices == 0
    message = records[0].message
    assert "no occupied pixel" in message and "map_mode, e.g. 'ipa'" in message
    assert "occupied_thresh, free_thresh, negate" in message and "--" not in message
    assert (
        main(
            [
                "batch",
                str(tmp_path / "raw.png"),
                "-o",
                str(tmp_path / "out"),
                "--no-progress",
                "--workers",
                "0",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert "1 empty" in captured.out and "empty    raw:" in captured.err
    assert "(--occupied-thresh, --free-thresh, --negate)" in captured.err
    assert "(--mode, e.g. 'ipa'" in captured.err and "map_mode" not in captured.err
    summary = (tmp_path / "out" / "summary.csv").read_text()
    assert ",empty," in summary and "--mode" in summary


def test_a_graph_emptied_by_pruning_says_so_not_that_no_corridor_was_found(tmp_path, capsys):
    """A map whose corridors are all removed by the pruning options is ``empty`` with the
    options that removed them named (the keyword in the record, the option on the
    command line), not told that no corridor was found or to check its thresholds."""
    import cv2

    from topojax.cli import main
    from topojax.config import GraphConfig

    occ = _synthetic((120, 160), 3, source="rooms")
    config = PipelineConfig(graph=GraphConfig(min_component_m=1000.0))
    (rec,) = build_graphs([occ], workers=0, config=config, progress=False)
    assert rec.status == "empty" and rec.vertices == 0
    assert "min_component_m" in rec.message and "removed every corridor" in rec.message
    assert "no corridor was found" not in rec.message and "thresholds" not in rec.message
    (plain,) = build_graphs([occ], workers=0, progress=False)  # the map gives corridors
    assert plain.status == "ok" and plain.vertices > 0

    cv2.imwrite(str(tmp_path / "rooms.png"), np.where(occ.occupied, 0, 255).astype(np.uint8))
    args = ["batch", str(tmp_path / "rooms.png"), "-o", str(tmp_path / "out")]
    args += ["--no-progress", "--workers", "0", "--min-component-m", "1000"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "empty    rooms: empty graph: --min-component-m=1000 removed every corridor" in err
    assert "no corridor was found" not in err and "min_component_m" not in err


def test_a_graph_emptied_by_free_space_only_says_so(tmp_path, capsys):
    """A map whose corridors all run through unknown space gives no graph with
    ``free_space_only`` (``--free-only``): its reason says so, not that no corridor was
    found between the obstacles."""
    import cv2

    from topojax.cli import main
    from topojax.config import GraphConfig

    pixels = np.full((100, 120), 205, np.uint8)  # unknown, but for walls and a free corner
    pixels[[0, -1], :] = pixels[:, [0, -1]] = pixels[50, 10:110] = 0
    pixels[2:6, 2:6] = 254
    cv2.imwrite(str(tmp_path / "hall.png"), pixels)
    config = PipelineConfig(graph=GraphConfig(free_space_only=True))
    (rec,) = build_graphs([tmp_path / "hall.png"], workers=0, config=config, progress=False)
    assert rec.status == "empty"
    assert "every corridor the map gave runs through unknown space" in rec.message
    assert "free_space_only" in rec.message and "no corridor was found" not in rec.message
    argv = ["batch", str(tmp_path / "hall.png"), "-o", str(tmp_path / "out"), "--no-progress"]
    assert main([*argv, "--workers", "0", "--free-only"]) == 0
    err = capsys.readouterr().err
    assert "which --free-only leaves out" in err and "free_space_only" not in err


def test_a_resumed_batch_prints_the_maps_it_skips_that_were_empty(tmp_path, capsys):
    """``topojax batch --resume`` prints the line of a map it skips whose earlier run found
    its graph empty, with why, as it prints a skipped map's warning: the user of a resumed
    (e.g. interrupted) run learns of every empty map, not of this run's only."""
    import cv2

    from topojax.cli import main

    occ = _synthetic((80, 100), 7)
    cv2.imwrite(str(tmp_path / "rooms.png"), np.where(occ.occupied, 0, 255).astype(np.uint8))
    argv = ["batch", str(tmp_path / "rooms.png"), "-o", str(tmp_path / "out"), "--no-progress"]
    argv += ["--workers", "0", "--min-component-m", "1000", "--resolution", "0.05"]
    assert main(argv) == 0
    assert "empty    rooms: empty graph: --min-component-m=1000" in capsys.readouterr().err
    assert main([*argv, "--resume"]) == 0
    captured = capsys.readouterr()
    assert "0 empty, 1 skipped" in captured.out
    assert (
        "skipped  rooms: outputs complete (resume) of an empty map: empty graph: "
        "--min-component-m=1000 removed every corridor"
    ) in captured.err


def test_a_bad_yaml_field_is_named_as_the_file_names_it(tmp_path, capsys):
    """An error row names a map YAML's field as the file spells it (``occupied_thresh``),
    not as the option of the same setting: the file is at fault."""
    import shutil

    from topojax.cli import main

    shutil.copy(PAPER_MAPS[0], tmp_path / "m.png")
    (tmp_path / "m.yaml").write_text(
        "image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 2\n"
    )
    args = ["batch", str(tmp_path / "m.yaml"), "-o", str(tmp_path / "out"), "--workers", "0"]
    assert main([*args, "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "'occupied_thresh'" in err and "--occupied-thresh" not in err, err


def test_resume_keeps_what_the_first_run_said_of_empty_and_warned_maps(tmp_path):
    """A map skipped by resume is ``skipped``, and its row still says that the map was
    empty and why, or its warning: the summary after a resumed (e.g. interrupted) run
    must not hide them."""
    import cv2

    raw = np.full((40, 50), 200, np.uint8)  # unknown everywhere but a hall: empty graph
    raw[10:30, 10:40] = 255
    cv2.imwrite(str(tmp_path / "raw.png"), raw)
    grey = np.full((120, 160), 205, np.uint8)  # walls that read as unknown: a warning
    grey[10:110, 10:150] = 254
    grey[8:10, 20:60] = 0
    cv2.imwrite(str(tmp_path / "grey.png"), grey)
    (tmp_path / "plain.png").write_bytes(PAPER_MAPS[2].read_bytes())
    paths = [tmp_path / n for n in ("raw.png", "grey.png", "plain.png")]
    out = tmp_path / "out"
    first = build_graphs(paths, out_dir=out, workers=0, progress=False)
    assert [r.status for r in first] == ["empty", "ok", "ok"]
    assert first[1].message.startswith("warning:") and first[2].message == ASSUMED
    again = build_graphs(paths, out_dir=out, workers=0, progress=False, resume=True)
    assert [r.status for r in again] == ["skipped"] * 3
    assert again[0].message == f"outputs complete (resume) of an empty map: {first[0].message}"
    assert again[1].message == f"outputs complete (resume); {first[1].message}"
    assert again[2].message == f"outputs complete (resume); {ASSUMED}"
    rows = _read_summary(out)
    assert [r["message"] for r in rows] == [r.message for r in again]


def test_grey_walls_are_flagged_with_a_warning(tmp_path, capsys):
    """A map whose walls read as unknown (grey) builds, but its row says why the graph
    may be odd, the summary counts it, and ``topojax graph`` notes it too."""
    import cv2

    from topojax.cli import main
    from topojax.maps.classify import wall_share

    img = np.full((120, 160), 205, np.uint8)  # unknown all round
    img[10:110, 10:150] = 254  # a free hall
    img[10:110, 78:82] = 205  # a grey wall through it, with a door
    img[55:65, 78:82] = 254
    img[8:10, 20:60] = 0  # one stretch of black wall
    path = tmp_path / "grey.png"
    cv2.imwrite(str(path), img)
    occ = load_map(path)
    assert 0 < wall_share(occ.occupied, occ.free) < 0.1
    records = build_graphs([path], out_dir=tmp_path / "out", workers=1)
    assert records[0].status == "ok" and records[0].message.startswith("warning: only ")
    assert "check occupied_thresh, free_thresh or map_mode" in records[0].message
    assert main(["batch", str(path), "-o", str(tmp_path / "cli"), "--workers", "1"]) == 0
    err = capsys.readouterr()
    assert "1 with a warning" in err.out and "grey" in err.err
    assert "check --occupied-thresh, --free-thresh or --mode" in err.err
    assert main(["graph", str(path), "-o", str(tmp_path / "g")]) == 0
    out = capsys.readouterr().out
    assert "are the walls drawn in grey? check --occupied-thresh, --free-thresh or --mode" in out


def test_an_empty_graph_with_the_nav2_format_is_empty_not_an_error(tmp_path):
    """With ``--formats ...,nav2``, a map whose graph has no edge (all unknown, all
    occupied) is ``empty`` with its reason, not ``status=error`` ("the Nav2 Route Server
    rejects a graph without edges") with its other files missing; as for the route
    graph's Nav2 file, it gets no Nav2 file; the other maps' are written."""
    import cv2

    cv2.imwrite(str(tmp_path / "unknown.png"), np.full((60, 60), 205, np.uint8))
    cv2.imwrite(str(tmp_path / "walls.png"), np.zeros((60, 60), np.uint8))
    (tmp_path / "office.png").write_bytes(PAPER_MAPS[1].read_bytes())
    maps = [tmp_path / "unknown.png", tmp_path / "walls.png", tmp_path / "office.png"]
    out = tmp_path / "out"
    kw = {"workers": 0, "progress": False, "out_dir": out, "formats": "json,nav2"}
    unknown, walls, office = build_graphs(maps, **kw)
    assert (unknown.status, walls.status, office.status) == ("empty", "empty", "ok")
    assert "no occupied and no free pixel" in unknown.message and "empty graph" in walls.message
    assert "no Nav2 file" in unknown.message and "no Nav2 file" in walls.message
    assert (out / "unknown.json").is_file() and (out / "walls.json").is_file()
    assert not (out / "unknown_nav2.geojson").exists()
    assert (out / "office_nav2.geojson").is_file()
    again = build_graphs(maps, resume=True, **kw)  # complete without a Nav2 file
    assert [r.status for r in again] == ["skipped"] * 3


def test_a_map_without_either_nav2_file_says_so_once_naming_both(tmp_path):
    """With both Nav2 formats, a map whose graph and route graph have no edge is told once
    that it gets no Nav2 file, with the files it does not get named: not the same note
    twice, which leaves the user to guess which file each is about."""
    walls = np.ones((60, 60), bool)
    occ = OccupancyMap(
        occupied=walls,
        free=np.zeros_like(walls),
        unknown=np.zeros_like(walls),
        resolution_m=0.05,
        origin=(0.0, 0.0, 0.0),
        source="walls",
    )
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "formats": "nav2,route_nav2"}
    (rec,) = build_graphs([occ], **kw)
    assert rec.status == "empty"
    assert rec.message.count("the Route Server needs an edge") == 1
    assert "no Nav2 file walls_nav2.geojson or walls_route_nav2.geojson (" in rec.message
    assert not (tmp_path / "walls_nav2.geojson").exists()
    assert not (tmp_path / "walls_route_nav2.geojson").exists()


def test_out_dir_and_bucket_are_checked_before_any_map_runs():
    """``out_dir`` must be a path (an int is named, not left to fail in ``pathlib``
    naming no option), and ``tiles_per_call`` is bounded as for :class:`PipelineConfig`
    (a huge bucket would fail every map with a MemoryError)."""
    occ = OccupancyMap.from_array(np.eye(16, dtype=bool))
    with pytest.raises(TypeError, match=r"out_dir: expected a path \(str or os.PathLike\), "):
        build_graphs([occ], workers=0, progress=False, out_dir=3)
    with pytest.raises(ValueError, match="tiles_per_call: expected an int from 1 to 4096"):
        build_graphs([occ], workers=0, progress=False, tiles_per_call=10**6)


def test_a_map_read_at_an_assumed_resolution_says_so_in_its_record_not_a_warning(tmp_path):
    """load_map warns of a resolution it assumes; a batch notes it in the map's record
    instead (a warning from each worker process would repeat on stderr), and a map whose
    file states its resolution gets no note."""
    import cv2

    grid = np.full((60, 60), 254, np.uint8)
    grid[[0, -1], :] = 0
    grid[:, [0, -1]] = 0
    grid[30, 10:50] = 0
    cv2.imwrite(str(tmp_path / "plain.png"), grid)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plain, given = build_graphs(
            [tmp_path / "plain.png", load_map(tmp_path / "plain.png", resolution_m=0.1)],
            workers=0,
            progress=False,
        )
    assert plain.message == ASSUMED
    assert given.message == "" and given.resolution_m == 0.1


def test_a_batch_assumes_no_resolution_where_a_pgm_comment_is_refused(tmp_path):
    """A batch gives load_map the resolution it would assume, so that no thread or
    worker warns; a PGM comment load_map refuses (a decimal comma) stays an error row,
    not a map read at the assumed 0.05 m/px, and the warnings filters are as before."""
    grid = np.full((40, 40), 254, np.uint8)
    grid[[0, -1], :] = 0
    grid[:, [0, -1]] = 0
    grid[20, 5:35] = 0
    bad = tmp_path / "comma.pgm"
    bad.write_bytes(b"P5\n# CREATOR: map_saver.cpp 0,05 m/pix\n40 40\n255\n" + grid.tobytes())
    plain = tmp_path / "plain.pgm"
    plain.write_bytes(b"P5\n40 40\n255\n" + grid.tobytes())
    filters = list(warnings.filters)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        refused, assumed = build_graphs([bad, plain] * 4, workers=0, progress=False)[:2]
    assert refused.status == "error" and "not a positive number" in refused.message
    assert assumed.status == "ok" and assumed.message == ASSUMED
    assert list(warnings.filters) == filters


def test_a_batch_notes_a_resolution_that_replaces_the_files_own(tmp_path):
    """A resolution given for every map file (``topojax batch --resolution``) that
    replaces the one a YAML or a PGM comment states makes every length and area scale:
    the map's note names the file's own; the same one, or none given, is no note."""
    from topojax.batch.worker import resolution_note

    grid = np.full((40, 40), 254, np.uint8)
    pgm = tmp_path / "stated.pgm"
    pgm.write_bytes(b"P5\n# CREATOR: map_saver.cpp 0.100 m/pix\n40 40\n255\n" + grid.tobytes())
    yaml = tmp_path / "stated.yaml"
    yaml.write_text("image: stated.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", encoding="utf-8")
    for path in (pgm, yaml):
        assert resolution_note(path, {"resolution_m": 0.05}, 0.05) == [
            "0.05 m/px from map_options' resolution_m: the file states 0.1"
        ]
        assert resolution_note(path, {"resolution_m": 0.1}, 0.1) == []
        assert resolution_note(path, {}, 0.1) == []
    assert resolution_note(None, {"resolution_m": 0.05}, 0.05) == []  # a loaded map


def test_an_empty_map_read_as_ipa_is_not_told_to_try_ipa(tmp_path):
    """The reason of an empty map suggests the IPA pixel convention only to a batch that
    did not read the map with it."""
    import cv2

    cv2.imwrite(str(tmp_path / "grey.png"), np.full((40, 40), 200, np.uint8))
    kw = {"workers": 0, "progress": False}
    plain = build_graphs([tmp_path / "grey.png"], **kw)[0]
    ipa = build_graphs([tmp_path / "grey.png"], map_mode="ipa", **kw)[0]
    assert plain.status == ipa.status == "empty"
    assert "e.g. 'ipa'" in plain.message
    assert "ipa" not in ipa.message and "pixel convention (map_mode)" in ipa.message
