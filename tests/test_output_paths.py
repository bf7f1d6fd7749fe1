"""The graph and map writers check the path they were given before any work, and name
their parameter and that path when it cannot be written."""

from __future__ import annotations

import re
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

import topojax as tj


def small_graph() -> nx.MultiGraph:
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), kind="end", clearance_m=0.5)
    g.add_node(1, world=(1.0, 0.0), kind="end", clearance_m=0.5)
    g.add_edge(0, 1, world=np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]), length_m=1.0)
    return g


def small_map() -> tj.OccupancyMap:
    occ = np.zeros((6, 8), bool)
    occ[0] = True
    return tj.OccupancyMap(occupied=occ, free=~occ, unknown=np.zeros_like(occ))


#: Each writer, the name of its path parameter, and a file name it accepts.
WRITERS = [
    (lambda p: tj.save_graph(small_graph(), p), "path", "g.json"),
    (lambda p: tj.save_graph(small_graph(), p), "path", "g.graphml"),
    (lambda p: tj.save_nav2_graph(small_graph(), p), "path", "n.geojson"),
    (lambda p: tj.save_map(small_map(), p), "yaml_path", "m.yaml"),
]


@pytest.mark.parametrize(("save", "name", "file"), WRITERS)
def test_a_missing_folder_is_named_with_the_parameter_and_the_path_given(
    tmp_path: Path, save, name: str, file: str
):
    missing = tmp_path / "missing" / file
    message = (
        f"^{name}: expected a file in an existing folder, received {re.escape(str(missing))}, "
        f"whose folder {re.escape(str(missing.parent))} does not exist"
    )
    with pytest.raises(FileNotFoundError, match=message):
        save(missing)
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(NotADirectoryError, match=f"^{name}: "):
        save(tmp_path / "a_file" / file)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]
