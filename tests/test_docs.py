"""The documentation builds and its links resolve.

``mkdocs build --strict`` fails on a page missing from the nav or a nav entry without a
page, a broken link between pages, and a docstring that mkdocstrings cannot render; it
runs offline.  The link check covers README.md as well, whose links point into the
repository rather than into the built site.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

# [text](target) and ![alt](target); the target ends at whitespace or ')'.
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_FENCE = re.compile(r"^\s*(```|~~~)")


def _markdown_files() -> list[Path]:
    return [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]


def _relative_links(path: Path) -> list[tuple[int, str]]:
    """``(line number, target)`` of every relative link outside fenced code blocks."""
    links = []
    in_code = False
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if _FENCE.match(line):
            in_code = not in_code
            continue
        if in_code:
            continue
        line = re.sub(r"`[^`]*`", "", line)  # inline code is not a link
        for target in _LINK.findall(line):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I) or target.startswith("#"):
                continue  # http:, https:, mailto:, in-page anchors
            links.append((number, target))
    return links


@pytest.mark.parametrize("path", _markdown_files(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_point_to_files(path: Path) -> None:
    missing = []
    for number, target in _relative_links(path):
        file_part = target.split("#", 1)[0]
        if not (path.parent / file_part).exists():
            missing.append(f"{path.name}:{number}: {target}")
    assert not missing, "links to missing files:\n" + "\n".join(missing)


def test_link_pattern_finds_links() -> None:
    # the check above is only as good as its pattern
    assert _LINK.findall("see [a](b.md) and ![c](img/d.png) but not `[e](f.md)`") == [
        "b.md",
        "img/d.png",
        "f.md",
    ]


@pytest.mark.skipif(
    importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings") is None,
    reason="mkdocs and mkdocstrings are not installed",
)
def test_mkdocs_build_strict(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    api = (tmp_path / "site" / "api.html").read_text(encoding="utf-8")
    # the page renders every public name under its flat name (a lazy name the docs tool
    # cannot see through the TYPE_CHECKING imports is silently left out)
    import topojax

    rendered = set(re.findall(r'<h2 id="topojax\.(\w+)"', api))
    assert sorted(set(topojax.__all__) - rendered) == []


def test_public_docstrings_start_their_body_at_the_margin() -> None:
    """A docstring whose body is indented past its summary renders as a code block."""
    import inspect

    import topojax

    indented = []
    for name in topojax.__all__:
        lines = inspect.cleandoc(getattr(topojax, name).__doc__ or "").splitlines()
        body = [line for line in lines[1:] if line.strip()]
        if body and body[0].startswith(" "):
            indented.append(name)
    assert indented == []


def test_no_merge_conflict_markers_are_left_in_tracked_text() -> None:
    listed = subprocess.run(
        ["git", "ls-files", "*.md", "*.py", "*.toml", "*.yaml", "*.yml", "*.json", "*.cfg"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    if listed.returncode != 0:
        pytest.skip("not a git checkout")
    marker = re.compile(r"^(<{7}|>{7}) ", re.MULTILINE)
    found = []
    for name in listed.stdout.split():
        path = ROOT / name
        if path.is_file() and marker.search(path.read_text(encoding="utf-8", errors="replace")):
            found.append(name)
    assert found == []


def _command_options() -> dict[str, set[str]]:
    """``{command: its --options}`` from the command line's own parser."""
    import argparse

    from topojax.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return {
        name: {s for action in parser._actions for s in action.option_strings}
        for name, parser in sub.choices.items()
    }


def test_command_line_options_named_in_the_docs_exist() -> None:
    """Every ``--option`` the pages name is an option of some command, and every one in a
    ``## `topojax COMMAND` `` section of the command-line page is one of that command's
    (a renamed or removed flag otherwise stays in the docs)."""
    options = _command_options()
    known = set().union(*options.values())
    flag = re.compile(r"(?<![\w-])(--[a-z][a-z0-9]*(?:-[a-z0-9]+)*)(?![\w*-])")  # not --min-*-m
    tools = {"--check", "--huge", "--strict"}  # ruff's, the benchmarks', mkdocs'
    unknown = []
    for path in _markdown_files():
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for name in flag.findall(line):
                if name not in known and name not in tools:
                    unknown.append(f"{path.name}:{number}: {name}")
    assert not unknown, "options no command has:\n" + "\n".join(unknown)
    page = (DOCS / "command-line.md").read_text(encoding="utf-8")
    for section in re.split(r"^## ", page, flags=re.M):
        command = re.match(r"`topojax ([\w-]+)`", section)
        if command is None:
            continue
        own = options[command.group(1)]
        # another command's options are named with it: "as `graph --rooms`", and
        # example command lines of the commands that wrote a folder
        text = re.sub(r"`(?:topojax )?[\w-]+ --[^`]*`", "", section)
        text = re.sub(rf"^topojax (?!{command.group(1)} ).*$", "", text, flags=re.M)
        missing = sorted({name for name in flag.findall(text) if name not in own})
        assert not missing, f"topojax {command.group(1)} has no {missing}"


def _python_blocks(path: Path) -> list[str]:
    """The ```python blocks of a page, in order."""
    text = path.read_text(encoding="utf-8")
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.M | re.S)


@pytest.mark.parametrize(
    "page", ["README.md", "docs/incremental.md", "docs/routing-and-nav2.md", "docs/viewer.md"]
)
def test_python_examples_run(page: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The first Python examples a newcomer copies run as written (files go to a scratch
    folder, where the repository's bundled ``tests/data`` is found as from its root); a
    renamed function, argument or attribute, or data that is not bundled, otherwise stays
    in the text."""
    import matplotlib

    matplotlib.use("Agg")
    blocks = _python_blocks(ROOT / page)
    assert blocks, f"{page} has no python example"
    (tmp_path / "tests").symlink_to(ROOT / "tests", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, page, "exec"), {"__name__": "docs_example"})


def _api_page_listing() -> str:
    """docs/api.md up to its rendered reference (the ``::: topojax`` block)."""
    page = (DOCS / "api.md").read_text(encoding="utf-8")
    assert "\n::: topojax\n" in page, "docs/api.md lost its mkdocstrings block"
    return page.split("\n::: topojax\n", 1)[0]


def test_api_page_lists_every_public_name_and_no_other() -> None:
    """docs/api.md names every ``topojax.__all__`` name in the first column of a table,
    once, and names nothing that is not public, so the page read on GitHub, without the
    built reference, cannot drift from the API."""
    import topojax

    listing = _api_page_listing()
    rows = re.findall(r"^\| `(\w+)` \|", listing, flags=re.M)
    duplicated = sorted({name for name in rows if rows.count(name) > 1})
    assert duplicated == []
    assert sorted(set(topojax.__all__) - set(rows)) == [], "public names not in docs/api.md"
    assert sorted(set(rows) - set(topojax.__all__)) == [], "docs/api.md lists non-public names"
    # a code span holding a Python name (``Name``, ``Name.attr``) anywhere in the listing
    # must start with a public one; besides, the package, unit suffixes, parameters and
    # ROS's map_server
    words = {"topojax", "__all__", "_px", "_m", "_s", "out_dir", "start", "goal", "map_server"}
    stray = sorted(
        {
            span
            for span in re.findall(r"`([A-Za-z_]\w*(?:\.\w+)*)`", listing)
            if span.split(".")[0] not in set(topojax.__all__) | words
        }
    )
    assert stray == [], f"docs/api.md names what is not public: {stray}"
