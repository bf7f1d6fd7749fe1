"""The inputs of a batch: brace and glob expansion, folder walks, and the unique name
(output file stem) of every map."""

from __future__ import annotations

import fnmatch
import glob as _glob
import json
import os
import warnings
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .._fs import yaml_image
from .._validate import instance_of
from .._words import counted
from ..io import GRAPH_FORMATS, ROOM_FILE_SUFFIXES
from ..maps import IMAGE_SUFFIXES, YAML_SUFFIXES, OccupancyMap

__all__ = [
    "ROUTE_FORMATS",
    "check_formats",
    "expand_braces",
    "expand_map_inputs",
    "planned_outputs",
]

_MAP_SUFFIXES = tuple(YAML_SUFFIXES) + tuple(IMAGE_SUFFIXES)
_MANIFEST_SUFFIX = ".manifest.json"
_PICTURE_SUFFIX = "_graph.png"
# with a route format, --plot also draws the route graph (as topojax route-graph --plot)
_ROUTE_PICTURE_SUFFIX = "_route.png"
_PICTURES = (_PICTURE_SUFFIX, _ROUTE_PICTURE_SUFFIX)
_FORMAT_SUFFIX = {fmt: suffix for suffix, fmt in GRAPH_FORMATS.items()}
# a route graph for the ROS 2 Nav2 Route Server (topojax.save_nav2_graph, default tolerance)
_FORMAT_SUFFIX["nav2"] = "_nav2.geojson"
# Every format and the files it writes: a graph format one, ``rooms`` the room files
# (topojax.io.save_room_files: GeoJSON, label picture, room graph as GraphML and JSON).
_FORMAT_FILES = {fmt: (suffix,) for fmt, suffix in _FORMAT_SUFFIX.items()}
_FORMAT_FILES["rooms"] = ROOM_FILE_SUFFIXES
# ``route``: the route graph of the map for a round robot (topojax.route_graph) as
# GraphML, JSON and GeoJSON, the files of ``topojax route-graph``; ``route_nav2``: that
# graph for the Nav2 Route Server.
_FORMAT_FILES["route"] = ("_route.graphml", "_route.json", "_route.geojson")
_FORMAT_FILES["route_nav2"] = ("_route_nav2.geojson",)
#: The formats that need the route graph.
ROUTE_FORMATS = ("route", "route_nav2")
# the images among a map's outputs: read as maps if found in a search
_IMAGES_OUT = tuple(
    s
    for s in (*(x for v in _FORMAT_FILES.values() for x in v), *_PICTURES)
    if s.lower().endswith(_MAP_SUFFIXES)
)


def _format_suffixes(formats: Iterable[str]) -> list[str]:
    """What the files of ``formats`` append to a map's name, in order."""
    return [suffix for fmt in formats for suffix in _FORMAT_FILES[fmt]]


def _matching_brace(text: str, start: int) -> tuple[int, list[int]] | None:
    """Index of the ``}`` closing the ``{`` at ``start`` and the top-level comma indices."""
    depth = 0
    commas: list[int] = []
    for i in range(start, len(text)):
        ch = text[i]
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0:
                return i, commas
        elif ch == "," and depth == 1:
            commas.append(i)
    return None


def expand_braces(pattern: str) -> list[str]:
    """Shell-style brace expansion: ``"a/*.{yaml,p{n,g}m}"`` -> ``["a/*.yaml", "a/*.pnm",
    "a/*.pgm"]``.

    Parameters
    ----------
    pattern : str
        Text with optional ``{x,y,...}`` groups (nestable).  As in bash, a group needs a
        matching ``}`` and at least one top-level comma; other braces stay literal
        (``"{a}"``, ``"a{"``).  Numeric ranges (``{1..3}``) and backslash escapes are not
        supported.

    Returns
    -------
    list of str
        The expansions, left to right in the order of the alternatives (duplicates kept).
    """
    instance_of("pattern", pattern, str)
    pos = pattern.find("{")
    while pos != -1:
        found = _matching_brace(pattern, pos)
        if found is not None and found[1]:
            end, commas = found
            cuts = [pos, *commas, end]
            alternatives = [pattern[a + 1 : b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
            head, tail = pattern[:pos], pattern[end + 1 :]
            out: list[str] = []
            for alt in alternatives:
                out.extend(expand_braces(head + alt + tail))
            return out
        pos = pattern.find("{", pos + 1)
    return [pattern]


def _is_map_file(path: Path) -> bool:
    return path.suffix.lower() in _MAP_SUFFIXES


def _walk_maps(folder: Path, unreadable: list[str] | None = None) -> list[Path]:
    """The map files below ``folder`` (hidden entries skipped); the folders that could not
    be listed are appended to ``unreadable`` (``os.walk`` would pass over them silently)."""
    found = []

    def failed(exc: OSError) -> None:
        if unreadable is not None:
            _note_unreadable(exc, unreadable)

    for root, dirs, files in os.walk(folder, onerror=failed):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for name in sorted(files):
            p = Path(root) / name
            if not name.startswith(".") and _is_map_file(p):
                found.append(p)
    return found


def _note_unreadable(exc: OSError, unreadable: list[str]) -> None:
    """Append the folder that ``exc`` could not list to ``unreadable``, with the reason;
    one that no longer exists, or never did (a pattern's fixed start), holds no map."""
    if not isinstance(exc, (FileNotFoundError, NotADirectoryError)):
        unreadable.append(f"{exc.filename} ({exc.strerror or type(exc).__name__})")


def _static_prefix(pattern: str) -> str:
    """The folder of a glob pattern before its first wildcard ("." if none)."""
    fixed = []
    for part in Path(pattern).parts:
        if _glob.has_magic(part):
            break
        fixed.append(part)
    return os.path.join(*fixed) if fixed else "."


def _each_map_once(found: list[Path]) -> list[Path]:
    """``found`` without repeats (the same file by any path) and without the images that
    a YAML among them references: each map once, through its YAML."""
    unique: list[Path] = []
    seen: set[str] = set()
    for p in found:
        key = os.path.realpath(p)
        if key not in seen:
            seen.add(key)
            unique.append(p)
    referenced = set()
    for p in unique:
        if p.suffix.lower() in YAML_SUFFIXES and p.is_file():
            img = yaml_image(p)
            if img is not None:
                referenced.add(os.path.realpath(img))
    return [
        p
        for p in unique
        if p.suffix.lower() in YAML_SUFFIXES or os.path.realpath(p) not in referenced
    ]


def expand_map_inputs(
    inputs: Iterable[str | os.PathLike[str]], *, exclude: str | os.PathLike[str] | None = None
) -> list[Path]:
    """Turn command-line inputs into a list of map files.

    Parameters
    ----------
    inputs : iterable of str or path
        Each is brace-expanded (:func:`expand_braces`), then

        * an existing folder is searched recursively (hidden entries skipped) for files
          with a map suffix (``.yaml``, ``.yml``, ``.pgm``, ``.png``, ``.jpg``, ``.jpeg``,
          ``.bmp``, ``.tif``, ``.tiff``);
        * a pattern with ``*``, ``?`` or ``[`` is globbed (``**`` matches any depth);
          matched map files are kept, matched folders searched as above;
        * a picture that a batch wrote (``NAME_graph.png``, ``NAME_route.png``,
          ``NAME_rooms.png``, listed by ``NAME.manifest.json`` beside it) is not a map to
          these searches;
        * anything else is taken as a file name as is (a missing or unsupported file
          then becomes an error row of the batch, not an exception here).

        A folder that a search could not list (no permission) and an input that gave no
        map file (an empty folder, a pattern that matched none) are named in a
        ``UserWarning``.
    exclude : str or path, optional
        A folder that searches of a folder (or pattern) strictly above it skip, e.g. the
        batch's output folder inside an input folder (its pictures are PNG files).  An
        input that is that folder, or lies inside it, is searched as usual.

    Returns
    -------
    list of Path
        In order of the inputs (sorted within each folder/pattern), without duplicates.
        An image referenced by a YAML that is also in the list is dropped: the map is
        processed once, through its YAML.

    Raises
    ------
    ValueError
        If an input is an empty string, or nothing at all was found.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    inputs = list(inputs)
    skip = None if exclude is None else os.path.join(os.path.realpath(exclude), "")

    def searched(root: str, files) -> list[Path]:
        # files found below ``root``, without those in ``exclude`` if it lies strictly
        # inside ``root`` (the batch's own outputs), nor pictures a batch manifest beside
        # them lists (an output folder that is the input folder)
        files = [f for f in files if not f.name.endswith(_IMAGES_OUT) or batch_input(f) is None]
        top = os.path.join(os.path.realpath(root), "")
        if skip is None or not (skip.startswith(top) and skip != top):
            return files
        return [f for f in files if not os.path.realpath(f).startswith(skip)]

    found: list[Path] = []
    unreadable: list[str] = []  # folders a search could not list
    fruitless: list[str] = []  # folders and patterns that gave no map file
    for raw in inputs:
        if not os.fspath(raw).strip():  # Path("") is ".": an unset $MAPS would batch it
            raise ValueError(
                "inputs: expected map files, folders or patterns, received an empty string "
                f"among {list(inputs)!r}"
            )
        before = len(found)
        for pattern in expand_braces(os.fspath(raw)):
            p = Path(pattern)
            if p.is_dir():
                found.extend(searched(pattern, _walk_maps(p, unreadable)))
            elif _glob.has_magic(pattern):
                matches = _pattern_maps(pattern, unreadable)
                found.extend(searched(_static_prefix(pattern), matches))
            else:
                found.append(p)
        if len(found) == before:
            fruitless.append(repr(os.fspath(raw)))
    result = _each_map_once(found)
    unreadable = list(dict.fromkeys(unreadable))
    denied = f"; could not search {', '.join(unreadable)}" if unreadable else ""
    if not result:
        shown = ", ".join(repr(os.fspath(x)) for x in inputs) if inputs else "(none)"
        raise ValueError(
            f"inputs: expected map files, folders or patterns; none found in {shown}{denied}"
        )
    if unreadable:  # os.walk and glob pass over such folders without a word
        warnings.warn(
            f"inputs: could not search {counted(len(unreadable), 'folder')}, so any maps in "
            f"{'it' if len(unreadable) == 1 else 'them'} are not in this batch: "
            f"{', '.join(unreadable)}",
            stacklevel=2,
        )
    if fruitless:
        warnings.warn(
            f"inputs: expected each input to give map files, received "
            f"{', '.join(fruitless)}, which gave none",
            stacklevel=2,
        )
    return result


def _pattern_maps(pattern: str, unreadable: list[str]) -> list[Path]:
    """The map files of the glob ``pattern`` (``**``: any depth), each folder listed once:
    the map files it matches and those below the folders it matches, as
    :func:`glob.glob` and :func:`_walk_maps` find them (in the order of the sorted
    matches, hidden entries skipped), the folders that could not be listed appended to
    ``unreadable``.  ``glob.glob`` listed every folder twice for ``**/NAME``, and the
    search for unreadable folders once more."""
    if ".." in Path(pattern).parts[1:]:  # resolved by glob; a folder listing has no ".."
        pattern = os.path.normpath(pattern)
    prefix = _static_prefix(pattern)
    parts = Path(pattern).parts[len(Path(prefix).parts) if prefix != "." else 0 :]
    groups: list[tuple[str, list[Path]]] = []  # each match, and its maps
    if prefix != "." and _parts_match((), parts):  # "x/**" matches x/ itself
        groups.append((os.path.join(prefix, ""), []))
    _scan(prefix, (), parts, groups[0][1] if groups else None, groups, unreadable, set())
    groups.sort(key=lambda group: group[0])
    return [path for _, paths in groups for path in paths]


def _scan(folder, names, parts, group, groups, unreadable, above) -> None:
    """List ``folder`` (``names`` below the pattern's fixed start) once: into ``group``
    (below a matched folder, as :func:`_walk_maps` lists them: symbolic links to folders
    not followed) its map files, into ``groups`` its matches (links followed, as
    :func:`glob.glob` follows them); then the folders below that hold either, but none
    of the folders ``above`` (the ids of those it lies in) again."""
    try:
        st = os.stat(folder)
        with os.scandir(folder) as listing:
            entries = sorted(listing, key=lambda entry: entry.name)
    except OSError as exc:
        _note_unreadable(exc, unreadable)
        return
    key = (st.st_dev, st.st_ino)
    if key in above:  # a link to a folder it lies in: glob would go round for ever
        return
    below = []
    for entry in entries:
        rel, is_dir = (*names, entry.name), _is_dir(entry)
        walked = group is not None and not entry.name.startswith(".")
        own = None
        if _could_match(names, parts) and _parts_match(rel, parts):
            groups.append((entry.path, own := []))
        if not is_dir:
            if (walked or own is not None) and _is_map_file(Path(entry.path)):
                (group if walked else own).append(Path(entry.path))
            continue
        into = group if walked and not entry.is_symlink() else own
        if into is not None or _could_match(rel, parts):
            below.append((entry.path, rel, into))
    for path, rel, into in below:
        _scan(path, rel, parts, into, groups, unreadable, above | {key})


def _is_dir(entry: os.DirEntry) -> bool:
    try:
        return entry.is_dir()
    except OSError:
        return False


def _name_matches(name: str, part: str) -> bool:
    """Whether the folder entry ``name`` matches the pattern part ``part`` as in
    :func:`glob.glob`: a wildcard matches a hidden name only where ``part`` starts
    with a dot."""
    if not _glob.has_magic(part):
        return name == part
    if name.startswith(".") and not part.startswith("."):
        return False
    return fnmatch.fnmatchcase(name, part)


def _parts_match(names: tuple[str, ...], parts: tuple[str, ...]) -> bool:
    """Whether the path ``names`` matches the pattern ``parts`` (``**``: any names)."""
    if not parts:
        return not names
    if parts[0] == "**":
        if _parts_match(names, parts[1:]):
            return True
        return bool(names) and not names[0].startswith(".") and _parts_match(names[1:], parts)
    return bool(names) and _name_matches(names[0], parts[0]) and _parts_match(names[1:], parts[1:])


def _could_match(names: tuple[str, ...], parts: tuple[str, ...]) -> bool:
    """Whether a path below the folder ``names`` may match the pattern ``parts``."""
    if not names:
        return True
    if not parts:
        return False
    if parts[0] == "**":
        if not names[0].startswith(".") and _could_match(names[1:], parts):
            return True
        return _could_match(names, parts[1:])
    return _name_matches(names[0], parts[0]) and _could_match(names[1:], parts[1:])


@dataclass
class _Item:
    index: int
    name: str
    path: Path | None
    occupancy: OccupancyMap | None

    @property
    def label(self) -> str | None:
        if self.path is not None:
            return os.fspath(self.path)
        return None if self.occupancy is None else self.occupancy.source

    @property
    def file(self) -> str | None:
        """The absolute path of the map's file: the path given, or the file that a map
        object's ``source`` names (None for a map that no file holds)."""
        if self.path is not None:
            return os.path.abspath(self.path)
        source = None if self.occupancy is None else self.occupancy.source
        if source and os.path.isfile(source):
            return os.path.abspath(source)
        return None


def _assign_names(sources: list[Path | None]) -> list[str]:
    """Unique output stems (rules: "Names" in docs/batch-internals.md)."""
    given = [p for p in sources if p is not None]
    root = None
    if given:
        root = os.path.commonpath([os.path.dirname(os.path.abspath(p)) for p in given])
    names = []
    for i, p in enumerate(sources):
        if p is None or root is None:
            names.append(f"map_{i:04d}")
            continue
        rel = Path(os.path.relpath(os.path.abspath(p), root))
        names.append(rel.with_suffix("").as_posix() if rel.suffix else rel.as_posix())
    counts = Counter(names)
    for i, p in enumerate(sources):
        if counts[names[i]] > 1 and p is not None and p.suffix:
            names[i] = f"{names[i]}_{p.suffix[1:].lower()}"
    used: set[str] = set()
    files: set[str] = set()  # every output file name of the names given so far
    for i, name in enumerate(names):
        if name.endswith(".manifest"):  # would collide with another map's manifest file
            name = name[: -len(".manifest")] + "_manifest"
        candidate, k = name, 2
        # A name is taken if any of its possible output files is another name's (``x_nav2``
        # would write ``x_nav2.geojson``, the Nav2 file of ``x``), whatever the formats, so
        # that names do not depend on them.
        while candidate in used or not files.isdisjoint(_output_files(candidate)):
            candidate, k = f"{name}_{k}", k + 1
        used.add(candidate)
        files.update(_output_files(candidate))
        names[i] = candidate
    return names


def _output_files(name: str) -> list[str]:
    """Every file name a map called ``name`` may write (any formats, picture, manifest)."""
    suffixes = [*_format_suffixes(_FORMAT_FILES), *_PICTURES, _MANIFEST_SUFFIX]
    return [name + suffix for suffix in suffixes]


def picture_suffixes(formats, plot: bool) -> list[str]:
    """The pictures ``plot`` adds for ``formats``: the graph's, and with a route format
    the route graph's."""
    if not plot:
        return []
    route = any(fmt in ("route", "route_nav2") for fmt in formats)
    return [_PICTURE_SUFFIX] + [_ROUTE_PICTURE_SUFFIX] * route


def check_formats(formats: Any) -> tuple[str, ...]:
    """The format names of ``formats`` (a sequence, or a comma-separated str), lower case,
    without leading dots and duplicates; ValueError naming ``formats`` for unknown ones."""
    if isinstance(formats, str):
        formats = [f for f in formats.split(",") if f.strip()]
    try:
        names = list(formats)
    except TypeError:
        raise TypeError(
            f"formats: expected a sequence of format names, received {type(formats).__name__}"
        ) from None
    for name in names:
        if not isinstance(name, str):
            raise TypeError(
                f"formats: expected format names (str), received {type(name).__name__} "
                f"{name!r} among {formats!r}"
            )
    items = [f.strip().lower().lstrip(".") for f in names]
    allowed = tuple(_FORMAT_FILES)
    bad = [f for f in items if f not in allowed]
    if bad:
        raise ValueError(f"formats: expected names from {allowed}, received {bad!r}")
    if not items:
        raise ValueError(f"formats: expected at least one of {allowed}, received none")
    return tuple(dict.fromkeys(items))


def planned_outputs(
    paths: Sequence[str | os.PathLike[str]], *, formats: Sequence[str] | str, plot: bool
) -> dict[str, Path]:
    """The files a batch of the map files ``paths`` writes for its maps.

    Parameters
    ----------
    paths : sequence of str or path
        The map files, in the order given to :func:`topojax.build_graphs`.
    formats, plot
        As for :func:`topojax.build_graphs`.

    Returns
    -------
    dict of str to Path
        Each output file, relative to ``out_dir`` (``/``-separated), and the map file it is
        made from; the summary table is not included.
    """
    fmts = check_formats(formats)
    sources = [Path(p) for p in paths]
    suffixes = _format_suffixes(fmts) + [_MANIFEST_SUFFIX]
    suffixes += picture_suffixes(fmts, plot)
    names = _assign_names(list(sources))
    return {
        name + suffix: source
        for name, source in zip(names, sources, strict=True)
        for suffix in suffixes
    }


def batch_input(target: str | os.PathLike[str], *, other_than: Path | None = None) -> str | None:
    """The input of the batch map that wrote the file ``target`` (its manifest's ``path``:
    the map file's absolute path, a map object's ``source``, ``""`` for one without), or
    None when no manifest beside ``target`` (other than the manifest ``other_than``) lists
    it."""
    target = Path(target)
    name = target.name
    for suffix in (*_format_suffixes(_FORMAT_FILES), *_PICTURES, _MANIFEST_SUFFIX):
        if not name.endswith(suffix):
            continue
        manifest = target.with_name(name[: -len(suffix)] + _MANIFEST_SUFFIX)
        if manifest == other_than:
            continue
        try:
            doc = json.loads(manifest.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        files = doc.get("files") if isinstance(doc, dict) else None
        if not isinstance(files, dict):
            continue
        if suffix == _MANIFEST_SUFFIX or any(Path(rel).name == name for rel in files):
            path = doc.get("path")
            return path if isinstance(path, str) else ""
    return None
