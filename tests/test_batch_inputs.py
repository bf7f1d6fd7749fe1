"""The inputs of a batch that give no map: folders that cannot be listed, and folders or
patterns with no map file in them, are named, not passed over in silence."""

from __future__ import annotations

import os
import re
import warnings

import pytest

from topojax.batch import expand_map_inputs

_PNG = b"\x89PNG\r\n\x1a\n"  # only the name and the suffix matter to the search


def _deny(monkeypatch, folder) -> None:
    """Make listing ``folder`` fail as a folder without read permission does (the tests
    may run as root, whom ``chmod 000`` does not stop)."""
    real = os.scandir
    denied = os.path.realpath(folder)

    def scandir(path="."):
        if os.path.realpath(os.fspath(path)) == denied:
            raise PermissionError(13, "Permission denied", os.fspath(path))
        return real(path)

    monkeypatch.setattr(os, "scandir", scandir)


@pytest.fixture
def tree(tmp_path):
    root = tmp_path / "maps"
    (root / "sub").mkdir(parents=True)
    (root / "a.png").write_bytes(_PNG)
    (root / "sub" / "b.png").write_bytes(_PNG)
    return root


def test_a_folder_that_cannot_be_listed_is_named(tree, monkeypatch):
    _deny(monkeypatch, tree / "sub")
    for inputs in ([tree], [f"{tree}/**/*.png"], [f"{tree}/*/*.png", tree / "a.png"]):
        with pytest.warns(UserWarning) as shown:
            assert expand_map_inputs(inputs) == [tree / "a.png"]
        texts = [str(w.message) for w in shown]
        assert any(
            re.match(r"inputs: could not search 1 folder, .* in it .*: .*sub", t) for t in texts
        )
    with pytest.raises(ValueError, match=r"none found in .*could not search .*sub"):
        expand_map_inputs([tree / "sub"])


def test_a_folder_the_pattern_does_not_enter_is_not_named(tree, monkeypatch):
    (tree / "other").mkdir()
    _deny(monkeypatch, tree / "other")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert expand_map_inputs([f"{tree}/sub/*.png"]) == [tree / "sub" / "b.png"]
        assert expand_map_inputs([f"{tree}/s*/*.png"]) == [tree / "sub" / "b.png"]
        assert expand_map_inputs([f"{tree}/*.png"]) == [tree / "a.png"]
    # ...though a search of every folder is
    with pytest.warns(UserWarning, match="could not search"):
        expand_map_inputs([tree])


def test_an_input_that_gives_no_map_is_named(tree):
    (tree / "empty").mkdir()
    typo = str(tree / "sbu" / "*.png")
    with pytest.warns(
        UserWarning, match=rf"received {re.escape(repr(typo))}, .*'.*empty', which gave none"
    ):
        got = expand_map_inputs([typo, tree / "sub", tree / "empty"])
    assert got == [tree / "sub" / "b.png"]
    with warnings.catch_warnings():  # one alternative of a brace pattern may match nothing
        warnings.simplefilter("error")
        assert expand_map_inputs([f"{tree}/**/*.{{png,pgm}}"]) == [
            tree / "a.png",
            tree / "sub" / "b.png",
        ]


@pytest.mark.parametrize("pattern", ["**/*.png", "**", "*", "*/**/*.p*", "**/deep/*"])
def test_a_pattern_lists_each_folder_once(tree, monkeypatch, pattern):
    """A glob pattern's tree is listed once (``glob.glob`` listed every folder twice for
    ``**/NAME``, then the search for unreadable folders once more): the same maps, in
    the order of the sorted matches, hidden entries skipped as ``glob.glob`` skips them."""
    deep = tree / "sub" / "deep"
    deep.mkdir()
    for path in (deep / "c.png", tree / ".hidden" / "h.png", tree / "z.v2" / "d.png"):
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(_PNG)
    real, listed = os.scandir, []

    def scandir(path="."):
        listed.append(os.path.normpath(os.fspath(path)))
        return real(path)

    monkeypatch.setattr(os, "scandir", scandir)
    got = expand_map_inputs([f"{tree}/{pattern}"])
    monkeypatch.undo()
    assert listed and len(listed) == len(set(listed))
    want = {
        "**/*.png": ["a.png", "sub/b.png", "sub/deep/c.png", "z.v2/d.png"],
        "**": ["a.png", "sub/b.png", "sub/deep/c.png", "z.v2/d.png"],
        "*": ["a.png", "sub/b.png", "sub/deep/c.png", "z.v2/d.png"],
        "*/**/*.p*": ["sub/b.png", "sub/deep/c.png", "z.v2/d.png"],
        "**/deep/*": ["sub/deep/c.png"],
    }[pattern]
    assert got == [tree / rel for rel in want]


def test_a_pattern_given_to_build_graphs_as_a_map_says_to_expand_it(tree):
    """``build_graphs`` takes map files: a glob pattern given in their place is an error
    row that says to expand it (as a folder's says to search it), not only that no such
    file exists."""
    from topojax.batch import build_graphs

    pattern = str(tree / "*.png")
    (rec,) = build_graphs(pattern, workers=0, progress=False)
    assert rec.status == "error"
    assert f"map file not found: {pattern}" in rec.message
    assert "a pattern? expand it first" in rec.message and "expand_map_inputs" in rec.message
    (plain,) = build_graphs(tree / "missing.png", workers=0, progress=False)
    assert "a pattern?" not in plain.message  # a plain name that is not there
