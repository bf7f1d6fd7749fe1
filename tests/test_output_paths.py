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


@pytest.mark.parametrize(("save", "name", "file"), WRITERS)
def test_a_fifo_or_socket_is_not_replaced_by_a_file(tmp_path: Path, save, name: str, file: str):
    import os
    import socket
    import stat

    fifo = tmp_path / file
    os.mkfifo(fifo)
    with pytest.raises(
        ValueError,
        match=f"^{name}: expected a regular file or a new name, "
        f"received the FIFO {re.escape(str(fifo))}",
    ):
        save(fifo)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    fifo.unlink()
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(fifo))
        with pytest.raises(ValueError, match=f"^{name}: .* received the socket "):
            save(fifo)
        assert stat.S_ISSOCK(os.lstat(fifo).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == [file]


def test_the_atomic_writer_replaces_only_a_regular_file(tmp_path: Path):
    import os
    import stat

    from topojax._fs import atomic_write_bytes

    fifo = tmp_path / "p.bin"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=f"cannot write over the FIFO {re.escape(str(fifo))}"):
        atomic_write_bytes(fifo, b"x")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == ["p.bin"]


def test_save_map_names_image_name_for_a_fifo_where_the_image_goes(tmp_path: Path):
    import os

    os.mkfifo(tmp_path / "m.pgm")
    with pytest.raises(ValueError, match="^image_name: .* received the FIFO "):
        tj.save_map(small_map(), tmp_path / "m.yaml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.pgm"]


@pytest.mark.parametrize(
    ("save", "name", "file"),
    [
        (lambda p: tj.save_graph(small_graph(), p), "path", ".json"),
        (lambda p: tj.save_graph(small_graph(), p), "path", ".GraphML"),
        (tj.load_graph, "path", ".geojson"),
        (lambda p: tj.save_map(small_map(), p), "yaml_path", ".yaml"),
    ],
)
def test_a_file_named_only_by_its_suffix_is_said_to_have_no_stem(
    tmp_path: Path, save, name: str, file: str
):
    path = tmp_path / file
    if save is tj.load_graph:
        tj.save_graph(small_graph(), tmp_path / "g.geojson").rename(path)
    with pytest.raises(ValueError) as info:
        save(path)
    assert str(info.value) == (
        f"{name}: a file named only {file!r} has no stem (the part before the suffix); "
        f"expected a name such as 'map{file}', received {str(path)!r}"
    )


def test_a_folder_that_is_a_loop_of_symbolic_links_is_named_as_one(tmp_path: Path):
    loop = tmp_path / "loop"
    loop.symlink_to("loop")
    path = loop / "g.json"
    with pytest.raises(ValueError) as info:
        tj.save_graph(small_graph(), path)
    assert str(info.value) == (
        f"path: expected a file in an existing folder, received {path}, whose folder {loop} "
        "is a loop of symbolic links"
    )
    with pytest.raises(ValueError) as info:
        tj.load_graph(path)
    assert str(info.value) == (
        f"path: expected a file, received {path}, whose folder {loop} is a loop of symbolic links"
    )
    with pytest.raises(ValueError) as info:
        tj.load_map(loop / "m.yaml")
    assert str(info.value) == (
        f"map path is not a file: {loop / 'm.yaml'}, whose folder {loop} is a loop of "
        "symbolic links"
    )
