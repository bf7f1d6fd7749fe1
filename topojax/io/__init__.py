"""Saving and loading topology graphs (GraphML, JSON node-link, GeoJSON, folders of
arrays), writing them as
route graphs for the ROS 2 Nav2 Route Server (:func:`save_nav2_graph`), and the files of a
room segmentation (:func:`save_rooms` / :func:`load_rooms`, :func:`save_room_labels`,
:func:`save_room_graph`), and ROS 2 MCAP recordings of maps, graphs, rooms and scans for
Foxglove, RViz and ``ros2 bag play`` (:func:`save_mcap`, :class:`McapRecorder`).

Graphs are :class:`networkx.MultiGraph` objects with integer node ids. The topojax
attribute schema is

* nodes: ``pixel`` (tuple (row, col) of int), ``world`` (tuple (x, y) of float, metres),
  ``kind`` (str), ``clearance_m`` (float);
* edges: ``path`` (np.ndarray of int, (K, 2), (row, col)), ``world`` (np.ndarray of float,
  (K, 2), (x, y) metres), ``length_m``, ``min_clearance_m``, ``mean_clearance_m`` (float);
* graph: ``resolution_m``, ``origin`` (3-tuple), ``shape`` ((H, W)) and any other
  attributes.

Every file also stores a small *type schema* (``"topojax_schema"``) that records, per
attribute name, whether values were numpy arrays (with dtype and trailing shape), tuples,
lists or other JSON values, and the type of node ids and edge keys. :func:`load_graph` uses
it to give back the same Python/numpy types. Files without a schema (written by other
tools) are decoded with the topojax defaults above.

Floats are written with Python's shortest round-trip representation, so they come back
bit-exact. Writes are atomic: a temporary file in the target folder is renamed over the
destination with :func:`os.replace`. Graph files are written a node and an edge at a time,
so writing one holds far less memory than the file's size.

Modules: ``_schema`` (value encoding and the type schema), ``_stream`` (writing a file
a piece at a time), ``nodelink``, ``graphml``, ``geojson`` (one per file format),
``files`` (:func:`save_graph` / :func:`load_graph`), ``nav2`` (:func:`save_nav2_graph`),
``rooms`` (rooms and doorways), ``mcap`` (ROS 2 recordings), ``store`` (a
:class:`~topojax.graph.GraphStore` as a folder of memory-mapped arrays:
:func:`save_graph_store` / :func:`load_graph_store`).
"""

from __future__ import annotations

from ._schema import as_multigraph as as_multigraph
from ._schema import jsonable as jsonable
from .files import GRAPH_FORMATS, load_graph, save_graph
from .mcap import McapRecorder, save_mcap
from .nav2 import save_nav2_graph
from .rooms import (
    ROOM_FILE_SUFFIXES,
    load_rooms,
    save_room_files,
    save_room_graph,
    save_room_labels,
    save_rooms,
)
from .store import load_graph_store, save_graph_store

__all__ = [
    "GRAPH_FORMATS",
    "ROOM_FILE_SUFFIXES",
    "McapRecorder",
    "load_graph",
    "load_graph_store",
    "load_rooms",
    "save_graph",
    "save_graph_store",
    "save_mcap",
    "save_nav2_graph",
    "save_room_files",
    "save_room_graph",
    "save_room_labels",
    "save_rooms",
]
