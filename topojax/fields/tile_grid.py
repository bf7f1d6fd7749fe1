"""Fixed-size tiles: cutting maps into haloed patches and putting results back.

Every JAX kernel in topojax runs on square tiles of one size, so each kernel is compiled
once for maps of every size.  A map of shape ``(H, W)`` is covered by
``ceil(H / T) x ceil(W / T)`` tiles of side ``T``; tile ``(i, j)`` owns the map pixels
``[i T, (i + 1) T) x [j T, (j + 1) T)`` (its *core*).  Kernels that look at neighbours get
the core plus a *halo* of ``h`` pixels on every side (or ``h_rows`` above and below and
``h_cols`` left and right), cut from the map padded with a constant.  Pixels of the last
row/column of tiles that fall outside the map are padding and are dropped when the tiles
are assembled.
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
            raise ValueError(f"map_shape: expected two positive ints, received {self.map_shape!r}")
        if self.tile_px < 1:
            raise ValueError(f"tile_px: expected a value >= 1, received {self.tile_px!r}")

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
        view = self.patch_view(array, halo, fill=fill)
        gr, gc = self.grid_shape
        if index is None:
            index = np.arange(gr * gc)
        rows, cols = np.divmod(np.asarray(index, dtype=np.intp), gc)
        return np.ascontiguousarray(view[rows, cols])

    def padded_shape(self, halo) -> tuple[int, int]:
        """Shape of the padded map behind :meth:`patch_view` for ``halo``."""
        hr, hc = self._halo(halo)
        gr, gc = self.grid_shape
        return (gr * self.tile_px + 2 * hr, gc * self.tile_px + 2 * hc)

    def _halo(self, halo) -> tuple[int, int]:
        hr, hc = (halo, halo) if np.ndim(halo) == 0 else tuple(halo)
        if min(hr, hc) < 0:
            raise ValueError(f"halo: expected values >= 0, received {halo!r}")
        return int(hr), int(hc)

    def patch_view(self, array: np.ndarray, halo, *, fill=0, out=None) -> np.ndarray:
        """Haloed patches of every tile as a read-only strided view (no copy per patch).

        Parameters
        ----------
        array : array, shape (H, W)
        halo : int or (int, int)
            Halo width on every side (>= 0), or separate (row, column) halo widths.
        fill : scalar
            Value of pixels outside the map.
        out : array, optional
            Buffer for the padded map, of shape :meth:`padded_shape` and ``array``'s
            dtype (e.g. reused between calls; it is overwritten).  Default: a new one.

        Returns
        -------
        array view, shape (tile rows, tile cols, T + 2 halo_rows, T + 2 halo_cols):
        ``view[i, j]`` is tile ``(i, j)`` with its halo.  The map is padded once;
        indexing a patch copies nothing until it is stacked.
        """
        if array.shape != tuple(self.map_shape):
            raise ValueError(f"array: expected shape {self.map_shape}, received {array.shape}")
        hr, hc = self._halo(halo)
        t = self.tile_px
        shape = self.padded_shape((hr, hc))
        if out is None:
            padded = np.full(shape, fill, dtype=array.dtype)
        else:
            if out.shape != shape or out.dtype != array.dtype:
                raise ValueError(
                    f"out: expected shape {shape} and dtype {array.dtype}, "
                    f"received {out.shape} and {out.dtype}"
                )
            padded = out
            h, w = array.shape  # fill only what the map does not overwrite
            padded[:hr] = fill
            padded[hr + h :] = fill
            padded[hr : hr + h, :hc] = fill
            padded[hr : hr + h, hc + w :] = fill
        padded[hr : hr + array.shape[0], hc : hc + array.shape[1]] = array
        return sliding_window_view(padded, (t + 2 * hr, t + 2 * hc))[::t, ::t]

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
            raise ValueError(f"tiles: expected shape {(gr * gc, t, t)}+..., received {tiles.shape}")
        rest = tiles.shape[3:]
        full = tiles.reshape(gr, gc, t, t, *rest).swapaxes(1, 2).reshape(gr * t, gc * t, *rest)
        return full[: self.map_shape[0], : self.map_shape[1]]
