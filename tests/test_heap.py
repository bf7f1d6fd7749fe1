"""The numba min-heap against Python's heapq: the same keys come out in the same order,
each with the value pushed beside it."""

from __future__ import annotations

import heapq

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from topojax._heap import heap_pop, heap_push

_ops = st.lists(st.one_of(st.integers(-50, 50), st.none()), max_size=60)


def _pop(keys, vals, size):
    """The smallest key and its value (the key itself without values)."""
    val = keys[0] if vals is None else vals[0]
    key, new_size = heap_pop(keys, vals, size)
    assert new_size == size - 1
    return key, val


def _run(ops, keys, vals):
    """Apply pushes (numbers) and pops (None, when the heap holds something) to the heap
    and to heapq; return what each popped."""
    mine, ref, size, ref_heap = [], [], 0, []
    for i, op in enumerate(ops):
        if op is None:
            if size:
                mine.append(_pop(keys, vals, size))
                size -= 1
                ref.append(heapq.heappop(ref_heap))
        else:
            size = heap_push(keys, vals, size, keys.dtype.type(op), i)
            heapq.heappush(ref_heap, (op, i))
    while size:
        mine.append(_pop(keys, vals, size))
        size -= 1
        ref.append(heapq.heappop(ref_heap))
    return mine, ref


@settings(max_examples=60, deadline=None)
@given(_ops)
def test_keys_with_values_pop_in_heapq_order(ops):
    keys = np.empty(len(ops) + 1, np.float64)
    vals = np.empty(len(ops) + 1, np.int64)
    mine, ref = _run(ops, keys, vals)
    assert [k for k, _ in mine] == [float(k) for k, _ in ref]
    # equal keys may come out in any order, but each with a value pushed with that key
    for key in {k for k, _ in ref}:
        assert sorted(v for k, v in mine if k == key) == sorted(v for k, v in ref if k == key)


@settings(max_examples=60, deadline=None)
@given(_ops)
def test_keys_alone_pop_in_heapq_order(ops):
    keys = np.empty(len(ops) + 1, np.int64)
    mine, ref = _run(ops, keys, None)
    assert [k for k, _ in mine] == [k for k, _ in ref]
