"""Stop 38, the fault monitor's room: the 10 Hz samples' products moved from numpy into
compiled calls (autopilot/monitor/stats.py: ``a.dot(b)`` and ``np.linalg.solve`` summed
as OpenBLAS's FMA kernels sum them) agree with numpy to rounding error on any machine
(bit for bit where numpy's OpenBLAS uses those kernels: the flights checked that)."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.lateral import AEROSONDE_LAT
from autopilot.monitor.stats import blas_dot, blas_matvec, solve3

EPS = np.finfo(float).eps


def test_dot_and_matvec_agree_with_numpy():
    """Within the rounding bound of a sum of n products, 2 n eps sum |x_i y_i|."""
    rng = np.random.default_rng(38)
    for _ in range(30000):
        n = (2, 3)[int(rng.integers(2))]
        P = rng.standard_normal((n, n)) * rng.choice((1e-6, 1.0, 1e4))
        h = rng.standard_normal(n)
        c = rng.standard_normal(n) * rng.choice((1e-3, 1.0, 1e3))
        assert abs(blas_dot(h, c) - h.dot(c)) <= 2 * n * EPS * np.abs(h * c).sum()
        out = np.empty(n)
        blas_matvec(P, h, out)
        assert np.all(np.abs(out - P.dot(h)) <= 2 * n * EPS * (np.abs(P) @ np.abs(h)))


def test_solve3_agrees_with_numpys_solve():
    """Random, badly scaled and the Aerosonde's lateral balance (its matrix, the
    right-hand sides of its turns): within the condition number's bound of numpy's
    solution, floats out; a singular matrix raises."""
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
        assert all(type(v) is float for v in got)
        x = np.linalg.solve(A, y)
        bound = 64 * EPS * np.linalg.cond(A) * np.abs(x).max()
        assert np.abs(np.array(got) - x).max() <= bound
    try:
        solve3(np.zeros((3, 3)), 1.0, 2.0, 3.0)
    except ZeroDivisionError:
        pass
    else:
        raise AssertionError("a singular matrix solved")
