"""The event calendar pops keys in exact time order under arbitrary updates."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edmd._core.queue import calendar_shape, new_queue, queue_build, queue_top, queue_update


def _pop_all(q, n_ops, rng, t_now=0.0):
    """Pop like the event loop does: the top gets a new later key (or inf); check the order."""
    key = q[0]
    out = []
    for _ in range(n_ops):
        i = queue_top(q)
        if i < 0:
            break
        t = key[i]
        assert t == key[np.isfinite(key)].min() if np.isfinite(key).any() else True
        assert t >= t_now
        t_now = t
        out.append(t)
        # the event is processed: new key later, and a random other particle changes too
        queue_update(q, i, t + rng.exponential(1.0) if rng.random() < 0.95 else np.inf)
        j = rng.integers(len(key))
        if np.isfinite(key[j]):
            queue_update(q, j, t_now + rng.exponential(0.5))
    return out


@pytest.mark.parametrize("n", [1, 7, 500])
@pytest.mark.parametrize("per_bucket", [0.5, 8.0, 1000.0])
def test_calendar_pops_in_order(n, per_bucket, rng):
    keys = rng.exponential(1.0, n)
    width, nb = calendar_shape(keys.copy(), 0.0, per_bucket)  # (sorts its keys)
    q = new_queue(n, nb)
    queue_build(q, keys, 0.0, width, nb)
    out = _pop_all(q, 20 * n, rng)
    assert np.all(np.diff(out) >= 0)


def test_all_infinite_keys_mean_no_event():
    q = new_queue(3, 4)
    queue_build(q, np.full(3, np.inf), 0.0, 1.0, 4)
    assert queue_top(q) == -1


def test_far_future_keys_are_found_after_laps(rng):
    keys = np.array([1e6, 2e6, np.inf, 5.0])
    q = new_queue(4, 8)
    queue_build(q, keys, 0.0, 0.1, 8)
    order = []
    for _ in range(3):
        i = queue_top(q)
        order.append(i)
        queue_update(q, i, np.inf)
    assert order == [3, 0, 1]
    assert queue_top(q) == -1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0, 100, allow_nan=False), min_size=1, max_size=60), st.integers(1, 50), st.floats(0.01, 10))
def test_calendar_matches_a_sorted_list(keys, nb, width):
    keys = np.array(keys)
    q = new_queue(len(keys), nb)
    queue_build(q, keys.copy(), 0.0, width, nb)
    popped = []
    for _ in range(len(keys)):
        i = queue_top(q)
        popped.append(keys[i])
        queue_update(q, i, np.inf)
    assert popped == sorted(keys.tolist())
