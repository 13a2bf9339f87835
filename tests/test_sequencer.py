"""Mission sequencing: leg switching by along-track projection (seed 1.16), turn arcs,
DO_JUMP, DO_CHANGE_SPEED, loiters and RTL, on a scripted vehicle position."""
import math

import numpy as np
import pytest

from autopilot.geo import LocalFrame
from autopilot.guidance.mission import MissionSequencer
from autopilot.mission.items import (DO_CHANGE_SPEED, DO_JUMP, FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT,
                                     FRAME_MISSION, NAV_LOITER_TURNS, NAV_RETURN_TO_LAUNCH,
                                     NAV_WAYPOINT, Mission, MissionItem)
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations

HOME = LocalFrame.from_degrees(-35.0, 149.0, 500.0)


def ll(n, e):
    lat, lon, _ = HOME.to_geodetic_fast(np.array([n, e, 0.0]))
    return math.degrees(lat), math.degrees(lon)


def item(seq, cmd, n=0.0, e=0.0, alt=100.0, p=(0, 0, 0, 0), frame=FRAME_GLOBAL_RELATIVE_ALT):
    lat, lon = ll(n, e) if frame != FRAME_MISSION else (0.0, 0.0)
    return MissionItem(seq, frame, cmd, 0, 1, *[float(x) for x in p], lat, lon, float(alt))


def mission(*items):
    home = MissionItem(0, FRAME_GLOBAL, NAV_WAYPOINT, 1, 1, 0, 0, 0, 0, -35.0, 149.0, 500.0)
    return Mission((home,) + tuple(items))


def seq_for(m, **params):
    ps = ParamStore(plane_param_declarations())
    for k, v in params.items():
        ps.set(k, v)
    return MissionSequencer(m, HOME, ps)


def fly(seq, path, v=(25.0, 0.0, 0.0)):
    """Feed positions; return the targets."""
    out = []
    for k, (n, e) in enumerate(path):
        out.append(seq.update(k * 10_000, np.array([n, e, -100.0]), np.array(v), 0.0, 600.0))
    return out


def test_switch_when_the_projection_passes_the_end_of_a_straight_continuation():
    # GIVEN two collinear legs north (no turn, so no anticipation)
    s = seq_for(mission(item(1, NAV_WAYPOINT, 500, 0), item(2, NAV_WAYPOINT, 1000, 0)), WP_RADIUS=10.0)
    s._prev_wp_ne = (0.0, 0.0)
    # WHEN the vehicle, 30 m off to the side, approaches and passes the 500 m line
    t = fly(s, [(n, 30.0) for n in (100, 300, 499)])
    assert all(x.seq == 1 for x in t)
    t = fly(s, [(501, 30.0)])
    # THEN it switches exactly there, although 30 m abeam of the waypoint
    assert t[0].seq == 2 and (1 in s.reached_seqs)


def test_turn_arc_starts_before_a_right_angle_and_ends_on_the_next_leg():
    s = seq_for(mission(item(1, NAV_WAYPOINT, 500, 0), item(2, NAV_WAYPOINT, 500, 600)),
                TURN_BANK_DEG=30.0, TURN_GS_FACTOR=1.0, WP_RADIUS=10.0)
    s._prev_wp_ne = (0.0, 0.0)
    v = s.airspeed_mps
    r = v * v / (9.80665 * math.tan(math.radians(30.0)))
    # before the tangent point (d = r for 90 deg): still the leg
    t = fly(s, [(500 - r - 5, 0.0)])[0]
    assert t.kind == "line" and t.seq == 1
    # at the tangent point: an arc of radius r centred r to the right (east)
    t = fly(s, [(500 - r + 1, 0.0)])[0]
    assert t.kind == "loiter" and t.direction == 1
    assert t.radius_m == pytest.approx(r, rel=1e-6)
    assert t.c_ne[0] == pytest.approx(500 - r, abs=1e-6) and t.c_ne[1] == pytest.approx(r, abs=1e-6)
    # along the arc until the course has turned 90 deg, then the next leg from B
    c = t.c_ne
    for ang in np.linspace(-math.pi / 2, -0.05, 20):   # bearing (atan2(e, n)) from the centre
        t = fly(s, [(c[0] + r * math.cos(ang), c[1] + r * math.sin(ang))])[0]
        assert t.kind == "loiter"
    t = fly(s, [(c[0] + r * math.cos(0.05), c[1] + r * math.sin(0.05))], v=(-1.0, 25.0, 0.0))[0]
    assert t.kind == "line" and t.seq == 2
    assert t.a_ne == pytest.approx((500.0, 0.0), abs=1e-6)


def test_too_sharp_for_the_legs_means_no_arc():
    # 150 deg turn between 150 m legs: the arc would need a radius far below the minimum
    s = seq_for(mission(item(1, NAV_WAYPOINT, 150, 0),
                        item(2, NAV_WAYPOINT, 150 - 150 * math.cos(math.radians(30)), 150 * math.sin(math.radians(30)))))
    s._prev_wp_ne = (0.0, 0.0)
    d, arc = s._fillet((0.0, 0.0), s.item_ne(s.items[1]))
    assert arc is None and d == 0.0


def test_do_jump_repeats_then_continues_and_do_change_speed_applies():
    m = mission(item(1, DO_CHANGE_SPEED, p=(0, 21, -1, 0), frame=FRAME_MISSION),
                item(2, NAV_WAYPOINT, 1000, 0), item(3, NAV_WAYPOINT, 1000, 1000),
                item(4, DO_JUMP, p=(2, 1, 0, 0), frame=FRAME_MISSION),
                item(5, NAV_RETURN_TO_LAUNCH, frame=FRAME_MISSION))
    s = seq_for(m, TURN_BANK_DEG=30.0, WP_RADIUS=10.0)
    order = []
    pos = [(0.0, 0.0)]
    vel = (25.0, 0.0, 0.0)
    targets = {2: (1000.0, 0.0), 3: (1000.0, 1000.0)}
    for _ in range(200):
        t = fly(s, pos, v=vel)[0]
        if t.kind == "direct":               # the straight of a planned join: fly it
            d = np.subtract(t.b_ne, t.a_ne)
            pos = [tuple(np.asarray(t.b_ne) + 0.01 * d)]
            vel = (*(25.0 * d / np.linalg.norm(d)), 0.0)
            continue
        if t.kind == "loiter":               # a turn arc: fly along it
            c, r = t.c_ne, t.radius_m
            b = math.atan2(pos[0][1] - c[1], pos[0][0] - c[0]) + t.direction * 0.1
            pos = [(c[0] + r * math.cos(b), c[1] + r * math.sin(b))]
            vel = (-25.0 * t.direction * math.sin(b), 25.0 * t.direction * math.cos(b), 0.0)
            continue
        if t.kind == "line":
            if not order or order[-1] != t.seq:
                order.append(t.seq)
            if t.seq in targets:
                pos = [targets[t.seq]]       # teleport onto the waypoint: reached
            else:
                pos = [(0.0, 0.0)]           # RTL leg: arrive home
        if s.finished:
            break
    assert order == [2, 3, 2, 3, 5]
    assert s.airspeed_mps == pytest.approx(21.0)
    assert s.finished and s.reached_seqs == {1, 2, 3, 4, 5}


def test_loiter_turns_count_full_circles():
    m = mission(item(1, NAV_LOITER_TURNS, 0, 0, p=(2, 0, 100, 0)), item(2, NAV_WAYPOINT, 1000, 0))
    s = seq_for(m)
    angles = np.linspace(0, 2 * 2 * math.pi + 0.3, 400)
    kinds = []
    for k, a in enumerate(angles):
        t = s.update(k * 10_000, np.array([100 * math.cos(a), 100 * math.sin(a), -100.0]),
                     np.zeros(3), 0.0, 600.0)
        kinds.append((t.kind, t.seq))
    first_leg = next(i for i, kt in enumerate(kinds) if kt == ("line", 2))
    assert angles[first_leg] == pytest.approx(4 * math.pi, abs=0.1)
    assert kinds[0] == ("loiter", 1)


def test_relative_and_absolute_altitudes():
    m = mission(item(1, NAV_WAYPOINT, 500, 0, alt=120.0), item(2, NAV_WAYPOINT, 500, 500, alt=700.0, frame=FRAME_GLOBAL))
    s = seq_for(m)
    assert s.item_alt_m(s.items[1]) == pytest.approx(620.0)
    assert s.item_alt_m(s.items[2]) == pytest.approx(700.0)


def follow(s, p, chi, steps, ds=2.0, v=25.0):
    """A perfect kinematic follower of the sequencer's targets: each step moves ``ds``
    along the commanded arc or line (snapped onto it). Returns [(target, p, chi)]."""
    out = []
    for k in range(steps):
        vel = np.array([v * math.cos(chi), v * math.sin(chi), 0.0])
        t = s.update(k * 80_000, np.array([p[0], p[1], -100.0]), vel, chi, 600.0)
        out.append((t, p, chi))
        if t.kind == "loiter":
            c, r, d = t.c_ne, t.radius_m, t.direction
            b = math.atan2(p[1] - c[1], p[0] - c[0]) + d * ds / r
            p = (c[0] + r * math.cos(b), c[1] + r * math.sin(b))
            chi = b + d * 0.5 * math.pi
        elif t.kind in ("line", "direct"):
            a, bb = np.asarray(t.a_ne), np.asarray(t.b_ne)
            u = (bb - a) / np.linalg.norm(bb - a)
            q = a + np.dot(np.asarray(p) - a, u) * u + ds * u
            p, chi = (float(q[0]), float(q[1])), math.atan2(u[1], u[0])
        if s.finished:
            break
    return out


def test_joining_a_leg_flying_the_other_way_is_a_planned_turn_onto_the_leg():
    s = seq_for(mission(item(1, NAV_WAYPOINT, 1000, 0), item(2, NAV_WAYPOINT, 1000, 800)))
    s._prev_wp_ne = (0.0, 0.0)
    # GIVEN the vehicle 50 m west of a northbound leg, flying south (away from it)
    trace = follow(s, (0.0, -50.0), math.pi, 1500)
    kinds = [t.kind for t, _, _ in trace]
    # THEN it first flies a planned turn: arcs no wider than the join radius and no
    # tighter than the bank midway between the nominal and the limit (here 36.5 deg)
    r_floor = 25.0 ** 2 / (9.80665 * math.tan(math.radians(36.5)))
    assert kinds[0] == "loiter"
    assert r_floor - 1e-6 <= trace[0][0].radius_m <= s.turn_radius_m(wind=True) + 1e-6
    first_line = kinds.index("line")
    assert "direct" in kinds[:first_line] or kinds[:first_line].count("loiter") >= 2
    # AND rolls out on the mission's own leg (from the previous waypoint), on its line
    # and on its course, not captured by L1 from beside it
    t, p, chi = trace[first_line]
    assert t.seq == 1 and t.a_ne == pytest.approx((0.0, 0.0))
    assert abs(p[1]) < 1.0 and abs(wrap(chi)) < math.radians(3.0)
    # AND never crosses to the far side of the leg (east) on the way
    assert max(p[1] for _, p, _ in trace[:first_line]) < 1.0
    # AND reaches the waypoint
    assert 1 in s.reached_seqs


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi
