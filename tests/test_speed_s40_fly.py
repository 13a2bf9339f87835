"""Stop 40's speed round in the fixed-wing flight path: what its shortcuts rely on.

* The vehicle flies L1 by ``steer_line`` / ``steer_loiter``: the kernel's tuple,
  LateralCommand's fields in order, with the ground speed it is given.
* The parameters the loop reads every step are read again at a PARAM_SET.
* ``_fly`` makes the wind's list only when the filter hands a new wind array: the filter
  hands the same array on between fusions and never writes into one it handed out.
"""
import math

import numpy as np

from autopilot.guidance.l1 import L1Guidance, LateralCommand
from autopilot.params import ParamStore
from autopilot.vehicle import PlaneVehicle, plane_param_declarations
from tools.runner import DEFAULT_SCENARIO, RunConfig, Session


def test_the_steering_tuples_are_the_lateral_commands_fields():
    l1 = L1Guidance(17.0, 0.75)
    for p, v, c, r, d in (((100.0, 10.0), (3.0, 22.0), (0.0, 0.0), 80.0, 1),
                          ((-40.0, 70.0), (-18.0, -9.0), (5.0, -5.0), 120.0, -1),
                          ((1.0, 0.5), (0.5, 0.2), (0.0, 0.0), 80.0, 1)):   # (slow: the heading)
        gs = math.hypot(*v)
        cmd = l1.loiter(p, v, c, r, d, 1.2, 21.0)
        assert type(cmd) is LateralCommand
        assert l1.steer_loiter(p, v, gs, c, r, d, 1.2, 21.0) == tuple(cmd)
        line = l1.line(p, v, c, (400.0, 300.0), 1.2, 21.0)
        assert l1.steer_line(p, v, gs, c, (400.0, 300.0), 1.2, 21.0) == tuple(line)
    # the ground speed is the caller's: another one steers otherwise
    assert l1.steer_line((0.0, 30.0), (20.0, 0.0), 40.0, (0.0, 0.0), (500.0, 0.0), 0.0, 20.0)[1] \
        != l1.line((0.0, 30.0), (20.0, 0.0), (0.0, 0.0), (500.0, 0.0), 0.0, 20.0).bank_rad


def test_the_parameters_read_every_step_follow_a_param_set():
    v = PlaneVehicle(ParamStore(plane_param_declarations()), None, nav_source="truth")
    assert v._crash_detect is True and v._level_alt_m == v.params["TKOFF_LVL_ALT"]
    assert v._moving_air_mps == 0.75 * v.params["ARSPD_FBW_MIN"]
    assert v.set_param("CRASH_DETECT", 0) is None and v._crash_detect is False
    assert v.set_param("TKOFF_LVL_ALT", 30.0) is None and v._level_alt_m == 30.0
    assert v.set_param("ARSPD_FBW_MIN", 18.0) is None and v._moving_air_mps == 0.75 * 18.0
    assert v.set_param("CRASH_GND_ALT", 2.0) is None and v._crash_gnd_alt_m == 2.0


def test_the_filter_hands_one_wind_array_per_estimate_and_never_writes_into_it():
    s = Session(RunConfig(nav="ekf", scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1))
    while not s.vehicle.armed:
        s.step()
    seen = {}                    # id -> (array, its values when first handed out)
    renewed = 0
    for _ in range(600):
        s.step()
        w = s.vehicle.nav_state.wind_ned
        if id(w) not in seen:
            renewed += 1
            seen[id(w)] = (w, w.copy())
        for arr, first in seen.values():
            assert np.array_equal(arr, first)
        # and the list _fly flies is that array's
        assert s.vehicle._wind_of is w and s.vehicle._wind_l == w.tolist()
    assert 1 < renewed < 600     # (new estimates come at fusions, not every step)
