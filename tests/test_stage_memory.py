"""The map-sized stages (``build_graph``, ``segment_rooms``, ``route_graph``) refuse a map
whose floor (bytes per map pixel, ``topojax/_stage_memory.py``) times its pixels exceeds
the memory available, before any map-sized work, with a message naming the stage, the
map's size, the need and the memory available; the callers that run them for many maps
or scans keep going."""

from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest

import topojax as tj
import topojax._cpus as cpus
import topojax._stage_memory as stage_memory
from topojax._cpus import MemoryRefusal
from topojax.datasets import sample_map, sample_map_path
from topojax.scans import read_carmen

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"

FLOORS = {
    "build_graph": stage_memory.BUILD_GRAPH_BYTES_PER_PX,
    "segment_rooms": stage_memory.SEGMENT_ROOMS_BYTES_PER_PX,
    "route_graph": stage_memory.ROUTE_GRAPH_BYTES_PER_PX,
}
ARGUMENT = {"build_graph": "occupancy", "segment_rooms": "source", "route_graph": "occupancy"}
ADVICE = {
    "build_graph": "; build it block by block with build_graph_tiled (topojax graph "
    "--tiled), which gives the same graph (docs/large-maps.md)",
    "segment_rooms": stage_memory.SMALLER_MAP,
    "route_graph": stage_memory.SMALLER_MAP,
}


def _memory(monkeypatch, available: int | None) -> None:
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: available)


def _run(stage: str, occupancy):
    return getattr(tj, stage)(occupancy)


def _need(stage: str, shape) -> int:
    return int(FLOORS[stage] * shape[0] * shape[1])


@pytest.mark.parametrize("stage", list(FLOORS))
def test_a_stage_refuses_a_map_its_floor_does_not_fit_and_runs_one_it_does(monkeypatch, stage):
    occ = sample_map("a_scan")
    need = _need(stage, occ.shape)
    _memory(monkeypatch, need - 1)
    with pytest.raises(MemoryRefusal) as info:
        _run(stage, occ)
    h, w = occ.shape
    assert str(info.value) == (
        f"{stage}: {ARGUMENT[stage]} of {h} x {w} pixels takes at least {FLOORS[stage]:g} "
        f"bytes a pixel beyond the map, {need / 2**20:,.1f} MiB, more than the "
        f"{(need - 1) / 2**20:,.1f} MiB of memory available{ADVICE[stage]}"
    )
    _memory(monkeypatch, need)
    assert _run(stage, occ) is not None


def test_the_need_is_the_floor_times_the_pixels(monkeypatch):
    _memory(monkeypatch, 4 << 30)
    with pytest.raises(MemoryRefusal) as info:
        stage_memory.check_stage_fits("stage", "occupancy", (40_000, 50_000), 4.0, "; advice")
    assert str(info.value) == (
        "stage: occupancy of 40000 x 50000 pixels takes at least 4 bytes a pixel beyond the "
        "map, 7.5 GiB, more than the 4.0 GiB of memory available; advice"
    )


@pytest.mark.parametrize("stage", list(FLOORS))
def test_without_a_known_memory_size_nothing_is_refused(monkeypatch, stage):
    _memory(monkeypatch, None)  # not Linux
    assert _run(stage, sample_map("a_scan")) is not None


@pytest.mark.parametrize("stage", list(FLOORS))
def test_a_normal_map_fits_the_memory_this_machine_has(stage):
    assert cpus.available_memory_bytes() is not None  # the check is live here (Linux)
    assert _run(stage, sample_map("a_scan")) is not None


@pytest.mark.parametrize(
    "call, error",
    [
        (lambda occ: tj.build_graph(occ, config="x"), TypeError),
        (lambda occ: tj.segment_rooms(occ, config="x"), TypeError),
        (lambda occ: tj.route_graph(occ, robot_radius_m=-1.0), ValueError),
        (lambda occ: tj.route_graph(occ, robot_radius_m=0.01), ValueError),  # < 1.5 px
    ],
)
def test_a_bad_argument_is_named_before_the_memory_is_weighed(monkeypatch, call, error):
    occ = sample_map("a_scan")
    _memory(monkeypatch, 0)
    with pytest.raises(error):
        call(occ)


@pytest.mark.parametrize(
    "command, stage",
    [("graph", "build_graph"), ("rooms", "segment_rooms"), ("route-graph", "route_graph")],
)
def test_the_command_line_prints_the_refusal(tmp_path, monkeypatch, capsys, command, stage):
    from topojax.cli import main

    # a binary PGM: memory-mapped, not decoded; its classes (4 bytes a pixel) fit, and
    # what they leave does not fit the stage
    path = tmp_path / "a_scan.pgm"
    assert cv2.imwrite(str(path), cv2.imread(str(sample_map_path("a_scan")), 0))
    h, w = tj.load_map(path).shape
    answers = iter([4 * h * w])  # the first question is load_map's
    left = _need(stage, (h, w)) - 1
    monkeypatch.setattr(cpus, "available_memory_bytes", lambda: next(answers, left))
    assert main([command, str(path), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"topojax {command}: error: {stage}: ")
    assert "MiB of memory available; " in err
    assert "out of memory" not in err and "Traceback" not in err


def test_the_mapper_keeps_mapping_when_its_rooms_do_not_fit(monkeypatch):
    """A due room update refused for memory does not fail the scan that made it due:
    the rooms stay as they were with a warning (once); asking for fresh rooms, or for
    the route graph, raises the refusal."""
    scans = list(read_carmen(INTEL_EXCERPT))
    mapper = tj.IncrementalMapper(skeleton_every=2, graph_every=2, rooms_local=False)
    for s in scans[:6]:
        mapper.add_scan(s)
    rooms = mapper.rooms
    _memory(monkeypatch, 1)
    with pytest.warns(RuntimeWarning, match=r"^scan 7: rooms not updated.*segment_rooms: "):
        mapper.add_scan(scans[6])
        report = mapper.add_scan(scans[7])
    assert mapper.n_scans == 8 and "graph" in report.loops and report.rooms_update is None
    assert mapper.rooms is rooms
    with warnings.catch_warnings(record=True) as caught:  # the next due update: no repeat
        warnings.simplefilter("always")
        mapper.add_scan(scans[8])
        mapper.add_scan(scans[9])
    assert not caught
    with pytest.raises(MemoryRefusal, match=r"^segment_rooms: source of "):
        mapper.update_rooms()
    with pytest.raises(MemoryRefusal, match=r"^route_graph: occupancy of "):
        mapper.route_graph()
    _memory(monkeypatch, None)
    assert mapper.update_rooms() is not None


def _hall(side: int) -> tj.OccupancyMap:
    occ = np.ones((side, side), bool)
    occ[2:-2, 2:-2] = False
    occ[side // 2, 2 : side // 2] = True  # a wall half across
    return tj.OccupancyMap(occupied=occ, free=~occ, unknown=np.zeros_like(occ))


@pytest.mark.parametrize("fmt, stage", [("rooms", "segment_rooms"), ("route", "route_graph")])
def test_a_batch_reports_the_refusal_for_that_map_and_goes_on(tmp_path, monkeypatch, fmt, stage):
    small, large = _hall(120), _hall(400)
    _memory(monkeypatch, _need(stage, large.shape) - 1)  # the small map fits
    records = tj.build_graphs(
        [large, small],
        workers=0,
        out_dir=tmp_path / "out",
        formats=("json", fmt),
        progress=False,
    )
    assert [r.status for r in records] == ["error", "ok"]
    assert records[0].message.startswith(f"MemoryRefusal: {stage}: ")
    assert "400 x 400 pixels" in records[0].message


def test_a_local_room_update_holds_each_window_to_the_floor(monkeypatch):
    """A local room update segments windows of the map, each held to the floor of
    ``segment_rooms``: one that fits is segmented although the whole map would not fit,
    one that does not is refused as the whole map is (the map is kept, the rooms stay as
    they were; ``update_rooms`` raises the refusal)."""
    hall = _hall(600)
    mapper = tj.IncrementalMapper(graph_every=None, skeleton_every=None, rooms_local=True)
    mapper.add_map(hall)
    mapper.update_rooms()  # the first update segments the whole map
    kept = mapper._rooms.labels.copy()
    pillar = np.zeros(hall.shape, bool)
    pillar[100:104, 450:454] = True  # far from the wall half across
    mapper.add_map(tj.OccupancyMap(occupied=pillar, free=np.zeros_like(pillar), unknown=~pillar))
    whole = _need("segment_rooms", mapper.occupancy.shape)
    _memory(monkeypatch, 1024)  # less than any window needs
    with pytest.raises(MemoryRefusal, match=r"^segment_rooms: window of \d+ x \d+ pixels "):
        mapper.update_rooms()
    np.testing.assert_array_equal(mapper._rooms.labels, kept)
    _memory(monkeypatch, whole - 1)  # the whole map does not fit, its windows do
    update = mapper.update_rooms()
    assert 0 < update.segmented_px < mapper.occupancy.free.size / 4
    assert not mapper.rooms.labels[100:104, 450:454].any()
