"""The quadrotor plant's conditions in its arrays (stop 39): the rotor thrust scales and
the ground's depth in its constants, the ground flag in its state, kept by the kernel;
the noise row taken before the noise is read."""
from __future__ import annotations

import math

import numpy as np

from sim_bridge.plants.quadrotor import QuadrotorPlant, flight_step
from sim_bridge.wind import dryden_step

HOME = (-35.363262, 149.165237, 584.0, 30.0)


def test_the_first_turbulent_step_takes_the_generators_first_noise_row():
    # GIVEN a plant at rest in turbulence, its gusts not yet drawn
    p = QuadrotorPlant(HOME, turbulence="light", rng=np.random.default_rng(4),
                       wind_ned=(0.0, 5.0, 0.0))
    s0 = p._gusts.s.copy()
    first = np.random.default_rng(4).standard_normal((1024, 3))[0]
    # WHEN it steps once
    st = p.step((0.3, 0.3, 0.3, 0.3))
    # THEN its gust is dryden_step driven by that row, at the skids' height and the
    # speed through the steady wind, and the state's wind is the steady wind + gust
    want = dryden_step(s0[0], s0[1], s0[2], p.af.gear_height_m, 5.0, p.dt_s, 1, s0[6],
                       *first, s0[7], s0[8])
    assert p._gusts.gust_ned == (want[3], want[4], want[2])
    assert st.wind_ned == (0.0 + want[3], 5.0 + want[4], 0.0 + want[2])


def test_the_ground_flag_follows_the_kernels_codes_and_the_scales_reach_the_rotors():
    # GIVEN a plant on the ground with a rotor at 80 % thrust
    p = QuadrotorPlant(HOME, rng=np.random.default_rng(1))
    p.rotor_scale = (1.0, 0.8, 1.0, 1.0)
    assert p.rotor_scale == (1.0, 0.8, 1.0, 1.0) and p.on_ground
    x0 = p._x.copy()
    # WHEN it runs up to full thrust
    grounded = []
    for _ in range(200):
        grounded.append(p.step((1.0, 1.0, 1.0, 1.0)).on_ground)
    # THEN it rests until the thrust lifts it, then flies, the flag in the state array
    k = grounded.index(False)
    assert 0 < k and not any(grounded[k:]) and not p.on_ground and p._x[23] == 0.0
    # AND its rotor 2 followed the scaled static thrust, as flight_step given the scales
    ref = x0.copy()
    t_ss = p.static_thrusts((1.0, 1.0, 1.0, 1.0))
    for _ in range(200):
        flight_step(ref, p._consts, 1.0, 1.0, 1.0, 1.0, 1.0, 0.8, 1.0, 1.0, 0.0, 0.0, 0.0,
                    True, 0.0)
    assert math.isclose(p.thrust[1], 0.8 * t_ss[1], rel_tol=1e-3)
    assert ref[19:23].tolist() == p._x[19:23].tolist()
    # AND set back on the ground, it rests again
    p.reset()
    assert p.on_ground and p._x[23] == 1.0
    assert p.step((0.0, 0.0, 0.0, 0.0)).on_ground



def _fly(launch: bool, steps: int = 1500):
    """The Aerosonde in light turbulence, catapulted at full throttle (``launch``) or trimmed
    at 60 m and nosed down into the ground: its states and whether JSBSim's ground and
    external reactions ran, step by step."""
    from sim_bridge.plants.base import PlaneControls
    from sim_bridge.plants.jsbsim_plane import JSBSimPlane
    p = JSBSimPlane(wind_ned=(2.0, 1.0, 0.0), turbulence="light", rng=np.random.default_rng(1))
    p.imu_mean_steps = 2
    if launch:
        c = first = PlaneControls(0.0, 0.25, 0.0, 1.0)
    else:
        first = p.trim(22.0, 60.0)
        c = PlaneControls(first.aileron, first.elevator - 0.3, first.rudder, 0.0)
    states, ran = [], []
    for k in range(steps):
        states.append(p.step(first if k < 100 else c, 2))
        ran.append((p._fdm["simulation/models/FGGroundReactions/enabled"],
                    p._fdm["simulation/models/FGExternalReactions/enabled"]))
    return states, ran


def _always_on(monkeypatch):
    from sim_bridge.plants.jsbsim_plane import JSBSimPlane
    switch = JSBSimPlane._set_reactions
    monkeypatch.setattr(JSBSimPlane, "_set_reactions", lambda self, g, l: switch(self, True, True))


def test_the_ground_reactions_are_off_clear_of_the_ground_and_change_nothing(monkeypatch):
    # GIVEN a dive into the ground with the reactions switched, and the same dive with
    # them always on
    states, ran = _fly(launch=False)
    _always_on(monkeypatch)
    always_states, always_ran = _fly(launch=False)
    # THEN the ground reactions were off in flight and back on near the ground, where
    # it landed; the launcher's were off throughout (trimmed: no launcher)
    assert set(always_ran) == {(1.0, 1.0)}
    assert ran[0] == (0.0, 0.0) and ran[-1] == (1.0, 0.0)
    assert min(s.alt_m for s, (g, _) in zip(states, ran) if not g) > 10.0
    assert states[-1].on_ground and min(s.alt_m for s, (g, _) in zip(states, ran) if g) < 5.0
    # AND every state is the one the reactions always on give, bit for bit
    assert states == always_states


def test_the_launchers_reactions_stop_after_the_release_and_change_nothing(monkeypatch):
    # GIVEN a catapult launch, uncontrolled (it flies back into the ground), with the
    # reactions switched, and the same with them always on
    states, ran = _fly(launch=True, steps=1000)
    _always_on(monkeypatch)
    always_states, _ = _fly(launch=True, steps=1000)
    # THEN both ran on the launcher; the launcher's stopped after the release, the
    # ground's stayed on, near the ground
    assert ran[0] == (1.0, 1.0) and states[0].on_ground
    released = next(k for k, (_, l) in enumerate(ran) if not l)
    assert 100 < released < 300 and all(not l for _, l in ran[released:])
    assert all(g for g, _ in ran) and states[-1].on_ground
    # AND every state is the one the reactions always on give, bit for bit
    assert states == always_states


def test_holding_a_vehicle_airborne_is_set_airborne_then_its_state():
    # GIVEN two plants alike, flown 0.4 s in turbulence and wind on the same commands
    p, q = (QuadrotorPlant(HOME, turbulence="moderate", rng=np.random.default_rng(9),
                           wind_ned=(2.0, -3.0, 0.0)) for _ in range(2))
    for k in range(100):
        u = (0.62, 0.6, 0.61 + 0.001 * k, 0.6)
        p.step(u)
        q.step(u)
    # WHEN one is set airborne and read, and the other held in one call
    p.set_airborne(12.5)
    st_p = p.state()
    st_q = q.hold_airborne(12.5)
    # THEN both hold the same state, bit for bit, hovering 12.5 m above home
    assert st_q == st_p
    assert np.array_equal(q._x, p._x) and not q.on_ground
    assert st_q.alt_m == HOME[2] + 12.5 and st_q.v_ned == (0.0, 0.0, 0.0) and st_q.wind_ned != (2.0, -3.0, 0.0)
    assert q.thrust == [q.af.mass_kg * q.g / 4.0] * 4
