"""Options shared by several commands, and the configurations they give."""

from __future__ import annotations

import argparse
import contextlib
import re
from collections.abc import Iterator

from .._constants import MODES

#: The configuration fields that an option of this module sets, and the option.
_OPTION_OF = {
    "sigma_m": "--sigma-m",
    "sigma_px": "--sigma-px",
    "tile_px": "--tile-px",
    "min_clearance_m": "--min-clearance-m",
    "min_spur_m": "--min-spur-m",
    "min_component_m": "--min-component-m",
}


def _as_option_error(
    exc: Exception, option_of: dict[str, str] = _OPTION_OF, *, advice: dict[str, str] | None = None
) -> Exception:
    """``exc`` with every configuration field its message names (``min_spur_m``) written
    as the option that sets it (``--min-spur-m``), ``option_of`` mapping the one to the
    other: the commands' errors name what their user typed; a ``ValueError``'s advice
    as :func:`_as_options` words it with ``advice``.  A ``TypeError``, a ``ValueError``
    or a built-in ``OSError`` (``NotADirectoryError`` as well) made from a message (and
    an error number) is rewritten; any other error is ``exc``.  A name within a file path
    (``out/resume/state.npz``, ``animate.gif``) or already an option (``--resume``) is
    left as it is."""
    if type(exc) is ValueError:  # a subclass keeps its own arguments
        return ValueError(_as_options(str(exc), option_of, advice=advice))
    if type(exc) is TypeError:
        return TypeError(_as_options(str(exc), option_of))
    if isinstance(exc, OSError) and type(exc).__module__ == "builtins" and exc.filename is None:
        if len(exc.args) == 1 and isinstance(exc.args[0], str):
            return type(exc)(_as_options(exc.args[0], option_of))
        if exc.errno is not None and isinstance(exc.strerror, str):
            return type(exc)(exc.errno, _as_options(exc.strerror, option_of))
    return exc


#: The map options to check when a map, as classified, gives nothing (for a note).
MAP_OPTIONS_TO_CHECK = (
    "--occupied-thresh, --free-thresh, --negate, --mode (e.g. --mode ipa for IPA "
    "benchmark maps, where every pixel below 250 is inaccessible)"
)


def _as_options(
    text: str, option_of: dict[str, str] = _OPTION_OF, *, advice: dict[str, str] | None = None
) -> str:
    """``text`` with every configuration field it names written as the option that sets
    it, as :func:`_as_option_error` writes a message; first each phrase of ``advice``
    (the library's advice, such as "build with resume=False") as the command words it."""
    for phrase, instead in (advice or {}).items():
        text = text.replace(phrase, instead)
    if not option_of:
        return text
    names = "|".join(map(re.escape, option_of))
    words = re.compile(rf"(?<![\w/\\.-])({names})(?![\w/\\-]|\.\w)")
    return words.sub(lambda m: option_of[m.group(1)], text)


@contextlib.contextmanager
def named_as_options(
    option_of: dict[str, str], resume_option_of: dict[str, str], *, advice: dict[str, str]
) -> Iterator[None]:
    """Within ``with``, an error of a library call that names its parameters names the
    options that set them (:func:`_as_option_error`): ``option_of``'s, or for a refused
    resume (``resume: ...``, which also names the settings that differ)
    ``resume_option_of``'s; a ``ValueError``'s advice as ``advice`` words it."""
    try:
        yield
    except (TypeError, ValueError, OSError) as exc:
        names = resume_option_of if str(exc).startswith("resume:") else option_of
        raise _as_option_error(exc, names, advice=advice) from None


def _option_named(exc: ValueError, field: str, option: str) -> ValueError:
    """``exc`` with ``field`` written as ``option`` where the error is about that field
    (its message starts ``field:``), else ``exc`` itself."""
    return _as_option_error(exc, {field: option}) if str(exc).startswith(f"{field}:") else exc


#: The advice of a map file's refusals that names ``load_map``'s ``resolution_m``, and
#: what the commands that read maps say instead.
MAP_ADVICE = {
    "pass resolution_m to set it": "give --resolution to set it",
    "give it with load_map's resolution_m=": "give it with --resolution",
}


#: The thresholds of :func:`map_options` that a map's loading checks against the other
#: one, read from its YAML or map_server's default, and the options that give them.
_THRESHOLD_OPTIONS = (("free_thresh", "--free-thresh"), ("occupied_thresh", "--occupied-thresh"))


def load_option_map(path, options: dict):
    """``load_map(path, **options)`` (the keyword arguments of :func:`map_options`), with
    the resolution it would assume given, as the command's map line says it; a threshold
    that an option gave and the map's other one refuses is named as that option, the
    other as the option that would set it."""
    from ..maps import load_map
    from ..maps.files import said_resolution

    try:
        return load_map(path, **said_resolution(path, options))
    except ValueError as exc:
        if given_threshold_refused(str(exc), options):
            raise _as_option_error(exc, dict(_THRESHOLD_OPTIONS)) from None
        if type(exc) is ValueError and any(phrase in str(exc) for phrase in MAP_ADVICE):
            raise _as_option_error(exc, {}, advice=MAP_ADVICE) from None
        raise


def given_threshold_refused(message: str, options: dict) -> bool:
    """Whether ``message`` refuses a threshold that ``options`` give (against the map's
    other one): its thresholds are then the options'."""
    return any(
        options.get(f) is not None and message.startswith(f"{f}:") for f, _ in _THRESHOLD_OPTIONS
    )


def pipeline_config(args, *, resolution_m: float | None = None):
    """The :class:`PipelineConfig` of the options of :func:`add_pipeline_options`, with
    the Gaussian of :func:`add_sigma_options` where the command has them: ``--sigma-px``
    as given, ``--sigma-m`` through ``resolution_m`` (a command that runs many maps
    passes none and converts per map; the value is still checked); an error names the
    option."""
    from ..config import DistanceConfig, PipelineConfig, SkeletonConfig

    distance = distance_config(args, resolution_m=resolution_m) or DistanceConfig()
    try:
        return PipelineConfig(
            distance=distance,
            skeleton=SkeletonConfig(thinning=args.thinning, remove_t=not args.keep_t),
            graph=graph_config(args),
            tile_px=args.tile_px,
        )
    except (TypeError, ValueError) as exc:
        raise _as_option_error(exc) from None


def distance_config(args, *, resolution_m: float | None = None):
    """The :class:`DistanceConfig` of the options of :func:`add_sigma_options`:
    ``--sigma-px`` as given, ``--sigma-m`` through ``resolution_m`` (without one, the
    value is only checked, and None returned); None where neither is given (the paper's
    Gaussian).  An error names the option."""
    from .._validate import positive_metres
    from ..config import DistanceConfig

    sigma_px, sigma_m = getattr(args, "sigma_px", None), getattr(args, "sigma_m", None)
    try:
        if sigma_px is not None:
            return DistanceConfig.from_pixels(sigma_px=sigma_px)
        if sigma_m is not None and resolution_m is not None:
            return DistanceConfig.from_metres(sigma_m=sigma_m, resolution_m=resolution_m)
        if sigma_m is not None:
            positive_metres("sigma_m", sigma_m)
        return None
    except (TypeError, ValueError) as exc:
        raise _as_option_error(exc) from None


def graph_config(args):
    """The :class:`GraphConfig` of the options of :func:`add_graph_options`; an error
    names the option."""
    from ..config import GraphConfig

    try:
        return GraphConfig(
            free_space_only=args.free_only,
            min_clearance_m=args.min_clearance_m,
            min_spur_m=args.min_spur_m,
            min_component_m=args.min_component_m,
        )
    except (TypeError, ValueError) as exc:
        raise _as_option_error(exc) from None


def graph_filters(config) -> dict:
    """The options of ``config`` (a :class:`GraphConfig`) that change the graph written,
    by their field names (``{"min_spur_m": 0.5}``); empty when it keeps the whole graph."""
    from ..config import PRUNING_SETTINGS

    names = ("free_space_only", *PRUNING_SETTINGS)
    return {name: getattr(config, name) for name in names if getattr(config, name)}


def add_pipeline_options(p: argparse.ArgumentParser) -> None:
    """Options shared by every command that runs the full-map pipeline (thinning, T
    removal, what to keep of the graph, tiles)."""
    p.add_argument(
        "--thinning",
        choices=("guo_hall", "zhang"),
        default="guo_hall",
        help="thinning algorithm (default: guo_hall, the paper's; zhang = the original code's)",
    )
    p.add_argument("--keep-t", action="store_true", help="do not remove T-junction centres")
    add_graph_options(p)
    p.add_argument("--tile-px", type=int, default=256, help="JAX tile side in pixels (default 256)")


def add_graph_options(p: argparse.ArgumentParser) -> None:
    """What to keep of the graph: ``--free-only`` and the ``--min-*-m`` pruning options."""
    p.add_argument(
        "--free-only",
        action="store_true",
        help="thin only the ridges in known free space (none in unknown space)",
    )
    p.add_argument(
        "--min-clearance-m",
        type=float,
        default=0.0,
        metavar="M",
        help="remove corridors narrower than M metres from wall to centre, e.g. the robot's "
        "radius (default 0: keep all)",
    )
    p.add_argument(
        "--min-spur-m",
        type=float,
        default=0.0,
        metavar="M",
        help="remove dead-end branches shorter than M metres (default 0: keep all)",
    )
    p.add_argument(
        "--min-component-m",
        type=float,
        default=0.0,
        metavar="M",
        help="remove pieces of graph shorter than M metres in all (default 0: keep all)",
    )


def add_sigma_options(p: argparse.ArgumentParser, *, each_map: str = "") -> None:
    """``--sigma-m`` / ``--sigma-px`` (mutually exclusive): the distance map's Gaussian."""
    scale = p.add_mutually_exclusive_group()
    scale.add_argument(
        "--sigma-m",
        type=float,
        metavar="M",
        help=f"Gaussian sigma of the distance map in metres{each_map}, the support scaled "
        "with it (default: the paper's 64.19 px, 3.2 m at 0.05 m/px; a finer map needs "
        "more pixels)",
    )
    scale.add_argument(
        "--sigma-px", type=float, metavar="P", help="the same in pixels (default 64.19)"
    )


def add_nav2_options(p: argparse.ArgumentParser, name: str) -> None:
    """``--nav2`` (also write the file ``name``: a Nav2 Route Server graph) and its
    ``--nav2-tolerance-m``."""
    p.add_argument(
        "--nav2",
        action="store_true",
        help=f"also write {name}, a route graph for the ROS 2 Nav2 Route Server",
    )
    p.add_argument(
        "--nav2-tolerance-m",
        type=float,
        default=None,
        metavar="M",
        help="Nav2 waypoints keep every corridor pixel within M metres (default 0.1)",
    )


def nav2_tolerance(args) -> float | None:
    """The checked ``--nav2-tolerance-m`` when ``--nav2`` is given (else None); the error
    names the option (checked before any work)."""
    if not args.nav2:
        if args.nav2_tolerance_m is not None:
            raise ValueError("--nav2-tolerance-m: only used with --nav2, which was not given")
        return None
    from .._validate import positive_metres

    tolerance = 0.1 if args.nav2_tolerance_m is None else args.nav2_tolerance_m
    return positive_metres("--nav2-tolerance-m", tolerance)


def add_map_options(p: argparse.ArgumentParser, *, each_map: str = "") -> None:
    """How a map file is read: ``--resolution``, ``--occupied-thresh``, ``--free-thresh``,
    ``--negate`` and ``--mode`` (:func:`map_options` gives them to ``load_map``), the
    options of every command that reads one; ``each_map`` ends the help of the first."""
    p.add_argument(
        "--resolution",
        dest="resolution_m",
        type=float,
        help=f"m/px of the map{each_map} (default: a YAML's own, a PGM's 'm/pix' comment, "
        "else 0.05; given, it replaces a YAML's or a PGM's)",
    )
    p.add_argument(
        "--occupied-thresh",
        type=float,
        help="a pixel is occupied above this share of occupancy, from 0 to 1 (default: the "
        "YAML's, else 0.65)",
    )
    p.add_argument(
        "--free-thresh",
        type=float,
        help="a pixel is free below this share of occupancy, from 0 to 1 (default: the "
        "YAML's, else 0.196)",
    )
    p.add_argument(
        "--negate",
        action=argparse.BooleanOptionalAction,
        help="image values are occupancy (--no-negate: they are not; default: a YAML's "
        "negate, else not)",
    )
    p.add_argument(
        "--mode",
        choices=MODES,
        help="pixel convention (default: the YAML's, else trinary; ipa: free if >= 250, "
        "everything else occupied)",
    )


def map_options(args) -> dict:
    """The keyword arguments of ``load_map`` that the options of :func:`add_map_options`
    set (those not given are left to the file and the defaults), checked under the
    options' names."""
    from .._validate import metres_per_pixel, positive_metres

    if args.resolution_m is not None:
        positive_metres("--resolution", args.resolution_m)
        metres_per_pixel("--resolution", args.resolution_m)  # and a map's range
    for name in ("occupied_thresh", "free_thresh"):
        value = getattr(args, name)
        if value is not None and not 0.0 <= value <= 1.0:  # also NaN
            option = "--" + name.replace("_", "-")
            raise ValueError(f"{option}: expected a share from 0 to 1, received {value!r}")
    if args.free_thresh is not None and args.occupied_thresh is not None:
        if args.free_thresh >= args.occupied_thresh:
            raise ValueError(
                "--free-thresh: expected less than --occupied-thresh "
                f"({args.occupied_thresh!r}), received {args.free_thresh!r}"
            )
    kw = {}
    for name in ("resolution_m", "occupied_thresh", "free_thresh", "mode"):
        if getattr(args, name) is not None:
            kw[name] = getattr(args, name)
    if args.negate is not None:
        kw["negate"] = args.negate
    return kw


def add_snap_option(p: argparse.ArgumentParser, *, default: float | None = 1.0) -> None:
    """``--snap-m``, the route graph's coverage distance (:func:`snap_option` checks it)."""
    p.add_argument(
        "--snap-m",
        type=float,
        default=default,
        metavar="M",
        help="every feasible point lies within M metres of the route graph (0.2 to 5, and "
        "at least 0.1 plus 1.5 pixels of the map; default 1.0)",
    )


def snap_option(value: float) -> float:
    """``--snap-m`` after checking it lies in the route graph's range (twice the waypoint
    tolerance to ``MAX_SNAP_M``); a ``ValueError`` naming the option otherwise."""
    from .._validate import positive_metres
    from ..routegraph import RouteGraphConfig
    from ..routegraph.scale import MAX_SNAP_M

    snap_m = positive_metres("--snap-m", value)
    least = 2 * RouteGraphConfig.waypoint_tolerance_m  # the class default: a float
    if not least <= snap_m <= MAX_SNAP_M:
        raise ValueError(
            f"--snap-m: expected {least:g} to {MAX_SNAP_M:g} m (twice the waypoint "
            f"tolerance at least), received {snap_m!r}"
        )
    return snap_m


def map_line(name, occupancy, assumed: str = "") -> str:
    """The ``map`` line the commands print: the map's name, its size in pixels, width x
    height as images are read (and said so), its resolution and the ``assumed`` note
    (:func:`assumed_resolution_note`)."""
    rows, cols = occupancy.shape[:2]
    return (
        f"map        {name}  ({cols} x {rows} px (w x h), {occupancy.resolution_m:g} m/px{assumed})"
    )


def assumed_resolution_note(args) -> str:
    """``", assumed: ..."`` where the map file (``args.map``) states no resolution and
    ``--resolution`` did not give one; ``", from --resolution: ..."`` where it replaced
    another the file states (every length and area then scales); else ``""``: for the
    line that prints it."""
    from ..maps.files import default_resolution_used, replaced_resolution

    if args.resolution_m is None:
        if default_resolution_used(args.map):
            return ", assumed: the file states none; --resolution sets it"
        return ""
    own = replaced_resolution(args.map, args.resolution_m)
    return "" if own is None else f", from --resolution: the file states {own:g}"


#: The room options: (option, RoomConfig field, default, metavar, help).  The defaults are
#: RoomConfig's (a test holds them equal); building the parser must not import it.
_ROOM_OPTIONS = (
    ("--min-door-width-m", "min_door_width_m", 0.5, "M", "narrower gaps are not doors"),
    ("--max-door-width-m", "max_door_width_m", 2.2, "M", "wider gaps are not doors"),
    (
        "--door-context-m",
        "door_context_m",
        1.0,
        "M",
        "a doorway is the narrowest point of the corridor within M metres",
    ),
    (
        "--door-ratio",
        "door_ratio",
        0.7,
        "R",
        "keep a door only if at most R times the width of each room it joins",
    ),
    (
        "--min-room-m2",
        "min_room_m2",
        2.0,
        "A",
        "smaller regions merge into a neighbour; unknown space of A m2 or more that a room "
        "surrounds stays no room",
    ),
    (
        "--min-isolated-room-m2",
        "min_isolated_room_m2",
        0.5,
        "A",
        "a free area without doorways is a room from A m2 on",
    ),
    (
        "--max-border-share",
        "max_border_share",
        0.25,
        "S",
        "merge two regions whose doors are more than S of the smaller one's boundary",
    ),
)


def add_room_options(p: argparse.ArgumentParser, *, only_with: str = "") -> None:
    """The options of the room segmentation (:class:`topojax.RoomConfig`), in metres, as
    an argument group; ``only_with`` names the option they need, if any."""
    title = "rooms" + (f" (with {only_with})" if only_with else "")
    group = p.add_argument_group(title, "room segmentation; lengths in metres, areas in m2")
    for option, field, default, metavar, text in _ROOM_OPTIONS:
        group.add_argument(
            option,
            dest=field,
            type=float,
            default=None,
            metavar=metavar,
            help=f"{text} (default {default:g})",
        )


def room_config(args, *, only_with: str | None = None, given: bool = True):
    """The :class:`RoomConfig` of the options of :func:`add_room_options`; an error names
    the option (checked before any work).  With ``only_with`` (the flag the options need,
    e.g. ``"--rooms"``) and ``given`` False: None, and an error when any option is set."""
    from ..rooms import RoomConfig

    option_of = {field: option for option, field, *_ in _ROOM_OPTIONS}
    values = {f: getattr(args, f) for f in option_of if getattr(args, f) is not None}
    if only_with is not None and not given:
        if values:
            names = ", ".join(option_of[f] for f in values)
            raise ValueError(f"{names}: only used with {only_with}, which was not given")
        return None
    try:
        return RoomConfig(**values)
    except (TypeError, ValueError) as exc:  # the messages name RoomConfig's fields
        raise _as_option_error(exc, option_of) from None
