"""Multirotor guidance (autopilot/guidance/multirotor.py): the reference trajectory's
limits, and the mission sequencer's item logic flown by a vehicle that tracks the
reference perfectly (kinematics only, fast)."""
import math

import numpy as np
import pytest

from autopilot.geo import LocalFrame
from autopilot.guidance.multirotor import (COPTER_GUIDANCE_PARAMS, CopterMissionSequencer,
                                           CopterNavigator, Trajectory)
from autopilot.control.multirotor import MULTIROTOR_PARAMS
from autopilot.mission.items import Mission, MissionItem
from autopilot.params import ParamStore

DT = 0.004
HOME = (-35.0, 149.0, 600.0)


def params(**kw):
    p = ParamStore(list(COPTER_GUIDANCE_PARAMS) + list(MULTIROTOR_PARAMS))
    for k, v in kw.items():
        p.set(k, v)
    return p


def item(seq, cmd, p1=0.0, p2=0.0, p3=0.0, p4=0.0, n=None, e=None, alt=0.0, frame=3):
    lat = lon = 0.0
    if n is not None:
        lat = HOME[0] + math.degrees(n / 6378137.0)
        lon = HOME[1] + math.degrees(e / (6378137.0 * math.cos(math.radians(HOME[0]))))
    return MissionItem(seq, frame, cmd, 0, 1, p1, p2, p3, p4, lat, lon, alt)


def mission(*items):
    home = MissionItem(0, 0, 16, 0, 1, 0, 0, 0, 0, HOME[0], HOME[1], HOME[2])
    return Mission((home,) + tuple(it if it.seq else it for it in items))


def test_line_respects_speed_and_acceleration_and_stops_on_the_goal():
    tr = Trajectory(4.0)
    tr.reset((0.0, 0.0, -10.0))
    tr.line_to((100.0, 50.0, -20.0), 5.0, 2.5, 1.5, 2.5, 1.5)
    vs, acs = [], []
    for _ in range(int(60 / DT)):
        tr.update(DT, tr.p, 4.0)
        vs.append(tr.v)
        acs.append(tr.a)
        if tr.arrived:
            break
    v = np.array(vs)
    a = np.array(acs)
    assert tr.arrived and np.allclose(tr.p, (100.0, 50.0, -20.0), atol=0.03)
    assert np.max(np.hypot(v[:, 0], v[:, 1])) <= 5.0 + 1e-6
    assert np.max(-v[:, 2]) <= 2.5 + 1e-6                    # climbing (up is -D)
    assert np.max(np.hypot(a[:, 0], a[:, 1])) <= 2.5 * 1.03    # (the braking curve's last step)
    assert np.max(np.abs(np.diff(a, axis=0))) / DT < 2 * 2.5 * 4.0  # jerk limited by the model
    # the speed limit is reached on a leg this long
    assert np.max(np.hypot(v[:, 0], v[:, 1])) > 4.9


def test_leash_holds_the_reference_near_a_vehicle_that_cannot_follow():
    tr = Trajectory(4.0)
    tr.reset((0.0, 0.0, -10.0))
    tr.line_to((200.0, 0.0, -10.0), 5.0, 2.5, 1.5, 2.5, 1.5)
    for _ in range(int(20 / DT)):
        tr.update(DT, (0.0, 0.0, -10.0), 4.0)                # stuck vehicle
    # the raw profile brakes at 4 m (a_max) and the smoothed reference settles on it
    assert 4.0 < tr.raw[0] < 4.0 + 5.0 ** 2 / (2 * 2.5) and tr.p[0] == pytest.approx(tr.raw[0], abs=0.05)
    assert abs(tr.v[0]) < 0.05


def fly(ms, p=None, t_max=600.0, p0=(0.0, 0.0, 0.0)):
    """A vehicle that sits exactly on the reference; touchdown at height 0."""
    p = p or params()
    frame = LocalFrame.from_degrees(*HOME)
    nav = CopterNavigator(p)
    nav.init(p0, 0.0)
    seq = CopterMissionSequencer(ms, frame, p, nav)
    t_us, pos, log = 0, list(p0), []
    touchdown = False
    while t_us * 1e-6 < t_max and not seq.landed:
        s, hold = seq.advance(t_us, pos, touchdown)
        nav.update(DT, pos, 0.0)
        tgt = nav.target(s, hold)
        pos = list(tgt.p_ned)
        touchdown = nav.phase == "land_descend" and pos[2] >= 0.0
        log.append((t_us * 1e-6, s, hold, tgt.kind, tuple(pos), nav.speed_mps))
        t_us += int(DT * 1e6)
    return seq, nav, log


def test_mission_items_in_order_with_holds_jump_speed_and_land_here():
    ms = mission(
        item(1, 22, alt=10.0),                               # takeoff to 10 m
        item(2, 178, p1=1, p2=3.0, frame=2),                 # 3 m/s
        item(3, 16, p1=2.0, n=30.0, e=0.0, alt=10.0),        # hold 2 s
        item(4, 16, n=30.0, e=30.0, alt=12.0),
        item(5, 177, p1=3, p2=1, frame=2),                   # jump to 3, once
        item(6, 19, p1=3.0, n=0.0, e=30.0, alt=8.0),         # loiter 3 s
        item(7, 21),                                         # land here (lat/lon 0)
    )
    seq, nav, log = fly(ms)
    assert seq.finished and seq.landed
    order = [s for _, s in seq.reached]
    assert order == [1, 2, 3, 4, 5, 3, 4, 6, 7]
    assert seq.reached_seqs == {1, 2, 3, 4, 5, 6, 7}
    # the speed change took effect
    assert nav.speed_mps == 3.0
    speeds = [math.hypot(*np.diff([r[4][:2] for r in log[k:k + 2]], axis=0)[0]) / DT
              for k in range(0, len(log) - 1, 50)]
    assert max(speeds) <= 3.0 + 0.05
    # holds: 2 s at item 3 (twice) and 3 s at item 6
    held = {}
    for t, s, hold, *_ in log:
        if hold:
            held[s] = held.get(s, 0.0) + DT
    assert held[3] == pytest.approx(4.0, abs=0.05) and held[6] == pytest.approx(3.0, abs=0.05)
    # landed where NAV_LAND was given (lat/lon 0: here = the loiter point)
    assert log[-1][4][:2] == pytest.approx((0.0, 30.0), abs=0.05)
    assert nav.land_ne == pytest.approx((0.0, 30.0), abs=0.05)


def test_return_to_launch_climbs_returns_and_lands_at_home():
    ms = mission(item(1, 22, alt=5.0), item(2, 16, n=40.0, e=-20.0, alt=5.0), item(3, 20))
    seq, nav, log = fly(ms, params(Q_RTL_ALT=15.0))
    assert seq.landed
    alts = [-r[4][2] for r in log]
    assert max(alts) == pytest.approx(15.0, abs=0.05)        # climbed to Q_RTL_ALT
    # the climb happened before the return leg (above the waypoint)
    i_top = int(np.argmax(np.array(alts) > 14.9))
    assert log[i_top][4][:2] == pytest.approx((40.0, -20.0), abs=0.3)
    assert log[-1][4][:2] == pytest.approx((0.0, 0.0), abs=0.05)


def test_mission_without_landing_returns_to_launch():
    ms = mission(item(1, 22, alt=10.0), item(2, 16, n=20.0, e=0.0, alt=20.0))
    seq, nav, log = fly(ms)
    assert seq.finished and seq.landed
    assert log[-1][4][:2] == pytest.approx((0.0, 0.0), abs=0.05)
    assert max(-r[4][2] for r in log) == pytest.approx(20.0, abs=0.05)   # above Q_RTL_ALT: kept


def test_heading_turns_towards_long_legs_only():
    p = params()
    nav = CopterNavigator(p)
    nav.init((0.0, 0.0, -10.0), 0.0)
    nav.goto((0.0, 3.0, -10.0))                              # short: heading kept
    for _ in range(500):
        nav.update(DT, nav.traj.p, 0.0)
    assert nav.yaw_ref == 0.0
    nav.goto((0.0, 50.0, -10.0))                             # east
    for _ in range(500):
        nav.update(DT, nav.traj.p, 0.0)
    assert nav.yaw_ref == pytest.approx(math.pi / 2)


def test_hold_brakes_to_a_stop_ahead_of_a_moving_reference():
    p = params()
    nav = CopterNavigator(p)
    nav.init((0.0, 0.0, -10.0), 0.0)
    nav.goto((100.0, 0.0, -10.0))
    for _ in range(int(6.0 / DT)):                           # cruising at 5 m/s
        nav.update(DT, nav.traj.p, 0.0)
    x0 = nav.traj.raw[0]
    nav.hold(None)
    for _ in range(int(8.0 / DT)):
        nav.update(DT, nav.traj.p, 0.0)
    # stops within the braking distance v^2 / 2a = 5 m of where it was, not at the goal
    assert nav.traj.arrived and x0 < nav.traj.p[0] <= x0 + 5.0 + 0.05


def test_new_target_is_the_named_tuple():
    """``new_target`` (tuple's constructor on CopterTarget) builds the same target as the
    named tuple's own constructor: its type, its fields by name, equal."""
    from autopilot.guidance.multirotor import CopterTarget, new_target
    fields = ("move", 3, 7, (1.0, 2.0, -10.0), (0.5, 0.0, 0.0), (0.0, 0.1, 0.0), 0.25, True,
              (4.0, 5.0), (1.0, 2.0))
    t = new_target(fields)
    assert type(t) is CopterTarget and t == CopterTarget(*fields)
    assert (t.kind, t.seq, t.leg_id, t.yaw_rad, t.hold, t.leg_a) == ("move", 3, 7, 0.25, True, (1.0, 2.0))
