"""The map options (``--resolution``, ``--occupied-thresh``, ``--free-thresh``,
``--negate``, ``--mode``): every command that reads a map file takes them and reads the
map with them, ``batch`` in its worker processes and for every map alike."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from room_maps import three_rooms_occupied, three_rooms_png

from topojax import load_graph
from topojax.cli import main

#: What reads :func:`_grey_occupancy_png` as the map of :func:`three_rooms_png`, at 0.1 m/px.
READ_AS_THREE_ROOMS = [
    *("--negate", "--occupied-thresh", "0.6", "--free-thresh", "0.3", "--resolution", "0.1")
]


def _grey_occupancy_png(path: Path) -> Path:
    """The three rooms as an image of occupancy (walls 155, free space 60): read with
    ``--negate``, ``--occupied-thresh 0.6`` and ``--free-thresh 0.3``, the map of
    :func:`three_rooms_png`; with the default thresholds every pixel is unknown, and
    without ``--negate`` the free space is occupied."""
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.where(three_rooms_occupied(), 155, 60).astype(np.uint8))
    return path


def _graph_doc(path: Path) -> dict:
    """A JSON graph file's document without the map file it names."""
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["graph"].pop("source", None)
    return doc


def _rows(out: Path) -> list[dict]:
    with open(out / "summary.csv", newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize(
    ("command", "written"),
    [("graph", "{}.json"), ("rooms", "{}_rooms.json"), ("route-graph", "{}_route.json")],
)
def test_a_command_reads_its_map_with_the_map_options(tmp_path, command, written):
    """The grey image of occupancy read with the map options gives the graph of the
    plain map, for every command that reads a map."""
    plain = three_rooms_png(tmp_path / "plain.png")
    grey = _grey_occupancy_png(tmp_path / "grey.png")
    assert main([command, str(plain), "-o", str(tmp_path / "a"), "--resolution", "0.1"]) == 0
    assert main([command, str(grey), "-o", str(tmp_path / "b"), *READ_AS_THREE_ROOMS]) == 0
    want = load_graph(tmp_path / "a" / written.format("plain"))
    assert want.number_of_nodes() and want.graph["resolution_m"] == 0.1
    assert _graph_doc(tmp_path / "b" / written.format("grey")) == _graph_doc(
        tmp_path / "a" / written.format("plain")
    )


def test_no_negate_reads_a_yaml_that_says_negate_as_it_is(tmp_path, capsys):
    """``--no-negate`` overrides a YAML's ``negate: 1`` (``--negate`` sets it where the
    file does not): a map whose YAML says so wrongly is still readable."""
    plain = three_rooms_png(tmp_path / "plain.png")
    (tmp_path / "wrong.yaml").write_text(
        "image: plain.png\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 1\n", encoding="utf-8"
    )
    assert main(["graph", str(plain), "-o", str(tmp_path / "a"), "--resolution", "0.1"]) == 0
    argv = ["graph", str(tmp_path / "wrong.yaml")]
    assert main([*argv, "-o", str(tmp_path / "b"), "--no-negate"]) == 0
    assert main([*argv, "-o", str(tmp_path / "c")]) == 0  # the file's negate: another map
    want = _graph_doc(tmp_path / "a" / "plain.json")
    assert _graph_doc(tmp_path / "b" / "wrong.json")["nodes"] == want["nodes"]
    assert _graph_doc(tmp_path / "c" / "wrong.json")["nodes"] != want["nodes"]
    assert main([*argv, "-o", str(tmp_path / "d"), "--negate", "--no-negate"]) == 0  # last
    capsys.readouterr()


def test_batch_reads_every_map_with_the_map_options(tmp_path, capsys):
    """Every map option reaches the batch's worker processes that read the maps, each
    map's manifest records them, ``--resume`` redoes a map read with other ones, and
    ``topojax view`` reads the map with them."""
    plain = three_rooms_png(tmp_path / "in" / "plain.png")
    grey = _grey_occupancy_png(tmp_path / "in" / "grey.png")
    want = tmp_path / "want"
    assert main(["batch", str(plain), "-o", str(want), "--resolution", "0.1", "--no-progress"]) == 0
    out = tmp_path / "out"
    argv = ["batch", str(grey), "-o", str(out), "--no-progress"]
    assert main([*argv, *READ_AS_THREE_ROOMS, "--workers", "1"]) == 0  # read by a worker
    ((a,), (b,)) = _rows(want), _rows(out)
    assert (b["status"], b["resolution_m"], b["message"]) == ("ok", "0.1", "")
    counts = ("vertices", "edges", "components", "total_length_m")
    assert int(a["vertices"]) and [b[k] for k in counts] == [a[k] for k in counts]
    manifest = json.loads((out / "grey.manifest.json").read_text(encoding="utf-8"))
    assert manifest["request"]["map_options"] == {
        "free_thresh": 0.3,
        "negate": True,
        "occupied_thresh": 0.6,
        "resolution_m": 0.1,
    }
    assert main([*argv, *READ_AS_THREE_ROOMS, "--resume"]) == 0
    assert _rows(out)[0]["status"] == "skipped"
    coarser = [*READ_AS_THREE_ROOMS[:-1], "0.2"]
    assert main([*argv, *coarser, "--resume"]) == 0
    ((c,),) = (_rows(out),)
    assert (c["status"], c["resolution_m"]) == ("ok", "0.2")
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"graph grey.json, map {grey.resolve()}" in printed and "graph only" not in printed


def test_batch_says_when_a_maps_resolution_was_assumed(tmp_path, capsys):
    """A map file that states no resolution (a PNG) is read at 0.05 m/px, and without
    ``--resolution`` its message says so, printed and in the summary table, as
    ``topojax graph`` says it on its map line; a YAML states its own."""
    png = three_rooms_png(tmp_path / "in" / "plain.png")
    three_rooms_png(tmp_path / "in" / "stated.png")
    (tmp_path / "in" / "stated.yaml").write_text(
        "image: stated.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n", encoding="utf-8"
    )
    out = tmp_path / "out"
    yaml = tmp_path / "in" / "stated.yaml"
    assert main(["batch", str(png), str(yaml), "-o", str(out), "--no-progress"]) == 0
    note = "0.05 m/px assumed: the file states none; --resolution sets it"
    rows = {r["map"]: r for r in _rows(out)}
    assert rows["plain"]["message"] == note and rows["stated"]["message"] == ""
    assert rows["plain"]["status"] == rows["stated"]["status"] == "ok"
    captured = capsys.readouterr()
    assert "1 with a warning" in captured.out
    assert captured.err.splitlines() == [f"  ok       plain: {note}"]


def test_batch_says_when_resolution_replaces_a_maps_own(tmp_path, capsys):
    """``--resolution`` that replaces the resolution a map file states (every length and
    area then scales) is named in that map's message, printed and in the summary table,
    as ``topojax graph`` names it on its map line; the map stays ok, and one given the
    same as the file's gets no remark."""
    three_rooms_png(tmp_path / "in" / "fine.png")
    three_rooms_png(tmp_path / "in" / "coarse.png")
    for name, res in (("fine", 0.05), ("coarse", 0.1)):
        (tmp_path / "in" / f"{name}.yaml").write_text(
            f"image: {name}.png\nresolution: {res}\norigin: [0.0, 0.0, 0.0]\n", encoding="utf-8"
        )
    out = tmp_path / "out"
    maps = [str(tmp_path / "in" / f"{name}.yaml") for name in ("fine", "coarse")]
    argv = ["batch", *maps, "-o", str(out), "--no-progress", "--resolution", "0.05"]
    assert main([*argv, "--workers", "0"]) == 0
    note = "0.05 m/px from --resolution: the file states 0.1"
    rows = {r["map"]: r for r in _rows(out)}
    assert rows["coarse"]["message"] == note and rows["fine"]["message"] == ""
    assert rows["coarse"]["status"] == rows["fine"]["status"] == "ok"
    assert rows["coarse"]["resolution_m"] == "0.05"
    captured = capsys.readouterr()
    assert "2 ok, 0 empty" in captured.out and "1 with a warning" in captured.out
    assert captured.err.splitlines() == [f"  ok       coarse: {note}"]


def test_the_resolution_help_says_it_replaces_a_pgms_too(capsys):
    """``--resolution`` replaces the m/px that a PGM's comment states as well as a YAML's
    (the docs' map options); its help said a YAML's only."""
    with pytest.raises(SystemExit):
        main(["graph", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "given, it replaces a YAML's or a PGM's" in text
