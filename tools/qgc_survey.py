"""Survey plans in QGroundControl's own format: a take-off, a survey ComplexItem with the
mission items QGroundControl stores in it, and the way home.

``python -m tools.qgc_survey transects RUN_DIR`` prints each transect's cross-track
error from a run folder of a survey flight (``transect_figures``).

``python -m tools.qgc_survey --vehicle plane|quad --out FILE.plan`` writes the plan the
shipped ``missions/survey_plane.plan`` / ``missions/survey_quad.plan`` were made with
(their options below are the defaults of each vehicle). The survey is a rectangle of
``--transects`` parallel transects ``--length`` m long, ``--spacing`` m apart, at
``--angle`` degrees from north, ``--alt`` m above home; what the file holds is what
QGroundControl saves for a survey over that area with a manual camera triggering by
distance (TransectStyleComplexItem::_save, SurveyComplexItem::save, version 5):

* the survey object: ``angle``, ``entryLocation``, ``flyAlternateTransects``,
  ``polygon``, ``splitConcavePolygons``, ``complexItemType`` "survey", ``version`` 5 and
  ``TransectStyleComplexItem`` (``CameraCalc``, ``CameraShots``,
  ``CameraTriggerInTurnAround``, ``HoverAndCapture``, ``Refly90Degrees``,
  ``TurnAroundDistance``, ``VisualTransectPoints``, ``Items``, ``version`` 2);
* ``Items``, per transect, as QGroundControl builds them
  (TransectStyleComplexItem::_buildAndAppendMissionItems, camera triggered per
  transect, turnarounds on): a waypoint ``TurnAroundDistance`` before the transect, its
  entry waypoint and DO_SET_CAM_TRIGG_DIST (the trigger distance, trigger once now), its
  exit waypoint and DO_SET_CAM_TRIGG_DIST 0, and a waypoint ``TurnAroundDistance``
  after it; waypoints are [0, 0, 0, null (heading unchanged), lat, lon, alt] in
  MAV_FRAME_GLOBAL_RELATIVE_ALT; each item's doJumpId is its sequence number;
* the transects are flown as a lawnmower (every other one reversed); with
  ``flyAlternateTransects`` (the fixed-wing's default: its turns need more room than one
  spacing) the even-numbered ones first, then the odd-numbered ones in reverse order,
  as QGroundControl orders them.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from autopilot.geo import LocalFrame

HOME = (-35.363262, 149.165237, 584.0)   # ArduPilot's SITL home (CMAC)
CMD_WAYPOINT, CMD_TAKEOFF, CMD_RTL, CMD_LAND, CMD_CAM_TRIGG_DIST = 16, 22, 20, 21, 206
FRAME_MISSION, FRAME_RELATIVE = 2, 3

DEFAULTS = {
    # 20 transects of 600 m, 80 m apart, flown alternately (160 m between consecutive ones)
    "plane": dict(transects=20, length=600.0, spacing=80.0, angle=0.0, alt=100.0,
                  turnaround=100.0, alternate=True, north=700.0, east=-700.0, trigger=40.0),
    # 20 transects of 80 m, 10 m apart
    "quad": dict(transects=20, length=80.0, spacing=10.0, angle=0.0, alt=30.0,
                 turnaround=10.0, alternate=False, north=30.0, east=-100.0, trigger=8.0),
}


def _ll(frame: LocalFrame, n: float, e: float) -> list[float]:
    lat, lon, _ = frame.to_geodetic_fast(np.array([n, e, 0.0]))
    return [round(math.degrees(lat), 7), round(math.degrees(lon), 7)]


def _simple(seq: int, command: int, frame: int, params: list) -> dict:
    return {"autoContinue": True, "command": command, "doJumpId": seq, "frame": frame,
            "params": params, "type": "SimpleItem"}


def survey_plan(vehicle: str, *, transects: int, length: float, spacing: float, angle: float,
                alt: float, turnaround: float, alternate: bool, north: float, east: float,
                trigger: float, home=HOME) -> dict:
    """The plan document (module docstring). ``north`` / ``east``: the survey area's
    first corner from home [m]."""
    frame = LocalFrame.from_degrees(*home)
    a = math.radians(angle)
    u = (math.cos(a), math.sin(a))          # along the transects
    w = (-math.sin(a), math.cos(a))         # across them (to the right of u)

    def pt(s_along: float, s_across: float) -> tuple[float, float]:
        return (north + s_along * u[0] + s_across * w[0], east + s_along * u[1] + s_across * w[1])

    width = spacing * (transects - 1)
    corners = [pt(0, 0), pt(length, 0), pt(length, width), pt(0, width)]
    polygon = [_ll(frame, *c) for c in corners]
    order = list(range(transects))
    if alternate:
        order = [i for i in order if i % 2 == 0] + [i for i in reversed(order) if i % 2 == 1]
    lines = []
    for k, i in enumerate(order):
        a0, a1 = (0.0, length) if k % 2 == 0 else (length, 0.0)
        lines.append((a0, a1, i * spacing))

    seq = 1
    items = [_simple(seq, CMD_TAKEOFF, FRAME_RELATIVE,
                     [15 if vehicle == "plane" else 0, 0, 0, None, home[0], home[1], alt])]
    seq += 1
    inner, visual = [], []

    def wp(n_e, s):
        lat, lon = _ll(frame, *n_e)
        inner.append(_simple(s, CMD_WAYPOINT, FRAME_RELATIVE, [0, 0, 0, None, lat, lon, alt]))

    def cam(d, s):
        inner.append(_simple(s, CMD_CAM_TRIGG_DIST, FRAME_MISSION, [d, 0, 1, 0, 0, 0, 0]))

    first = seq
    for a0, a1, c in lines:
        sign = 1.0 if a1 > a0 else -1.0
        wp(pt(a0 - sign * turnaround, c), seq)
        seq += 1
        wp(pt(a0, c), seq)
        cam(trigger, seq + 1)
        seq += 2
        wp(pt(a1, c), seq)
        cam(0, seq + 1)
        seq += 2
        wp(pt(a1 + sign * turnaround, c), seq)
        seq += 1
        visual += [_ll(frame, *pt(a0, c)), _ll(frame, *pt(a1, c))]
    shots = int(len(lines) * (length // trigger + 1))
    survey = {
        "TransectStyleComplexItem": {
            "CameraCalc": {"AdjustedFootprintFrontal": trigger, "AdjustedFootprintSide": spacing,
                           "CameraName": "Manual (no camera specs)", "DistanceMode": 1,
                           "DistanceToSurface": alt, "version": 2},
            "CameraShots": shots, "CameraTriggerInTurnAround": False, "HoverAndCapture": False,
            "Items": inner, "Refly90Degrees": False, "TurnAroundDistance": turnaround,
            "VisualTransectPoints": visual, "version": 2},
        "angle": angle, "complexItemType": "survey", "entryLocation": 0,
        "flyAlternateTransects": alternate, "polygon": polygon, "splitConcavePolygons": False,
        "type": "ComplexItem", "version": 5,
    }
    assert seq == first + len(inner)
    items.append(survey)
    if vehicle == "plane":
        items.append(_simple(seq, CMD_RTL, FRAME_MISSION, [0, 0, 0, 0, 0, 0, 0]))
    else:
        items.append(_simple(seq, CMD_LAND, FRAME_RELATIVE, [0, 0, 0, None, home[0], home[1], 0]))
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "groundStation": "QGroundControl",
        "mission": {"cruiseSpeed": 25 if vehicle == "plane" else 15, "firmwareType": 3,
                    "globalPlanAltitudeMode": 1, "hoverSpeed": 5, "items": items,
                    "plannedHomePosition": list(home), "vehicleType": 1 if vehicle == "plane" else 2,
                    "version": 2},
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }


def transect_figures(run_dir: str) -> list[dict]:
    """Each transect's cross-track error in a run folder of a survey: the lines of
    ``xtrack_mission_legs`` (summary.json) from a waypoint followed by a camera trigger
    start to one followed by a trigger stop (a transect's entry and exit)."""
    import os

    from autopilot.mission.files import load_mission
    with open(os.path.join(run_dir, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    m = load_mission(os.path.join(run_dir, "mission.waypoints"))

    def trigger(seq, start):
        nxt = m[seq + 1] if seq + 1 < len(m) else None
        return nxt is not None and nxt.command == CMD_CAM_TRIGG_DIST and (nxt.param1 > 0) == start

    return [dict(g, transect=k + 1) for k, g in enumerate(
        g for g in summary.get("xtrack_mission_legs", [])
        if g["from_seq"] is not None and trigger(g["from_seq"], True) and trigger(g["to_seq"], False))]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["transects"]:
        if len(argv) != 2:
            print("usage: python -m tools.qgc_survey transects RUN_DIR", file=sys.stderr)
            return 2
        rows = transect_figures(argv[1])
        for r in rows:
            rms = "-" if r["rms_m"] is None else f"{r['rms_m']:.2f}"
            mx = "-" if r["max_m"] is None else f"{r['max_m']:.2f}"
            print(f"transect {r['transect']:2d}  items {r['from_seq']}-{r['to_seq']}  "
                  f"xtrack rms {rms} m  max {mx} m")
        return 0
    ap = argparse.ArgumentParser(prog="python -m tools.qgc_survey", description=__doc__.splitlines()[0])
    ap.add_argument("--vehicle", choices=("plane", "quad"), required=True)
    ap.add_argument("--out", required=True, help="the .plan file to write")
    for name in ("transects",):
        ap.add_argument(f"--{name}", type=int)
    for name in ("length", "spacing", "angle", "alt", "turnaround", "north", "east", "trigger"):
        ap.add_argument(f"--{name}", type=float)
    args = ap.parse_args(argv)
    opts = dict(DEFAULTS[args.vehicle])
    for k in opts:
        v = getattr(args, k, None)
        if v is not None:
            opts[k] = v
    if opts["transects"] < 1 or opts["length"] <= 0 or opts["spacing"] <= 0:
        print("transects, length and spacing must be positive", file=sys.stderr)
        return 2
    doc = survey_plan(args.vehicle, **opts)
    with open(args.out, "w", encoding="utf-8", newline="\n") as f:
        f.write(json.dumps(doc, indent=4, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
