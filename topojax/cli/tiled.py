"""``topojax graph --tiled``: the topology graph of a map read block by block from disk."""

from __future__ import annotations

import warnings
from pathlib import Path

from ._graph_out import (
    emptied_text,
    graph_files,
    map_notes,
    summary_lines,
    write_graph_files,
    write_nav2,
)
from ._options import (
    _option_named,
    assumed_resolution_note,
    map_options,
    named_as_options,
    nav2_tolerance,
    pipeline_config,
    room_config,
)
from ._outputs import (
    OUT_OPTION,
    check_outputs,
    output_stem,
    planned,
    record_outputs,
    remove_earlier_outputs,
)

#: What ``--tiled`` leaves out: each needs the whole map in memory.
_WHOLE_MAP_OPTIONS = ("--plot", "--stages", "--rooms", "--mcap", "--view")

#: Default ``--memory-budget-mb``: as :func:`topojax.build_graph_tiled`'s.
DEFAULT_BUDGET_MB = 512.0


def add_tiled_options(p) -> None:
    """``--tiled`` and the options only it takes: ``--memory-budget-mb``, ``--resume``."""
    p.add_argument(
        "--tiled",
        action="store_true",
        help="build block by block, reading the map from disk a window at a time (maps "
        "larger than memory: a binary PGM, a YAML naming one, a tile folder or a Zarr "
        "array; topojax.build_graph_tiled): the same graph, also saved as arrays in "
        "STEM_store/ (topojax.load_graph_store), where finished blocks are kept for "
        f"--resume; not with {', '.join(_WHOLE_MAP_OPTIONS)}",
    )
    p.add_argument(
        "--memory-budget-mb",
        type=float,
        metavar="MB",
        help=f"with --tiled: memory for one block's stages (default {DEFAULT_BUDGET_MB:g})",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="with --tiled: reuse the blocks a stopped build kept in STEM_store/",
    )


def check_tiled_options(args) -> None:
    """Refuse ``--memory-budget-mb`` or ``--resume`` without ``--tiled``, and with it
    the options that need the whole map in memory (before any work)."""
    if not args.tiled:
        for option, given in (
            ("--memory-budget-mb", args.memory_budget_mb is not None),
            ("--resume", args.resume),
        ):
            if given:
                raise ValueError(f"{option}: only used with --tiled, which was not given")
        return
    given = {
        "--plot": args.plot,
        "--stages": args.stages,
        "--rooms": args.rooms,
        "--mcap": args.mcap is not None,
        "--view": args.view,
    }
    for option in _WHOLE_MAP_OPTIONS:
        if given[option]:
            raise ValueError(
                f"{option}: not with --tiled, which never holds the whole map in memory; "
                f"leave out {option}, or --tiled for a map that fits"
            )


#: The parameters of :func:`topojax.build_graph_tiled` that its errors about the kept
#: blocks name, and the options that set them.
_OPTION_OF = {"out_dir": "--out", "resume": "--resume"}
#: With them, what a refused resume names of the build description (the map's shape and
#: origin are the map's own), and its advice, in this command's words.
_RESUME_OPTION_OF = {
    **_OPTION_OF,
    "block_px": "block side from --memory-budget-mb",
    "resolution_m": "--resolution",
    "distance": "--sigma-px or --sigma-m",
    "skeleton": "--thinning or --keep-t",
    "tile_px": "--tile-px",
    "free_space_only": "--free-only",
}
_ADVICE = {
    "build with resume=False to start over": "run without --resume to start over",
    "build again with resume=True": "run again with --resume",
}


def tiled_files(stem: str, nav2: bool) -> list[str]:
    """The files ``topojax graph --tiled`` writes beside its ``STEM_store/`` folder."""
    return graph_files(stem, plot=False, stages=False, nav2=nav2, rooms=False, view=False)


def cmd_graph_tiled(args) -> int:
    """``topojax graph MAP --tiled`` (its options checked by :func:`check_tiled_options`):
    build, write the graph files, print a summary."""
    from .._lock import one_writer
    from .._validate import finite_positive
    from ..graph.prune import pruned_by
    from ..maps.files import said_resolution
    from ..outofcore.build import block_px_for_budget, build_graph_tiled, tiled_source

    tolerance = nav2_tolerance(args)
    room_config(args, only_with="--rooms", given=False)  # room options: refused here
    budget = DEFAULT_BUDGET_MB
    if args.memory_budget_mb is not None:
        budget = finite_positive("--memory-budget-mb", args.memory_budget_mb)
    stem, out = output_stem(args.map), Path(args.out)
    targets = [out / name for name in tiled_files(stem, args.nav2)]
    check_outputs(planned(targets, args.map), command="graph", option=OUT_OPTION)
    options = map_options(args)
    source = tiled_source(args.map, **said_resolution(args.map, options))
    config = pipeline_config(args, resolution_m=source.resolution_m)
    with warnings.catch_warnings(record=True) as caught:
        try:
            block_px = block_px_for_budget(budget, config, shape=source.shape)
        except ValueError as exc:  # its message names the parameter, not the option
            raise _option_named(exc, "memory_budget_mb", "--memory-budget-mb") from None
    for w in caught:  # so do its warnings
        text = str(w.message).replace("memory_budget_mb:", "--memory-budget-mb:", 1)
        warnings.warn(text, w.category, stacklevel=2)
    # one build per folder: two into it would overwrite each other's kept blocks
    with one_writer(out, name="--out", command="graph --tiled"):
        store = out / f"{stem}_store"
        with named_as_options(_OPTION_OF, _RESUME_OPTION_OF, advice=_ADVICE):
            result = build_graph_tiled(
                source, config=config, block_px=block_px, out_dir=store, resume=args.resume
            )
        _check_graph_files_fit(result, store)
        written = write_graph_files(result.graph, out, stem)
        empty = result.graph.number_of_nodes() == 0
        # its skeleton had pixels: the pruning options removed every corridor
        emptied = pruned_by(config.graph) if empty and result.cols.size else ""
        notes = map_notes(
            *_census(source, block_px * block_px),
            empty,
            emptied=emptied_text(config.graph, emptied),
        )
        if tolerance is not None:
            nav2, nav2_notes = write_nav2(result.graph, out / f"{stem}_nav2.geojson", tolerance)
            written, notes = written + nav2, notes + nav2_notes
        removed = remove_earlier_outputs(
            [out / name for name in graph_files(stem)], written, args.map, command="graph"
        )
        record_outputs(planned(written, args.map), command="graph", map_options=options)
    reused = f" ({result.blocks_reused} reused)" if result.blocks_reused else ""
    lines = summary_lines(str(args.map), result, assumed=assumed_resolution_note(args))
    lines.insert(1, f"blocks     {result.blocks}{reused}, memory budget {budget:g} MB")
    for line in [*lines, *notes, *removed]:
        print(line)
    print("wrote      " + ", ".join(str(p) for p in [*written, store]))
    return 0


def _check_graph_files_fit(result, store: Path) -> None:
    """A :class:`~topojax._cpus.MemoryRefusal` where the networkx graph that the graph
    files are written from exceeds the memory available, naming ``store``, which holds
    the graph already (a pruned graph is one already built)."""
    from ..graph.store import check_networkx_fits

    if result.graph_store is None:
        return
    check_networkx_fits(
        result.graph_store,
        "--tiled: to write the graph files,",
        f" (not bounded by --memory-budget-mb); the graph is saved in {store} "
        "(topojax.load_graph_store reads it memory-mapped)",
    )


def _census(source, max_pixels: int) -> tuple[tuple[int, int, int], float | None]:
    """The occupied, free and unknown pixels of a tiled map and its wall share (of
    :func:`topojax.maps.classify.wall_share`; None without free space), read in bands of
    rows of at most ``max_pixels`` pixels (two rows where a row is larger, the fewest a
    window holds; a single row left at the end is read with the band before it), each
    with a row more on either side for the pixels next to the free space."""
    from ..maps.classify import rim_counts, share_of_rim

    height, width = source.shape
    rows = max(2, max_pixels // max(width, 1))
    counts, rim = [0, 0, 0], [0, 0]
    r0 = 0
    while r0 < height:
        r1 = min(r0 + rows, height)
        r1 = height if height - r1 == 1 else r1
        lo, hi = max(r0 - 1, 0), min(r1 + 1, height)
        window = source.occupancy(lo, hi)
        own = slice(r0 - lo, r1 - lo)
        for i, mask in enumerate((window.occupied, window.free, window.unknown)):
            counts[i] += int(mask[own].sum())
        for i, n in enumerate(rim_counts(window.occupied, window.free, own)):
            rim[i] += n
        r0 = r1
    share = share_of_rim(*rim) if counts[1] else None
    return (counts[0], counts[1], counts[2]), share
