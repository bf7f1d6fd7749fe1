"""What is at a path that is no regular file (a folder, a FIFO, ...), for the errors of
the readers that expect a file."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

__all__ = [
    "LOOP",
    "dangling",
    "loop_in",
    "looped",
    "missing_file_error",
    "non_file_kind",
    "the_non_file",
]

#: What :func:`looped` calls a link that leads back to itself.
LOOP = "a loop of symbolic links"


def the_non_file(path: str | Path) -> str:
    """What :func:`non_file_kind` says is at ``path``, with "the" for its article: "the
    folder", "the FIFO" (for a message that then names the path)."""
    kind = non_file_kind(path) or "no regular file"
    article, _, noun = kind.partition(" ")
    return f"the {noun}" if article in ("a", "an") else kind


def non_file_kind(path: str | Path) -> str | None:
    """What ``path`` is when it exists but is no regular file ("a folder", "a FIFO", "a
    socket", "a character device", "a block device"), else None (a file, or nothing)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    kinds = (
        (stat.S_ISREG, None),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
    )
    return next((kind for test, kind in kinds if test(mode)), "no regular file")


def looped(path: str | Path) -> str | None:
    """ ", a loop of symbolic links" or ", whose folder F is a loop of symbolic links" (to
    follow ``path`` in a message) where resolving it loops; None otherwise."""
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            loop = loop_in(path)
            return f", {LOOP}" if loop is None else f", whose folder {loop} is {LOOP}"
    except ValueError:  # a NUL in the path
        pass
    return None


def dangling(path: str | Path) -> str:
    """ " (a symbolic link to TARGET, which does not exist)" where ``path`` is a link to
    nothing; "" otherwise (for a path that is not there, "not found" is then the truth)."""
    try:
        if os.path.islink(path) and not os.path.exists(path):
            return f" (a symbolic link to {os.readlink(path)}, which does not exist)"
    except ValueError:  # a NUL in the path
        pass
    return ""


def loop_in(path: str | Path) -> Path | None:
    """The first folder above ``path`` that is a loop of symbolic links, or None."""
    for folder in reversed(Path(path).parents):
        try:
            os.stat(folder)
        except OSError as exc:
            return folder if exc.errno == errno.ELOOP else None
    return None


def missing_file_error(name: str, path: str | Path) -> Exception:
    """The error for parameter ``name``'s ``path``, where no file is found: a ValueError
    for a loop of symbolic links, else a FileNotFoundError (naming where a dangling link
    leads)."""
    if (loop := looped(path)) is not None:
        return ValueError(f"{name}: expected a file, received {path}{loop}")
    return FileNotFoundError(f"{name}: file not found: {path}{dangling(path)}")
