"""The notebooks run top to bottom with the public API (code cells executed in order), and
are stored without outputs."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))

#: What each notebook must have computed once all its cells ran: name -> check.
KEY_OUTPUTS = {
    "quickstart.ipynb": {
        "res": lambda res: res.graph.number_of_edges() > 0,
        "rg": lambda g: g.graph.get("kind") == "route_graph" and g.number_of_edges() > 0,
        "report": lambda rep: rep.success_rate > 0.9 and rep.unsafe_share == 0,
        "routes": lambda g: g.number_of_edges() > 0,
        "r": lambda route: route.length_m > 0,
        "seg": lambda seg: seg.n_rooms > 1 and len(seg.doors) > 0,
        "back": lambda g: g.number_of_edges() > 0,
    },
    "incremental.ipynb": {
        "mapper": lambda mapper: mapper.n_scans > 0 and mapper.graph.number_of_edges() > 0,
        "reference": lambda res: res.graph.number_of_edges() > 0,
        "again": lambda mapper: mapper.n_scans > 0,
    },
    "method.ipynb": {
        "res": lambda res: res.graph.number_of_edges() > 0,
        "peaks": lambda peaks: len(peaks) >= 3,
        "summaries": lambda s: len(s) == 2,
        "skeleton": lambda skeleton: skeleton.any(),
        "route": lambda route: route.length_m > 0,
    },
}

#: Largest notebook file: notebooks are stored without outputs (no embedded images).
MAX_BYTES = 64_000


def _cells(path: Path) -> list[dict]:
    nb = json.loads(path.read_text())
    assert nb["nbformat"] == 4
    return nb["cells"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path):
    import matplotlib.pyplot as plt

    namespace: dict = {"__name__": "__notebook__"}
    code = [cell for cell in _cells(path) if cell["cell_type"] == "code"]
    assert code
    figures = 0
    try:
        for cell in code:
            exec(compile("".join(cell["source"]), f"{path.name}", "exec"), namespace)
            figures += len(plt.get_fignums())
            plt.close("all")
    finally:
        plt.close("all")
    assert figures > 0, "the notebook drew no figure"
    checks = KEY_OUTPUTS.get(path.name)
    assert checks is not None, f"add {path.name}'s key outputs to KEY_OUTPUTS"
    for name, check in checks.items():
        assert name in namespace, f"{path.name} no longer defines {name!r}"
        assert check(namespace[name]), f"{path.name}: {name!r} fails its check"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_is_stored_without_outputs(path):
    assert path.stat().st_size <= MAX_BYTES
    for cell in _cells(path):
        assert "attachments" not in cell
        if cell["cell_type"] == "code":
            assert cell["outputs"] == [], "clear the outputs before committing"
            assert cell["execution_count"] is None


def test_there_are_notebooks():
    assert {p.name for p in NOTEBOOKS} >= set(KEY_OUTPUTS)
