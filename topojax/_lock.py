"""One writer per output folder: the long runs that write into a folder and keep state
there for ``--resume`` (``topojax replay``, ``topojax batch``) hold an advisory lock on
it, so that a second one into the same folder is refused at once instead of silently
overwriting the first one's files.

The lock is ``flock`` on :data:`LOCK_FILE` inside the folder.  The system releases it
when the process ends however it ends (``kill -9``, out of memory, a power cut), so a
lock is never left stale; the file itself is removed on a clean exit and a file left by
a killed run is taken over by the next.  A process forked while the lock is held (a
``fork`` pool's worker) closes its copy of the descriptor at once: a ``flock`` belongs
to the open file, so a copy would keep the lock held after the writer is killed.  Where
the system or the file system has no ``flock`` (Windows, some network file systems), no
lock is taken.
"""

from __future__ import annotations

import contextlib
import errno
import multiprocessing
import os
from collections.abc import Iterator
from pathlib import Path

try:  # POSIX only
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

#: The lock file a writer holds in its output folder.
LOCK_FILE = ".topojax.lock"

#: The descriptors of the locks held, and the id of the process that took each.
_HELD: dict[int, int] = {}


def _close_inherited() -> None:
    """In a child just forked: close the lock descriptors copied from the parent (the
    parent's lock stays held; a close lets go only when the last copy goes)."""
    for fd in list(_HELD):
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD.clear()


if hasattr(os, "register_at_fork"):  # POSIX only
    os.register_at_fork(after_in_child=_close_inherited)


@contextlib.contextmanager
def one_writer(folder: str | os.PathLike, *, name: str, command: str = "replay") -> Iterator[Path]:
    """Within ``with``, hold the lock of the output folder ``folder`` (created, as
    :func:`~topojax._fs.output_folder` makes it) for ``topojax command``; yields the
    folder.  A ``BlockingIOError`` naming ``name`` (the parameter or option that chose
    the folder) when another process holds it, with that process's id and command."""
    from ._fs import output_folder

    out = output_folder(folder, name=name)
    fd = _acquire(out, name, command)
    try:
        yield out
    finally:
        if fd is not None:
            _release(out / LOCK_FILE, fd)


def _acquire(folder: Path, name: str, command: str) -> int | None:
    """Lock ``folder``'s lock file and write this process's id and ``command`` into it;
    returns its descriptor (None: no ``flock`` here).  A file that its holder removed
    between our opening and locking it is opened again."""
    if fcntl is None:
        return None
    path = folder / LOCK_FILE
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            raise OSError(
                exc.errno, f"{name}: cannot make the lock file {path} ({exc.strerror})"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            _refuse_a_worker_of_the_holder(name, holder)
            raise BlockingIOError(
                errno.EWOULDBLOCK,
                f"{name}: another topojax process{holder} is writing into {folder}; wait "
                "for it to end, or write into another folder",
            ) from None
        except OSError:  # a file system without flock: no lock, no lock file
            os.close(fd)
            with contextlib.suppress(OSError):
                path.unlink()
            return None
        if _same_file(path, fd):
            break
        os.close(fd)  # removed by the writer that held it: lock the file there now
    _HELD[fd] = os.getpid()
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()} topojax {command}\n".encode())
    return fd


def _same_file(path: Path, fd: int) -> bool:
    """Whether ``path`` is still the file open as ``fd``."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _holder(fd: int) -> str:
    """The process holding the lock, as its file says: `` (pid 123, topojax replay)``;
    "" where the file does not say (its holder has not written it yet)."""
    try:
        words = os.pread(fd, 200, 0).decode("utf-8", "replace").split()
    except OSError:
        return ""
    if not words or not words[0].isdigit():
        return ""
    return f" (pid {words[0]}{', ' + ' '.join(words[1:]) if words[1:] else ''})"


def _refuse_a_worker_of_the_holder(name: str, holder: str) -> None:
    """Raise a ``RuntimeError`` when this process is a ``spawn`` or ``forkserver`` worker
    still importing the calling script (it has a process name but no parent process yet):
    a script without the ``__main__`` guard starts the run again there, and finds the
    folder locked by the run that started the worker (``holder``, as :func:`_holder`
    gives it)."""
    if multiprocessing.parent_process() is not None:
        return
    if multiprocessing.current_process().name == "MainProcess":
        return
    raise RuntimeError(
        f"{name}: expected the run to start once, in the calling script, received a second "
        f"start in a worker process importing that script (the first run{holder} holds the "
        'folder\'s lock): a script must call build_graphs under if __name__ == "__main__":, '
        "since each worker process imports the script first"
    ) from None


def _release(path: Path, fd: int) -> None:
    """Remove the lock file while it is still locked, then let the lock go; nothing in a
    forked child, which closed its copy of ``fd`` and whose parent holds the lock."""
    if _HELD.pop(fd, None) != os.getpid():
        return
    try:
        with contextlib.suppress(OSError):
            os.unlink(path)
    finally:
        os.close(fd)
