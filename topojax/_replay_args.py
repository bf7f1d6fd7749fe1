"""The checks of :func:`topojax.replay`'s arguments, made before the log is opened (not
after the whole replay)."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

from ._fs import output_file
from ._replay_state import STATE_FILE
from ._validate import (
    flag,
    instance_or_default,
    path_like,
    positive_int,
    positive_metres,
    robot_radius,
)
from .config import GraphConfig


def check_options(reader_kwargs, mapper_kw: dict, **flags) -> None:
    """Check :func:`replay`'s bool options ``flags``, ``reader_kwargs`` (a dict or None)
    and the keywords it passes to the mapper (``mapper_kw``)."""
    for name, value in flags.items():
        flag(name, value)
    check_mapper_keywords(mapper_kw)
    for name in ("rooms_every", "room_config", "rooms_local"):
        if not flags.get("rooms") and mapper_kw.get(name) is not None:
            raise ValueError(
                f"{name}: only used with rooms=True, which was not given (the replay keeps "
                f"and writes rooms only with it); received {name}={mapper_kw[name]!r}"
            )
    if reader_kwargs is not None and not isinstance(reader_kwargs, dict):
        raise TypeError(
            "reader_kwargs: expected a dict of keyword arguments of read_scans, received "
            f"{type(reader_kwargs).__name__}"
        )


def check_mapper_keywords(mapper_kw: dict) -> None:
    """Refuse (TypeError, as :func:`replay`'s) keywords that :class:`IncrementalMapper`,
    to which :func:`replay` passes those it does not take itself, does not take either."""
    import inspect

    from .incremental import IncrementalMapper

    known = inspect.signature(IncrementalMapper).parameters
    unknown = [k for k in mapper_kw if k not in known]
    if unknown:
        s = "s" if len(unknown) > 1 else ""
        raise TypeError(
            f"replay: unexpected keyword argument{s} {', '.join(map(repr, unknown))}; "
            f"expected replay's own or IncrementalMapper's ({', '.join(map(repr, known))})"
        )


def check_replay_args(
    max_scans, nav2_tolerance_m, route_graph_radius_m, graph_config, out_dir, animate, mcap
):
    """Check :func:`replay`'s arguments before the replay starts (not after it); returns
    the Nav2 tolerance and the route graph's robot radius as floats (or None)."""
    if max_scans is not None:
        positive_int("max_scans", max_scans)
    if nav2_tolerance_m is not None:  # checked now, not after the whole replay
        nav2_tolerance_m = positive_metres("nav2_tolerance_m", nav2_tolerance_m)
    if graph_config is not None:
        instance_or_default("graph_config", graph_config, GraphConfig)
    out = path_like("out_dir", out_dir)
    if animate is not None:
        path_like("animate", animate)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(
            f"out_dir: expected a folder to write into, but {out} is an existing file"
        )
    if (
        animate is not None
        and Path(animate).suffix.lower() != ".gif"
        and not Path(animate).is_dir()
    ):
        raise ValueError(
            f"animate: expected a GIF file name ending in .gif, received {str(animate)!r}"
        )
    if animate is not None and Path(animate).is_dir():  # checked now, not after the replay
        raise IsADirectoryError(
            f"animate: expected a GIF file name, received the folder {animate}; e.g. "
            f"{Path(animate) / 'graph.gif'}"
        )
    if animate is not None:  # written last, after the whole replay: checked now
        output_file(animate, name="animate")
    if mcap is not None:
        from .io.mcap import mcap_path

        mcap_path(mcap, name="mcap")  # an .mcap file name, not a folder
    if route_graph_radius_m is not None:
        route_graph_radius_m = robot_radius(
            "route_graph_radius_m", route_graph_radius_m, allow_zero=False
        )
    return nav2_tolerance_m, route_graph_radius_m


def output_names(
    *,
    nav2: bool = False,
    plot: bool = False,
    route_graph: bool = False,
    rooms: bool = False,
    view: bool = False,
) -> list[str]:
    """The names of the files a replay writes into its folder, with these options on
    (``nav2_tolerance_m``, ``plot``, ``route_graph_radius_m``, ``rooms``, ``view``)."""
    from .io import ROOM_FILE_SUFFIXES

    names = ["graph.graphml", "graph.json", "graph.geojson"]
    names += ["graph_nav2.geojson"] * nav2
    names += ["map.yaml", "map.pgm", "timings.json"]
    names += ["graph.png", "stages.png"] * plot
    names += [f"route_graph{s}" for s in (".graphml", ".json", ".geojson")] * route_graph
    names += ["route_graph_nav2.geojson"] * (route_graph and nav2)
    names += ["route_graph.png"] * (route_graph and plot)
    names += [f"map{suffix}" for suffix in ROOM_FILE_SUFFIXES] * rooms
    return names + ["view.html", "timeline.json.gz"] * view


def refuse_folder_outputs(out: Path, **options: bool) -> None:
    """Refuse, naming ``out_dir`` before any scan is mapped, a folder or anything else that
    is no regular file where one of the files a replay with ``options`` (those of
    :func:`output_names`) writes into ``out`` goes."""
    from ._fs import refuse_non_files

    refuse_non_files([out / name for name in output_names(**options)], name="out_dir")


def refuse_overwriting_source(source, out: Path, animate, mcap) -> None:
    """Refuse a ``source`` that is not there (FileNotFoundError naming ``source``, not
    the reader's ``path``), and (ValueError) output paths that are the log itself or, for
    a bag folder (or a file in one), a file of that folder: e.g. ``mcap`` the recording
    being replayed (it was replaced by the new recording)."""
    from ._fs import refuse_overwriting_inputs

    src = path_like("source", source)
    if not src.exists():
        raise FileNotFoundError(f"source: no log file or bag there: {src}")
    folder = (
        src if src.is_dir() else src.parent if (src.parent / "metadata.yaml").is_file() else None
    )
    inputs = [src] if folder is None else [p for p in folder.iterdir() if p.is_file()]
    names = output_names(nav2=True, plot=True, route_graph=True, rooms=True, view=True)
    for option, targets in (
        ("out_dir", [out / name for name in [*names, STATE_FILE]]),
        ("animate", [] if animate is None else [Path(animate)]),
        ("mcap", [] if mcap is None else [Path(mcap)]),
    ):
        refuse_overwriting_inputs(
            inputs, targets, option=option, what="the replayed log", instead="path"
        )


def optional_outputs() -> list[str]:
    """The names of the files a replay writes only with some option."""
    always = set(output_names())
    every = output_names(nav2=True, plot=True, route_graph=True, rooms=True, view=True)
    return [n for n in every if n not in always]


def remove_stale(out: Path, written: list[Path]) -> list[str]:
    """Remove the optional outputs that the last replay into ``out`` wrote (as its
    ``timings.json`` lists them) and this one did not: they belong to another map, and
    ``topojax view`` would show them with this one.  Returns a message per file removed."""
    try:
        before = json.loads((out / "timings.json").read_text(encoding="utf-8"))["written"]
        before = {Path(p).name for p in before if isinstance(p, str)}
    except (OSError, ValueError, KeyError, TypeError):  # none, or not a replay's
        return []
    now = {Path(p).resolve() for p in written}
    messages = []
    for name in optional_outputs():
        path = out / name
        if name in before and path.is_file() and path.resolve() not in now:
            path.unlink()
            messages.append(f"removed {path}, written by an earlier replay")
    return messages


@contextlib.contextmanager
def no_empty_folder_left(out: Path):
    """Within ``with``, a failure (an empty log, a bad line, Ctrl-C) removes ``out`` if it
    was made within and is still empty; one that holds what was kept stays."""
    made = not out.exists()
    try:
        yield
    except BaseException:
        if made:
            with contextlib.suppress(OSError):  # not empty
                out.rmdir()
        raise
