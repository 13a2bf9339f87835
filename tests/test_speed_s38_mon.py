"""Stop 38, the fault monitor's room: the 10 Hz samples' products moved from numpy into
compiled calls give numpy's numbers bit for bit (autopilot/monitor/stats.py: ``a.dot(b)``
and ``np.linalg.solve`` as OpenBLAS sums them, with fused multiply-adds), and the
elevator's stage 2 on one sample (actuator.stage2_scalar) is stats.stage2_update's step
on its one-row arrays."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.actuator import stage2_scalar
from autopilot.monitor.lateral import AEROSONDE_LAT
from autopilot.monitor.stats import blas_dot, blas_matvec, solve3, stage2_update


def test_dot_and_matvec_are_numpys_bit_for_bit():
    rng = np.random.default_rng(38)
    for _ in range(30000):
        n = (2, 3)[int(rng.integers(2))]
        P = rng.standard_normal((n, n)) * rng.choice((1e-6, 1.0, 1e4))
        h = rng.standard_normal(n)
        c = rng.standard_normal(n) * rng.choice((1e-3, 1.0, 1e3))
        assert blas_dot(h, c) == h.dot(c)
        out = np.empty(n)
        blas_matvec(P, h, out)
        assert np.array_equal(out, P.dot(h))


def test_solve3_is_numpys_solve_bit_for_bit():
    """Random, badly scaled and the Aerosonde's lateral balance (its matrix, the
    right-hand sides of its turns)."""
    rng = np.random.default_rng(83)
    A_aero = AEROSONDE_LAT._A_simple
    for i in range(30000):
        if i % 3 == 0:
            A = A_aero
            y = rng.standard_normal(3) * np.array((0.5, 0.02, 0.02))
        else:
            A = rng.standard_normal((3, 3)) * rng.choice((1e-3, 1.0, 1e3), size=(3, 3))
            y = rng.standard_normal(3)
        got = solve3(A, *y.tolist())
        assert got == tuple(np.linalg.solve(A, y).tolist())
        assert all(type(v) is float for v in got)


def test_elevator_stage2_is_stage2_update_on_one_row():
    rng = np.random.default_rng(5)
    for _ in range(2000):
        A = rng.standard_normal((2, 2))
        P = A @ A.T * 1e-4
        gamma = np.array((rng.uniform(0.5, 1.1), rng.normal(0.0, 0.02)))
        d, e, r, q = rng.normal(0.0, 0.1), rng.normal(0.0, 0.01), rng.uniform(1e-4, 1e-3), 1e-6
        g_ref, P_ref = stage2_update(gamma, P, np.array(((d, 1.0),)), np.array((e,)), np.array((r,)), q)
        stage2_scalar(gamma, P, d, e, r, q)      # (in place)
        assert np.array_equal(gamma, g_ref) and np.array_equal(P, P_ref)
