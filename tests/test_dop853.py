"""The DOP853 tableau and the sums over its stages (the two-body solvers' steps)."""

import numpy as np

from edmd._core import dop853 as D


def test_the_sums_skip_only_zeros_of_the_tableau():
    """The stage and weight sums start after column 0 at ``stage_from(s)`` / ``WEIGHTS_FROM``:
    every entry they leave out is exactly zero, and the first one they keep is not."""
    for s in range(1, D.N_STAGES):
        start = D.stage_from(s)
        assert not D.A[s, 1:start].any()
        if start < s:
            assert D.A[s, start] != 0.0
    for w in (D.B, D.E5, D.E3):
        assert not w[1 : D.WEIGHTS_FROM].any() and w[D.WEIGHTS_FROM] != 0.0


def test_the_8th_order_weights_sum_to_one_and_the_error_weights_to_zero():
    """Consistency of the tableau (Hairer's dop853.f): each row of A sums to its node c, the
    weights B to 1 and the error estimators E5, E3 to 0."""
    assert np.allclose(D.A.sum(axis=1), D.C, rtol=0, atol=1e-14)
    assert abs(D.B.sum() - 1.0) < 1e-14
    assert abs(D.E5.sum()) < 1e-14 and abs(D.E3.sum()) < 1e-13
