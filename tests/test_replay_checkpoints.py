"""Checkpoints of a replay (``replay(..., checkpoint_every_s=...)``, ``topojax replay
--checkpoint-every``): the mapper's state saved as the replay goes, so that ``--resume``
continues a replay killed outright (``kill -9``, out of memory, a power cut), which saves
nothing as it dies."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import topojax._replay_state
import topojax.scans
from topojax.cli import main
from topojax.playback import STATE_FILE, replay

ROOT = Path(__file__).resolve().parents[1]
INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
SETTINGS = {"graph_every": 7, "skeleton_every": 3}
CLI_SETTINGS = ["--no-progress", "--graph-every", "7", "--skeleton-every", "3"]
OUTPUTS = ("graph.json", "graph.graphml", "graph.geojson", "map.pgm", "map.yaml")


def saved_record(out: Path) -> dict:
    """The replay record of the state saved in ``out``."""
    with np.load(out / STATE_FILE) as data:
        return json.loads(str(data["replay"]))


def assert_same_outputs(a: Path, b: Path) -> None:
    for name in OUTPUTS:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.fixture(scope="module")
def full_cli(tmp_path_factory):
    """An uninterrupted ``topojax replay`` of the excerpt, without checkpoints."""
    out = tmp_path_factory.mktemp("full_cli")
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), *CLI_SETTINGS]
    assert main([*args, "--checkpoint-every", "0"]) == 0
    return out


#: ``topojax replay`` killed with SIGKILL: when the reader is asked for the log's scan
#: KILL_AT ("scan"), or while the checkpoint after that many scans is being written, in
#: its temporary file's fsync ("write").
_KILLED = """
import os, signal, sys
import topojax._fs as fs
import topojax.scans
from topojax.cli import main

KILL_AT, WHEN = int(sys.argv[1]), sys.argv[2]
real = topojax.scans.read_scans
taken = 0

def reader(source, **kw):
    global taken
    for scan in real(source, **kw):
        if WHEN == "scan" and taken == KILL_AT:
            os.kill(os.getpid(), signal.SIGKILL)
        taken += 1
        yield scan

class Os:
    def __getattr__(self, name):
        return getattr(os, name)

    @staticmethod
    def fsync(fd):
        if WHEN == "write" and taken == KILL_AT:
            os.kill(os.getpid(), signal.SIGKILL)
        return os.fsync(fd)

topojax.scans.read_scans = reader
fs.os = Os()
sys.exit(main(sys.argv[3:]))
"""


def killed_replay(kill_at: int, when: str, out: Path, *options: str, every: str = "1e-9") -> None:
    """Run ``topojax replay`` of the excerpt into ``out`` with a checkpoint after every
    scan (or every ``every`` seconds), in a process killed with SIGKILL part way
    (:data:`_KILLED`)."""
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), *CLI_SETTINGS, *options]
    done = subprocess.run(
        [sys.executable, "-c", _KILLED, str(kill_at), when, *args, "--checkpoint-every", every],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=600,
    )
    assert done.returncode == -signal.SIGKILL, done.stderr


def test_a_replay_killed_outright_resumes_from_its_last_checkpoint(tmp_path, full_cli, capsys):
    """SIGKILL after 23 scans (no clean-up runs): the state of its last checkpoint, after
    the 23rd scan, is in the folder; --resume continues from it and writes the map and
    graph of a replay that was not killed.  The recordings, which a checkpoint does not
    keep, hold the scans after the 23rd, and the replay says why."""
    out = tmp_path / "out"
    recordings = ["--view", "--animate", str(out / "a.gif"), "--mcap", str(out / "run.mcap")]
    killed_replay(23, "scan", out, *recordings)
    record = saved_record(out)
    assert record["consumed"] == 23 and record["checkpoint"] is True
    assert not (out / "graph.json").exists() and not (out / "run.mcap").exists()
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), *CLI_SETTINGS, *recordings]
    assert main([*args, "--resume", "--checkpoint-every", "0"]) == 0  # its lock died with it
    said = capsys.readouterr().out
    assert_same_outputs(full_cli, out)
    for name in ("MCAP recording", "view timeline", "animation"):
        assert (
            f"the {name} holds the scans after the log's first 23: the replay was killed "
            "(kill -9, out of memory, a power cut) after saving this checkpoint"
        ) in said
    assert "mapper_state.npz: the replay has finished" in said
    assert (out / "run.mcap").is_file() and (out / "a.gif").is_file()
    left = sorted(p.name for p in out.iterdir() if p.name.startswith("."))
    assert left == [".topojax-outputs.json"]  # no temporary folder, lock or partial


def test_a_replay_killed_while_writing_a_checkpoint_keeps_the_one_before(tmp_path, full_cli):
    """SIGKILL part way through writing the checkpoint after the 23rd scan leaves the
    one after the 22nd whole (the new one goes to a temporary file renamed over it), and
    the resumed replay removes the temporary file the kill left."""
    out = tmp_path / "out"
    killed_replay(23, "write", out)
    assert saved_record(out)["consumed"] == 22
    assert [p.name for p in out.glob(f".{STATE_FILE}.*.tmp")]  # what the kill left
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), *CLI_SETTINGS, "--resume"]
    assert main([*args, "--checkpoint-every", "0"]) == 0
    assert_same_outputs(full_cli, out)
    assert not list(out.glob(".*.tmp")) and not (out / STATE_FILE).exists()


def test_a_fresh_replay_killed_before_its_first_checkpoint_leaves_nothing_to_resume(
    tmp_path, monkeypatch, capsys
):
    """A replay stopped after 17 scans leaves its state and recordings; a later replay
    without --resume (other options) killed outright after 5 scans, before its first
    checkpoint, has removed them as it started: --resume then says there is nothing to
    continue rather than continue the earlier run that the killed one replaced."""
    out = tmp_path / "out"
    stopping_reader(monkeypatch, 17, KeyboardInterrupt)
    args = ["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress", "--view"]
    assert main([*args, "--graph-every", "5"]) == 130
    monkeypatch.undo()
    assert saved_record(out)["consumed"] == 17 and (out / ".replay_partial").is_dir()
    killed_replay(5, "scan", out, "--view", every="0")
    assert not (out / STATE_FILE).exists() and not (out / ".replay_partial").exists()
    capsys.readouterr()
    assert main([*args, *CLI_SETTINGS[1:], "--resume"]) == 2
    assert "error: --resume: no saved state" in capsys.readouterr().err


def test_checkpoints_leave_the_results_as_they_were(tmp_path):
    """A checkpoint after every scan changes nothing the replay writes, and the finished
    replay removes the last one without a word (it was its own)."""
    kw = {"progress": False, "max_scans": 15, **SETTINGS}  # two graph updates and more
    plain = replay(INTEL_EXCERPT, out_dir=tmp_path / "a", checkpoint_every_s=0, **kw)
    summary = replay(INTEL_EXCERPT, out_dir=tmp_path / "b", checkpoint_every_s=1e-9, **kw)
    assert plain["checkpoints"] == 0 and summary["checkpoints"] == 15
    assert_same_outputs(tmp_path / "a", tmp_path / "b")
    assert not (tmp_path / "b" / STATE_FILE).exists()
    assert not [m for m in summary["messages"] if STATE_FILE in m]


class Killed(BaseException):
    """A kill in the process: nothing the replay does on an error or interrupt runs."""


def stopping_reader(monkeypatch, after: int, stop: type[BaseException] | None = None) -> None:
    """Make replay's reader raise ``stop`` (default :class:`Killed`) when asked for
    scan ``after``."""
    real = topojax.scans.read_scans

    def reader(source, **kw):
        for i, scan in enumerate(real(source, **kw)):
            if i == after:
                raise stop or Killed
            yield scan

    monkeypatch.setattr(topojax.scans, "read_scans", reader)


def test_checkpoints_come_once_their_time_is_due(tmp_path, monkeypatch):
    """With a clock that moves 10 s a scan, checkpoints 25 s apart come after every
    third scan: each saves the scans taken so far."""
    clock = SimpleNamespace(now=0.0)
    real = topojax.scans.read_scans

    def reader(source, **kw):
        for scan in real(source, **kw):
            clock.now += 10
            yield scan

    saved = []
    real_save = topojax._replay_state.save_replay_state

    def save(mapper, path, record):
        saved.append((record["consumed"], record.get("checkpoint")))
        return real_save(mapper, path, record)

    monkeypatch.setattr(topojax.scans, "read_scans", reader)
    monkeypatch.setattr(topojax._replay_state, "time", SimpleNamespace(monotonic=lambda: clock.now))
    monkeypatch.setattr(topojax._replay_state, "save_replay_state", save)
    summary = replay(
        INTEL_EXCERPT, out_dir=tmp_path / "out", progress=False, checkpoint_every_s=25, **SETTINGS
    )
    assert saved == [(n, True) for n in range(3, 41, 3)]
    assert summary["checkpoints"] == 13


def test_a_checkpoint_drops_the_recordings_an_earlier_stop_kept(tmp_path, monkeypatch):
    """Recordings a stopped replay kept (of its first 17 scans, made with a graph update
    every 5) do not belong to a later replay's checkpoint of as many scans: a resume
    after that replay was killed starts its recordings afresh, saying so, rather than
    continue those of the other run."""
    out = tmp_path / "out"

    def recorded(**kw):
        return replay(
            INTEL_EXCERPT, out_dir=out, progress=False, view=True, mcap=out / "r.mcap", **kw
        )

    stopping_reader(monkeypatch, 17, KeyboardInterrupt)
    with pytest.warns(RuntimeWarning), pytest.raises(KeyboardInterrupt):
        recorded(graph_every=5, skeleton_every=5)
    assert (out / ".replay_partial" / "recorded.json").is_file()
    monkeypatch.undo()
    stopping_reader(monkeypatch, 17)
    with pytest.raises(Killed):
        recorded(checkpoint_every_s=1e-9, **SETTINGS)
    monkeypatch.undo()
    assert saved_record(out)["consumed"] == 17 and not (out / ".replay_partial").exists()
    summary = recorded(resume=True, **SETTINGS)
    said = [m for m in summary["messages"] if "first 17: the replay was killed" in m]
    assert len(said) == 2, summary["messages"]  # the MCAP recording and the timeline


def test_a_failing_checkpoint_is_said_once_and_the_replay_goes_on(tmp_path, monkeypatch):
    def full_disk(mapper, path, record):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(topojax._replay_state, "save_replay_state", full_disk)
    with pytest.warns(RuntimeWarning, match="saving a checkpoint") as warned:
        summary = replay(
            INTEL_EXCERPT, out_dir=tmp_path / "o", progress=False, checkpoint_every_s=1e-9
        )
    assert summary["n_scans"] == 40 and summary["checkpoints"] == 0
    said = [str(w.message) for w in warned if "checkpoint" in str(w.message)]
    assert len(said) == 1 and "No space left on device" in said[0]
    assert "tries again every 1e-09 s" in said[0]
    assert [w.filename for w in warned] == [__file__]


@pytest.mark.parametrize("value", [-1, float("nan"), float("inf")])
def test_a_checkpoint_interval_must_be_a_number_of_seconds(tmp_path, value, capsys):
    with pytest.raises(ValueError, match=r"^checkpoint_every_s: expected a finite number of"):
        replay(INTEL_EXCERPT, out_dir=tmp_path / "o", checkpoint_every_s=value)
    args = ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "o")]
    assert main([*args, "--checkpoint-every", str(value)]) == 2
    assert "--checkpoint-every: expected a finite number of seconds >= 0" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_refused_resume_says_a_killed_replay_leaves_its_last_checkpoint(tmp_path, capsys):
    args = ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "new"), "--resume"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "one killed outright leaves its last checkpoint (every --checkpoint-every)" in err


def test_a_ctrl_c_while_a_checkpoint_is_saved_waits_for_it(tmp_path, monkeypatch):
    """Ctrl-C part way through a checkpoint takes effect once it is saved whole (the
    mapper is not left half way through counting free cells); the stop then saves the
    state as usual."""
    import signal as signals

    saved = []
    real_save = topojax._replay_state.save_replay_state

    def save(mapper, path, record):
        if record.get("checkpoint") and record["consumed"] == 12:
            signals.raise_signal(signals.SIGINT)
        result = real_save(mapper, path, record)
        saved.append((record["consumed"], record.get("checkpoint")))
        return result

    monkeypatch.setattr(topojax._replay_state, "save_replay_state", save)
    with pytest.warns(RuntimeWarning, match="stopped after 12 scans"):
        with pytest.raises(KeyboardInterrupt):
            replay(INTEL_EXCERPT, out_dir=tmp_path / "o", progress=False, checkpoint_every_s=1e-9)
    assert saved[-2:] == [(12, True), (12, None)]
