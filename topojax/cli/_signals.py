"""SIGTERM ending a command as Ctrl-C does."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator

__all__ = ["sigterm_stops"]

#: Times a stop that Python dropped is sent again (see :func:`sigterm_stops`).
_RESENDS = 10


@contextlib.contextmanager
def sigterm_stops(stopped: list[signal.Signals]) -> Iterator[None]:
    """Within ``with``, SIGTERM (``kill``, ``timeout``, a service manager's or job
    scheduler's stop) ends a command as Ctrl-C does: a ``KeyboardInterrupt``, with
    ``stopped`` then holding SIGTERM, so the command's clean-up runs (the default action,
    killing the process, would leave the temporary file of a write cut short in the output
    folder, and a batch's worker processes running).  It works where SIGINT is ignored (a
    background job of a script) too.

    A handler's exception raised where Python cannot pass it on (a garbage-collector
    callback, such as JAX's, or a ``__del__``) is dropped as "unraisable": the stop is
    then sent again, from a moment later, rather than lost.  Outside the main thread
    (where no handler can be set) nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    timers: list[threading.Timer] = []  # stops sent again
    closing = False  # the block has ended: a stop is only recorded

    def terminate(signum, frame):
        stopped[:] = [signal.SIGTERM]
        if not closing:
            raise KeyboardInterrupt

    def dropped(unraisable) -> None:
        if stopped and isinstance(unraisable.exc_value, KeyboardInterrupt):
            if len(timers) < _RESENDS:
                timers.append(threading.Timer(0.01, os.kill, (os.getpid(), signal.SIGTERM)))
                timers[-1].daemon = True
                timers[-1].start()
                return
        hook(unraisable)

    previous = signal.signal(signal.SIGTERM, terminate)
    hook, sys.unraisablehook = sys.unraisablehook, dropped
    try:
        yield
    finally:
        closing = True
        pending = False
        for timer in timers:  # none may stop the caller once the handler is restored
            pending |= timer.is_alive()
            timer.cancel()
            timer.join()
        signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = hook
    if pending:  # a stop sent again had not come yet: the block ended, the stop stands
        raise KeyboardInterrupt
