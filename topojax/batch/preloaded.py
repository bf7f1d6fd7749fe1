"""Imported last by the batch's forkserver, once it has imported the other modules its
workers need (:func:`topojax.batch.worker.worker_context`).

The pool starts the forkserver with Ctrl-C (SIGINT) blocked, so that one that comes while
it imports prints no traceback (the pool's process takes it and stops the workers).  The
forkserver is the whole process's: its later children, a caller's own processes among
them, must take Ctrl-C again.  Imported where SIGINT is not blocked, it does nothing.
"""

from __future__ import annotations

import signal

__all__: list[str] = []


def _take_ctrl_c_again() -> None:
    """Unblock SIGINT, dropping one that came while it was blocked."""
    if not hasattr(signal, "pthread_sigmask"):  # not POSIX
        return
    if signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, ()):
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # a pending one is dropped
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, previous)


_take_ctrl_c_again()
