"""Maps larger than memory: the topology graph computed block by block.

:func:`build_graph_tiled` reads a :class:`~topojax.maps.tiled.TiledMap` (a tile folder, a
Zarr array, a memory-mapped PGM) one block and its halo at a time, proves each block's
skeleton equal to the whole map's (:mod:`~topojax.outofcore.exact`), keeps only the
skeleton's pixels and builds the graph from them
(:func:`topojax.graph.pixels_graph_store`); the blocks can run as Dask tasks.

Modules: :mod:`~topojax.outofcore.exact` (thinning and T removal of a window, with the
proof), :mod:`~topojax.outofcore.blocks` (one block's stages), :mod:`~topojax.outofcore.build`
(the driver), :mod:`~topojax.outofcore.checkpoint` (finished blocks kept for
``resume=True``).
"""

from .blocks import BlockPiece, block_piece, fields_halo_px
from .build import BYTES_PER_WINDOW_PX, TiledResult, block_px_for_budget, build_graph_tiled
from .exact import exact_after_t_removal, remove_t_in_map_order, thin_window, uniform_tables

__all__ = [
    "BYTES_PER_WINDOW_PX",
    "BlockPiece",
    "TiledResult",
    "block_piece",
    "block_px_for_budget",
    "build_graph_tiled",
    "exact_after_t_removal",
    "fields_halo_px",
    "remove_t_in_map_order",
    "thin_window",
    "uniform_tables",
]
