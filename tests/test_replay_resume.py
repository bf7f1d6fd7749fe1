"""Resuming a replay that stopped part way (``replay(..., resume=True)``, ``topojax
replay --resume``) from the state it saved: the scans already taken are skipped and the
written map and graph are those of a replay that did not stop."""

from __future__ import annotations

import gzip
import json
import os
import signal
from pathlib import Path

import pytest

import topojax as tj
import topojax.scans
from topojax.cli import main
from topojax.incremental import IncrementalMapper
from topojax.playback import STATE_FILE, replay

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
SETTINGS = {"graph_every": 7, "skeleton_every": 3}


def interrupted_reader(monkeypatch, after: int, error=KeyboardInterrupt):
    """Make replay's reader raise ``error`` after ``after`` scans, once (as Ctrl-C or a
    log unreadable part way would)."""
    real = topojax.scans.read_scans
    calls = []

    def reader(source, **kw):
        calls.append(source)
        scans = real(source, **kw)
        if len(calls) > 1:
            return scans

        def stopping():
            for i, scan in enumerate(scans):
                if i == after:
                    raise error()
                yield scan

        return stopping()

    monkeypatch.setattr(topojax.scans, "read_scans", reader)


def assert_same_outputs(a: Path, b: Path) -> None:
    """The graph files and the map of two replays hold the same bytes."""
    assert tj.load_graph(a / "graph.json").number_of_edges() > 10
    for name in ("graph.json", "graph.graphml", "graph.geojson", "map.pgm", "map.yaml"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("full")
    return out, replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)


@pytest.mark.parametrize("after", [1, 13, 39])
def test_a_resumed_replay_writes_what_an_uninterrupted_one_does(
    tmp_path, monkeypatch, full_run, after
):
    full_out, full = full_run
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, after)
    with (
        pytest.warns(
            RuntimeWarning,
            match=rf"stopped after {after} scan{'s' if after != 1 else ''}; .*resume",
        ) as warned,
        pytest.raises(KeyboardInterrupt),
    ):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)
    assert [w.filename for w in warned] == [__file__]  # where replay was called
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == after  # old loader reads it
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert_same_outputs(full_out, out)
    assert summary["n_scans"] == full["n_scans"] == 40
    assert summary["resumed_after"] == after and full["resumed_after"] == 0
    assert (summary["vertices"], summary["edges"]) == (full["vertices"], full["edges"])


def test_a_replay_stopped_by_its_export_limit_resumes_with_a_larger_one(
    tmp_path, monkeypatch, full_run
):
    """A map past ``max_export_bytes`` stops the replay with its scans saved, and the
    message says to raise the limit: a resume may, as the limit only refuses (the
    scans are mapped alike), and writes what a replay that did not stop writes.  The
    other mapper settings must still be the saved ones."""
    full_out, full = full_run
    out = tmp_path / "out"
    small = 5_000_000
    with pytest.raises(ValueError, match=r"max_export_bytes.* state is saved"):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_export_bytes=small, **SETTINGS)
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 40
    with pytest.raises(ValueError, match=r"other settings \(graph_every: saved 7, now 8\)"):
        replay(
            INTEL_EXCERPT,
            out_dir=out,
            progress=False,
            resume=True,
            **{**SETTINGS, "graph_every": 8},
        )
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert_same_outputs(full_out, out)
    assert summary["resumed_after"] == 40
    assert (summary["vertices"], summary["edges"]) == (full["vertices"], full["edges"])


RECORDINGS = ("animation.gif", "view.html")


def recorded_replay(out: Path, **kw) -> dict:
    """A replay of the excerpt with every recording: animation, view timeline, MCAP."""
    return replay(
        INTEL_EXCERPT,
        out_dir=out,
        progress=False,
        animate=out / "animation.gif",
        mcap=out / "run.mcap",
        view=True,
        **SETTINGS,
        **kw,
    )


def mcap_messages(path: Path) -> list:
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return sorted((c.topic, t, bytes(raw)) for c, t, raw in reader.messages())


@pytest.fixture(scope="module")
def full_recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("full_recorded")
    recorded_replay(out)
    return out


def test_a_resumed_replay_continues_the_recordings_of_the_stopped_one(
    tmp_path, monkeypatch, full_recorded
):
    """The animation, the view timeline and the MCAP recording of a replay stopped after
    17 scans and resumed are those of a replay that did not stop, not recordings of the
    scans after the stop alone."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 17)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    assert not (out / "run.mcap").exists() and (out / ".replay_partial").is_dir()
    summary = recorded_replay(out, resume=True)
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name
    timelines = [
        gzip.decompress((d / "timeline.json.gz").read_bytes()) for d in (out, full_recorded)
    ]
    assert timelines[0] == timelines[1]
    messages = mcap_messages(out / "run.mcap")
    assert len(messages) > 80 and messages == mcap_messages(full_recorded / "run.mcap")
    assert not (out / ".replay_partial").exists()
    assert any(".replay_partial: the replay has finished" in m for m in summary["messages"])


def test_a_replay_stopped_before_its_first_graph_update_continues_its_recordings(
    tmp_path, monkeypatch, full_recorded
):
    """Stopped after 5 scans, before the first graph update (every 7 scans), the replay's
    timeline has the robot's path but no snapshot; the resumed replay continues it."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 5)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    monkeypatch.undo()
    summary = recorded_replay(out, resume=True)
    assert not [m for m in summary["messages"] if "after the log's first" in m]
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name


def test_a_replay_stopped_while_writing_its_files_keeps_its_recordings_as_they_were(
    tmp_path, monkeypatch, full_recorded
):
    """Stopped while the animation is written (after the view, whose timeline has the
    final snapshot), the replay keeps the recordings of its scans, not that snapshot: the
    resumed replay's recordings are those of one that did not stop."""
    import topojax.playback

    def stopping(*args, **kwargs):
        raise KeyboardInterrupt

    out = tmp_path / "out"
    monkeypatch.setattr(topojax.playback, "write_animation", stopping)
    with pytest.warns(RuntimeWarning, match="stopped after 40 scans"):
        with pytest.raises(KeyboardInterrupt):
            recorded_replay(out)
    monkeypatch.undo()
    summary = recorded_replay(out, resume=True)
    assert summary["resumed_after"] == 40
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name
    assert mcap_messages(out / "run.mcap") == mcap_messages(full_recorded / "run.mcap")


def test_a_replay_stopped_while_ending_its_recording_keeps_the_rest(
    tmp_path, monkeypatch, full_recorded
):
    """Stopped part way through the MCAP recording's last messages, the replay keeps the
    mapper's state, the timeline and the frames, but not a recording that holds some of
    those messages: the resumed replay's GIF and view are those of one that did not
    stop, and it says its MCAP recording starts after the log's 40 scans."""
    import topojax.playback

    def stopping(recorder, done):
        recorder.add_map(done.result.map, done.result.graph)
        raise KeyboardInterrupt

    out = tmp_path / "out"
    monkeypatch.setattr(topojax.playback, "_record_final", stopping)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    monkeypatch.undo()
    assert not (out / ".replay_partial" / "recording.mcap").exists()
    summary = recorded_replay(out, resume=True)
    said = [m for m in summary["messages"] if "after the log's first 40" in m]
    assert len(said) == 1 and "MCAP" in said[0]
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name
    assert {t for t, *_ in mcap_messages(out / "run.mcap")} == {"/map", "/topology"}


def test_a_resume_may_not_record_route_graphs_of_another_radius(tmp_path, monkeypatch, capsys):
    """The MCAP recording of a stopped replay holds its route graphs for one robot: a
    resume that would add those of another radius (or none) is refused before it maps a
    scan, and with the same radius the recording goes on."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 17)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out, route_graph_radius_m=0.3)
    monkeypatch.undo()
    for radius, said in ((0.4, "for a robot of 0.4 m"), (None, "would add no route graph")):
        with pytest.raises(ValueError, match=r"^resume: the MCAP recording") as caught:
            recorded_replay(out, resume=True, route_graph_radius_m=radius)
        assert "holds route graphs for a robot of 0.3 m" in str(caught.value)
        assert said in str(caught.value)
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--resume", "--no-progress"]
    args += ["--graph-every", "7", "--skeleton-every", "3", "--mcap", str(out / "run.mcap")]
    assert main([*args, "--view", "--animate", str(out / "animation.gif")]) == 2
    err = capsys.readouterr().err
    assert "resume with the same --route-graph" in err and "route_graph_radius_m" not in err
    assert not (out / "run.mcap").exists()  # the state and the kept recording stay
    summary = recorded_replay(out, resume=True, route_graph_radius_m=0.3)
    assert summary["resumed_after"] == 17
    assert {"/route_graph"} <= {t for t, *_ in mcap_messages(out / "run.mcap")}


def test_a_resume_that_records_nothing_leaves_the_kept_recordings(
    tmp_path, monkeypatch, full_recorded
):
    """A resume without the recordings, stopped before it maps a scan, leaves the
    earlier replay's kept recordings for the next resume, not deleted."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 17)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    monkeypatch.undo()
    interrupted_reader(monkeypatch, 17)  # the resume's first scan: none mapped
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    monkeypatch.undo()
    recorded_replay(out, resume=True)
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name
    assert mcap_messages(out / "run.mcap") == mcap_messages(full_recorded / "run.mcap")


def test_a_resumed_replay_without_the_stopped_ones_recordings_says_so(tmp_path, monkeypatch):
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 17)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)  # no recordings
    summary = recorded_replay(out, resume=True)
    said = [m for m in summary["messages"] if "after the log's first 17" in m]
    assert len(said) == 3, summary["messages"]  # animation, timeline, MCAP
    scans = [m for m in mcap_messages(out / "run.mcap") if m[0] == "/scan"]
    assert len(scans) == 40 - 17


def test_damaged_recordings_of_a_stopped_replay_are_started_afresh(tmp_path, monkeypatch):
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 20)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    for name in ("recording.mcap", "timeline.json.gz", "frames.npz"):
        (out / ".replay_partial" / name).write_bytes(b"damaged")
    summary = recorded_replay(out, resume=True)
    said = [m for m in summary["messages"] if "after the log's first 20: the one the" in m]
    assert len(said) == 3, summary["messages"]
    assert len([m for m in mcap_messages(out / "run.mcap") if m[0] == "/scan"]) == 20


def test_recordings_of_fewer_scans_than_the_state_are_not_continued(tmp_path, monkeypatch):
    """A stop while a scan's update was being recorded leaves recordings one scan short
    of the mapper's state: a resumed replay starts its recordings afresh and says so."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 20)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    (out / ".replay_partial" / "recorded.json").write_text('{"recorded": 19}')
    summary = recorded_replay(out, resume=True)
    assert sum("after the log's first 20" in m for m in summary["messages"]) == 3
    assert len([m for m in mcap_messages(out / "run.mcap") if m[0] == "/scan"]) == 20


def test_a_resumed_replay_that_stops_again_resumes_again(tmp_path, monkeypatch, full_run):
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 10, error=RuntimeError)
    with pytest.warns(RuntimeWarning, match="stopped after 10 scans"), pytest.raises(RuntimeError):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)
    monkeypatch.undo()
    interrupted_reader(monkeypatch, 25)  # the log's scan 25: 15 after the first 10
    with pytest.warns(RuntimeWarning, match="stopped after 25 scans"):
        with pytest.raises(KeyboardInterrupt):
            replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    monkeypatch.undo()
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert summary["resumed_after"] == 25 and summary["n_scans"] == 40
    assert_same_outputs(full_run[0], out)


def test_resume_keeps_max_scans_counted_from_the_log_start(tmp_path, monkeypatch):
    whole = tmp_path / "whole"
    replay(INTEL_EXCERPT, out_dir=whole, progress=False, max_scans=30, **SETTINGS)
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 12)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_scans=30, **SETTINGS)
    with pytest.raises(ValueError, match=r"already taken 12 scans .* max_scans=5"):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_scans=5, resume=True, **SETTINGS)
    summary = replay(
        INTEL_EXCERPT, out_dir=out, progress=False, max_scans=30, resume=True, **SETTINGS
    )
    assert summary["n_scans"] == 30
    assert_same_outputs(whole, out)
    # the finished replay removed the state it continued: nothing is left to resume
    assert not (out / STATE_FILE).exists()
    assert any("mapper_state.npz: the replay has finished" in m for m in summary["messages"])
    with pytest.raises(FileNotFoundError, match="resume: no saved state"):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_scans=30, resume=True, **SETTINGS)


@pytest.mark.parametrize("error", [KeyboardInterrupt, OSError])
def test_a_replay_stopped_while_writing_its_files_keeps_its_scans(
    tmp_path, monkeypatch, full_run, error
):
    # every scan is mapped; Ctrl-C (or a full disk) while the map is written must not
    # lose them: the state is saved and a resume writes the uninterrupted replay's files
    import topojax.maps

    def failing_save_map(*args, **kwargs):
        raise error("while writing")

    out = tmp_path / "out"
    monkeypatch.setattr(topojax.maps, "save_map", failing_save_map)
    with pytest.warns(RuntimeWarning, match="stopped after 40 scans"), pytest.raises(error):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)
    monkeypatch.undo()
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 40
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert summary["n_scans"] == 40 and summary["resumed_after"] == 40
    assert_same_outputs(full_run[0], out)
    assert not (out / STATE_FILE).exists()


@pytest.fixture
def stopped(tmp_path, monkeypatch):
    """An output folder with the state of a replay stopped after 12 scans."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 12)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)
    monkeypatch.undo()
    return out


def test_a_stop_as_the_finished_replay_removes_its_state_leaves_timings(stopped, monkeypatch):
    # the state of a stopped replay goes only once timings.json records the finished
    # one: a Ctrl-C just after it goes must not leave a folder with neither
    real_unlink = Path.unlink

    def unlink_then_stop(self, *args, **kwargs):
        real_unlink(self, *args, **kwargs)
        if self.name == STATE_FILE:
            raise KeyboardInterrupt

    monkeypatch.setattr(Path, "unlink", unlink_then_stop)
    with pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, **SETTINGS)
    assert not (stopped / STATE_FILE).exists()
    assert json.loads((stopped / "timings.json").read_text())["n_scans"] == 40


def test_resume_without_a_saved_state_is_refused(tmp_path):
    with pytest.raises(FileNotFoundError, match=rf"resume: no saved state .*{STATE_FILE}"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "new", progress=False, resume=True)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"graph_every": 8, "skeleton_every": 3},
            r"other settings \(graph_every: saved 7, now 8\)",
        ),
        (
            {"reader_kwargs": {"max_range_m": 40.0}, **SETTINGS},
            r"other reader options \(max_range_m: saved None",
        ),
    ],
)
def test_resume_with_other_settings_is_refused(stopped, options, message):
    with pytest.raises(ValueError, match=message):
        replay(INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, **options)


def test_resume_from_another_log_is_refused(stopped, tmp_path):
    other = tmp_path / "other.log.gz"
    data = bytearray(INTEL_EXCERPT.read_bytes())
    other.write_bytes(bytes(data[:-100]))  # the same log cut short is another log
    with pytest.raises(ValueError, match=r"saved replaying .*intel_first40.*different log"):
        replay(other, out_dir=stopped, progress=False, resume=True, **SETTINGS)


def test_resume_from_a_log_changed_since_says_so(tmp_path, monkeypatch):
    """A log written to after the replay stopped (a robot still logging into it) is
    named as that log, changed since, not as "a different log from" itself."""
    log, out = tmp_path / "run.log", tmp_path / "out"
    log.write_text(gzip.open(INTEL_EXCERPT, "rt").read())
    interrupted_reader(monkeypatch, 12)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(log, out_dir=out, progress=False, **SETTINGS)
    monkeypatch.undo()
    with log.open("a") as fh:
        fh.write("ODOM 0 0 0 0 0 0 999.0 host 999.0\n")
    with pytest.raises(
        ValueError, match=r"saved replaying \S*run\.log, which has changed si"
    ) as info:
        replay(log, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert "different log" not in str(info.value)


def test_resume_from_a_state_that_records_no_replay_is_refused(stopped):
    """A state saved by IncrementalMapper.save (or before replays recorded their
    progress) loads as before but cannot be resumed: how far it got is unknown."""
    mapper = IncrementalMapper.load(stopped / STATE_FILE)
    mapper.save(stopped / STATE_FILE)
    with pytest.raises(ValueError, match="does not record which log it mapped nor how far"):
        replay(INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, **SETTINGS)


def test_replay_cli_resume(stopped, tmp_path, full_run, capsys):
    args = ["replay", str(INTEL_EXCERPT), "-o", str(stopped), "--no-progress"]
    args += ["--graph-every", "7", "--skeleton-every", "3", "--resume"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "replayed   40 scans" in out
    # the time and the loop timings are this run's: the summary says after what
    assert "\nresumed    after 12 scans of the log: the time and the loop timings" in out
    assert_same_outputs(full_run[0], stopped)
    assert main(["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "empty"), "--resume"]) != 0
    assert "error: --resume: no saved state" in capsys.readouterr().err  # the option
    assert not (tmp_path / "empty").exists()


def test_replay_cli_resumes_a_replay_its_export_limit_stopped_with_a_larger_one(
    tmp_path, full_run, capsys
):
    out = tmp_path / "out"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    args += ["--graph-every", "7", "--skeleton-every", "3"]
    assert main([*args, "--max-export-mb", "5"]) == 2
    err = capsys.readouterr().err
    assert "more than --max-export-mb 5 (5,242,880 bytes)" in err
    assert "or give a larger --max-export-mb" in err
    assert err.rstrip().endswith("replay again with --resume and a larger --max-export-mb.")
    assert main([*args, "--resume"]) == 0  # the default limit, 2048 MB
    assert_same_outputs(full_run[0], out)
    for bad in ("0", "-1", "nan", "inf", "1e-9"):
        assert main([*args, "--max-export-mb", bad]) == 2, bad
        assert "error: --max-export-mb: expected" in capsys.readouterr().err


def test_replay_cli_refused_resume_names_the_options(stopped, capsys):
    """A resume refused for other options names the options typed, not the library's
    parameters (``graph_every``, ``max_range_m``, ``max_scans=5``)."""
    args = ["replay", str(INTEL_EXCERPT), "-o", str(stopped), "--resume", "--no-progress"]
    for options, message in (
        (["--graph-every", "8"], "other settings (--graph-every: saved 7, now 8)"),
        (["--max-range", "40"], "other reader options (--max-range: saved None, now 40.0)"),
        (["--max-scans", "5"], "more than --max-scans=5"),
        (["--rooms"], "(--rooms: the saved replay had no --rooms, this one updates rooms every 7"),
    ):
        given = ["--graph-every", "7", "--skeleton-every", "3", *options]
        assert main([*args, *given]) == 2
        err = capsys.readouterr().err
        assert message in err and "_every" not in err and "max_range_m" not in err
    assert IncrementalMapper.load(stopped / STATE_FILE).n_scans == 12  # left for a resume


def test_a_resume_with_other_room_settings_names_only_those_that_differ(
    tmp_path, monkeypatch, capsys
):
    """The room settings are one record: a refused resume names the field that differs
    (``room_config.max_door_width_m: saved 2.2, now 1.5``), not the two records whole."""
    from topojax.rooms import RoomConfig

    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 12)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, rooms=True, **SETTINGS)
    monkeypatch.undo()
    other = RoomConfig(max_door_width_m=1.5)
    with pytest.raises(ValueError, match="room_config") as info:
        replay(
            INTEL_EXCERPT,
            out_dir=out,
            progress=False,
            resume=True,
            rooms=True,
            room_config=other,
            **SETTINGS,
        )
    message = str(info.value)
    assert "(room_config.max_door_width_m: saved 2.2, now 1.5)" in message, message
    assert "min_door_width_m" not in message
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--resume", "--no-progress", "--rooms"]
    args += ["--graph-every", "7", "--skeleton-every", "3", "--max-door-width-m", "1.5"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "(--max-door-width-m: saved 2.2, now 1.5)" in err and "room_config" not in err


def test_replay_cli_refused_resume_without_rooms_says_so_in_words(tmp_path, monkeypatch, capsys):
    """A replay stopped with --rooms, resumed without (or with rooms at its end only),
    is refused saying how each replay keeps its rooms, in the option's words."""
    out = tmp_path / "out"
    interrupted_reader(monkeypatch, 12)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, rooms=True, **SETTINGS)
    monkeypatch.undo()
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--resume", "--no-progress"]
    for options, message in (
        ([], "(--rooms: the saved replay updated rooms every 7 scans, this one has no --rooms)"),
        (
            ["--rooms", "--graph-every", "0"],
            "--rooms: the saved replay updated rooms every 7 scans, this one after its last "
            "scan only)",
        ),
    ):
        assert main([*args, "--graph-every", "7", "--skeleton-every", "3", *options]) == 2
        assert message in capsys.readouterr().err


@pytest.mark.parametrize(("signum", "status"), [("SIGTERM", 143), ("SIGINT", 130)])
def test_replay_cli_stopped_by_a_signal_keeps_its_scans(
    tmp_path, monkeypatch, full_run, capsys, signum, status
):
    # kill, timeout or a service manager's stop (SIGTERM) stops the replay as Ctrl-C
    # does, not at once with every mapped scan lost: the scans are kept for --resume,
    # and the command ends with one line, not a traceback
    import os
    import signal

    real = topojax.scans.read_scans

    def reader(source, **kw):
        for i, scan in enumerate(real(source, **kw)):
            if i == 15:
                os.kill(os.getpid(), getattr(signal, signum))
            yield scan

    def ignored(signum, frame):  # what SIGTERM does outside the command
        pass

    monkeypatch.setattr(topojax.scans, "read_scans", reader)
    previous = signal.signal(signal.SIGTERM, ignored)
    out = tmp_path / "out"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    args += ["--graph-every", "7", "--skeleton-every", "3"]
    try:
        assert main(args) == status
        assert signal.getsignal(signal.SIGTERM) is ignored  # the command's is undone
    finally:
        signal.signal(signal.SIGTERM, previous)
    err = capsys.readouterr().err
    assert "topojax replay: warning: replay stopped after 15 scans; " in err
    assert f"topojax replay: stopped by {signum}" in err
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 15
    monkeypatch.undo()
    assert main([*args, "--resume"]) == 0
    assert_same_outputs(full_run[0], out)


def test_the_command_line_page_says_how_replay_ends_on_a_signal():
    """The page says how ``replay`` ends on a signal, unlike the other commands'
    ``interrupted (Ctrl-C)``: it warns where it saved its state and ends with the lines
    that :func:`test_replay_cli_stopped_by_a_signal_keeps_its_scans` checks."""
    page = (Path(__file__).parents[1] / "docs" / "command-line.md").read_text("utf-8")
    stops = " ".join(page[page.index("Ctrl-C stops") : page.index("## Map options")].split())
    assert "`topojax replay: stopped by SIGINT` and status 130" in stops
    assert "`stopped by SIGTERM` and 143" in stops and "mapper_state.npz" in stops
    assert "`topojax replay: warning: replay stopped after N scans;" in stops


def test_replay_cli_in_a_background_job_stops_on_sigterm_too(
    tmp_path, monkeypatch, full_run, capsys
):
    """A script's background job ignores SIGINT, and there SIGTERM (``kill``) stops the
    replay too, once the scan being mapped is counted, rather than ending the command at
    once with every mapped scan lost; a SIGINT is still ignored."""
    real = IncrementalMapper.add_scan

    def add_scan(self, scan):
        if self.n_scans == 10:
            os.kill(os.getpid(), signal.SIGINT)  # ignored
        if self.n_scans == 14:
            os.kill(os.getpid(), signal.SIGTERM)  # held while scan 15 is mapped
        return real(self, scan)

    def ignored(signum, frame):  # what SIGTERM does outside the command
        pass

    monkeypatch.setattr(IncrementalMapper, "add_scan", add_scan)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN), signal.signal(signal.SIGTERM, ignored)
    out = tmp_path / "out"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    args += ["--graph-every", "7", "--skeleton-every", "3"]
    try:
        assert main(args) == 143
        assert signal.getsignal(signal.SIGTERM) is ignored  # the command's is undone
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous[0])
        signal.signal(signal.SIGTERM, previous[1])
    err = capsys.readouterr().err
    assert "topojax replay: warning: replay stopped after 15 scans; " in err
    assert "topojax replay: stopped by SIGTERM" in err
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 15
    monkeypatch.undo()
    assert main([*args, "--resume"]) == 0
    assert_same_outputs(full_run[0], out)


class SlowMapper:
    """Counts scans as IncrementalMapper does; a Ctrl-C arrives while it maps scan
    ``interrupted`` (after it has counted it), and twice while it maps ``twice``."""

    def __init__(self, interrupted: int, twice: int = -1) -> None:
        self.n_scans = self.finished = 0
        self.interrupted, self.twice = interrupted, twice

    def add_scan(self, scan):
        self.n_scans += 1
        if scan in (self.interrupted, self.twice):
            os.kill(os.getpid(), signal.SIGINT)
        if scan == self.twice:
            os.kill(os.getpid(), signal.SIGINT)
        self.finished += 1
        return scan


def test_an_interrupt_while_a_scan_is_mapped_waits_for_it_to_be_counted():
    """Ctrl-C part way through a scan stops the replay after the scan, counted: stopped
    with the scan mapped but not counted, a resumed replay would map it twice."""
    from topojax._replay_state import ReplayProgress, WholeScans

    mapper, progress = SlowMapper(interrupted=3), ReplayProgress()
    with pytest.raises(KeyboardInterrupt), WholeScans() as whole:
        for i in range(10):
            assert whole.add(mapper, i, i, progress) == i
    assert progress.consumed == mapper.n_scans == mapper.finished == 4
    mapper, progress = SlowMapper(interrupted=-1, twice=2), ReplayProgress()
    with pytest.raises(KeyboardInterrupt), WholeScans() as whole:  # the second: at once
        for i in range(10):
            whole.add(mapper, i, i, progress)
    assert progress.consumed == mapper.n_scans == 3 and mapper.finished == 2


@pytest.mark.parametrize("signals", [1, 2])
def test_interrupts_while_a_scan_is_recorded_wait_for_the_recording(signals):
    """One Ctrl-C, or two, while the replay records scan 5 stop it once scan 5 is
    recorded: the second one at once would cut the recording short of the mapped scans."""
    from topojax._replay_state import ReplayProgress, WholeScans

    mapper, progress, seen = SlowMapper(interrupted=-1), ReplayProgress(), []

    def record(scan, report):
        if scan == 5:
            for _ in range(signals):
                os.kill(os.getpid(), signal.SIGINT)
        seen.append(scan)

    with pytest.raises(KeyboardInterrupt), WholeScans() as whole:
        for i in range(10):
            whole.add(mapper, i, i, progress, then=record)
    assert seen == list(range(6)) and progress.consumed == progress.recorded == 6
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored


def test_a_replay_interrupted_twice_while_recording_an_update_keeps_its_recordings(
    tmp_path, monkeypatch, full_recorded
):
    """Ctrl-C twice in a row while the MCAP recording takes the second graph update's
    map: the replay stops once that scan is recorded, keeps every recording, and the
    resumed one writes those of a replay that did not stop (not recordings of the scans
    after the stop alone, as when the second Ctrl-C cut the recording short)."""
    from topojax.io.mcap import McapRecorder

    real, calls = McapRecorder.add_map, []

    def add_map(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(McapRecorder, "add_map", add_map)
    out = tmp_path / "out"
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded_replay(out)
    monkeypatch.undo()
    summary = recorded_replay(out, resume=True)
    assert summary["resumed_after"] == 14  # the graph update after the 14th scan
    assert not [m for m in summary["messages"] if "holds the scans after" in m]
    assert mcap_messages(out / "run.mcap") == mcap_messages(full_recorded / "run.mcap")
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name


def test_a_failing_recording_leaves_the_scan_counted_but_not_recorded():
    from topojax._replay_state import ReplayProgress, WholeScans

    def record(scan, report):
        if scan == 2:
            raise OSError("disk full")

    mapper, progress = SlowMapper(interrupted=-1), ReplayProgress()
    with pytest.raises(OSError, match="disk full"), WholeScans() as whole:
        for i in range(10):
            whole.add(mapper, i, i, progress, then=record)
    assert (progress.consumed, progress.recorded) == (3, 2)


@pytest.mark.parametrize("inside", ["_splat_group", "skeleton_exact"])
def test_an_interrupt_during_the_final_update_waits_for_it(tmp_path, monkeypatch, full_run, inside):
    """Ctrl-C part way through the update after the last scan stops the replay once the
    update has run: stopped half done (the pending obstacles or the changed ridges
    dropped) and saved in that state, the resumed replay would write another graph."""
    import topojax.incremental._splat as splat_module
    import topojax.incremental.mapper as mapper_module
    import topojax.playback as playback

    module = splat_module if inside == "_splat_group" else mapper_module
    real, real_final = getattr(module, inside), playback._final
    stage = {"final": False, "sent": False}

    def final(*args, **kw):
        stage["final"] = True
        return real_final(*args, **kw)

    def interrupted(*args, **kw):
        if stage["final"] and not stage["sent"]:
            stage["sent"] = True
            os.kill(os.getpid(), signal.SIGINT)
        return real(*args, **kw)

    monkeypatch.setattr(playback, "_final", final)
    monkeypatch.setattr(module, inside, interrupted)
    out = tmp_path / "out"
    with pytest.warns(RuntimeWarning, match="stopped after 40 scans"):
        with pytest.raises(KeyboardInterrupt):
            replay(INTEL_EXCERPT, out_dir=out, progress=False, **SETTINGS)
    assert stage["sent"]
    monkeypatch.undo()
    replay(INTEL_EXCERPT, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert_same_outputs(full_run[0], out)


def test_a_replay_stopped_at_a_malformed_line_resumes_past_it_skipping_bad_lines(tmp_path, capsys):
    """A damaged scan line stops a replay, and a plain resume stops at it again, so the
    rest of the log cannot be mapped that way; resumed with ``bad_lines="skip"``
    (``--skip-bad-lines``) it goes on past the line, as a replay skipping bad lines from
    the start does."""
    lines = gzip.open(INTEL_EXCERPT, "rt").read().splitlines()
    laser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    damaged = lines[laser[20]].split()
    damaged[5] = "abc"  # a range that is not a number
    lines[laser[20]] = " ".join(damaged)
    log = tmp_path / "damaged.log"
    log.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    given = {"max_range_m": 50.0}  # no survey of the whole log before the first scan
    with (
        pytest.warns(RuntimeWarning, match="stopped after 20 scans"),
        pytest.raises(ValueError, match=r"malformed FLASER line: .*bad_lines='skip'"),
    ):
        replay(log, out_dir=out, progress=False, reader_kwargs=given, **SETTINGS)
    with (  # the same line again
        pytest.warns(RuntimeWarning, match="stopped after 20 scans"),
        pytest.raises(ValueError, match="malformed FLASER line"),
    ):
        replay(log, out_dir=out, progress=False, resume=True, reader_kwargs=given, **SETTINGS)
    skip = {**given, "bad_lines": "skip"}
    with pytest.warns(UserWarning, match=r"skipped 1 malformed FLASER line\(s\)"):
        resumed = replay(
            log, out_dir=out, progress=False, resume=True, reader_kwargs=skip, **SETTINGS
        )
    whole = tmp_path / "whole"
    with pytest.warns(UserWarning, match="skipped 1 malformed"):
        replay(log, out_dir=whole, progress=False, reader_kwargs=skip, **SETTINGS)
    assert resumed["n_scans"] == len(laser) - 1
    assert_same_outputs(out, whole)
    # the command line's option
    again = tmp_path / "cli"
    argv = ["replay", str(log), "-o", str(again), "--max-range", "50"]
    argv += ["--graph-every", "7", "--skeleton-every", "3"]
    capsys.readouterr()
    assert main([*argv, "--skip-bad-lines"]) == 0
    assert "topojax replay: warning: " in capsys.readouterr().err  # one line
    assert_same_outputs(again, whole)


def test_replay_cli_a_signal_lost_on_the_way_ends_with_the_files_recorded(
    tmp_path, monkeypatch, capsys
):
    """A SIGTERM whose interrupt is lost (raised inside a callback that swallows it, as
    JAX's garbage-collection callback does) lets the replay finish: its files are
    complete and recorded for ``topojax view``, and the command still ends with 143."""
    import os
    import signal

    real = topojax.scans.read_scans

    def reader(source, **kw):
        for i, scan in enumerate(real(source, **kw)):
            if i == 5:
                try:
                    os.kill(os.getpid(), signal.SIGTERM)
                except KeyboardInterrupt:  # a callback that swallows it
                    pass
            yield scan

    monkeypatch.setattr(topojax.scans, "read_scans", reader)
    previous = signal.getsignal(signal.SIGTERM)
    out = tmp_path / "out"
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]
    try:
        assert main(args) == 143
    finally:
        signal.signal(signal.SIGTERM, previous)
    captured = capsys.readouterr()
    assert "SIGTERM arrived but the replay finished; its files are complete" in captured.err
    assert "wrote      " in captured.out
    assert (out / "graph.json").is_file() and not (out / STATE_FILE).exists()
    assert (out / ".topojax-outputs.json").is_file()


def test_a_replay_that_fails_before_keeping_anything_leaves_no_folder_it_made(tmp_path):
    """A log without laser lines is refused once read; the output folder the replay made
    for it goes again (one that was there stays), so no empty folder is left behind."""
    empty = tmp_path / "empty.log"
    empty.write_text("# a CARMEN log with no scans\n")
    out = tmp_path / "runs" / "out"
    with pytest.raises(ValueError, match="no laser lines"):
        replay(empty, out_dir=out)
    assert not out.exists()
    assert main(["replay", str(empty), "-o", str(out)]) == 2
    assert not out.exists()
    out.mkdir(parents=True)
    with pytest.raises(ValueError, match="no laser lines"):
        replay(empty, out_dir=out)
    assert out.is_dir()


@pytest.mark.parametrize("presses", [1, 2])
def test_a_ctrl_c_while_a_stopped_replay_keeps_its_scans_waits_for_them(
    tmp_path, monkeypatch, full_run, presses
):
    """Ctrl-C pressed again while a stopping replay saves its state (a second press of
    an impatient user) must not break off the save and lose the mapped scans without a
    word: a press then waits for the state and the recordings to be kept; a second one
    while it waits breaks off at once, and the warning says that nothing was kept."""
    import topojax._replay_state as replay_state
    import topojax.incremental.state as state_module

    def pressed(real):
        def saving(*args, **kwargs):
            for _ in range(presses):
                os.kill(os.getpid(), signal.SIGINT)
            return real(*args, **kwargs)

        return saving

    out, gif = tmp_path / "out", tmp_path / "graph.gif"
    interrupted_reader(monkeypatch, 12)
    monkeypatch.setattr(state_module, "save_state", pressed(state_module.save_state))
    monkeypatch.setattr(replay_state, "save_frames", pressed(replay_state.save_frames))
    kept = "is saved to" if presses == 1 else "was interrupted, so it is not kept"
    with pytest.warns(RuntimeWarning, match=kept), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, animate=gif, **SETTINGS)
    monkeypatch.undo()
    if presses == 2:
        assert not (out / STATE_FILE).exists()
        return
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 12
    assert (out / ".replay_partial" / "recorded.json").is_file()
    summary = replay(
        INTEL_EXCERPT, out_dir=out, progress=False, resume=True, animate=gif, **SETTINGS
    )
    assert summary["resumed_after"] == 12
    assert not [m for m in summary["messages"] if "holds the scans after" in m]
    assert_same_outputs(full_run[0], out)


def test_a_rooms_difference_on_resume_counts_one_scan_in_the_singular():
    from topojax._replay_state import _IN_WORDS

    differs = _IN_WORDS["rooms_every"]
    assert (
        differs(1, None)
        == "the saved replay updated rooms every 1 scan, this one has no rooms_every"
    )
    assert differs(None, 2).endswith("this one updates rooms every 2 scans")


def test_a_ctrl_c_while_the_recording_is_closed_keeps_the_scans(
    tmp_path, monkeypatch, full_recorded
):
    """A Ctrl-C that comes as the finished MCAP recording is closed into its file (the
    last of the replay's writing) keeps the mapper's state like one during the other
    files: the resumed replay writes the files of one that did not stop, and no
    temporary folder of the recording is left beside it."""
    from topojax.io.mcap import McapRecorder

    real = McapRecorder.close

    def close(self, path=None):
        if path is None:  # the final file, not a stopped replay's part
            raise KeyboardInterrupt
        return real(self, path)

    out = tmp_path / "out"
    monkeypatch.setattr(McapRecorder, "close", close)
    with pytest.warns(RuntimeWarning, match="stopped after 40 scans"):
        with pytest.raises(KeyboardInterrupt):
            recorded_replay(out)
    monkeypatch.undo()
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 40
    assert not [p.name for p in out.iterdir() if p.name.startswith(".run.mcap.")]
    summary = recorded_replay(out, resume=True)
    assert summary["resumed_after"] == 40
    assert_same_outputs(full_recorded, out)
    for name in RECORDINGS:
        assert (out / name).read_bytes() == (full_recorded / name).read_bytes(), name
    assert {t for t, *_ in mcap_messages(out / "run.mcap")} == {"/map", "/topology"}


def test_the_stop_warning_names_the_keyword_or_the_option_of_its_caller(
    tmp_path, monkeypatch, capsys
):
    """The warning of a stopped replay says how to continue it in its caller's words:
    ``resume=True`` from :func:`topojax.replay`, ``--resume`` from ``topojax replay``,
    not both to either."""
    interrupted_reader(monkeypatch, after=10)
    with pytest.warns(RuntimeWarning, match="stopped after 10 scans") as caught:
        with pytest.raises(KeyboardInterrupt):
            replay(INTEL_EXCERPT, out_dir=tmp_path / "api", progress=False, **SETTINGS)
    (text,) = [str(w.message) for w in caught if "stopped after" in str(w.message)]
    assert text.endswith("(replay again with resume=True to continue from it)")
    assert "--resume" not in text and "topojax replay" not in text
    monkeypatch.undo()
    interrupted_reader(monkeypatch, after=10)
    args = ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "cli"), "--no-progress"]
    assert main([*args, "--graph-every", "7", "--skeleton-every", "3"]) == 130
    err = capsys.readouterr().err
    assert "(the same command with --resume continues from it)" in err
    assert "resume=True" not in err
