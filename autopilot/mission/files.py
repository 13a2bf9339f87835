"""Mission files: QGC WPL 110 `.waypoints` and QGroundControl `.plan`, read strictly.

* `.waypoints` (the plain-text format of https://mavlink.io/en/file_formats/, written by
  MAVProxy, Mission Planner and QGroundControl): a `QGC WPL 110` header, then one line
  per item, fields separated by tabs (any whitespace accepted):
  `seq current frame command p1 p2 p3 p4 lat lon alt autocontinue`. Line 1 of the items
  (seq 0) is home, as ArduPilot writes it.
* `.plan` (QGroundControl's JSON, docs.qgroundcontrol.com "Plan File Format"):
  `fileType` "Plan", `version` 1, `mission.plannedHomePosition` [lat, lon, alt MSL]
  becomes item 0, `mission.items` are SimpleItems (command, frame, params[7] with null
  for NaN, autoContinue, doJumpId) that become items 1, 2, ... Nulls are read as
  QGroundControl's own loader reads them (MissionItem::load): any param null is NaN
  (a NaN altitude flies at the current altitude, a NaN heading leaves it alone; NaN in
  an unused latitude / longitude goes out as 0 in MISSION_ITEM_INT); a null doJumpId is
  no doJumpId; a null home altitude is 0 m; QGroundControl's display fields (Altitude,
  AltitudeMode, AMSLAltAboveTerrain, cruiseSpeed, hoverSpeed) are not read. Its older
  item form (params[4] + "coordinate" [lat, lon, alt]) is read too. A ComplexItem
  (survey, corridor scan) is flown from the mission items QGroundControl stored in it
  (TransectStyleComplexItem.Items), numbered on from the item before it as QGroundControl
  numbers them; a structure scan (which QGroundControl saves as geometry) from the
  items QGroundControl generates for it (``_structure_scan_items``); one without stored
  items (a landing pattern, a survey saved without them) is refused, named. Its items' doJumpIds are not DO_JUMP targets. A DO_JUMP's param1 in a
  plan names the target's doJumpId; it is mapped to the target's seq on load, and on
  save every item gets doJumpId = seq so the two numberings agree. Geofence and rally
  points are ignored.

`load_mission(path, vehicle="plane" | "quad")` also refuses what that vehicle does not fly
(`autopilot.mission.items.vehicle_problem`), naming the item; without ``vehicle`` any
command some vehicle flies is accepted.

Every defect raises `MissionFileError`, whose text points at the place:
`missions/x.waypoints:7: expected 12 fields, got 9` (line number) or
`missions/x.plan:item 3: ...` (item N = seq N = mission.items[N-1]; item 0 = home).
A missing or unreadable file raises the usual OSError.
"""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from autopilot.mission.items import (
    DO_JUMP,
    FRAME_GLOBAL,
    NAV_WAYPOINT,
    Mission,
    MissionItem,
    item_problem,
    validate_mission,
)

WPL_HEADER = "QGC WPL 110"
WPL_FIELDS = ("seq", "current", "frame", "command", "param1", "param2", "param3", "param4",
              "latitude", "longitude", "altitude", "autocontinue")
_WPL_INT_FIELDS = frozenset({0, 1, 2, 3, 11})

PLAN_FILE_TYPE = "Plan"
PLAN_VERSION = 1
PLAN_MISSION_VERSION = 2

_INT_RE = re.compile(r"[+-]?\d+")
_FLOAT_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?nan", re.IGNORECASE)

PathLike = str | os.PathLike[str]


class MissionFileError(ValueError):
    """A mission file that cannot be used; `where` is a line number or 'item N' or None."""

    def __init__(self, path: PathLike, where: int | str | None, message: str) -> None:
        self.path = os.fspath(path)
        self.where = where
        self.message = message
        super().__init__(str(self))

    def __str__(self) -> str:
        if self.where is None:
            return f"{self.path}: {self.message}"
        return f"{self.path}:{self.where}: {self.message}"


# --- entry points ----------------------------------------------------------------------

def load_mission(path: PathLike, vehicle: str | None = None) -> Mission:
    """Read a `.waypoints` or `.plan` file (by extension, else by content); with
    ``vehicle`` ('plane' / 'quad'), one that vehicle can fly."""
    with open(path, "rb") as f:
        raw = f.read()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise MissionFileError(path, None, f"not UTF-8 text ({exc.reason})") from None
    suffix = os.path.splitext(os.fspath(path))[1].lower()
    if suffix == ".plan":
        return loads_plan(text, path, vehicle)
    if suffix in (".waypoints", ".txt"):
        return loads_waypoints(text, path, vehicle)
    stripped = text.lstrip()
    if stripped.startswith("{"):
        return loads_plan(text, path, vehicle)
    if stripped.startswith("QGC WPL"):
        return loads_waypoints(text, path, vehicle)
    raise MissionFileError(path, None, "unknown mission file format "
                                       "(expected a .waypoints or .plan file)")


def save_waypoints(mission: Mission, path: PathLike) -> None:
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(dumps_waypoints(mission))


def save_plan(mission: Mission, path: PathLike, *,
              vehicle_type: int = mavlink2.MAV_TYPE_FIXED_WING,
              cruise_speed_m_s: float = 22.0, hover_speed_m_s: float = 5.0) -> None:
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(dumps_plan(mission, vehicle_type=vehicle_type,
                           cruise_speed_m_s=cruise_speed_m_s, hover_speed_m_s=hover_speed_m_s))


# --- .waypoints ------------------------------------------------------------------------

def loads_waypoints(text: str, path: PathLike = "<string>", vehicle: str | None = None) -> Mission:
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise MissionFileError(path, 1, f"missing header, expected '{WPL_HEADER}'")
    header = " ".join(lines[0].split())
    if header != WPL_HEADER:
        raise MissionFileError(path, 1, f"bad header '{lines[0].strip()}', expected '{WPL_HEADER}'")

    items: list[MissionItem] = []
    line_of_seq: list[int] = []
    for lineno, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        parts = line.split()
        if len(parts) != len(WPL_FIELDS):
            raise MissionFileError(path, lineno,
                                   f"expected {len(WPL_FIELDS)} fields, got {len(parts)}")
        values: list[int | float] = []
        for index, (name, token) in enumerate(zip(WPL_FIELDS, parts)):
            if index in _WPL_INT_FIELDS:
                if not _INT_RE.fullmatch(token):
                    raise MissionFileError(
                        path, lineno, f"field {index + 1} ({name}): '{token}' is not an integer")
                values.append(int(token))
            else:
                if not _FLOAT_RE.fullmatch(token):
                    raise MissionFileError(
                        path, lineno, f"field {index + 1} ({name}): '{token}' is not a number")
                values.append(float(token))
        (seq, current, frame, command, p1, p2, p3, p4, lat, lon, alt, autocontinue) = values
        if seq != len(items):
            raise MissionFileError(path, lineno, f"expected seq {len(items)}, got {seq}")
        item = MissionItem(seq=seq, frame=frame, command=command, current=current,
                           autocontinue=autocontinue, param1=p1, param2=p2, param3=p3,
                           param4=p4, x_lat_deg=lat, y_lon_deg=lon, z_alt_m=alt)
        problem = item_problem(item, vehicle)
        if problem is not None:
            raise MissionFileError(path, lineno, f"item {seq}: {problem}")
        items.append(item)
        line_of_seq.append(lineno)

    if not items:
        raise MissionFileError(path, None, "empty mission: no items after the header")
    if len(items) == 1:
        raise MissionFileError(path, None, "empty mission: only home (item 0), no mission items")
    problem = validate_mission(items, vehicle)
    if problem is not None:
        raise MissionFileError(path, line_of_seq[problem.seq], f"item {problem.seq}: {problem}")
    return Mission(tuple(items))


def dumps_waypoints(mission: Mission) -> str:
    out = [WPL_HEADER]
    for it in mission:
        fields = (str(it.seq), str(it.current), str(it.frame), str(it.command),
                  *(_fmt(v) for v in it.params), str(it.autocontinue))
        out.append("\t".join(fields))
    return "\n".join(out) + "\n"


def _fmt(value: float) -> str:
    """Shortest text that reads back to the same float; whole numbers without '.0'."""
    text = repr(value)
    return text[:-2] if text.endswith(".0") else text


# --- .plan -----------------------------------------------------------------------------

def loads_plan(text: str, path: PathLike = "<string>", vehicle: str | None = None) -> Mission:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MissionFileError(path, exc.lineno,
                               f"invalid JSON: {exc.msg} (column {exc.colno})") from None
    if not isinstance(doc, dict):
        raise MissionFileError(path, None, "not a plan: the top level is not a JSON object")
    if doc.get("fileType") != PLAN_FILE_TYPE:
        raise MissionFileError(path, None,
                               f"wrong fileType {doc.get('fileType')!r}, expected 'Plan'")
    if doc.get("version") != PLAN_VERSION or isinstance(doc.get("version"), bool):
        raise MissionFileError(path, None, f"unsupported plan version {doc.get('version')!r}, "
                                           f"expected {PLAN_VERSION}")
    mission = doc.get("mission")
    if not isinstance(mission, dict):
        raise MissionFileError(path, None, "no 'mission' object")

    home_pos = mission.get("plannedHomePosition")
    if not (isinstance(home_pos, list) and len(home_pos) == 3 and all(map(_is_number, home_pos[:2]))
            and (home_pos[2] is None or _is_number(home_pos[2]))):
        raise MissionFileError(path, "item 0",
                               "plannedHomePosition must be [lat, lon, alt] numbers")
    # a null home altitude (QGroundControl saves one when it had no terrain height for
    # the planned home) is read as sea level: the vehicle sets home at arming anyway
    home_alt = 0.0 if home_pos[2] is None else home_pos[2]
    home = MissionItem(seq=0, frame=FRAME_GLOBAL, command=NAV_WAYPOINT, current=1,
                       autocontinue=1, param1=0.0, param2=0.0, param3=0.0, param4=0.0,
                       x_lat_deg=home_pos[0], y_lon_deg=home_pos[1], z_alt_m=home_alt)
    problem = item_problem(home)
    if problem is not None:
        raise MissionFileError(path, "item 0", f"plannedHomePosition: {problem}")

    raw_items = mission.get("items")
    if not isinstance(raw_items, list):
        raise MissionFileError(path, None, "mission.items is missing or not a list")
    if not raw_items:
        raise MissionFileError(path, None, "empty mission: mission.items is empty")

    items = [home]
    place = {0: "item 0"}     # where each item is in the file (an item of a ComplexItem named so)
    seq_of_jump_id: dict[int, int] = {}
    for index, raw in enumerate(raw_items, start=1):
        seq = len(items)
        where = f"item {seq}"
        if isinstance(raw, dict) and raw.get("type") == "ComplexItem":
            for k, inner in enumerate(_complex_items(raw, index, path, where)):
                at = f"item {seq + k} ({raw.get('complexItemType')} at mission.items[{index - 1}], " \
                     f"its item {k + 1})"
                item, _ = _plan_item(inner, seq + k, path, at)
                items.append(item)
                place[item.seq] = at
            continue
        place[seq] = where
        item, jump_id = _plan_item(raw, seq, path, where)
        if jump_id is not None:
            if jump_id in seq_of_jump_id:
                raise MissionFileError(path, where, f"doJumpId {jump_id} used twice "
                                                    f"(also item {seq_of_jump_id[jump_id]})")
            seq_of_jump_id[jump_id] = seq
        items.append(item)

    # DO_JUMP param1 names a doJumpId; the mission wants the target's seq.
    for item in items[1:]:
        if item.command != DO_JUMP:
            continue
        where = f"item {item.seq}"
        target = item.param1
        if not (math.isfinite(target) and target == int(target)):
            raise MissionFileError(path, where,
                                   f"DO_JUMP target doJumpId {target} is not an integer")
        if int(target) not in seq_of_jump_id:
            raise MissionFileError(path, where, f"DO_JUMP to missing doJumpId {int(target)}")
        items[item.seq] = item.replace(param1=float(seq_of_jump_id[int(target)]))

    for item in items:
        problem = item_problem(item, vehicle)
        if problem is not None:
            raise MissionFileError(path, place[item.seq], str(problem))
    problem = validate_mission(items, vehicle)
    if problem is not None:
        raise MissionFileError(path, place.get(problem.seq, f"item {problem.seq}"), str(problem))
    return Mission(tuple(items))


# QGroundControl's ComplexItems and where each keeps the mission items it generated.
# A transect-style item (survey, corridor scan) saves them in TransectStyleComplexItem.Items
# (TransectStyleComplexItem::_save) and QGroundControl flies those as saved; a structure
# scan saves only its geometry and QGroundControl generates its items on load: so do we
# (``_structure_scan_items``); the landing patterns are refused here, named.
TRANSECT_COMPLEX_TYPES = ("survey", "CorridorScan")   # (a structure scan is generated)
COMPLEX_ITEM_NAMES = {"survey": "survey", "CorridorScan": "corridor scan",
                      "StructureScan": "structure scan", "fwLandingPattern": "fixed-wing landing pattern",
                      "vtolLandingPattern": "VTOL landing pattern"}


def _complex_items(raw: dict, index: int, path: PathLike, where: str) -> list:
    """The mission items a ComplexItem stores (mission.items[index - 1]), or a
    MissionFileError naming it."""
    ctype = raw.get("complexItemType")
    name = COMPLEX_ITEM_NAMES.get(ctype, repr(ctype))
    if ctype in TRANSECT_COMPLEX_TYPES:
        inner = raw.get("TransectStyleComplexItem")
        stored = inner.get("Items") if isinstance(inner, dict) else None
        if isinstance(stored, list) and stored:
            return stored
        raise MissionFileError(path, where, f"ComplexItem {name} (mission.items[{index - 1}]) has no "
                                            "stored mission items (TransectStyleComplexItem.Items): "
                                            "open and save the plan again with QGroundControl")
    if ctype == "StructureScan":
        return _structure_scan_items(raw, index, path, where)
    if ctype in COMPLEX_ITEM_NAMES:
        raise MissionFileError(path, where, f"ComplexItem {name} (mission.items[{index - 1}]) has no "
                                            "stored mission items: QGroundControl saves only its "
                                            "geometry; upload it from QGroundControl instead")
    raise MissionFileError(path, where, f"unknown ComplexItem type {ctype!r} "
                                        f"(mission.items[{index - 1}])")


def _structure_scan_items(raw: dict, index: int, path: PathLike, where: str) -> list:
    """A structure scan's mission items, generated from what QGroundControl saves of it
    as QGroundControl generates them when it loads one (StructureScanComplexItem:
    appendMissionItems, version 3): the flight polygon is the structure's ``polygon``
    moved out by ``CameraCalc.DistanceToSurface`` (each edge moved out, the new vertices
    where consecutive moved edges meet, QGCMapPolygon::offset); then a waypoint at its
    first vertex at ``EntranceAltitude``, DO_SET_ROI_WPNEXT_OFFSET (pitch
    ``GimbalPitch``, yaw offset 90: the camera looks at the structure), ``Layers``
    layers ``CameraCalc.AdjustedFootprintFrontal`` apart from half a layer above
    ``ScanBottomAlt`` up (or half a layer below ``StructureHeight`` down, with
    ``StartFromTop``), each a waypoint at every vertex and back at the first, camera
    triggering by ``AdjustedFootprintSide`` from its first waypoint to its end, then
    DO_SET_ROI_NONE and the exit waypoint at the entrance; altitudes above home."""
    def bad(what: str) -> MissionFileError:
        return MissionFileError(path, where, f"ComplexItem structure scan (mission.items[{index - 1}]): {what}")

    if raw.get("version") != 3:
        raise bad(f"version {raw.get('version')!r} not supported (QGroundControl writes 3)")
    cam = raw.get("CameraCalc")
    poly = raw.get("polygon")
    if not isinstance(cam, dict) or not isinstance(poly, list) or len(poly) < 3:
        raise bad("needs 'CameraCalc' and a 'polygon' of at least 3 [lat, lon] vertices")
    try:
        pts = [(float(a), float(b)) for a, b in poly]
        dist = float(cam["DistanceToSurface"])
        layer_h = float(cam["AdjustedFootprintFrontal"])
        trigger = float(cam["AdjustedFootprintSide"])
        layers = int(raw["Layers"])
        entrance = float(raw["EntranceAltitude"])
        bottom = float(raw["ScanBottomAlt"])
        top = float(raw["StructureHeight"])
        pitch = float(raw.get("GimbalPitch", 0.0))
        from_top = bool(raw.get("StartFromTop", False))
    except (KeyError, TypeError, ValueError) as exc:
        raise bad(f"missing or bad value ({exc})") from None
    if layers < 1 or layer_h <= 0:
        raise bad("needs Layers >= 1 and CameraCalc.AdjustedFootprintFrontal > 0")
    # the flight polygon, in a flat frame at the first vertex (metres north, east)
    lat0 = math.radians(pts[0][0])
    k_n, k_e = 6371000.0 * math.pi / 180.0, 6371000.0 * math.pi / 180.0 * math.cos(lat0)
    ne = [((la - pts[0][0]) * k_n, (lo - pts[0][1]) * k_e) for la, lo in pts]
    area = sum(a[1] * b[0] - b[1] * a[0] for a, b in zip(ne, ne[1:] + ne[:1]))  # <0: clockwise
    side = 1.0 if area > 0 else -1.0
    moved = []
    for a, b in zip(ne, ne[1:] + ne[:1]):
        ln = math.hypot(b[0] - a[0], b[1] - a[1]) or 1.0
        # outward normal of a clockwise polygon seen from above: to the left of a->b
        nx, ny = side * -(b[1] - a[1]) / ln, side * (b[0] - a[0]) / ln
        moved.append(((a[0] + nx * dist, a[1] + ny * dist), (b[0] + nx * dist, b[1] + ny * dist)))
    flight = []
    for (p1, p2), (q1, q2) in zip(moved[-1:] + moved[:-1], moved):
        d1 = (p2[0] - p1[0], p2[1] - p1[1])
        d2 = (q2[0] - q1[0], q2[1] - q1[1])
        den = d1[0] * d2[1] - d1[1] * d2[0]
        if abs(den) < 1e-9:
            flight.append(q1)
            continue
        t = ((q1[0] - p1[0]) * d2[1] - (q1[1] - p1[1]) * d2[0]) / den
        flight.append((p1[0] + t * d1[0], p1[1] + t * d1[1]))
    geo = [(round(pts[0][0] + n / k_n, 7), round(pts[0][1] + e / k_e, 7)) for n, e in flight]

    def wp(lat, lon, alt):
        return {"type": "SimpleItem", "command": NAV_WAYPOINT, "frame": 3, "autoContinue": True,
                "params": [0, 0, 0, None, lat, lon, alt]}

    def do(cmd, params):
        return {"type": "SimpleItem", "command": cmd, "frame": 2, "autoContinue": True,
                "params": params}

    items = [wp(*geo[0], entrance),
             do(mavlink2.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, [0, 0, 0, 0, pitch, 0, 90])]
    alt = (top - 0.5 * layer_h) if from_top else (bottom + 0.5 * layer_h)
    for _ in range(layers):
        for k, (la, lo) in enumerate(geo + geo[:1]):
            items.append(wp(la, lo, alt))
            if k == 0:
                items.append(do(mavlink2.MAV_CMD_DO_SET_CAM_TRIGG_DIST, [trigger, 0, 1, 0, 0, 0, 0]))
        items.append(do(mavlink2.MAV_CMD_DO_SET_CAM_TRIGG_DIST, [0, 0, 0, 0, 0, 0, 0]))
        alt += -layer_h if from_top else layer_h
    items.append(do(mavlink2.MAV_CMD_DO_SET_ROI_NONE, [0, 0, 0, 0, 0, 0, 0]))
    items.append(wp(*geo[0], entrance))
    return items


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _plan_item(raw: Any, seq: int, path: PathLike, where: str) -> tuple[MissionItem, int | None]:
    if not isinstance(raw, dict):
        raise MissionFileError(path, where, "item is not a JSON object")
    kind = raw.get("type")
    if kind != "SimpleItem":
        raise MissionFileError(path, where, f"unknown item type {kind!r}, expected 'SimpleItem'")
    for key in ("command", "frame"):
        if not isinstance(raw.get(key), int) or isinstance(raw.get(key), bool):
            raise MissionFileError(path, where, f"'{key}' must be an integer, got {raw.get(key)!r}")
    params = raw.get("params")
    coordinate = raw.get("coordinate")
    if isinstance(params, list) and len(params) == 4 and coordinate is not None:
        # QGroundControl's older item format: param5..7 in "coordinate" [lat, lon, alt]
        if not (isinstance(coordinate, list) and len(coordinate) == 3):
            raise MissionFileError(path, where, "'coordinate' must be [lat, lon, alt]")
        params = params + coordinate
    if not isinstance(params, list) or len(params) != 7:
        count = len(params) if isinstance(params, list) else "none"
        raise MissionFileError(path, where, f"expected 7 params, got {count}")
    values: list[float] = []
    for index, value in enumerate(params, start=1):
        if value is None:
            values.append(math.nan)  # QGC writes NaN ("default") as null
        elif _is_number(value):
            values.append(float(value))
        else:
            raise MissionFileError(path, where, f"param{index}: {value!r} is not a number or null")
    auto = raw.get("autoContinue", True)
    if not isinstance(auto, bool):
        raise MissionFileError(path, where, f"'autoContinue' must be true or false, got {auto!r}")
    jump_id = raw.get("doJumpId")
    if jump_id is not None and (not isinstance(jump_id, int) or isinstance(jump_id, bool)):
        raise MissionFileError(path, where, f"'doJumpId' must be an integer, got {jump_id!r}")
    item = MissionItem(seq=seq, frame=raw["frame"], command=raw["command"], current=0,
                       autocontinue=int(auto), param1=values[0], param2=values[1],
                       param3=values[2], param4=values[3], x_lat_deg=values[4],
                       y_lon_deg=values[5], z_alt_m=values[6])
    return item, jump_id


def dumps_plan(mission: Mission, *, vehicle_type: int = mavlink2.MAV_TYPE_FIXED_WING,
               cruise_speed_m_s: float = 22.0, hover_speed_m_s: float = 5.0) -> str:
    home = mission.home
    items = []
    for it in mission.items[1:]:
        items.append({
            "autoContinue": bool(it.autocontinue),
            "command": it.command,
            "doJumpId": it.seq,  # so a DO_JUMP's param1 (a seq) is also the target's doJumpId
            "frame": it.frame,
            "params": [_json_number(v) for v in it.params],
            "type": "SimpleItem",
        })
    doc = {
        "fileType": PLAN_FILE_TYPE,
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "groundStation": "pysitl",
        "mission": {
            "cruiseSpeed": _json_number(cruise_speed_m_s),
            "firmwareType": mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
            "hoverSpeed": _json_number(hover_speed_m_s),
            "items": items,
            "plannedHomePosition": [home.x_lat_deg, home.y_lon_deg, _json_number(home.z_alt_m)],
            "vehicleType": vehicle_type,
            "version": PLAN_MISSION_VERSION,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": PLAN_VERSION,
    }
    return json.dumps(doc, indent=4, sort_keys=True, allow_nan=False) + "\n"


def _json_number(value: float) -> int | float | None:
    if math.isnan(value):
        return None
    if value.is_integer() and abs(value) < 2**53:
        return int(value)
    return value
