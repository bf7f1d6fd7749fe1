"""Gaussian max-splat distance maps as JAX kernels on fixed-size tiles.

The paper's distance map puts a Gaussian on every obstacle pixel and keeps the per-pixel
maximum::

    H(x) = max_p exp(-|x - p|^2 / (2 sigma^2)),   p obstacle, |x - p|_inf <= R

Because the Gaussian decreases with distance, ``H(x) = exp(-d(x)^2 / (2 sigma^2))`` where
``d(x)`` is the distance to the nearest obstacle *inside the square window* of half-width
``R`` around ``x``.  This module computes that windowed squared distance exactly, in
integers, with a separable two-pass algorithm that runs as one jitted kernel per tile:

1. along columns: distance to the nearest obstacle within ``R`` rows, from two
   associative scans (last obstacle above, next obstacle below);
2. along rows: ``d^2(r, c) = min_{|k| <= R} g(r, c + k) + k^2`` (``g`` from pass 1).  The
   offsets run in increasing ``|k|`` and stop, per band of rows, as soon as ``k^2`` is not
   below the largest current best of the band: no larger offset can improve any pixel
   there.  The early exit is exact, and it makes the cost scale with the local clearance
   instead of with ``R``.

Every number here is an integer until the final ``exp``, so the tiled result does not
depend on the tiling.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

__all__ = ["FAR_SQ", "window_sq_distance_tile", "gaussian_from_sq_distance"]

#: Squared-distance value of pixels with no obstacle inside their window.
FAR_SQ = 1 << 30

_BAND_ROWS = 16
_UNROLL = 4


def window_sq_distance_tile(patch: jax.Array, *, out_px: int, half_width: int) -> jax.Array:
    """Windowed squared distance to the nearest obstacle for one tile.

    Pure function of one fixed-size patch; batch it with :func:`jax.vmap` or
    :func:`jax.lax.map`.

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
    r = half_width
    size = out_px + 2 * r
    if patch.shape != (size, size):
        raise ValueError(f"patch must have shape {(size, size)}, got {patch.shape}")
    far = jnp.int32(FAR_SQ)
    big = jnp.int32(1 << 24)

    # Pass 1 (columns): nearest obstacle row above / below the output rows
    # [r, r + out_px).  The r halo rows on each side only matter through their last
    # (first) obstacle row, a single reduction; only the output rows need running scans.
    rows = jnp.arange(size, dtype=jnp.int32)[:, None]
    inner = slice(r, r + out_px)
    above0 = jnp.max(jnp.where(patch[:r], rows[:r], -big), axis=0)
    below0 = jnp.min(jnp.where(patch[r + out_px :], rows[r + out_px :], big), axis=0)
    above = _running(jnp.maximum, jnp.where(patch[inner], rows[inner], -big), above0)
    below = _running(jnp.minimum, jnp.where(patch[inner], rows[inner], big), below0, reverse=True)
    dv = jnp.minimum(rows[inner] - above, below - rows[inner])  # (out_px, size)
    g = jnp.where(dv <= r, dv * dv, far)

    # Upper bound on every pixel's answer from the nearest finite column site on each
    # side: running scans along the output columns carrying that site's column and value,
    # started from the last (first) site of the r halo columns on each side.
    cols = jnp.arange(size, dtype=jnp.int32)
    left_col, left_g = _last_site(g, cols, start=r, stop=r + out_px, reverse=False)
    right_col, right_g = _last_site(g, cols, start=r, stop=r + out_px, reverse=True)
    kl = cols[None, inner] - left_col
    kr = right_col - cols[None, inner]
    bound = jnp.minimum(
        jnp.where(kl <= r, left_g + kl * kl, far), jnp.where(kr <= r, right_g + kr * kr, far)
    )

    def step(k, best, gb):
        right_k = lax.dynamic_slice_in_dim(gb, r + k, out_px, axis=1)
        left_k = lax.dynamic_slice_in_dim(gb, r - k, out_px, axis=1)
        return jnp.minimum(best, jnp.minimum(left_k, right_k) + k * k)

    # Pass 2 (rows), by bands of rows: offsets k run while k^2 < the band's largest
    # upper bound; beyond it no offset can improve any pixel of the band (exact).
    n_bands = -(-out_px // _BAND_ROWS)
    pad_rows = n_bands * _BAND_ROWS - out_px
    g = jnp.pad(g, ((0, pad_rows), (0, 0)), constant_values=FAR_SQ)
    bound = jnp.pad(bound, ((0, pad_rows), (0, 0)), constant_values=FAR_SQ)

    def band(args):
        gb, ub = args
        worst = jnp.max(jnp.where(ub < far, ub, 0))
        # largest k with k^2 < worst, capped at R
        k_max = jnp.minimum(jnp.ceil(jnp.sqrt(worst.astype(jnp.float32))).astype(jnp.int32), r)
        k_max = jnp.where((k_max * k_max >= worst) & (k_max > 0), k_max - 1, k_max)
        # The bound is achieved by a real site, so it seeds the running best: offsets with
        # k^2 >= worst then cannot improve any pixel, and stopping there is exact.
        start = jnp.minimum(gb[:, r : r + out_px], ub)
        # Hand-unrolled by _UNROLL offsets (fori_loop cannot unroll dynamic bounds).
        # Overshooting k_max is harmless: a slice clamped at the patch edge only adds a
        # real site's cost plus a larger k^2, never less than the true minimum.

        def unrolled(i, b):
            for j in range(_UNROLL):
                b = step(1 + i * _UNROLL + j, b, gb)
            return b

        best = lax.fori_loop(0, (k_max + _UNROLL - 1) // _UNROLL, unrolled, start)
        return jnp.minimum(best, far)

    bands = g.reshape(n_bands, _BAND_ROWS, size)
    ubs = bound.reshape(n_bands, _BAND_ROWS, out_px)
    out = lax.map(band, (bands, ubs))
    return out.reshape(n_bands * _BAND_ROWS, out_px)[:out_px]


def _running(op, x: jax.Array, init: jax.Array, *, reverse: bool = False) -> jax.Array:
    """Running ``op`` (max or min) down axis 0, starting from ``init`` (shape ``x[0]``),
    with a sequential scan (fastest on CPU)."""

    def body(carry, row):
        carry = op(carry, row)
        return carry, carry

    _, out = lax.scan(body, init, x, reverse=reverse)
    return out


def _last_site(
    g: jax.Array, cols: jax.Array, *, start: int, stop: int, reverse: bool
) -> tuple[jax.Array, jax.Array]:
    """Column and value of the nearest finite entry of ``g`` at or before each column of
    ``[start, stop)`` (with ``reverse``: at or after).

    Columns outside ``[start, stop)`` enter through one reduction (the last finite site
    before ``start``, or the first after ``stop``); the scan runs over ``[start, stop)``
    only.  Returns two int32 arrays (rows, stop - start); a missing site gets a column
    2^24 away, beyond any window.
    """
    big = jnp.int32(1 << 24)
    far = jnp.int32(FAR_SQ)
    finite = g < far
    if reverse:
        outer = slice(stop, None)
        col0 = jnp.min(jnp.where(finite[:, outer], cols[outer], big), axis=1)
    else:
        outer = slice(0, start)
        col0 = jnp.max(jnp.where(finite[:, outer], cols[outer], -big), axis=1)
    found = jnp.abs(col0) < big
    val0 = jnp.take_along_axis(g, jnp.clip(col0, 0, g.shape[1] - 1)[:, None], axis=1)[:, 0]
    val0 = jnp.where(found, val0, far)

    def body(carry, xs):
        col, val = carry
        gcol, c = xs
        hit = gcol < far
        col = jnp.where(hit, c, col)
        val = jnp.where(hit, gcol, val)
        return (col, val), (col, val)

    inner = slice(start, stop)
    _, (col, val) = lax.scan(body, (col0, val0), (g[:, inner].T, cols[inner]), reverse=reverse)
    return col.T, val.T


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


@partial(jax.jit, static_argnames=("out_px", "half_width"))
def _window_sq_distance_tiles(patches: jax.Array, *, out_px: int, half_width: int) -> jax.Array:
    return lax.map(partial(window_sq_distance_tile, out_px=out_px, half_width=half_width), patches)


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
