"""The CPUs and memory this process may use, for sizing thread and process pools, and the
executors users may hand in for running work in parallel."""

from __future__ import annotations

import concurrent.futures as cf
import os
from typing import Any

__all__ = ["as_executor", "available_memory_bytes", "usable_cpus"]


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the platform has one, which
    a container's or ``taskset``'s limit narrows; else all of the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def available_memory_bytes() -> int | None:
    """Bytes of memory new allocations may still take without swapping: the kernel's
    ``MemAvailable`` estimate, or less where this process's cgroup (a container, a job
    scheduler) has a lower limit left; None where neither can be read (not on Linux)."""
    found = []
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    for limit_file, usage_file in (
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),  # cgroup v2
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes",  # cgroup v1
            "/sys/fs/cgroup/memory/memory.usage_in_bytes",
        ),
    ):
        try:
            with open(limit_file, encoding="ascii") as f:
                limit = f.read().strip()
            with open(usage_file, encoding="ascii") as f:
                usage = int(f.read().strip())
            if limit.isdigit():  # "max": no limit
                found.append(max(int(limit) - usage, 0))
            break
        except (OSError, ValueError):
            continue
    return min(found) if found else None


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
