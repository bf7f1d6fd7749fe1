"""The records and messages of a batch's maps that failed before their CPU stage ended:
a map that could not be loaded, or one whose task a worker process took with it."""

from __future__ import annotations

import concurrent.futures as cf

from .inputs import _Item
from .pool import WorkerDied
from .records import MapRecord
from .worker import _error_text


def _error_record(item: _Item, message: str) -> MapRecord:
    """The record of a map that could not be loaded, with ``message``."""
    return MapRecord(map=item.name, path=item.label, status="error", message=message)


def _lost_text(exc: BaseException, *, started: bool = True) -> str:
    """The message of ``exc``, saying what happened where a worker process died with the
    map's task (a broken pool's error, or the cancelling of the task): killed, or, where
    no worker task ever ran (not ``started``), failed to start."""
    if not isinstance(exc, (cf.BrokenExecutor, cf.CancelledError)):
        return _error_text(exc)
    if not started:
        return (
            f"{_error_text(exc)} (the worker processes failed to start: see their errors "
            'above; a script must call build_graphs under if __name__ == "__main__":, '
            "and no folder named topojax may hide the package from them)"
        )
    if isinstance(exc, WorkerDied):  # the own pool's: its message says which task died
        return f"{_error_text(exc)} (killed for memory?; resume=True runs it again)"
    return (
        f"{_error_text(exc)} (a worker process died while this map was queued or "
        "running, killed for memory?; resume=True runs it again)"
    )
