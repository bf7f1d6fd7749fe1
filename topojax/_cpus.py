"""The CPUs this process may run on, for sizing thread pools, and the executors users may
hand in for running work in parallel."""

from __future__ import annotations

import concurrent.futures as cf
import os
from typing import Any

__all__ = ["as_executor", "usable_cpus"]


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the platform has one, which
    a container's or ``taskset``'s limit narrows; else all of the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def as_executor(executor: Any) -> cf.Executor | None:
    """``executor`` itself (None or a :class:`concurrent.futures.Executor`), or the
    executor of a Dask ``Client`` (``pure=False``)."""
    if executor is None or isinstance(executor, cf.Executor):
        return executor
    get_executor = getattr(executor, "get_executor", None)
    if get_executor is None:
        raise TypeError(
            "executor: expected None, a concurrent.futures.Executor or a "
            f"dask.distributed Client, received {type(executor).__name__}"
        )
    return get_executor(pure=False)
