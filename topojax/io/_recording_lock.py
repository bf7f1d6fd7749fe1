"""The temporary folder of an MCAP recording being written: locked by its recorder's
process, so that a folder a killed process left behind is told from one still recording
(:class:`~topojax.io.mcap.McapRecorder`)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

try:  # file locks (flock): POSIX only
    import fcntl
except ImportError:
    fcntl = None

#: The file a recorder holds locked in its temporary folder while it records (the lock
#: goes with its process, however that ends).
OWNER_LOCK = "recorder.lock"


def lock_as_owner(folder: Path):
    """Hold ``folder/recorder.lock`` locked (``flock``) while the returned descriptor is
    open; None where the system has no ``flock``.  The file is locked before it gets its
    name, so a lock file found unlocked was left by a process that has ended."""
    if fcntl is None:  # no flock: no temporary folder is ever taken for abandoned
        return None
    part = folder / f"{OWNER_LOCK}.part"
    fd = os.open(part, os.O_CREAT | os.O_WRONLY, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # a file system without flock: no lock file, never taken as abandoned
        os.close(fd)
        return None
    try:
        os.rename(part, folder / OWNER_LOCK)
    except BaseException:
        os.close(fd)
        raise
    return fd


def remove_abandoned(path: Path) -> None:
    """Remove the temporary folders that recorders of ``path`` left beside it when their
    process ended without closing them (killed with SIGKILL, a power cut): those whose
    lock file no process holds.  A folder without one (being made, or not a recorder's)
    and one whose recorder still records are left as they are."""
    if fcntl is None:
        return
    if not path.parent.is_dir():
        return
    prefix = f".{path.name}."
    for folder in path.parent.iterdir():
        # mkdtemp's own part has no dot: ".run.mcap.bak.x1y2" is another file's folder
        mine = folder.name.startswith(prefix) and "." not in folder.name[len(prefix) :]
        if not mine or folder.is_symlink() or not folder.is_dir():
            continue
        try:
            fd = os.open(folder / OWNER_LOCK, os.O_RDONLY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: its recorder is recording
            os.close(fd)
            continue
        try:
            shutil.rmtree(folder, ignore_errors=True)
        finally:
            os.close(fd)
