"""A binary min-heap in preallocated numba arrays, with or without a value per key."""

from __future__ import annotations

from ._jit import cached_njit


@cached_njit(nogil=True)
def heap_push(keys, vals, size, key, val):
    """Push ``key`` (and ``val`` beside it, unless ``vals`` is None) on the heap held in
    ``keys[:size]`` / ``vals[:size]``; room for it is the caller's business.  Returns the
    new size."""
    i = size
    keys[i] = key
    if vals is not None:
        vals[i] = val
    while i > 0:
        p = (i - 1) >> 1
        if keys[p] <= keys[i]:
            break
        keys[p], keys[i] = keys[i], keys[p]
        if vals is not None:
            vals[p], vals[i] = vals[i], vals[p]
        i = p
    return size + 1


@cached_njit(nogil=True)
def heap_pop(keys, vals, size):
    """Pop the smallest key of the heap ``keys[:size]`` (its value, ``vals[0]``, is the
    caller's to read first); returns the key and the new size."""
    key = keys[0]
    size -= 1
    keys[0] = keys[size]
    if vals is not None:
        vals[0] = vals[size]
    i = 0
    while True:
        a = 2 * i + 1
        if a >= size:
            break
        if a + 1 < size and keys[a + 1] < keys[a]:
            a += 1
        if keys[i] <= keys[a]:
            break
        keys[a], keys[i] = keys[i], keys[a]
        if vals is not None:
            vals[a], vals[i] = vals[i], vals[a]
        i = a
    return key, size
