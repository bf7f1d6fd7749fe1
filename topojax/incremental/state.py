"""Saved mapper states: format name and version."""

from __future__ import annotations

import io as _io
import json
import zipfile
from pathlib import Path

import numpy as np

from .._npy import check_npz_fits, check_npz_sizes, savez_deflated
from .._validate import existing_file
from ..config import DistanceConfig, GraphConfig, PipelineConfig, RidgeConfig, SkeletonConfig
from ..graph import KIND_NAMES
from ._graph_store import add_paths, edge_ids, edge_paths, reserve, vertex_ids
from ._rays import cast_pending_rays, check_whole
from ._rooms_state import restore_rooms_seg, rooms_seg_arrays
from ._settings import settings_of
from ._state_checks import check_counters, check_graph_tables, check_pixels
from ._tiles import _pack, _unpack

#: ``format`` field of saved mapper states.
STATE_FORMAT = "topojax.IncrementalMapper"


#: zlib level of saved states: 3, the best ratio of zlib's fast levels (1-3), saves the
#: whole Intel log's state (mostly tiles of squared distances, which compress least) in
#: about a third of the time of numpy's default, 6, for a file about 15% larger; a
#: replay's checkpoints save it every minute.  States saved at any level load alike.
STATE_ZLIB_LEVEL = 3


#: Version of the saved-state layout; :meth:`IncrementalMapper.load` accepts only this one.
STATE_VERSION = 2


def save_state(mapper, path, *, replay: dict | None = None) -> Path:
    """The body of :meth:`IncrementalMapper.save`; with ``replay`` (a JSON-ready dict),
    also the record of the replay that stopped part way (:mod:`topojax._replay_state`),
    which :meth:`IncrementalMapper.load` ignores."""
    from .._fs import atomic_write_bytes

    check_whole(mapper, "save")
    p = Path(path)
    cast_pending_rays(mapper)
    arrays: dict[str, np.ndarray] = {
        "format": np.asarray(STATE_FORMAT),
        "version": np.asarray(STATE_VERSION, np.int64),
        "settings": np.asarray(json.dumps(settings_of(mapper))),
    }
    if replay is not None:
        arrays["replay"] = np.asarray(json.dumps(replay))
    for key, value in mapper._tiles.state().items():
        arrays[f"tiles/{key}"] = value
    pend = np.concatenate(mapper._pending) if mapper._pending else np.zeros((0, 2), np.int64)
    chg = (
        np.concatenate(mapper._skel_changed) if mapper._skel_changed else np.zeros((0, 2), np.int64)
    )
    arrays["pending"] = pend.astype(np.int64)
    arrays["skel_changed"] = chg.astype(np.int64)
    rb = mapper._ridge_bbox
    arrays["ridge_bbox"] = np.asarray(rb if rb is not None else (0, 0, 0, 0), np.int64)
    arrays["has_ridge_bbox"] = np.asarray(rb is not None)
    arrays["counters"] = np.asarray(
        [
            mapper._n_scans,
            mapper._since_skeleton,
            mapper._since_graph,
            mapper._next_vertex,
            mapper._next_edge,
            mapper._n_ridge,
        ],
        np.int64,
    )
    nodes = vertex_ids(mapper)
    arrays["v_id"] = nodes
    arrays["v_pixel"] = np.stack(_unpack(mapper._v_key[nodes]), axis=1)
    arrays["v_kind"] = mapper._v_code[nodes].copy()
    edges = edge_ids(mapper)
    arrays["e_id"] = edges
    arrays["e_uv"] = mapper._e_uv[edges]
    paths, lens = edge_paths(mapper, edges)
    arrays["e_len"] = lens.astype(np.int64)
    arrays["e_path"] = paths.astype(np.int64)
    keeper = mapper._rooms
    if keeper.labels is not None:
        arrays["rooms_labels"] = keeper.labels
        arrays["rooms_box"] = np.asarray(keeper.box, np.int64)
        arrays.update(rooms_seg_arrays(keeper))
    arrays["rooms_counters"] = np.asarray(
        [keeper.next_id, int(keeper.active), mapper._since_rooms], np.int64
    )
    buf = _io.BytesIO()
    savez_deflated(buf, arrays, STATE_ZLIB_LEVEL)
    atomic_write_bytes(p, buf.getvalue())
    return p


def read_state(path) -> tuple[Path, dict[str, np.ndarray]]:
    """The arrays of a mapper state file, its format and version checked.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If it is not a file (a folder), or the file is not a mapper state or has another
        format version.
    MemoryError
        If its arrays unpack to more bytes than the memory available (checked before
        any is read).
    """
    p = existing_file("path", path)
    if not zipfile.is_zipfile(p):  # np.load would read a .npy or ask about pickles
        raise ValueError(
            f"{p}: not a mapper state: a state is an .npz (zip) archive written by "
            "IncrementalMapper.save"
        )
    try:
        with np.load(p, allow_pickle=False) as z:
            check_npz_fits(z, str(p))  # a MemoryError: not caught below
            check_npz_sizes(z)  # before z[k] allocates what a header claims
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise ValueError(f"{p}: not a readable mapper state (.npz): {exc}") from None
    try:
        fmt = str(data["format"])
        version = int(data["version"])
    except KeyError:
        raise ValueError(f"{p}: not a mapper state (no format/version field)") from None
    except (TypeError, ValueError):
        raise ValueError(
            f"{p}: not a mapper state (format/version field of another kind: "
            f"{data['format']!r}, {data['version']!r})"
        ) from None
    if fmt != STATE_FORMAT:
        raise ValueError(f"{p}: format: expected {STATE_FORMAT!r}, received {fmt!r}")
    if version != STATE_VERSION:
        raise ValueError(
            f"{p}: mapper state version {version} is not supported; expected "
            f"{STATE_VERSION} (saved by another topojax version)"
        )
    return p, data


def load_rooms_state(mapper, data) -> None:
    """Restore the mapper's room keeper: the stored labels and ids, and the last
    segmentation with the free and unknown space it was made from, so that the next
    (local) update is the one the saved mapper would have made.  A state without the
    segmentation (saved by an older topojax) segments the whole map at the next update,
    keeping the stored ids."""
    if "rooms_counters" not in data:
        return
    keeper = mapper._rooms
    keeper.next_id, active, mapper._since_rooms = (int(v) for v in data["rooms_counters"])
    keeper.active = bool(active)
    if "rooms_labels" in data:
        keeper.labels = np.asarray(data["rooms_labels"], np.int32)
        keeper.box = tuple(int(v) for v in data["rooms_box"])
        if keeper.labels.shape != (keeper.box[2] - keeper.box[0], keeper.box[3] - keeper.box[1]):
            raise ValueError("the stored room labels do not match their box")
        if keeper.labels.size and int(keeper.labels.max()) >= keeper.next_id:
            raise ValueError("stored room ids reach past the next unused id")
        restore_rooms_seg(keeper, data, mapper.resolution_m)


def saved_settings(text: str) -> dict:
    """The keyword arguments of the mapper whose settings :meth:`IncrementalMapper.save`
    wrote as the JSON ``text``; a key missing from them raises ValueError naming it."""
    try:
        settings = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(
            f"settings: expected a JSON object, received {text[:80]!r} ({exc})"
        ) from None
    if not isinstance(settings, dict):
        raise ValueError(f"settings: expected a JSON object, received {text[:80]!r}")
    try:
        cfg = settings.pop("config")
        if "room_config" in settings:
            from ..rooms import RoomConfig

            settings["room_config"] = RoomConfig(**settings["room_config"])
        settings["config"] = PipelineConfig(
            distance=DistanceConfig(**cfg["distance"]),
            ridge=RidgeConfig(**cfg["ridge"]),
            skeleton=SkeletonConfig(**cfg["skeleton"]),
            graph=GraphConfig(**cfg["graph"]),
            tile_px=cfg["tile_px"],
            tiles_per_call=cfg["tiles_per_call"],
        )
    except KeyError as exc:
        raise ValueError(f"settings: expected the key {exc} in the saved settings") from None
    return settings


def load_state(cls, path):
    """The body of :meth:`IncrementalMapper.load` (``cls``: the mapper class)."""
    return mapper_from_state(cls, *read_state(path))


def mapper_from_state(cls, p: Path, data: dict[str, np.ndarray]):
    """The mapper (of class ``cls``) of the state ``data`` read from ``p``
    (:func:`read_state`); a corrupt or inconsistent state raises ValueError naming ``p``."""
    try:
        mapper = cls(**saved_settings(str(data["settings"])))
        tile_state = {k[6:]: v for k, v in data.items() if k.startswith("tiles/")}
        mapper._tiles.load_state(tile_state)
        tiles = mapper._tiles
        check_counters(data, tiles.n_tiles, mapper.tile_px)
        check_pixels(data, tiles.keys, mapper.tile_px, tiles.pixel_bbox)
        pend = np.asarray(data["pending"], np.int64).reshape(-1, 2)
        mapper._pending = [pend] if pend.shape[0] else []
        mapper._n_pending = int(pend.shape[0])
        chg = np.asarray(data["skel_changed"], np.int64).reshape(-1, 2)
        mapper._skel_changed = [chg] if chg.shape[0] else []
        if bool(data["has_ridge_bbox"]):
            mapper._ridge_bbox = tuple(int(v) for v in data["ridge_bbox"])
        (
            mapper._n_scans,
            mapper._since_skeleton,
            mapper._since_graph,
            mapper._next_vertex,
            mapper._next_edge,
            mapper._n_ridge,
        ) = (int(v) for v in data["counters"])
        v_id = np.asarray(data["v_id"], np.int64)
        v_px = np.asarray(data["v_pixel"], np.int64).reshape(-1, 2)
        v_code = np.asarray(data["v_kind"], np.int8)
        e_id = np.asarray(data["e_id"], np.int64)
        e_uv = np.asarray(data["e_uv"], np.int64).reshape(-1, 2)
        nv, ne = mapper._next_vertex, mapper._next_edge
        for name, ids, n in (("vertex", v_id, nv), ("edge", e_id, ne)):
            if ids.size and (ids.min() < 0 or ids.max() >= n):
                raise ValueError(
                    f"{name} ids: expected values in [0, {n}), received {ids.min()}..{ids.max()}"
                )
        check_graph_tables(data, KIND_NAMES)
        reserve(mapper, vertices=nv, edges=ne)
        mapper._v_key[v_id] = _pack(v_px[:, 0], v_px[:, 1])
        mapper._v_code[v_id] = v_code
        mapper._v_alive[v_id] = True
        paths = np.asarray(data["e_path"], np.int64).reshape(-1, 2)
        mapper._e_uv[e_id] = e_uv
        mapper._e_alive[e_id] = True
        add_paths(mapper, e_id, paths.astype(np.int32), np.asarray(data["e_len"], np.int64))
        load_rooms_state(mapper, data)
    except KeyError as exc:
        raise ValueError(
            f"{p}: corrupt or inconsistent mapper state: no field {exc} (expected the "
            f"fields IncrementalMapper.save writes, version {STATE_VERSION})"
        ) from None
    except (TypeError, ValueError, IndexError) as exc:
        raise ValueError(f"{p}: corrupt or inconsistent mapper state: {exc}") from None
    return mapper
