"""Geofence and rally points in flight, both vehicles, headless over the memory-pipe HIL
link (tools.runner.Session), scored from truth: a leg crossing an exclusion circle
triggers FENCE_ACTION within 0.5 s of the crossing (truth), the vehicle comes back out
and the breach clears; the altitude fence likewise; RTL goes to the nearest rally point."""
import math

import numpy as np

from autopilot.fence.files import loads_fence, loads_rally
from autopilot.geo import LocalFrame
from tools.runner import MISSIONS_DIR, RunConfig, Session
from tools.summary import run_summary

PLANE_EXCL = (-35.3583, 149.16987, 60.0)       # on the leg WP4 -> WP5 of the default mission
QUAD_EXCL = (-35.3625433, 149.16578, 15.0)     # on the leg WP3 -> WP4 of quad_default


def _wpl(cmd, p1, lat, lon, alt=0.0, frame=0):
    return f"QGC WPL 110\n0\t0\t{frame}\t{cmd}\t{p1}\t0\t0\t0\t{lat}\t{lon}\t{alt}\t1\n"


def _session(tmp_path, vehicle="plane", fence=None, rally=None, **params):
    kw = {}
    if fence is not None:
        (tmp_path / "f.fence").write_text(fence)
        kw["fence"] = tmp_path / "f.fence"
    if rally is not None:
        (tmp_path / "r.rally").write_text(rally)
        kw["rally"] = tmp_path / "r.rally"
    mission = MISSIONS_DIR / ("quad_default.waypoints" if vehicle == "quad" else "default.waypoints")
    cfg = RunConfig(vehicle=vehicle, mission=mission, seed=3, wind=(4.0, 250.0), turbulence="light",
                    param_overrides={k: str(v) for k, v in params.items()}, duration_s=300.0, **kw)
    return Session(cfg)


def _truth_ne(s, lat, lon):
    a = s.log.arrays()
    ok = np.isfinite(a["truth_n_m"])
    c = s.vehicle.home_frame.to_ned_fast(math.radians(lat), math.radians(lon), s.vehicle.home_frame.alt0_m)
    return a["t_s"][ok], a["truth_n_m"][ok] - c[0], a["truth_e_m"][ok] - c[1], a


def _check_exclusion_breach(tmp_path, vehicle, zone):
    lat, lon, r = zone
    s = _session(tmp_path, vehicle, fence=_wpl(5004, r, lat, lon), FENCE_ENABLE=1, FENCE_TYPE=4)
    s.run()
    summary = run_summary(s)
    t, dn, de, a = _truth_ne(s, lat, lon)
    inside = np.hypot(dn, de) < r
    assert inside.any(), "the leg never entered the exclusion circle"
    t_cross = t[np.argmax(inside)]
    b = summary["fence_breaches"]
    # THEN exactly one breach, by the uploaded zones ("polygon" type, as ArduPilot's),
    # acted on within 0.5 s of the crossing on truth
    assert len(b) == 1 and b[0]["type"] == "polygon" and b[0]["action"] == "RTL"
    assert abs(b[0]["at_s"] - t_cross) <= 0.5, (b[0]["at_s"], t_cross)
    # the summary's own score agrees, to a log row (its projection is the fence's own)
    assert abs(b[0]["truth_at_s"] - t_cross) <= 0.021
    print(f"{vehicle}: crossing (truth) {t_cross:.3f} s, breach {b[0]['at_s']:.3f} s, "
          f"cleared {b[0]['cleared_s']:.3f} s")
    # ... the vehicle was out again (on truth) when it cleared, and did not come back in
    assert b[0]["cleared_s"] is not None
    after = t > b[0]["cleared_s"]
    assert np.all(np.hypot(dn, de)[after] > r)
    assert not s.crashed
    # the breach explains the mode change (tools/invariants.py no_unexpected_mode)
    assert summary["invariants"]["no_unexpected_mode"]["passed"]
    return s, summary, b[0]


def test_plane_crossing_an_exclusion_circle_returns_and_loiters_over_home(tmp_path):
    s, summary, b = _check_exclusion_breach(tmp_path, "plane", PLANE_EXCL)
    # the RTL loiter over home established (the run ends on it), mission not completed
    assert s.vehicle.mode.name == "RTL" and s.vehicle.sequencer.rtl_established
    assert summary["completed"] is False
    a = s.log.arrays()
    last = np.isfinite(a["truth_n_m"])
    rad = np.hypot(a["truth_n_m"][last][-50:], a["truth_e_m"][last][-50:])
    assert np.all(np.abs(rad - s.params["LOITER_RAD"]) < 25.0)
    # STATUSTEXT of the breach and of its end
    texts = [n[2] for n in s.vehicle.notices]
    assert "Fence breach: polygon, RTL" in texts and "Fence breach cleared" in texts


def test_quad_crossing_an_exclusion_circle_returns_home_and_lands(tmp_path):
    s, summary, b = _check_exclusion_breach(tmp_path, "quad", QUAD_EXCL)
    a = s.log.arrays()
    ok = np.isfinite(a["truth_n_m"])
    assert s.vehicle.mission_landed and not s.vehicle.armed
    assert math.hypot(a["truth_n_m"][ok][-1], a["truth_e_m"][ok][-1]) < 2.0   # landed at home


def test_quad_fence_action_report_only_keeps_flying_the_mission(tmp_path):
    lat, lon, r = QUAD_EXCL
    s = _session(tmp_path, "quad", fence=_wpl(5004, r, lat, lon), FENCE_ENABLE=1, FENCE_TYPE=4,
                 FENCE_ACTION=0)
    g = s.vehicle.geofence
    while not (g.breaches and g.breaches[-1]["cleared_s"] is not None) and s.t_s < 120.0:
        s.step()
    # THEN reported (STATUSTEXT, the summary) and cleared, the mission flown on in AUTO
    assert g.breaches == [dict(g.breaches[0], action="report")]
    assert "Fence breach: polygon, report" in [n[2] for n in s.vehicle.notices]
    assert s.vehicle.mode.name == "AUTO" and s.vehicle.sequencer.current >= 4


def test_plane_altitude_fence_breach_descends_and_clears(tmp_path):
    # GIVEN the default mission (WP6 at 110 m) and a ceiling of 105 m set in flight
    s = _session(tmp_path, "plane", FENCE_TYPE=1, FENCE_ALT_MAX=105)
    v = s.vehicle
    while not (v.sequencer is not None and v.sequencer.current >= 5):
        s.step()
    assert v.set_param("FENCE_ENABLE", 1) is None
    s.run()
    summary = run_summary(s)
    a = s.log.arrays()
    ok = np.isfinite(a["truth_alt_m"])
    t, h = a["t_s"][ok], a["truth_alt_m"][ok] - v.home_truth_alt_m
    above = h > 105.0
    assert above.any()
    t_cross = t[np.argmax(above)]
    b = summary["fence_breaches"]
    assert len(b) == 1 and b[0]["type"] == "max_alt" and b[0]["action"] == "RTL"
    assert abs(b[0]["at_s"] - t_cross) <= 0.5, (b[0]["at_s"], t_cross)
    print(f"altitude: crossing (truth) {t_cross:.3f} s, breach {b[0]['at_s']:.3f} s, "
          f"cleared {b[0]['cleared_s']:.3f} s, peak {h.max():.1f} m")
    # back under the ceiling (RTL_ALT 100 m): cleared, and never above it again
    assert b[0]["cleared_s"] is not None
    assert np.all(h[t > b[0]["cleared_s"]] < 105.0)


def test_quad_altitude_fence_breach_returns_and_clears(tmp_path):
    # GIVEN quad_default (WP3 at 15 m, WP4 at 20 m) and a ceiling of 18 m set in flight
    s = _session(tmp_path, "quad", FENCE_TYPE=1, FENCE_ALT_MAX=18)
    v = s.vehicle
    while not (v.sequencer is not None and v.sequencer.current >= 3):
        s.step()
    assert v.set_param("FENCE_ENABLE", 1) is None
    s.run()
    summary = run_summary(s)
    a = s.log.arrays()
    ok = np.isfinite(a["truth_alt_m"])
    t, h = a["t_s"][ok], a["truth_alt_m"][ok] - v.home_truth_alt_m
    t_cross = t[np.argmax(h > 18.0)]
    (b,) = summary["fence_breaches"]
    assert b["type"] == "max_alt" and b["action"] == "RTL"
    assert abs(b["at_s"] - t_cross) <= 0.5, (b["at_s"], t_cross)
    print(f"quad altitude: crossing (truth) {t_cross:.3f} s, breach {b['at_s']:.3f} s, "
          f"cleared {b['cleared_s']:.3f} s, peak {h.max():.2f} m")
    # the RTL brings it home and down: cleared on the way, landed at home
    assert b["cleared_s"] is not None and v.mission_landed and not v.armed
    assert h.max() < 19.0


def test_plane_rtl_goes_to_the_nearest_rally_point_and_loiters_there(tmp_path):
    near, far = (-35.3655, 149.1765), (-35.3500, 149.1500)
    rally = "".join(f"RALLY {la} {lo} 90 0 0 0\n" for la, lo in (far, near))
    s = _session(tmp_path, "plane", rally=rally)
    v = s.vehicle
    while not (v.sequencer is not None and v.sequencer.current >= 7):   # east, far from home
        s.step()
    assert v.set_mode(v.modes.RTL, 0) is None
    t_rtl = s.t_s
    while s.t_s < t_rtl + 90.0:
        s.step()
    t, dn, de, a = _truth_ne(s, *near)
    d = np.hypot(dn, de)[t > t_rtl + 60.0]
    r = v.rtl_hold.radius_m
    # THEN it circles the near rally point (not home, not the far one) at its height
    assert np.all(np.abs(d - r) < 25.0), (d.min(), d.max(), r)
    print(f"plane rally loiter: radius {r:.0f} m, distance to the point {d.min():.1f}-{d.max():.1f} m")
    h = a["truth_alt_m"][np.isfinite(a["truth_alt_m"])][-50:] - v.home_truth_alt_m
    assert np.all(np.abs(h - 90.0) < 5.0)


def test_quad_rtl_lands_at_the_nearest_rally_point(tmp_path):
    rp = (-35.3636213, 149.1668)
    s = _session(tmp_path, "quad", rally=_wpl(5100, 0, rp[0], rp[1], 12.0, frame=3))
    v = s.vehicle
    while not (v.sequencer is not None and v.sequencer.current >= 5):
        s.step()
    assert v.set_mode(v.modes.RTL, 0) is None
    s.run()
    t, dn, de, a = _truth_ne(s, *rp)
    assert v.mission_landed and not v.armed
    assert math.hypot(dn[-1], de[-1]) < 2.0, (dn[-1], de[-1])
    print(f"quad rally landing: {math.hypot(dn[-1], de[-1]):.2f} m from the point")


def test_quad_rtl_with_landing_disabled_holds_over_the_rally_point(tmp_path):
    # GIVEN RTL_ALT_FINAL 8 m (ArduCopter's: no landing at the end of RTL)
    rp = (-35.3636213, 149.1668)
    s = _session(tmp_path, "quad", rally=_wpl(5100, 0, rp[0], rp[1], 12.0, frame=3), RTL_ALT_FINAL=8)
    v = s.vehicle
    while not (v.sequencer is not None and v.sequencer.current >= 5):
        s.step()
    assert v.set_mode(v.modes.RTL, 0) is None
    t_rtl = s.t_s
    while s.t_s < t_rtl + 55.0:
        s.step()
    t, dn, de, a = _truth_ne(s, *rp)
    late = t > t_rtl + 45.0
    h = a["truth_alt_m"][np.isfinite(a["truth_n_m"])] - v.home_truth_alt_m
    # THEN still armed and flying, over the rally point at 8 m
    assert v.armed and not v.mission_landed
    assert np.all(np.hypot(dn, de)[late] < 1.0)
    assert np.all(np.abs(h[late] - 8.0) < 0.5)


def test_quad_missions_rtl_item_lands_at_the_nearest_rally_point(tmp_path):
    # GIVEN a short mission ending in NAV_RETURN_TO_LAUNCH, a rally point beside its waypoint
    wp = (-35.3632620, 149.1659)            # about 60 m east of home
    rp = (-35.3634, 149.1657)
    (tmp_path / "m.waypoints").write_text(
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t-35.363262\t149.165237\t584\t1\n"
        "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1\n"
        f"2\t0\t3\t16\t0\t0\t0\t0\t{wp[0]}\t{wp[1]}\t10\t1\n"
        "3\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1\n")
    (tmp_path / "r.rally").write_text(f"RALLY {rp[0]} {rp[1]} 10 0 0 0\n")
    s = Session(RunConfig(vehicle="quad", mission=tmp_path / "m.waypoints", rally=tmp_path / "r.rally",
                          seed=2, duration_s=120.0))
    s.run()
    summary = run_summary(s)
    t, dn, de, a = _truth_ne(s, *rp)
    # THEN the mission completes with its landing at the rally point (ArduCopter's RTL)
    assert summary["completed"] is True and s.vehicle.mission_landed
    assert math.hypot(dn[-1], de[-1]) < 1.0, (dn[-1], de[-1])


def test_fence_files_and_refusals():
    # the legacy MAVProxy list: return point, vertices, closing point
    items = loads_fence("-35.36 149.16\n-35.35 149.15\n-35.35 149.18\n-35.37 149.18\n-35.35 149.15\n")
    assert [it.command for it in items] == [5000, 5001, 5001, 5001]
    assert all(it.param1 == 3 for it in items[1:])
    rally = loads_rally("RALLY -35.36 149.17 80 40 0 0\n")
    assert rally[0].command == 5100 and rally[0].z_alt_m == 80.0 and rally[0].frame == 3
    import pytest
    from autopilot.mission.files import MissionFileError
    with pytest.raises(MissionFileError, match="4 vertices declared, 3 given"):
        loads_fence("QGC WPL 110\n" + "".join(
            f"{k}\t0\t0\t5001\t4\t0\t0\t0\t-35.3{k}\t149.1{k}\t0\t1\n" for k in range(3)))
    with pytest.raises(MissionFileError, match="at least 3 vertices"):
        loads_fence(_wpl(5001, 2, -35.3, 149.1))


def _plan_with_fence(tmp_path, circles):
    import json
    doc = json.loads((MISSIONS_DIR / "default.plan").read_text())
    doc["geoFence"] = {"version": 2, "circles": circles, "polygons": [
        {"inclusion": True, "version": 1,
         "polygon": [[-35.348, 149.158], [-35.348, 149.183], [-35.376, 149.183], [-35.376, 149.158]]}],
        "breachReturn": [-35.3600, 149.1700, 90]}
    doc["rallyPoints"] = {"version": 2, "points": [[-35.3655, 149.1765, 90], [-35.3500, 149.1600, 80]]}
    p = tmp_path / "fenced.plan"
    p.write_text(json.dumps(doc))
    return p


def test_a_plan_brings_its_fence_and_rally_points_and_an_outside_mission_is_refused(tmp_path):
    import pytest
    from autopilot.mission.files import MissionFileError
    excl = {"inclusion": False, "version": 1, "circle": {"center": [-35.3583, 149.16987], "radius": 60}}
    plan = _plan_with_fence(tmp_path, [excl])
    s = Session(RunConfig(mission=plan, seed=1, duration_s=1.0))
    g = s.vehicle.geofence
    assert [it.command for it in g.fence_items] == [5001] * 4 + [5004, 5000]
    assert g.fence_items[4].param1 == 60 and g.return_point(584.0) == (-35.36, 149.17, 674.0)
    assert [(it.command, it.z_alt_m, it.frame) for it in g.rally_items] == [(5100, 90, 3), (5100, 80, 3)]
    # an enabled fence with a waypoint (WP4) inside its exclusion circle: refused, named
    excl["circle"]["center"] = [-35.3565171, 149.1698685]
    plan = _plan_with_fence(tmp_path, [excl])
    with pytest.raises(MissionFileError, match="item 4 outside the fence"):
        Session(RunConfig(mission=plan, seed=1, param_overrides={"FENCE_ENABLE": "1", "FENCE_TYPE": "4"}))


def test_plane_fence_action_guided_loiters_at_the_return_point(tmp_path):
    # GIVEN the exclusion circle on leg 4 -> 5 and a return point, FENCE_ACTION 6
    lat, lon, r = PLANE_EXCL
    rp = (-35.3620, 149.1600)
    fence = _wpl(5004, r, lat, lon) + f"1\t0\t3\t5000\t0\t0\t0\t0\t{rp[0]}\t{rp[1]}\t80\t1\n"
    s = _session(tmp_path, "plane", fence=fence, FENCE_ENABLE=1, FENCE_TYPE=4, FENCE_ACTION=6)
    s.cfg.duration_s = 240.0   # arrives ~145 s in (the default mission), settles within a minute
    s.run()
    summary = run_summary(s)
    (b,) = summary["fence_breaches"]
    assert b["action"] == "GUIDED" and b["cleared_s"] is not None
    # THEN it circles the return point at its altitude, in GUIDED, until told otherwise
    assert s.vehicle.mode.name == "GUIDED"
    t, dn, de, a = _truth_ne(s, *rp)
    d = np.hypot(dn, de)[t > s.t_s - 30.0]
    assert np.all(np.abs(d - s.vehicle.hold.radius_m) < 25.0), (d.min(), d.max())
    print(f"guided: radius {s.vehicle.hold.radius_m:.0f} m, distance to the return point "
          f"{d.min():.1f}-{d.max():.1f} m")
    h = a["truth_alt_m"][np.isfinite(a["truth_alt_m"])][-50:] - s.vehicle.home_truth_alt_m
    assert np.all(np.abs(h - 80.0) < 5.0)


def test_sitl_run_names_a_malformed_fence_or_rally_file(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    import pytest
    from autopilot.mission.files import MissionFileError
    repo = Path(__file__).resolve().parent.parent
    (tmp_path / "bad.fence").write_text("-35.36 149.16\n-35.35 149.15\n-35.35 149.18\n")
    r = subprocess.run([sys.executable, "-m", "tools.sitl", "run", "--fence", str(tmp_path / "bad.fence"),
                        "--json"], cwd=repo, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stdout == ""
    assert "bad.fence: 3 points: a return point, at least 3 vertices" in r.stderr, r.stderr
    with pytest.raises(MissionFileError, match=":1: expected 'RALLY LAT LON ALT"):
        loads_rally("RALLY -35.36 149.17 80\n", "bad.rally")


def test_plane_missions_rtl_item_goes_to_the_nearest_rally_point_and_loiters_there(tmp_path):
    # GIVEN a plane mission ending in NAV_RETURN_TO_LAUNCH after a waypoint 900 m east,
    # and a rally point 300 m north of that waypoint (nearer than home)
    wp = (-35.363262, 149.175137)
    rp = (-35.360562, 149.175137)
    (tmp_path / "m.waypoints").write_text(
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t-35.363262\t149.165237\t584\t1\n"
        "1\t0\t3\t22\t15\t0\t0\t0\t0\t0\t40\t1\n"
        f"2\t0\t3\t16\t0\t0\t0\t0\t{wp[0]}\t{wp[1]}\t60\t1\n"
        "3\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1\n")
    (tmp_path / "r.rally").write_text(f"RALLY {rp[0]} {rp[1]} 80 0 0 0\n")
    s = Session(RunConfig(mission=tmp_path / "m.waypoints", rally=tmp_path / "r.rally", seed=2,
                          duration_s=400.0))
    v = s.vehicle
    while s.t_s < 400.0 and not (v.sequencer is not None and v.sequencer.rtl_established):
        s.step()
    t_est = s.t_s
    while s.t_s < t_est + 30.0:
        s.step()
    summary = run_summary(s)
    t, dn, de, a = _truth_ne(s, *rp)
    late = t > t_est
    r = v.sequencer.home_loiter_radius_m(0)
    # THEN the RTL item is flown to the rally point (said), and the plane circles it at
    # its height: not home, which is 900 m further
    assert v.sequencer.rtl_established and summary["completed"] is True
    assert "RTL: to rally point -35.3605620 149.1751370" in [x for _, _, x in v.notices]
    d = np.hypot(dn, de)[late]
    assert np.all(np.abs(d - r) < 25.0), (d.min(), d.max(), r)
    h = a["truth_alt_m"][np.isfinite(a["truth_alt_m"])][-50:] - v.home_truth_alt_m
    assert np.all(np.abs(h - 80.0) < 5.0), (h.min(), h.max())
    print(f"plane mission RTL at the rally point: radius {r:.0f} m, distance {d.min():.1f}-{d.max():.1f} m")
