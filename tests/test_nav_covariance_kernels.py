"""The EKF's covariance kernels that write into the caller's arrays (autopilot/nav/ekf.py:
``predict_covariance_into``, ``joseph_update_into``; autopilot/nav/base.py:
``sampling_error_into``, ``imu_step``) against the equations written out in numpy, and
the filter's two covariance arrays used in turn."""
from __future__ import annotations

import numpy as np

from autopilot.geo import euler_to_quat
from autopilot.nav.base import (_B_H, _B_O, _B_S, _B_SIZE, _H_SIZE, _HIST, S_ACC, S_ACC_HAS, S_F0,
                                S_G, S_GM, S_HI, S_QS, S_QS_HAS, S_SF, S_SIZE, S_THR, S_W0,
                                S_WIE, imu_step, sampling_error_into)
from autopilot.nav.ekf import InsGpsEkf, joseph_update_into, predict_covariance_into
from autopilot.nav.strapdown import X_BA, X_BG, Nominal, dcm9, mechanise
from autopilot.nav.layout import ABIAS, ATT, GBIAS, GPSB, POS, VEL


def _spd(rng, n):
    A = rng.standard_normal((n, n))
    return A @ A.T + n * np.eye(n)


def test_predict_covariance_into_writes_F_P_Ft_plus_Q_into_the_given_array():
    rng = np.random.default_rng(21)
    for n in (19, 21):
        P = _spd(rng, n)
        P0 = P.copy()
        T, a = 0.04, 0.998
        S = tuple(rng.standard_normal(3) * 0.4)
        Rs = tuple(rng.standard_normal(9) * 0.04)
        q = rng.uniform(0, 1e-4, n)
        qs = rng.uniform(0, 1e-5, 18)
        qs_idx = np.array([i * n + j for blk in (VEL, ATT) for i in range(blk.start, blk.stop)
                           for j in range(blk.start, blk.stop)], dtype=np.int64)
        F = np.eye(n)
        F[POS, VEL] = T * np.eye(3)
        sx, sy, sz = S
        F[VEL, ATT] = -np.array([[0.0, -sz, sy], [sz, 0.0, -sx], [-sy, sx, 0.0]])
        F[VEL, ABIAS] = F[ATT, GBIAS] = -np.reshape(Rs, (3, 3))
        F[GPSB, GPSB] = a * np.eye(3)
        want = F @ P @ F.T + np.diag(q)
        want.flat[qs_idx] += qs
        # the interval's sums as imu_step leaves them in the per-step array
        s = np.zeros(S_SIZE)
        s[S_ACC:S_ACC + 3], s[S_ACC + 3:S_ACC + 12], s[S_ACC + 12:S_ACC + 30] = S, Rs, qs
        s[S_ACC_HAS] = s[S_QS_HAS] = 1.0
        s0 = s.copy()
        out = np.full((n, n), np.nan)                 # every entry must be written
        assert predict_covariance_into(P, T, s, a, q, out) is None
        assert np.abs(out - want).max() <= 1e-12 * np.abs(want).max()
        assert np.array_equal(P, P0)                  # P itself untouched
        # the interval taken: its flags cleared, nothing else of s written
        assert s[S_ACC_HAS] == 0.0 and s[S_QS_HAS] == 0.0
        s0[S_ACC_HAS] = s0[S_QS_HAS] = 0.0
        assert np.array_equal(s, s0)
        # the IMU sampling error lands at its indices and nowhere else (an interval
        # without one: S_QS_HAS clear)
        without = np.empty((n, n))
        predict_covariance_into(P, T, s, a, q, without)
        d = out - without
        assert np.allclose(d.flat[qs_idx], qs, rtol=0, atol=1e-12 * np.abs(want).max())
        d.flat[qs_idx] = 0.0
        assert not d.any()


def test_joseph_update_into_writes_dx_and_P_and_nothing_when_S_is_not_definite():
    rng = np.random.default_rng(22)
    n, m = 21, 6
    P = _spd(rng, n) * 1e-2
    P0 = P.copy()
    H = np.zeros((m, n))
    for k in range(m):
        H[k, rng.choice(n, 3, replace=False)] = rng.standard_normal(3)
    R = rng.uniform(0.1, 2.0, m)
    y = rng.standard_normal(m)
    floor, ceil = np.full(n, 1e-9), np.full(n, 0.04)
    PHt = P @ H.T
    S = H @ PHt
    K = PHt @ np.linalg.inv(S + np.diag(R))
    A = np.eye(n) - K @ H
    want = A @ P @ A.T + K @ np.diag(R) @ K.T
    want = 0.5 * (want + want.T)
    want[np.diag_indices(n)] = np.clip(want.diagonal(), floor, ceil)
    dx = np.full(n, np.nan)
    out = np.full((n, n), np.nan)
    assert joseph_update_into(P, H, PHt, S, R, y, floor, ceil, dx, out)
    assert np.abs(dx - K @ y).max() <= 1e-12 * np.abs(K @ y).max()
    assert np.abs(out - want).max() <= 1e-12 * np.abs(want).max()
    assert (out == out.T).all() and (out.diagonal() <= ceil).all()
    assert np.array_equal(P, P0)
    bad = S.copy()
    bad[0, 0] = -1.0 - R[0]
    dx[:] = 7.0
    out[:] = 7.0
    assert not joseph_update_into(P, H, PHt, bad, R, y, floor, ceil, dx, out)
    assert (dx == 7.0).all() and (out == 7.0).all()


def test_the_filter_uses_two_covariance_arrays_in_turn():
    # GIVEN an aligned filter (its covariance initialised) predicting every step
    f = InsGpsEkf(vehicle="quad")
    f._init_covariance(np.full(f.n, 0.1))
    f.aligned = True
    P0 = f.P
    P0_values = P0.copy()
    f._predict(0.01, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0], 10_000)
    P1 = f.P
    # THEN a prediction writes a new array, leaving the one handed out before as it was
    assert P1 is not P0 and np.array_equal(P0, P0_values)
    f._predict(0.01, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0], 10_000)
    # AND the next one reuses the older array (the filter's own memory: copy P to keep it)
    assert f.P is P0 and f.P is not P1
    assert np.all(np.diag(f.P) > np.diag(P1))


def test_sampling_error_into_writes_or_adds_e_et_and_c_ct_above_the_thresholds():
    rng = np.random.default_rng(5)
    R = dcm9(euler_to_quat(0.3, -0.2, 2.0))
    Rm = np.array(R).reshape(3, 3)
    dt = 0.01
    f0, f1 = rng.standard_normal(3), rng.standard_normal(3) * 5.0
    w0, w1 = rng.standard_normal(3) * 0.1, rng.standard_normal(3)
    args = (dt, *f0.tolist(), *f1.tolist(), *w0.tolist(), *w1.tolist(), R)
    # e = R (f1 - f0) dt / 2, c = R (w1 - w0) dt / 2; q_s = (e e^T, c c^T) row-major
    e = Rm @ (f1 - f0) * (0.5 * dt)
    c = Rm @ (w1 - w0) * (0.5 * dt)
    want = np.concatenate((np.outer(e, e).ravel(), np.outer(c, c).ravel()))
    qs = np.full(18, np.nan)
    added, *ee = sampling_error_into(*args, 1e-3, 1e-3, qs, False)
    assert added
    np.testing.assert_allclose(qs, want, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(ee, e * e, rtol=1e-12, atol=0.0)
    # added to what the array holds
    base = rng.uniform(0.0, 1e-6, 18)
    qs = base.copy()
    assert sampling_error_into(*args, 1e-3, 1e-3, qs, True)[0]
    np.testing.assert_allclose(qs, base + want, rtol=1e-12, atol=0.0)
    # below both thresholds: nothing written
    qs = base.copy()
    thr_f = float((f1 - f0) @ (f1 - f0)) * (1.0 + 1e-9)
    thr_w = float((w1 - w0) @ (w1 - w0)) * (1.0 + 1e-9)
    assert not sampling_error_into(*args, thr_f, thr_w, qs, True)[0]
    assert np.array_equal(qs, base)
    # above one of them: written
    assert sampling_error_into(*args, thr_f, 0.5 * thr_w, qs, False)[0]
    np.testing.assert_allclose(qs, want, rtol=1e-12, atol=0.0)


def test_imu_step_is_the_mechanisation_the_sampling_error_and_the_interval_sums():
    rng = np.random.default_rng(8)
    nom = Nominal()
    nom.set_attitude(euler_to_quat(0.2, 0.1, -1.0))
    nom.p, nom.v = rng.standard_normal(3).tolist(), (rng.standard_normal(3) * 20.0).tolist()
    nom.bg, nom.ba = (rng.standard_normal(3) * 1e-3).tolist(), (rng.standard_normal(3) * 0.05).tolist()
    nom.gb = [0.5, -0.3, 1.0]
    f0, f1 = [0.5, 0.1, -9.0], [3.0, -1.0, -12.0]
    w0, w1 = [0.1, -0.2, 0.05], [0.3, 0.1, -0.2]
    dt, g, w_ie, thr, a_gm = 0.01, 9.79, (5e-5, 0.0, -4e-5), (1e-3, 1e-3), 0.999
    b = np.zeros(_B_SIZE)                  # the filter's buffer of x, s, the history, the output
    b[:_B_S] = nom.x
    nom = Nominal(b[:_B_S])
    s, hist, out = b[_B_S:_B_H], b[_B_H:_B_O].reshape(_HIST, _H_SIZE), b[_B_O:]
    s[S_F0:S_F0 + 3], s[S_W0:S_W0 + 3] = f0, w0
    s[S_G], s[S_WIE:S_WIE + 3], s[S_THR:S_THR + 2], s[S_GM] = g, w_ie, thr, a_gm
    s[S_SF:S_SF + 3], s[S_QS:S_QS + 3] = (1.0, 2.0, 3.0), (0.1, 0.2, 0.3)
    s[S_ACC:S_ACC + 30] = np.nan
    x0, s0 = nom.x.copy(), s.copy()
    # WHEN one step is taken
    geo = imu_step(b, *f1, *w1, dt, 7)
    # THEN the mechanisation with f1 and the trapezoid of the rates, bit for bit
    wm = [0.5 * (w0[i] + w1[i]) for i in range(3)]
    o = mechanise(*x0[0:10], *x0[X_BG:X_BG + 3], *x0[X_BA:X_BA + 3], *f1, *wm, dt, g, *w_ie)
    assert nom.x[0:25].tolist() == list(o)
    # AND the sampling error at the attitude before the step, bit for bit, into the
    # interval (not added: none there yet) and its velocity part into the running sum
    qs = np.empty(18)
    smp = sampling_error_into(dt, *f0, *f1, *w0, *w1, dcm9(x0[6:10]), *thr, qs, False)
    assert smp[0] and np.array_equal(s[S_ACC + 12:S_ACC + 30], qs) and s[S_QS_HAS] == 1.0
    assert s[S_QS:S_QS + 3].tolist() == [s0[S_QS + k] + smp[1 + k] for k in range(3)]
    # AND f_n dt and R(q') dt started afresh, the running f_n dt, the GPS error's decay
    assert s[S_ACC:S_ACC + 3].tolist() == [c * dt for c in o[19:22]]
    assert s[S_ACC + 3:S_ACC + 12].tolist() == [c * dt for c in o[10:19]]
    assert s[S_SF:S_SF + 3].tolist() == [s0[S_SF + k] + o[19 + k] * dt for k in range(3)]
    assert nom.gb == [c * a_gm for c in (0.5, -0.3, 1.0)]
    # AND this step's samples kept for the next, the history row, the output
    assert s[S_F0:S_F0 + 6].tolist() == f1 + w1
    assert hist[0, 0] == 7 and hist[0, 1:7].tolist() == list(o[0:6]) and s[S_HI] == 1
    assert out.tolist() == list(o[0:10]) + [w1[k] - nom.bg[k] for k in range(3)]
    assert geo[:3] == (0.0, 0.0, -o[2])                  # (no origin)
    # AND the next step adds to the sums
    before = s.copy()
    x1 = nom.x.copy()
    imu_step(b, *f0, *w0, dt, 8)
    o2 = mechanise(*x1[0:10], *x1[X_BG:X_BG + 3], *x1[X_BA:X_BA + 3], *f0, *wm, dt, g, *w_ie)
    assert nom.x[0:25].tolist() == list(o2)
    a = S_ACC
    assert s[a:a + 3].tolist() == [before[a + k] + o2[19 + k] * dt for k in range(3)]
    assert s[a + 3:a + 12].tolist() == [before[a + 3 + k] + o2[10 + k] * dt for k in range(9)]
    sampling_error_into(dt, *f1, *f0, *w1, *w0, dcm9(x1[6:10]), *thr, qs, False)
    assert s[a + 12:a + 30].tolist() == (before[a + 12:a + 30] + qs).tolist()
