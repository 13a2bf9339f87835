"""The c172p's runway take-off in gusts and crosswind: on its wheels the aircraft is
steered by the rudder and the nose wheel on the take-off heading, wings level
(GROUND_STEER_ALT, autopilot/vehicle.py), and lifts off on the runway's line.

Before ground steering, the take-off roll in light turbulence drifted off its heading
(7.7 deg, 14 m off the centreline by the lift-off), the heading error was asked of the
roll loop, which cannot roll an aircraft on its gear: its integrator wound up (aileron
0.57) and rolled the aircraft at the lift-off, onto the ground 18-22 s into the run.
"""
import math

import numpy as np
import pytest

from tools.runner import MISSIONS_DIR, RunConfig, Session

CIRCUIT = MISSIONS_DIR / "c172p_circuit.waypoints"


@pytest.mark.parametrize("seed, wind", [(1, None), (2, None), (3, None), (1, (5.0, 90.0))])
def test_a_runway_take_off_in_light_turbulence_holds_the_runway_and_climbs_away(seed, wind):
    cfg = RunConfig(airframe="c172p", mission=CIRCUIT, seed=seed, duration_s=50.0,
                    turbulence="light", wind=wind)
    s = Session(cfg)
    v = s.vehicle
    while s.t_s < cfg.duration_s and not s.done():     # as a headless run steps it
        s.step()
    a = s.log.arrays()
    h = a["truth_alt_m"] - v.home_truth_alt_m
    armed = a["armed"] > 0
    roll = np.degrees(np.abs(a["truth_roll_rad"]))
    # the runway: where the aircraft rested, on the heading it rested on (into the wind,
    # as an operator lines it up)
    on_wheels = armed & (h < 0.25)                     # (its CG rests at 0.03 m)
    i0 = int(np.flatnonzero(armed)[0])
    yaw0, n0, e0 = (float(a[k][i0]) for k in ("truth_yaw_rad", "truth_n_m", "truth_e_m"))
    yaw = np.degrees(np.abs((a["truth_yaw_rad"] - yaw0 + np.pi) % (2 * np.pi) - np.pi))
    xt = -(a["truth_n_m"] - n0) * math.sin(yaw0) + (a["truth_e_m"] - e0) * math.cos(yaw0)
    assert v.crash is None and v.armed and not s.crashed
    assert on_wheels.sum() > 500                       # a take-off roll, logged
    assert yaw[on_wheels].max() < 5.0, yaw[on_wheels].max()
    assert np.abs(xt[on_wheels]).max() < 5.0, np.abs(xt[on_wheels]).max()
    low = armed & (h >= 0.25) & (h < 15.0)
    assert roll[low].max() < 15.0, roll[low].max()
    assert h[-1] > 30.0                                # and it climbs away
