"""The plane glue's per-step shortcuts (stop 34) against what they replace: the log
rows' unconverted flags and counts, and the parameters the
controller and the L1 design read once per change instead of every step."""
import math

import numpy as np
import pytest

from autopilot.control.fixed_wing import FixedWingController
from autopilot.log.flightlog import FlightLog
from autopilot.messages import NavState
from autopilot.modes.plane import PlaneMode
from autopilot.params import ParamStore
from autopilot.vehicle import PlaneVehicle, plane_param_declarations


def test_log_rows_convert_flags_codes_and_counts_exactly():
    log = FlightLog(("t_s", "armed", "mode", "seq", "kind", "x"))
    log.append((0.01, True, PlaneMode.AUTO, 7, 3, 2.5))
    log.append((0.02, np.bool_(False), PlaneMode.RTL, 2**40 + 1, 0, -1.0))
    a = log.arrays()
    assert a["armed"].tolist() == [1.0, 0.0]
    assert a["mode"].tolist() == [float(int(PlaneMode.AUTO)), float(int(PlaneMode.RTL))]
    assert a["seq"].tolist() == [7.0, float(2**40 + 1)]
    assert all(a[c].dtype == np.float64 for c in log.columns)


def _nav(alt_m=100.0, airspeed=23.0):
    return NavState(0, np.zeros(3), np.array([23.0, 0.0, -0.4]), np.array([1.0, 0.0, 0.0, 0.0]),
                    np.array([0.01, -0.02, 0.03]), 0.0, 0.0, alt_m, airspeed)


def _fly(ctrl, n=50):
    out = []
    for _ in range(n):
        out.append(ctrl.update(_nav(), 0.01, 0.2, 130.0, 25.0, euler=(0.05, 0.08, 0.0)))
    return out


@pytest.mark.parametrize("name,value", [("ALT_KP", 0.9), ("TRIM_ARSPD", 21.0), ("PTCH_TRIM_DEG", 2.0),
                                        ("ROLL_LIMIT_DEG", 8.0), ("DEM_CLMB_FRAC", 0.3),
                                        ("THR_CLMB_FF", 0.2), ("YAW_KD", 1.5), ("SPD_PRIO_DB", 0.5)])
def test_a_parameter_change_reaches_the_controller_through_set_param(name, value):
    # a vehicle's controller after set_param flies as one built with the new value
    p = ParamStore(plane_param_declarations())
    v = PlaneVehicle(p, None, nav_source="truth", autostart=False)
    before = _fly(FixedWingController(p))
    assert v.set_param(name, value) is None
    fresh = ParamStore(plane_param_declarations())
    fresh.set(name, value)
    want = _fly(FixedWingController(fresh))
    assert _fly(v.ctrl) == want
    assert want != before        # (the parameter does act on these steps)


def test_the_l1_design_follows_set_param():
    p = ParamStore(plane_param_declarations())
    v = PlaneVehicle(p, None, nav_source="truth", autostart=False)
    assert v.set_param("NAVL1_PERIOD", 21.0) is None and v.set_param("NAVL1_DAMPING", 0.8) is None
    assert (v.l1.period_s, v.l1.damping, v.l1.k) == (21.0, 0.8, 4.0 * 0.8 * 0.8)
