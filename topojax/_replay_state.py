"""The state a replay that stops part way leaves in its output folder, and resuming from
it (``topojax replay --resume``): the mapper's state plus a record of the log, the
reader's options and how far into the log the replay got."""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import shutil
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from ._animation import load_frames, save_frames
from ._replay_skips import SkippedScans, check_replay_counts
from ._words import counted

#: Where a replay that stops part way keeps the mapper's state, in its output folder.
STATE_FILE = "mapper_state.npz"
_HASHED_BYTES = 1 << 20  # of each end of a log file, for its fingerprint


class ReplayProgress:
    """How far a replay got: ``consumed`` scans taken from the log (mapped or skipped),
    ``skipped``: those refused (:class:`~topojax._replay_skips.SkippedScans`: how many,
    per bound met, the refusals of the first and of the latest), and ``recorded``: the
    scans whose updates the replay's recordings (animation, view timeline, MCAP) hold;
    updated after every scan; ``checkpoints``: the states this replay saved as it went
    (:class:`Checkpoints`)."""

    __slots__ = ("checkpoints", "consumed", "recorded", "resumed_after", "skipped")

    def __init__(self, consumed: int = 0, skipped: SkippedScans | None = None) -> None:
        self.consumed = consumed
        self.recorded = consumed
        self.resumed_after = consumed
        self.skipped = SkippedScans() if skipped is None else skipped
        self.checkpoints = 0  # saved by this replay (:class:`Checkpoints`)

    def skip(self, refusal: str, bound: str) -> None:
        """Count a skipped scan: its ``refusal`` and the ``bound`` it met."""
        self.skipped.skip(refusal, bound)


#: How the warning of a stopped replay says to continue it (``topojax replay`` words it
#: with its option).
RESUME_ADVICE = "resume=True to continue from it"


def skipped_message(progress: ReplayProgress) -> list[str]:
    """The scans a replay skipped (refused as beyond the mapper's bounds) in one message,
    none if none: the refusal itself for one scan, else how many of the scans taken, the
    bounds they met and the first refusal (the others kept are in the summary's
    ``skipped_scans``: all, or those of the first and of the latest, as it says)."""
    skipped = progress.skipped
    if skipped.count <= 1:
        return [f"skipped {m}" for m in skipped.texts]
    met = _bounds_met(skipped.per_bound)
    listed = "every refusal (skipped_scans)"
    if skipped.left_out:
        listed = (
            f"the refusals of the first {skipped.first_kept} and of the latest (skipped_scans; "
            f"the other {skipped.left_out} are left out)"
        )
    return [
        f"skipped {skipped.count} of {progress.consumed} scans, each refused as beyond the "
        f"mapper's bounds{met} and not mapped; timings.json lists {listed}; the first: "
        f"{skipped.texts[0]}"
    ]


#: The mapper's bounds a refusal may meet (:attr:`ExtentError.bound`) that the summary
#: names, in its order, each as it names it (``topojax replay`` names its option);
#: pixels beyond 2^30 px from the origin are no setting.
_BOUNDS = {
    "max_extent_m": "max_extent_m",
    "max_tile_bytes": "max_tile_bytes",
    "max_grid_cells": "max_grid_cells",
}


def _bounds_met(bounds) -> str:
    """The settings among the ``bounds`` the refusals met (any collection of names),
    as ``" (max_extent_m; max_tile_bytes)"``; ""
    where none is a setting (pixels beyond 2^30 px from the origin, or not known)."""
    met = [name for bound, name in _BOUNDS.items() if bound in bounds]
    return f" ({'; '.join(met)})" if met else ""


def skipped_note(progress: ReplayProgress) -> str:
    """The scans a replay skipped, as a sentence (with a leading space) for an error that
    ends the replay before its summary, which would list them, is written; "" if none.
    Each refusal names the bound it met, so the first is quoted."""
    skipped, n = progress.skipped.texts, progress.skipped.count
    if n == 1:
        return f" The replay skipped one scan, refused: {skipped[0]}"
    if n:
        return (
            f" The replay skipped {n} of the {progress.consumed} scans it took, each "
            f"refused as beyond the mapper's bounds; the first: {skipped[0]}"
        )
    return ""


#: The :class:`WholeScans` in force in the main thread, the innermost last.
_IN_FORCE: list[WholeScans] = []


def interrupt(signum, frame) -> None:
    """Interrupt a replay as a Ctrl-C does, from a signal handler of the main thread:
    held by the innermost :class:`WholeScans` in force while it maps a scan (or holds),
    at once (``KeyboardInterrupt``) otherwise.  For a signal other than SIGINT (``topojax
    replay``'s SIGTERM) where SIGINT is ignored (a background job of a script)."""
    if _IN_FORCE:
        _IN_FORCE[-1]._interrupt(signum, frame)
    else:
        raise KeyboardInterrupt


class WholeScans:
    """Maps scans so that an interrupt falls between them: within ``with``, a Ctrl-C
    (SIGINT) that arrives while :meth:`add` maps a scan is held until the scan is mapped
    and counted, then raised; a second one while it is held, or one between scans,
    interrupts at once, except while the mapped scan is recorded (:meth:`add`'s
    ``then``): every Ctrl-C waits for that.  Outside the main thread, or where SIGINT
    has a handler other than Python's default, interrupts are left as they are
    (:func:`interrupt` is held in the main thread all the same)."""

    def __init__(self) -> None:
        self._busy = False
        self._pending = False
        self._recording = False  # every Ctrl-C held, not only the first
        self._old = None
        self._main = False

    def __enter__(self) -> WholeScans:
        import signal
        import threading

        self._main = threading.current_thread() is threading.main_thread()
        if self._main:
            _IN_FORCE.append(self)
            if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                self._old = signal.signal(signal.SIGINT, self._interrupt)
        return self

    def __exit__(self, *exc) -> None:
        import signal

        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
            self._old = None
        if self._main:
            _IN_FORCE.remove(self)
            self._main = False

    def _interrupt(self, signum, frame) -> None:
        if self._busy and (self._recording or not self._pending):
            self._pending = True
            return
        raise KeyboardInterrupt

    @contextlib.contextmanager
    def held(self):
        """Within ``with``, a Ctrl-C is held as while a scan is mapped, and raised once the
        block has run: for the mapper's updates after the last scan (the final skeleton
        and graph update, the route graph), which an interrupt part way would leave
        half done, for the state saved on the interrupt to hold."""
        self._busy = True
        try:
            yield
        finally:
            self._busy = False
            if self._pending:  # the held Ctrl-C, now that the block has run
                self._pending = False
                raise KeyboardInterrupt  # noqa: B012

    @contextlib.contextmanager
    def held_then_dropped(self):
        """Within ``with``, a Ctrl-C is held as in :meth:`held`, and dropped once the
        block has run: for keeping what a stopping replay mapped (its state, its
        recordings), after which the stop is raised anyway; a second one while it is held
        interrupts at once."""
        self._busy = True
        try:
            yield
        finally:
            self._busy = self._pending = False

    def add(self, mapper, scan, index: int, progress: ReplayProgress, then=None):
        """``mapper.add_scan(scan)`` of the log's scan ``index`` (from 0), counted in
        ``progress`` once the mapper took it (also when it raised part way), then
        ``then(scan, report)`` (what the replay records of it; a held Ctrl-C waits for it too,
        and ``progress.recorded`` counts the scan once it returned); None for a scan
        refused with :class:`ExtentError` (its refusal is kept in ``progress``).  While
        ``then`` runs, a second Ctrl-C is held as well: one cut part way would leave the
        recordings short of the mapped scans, which a resume could not continue, so all
        they held would be lost."""
        from .incremental import ExtentError

        before = mapper.n_scans
        with self.held():  # a Ctrl-C is raised once the scan is counted
            try:
                report = mapper.add_scan(scan)
                self._recording = True
                try:
                    if then is not None:
                        then(scan, report)
                    progress.recorded = index + 1
                finally:
                    self._recording = False
                return report
            except ExtentError as exc:  # a localisation glitch: skipped, the replay goes on
                progress.skip(_named_in_log(exc, index), exc.bound)
                progress.consumed = progress.recorded = index + 1
                return None
            finally:
                if mapper.n_scans != before:
                    progress.consumed = index + 1


def _named_in_log(refusal, index: int) -> str:
    """The message of the mapper's ``refusal`` (:class:`ExtentError`) of a scan, which
    names the scan by the scans the mapper had added ("scan 594 (timestamp ...): ..."),
    naming it instead by its ``index`` in the log (from 0), as the replay counts scans:
    refused scans and those a resumed replay skipped are not the mapper's, so that number
    would not find it."""
    if refusal.scan is None:  # not a scan
        return str(refusal)
    return refusal.renamed(f"scan {index} of the log")


def _file_digest(path: Path, digest) -> None:
    """Feed ``path``'s size and its first and last MiB to ``digest``."""
    size = path.stat().st_size
    digest.update(f"{size}:".encode())
    with open(path, "rb") as fh:
        digest.update(fh.read(_HASHED_BYTES))
        if size > 2 * _HASHED_BYTES:
            fh.seek(size - _HASHED_BYTES)
        digest.update(fh.read(_HASHED_BYTES))


def log_fingerprint(source) -> str:
    """A hex digest of a log (a file, or a bag folder's files): sizes and the first and
    last MiB of each file, so that the same log moved elsewhere still matches."""
    src = Path(source)
    digest = hashlib.sha256()
    files = sorted(p for p in src.rglob("*") if p.is_file()) if src.is_dir() else [src]
    for p in files:
        digest.update(str(p.relative_to(src) if src.is_dir() else "").encode() + b"\0")
        _file_digest(p, digest)
    return digest.hexdigest()


def _plain(value):
    """``value`` as JSON gives it back (tuples as lists), for comparing."""
    return json.loads(json.dumps(value, sort_keys=True, default=str))


def replay_record(
    source, reader_kwargs, progress: ReplayProgress, mapper, route_graph_radius_m=None
) -> dict:
    """What a saved state records of its replay: the log (path and fingerprint), the
    reader's options, the scans taken from the log and mapped, the refusals, and the
    robot radius of the route graphs recorded (None: none).  Of the refusals, those of
    the first scans skipped and of the latest (:class:`~topojax._replay_skips.SkippedScans`),
    so that it stays bounded however many scans are skipped."""
    return {
        "route_graph_radius_m": route_graph_radius_m,
        "source": str(Path(source).resolve()),
        "fingerprint": log_fingerprint(source),
        "reader_kwargs": _plain(reader_kwargs or {}),
        "consumed": int(progress.consumed),
        "mapped": int(mapper.n_scans),
        **progress.skipped.record(),
    }


#: Stack level of this module's warnings: the caller of :func:`topojax.replay` (from
#: here, through ``_map_scans`` or ``_write_and_close``, ``_replay_checked`` and ``replay``).
_CALLER = 5


def save_replay_state(mapper, path: Path, record: dict) -> Path:
    """Save ``mapper``'s state to ``path`` (as :meth:`IncrementalMapper.save`) with the
    replay ``record``; returns the path."""
    from .incremental.state import save_state

    return save_state(mapper, path, replay=record)


def keep_state(mapper, out: Path, record) -> bool:
    """After a failure part way through a log, save the mapper's state with the replay
    ``record`` (a callable giving it) to ``out`` (if it mapped a scan) and say so in a
    RuntimeWarning; a failing save does not hide the failure.  Returns whether the
    state was saved."""
    if mapper.n_scans == 0 or mapper.pixel_bbox is None:
        return False
    try:
        with WholeScans() as whole, whole.held_then_dropped():  # a Ctrl-C waits for it
            path = save_replay_state(mapper, out / STATE_FILE, record())
    except KeyboardInterrupt:  # a second Ctrl-C while the state was saved
        warnings.warn(
            f"replay stopped after {counted(mapper.n_scans, 'scan')}; saving the mapper's "
            "state was interrupted, so it is not kept",
            RuntimeWarning,
            stacklevel=_CALLER,
        )
        raise
    except Exception as exc:  # noqa: BLE001 - the original failure is what is raised
        warnings.warn(
            f"replay stopped after {counted(mapper.n_scans, 'scan')}; saving the mapper's state "
            f"failed too ({exc})",
            RuntimeWarning,
            stacklevel=_CALLER,
        )
        return False
    warnings.warn(
        f"replay stopped after {counted(mapper.n_scans, 'scan')}; the mapper's state is saved to "
        f"{path} (replay again with {RESUME_ADVICE})",
        RuntimeWarning,
        stacklevel=_CALLER,
    )
    return True


class Checkpoints:
    """Saves a replay's state into its output folder ``out`` as it goes, for a resume
    after a replay killed outright (``kill -9``, out of memory, a power cut), which
    saves nothing when it stops: after a scan, once ``every_s`` seconds of wall time
    have passed since the replay started or the last checkpoint was saved (0: never).
    The state is the one a stopped replay saves (:data:`STATE_FILE`, with ``record()``,
    marked ``checkpoint``), written atomically: a kill while it is written leaves the
    last one.  Recordings a stopped replay kept in ``out`` are removed first: they hold
    fewer scans than the checkpoint.  ``progress.checkpoints`` counts the states saved;
    a failing save is said in a RuntimeWarning (once) and the replay goes on."""

    def __init__(self, every_s: float, out: Path, record, progress: ReplayProgress) -> None:
        self._every_s = every_s
        self._out = out
        self._record = record
        self._progress = progress
        self._due = time.monotonic() + every_s if every_s else math.inf
        self._failed = False

    def after_scan(self, mapper) -> None:
        """Save the state if a checkpoint is due and the mapper has mapped something."""
        if time.monotonic() < self._due or mapper.pixel_bbox is None:
            return
        try:
            drop_recordings(self._out)
            record = {**self._record(), "checkpoint": True}
            save_replay_state(mapper, self._out / STATE_FILE, record)
            self._progress.checkpoints += 1
        except Exception as exc:  # noqa: BLE001 - the mapping goes on; the next one may work
            if not self._failed:
                warnings.warn(
                    f"replay: saving a checkpoint of the mapper's state after "
                    f"{counted(mapper.n_scans, 'scan')} failed ({exc}); the replay goes on "
                    f"and tries again every {self._every_s:g} s",
                    RuntimeWarning,
                    stacklevel=_CALLER + 1,
                )
            self._failed = True
        self._due = time.monotonic() + self._every_s


def remove_torn_states(out: Path) -> None:
    """Remove the temporary files of states (checkpoints) that a replay killed while it
    wrote one left in ``out`` (the state itself is the one before, whole).  For a replay
    that holds ``out``'s lock: no other replay is writing one."""
    for tmp in out.glob(f".{STATE_FILE}.*.tmp"):
        tmp.unlink(missing_ok=True)


def retire_earlier_replay(out: Path) -> list[str]:
    """Remove the state (a stop's or a checkpoint) and the recordings that an earlier
    replay into ``out`` left for a resume, for a replay from the log's first scan, before
    it writes anything: a resume after this one is killed before its first checkpoint
    then finds nothing to continue, not the earlier run (which it chose not to resume).
    The state goes first: a kill in between leaves recordings that no state continues.
    Returns a message for each thing removed."""
    messages = []
    state = out / STATE_FILE
    if state.is_file():
        state.unlink()
        messages.append(
            f"removed {state}: the state of an earlier replay into {out}, which this one, "
            "from the log's first scan, replaces"
        )
    folder = out / PARTIAL_DIR
    if folder.exists():
        (folder / "recorded.json").unlink(missing_ok=True)  # first, as drop_recordings
        shutil.rmtree(folder, ignore_errors=True)
        messages.append(f"removed {folder}: the recordings of an earlier replay into {out}")
    return messages


#: Reader options a replay may resume with changed: skipping malformed lines leaves the
#: scans before the line a replay stopped at as they were (and a state saved skipping
#: lines, resumed without, stops at the first such line again).
_RESUME_FREE = ("bad_lines",)


#: Mapper settings a resume may change: limits that only refuse (an export past
#: ``max_export_bytes`` stops the replay, and its message says to raise the limit), so
#: the scans are mapped alike; the resumed mapper takes the new ones.
_RESUME_FREE_SETTINGS = ("max_export_bytes",)


def _without(options: dict, keys) -> dict:
    return {k: v for k, v in options.items() if k not in keys}


def resumed_mapper(out: Path, source, reader_kwargs, settings: dict, max_scans):
    """The mapper saved in ``out`` by a replay of ``source`` that stopped part way, and
    that replay's record (``consumed``, ``mapped``, the skipped scans: see
    :meth:`~topojax._replay_skips.SkippedScans.from_record`), its counts checked.

    Raises
    ------
    FileNotFoundError
        If ``out`` has no saved state.
    ValueError
        If the state is unreadable, records no replay (saved by
        :meth:`IncrementalMapper.save` or an older topojax), was made from another log,
        with other reader options or mapper ``settings`` (but for
        ``max_export_bytes``, which the resumed mapper takes), records counts that are no
        counts of scans or that do not add up (a damaged state; the message names the
        field, what was expected and what was received), or took more scans than
        ``max_scans``.
    """
    from .incremental import IncrementalMapper
    from .incremental.state import mapper_from_state, read_state

    path = out / STATE_FILE
    if not path.is_file():
        raise FileNotFoundError(
            f"resume: no saved state {path} to continue from: a replay that stops part way "
            "(an error or an interrupt) saves one there, and one killed outright leaves its "
            "last checkpoint (every checkpoint_every_s) there, if it saved one (a replay "
            "without resume removes those of earlier replays as it starts); replay without "
            "resume to start from the first scan"
        )
    path, data = read_state(path)
    if "replay" not in data:
        raise ValueError(
            f"resume: {path} does not record which log it mapped nor how far (saved by "
            "IncrementalMapper.save or an older topojax); replay without resume"
        )
    try:
        record = json.loads(str(data["replay"]))
        for key in ("source", "fingerprint", "reader_kwargs", "consumed", "skipped"):
            record[key]
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"resume: {path}: corrupt record of its replay ({exc!r})") from None
    if record["fingerprint"] != log_fingerprint(source):
        if record["source"] == str(Path(source).resolve()):  # the same file, written since
            which = "which has changed since (written to, cut or replaced)"
        else:
            which = f"a different log from {source}"
        raise ValueError(
            f"resume: {path} was saved replaying {record['source']}, {which}; replay "
            "without resume, or into another folder"
        )
    _check_same(
        path,
        "reader options",
        _without(record["reader_kwargs"], _RESUME_FREE),
        _without(_plain(reader_kwargs or {}), _RESUME_FREE),
    )
    saved = _without(_plain(json.loads(str(data["settings"]))), _RESUME_FREE_SETTINGS)
    _check_same(path, "settings", saved, _without(_plain(settings), _RESUME_FREE_SETTINGS))
    mapper = mapper_from_state(IncrementalMapper, path, data)
    for key in _RESUME_FREE_SETTINGS:  # checked as the new mapper's own
        setattr(mapper, key, settings[key])
    try:
        check_replay_counts(record, mapper.n_scans)
    except ValueError as exc:
        raise ValueError(f"resume: {path}: {exc}") from None
    if max_scans is not None and record["consumed"] > max_scans:
        raise ValueError(
            f"resume: {path} has already taken {record['consumed']} scans from the log, "
            f"more than max_scans={max_scans}"
        )
    return mapper, record


def _rooms_every_differs(saved, now) -> str:
    """How the saved replay's ``rooms_every`` and this one's differ, in words: None is
    no rooms (``rooms`` not asked for), 0 rooms after the last scan only."""

    def updated(every) -> str:
        return "after its last scan only" if every == 0 else f"every {counted(every, 'scan')}"

    if now is None:
        return f"the saved replay updated rooms {updated(saved)}, this one has no rooms_every"
    if saved is None:
        return f"the saved replay had no rooms_every, this one updates rooms {updated(now)}"
    return f"the saved replay updated rooms {updated(saved)}, this one {updated(now)}"


#: Settings whose difference is said in words, not as the two values.
_IN_WORDS = {"rooms_every": _rooms_every_differs}


def _differences(saved: dict, now: dict, prefix: str = "") -> list[str]:
    """``key: saved ..., now ...`` for each key whose value differs; a setting that is
    itself a dict (``room_config``) by the keys of it that differ."""
    out = []
    for k in sorted(set(saved) | set(now), key=str):
        a, b = saved.get(k), now.get(k)
        if a == b:
            continue
        if isinstance(a, dict) and isinstance(b, dict):
            out += _differences(a, b, f"{prefix}{k}.")
        elif k in _IN_WORDS and not prefix:
            out.append(f"{k}: {_IN_WORDS[k](a, b)}")
        else:
            out.append(f"{prefix}{k}: saved {a!r}, now {b!r}")
    return out


def _check_same(path: Path, what: str, saved: dict, now: dict) -> None:
    """Refuse (ValueError) resuming when the ``saved`` and ``now`` dicts differ, naming
    the keys that differ."""
    if saved == now:
        return
    diff = "; ".join(_differences(saved, now))
    raise ValueError(
        f"resume: {path} was made with other {what} ({diff}); resume with the same "
        "options, or replay without resume"
    )


#: Where a replay that stops part way keeps its recordings so far (animation frames, view
#: timeline, MCAP recording), in its output folder, for a resumed replay to continue.
PARTIAL_DIR = ".replay_partial"


@dataclass(frozen=True)
class ScanRecording:
    """Writes each scan into an open :class:`~topojax.io.mcap.McapRecorder`, and what the
    scan's report updated: the map and graph at a graph update (and the route graph of
    the map, for a robot of ``route_graph_radius_m``), the rooms at a rooms update."""

    recorder: object
    route_graph_radius_m: float | None

    def __call__(self, mapper, scan, rep) -> None:
        self.recorder.add_scan(scan)
        if mapper.pixel_bbox is None:
            return
        if rep.graph_update is not None:
            self.recorder.add_map(mapper.occupancy, mapper.graph)
            if self.route_graph_radius_m is not None:
                routes = quiet_route_graph(mapper, self.route_graph_radius_m)
                self.recorder.add_route_graph(routes)
        if rep.rooms_update is not None:
            self.recorder.add_rooms(mapper.rooms)


def keep_recordings(out: Path, progress: ReplayProgress, recorder, timeline, frames) -> None:
    """After a failure part way through a log, keep what the replay recorded of its
    first ``progress.recorded`` scans in ``out/.replay_partial``: the open MCAP
    ``recorder`` finished there, the view ``timeline`` and the animation ``frames`` (each
    None when not recorded).  A resumed replay that recorded no scan leaves the folder as
    it was (it holds what the earlier replays recorded, also of outputs not asked for
    now).  A failing save is said in a RuntimeWarning."""
    folder = out / PARTIAL_DIR
    if progress.recorded == progress.resumed_after and folder.exists():
        return
    recorded = progress.recorded
    try:
        with WholeScans() as whole, whole.held_then_dropped():  # a Ctrl-C waits for them
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir(parents=True)
            if recorder is not None:
                recorder.close(folder / "recording.mcap")
            if timeline is not None:
                timeline.save(folder / "timeline.json.gz")
            if frames is not None:
                save_frames(frames, folder / "frames.npz")
            (folder / "recorded.json").write_text(json.dumps({"recorded": recorded}))
    except Exception as exc:  # noqa: BLE001 - the original failure is what is raised
        shutil.rmtree(folder, ignore_errors=True)
        warnings.warn(
            f"replay stopped; keeping its recordings so far failed ({exc}): a resumed "
            "replay's animation, view timeline and MCAP recording will hold only the "
            "scans after the stop",
            RuntimeWarning,
            stacklevel=_CALLER,
        )


@contextlib.contextmanager
def open_recording(mcap, continue_from):
    """Within ``with``, an open :class:`~topojax.io.mcap.McapRecorder` for ``mcap``
    (continuing the recording ``continue_from``, if not None), or None.  The replay
    closes it with its files, keeping the mapper's state when that is interrupted; a
    failure or an interrupt before then drops it."""
    if mcap is None:
        yield None
        return
    from .io.mcap import McapRecorder

    recorder = McapRecorder(mcap, continue_from=continue_from).open()
    try:
        yield recorder
    except BaseException:
        recorder.abort()
        raise


class KeptRecordings(NamedTuple):
    """What a stopped replay recorded (:func:`keep_recordings`), for the resumed one to
    continue: the MCAP recording's path, the view timeline and the animation frames
    (None where not kept or not wanted now), and a message per recording that holds
    only the scans after the stop."""

    mcap: Path | None
    timeline: Any
    frames: list | None
    messages: list[str]


def same_recorded_radius(out: Path, record: dict, kept, route_graph_radius_m) -> None:
    """Refuse (ValueError) to continue the stopped replay's MCAP recording (``kept.mcap``)
    with route graphs for another robot radius than it holds (a state saved before the
    radius was recorded is not checked)."""
    if kept.mcap is None or "route_graph_radius_m" not in record:
        return
    saved = record["route_graph_radius_m"]
    if saved != route_graph_radius_m:

        def said(r) -> str:
            return "no route graph" if r is None else f"route graphs for a robot of {r} m"

        raise ValueError(
            f"resume: the MCAP recording of the stopped replay in {out} holds "
            f"{said(saved)}, this replay would add {said(route_graph_radius_m)}; resume "
            "with the same route_graph_radius_m, or replay without resume"
        )


def kept_recordings(
    out: Path, consumed: int, *, mcap: bool, view: bool, animate: bool, checkpoint: bool = False
):
    """The recordings kept in ``out`` by the replay that stopped after taking
    ``consumed`` scans, those wanted now (:class:`KeptRecordings`); recordings of
    another number of scans are not used.  ``checkpoint``: the state is a checkpoint
    (:class:`Checkpoints`) of a replay killed outright, which keeps no recordings."""
    from .view import Timeline

    folder = out / PARTIAL_DIR
    try:
        recorded = json.loads((folder / "recorded.json").read_text())["recorded"]
    except (OSError, ValueError, KeyError, TypeError):
        recorded = None
    usable = recorded == consumed
    found: dict[str, Any] = {}
    messages = []
    for name, file, wanted, load in (
        ("MCAP recording", "recording.mcap", mcap, _readable_mcap),
        ("view timeline", "timeline.json.gz", view, Timeline.load),
        ("animation", "frames.npz", animate, load_frames),
    ):
        path = folder / file
        if not wanted:
            continue
        why = "the stopped replay kept none of its own"
        if checkpoint:
            why = (
                "the replay was killed (kill -9, out of memory, a power cut) after saving "
                "this checkpoint of its state, which keeps no recordings"
            )
        if usable and path.is_file():
            try:
                found[file] = load(path)
                continue
            except Exception as exc:  # noqa: BLE001 - a damaged part is started afresh
                why = f"the one the stopped replay kept is unreadable ({exc})"
        messages.append(f"the {name} holds the scans after the log's first {consumed}: {why}")
    return KeptRecordings(
        found.get("recording.mcap"),
        found.get("timeline.json.gz"),
        found.get("frames.npz"),
        messages,
    )


def _readable_mcap(path: Path) -> Path:
    """``path``, once every message of the MCAP file reads (an exception otherwise: a
    recording that cannot be continued is started afresh, before any scan is mapped)."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        for _ in reader.messages():
            pass
    return path


def drop_recordings(out: Path) -> list[str]:
    """Remove the recordings a stopped replay kept in ``out``; returns a message if any."""
    folder = out / PARTIAL_DIR
    if not folder.exists():
        return []
    (folder / "recorded.json").unlink(missing_ok=True)  # first: a kill part way leaves
    shutil.rmtree(folder, ignore_errors=True)  # no recordings that look usable
    return [f"removed {folder}: the replay has finished"]


def quiet_route_graph(mapper, robot_radius_m: float):
    """``mapper.route_graph``, without its warning of an empty graph: the replay reports
    the final graph's note itself, and a graph recorded on the way is empty while the
    map is small.  (The warning is filtered, which is process-wide: a replay maps on one
    thread.)"""
    with warnings.catch_warnings():  # the replay runs on one thread
        warnings.filterwarnings("ignore", r"empty route graph: |warning: the route graph has")
        return mapper.route_graph(robot_radius_m=robot_radius_m)  # its export budget checked
