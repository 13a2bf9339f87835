"""Stop 39's speed round in the fixed-wing flight path: what its shortcuts rely on.

* The loops' optional demands live in the controller's one array (``_ovr``): written on
  a step that has one, cleared once on the next step that has none.
* The mission's targets are built by ``NavTarget.__new__`` without the class call: the
  same records, defaults and all.
* A waypoint leg's length is kept with its fillet, planned once a leg.
"""
import math

import numpy as np

from autopilot.control.fixed_wing import O_PITCH_MIN, O_THROTTLE, FixedWingController
from autopilot.guidance.mission import NO_NE, NavTarget, _new_target
from autopilot.messages import NavState
from autopilot.mission.items import NAV_WAYPOINT
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations

from tests.test_sequencer import item, mission, seq_for


def _nav():
    return NavState(0, np.zeros(3), np.array([25.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0, 0.0]),
                    np.array([0.01, -0.02, 0.03]), 0.0, 0.0, 100.0, 25.0)


def test_a_demand_is_flown_on_its_step_and_cleared_on_the_next_without_one():
    p = ParamStore(plane_param_declarations())
    a, b = FixedWingController(p), FixedWingController(p)
    nav, euler = _nav(), (0.05, 0.02, 0.0)
    # GIVEN a take-off step: a pitch floor and the throttle given
    a.update(nav, 0.01, 0.0, 120.0, 25.0, 0.2, 0.9, euler)
    assert a._ovr[O_PITCH_MIN] == 0.2 and a._ovr[O_THROTTLE] == 0.9
    assert np.isnan(np.delete(a._ovr, [O_PITCH_MIN, O_THROTTLE])).all()
    # WHEN the next step has none
    b._buf[:] = a._buf                        # (b: the same state, its demands cleared)
    b._ovr[:] = math.nan
    out_a = a.update(nav, 0.01, 0.1, 120.0, 25.0, None, None, euler)
    out_b = b.update(nav, 0.01, 0.1, 120.0, 25.0, None, None, euler)
    # THEN it flies as a controller that never had them, and they are gone
    assert out_a == out_b and np.isnan(a._ovr).all()
    assert np.array_equal(a._buf, b._buf, equal_nan=True)


def test_a_target_built_without_the_class_call_is_the_same_record():
    t = _new_target(NavTarget, "loiter", 3, 7, 100.0, 25.0, NO_NE, NO_NE, (1.0, 2.0), 80.0, -1)
    ref = NavTarget("loiter", 3, 7, 100.0, 25.0, NO_NE, NO_NE, (1.0, 2.0), 80.0, -1)
    assert type(t) is NavTarget and t == ref
    assert t.land == "" and t.climb_mps is None and t.spd_weight == 1.0   # (the defaults)
    kw = _new_target(NavTarget, "line", 1, 2, 50.0, 20.0, a_ne=(0.0, 0.0), b_ne=(5.0, 5.0), land="flare")
    assert kw == NavTarget("line", 1, 2, 50.0, 20.0, a_ne=(0.0, 0.0), b_ne=(5.0, 5.0), land="flare")


def test_a_legs_length_is_kept_with_its_fillet():
    s = seq_for(mission(item(1, NAV_WAYPOINT, 400.0, 0.0), item(2, NAV_WAYPOINT, 400.0, 300.0),
                        item(3, NAV_WAYPOINT, 0.0, 300.0)))
    n = e = 0.0
    for k in range(3000):
        tgt = s.update(k * 20_000, (n, e, -100.0), [25.0, 0.0, 0.0], 0.0, 600.0, [0.0, 0.0, 0.0], 25.0)
        if s._fillet_at is not None:
            (a_ne, b_ne), _, length = s._fillet_at
            assert length == math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        if tgt.seq >= 2:
            break
        n += 0.5
    # (the second leg's: towards the waypoint 300 m east)
    assert s._fillet_at is not None and math.isclose(s._fillet_at[2], 300.0, rel_tol=1e-6)
