"""The name of an MCAP recording: a bad one is refused showing the value given."""

from __future__ import annotations

import pytest

from topojax.cli import main
from topojax.io.mcap import mcap_path

pytest.importorskip("rosbags")


@pytest.mark.parametrize(
    ("given", "shown"),
    [("", "an empty path"), ("run.txt", "'run.txt'"), ("./notes", "'./notes'")],
)
def test_a_name_without_the_mcap_suffix_is_shown_as_given(given, shown):
    with pytest.raises(ValueError) as info:
        mcap_path(given, name="--mcap")
    assert str(info.value) == f"--mcap: expected a file name ending in .mcap, received {shown}"


def test_graph_names_an_empty_mcap_option(tmp_path, capsys):
    assert main(["graph", "map.pgm", "-o", str(tmp_path), "--mcap", ""]) == 2
    err = capsys.readouterr().err
    assert "--mcap: expected a file name ending in .mcap, received an empty path" in err
    assert "'.'" not in err


@pytest.mark.parametrize("given", [".mcap", "runs/.MCAP"])
def test_a_name_that_is_only_the_suffix_is_said_to_have_no_stem(given):
    with pytest.raises(ValueError) as info:
        mcap_path(given, name="--mcap")
    name = given.rpartition("/")[2]
    assert str(info.value) == (
        f"--mcap: a file named only {name!r} has no stem (the part before the suffix); "
        f"expected a name such as 'map{name}', received {given!r}"
    )
