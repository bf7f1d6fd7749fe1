"""Words for counts in messages, summaries and titles."""

from __future__ import annotations

__all__ = ["counted"]


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, plural unless ``n`` is 1: ``"1 door"``, ``"3 doors"``; the
    plural is ``plural`` where given (``"vertex"``, ``"vertices"``), else ``noun`` + s."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
