"""The batch's own process pool: one pipe per worker process, so that a worker killed at
any moment (the OOM killer, say) loses only the task it ran.

Python's :class:`~concurrent.futures.ProcessPoolExecutor` gathers every worker's result
on one shared pipe: a worker killed half way through writing its result leaves half a
message there, the pool's reader waits for the rest for ever, and the other workers wait
for the pipe's lock the dead one held.  Here each worker has its own pipe, whose far end
closes when the worker dies: a cut-off result reads as the end of the file, the task
fails with :class:`WorkerDied`, and a new process takes the worker's place.
"""

from __future__ import annotations

import atexit
import concurrent.futures as cf
import contextlib
import multiprocessing
import multiprocessing.connection as mpc
import signal
import threading
import traceback
import weakref
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from multiprocessing import resource_tracker
from multiprocessing.reduction import ForkingPickler
from typing import Any

__all__ = ["WorkerDied", "WorkerPool", "terminate_workers"]

#: Worker deaths in a row, with no task done in between, after which the pool is broken
#: (workers that cannot start, or a machine out of memory, would be replaced for ever).
DEATHS_IN_A_ROW = 3


class WorkerDied(cf.BrokenExecutor):
    """A worker process died while it ran the task, or the pool was broken before the
    task could run."""


class _RemoteTraceback(Exception):
    """The traceback of an exception raised in a worker process, as its cause."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def _outcome_bytes(ok: bool, value: Any, trace: str) -> memoryview:
    """The pickled ``(ok, value, trace)`` a worker sends back; an exception or result that
    cannot be pickled becomes a RuntimeError that names it."""
    try:
        return ForkingPickler.dumps((ok, value, trace))
    except Exception as exc:
        what = "result" if ok else f"exception {type(value).__name__}: {value}"
        error = RuntimeError(f"the task's {what} cannot be sent back: {exc}")
        return ForkingPickler.dumps((False, error, trace))


def _serve(conn: mpc.Connection) -> None:
    """A worker process: run each task read from ``conn`` and send back its outcome, until
    the pool closes the pipe."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the pool's process stops the workers
    while True:
        try:
            data = conn.recv_bytes()
        except (EOFError, OSError):
            return
        try:
            fn, args, kwargs = ForkingPickler.loads(data)
            del data
            outcome = (True, fn(*args, **kwargs), "")
        except BaseException as exc:  # noqa: BLE001 - every failure goes back to the pool
            outcome = (False, exc, "".join(traceback.format_exception(exc)))
        fn = args = kwargs = data = None  # an idle worker holds no task's arguments
        try:
            conn.send_bytes(_outcome_bytes(*outcome))
        except OSError:  # the pool's process has gone
            return
        del outcome


@contextlib.contextmanager
def _ctrl_c_blocked() -> Iterator[None]:
    """Within ``with``, the calling thread takes no Ctrl-C (SIGINT, blocked), and a
    process it starts takes none from its first instruction on: the pool stops its
    workers (and the forkserver they are forked from), and a Ctrl-C that came while one
    imported its modules printed its traceback.  A forkserver unblocks it once its
    modules are imported (:mod:`topojax.batch.preloaded`), for its later children.  The
    caller's other threads, or this one after the block, take a Ctrl-C that comes
    meanwhile."""
    if not hasattr(signal, "pthread_sigmask"):  # not POSIX
        yield
        return
    # started first by a process's start, multiprocessing's resource tracker unblocks
    # SIGINT as its own start ends
    resource_tracker.ensure_running()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@dataclass(eq=False)
class _Task:
    future: cf.Future
    call: tuple[Any, tuple, dict] | None  # fn, args, kwargs: pickled as it is handed over


def _fail(tasks: list[_Task], message: str) -> None:
    """Fail each of ``tasks`` (one cancelled meanwhile stays cancelled) with ``message``."""
    for task in tasks:
        try:
            task.future.set_exception(WorkerDied(message))
        except cf.InvalidStateError:
            pass


def _drop(tasks: list[_Task]) -> None:
    """Cancel each of ``tasks``; one already running (handed to a worker that died before
    it could run it) fails instead."""
    _fail([task for task in tasks if not task.future.cancel()], "the pool was stopped")


@dataclass(eq=False)
class _Worker:
    process: Any  # a multiprocessing Process
    conn: mpc.Connection
    task: _Task | None = None


#: The pools not yet ended: their workers are stopped when the interpreter exits.
_LIVE_POOLS: weakref.WeakSet[WorkerPool] = weakref.WeakSet()


@atexit.register
def _stop_live_pools() -> None:
    """At exit (before multiprocessing's own clean-up, registered earlier), stop every
    pool's workers and drop its waiting tasks: no worker is started, or left running, for
    a process that has gone."""
    for pool in list(_LIVE_POOLS):
        pool.terminate_workers()


class WorkerPool(cf.Executor):
    """A pool of ``max_workers`` worker processes, each with its own pipe.

    Parameters
    ----------
    max_workers : int
        Worker processes, at least 1.
    mp_context : multiprocessing context, optional
        How the processes start (default: multiprocessing's default context).

    Notes
    -----
    A task runs on one idle worker at a time; tasks wait in this process until a worker
    is free.  A worker that dies fails its task with :class:`WorkerDied` and is replaced;
    after :data:`DEATHS_IN_A_ROW` deaths with no task done in between, or when no worker
    can be started, the pool is broken: its waiting tasks fail with :class:`WorkerDied`
    and :meth:`submit` raises it.
    """

    def __init__(self, max_workers: int, *, mp_context: Any = None) -> None:
        if isinstance(max_workers, bool) or not isinstance(max_workers, int) or max_workers < 1:
            raise ValueError(f"max_workers: expected an int >= 1, got {max_workers!r}")
        self._ctx = mp_context if mp_context is not None else multiprocessing.get_context()
        self._size = max_workers
        self._lock = threading.Lock()
        self._queue: deque[_Task] = deque()
        self._workers: list[_Worker] = []
        self._broken: str | None = None
        self._closing = False  # shut down: no new task
        self._stopped = False  # workers terminated: none is started, no task handed over
        self._deaths = 0  # in a row
        self._wake_lock = threading.Lock()
        self._woken = False  # a wake-up message waits in the pipe
        self._wake_r, self._wake_w = multiprocessing.Pipe(duplex=False)
        try:  # here, so that a process that cannot start says so to the caller
            for _ in range(max_workers):
                self._start_worker()
        except BaseException:
            self._stopped = True
            self._close()
            raise
        _LIVE_POOLS.add(self)
        self._thread = threading.Thread(target=self._run, name="topojax-pool", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ the Executor API
    def submit(self, fn, /, *args, **kwargs):  # noqa: D102 - Executor API
        future: cf.Future = cf.Future()
        with self._lock:
            if self._broken is not None:
                raise WorkerDied(self._broken)
            if self._closing:
                raise RuntimeError("cannot schedule new tasks after shutdown")
            self._queue.append(_Task(future, (fn, args, kwargs)))
        self._wake()
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop taking tasks; the waiting ones run (or are cancelled with
        ``cancel_futures``), then the workers exit.  ``wait`` waits for that."""
        with self._lock:
            self._closing = True
            dropped = list(self._queue) if cancel_futures else []
            if cancel_futures:
                self._queue.clear()
        _drop(dropped)  # outside the lock: a done-callback may call the pool
        self._wake()
        if wait and self._thread is not threading.current_thread():
            self._thread.join()

    def terminate_workers(self) -> None:
        """Stop the worker processes now (SIGTERM): their tasks fail with
        :class:`WorkerDied`, the waiting ones are cancelled, and the pool takes no more."""
        with self._lock:
            self._closing = self._stopped = True
            processes = [w.process for w in self._workers]
            dropped = list(self._queue)
            self._queue.clear()
        _drop(dropped)
        for process in processes:
            if process.is_alive():
                process.terminate()
        self._wake()

    @property
    def pids(self) -> list[int]:
        """The process ids of the live workers."""
        with self._lock:
            return [w.process.pid for w in self._workers if w.process.pid is not None]

    # ------------------------------------------------------------------ the pool's thread
    def _wake(self) -> None:
        """Wake the pool's thread (one message waits at most: the pipe never fills)."""
        with self._wake_lock:
            if not self._woken and not self._wake_w.closed:
                self._woken = True
                self._wake_w.send_bytes(b"")

    def _start_worker(self) -> None:
        ours, theirs = multiprocessing.Pipe(duplex=True)
        try:
            process = self._ctx.Process(target=_serve, args=(theirs,), daemon=True)
            with _ctrl_c_blocked():
                process.start()
        except BaseException:
            ours.close()
            raise
        finally:
            theirs.close()  # only the worker holds that end: its death closes the pipe
        with self._lock:
            self._workers.append(_Worker(process, ours))
            stopped = self._stopped
        if stopped:  # terminate_workers ran while it started
            process.terminate()

    def _run(self) -> None:
        try:
            while self._step():
                pass
        except BaseException as exc:  # no task may wait for ever on a pool that ended
            self._break(f"the pool's thread failed: {type(exc).__name__}: {exc}")
            raise
        finally:
            self._close()

    def _break(self, reason: str) -> None:
        """Break the pool: :meth:`submit` refuses, and the waiting tasks fail."""
        with self._lock:
            if self._broken is None:
                self._broken = reason
            failed = list(self._queue)
            self._queue.clear()
        _fail(failed, f"the pool is broken: {reason}")

    def _fill(self) -> None:
        """Start workers up to the pool's size while tasks may come; where one cannot
        start, the pool goes on with those it has, and breaks when it has none."""
        while len(self._workers) < self._size and self._broken is None:
            if self._stopped or (self._closing and not self._queue):
                return
            try:
                self._start_worker()
            except Exception as exc:  # out of memory or processes, say
                if self._workers:
                    self._size = len(self._workers)
                    return
                self._break(f"a worker process could not start: {type(exc).__name__}: {exc}")

    def _step(self) -> bool:
        """Hand tasks to idle workers and wait for one event; False once the pool ends."""
        self._fill()
        with self._lock:
            if self._closing and not self._queue and all(w.task is None for w in self._workers):
                return False
            handed = []
            for w in self._workers:
                while w.task is None and self._queue and not self._stopped:
                    task = self._queue.popleft()
                    # one handed back is running already (its worker died before it)
                    if task.future.running() or task.future.set_running_or_notify_cancel():
                        w.task = task
                        handed.append(w)
        for w in handed:
            self._send(w)
        busy = [w.conn for w in self._workers if w.task is not None]
        sentinels = [w.process.sentinel for w in self._workers]
        with self._lock:  # a task left for an idle worker (its last could not be sent)
            more = bool(self._queue) and len(busy) < len(self._workers) and not self._stopped
        ready = mpc.wait([self._wake_r, *busy, *sentinels], timeout=0 if more else None)
        if self._wake_r in ready:
            with self._wake_lock:
                self._wake_r.recv_bytes()
                self._woken = False
        for w in list(self._workers):
            if w.conn in ready:
                self._receive(w)
            elif w.process.sentinel in ready:
                self._died(w)
        return True

    def _send(self, w: _Worker) -> None:
        task = w.task
        assert task is not None and task.call is not None
        if w.process.exitcode is not None:  # it died idle: the task goes to another
            self._hand_back(w)
            return
        try:
            payload = ForkingPickler.dumps(task.call)
        except Exception as exc:  # the worker stays idle, for the next task
            w.task = None
            task.future.set_exception(exc)
            return
        try:
            w.conn.send_bytes(payload)
        except OSError:  # it died before it read the task (or was stopped)
            self._hand_back(w)
            return
        task.call = None

    def _hand_back(self, w: _Worker) -> None:
        """Worker ``w`` died before it could read its task: the task waits for another
        worker, first in line, or, in a pool stopped or broken meanwhile, is dropped."""
        task, w.task = w.task, None
        with self._lock:
            ended = self._stopped or self._broken is not None
            if not ended:
                self._queue.appendleft(task)
        if ended:
            _drop([task])
        self._died(w)

    def _receive(self, w: _Worker) -> None:
        try:
            data = w.conn.recv_bytes()
        except (EOFError, OSError):  # it died, perhaps half way through its result
            self._died(w)
            return
        task, w.task = w.task, None
        with self._lock:
            self._deaths = 0
        if task is None:
            return
        try:
            ok, value, trace = ForkingPickler.loads(data)
        except Exception as exc:
            task.future.set_exception(exc)
            return
        if ok:
            task.future.set_result(value)
        else:
            value.__cause__ = _RemoteTraceback(f'\n"""\n{trace}"""')
            task.future.set_exception(value)

    def _died(self, w: _Worker) -> None:
        """Worker ``w`` died: fail its task, forget it (a new one takes its place) and,
        after too many deaths in a row, break the pool."""
        w.process.join(timeout=5)
        w.conn.close()
        code = w.process.exitcode
        with self._lock:
            self._workers.remove(w)
            self._deaths += 1
            failed = [] if w.task is None else [w.task]
            broken = self._deaths >= DEATHS_IN_A_ROW and not self._closing
        _fail(failed, f"a worker process died (exit code {code}) while it ran the task")
        if broken:
            self._break(
                f"worker processes died {DEATHS_IN_A_ROW} times in a row (last exit code "
                f"{code}) with no task done in between"
            )

    def _close(self) -> None:
        """Let the idle workers exit (their pipes close), stop busy ones (only a pool
        whose thread failed has them), and fail what is left."""
        _LIVE_POOLS.discard(self)
        with self._lock:
            workers, self._workers = self._workers, []
            left = list(self._queue)
            self._queue.clear()
            self._closing = True
        for w in workers:
            w.conn.close()
            if w.task is not None:
                left.append(w.task)
                w.process.kill()
        for w in workers:
            w.process.join(timeout=10)
            if w.process.is_alive():
                w.process.kill()
                w.process.join()
        _fail(left, "the pool ended before the task's outcome came back")
        with self._wake_lock:
            self._wake_w.close()
        self._wake_r.close()


def terminate_workers(executor: cf.Executor | None) -> None:
    """Stop the processes of an own process pool now, for a batch that is interrupted.

    Shutting the pool down waits for the maps its processes are building, whose results
    the interrupted batch no longer records (no manifest): an interrupt then took as
    long as the slowest map in flight.  Their partly written files are removed when
    the maps are redone.
    """
    if isinstance(executor, WorkerPool):
        executor.terminate_workers()
