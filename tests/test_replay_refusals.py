"""How a replay names the scans the mapper refused (skipped, the replay goes on): each by
its index in the log, and the summary by the bounds the refusals met."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from topojax._replay_skips import SkippedScans
from topojax._replay_state import ReplayProgress, skipped_message
from topojax.cli import main
from topojax.incremental import ExtentError, IncrementalMapper
from topojax.playback import replay
from topojax.rooms import RoomConfig
from topojax.scans import read_scans

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
#: Bytes of one of the default mapper's tiles.
TILE_BYTES = IncrementalMapper()._tiles.tile_nbytes


def test_each_skipped_scan_is_named_by_its_index_in_the_log(tmp_path):
    """Refused scans after the first are not the mapper's (it counts the scans it added),
    so each refusal names the scan by its index in the log: the scan with that index
    has the refusal's timestamp, and no two refusals name the same scan."""
    summary = replay(INTEL_EXCERPT, out_dir=tmp_path / "o", progress=False, max_extent_m=46)
    skipped = summary["skipped_scans"]
    assert len(skipped) > 1 and summary["n_scans"] == 40 - len(skipped)
    stamps = [s.timestamp for s in read_scans(INTEL_EXCERPT)]
    named = []
    for refusal in skipped:
        index, stamp = re.match(
            r"scan (\d+) of the log \(timestamp ([\d.]+) s\): ", refusal
        ).groups()
        assert f"{stamps[int(index)]:.6f}" == stamp
        named.append(int(index))
    assert len(set(named)) == len(named)


def test_the_skipped_scans_line_names_the_bound_they_met(tmp_path, capsys):
    """Scans refused for the memory of the mapper's tiles (``max_tile_bytes``) are said
    to be so in the summary's line, not blamed on ``max_extent_m``."""
    out = tmp_path / "o"
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, max_tile_bytes=50 * TILE_BYTES)
    assert len(summary["skipped_scans"]) > 1
    line = next(m for m in summary["messages"] if m.startswith("skipped"))
    assert "bounds (max_tile_bytes) and not mapped" in line
    assert "max_extent_m" not in line and "--max-extent-m" not in line


def test_the_skipped_scans_line_of_the_command_names_its_option(tmp_path, capsys):
    """``topojax replay`` words the line of scans refused as beyond ``--max-extent-m`` with
    its option, as before, and names the scans by their index in the log."""
    args = ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "o"), "--no-progress"]
    assert main([*args, "--max-extent-m", "46"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("skipped"))
    assert "bounds (--max-extent-m) and not mapped" in line
    assert re.search(r"the first: scan \d+ of the log \(timestamp", line)


def _reworded(monkeypatch) -> None:
    """Make every refusal of the mapper say only that it refused, in other words than the
    mapper's (its fields as they were): what a replay makes of refusals must not hang on
    their wording."""
    from topojax.incremental import _rays

    def refusal(where, reason, bound):
        what = where()
        return ExtentError(
            f"{what.name}{what.more}: refused, not mapped", bound=bound, subject=what.name,
            scan=what.scan,
        )  # fmt: skip

    monkeypatch.setattr(_rays, "refusal", refusal)


def test_the_bound_each_skipped_scan_met_is_in_timings_json_whatever_the_wording(
    tmp_path, monkeypatch
):
    """``timings.json`` names the bound each skipped scan met (``skipped_bounds``, beside
    ``skipped_scans``), and the summary's line the bounds, from the refusals' fields: a
    reworded refusal changes neither, and its scan is named by its index in the log."""
    _reworded(monkeypatch)
    out = tmp_path / "o"
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, max_tile_bytes=50 * TILE_BYTES)
    written = json.loads((out / "timings.json").read_text())
    skipped = written["skipped_scans"]
    assert len(skipped) > 1 and skipped == summary["skipped_scans"]
    assert written["skipped_bounds"] == ["max_tile_bytes"] * len(skipped)
    for refusal in skipped:
        assert re.fullmatch(r"scan \d+ of the log \(timestamp .*: refused, not mapped", refusal)
    line = next(m for m in summary["messages"] if m.startswith("skipped"))
    assert "bounds (max_tile_bytes) and not mapped" in line


def test_the_skipped_scans_line_of_the_command_names_its_option_whatever_the_wording(
    tmp_path, monkeypatch, capsys
):
    _reworded(monkeypatch)
    out = tmp_path / "o"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    assert main([*args, "--max-extent-m", "46"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("skipped"))
    assert "bounds (--max-extent-m) and not mapped" in line
    bounds = json.loads((out / "timings.json").read_text())["skipped_bounds"]
    assert len(bounds) > 1 and set(bounds) == {"max_extent_m"}


def test_a_resumed_replay_names_the_bounds_the_stopped_one_met(tmp_path, monkeypatch):
    """The bounds met by the scans skipped before a stop are kept with the mapper's state
    and named by the resumed replay (its refusals reworded: not read from their words)."""
    import topojax.scans

    _reworded(monkeypatch)
    real = topojax.scans.read_scans

    def stopping(source, **kw):  # the first replay stops after 12 scans (6 skipped)
        monkeypatch.setattr(topojax.scans, "read_scans", real)
        for i, scan in enumerate(real(source, **kw)):
            if i == 12:
                raise KeyboardInterrupt
            yield scan

    monkeypatch.setattr(topojax.scans, "read_scans", stopping)
    out, kw = tmp_path / "o", {"progress": False, "max_tile_bytes": 50 * TILE_BYTES}
    with pytest.warns(RuntimeWarning, match="resume"), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, **kw)
    # the resumed replay skips no scan: only those before the stop are refused
    summary = replay(INTEL_EXCERPT, out_dir=out, resume=True, max_scans=12, **kw)
    assert summary["resumed_after"] == 12 and len(summary["skipped_scans"]) > 1
    assert summary["skipped_bounds"] == ["max_tile_bytes"] * len(summary["skipped_scans"])
    line = next(m for m in summary["messages"] if m.startswith("skipped"))
    assert "bounds (max_tile_bytes) and not mapped" in line


def test_refusals_recorded_without_their_bounds_name_none():
    """A state saved by an older topojax records the refusals without their bounds: those
    are not known, and the summary names no bound for them."""
    record = {"skipped": ["scan 1 of the log: refused", "scan 3 of the log: refused"]}
    progress = ReplayProgress(5, SkippedScans.from_record(record))
    assert progress.skipped.bounds == [None, None]
    assert progress.skipped.per_bound == {"unknown": 2}
    assert skipped_message(progress)[0].startswith(
        "skipped 2 of 5 scans, each refused as beyond the mapper's bounds and not mapped"
    )
    progress.skip("scan 4 of the log: refused", "max_extent_m")
    assert "bounds (max_extent_m) and" in (skipped_message(progress)[0])


def test_a_keyword_neither_replay_nor_the_mapper_takes_is_named_as_replays(tmp_path):
    """``replay`` passes the keywords it does not take to the mapper: one the mapper does
    not take either is refused before any work, as replay's, with what it takes."""
    with pytest.raises(TypeError, match=r"^replay: unexpected keyword argument 'sigma'; "):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "o", progress=False, sigma=3)
    with pytest.raises(TypeError, match=r"arguments 'a', 'b'; expected .*'graph_every'"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "o", progress=False, a=1, b=2)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "keyword",
    [{"rooms_every": 5}, {"room_config": RoomConfig(min_room_m2=5.0)}, {"rooms_local": False}],
)
def test_room_keywords_without_rooms_are_refused_before_the_replay(tmp_path, keyword):
    """The mapper's room keywords only matter with ``rooms=True``: without it the replay
    writes no rooms, so ``rooms_every`` would segment rooms for nothing and the others be
    ignored; each is refused naming it and ``rooms``, before any file is written."""
    (name,) = keyword
    out = tmp_path / "o"
    with pytest.raises(ValueError, match=rf"^{name}: only used with rooms=True, "):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_scans=5, **keyword)
    assert not out.exists()


@pytest.mark.parametrize("name", ["graph.json", "view.html", "map_rooms.geojson"])
def test_a_folder_where_an_output_goes_is_refused_before_any_scan(tmp_path, capsys, name):
    """A folder where one of the files the replay writes goes is refused naming the output
    folder (out_dir to the API, --out on the command line) before any scan is mapped: it
    was met only when the files were written, after the whole log, and named the graph
    writer's own parameter.  A folder with a name this replay does not write is left be."""
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    with pytest.raises(IsADirectoryError, match=rf"^out_dir: expected to write the file .*{name}"):
        replay(INTEL_EXCERPT, out_dir=out, view=True, rooms=True, progress=False)
    assert sorted(p.name for p in out.iterdir()) == [name]  # no state: no scan was mapped
    argv = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--view", "--rooms", "--no-progress"]
    assert main(argv) == 2
    assert f"error: --out: expected to write the file {out / name}" in capsys.readouterr().err
    if name != "graph.json":  # not written without --view and --rooms
        assert replay(INTEL_EXCERPT, out_dir=out, max_scans=3, progress=False)["n_scans"] == 3
