"""The batch's own process pool: results and errors come back, and a worker that dies at
any moment, half way through writing its result too, costs only the task it ran."""

from __future__ import annotations

import concurrent.futures as cf
import os
import signal
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
    while not running.running():  # handed to the worker
        time.sleep(0.01)
    pool.shutdown(wait=True, cancel_futures=True)
    assert running.result(timeout=0) is None
    assert all(f.cancelled() for f in waiting)
    with pytest.raises(RuntimeError, match="after shutdown"):
        pool.submit(pow, 2, 2)

    pool = WorkerPool(1, mp_context=worker_context())
    pids = []
    long = pool.submit(time.sleep, 60)
    while not pids:
        pids = pool.pids
    t0 = time.monotonic()
    pool.terminate_workers()
    with pytest.raises(WorkerDied):
        long.result(timeout=30)
    pool.shutdown(wait=True)
    assert time.monotonic() - t0 < 30
    assert not os.path.exists(f"/proc/{pids[0]}") or _zombie_or_gone(pids[0])


def _zombie_or_gone(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] in "ZX"
    except OSError:
        return True


def test_max_workers_is_checked():
    with pytest.raises(ValueError, match="max_workers: expected an int >= 1, got 0"):
        WorkerPool(0)
    with pytest.raises(ValueError, match="max_workers"):
        WorkerPool(True)  # type: ignore[arg-type]


def test_a_pool_that_is_not_shut_down_lets_its_workers_go():
    pool = WorkerPool(1, mp_context=worker_context())
    assert pool.submit(pow, 2, 3).result(timeout=60) == 8
    pool.shutdown(wait=True)
    assert isinstance(pool, cf.Executor)
