"""Replay of a scan log through the mapper (the ``topojax replay`` command)."""

from __future__ import annotations

import contextvars
import copy
import functools
import json
import time
from pathlib import Path
from typing import NamedTuple

from ._animation import animation_frame, write_animation
from ._lock import one_writer
from ._replay_args import (
    check_options,
    check_replay_args,
    no_empty_folder_left,
    optional_outputs,  # noqa: F401 - for topojax.playback's users
    output_names,  # noqa: F401
    refuse_folder_outputs,
    refuse_overwriting_source,
    remove_stale,
)
from ._replay_skips import SkippedScans
from ._replay_state import (
    STATE_FILE,
    Checkpoints,
    KeptRecordings,
    ReplayProgress,
    ScanRecording,
    WholeScans,
    drop_recordings,
    keep_recordings,
    keep_state,
    kept_recordings,
    open_recording,
    quiet_route_graph,
    remove_torn_states,
    replay_record,
    resumed_mapper,
    retire_earlier_replay,
    same_recorded_radius,
    save_replay_state,
    skipped_message,
    skipped_note,
)
from ._replay_summary import empty_note, replay_summary, route_note, summary_text
from ._validate import flag, nonnegative_quantity
from ._words import counted
from .config import GraphConfig
from .incremental import (
    ExportBudgetError,
    IncrementalMapper,
    ScanReport,
    settings_of,
)

#: Whether :func:`replay` with ``progress`` prints its summary: False where the caller
#: prints it in its own words (``topojax replay``, in its options').
summary_printed = contextvars.ContextVar("summary_printed", default=True)
#: Suffixes dropped from a log's file name for the pictures' titles.
_LOG_SUFFIXES = (".gz", ".bz2", ".log", ".bag", ".db3", ".mcap", ".txt", ".dat", ".clf")


def _source_name(source) -> str:
    """A log's name for titles: its file name without log suffixes (``intel.log.gz`` ->
    ``intel``)."""
    name = Path(str(source)).name
    while Path(name).suffix.lower() in _LOG_SUFFIXES:
        name = Path(name).stem
    return name


def replay(
    source,
    *,
    out_dir,
    plot: bool = False,
    animate=None,
    progress: bool = True,
    max_scans: int | None = None,
    reader_kwargs: dict | None = None,
    nav2_tolerance_m: float | None = None,
    graph_config: GraphConfig | None = None,
    route_graph_radius_m: float | None = None,
    rooms: bool = False,
    view: bool = False,
    mcap=None,
    resume: bool = False,
    checkpoint_every_s: float = 60.0,
    **mapper_kw,
) -> dict:
    """Replay a scan log through an :class:`IncrementalMapper` and write the results.

    Parameters
    ----------
    source : str or Path
        A CARMEN log, ROS bag or Octave laser file (see :func:`topojax.scans.read_scans`).
    out_dir : str or Path
        Output folder (created).  Written: ``graph.graphml``, ``graph.json``,
        ``graph.geojson`` (skipped with a message when an attribute is not finite),
        ``map.yaml`` + ``map.pgm`` (the occupancy map), ``timings.json`` (per-loop
        statistics, see :func:`timing_summary`) and, with ``plot``, ``graph.png`` and
        ``stages.png`` (and ``route_graph.png`` with ``route_graph_radius_m``).  Locked
        while the replay runs: a second one into it is refused (BlockingIOError).
    plot : bool
        Write pictures, at the end (with ``rooms``, the final ones under the graph).
    animate : str or Path, optional
        Write an animated GIF with one frame per graph update.
    progress : bool
        Show a tqdm progress bar.
    max_scans : int, optional
        Stop after this many scans of the log, those skipped included.
    reader_kwargs : dict, optional
        Passed to the reader.
    nav2_tolerance_m : float, optional
        Also write ``graph_nav2.geojson`` (and ``route_graph_nav2.geojson``, where it has
        an edge) for Nav2 with this tolerance (:func:`topojax.save_nav2_graph`).
    graph_config : GraphConfig, optional
        What the written graph (and Nav2 file and pictures) keep of the final graph
        (``free_space_only``, ``min_*_m``): ``build_graph(map, ...)``'s with this
        ``graph``.  Default: the mapper's whole graph, as the paper keeps it.
    route_graph_radius_m : float, optional
        Also write ``route_graph.{graphml,json,geojson}``, the final map's route graph for
        a round robot of this radius (recorded at every update with ``mcap``).
    rooms : bool
        Keep rooms as the map grows (``room_config``, ``rooms_*`` in ``mapper_kw``; refused
        without it), give the graphs rooms, write ``map_rooms.{geojson,png,graphml,json}``.
    mcap : str or Path, optional
        Also write a ROS 2 MCAP recording (:mod:`topojax.io.mcap`, needs ``rosbags``):
        scans, map, graph (route graph, rooms) at every update, at the log's times.
    view : bool
        Also write ``view.html`` (:func:`topojax.write_view`), the final map and graph
        with a timeline of every graph update, and ``timeline.json.gz``.
    resume : bool
        Continue the replay of ``source`` into ``out_dir`` that stopped part way from the
        state it saved there (see Returns) or its last checkpoint: the scans it took are
        skipped, and the map and graph written are those of a replay that did not stop.
        Refused (ValueError, FileNotFoundError) without a state, or one saved replaying
        another log or with other ``reader_kwargs`` or mapper settings.  The recordings
        go on from those the stopped replay kept (``out_dir/.replay_partial``); one it
        did not keep holds only the scans replayed now (the ``messages`` say so).
    checkpoint_every_s : float
        After the scan that ends each such span of wall time, save that state
        (atomically), for ``resume`` after a replay killed outright (``kill -9``, out of
        memory, a power cut), which saves nothing as it dies; 0: never.
    **mapper_kw
        Passed to :class:`IncrementalMapper` (``resolution_m``, ``skeleton_every``,
        ``graph_every``, ``strategy``, ``room_config``, ...).

    Returns
    -------
    dict
        ``n_scans`` (scans mapped), ``n_skipped`` (scans refused, :class:`ExtentError`,
        as beyond the mapper's bounds, and skipped), ``skipped_per_bound``,
        ``skipped_scans`` and ``skipped_bounds`` (the refusals of the first 100 and the
        latest, and their bounds), ``skipped_left_out``, all from the log's start;
        ``resumed_after`` (scans taken before this call), ``n_tiles``, ``vertices``,
        ``edges``, ``rooms`` and ``doors`` (None without ``rooms``), ``route_graph`` (its
        ``vertices``, ``edges``, ``components``, ``robot_radius_m``; None without one),
        ``timings`` (per loop), ``checkpoints`` (states saved as it went), ``written``
        (paths), ``messages``.  An error or interrupt (a map grown too large to export, an
        unreadable scan, also while the files are written) leaves the mapper's state in
        ``out_dir/mapper_state.npz`` (with a RuntimeWarning) and raises; one that finishes
        removes it, one without ``resume`` an earlier one's state and recordings as it
        starts; the files the last replay there wrote and this one does not are removed.
    """
    nav2_tolerance_m, route_graph_radius_m = check_replay_args(
        max_scans, nav2_tolerance_m, route_graph_radius_m, graph_config, out_dir, animate, mcap
    )
    refuse_overwriting_source(source, Path(out_dir), animate, mcap)
    check_options(reader_kwargs, mapper_kw, plot=plot, progress=progress, rooms=rooms, view=view)
    flag("resume", resume)
    every_s = nonnegative_quantity("checkpoint_every_s", checkpoint_every_s, "seconds")
    with no_empty_folder_left(Path(out_dir)), one_writer(Path(out_dir), name="out_dir"):
        return _replay_checked(
            source,
            Path(out_dir),
            mapper_kw,
            plot=plot,
            animate=animate,
            progress=progress,
            max_scans=max_scans,
            reader_kwargs=reader_kwargs,
            nav2_tolerance_m=nav2_tolerance_m,
            graph_config=graph_config,
            route_graph_radius_m=route_graph_radius_m,
            rooms=rooms,
            view=view,
            mcap=mcap,
            resume=resume,
            checkpoint_every_s=every_s,
        )


def _replay_checked(
    source,
    out: Path,
    mapper_kw: dict,
    *,
    plot,
    animate,
    progress,
    max_scans,
    reader_kwargs,
    nav2_tolerance_m,
    graph_config,
    route_graph_radius_m,
    rooms,
    view,
    mcap,
    resume,
    checkpoint_every_s,
) -> dict:
    """The body of :func:`replay`, its arguments checked: open the log and make the
    mapper, map the scans, write the files and the summary; returns the summary."""
    options = {"plot": plot, "rooms": rooms, "view": view, "nav2": nav2_tolerance_m is not None}
    refuse_folder_outputs(out, route_graph=route_graph_radius_m is not None, **options)
    scans, mapper, progress_at, kept = _start(
        source,
        out,
        reader_kwargs,
        rooms,
        view,
        mapper_kw,
        resume=resume,
        max_scans=max_scans,
        mcap=mcap is not None,
        animate=animate is not None,
        route_graph_radius_m=route_graph_radius_m,
    )
    timeline = kept.timeline
    if route_graph_radius_m is not None:  # now, not after the whole replay
        from .routegraph.build import RouteGraphConfig
        from .routegraph.scale import check_scale

        config = RouteGraphConfig(robot_radius_m=route_graph_radius_m)
        check_scale(config, mapper.resolution_m, "route_graph_radius_m", snap_name=None)
    retired = [] if resume else retire_earlier_replay(out)  # its options all checked
    with open_recording(mcap, kept.mcap) as recorder:
        done = _map_scans(
            mapper,
            scans,
            source,
            recorder,
            timeline,
            max_scans=max_scans,
            frames=kept.frames,
            progress=progress,
            graph_config=graph_config,
            rooms=rooms,
            route_graph_radius_m=route_graph_radius_m,
            out=out,
            progress_at=progress_at,
            reader_kwargs=reader_kwargs,
            checkpoint_every_s=checkpoint_every_s,
        )
        written, messages = _write_and_close(
            mapper,
            done,
            out,
            recorder,
            timeline,
            progress_at,
            functools.partial(
                replay_record, source, reader_kwargs, progress_at, mapper, route_graph_radius_m
            ),
            nav2_tolerance_m=nav2_tolerance_m,
            plot=plot,
            animate=animate,
            source=source,
        )
    if recorder is not None:
        written.append(recorder.path)
    messages += retired + remove_stale(out, [*written, out / "timings.json"]) + kept.messages
    return _finish(source, mapper, done, out, progress_at, written, messages, progress)


def _finish(source, mapper, done, out: Path, progress_at, written, messages, progress) -> dict:
    """End a replay whose files are written (``written``, with ``messages`` about them):
    write ``timings.json``, then remove the state and recordings a stopped replay left in
    ``out`` (this finished one supersedes them) and print the summary (with
    ``progress``); returns the summary."""
    from ._fs import atomic_write_bytes

    written.append(out / "timings.json")
    summary = replay_summary(source, mapper, done, progress_at)
    summary["written"] = [str(p) for p in written]
    # timings.json before the state goes: a stop in between leaves the state, which
    # --resume finishes again, never a folder with neither
    atomic_write_bytes(out / "timings.json", json.dumps(summary, indent=2).encode("utf-8"))
    state = out / STATE_FILE
    if state.is_file():  # a stopped replay's state or a checkpoint, superseded now
        state.unlink()
        if not progress_at.checkpoints:  # not this replay's own checkpoint
            messages.append(f"removed {state}: the replay has finished")
    messages += drop_recordings(out)
    summary["messages"] = messages + skipped_message(progress_at)
    if progress and summary_printed.get():
        print(summary_text(summary))
    return summary


class _Replayed(NamedTuple):
    """What mapping a log gave: the scans' reports, the animation frames, the wall time
    of the scans (s), the skipped scans (:class:`SkippedScans`), the final graph update and its time
    (s), the result to write, the final rooms and the final route graph (or None)."""

    reports: list
    frames: list
    wall_s: float
    skipped: SkippedScans
    update: object
    final_s: float
    result: object
    seg: object
    routes: object


def _start(
    source,
    out: Path,
    reader_kwargs,
    rooms: bool,
    view: bool,
    mapper_kw: dict,
    *,
    resume,
    max_scans,
    mcap: bool,
    animate: bool,
    route_graph_radius_m,
):
    """Open the log, make the mapper (with ``rooms``, rooms at every graph update unless
    ``rooms_every`` is given; with ``resume``, the one saved in ``out``, checked against
    these settings) and create the output folder; returns the scans (with ``resume``,
    from the first one not yet taken), the mapper, the replay's progress so far and the
    recordings to continue (:class:`KeptRecordings`: with ``view`` a timeline, with
    ``animate`` the frames, with ``mcap`` the stopped replay's recording, refused where
    its route graphs are of another ``route_graph_radius_m``)."""
    import itertools

    from ._fs import output_folder
    from .scans import read_scans

    if rooms and mapper_kw.get("rooms_every") is None:
        mapper_kw["rooms_every"] = mapper_kw.get("graph_every", 80) or 0
    mapper = IncrementalMapper(**mapper_kw)
    progress_at = ReplayProgress()
    if resume:
        mapper, record = resumed_mapper(out, source, reader_kwargs, settings_of(mapper), max_scans)
        progress_at = ReplayProgress(record["consumed"], SkippedScans.from_record(record))
    try:
        scans = read_scans(source, **(reader_kwargs or {}))
    except ValueError as exc:  # named as this function names its file
        message = str(exc)
        if not message.startswith("path: "):
            raise
        raise ValueError("source: " + message.removeprefix("path: ")) from None
    if progress_at.consumed:
        scans = itertools.islice(scans, progress_at.consumed, None)
    output_folder(out)
    remove_torn_states(out)
    kept = KeptRecordings(None, None, None, [])
    if resume:
        kept = kept_recordings(
            out,
            progress_at.consumed,
            mcap=mcap,
            view=view,
            animate=animate,
            checkpoint=bool(record.get("checkpoint")),
        )
        same_recorded_radius(out, record, kept, route_graph_radius_m)
    if view and kept.timeline is None:
        from .view import Timeline

        kept = kept._replace(timeline=Timeline())
    if animate and kept.frames is None:
        kept = kept._replace(frames=[])
    return scans, mapper, progress_at, kept


def _map_scans(
    mapper,
    scans,
    source,
    recorder,
    timeline,
    *,
    max_scans,
    frames,
    progress,
    graph_config,
    rooms,
    route_graph_radius_m,
    out: Path,
    progress_at: ReplayProgress,
    reader_kwargs,
    checkpoint_every_s: float,
) -> _Replayed:
    """Feed the scans to the mapper (:func:`_run`), check that they mapped something,
    run the final update (:func:`_final`; a map too large to write leaves the mapper's
    state in ``out``) and make the final route graph (with a radius).  ``frames``
    (animation frames so far, or None) grows by a frame at every update.  ``progress_at``
    (where the replay starts in the log) follows the scans taken, for the state (and the
    recordings) saved on a failure, and for the checkpoints, every
    ``checkpoint_every_s`` (:class:`~topojax._replay_state.Checkpoints`)."""
    record = None if recorder is None else ScanRecording(recorder, route_graph_radius_m)

    def state_record():
        return replay_record(source, reader_kwargs, progress_at, mapper, route_graph_radius_m)

    checkpoints = Checkpoints(checkpoint_every_s, out, state_record, progress_at)
    try:  # a map grown too large to export (the recording's, the final) is kept
        reports, wall = _run(
            mapper, scans, max_scans, frames, progress, record, timeline, progress_at, checkpoints
        )
        skipped = progress_at.skipped  # from the log's start
        if not mapper.n_scans and skipped.count:
            n = skipped.count
            which = "the only scan replayed was" if n == 1 else f"all {counted(n, 'scan')} were"
            first = ": " if n == 1 else "; the first: "
            raise ValueError(f"source {source}: {which} refused{first}{skipped.texts[0]}")
        if not mapper.n_scans:
            raise ValueError(f"source {source}: no scans to replay")
        if mapper.pixel_bbox is None:
            raise ValueError(
                f"source {source}: no valid laser readings in {counted(mapper.n_scans, 'scan')}"
            )
        with WholeScans() as whole, whole.held():  # a Ctrl-C waits for the update
            update, final_s, result, seg = _final(mapper, graph_config, rooms)
            routes = None
            if route_graph_radius_m is not None:
                routes = quiet_route_graph(mapper, route_graph_radius_m)
    except ExportBudgetError as exc:
        keep_recordings(out, progress_at, recorder, timeline, frames)
        raise _unwritable(mapper, exc, out, state_record(), progress_at) from None
    except (Exception, KeyboardInterrupt):  # a bad line mid-log, Ctrl-C: keep the scans
        if keep_state(mapper, out, state_record):
            keep_recordings(out, progress_at, recorder, timeline, frames)
        raise
    return _Replayed(reports, frames, wall, skipped, update, final_s, result, seg, routes)


def _write_and_close(
    mapper,
    done: _Replayed,
    out: Path,
    recorder,
    timeline,
    progress_at: ReplayProgress,
    record,
    *,
    nav2_tolerance_m,
    plot,
    animate,
    source,
) -> tuple[list[Path], list[str]]:
    """Write the replay's files, then end the recording (if any) with the final map,
    graph, rooms and route graph and close it into its file; returns the paths written
    and messages.  A Ctrl-C or a failure keeps the mapper's state (``record()``: its
    replay record) and, before the recording's last messages, the recordings for a
    resume."""
    final = False  # whether the recording's last messages are being written
    try:
        written, messages = _write_graphs_and_map(done.result, out, nav2_tolerance_m)
        messages += empty_note(done.result) + route_note(done, nav2_tolerance_m)
        written += _write_rooms_routes_view(mapper, done, out, timeline, nav2_tolerance_m)
        written += _write_pictures_and_animation(mapper, done, out, plot, animate, source)
        final = True
        if recorder is not None:
            _record_final(recorder, done)
            recorder.close()  # the file in place: a Ctrl-C while it closes keeps the state
    except (Exception, KeyboardInterrupt):
        if keep_state(mapper, out, record):  # the recording itself only before its end
            keep_recordings(out, progress_at, None if final else recorder, timeline, done.frames)
        raise
    return written, messages


def _record_final(recorder, done: _Replayed) -> None:
    """End the recording with the written map, graph, rooms and route graph."""
    recorder.add_map(done.result.map, done.result.graph)
    if done.seg is not None:
        recorder.add_rooms(done.seg)
    if done.routes is not None:
        recorder.add_route_graph(done.routes)


def _write_rooms_routes_view(
    mapper: IncrementalMapper, done: _Replayed, out: Path, timeline, nav2_tolerance_m
) -> list[Path]:
    """Write what the replay's options add to the graph and map files: the room files
    (with rooms), the route graph files (with a robot radius; its Nav2 file too with a
    ``nav2_tolerance_m``, where it has an edge) and the interactive view (with a
    ``timeline``); returns the paths written."""
    written: list[Path] = []
    seg = done.seg
    if seg is not None:
        from .io import save_room_files

        written += save_room_files(seg, out / "map")
    routes = done.routes
    if routes is not None:
        from .io import save_graph

        written += [
            save_graph(routes, out / f"route_graph{s}") for s in (".graphml", ".json", ".geojson")
        ]
        if nav2_tolerance_m is not None and routes.number_of_edges():
            from .io import save_nav2_graph

            path = out / "route_graph_nav2.geojson"
            written.append(save_nav2_graph(routes, path, tolerance_m=nav2_tolerance_m))
    if timeline is not None:
        from .view import write_view

        timeline = copy.deepcopy(timeline)  # the replay's stays as recorded, for a resume
        timeline.snapshot(mapper, rooms=seg is not None)
        extra = {"route graph": routes} if routes is not None else None
        written.append(
            write_view(done.result, out / "view.html", rooms=seg, graphs=extra, timeline=timeline)
        )
        written.append(timeline.save(out / "timeline.json.gz"))  # for topojax view
    return written


def _write_pictures_and_animation(
    mapper: IncrementalMapper, done: _Replayed, out: Path, plot: bool, animate, source
) -> list[Path]:
    """With ``plot``, write the still pictures (the final rooms, if any, drawn on the
    graph's; the route graph, if any, in ``route_graph.png``); with ``animate`` (a GIF
    path), the animation, its last frame the final map.  Returns the paths written."""
    written: list[Path] = []
    name = _source_name(source)
    if plot:
        written += _write_pictures(done.result, out, name, rooms=done.seg)
    if plot and done.routes is not None:  # as topojax route-graph --plot draws it
        from ._fs import atomic_write_bytes
        from .plotting import route_graph_png

        routes = done.routes
        title = f"{name}: r = {routes.graph['robot_radius_m']:g} m: "
        title += f"{counted(len(routes), 'vertex', 'vertices')}, "
        title += counted(routes.number_of_edges(), "edge")
        png = route_graph_png(routes, done.result.map, title=title)
        atomic_write_bytes(out / "route_graph.png", png)
        written.append(out / "route_graph.png")
    if animate is not None:
        frames = [*done.frames, animation_frame(mapper)]  # done's stay as recorded
        apath = Path(animate)
        apath.parent.mkdir(parents=True, exist_ok=True)
        write_animation(frames, apath, name)
        written.append(apath)
    return written


def _final(mapper: IncrementalMapper, graph_config, rooms: bool):
    """The final graph update; returns its report, its time (s), the result to write
    (with ``graph_config``'s graph) and, with ``rooms``, the final rooms (assigned to the
    result's graph)."""
    t_final = time.perf_counter()
    update = mapper.update_graph()
    final_s = time.perf_counter() - t_final
    result = mapper.to_result(update=False)
    if graph_config is not None and (graph_config.free_space_only or graph_config.prunes):
        result = _with_graph_config(result, graph_config)
    seg = None
    if rooms:
        from .rooms import assign_rooms

        mapper.update_rooms()
        seg = mapper.rooms
        assign_rooms(result.graph, seg)  # before the graph files are written
    return update, final_s, result, seg


def _unwritable(mapper, exc: ExportBudgetError, out: Path, record: dict, progress_at) -> ValueError:
    """Save the mapper's state with the replay ``record`` to ``out`` (nothing mapped is
    lost) and return the error for a map too large to write whole, naming the scans
    skipped so far (``progress_at``: no summary lists them)."""
    path = save_replay_state(mapper, out / STATE_FILE, record)
    return ValueError(
        f"{exc}. The map of the {counted(mapper.n_scans, 'scan')} mapped is too large to export "
        f"whole; the mapper's state is saved to {path} (IncrementalMapper.load; export "
        "windows of it with occupancy_window). A pose far off (a localisation glitch)? "
        f"Replay with a smaller max_extent_m (now {mapper.max_extent_m:g} m) to skip such "
        "scans. To write it, replay again with resume=True "
        f"and a larger max_export_bytes.{skipped_note(progress_at)}"
    )


def _run(
    mapper,
    scans,
    max_scans,
    frames: list | None,
    progress: bool,
    record,
    timeline,
    progress_at: ReplayProgress,
    checkpoints: Checkpoints,
):
    """Feed ``scans`` to ``mapper`` until the log's scan ``max_scans``; returns the
    reports and the wall time (s).  Each scan mapped is recorded: ``record`` (a
    :class:`~topojax._replay_state.ScanRecording`) writes it and what its report
    updated, ``timeline`` takes its update, ``frames`` (a list, or None) gets a frame at
    each graph or rooms update.  ``progress_at`` gives where ``scans`` start in the log,
    and follows each scan taken
    (mapped, or skipped with its refusal) and recorded; ``checkpoints`` saves the state
    after a scan when one is due (a Ctrl-C waits for it)."""
    from tqdm import tqdm

    reports: list[ScanReport] = []

    def recorded(scan, rep: ScanReport) -> None:  # inside the scan: a Ctrl-C waits for it
        if timeline is not None:
            timeline.record(mapper, rep, scan)
        if record is not None:
            record(mapper, scan, rep)
        if frames is not None and (rep.graph_update or rep.rooms_update) and mapper.pixel_bbox:
            frames.append(animation_frame(mapper))

    bar = tqdm(
        total=max_scans,
        initial=progress_at.consumed,
        unit="scan",
        disable=not progress,
        desc="replay",
    )
    t0 = time.perf_counter()
    with WholeScans() as whole:  # a Ctrl-C waits for the scan being mapped
        for i, scan in enumerate(scans, start=progress_at.consumed):
            if max_scans is not None and i >= max_scans:
                break
            rep = whole.add(mapper, scan, i, progress_at, then=recorded)
            with whole.held():
                checkpoints.after_scan(mapper)
            bar.update(1)
            if rep is not None:  # else skipped
                reports.append(rep)
    bar.close()
    return reports, time.perf_counter() - t0


def _write_graphs_and_map(result, out: Path, nav2_tolerance_m) -> tuple[list, list[str]]:
    """Write the graph files, the Nav2 route graph (with a tolerance) and the map; returns
    the paths written and messages about files skipped."""
    from .io import save_graph, save_nav2_graph
    from .maps import save_map

    written: list[Path] = []
    messages: list[str] = []
    for suffix in (".graphml", ".json", ".geojson"):
        try:
            written.append(save_graph(result.graph, out / f"graph{suffix}"))
        except ValueError as exc:
            messages.append(f"graph{suffix} not written: {exc}")
    if nav2_tolerance_m is not None:
        try:
            written.append(
                save_nav2_graph(
                    result.graph, out / "graph_nav2.geojson", tolerance_m=nav2_tolerance_m
                )
            )
        except ValueError as exc:  # e.g. a graph without edges, which Nav2 refuses
            messages.append(f"graph_nav2.geojson not written: {exc}")
    written.append(save_map(result.map, out / "map.yaml"))
    written.append(out / "map.yaml")
    return written, messages


def _write_pictures(result, out: Path, name: str, *, rooms=None) -> list[Path]:
    """Write ``graph.png`` (with ``rooms``, a RoomSegmentation of the result's map, drawn
    under the graph as ``topojax graph --rooms --plot`` draws them) and ``stages.png``,
    titled with the log's ``name``; returns their paths."""
    import matplotlib

    matplotlib.use("Agg")  # plot_stages draws with pyplot; no window
    from ._fs import atomic_write_bytes
    from .plotting import result_png, stages_png

    g = result.graph
    n = g.number_of_nodes()
    title = f"{name}: {n} {'vertex' if n == 1 else 'vertices'}, "
    title += counted(g.number_of_edges(), "edge")
    if rooms is not None:
        title += f", {counted(rooms.n_rooms, 'room')}"
    atomic_write_bytes(out / "graph.png", result_png(result, title=title, rooms=rooms))
    atomic_write_bytes(out / "stages.png", stages_png(result, title=name))
    return [out / "graph.png", out / "stages.png"]


def _with_graph_config(result, graph_config: GraphConfig):
    """``result`` with the skeleton and graph that ``graph_config`` keeps: the CPU stages
    of the full-map pipeline re-run on its ridge map (exact, so the graph is the one
    ``build_graph(result.map, ...)`` gives with that ``graph``)."""
    from dataclasses import replace

    from .pipeline import graph_of_map

    config = replace(result.config, graph=graph_config)
    skeleton, graph, _ = graph_of_map(result.map, result.ridges, result.sq_distance_px, config)
    return replace(result, skeleton=skeleton, graph=graph, config=config)
