"""The fault monitor's compiled and shortened paths give what the laws written out in
plain Python and numpy give, bit for bit: the electric rotor's kernels of the throttle
balance (autopilot/monitor/throttle.py: the rotor's and the propeller's steps, the
propeller's throttle, the table interpolation), the lateral balance's deflections
(autopilot/monitor/lateral.py, its matrix built once) and the least-squares update."""
from __future__ import annotations

import math
from bisect import bisect_right

import numpy as np
import pytest

from autopilot.monitor import throttle
from autopilot.monitor.lateral import AEROSONDE_LAT, C172P_LAT
from autopilot.monitor.throttle import AEROSONDE_THRUST

M = AEROSONDE_THRUST


# ---- the laws as they were written in Python (the reference) --------------------------
def _interp(x, xs, ys):
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    i = bisect_right(xs, x)
    x0, x1 = xs[i - 1], xs[i]
    return ys[i - 1] + (ys[i] - ys[i - 1]) * (x - x0) / (x1 - x0)


def _rpm_line(V):
    a, b, c, d = M.rpm
    k = 2.0 * math.pi / 60.0
    return (a + c * V) * k, (b + d * V) * k


def rotor_speed(throttle, V):
    w0, s = _rpm_line(V)
    w = w0 + s * throttle
    return 0.0 if 0.0 > w else w


def rotor_step(w, throttle, V, dt):
    w0, s = _rpm_line(V)
    wq = 1.0 if 1.0 > w else w
    q_m = M.p_max_w * (0.0 if 0.0 > throttle else throttle) / wq
    q_m = q_m if q_m < M.q_max_nm else M.q_max_nm
    q_p = M.p_max_w * (0.0 if 0.0 > w - w0 else w - w0) / s / wq
    q_idle = M.k_idle * w * w
    q_p = q_idle if q_idle > q_p else q_p
    w = w + dt * (q_m - q_p) / M.prop_ixx
    return 0.0 if 0.0 > w else w


def rotor_throttle(w, V):
    w0, s = _rpm_line(V)
    u = (w - w0) / s
    u = 0.0 if 0.0 > u else u
    return 1.0 if 1.0 < u else u


def prop_throttle(w, V, rho):
    n = w / (2.0 * math.pi)
    if n <= 0.0:
        return 0.0
    cp = _interp(V / (n * M.prop_d_m), M.cp_j, M.cp)
    k = _interp(n * 60.0, M.cp_rpm, M.cp_rpm_k)
    return cp * k * rho * n * n * n * M.prop_d_m ** 5 / M.p_max_w


def prop_step(w, throttle, V, rho, dt):
    wq = 1.0 if 1.0 > w else w
    q_m = M.p_max_w * (0.0 if 0.0 > throttle else throttle) / wq
    q_m = M.q_max_nm if M.q_max_nm < q_m else q_m
    q_p = M.p_max_w * prop_throttle(w, V, rho) / wq
    w = w + dt * (q_m - q_p) / M.prop_ixx
    return 0.0 if 0.0 > w else w


def _same(a, b):
    return type(a) is float and (a == b or (a != a and b != b))


def test_the_electric_rotor_kernels_are_the_laws_bit_for_bit():
    rng = np.random.default_rng(11)
    tabs = M._cp_tables
    for _ in range(20000):
        w = float(rng.uniform(-50.0, 1500.0))
        thr = float(rng.uniform(-0.2, 1.2))
        V = float(rng.uniform(5.0, 45.0))
        dt = float(rng.choice((0.02, 0.01, rng.uniform(0.0, 0.1))))
        rho = float(rng.uniform(0.9, 1.3))
        assert _same(M.rotor_speed(thr, V), rotor_speed(thr, V))
        assert _same(M.rotor_step(w, thr, V, dt), rotor_step(w, thr, V, dt))
        assert _same(M.rotor_throttle(w, V), rotor_throttle(w, V))
        assert _same(M.prop_throttle(w, V, rho), prop_throttle(w, V, rho))
        assert _same(M.prop_step(w, thr, V, rho, dt), prop_step(w, thr, V, rho, dt))
        # the residual's step on the measured speed w: the model rotor w2 on the command
        w2, l0, l1 = float(rng.uniform(0.0, 1500.0)), float(rng.uniform()), float(rng.uniform())
        got = throttle._prop_advance(w2, l0, l1, thr, w, V, rho, dt, M._rotor, *tabs)
        # the two in one call (the thrust's rotor at the airspeed, the residual's at the true axial one)
        vt = V * float(rng.uniform(0.9, 1.1))
        both = throttle._rotors_advance(w, thr, V, dt, w2, l0, l1, w, vt, rho, M._rotor, *tabs)
        apart = (throttle._rotor_advance(w, thr, V, dt, M._rotor)
                 + throttle._prop_advance(w2, l0, l1, thr, w, vt, rho, dt, M._rotor, *tabs))
        assert all(_same(a, b) for a, b in zip(both, apart)) and len(both) == 5
        a = dt / (0.25 + dt)
        w2 = prop_step(w2, thr, V, rho, dt)
        assert _same(got[0], w2)
        assert _same(got[1], l0 + a * (prop_throttle(w, V, rho) - l0))
        assert _same(got[2], l1 + a * (prop_throttle(w2, V, rho) - l1))
        got = throttle._rotor_advance(w, thr, V, dt, M._rotor)
        w2 = rotor_step(w, thr, V, dt) if dt > 0.0 else w
        assert _same(got[0], w2) and _same(got[1], rotor_throttle(w2, V))


def test_the_table_kernel_is_the_interpolation_with_bisect():
    rng = np.random.default_rng(5)
    xs, ys = M.cp_j, M.cp
    axs, ays = np.array(xs, dtype=float), np.array(ys, dtype=float)
    for x in list(xs) + [-1.0, 0.0, xs[-1], 2.0] + rng.uniform(-0.1, 0.7, 5000).tolist():
        assert _same(throttle._table(float(x), axs, ays), _interp(float(x), xs, ys))


@pytest.mark.parametrize("model", (AEROSONDE_LAT, C172P_LAT), ids=("aerosonde", "c172p"))
def test_the_lateral_deflections_are_numpys_solve_bit_for_bit(model):
    rng = np.random.default_rng(2)
    # the deflections as the balance solved them, the matrix built at every sample
    for _ in range(2000):
        V, p, q, r, pd, rd, ay = (float(v) for v in rng.uniform((15.0, -1, -1, -1, -2, -2, -3),
                                                                   (40.0, 1, 1, 1, 2, 2, 3)))
        got = model.deflections(V, p, q, r, pd, rd, ay, 0.1, -9.0)
        if model._simple:
            m = model
            qS = 0.5 * 1.225 * V * V * m.wing_area_m2
            k = m.span_m / (2.0 * V)
            L = m.Jx * pd - m.Jxz * (rd + p * q) + (m.Jz - m.Jy) * q * r
            N = m.Jz * rd - m.Jxz * (pd - q * r) + (m.Jy - m.Jx) * p * q
            A = np.array(((m.CY_b, 0.0, m.CY_dr), (m.Cl_b, m.Cl_da, m.Cl_dr), (m.Cn_b, m.Cn_da, m.Cn_dr)))
            y = np.array((m.mass_kg * ay / qS, L / (qS * m.span_m) - m.Cl_p * k * p - m.Cl_r * k * r,
                          (N - 0.1) / (qS * m.span_m) - m.Cn_p * k * p - m.Cn_r * k * r))
            _b, da, dr = np.linalg.solve(A, y)
            assert got == (float(da), float(-dr))
        assert all(type(v) is float for v in got)


def test_dot_is_the_matmul_of_the_balances_bit_for_bit():
    """The balances' least squares and stage 2 call ``a.dot(b)`` for ``a @ b`` (the same
    BLAS routine without the matmul ufunc's set-up): the same numbers at their sizes."""
    rng = np.random.default_rng(9)
    for _ in range(20000):
        n = (2, 3)[int(rng.integers(2))]
        P = rng.standard_normal((n, n)) * rng.choice((1e-6, 1.0, 1e4))
        h, c = rng.standard_normal(n), rng.standard_normal(n)
        assert np.array_equal(P.dot(h), P @ h)
        assert h.dot(c) == h @ c
        assert h.dot(P).dot(h) == h @ P @ h


def test_the_least_squares_kernel_is_numpys_update_bit_for_bit():
    """actuator.rls_update (in place) against the update as it was written in numpy:
    g = P phi / (1 + phi^T P phi), c + g (y - phi^T c), P - outer(g, P phi); it returns
    the prediction error y - phi^T c."""
    from autopilot.monitor.actuator import rls_update
    rng = np.random.default_rng(4)
    for _ in range(20000):
        n = (2, 3)[int(rng.integers(2))]
        A = rng.standard_normal((n, n))
        P = A @ A.T * rng.choice((1e-4, 1.0, 1e4))
        c, ph, y = rng.standard_normal(n), rng.standard_normal(n), float(rng.standard_normal())
        Pp = P.dot(ph)
        g = Pp / (1.0 + ph.dot(Pp))
        e_ref = float(y - ph.dot(c))
        c_ref = c + g * e_ref
        P_ref = P - np.outer(g, Pp)
        e = rls_update(c, P, ph, y)   # (in place)
        assert e == e_ref and np.array_equal(c, c_ref) and np.array_equal(P, P_ref)
