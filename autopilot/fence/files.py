"""Fence and rally files: what ``sitl run --fence / --rally`` and a ``.plan`` carry.

Fence files (MAVProxy's ``fence load`` reads both):

* ``QGC WPL 110``: one item per line (``seq current frame command p1 p2 p3 p4 lat lon
  alt autocontinue``, tab or space separated), the fence items of
  MAV_MISSION_TYPE_FENCE themselves (no home line): what MAVProxy's ``fence save``
  writes;
* the legacy list of ``LAT LON`` lines (``#`` comments): the first is the return point,
  the last closes the polygon (repeats the first vertex), those between are one
  inclusion polygon. So at least 5 lines.

Rally files (MAVProxy's ``rally load``): ``QGC WPL 110`` lines of
MAV_CMD_NAV_RALLY_POINT, or legacy ``RALLY LAT LON ALT BREAK_ALT LAND_DIR FLAGS`` lines
(altitude in metres above home).

``.plan`` (QGroundControl): ``geoFence`` with ``polygons`` (``polygon``: [[lat, lon],
...], ``inclusion``), ``circles`` (``circle``: {``center``: [lat, lon], ``radius``},
``inclusion``) and ``breachReturn`` ([lat, lon, alt], when given); ``rallyPoints`` with
``points`` ([lat, lon, alt above home] each).

Every reader returns the MissionItems (mission_type FENCE / RALLY) after the same check
as an upload (``fence_items_problem`` / ``rally_items_problem``), or raises
``MissionFileError`` naming the line or item.
"""
from __future__ import annotations

import json
import math
import re

from ..mission.files import MissionFileError, PathLike
from ..mission.items import FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT, MissionItem
from .geofence import (CIRCLE_EXCL, CIRCLE_INCL, FENCE_RETURN, MISSION_TYPE_FENCE, MISSION_TYPE_RALLY,
                       POLY_EXCL, POLY_INCL, RALLY_POINT, fence_items_problem, rally_items_problem)

_LATLON = re.compile(r"^\s*[-+0-9.]+\s+[-+0-9.]+\s*$")


def _read(path: PathLike) -> str:
    try:
        with open(path, encoding="utf-8-sig") as f:
            return f.read()
    except UnicodeDecodeError as exc:
        raise MissionFileError(path, None, f"not UTF-8 text ({exc.reason})") from None


def _item(seq, frame, command, p1, lat, lon, alt, mtype, p2=0.0, p3=0.0, p4=0.0) -> MissionItem:
    return MissionItem(seq, frame, command, 0, 1, p1, p2, p3, p4, lat, lon, alt, mtype)


def _wpl(text: str, path: PathLike, mtype: int) -> tuple[MissionItem, ...]:
    items = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith(("#", "QGC WPL")):
            continue
        f = line.split()
        if len(f) != 12:
            raise MissionFileError(path, lineno, f"expected 12 fields, got {len(f)}")
        try:
            ints = [int(f[k]) for k in (0, 1, 2, 3, 11)]
            vals = [float(x) for x in f[4:11]]
        except ValueError:
            raise MissionFileError(path, lineno, "not a number") from None
        items.append(MissionItem(len(items), ints[2], ints[3], 0, ints[4], *vals, mission_type=mtype))
    return tuple(items)


def _checked(items, path, fence: bool) -> tuple[MissionItem, ...]:
    problem = fence_items_problem(items) if fence else rally_items_problem(items)
    if problem is not None:
        raise MissionFileError(path, f"item {problem.seq}", f"{problem.text} ({problem.code})")
    return tuple(items)


def loads_fence(text: str, path: PathLike = "<string>") -> tuple[MissionItem, ...]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise MissionFileError(path, None, "empty fence file")
    if lines[0].strip().startswith("QGC WPL"):
        if lines[0].split()[-1] != "110":
            raise MissionFileError(path, 1, f"unsupported format {lines[0].strip()!r} (QGC WPL 110)")
        return _checked(_wpl(text, path, MISSION_TYPE_FENCE), path, True)
    pts = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if not _LATLON.match(line):
            raise MissionFileError(path, lineno, "expected 'LAT LON' (or a QGC WPL 110 file)")
        try:
            pts.append(tuple(float(x) for x in line.split()))
        except ValueError:
            raise MissionFileError(path, lineno, "not a number") from None
    if len(pts) < 5:
        raise MissionFileError(path, None, f"{len(pts)} points: a return point, at least 3 "
                                           "vertices and the closing point are needed")
    verts = pts[1:-1]
    items = [_item(0, FRAME_GLOBAL, FENCE_RETURN, 0.0, pts[0][0], pts[0][1], 0.0, MISSION_TYPE_FENCE)]
    items += [_item(k + 1, FRAME_GLOBAL, POLY_INCL, float(len(verts)), la, lo, 0.0, MISSION_TYPE_FENCE)
              for k, (la, lo) in enumerate(verts)]
    return _checked(items, path, True)


def loads_rally(text: str, path: PathLike = "<string>") -> tuple[MissionItem, ...]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise MissionFileError(path, None, "empty rally file")
    if lines[0].strip().startswith("QGC WPL"):
        return _checked(_wpl(text, path, MISSION_TYPE_RALLY), path, False)
    items = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        f = line.split()
        if len(f) != 7 or f[0].upper() != "RALLY":
            raise MissionFileError(path, lineno, "expected 'RALLY LAT LON ALT BREAK_ALT LAND_DIR FLAGS' "
                                                 "(or a QGC WPL 110 file)")
        try:
            lat, lon, alt = float(f[1]), float(f[2]), float(f[3])
            flags = int(f[6])
        except ValueError:
            raise MissionFileError(path, lineno, "not a number") from None
        items.append(_item(len(items), FRAME_GLOBAL_RELATIVE_ALT, RALLY_POINT, float(flags), lat, lon, alt,
                           MISSION_TYPE_RALLY))
    return _checked(items, path, False)


def load_fence(path: PathLike) -> tuple[MissionItem, ...]:
    return loads_fence(_read(path), path)


def load_rally(path: PathLike) -> tuple[MissionItem, ...]:
    return loads_rally(_read(path), path)


def _num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _latlon(v, path, where) -> tuple[float, float]:
    if not (isinstance(v, list) and len(v) >= 2 and _num(v[0]) and _num(v[1])):
        raise MissionFileError(path, where, "expected [latitude, longitude]")
    return float(v[0]), float(v[1])


def loads_plan_fence(text: str, path: PathLike = "<string>") -> tuple[tuple, tuple]:
    """The ``geoFence`` and ``rallyPoints`` of a .plan as (fence items, rally items);
    sections absent: empty. The mission part is ``autopilot.mission.files``'."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MissionFileError(path, exc.lineno, f"invalid JSON: {exc.msg}") from None
    if not isinstance(doc, dict):
        return (), ()
    fence: list[MissionItem] = []
    gf = doc.get("geoFence") or {}
    if not isinstance(gf, dict):
        raise MissionFileError(path, "geoFence", "not an object")
    polys = gf.get("polygons") or []
    circles = gf.get("circles") or []
    if not isinstance(polys, list) or not isinstance(circles, list):
        raise MissionFileError(path, "geoFence", "polygons / circles must be lists")
    for k, poly in enumerate(polys):
        where = f"geoFence polygon {k}"
        if not isinstance(poly, dict) or not isinstance(poly.get("polygon"), list):
            raise MissionFileError(path, where, "expected {'polygon': [[lat, lon], ...], 'inclusion': ...}")
        verts = [_latlon(v, path, where) for v in poly["polygon"]]
        if len(verts) < 3:
            raise MissionFileError(path, where, f"{len(verts)} vertices: a polygon needs at least 3")
        cmd = POLY_INCL if poly.get("inclusion", True) else POLY_EXCL
        fence += [_item(len(fence), FRAME_GLOBAL, cmd, float(len(verts)), la, lo, 0.0, MISSION_TYPE_FENCE)
                  for la, lo in verts]
        # (seq fixed below)
    for k, c in enumerate(circles):
        where = f"geoFence circle {k}"
        circ = c.get("circle") if isinstance(c, dict) else None
        if not isinstance(circ, dict) or not _num(circ.get("radius")):
            raise MissionFileError(path, where, "expected {'circle': {'center': [lat, lon], 'radius': m}}")
        la, lo = _latlon(circ.get("center"), path, where)
        cmd = CIRCLE_INCL if c.get("inclusion", True) else CIRCLE_EXCL
        fence.append(_item(0, FRAME_GLOBAL, cmd, float(circ["radius"]), la, lo, 0.0, MISSION_TYPE_FENCE))
    br = gf.get("breachReturn")
    if isinstance(br, list) and len(br) >= 2 and _num(br[0]) and _num(br[1]) and (br[0], br[1]) != (0, 0):
        alt = float(br[2]) if len(br) > 2 and _num(br[2]) else 0.0
        fence.append(_item(0, FRAME_GLOBAL_RELATIVE_ALT, FENCE_RETURN, 0.0, float(br[0]), float(br[1]), alt,
                           MISSION_TYPE_FENCE))
    fence = [it.replace(seq=k) for k, it in enumerate(fence)]
    rally: list[MissionItem] = []
    rp = doc.get("rallyPoints") or {}
    pts = rp.get("points") if isinstance(rp, dict) else None
    for k, p in enumerate(pts or []):
        if not (isinstance(p, list) and len(p) >= 3 and all(_num(x) for x in p[:3])):
            raise MissionFileError(path, f"rallyPoints point {k}", "expected [lat, lon, alt]")
        rally.append(_item(k, FRAME_GLOBAL_RELATIVE_ALT, RALLY_POINT, 0.0, float(p[0]), float(p[1]),
                           float(p[2]), MISSION_TYPE_RALLY))
    return _checked(fence, path, True), _checked(rally, path, False)


def load_plan_fence(path: PathLike) -> tuple[tuple, tuple]:
    return loads_plan_fence(_read(path), path)
