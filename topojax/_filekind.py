"""What is at a path that is no regular file (a folder, a FIFO, ...), for the errors of
the readers that expect a file."""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["non_file_kind", "the_non_file"]


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
