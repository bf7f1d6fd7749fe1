"""Graph files written by other tools (networkx, GIS programs): loaded as the graph they
hold, or refused naming what is wrong."""

from __future__ import annotations

import json
from pathlib import Path

import networkx as nx
import pytest

from topojax.io import load_graph, save_graph


@pytest.mark.parametrize("suffix", [".graphml", ".json"])
def test_string_ids_that_only_look_like_numbers_stay_distinct_strings(tmp_path: Path, suffix: str):
    # "01" and "1" are two nodes, "1_0" is not the number 10
    g = nx.Graph([("01", "1"), ("1", "a"), ("1_0", "x")])
    path = tmp_path / f"ids{suffix}"
    if suffix == ".graphml":
        nx.write_graphml(g, path)
    else:
        path.write_text(json.dumps(nx.node_link_data(g, edges="edges")))
    back = load_graph(path)
    assert list(back.nodes) == ["01", "1", "a", "1_0", "x"]
    assert list(back.edges()) == [("01", "1"), ("1", "a"), ("1_0", "x")]
    save_graph(back, tmp_path / f"again{suffix}")  # one kind of id: it saves again


@pytest.mark.parametrize("suffix", [".graphml", ".json"])
def test_numeric_string_ids_of_another_tool_load_as_ints(tmp_path: Path, suffix: str):
    g = nx.Graph([(0, 1), (1, 12)])
    path = tmp_path / f"ints{suffix}"
    if suffix == ".graphml":
        nx.write_graphml(g, path)  # GraphML ids are text: "0", "1", "12"
    else:
        path.write_text(json.dumps(nx.node_link_data(nx.relabel_nodes(g, str), edges="edges")))
    assert list(load_graph(path).nodes) == [0, 1, 12]
