"""The propeller's speed as ESC telemetry: the sensor (sim_bridge/sensors/rpm.py), its
MAVLink message on the HIL link (ESC_TELEMETRY_1_TO_4, sim_bridge/hil.py and
autopilot/link/hil.py), and its stream of the seed."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from autopilot.link.codec import MAV, Codec
from autopilot.link.hil import ID_ESC, AutopilotHilEnd
from autopilot.link.transports import memory_pair
from autopilot.messages import RpmSample
from sim_bridge.hil import SimulatorHilEnd, esc_telemetry_payload
from sim_bridge.plants.base import PlantState
from sim_bridge.plants.jsbsim_plane import JSBSimPlane
from sim_bridge.sensors import SensorParams, SensorSuite
from sim_bridge.sensors.rpm import RpmParams, RpmReading, RpmSensor


def state(t_us=0, rpm=6000.0):
    return PlantState(t_us=t_us, lat_rad=math.radians(-35.36), lon_rad=math.radians(149.17),
                      alt_m=600.0, v_ned=np.zeros(3), q_nb=np.array((1.0, 0.0, 0.0, 0.0)),
                      omega_b=np.zeros(3), f_b=np.array((0.0, 0.0, -9.80665)), wind_ned=np.zeros(3),
                      airspeed_mps=25.0, alpha_rad=0.0, beta_rad=0.0, on_ground=False, rpm=rpm)


# --- the wire -------------------------------------------------------------------------

def test_esc_telemetry_bytes_are_the_mavlink_message():
    ours = Codec(1, MAV.MAV_COMP_ID_USER1).frame(ID_ESC, esc_telemetry_payload(RpmReading(1_000_000, 6123.4), 7))
    # temperature, voltage, current, totalcurrent 0 (not measured); ESC 1's rpm rounded,
    # its frame count
    ref = MAV.MAVLink(None, 1, MAV.MAV_COMP_ID_USER1)
    theirs = MAV.MAVLink_esc_telemetry_1_to_4_message([0] * 4, [0] * 4, [0] * 4, [0] * 4,
                                                      [6123, 0, 0, 0], [7, 0, 0, 0]).pack(ref)
    assert ours == theirs
    m = MAV.MAVLink(None, 255, 0).decode(bytearray(ours))
    assert m.get_type() == "ESC_TELEMETRY_1_TO_4" and list(m.rpm) == [6123, 0, 0, 0]
    assert list(m.count) == [7, 0, 0, 0] and list(m.voltage) == list(m.temperature) == [0] * 4
    # saturated to the uint16 field, never negative; the count rolls over
    m = MAV.MAVLink(None, 255, 0).decode(bytearray(Codec(1, 1).frame(
        ID_ESC, esc_telemetry_payload(RpmReading(0, 70000.0), 65537))))
    assert list(m.rpm) == [65535, 0, 0, 0] and list(m.count) == [1, 0, 0, 0]


def test_rpm_round_trip_in_lockstep():
    sim_t, ap_t = memory_pair()
    sim, ap = SimulatorHilEnd(sim_t), AutopilotHilEnd(ap_t)
    suite = SensorSuite(SensorParams(), np.random.default_rng(1), 0.01)
    frames = []
    for k, (rpm, t_us) in enumerate(((6543.6, 1_000_000), (0.2, 1_010_000), (None, 1_020_000))):
        st = state(t_us)
        sim.send_step(suite.sample(st), st, None, None if rpm is None else RpmReading(t_us, rpm))
        steps = ap.poll()
        assert len(steps) == 1
        frames.append(steps[0][0])
    # the step's time, the rpm to the unit the field carries
    assert frames[0].rpm == RpmSample(1_000_000, 6544.0)
    assert frames[1].rpm == RpmSample(1_010_000, 0.0)
    assert frames[2].rpm is None and frames[2].t_us == 1_020_000


# --- the sensor -------------------------------------------------------------------------

def test_readings_at_the_rate_with_the_noise_and_the_seed_alone():
    def readings(seed, n=20000):
        rs = RpmSensor(RpmParams(), np.random.default_rng(seed))
        return [r for r in (rs.sample(state(k * 10_000)) for k in range(n)) if r is not None]
    got = readings(5)
    assert len(got) == 4000                                  # 20 Hz of 100 Hz steps
    assert all(got[i + 1].t_us - got[i].t_us == 50_000 for i in range(len(got) - 1))
    e = np.array([r.rpm for r in got]) / 6000.0 - 1.0
    # 4000 draws of 0.5 %: mean within 4 standard errors, sigma within 5 %
    assert abs(e.mean()) < 4 * 0.005 / math.sqrt(4000)
    assert 0.95 * 0.005 < e.std() < 1.05 * 0.005
    assert [r.rpm for r in got[:50]] == [r.rpm for r in readings(5, n=250)]
    assert got[0].rpm != readings(6, n=10)[0].rpm


def test_reading_is_the_plants_propeller_speed():
    # GIVEN the plant trimmed at 25 m/s, then the throttle stepped to 0.8 and held 2 s
    plant = JSBSimPlane(home=(47.0, 8.0, 500.0, 270.0))
    c = plant.trim(airspeed_mps=25.0, height_m=100.0)
    rs = RpmSensor(RpmParams(), np.random.default_rng(3))
    st0 = plant.state()
    fdm = plant._fdm
    assert st0.rpm == fdm["propulsion/engine/propeller-rpm"] and st0.rpm > 3000.0
    errs = []
    n = int(round(2.0 / plant.dt_s))          # 2 s of plant steps
    for k in range(n):
        st = plant.step(replace(c, throttle=0.8), 1)
        r = rs.sample(st)
        if r is not None:
            # THEN each reading is the plant's propeller speed within 2 % (4 sigma)
            assert r.t_us == st.t_us
            errs.append(r.rpm / fdm["propulsion/engine/propeller-rpm"] - 1.0)
    assert len(errs) == 40 and max(abs(e) for e in errs) < 0.02, max(abs(e) for e in errs)
    # AND the speed rose with the throttle (the rotor's spin-up, measured 63 % in 0.5 s)
    assert plant.state().rpm > st0.rpm + 500.0


def test_the_rpm_sensor_has_its_own_stream_and_leaves_the_others_as_they_were():
    from sim_bridge.world import build_world
    home = (-35.363262, 149.165237, 584.0, 0.0)
    w = build_world(home, 7)
    # (the c172p's engine tachometer too: the throttle's monitor, FDI_EL_MODEL 2)
    assert w.rpm is not None and build_world(home, 7, airframe="c172p").rpm is not None
    assert build_world(home, 7, vehicle="quad").rpm is None
    seq = np.random.SeedSequence(7).spawn(5)
    old = [np.random.default_rng(s) for s in np.random.SeedSequence(7).spawn(4)]
    SensorSuite(SensorParams(), old[1], 0.01)           # the suite's draws at construction
    assert w.sensors._rng.bit_generator.state == old[1].bit_generator.state
    assert w.faults._rng.bit_generator.state == old[2].bit_generator.state
    assert w.rangefinder._rng.bit_generator.state == old[3].bit_generator.state
    assert w.rpm._rng.bit_generator.state == np.random.default_rng(seq[4]).bit_generator.state


def test_ground_station_gets_the_rpm_as_esc_telemetry():
    from types import SimpleNamespace

    from autopilot.gcs.telemetry import STREAMS, Telemetry
    assert STREAMS["ESC_TELEMETRY_1_TO_4"][2] == MAV.MAV_DATA_STREAM_EXTRA3
    v = SimpleNamespace(mav_type=MAV.MAV_TYPE_FIXED_WING, rpm=-1.0)
    tm = Telemetry(v)
    # nothing before the ESC has reported; then its rpm on ESC 1, on real bytes
    assert tm.build("ESC_TELEMETRY_1_TO_4", 0) is None
    v.rpm = 6543.4
    m = tm.build("ESC_TELEMETRY_1_TO_4", 0)
    buf = Codec(1, 1).encode(m)
    back = MAV.MAVLink(None, 255, 0).decode(bytearray(buf))
    assert list(back.rpm) == [6543, 0, 0, 0]
