"""Sensor models and fault injection: statistics, timing, geometry, determinism.

Scenarios in GIVEN / WHEN / THEN form with numeric bounds. The tolerances are a few
standard errors of the estimate for the sample sizes used, so a wrong model fails.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from autopilot.geo import LocalFrame, euler_to_quat, quat_to_dcm
from sim_bridge.faults import FaultInjector, FaultSpecError
from sim_bridge.plants.base import PlantState
from sim_bridge.sensors import SensorParams, SensorSuite, isa
from autopilot.geo.magfield import declination_inclination_rad, igrf_field_ned_gauss

HOME = (math.radians(-35.36), math.radians(149.17), 584.0)
G = 9.80665
DT = 0.01

QUIET = SensorParams(  # every noise source off: the output is the truth
    accel_noise_density=0.0, gyro_noise_density=0.0, accel_bias_turn_on_sigma=0.0,
    gyro_bias_turn_on_sigma=0.0, accel_bias_rw_density=0.0, gyro_bias_rw_density=0.0,
    gps_pos_white_sigma_h=0.0, gps_pos_white_sigma_v=0.0, gps_pos_gm_sigma_h=0.0,
    gps_pos_gm_sigma_v=0.0, gps_vel_sigma_h=0.0, gps_vel_sigma_v=0.0,
    baro_noise_sigma_pa=0.0, baro_drift_rw_density=0.0, baro_tendency_sigma_pa_s=0.0,
    baro_temperature_sigma_k=0.0,
    mag_noise_sigma_gauss=0.0, airspeed_noise_sigma_pa=0.0)


def state(t_us=0, lat=HOME[0], lon=HOME[1], alt=HOME[2], v_ned=(0.0, 0.0, 0.0),
          q_nb=None, omega_b=(0.0, 0.0, 0.0), f_b=(0.0, 0.0, -G), airspeed=0.0, **kw):
    vec = lambda x: tuple(float(c) for c in x)        # (base.PlantState: tuples of floats)
    return PlantState(
        t_us=t_us, lat_rad=lat, lon_rad=lon, alt_m=alt, v_ned=vec(v_ned),
        q_nb=(1.0, 0.0, 0.0, 0.0) if q_nb is None else vec(q_nb),
        omega_b=vec(omega_b), f_b=vec(f_b),
        wind_ned=(0.0, 0.0, 0.0), airspeed_mps=airspeed, alpha_rad=0.0, beta_rad=0.0,
        on_ground=False, **kw)


def run(suite, n, make=lambda k, t_us: state(t_us), dt=DT):
    return [suite.sample(make(k, int(round(k * dt * 1e6)))) for k in range(n)]


def moving_truth(v_ned=(20.0, 5.0, -1.0)):
    """Truth moving at constant NED velocity from HOME (exact through LocalFrame)."""
    frame = LocalFrame(*HOME)
    v = np.array(v_ned)

    def make(k, t_us):
        lat, lon, alt = frame.to_geodetic(v * (t_us * 1e-6))
        return state(t_us, lat, lon, alt, v_ned=v_ned)
    return frame, v, make


# --- IMU -----------------------------------------------------------------------------

def test_the_readings_vectors_are_tuples_of_floats():
    # (readings.py: what the HIL link reads element by element)
    suite = SensorSuite(SensorParams(), np.random.default_rng(3), DT)
    _, _, make = moving_truth()
    r = run(suite, 150, make)
    gps = [x.gps for x in r if x.gps is not None]
    assert gps and any(x.mag_updated for x in r)
    for x in r:
        for v in (x.accel_b, x.gyro_b, x.mag_b_gauss):
            assert type(v) is tuple and len(v) == 3 and all(type(c) is float for c in v)
    assert all(type(g.v_ned) is tuple and all(type(c) is float for c in g.v_ned) for g in gps)


def test_imu_white_noise_std_matches_noise_density_over_sqrt_dt():
    # GIVEN an IMU with only white noise, at rest, sampled at 100 Hz
    p = dataclasses.replace(QUIET, accel_noise_density=1.5e-3, gyro_noise_density=1.75e-4)
    suite = SensorSuite(p, np.random.default_rng(1), DT)
    # WHEN 20000 steps are sampled
    r = run(suite, 20000)
    acc = np.array([x.accel_b for x in r])
    gyr = np.array([x.gyro_b for x in r])
    # THEN each axis's std is density / sqrt(dt) within 3 % (std error 0.5 %)
    np.testing.assert_allclose(acc.std(axis=0), 1.5e-3 / math.sqrt(DT), rtol=0.03)
    np.testing.assert_allclose(gyr.std(axis=0), 1.75e-4 / math.sqrt(DT), rtol=0.03)
    # AND the means are the truth within 5 standard errors
    se = 1.5e-3 / math.sqrt(DT) / math.sqrt(len(r))
    np.testing.assert_allclose(acc.mean(axis=0), [0.0, 0.0, -G], atol=5 * se)


def test_imu_bias_random_walk_increments_have_density_times_sqrt_dt():
    # GIVEN an IMU whose only error is the bias random walk
    p = dataclasses.replace(QUIET, accel_bias_rw_density=1e-3, gyro_bias_rw_density=3e-5)
    suite = SensorSuite(p, np.random.default_rng(2), DT)
    # WHEN 20000 steps are sampled (crossing several noise blocks)
    r = run(suite, 20000)
    gyr = np.array([x.gyro_b for x in r])
    acc = np.array([x.accel_b for x in r])
    # THEN step-to-step increments have std K sqrt(dt) within 3 %, mean ~ 0
    dg, da = np.diff(gyr, axis=0), np.diff(acc, axis=0)
    np.testing.assert_allclose(dg.std(axis=0), 3e-5 * math.sqrt(DT), rtol=0.03)
    np.testing.assert_allclose(da.std(axis=0), 1e-3 * math.sqrt(DT), rtol=0.03)
    assert np.all(np.abs(dg.mean(axis=0)) < 5 * 3e-5 * math.sqrt(DT) / math.sqrt(len(dg)))
    # AND the reported true bias is exactly what the readings carry
    b_acc, b_gyr = suite.imu_bias
    np.testing.assert_allclose(b_gyr, gyr[-1], atol=1e-15)
    np.testing.assert_allclose(b_acc, acc[-1] - [0.0, 0.0, -G], atol=1e-12)


def test_imu_turn_on_bias_is_constant_per_run_with_the_configured_spread():
    # GIVEN 300 runs (seeds) of an IMU with only a turn-on bias
    p = dataclasses.replace(QUIET, gyro_bias_turn_on_sigma=2e-3, accel_bias_turn_on_sigma=0.03)
    first, drift = [], []
    for seed in range(300):
        suite = SensorSuite(p, np.random.default_rng(seed), DT)
        r = run(suite, 3)
        first.append(np.concatenate((r[0].gyro_b, np.subtract(r[0].accel_b, [0.0, 0.0, -G]))))
        drift.append(np.abs(np.subtract(r[2].gyro_b, r[0].gyro_b)).max())
    first = np.array(first)
    # THEN the spread over runs is the configured sigma within 10 % (900 draws each)
    assert abs(first[:, :3].std() / 2e-3 - 1.0) < 0.1
    assert abs(first[:, 3:].std() / 0.03 - 1.0) < 0.1
    # AND within one run it does not move
    assert max(drift) == 0.0


# --- GPS -----------------------------------------------------------------------------

def test_gps_is_5_hz_and_delivers_exactly_the_truth_of_latency_earlier():
    # GIVEN a noise-free GPS and a vehicle moving at 20 m/s north, 5 east, 1 up
    frame, v, make = moving_truth()
    suite = SensorSuite(QUIET, np.random.default_rng(3), DT)
    # WHEN 10 s are sampled
    fixes = [x.gps for x in run(suite, 1000, make) if x.gps is not None]
    # THEN fixes arrive every 200 ms, the first one 150 ms after start
    t = np.array([f.t_us for f in fixes])
    assert t[0] == 150_000
    assert set(np.diff(t)) == {200_000}
    assert len(fixes) == 50          # 0.15 s, 0.35 s, ... 9.95 s
    for f in fixes:
        # AND each is valid exactly 150 ms before arrival ...
        assert f.t_us - f.t_valid_us == 150_000
        # ... and equals the truth at that time (to a millimetre) ...
        p_fix = frame.to_ned(f.lat_rad, f.lon_rad, f.alt_m)
        np.testing.assert_allclose(p_fix, v * f.t_valid_us * 1e-6, atol=1e-3)
        # ... not the truth at arrival, which is 3.1 m further on
        assert np.linalg.norm(p_fix - v * f.t_us * 1e-6) > 3.0
        np.testing.assert_allclose(f.v_ned, v, atol=1e-12)
        assert f.fix_type == 3
        # AND ground speed and course are those of v_ned
        assert f.ground_speed_mps == pytest.approx(math.hypot(20.0, 5.0))
        assert f.cog_rad == pytest.approx(math.atan2(5.0, 20.0))


def test_gps_latency_follows_the_parameter():
    # GIVEN a GPS configured with 300 ms latency at 10 Hz
    p = dataclasses.replace(QUIET, gps_latency_s=0.3, gps_rate_hz=10.0)
    suite = SensorSuite(p, np.random.default_rng(4), DT)
    # WHEN 3 s are sampled
    fixes = [x.gps for x in run(suite, 300) if x.gps is not None]
    # THEN the delay and the rate are as configured
    assert fixes[0].t_us == 300_000
    assert {f.t_us - f.t_valid_us for f in fixes} == {300_000}
    assert set(np.diff([f.t_us for f in fixes])) == {100_000}


def test_gps_error_with_default_noise_is_within_reported_accuracy():
    # GIVEN default GPS noise and a moving vehicle
    frame, v, make = moving_truth()
    suite = SensorSuite(SensorParams(), np.random.default_rng(5), DT)
    # WHEN 60 s are sampled
    fixes = [x.gps for x in run(suite, 6000, make) if x.gps is not None]
    err = np.array([frame.to_ned(f.lat_rad, f.lon_rad, f.alt_m) - v * f.t_valid_us * 1e-6
                    for f in fixes])
    verr = np.array([f.v_ned - v for f in fixes])
    # THEN position errors stay inside 4x the reported 1-sigma eph / epv
    eph, epv = fixes[0].eph_m, fixes[0].epv_m
    assert eph == pytest.approx(math.sqrt(2 * (0.2 ** 2 + 0.3 ** 2)))
    assert epv == pytest.approx(math.hypot(0.4, 0.6))
    assert np.all(np.hypot(err[:, 0], err[:, 1]) < 4 * eph)
    assert np.all(np.abs(err[:, 2]) < 4 * epv)
    # AND the velocity noise is ~0.1 m/s horizontally (300 fixes: within 15 %)
    assert abs(verr[:, :2].std() / 0.1 - 1.0) < 0.15
    # AND the satellite count stays within 10..14
    assert all(10 <= f.satellites <= 14 for f in fixes)


def test_gps_gauss_markov_error_has_exponential_autocorrelation():
    # GIVEN a GPS whose position error is only the Gauss-Markov part, tau = 2 s
    p = dataclasses.replace(QUIET, gps_pos_gm_sigma_h=1.5, gps_pos_gm_sigma_v=3.0,
                            gps_pos_gm_tau_s=2.0)
    suite = SensorSuite(p, np.random.default_rng(6), 0.05)
    frame = LocalFrame(*HOME)
    # WHEN 2000 s are sampled at a static position (10000 fixes)
    fixes = [x.gps for x in run(suite, 40000, dt=0.05) if x.gps is not None]
    e = np.array([frame.to_ned(f.lat_rad, f.lon_rad, f.alt_m) for f in fixes])
    # THEN the std is the steady-state sigma (effective N ~ 1000 per axis: within 10 %)
    assert abs(e[:, :2].std() / 1.5 - 1.0) < 0.1
    assert abs(e[:, 2].std() / 3.0 - 1.0) < 0.1

    def autocorr(x, lag):
        x = x - x.mean()
        return float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))
    # AND the autocorrelation at lag 0.2 s and 1 s is exp(-lag / tau)
    for lag, expected in ((1, math.exp(-0.1)), (5, math.exp(-0.5))):
        r = np.mean([autocorr(e[:, i], lag) for i in range(3)])
        assert r == pytest.approx(expected, abs=0.04)


def test_gps_default_error_is_fix_noise_plus_a_minute_scale_wander():
    # GIVEN the default receiver (white 0.3 m + Gauss-Markov 0.2 m per horizontal axis,
    #       tau 60 s; params.py) at rest
    suite = SensorSuite(SensorParams(), np.random.default_rng(21), 0.05)
    frame = LocalFrame(*HOME)
    # WHEN 40 minutes are sampled (12000 fixes)
    fixes = [x.gps for x in run(suite, 48000, dt=0.05) if x.gps is not None]
    e = np.array([frame.to_ned(f.lat_rad, f.lon_rad, f.alt_m) for f in fixes])[:, :2]
    # THEN from fix to fix it is the white part: differences of sqrt(2) x 0.3 m (+ the
    #      Gauss-Markov's 0.2 sqrt(2 (1 - exp(-0.2 / 60))) = 0.016 m) -- within 5 %
    assert np.diff(e, axis=0).std() == pytest.approx(math.sqrt(2.0) * 0.3, rel=0.05)
    # AND the 10 s means (white part averaged down to 0.04 m) wander by the Gauss-Markov
    #     part, 0.2 m (40 independent minutes per axis: within 25 %)
    means = e[: len(e) // 50 * 50].reshape(-1, 50, 2).mean(axis=1)
    assert means.std() == pytest.approx(math.hypot(0.2, 0.3 / math.sqrt(50)), rel=0.25)
    # AND the total is far inside the data sheet's 24-hour figure (2.5 m CEP): the
    #     hours-scale part is left out of the defaults
    assert 1.1774 * e.std() < 0.6


def test_gps_long_horizon_parameter_set():
    from sim_bridge.sensors.params import GPS_LONG_HORIZON
    from autopilot.nav.config import NAV_GPS_LONG_HORIZON, resolve
    # GIVEN the pessimistic long-horizon model
    p = SensorParams(**GPS_LONG_HORIZON)
    suite = SensorSuite(p, np.random.default_rng(22), DT)
    # THEN it reports the 24-hour-class accuracy (CEP 1.46 m per the data sheet's scale)
    assert suite.eph_m == pytest.approx(math.sqrt(2 * (1.2 ** 2 + 0.3 ** 2)))
    assert 1.1774 * suite.eph_m / math.sqrt(2) == pytest.approx(1.46, abs=0.01)
    # AND the navigation filter's matching values are valid parameters
    nav = resolve(NAV_GPS_LONG_HORIZON)
    assert (nav["EK_GPSB_SD"], nav["EK_GPSB_Z_SD"], nav["EK_GPSB_TAU"]) == (
        p.gps_pos_gm_sigma_h, p.gps_pos_gm_sigma_v, p.gps_pos_gm_tau_s)
    assert (nav["EK_GPS_P_NSE"], nav["EK_GPS_Z_NSE"]) == (p.gps_pos_white_sigma_h, p.gps_pos_white_sigma_v)


def test_gps_satellite_count_varies_slowly():
    # GIVEN default parameters (a +-1 change every 20 s on average)
    suite = SensorSuite(SensorParams(), np.random.default_rng(7), 0.05)
    # WHEN 600 s are sampled
    sats = [x.gps.satellites for x in run(suite, 12000, dt=0.05) if x.gps is not None]
    changes = np.count_nonzero(np.diff(sats))
    # THEN it changed, but only ~30 times (Poisson: 30 +- 5.5), in unit steps
    assert 12 <= changes <= 50
    assert set(np.abs(np.diff(sats))) <= {0, 1}
    assert min(sats) >= 10 and max(sats) <= 14


# --- barometer -----------------------------------------------------------------------

def test_baro_altitude_error_is_bounded_and_updates_at_50_hz():
    # GIVEN the default barometer at 500 m with no plant pressure (ISA used)
    suite = SensorSuite(SensorParams(), np.random.default_rng(8), DT)
    # WHEN 60 s are sampled
    r = run(suite, 6000, lambda k, t: state(t, alt=500.0))
    upd = [x for x in r if x.baro_updated]
    alt = np.array([x.pressure_alt_m for x in upd])
    pres = np.array([x.pressure_pa for x in upd])
    # THEN it updated on every second 10 ms step
    assert [x.baro_updated for x in r[:6]] == [True, False, True, False, True, False]
    assert len(upd) == 3000
    # AND the altitude error stays within 1.5 m (noise 0.27 m, drift < 0.3 m @ 3 sigma)
    assert np.all(np.abs(alt - 500.0) < 1.5)
    # AND the white noise is 3 Pa: first differences have std sqrt(2) * 3 Pa (+-5 %)
    assert np.diff(pres).std() == pytest.approx(math.sqrt(2) * 3.0, rel=0.05)
    # AND the temperature is the ISA temperature at 500 m
    assert np.mean([x.temperature_k for x in upd]) == pytest.approx(288.15 - 3.25, abs=0.01)


def test_baro_drift_is_a_per_flight_pressure_tendency():
    # GIVEN a barometer whose only error is the weather's tendency (sigma 1 hPa / 3 h)
    p = dataclasses.replace(QUIET, baro_tendency_sigma_pa_s=SensorParams().baro_tendency_sigma_pa_s)
    assert p.baro_tendency_sigma_pa_s == pytest.approx(100.0 / 10800.0)
    rates = []
    for seed in range(200):
        suite = SensorSuite(p, np.random.default_rng(seed), DT)
        # WHEN 2 s are sampled at a constant altitude
        r = [x for x in run(suite, 200, lambda k, t: state(t, alt=500.0)) if x.baro_updated]
        t = np.array([x.t_us for x in r]) * 1e-6
        err = np.array([x.pressure_pa for x in r]) - isa.pressure_pa(500.0)
        # THEN the pressure error is a straight line through zero at t = 0 ...
        rate = float(err[-1] / t[-1])
        assert np.abs(err - rate * t).max() < 1e-6
        rates.append(rate)
    # ... whose slope differs from flight to flight with sd 0.0093 Pa/s (+-15 % for n=200)
    assert np.std(rates) == pytest.approx(100.0 / 10800.0, rel=0.15)
    assert abs(np.mean(rates)) < 3 * 0.0093 / math.sqrt(200)


def test_baro_uses_the_plant_pressure_when_given():
    # GIVEN a plant reporting 90 kPa (a low-pressure day) at 500 m
    suite = SensorSuite(SensorParams(), np.random.default_rng(9), DT)
    # WHEN sampled
    r = run(suite, 200, lambda k, t: state(t, alt=500.0, pressure_pa=90000.0))
    p = np.mean([x.pressure_pa for x in r if x.baro_updated])
    # THEN the pressure is the plant's (not ISA's 95461 Pa) and the altitude is its ISA altitude
    assert p == pytest.approx(90000.0, abs=5.0)
    assert r[-1].pressure_alt_m == pytest.approx(isa.pressure_altitude_m(r[-1].pressure_pa))
    assert isa.pressure_altitude_m(90000.0) == pytest.approx(988.5, abs=1.0)


def test_isa_round_trip_and_standard_values():
    # GIVEN the ISA model; THEN it reproduces standard table values and inverts itself
    assert isa.pressure_pa(0.0) == 101325.0
    assert isa.pressure_pa(1000.0) == pytest.approx(89874.6, abs=1.0)
    assert isa.pressure_pa(11000.0) == pytest.approx(22632.1, abs=1.0)
    assert isa.density_kgm3(0.0) == pytest.approx(1.225, abs=1e-3)
    for h in (-200.0, 0.0, 584.0, 5000.0, 15000.0):
        assert isa.pressure_altitude_m(isa.pressure_pa(h)) == pytest.approx(h, abs=1e-6)


# --- magnetometer --------------------------------------------------------------------

@pytest.mark.parametrize("lat, lon, dec_deg, inc_deg", [
    (-35.36, 149.17, 12.5, -66.0),   # Canberra (NOAA/GA 2020: D 12.4 E, I -66.0)
    (51.5, 0.0, 0.5, 66.5),          # London (D crossed 0 in 2019; I 66.4)
    (40.0, -105.27, 8.2, 66.3),      # Boulder (NOAA 2020: D 8.2 E, I 66.3)
])
def test_igrf_declination_and_inclination_at_known_places(lat, lon, dec_deg, inc_deg):
    # GIVEN the IGRF-13 field at a known place in 2020-2025
    for year in (2020.0, 2025.0):
        b = igrf_field_ned_gauss(math.radians(lat), math.radians(lon), 0.0, year)
        dec, inc = declination_inclination_rad(b)
        # THEN declination and inclination are the published ones within 2 degrees
        assert math.degrees(dec) == pytest.approx(dec_deg, abs=2.0)
        assert math.degrees(inc) == pytest.approx(inc_deg, abs=2.0)
        # AND the strength is Earth-like
        assert 0.25 < math.sqrt(sum(c * c for c in b)) < 0.65


def test_igrf_dipole_limit_and_validity_range():
    # GIVEN IGRF: at the geographic north pole the field points down (inclination ~ 87 deg)
    b = igrf_field_ned_gauss(math.radians(89.9), 0.0, 0.0, 2020.0)
    assert math.degrees(declination_inclination_rad(b)[1]) > 80.0
    # AND the model refuses dates outside its validity
    with pytest.raises(ValueError):
        igrf_field_ned_gauss(0.0, 0.0, 0.0, 2030.0)


def test_mag_reading_is_the_earth_field_rotated_into_the_body():
    # GIVEN a magnetometer with noise, hard iron (0.01, 0, -0.02) G, a tilted, yawed vehicle
    p = dataclasses.replace(QUIET, mag_noise_sigma_gauss=0.005,
                            mag_hard_iron_gauss=(0.01, 0.0, -0.02))
    suite = SensorSuite(p, np.random.default_rng(10), DT)
    q = euler_to_quat(0.3, -0.2, 2.0)
    # WHEN sampled for 20 s
    r = [x for x in run(suite, 2000, lambda k, t: state(t, q_nb=q)) if x.mag_updated]
    m = np.array([x.mag_b_gauss for x in r])
    b_ned = np.array(suite.mag_field_ned_gauss)
    # THEN the mean reading, less hard iron, rotated back to NED is the IGRF field
    back = quat_to_dcm(q) @ (m.mean(axis=0) - [0.01, 0.0, -0.02])
    np.testing.assert_allclose(back, b_ned, atol=5 * 0.005 / math.sqrt(len(r)))
    # AND the noise std is 0.005 G (1000 samples: within 8 %)
    np.testing.assert_allclose(m.std(axis=0), 0.005, rtol=0.08)
    # AND it updated at 50 Hz
    assert len(r) == 1000
    # AND the heading a compass would compute (level, declination-corrected) is the yaw
    suite2 = SensorSuite(QUIET, np.random.default_rng(11), DT)
    mb = suite2.sample(state(0, q_nb=euler_to_quat(0.0, 0.0, 1.0))).mag_b_gauss
    dec, _ = declination_inclination_rad(suite2.mag_field_ned_gauss)
    assert math.atan2(-mb[1], mb[0]) + dec == pytest.approx(1.0, abs=1e-9)


# --- airspeed ------------------------------------------------------------------------

def test_airspeed_from_differential_pressure_is_equivalent_airspeed():
    # GIVEN 25 m/s true airspeed in air of density 1.0 kg/m^3 (as the plant reports)
    suite = SensorSuite(SensorParams(), np.random.default_rng(12), DT)
    r = [x for x in run(suite, 4000, lambda k, t: state(t, airspeed=25.0, rho_kgm3=1.0))
         if x.airspeed_updated]
    dp = np.array([x.diff_pressure_pa for x in r])
    asp = np.array([x.airspeed_mps for x in r])
    # THEN dp = 1/2 rho V^2 = 312.5 Pa with 1.5 Pa noise
    assert dp.mean() == pytest.approx(312.5, abs=5 * 1.5 / math.sqrt(len(dp)))
    assert dp.std() == pytest.approx(1.5, rel=0.08)
    # AND the airspeed is EAS = V sqrt(rho / rho0) = 22.59 m/s, each sample from its dp
    assert asp.mean() == pytest.approx(25.0 * math.sqrt(1.0 / 1.225), abs=0.01)
    np.testing.assert_allclose(asp, np.sqrt(2 * dp / 1.225))


def test_airspeed_at_rest_is_never_negative_or_nan():
    # GIVEN a vehicle at rest: dp is noise around 0
    suite = SensorSuite(SensorParams(), np.random.default_rng(13), DT)
    r = run(suite, 500)
    asp = np.array([x.airspeed_mps for x in r])
    # THEN the airspeed is finite and >= 0, and dp takes both signs
    assert np.all(np.isfinite(asp)) and np.all(asp >= 0.0)
    dps = [x.diff_pressure_pa for x in r]
    assert min(dps) < 0.0 < max(dps)


# --- determinism and cost ----------------------------------------------------------------

def _record(seed, n=1500):
    frame, v, make = moving_truth()
    suite = SensorSuite(SensorParams(), np.random.default_rng(seed), DT)
    out = []
    for x in run(suite, n, make):
        g = x.gps
        out.append(np.concatenate((
            x.accel_b, x.gyro_b, x.mag_b_gauss,
            [x.pressure_pa, x.pressure_alt_m, x.temperature_k, x.diff_pressure_pa,
             x.airspeed_mps],
            [g.lat_rad, g.lon_rad, g.alt_m, *g.v_ned, g.satellites] if g else [0.0] * 7)))
    return np.array(out)


def test_same_seed_is_bit_identical_and_another_seed_differs():
    # GIVEN two runs with seed 42 and one with seed 43
    a, b, c = _record(42), _record(42), _record(43)
    # THEN the seed-42 runs are bit-identical, and seed 43 differs in every channel kind
    assert np.array_equal(a, b)
    assert not np.any(np.all(a == c, axis=0)[:14])


# --- faults --------------------------------------------------------------------------

def faulty(seed=20, params=None, dt=DT):
    p = params or SensorParams()
    return (SensorSuite(p, np.random.default_rng(seed), dt),
            FaultInjector(np.random.default_rng(seed + 1000), p, dt))


def step_all(suite, inj, t0_s, t1_s, make=lambda k, t: state(t), dt=DT):
    out = []
    for k in range(int(round(t0_s / dt)), int(round(t1_s / dt))):
        out.append(inj.apply(suite.sample(make(k, int(round(k * dt * 1e6))))))
    return out


def test_normals_in_blocks_are_the_scalar_draws_in_order():
    # GIVEN two generators of one seed
    # WHEN one is read through readings.normals (blocks of 7) and the other one
    # standard_normal() at a time
    # THEN the numbers are the same, across block boundaries, and nothing is drawn
    # before the first number is asked for
    from sim_bridge.sensors.readings import normals
    a, b = np.random.default_rng(11), np.random.default_rng(11)
    stream = normals(a, block=7)
    assert a.bit_generator.state == b.bit_generator.state
    assert [next(stream) for _ in range(30)] == [float(b.standard_normal()) for _ in range(30)]


def test_gps_off_stops_fixes_and_ok_brings_them_back():
    suite, inj = faulty()
    # GIVEN fixes flowing for 5 s
    before = step_all(suite, inj, 0.0, 5.0)
    assert sum(x.gps is not None for x in before) == 25   # 0.15 s ... 4.95 s
    # WHEN the GPS is failed off (by MAVLink numbers) for 10 s
    assert inj.inject(mav.FAILURE_UNIT_SENSOR_GPS, mav.FAILURE_TYPE_OFF, 0) is True
    assert inj.active == [(4, 1, 0, {})]
    during = step_all(suite, inj, 5.0, 15.0)
    # THEN no fix arrives, and the other sensors carry on
    assert all(x.gps is None for x in during)
    assert sum(x.baro_updated for x in during) == 500
    # WHEN it is cleared with type ok (by name)
    assert inj.inject("gps", "ok") is True
    after = step_all(suite, inj, 15.0, 20.0)
    # THEN fixes resume at 5 Hz at once, with fresh (not stale) validity times
    fixes = [x.gps for x in after if x.gps is not None]
    assert len(fixes) == 25
    assert fixes[0].t_us <= 15_200_000
    assert fixes[0].t_valid_us >= 14_800_000
    assert inj.active == []


def test_unsupported_combinations_are_refused():
    suite, inj = faulty()
    # THEN units without a model, unknown numbers and other sensor instances give False
    assert inj.inject(mav.FAILURE_UNIT_SYSTEM_BATTERY, mav.FAILURE_TYPE_OFF) is False
    assert inj.inject(mav.FAILURE_UNIT_SENSOR_OPTICAL_FLOW, mav.FAILURE_TYPE_OFF) is False
    assert inj.inject(99, 1) is False
    assert inj.inject("gps", 42) is False
    assert inj.inject("gps", "off", instance=2) is False
    assert inj.inject("servo", "slow") is False
    assert inj.inject("motor", "off", instance=1) is False   # the plane has one motor
    assert inj.active == []
    # AND a bad magnitude is an error, not a silent default
    with pytest.raises(FaultSpecError):
        inj.inject("gyro", "garbage", noise_scale=0.5)
    with pytest.raises(FaultSpecError):
        inj.inject("gps", "off", bias=1.0)


def test_gyro_stuck_holds_the_last_value_while_the_truth_moves():
    suite, inj = faulty()
    turning = lambda k, t: state(t, omega_b=(0.1 * math.sin(k * 0.05), 0.2, 0.0))
    last = step_all(suite, inj, 0.0, 1.0, turning)[-1].gyro_b
    # WHEN the gyro sticks
    assert inj.inject("gyro", "stuck")
    r = step_all(suite, inj, 1.0, 3.0, turning)
    # THEN every reading is the one before the fault, and the accel is unaffected
    assert all(np.array_equal(x.gyro_b, last) for x in r)
    assert len({x.accel_b[0] for x in r}) == len(r)


def test_wrong_bias_on_one_axis_and_on_baro():
    suite, inj = faulty()
    step_all(suite, inj, 0.0, 1.0)
    # WHEN gyro axis 2 gets a 0.1 rad/s bias and the baro +20 m
    assert inj.inject("gyro", "wrong", bias=0.1, axis=2)
    assert inj.inject("baro", "wrong", bias=20.0)
    r = step_all(suite, inj, 1.0, 11.0)
    g = np.array([x.gyro_b for x in r])
    alt = np.array([x.pressure_alt_m for x in r if x.baro_updated])
    # THEN only axis 2 is offset, by 0.1 (noise 1.7e-3, bias < 4e-3 rad/s)
    assert g[:, 2].mean() == pytest.approx(0.1, abs=0.01)
    assert np.all(np.abs(g[:, :2].mean(axis=0)) < 0.01)
    # AND the baro altitude reads 20 m high
    assert alt.mean() == pytest.approx(HOME[2] + 20.0, abs=1.0)
    # WHEN cleared, THEN the truth comes back
    inj.inject("gyro", "ok")
    g2 = np.array([x.gyro_b for x in step_all(suite, inj, 11.0, 12.0)])
    assert abs(g2[:, 2].mean()) < 0.01


def test_garbage_scales_the_noise_std():
    # GIVEN a gyro with white noise only
    p = dataclasses.replace(QUIET, gyro_noise_density=1.75e-4)
    suite, inj = faulty(params=p)
    base = np.array([x.gyro_b for x in step_all(suite, inj, 0.0, 20.0)])
    # WHEN garbage with noise_scale 10
    inj.inject("gyro", "garbage", noise_scale=10.0)
    bad = np.array([x.gyro_b for x in step_all(suite, inj, 20.0, 40.0)])
    # THEN the std is 10x the nominal (2000 samples: within 5 %)
    assert bad.std() / base.std() == pytest.approx(10.0, rel=0.05)


def test_gps_garbage_and_wrong_offsets():
    frame = LocalFrame(*HOME)
    suite, inj = faulty(params=QUIET)
    step_all(suite, inj, 0.0, 1.0)
    # WHEN the GPS is wrong by 15 m north, 5 m west
    inj.inject("gps", "wrong", north_m=15.0, east_m=-5.0)
    f = [x.gps for x in step_all(suite, inj, 1.0, 3.0) if x.gps]
    # THEN every fix is offset by that
    for fix in f:
        np.testing.assert_allclose(frame.to_ned(fix.lat_rad, fix.lon_rad, fix.alt_m),
                                   [15.0, -5.0, 0.0], atol=1e-3)
    # WHEN garbage x10 on a default-noise receiver
    suite, inj = faulty()
    inj.inject("gps", "garbage", noise_scale=10.0)
    f = [x.gps for x in step_all(suite, inj, 0.0, 100.0) if x.gps]
    e = np.array([frame.to_ned(x.lat_rad, x.lon_rad, x.alt_m) for x in f])
    # THEN the horizontal scatter is ~10 x 0.36 m (500 fixes: within 15 %)
    assert e[:, :2].std() == pytest.approx(10 * math.hypot(0.2, 0.3), rel=0.15)


def test_slow_intermittent_and_off_on_flagged_sensors():
    suite, inj = faulty()
    step_all(suite, inj, 0.0, 1.0)
    # WHEN mag is slowed 5x, airspeed drops half its updates, baro is off
    inj.inject("mag", "slow", rate_div=5)
    inj.inject("airspeed", "intermittent", drop_prob=0.5)
    inj.inject("baro", "off")
    r = step_all(suite, inj, 1.0, 21.0)
    # THEN mag updates at 10 Hz, airspeed ~ half of 1000 (+-5 sigma = 80), baro never
    assert sum(x.mag_updated for x in r) == 200
    assert abs(sum(x.airspeed_updated for x in r) - 500) < 80
    assert not any(x.baro_updated for x in r)
    # AND held values do not change between updates
    held = [x.mag_b_gauss for x in r if not x.mag_updated]
    assert len({tuple(m) for m in held}) <= 200
    assert len({x.pressure_pa for x in r}) == 1


def test_imu_off_reads_zero():
    suite, inj = faulty()
    step_all(suite, inj, 0.0, 0.5)
    inj.inject("accel", "off")
    r = step_all(suite, inj, 0.5, 1.0)
    assert all(x.accel_b == (0.0, 0.0, 0.0) for x in r)
    assert all(any(x.gyro_b) for x in r)


def test_delayed_baro_lags_by_delay():
    # GIVEN a noise-free baro on a vehicle climbing at 2 m/s
    suite, inj = faulty(params=QUIET)
    climb = lambda k, t: state(t, alt=100.0 + 2.0 * t * 1e-6)
    step_all(suite, inj, 0.0, 1.0, climb)
    # WHEN the baro is delayed by 0.5 s
    inj.inject("baro", "delayed", delay_s=0.5)
    r = [x for x in step_all(suite, inj, 1.0, 5.0, climb) if x.baro_updated]
    # THEN once filled, each reading is the altitude 0.5 s earlier (1 m lower)
    late = [x for x in r if x.t_us >= 2_000_000]
    for x in late:
        assert x.pressure_alt_m == pytest.approx(100.0 + 2.0 * (x.t_us * 1e-6 - 0.5), abs=1e-6)
    assert len(late) == 150


def test_gps_delayed_stuck_slow():
    suite, inj = faulty(params=QUIET)
    frame, v, make = moving_truth()
    step_all(suite, inj, 0.0, 1.0, make)
    # WHEN the GPS is delayed a further 0.4 s
    inj.inject("gps", "delayed", delay_s=0.4)
    f = [x.gps for x in step_all(suite, inj, 1.0, 3.0, make) if x.gps]
    # THEN fixes are 550 ms old on arrival
    assert {x.t_us - x.t_valid_us for x in f} == {550_000}
    # WHEN stuck: fixes keep coming with the same position
    inj.inject("gps", "stuck")
    f = [x.gps for x in step_all(suite, inj, 3.0, 5.0, make) if x.gps]
    assert len(f) == 10 and len({(x.lat_rad, x.lon_rad) for x in f}) == 1
    # WHEN slowed 4x: 1.25 Hz
    inj.inject("gps", "slow", rate_div=4)
    f = [x.gps for x in step_all(suite, inj, 5.0, 13.0, make) if x.gps]
    assert len(f) == 10


def test_actuator_faults():
    suite, inj = faulty()
    u = (0.2, -0.1, 0.05, 0.7)
    assert inj.apply_controls(u) == u
    # WHEN the elevator sticks at 0.175 rad (half of 0.35 rad max)
    assert inj.inject(mav.FAILURE_UNIT_SYSTEM_SERVO, mav.FAILURE_TYPE_STUCK, 1, value_rad=0.175)
    # AND the aileron loses 40 % effectiveness, the rudder sticks where it is
    assert inj.inject("servo", "wrong", 0, effectiveness=0.6)
    assert inj.inject("servo", "stuck", 2)
    # AND the motor runs at 50 %
    assert inj.inject("motor", "wrong", 0, effectiveness=0.5)
    out = inj.apply_controls((0.5, 0.9, -0.9, 1.0))
    # THEN
    assert out == pytest.approx((0.3, 0.5, 0.05, 0.5))
    # WHEN the motor is off and the elevator cleared
    inj.inject("motor", "off")
    inj.inject("servo", "ok", 1)
    assert inj.apply_controls((0.5, 0.9, -0.9, 1.0)) == pytest.approx((0.3, 0.9, 0.05, 0.0))
