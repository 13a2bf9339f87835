"""The simulator's arrays (stop 40): the gusts' noise block inside their state array,
drawn in place; the quadrotor plant's state, constants and gusts in one array, which
its per-step kernels take whole."""
from __future__ import annotations

import numpy as np

from sim_bridge.plants.quadrotor import QuadrotorPlant, plant_step
from sim_bridge.wind import GUST_STATE_N, DrydenGusts

HOME = (-35.363262, 149.165237, 584.0, 30.0)


def test_the_noise_blocks_are_drawn_in_place_in_the_state_array():
    # GIVEN gusts on a generator, and the same generator's numbers drawn directly
    g = DrydenGusts(np.random.default_rng(3), 0.004, "moderate")
    direct = np.random.default_rng(3).standard_normal((3 * 1024, 3))
    noise = g.noise
    # WHEN three blocks' rows are taken
    rows = [g.noise[g.next_row()].tolist() for _ in range(3 * 1024)]
    # THEN they are the generator's rows in order, each block written over the last in
    # the state array's own memory
    assert rows == direct.tolist()
    assert g.noise is noise and np.shares_memory(g.noise, g.s)
    assert g.noise.tolist() == direct[2048:].tolist()


def test_gusts_given_an_array_keep_their_state_in_it():
    # GIVEN an array, WHEN gusts are made on it
    buf = np.zeros(GUST_STATE_N)
    g = DrydenGusts(np.random.default_rng(1), 0.005, "light", (0.0, 4.0, 0.0), buf)
    # THEN their state is that array, set as a new array's would be
    h = DrydenGusts(np.random.default_rng(1), 0.005, "light", (0.0, 4.0, 0.0))
    assert g.s is buf and buf.tolist() == h.s.tolist()


def test_the_quadrotor_keeps_state_constants_and_gusts_in_one_array():
    # GIVEN a turbulent plant in flight
    p = QuadrotorPlant(HOME, wind_ned=(1.0, 2.0, 0.0), turbulence="severe",
                       rng=np.random.default_rng(6))
    p.set_airborne(15.0)
    # THEN its state, constants and gusts are views of its one array, in that order
    for part in (p._x, p._consts, p._gusts.s):
        assert part.base is p._a
    assert len(p._x) + len(p._consts) + len(p._gusts.s) == len(p._a)
    # AND a step through the plant is plant_step on that array, bit for bit
    q = QuadrotorPlant(HOME, wind_ned=(1.0, 2.0, 0.0), turbulence="severe",
                       rng=np.random.default_rng(6))
    q.set_airborne(15.0)
    u = (0.55, 0.5, 0.52, 0.51)
    for k in range(50):
        st = p.step(u)
        code, readout = plant_step(q._a, q._gusts.next_row(), *u, (k + 1) * 4000)
        assert code == 0 and (st.t_us, st.lat_rad, st.v_ned, st.wind_ned) == \
            (readout[0], readout[1], readout[4], readout[8])
    assert p._a.tolist() == q._a.tolist()
