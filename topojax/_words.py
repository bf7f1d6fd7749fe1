"""Words for counts in messages, summaries and titles, and for values in errors."""

from __future__ import annotations

__all__ = ["counted", "graphml_text", "memory_size"]


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, plural unless ``n`` is 1: ``"1 door"``, ``"3 doors"``; the
    plural is ``plural`` where given (``"vertex"``, ``"vertices"``), else ``noun`` + s."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def memory_size(n_bytes: int) -> str:
    """A memory size for a message: whole MiB from 1 MiB (``"1,536 MiB"``), else bytes
    (``"16,000 bytes"``, never ``"0 MiB"``)."""
    return f"{n_bytes / 2**20:,.0f} MiB" if n_bytes >= 2**20 else f"{n_bytes:,} bytes"


def graphml_text(value) -> str:
    """Where ``value`` is text (a str or bytes), the words that say so in an error that
    expected numbers: GraphML keeps lists as text, which networkx.read_graphml leaves as
    it is, and topojax.load_graph decodes; else ``""``."""
    if not isinstance(value, (str, bytes)):
        return ""
    return (
        " (text, as networkx.read_graphml leaves GraphML's lists: read the file with "
        "topojax.load_graph, which decodes JSON lists such as '[x, y]')"
    )
