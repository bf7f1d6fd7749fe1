"""Map files: ROS ``map_server`` YAML descriptions and plain images in, YAML + PGM out."""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .._cpus import check_fits_memory
from .._filekind import dangling, looped, non_file_kind, the_non_file
from .._fs import refuse_suffix_only
from .._validate import (
    MAX_RESOLUTION_M,
    MIN_RESOLUTION_M,
    binary_flag,
    is_real_number,
    metres_per_pixel,
    occupancy_thresholds,
    one_of,
    path_like,
    pose,
    threshold,
)
from .classify import (
    DEFAULT_FREE_THRESH,
    DEFAULT_OCCUPIED_THRESH,
    MODES,
    _grid_values,
    classify_image,
)
from .occupancy import DEFAULT_RESOLUTION_M, OccupancyMap
from .pnm import (
    _parse_pnm_header,
    pnm_header_tokens,
    read_image,
    resolution_from_pgm_comments,
)
from .yaml_keys import DuplicateKeyError, safe_load_unique

__all__ = ["IMAGE_SUFFIXES", "YAML_SUFFIXES", "load_map", "save_map"]

#: File suffixes read as plain images by :func:`load_map`.
IMAGE_SUFFIXES = (".pgm", ".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: File suffixes read as ``map_server`` YAML by :func:`load_map`.
YAML_SUFFIXES = (".yaml", ".yml")


def _yaml_error(path: Path, field: str, expected: str, value: Any) -> ValueError:
    return ValueError(f"map YAML {path}: field {field!r}: expected {expected}, received {value!r}")


def _load_yaml(path: Path) -> dict[str, Any]:
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"map YAML {path} is not valid UTF-8 text: {exc}") from None
    try:
        doc = safe_load_unique(text)
    except DuplicateKeyError as exc:
        raise ValueError(f"map YAML {path}: {exc}; expected each key once") from None
    except yaml.YAMLError as exc:
        raise ValueError(
            f"map YAML {path} could not be parsed: {_yaml_problem(exc, text)}"
        ) from None
    if not isinstance(doc, dict):
        if doc is None:
            received = "an empty document"
        elif isinstance(doc, list):
            received = "a list"
        else:
            received = f"the text {str(doc)!r:.80}"
        raise ValueError(
            f"map YAML {path}: expected a mapping of keys to values (image: ..., resolution: "
            f"...), received {received}"
        )
    # map_server reads these with yaml-cpp, which converts 5e-2 and quoted numbers too;
    # PyYAML (YAML 1.1) leaves them strings
    for key in ("resolution", "occupied_thresh", "free_thresh"):
        if key in doc:
            doc[key] = _number_text(doc[key])
    if isinstance(doc.get("origin"), list):
        doc["origin"] = [_number_text(v) for v in doc["origin"]]
    negate = doc.get("negate")
    if isinstance(negate, str) and _INTEGER_RE.fullmatch(negate.strip()):
        doc["negate"] = int(negate)  # an int to map_server too (then checked: 0 or 1)
    return doc


def _yaml_problem(exc: Exception, text: str) -> str:
    """Where in the file and what PyYAML found wrong (``line 3, column 5: mapping values
    are not allowed here``), without its ``in "<unicode string>"`` and the quoted text."""
    import yaml

    if isinstance(exc, yaml.MarkedYAMLError):
        for mark, problem in ((exc.problem_mark, exc.problem), (exc.context_mark, exc.context)):
            if mark is not None and problem:
                return f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
    if isinstance(exc, yaml.reader.ReaderError):  # a character PyYAML does not read
        line = text.count("\n", 0, exc.position) + 1
        column = exc.position - text.rfind("\n", 0, exc.position)
        return f"line {line}, column {column}: character #x{exc.character:04x}: {exc.reason}"
    return str(exc)


_INTEGER_RE = re.compile(r"[-+]?[0-9]+")
_NUMBER_RE = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")


def _number_text(value: Any) -> Any:
    """A string that spells a decimal number as that float; anything else unchanged."""
    if isinstance(value, str) and _NUMBER_RE.fullmatch(value.strip()):
        return float(value)
    return value


def _resolve_image_path(yaml_path: Path, image: Any) -> Path:
    if not isinstance(image, str) or not image.strip():
        raise _yaml_error(yaml_path, "image", "a non-empty file name", image)
    if "\0" in image:  # os would say "embedded null byte", naming no file
        raise _yaml_error(yaml_path, "image", "a file name without a NUL character", image)
    img = Path(image.strip())
    folder = yaml_path.parent
    if img.is_absolute():
        _refuse_non_file(yaml_path, img)
        if img.is_file():
            return img
        fallback = folder / img.name
        _refuse_non_file(yaml_path, fallback)
        if fallback.is_file():
            return fallback
        raise FileNotFoundError(
            f"map YAML {yaml_path}: image {str(img)!r} not found, nor {str(fallback)!r} "
            "next to the YAML"
        )
    resolved = folder / img
    _refuse_non_file(yaml_path, resolved)
    if not resolved.is_file():
        raise FileNotFoundError(
            f"map YAML {yaml_path}: image {image!r} not found (looked for {resolved})"
        )
    return resolved


def _refuse_non_file(yaml_path: Path, image: Path) -> None:
    """A ValueError if ``image`` exists but is no regular file (reading a FIFO would wait
    for a writer for ever; "not found" would be untrue), or a loop of symbolic links."""
    if (loop := looped(image)) is not None:
        raise ValueError(
            f"map YAML {yaml_path}: field 'image': expected an image file, received {image}{loop}"
        )
    if non_file_kind(image) is not None:
        raise ValueError(
            f"map YAML {yaml_path}: field 'image': expected an image file, received "
            f"{the_non_file(image)} {image}"
        )


def load_map(
    path: str | Path,
    *,
    resolution_m: float | None = None,
    origin: Iterable[float] | None = None,
    occupied_thresh: float | None = None,
    free_thresh: float | None = None,
    negate: bool | None = None,
    mode: str | None = None,
) -> OccupancyMap:
    """Load an occupancy map from a ``map_server`` YAML file or a plain image.

    Parameters
    ----------
    path : str or Path
        ``.yaml`` / ``.yml``: ROS ``map_server`` map description with the keys ``image``
        (required; relative to the YAML's folder; an absolute path that does not exist
        falls back to the file of the same name next to the YAML), ``resolution``
        (required, m/px, unless given here), ``origin`` ``[x, y, yaw]`` (required, as in
        ``map_server``, unless given here), ``negate`` (default 0), ``occupied_thresh``
        (default 0.65), ``free_thresh`` (default 0.196) and ``mode`` (default
        ``trinary``).
        ``.pgm``, ``.png``, ``.jpg``, ``.jpeg``, ``.bmp``, ``.tif``, ``.tiff``: a plain
        image (1- to 16-bit; grey, grey + alpha, RGB, RGBA, CMYK or palette). Defaults:
        resolution from a PGM ``# CREATOR: map_saver.cpp 0.050 m/pix`` style comment if
        present, else 0.05 m/px (the IPA benchmark / paper value, with a
        ``UserWarning`` naming ``resolution_m``); origin (0, 0, 0); thresholds
        0.65 / 0.196; trinary mode.
    resolution_m, origin, occupied_thresh, free_thresh, negate, mode
        Override the values from the YAML file or the defaults (see
        :meth:`OccupancyMap.from_array` for their meaning).

    Returns
    -------
    OccupancyMap
        With ``source`` set to ``str(path)``.

    Raises
    ------
    FileNotFoundError
        If the file (or the YAML's image) does not exist.
    ValueError
        For undecodable images, images whose data the decoder reports damaged (a PNG
        checksum, corrupt JPEG data), files of several images (the pages of a TIFF, less
        reduced-resolution copies; the frames of an animation), malformed YAML (a key given
        twice included), missing or invalid fields, or invalid parameters; the message
        names the file and the field.
    MemoryError
        For an image decoded into memory (any but a binary 8-bit PGM, which is
        memory-mapped) whose header gives more pixels than the memory available can
        decode and classify (5 bytes a pixel at least): refused before it is decoded;
        for a binary 8-bit PGM, one whose classes (4 bytes a pixel while classified) do
        not fit: refused before it is classified.
        The header is read here for PNG, JPEG, BMP, TIFF, PGM/PPM, GIF, WebP and JPEG
        2000, and by PIL for the other formats it reads; an image PIL refuses to open as
        larger than twice its ``MAX_IMAGE_PIXELS`` goes unchecked.

    Notes
    -----
    16-bit images are classified at full precision, ``p = (65535 - v) / 65535``. PGM files
    with a maxval other than 255 / 65535 use ``v / maxval``.  An image with an alpha
    channel behind a YAML in trinary mode is read as ``map_server`` reads it, with alpha
    averaged in with the colour channels (so an opaque RGBA grey of 205 is free there, p =
    0.147); plain images ignore alpha, as the IPA maps' own tools do.
    """
    p = path_like("path", path)
    suffix = p.suffix.lower()
    _check_map_path(p, suffix)
    resolution_m, origin, negate, mode = _given_settings(resolution_m, origin, negate, mode)
    if suffix in YAML_SUFFIXES:
        image_path, settings = _yaml_settings(
            p,
            resolution_m=resolution_m,
            origin=origin,
            occupied_thresh=occupied_thresh,
            free_thresh=free_thresh,
            negate=negate,
            mode=mode,
        )
        where = f"map YAML {p}"
        occupancy_thresholds(settings["occupied_thresh"], settings["free_thresh"], where=where)
        pixels, full, _ = _read_pixels(image_path)
    else:
        pixels, full, comments = _read_pixels(p)
        if resolution_m is None:
            resolution_m = resolution_from_pgm_comments(comments, p)
        if resolution_m is None:
            resolution_m = DEFAULT_RESOLUTION_M
            warnings.warn(
                f"map {p} states no resolution: assumed {resolution_m:g} m/px, on which every "
                "length and world point rests; give the map's own with load_map(..., "
                "resolution_m=...)",
                UserWarning,
                stacklevel=2,
            )
        settings = {
            "resolution_m": resolution_m,
            "origin": (0.0, 0.0, 0.0) if origin is None else origin,
            **thresholds_without_yaml(p, occupied_thresh, free_thresh),
            "negate": False if negate is None else negate,
            "mode": "trinary" if mode is None else mode,
        }
        where = f"map {p}"

    # map_server averages an alpha channel in with the colour in trinary mode; a YAML map
    # is read as map_server reads it (plain images and arrays ignore alpha)
    average_alpha = (
        suffix in YAML_SUFFIXES
        and settings["mode"] == "trinary"
        and pixels.ndim == 3
        and pixels.shape[2] in (2, 4)
    )
    return _classify_pixels(
        pixels, full, settings, average_alpha=average_alpha, path=p, where=where
    )


def default_resolution_used(path: str | Path) -> bool:
    """Whether :func:`load_map` of ``path`` without ``resolution_m`` falls back to
    ``DEFAULT_RESOLUTION_M`` (:func:`unstated_resolution`)."""
    return unstated_resolution(path) is not None


def said_resolution(path: str | Path, options: dict[str, Any]) -> dict[str, Any]:
    """``options`` (:func:`load_map`'s keyword arguments for ``path``) with the
    resolution ``load_map`` would assume given (:func:`unstated_resolution`), so that it
    does not warn of it: for a caller that says so itself (a command's map line, a
    batch's record).  Without a filter of warnings, which are process-wide."""
    if options.get("resolution_m") is not None:
        return options
    assumed = unstated_resolution(path)
    return options if assumed is None else {**options, "resolution_m": assumed}


def unstated_resolution(path: str | Path) -> float | None:
    """``DEFAULT_RESOLUTION_M`` where :func:`load_map` of ``path`` without
    ``resolution_m`` would assume it (warning that it does); None for a YAML, a PGM whose
    comment states a resolution, and a PGM whose header cannot be read or whose comment
    is refused, and a path that is there but not a file (a named pipe, which opening
    would wait on; ``load_map`` names each fault)."""
    p = Path(path)
    if p.suffix.lower() in YAML_SUFFIXES or (p.exists() and not p.is_file()):  # a pipe
        return None
    if p.suffix.lower() == ".pgm":
        try:
            with open(p, "rb") as f:
                comments = _parse_pnm_header(f.read(_HEADER_BYTES))[1]
            if resolution_from_pgm_comments(comments, p) is not None:
                return None
        except (OSError, ValueError):
            return None
    return DEFAULT_RESOLUTION_M


def replaced_resolution(path: str | Path, resolution_m: float | None) -> float | None:
    """The resolution (m/px) the map file ``path`` states where ``resolution_m``, given to
    :func:`load_map`, replaces another (every length and area then scales); None where
    none is given, the file states none, or it states the same."""
    if resolution_m is None:
        return None
    own = stated_resolution(path)
    return own if own is not None and own != resolution_m else None


def stated_resolution(path: str | Path) -> float | None:
    """The resolution (m/px) the map file ``path`` states itself: a YAML's ``resolution``
    or a PGM's comment; None where it states none or cannot be read (:func:`load_map`
    names each fault)."""
    p = Path(path)
    try:
        if p.suffix.lower() in YAML_SUFFIXES and p.is_file():
            doc = _load_yaml(p)
            value = doc.get("resolution") if isinstance(doc, dict) else None
            return metres_per_pixel("resolution", value) if value is not None else None
        if p.suffix.lower() == ".pgm" and p.is_file():
            with open(p, "rb") as f:
                comments = _parse_pnm_header(f.read(_HEADER_BYTES))[1]
            return resolution_from_pgm_comments(comments, p)
    except (OSError, TypeError, ValueError):
        return None
    return None


#: Bytes a pixel of a memory-mapped PGM takes while :func:`load_map` classifies it: 1 for
#: the class codes and 3 for the map's classes (the pixels stay in the file).
_CLASSIFY_BYTES_PER_PIXEL = 4

#: How much of a PGM :func:`_pgm_header` reads for its header.
_HEADER_BYTES = 1 << 16


class _NotMappable(ValueError):
    """A file that is not a binary PGM, or whose header (comments) runs past
    ``_HEADER_BYTES``: :func:`load_map` decodes it whole instead."""


def _pgm_header(path: Path) -> tuple[int, int, int, int, list[str]]:
    """``(width, height, maxval, data offset, comments)`` of a binary PGM; a ValueError
    naming the file and what its header holds where that is not a valid P5 header."""
    with open(path, "rb") as f:
        head = f.read(_HEADER_BYTES)
    if not head:  # nothing at all, not an image of another kind
        raise _NotMappable(f"path: {path} is empty (0 bytes)")
    if head[:2] != b"P5":
        raise _NotMappable(
            f"path: {path} is not a binary PGM (P5); read other images with load_map"
        )
    tokens, comments, end = pnm_header_tokens(head)
    words = " ".join(t.decode("latin-1") for t in tokens)
    if len(tokens) < 3:
        # a header longer than we read may still be whole: decode the file instead
        error = _NotMappable if len(head) == _HEADER_BYTES else ValueError
        raise error(
            f"map image {path}: incomplete PGM header: expected width, height and maxval, "
            f"received {words!r} in its first {len(head)} bytes"
        )
    if not all(t.isdigit() for t in tokens):
        raise ValueError(
            f"map image {path}: PGM header: expected width, height and maxval as decimal "
            f"integers, received {words!r}"
        )
    width, height, maxval = (int(t) for t in tokens)
    if width < 1 or height < 1 or not 0 < maxval < 65536:
        raise ValueError(
            f"map image {path}: PGM header: expected width and height >= 1 and maxval "
            f"1..65535, received {width} x {height}, maxval {maxval}"
        )
    return width, height, maxval, end + 1, comments  # one whitespace byte after maxval


def _check_pgm_size(path: Path, width: int, height: int, maxval: int, offset: int) -> None:
    """A ValueError unless the binary PGM at ``path`` holds the pixels its header gives
    (no decoder reads a shorter one; said without allocating them)."""
    need = width * height * (1 if maxval < 256 else 2)
    size = path.stat().st_size
    if size < offset + need:
        raise ValueError(
            f"map image {path}: its PGM header gives {width} x {height} pixels, "
            f"expected {need} bytes of pixels after the {offset}-byte header, "
            f"received a file of {size} bytes"
        )


def _read_pixels(path: Path) -> tuple[np.ndarray, int, list[str]]:
    """:func:`read_image`, except that a binary 8-bit PGM (``P5``, maxval 255) is
    memory-mapped at its data offset instead of read whole and decoded: a map is then
    classified straight from the file (the same pixels), where its classes fit the memory
    available."""
    if path.suffix.lower() == ".pgm" and path.is_file():
        try:
            width, height, maxval, offset, comments = _pgm_header(path)
        except _NotMappable:
            return read_image(path)
        _check_pgm_size(path, width, height, maxval, offset)
        if maxval == 255:
            check_fits_memory(
                width * height * _CLASSIFY_BYTES_PER_PIXEL,
                f"map image {path}: its header gives {width} x {height} pixels, and "
                f"classifying them ({_CLASSIFY_BYTES_PER_PIXEL} bytes a pixel) takes at least",
                "; crop or coarsen the map, or build its topology graph with "
                "build_graph_tiled (topojax graph --tiled), which reads a binary PGM a "
                "window at a time (docs/large-maps.md)",
            )
            pixels = np.memmap(path, np.uint8, mode="r", offset=offset, shape=(height, width))
            return pixels, 255, comments
    return read_image(path)


def _pattern_hint(p: Path) -> str:
    """For a missing map path that looks like a glob pattern (below the folders there),
    what expands it; else ""."""
    there = next((a for a in p.parents if a.exists()), None)
    missing = str(p if there is None else p.relative_to(there))
    if not any(c in missing for c in "*?[{"):
        return ""
    return (
        "; a pattern? expand it first (topojax batch, and topojax.batch.expand_map_inputs, "
        "expand patterns)"
    )


def _refuse_missing(p: Path) -> None:
    """The error for a map path that reaches no file: a loop of symbolic links is said to
    be one, a dangling link names where it leads."""
    if (loop := looped(p)) is not None:
        raise ValueError(f"map path is not a file: {p}{loop}")
    raise FileNotFoundError(f"map file not found: {p}{dangling(p) or _pattern_hint(p)}")


def _check_map_path(p: Path, suffix: str) -> None:
    """Refuse a folder, an unsupported suffix, a missing file or one that is not a regular
    file (in that order)."""
    if p.is_dir():
        # the marker files of a stored tiled map (maps.tiled imports this module)
        kind = {"tiles.json": "tile folder", "zarr.json": "Zarr array"}
        stored = [what for marker, what in kind.items() if (p / marker).is_file()]
        if stored:
            raise ValueError(
                f"map path is not a file: {p} is a {stored[0]}, a map read a window at a "
                "time; open it with topojax.open_tiled_map (its .occupancy() is the whole "
                "map, where it fits), or build its graph with build_graph_tiled (topojax "
                "graph --tiled)"
            )
        raise ValueError(
            f"map path is not a file: {p} is a folder; give a map file (topojax batch, "
            "and topojax.batch.expand_map_inputs, search folders for maps)"
        )
    if suffix not in YAML_SUFFIXES + IMAGE_SUFFIXES:
        if not p.exists():
            _refuse_missing(p)
        refuse_suffix_only("path", p, YAML_SUFFIXES + IMAGE_SUFFIXES)
        raise ValueError(
            f"map file {p} has unsupported suffix {p.suffix!r}; expected one of "
            f"{YAML_SUFFIXES + IMAGE_SUFFIXES}"
        )
    if not p.exists():
        _refuse_missing(p)
    if not p.is_file():  # opening a FIFO would wait for a writer forever
        raise ValueError(
            f"map path is not a regular file: {p} is {non_file_kind(p) or 'no file'}; give a "
            "map file"
        )


def _given_settings(resolution_m, origin, negate, mode) -> tuple:
    """:func:`load_map`'s own ``resolution_m``, ``origin``, ``negate`` and ``mode``,
    checked (None where not given): a bad one is the caller's, named alone, not as a
    field of the map file."""
    return (
        None if resolution_m is None else metres_per_pixel("resolution_m", resolution_m),
        None if origin is None else pose("origin", origin),
        None if negate is None else binary_flag("negate", negate),
        None if mode is None else one_of("mode", mode, MODES),
    )


def _yaml_settings(
    p: Path,
    *,
    resolution_m: float | None,
    origin: Iterable[float] | None,
    occupied_thresh: float | None,
    free_thresh: float | None,
    negate: bool | None,
    mode: str | None,
) -> tuple[Path, dict[str, Any]]:
    """The image path of a map YAML and the settings for :meth:`OccupancyMap.from_array`:
    each given argument, else the YAML's field (checked, the error naming the file and
    the field), else ``map_server``'s default."""
    doc = _load_yaml(p)
    if "image" not in doc:
        raise ValueError(f"map YAML {p} is missing the required key 'image'")
    if resolution_m is None and "resolution" not in doc:
        raise ValueError(
            f"map YAML {p} is missing the required key 'resolution', as map_server requires "
            "it: add 'resolution: M' (metres per pixel) to the file, or give it with "
            "load_map's resolution_m="
        )
    if origin is None and "origin" not in doc:
        raise ValueError(
            f"map YAML {p} is missing the required key 'origin', as map_server requires "
            "it: add 'origin: [x, y, yaw]' (m, m, rad: the world pose of the lower-left "
            "corner of the image) to the file, or in Python give it with load_map's origin="
        )
    image_path = _resolve_image_path(p, doc["image"])
    if resolution_m is None:
        res = doc["resolution"]
        try:
            resolution_m = metres_per_pixel("resolution", res)
        except (TypeError, ValueError):  # a bad field is a bad file: ValueError
            expected = f"a number from {MIN_RESOLUTION_M:g} to {MAX_RESOLUTION_M:g}"
            raise _yaml_error(p, "resolution", expected, res) from None
    if origin is None:
        raw_origin = doc["origin"]
        try:
            origin = pose("origin", raw_origin)
        except (TypeError, ValueError):  # a bad field is a bad file: ValueError
            raise _yaml_error(
                p, "origin", "a list of 3 finite numbers [x, y, yaw]", raw_origin
            ) from None
    if negate is None:
        raw_neg = doc.get("negate", 0)
        try:
            negate = binary_flag("negate", raw_neg)
        except (TypeError, ValueError):
            raise _yaml_error(p, "negate", "0, 1, true or false", raw_neg) from None
    thresholds = {}
    for key, given, default in (
        ("occupied_thresh", occupied_thresh, DEFAULT_OCCUPIED_THRESH),
        ("free_thresh", free_thresh, DEFAULT_FREE_THRESH),
    ):
        if given is not None:
            thresholds[key] = given
            continue
        val = doc.get(key, default)
        if not is_real_number(val) or not 0.0 <= float(val) <= 1.0:
            raise _yaml_error(p, key, "a number in [0, 1]", val)
        thresholds[key] = float(val)
    other = "occupied_thresh" if occupied_thresh is None else "free_thresh"
    source = (
        f"from map YAML {p}" if other in doc else f"map_server's default: map YAML {p} sets none"
    )
    _check_caller_thresholds(occupied_thresh, free_thresh, thresholds, source)
    if mode is None:
        raw_mode = doc.get("mode", "trinary")
        if not isinstance(raw_mode, str) or raw_mode not in ("trinary", "scale", "raw"):
            raise _yaml_error(p, "mode", "'trinary', 'scale' or 'raw'", raw_mode)
        mode = raw_mode
    settings = {
        "resolution_m": resolution_m,
        "origin": origin,
        "occupied_thresh": thresholds["occupied_thresh"],
        "free_thresh": thresholds["free_thresh"],
        "negate": negate,
        "mode": mode,
    }
    return image_path, settings


def thresholds_without_yaml(p: Path, occupied_thresh, free_thresh) -> dict[str, float]:
    """The thresholds of a map image ``p`` read without a YAML: each one given (None:
    not given), else map_server's default, the caller's checked against the other."""
    thresholds = {
        "occupied_thresh": DEFAULT_OCCUPIED_THRESH if occupied_thresh is None else occupied_thresh,
        "free_thresh": DEFAULT_FREE_THRESH if free_thresh is None else free_thresh,
    }
    source = f"map_server's default: map {p} has no YAML"
    _check_caller_thresholds(occupied_thresh, free_thresh, thresholds, source)
    return thresholds


def _check_caller_thresholds(occupied_thresh, free_thresh, thresholds: dict, source: str):
    """Check the thresholds the caller gave (None: not given): a pair against each other,
    one against the other of ``thresholds`` (the file's or map_server's default, which
    ``source`` names); the error names the one given and says where the other came
    from."""
    if occupied_thresh is not None and free_thresh is not None:  # the caller's pair
        occupancy_thresholds(occupied_thresh, free_thresh)
        return
    if occupied_thresh is None and free_thresh is None:
        return
    given = occupied_thresh is None  # free_thresh given
    occ, free = thresholds["occupied_thresh"], thresholds["free_thresh"]
    name, value = ("free_thresh", free) if given else ("occupied_thresh", occ)
    number = threshold(name, value)
    other, other_value = ("occupied_thresh", occ) if given else ("free_thresh", free)
    if (number < occ) if given else (number > free):
        return
    relation = "less" if given else "more"
    raise ValueError(
        f"{name}: expected {relation} than {other} ({other_value!r}, {source}), received {value!r}"
    )


def _classify_pixels(
    pixels: np.ndarray,
    full: int,
    settings: dict[str, Any],
    *,
    average_alpha: bool,
    path: Path,
    where: str,
) -> OccupancyMap:
    """The map of decoded image pixels whose white is ``full``: 8-bit images through
    :meth:`OccupancyMap.from_array` (errors prefixed with ``where`` unless they name the
    file), 16-bit, other maxvals and ``map_server``'s alpha rule classified here, as are
    8-bit images of 0, 100 and 255: an array of them may be OccupancyGrid cells, which
    ``from_array`` refuses, but a file is an image, read as map_server reads it."""
    grid_like = pixels.ndim == 2 and pixels.dtype == np.uint8 and _grid_values(pixels)
    if full == 255 and pixels.dtype == np.uint8 and not average_alpha and not grid_like:
        try:
            return OccupancyMap.from_array(pixels, **settings, source=str(path))
        except ValueError as exc:  # name the file (e.g. a 0/1 mask saved as an image)
            if str(path) in str(exc):
                raise
            # the decoded pixels are the file's: a refusal of the array is the file's
            raise ValueError(f"{where}: {str(exc).removeprefix('array: ')}") from None
    # 16-bit, non-standard maxval or map_server's alpha rule: classify directly.
    resolution_m = metres_per_pixel("resolution_m", settings["resolution_m"])
    origin_t = pose("origin", settings["origin"])
    occ_t, free_t = occupancy_thresholds(
        settings["occupied_thresh"], settings["free_thresh"], where=where
    )
    try:
        codes = classify_image(
            pixels,
            full_scale=full,
            occupied_thresh=occ_t,
            free_thresh=free_t,
            negate=binary_flag("negate", settings["negate"]),
            mode=one_of("mode", settings["mode"], MODES),
            unknown_values=None,
            average_alpha=average_alpha,
        )
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    return OccupancyMap._from_codes(codes, resolution_m, origin_t, str(path), where=where)


def map_argument(name: str, value: Any, *, files: bool = False) -> OccupancyMap:
    """``value`` as an :class:`OccupancyMap`: itself, or (``files``) the map
    :func:`load_map` reads from a path; a TypeError naming ``name`` for anything else."""
    if isinstance(value, OccupancyMap):
        return value
    if files and isinstance(value, (str, os.PathLike)):
        return load_map(value)
    what = "an OccupancyMap or a map file path (str or Path)" if files else "an OccupancyMap"
    if isinstance(value, np.ndarray):
        hint = " (an array has no resolution: see OccupancyMap.from_array)"
    elif type(value).__module__ == "topojax.maps.tiled":  # a TiledMap (tiled imports this
        # module): loaded already, so load_map is no help
        hint = " (its .occupancy() is the OccupancyMap of the whole map, for maps that fit)"
    else:
        hint = " (see load_map)"
    raise TypeError(f"{name}: expected {what}, received {type(value).__name__}{hint}")


def save_map(
    occupancy_map: OccupancyMap, yaml_path: str | Path, *, image_name: str | None = None
) -> Path:
    """Write a ``map_server`` YAML + PGM pair.

    The PGM (binary P5, maxval 255) holds 0 = occupied, 205 = unknown, 254 = free; the
    YAML stores the resolution, origin, ``negate: 0``, thresholds 0.65 / 0.196 and
    ``mode: trinary``, so :func:`load_map` restores the same masks. Both files are written
    atomically (temporary file in the same folder, then ``os.replace``); the image first.

    Parameters
    ----------
    occupancy_map : OccupancyMap
        Map to save.
    yaml_path : str or Path
        Output ``.yaml`` / ``.yml`` path.
    image_name : str, optional
        File name of the PGM, written next to the YAML; default ``<yaml stem>.pgm``.

    Returns
    -------
    Path
        The path of the written PGM.
    """
    import yaml

    from .._fs import atomic_write_bytes, output_file_in_folder, refuse_suffix_only

    occupancy_map = map_argument("occupancy_map", occupancy_map)
    yp = path_like("yaml_path", yaml_path)
    refuse_suffix_only("yaml_path", yp, YAML_SUFFIXES)
    if yp.suffix.lower() not in YAML_SUFFIXES:
        raise ValueError(
            f"yaml_path: expected a name ending in .yaml or .yml, received {str(yp)!r}"
        )
    if image_name is None:
        image_name = yp.stem + ".pgm"
    if not isinstance(image_name, str):
        raise TypeError(
            "image_name: expected a bare file name ending in .pgm (a str), received "
            f"{type(image_name).__name__} {image_name!r}"
        )
    if Path(image_name).name != image_name or not image_name.lower().endswith(".pgm"):
        raise ValueError(
            f"image_name: expected a bare file name ending in .pgm, received {image_name!r}"
        )
    for name, target in (("yaml_path", yp), ("image_name", yp.with_name(image_name))):
        if target.is_dir():  # before writing either file
            raise IsADirectoryError(
                f"{name}: {target} is a folder; expected a file name to write there"
            )
        output_file_in_folder(target, name=name)
    img = occupancy_map.to_image()
    h, w = img.shape
    header = (
        f"P5\n# CREATOR: topojax save_map {occupancy_map.resolution_m!r} m/pix\n{w} {h}\n255\n"
    ).encode("ascii")
    image_path = yp.parent / image_name
    atomic_write_bytes(image_path, header + img.tobytes())
    doc = {
        "image": image_name,
        "mode": "trinary",
        "resolution": occupancy_map.resolution_m,
        "origin": list(occupancy_map.origin),
        "negate": 0,
        "occupied_thresh": DEFAULT_OCCUPIED_THRESH,
        "free_thresh": DEFAULT_FREE_THRESH,
    }
    text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)
    atomic_write_bytes(yp, text.encode("utf-8"))
    return image_path
