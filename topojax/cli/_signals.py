"""SIGTERM ending a command as Ctrl-C does."""

from __future__ import annotations

import signal
import threading

__all__ = ["stop_on_sigterm"]


def stop_on_sigterm(stopped: list[signal.Signals]):
    """Make SIGTERM (``kill``, ``timeout``, a service manager's or job scheduler's stop)
    end a command as Ctrl-C does: a ``KeyboardInterrupt``, with ``stopped`` then holding
    SIGTERM, so the command's clean-up runs (the default action, killing the process,
    would leave the temporary file of a write cut short in the output folder, and a
    batch's worker processes running).  It works where SIGINT is ignored (a background
    job of a script) too.  Returns the previous handler, or None outside the main thread
    (where no handler can be set)."""
    if threading.current_thread() is not threading.main_thread():
        return None

    def terminate(signum, frame):
        stopped[:] = [signal.SIGTERM]
        raise KeyboardInterrupt

    return signal.signal(signal.SIGTERM, terminate)
