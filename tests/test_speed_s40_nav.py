"""Stop 40's cheaper fusion set-up (autopilot/nav/ekf.py): the gate's products P H^T and
H P H^T by ``np.dot`` are the ``@`` products they replaced, bit for bit, for every batch
height the filter stacks (1 to 12 rows, H sparse) on both error-state sizes; and the
filter's gate statistics are those products."""
from __future__ import annotations

import numpy as np

from autopilot.nav import InsGpsEkf
from autopilot.nav.base import Batch


def _sparse_h(rng, m, n):
    H = np.zeros((12, n))
    for k in range(m):
        cols = rng.choice(n, rng.integers(1, 10), replace=False)
        H[k, cols] = rng.standard_normal(cols.size)
    return H[:m]                      # a view of the first rows, as the filter's buffer


def test_np_dot_is_the_matmul_bit_for_bit_on_the_gate_shapes():
    rng = np.random.default_rng(40)
    for trial in range(400):
        n = (19, 21)[trial % 2]
        A = rng.standard_normal((n, n))
        P = A @ A.T * 10.0 ** rng.uniform(-6, 3)
        H = _sparse_h(rng, 1 + trial % 12, n)
        PHt = np.dot(P, H.T)
        assert np.array_equal(PHt, P @ H.T)
        assert np.array_equal(np.dot(H, PHt), H @ (P @ H.T))


def test_the_gate_statistics_are_the_products():
    rng = np.random.default_rng(7)
    ekf = InsGpsEkf(vehicle="plane", cov_div=4)
    n = ekf.n
    A = rng.standard_normal((n, n))
    ekf._set_P(A @ A.T)
    m = 5
    H = _sparse_h(rng, m, n)
    z, h0, R = list(rng.standard_normal(m)), list(rng.standard_normal(m)), [0.5] * m
    b = Batch(["gps_pos", "baro", "mag"], [0, 3, 4], [3, 1, 1], [False] * 3, z, h0, R,
              [9.0] * m, H)
    ekf._gate_stats(b)
    S = H @ (ekf.P @ H.T)
    assert np.array_equal(b.Sd, S.diagonal() + np.array(R))
    assert np.array_equal(ekf._S, S) and b.y is b.y0
