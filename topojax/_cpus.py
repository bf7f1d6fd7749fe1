"""The CPUs and memory this process may use, for sizing thread and process pools, and the
executors users may hand in for running work in parallel."""

from __future__ import annotations

import concurrent.futures as cf
import os
from typing import Any

__all__ = [
    "MemoryRefusal",
    "as_executor",
    "available_memory_bytes",
    "byte_size",
    "check_fits_memory",
    "usable_cpus",
]


class MemoryRefusal(MemoryError):
    """Input refused before the work because it would not fit the memory available (see
    :func:`available_memory_bytes`); the message says what it needs, what there is and,
    where there is one, what to do instead."""


def check_fits_memory(need_bytes: int, what: str, advice: str = "") -> None:
    """A :class:`MemoryRefusal` saying ``what`` (e.g. "map image m.png: ... takes at
    least") ``need_bytes``, more than the memory available, then ``advice``; nothing when
    it fits or the memory available is not known (not on Linux)."""
    available = available_memory_bytes()
    if available is not None and need_bytes > available:
        raise MemoryRefusal(
            f"{what} {byte_size(need_bytes)}, more than the {byte_size(available)} of memory "
            f"available{advice}"
        )


def byte_size(n: float) -> str:
    """``n`` bytes as a person reads them: GiB from one GiB, MiB from one MiB, else
    bytes."""
    for unit, size in (("GiB", 2**30), ("MiB", 2**20)):
        if n >= size:
            return f"{n / size:,.1f} {unit}"
    return f"{int(n):,} bytes"


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the platform has one, which
    a container's or ``taskset``'s limit narrows; else all of the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def available_memory_bytes(
    *,
    meminfo: str = "/proc/meminfo",
    cgroups: str = "/proc/self/cgroup",
    root: str = "/sys/fs/cgroup",
) -> int | None:
    """Bytes of memory new allocations may still take without swapping: the kernel's
    ``MemAvailable`` estimate (read from ``meminfo``), or less where a memory limit of this
    process's cgroup or one of its parents (a container, a job scheduler; v2 or v1, listed
    in ``cgroups``, mounted under ``root``) leaves less; None where neither can be read
    (not on Linux)."""
    found = []
    try:
        with open(meminfo, encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    found += _cgroup_room(cgroups, root)
    return min(found) if found else None


#: A cgroup v1 memory limit at or above this is no limit (the kernel's "unlimited" is
#: about 2**63 rounded down to a page).
_NO_LIMIT = 1 << 60


def _cgroup_room(cgroups: str, root: str) -> list[int]:
    """Bytes left under each memory limit of this process's cgroups (listed in
    ``cgroups``, as ``/proc/self/cgroup``) and their parents, mounted under ``root``:
    the limit less the usage, page cache the kernel may drop (``inactive_file``) counted
    as free."""
    try:
        with open(cgroups, encoding="ascii") as f:
            lines = f.read().splitlines()
    except (OSError, ValueError):
        return []
    room = []
    for line in lines:
        _, controllers, path = (line.split(":", 2) + ["", ""])[:3]
        if line.startswith("0::"):  # v2: one hierarchy
            base, files = root, ("memory.max", "memory.current", "inactive_file")
        elif "memory" in controllers.split(","):  # v1: the memory controller's own
            base = os.path.join(root, "memory")
            files = ("memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file")
        else:
            continue
        parts = [p for p in path.split("/") if p and p != ".."]
        for depth in range(len(parts), -1, -1):  # the process's cgroup, then its parents
            left = _room_in(os.path.join(base, *parts[:depth]), *files)
            if left is not None:
                room.append(left)
    return room


def _room_in(folder: str, limit_file: str, usage_file: str, inactive_key: str) -> int | None:
    """Bytes left under the memory limit of the cgroup ``folder``, or None without a
    limit (or where its files cannot be read)."""
    try:
        with open(os.path.join(folder, limit_file), encoding="ascii") as f:
            limit = f.read().strip()
        if not limit.isdigit() or int(limit) >= _NO_LIMIT:  # "max": no limit
            return None
        with open(os.path.join(folder, usage_file), encoding="ascii") as f:
            usage = int(f.read().strip())
    except (OSError, ValueError):
        return None
    inactive = 0
    try:
        with open(os.path.join(folder, "memory.stat"), encoding="ascii") as f:
            for line in f:
                key, _, value = line.partition(" ")
                if key == inactive_key:
                    inactive = int(value)
                    break
    except (OSError, ValueError):
        pass
    return max(int(limit) - max(usage - inactive, 0), 0)


def as_executor(executor: Any) -> cf.Executor | None:
    """``executor`` itself (None or a :class:`concurrent.futures.Executor`), or the
    executor of a Dask ``Client`` (``pure=False``); ValueError naming ``executor`` if it
    takes no tasks (shut down, or the client closed), before any work is given to it."""
    if executor is None:
        return None
    if not isinstance(executor, cf.Executor):
        get_executor = getattr(executor, "get_executor", None)
        if get_executor is None:
            raise TypeError(
                "executor: expected None, a concurrent.futures.Executor or a "
                f"dask.distributed Client, received {type(executor).__name__}"
            )
        executor = get_executor(pure=False)
    try:  # a shut-down executor refuses at once; a running one gets a task of no cost
        executor.submit(int)
    except Exception as exc:  # RuntimeError, Dask's ClosedClientError, ...
        raise ValueError(
            "executor: expected an executor that takes tasks, received one that refuses "
            f"them (shut down, or its client closed): {type(exc).__name__}: {exc}"
        ) from None
    return executor
