"""Output folders shared by several commands: no command silently replaces a file that a
different command, or the same command from a different input, wrote.

Every folder a command writes into gets a small record, ``.topojax-outputs.json``: for
each file written there, the command and the absolute path of the input it was made from
(and the options a map input was read with, and those that filtered a replay's graph).
Before any work a command checks its planned files: one that exists and is recorded as
written by another command or from another input is refused (``ValueError`` naming the
option, the file and who wrote it).  A file the record does not list (written by hand, or
by an older topojax) is replaced as before, and so is a file of the same command and
input: running a command again updates its own outputs, and the optional files of
its earlier run from that input that it does not write again are removed
(:func:`remove_earlier_outputs`).  A view page (``view.html``,
``STEM_view.html``) that ``topojax view`` wrote, or that it is asked to write over, is
replaced too: it is made from the folder's results and can be made again.  After the
work the files written are recorded (the record is replaced atomically).  ``topojax
batch`` writes no record: the manifest of each of its maps (``<name>.manifest.json``)
names the map file it was made from, read relative to the current folder when the batch
was given a relative path.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

__all__ = [
    "OUT_OPTION",
    "RECORD_NAME",
    "check_outputs",
    "output_stem",
    "planned",
    "record_outputs",
    "remove_earlier_outputs",
]

#: The record's file name, in each folder written into.
RECORD_NAME = ".topojax-outputs.json"
#: The option that chooses the output folder (or file), as errors name it.
OUT_OPTION = "-o/--out"
_VERSION = 1


def output_stem(map_path: str | os.PathLike[str]) -> str:
    """The STEM of the files made from the map ``map_path``: a file's name without its
    suffix (``office.yaml``: ``office``), a folder's (a tile folder, a Zarr array) whole
    (``floor.v2``: ``floor.v2``; ``.``: the current folder's name; a link's own name)."""
    path = Path(map_path)
    if path.is_dir():
        return Path(os.path.abspath(path)).name
    return path.stem


def planned(files: Iterable[str | os.PathLike[str]], source) -> dict[Path, str | None]:
    """``{file: source}`` for every file of ``files`` (one input for all of them)."""
    return {Path(f): source for f in files}


def _owner(command: str, source) -> dict[str, str | None]:
    return {
        "command": command,
        "input": None if source is None else os.path.realpath(os.fspath(source)),
    }


def read_record(folder: Path) -> dict[str, dict]:
    """The files recorded in ``folder``; empty when there is no (readable) record."""
    try:
        doc = json.loads((folder / RECORD_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    files = doc.get("files") if isinstance(doc, dict) else None
    return files if isinstance(files, dict) else {}


def _by_folder(claims: Mapping[Path, object]) -> dict[Path, dict[Path, object]]:
    folders: dict[Path, dict[Path, object]] = {}
    for target, source in claims.items():
        target = Path(target)
        folders.setdefault(target.parent, {})[target] = source
    return folders


def check_outputs(
    claims: Mapping[Path, str | os.PathLike[str] | None],
    *,
    command: str,
    option: str,
    names_file: bool = False,
) -> None:
    """Refuse files another command or input wrote (checked before any work).

    Parameters
    ----------
    claims : mapping of Path to (str, path or None)
        Each file the command is about to write and the input it is made from (None: the
        command's run as a whole, e.g. a batch's summary table).
    command : str
        The command's name, e.g. ``"graph"``.
    option : str
        The option that chose the folder, named in the error (e.g. ``"-o/--out"``).
    names_file : bool
        The option names the file itself (``route -o``, ``--mcap``): the error's example
        is then that file in another folder, not a folder.

    Raises
    ------
    ValueError
        If a file of ``claims`` exists and its folder's record names another command or
        another input.
    """
    for folder, files in _by_folder(claims).items():
        recorded = read_record(folder)
        for target, source in files.items():
            if not target.exists():
                continue
            before = _written_by(target, recorded)
            owner = _owner(command, source)
            if before is None or all(before.get(k) == v for k, v in owner.items()):
                continue
            page = target.name == "view.html" or target.name.endswith("_view.html")
            if page and "view" in (command, before.get("command")):
                continue  # a view page: made again from the folder's results at any time
            raise ValueError(_conflict(option, target, before, command, source, names_file))


def _written_by(target: Path, recorded: dict[str, dict]) -> dict | None:
    """Who wrote ``target``: its entry in the folder's record, else the batch map whose
    manifest lists it (``topojax batch`` keeps no record: its manifests are one)."""
    before = recorded.get(target.name)
    if isinstance(before, dict):
        return before
    from ..batch.manifest import batch_input

    label = batch_input(target)
    if label is None:
        return None
    return _owner("batch", label or None)


def _conflict(
    option: str, target: Path, before: dict, command: str, source, names_file: bool
) -> str:
    was = f"'topojax {before.get('command')}'"
    if before.get("input") is not None:
        was += f" from {before['input']}"
    now, hint = f"'topojax {command}'", command
    if source is not None:
        path = Path(os.path.realpath(os.fspath(source)))
        now += f" from {path}"
        hint = path.parent.name or path.stem
    example = target.parent / hint / target.name if names_file else target.parent / hint
    return (
        f"{option}: {target} was written by {was}; {now} would overwrite it. Write into "
        f"another folder (e.g. {option.split('/')[0]} {example}) or remove the file first"
    )


def remove_earlier_outputs(
    possible: Iterable[Path], written: Iterable[Path], source, *, command: str
) -> list[str]:
    """Remove the files of ``possible`` (the optional outputs a command may write for one
    input) that this run did not write (``written``) and the folder's record names as
    written by ``command`` from ``source``: an earlier run's, which no longer match the
    files written beside them (``topojax view`` would show them together).  A file the
    record does not name as this command's from this input stays; :func:`record_outputs`
    then drops the removed ones from the record.  Returns a line per file removed."""
    now = {Path(p).resolve() for p in written}
    owner = _owner(command, source)
    lines = []
    for folder, files in _by_folder(planned(possible, source)).items():
        recorded = read_record(folder)
        for target in files:
            before = recorded.get(target.name)
            if not isinstance(before, dict) or target.resolve() in now:
                continue
            if all(before.get(k) == v for k, v in owner.items()) and target.is_file():
                target.unlink()
                lines.append(f"removed    {target}, written by an earlier run from this map")
    return lines


def record_outputs(
    claims: Mapping[Path, str | os.PathLike[str] | None],
    *,
    command: str,
    map_options: Mapping[str, object] | None = None,
    graph_options: Mapping[str, object] | None = None,
) -> None:
    """Record the files of ``claims`` that exist as written by ``command`` from their
    input (in the record of each file's folder), with the ``load_map`` options the input
    was read with (``map_options``, JSON values), so that ``topojax view`` reads it the
    same way, and the ``GraphConfig`` options that filtered the graph written
    (``graph_options``: a replay's graph is then not its timeline's last).  Entries of
    files no longer in the folder are dropped."""
    from .._fs import atomic_write_bytes

    for folder, files in _by_folder(claims).items():
        written = {t: s for t, s in files.items() if t.is_file()}
        if not written:
            continue
        # the record lists files that are there: one removed since is dropped
        recorded = {n: e for n, e in read_record(folder).items() if (folder / n).is_file()}
        for target, source in written.items():
            recorded[target.name] = _owner(command, source)
            if map_options:
                recorded[target.name]["map_options"] = dict(map_options)
            if graph_options:
                recorded[target.name]["graph_options"] = dict(graph_options)
        doc = {"version": _VERSION, "files": dict(sorted(recorded.items()))}
        atomic_write_bytes(folder / RECORD_NAME, json.dumps(doc, indent=1).encode("utf-8"))
