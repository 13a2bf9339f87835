"""Plans as QGroundControl writes them (issue 17): its nulls, read as its own loader
and ArduPilot read them; flown as the vehicles fly them; over the mission protocol too."""
import json
import math

import numpy as np
import pytest

from autopilot.link.codec import MAV
from autopilot.mission.files import MissionFileError, load_mission, loads_plan
from autopilot.mission.items import (DO_CHANGE_SPEED, NAV_LOITER_TIME, NAV_TAKEOFF,
                                     NAV_WAYPOINT, MissionItem)
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
    assert t.seq == 2 and t.kind == "loiter" and t.alt_m == pytest.approx(630.0)
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
