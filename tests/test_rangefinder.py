"""The downward rangefinder: the simulator's lidar (sim_bridge/sensors/rangefinder.py),
its DISTANCE_SENSOR on the HIL link (sim_bridge/hil.py -> autopilot/link/hil.py), and
the autopilot's use of it on a landing (autopilot/guidance/rangefinder.py, RNGFND_*)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.geo import euler_to_quat
from autopilot.guidance.landing import Landing
from autopilot.guidance.rangefinder import RangefinderHeight
from autopilot.link.codec import MAV, Codec
from autopilot.link.hil import HIL_IDS, ID_DISTANCE, AutopilotHilEnd
from autopilot.link.transports import memory_pair
from autopilot.messages import RangeSample
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations
from sim_bridge.hil import SimulatorHilEnd, distance_sensor_payload
from sim_bridge.plants.base import PlantState
from sim_bridge.sensors import SensorParams, SensorSuite
from sim_bridge.sensors.rangefinder import Rangefinder, RangefinderParams, RangeReading

HOME_ALT = 584.0


def state(t_us=0, h=10.0, roll_deg=0.0, pitch_deg=0.0):
    q = np.array(euler_to_quat(math.radians(roll_deg), math.radians(pitch_deg), 0.3))
    return PlantState(t_us=t_us, lat_rad=math.radians(-35.36), lon_rad=math.radians(149.17),
                      alt_m=HOME_ALT + h, v_ned=np.zeros(3), q_nb=q, omega_b=np.zeros(3),
                      f_b=np.array((0.0, 0.0, -9.80665)), wind_ned=np.zeros(3), airspeed_mps=20.0,
                      alpha_rad=0.0, beta_rad=0.0, on_ground=False)


# --- the wire -------------------------------------------------------------------------

def test_distance_sensor_bytes_are_the_mavlink_message():
    r = RangeReading(123_450_000, 12.345, 0.05, 40.0, 0.025)
    ours = Codec(1, MAV.MAV_COMP_ID_USER1).frame(ID_DISTANCE, distance_sensor_payload(r))
    # time_boot_ms, min/max/current [cm], LASER, id 0, PITCH_270 (down), variance [cm^2],
    # fovs 0, quaternion 0, signal quality 100
    ref = MAV.MAVLink(None, 1, MAV.MAV_COMP_ID_USER1)
    theirs = MAV.MAVLink_distance_sensor_message(123_450, 5, 4000, 1235, 0, 0, 25, 6, 0.0, 0.0,
                                                 [0.0] * 4, 100).pack(ref)
    assert ours == theirs and ours[7] == 132 and len(ours) == 12 + 39
    # no return: over range (max + 1 cm), "invalid signal"
    m = MAV.MAVLink(None, 255, 0).decode(bytearray(Codec(1, 1).frame(
        ID_DISTANCE, distance_sensor_payload(RangeReading(10_000, None, 0.05, 40.0, 0.025)))))
    assert (m.current_distance, m.signal_quality) == (4001, 1)


def test_distance_sensor_round_trip_in_lockstep():
    sim_t, ap_t = memory_pair()
    sim, ap = SimulatorHilEnd(sim_t), AutopilotHilEnd(ap_t)
    suite = SensorSuite(SensorParams(), np.random.default_rng(1), 0.01)
    frames = []
    for k, (dist, t_us) in enumerate(((7.891, 1_000_000), (None, 1_010_000), (None, 1_020_000))):
        st = state(t_us)
        rd = None if k == 2 else RangeReading(t_us, dist, 0.05, 40.0, 0.025)
        sim.send_step(suite.sample(st), st, rd)
        steps = ap.poll()
        assert len(steps) == 1
        frames.append(steps[0][0])
    assert frames[0].range == RangeSample(1_000_000, 789 * 0.01, 5 * 0.01, 4000 * 0.01, 25, 100)
    assert frames[1].range == RangeSample(1_010_000, 4001 * 0.01, 5 * 0.01, 4000 * 0.01, 25, 1)
    assert frames[2].range is None          # none sent with this step's HIL_SENSOR
    assert frames[2].t_us == 1_020_000


# --- the sensor's geometry, noise, rate -------------------------------------------------

def test_range_along_the_body_down_axis_reads_long_when_tilted_and_none_past_limits():
    rf = Rangefinder(RangefinderParams(), np.random.default_rng(0), HOME_ALT)
    assert rf.true_range_m(state(h=10.0)) == pytest.approx(10.0, abs=1e-9)
    assert rf.true_range_m(state(h=10.0, roll_deg=30.0)) == pytest.approx(10.0 / math.cos(math.radians(30)), abs=1e-9)
    assert rf.true_range_m(state(h=10.0, roll_deg=20.0, pitch_deg=-25.0)) == pytest.approx(
        10.0 / (math.cos(math.radians(20)) * math.cos(math.radians(25))), abs=1e-9)
    assert rf.true_range_m(state(h=10.0, roll_deg=44.0)) == pytest.approx(13.90, abs=0.01)
    assert rf.true_range_m(state(h=10.0, roll_deg=46.0)) is None          # past 45 deg: no return
    assert rf.true_range_m(state(h=10.0, roll_deg=30.0, pitch_deg=36.0)) is None  # 45.5 deg off vertical
    assert rf.true_range_m(state(h=39.9)) == pytest.approx(39.9, abs=1e-9)
    assert rf.true_range_m(state(h=40.2)) is None                           # past 40 m
    assert rf.true_range_m(state(h=35.0, roll_deg=30.0)) is None            # 40.4 m slant
    # the ground from the terrain under the aircraft when there is one
    rf_t = Rangefinder(RangefinderParams(), np.random.default_rng(0), HOME_ALT, terrain=lambda la, lo: HOME_ALT + 4.0)
    assert rf_t.true_range_m(state(h=10.0)) == pytest.approx(6.0, abs=1e-9)


def test_readings_at_the_rate_with_the_noise_and_the_seed_alone():
    def readings(seed, h=20.0, n=20000):
        rf = Rangefinder(RangefinderParams(), np.random.default_rng(seed), HOME_ALT)
        out = [rf.sample(state(k * 10_000, h=h)) for k in range(n)]
        return out
    a = readings(5)
    got = [r for r in a if r is not None]
    assert len(got) == 4000                                  # 20 Hz of 100 Hz steps
    assert all(got[i + 1].t_us - got[i].t_us == 50_000 for i in range(len(got) - 1))
    e = np.array([r.distance_m for r in got]) - 20.0
    # 4000 draws of sigma 0.025: mean within 4 standard errors, sigma within 5 %
    assert abs(e.mean()) < 4 * 0.025 / math.sqrt(4000)
    assert 0.95 * 0.025 < e.std() < 1.05 * 0.025
    assert [r.distance_m for r in got[:50]] == [r.distance_m for r in readings(5, n=250) if r is not None]
    assert got[0].distance_m != [r for r in readings(6, n=10) if r is not None][0].distance_m
    # out of range: no distance, and the same draws consumed (the next in-range reading
    # carries the noise it would have carried)
    rf1 = Rangefinder(RangefinderParams(), np.random.default_rng(5), HOME_ALT)
    rf2 = Rangefinder(RangefinderParams(), np.random.default_rng(5), HOME_ALT)
    assert rf1.sample(state(0, h=60.0)).distance_m is None
    assert rf2.sample(state(0, h=20.0)).distance_m is not None
    assert rf1.sample(state(50_000, h=20.0)).distance_m == rf2.sample(state(50_000, h=20.0)).distance_m


# --- the autopilot's use on a landing ---------------------------------------------------

def params(**kw):
    p = ParamStore(plane_param_declarations())
    for k, v in {"RNGFND1_TYPE": 100, "RNGFND1_MIN_CM": 5, "RNGFND1_MAX_CM": 4000,
                 "RNGFND1_GNDCLEAR": 17, "RNGFND_LANDING": 1, **kw}.items():
        p.set(k, v)
    return p


def sample(t_us, d, q=1):
    return RangeSample(t_us, d, 0.05, 40.0, 25, 100 if q else 1)


LEVEL = np.array((1.0, 0.0, 0.0, 0.0))


def test_correction_engages_after_ten_moving_readings_and_filters_as_arduplane():
    rf = RangefinderHeight(params())
    notes = []
    # descending from 30 m at 1 m/s, the navigation 0.8 m high: readings every 50 ms
    t, k = 0, 0
    while not rf.in_range:
        h = 30.0 - 0.05 * k
        notes.append(rf.update(t, sample(t, h + 0.17), LEVEL, h + 0.8, True))
        assert rf.correction_m(t, True) == 0.0 or rf.in_range
        t += 50_000
        k += 1
    # the first 2 m of the descent (5 % of 40 m) do not count, then 10 readings, then in range
    assert 2.0 / 0.05 + 10 <= k <= 2.0 / 0.05 + 12
    assert "Rangefinder engaged at" in (notes[-1] or "")
    assert rf.correction_m(t, True) == pytest.approx(0.8, abs=1e-9)     # the first whole
    rf.update(t, sample(t, 20.17), LEVEL, 20.0 + 1.8, True)             # the navigation jumps 1 m
    assert rf.correction_m(t, True) == pytest.approx(0.8 * 0.8 + 0.2 * 1.8, abs=1e-9)
    # not on a landing, or RNGFND_LANDING 0: nothing
    assert rf.correction_m(t, False) == 0.0
    rf.params.set("RNGFND_LANDING", 0)
    assert rf.correction_m(t, True) == 0.0
    rf.params.set("RNGFND_LANDING", 1)
    # out of range (under RNGFND1_MIN_CM, or no return): kept 5 s, then the navigation's
    c = rf.correction_m(t, True)
    rf.update(t + 50_000, sample(t + 50_000, 0.03), LEVEL, 0.5, True)
    rf.update(t + 100_000, sample(t + 100_000, 40.01, q=0), LEVEL, 0.5, True)
    assert not rf.in_range
    assert rf.correction_m(t + 5_000_000, True) == c
    assert rf.correction_m(t + 5_100_000, True) == 0.0


def test_tilt_corrected_height_and_a_stuck_sensor_never_engages():
    rf = RangefinderHeight(params())
    q = np.array(euler_to_quat(math.radians(30.0), math.radians(10.0), 1.0))
    rf.update(0, sample(0, 10.0), q, 9.0, True)
    assert rf.height_m == pytest.approx(10.0 * math.cos(math.radians(30)) * math.cos(math.radians(10)) - 0.17, abs=1e-9)
    stuck = RangefinderHeight(params())
    for k in range(200):
        stuck.update(k * 50_000, sample(k * 50_000, 12.0), LEVEL, 11.0, True)
    assert not stuck.in_range and stuck.correction_m(200 * 50_000, True) == 0.0
    off = RangefinderHeight(params(RNGFND1_TYPE=0))
    for k in range(100):
        off.update(k * 50_000, sample(k * 50_000, 30.0 - 0.1 * k), LEVEL, 31.0 - 0.1 * k, True)
    assert not off.in_range and off.correction_m(100 * 50_000, True) == 0.0


def test_landing_flies_the_corrected_height():
    p = params()
    land = Landing(p, (0.0, 0.0), (1000.0, 0.0), 45.0, 0.0, 25.0)
    a = Landing(p, (0.0, 0.0), (1000.0, 0.0), 45.0, 0.0, 25.0)
    along = 900.0
    # the glide slope's demand moves with the correction (in the navigation's frame)
    land.h_corr_m = 0.6
    assert land.glide_demand(along) == pytest.approx(a.glide_alt(along) + 0.6, abs=1e-12)
    # the flare's height trigger: 3.4 m by the navigation, 2.8 m by the rangefinder
    v = np.array((25.0, 0.0, 1.2))
    land.step(0, (985.0, 0.0), 3.4, v, 25.0)
    a.step(0, (985.0, 0.0), 3.4, v, 25.0)
    assert land.phase == "flare" and a.phase == "approach"
    assert land.flare_info[0] == pytest.approx(2.8, abs=1e-12)


def test_terrain_between_the_aircraft_and_the_land_point_is_not_a_correction():
    """Over a terrain model the ground under the beam may not be the land point's:
    ArduPlane adds the difference to the rangefinder's height before comparing."""
    rf = RangefinderHeight(params())
    t = 0
    for k in range(60):                       # level at 25 m above ground that is 5 m
        t = k * 50_000                        # above the land point's; navigation exact
        d = 25.17 + (0.001 if k % 2 else 0.0) - 0.05 * k
        rf.update(t, sample(t, d), LEVEL, d - 0.17 + 5.0, True, terrain_m=5.0)
    assert rf.in_range
    assert rf.correction_m(t, True) == pytest.approx(0.0, abs=1e-9)


def test_the_rangefinder_has_its_own_stream_and_leaves_the_others_as_they_were():
    from sim_bridge.world import build_world
    home = (-35.363262, 149.165237, 584.0, 0.0)
    w = build_world(home, 7)
    assert w.rangefinder is not None and build_world(home, 7, airframe="c172p").rangefinder is None
    assert build_world(home, 7, vehicle="quad").rangefinder is None
    # the sensors' and the faults' generators are those of the three-way split before it
    old = [np.random.default_rng(s) for s in np.random.SeedSequence(7).spawn(3)]
    SensorSuite(SensorParams(), old[1], 0.01)           # the suite's draws at construction
    assert w.sensors._rng.bit_generator.state == old[1].bit_generator.state
    assert w.faults._rng.bit_generator.state == old[2].bit_generator.state
    assert w.rangefinder._rng.bit_generator.state == np.random.default_rng(
        np.random.SeedSequence(7).spawn(4)[3]).bit_generator.state
