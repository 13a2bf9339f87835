"""Stop 37's speed round in the fixed-wing flight path: what its shortcuts rely on.

* ``MissionSequencer.update`` takes the vehicle's floats as they are (no ``float()`` of
  each): a tuple and lists fly the same targets as numpy arrays.
* ``_fly_path`` works an arc's roll lead out only within ROLL_LEAD_MAX_RAD of its end:
  ``_roll_lead_rad`` never returns more.
* ``L1Guidance`` builds its LateralCommand from the kernel's tuple without ``_make``.
"""
import math

import numpy as np

from autopilot.guidance.l1 import L1Guidance, LateralCommand, _line, _loiter
from autopilot.guidance.mission import ROLL_LEAD_MAX_RAD
from autopilot.mission.items import NAV_WAYPOINT

from tests.test_sequencer import item, mission, seq_for


def _square():
    return mission(item(1, NAV_WAYPOINT, 400.0, 0.0), item(2, NAV_WAYPOINT, 400.0, 400.0),
                   item(3, NAV_WAYPOINT, 0.0, 400.0), item(4, NAV_WAYPOINT, 0.0, 0.0))


def test_the_sequencer_flies_floats_as_it_flies_arrays():
    a, b = seq_for(_square()), seq_for(_square())
    n = e = 0.0
    chi = 0.0
    for k in range(6000):
        t_us = k * 20_000
        v = (25.0 * math.cos(chi), 25.0 * math.sin(chi), -0.5)
        ta = a.update(t_us, np.array([n, e, -100.0]), np.array(v), chi, 600.0,
                      np.array([3.0, -2.0, 0.0]), 24.0)
        tb = b.update(t_us, (n, e, -100.0), list(v), chi, 600.0, [3.0, -2.0, 0.0], 24.0)
        assert ta == tb
        # a vehicle that heads for the line's end, or along the circle
        if ta.kind in ("line", "direct"):
            chi = math.atan2(ta.b_ne[1] - e, ta.b_ne[0] - n)
        elif ta.kind == "loiter":
            chi = math.atan2(e - ta.c_ne[1], n - ta.c_ne[0]) + ta.direction * 0.5 * math.pi
        n += v[0] * 0.02
        e += v[1] * 0.02
    assert a.reached == b.reached and len(a.reached) >= 2     # (it went somewhere)


def test_the_roll_lead_is_capped_where_the_arc_check_assumes():
    s = seq_for(_square())
    arc = ("arc", (0.0, 0.0), 50.0, 1, 1.0, (50.0, 0.0))
    s._path = [arc]
    s.ground_speed_mps = 1e6           # as fast as can be: the lead at its cap
    assert s._roll_lead_rad(50.0, 1) == ROLL_LEAD_MAX_RAD
    s.ground_speed_mps = 20.0
    assert 0.0 < s._roll_lead_rad(50.0, 1) < ROLL_LEAD_MAX_RAD


def test_l1_answers_are_lateral_commands_of_the_kernels_tuples():
    l1 = L1Guidance(17.0, 0.75)
    cmd = l1.loiter((100.0, 10.0), (3.0, 22.0), (0.0, 0.0), 80.0, 1, 1.2, 21.0)
    assert type(cmd) is LateralCommand and len(cmd) == 6
    assert tuple(cmd) == _loiter(3.0, 22.0, math.hypot(3.0, 22.0), 100.0, 10.0,
                                 math.hypot(100.0, 10.0), 80.0, 1, 1.2, 21.0, l1._zeta_t, l1.k)
    cmd = l1.line((10.0, 5.0), (20.0, 1.0), (0.0, 0.0), (100.0, 0.0), 0.0, 20.0)
    assert type(cmd) is LateralCommand
    assert cmd.xtrack_m == cmd[2] == 5.0 and cmd.along_m == 10.0
    assert tuple(cmd) == _line(20.0, 1.0, math.hypot(20.0, 1.0), 100.0, 0.0, 100.0, 10.0, 5.0,
                               0.0, 20.0, l1._zeta_t, l1.k)
