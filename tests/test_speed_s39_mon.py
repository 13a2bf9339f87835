"""The fault monitor's per-sample work cut (stop 39), nothing else changed: a balance's
fit at a sample in one compiled call (actuator.offset_step: the lateral and thrust
balances' axes, the moment balance) against the dots and the least-squares step it
replaces (stats.blas_dot, actuator.rls_update on new regressor arrays), bit for bit."""
from __future__ import annotations

import random

import numpy as np
import pytest

from autopilot.monitor.actuator import FIT, LEFT, NO_FIT, offset_step, rls_update
from autopilot.monitor.stats import blas_dot


@pytest.mark.parametrize("n", [2, 3])
def test_offset_step_is_the_dot_and_the_fit_bit_for_bit(n):
    # GIVEN the same offset fit twice: one array (c in row 0, P under it), and c and P apart
    rng = random.Random(39 + n)
    fit = np.zeros((n + 1, n))
    fit[1:] = np.eye(n) * 0.25
    c, P = np.zeros(n), np.eye(n) * 0.25
    for k in range(2000):
        x = [rng.gauss(0.0, 0.3) for _ in range(2)]
        y = [rng.gauss(0.0, 0.3) for _ in range(2)]
        meas = rng.gauss(0.02, 0.01)
        mode = (NO_FIT, FIT, FIT, LEFT)[k % 4]
        # WHEN a sample's offset and the old sample's fit are taken in one call
        got = offset_step(fit, x[0], x[1], y[0], y[1], meas, mode)
        # THEN they are the separate calls' on the regressors as arrays, to the bit
        phi = np.array((1.0, *x))[:n]
        want_before = blas_dot(phi, c)
        want_e = 0.0
        ph = np.array((1.0, *y))[:n]
        if mode == FIT:
            want_e = rls_update(c, P, ph, meas)
        elif mode == LEFT:
            want_e = meas - blas_dot(ph, c)
        assert got == (want_before, want_e, blas_dot(phi, c))
        assert fit[0].tolist() == c.tolist() and fit[1:].tolist() == P.tolist()
    # (and the fit moved: the comparison was not of two untouched arrays)
    assert np.abs(c).max() > 1e-3
