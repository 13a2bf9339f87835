"""Stop 38, the simulator's per-step work done on the event: the sensor suite's steps of
the IMU alone (before the first slower sensor or fix is due), the fixed-wing gust's
ground velocity (the last readout's), the Aerosonde's unsteered contacts (no steering
command) and the quadrotor's thrust scales (set when an actuator fault changes)."""
from __future__ import annotations

import math

import numpy as np

from sim_bridge.bridge import SimBridge
from sim_bridge.faults import FaultInjector
from sim_bridge.plants.base import PlantState, PlaneControls
from sim_bridge.plants.jsbsim_plane import FT_M, JSBSimPlane
from sim_bridge.sensors import SensorParams, SensorSuite
from sim_bridge.wind import gust_advance

HOME = (-35.36, 149.17, 584.0, 30.0)


def _truth(t_us: int) -> PlantState:
    return PlantState(t_us, math.radians(HOME[0]), math.radians(HOME[1]), HOME[2],
                      (20.0, 1.0, -0.5), (1.0, 0.0, 0.0, 0.0), (0.01, 0.02, 0.03),
                      (0.1, 0.2, -9.8), (0.0, 0.0, 0.0), 20.0, 0.05, 0.0, False)


def test_each_slower_sensor_and_each_fix_keeps_its_own_schedule():
    # GIVEN a suite whose slower sensors run at different rates, and a fix latency off
    #       the other sensors' grids
    params = SensorParams(baro_rate_hz=50.0, mag_rate_hz=25.0, airspeed_rate_hz=10.0,
                          gps_rate_hz=5.0, gps_latency_s=0.03)
    suite = SensorSuite(params, np.random.default_rng(4), dt_s=0.01)
    # WHEN it is sampled every 10 ms for 2 s
    got = []
    for k in range(200):
        r = suite.sample(_truth(k * 10_000))
        got.append((r.baro_updated, r.mag_updated, r.airspeed_updated, r.gps is not None))
    # THEN each updates on its own period from the first step, and the fixes arrive
    #      30 ms after each 200 ms epoch (steps where nothing else updates)
    want = [(k % 2 == 0, k % 4 == 0, k % 10 == 0, k % 20 == 3) for k in range(200)]
    assert got == want
    # AND between updates the held values are the last update's
    a = suite.sample(_truth(200 * 10_000))
    b = suite.sample(_truth(201 * 10_000))
    assert not (b.baro_updated or b.mag_updated or b.airspeed_updated) and b.gps is None
    assert (b.mag_b_gauss, b.pressure_pa, b.temperature_k, b.airspeed_mps) == \
        (a.mag_b_gauss, a.pressure_pa, a.temperature_k, a.airspeed_mps)
    assert b.accel_b != a.accel_b                 # (the IMU: new noise every step)


def _gust_from_jsbsim(plant: JSBSimPlane, n_steps: int) -> tuple:
    """The gust a step is to take, from JSBSim's own velocity (the law, read afresh)."""
    fdm, gusts = plant._fdm, plant._gusts
    v = [fdm[f"velocities/v-{a}-fps"] * FT_M for a in ("north", "east", "down")]
    du, dv, dw = (v[i] - plant._gust_wind[i] for i in range(3))
    s, k = gusts.s.copy(), gusts._k
    assert k < len(gusts.noise)                   # (this row is in the current block)
    return gust_advance(s, k, fdm["position/h-agl-ft"] * FT_M,
                        math.sqrt(du * du + dv * dv + dw * dw), n_steps)


def test_the_gust_takes_the_velocity_jsbsim_has_at_each_step():
    # GIVEN the Aerosonde trimmed in moderate turbulence
    plant = JSBSimPlane(home=HOME, rng=np.random.default_rng(7))
    plant.set_wind((2.0, -3.0, 0.0), "moderate")
    c = plant.trim(22.0, 150.0)
    plant._gusts.next_row()                       # (a block drawn: rows to compare)
    for k in range(40):
        # WHEN it steps (after trim, then step after step)
        want = _gust_from_jsbsim(plant, 2)
        plant.step(c, 2)
        # THEN the gust is the one from JSBSim's velocity read at the step's start
        assert plant._gusts.gust_ned == want
    # AND so after a restart at rest on the launcher, once the catapult has fired
    plant._place_at_start()
    plant.launch()
    plant._gusts.next_row()
    for _ in range(30):
        want = _gust_from_jsbsim(plant, 2)
        plant.step(PlaneControls(throttle=1.0), 2)
        assert plant._gusts.gust_ned == want


def test_the_aerosonde_has_no_steering_command_and_the_c172p_steers():
    # GIVEN each airframe, WHEN a rudder command is applied
    for airframe, steers in (("aerosonde", False), ("c172p", True)):
        plant = JSBSimPlane(airframe, home=HOME)
        plant.step(PlaneControls(rudder=0.4), 1)
        # THEN only the c172p's nose wheel takes it (the Aerosonde's contacts do not
        #      steer: its command is left alone)
        steer = plant._fdm["fcs/steer-cmd-norm"]
        assert steer == (0.4 if steers else 0.0), airframe


class _Link:                                      # the HIL end advance() talks to
    commands: list = []
    armed = True

    def send_battery(self, _b):
        pass


def test_the_rotor_thrust_scales_follow_each_actuator_fault_change():
    # GIVEN a quadrotor behind the bridge with a thrust-scaled motor fault injected
    from sim_bridge.plants.quadrotor import QuadrotorPlant
    p = QuadrotorPlant(home=HOME, rng=np.random.default_rng(1))
    p.set_airborne(20.0)
    inj = FaultInjector(np.random.default_rng(3), dt_s=0.004, motor_channels=(0, 1, 2, 3),
                        thrust_motors=True)
    br = SimBridge(p, None, _Link(), inj, hil_rate_hz=250.0, vehicle="quad")
    u = p.af.hover_command(p.rho, p.g)
    br.advance((u, u, u, u))
    assert p.rotor_scale == (1.0, 1.0, 1.0, 1.0)
    inj.inject("motor", "wrong", 2, effectiveness=0.6)
    br.advance(None)
    assert p.rotor_scale == (1.0, 1.0, 0.6, 1.0)
    # WHEN another is added, then all are cleared
    inj.inject("motor", "wrong", 0, effectiveness=0.8)
    br.advance(None)
    assert p.rotor_scale == (0.8, 1.0, 0.6, 1.0)
    inj.clear_all()
    br.advance(None)
    # THEN the plant's scales follow each change
    assert p.rotor_scale == (1.0, 1.0, 1.0, 1.0)
