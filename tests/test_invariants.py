"""Flight invariants and the cross-track error against the mission as written
(tools/invariants.py), on synthetic flight logs whose answers are known, and on one
real flight."""
from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.geo import LocalFrame
from autopilot.mission.files import loads_waypoints
from tools.invariants import (check_invariants, expected_order, mission_legs, order_figure,
                              orbit_turns, xtrack_mission)

HOME = LocalFrame.from_degrees(-35.0, 149.0, 500.0)
PARAMS = {"ROLL_LIMIT_DEG": 45.0, "PTCH_LIM_MAX_DEG": 20.0, "PTCH_LIM_MIN_DEG": -15.0,
          "ARSPD_FBW_MIN": 20.0, "TRIM_ARSPD": 25.0, "LOITER_RAD": 80.0, "ANGLE_MAX_DEG": 30.0}


def _ll(n, e):
    lat, lon, _ = HOME.to_geodetic(np.array([n, e, 0.0]))
    return math.degrees(lat), math.degrees(lon)


def _mission(rows):
    """rows: (command, frame, p1, p2, p3, n, e, h) after home; n None = lat/lon 0."""
    lines = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t-35.0\t149.0\t500\t1"]
    for seq, (cmd, fr, p1, p2, p3, n, e, h) in enumerate(rows, start=1):
        lat, lon = (0.0, 0.0) if n is None else _ll(n, e)
        lines.append(f"{seq}\t0\t{fr}\t{cmd}\t{p1}\t{p2}\t{p3}\t0\t{lat:.9f}\t{lon:.9f}\t{h}\t1")
    return loads_waypoints("\n".join(lines) + "\n")


# takeoff here, A (north 1000), B (east 1000 of A), jump back to A once, RTL
SQUARE = _mission([(22, 3, 0, 0, 0, None, None, 50),
                   (16, 3, 0, 0, 0, 1000.0, 0.0, 50),
                   (16, 3, 0, 0, 0, 1000.0, 1000.0, 50),
                   (177, 2, 2, 1, 0, None, None, 0),
                   (20, 2, 0, 0, 0, None, None, 0)])


def test_legs_resolve_jumps_from_the_takeoff_point():
    legs = mission_legs(SQUARE, HOME, "plane", PARAMS)
    ends = [(leg["seq"], round(leg["a"][0]), round(leg["a"][1]), round(leg["b"][0]), round(leg["b"][1]))
            for leg in legs]
    assert ends == [(2, 0, 0, 1000, 0), (3, 1000, 0, 1000, 1000), (2, 1000, 1000, 1000, 0),
                    (3, 1000, 0, 1000, 1000), (5, 1000, 1000, 0, 0)]
    assert expected_order(SQUARE) == [1, 2, 3, 2, 3, 5]     # navigation items, the jump taken once


def _log(points, seqs, dt=0.1, alt=550.0, roll=0.0):
    """A log flying through the given (n, e) points at 25 m/s, seq per segment."""
    t, n, e, vn, ve, sq = [], [], [], [], [], []
    now = 0.0
    for (p0, p1), s in zip(zip(points, points[1:]), seqs):
        d = math.hypot(p1[0] - p0[0], p1[1] - p0[1])
        k = max(int(d / 25.0 / dt), 1)
        for i in range(k):
            f = i / k
            t.append(now)
            n.append(p0[0] + f * (p1[0] - p0[0]))
            e.append(p0[1] + f * (p1[1] - p0[1]))
            vn.append((p1[0] - p0[0]) / d * 25.0 if d else 0.0)
            ve.append((p1[1] - p0[1]) / d * 25.0 if d else 0.0)
            sq.append(s)
            now += dt
    size = len(t)
    a = {"t_s": np.array(t), "truth_n_m": np.array(n), "truth_e_m": np.array(e),
         "truth_vn_mps": np.array(vn), "truth_ve_mps": np.array(ve), "seq": np.array(sq, float),
         "armed": np.ones(size), "kind": np.full(size, 2.0), "truth_alt_m": np.full(size, alt),
         "truth_roll_rad": np.full(size, roll), "truth_pitch_rad": np.zeros(size),
         "gps_n_m": np.full(size, np.nan), "est_n_m": np.array(n)}
    return a


def test_xtrack_mission_sees_what_the_flown_legs_do_not():
    """After the jump the vehicle flies from B straight to a point 100 m beside A (the
    guidance's own leg would start where it is): 100 m off the mission's line A-B
    at the end of that leg."""
    pts = [(0, 0), (1000, 0), (1000, 1000), (1100, 0), (1000, 1000), (0, 0)]
    a = _log(pts, [2, 3, 2, 3, 5])
    t = a["t_s"]
    seq = a["seq"]
    # reached: takeoff at t0, then each item at the end of its segment
    ev = [(0, 1)]
    for i in range(1, len(t)):
        if seq[i] != seq[i - 1]:
            ev.append((int(round(t[i - 1] * 1e6)), int(seq[i - 1])))
    ev.append((int(round(t[-1] * 1e6)), 5))
    rms, mx, legs = xtrack_mission(a, SQUARE, HOME, "plane", ev, PARAMS)
    # the third leg (B -> A, flown B -> A + 100 m north) ends 100 m beside the line
    assert legs[2]["xtrack_max_m"] == pytest.approx(100.0, abs=5.0)
    assert legs[0]["xtrack_max_m"] < 1.0 and legs[4]["xtrack_max_m"] < 1.0
    assert mx == pytest.approx(100.0, abs=5.0)
    assert 10.0 < rms < 60.0


def test_a_reversal_is_captured_when_flown_along_the_line():
    """Out to A, on 400 m past it, a 200 m wide turn back, home: the leg A -> home is
    scored from where the aircraft is back on the line flying home, not from A, where it
    passes flying away (the turn-around is the join)."""
    out_back = _mission([(22, 3, 0, 0, 0, None, None, 50), (16, 3, 0, 0, 0, 1000.0, 0.0, 50),
                         (20, 2, 0, 0, 0, None, None, 0)])
    pts = [(0, 0), (1000, 0), (1400, 0), (1400, 200), (1200, 5), (1000, 2), (0, 0)]
    a = _log(pts, [2, 3, 3, 3, 3, 3])
    t = a["t_s"]
    i_a = int(np.flatnonzero(a["seq"] == 3)[0]) - 1
    ev = [(0, 1), (int(round(t[i_a] * 1e6)), 2), (int(round(t[-1] * 1e6)), 3)]
    rms, mx, legs = xtrack_mission(a, out_back, HOME, "plane", ev, PARAMS)
    assert legs[1]["seq"] == 3 and legs[1]["xtrack_max_m"] < 10.0
    assert mx < 10.0


def test_order_figure():
    ev = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 2), (5, 3), (6, 5)]
    assert order_figure(SQUARE, ev) == (0, None)
    assert order_figure(SQUARE, ev[:3]) == (3, 2)             # the jump never flown
    swapped = [(0, 1), (1, 3), (2, 2)]
    assert order_figure(SQUARE, swapped) == (5, 2)


def test_orbit_around_a_waypoint_is_caught_and_a_loiter_is_not():
    # 4 circles of 100 m radius while flying item 2 (a waypoint), then 4 while flying
    # a loiter item
    ang = np.linspace(0.0, 8 * math.pi, 800)
    pts = [(100 * math.cos(x), 100 * math.sin(x)) for x in ang]
    a = _log(pts, [2] * (len(pts) - 1))
    turns, at = orbit_turns(a, SQUARE, "plane")
    assert turns == pytest.approx(4.0, abs=0.1) and at == 2
    loiter = _mission([(22, 3, 0, 0, 0, None, None, 50), (18, 3, 4, 0, 100, 0.0, 0.0, 50)])
    assert orbit_turns(a, loiter, "plane")[0] == 0.0
    # a zig-zag turns back and forth: no orbit
    zig = [(i * 100.0, (i % 2) * 100.0) for i in range(30)]
    assert orbit_turns(_log(zig, [2] * 29), SQUARE, "plane")[0] < 0.5


def _check(a, events, **kw):
    args = dict(completed=True, done_t_s=float(a["t_s"][-1]), home_truth_alt_m=500.0,
                params=PARAMS, wind_mps=0.0, fault_free=True, log_events=[(0.0, "mode AUTO")])
    args.update(kw)
    return check_invariants(a, SQUARE, "plane", events, **args)


def test_heights_attitude_nan_and_modes():
    pts = [(0, 0), (1000, 0), (1000, 1000), (1000, 0), (1000, 1000), (0, 0)]
    a = _log(pts, [2, 3, 2, 3, 5])
    ev = [(0, 1), (10, 2), (20, 3), (30, 4), (40, 2), (50, 3), (60, 5)]
    inv = _check(a, ev)
    assert all(v["passed"] for v in inv.values()), inv
    assert inv["height_floor"]["figure"] == pytest.approx(50.0)
    # touching the ground in flight
    b = dict(a)
    b["truth_alt_m"] = a["truth_alt_m"].copy()
    b["truth_alt_m"][300:310] = 500.2
    inv = _check(b, ev)
    assert not inv["no_ground_contact"]["passed"] and not inv["height_floor"]["passed"]
    assert inv["no_ground_contact"]["figure"] == pytest.approx(0.2)
    # a crash (the crash detection disarmed it on the ground) is a ground contact
    inv = _check(a, ev, crashed=True, completed=False)
    assert not inv["no_ground_contact"]["passed"] and inv["height_floor"]["passed"]
    # banked beyond the limit
    inv = _check(_log(pts, [2, 3, 2, 3, 5], roll=math.radians(60)), ev)
    assert not inv["attitude_limits"]["passed"] and inv["attitude_limits"]["figure"] == pytest.approx(60.0)
    # a NaN where none belongs; GPS NaNs are by design
    c = dict(a)
    c["est_n_m"] = a["est_n_m"].copy()
    c["est_n_m"][5] = np.nan
    inv = _check(c, ev)
    assert not inv["finite_log"]["passed"] and inv["finite_log"]["figure"] == 1
    # an RTL nobody asked for, and the same in a run with a fault injected
    modes = [(0.0, "mode AUTO"), (30.0, "mode RTL")]
    assert not _check(a, ev, log_events=modes)["no_unexpected_mode"]["passed"]
    assert _check(a, ev, log_events=modes, fault_free=False)["no_unexpected_mode"]["passed"]
    # not completed, or too slow
    assert not _check(a, ev, completed=False)["mission_order"]["passed"]
    inv = _check(a, ev, done_t_s=1e5)
    assert not inv["time_bound"]["passed"] and inv["time_bound"]["limit"] > 60.0


def test_a_real_flight_passes_and_scores_against_the_mission(tmp_path):
    """The repository's quad mission, flown: every invariant holds, and its mission
    lines are the lines it flies (a quad flies every waypoint to a stop)."""
    from pathlib import Path

    from tools.runner import QUAD_DEFAULT_MISSION, RunConfig, Session
    from tools.summary import run_summary
    s = Session(RunConfig(vehicle="quad", airframe="f450", mission=Path(QUAD_DEFAULT_MISSION),
                          duration_s=400.0))
    s.run()
    summary = run_summary(s)
    assert summary["completed"] and summary["invariants_passed"], summary["invariants"]
    assert summary["xtrack_mission_rms_m"] == pytest.approx(summary["xtrack_rms_m"], abs=0.05)
    assert summary["xtrack_mission_max_m"] < 1.0
    worst = summary["xtrack_mission_worst_leg"]
    assert worst["max_m"] == summary["xtrack_mission_max_m"] and 1 <= worst["from_seq"] < len(s.mission)
    # the run folder keeps the mission's lines for sitl report, which draws them
    from tools.report import make_report
    from tools.runner import write_run
    write_run(s, summary, tmp_path)
    with np.load(tmp_path / "flight.npz") as z:
        lines = z["mission_lines"]
    legs = mission_legs(s.mission, s.vehicle.home_frame, "quad")
    assert lines.shape == (len(legs), 5) and len(legs) >= 3
    assert np.allclose(lines[:, 3:], [g["b"] for g in legs])
    assert (tmp_path / "track.png") in make_report(tmp_path)


def test_a_go_around_re_flying_its_landing_sequence_keeps_the_mission_order():
    from autopilot.mission.files import load_mission
    from tools.invariants import order_figure
    from tools.runner import MISSIONS_DIR
    m = load_mission(MISSIONS_DIR / "default_land.plan")     # DO_LAND_START 12, 13, 14, NAV_LAND 15
    body = [1, 3, 4, 5, 6, 7, 8, 5, 6, 7, 8, 10, 11]
    ev = lambda seqs: [(i, s) for i, s in enumerate(seqs)]   # noqa: E731
    assert order_figure(m, ev(body + [13, 14, 15])) == (0, None)
    # aborted on short final, flown again from the DO_LAND_START: still in order
    assert order_figure(m, ev(body + [13, 14, 13, 14, 15])) == (0, None)
    assert order_figure(m, ev(body + [13, 13, 14, 15])) == (0, None)
    # going back out of the landing sequence is not a go-around
    assert order_figure(m, ev(body + [13, 14, 10, 13, 14, 15]))[0] > 0


def test_a_go_around_is_scored_on_the_last_approach_not_across_its_circuit():
    """Out to A, to B, down the final towards the land point, a go-around half-way (a
    circuit 500 m off the final) back to B and the final flown again: the final is
    scored on the last pass from B (before: from the first, the circuit counted as 500 m
    of cross-track)."""
    m = _mission([(22, 3, 0, 0, 0, None, None, 50), (16, 3, 0, 0, 0, 1000.0, 0.0, 50),
                  (16, 3, 0, 0, 0, 1000.0, 1000.0, 50), (21, 3, 0, 0, 0, 0.0, 1000.0, 0)])
    pts = [(0, 0), (1000, 0), (1000, 1000), (500, 1000), (500, 1500), (1200, 1500),
           (1000, 1000), (0, 1000)]
    a = _log(pts, [2, 3, 4, 4, 4, 4, 4])
    t = a["t_s"]
    i_a = int(np.flatnonzero(a["seq"] == 3)[0]) - 1
    i_b = int(np.flatnonzero(a["seq"] == 4)[0]) - 1
    i_b2 = int(np.argmin(np.hypot(a["truth_n_m"] - 1000.0, a["truth_e_m"] - 1000.0)
                         + 1e6 * (t < t[i_b] + 30.0)))
    ev = [(0, 1), (int(round(t[i_a] * 1e6)), 2), (int(round(t[i_b] * 1e6)), 3),
          (int(round(t[i_b2] * 1e6)), 3)]
    rms, mx, legs = xtrack_mission(a, m, HOME, "plane", ev, PARAMS)
    final = [g for g in legs if g["seq"] == 4][0]
    assert final["xtrack_max_m"] is not None and final["xtrack_max_m"] < 1.0
    assert mx < 1.0


def test_a_landings_descent_circle_is_not_scored_as_its_approach():
    """Out to A, to B, then the landing's own descent circle (an approach started too
    high loses its height first on a circle tangent to the approach at B, 300 m across,
    kind "loiter") and the final from B: the final is scored from where the vehicle
    leaves the circle (before: from B, the circle counted as 300 m of cross-track)."""
    m = _mission([(22, 3, 0, 0, 0, None, None, 50), (16, 3, 0, 0, 0, 1000.0, 0.0, 50),
                  (16, 3, 0, 0, 0, 1000.0, 1000.0, 50), (21, 3, 0, 0, 0, 0.0, 1000.0, 0)])
    pts = [(0, 0), (1000, 0), (1000, 1000), (700, 1000), (700, 1300), (1000, 1300),
           (1000, 1000), (0, 1000)]
    a = _log(pts, [2, 3, 4, 4, 4, 4, 4])
    t = a["t_s"]
    final = int(np.flatnonzero(a["seq"] == 4)[-1]) - int(1000.0 / 25.0 / 0.1) + 1
    first = int(np.flatnonzero(a["seq"] == 4)[0])
    a["kind"][first:final] = 3.0
    i_a = int(np.flatnonzero(a["seq"] == 3)[0]) - 1
    ev = [(0, 1), (int(round(t[i_a] * 1e6)), 2), (int(round(t[first - 1] * 1e6)), 3)]
    rms, mx, legs = xtrack_mission(a, m, HOME, "plane", ev, PARAMS)
    leg = [g for g in legs if g["seq"] == 4][0]
    assert leg["xtrack_max_m"] is not None and leg["xtrack_max_m"] < 1.0
    # the same path not marked as the landing's circling: the line flown badly, scored
    a["kind"][:] = 2.0
    _, mx2, legs2 = xtrack_mission(a, m, HOME, "plane", ev, PARAMS)
    assert [g for g in legs2 if g["seq"] == 4][0]["xtrack_max_m"] > 250.0


def _counted(a, first=1):
    """The reached events of a synthetic log: the take-off at 0, then each item where
    the log's seq moves past it."""
    seq, t = a["seq"], a["t_s"]
    ev = [(0, first)]
    for i in np.flatnonzero(np.diff(seq)) + 1:
        ev.append((int(round(t[i] * 1e6)), int(seq[i - 1])))
    ev.append((int(round(t[-1] * 1e6)), int(seq[-1])))
    return ev


def test_a_waypoint_counted_far_from_where_the_vehicle_went_fails():
    """waypoints_passed: a turn that starts far before a sharp corner (the fillet of a
    near-reversal at the nominal radius) counts a waypoint the vehicle never went to;
    flying through the corners, or cutting them within WP_RADIUS, passes."""
    params = dict(PARAMS, WP_RADIUS=100.0)
    through = [(0, 0), (1000, 0), (1000, 1000), (1000, 0), (1000, 1000), (0, 0)]
    a = _log(through, [2, 3, 2, 3, 5])
    inv = _check(a, _counted(a), params=params, frame=HOME)["waypoints_passed"]
    assert inv["passed"] and inv["figure"] < -90.0
    # the corner at A cut 60 m inside it (within the radius): still passed
    cut = [(0, 0), (960, 0), (1000, 40), (1000, 1000), (1000, 0), (1000, 1000), (0, 0)]
    a = _log(cut, [2, 3, 3, 2, 3, 5])
    inv = _check(a, _counted(a), params=params, frame=HOME)["waypoints_passed"]
    assert inv["passed"] and -80.0 < inv["figure"] < -60.0
    # the first pass at B (1000, 1000) cut 400 m before it: B counted 283 m away
    far = [(0, 0), (1000, 0), (1000, 600), (1400, 1000), (1000, 0), (1000, 1000), (0, 0)]
    a = _log(far, [2, 3, 2, 2, 3, 5])
    inv = _check(a, _counted(a), params=params, frame=HOME)["waypoints_passed"]
    assert not inv["passed"] and inv["seq"] == 3
    assert inv["figure"] == pytest.approx(400 / math.sqrt(2) - 100.0, abs=3.0)


def _passed(a, mission):
    """waypoints_passed of a synthetic log of ``mission`` (WP_RADIUS 100 m), counted
    where its seq moves on."""
    return check_invariants(a, mission, "plane", _counted(a), completed=True,
                            done_t_s=float(a["t_s"][-1]), home_truth_alt_m=500.0,
                            params=dict(PARAMS, WP_RADIUS=100.0), wind_mps=0.0, fault_free=True,
                            log_events=[(0.0, "mode AUTO")], frame=HOME)["waypoints_passed"]


def test_a_waypoint_passed_after_the_next_one_in_its_cluster_counted_passes():
    """waypoints_passed: B (radius 40 m) counted 85 m from it where the turn past a
    cluster starts, C (45 m beyond B, the default 100 m radius: the two circles
    overlap) counted at once as the vehicle enters C's circle, and B passed 5 m off
    on the turn after that (random-plane trial 260's class): passed. The same with C's
    radius 4 m (the circles apart): B's window ends at C's counting, failed."""
    def mission(c_accept):
        return _mission([(22, 3, 0, 0, 0, None, None, 50), (16, 3, 0, 0, 0, 1000.0, 0.0, 50),
                         (16, 3, 0, 40.0, 0, 1000.0, 500.0, 50), (16, 3, 0, c_accept, 0, 1000.0, 545.0, 50),
                         (16, 3, 0, 0, 0, 0.0, 1000.0, 50), (20, 2, 0, 0, 0, None, None, 0)])
    pts = [(0, 0), (1000, 0), (1060, 440), (1060, 441), (1000, 505), (0, 1000), (0, 0)]
    a = _log(pts, [2, 3, 4, 5, 5, 6])
    for c_accept, ok in ((0.0, True), (4.0, False)):
        inv = _passed(a, mission(c_accept))
        assert inv["passed"] is ok
        if ok:
            assert inv["figure"] < -30.0
        else:
            assert inv["seq"] == 3 and inv["figure"] == pytest.approx(math.hypot(60, 60) - 40.0, abs=2.0)


def test_a_waypoint_passed_on_the_way_to_a_loiter_around_it_passes():
    """waypoints_passed: B (the default 100 m radius) 60 m from the centre of the loiter
    before it, passed 10 m off on the loiter's approach, the loiter ending on its far
    side 140 m from B, B counted there (random-plane trial 3's class): the loiter's
    point lies within B's radius (a cluster), so B's window starts with the loiter:
    passed. The loiter 200 m from B: B's window starts at the loiter's counting,
    failed."""
    def mission(c_e):
        return _mission([(22, 3, 0, 0, 0, None, None, 50), (16, 3, 0, 0, 0, 1000.0, 0.0, 50),
                         (19, 3, 0.5, 0, 80.0, 1000.0, c_e, 50), (16, 3, 0, 0, 0, 1000.0, 440.0, 50),
                         (16, 3, 0, 0, 0, 0.0, 1000.0, 50), (20, 2, 0, 0, 0, None, None, 0)])
    pts = [(0, 0), (1000, 0), (1000, 430), (1000, 580), (1000, 581), (0, 1000), (0, 0)]
    a = _log(pts, [2, 3, 3, 4, 5, 6])
    for c_e, ok in ((500.0, True), (640.0, False)):
        inv = _passed(a, mission(c_e))
        assert inv["passed"] is ok, inv
        if not ok:
            assert inv["seq"] == 4 and inv["figure"] > 20.0
