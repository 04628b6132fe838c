"""The shared counter of :mod:`erosim.kernels.work_queue`: every item taken exactly once, by any lanes."""

import numba
import numpy as np
import pytest
from numba import njit, prange

from erosim.kernels.work_queue import take


@njit(parallel=True)
def _take_all(n_items, lanes):
    """Lanes take items until none is left; returns how often each item was taken and by which lane."""
    counter = np.zeros(1, np.int64)
    times = np.zeros(n_items, np.int64)
    lane_of = np.full(n_items, -1, np.int64)
    work = np.zeros(n_items)
    for t in prange(lanes):
        while True:
            i = take(counter)
            if i >= n_items:
                break
            times[i] += 1  # item i is taken by one lane only: no other lane writes here
            # uneven work, as droplets of a batch: item i costs i % 97 units
            s = 0.0
            for k in range(1000 * (i % 97)):
                s += k * 1e-9
            work[i] = s  # kept, so that the work is done
            lane_of[i] = t
    return times, lane_of, counter  # read outside: the compiler does not see take() write it


@pytest.mark.parametrize("lanes", [1, 2, 7])
def test_every_item_is_taken_exactly_once(lanes):
    times, lane_of, final = _take_all(5000, lanes)
    assert np.all(times == 1)
    assert np.all((lane_of >= 0) & (lane_of < lanes))
    # each lane stops after one take past the end: the counter ends at items + lanes
    assert final[0] == 5000 + lanes


def test_take_refuses_anything_but_a_1d_int64_array():
    @njit
    def bad(a):
        return take(a)

    with pytest.raises(numba.core.errors.TypingError):
        bad(np.zeros(1, np.float64))
