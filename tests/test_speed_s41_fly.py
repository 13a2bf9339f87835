"""Stop 41, the fixed-wing's orchestration: the controller's log commands read through a
view made with its array, and the reaction limits asked by the mission when it plans a
turn (the controller's method handed over at arming), not handed to it every step."""
import math

import numpy as np

from autopilot.control.fixed_wing import LAT_DEFLECTION_RAD, FixedWingController
from autopilot.messages import NavState
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations
from tools.runner import DEFAULT_SCENARIO, RunConfig, Session

NAV = NavState(0, np.zeros(3), np.array([25.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0, 0.0]),
               np.zeros(3), 0.0, 0.0, 100.0, 25.0)


def test_the_commands_follow_the_controllers_array_after_it_is_made_again():
    # GIVEN a controller that has flown a step, then had its array made again
    p = ParamStore(plane_param_declarations())
    ctrl = FixedWingController(p)
    ctrl.update(NAV, 0.01, 0.2, 120.0, 25.0, None, None, (0.0, 0.0, 0.0))
    ctrl.configure()
    # WHEN it flies a step towards another bank
    ctrl.update(NAV, 0.01, -0.1, 120.0, 25.0, None, None, (0.0, 0.0, 0.0))
    # THEN the commands are that step's, read off the new array
    alt_dem, roll_c, _, _ = ctrl.commands()
    assert roll_c == -0.1 and 100.0 < alt_dem < 100.1
    assert ctrl.commands() == ctrl._x[5:9].tolist()


def test_the_mission_asks_the_controllers_reaction_limits_when_it_plans():
    # GIVEN a fixed-wing flight past its arming, no reaction in force
    s = Session(RunConfig(nav="ekf", scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1))
    while not s.vehicle.armed or s.t_s < 8.0:
        s.step()
    v = s.vehicle
    seq = v.sequencer
    assert seq.reaction_limits() == (None, None)
    radius_m = seq.min_turn_radius_m()
    # WHEN the controller flies an aileron on the rudder (its counter takes 60 % of the
    #      rudder's travel: the bank limited to 40 % of ROLL_LIMIT_DEG)
    v.ctrl.surface_out = {"surface": "aileron", "stuck_rad": 0.1,
                          "counter_rad": -0.6 * LAT_DEFLECTION_RAD}
    # THEN the mission plans at that limit at once, with no step in between
    bank_rad, _ = seq.reaction_limits()
    assert math.isclose(bank_rad, 0.4 * math.radians(s.params["ROLL_LIMIT_DEG"]), rel_tol=1e-9)
    assert seq.min_turn_radius_m() > 2.0 * radius_m
    # AND without it, the radius planned before
    v.ctrl.surface_out = None
    assert seq.min_turn_radius_m() == radius_m
