"""SIGTERM ending a command as Ctrl-C does, and neither lost where Python drops it."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator

__all__ = ["sigterm_stops"]

#: Times a stop that Python dropped is sent again (see :func:`sigterm_stops`), and the
#: delays before each, growing from the first to the last: while an extension module
#: initialises (JAX's, for a second), every stop is dropped in its garbage collections.
_RESENDS = 100
_DELAYS_S = (0.01, 0.25)


@contextlib.contextmanager
def sigterm_stops(stopped: list[signal.Signals]) -> Iterator[None]:
    """Within ``with``, SIGTERM (``kill``, ``timeout``, a service manager's or job
    scheduler's stop) ends a command as Ctrl-C does: a ``KeyboardInterrupt``, with
    ``stopped`` then holding SIGTERM, so the command's clean-up runs (the default action,
    killing the process, would leave the temporary file of a write cut short in the output
    folder, and a batch's worker processes running).  It works where SIGINT is ignored (a
    background job of a script) too.

    A handler's exception raised where Python cannot pass it on (a garbage-collector
    callback, such as JAX's, or a ``__del__``) is dropped as "unraisable": the stop, or
    the Ctrl-C, is then sent again, from a moment later, rather than lost.  Outside the
    main thread (where no handler can be set) nothing changes."""
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
        signum = stopped[0] if stopped else signal.SIGINT  # else a Ctrl-C's
        handled = callable(signal.getsignal(signum))  # not ignored (nor fatal) here
        if isinstance(unraisable.exc_value, KeyboardInterrupt) and handled:
            if len(timers) >= _RESENDS:
                return hook(unraisable)
            delay = min(_DELAYS_S[0] * 1.5 ** len(timers), _DELAYS_S[1])
            timers.append(threading.Timer(delay, os.kill, (os.getpid(), signum)))
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
