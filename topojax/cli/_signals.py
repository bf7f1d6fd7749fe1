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
    the Ctrl-C, is then sent again, from a moment later, rather than lost.  One still
    owed when the block ends, or one that comes while it ends, raises
    ``KeyboardInterrupt`` once the handlers are restored; none is sent after.  Outside the
    main thread (where no handler can be set) nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    timers: list[threading.Timer] = []  # stops sent again
    lock = threading.Lock()  # no stop is sent again once the block ends
    closing = False  # the block has ended: a stop is only recorded
    owed = False  # a stop was dropped and not sent again: it stands when the block ends
    due = False  # a stop is to be sent again: one dropped meanwhile is the same stop

    def terminate(signum, frame):
        nonlocal owed
        stopped[:] = [signal.SIGTERM]
        if closing:
            owed = True
            return
        raise KeyboardInterrupt

    def resend(signum: int) -> None:
        nonlocal owed, due
        with lock:
            due = False
            if not closing:
                owed = False  # it is owed again if it is dropped again
                os.kill(os.getpid(), signum)

    def dropped(unraisable) -> None:
        nonlocal owed, due
        signum = stopped[0] if stopped else signal.SIGINT  # else a Ctrl-C's
        handled = callable(signal.getsignal(signum))  # not ignored (nor fatal) here
        if isinstance(unraisable.exc_value, KeyboardInterrupt) and handled:
            owed = True
            if due:  # two Ctrl-Cs dropped are one stop: a second would cut the clean-up
                return
            if len(timers) < _RESENDS:
                due = True
                delay = min(_DELAYS_S[0] * 1.5 ** len(timers), _DELAYS_S[1])
                timers.append(threading.Timer(delay, resend, (signum,)))
                timers[-1].daemon = True
                timers[-1].start()
                return
        hook(unraisable)

    def close() -> None:  # may run again: a Ctrl-C may come part way through
        nonlocal closing
        with lock:
            closing = True
        while timers:  # one left uncancelled sends nothing: the block is closing
            timer = timers.pop()
            timer.cancel()
            timer.join()
        signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = hook

    previous = signal.signal(signal.SIGTERM, terminate)
    hook, sys.unraisablehook = sys.unraisablehook, dropped
    try:
        yield
    finally:
        while True:
            try:
                close()
                break
            except KeyboardInterrupt:  # a Ctrl-C during the clean-up: it stands
                owed = True
    if owed:  # a stop that was dropped, or came as the block ended, stands
        raise KeyboardInterrupt
