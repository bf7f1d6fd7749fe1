"""A :class:`~topojax.graph.GraphStore` as a folder of ``.npy`` arrays: the graph of a map
larger than memory saved and opened again without networkx, its arrays memory-mapped.

The folder holds one ``NAME.npy`` per array of the store (``node_pixel``,
``path_pixels``, ...; optional arrays only where present) and ``graph_store.json``: the
format's name and version, each array's file, dtype and shape, and the graph attributes
with their type schema (as :func:`topojax.save_graph` records them).  The file is strict
JSON: a NaN or infinity of an attribute is null there, its place and spelling listed in
``"non_finite"``, which loading puts back.  The JSON file is written last, so a folder
without it (a save that was interrupted) is refused on load.

A route graph's store adds ``waypoint_offsets`` and ``waypoints``; being optional arrays,
they leave the version at 1: a store without them is saved byte for byte as before, and
a folder saved before them loads.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .._fs import atomic_write, atomic_write_bytes, output_folder
from .._npy import check_npy_size, load_npy
from .._validate import flag, instance_of, path_like
from ..graph.store import GraphStore
from ._schema import _collect_schema, _decode_attrs, jsonable
from ._stream import DuplicateKeyError, loads_unique

__all__ = ["STORE_FILE", "load_graph_store", "save_graph_store", "write_store"]

#: The file that describes a saved store (and marks the folder complete).
STORE_FILE = "graph_store.json"
_FORMAT = "topojax.GraphStore"
_VERSION = 1
_ARRAYS = tuple(f.name for f in dataclasses.fields(GraphStore) if f.name != "attrs")
_REQUIRED = tuple(
    f.name
    for f in dataclasses.fields(GraphStore)
    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
)


def _write_array(path: Path, arr: np.ndarray) -> None:
    """``arr`` to the ``.npy`` file ``path``, replacing it whole (a file of an earlier
    store there may still be memory-mapped)."""
    arr = np.ascontiguousarray(arr)
    atomic_write(path, lambda fh: np.lib.format.write_array(fh, arr, allow_pickle=False))


def save_graph_store(store: GraphStore, folder) -> Path:
    """Save a graph store as a folder of ``.npy`` arrays.

    Parameters
    ----------
    store : GraphStore
        For example ``build_graph_tiled(...).graph_store`` or
        ``GraphStore.from_networkx(graph)`` (of a route graph too: its waypoints are
        arrays of the store).  Its graph attributes are saved, all but ``timings_s``.
    folder : str or Path
        Folder (created); the store's arrays replace its files of the same name (a
        store memory-mapped from them keeps reading the files it opened).  Until the
        save has finished the folder holds no ``graph_store.json``, so a save that
        stops half way is refused by :func:`load_graph_store` rather than read as a
        mixture.

    Returns
    -------
    Path
        ``folder``.

    Raises
    ------
    TypeError
        ``store`` is not a GraphStore, or a graph attribute cannot be saved as JSON.
    """
    if not isinstance(store, GraphStore) and hasattr(store, "adj"):  # a networkx graph
        raise TypeError(
            f"store: expected a GraphStore, received {type(store).__name__} (a networkx "
            "graph: topojax.graph.GraphStore.from_networkx(graph) holds it as a store)"
        )
    instance_of("store", store, GraphStore)
    return write_store(store, output_folder(folder, name="folder"))


def write_store(store: GraphStore, folder: Path, *, written: tuple[str, ...] = ()) -> Path:
    """:func:`save_graph_store` into the existing ``folder``, whose files of the arrays
    named in ``written`` hold the store's already (the paths a tiled build wrote there a
    block at a time, which the store maps)."""
    attrs = {k: v for k, v in store.attrs.items() if k != "timings_s"}
    non_finite: list[list] = []
    doc_attrs = _finite_json(
        {k: jsonable(v, f"graph attribute {k!r}") for k, v in attrs.items()}, (), non_finite
    )
    # the folder is not a complete store again until its description is written, last
    (folder / STORE_FILE).unlink(missing_ok=True)
    arrays = {}
    for name in _ARRAYS:
        arr = getattr(store, name)
        path = folder / f"{name}.npy"
        if arr is None:  # an earlier store's optional array would only mislead
            path.unlink(missing_ok=True)
            continue
        if name not in written:
            _write_array(path, arr)
        arrays[name] = {"file": path.name, "dtype": arr.dtype.str, "shape": list(arr.shape)}
    doc = {
        "format": _FORMAT,
        "version": _VERSION,
        "arrays": arrays,
        "attrs": doc_attrs,
        "attrs_schema": _collect_schema([attrs], "graph"),
    }
    if non_finite:  # strict JSON holds no NaN: null in attrs, its place and value here
        doc["non_finite"] = non_finite
    atomic_write_bytes(folder / STORE_FILE, json.dumps(doc, indent=1).encode("utf-8"))
    return folder


def load_graph_store(folder, *, mmap: bool = True) -> GraphStore:
    """Open a graph store saved by :func:`save_graph_store` (or ``build_graph_tiled``'s
    ``out_dir``).

    Parameters
    ----------
    folder : str or Path
    mmap : bool, default True
        Memory-map the arrays (read-only; they are read from disk as they are used)
        rather than read them into memory.

    Returns
    -------
    GraphStore
        Equal to the saved store, array for array; ``to_networkx()`` gives its graph.

    Raises
    ------
    FileNotFoundError
        No ``graph_store.json`` in ``folder`` (not a saved store, or a save that did not
        finish), or an array file it lists is missing.
    ValueError
        The description is not a saved store's, or an array's file does not hold the
        dtype and shape the description gives (a file replaced or cut short).
    """
    folder = path_like("folder", folder)
    mmap = flag("mmap", mmap)
    desc = folder / STORE_FILE
    if not desc.is_file():
        raise FileNotFoundError(
            f"folder: expected a saved graph store (a folder holding {STORE_FILE}), "
            f"received {folder}" + (", which does not exist" if not folder.exists() else "")
        )
    try:
        doc = loads_unique(desc.read_text(encoding="utf-8"))
    except DuplicateKeyError as exc:
        raise ValueError(f"{desc}: {exc}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{desc}: expected a graph store's description, not JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != _FORMAT:
        raise ValueError(f"{desc}: expected a {_FORMAT} description, received another file")
    if doc.get("version") != _VERSION:
        raise ValueError(
            f"{desc}: expected version {_VERSION} of the format, received "
            f"{doc.get('version')!r} (written by another topojax release)"
        )
    listed = doc.get("arrays")
    missing = [n for n in _REQUIRED if not isinstance(listed, dict) or n not in listed]
    if missing:
        raise ValueError(f"{desc}: expected the arrays {', '.join(missing)} listed, received none")
    arrays = {}
    for name, spec in listed.items():
        if name not in _ARRAYS:
            raise ValueError(f"{desc}: unknown array {name!r}")
        if not isinstance(spec, dict) or not {"file", "dtype", "shape"} <= spec.keys():
            raise ValueError(f"{desc}: array {name!r}: expected its file, dtype and shape")
        file = str(spec["file"])
        if Path(file).name != file or file in ("", ".", ".."):
            raise ValueError(
                f"{desc}: array {name!r}: expected a file in the folder, received {file!r}"
            )
        path = folder / file
        if not path.is_file():
            raise FileNotFoundError(f"{desc}: the array file {path} is missing")
        with open(path, "rb") as fh:  # before np.load allocates what the header claims
            check_npy_size(fh, path.stat().st_size, str(path))
        try:
            arr = load_npy(path, mmap_mode="r" if mmap else None)
        except (ValueError, EOFError) as exc:  # EOFError: an empty file
            raise ValueError(f"{path}: not a readable .npy array ({exc})") from None
        if arr.dtype.str != spec["dtype"] or list(arr.shape) != spec["shape"]:
            raise ValueError(
                f"{path}: expected {spec['dtype']} {tuple(spec['shape'])} as {STORE_FILE} "
                f"describes it, received {arr.dtype.str} {arr.shape} (the file was replaced "
                "or cut short)"
            )
        arrays[name] = arr
    attrs = doc.get("attrs", {})
    _put_non_finite(attrs, doc.get("non_finite", []), desc)
    attrs = _decode_attrs(attrs, doc.get("attrs_schema", {}))
    try:
        return GraphStore(**arrays, attrs=attrs)
    except (TypeError, ValueError) as exc:  # files of different stores side by side
        raise ValueError(f"{desc}: the arrays do not make one graph store: {exc}") from None


#: The spellings of the floats strict JSON cannot hold, in ``"non_finite"``.
_NON_FINITE = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}


def _finite_json(value: Any, place: tuple, found: list[list]) -> Any:
    """The JSON value ``value`` with null for each NaN or infinity in it, whose place (the
    keys and indices to it) and spelling (:data:`_NON_FINITE`) are added to ``found``."""
    if isinstance(value, float) and not math.isfinite(value):
        spelling = "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
        found.append([*place, spelling])
        return None
    if isinstance(value, list):
        return [_finite_json(v, (*place, i), found) for i, v in enumerate(value)]
    if isinstance(value, dict):
        return {k: _finite_json(v, (*place, k), found) for k, v in value.items()}
    return value


def _put_non_finite(attrs: Any, entries: Any, desc: Path) -> None:
    """Put the NaNs and infinities of a description's ``"non_finite"`` ``entries`` back
    into its ``attrs``, in the places that hold null."""
    if not isinstance(entries, list):
        raise ValueError(f"{desc}: non_finite: expected a list, received {entries!r}")
    for entry in entries:
        try:
            *steps, last, spelling = entry
            target = attrs
            for step in steps:
                target = target[step]
            if target[last] is not None:
                raise TypeError
            target[last] = _NON_FINITE[spelling]
        except (TypeError, ValueError, KeyError, IndexError):
            raise ValueError(
                f"{desc}: non_finite: expected the place of a null in attrs and one of "
                f"{sorted(_NON_FINITE)}, received {entry!r}"
            ) from None
