"""A batch's rooms format: its status (judged by the rooms where only rooms are asked for)
and its room settings (room_config, the room options of topojax batch)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import topojax as tj
from topojax import RoomConfig
from topojax.batch import build_graphs


def _hall(*, walls: bool) -> tj.OccupancyMap:
    """A 4.5 x 4.5 m free square, closed by walls or by unknown space only."""
    free = np.zeros((100, 100), bool)
    free[5:95, 5:95] = True
    other = ~free
    occupied = other if walls else np.zeros_like(free)
    unknown = np.zeros_like(free) if walls else other
    return tj.OccupancyMap(
        occupied=occupied, free=free, unknown=unknown, resolution_m=0.05, source="hall"
    )


def test_only_rooms_asked_for_ignore_the_papers_graph(tmp_path):
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path}
    (rooms_only,) = build_graphs([_hall(walls=False)], formats="rooms", **kw)
    assert rooms_only.vertices == 0 and rooms_only.rooms == 1  # no obstacle: no graph
    assert rooms_only.status == "ok" and "empty graph" not in rooms_only.message
    (both,) = build_graphs([_hall(walls=False)], formats="json,rooms", **kw)
    assert both.status == "empty" and "no occupied pixel" in both.message


def test_a_map_without_rooms_is_empty_and_says_why(tmp_path):
    free = np.zeros((40, 40), bool)
    free[5:15, 5:15] = True  # 0.25 m2: below the smallest room without a doorway
    speck = tj.OccupancyMap(
        occupied=~free, free=free, unknown=np.zeros_like(free), resolution_m=0.05, source="speck"
    )
    kw = {"workers": 0, "progress": False, "out_dir": tmp_path}
    for formats in ("rooms", "json,rooms"):
        (rec,) = build_graphs([speck], formats=formats, **kw)
        assert rec.rooms == 0 and rec.status == "empty", formats
        assert "no room found: the map has 100 free pixels" in rec.message, formats
        assert "without doorways (min_isolated_room_m2)" in rec.message, formats
    (walled,) = build_graphs([_hall(walls=True)], formats="json,rooms", **kw)
    assert walled.rooms == 1 and walled.status == "ok"


def _three_rooms_png(tmp_path):
    """The three rooms as an IPA-style PNG, the output folder and the arguments of
    ``topojax batch`` for it (IPA pixel convention, in process), formats to add."""
    from room_maps import three_rooms_png

    png = three_rooms_png(tmp_path / "maps" / "three.png")
    out = tmp_path / "out"
    argv = ["batch", str(png), "-o", str(out), "--mode", "ipa", "--workers", "0"]
    return png, out, [*argv, "--no-progress"]


def _summary_rows(out) -> list[dict]:
    return list(csv.DictReader((out / "summary.csv").read_text().splitlines()))


def test_room_config_sets_the_rooms_written(tmp_path):
    from room_maps import three_rooms

    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "formats": "rooms"}
    (default,) = build_graphs([three_rooms()], **kw)
    assert default.rooms == 3
    large = RoomConfig(min_room_m2=8.0)
    (merged,) = build_graphs([three_rooms()], room_config=large, **kw)
    want = tj.segment_rooms(three_rooms(), config=large)
    assert merged.status == "ok" and merged.rooms == want.n_rooms < default.rooms
    assert merged.doors == len(want.doors)
    (geojson,) = tmp_path.glob("*_rooms.geojson")
    rooms, doors = tj.load_rooms(geojson)
    assert (len(rooms), len(doors)) == (want.n_rooms, len(want.doors))


def test_resume_redoes_a_map_whose_room_settings_differ(tmp_path):
    from room_maps import three_rooms

    kw = {"workers": 0, "progress": False, "out_dir": tmp_path, "formats": "json,rooms"}
    (first,) = build_graphs([three_rooms()], **kw)
    assert first.status == "ok" and first.rooms == 3
    # RoomConfig's defaults are the settings of a batch run without room_config
    (same,) = build_graphs([three_rooms()], resume=True, room_config=RoomConfig(), **kw)
    assert same.status == "skipped" and same.rooms == 3
    large = RoomConfig(min_room_m2=8.0)
    (redone,) = build_graphs([three_rooms()], resume=True, room_config=large, **kw)
    assert redone.status == "ok" and redone.rooms == 1
    (again,) = build_graphs([three_rooms()], resume=True, room_config=large, **kw)
    assert again.status == "skipped" and again.rooms == 1
    (back,) = build_graphs([three_rooms()], resume=True, **kw)
    assert back.status == "ok" and back.rooms == 3


def test_room_config_is_checked(tmp_path):
    from room_maps import three_rooms

    kw = {"workers": 0, "progress": False, "out_dir": tmp_path}
    with pytest.raises(TypeError, match="room_config: expected a RoomConfig"):
        build_graphs([three_rooms()], formats="rooms", room_config={"min_room_m2": 8.0}, **kw)
    with pytest.raises(ValueError, match="room_config: only used with the format rooms"):
        build_graphs([three_rooms()], formats="json", room_config=RoomConfig(), **kw)
    assert not list(tmp_path.iterdir())


def test_the_rooms_format_needs_a_folder():
    from room_maps import three_rooms

    # rooms are written, not kept in the records: without a folder they would be lost
    with pytest.raises(ValueError, match=r"^out_dir: expected a folder .*'rooms'.* None$"):
        build_graphs([three_rooms()], formats="rooms,json", workers=0, progress=False)


def test_batch_command_takes_the_room_options(tmp_path, capsys):
    from topojax.cli import main

    png, out, argv = _three_rooms_png(tmp_path)
    assert main([*argv, "--formats", "rooms", "--min-room-m2", "8"]) == 0
    occupancy = tj.load_map(png, mode="ipa")
    want = tj.segment_rooms(occupancy, config=RoomConfig(min_room_m2=8.0))
    (row,) = _summary_rows(out)
    assert (row["status"], int(row["rooms"])) == ("ok", want.n_rooms)
    assert want.n_rooms < tj.segment_rooms(occupancy).n_rooms
    assert main([*argv, "--formats", "rooms", "--min-room-m2", "8", "--resume"]) == 0
    assert _summary_rows(out)[0]["status"] == "skipped"
    assert main([*argv, "--formats", "rooms", "--resume"]) == 0
    (row,) = _summary_rows(out)
    assert (row["status"], int(row["rooms"])) == ("ok", 3)
    capsys.readouterr()
    none = ["--min-room-m2", "100", "--min-isolated-room-m2", "100"]
    assert main([*argv, "--formats", "rooms", *none]) == 0
    (row,) = _summary_rows(out)
    assert (row["status"], int(row["rooms"])) == ("empty", 0)
    for message in (capsys.readouterr().err, row["message"]):
        assert "without doorways (--min-isolated-room-m2)" in message


def test_batch_command_refuses_room_options_it_cannot_use(tmp_path, capsys):
    from topojax.cli import main

    _, out, argv = _three_rooms_png(tmp_path)
    capsys.readouterr()
    assert main([*argv, "--formats", "json", "--min-room-m2", "8"]) == 2
    err = capsys.readouterr().err
    assert "--min-room-m2: only used with the format rooms" in err and "'json'" in err
    assert main([*argv, "--formats", "rooms", "--min-room-m2", "-1"]) == 2
    err = capsys.readouterr().err
    assert "--min-room-m2:" in err and "min_room_m2" not in err
    assert main([*argv, "--formats", "rooms", "--min-door-width-m", "3"]) == 2
    err = capsys.readouterr().err
    assert "--min-door-width-m, --max-door-width-m:" in err and "_width_m" not in err
    assert not out.exists()
