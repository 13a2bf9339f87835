"""Stop 38, the fault monitor's room: the 10 Hz samples' products moved from numpy into
compiled calls give numpy's numbers bit for bit (autopilot/monitor/stats.py: ``a.dot(b)``
and ``np.linalg.solve`` as OpenBLAS sums them, with fused multiply-adds)."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.lateral import AEROSONDE_LAT
from autopilot.monitor.stats import blas_dot, blas_matvec, solve3


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

