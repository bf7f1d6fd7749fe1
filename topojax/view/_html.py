"""The viewer page: the data and the viewer's own script and style, in one HTML file
that needs no server and no network."""

from __future__ import annotations

import html
import json
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


def page(payload: dict) -> str:
    """The complete HTML document showing ``payload`` (see :func:`build_payload`)."""
    data = _script_safe(json.dumps(payload, separators=(",", ":"), allow_nan=False))
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
