"""Fixed-size tiles: cutting maps into haloed patches and putting results back.

Every JAX kernel in topojax runs on square tiles of one size, so one compiled kernel
serves maps of every size.  A map of shape ``(H, W)`` is covered by
``ceil(H / T) x ceil(W / T)`` tiles of side ``T``; tile ``(i, j)`` owns the map pixels
``[i T, (i + 1) T) x [j T, (j + 1) T)`` (its *core*).  Kernels that look at neighbours get
the core plus a *halo* of ``h`` pixels on every side, cut from the map padded with a
constant.  Pixels of the last row/column of tiles that fall outside the map are padding and
are dropped when the tiles are assembled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

__all__ = ["TileGrid"]


@dataclass(frozen=True)
class TileGrid:
    """Tiling of an ``(H, W)`` map by square tiles of side ``tile_px``.

    Parameters
    ----------
    map_shape : (int, int)
        Map (rows, cols).
    tile_px : int
        Tile side in pixels.
    """

    map_shape: tuple[int, int]
    tile_px: int

    def __post_init__(self) -> None:
        if len(self.map_shape) != 2 or min(self.map_shape) < 1:
            raise ValueError(f"map_shape must be two positive ints, got {self.map_shape!r}")
        if self.tile_px < 1:
            raise ValueError(f"tile_px must be >= 1, got {self.tile_px!r}")

    @property
    def grid_shape(self) -> tuple[int, int]:
        """Number of tile rows and tile columns."""
        t = self.tile_px
        return (-(-self.map_shape[0] // t), -(-self.map_shape[1] // t))

    @property
    def n_tiles(self) -> int:
        r, c = self.grid_shape
        return r * c

    def origins(self) -> np.ndarray:
        """Map (row, col) of each tile's first core pixel, int32 (n_tiles, 2), raster order."""
        r, c = self.grid_shape
        ii, jj = np.meshgrid(np.arange(r), np.arange(c), indexing="ij")
        return (np.stack([ii.ravel(), jj.ravel()], axis=1) * self.tile_px).astype(np.int32)

    def patches(self, array: np.ndarray, halo: int, *, fill=0, index=None) -> np.ndarray:
        """Cut haloed patches.

        Parameters
        ----------
        array : array, shape (H, W)
            The map-sized array.
        halo : int
            Halo width on every side (>= 0).
        fill : scalar
            Value of pixels outside the map.
        index : int array, optional
            Tile numbers (raster order) to cut; default all.

        Returns
        -------
        array, shape (n, T + 2 halo, T + 2 halo), same dtype as ``array``.
        """
        if array.shape != tuple(self.map_shape):
            raise ValueError(f"array must have shape {self.map_shape}, got {array.shape}")
        t = self.tile_px
        gr, gc = self.grid_shape
        padded = np.full((gr * t + 2 * halo, gc * t + 2 * halo), fill, dtype=array.dtype)
        padded[halo : halo + array.shape[0], halo : halo + array.shape[1]] = array
        size = t + 2 * halo
        view = sliding_window_view(padded, (size, size))[::t, ::t]
        view = view.reshape(gr * gc, size, size)
        if index is not None:
            view = view[np.asarray(index, dtype=np.intp)]
        return np.ascontiguousarray(view)

    def assemble(self, tiles: np.ndarray) -> np.ndarray:
        """Put per-tile cores back together.

        Parameters
        ----------
        tiles : array, shape (n_tiles, T, T, ...)
            One core per tile, raster order.

        Returns
        -------
        array, shape (H, W, ...)
        """
        t = self.tile_px
        gr, gc = self.grid_shape
        if tiles.shape[:3] != (gr * gc, t, t):
            raise ValueError(f"tiles must have shape {(gr * gc, t, t)}+..., got {tiles.shape}")
        rest = tiles.shape[3:]
        full = tiles.reshape(gr, gc, t, t, *rest).swapaxes(1, 2).reshape(gr * t, gc * t, *rest)
        return full[: self.map_shape[0], : self.map_shape[1]]
