"""The command line: start-up cost (what ``import topojax`` and the parser load),
``--version``, and output folders shared by several commands or inputs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import topojax
from topojax.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("jax", "numba", "matplotlib", "scipy", "networkx", "PIL", "yaml")


def _python(code: str) -> str:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    return out.stdout.strip()


def _loaded_after(statement: str) -> list[str]:
    code = f"import sys; {statement}; print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    return _python(code).split()


def test_import_topojax_loads_no_heavy_module():
    assert _loaded_after("import topojax") == []


def test_building_the_parser_loads_no_heavy_module():
    assert _loaded_after("from topojax.cli import build_parser; build_parser()") == []


def test_names_load_on_first_use():
    code = (
        "import sys, topojax; from topojax import OccupancyMap, GraphConfig; "
        "print('jax' in sys.modules, OccupancyMap.__module__, GraphConfig.__module__)"
    )
    assert _python(code) == "False topojax.maps topojax.config"
    assert set(topojax.__all__) <= set(dir(topojax))
    assert topojax.pipeline.build_graph is topojax.build_graph


def test_version():
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    version = re.search(r'^version = "([^"]+)"', pyproject, re.M).group(1)
    assert topojax.__version__ == version
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-m", "topojax.cli", "--version"],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    )
    assert out.stdout.strip() == f"topojax {version}"
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["--version"])
    assert exit_.value.code == 0


def test_parser_constants_match_their_modules():
    from topojax._constants import MODES, STRATEGIES
    from topojax.incremental import STRATEGIES as incremental_strategies
    from topojax.maps import MODES as maps_modes

    assert MODES == maps_modes
    assert STRATEGIES == incremental_strategies
