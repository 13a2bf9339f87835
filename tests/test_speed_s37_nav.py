"""Stop 37's fewer layers per fusion (autopilot/nav/base.py, ekf.py): ``fuse_into`` (the
Joseph update and the injection in one kernel) against the two kernels it calls, bit
for bit; a Batch's arrays are its lists; the output after a fusion is the nominal
state's, in imu_step's array; the innovation lists handed out stay what they were."""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import euler_to_quat
from autopilot.nav import InsGpsEkf
from autopilot.nav.base import (_B_H, _B_O, _B_S, _B_SIZE, _P_CEIL, _P_FLOOR, S_CP, Batch, inject_into,
                                output_into)
from autopilot.nav.ekf import fuse_into, joseph_update_into
from autopilot.nav.simulate import SimConfig, simulate_flight
from autopilot.nav.strapdown import X_SIZE


def _spd(rng, n):
    A = rng.standard_normal((n, n))
    return A @ A.T + n * np.eye(n)


def test_fuse_into_is_the_joseph_update_then_the_injection_bit_for_bit():
    rng = np.random.default_rng(37)
    n, m = 21, 5
    P = _spd(rng, n) * 1e-2
    H = np.zeros((m, n))
    for k in range(m):
        H[k, rng.choice(n, 3, replace=False)] = rng.standard_normal(3)
    R = rng.uniform(0.1, 2.0, m)
    y = rng.standard_normal(m) * 0.1
    floor, ceil = _P_FLOOR[:n], _P_CEIL[:n]     # fuse_into's: the filter's limits
    PHt = np.ascontiguousarray(P @ H.T)
    S = H @ PHt
    b = np.zeros(_B_SIZE)
    b[:X_SIZE] = rng.standard_normal(X_SIZE)
    b[6:10] = euler_to_quat(0.2, -0.1, 1.0)
    b[_B_S + S_CP:_B_S + S_CP + 6] = rng.standard_normal(6)
    b0 = b.copy()
    # the two kernels one after the other
    dx_w, out_w = np.empty(n), np.empty((n, n))
    assert joseph_update_into(P, H, PHt, S, R, y, floor, ceil, dx_w, out_w)
    inject_into(b0[:_B_S], b0[_B_S:_B_H], dx_w)
    geo_w = output_into(b0[:_B_S], b0[_B_S:_B_H], b0[_B_O:])      # (stop 41: and the output)
    # the one
    out = np.empty((n, n))
    ok, geo = fuse_into(P, H, PHt, S, R, y, out, b)
    assert ok and geo == geo_w
    assert np.array_equal(out, out_w)
    assert np.array_equal(b, b0) and b[:X_SIZE].any() and b[_B_O:].any()
    # S not positive definite: nothing written, the state untouched
    bad = S.copy()
    bad[0, 0] = -1.0 - R[0]
    assert not fuse_into(P, H, PHt, bad, R, y, out, b)[0]
    assert np.array_equal(b, b0)


def test_a_batch_holds_its_lists_as_arrays():
    z, h0, R = [1.0, 2.5, -3.0], [0.5, 2.0, -1.0], [0.1, 0.2, 0.3]
    bt = Batch(["gps_pos"], [0], [3], [False], z, h0, R, [9.0] * 3, np.zeros((3, 21)))
    assert bt.z.tolist() == z and bt.h0.tolist() == h0 and bt.R.tolist() == R
    assert bt.y0.tolist() == [zi - hi for zi, hi in zip(z, h0)] and bt.z_tuple == tuple(z)


def test_the_output_after_a_fusion_is_the_nominal_states_and_past_records_stay():
    # GIVEN a simulated fixed-wing flight through the EKF (fusions on about one step in five)
    cfg = SimConfig()
    sim = simulate_flight(np.random.default_rng(3), cfg, duration_s=30.0)
    filt = InsGpsEkf({"EK_MAG_DEC": math.radians(cfg.mag_declination_deg), "EK_MAG_AUTODEC": 0},
                     "plane", cfg.origin(), cov_div=4)
    handed = []
    fused = 0
    for frame in sim.frames():
        nav = filt.update(frame)
        # THEN every output is the one computed afresh from the nominal state as it is
        a = np.empty(13)
        lat, lon, alt, *_ = output_into(filt.nom.x, filt._s, a)
        got = np.concatenate((nav.p_ned, nav.v_ned, nav.q_nb, nav.omega_b))
        assert np.array_equal(got, a) and (nav.lat_rad, nav.lon_rad, nav.alt_m) == (lat, lon, alt)
        fused += bool(filt.innovations)
        handed.append((filt.innovations, list(filt.innovations)))
    # AND the records handed out at each step are still those of that step
    assert all(lst == kept for lst, kept in handed)
    assert fused > len(handed) // 10 and not all(lst for lst, _ in handed)
