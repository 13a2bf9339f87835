"""The simulator's one-call-per-step kernels against the laws they compose, bit for bit
(sim_bridge/wind.py gust_advance, sim_bridge/plants/quadrotor.py plant_step and
state_readout)."""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import LocalFrame
from sim_bridge.plants.quadrotor import (QuadrotorPlant, air_data, flight_step, plant_step,
                                         state_readout)
from sim_bridge.wind import DrydenGusts, dryden_step, gust_advance


def test_gust_advance_is_dryden_step_on_the_state_array():
    # GIVEN turbulent gusts with some filter state and a block of noise
    g = DrydenGusts(np.random.default_rng(2), 0.005, "moderate", (3.0, -4.0, 0.0))
    g.s[0:3] = (0.4, -1.2, 0.3)
    noise = np.random.default_rng(3).standard_normal((4, 3))
    g.noise[:4] = noise
    s0 = g.s.copy()
    # WHEN one step is taken on row 2
    got = gust_advance(g.s, 2, 37.5, 18.0, 2)
    # THEN it is dryden_step on the same numbers, written into the state array
    want = dryden_step(s0[0], s0[1], s0[2], 37.5, 18.0, 0.005, 2, s0[6], *noise[2], s0[7], s0[8])
    assert got == (want[3], want[4], want[2])
    assert g.s[0:6].tolist() == [want[0], want[1], want[2], want[3], want[4], want[2]]
    assert g.gust_ned == got
    assert g.s[6:].tolist() == s0[6:].tolist()


def test_gusts_draw_their_noise_in_blocks_in_order():
    # GIVEN gusts on a generator, and the same generator's numbers drawn directly
    g = DrydenGusts(np.random.default_rng(9), 0.004, "light")
    direct = np.random.default_rng(9).standard_normal((2048, 3))
    # WHEN 1500 rows are taken
    rows = []
    for _ in range(1500):
        k = g.next_row()                          # (first: it may draw a new block)
        rows.append(g.noise[k].tolist())
    # THEN they are the generator's rows in order, across the block boundary
    assert rows == direct[:1500].tolist()


def _plant(turbulence="light", wind=(1.0, 3.0, 0.0), home=(-35.36, 149.17, 584.0, 30.0)):
    p = QuadrotorPlant(home=home, wind_ned=wind, turbulence=turbulence,
                       rng=np.random.default_rng(5))
    p.set_airborne(25.0)
    return p


def test_state_readout_is_air_data_and_the_frames_geodetic_position():
    # GIVEN plant states east and west of home, across the antimeridian
    for home in ((-35.36, 149.17, 584.0, 0.0), (10.0, 179.9999, 20.0, 0.0),
                 (60.0, -179.9999, 0.0, 0.0)):
        p = _plant(home=home)
        rng = np.random.default_rng(1)
        frame = LocalFrame.from_degrees(*home[:3])
        for _ in range(50):
            x = p._x
            x[0:6] = rng.standard_normal(6) * (400.0, 400.0, 50.0, 10.0, 10.0, 3.0)
            q = rng.standard_normal(4)
            x[6:10] = q / np.linalg.norm(q)
            p._gusts.s[3:6] = rng.standard_normal(3)
            # WHEN the readout is taken
            got = state_readout(x, p._consts, p._gusts.s, 123_000, True)
            # THEN it is the time, LocalFrame.to_geodetic_fast, the state's vectors,
            # air_data in the steady wind + gust (stored in the state as its wind), the
            # ground flag and the plant's air density
            y = x.copy()
            gn, ge, gd = p._gusts.gust_ned
            want_air = air_data(y, 1.0 + gn, 3.0 + ge, 0.0 + gd)
            want_geo = frame.to_geodetic_fast(x[0:3].tolist())
            xs = x.tolist()
            assert got == (123_000, *want_geo, tuple(xs[3:6]), tuple(xs[6:10]),
                           tuple(xs[10:13]), tuple(xs[13:16]), tuple(xs[16:19]), *want_air,
                           True, p.rho)
            assert xs == y.tolist()


def test_plant_step_is_the_gust_then_flight_step_then_the_readout():
    # GIVEN two identical turbulent plants in flight
    a, b = _plant("severe"), _plant("severe")
    u = (0.52, 0.55, 0.5, 0.53)
    k = (1.0, 0.9, 1.0, 1.0)
    a.rotor_scale = k                             # (plant_step reads the scales from its constants)
    for _ in range(300):
        # WHEN one takes plant_step and the other the steps it composes, in Python
        row = a._gusts.next_row()
        code, readout = plant_step(a._a, row, *u, 4000)
        x = b._x
        wn, we, wd = b._wind
        an, ae, ad = x[3] - wn, x[4] - we, x[5] - wd
        row = b._gusts.next_row()
        gn, ge, gd = gust_advance(b._gusts.s, row, -x[2],
                                  math.sqrt(an * an + ae * ae + ad * ad), 1)
        want = flight_step(x, b._consts, *u, *k, wn + gn, we + ge, wd + gd, False, 0.0)
        # THEN the states, gusts, readouts and codes agree bit for bit
        assert readout == state_readout(x, b._consts, b._gusts.s, 4000, False)
        assert code == want == 0
        assert a._x.tolist() == b._x.tolist()
        assert a._gusts.s.tolist() == b._gusts.s.tolist()


def test_plant_step_without_turbulence_draws_nothing():
    # GIVEN a plant in still turbulence-free air
    p = _plant("none", (0.0, 0.0, 0.0))
    state = p._gusts._rng.bit_generator.state
    # WHEN it steps
    for _ in range(20):
        st = p.step((0.5,) * 4)
    # THEN no random number is drawn and the state's wind is the steady wind
    assert p._gusts._rng.bit_generator.state == state
    assert st.wind_ned == (0.0, 0.0, 0.0)
