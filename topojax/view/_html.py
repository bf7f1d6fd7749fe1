"""The viewer page: the data and the viewer's own script and style, in one HTML file
that needs no server and no network."""

from __future__ import annotations

import html
import json
import math
from importlib import resources

__all__ = ["SCRIPTS", "page"]

#: The page's scripts, in the order they run (``topojax/view/static``).
SCRIPTS = ("decode.js", "route.js", "draw.js", "viewer.js")


def _static(name: str) -> str:
    return (resources.files("topojax.view") / "static" / name).read_text(encoding="utf-8")


def _script_safe(text: str) -> str:
    """JSON text that can sit inside ``<script>``: no ``<`` at all (``</script>`` or
    ``<!--`` in a label would end or confuse the element)."""
    return text.replace("<", "\\u003c")


def _not_finite(value, where: str = "") -> tuple[str, float] | None:
    """Where in ``value`` (dicts and lists) the first NaN or infinite float is, and it."""
    if isinstance(value, float) and not math.isfinite(value):
        return where, value
    items = (
        value.items()
        if isinstance(value, dict)
        else enumerate(value)
        if isinstance(value, (list, tuple))
        else ()
    )
    for key, item in items:
        found = _not_finite(item, f"{where}.{key}" if isinstance(key, str) else f"{where}[{key}]")
        if found is not None:
            return found
    return None


def page(payload: dict) -> str:
    """The complete HTML document showing ``payload`` (see :func:`build_payload`).

    Raises
    ------
    ValueError
        A value of ``payload`` is NaN or infinite (the message says where).
    """
    try:
        text = json.dumps(payload, separators=(",", ":"), allow_nan=False)
    except ValueError:
        found = _not_finite(payload)
        if found is None:
            raise
        raise ValueError(
            f"the view's data: {found[0].lstrip('.')} is {found[1]}, expected a finite number "
            "(the page's JSON holds no NaN or infinity)"
        ) from None
    data = _script_safe(text)
    scripts = "\n".join(_static(name) for name in SCRIPTS)
    title = html.escape(str(payload.get("title") or "topojax view"))
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{title}</title>\n"
        f"<style>\n{_static('viewer.css')}</style>\n</head>\n<body>\n"
        f"{_static('body.html')}"
        f'<script type="application/json" id="tj-data">{data}</script>\n'
        f"<script>\n{scripts}</script>\n</body>\n</html>\n"
    )
