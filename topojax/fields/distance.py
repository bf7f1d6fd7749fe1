"""Gaussian max-splat distance maps as JAX kernels on fixed-size tiles.

``H(x) = max_p exp(-|x - p|^2 / (2 sigma^2))`` over obstacles ``p`` with
``|x - p|_inf <= R`` equals ``exp(-d^2 / (2 sigma^2))`` for the squared distance ``d^2``
to the nearest obstacle in the square window, which separates exactly into a column pass
(:func:`column_distance_tile`) and a row pass with an exact early exit
(:func:`row_sq_distance_tile`); :func:`window_sq_distance_tile` chains both on one patch.
Every number is an integer until the final ``exp``, so the result does not depend on the
tiling.  The algorithm is described in ``docs/design-fields.md``.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._constants import FAR_SQ

__all__ = [
    "FAR_SQ",
    "column_dtype",
    "column_distance_tile",
    "row_sq_distance_tile",
    "window_sq_distance_tile",
    "gaussian_from_sq_distance",
    "brute_force_distance_map",
]


# Row pass: rows per band (each band has its own early exit) and offsets per loop step
# (the loop's per-iteration cost on the CPU is worth a few offsets of overshoot).
_BAND_ROWS = 26
_UNROLL = 16
# "No candidate" (and saturation) value of the row pass's 16-bit lanes.
_TOP16 = 65535


def column_dtype(half_width: int) -> np.dtype:
    """Smallest unsigned dtype of the column pass for window half-width ``R``.

    Values ``0..R`` are distances; the dtype's maximum (``> R``) means "no obstacle
    within ``R`` rows".
    """
    if half_width < 255:
        return np.dtype(np.uint8)
    if half_width < 65535:
        return np.dtype(np.uint16)
    raise ValueError(f"half_width: expected a value < 65535 px, received {half_width}")


def column_distance_tile(strip: jax.Array, *, half_width: int) -> jax.Array:
    """Distance along each column to the nearest obstacle within ``R`` rows.

    Pure function of one fixed-size strip; batch it with :func:`jax.vmap`.

    Parameters
    ----------
    strip : bool array, shape (n + 2 R, w)
        Obstacle mask ``strip[row, col]``; the output row ``i`` is ``strip[R + i]``, and
        the ``R`` rows above and below are its halo.  Pixels outside the map: False.
    half_width : int
        Window half-width ``R`` in pixels (static).

    Returns
    -------
    array of :func:`column_dtype` (R), shape (n, w)
        ``min |dr|`` over obstacles ``strip[R + i + dr, j]`` with ``|dr| <= R``, or the
        dtype's maximum where there is none.
    """
    r = half_width
    size, width = strip.shape
    n = size - 2 * r
    if n < 1:
        raise ValueError(f"strip: expected more than 2 R = {2 * r} rows, received {size}")
    dtype = column_dtype(r)
    # Row indices in int16 where they fit (twice the lanes per vector of int32); "none"
    # sentinels stay clear of every row.
    index_dtype = jnp.int16 if size < (1 << 13) else jnp.int32
    big = jnp.array(1 << 14 if index_dtype == jnp.int16 else 1 << 24, index_dtype)
    rows = jnp.arange(size, dtype=index_dtype)[:, None]
    inner = slice(r, r + n)
    # The halo rows only matter through their last (first) obstacle row: one reduction
    # each; the running scans cover the output rows only.
    above0 = jnp.max(jnp.where(strip[:r], rows[:r], -big), axis=0)
    below0 = jnp.min(jnp.where(strip[r + n :], rows[r + n :], big), axis=0)
    above = _running(jnp.maximum, jnp.where(strip[inner], rows[inner], -big), above0)
    below = _running(jnp.minimum, jnp.where(strip[inner], rows[inner], big), below0, reverse=True)
    dv = jnp.minimum(rows[inner] - above, below - rows[inner])
    return jnp.where(dv <= r, dv, np.iinfo(dtype).max).astype(dtype)


def row_sq_distance_tile(
    column: jax.Array, *, half_width: int, needed: jax.Array | None = None
) -> jax.Array:
    """Windowed squared distance from the column pass, along rows.

    Pure function of one fixed-size patch; batch it with :func:`jax.lax.map` (each band of
    rows stops at its own offset, which :func:`jax.vmap` would equalise).

    Parameters
    ----------
    column : uint8 or uint16 array, shape (n, w + 2 R)
        Output of :func:`column_distance_tile` around the tile: output pixel ``(i, j)`` is
        ``column[i, R + j]``, with ``R`` halo columns on each side.  Columns outside the
        map must hold the "none" value (the dtype's maximum).
    half_width : int
        Window half-width ``R`` in pixels (static).
    needed : int32 array (4,), optional
        ``(row0, row1, col0, col1)``: only output pixels in ``[row0, row1) x [col0, col1)``
        are needed (traced, e.g. the part of a border tile that lies inside the map).  The
        others do not hold up a band's early exit, and their values are then unspecified
        (an upper bound).  Default: all pixels.

    Returns
    -------
    int32 array, shape (n, w)
        ``min (dr^2 + dc^2)`` over obstacles with ``|dr| <= R`` and ``|dc| <= R``, or
        :data:`FAR_SQ` where there is none (at the needed pixels).
    """
    r = half_width
    n, size = column.shape
    w = size - 2 * r
    if w < 1:
        raise ValueError(f"column: expected more than 2 R = {2 * r} columns, received {size}")
    far = jnp.int32(FAR_SQ)
    n_bands = -(-n // _BAND_ROWS)
    n_pad = n_bands * _BAND_ROWS
    none = np.iinfo(column.dtype).max
    column = jnp.pad(column, ((0, n_pad - n), (0, 0)), constant_values=none)
    rows = jnp.arange(n_pad, dtype=jnp.int32)[:, None]
    cols = jnp.arange(w, dtype=jnp.int32)[None, :]
    if needed is None:
        mask = rows < n
    else:
        needed = jnp.asarray(needed, jnp.int32)
        mask = (rows >= needed[0]) & (rows < jnp.minimum(needed[1], n))
        mask = mask & (cols >= needed[2]) & (cols < needed[3])
    mask = jnp.broadcast_to(mask, (n_pad, w)).reshape(n_bands, _BAND_ROWS, w)

    # Pixels with no obstacle anywhere in their window stay at FAR whatever the loop
    # does, so they must not hold up a band's exit (they would run all R offsets).  A
    # column "reaches" a band if any of the band's rows has an obstacle within R rows; a
    # pixel stays in its band's exit test if a reaching column lies in its window (the
    # union over the band's rows is conservative, so the exit stays exact).
    near = column <= r  # (n_pad, size): an obstacle within R rows
    reach = jnp.any(near.reshape(n_bands, _BAND_ROWS, size), axis=1)
    mask = mask & _window_any(reach, 2 * r + 1)[:, None, :w]

    # Bands run in 16-bit lanes (twice the pixels per vector) when no needed pixel's
    # squared distance can reach _TOP16; candidates then saturate there harmlessly.  A
    # pixel with a near column within h columns of it has d^2 <= R^2 + h^2 < _TOP16, so
    # only bands with a needed pixel without one ("lonely") run in int32.
    if r * r >= _TOP16:
        narrow = np.zeros(n_bands, bool)
    elif 2 * r * r < _TOP16:  # no windowed squared distance reaches _TOP16
        narrow = np.ones(n_bands, bool)
    else:
        # "near in every row of the band": makes more pixels lonely, never fewer (sound),
        # and is 26 times less work than row by row
        h = math.isqrt(_TOP16 - 1 - r * r)  # < R here
        near_all = jnp.all(near.reshape(n_bands, _BAND_ROWS, size), axis=1)
        lonely = ~_window_any(near_all, 2 * h + 1)[:, r - h : r - h + w]
        narrow = ~jnp.any(mask & lonely[:, None, :], axis=(1, 2))
    narrow = jnp.asarray(narrow)
    # squared column distances, "none" = the dtype's top; 16-bit where they fit
    v = column.astype(jnp.int32)
    if r * r < _TOP16:
        bands = jnp.where(v <= r, v * v, _TOP16).astype(jnp.uint16)
    else:
        bands = jnp.where(v <= r, v * v, far)
    bands = bands.reshape(n_bands, _BAND_ROWS, size)

    def run(selected, dtype, top, out):
        # the bands of ``selected``, in a loop whose trip count is their number
        index = jnp.nonzero(selected, size=n_bands, fill_value=0)[0]

        def body(i, out):
            b = index[i]
            gb = bands[b]
            if gb.dtype != dtype:  # 16-bit squares into int32: "none" becomes FAR
                gb = jnp.where(gb == _TOP16, far, gb.astype(jnp.int32))
            best = _band_min(gb, mask[b], half_width=r, width=w).astype(jnp.int32)
            return out.at[b].set(jnp.where(best == top, far, best))

        return lax.fori_loop(0, jnp.sum(selected, dtype=jnp.int32), body, out)

    out = jnp.zeros((n_bands, _BAND_ROWS, w), jnp.int32)
    if r * r < _TOP16:  # (static) a loop that can never run is not compiled
        out = run(narrow, jnp.uint16, _TOP16, out)
    if 2 * r * r >= _TOP16:
        out = run(~narrow, jnp.int32, FAR_SQ, out)
    return out.reshape(n_pad, w)[:n]


def _window_any(x: jax.Array, span: int) -> jax.Array:
    """``out[..., i] = any(x[..., i : i + span])`` for a bool array (last axis), by
    doubling window widths; the output has ``span - 1`` fewer columns."""
    m = 1
    while 2 * m <= span:  # x[..., i]: any of [i, i + m)
        x = x[..., :-m] | x[..., m:]
        m *= 2
    n = x.shape[-1] - (span - m)
    return x[..., :n] | x[..., span - m : span - m + n]


def _band_min(gb: jax.Array, mb: jax.Array, *, half_width: int, width: int) -> jax.Array:
    """Row pass of one band: ``min_{|k| <= R} gb[:, R + j + k] + k^2`` at every column
    ``j`` of the band, offsets in increasing ``|k|``, stopping once no pixel of ``mb`` can
    improve.

    ``gb`` (rows, width + 2 R) holds squared column distances: int32 with
    :data:`FAR_SQ` for "none", or uint16 with :data:`_TOP16` for "none", in which case
    every candidate saturates at ``_TOP16`` (exact below it; needs ``R^2 < _TOP16``).
    Returns the band's best, same dtype.
    """
    r, w = half_width, width
    narrow = gb.dtype == jnp.uint16

    def square(k):
        # k^2 in the band's dtype, saturated for the exit test of the last step
        return jnp.minimum(k * k, _TOP16).astype(jnp.uint16) if narrow else k * k

    def unfinished(best, k):
        # Is there a needed pixel that offsets >= k may still improve?  (A pixel whose
        # best is <= k^2 is final: every candidate from offsets >= k is >= k^2.)  A
        # boolean any rather than an int32 max reduction of the band's best.
        return jnp.any(mb & (best > square(k)))

    def cond(carry):
        k, _, more = carry
        return more & (k <= r)

    def body(carry):
        k, best, _ = carry
        # Hand-unrolled; offsets past R are clamped to R, which repeats a real candidate
        # and so cannot change the minimum.
        for j in range(_UNROLL):
            kk = jnp.minimum(k + j, r)
            right = lax.dynamic_slice_in_dim(gb, r + kk, w, axis=1)
            left = lax.dynamic_slice_in_dim(gb, r - kk, w, axis=1)
            nearer = jnp.minimum(left, right)
            if narrow:  # min(nearer + k^2, _TOP16) without overflow
                k2 = kk * kk
                nearer = jnp.minimum(nearer, (_TOP16 - k2).astype(jnp.uint16))
                best = jnp.minimum(best, nearer + k2.astype(jnp.uint16))
            else:
                best = jnp.minimum(best, nearer + kk * kk)
        k = k + _UNROLL
        return k, best, unfinished(best, k)

    best0 = gb[:, r : r + w]
    k0 = jnp.int32(1)
    _, best, _ = lax.while_loop(cond, body, (k0, best0, unfinished(best0, k0)))
    return best


def window_sq_distance_tile(patch: jax.Array, *, out_px: int, half_width: int) -> jax.Array:
    """Windowed squared distance to the nearest obstacle for one square patch.

    Both passes on one patch: :func:`column_distance_tile` over all its columns, then
    :func:`row_sq_distance_tile`.

    Parameters
    ----------
    patch : bool array, shape (out_px + 2 R, out_px + 2 R)
        Obstacle mask around the tile, ``patch[row, col]``; the output pixel ``(i, j)`` is
        ``patch[R + i, R + j]``.  Pixels outside the map must be False.
    out_px : int
        Side of the output square (static).
    half_width : int
        Window half-width ``R`` in pixels (static).

    Returns
    -------
    int32 array, shape (out_px, out_px)
        ``min (dr^2 + dc^2)`` over obstacles with ``|dr| <= R`` and ``|dc| <= R``, or
        :data:`FAR_SQ` where there is none.
    """
    size = out_px + 2 * half_width
    if patch.shape != (size, size):
        raise ValueError(f"patch: expected shape {(size, size)}, received {patch.shape}")
    column = column_distance_tile(patch, half_width=half_width)
    return row_sq_distance_tile(column, half_width=half_width)


def _running(op, x: jax.Array, init: jax.Array, *, reverse: bool = False) -> jax.Array:
    """Running ``op`` (max or min) down axis 0, starting from ``init`` (shape ``x[0]``),
    with a sequential scan (fastest on CPU)."""

    def body(carry, row):
        carry = op(carry, row)
        return carry, carry

    _, out = lax.scan(body, init, x, reverse=reverse)
    return out


def gaussian_from_sq_distance(d2: jax.Array, sigma_px: jax.Array | float) -> jax.Array:
    """Distance map value ``exp(-d^2 / (2 sigma^2))`` from squared pixel distances.

    Parameters
    ----------
    d2 : int32 array, any shape
        Squared distances in pixels^2 (:data:`FAR_SQ` gives 0).
    sigma_px : float
        Gaussian standard deviation in pixels.

    Returns
    -------
    float32 array, same shape, values in [0, 1].
    """
    scale = 1.0 / (2.0 * jnp.asarray(sigma_px, jnp.float32) ** 2)
    h = jnp.exp(-d2.astype(jnp.float32) * scale)
    return jnp.where(d2 >= FAR_SQ, jnp.float32(0), h)


def brute_force_distance_map(
    obstacles: np.ndarray, *, sigma_px: float, half_width_px: int
) -> np.ndarray:
    """Float64 NumPy max-splat, the paper's definition, for tests and benchmarks.

    Loops over the offsets of the square window and keeps the maximum of the shifted
    Gaussian weights: ``O(H W (2R+1)^2)``, so use it only on small maps.

    Parameters
    ----------
    obstacles : bool array, shape (H, W)
    sigma_px : float
    half_width_px : int

    Returns
    -------
    float64 array, shape (H, W)
    """
    obstacles = np.asarray(obstacles, dtype=bool)
    h, w = obstacles.shape
    r = int(half_width_px)
    out = np.zeros((h, w), np.float64)
    rows, cols = np.nonzero(obstacles)
    if rows.size == 0:
        return out
    padded = np.zeros((h + 2 * r, w + 2 * r), np.float64)
    dr = np.arange(-r, r + 1)
    kern = np.exp(-(dr[:, None] ** 2 + dr[None, :] ** 2) / (2.0 * sigma_px**2))
    for y, x in zip(rows.tolist(), cols.tolist(), strict=True):
        view = padded[y : y + 2 * r + 1, x : x + 2 * r + 1]
        np.maximum(view, kern, out=view)
    return padded[r : r + h, r : r + w]
