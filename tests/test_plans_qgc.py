"""Plans as QGroundControl writes them (issue 17): its nulls, read as its own loader
and ArduPilot read them; flown as the vehicles fly them; over the mission protocol too."""
import json
import math

import numpy as np
import pytest

from autopilot.link.codec import MAV
from autopilot.mission.files import MissionFileError, load_mission, loads_plan
from autopilot.mission.items import (DO_CHANGE_SPEED, DO_SET_CAM_TRIGG_DIST, DO_SET_ROI_LOCATION, DO_SET_ROI_NONE,
                                     DO_SET_ROI_WPNEXT_OFFSET,
                                     NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT,
                                     NAV_TAKEOFF, NAV_WAYPOINT, MissionItem)
from test_gcs_protocol import download, make_core, make_quad, upload
from test_mission_commands import fly as fly_quad
from test_quad_guidance import HOME as QHOME
from test_quad_guidance import item as qitem
from test_quad_guidance import mission as qmission
import test_sequencer as ps

HOME = [-35.363262, 149.165237, 584]


def plan_text(items, home=HOME, **mission_extra):
    doc = {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
           "geoFence": {"circles": [], "polygons": [], "version": 2},
           "rallyPoints": {"points": [], "version": 2},
           "mission": {"cruiseSpeed": 15, "hoverSpeed": 5, "firmwareType": 3, "vehicleType": 2,
                       "version": 2, "plannedHomePosition": home, "items": items,
                       **mission_extra}}
    return json.dumps(doc)


def simple(cmd, frame, params, jid=None, **extra):
    d = {"type": "SimpleItem", "command": cmd, "frame": frame, "params": params,
         "autoContinue": True, **extra}
    if jid is not None:
        d["doJumpId"] = jid
    return d


# --- nulls -----------------------------------------------------------------------------

EVERY_NULL = [
    # takeoff: yaw null, QGroundControl's display fields null
    simple(22, 3, [0, 0, 0, None, -35.3605, 149.1652, 30], 1,
           AMSLAltAboveTerrain=None, Altitude=None, AltitudeMode=None),
    # waypoint: heading null (no change)
    simple(16, 3, [0, 0, 0, None, -35.3600, 149.1660, 40], 2),
    # loiter: altitude null (the current altitude), frame absolute as QGC writes it
    simple(19, 0, [5, 0, 0, 1, -35.3595, 149.1660, None], 3),
    # DO_CHANGE_SPEED: unused latitude / longitude / altitude null, doJumpId null
    simple(178, 2, [1, 8, -1, 0, None, None, None], None, doJumpId=None),
    # QGroundControl's older item form: four params and a "coordinate"
    simple(16, 3, [0, 0, 0, None], 5, coordinate=[-35.3600, 149.1650, 35]),
    simple(20, 2, [0, 0, 0, 0, 0, 0, 0], 6),
]


@pytest.mark.parametrize("vehicle", ["plane", "quad"])
def test_every_null_qgroundcontrol_writes_loads_as_its_loader_reads_it(vehicle):
    m = loads_plan(plan_text(EVERY_NULL, cruiseSpeed=None, hoverSpeed=None), "x.plan", vehicle)
    assert [it.command for it in m.items[1:]] == [22, 16, 19, 178, 16, 20]
    assert math.isnan(m[1].param4) and math.isnan(m[2].param4)
    assert math.isnan(m[3].z_alt_m) and m[3].frame == 0
    assert math.isnan(m[4].x_lat_deg) and math.isnan(m[4].z_alt_m)
    wire = m[4].to_int()
    assert (wire["x"], wire["y"]) == (0, 0) and math.isnan(wire["z"])
    assert (m[5].x_lat_deg, m[5].y_lon_deg, m[5].z_alt_m) == (-35.36, 149.165, 35.0)


def test_a_null_home_altitude_is_sea_level_and_a_null_where_a_number_is_needed_is_refused():
    m = loads_plan(plan_text(EVERY_NULL, home=[-35.36, 149.16, None]), "x.plan", "quad")
    assert m.home.z_alt_m == 0.0
    with pytest.raises(MissionFileError, match=r"x.plan:item 0: plannedHomePosition"):
        loads_plan(plan_text(EVERY_NULL, home=[None, 149.16, 584]), "x.plan")
    bad = [simple(22, 3, [0, 0, 0, None, -35.3605, 149.1652, None], 1)] + EVERY_NULL[1:]
    with pytest.raises(MissionFileError, match=r"item 1: altitude nan m outside"):
        loads_plan(plan_text(bad), "x.plan")     # a takeoff needs its altitude
    bad = EVERY_NULL[:1] + [simple(16, 3, [0, 0, 0, None, None, 149.1652, 40], 2)] + EVERY_NULL[2:]
    with pytest.raises(MissionFileError, match=r"item 2: latitude nan outside"):
        loads_plan(plan_text(bad), "x.plan")
    bad = EVERY_NULL[:1] + [simple(16, None, [0, 0, 0, None, -35.36, 149.16, 40], 2)]
    with pytest.raises(MissionFileError, match=r"item 2: 'frame' must be an integer"):
        loads_plan(plan_text(bad), "x.plan")


def test_a_nan_altitude_is_the_current_altitude_for_both_vehicles():
    # the quadrotor: take off to 20 m, then a waypoint 60 m north at NaN: flown at 20 m
    ms = qmission(qitem(1, NAV_TAKEOFF, alt=20.0), qitem(2, NAV_WAYPOINT, n=60.0, e=0.0, alt=math.nan))
    seq, nav, log = fly_quad(ms, t_max=60.0)
    on_wp = [r for r in log if r["seq"] == 2]
    assert on_wp and all(abs(r["pos"][2] + 20.0) < 0.3 for r in on_wp)
    assert 2 in seq.reached_seqs
    # the fixed-wing: a loiter at NaN altitude is flown at the altitude it starts at
    s = ps.seq_for(ps.mission(ps.item(1, NAV_WAYPOINT, 500, 0, alt=100.0),
                              ps.item(2, NAV_LOITER_TIME, 900, 0, alt=math.nan, p=(30, 0, 80, 0))))
    s._prev_wp_ne = (0.0, 0.0)
    t = s.update(0, np.array([600.0, 0.0, -130.0]), np.array([25.0, 0, 0]), 0.0, 630.0)
    # (on the line into the loiter, flown to its circle, at the altitude the item started at)
    assert t.seq == 2 and t.kind in ("line", "loiter") and t.alt_m == pytest.approx(630.0)
    t = s.update(10_000, np.array([620.0, 0.0, -140.0]), np.array([25.0, 0, 0]), 0.0, 640.0)
    assert t.alt_m == pytest.approx(630.0)          # fixed when the item started


def test_mission_item_int_with_a_nan_altitude_is_accepted_and_downloaded_back_as_nan():
    items = list(load_mission_items())
    for vehicle in (None, make_quad()):
        core, v, _, _ = make_core(vehicle)
        acks = upload(core, items)
        assert [a.type for a in acks] == [MAV.MAV_MISSION_ACCEPTED]
        got = download(core)
        assert math.isnan(got[3].z_alt_m) and math.isnan(got[2].param4)
        assert (got[4].command, got[4].x_lat_deg, got[4].y_lon_deg) == (DO_CHANGE_SPEED, 0.0, 0.0)
        # a takeoff at NaN: refused, INVALID_PARAM7, and the mission kept
        old = v.mission
        bad = list(items)
        bad[1] = bad[1].replace(z_alt_m=math.nan)
        assert [a.type for a in upload(core, bad)] == [MAV.MAV_MISSION_INVALID_PARAM7]
        assert v.mission is old


def load_mission_items() -> tuple[MissionItem, ...]:
    return loads_plan(plan_text(EVERY_NULL), "x.plan", "quad").items


# --- the commands of QGroundControl's plans --------------------------------------------

def test_the_quad_points_its_nose_at_the_roi_until_roi_none():
    ms = qmission(qitem(1, NAV_TAKEOFF, alt=10.0),
                  qitem(2, DO_SET_ROI_LOCATION, n=0.0, e=80.0, alt=0.0, frame=0),
                  qitem(3, NAV_WAYPOINT, n=60.0, e=0.0, alt=10.0),
                  qitem(4, NAV_WAYPOINT, n=60.0, e=40.0, alt=10.0),
                  qitem(5, DO_SET_ROI_NONE, frame=2),
                  qitem(6, NAV_WAYPOINT, n=0.0, e=40.0, alt=10.0))
    seq, nav, log = fly_quad(ms, t_max=120.0, yaw_lag_s=0.3)
    assert {3, 4, 6} <= seq.reached_seqs
    errs = []
    for r in log:
        if r["seq"] in (3, 4) and r["t"] > 0:
            n, e = r["pos"][0], r["pos"][1]
            want = math.atan2(80.0 - e, 0.0 - n)
            errs.append(abs(math.degrees(wrap(r["yaw"] - want))))
    # after the first turn towards it (at most 180 deg at YAW_RATE_MAX), the nose is on it
    settled = errs[int(len(errs) * 0.3):]
    assert max(settled) < 5.0, max(settled)
    # after DO_SET_ROI_NONE the nose follows the leg again (south)
    last = [r for r in log if r["seq"] == 6][-200]
    assert abs(math.degrees(wrap(last["yaw"] - math.pi))) < 5.0


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_the_plane_notes_the_roi_once_for_a_gimbal_it_does_not_have():
    roi = ps.item(2, DO_SET_ROI_LOCATION, 300, 300, alt=0.0, frame=0)
    s = ps.seq_for(ps.mission(ps.item(1, NAV_WAYPOINT, 500, 0), roi,
                              ps.item(3, NAV_WAYPOINT, 1000, 0), roi.replace(seq=4),
                              ps.item(5, NAV_WAYPOINT, 1500, 0)))
    s._prev_wp_ne = (0.0, 0.0)
    ps.fly(s, [(n, 0.0) for n in range(0, 1600, 20)])
    said = [text for _, _, text in s.notices if "ROI" in text]
    assert said == ["ROI noted: no gimbal on this airframe to point"]
    assert s.roi is not None and {2, 4} <= s.reached_seqs


def test_spline_waypoints_are_a_smooth_path_through_the_points_for_the_quad():
    pts = [(60.0, 0.0), (60.0, 60.0), (0.0, 60.0)]
    ms = qmission(qitem(1, NAV_TAKEOFF, alt=10.0),
                  *[qitem(2 + k, NAV_SPLINE_WAYPOINT, n=n, e=e, alt=10.0)
                    for k, (n, e) in enumerate(pts)])
    seq, nav, log = fly_quad(ms, t_max=120.0)
    assert {2, 3, 4} <= seq.reached_seqs
    for n, e in pts[:2]:
        near = min(log, key=lambda r: math.hypot(r["pos"][0] - n, r["pos"][1] - e))
        # through the point (within a metre) without stopping there (flown through)
        assert math.hypot(near["pos"][0] - n, near["pos"][1] - e) < 1.0
        assert math.hypot(near["vel"][0], near["vel"][1]) > 3.0
    # no corner: the course changes smoothly (never more than 3 deg per 0.1 s step)
    moving = [r for r in log if r["seq"] in (3, 4) and math.hypot(r["vel"][0], r["vel"][1]) > 2.0]
    courses = [math.atan2(r["vel"][1], r["vel"][0]) for r in moving[::25]]
    steps = [abs(math.degrees(wrap(b - a))) for a, b in zip(courses, courses[1:])]
    assert steps and max(steps) < 3.0, max(steps)
    # and it stops on the last point (no spline after it)
    end = next(r for r in log if r["seq"] == 5)
    assert math.hypot(end["pos"][0] - 0.0, end["pos"][1] - 60.0) < 0.5
    assert math.hypot(end["vel"][0], end["vel"][1]) < 0.2


def test_the_plane_flies_a_spline_waypoint_as_a_waypoint_and_loiter_to_alt_by_its_sign():
    s = ps.seq_for(ps.mission(ps.item(1, NAV_SPLINE_WAYPOINT, 500, 0, p=(5, 0, 0, 0)),
                              ps.item(2, NAV_LOITER_TO_ALT, 900, 0, alt=120.0, p=(0, -200, 0, 0))))
    s._prev_wp_ne = (0.0, 0.0)
    t = ps.fly(s, [(n, 0.0) for n in (100, 300)])
    assert t[-1].kind == "line" and t[-1].b_ne == pytest.approx((500.0, 0.0), abs=0.5)
    # the line into the loiter is flown to its circle (radius 200 + 10 m), then the circle
    t = ps.fly(s, [(n, 0.0) for n in (450, 520, 600)])
    assert t[-1].seq == 2 and t[-1].kind == "line" and t[-1].b_ne == pytest.approx((900.0, 0.0), abs=0.5)
    t = ps.fly(s, [(n, 0.0) for n in (650, 700)])
    assert t[-1].seq == 2 and t[-1].kind == "loiter"
    assert t[-1].radius_m == pytest.approx(200.0) and t[-1].direction == -1


def test_do_change_speed_of_ground_speed_sets_the_plane_minimum_and_the_quad_speed():
    s = ps.seq_for(ps.mission(ps.item(1, DO_CHANGE_SPEED, frame=2, alt=0.0, p=(1, 18, -1, 0)),
                              ps.item(2, NAV_WAYPOINT, 800, 0)))
    s._prev_wp_ne = (0.0, 0.0)
    s.update(0, np.array([10.0, 0.0, -100.0]), np.array([20.0, 0, 0]), 0.0, 600.0,
             wind_ne=(-10.0, 0.0))
    assert s.min_groundspeed_mps == 18.0
    t = s.update(10_000, np.array([20.0, 0.0, -100.0]), np.array([20.0, 0, 0]), 0.0, 600.0,
                 wind_ne=(-10.0, 0.0))
    assert t.airspeed_mps == pytest.approx(min(28.0, s.params["ARSPD_FBW_MAX"]), abs=0.01)
    ms = qmission(qitem(1, NAV_TAKEOFF, alt=5.0), qitem(2, DO_CHANGE_SPEED, 1, 8, -1, frame=2),
                  qitem(3, NAV_WAYPOINT, n=150.0, e=0.0, alt=5.0))
    seq, nav, log = fly_quad(ms, t_max=60.0)
    top = max(math.hypot(r["vel"][0], r["vel"][1]) for r in log)
    assert top == pytest.approx(8.0, abs=0.1)


# --- ComplexItems ----------------------------------------------------------------------

def survey_doc(vehicle, **kw):
    from tools.qgc_survey import DEFAULTS, survey_plan
    return survey_plan(vehicle, **{**DEFAULTS[vehicle], **kw})


@pytest.mark.parametrize("vehicle", ["plane", "quad"])
def test_a_survey_is_flown_from_its_stored_items_numbered_as_qgroundcontrol_numbers_them(vehicle):
    doc = survey_doc(vehicle)
    stored = doc["mission"]["items"][1]["TransectStyleComplexItem"]["Items"]
    m = loads_plan(json.dumps(doc), "s.plan", vehicle)
    # take-off 1, the survey's items 2.., then the item after it
    assert len(m) == 1 + 1 + len(stored) + 1
    assert [it.seq for it in m] == list(range(len(m)))
    assert [d["doJumpId"] for d in stored] == [it.seq for it in m.items[2:-1]]
    assert [(it.command, it.param1) for it in m.items[2:-1]] == \
        [(d["command"], d["params"][0]) for d in stored]
    # 20 transects: an entry (trigger distance) and an exit (0) camera command each
    trig = [it.param1 for it in m if it.command == DO_SET_CAM_TRIGG_DIST]
    assert len(trig) == 40 and trig[0::2] == [trig[0]] * 20 and set(trig[1::2]) == {0.0}
    assert m[-1].command == (20 if vehicle == "plane" else 21)


def test_the_shipped_survey_plans_are_what_the_tool_writes():
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    for vehicle in ("plane", "quad"):
        shipped = json.loads((root / "missions" / f"survey_{vehicle}.plan").read_text())
        assert shipped == json.loads(json.dumps(survey_doc(vehicle)))
        m = load_mission(root / "missions" / f"survey_{vehicle}.plan", vehicle)
        assert len(m) == 123


def test_a_complex_item_without_stored_items_is_refused_naming_it():
    doc = survey_doc("quad", transects=2)
    items = doc["mission"]["items"]
    del items[1]["TransectStyleComplexItem"]["Items"]
    with pytest.raises(MissionFileError, match=r"x.plan:item 2: ComplexItem survey \(mission.items\[1\]\) "
                                               r"has no stored mission items"):
        loads_plan(json.dumps(doc), "x.plan")
    items[1] = {"type": "ComplexItem", "complexItemType": "fwLandingPattern", "version": 2}
    with pytest.raises(MissionFileError, match=r"item 2: ComplexItem fixed-wing landing pattern .*saves only its geometry"):
        loads_plan(json.dumps(doc), "x.plan")
    items[1] = {"type": "ComplexItem", "complexItemType": "StructureScan", "version": 3,
                "polygon": [[-35.36, 149.16], [-35.36, 149.17], [-35.37, 149.17]], "Layers": 2}
    with pytest.raises(MissionFileError, match=r"item 2: ComplexItem structure scan .*needs .CameraCalc."):
        loads_plan(json.dumps(doc), "x.plan")
    items[1] = {"type": "ComplexItem", "complexItemType": "CorridorScan", "version": 3,
                "TransectStyleComplexItem": {"Items": []}}
    with pytest.raises(MissionFileError, match=r"ComplexItem corridor scan .* has no stored"):
        loads_plan(json.dumps(doc), "x.plan")


def test_a_corridor_scan_loads_and_a_bad_stored_item_is_named_with_its_complex_item():
    doc = survey_doc("quad", transects=2)
    survey = doc["mission"]["items"][1]
    corridor = {"type": "ComplexItem", "complexItemType": "CorridorScan", "version": 3,
                "CorridorWidth": 20, "EntryPoint": 0, "polyline": survey["polygon"][:2],
                "TransectStyleComplexItem": survey["TransectStyleComplexItem"]}
    doc["mission"]["items"][1] = corridor
    m = loads_plan(json.dumps(doc), "c.plan", "quad")
    assert len(m) == 1 + 1 + len(survey["TransectStyleComplexItem"]["Items"]) + 1
    corridor["TransectStyleComplexItem"]["Items"][3]["params"][4] = 95.0
    with pytest.raises(MissionFileError, match=r"c.plan:item 5 \(CorridorScan at mission.items\[1\], "
                                               r"its item 4\): latitude 95.0 outside"):
        loads_plan(json.dumps(doc), "c.plan", "quad")


def test_camera_commands_are_noted_once_by_both_vehicles():
    doc = survey_doc("quad", transects=3, length=20.0, north=10.0, east=0.0, home=QHOME)
    m = loads_plan(json.dumps(doc), "s.plan", "quad")
    seq, nav, log = fly_quad(m, t_max=300.0)
    assert seq.landed
    said = [t for _, _, t in seq.notices if "camera" in t]
    assert said == ["Mission: camera commands noted: no camera on this airframe"]
    cams = {it.seq for it in m if it.command == DO_SET_CAM_TRIGG_DIST}
    assert cams <= seq.reached_seqs
    s = ps.seq_for(ps.mission(ps.item(1, NAV_WAYPOINT, 500, 0),
                              ps.item(2, DO_SET_CAM_TRIGG_DIST, frame=2, alt=0.0, p=(40, 0, 1, 0)),
                              ps.item(3, NAV_WAYPOINT, 1000, 0),
                              ps.item(4, DO_SET_CAM_TRIGG_DIST, frame=2, alt=0.0),
                              ps.item(5, NAV_WAYPOINT, 1500, 0)))
    s._prev_wp_ne = (0.0, 0.0)
    ps.fly(s, [(n, 0.0) for n in range(0, 1600, 20)])
    assert [t for _, _, t in s.notices if "amera" in t] == \
        ["Camera commands noted: no camera on this airframe"]
    assert {2, 4} <= s.reached_seqs


def structure_scan(poly, layers=2, **kw):
    return {"type": "ComplexItem", "complexItemType": "StructureScan", "version": 3,
            "polygon": poly, "Layers": layers, "EntranceAltitude": 20, "ScanBottomAlt": 5,
            "StructureHeight": 25, "GimbalPitch": 0, "StartFromTop": False,
            "CameraCalc": {"CameraName": "Manual (no camera specs)", "DistanceToSurface": 10,
                           "AdjustedFootprintFrontal": 10, "AdjustedFootprintSide": 5,
                           "DistanceMode": 1, "version": 2}, **kw}


def test_a_structure_scan_is_generated_as_qgroundcontrol_generates_it_and_the_quad_looks_at_it():
    # a 20 m square building 30 m north of home, its corners clockwise
    sq = [(30, -10), (50, -10), (50, 10), (30, 10)]
    poly = [[QHOME[0] + math.degrees(n / 6371000.0),
             QHOME[1] + math.degrees(e / (6371000.0 * math.cos(math.radians(QHOME[0]))))] for n, e in sq]
    doc = json.loads(plan_text([simple(22, 3, [0, 0, 0, None, QHOME[0], QHOME[1], 20], 1),
                                structure_scan(poly), simple(21, 3, [0] * 3 + [None, 0, 0, 0], 2)],
                               home=list(QHOME)))
    m = loads_plan(json.dumps(doc), "s.plan", "quad")
    # QGroundControl's count: layers x (vertices + 1 + 2 camera commands) + ROI x 2 + entry/exit
    assert len(m) == 1 + 1 + (2 * (4 + 1 + 2) + 4) + 1
    frame = ps.LocalFrame.from_degrees(*QHOME)
    wps = [it for it in m.items[2:-1] if it.command == NAV_WAYPOINT]
    ne = [tuple(round(float(c), 1) for c in frame.to_ned_fast(math.radians(it.x_lat_deg),
                                                              math.radians(it.y_lon_deg), QHOME[2])[:2])
          for it in wps]
    # the flight polygon: the square moved out by DistanceToSurface (10 m)
    assert np.allclose(ne[1:6], [(20, -20), (60, -20), (60, 20), (20, 20), (20, -20)], atol=0.3)
    assert [it.z_alt_m for it in wps] == [20.0] + [10.0] * 5 + [20.0] * 5 + [20.0]
    assert m[3].command == DO_SET_ROI_WPNEXT_OFFSET and m[3].z_alt_m == 90.0
    # flown: on the layers' legs the nose is 90 deg right of the leg, at the building
    seq, nav, log = fly_quad(m, t_max=300.0, yaw_lag_s=0.3)
    assert seq.landed
    errs = []
    for r in log:
        it = m[r["seq"]] if r["seq"] < len(m) else None
        if it is not None and it.command == NAV_WAYPOINT and 4 <= r["seq"] <= 20:
            v = math.hypot(r["vel"][0], r["vel"][1])
            if v > 2.0:
                want = math.atan2(r["vel"][1], r["vel"][0]) + math.pi / 2
                errs.append(abs(math.degrees(wrap(r["yaw"] - want))))
    assert errs and np.percentile(errs, 90) < 10.0, np.percentile(errs, 90)
