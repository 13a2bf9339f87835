"""INS/GPS error-state UKF (autopilot/nav/ukf.py, filterpy): the EKF's scenario checks on
shorter runs (the UKF costs ~10x more per step), and agreement with the EKF.
The interface/record contract test covering both filters is in test_nav_ekf.py."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from autopilot.geo import quat_to_euler
from autopilot.nav import InsGpsEkf, InsGpsUkf
from autopilot.nav.simulate import (DEFAULT_SEGMENTS, accuracy, golden_numbers, run_filter,
                                    simulate_flight, simulate_static)

from test_nav_ekf import CFG, check_golden, make


def test_static_alignment_converges_in_two_seconds():
    # GIVEN a vehicle at rest with sensor biases WHEN 2 s of samples have been processed
    sim = simulate_static(np.random.default_rng(1), CFG, duration_s=2.5, roll_rad=0.03,
                          pitch_rad=-0.05, yaw_rad=2.5)
    filt = make(InsGpsUkf, origin=None)
    states = [filt.update(fr) for fr in sim.frames(0, 201)]
    # THEN roll/pitch are within 0.5 deg and yaw within 3 deg, and it is healthy
    err = np.degrees(np.subtract(quat_to_euler(states[-1].q_nb), quat_to_euler(sim.q_nb[200])))
    err[2] = (err[2] + 180.0) % 360.0 - 180.0
    assert states[-1].aligned and states[-1].healthy
    assert np.all(np.abs(err[:2]) < 0.5) and abs(err[2]) < 3.0, err


@pytest.fixture(scope="module")
def manoeuvre_run():
    # GIVEN an in-flight start, a 0.01 rad/s gyro bias on y, accelerometer biases, and
    #       80 s of straight flight, a 28 deg turn, a climb and a -25 deg turn
    cfg = dataclasses.replace(CFG, gyro_bias=(0.0, 0.01, 0.0), accel_bias=(0.1, -0.08, 0.15))
    sim = simulate_flight(np.random.default_rng(11), cfg, heading0_rad=1.0,
                          segments=((20, 0, 0), (25, 28, 0), (15, 0, 2.0), (20, -25, 0)))
    ukf = make(InsGpsUkf, cfg=cfg)
    ekf = make(InsGpsEkf, cfg=cfg)
    both = _WithEkf(ukf, ekf)
    # WHEN both filters run on it (the UKF scored, the EKF alongside)
    trace = run_filter(both, sim, keep_records=False)
    return cfg, sim, ukf, ekf, trace, both.P_checks


class _WithEkf:
    """Steps an EKF alongside the UKF and keeps a copy of the UKF's P every 5 s."""

    def __init__(self, ukf, ekf):
        self.ukf, self.ekf, self.P_checks, self.k = ukf, ekf, [], 0

    @property
    def P(self):
        return self.ukf.P

    def update(self, frame):
        self.ekf.update(frame)
        s = self.ukf.update(frame)
        self.k += 1
        if self.k % 500 == 0:
            self.P_checks.append(self.ukf.P.copy())
        return s


def test_biases_converge(manoeuvre_run):
    cfg, _, ukf, _, _, _ = manoeuvre_run
    # THEN the gyro bias (0.01 rad/s on y) is found to 1 mrad/s on every axis and the
    #      accelerometer biases to 0.03 m/s^2
    np.testing.assert_allclose(ukf.gyro_bias, cfg.gyro_bias, atol=1e-3)
    np.testing.assert_allclose(ukf.accel_bias, cfg.accel_bias, atol=0.03)


def test_accuracy_and_consistency(manoeuvre_run):
    _, sim, _, _, trace, _ = manoeuvre_run
    # THEN after 30 s: roll/pitch RMS <= 0.5 deg, yaw RMS <= 2 deg, >= 95 % of samples
    #      inside 3 sigma, and the position within issue 3's 0.7 of the GPS's own (the
    #      receiver's white 0.3 m is averaged out, its 0.2 m minute-scale wander is not;
    #      0.38 on this draw)
    a = accuracy(trace, sim, 30.0)
    assert a["roll_rms_deg"] <= 0.5 and a["pitch_rms_deg"] <= 0.5 and a["yaw_rms_deg"] <= 2.0, a
    assert a["inside_3sigma_min"] >= 0.95, a
    assert a["nav_pos_h_rms"] <= 0.7 * a["gps_pos_h_rms"], a


def test_covariance_stays_symmetric_positive_definite(manoeuvre_run):
    *_, P_checks = manoeuvre_run
    # THEN P is finite, symmetric and positive definite at every 5 s check
    assert len(P_checks) == 16
    for P in P_checks:
        assert np.all(np.isfinite(P))
        assert np.abs(P - P.T).max() <= 1e-12 * np.abs(P).max()
        assert np.linalg.eigvalsh(P).min() > 0.0


def test_agrees_with_the_ekf(manoeuvre_run):
    # THEN the UKF and the EKF end within 1 m, 0.1 m/s and 0.2 deg of each other
    _, _, ukf, ekf, _, _ = manoeuvre_run
    assert np.linalg.norm(np.subtract(ukf.nom.p, ekf.nom.p)) < 1.0
    assert np.linalg.norm(np.subtract(ukf.nom.v, ekf.nom.v)) < 0.1
    d = np.degrees(np.subtract(quat_to_euler(np.array(ukf.nom.q)), quat_to_euler(np.array(ekf.nom.q))))
    assert np.all(np.abs((d + 180.0) % 360.0 - 180.0) < 0.2), d


def test_gps_jump_is_rejected_by_the_gate():
    # GIVEN a GPS jumping 50 m north for 1 s at t = 25 s
    sim = simulate_flight(np.random.default_rng(7), CFG, segments=((20, 0, 0), (15, 25, 0)),
                          gps_glitches=((25.0, 26.0, (50.0, 0.0, 0.0)),))
    filt = make(InsGpsUkf)
    # WHEN the UKF runs through it
    trace = run_filter(filt, sim)
    k0, k1 = int(24.9 / CFG.dt_s), int(29.0 / CFG.dt_s)
    glitch = [r for k in range(k0, k1) for r in trace.records[k]
              if r.source == "gps_pos" and 25.0 <= trace.t_s[k] < 26.0]
    # THEN the glitched fixes are rejected and the estimate moves less than 2 m
    assert glitch and all(r.rejected and not r.fused for r in glitch)
    assert np.abs(trace.p_err[k0:k1, :2] - trace.p_err[k0, :2]).max() < 2.0


def test_outage_and_reacquisition():
    # GIVEN a 6 m/s cross wind, a turn, and no GPS from 15 s to 45 s
    cfg = dataclasses.replace(CFG, wind_ned=(0.0, 6.0, 0.0))
    sim = simulate_flight(np.random.default_rng(5), cfg, segments=((15, 0, 0), (20, 28, 0), (20, 0, 0)),
                          gps_outages=((15.0, 45.0),))
    filt = make(InsGpsUkf, cfg=cfg)
    # WHEN the UKF dead-reckons through it
    trace = run_filter(filt, sim)
    herr = np.hypot(trace.p_err[:, 0], trace.p_err[:, 1])
    sig_h = np.hypot(trace.sigma[:, 0], trace.sigma[:, 1])
    k_in, k_out, k_10 = int(15.0 / CFG.dt_s), int(44.99 / CFG.dt_s), int(55.0 / CFG.dt_s)
    # THEN the error after 30 s is within 30 m and inside the grown 3 sigma,
    assert herr[k_out] <= 30.0 and herr[k_out] <= 3.0 * sig_h[k_out], (herr[k_out], sig_h[k_out])
    assert sig_h[k_out] > 2.0 * sig_h[k_in]
    # the returning GPS is fused and the error is under 3 m within 10 s, without divergence
    assert herr[k_10] < 3.0, herr[k_10]
    assert herr[k_10:].max() < 5.0


def test_golden_regression():
    # GIVEN a fixed seed WHEN the UKF flies 20 s THEN it reproduces the stored numbers
    sim = simulate_flight(np.random.default_rng(1234), CFG, segments=DEFAULT_SEGMENTS[:1])
    filt = make(InsGpsUkf)
    trace = run_filter(filt, sim)
    check_golden("ukf", golden_numbers(filt, trace))
