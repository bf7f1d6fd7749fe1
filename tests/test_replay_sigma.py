"""``topojax replay --sigma-m`` / ``--sigma-px``: the Gaussian of the mapper's distance
map, as ``topojax graph`` sets it; a resume with another one is refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import topojax.scans
from topojax.cli import main
from topojax.config import ORIGINAL_SIGMA_PX
from topojax.incremental import IncrementalMapper
from topojax.playback import STATE_FILE

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
BASE = ["replay", str(INTEL_EXCERPT), "--no-progress", "--max-scans", "12"]


def distance_of(out: Path) -> dict:
    """The distance settings of the mapper of the replay written into ``out``."""
    return json.loads((out / "timings.json").read_text())["settings"]["config"]["distance"]


@pytest.mark.parametrize(
    ("options", "sigma_px"),
    [
        ([], ORIGINAL_SIGMA_PX),  # the paper's pixels at any resolution, as graph's
        (["--sigma-m", "3.2"], 16.0),
        (["--sigma-px", "16"], 16.0),
    ],
)
def test_replay_sets_the_mappers_sigma(tmp_path, options, sigma_px):
    out = tmp_path / "out"
    assert main([*BASE, "-o", str(out), "--resolution", "0.2", *options]) == 0
    assert distance_of(out)["sigma_px"] == pytest.approx(sigma_px)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--sigma-m", "0"], "--sigma-m: expected a finite number of metres > 0"),
        (["--sigma-px", "-3"], "--sigma-px: expected a finite number of pixels > 0"),
        (["--sigma-m", "1e-8"], "--sigma-m: 1e-08 m at 0.2 m/px is 5e-08 px, less than"),
    ],
)
def test_replay_refuses_a_bad_sigma_naming_the_option(tmp_path, capsys, options, message):
    out = tmp_path / "out"
    assert main([*BASE, "-o", str(out), "--resolution", "0.2", *options]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()  # refused before the replay


def test_replay_takes_one_of_sigma_m_and_sigma_px(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main([*BASE, "-o", str(tmp_path / "out"), "--sigma-m", "1", "--sigma-px", "5"])
    assert "--sigma-px: not allowed with argument --sigma-m" in capsys.readouterr().err


def test_a_resume_with_another_sigma_is_refused_naming_the_option(tmp_path, monkeypatch, capsys):
    real = topojax.scans.read_scans

    def stopping(source, **kw):  # Ctrl-C after 6 scans
        for i, scan in enumerate(real(source, **kw)):
            if i == 6:
                raise KeyboardInterrupt
            yield scan

    out = tmp_path / "out"
    args = [*BASE, "-o", str(out), "--sigma-m", "2"]
    monkeypatch.setattr(topojax.scans, "read_scans", stopping)
    assert main(args) == 130
    monkeypatch.undo()
    assert main([*args[:-1], "3", "--resume"]) == 2
    err = capsys.readouterr().err
    assert "--sigma-px or --sigma-m (sigma in px): saved 40.0, now 60.0" in err
    assert "config.distance" not in err
    assert IncrementalMapper.load(out / STATE_FILE).n_scans == 6  # left for a resume
    assert main([*args, "--resume"]) == 0
    assert distance_of(out)["sigma_px"] == pytest.approx(40.0)
