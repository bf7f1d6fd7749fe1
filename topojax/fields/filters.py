"""Laplacian ridge detection on distance-map tiles (JAX).

OpenCV's ``Laplacian`` with aperture 3 or 5 is the sum of two separable second-derivative
filters, ``d2 (x) s`` along rows plus the same along columns, with

* ``ksize=3``: ``d2 = [1, -2, 1]``, ``s = [1, 2, 1]``;
* ``ksize=5``: ``d2 = [1, 0, -2, 0, 1]``, ``s = [1, 4, 6, 4, 1]``;

and ``ksize=1`` is the plain 3 x 3 cross ``[[0, 1, 0], [1, -4, 1], [0, 1, 0]]``.  At the map
border OpenCV uses ``BORDER_REFLECT_101`` (``... 2 1 | 0 1 2 ...``).  The ridge map is
``convertScaleAbs`` of the response (absolute value, rounded half to even, saturated to
0..255) compared with ``> threshold``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax import lax

__all__ = ["HALO_PX", "reflect_101_halo", "laplacian_valid", "ridge_from_laplacian"]

#: Halo (pixels on each side) a tile needs for the largest supported aperture.
HALO_PX = 2

_SEPARABLE = {
    3: ((1.0, -2.0, 1.0), (1.0, 2.0, 1.0)),
    5: ((1.0, 0.0, -2.0, 0.0, 1.0), (1.0, 4.0, 6.0, 4.0, 1.0)),
}


def reflect_101_halo(
    values: jax.Array, origin: jax.Array, map_shape: jax.Array, *, halo: int
) -> jax.Array:
    """Replace the parts of a tile's halo that lie outside the map by reflected values.

    Parameters
    ----------
    values : array, shape (S + 2 halo, S + 2 halo)
        Tile with its halo; ``values[halo + i, halo + j]`` is map pixel
        ``(origin[0] + i, origin[1] + j)``.
    origin : int32 array, shape (2,)
        Map (row, col) of the tile's first core pixel.  Traced: no recompile per tile.
    map_shape : int32 array, shape (2,)
        Map (rows, cols).  Traced: no recompile per map size.
    halo : int
        Halo width (static).

    Returns
    -------
    array, same shape and dtype: rows/cols outside ``[0, map_shape)`` hold the
    ``BORDER_REFLECT_101`` image of the inside (OpenCV's default border).
    """
    # Only the ``halo`` rows (cols) just outside each map edge can be read by the
    # Laplacian of a map pixel, so only those are replaced, by row (col) copies: a gather
    # of the whole tile costs more than the filter itself.  The reflection repeats with
    # period ``2 * last`` (OpenCV reflects again where one reflection leaves the map, as
    # on a map 2 pixels across), so every source lies inside the map; sources are read
    # before any write.
    out = values
    for axis in (0, 1):
        n = out.shape[axis]
        start = origin[axis] - halo
        last = map_shape[axis] - 1
        local_last = last - start
        targets = [jnp.int32(i) for i in range(halo)]
        targets += [local_last + 1 + i for i in range(halo)]
        rows = []
        for t in targets:
            glob = start + t
            src = jnp.remainder(jnp.abs(glob), 2 * last)  # maps have >= 2 pixels: last >= 1
            src = jnp.where(src > last, 2 * last - src, src)
            src = jnp.clip(src - start, 0, n - 1)
            inside = (t >= 0) & (t < n)
            rows.append((jnp.clip(t, 0, n - 1), inside, lax.dynamic_index_in_dim(out, src, axis)))
        for t, inside, row in rows:
            current = lax.dynamic_index_in_dim(out, t, axis)
            out = lax.dynamic_update_index_in_dim(out, jnp.where(inside, row, current), t, axis)
    return out


def laplacian_valid(values: jax.Array, *, ksize: int) -> jax.Array:
    """OpenCV-equivalent Laplacian on the interior of a haloed tile.

    Parameters
    ----------
    values : float32 array, shape (S + 4, S + 4)
        Tile with a 2-pixel halo (already border-reflected where it leaves the map).
    ksize : {1, 3, 5}
        Aperture (static).

    Returns
    -------
    float32 array, shape (S, S): the Laplacian of the core pixels.
    """
    n = values.shape[0]
    s = n - 2 * HALO_PX
    if ksize == 1:
        c = values[2 : 2 + s, 2 : 2 + s]
        return (
            values[1 : 1 + s, 2 : 2 + s]
            + values[3 : 3 + s, 2 : 2 + s]
            + values[2 : 2 + s, 1 : 1 + s]
            + values[2 : 2 + s, 3 : 3 + s]
            - 4.0 * c
        )
    d2, sm = _SEPARABLE[ksize]
    m = len(d2)
    off = HALO_PX - m // 2

    def along_rows(x: jax.Array, taps, rows_out: int) -> jax.Array:
        return sum(t * x[off + i : off + i + rows_out] for i, t in enumerate(taps) if t != 0.0)

    def along_cols(x: jax.Array, taps, cols_out: int) -> jax.Array:
        return sum(t * x[:, off + i : off + i + cols_out] for i, t in enumerate(taps) if t != 0.0)

    # d2/dcol2: second difference along columns, smoothing along rows; and vice versa.
    xx = along_rows(along_cols(values, d2, s), sm, s)
    yy = along_cols(along_rows(values, d2, s), sm, s)
    return xx + yy


def ridge_from_laplacian(
    lap: jax.Array, *, scale: jax.Array | float, threshold: jax.Array | float
) -> tuple[jax.Array, jax.Array]:
    """``convertScaleAbs`` and threshold.

    Parameters
    ----------
    lap : float32 array
        Laplacian of the unscaled [0, 1] distance map.
    scale : float
        Scale applied to the map before filtering (paper: 255); the Laplacian is linear.
    threshold : float
        Strict threshold on the rounded absolute response (paper: 10).

    Returns
    -------
    lap_abs : uint8 array, same shape: ``saturate(round_half_even(|scale * lap|))``.
    ridge : bool array, same shape: ``round_half_even(|scale * lap|) > threshold`` (equal
        to ``lap_abs > threshold`` for every threshold below 255).
    """
    mag = jnp.round(jnp.abs(lap * jnp.asarray(scale, jnp.float32)))
    lap_abs = jnp.clip(mag, 0, 255).astype(jnp.uint8)
    return lap_abs, mag > jnp.asarray(threshold, jnp.float32)
