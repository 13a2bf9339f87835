"""Stop 38, the fixed-wing's orchestration: its flight-log rows hold numbers only (the
cyclic collector then leaves them alone), the controller's one array for its kernel,
and the reactions' limits handed to the mission in one call."""
import gc
import math

import numpy as np

from autopilot.control.fixed_wing import LAT_DEFLECTION_RAD, FixedWingController
from autopilot.messages import NavState
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations
from tools.runner import DEFAULT_SCENARIO, RunConfig, Session


def test_the_flight_logs_rows_are_untracked_by_the_collector_after_its_first_pass():
    # GIVEN a fixed-wing flight past its arming (the mode in every row is AUTO)
    s = Session(RunConfig(nav="ekf", scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1))
    while not s.vehicle.armed or s.t_s < 12.0:
        s.step()
    rows = s.log.rows
    assert len(rows) > 100 and rows[-1][2] == int(s.vehicle.mode)
    # WHEN the collector passes once
    gc.collect()
    # THEN no row is tracked any more: a row holding a tracked object (the PlaneMode
    #      member) stayed tracked and was walked again at every older generation's pass
    assert not any(gc.is_tracked(r) for r in rows)
    # AND the mode is logged as the number it was (the column reads the same)
    assert type(rows[-1][2]) is int
    a = s.log.arrays()
    assert a["mode"][-1] == float(int(s.vehicle.mode))


def _ctrl(**over) -> FixedWingController:
    p = ParamStore(plane_param_declarations())
    for k, v in over.items():
        p.set(k, v)
    return FixedWingController(p)


def test_the_reaction_limits_are_the_two_the_mission_reads():
    ctrl = _ctrl(ROLL_LIMIT_DEG=30.0)
    assert ctrl.reaction_limits() == (None, None)
    # an aileron out (its counter takes 60 % of the rudder's travel): its bank limit
    ctrl.surface_out = {"surface": "aileron", "stuck_rad": 0.1, "counter_rad": -0.6 * LAT_DEFLECTION_RAD}
    bank, v = ctrl.reaction_limits()
    assert math.isclose(bank, math.radians(12.0), rel_tol=1e-9) and v is None
    assert bank == ctrl.reaction_bank_limit_rad()
    # a throttle stuck where it holds level flight: its top speed as well
    ctrl.throttle_out = {"level": True, "v_top": 33.0}
    assert ctrl.reaction_limits() == (ctrl.reaction_bank_limit_rad(), 33.0)
    ctrl.surface_out = None
    assert ctrl.reaction_limits() == (None, 33.0)
    ctrl.throttle_out = None
    assert ctrl.reaction_limits() == (None, None)


def test_the_loops_kernel_reads_and_advances_the_controllers_one_array():
    # GIVEN a controller whose gains, state and parameters are views of one array
    ctrl = _ctrl()
    buf = ctrl._buf
    assert ctrl._gains.base is buf and ctrl._x.base is buf and ctrl._c.base is buf
    nav = NavState(0, np.zeros(3), np.array([25.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0, 0.0]),
                   np.zeros(3), 0.0, 0.0, 100.0, 25.0)
    # WHEN a step is flown towards a bank and a height above
    out = ctrl.update(nav, 0.01, 0.2, 120.0, 25.0, None, None, (0.0, 0.0, 0.0))
    # THEN the state advanced in that array (the altitude demand slewed up from 100 m,
    #      the roll command logged) and the controls came of its gains
    alt_dem, roll_c, _, _ = ctrl.commands()
    assert 100.0 < alt_dem < 100.1 and roll_c == 0.2 and buf[30 + 6] == 0.2
    assert out[0] > 0.0                      # (aileron: roll right towards the bank)
    # AND a gain changed in place is the one the next step flies
    ctrl._gains[0, 0] *= 2.0
    out2 = ctrl.update(nav, 0.01, 0.2, 120.0, 25.0, None, None, (0.0, 0.0, 0.0))
    assert out2[0] > out[0]
