"""One writer per output folder: a replay or a batch holds a lock on its output folder
while it runs (``topojax._lock``), so that a second one into the same folder is refused
at once instead of silently overwriting the first one's files."""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import topojax
import topojax._lock
from topojax import build_graph_tiled, build_graphs
from topojax._lock import LOCK_FILE, one_writer
from topojax.cli import main
from topojax.playback import replay

ROOT = Path(__file__).resolve().parents[1]
INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
OFFICE = Path(topojax.__file__).parent / "data" / "office.png"

#: Holds the lock of the folder argv[1] for ``topojax replay`` until its input closes.
_HOLDER = """
import sys
from topojax._lock import one_writer

with one_writer(sys.argv[1], name="out_dir", command="replay"):
    print("locked", flush=True)
    sys.stdin.read()
"""


@pytest.fixture
def held(tmp_path):
    """An output folder whose lock another process holds; yields it and that process."""
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(out)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        assert proc.stdout.readline().strip() == "locked"
        yield out, proc
    finally:
        proc.kill()
        proc.wait(timeout=60)


def test_a_second_writer_into_a_folder_is_refused_at_once(held, capsys):
    """While another process writes into the folder, a replay, a batch and a tiled build
    into it are refused before they read anything, naming the option (or parameter), the
    folder and the process; they write nothing there."""
    out, proc = held
    said = f"another topojax process (pid {proc.pid}, topojax replay) is writing into {out}"
    assert main(["replay", str(INTEL_EXCERPT), "-o", str(out), "--no-progress"]) == 2
    assert f"topojax replay: error: --out: {said}; wait for it" in capsys.readouterr().err
    assert main(["batch", str(OFFICE), "-o", str(out), "--no-progress", "--workers", "0"]) == 2
    assert f"topojax batch: error: --out: {said}" in capsys.readouterr().err
    with pytest.raises(BlockingIOError, match=rf"^\[Errno {errno.EWOULDBLOCK}\] out_dir: "):
        replay(INTEL_EXCERPT, out_dir=out, progress=False)
    with pytest.raises(BlockingIOError, match="out_dir: another topojax process"):
        build_graphs([OFFICE], out_dir=out, workers=0, progress=False)
    with pytest.raises(BlockingIOError, match="out_dir: another topojax process"):
        build_graph_tiled(np.ones((64, 64), bool), out_dir=out)
    assert sorted(p.name for p in out.iterdir()) == [LOCK_FILE]


def test_a_tiled_build_into_a_locked_folder_is_refused(held, capsys):
    """``topojax graph --tiled`` keeps its blocks for ``--resume`` in its output folder:
    it takes the folder's lock too, and is refused while another process holds it."""
    out, proc = held
    argv = ["graph", str(OFFICE), "-o", str(out), "--tiled", "--resolution", "0.05"]
    assert main(argv) == 2
    said = f"another topojax process (pid {proc.pid}, topojax replay) is writing into {out}"
    assert f"topojax graph: error: --out: {said}; wait for it" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [LOCK_FILE]


def test_a_tiled_build_holds_the_lock_of_its_folder(tmp_path, monkeypatch, capsys):
    """While a tiled build runs, its folder's lock is held in the build's name."""
    from topojax.outofcore import build

    out, seen = tmp_path / "out", []
    real = build.build_graph_tiled

    def spying(*args, **kwargs):
        seen.append((out / LOCK_FILE).read_text())
        return real(*args, **kwargs)

    monkeypatch.setattr(build, "build_graph_tiled", spying)
    argv = ["graph", str(OFFICE), "-o", str(out), "--tiled", "--resolution", "0.05"]
    assert main(argv) == 0
    assert seen == [f"{os.getpid()} topojax graph --tiled\n"]
    assert not (out / LOCK_FILE).exists()


def test_the_lock_of_a_killed_writer_is_not_left_behind(held):
    """``kill -9`` of the writer lets its lock go (the file stays): the next replay
    takes it over and, done, removes it."""
    out, proc = held
    proc.kill()
    proc.wait(timeout=60)
    assert (out / LOCK_FILE).is_file()
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, max_scans=5)
    assert summary["n_scans"] == 5
    assert not (out / LOCK_FILE).exists()


#: Holds the lock of the folder argv[1] and forks: with argv[2] "pool", a ``fork`` pool
#: worker that sleeps on, then the writer kills itself; with "leave", a child that leaves
#: the ``with`` block as its parent would, then the writer waits for its input to close.
_FORKING = """
import multiprocessing, os, signal, sys, time
from topojax._lock import one_writer

def sleeper(started):
    started.set()  # after the fork's handlers: the copy of the lock is closed by now
    time.sleep(60)

with one_writer(sys.argv[1], name="out_dir", command="batch"):
    if sys.argv[2] == "pool":
        fork = multiprocessing.get_context("fork")
        started = fork.Event()
        child = fork.Process(target=sleeper, args=(started,))
        child.start()
        started.wait(60)
        print(child.pid, flush=True)
        os.kill(os.getpid(), signal.SIGKILL)
    pid = os.fork()
    if pid == 0:
        sys.exit(0)  # leaves the with block: must not let the parent's lock go
    os.waitpid(pid, 0)
    print(pid, flush=True)
    sys.stdin.read()
"""


@pytest.mark.parametrize("how", ["pool", "leave"])
def test_a_forked_child_does_not_keep_or_drop_the_lock(tmp_path, how):
    """A process forked while the lock is held closes its copy: a writer killed with
    its ``fork`` pool's workers alive leaves the folder free (a copy in the workers
    would hold the ``flock`` on), and a child that leaves the ``with`` block neither
    removes the lock file nor lets the lock go."""
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-c", _FORKING, str(out), how],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    child = int(proc.stdout.readline())
    try:
        if how == "pool":
            proc.wait(timeout=60)
            with one_writer(out, name="out_dir"):
                pass
        else:
            assert (out / LOCK_FILE).read_text() == f"{proc.pid} topojax batch\n"
            with pytest.raises(BlockingIOError, match=f"pid {proc.pid}, topojax batch"):
                with one_writer(out, name="out_dir"):
                    pass
    finally:
        if how == "pool":
            with contextlib.suppress(ProcessLookupError):
                os.kill(child, signal.SIGKILL)
        proc.kill()
        proc.wait(timeout=60)


def test_the_lock_names_its_holder_and_goes_with_it(tmp_path):
    out = tmp_path / "out"
    with one_writer(out, name="-o/--out", command="batch") as folder:
        assert folder == out
        assert (out / LOCK_FILE).read_text() == f"{os.getpid()} topojax batch\n"
        with pytest.raises(BlockingIOError) as refused:
            with one_writer(out, name="out_dir"):
                pass
        assert refused.value.strerror == (
            f"out_dir: another topojax process (pid {os.getpid()}, topojax batch) is "
            f"writing into {out}; wait for it to end, or write into another folder"
        )
    assert not (out / LOCK_FILE).exists()
    with one_writer(out, name="out_dir"):  # free again
        pass


def no_locks(fd, operation):
    raise OSError(errno.ENOLCK, os.strerror(errno.ENOLCK))


@pytest.mark.parametrize(
    "fcntl",
    [None, SimpleNamespace(LOCK_EX=2, LOCK_NB=4, flock=no_locks)],
    ids=["no fcntl", "no flock on the file system"],
)
def test_without_flock_no_lock_is_taken(tmp_path, monkeypatch, fcntl):
    """Where the system has no ``fcntl`` (Windows), or the file system no ``flock`` (an
    error), the writers run unlocked and leave no lock file."""
    monkeypatch.setattr(topojax._lock, "fcntl", fcntl)
    out = tmp_path / "out"
    with one_writer(out, name="out_dir"):
        with one_writer(out, name="out_dir"):
            assert not (out / LOCK_FILE).exists()
