"""INS/GPS error-state EKF (autopilot/nav/ekf.py): scenarios with numeric bounds on the
nav sensor simulator (autopilot/nav/simulate.py), measurement-model checks, contracts
shared with the UKF, and a golden regression.

Regenerate the golden numbers after an intended change with
``NAV_UPDATE_GOLDEN=1 pytest tests/test_nav_ekf.py tests/test_nav_ukf.py -k golden``.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from autopilot.geo import LocalFrame, euler_to_quat, quat_to_euler
from autopilot.messages import (AirspeedSample, BaroSample, GpsFix, ImuSample, MagSample, NavState,
                                SensorFrame)
from autopilot.nav import InsGpsEkf, InsGpsUkf, NAV_PARAMS
from autopilot.nav.base import S_BB0
from autopilot.nav.layout import N_BASE, N_WIND, STATE_NAMES
from autopilot.nav.records import SOURCES, InnovationRecord
from autopilot.nav.simulate import (DEFAULT_SEGMENTS, SimConfig, accuracy, golden_numbers,
                                    run_filter, simulate_flight, simulate_static)
from autopilot.params import ParamStore

GOLDEN = Path(__file__).parent / "data" / "nav_golden.json"
CFG = SimConfig()
PARAMS = {"EK_MAG_DEC": math.radians(CFG.mag_declination_deg), "EK_MAG_AUTODEC": 0}


def make(cls=InsGpsEkf, cfg: SimConfig = CFG, origin="sim", **overrides):
    params = dict(PARAMS, **overrides)
    return cls(params, "plane", cfg.origin() if origin == "sim" else origin)


def check_golden(key: str, numbers: dict) -> None:
    """Compare with tests/data/nav_golden.json[key] at 1e-9 (or rewrite it on request)."""
    data = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}
    if os.environ.get("NAV_UPDATE_GOLDEN"):
        data[key] = numbers
        GOLDEN.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        return
    assert key in data, f"no golden numbers for {key}: run with NAV_UPDATE_GOLDEN=1"
    want = data[key]
    assert sorted(want) == sorted(numbers)
    for name, values in want.items():
        np.testing.assert_allclose(numbers[name], values, rtol=1e-9, atol=1e-9, err_msg=name)


# ------------------------------------------------------------------------ scenarios --

def test_static_alignment_converges_in_two_seconds():
    # GIVEN a vehicle at rest (roll 1.7 deg, pitch -2.9 deg, heading 143 deg) with
    #       accelerometer and gyro biases, a -66 deg / 12 deg magnetic field, GPS
    sim = simulate_static(np.random.default_rng(1), CFG, duration_s=2.5,
                          roll_rad=0.03, pitch_rad=-0.05, yaw_rad=2.5)
    filt = make(origin=None)
    # WHEN 2 s of samples have been processed
    states = [filt.update(fr) for fr in sim.frames(0, 201)]
    # THEN it was unaligned while averaging (EK_ALIGN_T = 1.5 s) and is aligned now,
    assert not states[100].aligned and states[-1].aligned
    # with roll/pitch within 0.5 deg and yaw within 3 deg,
    err = np.degrees(np.subtract(quat_to_euler(states[-1].q_nb), quat_to_euler(sim.q_nb[200])))
    err[2] = (err[2] + 180.0) % 360.0 - 180.0
    assert np.all(np.abs(err[:2]) < 0.5) and abs(err[2]) < 3.0, err
    # the gyro bias taken from the stationary mean, and healthy once a GPS fix reset
    # the position (the first fix is the origin)
    np.testing.assert_allclose(filt.gyro_bias, CFG.gyro_bias, atol=1e-3)
    assert states[-1].healthy
    assert np.linalg.norm(states[-1].p_ned) < 5.0


def test_unaligned_filter_says_so():
    # GIVEN a filter WHEN it sees a vehicle that is neither still nor moving over ground
    filt = make()
    frame = SensorFrame(0, ImuSample(0, np.array([3.0, 0.0, -9.8]), np.array([0.0, 0.5, 0.0])))
    s = filt.update(frame)
    # THEN it reports unaligned and unhealthy, and fuses nothing
    assert not s.aligned and not s.healthy and s.source == "ekf"
    assert filt.innovations == []


@pytest.fixture(scope="module")
def bias_run():
    # GIVEN a flight started without alignment (in-flight alignment from GPS velocity),
    #       a 0.01 rad/s gyro bias on y and accelerometer biases of 0.08-0.15 m/s^2
    cfg = dataclasses.replace(CFG, gyro_bias=(0.0, 0.01, 0.0), accel_bias=(0.1, -0.08, 0.15))
    sim = simulate_flight(np.random.default_rng(11), cfg, heading0_rad=1.0)
    filt = make(cfg=cfg)
    # WHEN three minutes of turns, climbs and straight legs are flown
    trace = run_filter(filt, sim, keep_records=False)
    return cfg, sim, filt, trace


def test_gyro_and_accel_biases_converge(bias_run):
    cfg, sim, filt, trace = bias_run
    # THEN the gyro bias is found to 0.5 mrad/s on every axis, the accelerometer's to
    #      0.02 m/s^2, and the wind to 0.2 m/s
    np.testing.assert_allclose(filt.gyro_bias, cfg.gyro_bias, atol=5e-4)
    np.testing.assert_allclose(filt.accel_bias, cfg.accel_bias, atol=0.02)
    np.testing.assert_allclose(filt.nom.wind, cfg.wind_ned[:2], atol=0.2)
    # and velocity and attitude are consistent with their covariance after 30 s
    # (position consistency over a 3-minute run depends on the GPS error's draw -- the
    # Gauss-Markov part is not separable from the position within tau; long_run checks it)
    a = accuracy(trace, sim, 30.0)
    assert a["inside_3sigma"][3:].min() >= 0.95, a
    assert a["roll_rms_deg"] < 0.5 and a["pitch_rms_deg"] < 0.5 and a["yaw_rms_deg"] < 2.0, a


def test_gps_jump_is_rejected_by_the_gate():
    # GIVEN a flight in which the GPS jumps 50 m north for 1 s at t = 60 s
    sim = simulate_flight(np.random.default_rng(7), CFG, segments=((40, 0, 0), (20, 25, 0), (20, 0, 0)),
                          gps_glitches=((60.0, 61.0, (50.0, 0.0, 0.0)),))
    filt = make()
    # WHEN the filter runs through it
    trace = run_filter(filt, sim)
    k0, k1 = int(59.9 / CFG.dt_s), int(64.0 / CFG.dt_s)
    gps = [(trace.t_s[k], r) for k in range(k0, k1) for r in trace.records[k] if r.source == "gps_pos"]
    glitch = [r for t, r in gps if 60.0 <= t < 61.0]
    after = [r for t, r in gps if t >= 61.5]
    # THEN every glitched fix is rejected and not fused (test ratio far above 1),
    assert glitch and all(r.rejected and not r.fused for r in glitch)
    assert min(max(r.test_ratio) for r in glitch) > 10.0
    # the position estimate moves less than 2 m relative to the truth,
    drift = np.abs(trace.p_err[k0:k1, :2] - trace.p_err[k0, :2]).max()
    assert drift < 2.0, drift
    # and the good fixes afterwards are fused again; the filter stays healthy
    assert after and all(r.fused and not r.rejected for r in after)
    assert trace.healthy[k1:].all()


def test_persistent_gps_shift_resets_position_after_timeout():
    # GIVEN a GPS that jumps 50 m and stays there (EK_GPS_RST_T = 5 s)
    sim = simulate_flight(np.random.default_rng(7), CFG, segments=((40, 0, 0), (30, 25, 0)),
                          gps_glitches=((60.0, 1e9, (50.0, 0.0, 0.0)),))
    filt = make()
    # WHEN the filter runs on
    trace = run_filter(filt, sim)
    resets = [trace.t_s[k] for k, recs in enumerate(trace.records)
              for r in recs if r.source == "gps_pos" and r.rejected and r.fused]
    # THEN the first 5 s of shifted fixes are rejected, then position is reset to the
    #      GPS once (recorded as rejected and fused), and the GPS is followed again
    assert len(resets) == 1 and 64.9 <= resets[0] <= 65.3, resets
    assert abs(trace.p_err[-1, 0] - 50.0) < 3.0


@pytest.fixture(scope="module")
def outage_run():
    # GIVEN a 6 m/s cross wind, turns at 25-28 deg of bank, and no GPS from 90 s to 120 s
    cfg = dataclasses.replace(CFG, wind_ned=(0.0, 6.0, 0.0))
    segs = ((30, 0, 0), (20, 28, 0), (20, 0, 0), (20, -28, 0), (20, 0, 1.0), (20, 28, 0),
            (20, 0, 0), (20, -25, 0), (40, 0, 0))
    sim = simulate_flight(np.random.default_rng(5), cfg, segments=segs, gps_outages=((90.0, 120.0),))
    filt = make(cfg=cfg)
    # WHEN the filter dead-reckons on airspeed, sideslip, heading and its wind estimate
    return sim, run_filter(filt, sim)


def test_outage_dead_reckoning(outage_run):
    sim, trace = outage_run
    k_in, k_out = int(90.0 / CFG.dt_s), int(119.99 / CFG.dt_s)
    herr = np.hypot(trace.p_err[:, 0], trace.p_err[:, 1])
    sig_h = np.hypot(trace.sigma[:, 0], trace.sigma[:, 1])
    # THEN the horizontal error after 30 s without GPS is within 30 m,
    assert herr[k_out] <= 30.0, herr[k_out]
    # the position variance rises all through the outage, every second (the air data
    # fused at 50 Hz take a little off between predictions: a sawtooth on the rise),
    assert np.all(np.diff(sig_h[k_in + 10:k_out:100]) > 0.0)
    assert sig_h[k_out] > 2.0 * sig_h[k_in]
    # and the filter's 3 sigma holds the error
    assert np.all(herr[k_in:k_out] <= 3.0 * sig_h[k_in:k_out])


def test_reacquisition_after_outage(outage_run):
    sim, trace = outage_run
    k_back, k_10 = int(120.0 / CFG.dt_s), int(130.0 / CFG.dt_s)
    herr = np.hypot(trace.p_err[:, 0], trace.p_err[:, 1])
    # THEN when the GPS returns it is fused (not rejected) and the error is under 3 m
    #      within 10 s,
    first = [r for recs in trace.records[k_back:k_back + 30] for r in recs if r.source == "gps_pos"]
    assert first and first[0].fused and not first[0].rejected
    assert herr[k_10] < 3.0, herr[k_10]
    # no step moves the estimate (relative to the truth) by more than that step's GPS
    # position innovation warrants (+10 %: the current position's correction includes
    # the latency's share of the velocity correction), nor by more than 5 cm between fixes,
    for k in range(k_back, k_10):
        step = float(np.linalg.norm(trace.p_err[k, :2] - trace.p_err[k - 1, :2]))
        gps = [r for r in trace.records[k] if r.source == "gps_pos"]
        allowed = 1.1 * float(np.linalg.norm(gps[0].innovation[:2])) + 0.05 if gps else 0.05
        assert step <= allowed, (trace.t_s[k], step, allowed)
    # and nothing diverges afterwards
    assert herr[k_10:].max() < 5.0


@pytest.fixture(scope="module")
def long_run():
    # GIVEN ten minutes of manoeuvring flight (22 m/s, banks of 25-30 deg, climbs,
    #       5 m/s wind) with the default sensor models (GPS: Gauss-Markov 0.2 m, tau 60 s,
    #       + 0.3 m white per horizontal axis, 150 ms latency)
    sim = simulate_flight(np.random.default_rng(1), CFG, duration_s=600.0)
    filt = make()
    P_checks = []
    # WHEN the EKF runs through it, P sampled every 10 s
    trace = run_filter(_Sampler(filt, P_checks, every=1000), sim, keep_records=False)
    return sim, filt, trace, P_checks


class _Sampler:
    """Wraps a filter to keep a copy of P every ``every`` steps."""

    def __init__(self, filt, out, every):
        self.filt, self.out, self.every, self.k = filt, out, every, 0

    @property
    def P(self):
        return self.filt.P

    @property
    def innovations(self):
        return self.filt.innovations

    def update(self, frame):
        s = self.filt.update(frame)
        self.k += 1
        if self.k % self.every == 0:
            self.out.append(self.filt.P.copy())
        return s


def test_covariance_stays_symmetric_positive_definite(long_run):
    _, filt, _, P_checks = long_run
    # THEN at every check P is finite, symmetric (to rounding: a predict-only step is not
    #      symmetrised) and positive definite
    assert len(P_checks) == 60
    for P in P_checks + [filt.P]:
        assert np.all(np.isfinite(P))
        assert np.abs(P - P.T).max() <= 1e-12 * np.abs(P).max()
        assert np.linalg.eigvalsh(P).min() > 0.0


def test_accuracy_targets_on_the_simulator(long_run):
    sim, _, trace, _ = long_run
    a = accuracy(trace, sim, 60.0)
    # THEN the product's acceptance targets hold after the first minute:
    #   nav_pos_h_rms <= 0.7 gps_pos_h_rms (the white part is averaged out, the
    #   Gauss-Markov part only through GPS velocity over windows longer than tau;
    #   figures: docs/status.md, "Navigation"), roll/pitch RMS <= 0.5 deg, yaw RMS <= 2 deg,
    #   >= 95 % of samples inside +-3 sigma for every position/velocity/attitude component
    assert a["ratio"] <= 0.7, a
    assert a["roll_rms_deg"] <= 0.5 and a["pitch_rms_deg"] <= 0.5, a
    assert a["yaw_rms_deg"] <= 2.0, a
    assert a["inside_3sigma_min"] >= 0.95, a


def test_covariance_every_few_steps_keeps_the_accuracy(long_run):
    # GIVEN the same ten minutes of flight, WHEN the EKF predicts its covariance only
    #       every 4th step and before each fusion (cov_div=4; the nominal state and the
    #       fusions stay at every step; the fixed-wing flies with this)
    sim, _, trace1, _ = long_run
    filt = InsGpsEkf(PARAMS, "plane", CFG.origin(), cov_div=4)
    trace4 = run_filter(filt, sim, keep_records=False)
    a1, a4 = accuracy(trace1, sim, 60.0), accuracy(trace4, sim, 60.0)
    # THEN the acceptance targets hold and the figures stay those of every-step prediction
    assert a4["ratio"] <= 0.7, a4
    assert a4["roll_rms_deg"] <= 0.5 and a4["pitch_rms_deg"] <= 0.5, a4
    assert a4["yaw_rms_deg"] <= 2.0, a4
    assert a4["inside_3sigma_min"] >= 0.95, a4
    assert abs(a4["nav_pos_h_rms"] - a1["nav_pos_h_rms"]) <= 0.05 * a1["nav_pos_h_rms"], (a1, a4)
    for k in ("roll_rms_deg", "pitch_rms_deg", "yaw_rms_deg"):
        assert abs(a4[k] - a1[k]) <= 0.1 * a1[k] + 0.005, (k, a1, a4)
    P = filt.P
    assert np.abs(P - P.T).max() <= 1e-12 * np.abs(P).max()
    assert np.linalg.eigvalsh(P).min() > 0.0


def test_accuracy_with_white_gps_noise():
    # GIVEN a GPS whose 1.6 m error is white (as many SITL GPS models are), the filter
    #       told so (no Gauss-Markov state), four minutes of flight
    cfg = dataclasses.replace(CFG, gps_gm_sigma_m=1e-3, gps_white_m=1.58, gps_vert_gm_m=1e-3,
                              gps_vert_white_m=2.6)
    sim = simulate_flight(np.random.default_rng(2), cfg, duration_s=240.0)
    filt = make(cfg=cfg, EK_GPSB_SD=0.0, EK_GPSB_Z_SD=0.0, EK_GPS_P_NSE=1.58, EK_GPS_Z_NSE=2.6)
    # WHEN the EKF runs
    trace = run_filter(filt, sim, keep_records=False)
    a = accuracy(trace, sim, 60.0)
    # THEN it removes most of the GPS noise and stays consistent
    assert a["ratio"] <= 0.35, a
    assert a["inside_3sigma_min"] >= 0.95, a


def test_copter_has_no_wind_or_air_data():
    # GIVEN the multirotor layout (19 error states) on a GPS/baro/mag-aided flight
    sim = simulate_flight(np.random.default_rng(4), CFG, duration_s=60.0)
    filt = InsGpsEkf(PARAMS, "copter", CFG.origin())
    # WHEN it runs
    trace = run_filter(filt, sim)
    # THEN no airspeed or sideslip is fused, there is no wind in the sigmas, and it navigates
    sources = {r.source for recs in trace.records for r in recs}
    assert filt.P.shape == (N_BASE, N_BASE) and "wind" not in filt.sigma()
    assert sources == {"gps_pos", "gps_vel", "baro", "mag"}
    a = accuracy(trace, sim, 30.0)
    assert a["nav_pos_h_rms"] < 3.0 and a["inside_3sigma_min"] >= 0.95, a


def test_barometric_height_reference_keeps_the_height_off_the_gps_wander():
    # GIVEN a copter flight with a drift-free barometer and the GPS's vertical error
    #       (0.6 m white, 0.4 m Gauss-Markov over 60 s)
    cfg = dataclasses.replace(CFG, baro_drift=0.0)
    sim = simulate_flight(np.random.default_rng(3), cfg, duration_s=120.0)
    spread = {}
    for ref in (0, 1):
        filt = InsGpsEkf(dict(PARAMS, EK_HGT_REF=ref), "copter", cfg.origin())
        # WHEN it runs with the barometer (0) or the GPS (1) as its height reference
        ez = []
        for i, frame in enumerate(sim.frames(0, len(sim))):
            s = filt.update(frame)
            if s.aligned and sim.t_us[i] > 20e6:
                ez.append(s.p_ned[2] - sim.p_ned[i, 2])
                # the filter's own position is the same in both; only the output differs
                if ref == 0:
                    assert s.p_ned[2] == pytest.approx(
                        filt.position_ned[2] - (filt.baro_bias - filt._s[S_BB0]), abs=1e-9)
        spread[ref] = float(np.std(ez))
    # THEN the output height on the barometer's datum moves by centimetres, under half
    #      of what it moves when it follows the GPS's height, whose Gauss-Markov wander is
    #      decimetres (figures: docs/status.md, "Navigation")
    assert spread[0] <= 0.07, spread
    assert spread[0] <= 0.5 * spread[1], spread


# ----------------------------------------------------------------- measurement models --

def _aligned_filter(vehicle="plane"):
    f = InsGpsEkf({"EK_MAG_DEC": 0.2, "EK_MAG_AUTODEC": 0, "EK_GPS_DELAY": 0.0}, vehicle, LocalFrame.from_degrees(-35, 149, 500))
    f.aligned, f._pos_src, f._baro_ok, f._tilt_ok = True, "gps", True, True
    nom = f.nom
    nom.p, nom.v = [10.0, -20.0, -100.0], [15.0, 8.0, -1.0]
    nom.set_attitude(euler_to_quat(0.3, 0.1, 2.0))
    nom.ba, nom.bg, nom.bb = [0.05, -0.02, 0.1], [0.01, 0.0, -0.01], 3.0
    nom.gb, nom.wind, nom.f_n = [0.5, -0.3, 1.0], [3.0, -2.0], [1.0, -0.5, -9.7]
    f._push_history(1_000_000)
    return f


def _measurements_of(f) -> SensorFrame:
    """Noise-free measurements of the filter's nominal state (taken as the truth)."""
    nom = f.nom
    R = np.array(nom.R).reshape(3, 3)
    field = 0.5 * np.array([math.cos(-1.15) * math.cos(0.2), math.cos(-1.15) * math.sin(0.2), math.sin(-1.15)])
    vr = np.array(nom.v) - np.array([*nom.wind, 0.0])
    t = 1_000_000
    lat, lon, alt = f.origin.to_geodetic_fast(np.array(nom.p) + np.array(nom.gb))
    # the pitot's dynamic pressure of that true airspeed in the barometer's air
    qbar = 0.5 * 1e5 / (287.05287 * 288.0) * float(vr @ vr)
    return SensorFrame(t, ImuSample(t, np.zeros(3), np.zeros(3)), MagSample(t, R.T @ field),
                       BaroSample(t, 1e5, f.origin.alt0_m - nom.p[2] + nom.bb, 288.0),
                       AirspeedSample(t, qbar, math.sqrt(2.0 * qbar / 1.225)),
                       GpsFix(t, lat, lon, alt, np.array(nom.v), 1.6, 2.6, 3, 12))


@pytest.mark.parametrize("i", range(N_WIND), ids=STATE_NAMES)
def test_measurement_jacobians_match_finite_differences(i):
    # GIVEN a filter whose true state differs from its estimate by eps along one error state
    eps = 1e-4
    dx = np.zeros(N_WIND)
    dx[i] = eps
    truth = _aligned_filter()
    truth._inject(dx)
    frame = _measurements_of(truth)
    est = _aligned_filter()
    # WHEN it forms this step's innovations from the true state's measurements
    batch = est._assemble(frame, frame.gps, est._accumulate_aux(frame))
    y = batch.z - batch.h0
    # (sideslip is a pseudo-measurement of zero: compare the change of its prediction)
    k = batch.src.index("sideslip")
    h_true = truth._assemble(frame, frame.gps, truth._accumulate_aux(frame)).h0
    y[batch.start[k]] = h_true[batch.start[k]] - batch.h0[batch.start[k]]
    # THEN y = H dx to first order for every source
    np.testing.assert_allclose(y / eps, batch.H @ dx / eps, atol=1e-3, err_msg=str(batch.src))


# ------------------------------------------------------------------------- contracts --

@pytest.mark.parametrize("cls", [InsGpsEkf, InsGpsUkf])
def test_interface_and_record_contract(cls):
    # GIVEN either filter on a short flight
    sim = simulate_flight(np.random.default_rng(9), CFG, segments=((8.0, 20.0, 0.0),))
    filt = make(cls)
    seen = set()
    previous = None
    for k, frame in enumerate(sim.frames()):
        # WHEN it is updated once per 100 Hz step
        s = filt.update(frame)
        # THEN it returns a NavState tagged with its kind,
        assert isinstance(s, NavState) and s.source == cls.SOURCE
        recs = filt.innovations
        # a fresh list of this step's records each call,
        assert recs is not previous
        previous = recs
        for r in recs:
            assert isinstance(r, InnovationRecord) and r.source in SOURCES and r.t_us == frame.t_us
            # the vectors as tuples of floats, one per component
            vecs = (r.observation, r.innovation, r.innovation_variance, r.test_ratio)
            assert all(type(v) is tuple and all(isinstance(c, float) for c in v) for v in vecs)
            m = len(r.innovation)
            assert len(r.observation) == len(r.innovation_variance) == len(r.test_ratio) == m
            y, var, ratio = (np.array(v) for v in vecs[1:])
            assert np.all(var > 0)
            gate = filt.params[{"gps_pos": "EK_GPS_P_GATE", "gps_vel": "EK_GPS_V_GATE", "baro": "EK_BARO_GATE",
                                "mag": "EK_MAG_GATE", "airspeed": "EK_ARSP_GATE",
                                "sideslip": "EK_BETA_GATE"}[r.source]]
            # test ratio = innovation^2 / (gate^2 variance), rejected iff any ratio > 1
            np.testing.assert_allclose(ratio, y ** 2 / (gate ** 2 * var))
            assert r.rejected == bool(np.any(ratio > 1.0))
            seen.add(r.source)
        if s.aligned and k > 10:
            # omega_b = gyro - bias estimate; airspeed = the measured one when present
            np.testing.assert_allclose(s.omega_b, frame.imu.omega_b - filt.gyro_bias, atol=1e-12)
            if frame.airspeed is not None:
                assert s.airspeed_mps == frame.airspeed.airspeed_mps
    assert seen == {"gps_pos", "gps_vel", "baro", "mag", "airspeed", "sideslip"}
    sig = filt.sigma()
    assert set(sig) >= {"p_ned", "v_ned", "att", "accel_bias", "gyro_bias", "wind"}
    # lat/lon/alt agree with p_ned through the origin
    lat, lon, alt = CFG.origin().to_geodetic_fast(s.p_ned)
    assert (s.lat_rad, s.lon_rad, s.alt_m) == pytest.approx((lat, lon, alt), abs=1e-12)
    # and reset() forgets the alignment (until a GPS fix over ground or a still vehicle)
    filt.reset()
    assert not filt.update(dataclasses.replace(frame, gps=None)).aligned
    assert filt.update(frame).aligned


def test_parameters_are_declared_once_and_accepted_from_a_store():
    # GIVEN the nav parameter declarations
    store = ParamStore(NAV_PARAMS)
    names = [p.name for p in NAV_PARAMS]
    # THEN names are unique, at most 16 characters, and carry units and descriptions
    assert len(set(names)) == len(names) and all(len(n) <= 16 for n in names)
    assert all(p.unit and p.description for p in NAV_PARAMS)
    # WHEN a ParamStore is handed to the filter THEN its values are used
    store.set("EK_GPS_P_GATE", 3.0)
    assert InsGpsEkf(store).params["EK_GPS_P_GATE"] == 3.0
    # and a misspelt EK_ name is refused rather than ignored
    with pytest.raises(KeyError):
        InsGpsEkf({"EK_GPS_P_GAT": 3.0})
    with pytest.raises(ValueError):
        InsGpsEkf(None, vehicle="boat")


def test_golden_regression():
    # GIVEN a fixed seed WHEN the EKF flies one minute of the default profile
    sim = simulate_flight(np.random.default_rng(1234), CFG, segments=DEFAULT_SEGMENTS[:4])
    filt = make()
    trace = run_filter(filt, sim)
    # THEN its final state, covariance and innovation sums equal the stored ones
    check_golden("ekf", golden_numbers(filt, trace))
