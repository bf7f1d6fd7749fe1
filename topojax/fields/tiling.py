"""Tiles of maps: the fixed tiling of the JAX kernels and the sparse tile storage of
incremental mapping.

:class:`TileGrid` (defined in ``tile_grid``) cuts a bounded map into haloed patches of one
size and puts the results back.  :class:`TileManager` allocates square tiles on demand
on an unbounded pixel lattice, with named per-tile layers and dirty flags.
"""

from __future__ import annotations

import math
import mmap

import numpy as np

from .._validate import int_at_least, positive_int
from .tile_grid import TileGrid

__all__ = [
    "GROWTH_FACTOR",
    "HUGE_PAGES",
    "MAX_GRID_CELLS",
    "TileGrid",
    "TileManager",
    "unique_pairs",
]


# --------------------------------------------------------------------------------------
# Sparse, unbounded tile storage for incremental mapping
# --------------------------------------------------------------------------------------

#: Largest number of cells the dense tile index (:attr:`TileManager.slot_grid`) may have.
#: With 128-pixel tiles at 5 cm this is a square of 4096 tiles = 26 km on a side.
MAX_GRID_CELLS = 1 << 24
#: Largest ``max_grid_cells``: :meth:`TileManager.state` stores it as an int64.
_INT64_MAX = (1 << 63) - 1
#: Layer storage at least this large gets its own memory mapping (see ``_storage``).
_MAPPED_MIN_BYTES = 1 << 20
#: Capacity growth factor of the tile storage.  Growing copies every tile into new,
#: lazily zeroed memory, whose first touch costs a page fault per page (see
#: :data:`HUGE_PAGES`): growing 4x instead of 2x
#: copies a third as much in total; unused capacity is reserved, not touched.
GROWTH_FACTOR = 4
#: Ask for transparent huge pages (2 MiB, where the kernel allows them: Linux ``madvise``
#: mode) for the mapped layers: a first touch then maps 2 MiB at once instead of 4 KiB,
#: so a replay takes several times fewer page faults.  Resident memory grows in 2 MiB
#: steps per layer.
HUGE_PAGES = True


def _storage(capacity: int, shape, dt: np.dtype) -> np.ndarray:
    """Layer storage for ``capacity`` slots, all zero, whose pages are mapped only when
    first written (huge pages where allowed, see :data:`HUGE_PAGES`): capacity that no
    tile uses takes no memory.

    Large layers get an anonymous private memory mapping of their own.  ``np.zeros``
    does not guarantee this: once the C allocator has recycled freed memory of that
    size (it raises its mapping threshold after a large free), it hands out heap memory
    and clears all of it at once (a growth then costs its full size in memory).
    """
    shape = (capacity, *shape)
    count = math.prod(shape)
    nbytes = count * dt.itemsize
    anonymous = getattr(mmap, "MAP_ANONYMOUS", None)
    if nbytes < _MAPPED_MIN_BYTES or anonymous is None:  # small, or not on a POSIX system
        return np.zeros(shape, dt)
    # No swap reservation: untouched capacity is address space only (Linux ignores the
    # flag under strict overcommit, where a large reservation then fails: see
    # TileManager's reserve_bytes)
    flags = mmap.MAP_PRIVATE | anonymous | getattr(mmap, "MAP_NORESERVE", 0)
    buf = mmap.mmap(-1, nbytes, flags=flags)
    if HUGE_PAGES and hasattr(mmap, "MADV_HUGEPAGE"):
        try:
            buf.madvise(mmap.MADV_HUGEPAGE)
        except OSError:  # a kernel built without transparent huge pages: 4 KiB pages
            pass
    return np.frombuffer(buf, dt, count=count).reshape(shape)


def unique_pairs(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Distinct ``(row, col)`` pairs sorted by row, then column: int64 (n, 2).

    Same result as ``np.unique(np.stack([rows, cols], 1), axis=0)``, through one packed
    integer key (``axis=0`` goes through a structured view).
    """
    r0, c0 = rows.min(), cols.min()
    span = cols.max() - c0 + 1
    key = np.unique((rows - r0) * span + (cols - c0))
    return np.stack([key // span + r0, key % span + c0], axis=1)


class TileManager:
    """Square tiles allocated on demand on an unbounded pixel lattice.

    The world is the lattice of pixels ``(row, col)`` in ``Z^2`` (negative indices
    allowed).  Tile ``(tile_row, tile_col)`` owns the pixels
    ``[tile_row * T, (tile_row + 1) * T) x [tile_col * T, (tile_col + 1) * T)``
    (``T = tile_px``; floor division, so negative pixels belong to negative tiles).
    Tiles are created only when asked for (:meth:`ensure`), so memory grows with the
    number of touched tiles, not with the extent of the map.

    Every tile has the same named *layers*: per-tile arrays of a fixed shape and dtype
    (e.g. a ``(T, T)`` int32 distance tile, or a small per-tile summary).  A layer is stored
    as one array of shape ``(capacity, *shape)``; a tile's data lives at its *slot* (the
    index in allocation order), which never changes.  A dense index over the bounding
    box of the allocated tiles (:attr:`slot_grid`) maps tile coordinates to slots, so
    numba kernels can find the tile of any pixel with one array read.

    The manager also keeps one *dirty* flag per tile and per named update loop
    (:meth:`mark_dirty`, :meth:`dirty`, :meth:`clear_dirty`).

    Parameters
    ----------
    tile_px : int
        Tile side ``T`` in pixels (>= 4).
    layers : mapping of str to (dtype, fill) or (dtype, fill, shape)
        Layers of every tile: numpy dtype, the value of a newly allocated tile, and the
        per-tile shape (default ``(T, T)``).
    loops : sequence of str
        Names of the update loops that track dirty tiles.
    max_grid_cells : int
        Upper bound on the cells of the dense tile index (its area in tiles).  Adding a
        tile that would make the bounding box larger raises :class:`ValueError` before
        anything is changed.  At most ``2**63 - 1`` (an int64).
    initial_capacity : int
        Tiles the storage holds before its first growth.
    reserve_bytes : int, optional
        Start with at least as many tiles as fit in this many bytes.  The capacity is
        reserved address space: untouched capacity takes no memory, and every growth it
        saves is a copy of every tile saved.
        Where the system refuses the reservation (strict overcommit, an address-space
        limit), the storage starts at ``initial_capacity`` and grows.
    """

    def __init__(
        self,
        *,
        tile_px: int,
        layers: dict,
        loops: tuple[str, ...] | list[str] = (),
        max_grid_cells: int = MAX_GRID_CELLS,
        initial_capacity: int = 16,
        reserve_bytes: int | None = None,
    ) -> None:
        tile_px = int_at_least("tile_px", tile_px, 4)
        max_grid_cells = positive_int("max_grid_cells", max_grid_cells)
        if max_grid_cells > _INT64_MAX:  # saved states store it as an int64
            raise ValueError(
                f"max_grid_cells: expected an int <= {_INT64_MAX}, received {max_grid_cells}"
            )
        self.tile_px = tile_px
        self.max_grid_cells = max_grid_cells
        self._capacity = 0
        self._n = 0
        self._nbr9: np.ndarray | None = None
        self._specs: dict[str, tuple[np.dtype, object, tuple[int, ...]]] = {}
        self._data: dict[str, np.ndarray] = {}
        for name, spec in layers.items():
            self.add_layer(name, *spec)  # no storage yet (capacity 0)
        self._min_capacity = max(1, int(initial_capacity))
        self._reserve = 0
        if reserve_bytes is not None:
            self._reserve = int(reserve_bytes) // max(1, self.tile_nbytes)
        self._loops = tuple(loops)
        self._allocate(0)
        self._grid = np.full((0, 0), -1, np.int32)
        self._grid_origin = (0, 0)
        self._bbox: tuple[int, int, int, int] | None = None
        # storage for the next growth, being paged in by a job (see prepare_growth)
        self._spare: dict[str, np.ndarray] | None = None
        self._spare_job = None

    # ------------------------------------------------------------------ layers
    def add_layer(self, name: str, dtype, fill, shape: tuple[int, ...] | None = None) -> None:
        """Add a layer to every tile (existing tiles get ``fill``).

        Parameters
        ----------
        name : str
        dtype : numpy dtype
        fill : scalar
            Value of new tiles.
        shape : tuple of int, optional
            Per-tile shape; default ``(tile_px, tile_px)``.
        """
        if name in self._specs:
            raise ValueError(f"layer {name!r} exists already")
        shape = (self.tile_px, self.tile_px) if shape is None else tuple(int(s) for s in shape)
        dt = np.dtype(dtype)
        self._specs[name] = (dt, fill, shape)
        self._data[name] = data = _storage(self._capacity, shape, dt)
        if dt.type(fill) != 0:
            data[: self._n] = fill

    def _allocate(self, n: int) -> None:
        """Fresh storage for at least ``n`` tiles (keys, layers and clear dirty flags; the
        caller fills them): the reserved capacity if the system grants it, else just
        enough."""
        need = max(n, self._min_capacity)
        for capacity in dict.fromkeys((max(need, self._reserve), need)):
            try:
                data = {
                    name: _storage(capacity, shape, dt)
                    for name, (dt, _fill, shape) in self._specs.items()
                }
            except (OSError, MemoryError):
                if capacity == need:
                    raise
                continue  # the reservation was refused: allocate what is needed
            break
        self._capacity = capacity
        self._keys = np.zeros((capacity, 2), np.int64)
        self._data = data
        self._dirty = {loop: np.zeros(capacity, bool) for loop in self._loops}

    @property
    def tile_nbytes(self) -> int:
        """Bytes of one tile over all layers."""
        return sum(dt.itemsize * math.prod(shape) for dt, _fill, shape in self._specs.values())

    def layer(self, name: str) -> np.ndarray:
        """Storage of a layer, shape ``(capacity, *shape)``, indexed by slot.

        Only the first :attr:`n_tiles` entries are tiles; the array is replaced when the
        capacity grows, so do not keep it across :meth:`ensure` calls.
        """
        try:
            return self._data[name]
        except KeyError:
            raise KeyError(f"no layer {name!r}; layers are {list(self._specs)}") from None

    # ------------------------------------------------------------------ tiles
    @property
    def n_tiles(self) -> int:
        """Number of allocated tiles."""
        return self._n

    @property
    def keys(self) -> np.ndarray:
        """Tile coordinates ``(tile_row, tile_col)`` of each slot, int64 (n_tiles, 2)."""
        return self._keys[: self._n]

    @property
    def tile_bbox(self) -> tuple[int, int, int, int] | None:
        """``(tile_row0, tile_col0, tile_row1, tile_col1)`` (end exclusive) or None if empty."""
        return self._bbox

    @property
    def pixel_bbox(self) -> tuple[int, int, int, int] | None:
        """Pixel bounding box ``(row0, col0, row1, col1)`` of the allocated tiles (end
        exclusive), or None if no tile is allocated."""
        if self._bbox is None:
            return None
        t = self.tile_px
        r0, c0, r1, c1 = self._bbox
        return (r0 * t, c0 * t, r1 * t, c1 * t)

    @property
    def slot_grid(self) -> tuple[np.ndarray, tuple[int, int]]:
        """Dense tile index: ``(grid, (tile_row0, tile_col0))``.

        ``grid[tr - tile_row0, tc - tile_col0]`` is the slot of tile ``(tr, tc)`` or -1.
        int32, covering at least :attr:`tile_bbox` (tiles outside the grid are absent).
        """
        return self._grid, self._grid_origin

    def lookup(self, tile_rows, tile_cols) -> np.ndarray:
        """Slots of tiles (vectorised); -1 for tiles that are not allocated.

        Parameters
        ----------
        tile_rows, tile_cols : int arrays (broadcast together)

        Returns
        -------
        int64 array of the broadcast shape.
        """
        tr = np.asarray(tile_rows, np.int64) - self._grid_origin[0]
        tc = np.asarray(tile_cols, np.int64) - self._grid_origin[1]
        tr, tc = np.broadcast_arrays(tr, tc)
        gh, gw = self._grid.shape
        inside = (tr >= 0) & (tr < gh) & (tc >= 0) & (tc < gw)
        out = np.full(tr.shape, -1, np.int64)
        out[inside] = self._grid[tr[inside], tc[inside]]
        return out

    def check_extent(self, tile_rows, tile_cols) -> None:
        """Raise ValueError if allocating these tiles would exceed ``max_grid_cells``.

        Changes nothing; :meth:`ensure` calls it before allocating.
        """
        tr = np.asarray(tile_rows, np.int64).ravel()
        tc = np.asarray(tile_cols, np.int64).ravel()
        if tr.size == 0:
            return
        lo_r, hi_r, lo_c, hi_c = int(tr.min()), int(tr.max()) + 1, int(tc.min()), int(tc.max()) + 1
        if self._bbox is not None:
            lo_r, lo_c = min(lo_r, self._bbox[0]), min(lo_c, self._bbox[1])
            hi_r, hi_c = max(hi_r, self._bbox[2]), max(hi_c, self._bbox[3])
        cells = (hi_r - lo_r) * (hi_c - lo_c)
        if cells > self.max_grid_cells:
            t = self.tile_px
            raise ValueError(
                f"tiles: the map would span {hi_r - lo_r} x {hi_c - lo_c} tiles of {t} px "
                f"({(hi_r - lo_r) * t} x {(hi_c - lo_c) * t} px); expected at most "
                f"{self.max_grid_cells} tiles in its bounding box (max_grid_cells)"
            )

    def check_extent_box(self, tile_row0: int, tile_col0: int, tile_row1: int, tile_col1: int):
        """:meth:`check_extent` for the tiles of a rectangle ``[row0, row1) x [col0, col1)``
        (tile coordinates, end exclusive); pure Python, for per-scan use."""
        lo_r, lo_c, hi_r, hi_c = int(tile_row0), int(tile_col0), int(tile_row1), int(tile_col1)
        if self._bbox is not None:
            b = self._bbox
            if lo_r >= b[0] and lo_c >= b[1] and hi_r <= b[2] and hi_c <= b[3]:
                return
            lo_r, lo_c = min(lo_r, b[0]), min(lo_c, b[1])
            hi_r, hi_c = max(hi_r, b[2]), max(hi_c, b[3])
        self.check_extent([lo_r, hi_r - 1], [lo_c, hi_c - 1])

    def neighbour_slots(self) -> np.ndarray:
        """Slots of the 3 x 3 tiles around every tile, int64 (n_tiles, 9), -1 if absent.

        Column ``3 * (dr + 1) + (dc + 1)`` holds the tile at offset ``(dr, dc)``.  Cached
        until tiles are added (the incremental loops ask for it several times per update);
        the returned array is read-only.
        """
        if self._nbr9 is None:
            k = self.keys
            dr = np.repeat(np.arange(-1, 2), 3)
            dc = np.tile(np.arange(-1, 2), 3)
            nbr = self.lookup(k[:, 0:1] + dr[None, :], k[:, 1:2] + dc[None, :])
            nbr.flags.writeable = False
            self._nbr9 = nbr
        return self._nbr9

    def ensure(self, tile_rows, tile_cols) -> tuple[np.ndarray, int]:
        """Allocate the tiles that do not exist yet.

        Parameters
        ----------
        tile_rows, tile_cols : int arrays of the same shape
            Tile coordinates (duplicates allowed).

        Returns
        -------
        slots : int64 array, same shape
            Slot of every requested tile.
        n_new : int
            Number of newly allocated tiles (new tiles get their layers' fill values and
            are marked dirty in every loop).
        """
        tr = np.asarray(tile_rows, np.int64)
        tc = np.asarray(tile_cols, np.int64)
        slots = self.lookup(tr, tc)
        missing = slots < 0
        if not missing.any():
            return slots, 0
        self.check_extent(tr[missing], tc[missing])
        packed = unique_pairs(tr[missing], tc[missing])
        n_new = packed.shape[0]
        self._grow_capacity(self._n + n_new)
        self._grow_grid(packed)
        new_slots = np.arange(self._n, self._n + n_new)
        self._keys[new_slots] = packed
        for name, (dt, fill, _shape) in self._specs.items():
            if dt.type(fill) != 0:  # unused capacity of the other layers is zero already
                self._data[name][new_slots] = fill
        for flags in self._dirty.values():
            flags[new_slots] = True
        g0 = self._grid_origin
        self._grid[packed[:, 0] - g0[0], packed[:, 1] - g0[1]] = new_slots
        self._n += n_new
        self._nbr9 = None
        lo = packed.min(axis=0)
        hi = packed.max(axis=0) + 1
        if self._bbox is None:
            self._bbox = (int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1]))
        else:
            b = self._bbox
            self._bbox = (
                min(b[0], int(lo[0])),
                min(b[1], int(lo[1])),
                max(b[2], int(hi[0])),
                max(b[3], int(hi[1])),
            )
        return self.lookup(tr, tc), n_new

    def prepare_growth(self, submit, *, fraction: float = 0.75) -> bool:
        """Page in the storage of the next capacity growth ahead of time, off the caller's
        thread.

        Growing copies every tile into new memory, and on a first touch each page of it
        costs a page fault: a stall on large maps.  Once the tiles fill ``fraction`` of the
        capacity, this allocates the next storage and submits a job that writes the part
        the growth will copy into (as much as the current capacity), so that the growth
        only copies.  The job touches nothing else; the growth waits for it.

        Parameters
        ----------
        submit : callable
            ``submit(fn) -> future`` (e.g. ``ThreadPoolExecutor.submit``).
        fraction : float
            Fill level that starts the job.

        Returns
        -------
        bool
            Whether a job was started.
        """
        if self._spare is not None or self._n < fraction * self._capacity:
            return False
        cap = GROWTH_FACTOR * self._capacity
        spare = {name: _storage(cap, shape, dt) for name, (dt, _f, shape) in self._specs.items()}
        used = self._capacity

        def page_in():
            for arr in spare.values():
                arr[:used] = 0

        self._spare = spare
        self._spare_job = submit(page_in)
        return True

    def _grow_capacity(self, need: int) -> None:
        if need <= self._capacity:
            return
        cap = max(need, GROWTH_FACTOR * self._capacity)
        spare, job = self._spare, self._spare_job
        self._spare = self._spare_job = None
        if job is not None:
            job.result()  # the job writes only the spare arrays
        keys = np.zeros((cap, 2), np.int64)
        keys[: self._n] = self._keys[: self._n]
        self._keys = keys
        for name, (dt, _fill, shape) in self._specs.items():
            # Copy the tiles only: the unused capacity is zero and untouched (its pages stay
            # unmapped until used); :meth:`ensure` writes the fill of nonzero-filled layers
            # into each slot it allocates.
            arr = spare.get(name) if spare is not None else None
            if arr is None or arr.shape[0] < cap:
                arr = _storage(cap, shape, dt)
            arr[: self._n] = self._data[name][: self._n]
            self._data[name] = arr
        for loop, flags in self._dirty.items():
            new = np.zeros(cap, bool)
            new[: self._n] = flags[: self._n]
            self._dirty[loop] = new
        self._capacity = cap

    def _grow_grid(self, packed: np.ndarray) -> None:
        gh, gw = self._grid.shape
        g0r, g0c = self._grid_origin
        lo_r, lo_c = (int(v) for v in packed.min(axis=0))
        hi_r, hi_c = (int(v) + 1 for v in packed.max(axis=0))
        if gh and gw and lo_r >= g0r and lo_c >= g0c and hi_r <= g0r + gh and hi_c <= g0c + gw:
            return
        if self._bbox is not None:
            lo_r, lo_c = min(lo_r, self._bbox[0]), min(lo_c, self._bbox[1])
            hi_r, hi_c = max(hi_r, self._bbox[2]), max(hi_c, self._bbox[3])
        # Slack on each side (a quarter of the extent, at least 2 tiles), capped so that
        # the grid never exceeds max_grid_cells.
        sr = max(2, (hi_r - lo_r) // 4)
        sc = max(2, (hi_c - lo_c) // 4)
        while sr or sc:
            if (hi_r - lo_r + 2 * sr) * (hi_c - lo_c + 2 * sc) <= self.max_grid_cells:
                break
            sr, sc = sr // 2, sc // 2
        nr0, nc0 = lo_r - sr, lo_c - sc
        grid = np.full((hi_r - lo_r + 2 * sr, hi_c - lo_c + 2 * sc), -1, np.int32)
        if gh and gw:
            grid[g0r - nr0 : g0r - nr0 + gh, g0c - nc0 : g0c - nc0 + gw] = self._grid
        self._grid = grid
        self._grid_origin = (nr0, nc0)

    # ------------------------------------------------------------------ windows
    def read(self, name: str, row0: int, col0: int, height: int, width: int, fill=None):
        """Dense copy of a layer over a pixel window (global pixel coordinates).

        Parameters
        ----------
        name : str
            A ``(T, T)`` layer.
        row0, col0 : int
            Global pixel of the window's top-left corner.
        height, width : int
            Window size in pixels.
        fill : scalar, optional
            Value of pixels in tiles that are not allocated (default: the layer's fill).

        Returns
        -------
        array, shape (height, width), the layer's dtype.
        """
        dt, lfill, shape = self._specs[name]
        t = self.tile_px
        if shape != (t, t):
            raise ValueError(f"layer {name!r} has per-tile shape {shape}, not ({t}, {t})")
        out = np.full((height, width), lfill if fill is None else fill, dt)
        if height <= 0 or width <= 0 or self._n == 0:
            return out
        data = self._data[name]
        grid = self._grid
        g0r, g0c = self._grid_origin
        gh, gw = grid.shape
        for tr in range(row0 // t, (row0 + height - 1) // t + 1):
            if not 0 <= tr - g0r < gh:
                continue
            row = grid[tr - g0r].tolist()  # plain ints: no per-tile NumPy call
            for tc in range(col0 // t, (col0 + width - 1) // t + 1):
                slot = row[tc - g0c] if 0 <= tc - g0c < gw else -1
                if slot < 0:
                    continue
                r_lo, r_hi = max(row0, tr * t), min(row0 + height, (tr + 1) * t)
                c_lo, c_hi = max(col0, tc * t), min(col0 + width, (tc + 1) * t)
                out[r_lo - row0 : r_hi - row0, c_lo - col0 : c_hi - col0] = data[
                    slot, r_lo - tr * t : r_hi - tr * t, c_lo - tc * t : c_hi - tc * t
                ]
        return out

    def write(self, name: str, row0: int, col0: int, values: np.ndarray, mask=None) -> None:
        """Write a dense window into a ``(T, T)`` layer of the allocated tiles.

        Parameters
        ----------
        name : str
        row0, col0 : int
            Global pixel of ``values[0, 0]``.
        values : array, shape (h, w)
        mask : bool array, shape (h, w), optional
            Write only where True (default everywhere).  Pixels of tiles that are not
            allocated must not be selected: ValueError.
        """
        values = np.asarray(values)
        h, w = values.shape
        t = self.tile_px
        data = self._data[name]
        for tr in range(row0 // t, (row0 + h - 1) // t + 1):
            for tc in range(col0 // t, (col0 + w - 1) // t + 1):
                r_lo, r_hi = max(row0, tr * t), min(row0 + h, (tr + 1) * t)
                c_lo, c_hi = max(col0, tc * t), min(col0 + w, (tc + 1) * t)
                src = (slice(r_lo - row0, r_hi - row0), slice(c_lo - col0, c_hi - col0))
                slot = int(self.lookup(tr, tc))
                if slot < 0:
                    if mask is None or np.asarray(mask)[src].any():
                        raise ValueError(
                            f"write to layer {name!r}: tile ({tr}, {tc}) is not allocated"
                        )
                    continue
                dst = data[slot, r_lo - tr * t : r_hi - tr * t, c_lo - tc * t : c_hi - tc * t]
                if mask is None:
                    dst[...] = values[src]
                else:
                    m = np.asarray(mask)[src]
                    dst[m] = values[src][m]

    # ------------------------------------------------------------------ dirty sets
    @property
    def loops(self) -> tuple[str, ...]:
        """Names of the loops with dirty sets."""
        return self._loops

    def mark_dirty(self, loop: str, slots) -> None:
        """Mark tiles (slots; negative entries ignored) dirty for ``loop``."""
        s = np.asarray(slots, np.int64).ravel()
        self._dirty[loop][s[s >= 0]] = True

    def dirty_flags(self, loop: str) -> np.ndarray:
        """The dirty flags of ``loop`` themselves, bool (capacity,), indexed by slot (for
        compiled kernels that mark tiles; replaced when the capacity grows, like the
        layers)."""
        return self._dirty[loop]

    def dirty(self, loop: str) -> np.ndarray:
        """Slots of the tiles dirty for ``loop``, int64, ascending."""
        return np.flatnonzero(self._dirty[loop][: self._n])

    def clear_dirty(self, loop: str, slots=None) -> None:
        """Clear the dirty flags of ``loop`` (all tiles, or only ``slots``)."""
        if slots is None:
            self._dirty[loop][: self._n] = False  # unused capacity is never set
        else:
            self._dirty[loop][np.asarray(slots, np.int64)] = False

    # ------------------------------------------------------------------ state
    def state(self) -> dict[str, np.ndarray]:
        """The complete state as arrays (for saving): tile keys, layers, dirty flags,
        grid.  Keys: ``keys``, ``layer/<name>``, ``dirty/<loop>``, ``grid``,
        ``grid_origin``, ``bbox``, ``tile_px``."""
        n = self._n
        out: dict[str, np.ndarray] = {
            "tile_px": np.asarray(self.tile_px, np.int64),
            "keys": self._keys[:n].copy(),
            "grid": self._grid.copy(),
            "grid_origin": np.asarray(self._grid_origin, np.int64),
            "bbox": np.asarray(self._bbox if self._bbox is not None else (0, 0, 0, 0), np.int64),
            "has_bbox": np.asarray(self._bbox is not None),
            "max_grid_cells": np.asarray(self.max_grid_cells, np.int64),
        }
        for name in self._specs:
            out[f"layer/{name}"] = self._data[name][:n].copy()
        for loop in self._loops:
            out[f"dirty/{loop}"] = self._dirty[loop][:n].copy()
        return out

    def load_state(self, state: dict[str, np.ndarray]) -> None:
        """Replace the tiles by a :meth:`state` of a manager with the same tile size,
        layers and loops.  Raises ValueError naming the first inconsistent entry (a
        missing, extra or mis-shaped one)."""
        want = {f"layer/{name}" for name in self._specs} | {f"dirty/{loop}" for loop in self._loops}
        got = {k for k in state if k.startswith(("layer/", "dirty/"))}
        for key in sorted(want ^ got):
            which = "lacks" if key in want else "has the extra entry"
            raise ValueError(
                f"tile state {which} {key!r} (expected the layers {sorted(self._specs)} and "
                f"the loops {sorted(self._loops)})"
            )
        for key in ("tile_px", "keys", "grid", "grid_origin", "bbox", "has_bbox"):
            if key not in state:  # checked before anything changes
                raise ValueError(f"tile state lacks {key!r}")
        if int(state["tile_px"]) != self.tile_px:
            raise ValueError(
                f"tile state: tile_px: expected {self.tile_px}, received {int(state['tile_px'])}"
            )
        keys = np.asarray(state["keys"], np.int64)
        if keys.ndim != 2 or keys.shape[1] != 2:
            raise ValueError(f"tile state: keys: expected shape (n, 2), received {keys.shape}")
        n = keys.shape[0]
        arrays = {}
        for name, (dt, _fill, shape) in self._specs.items():
            arr = np.asarray(state[f"layer/{name}"])
            if arr.shape != (n, *shape) or arr.dtype != dt:
                raise ValueError(
                    f"tile state: layer {name!r}: expected {(n, *shape)} {dt}, "
                    f"received {arr.shape} {arr.dtype}"
                )
            arrays[name] = arr
        dirty = {}
        for loop in self._loops:
            arr = np.asarray(state[f"dirty/{loop}"])
            if arr.shape != (n,) or arr.dtype != bool:
                raise ValueError(f"tile state: dirty flags of {loop!r} have shape {arr.shape}")
            dirty[loop] = arr
        grid = np.asarray(state["grid"], np.int32)
        origin = tuple(int(v) for v in state["grid_origin"])
        if grid.ndim != 2 or len(origin) != 2:
            raise ValueError(f"tile state: bad grid shape {grid.shape}")
        valid = grid[grid >= 0]
        if valid.size != n or (n and (np.sort(valid) != np.arange(n)).any()):
            raise ValueError("tile state: the tile index does not match the tile keys")
        gr, gc = np.nonzero(grid >= 0)
        if n and not np.array_equal(
            keys[grid[gr, gc]], np.stack([gr + origin[0], gc + origin[1]], axis=1)
        ):
            raise ValueError("tile state: the tile index does not match the tile keys")
        box = tuple(int(v) for v in state["bbox"]) if bool(state["has_bbox"]) else None
        if box != (None if n == 0 else (*keys.min(0).tolist(), *(keys.max(0) + 1).tolist())):
            raise ValueError(f"tile state: bbox {box} is not the box of the tile keys")
        self._allocate(n)  # replaces nothing if it fails
        self._spare = self._spare_job = None
        self._keys[:n] = keys
        for name in self._specs:
            self._data[name][:n] = arrays[name]
        for loop in self._loops:
            self._dirty[loop][:n] = dirty[loop]
        self._grid = grid.copy()
        self._grid_origin = (origin[0], origin[1])
        self._n = n
        self._nbr9 = None
        self._bbox = box


__all__ += ["MAX_GRID_CELLS", "TileManager"]
