"""Stop 41's quadrotor speed changes against what they replaced: the motor monitor's
stage 1 in one kernel (balance_step) and the isolation statistic (isolation) against the
numpy and Python code they replaced. The isolation statistic's arithmetic is Python's,
so it is compared bit for bit; stage 1's 4 x 4 products are summed in the order this
host's OpenBLAS sums them (matvec4), an order OpenBLAS picks by CPU, so they are compared
to numpy's within rounding bounds: a CI machine with another CPU may sum otherwise."""
from __future__ import annotations

import math

import numpy as np

from autopilot.control.multirotor import Y_N, Y_W
from autopilot.monitor.motors import (KF_PERIOD_S, LP_TAU_S, MIN_THRUST_SHARE, S_LP, SCALE_TAU_S,
                                      VAR_TAU_S, MotorMonitor, balance_residuals, balance_step,
                                      isolation, matvec4)
from autopilot.params import ParamStore
from autopilot.vehicle_quad import quad_param_declarations


def test_matvec4_is_numpys_product():
    rng = np.random.default_rng(3)
    for _ in range(2000):
        t = rng.uniform(0.5, 8.0, 4)
        H = np.array(((t[0], t[1], t[2], t[3]), (0.0, t[1], 0.0, -t[3]), (-t[0], 0.0, t[2], 0.0),
                      (t[0], -t[1], t[2], -t[3])))
        for v in (np.ones(4), rng.uniform(0.3, 1.2, 4), rng.normal(size=4)):
            # any summation order of four products is within 3 roundings of their sum
            bound = 4 * np.finfo(float).eps * (np.abs(H) @ np.abs(v))
            assert np.all(np.abs(matvec4(H, v) - H @ v) <= bound)


def _stage1_python(mon, omega, c, c_ok, gamma, var, learn, first):
    """MotorMonitor._stage's stage 1 as the Python code before wrote it."""
    t1, t2, t3, t4, fz, pf, qf, rf, qr, pr, pq = mon._s[S_LP:S_LP + 11].tolist()
    m, l, ixx, iyy, izz, km = 1.4, 0.2335, 0.019, 0.019, 0.0252, 0.0197
    tsum = t1 + t2 + t3 + t4
    if tsum < MIN_THRUST_SHARE * m * 9.80665 * (c if c_ok else 1.0):
        return None
    inv = 1.0 / LP_TAU_S
    pd, qd, rd = (omega[0] - pf) * inv, (omega[1] - qf) * inv, (omega[2] - rf) * inv
    thrust = -m * fz
    y = np.array((thrust, (ixx * pd + (izz - iyy) * qr) / l, (iyy * qd + (ixx - izz) * pr) / l,
                  (izz * rd + (iyy - ixx) * pq) / km))
    H = np.array(((t1, t2, t3, t4), (0.0, t2, 0.0, -t4), (-t1, 0.0, t3, 0.0), (t1, -t2, t3, -t4)))
    if learn:
        w = 1.0 - math.exp(-KF_PERIOD_S / SCALE_TAU_S) if c_ok else 1.0
        c += (thrust / tsum - c) * w
    r1, sd, r, e = balance_residuals(y, H @ np.ones(4), H @ gamma, c, var, learn, first,
                                     1.0 - math.exp(-KF_PERIOD_S / VAR_TAU_S))
    return c, H, r1[1:] / sd[1:], r, e


def test_balance_step_is_the_python_stage1():
    mon = MotorMonitor(ParamStore(quad_param_declarations()), 0.004, div=2)
    rng = np.random.default_rng(4)
    ran_n = 0
    for k in range(400):
        mon._s[S_LP:S_LP + 4] = rng.uniform(1.0, 5.0, 4)
        mon._s[S_LP + 4:S_LP + 11] = (-9.8 + rng.normal(), *rng.normal(scale=0.1, size=6))
        y = rng.normal(scale=0.1, size=Y_N)
        gamma = rng.uniform(0.6, 1.1, 4)
        c, c_ok, learn, first = rng.uniform(0.9, 1.1), k % 3 > 0, k % 4 > 0, k % 5 == 0
        var_a = rng.uniform(0.01, 1.0, 4)
        var_b = var_a.copy()
        ref = _stage1_python(mon, y[Y_W:Y_W + 3].tolist(), c, c_ok, gamma, var_a, learn, first)
        got = balance_step(mon._s, y, c, c_ok, gamma, var_b, learn, first)
        assert got[0] == (ref is not None)
        if ref is None:
            assert got[1] == c
            continue
        ran_n += 1
        assert got[1] == ref[0]
        np.testing.assert_allclose(var_b, var_a, rtol=1e-12, atol=0.0)
        for a, b in zip(got[2:], ref[1:]):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    assert ran_n > 100


def test_isolation_is_the_python_statistic():
    rng = np.random.default_rng(6)
    thr = 6.63
    for k in range(500):
        g = 1.0 + rng.normal(0.0, 0.05, 4)
        A = rng.normal(scale=0.01, size=(4, 4))
        P = A @ A.T + np.diag(rng.choice((0.0, 1e-13, 1e-4), 4))
        if k % 50 == 0:
            g[k % 4] = g[(k + 1) % 4]                    # ties
        gl = g.tolist()
        total = float(g.sum())
        others = [(total - gi) / 3.0 for gi in gl]
        dev = [(gi - oi) * (gi - oi) / ((pii if not pii < 1e-12 else 1e-12) * (4.0 / 3.0)) / thr
               for gi, oi, pii in zip(gl, others, P.diagonal().tolist())]
        j = dev.index(max(dev))
        assert isolation(g, P, thr) == (j, dev[j], gl[j] < others[j])
