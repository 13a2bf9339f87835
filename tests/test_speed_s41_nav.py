"""Stop 41's navigation output (autopilot/nav/base.py): the NavState's vectors are views
of the filter's one output array, written in place at every update."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from autopilot.nav import InsGpsEkf, InsGpsUkf
from autopilot.nav.base import output_into
from autopilot.nav.simulate import SimConfig, simulate_flight

CFG = SimConfig()
PARAMS = {"EK_MAG_DEC": math.radians(CFG.mag_declination_deg), "EK_MAG_AUTODEC": 0}


@pytest.mark.parametrize("cls, kw", [(InsGpsEkf, {"cov_div": 4}), (InsGpsUkf, {})])
def test_the_outputs_vectors_are_the_filters_array_written_at_every_update(cls, kw):
    # GIVEN a simulated fixed-wing flight through the filter (alignment, fusions, a
    # GPS outage)
    sim = simulate_flight(np.random.default_rng(7), CFG, duration_s=20.0,
                          gps_outages=[(12.0, 14.0)])
    filt = cls(PARAMS, "plane", CFG.origin(), **kw)
    first = None
    for frame in sim.frames():
        nav = filt.update(frame)
        vecs = (nav.p_ned, nav.v_ned, nav.q_nb, nav.omega_b)
        if first is None:
            first = vecs
        # THEN every step hands out the same four arrays, views of the filter's buffer
        assert all(a is b for a, b in zip(vecs, first))
        assert all(np.shares_memory(a, filt._buf) for a in vecs)
        # AND they hold this step's output, as computed afresh from the nominal state
        want = np.empty(13)
        geo = output_into(filt.nom.x, filt._s, want)
        assert np.concatenate(vecs).tolist() == want.tolist()
        assert (nav.lat_rad, nav.lon_rad, nav.alt_m) == geo[:3]
    assert filt.aligned



def test_the_dead_reckoned_airspeed_is_that_of_the_nominal_velocity_and_wind():
    # GIVEN a simulated fixed-wing flight whose airspeed samples stop at 10 s (from 10.5 s
    # on the output's airspeed is dead-reckoned, as the quadrotor's at every step)
    sim = simulate_flight(np.random.default_rng(2), CFG, duration_s=20.0)
    filt = InsGpsEkf(PARAMS, "plane", CFG.origin(), cov_div=4)
    checked = 0
    for frame in sim.frames():
        if frame.t_us >= 10_000_000:
            frame = replace(frame, airspeed=None)
        nav = filt.update(frame)
        if frame.t_us >= 10_500_000:
            # THEN the airspeed is |v - (w, 0)| of the nominal state as it is after the step
            (v0, v1, v2), (w0, w1) = filt.nom.v, filt.nom.wind
            assert nav.airspeed_mps == math.sqrt((v0 - w0) ** 2 + (v1 - w1) ** 2 + v2 ** 2)
            # AND the wind handed out is the nominal state's
            assert nav.wind_ned.tolist() == [w0, w1, 0.0]
            checked += 1
    assert checked > 900 and filt.nom.wind != [0.0, 0.0]
