"""Ctrl-C and SIGTERM taken by the batch's main loop between steps, never part way
through one (``docs/batch-internals.md``)."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import signal
import threading
from collections.abc import Collection, Iterator
from types import FrameType
from typing import Any

__all__ = ["HeldInterrupts"]

#: Seconds between checks for a held interrupt while the main loop waits.
POLL_S = 0.1
#: The signals held: Ctrl-C, and the SIGTERM that ``topojax batch`` turns into one.
_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class HeldInterrupts:
    """Within ``with`` in the main thread, a SIGINT or SIGTERM whose handler is a Python
    function (Ctrl-C's ``KeyboardInterrupt``, the command's SIGTERM) is held, and that
    handler runs at the next :meth:`check` or :meth:`wait`, or at the end of the block.

    An exception raised wherever the signal found the main thread could leave a lock
    held that the batch's other threads need: :func:`concurrent.futures.wait` takes each
    future's lock in turn, and one left taken stopped the pool's thread for ever, so the
    interrupted batch never ended.  Signals with the default action (which ends the
    process at once) or ignored, and every signal outside the main thread, are left as
    they are.
    """

    def __init__(self) -> None:
        self._previous: dict[int, Any] = {}
        self._pending: tuple[int, FrameType | None] | None = None  # the first held
        self._holding = True

    def __enter__(self) -> HeldInterrupts:
        if threading.current_thread() is threading.main_thread():
            try:
                for signum in _SIGNALS:
                    handler = signal.getsignal(signum)
                    if callable(handler):  # noted before it is replaced
                        self._previous[signum] = handler
                        signal.signal(signum, self._hold)
            except BaseException:  # a signal's handler ran first: none is left held
                self._restore()
                raise
        return self

    def __exit__(self, *exc: object) -> None:
        handlers = dict(self._previous)
        self._restore()
        self._deliver(handlers)

    def _restore(self) -> None:
        """Set the handlers that were replaced again, every one of them: ``signal.signal``
        first runs the handlers of signals that came, and the one of a signal whose own
        handler is back may raise before the next is set.  That exception (the stop) is
        raised once all are set."""
        stop: BaseException | None = None
        while True:
            try:
                for signum, handler in self._previous.items():
                    signal.signal(signum, handler)
                break
            except BaseException as exc:  # setting them again is harmless
                stop = stop or exc
        self._previous = {}
        if stop is not None:
            self._pending = None  # the same stop
            raise stop

    def _hold(self, signum: int, frame: FrameType | None) -> None:
        if self._pending is None:  # a later one is the same stop
            self._pending = (signum, frame)
        if not self._holding:
            self._deliver(self._previous)

    def _deliver(self, handlers: dict[int, Any]) -> None:
        """Run the handler of the held signal, if any."""
        if self._pending is not None:
            (signum, frame), self._pending = self._pending, None
            handlers[signum](signum, frame)

    def check(self) -> None:
        """Run the handler of a held signal now (``KeyboardInterrupt``, as a rule)."""
        self._deliver(self._previous)

    def wait(self, futures: Collection[cf.Future]) -> set[cf.Future]:
        """The futures of ``futures`` done once one is, as :func:`concurrent.futures.wait`
        with ``FIRST_COMPLETED`` finds them; a held signal is delivered meanwhile."""
        timeout = POLL_S if self._previous else None
        while True:
            self.check()
            done, _ = cf.wait(futures, timeout=timeout, return_when=cf.FIRST_COMPLETED)
            if done:
                return done

    @contextlib.contextmanager
    def at_once(self) -> Iterator[None]:
        """Within ``with``, signals are delivered as they come: for work the main thread
        does itself (a map's CPU stage with ``workers=0``), which holds no lock of the
        batch's threads and may take minutes."""
        self._holding = False
        try:
            self.check()  # after the change: one that comes between is not held
            yield
        finally:
            self._holding = True
