"""The batch's own process pool: results and errors come back, and a worker that dies at
any moment, half way through writing its result too, costs only the task it ran."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from topojax.batch.pool import DEATHS_IN_A_ROW, WorkerDied, WorkerPool
from topojax.batch.worker import worker_context


def _late_bytes(delay_s: float, n: int) -> bytes:
    time.sleep(delay_s)
    return bytes(n)


def _fail(text: str) -> None:
    raise ValueError(text)


def _unpicklable() -> object:
    return threading.Lock()


@pytest.fixture
def pool():
    p = WorkerPool(2, mp_context=worker_context())
    yield p
    p.terminate_workers()
    p.shutdown(wait=True)


def test_results_and_errors_come_back(pool):
    futures = [pool.submit(pow, i, 2) for i in range(20)]
    assert [f.result(timeout=60) for f in futures] == [i * i for i in range(20)]
    failed = pool.submit(_fail, "no such map")
    with pytest.raises(ValueError, match="no such map") as info:
        failed.result(timeout=60)
    assert "_fail" in str(info.value.__cause__)  # the worker's traceback
    with pytest.raises(RuntimeError, match="cannot be sent back"):
        pool.submit(_unpicklable).result(timeout=60)
    unsendable = [pool.submit(pow, threading.Lock(), 2) for _ in range(3)]
    after = pool.submit(pow, 5, 2)
    for f in unsendable:
        with pytest.raises(TypeError, match="pickle"):
            f.result(timeout=60)
    assert after.result(timeout=60) == 25
    assert pool.submit(os.getpid).result(timeout=60) in pool.pids


def test_a_worker_that_dies_fails_only_its_task(pool):
    slow = [pool.submit(_late_bytes, 0.5, 10) for _ in range(3)]
    dead = pool.submit(os._exit, 7)
    with pytest.raises(WorkerDied, match="exit code 7"):
        dead.result(timeout=60)
    assert [f.result(timeout=60) for f in slow] == [bytes(10)] * 3
    assert pool.submit(pow, 3, 3).result(timeout=60) == 27  # a new worker took its place
    assert len(pool.pids) == 2


def _writing(pid: int) -> bool:
    """Whether process ``pid`` waits in a write to a full pipe or socket."""
    try:
        wchan = Path(f"/proc/{pid}/wchan").read_text()
    except OSError:
        return False
    return any(word in wchan for word in ("pipe_write", "pipe_wait", "sock_alloc_send", "sendmsg"))


@pytest.mark.skipif(not Path("/proc/self/wchan").is_file(), reason="needs /proc")
def test_a_worker_killed_while_it_writes_its_result_costs_only_that_task(pool):
    """Python's process pool waits for ever on such a half-written result."""
    entered, gate = threading.Event(), threading.Event()
    blocker = pool.submit(time.sleep, 1.0)

    def hold(_):  # runs on the pool's thread, which then reads no result
        entered.set()
        gate.wait(60)

    blocker.add_done_callback(hold)
    big = pool.submit(_late_bytes, 2.0, 64 << 20)
    try:
        assert entered.wait(60)
        deadline = time.monotonic() + 60
        writers: list[int] = []
        while not writers and time.monotonic() < deadline:
            time.sleep(0.1)
            writers = [pid for pid in pool.pids if _writing(pid)]
        assert len(writers) == 1, "no worker blocked writing its result"
        os.kill(writers[0], signal.SIGKILL)
    finally:
        gate.set()
    with pytest.raises(WorkerDied, match="died"):
        big.result(timeout=60)
    assert pool.submit(pow, 2, 10).result(timeout=60) == 1024


def test_workers_that_keep_dying_break_the_pool():
    pool = WorkerPool(1, mp_context=worker_context())
    try:
        futures = [pool.submit(os._exit, 1) for _ in range(DEATHS_IN_A_ROW)]
        waiting = pool.submit(pow, 2, 2)
        for f in futures:
            with pytest.raises(WorkerDied):
                f.result(timeout=60)
        with pytest.raises(WorkerDied, match="broken"):
            waiting.result(timeout=60)
        with pytest.raises(WorkerDied, match="in a row"):
            pool.submit(pow, 2, 2)
    finally:
        pool.shutdown(wait=True)


def test_shutdown_cancels_or_runs_what_waits_and_terminate_kills():
    pool = WorkerPool(1, mp_context=worker_context())
    running = pool.submit(time.sleep, 0.5)
    waiting = [pool.submit(pow, 2, i) for i in range(3)]
    seen: list = []
    waiting[0].add_done_callback(lambda f: seen.append(pool.pids))  # calls the pool back
    while not running.running():  # handed to the worker
        time.sleep(0.01)
    closer = threading.Thread(target=pool.shutdown, kwargs={"cancel_futures": True}, daemon=True)
    closer.start()
    closer.join(60)
    assert not closer.is_alive(), "shutdown waits on its own lock"
    assert running.result(timeout=0) is None
    assert all(f.cancelled() for f in waiting) and len(seen) == 1
    with pytest.raises(RuntimeError, match="after shutdown"):
        pool.submit(pow, 2, 2)

    pool = WorkerPool(1, mp_context=worker_context())
    long = pool.submit(time.sleep, 60)
    queued = [pool.submit(os.getpid) for _ in range(3)]
    while not long.running():
        time.sleep(0.01)
    pids = pool.pids
    pool.terminate_workers()
    with pytest.raises(WorkerDied):
        long.result(timeout=30)
    assert all(f.cancelled() for f in queued)  # not run on a new worker
    pool.shutdown(wait=True)
    assert pool.pids == [] and not any(_alive(pid) for pid in pids)


def test_a_pool_stopped_while_it_hands_over_a_task_ends():
    """terminate_workers while a large task is being sent: the task fails or is
    cancelled, and shutdown returns (the task was put back in the queue of a stopped
    pool, and shutdown waited for ever)."""
    pool = WorkerPool(1, mp_context=worker_context())
    assert pool.submit(int).result(timeout=60) == 0  # the worker is up
    big = pool.submit(len, bytes(128 << 20))
    while not big.running():  # handed over: the pool's thread pickles and sends it
        time.sleep(0.001)
    pool.terminate_workers()
    closer = threading.Thread(target=pool.shutdown, daemon=True)
    closer.start()
    closer.join(60)
    assert not closer.is_alive(), "shutdown waits on a task no worker will run"
    assert big.done()


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (not gone, not a zombie)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in "ZX"
    except OSError:
        return False


def test_max_workers_is_checked():
    with pytest.raises(ValueError, match="max_workers: expected an int >= 1, got 0"):
        WorkerPool(0)
    with pytest.raises(ValueError, match="max_workers"):
        WorkerPool(True)  # type: ignore[arg-type]


_EXIT_WITHOUT_SHUTDOWN = """
import multiprocessing.forkserver
import time
from pathlib import Path

from topojax.batch.pool import WorkerPool
from topojax.batch.worker import worker_context

if __name__ == "__main__":
    pool = WorkerPool(1, mp_context=worker_context())
    running = pool.submit(time.sleep, 30)
    waiting = [pool.submit(Path(f"ran-{i}").touch) for i in range(3)]
    while not running.running():
        time.sleep(0.01)
    server = multiprocessing.forkserver._forkserver._forkserver_pid
    print(*pool.pids, server, flush=True)
"""


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs /proc")
def test_a_process_that_exits_without_shutdown_leaves_no_worker(tmp_path):
    """The interpreter's exit stops the workers and drops the waiting tasks: none runs on
    a worker started for a process that has gone."""
    script = tmp_path / "exits.py"
    script.write_text(_EXIT_WITHOUT_SHUTDOWN)
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    pids = [int(word) for word in done.stdout.split()]
    deadline = time.monotonic() + 20
    while any(map(_alive, pids)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(map(_alive, pids)), "a worker or the fork server outlived the process"
    assert not list(tmp_path.glob("ran-*")), "a waiting task ran after the exit"


_CTRL_C_MASKS = """
import multiprocessing as mp
import multiprocessing.forkserver as fs
import signal
from topojax.batch.pool import WorkerPool
from topojax.batch.worker import worker_context

def takes_ctrl_c(pid="self"):  # neither blocked nor ignored
    with open(f"/proc/{pid}/status") as f:
        masks = dict(line.split()[:2] for line in f if line.startswith(("SigBlk", "SigIgn")))
    bit = 1 << (signal.SIGINT - 1)
    return not (int(masks["SigBlk:"], 16) | int(masks["SigIgn:"], 16)) & bit

if __name__ == "__main__":
    ctx = worker_context()
    pool = WorkerPool(1, mp_context=ctx)
    ours = [pool.submit(takes_ctrl_c).result(timeout=120)]
    if ctx.get_start_method() == "forkserver":
        ours.append(takes_ctrl_c(fs._forkserver._forkserver_pid))
        with mp.get_context("forkserver").Pool(1) as users:  # the same forkserver
            theirs = users.apply(takes_ctrl_c)
    else:
        theirs = True
    print(*ours, theirs, takes_ctrl_c())
    pool.shutdown()
"""


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs /proc")
def test_worker_processes_leave_ctrl_c_to_the_pool_and_others_take_it(tmp_path):
    """A Ctrl-C in a terminal reaches every process of the batch: the workers, and the
    forkserver they come from, leave it to the pool's process (which stops them); a
    caller's own processes forked later by the same forkserver, and the pool's process,
    take it."""
    script = tmp_path / "masks.py"
    script.write_text(_CTRL_C_MASKS)
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr
    *ours, theirs, caller = run.stdout.split()
    assert ours and all(took == "False" for took in ours)
    assert (theirs, caller) == ("True", "True")


_PENDING_CTRL_C = """
import os, signal
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})  # as the forkserver starts
os.kill(os.getpid(), signal.SIGINT)  # a Ctrl-C while it imports: pending
import topojax.batch.preloaded
print(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, ()),
      signal.getsignal(signal.SIGINT) is signal.default_int_handler)
"""


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="POSIX signal masks")
def test_the_forkserver_takes_ctrl_c_again_once_its_modules_are_imported():
    """The module the forkserver imports last unblocks SIGINT and drops a Ctrl-C that
    came while it imported (no traceback); its handler is left as it was."""
    run = subprocess.run(
        [sys.executable, "-c", _PENDING_CTRL_C], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["False", "True"]
