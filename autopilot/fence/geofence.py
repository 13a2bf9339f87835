"""The geofence and the rally points of one vehicle: zones, checks, breaches.

Zones (MAV_MISSION_TYPE_FENCE items, mavlink.io "Mission Protocol: fence"):

* MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION (5001 / 5002): one item per
  vertex, param1 = the polygon's vertex count (at least 3), the vertices consecutive;
* MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION / _EXCLUSION (5003 / 5004): param1 = radius [m];
* MAV_CMD_NAV_FENCE_RETURN_POINT (5000): where FENCE_ACTION 6 (guided) flies; at most one.

Rally points (MAV_MISSION_TYPE_RALLY): MAV_CMD_NAV_RALLY_POINT (5100), a position each.

Semantics as ArduPilot's AC_Fence (its parameter names and numbering, its documented
behaviour; the code is ours): the vehicle must stay inside every inclusion zone and
outside every exclusion zone (FENCE_TYPE bit 4, "polygon", covers all uploaded zones,
circles included), within FENCE_RADIUS of home (bit 2, "circle"), below FENCE_ALT_MAX
(bit 1) and above FENCE_ALT_MIN (bit 8) above home. FENCE_ENABLE turns the whole fence
on. The floor (minimum altitude) counts only once the vehicle has flown above it since
arming, and not while it lands, as ArduPilot's floor that arms itself after takeoff.

Geometry: every zone is projected once, when the fence is loaded, onto an
equirectangular plane at the fence's first point (north = dlat R, east = dlon R cos
lat0, R = 6378137 m): zones are at most tens of km across, where this is good to a few
centimetres per km, far below the navigation error. The check is a signed distance
per fence type, positive outside: for a polygon the distance to its nearest edge with
the crossing-number test for the sign, for a circle |p - c| - r.

Breach: checked every step on the navigation solution (never on truth). A breach
starts when any enabled fence type's distance turns positive; it is recorded once, its
action (FENCE_ACTION) taken by the vehicle, and it clears when the vehicle is back
inside every enabled fence by FENCE_MARGIN (a hysteresis, so a vehicle flying along
the boundary is not announced at every step). Pre-arm and an uploaded mission are held
to the same fence with FENCE_MARGIN to spare.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from ..mission.items import (ABSOLUTE_ALT_FRAMES, ALT_MAX_M, ALT_MIN_M, GLOBAL_FRAMES, MissionItem,
                             Problem)
from ..params import Param

FENCE_RETURN = mavlink2.MAV_CMD_NAV_FENCE_RETURN_POINT            # 5000
POLY_INCL = mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION   # 5001
POLY_EXCL = mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION   # 5002
CIRCLE_INCL = mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION         # 5003
CIRCLE_EXCL = mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION         # 5004
RALLY_POINT = mavlink2.MAV_CMD_NAV_RALLY_POINT                    # 5100
FENCE_COMMANDS = frozenset({FENCE_RETURN, POLY_INCL, POLY_EXCL, CIRCLE_INCL, CIRCLE_EXCL})
MISSION_TYPE_FENCE = mavlink2.MAV_MISSION_TYPE_FENCE              # 1
MISSION_TYPE_RALLY = mavlink2.MAV_MISSION_TYPE_RALLY              # 2

# FENCE_TYPE bits (ArduPilot AC_Fence numbering)
TYPE_ALT_MAX, TYPE_CIRCLE, TYPE_POLYGON, TYPE_ALT_MIN = 1, 2, 4, 8
BREACH_TYPE_NAMES = {TYPE_ALT_MAX: "max_alt", TYPE_CIRCLE: "circle", TYPE_POLYGON: "polygon",
                     TYPE_ALT_MIN: "min_alt"}
# FENCE_STATUS breach_type (MAVLink FENCE_BREACH)
_STATUS_TYPE = {TYPE_ALT_MIN: mavlink2.FENCE_BREACH_MINALT, TYPE_ALT_MAX: mavlink2.FENCE_BREACH_MAXALT,
                TYPE_CIRCLE: mavlink2.FENCE_BREACH_BOUNDARY, TYPE_POLYGON: mavlink2.FENCE_BREACH_BOUNDARY}
# FENCE_ACTION values (ArduPilot's): 0 report only, 1 RTL, 2 land (ArduCopter's "always
# land"), 6 guided to the return point (ArduPlane's "Guided"); per vehicle what it flies
ACTION_NAMES = {0: "report", 1: "RTL", 2: "LAND", 6: "GUIDED"}
VEHICLE_ACTIONS = {"plane": frozenset({0, 1, 6}), "quad": frozenset({0, 1, 2, 6})}

FENCE_PARAMS = (
    Param("FENCE_ENABLE", 0, 0, 1, "", "geofence on (1) or off (0)", is_int=True),
    Param("FENCE_TYPE", 7, 0, 15, "", "fences checked, a bitmask: 1 maximum altitude, 2 circle of "
          "FENCE_RADIUS around home, 4 the uploaded polygons and circles, 8 minimum altitude",
          is_int=True),
    Param("FENCE_ACTION", 1, 0, 6, "", "on a breach: 0 report only, 1 RTL, 2 land (quadrotor), "
          "6 guided to the fence return point", is_int=True),
    Param("FENCE_ALT_MAX", 100.0, 10.0, 1000.0, "m", "maximum altitude above home"),
    Param("FENCE_ALT_MIN", -10.0, -100.0, 100.0, "m", "minimum altitude above home (checked once flown above it)"),
    Param("FENCE_RADIUS", 300.0, 30.0, 10000.0, "m", "radius of the circular fence around home"),
    Param("FENCE_MARGIN", 2.0, 1.0, 10.0, "m", "a breach clears this far back inside; pre-arm and "
          "mission waypoints keep this far inside"),
)


def rally_params(kind: str) -> tuple[Param, ...]:
    """RALLY_LIMIT_KM's default is ArduPlane's 5 km for the plane, ArduCopter's 0.3 km for
    the quadrotor."""
    return (
        Param("RALLY_LIMIT_KM", 5.0 if kind == "plane" else 0.3, 0.0, 100.0, "km",
              "a rally point farther than this from the vehicle is not used when home is nearer "
              "(0: no limit); the quadrotor's default is ArduCopter's 0.3 km"),
        Param("RALLY_INCL_HOME", 1, 0, 1, "", "home counts as a rally point: RTL goes to whichever "
              "is nearest (0: the nearest rally point even when home is nearer)", is_int=True),
    )


RALLY_PARAMS = rally_params("plane")
EARTH_R_M = 6378137.0


def _bad(seq: int, code: str, text: str) -> Problem:
    return Problem(seq, f"MAV_MISSION_{code}", text)


def _position_problem(it: MissionItem, what: str) -> Problem | None:
    if it.frame not in GLOBAL_FRAMES:
        return _bad(it.seq, "UNSUPPORTED_FRAME", f"{what}: frame {it.frame} is not a global frame")
    if not (math.isfinite(it.x_lat_deg) and -90.0 <= it.x_lat_deg <= 90.0):
        return _bad(it.seq, "INVALID_PARAM5_X", f"{what}: latitude {it.x_lat_deg} out of range")
    if not (math.isfinite(it.y_lon_deg) and -180.0 <= it.y_lon_deg <= 180.0):
        return _bad(it.seq, "INVALID_PARAM6_Y", f"{what}: longitude {it.y_lon_deg} out of range")
    return None


def fence_item_problem(it: MissionItem) -> Problem | None:
    """One fence item on its own (the upload checks each as it arrives)."""
    if it.command not in FENCE_COMMANDS:
        return _bad(it.seq, "UNSUPPORTED", f"command {it.command} is not a fence item")
    what = f"fence item {it.seq}"
    p = _position_problem(it, what)
    if p is not None:
        return p
    if it.command in (POLY_INCL, POLY_EXCL):
        if not (math.isfinite(it.param1) and it.param1 == int(it.param1) and it.param1 >= 3):
            return _bad(it.seq, "INVALID_PARAM1", f"{what}: a polygon needs at least 3 vertices "
                                                  f"(vertex count {it.param1:g})")
    elif it.command in (CIRCLE_INCL, CIRCLE_EXCL):
        if not (math.isfinite(it.param1) and it.param1 > 0.0):
            return _bad(it.seq, "INVALID_PARAM1", f"{what}: circle radius {it.param1:g} m")
    elif not (math.isfinite(it.z_alt_m) and ALT_MIN_M < it.z_alt_m < ALT_MAX_M):
        return _bad(it.seq, "INVALID_PARAM7", f"{what}: return point altitude {it.z_alt_m}")
    return None


def fence_items_problem(items) -> Problem | None:
    """The whole fence: each item, the polygons' vertex runs (each polygon's items
    consecutive, as many as each declares), at most one return point."""
    items = tuple(items)
    returns = 0
    i = 0
    while i < len(items):
        it = items[i]
        p = fence_item_problem(it)
        if p is not None:
            return p
        if it.command in (POLY_INCL, POLY_EXCL):
            n = int(it.param1)
            run = items[i:i + n]
            if len(run) < n or any(r.command != it.command or r.param1 != it.param1 for r in run):
                got = 0
                while got < len(run) and run[got].command == it.command and run[got].param1 == it.param1:
                    got += 1
                return _bad(it.seq, "INVALID_PARAM1", f"polygon at fence item {it.seq}: "
                                                      f"{n} vertices declared, {got} given")
            for r in run[1:]:
                p = fence_item_problem(r)
                if p is not None:
                    return p
            i += n
            continue
        if it.command == FENCE_RETURN:
            returns += 1
            if returns > 1:
                return _bad(it.seq, "INVALID", f"fence item {it.seq}: a second return point")
        i += 1
    return None


def rally_items_problem(items) -> Problem | None:
    for it in items:
        if it.command != RALLY_POINT:
            return _bad(it.seq, "UNSUPPORTED", f"command {it.command} is not a rally point")
        p = _position_problem(it, f"rally point {it.seq}")
        if p is not None:
            return p
        if not (math.isfinite(it.z_alt_m) and ALT_MIN_M < it.z_alt_m < ALT_MAX_M):
            return _bad(it.seq, "INVALID_PARAM7", f"rally point {it.seq}: altitude {it.z_alt_m}")
    return None


# ------------------------------------------------------------------- geometry --
class Plane2:
    """The equirectangular projection at (lat0, lon0) [deg]: (north, east) metres."""

    __slots__ = ("lat0", "lon0", "k_e")

    def __init__(self, lat0_deg: float, lon0_deg: float):
        self.lat0, self.lon0 = lat0_deg, lon0_deg
        self.k_e = math.radians(1.0) * EARTH_R_M * math.cos(math.radians(lat0_deg))

    def ne(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        dlon = (lon_deg - self.lon0 + 180.0) % 360.0 - 180.0
        return (math.radians(lat_deg - self.lat0) * EARTH_R_M, dlon * self.k_e)


def _seg_dist(p, a, b) -> float:
    ax, ay = b[0] - a[0], b[1] - a[1]
    px, py = p[0] - a[0], p[1] - a[1]
    L2 = ax * ax + ay * ay
    t = 0.0 if L2 <= 0.0 else max(0.0, min(1.0, (px * ax + py * ay) / L2))
    return math.hypot(px - t * ax, py - t * ay)


def _inside(p, poly) -> bool:
    """Crossing-number test."""
    x, y = p
    inside = False
    n = len(poly)
    for k in range(n):
        (x1, y1), (x2, y2) = poly[k], poly[(k + 1) % n]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


@dataclass(frozen=True)
class Zone:
    inclusion: bool
    polygon: tuple = ()               # vertices (north, east) [m] on the fence's plane
    center: tuple = (0.0, 0.0)        # circle centre (north, east) [m]
    radius_m: float = 0.0             # > 0: a circle

    def outside_m(self, p) -> float:
        """Signed distance out of the allowed region [m] (> 0: a breach of this zone)."""
        if self.radius_m > 0.0:
            d = math.hypot(p[0] - self.center[0], p[1] - self.center[1]) - self.radius_m
        else:
            poly = self.polygon
            d = min(_seg_dist(p, poly[k], poly[(k + 1) % len(poly)]) for k in range(len(poly)))
            if _inside(p, poly):
                d = -d
        return d if self.inclusion else -d


class FenceSet:
    """The uploaded zones (and return point), projected once. Items must have passed
    `fence_items_problem`."""

    def __init__(self, items=()):
        self.items = tuple(items)
        self.zones: list[Zone] = []
        self.return_point: MissionItem | None = None
        self.plane: Plane2 | None = None
        if self.items:
            self.plane = Plane2(self.items[0].x_lat_deg, self.items[0].y_lon_deg)
        i = 0
        while i < len(self.items):
            it = self.items[i]
            c = it.command
            if c in (POLY_INCL, POLY_EXCL):
                n = int(it.param1)
                verts = tuple(self.plane.ne(v.x_lat_deg, v.y_lon_deg) for v in self.items[i:i + n])
                self.zones.append(Zone(c == POLY_INCL, polygon=verts))
                i += n
                continue
            if c in (CIRCLE_INCL, CIRCLE_EXCL):
                self.zones.append(Zone(c == CIRCLE_INCL, center=self.plane.ne(it.x_lat_deg, it.y_lon_deg),
                                       radius_m=float(it.param1)))
            elif c == FENCE_RETURN:
                self.return_point = it
            i += 1

    @property
    def has_inclusion(self) -> bool:
        return any(z.inclusion for z in self.zones)

    def outside_m(self, lat_deg: float, lon_deg: float) -> float | None:
        """The largest signed distance out of any zone [m], None without zones."""
        if not self.zones:
            return None
        p = self.plane.ne(lat_deg, lon_deg)
        return max(z.outside_m(p) for z in self.zones)


class RallySet:
    def __init__(self, items=()):
        self.items = tuple(items)


def _alt_msl(it: MissionItem, home_alt_m: float) -> float:
    return it.z_alt_m if it.frame in ABSOLUTE_ALT_FRAMES else home_alt_m + it.z_alt_m


def distance_m(lat1, lon1, lat2, lon2) -> float:
    p = Plane2(lat1, lon1)
    n, e = p.ne(lat2, lon2)
    return math.hypot(n, e)


# -------------------------------------------------------------------- the state --
class Geofence:
    """One vehicle's fence, rally points and breach state. ``kind``: 'plane' / 'quad'.

    ``update`` is called every step with the navigation solution; it returns "breach"
    when a breach starts (the vehicle then takes ``action``) and "clear" when it ends.
    ``breaches`` is the summary's list; ``notices`` what the vehicle announces."""

    def __init__(self, params, kind: str):
        self.params = params
        self.kind = kind
        self.fence = FenceSet()
        self.rally = RallySet()
        self.breached = 0                 # FENCE_TYPE bits breached now
        self.breach_count = 0
        self.breach_status_type = mavlink2.FENCE_BREACH_NONE
        self.breach_time_ms = 0
        self.breaches: list[dict] = []    # {at_s, type, action, cleared_s}
        self.action: str | None = None    # the action of the breach now (None: none)
        self._floor_armed = False

    # ------------------------------------------------------------- loading ---
    @property
    def fence_items(self) -> tuple:
        return self.fence.items

    @property
    def rally_items(self) -> tuple:
        return self.rally.items

    def set_fence(self, items) -> Problem | None:
        items = tuple(it.replace(seq=k) for k, it in enumerate(items))
        problem = fence_items_problem(items)
        if problem is None:
            self.fence = FenceSet(items)
        return problem

    def set_rally(self, items) -> Problem | None:
        items = tuple(it.replace(seq=k) for k, it in enumerate(items))
        problem = rally_items_problem(items)
        if problem is None:
            self.rally = RallySet(items)
        return problem

    @property
    def enabled(self) -> bool:
        return self.params["FENCE_ENABLE"] >= 1

    def types(self) -> int:
        return int(self.params["FENCE_TYPE"]) if self.enabled else 0

    def action_problem(self, value: float) -> str | None:
        if int(value) not in VEHICLE_ACTIONS[self.kind]:
            ok = ", ".join(f"{k} {ACTION_NAMES[k]}" for k in sorted(VEHICLE_ACTIONS[self.kind]))
            return f"FENCE_ACTION {value:g} not available on this vehicle ({ok})"
        return None

    # ------------------------------------------------------------- checking ---
    def distances(self, lat_deg: float, lon_deg: float, h_m: float, home, floor: bool = True) -> dict:
        """Signed distance out of each enabled fence type [m] (> 0: outside). ``home``:
        (lat_deg, lon_deg); ``h_m``: height above home."""
        t = self.types()
        p = self.params
        out = {}
        if t & TYPE_ALT_MAX:
            out[TYPE_ALT_MAX] = h_m - p["FENCE_ALT_MAX"]
        if t & TYPE_ALT_MIN and floor:
            out[TYPE_ALT_MIN] = p["FENCE_ALT_MIN"] - h_m
        if t & TYPE_CIRCLE and home is not None:
            out[TYPE_CIRCLE] = distance_m(home[0], home[1], lat_deg, lon_deg) - p["FENCE_RADIUS"]
        if t & TYPE_POLYGON:
            d = self.fence.outside_m(lat_deg, lon_deg)
            if d is not None:
                out[TYPE_POLYGON] = d
        return out

    def position_problem(self, lat_deg: float, lon_deg: float, h_m: float | None, home) -> str | None:
        """Why a position (pre-arm, a mission waypoint) is not FENCE_MARGIN inside the
        enabled fence; None when it is. ``h_m`` None: horizontal only."""
        margin = self.params["FENCE_MARGIN"]
        d = self.distances(lat_deg, lon_deg, 0.0 if h_m is None else h_m, home, floor=False)
        if h_m is None:
            d.pop(TYPE_ALT_MAX, None)
        bad = [BREACH_TYPE_NAMES[b] for b, v in sorted(d.items()) if v > -margin]
        return ("outside the fence (" + ", ".join(bad) + ")") if bad else None

    def arm_problem(self, lat_deg: float, lon_deg: float) -> str | None:
        """Pre-arm: on the ground, inside every enabled horizontal fence (with margin)."""
        if not self.enabled:
            return None
        return self.position_problem(lat_deg, lon_deg, None, (lat_deg, lon_deg))

    def mission_problem(self, items, home) -> str | None:
        """The first mission waypoint outside the enabled fence. ``home``: (lat_deg,
        lon_deg, alt_m MSL) or None (item 0's)."""
        if not self.enabled:
            return None
        items = tuple(items)
        if home is None and items:
            home = (items[0].x_lat_deg, items[0].y_lon_deg, items[0].z_alt_m)
        if home is None:
            return None
        for it in items[1:]:
            if it.frame not in GLOBAL_FRAMES or (it.x_lat_deg, it.y_lon_deg) == (0.0, 0.0):
                continue
            h = _alt_msl(it, home[2]) - home[2] if it.z_alt_m != 0.0 else None
            why = self.position_problem(it.x_lat_deg, it.y_lon_deg, h, home[:2])
            if why is not None:
                return f"item {it.seq} {why}"
        return None

    def update(self, t_us: int, lat_deg: float, lon_deg: float, h_m: float, home,
               flying: bool, landing: bool = False) -> str | None:
        """One step. Returns "breach" when a breach starts, "clear" when it ends."""
        if not self.enabled or not flying or home is None:
            self._floor_armed = self._floor_armed and flying
            if self.breached and not self.enabled:
                return self._clear(t_us)
            return None
        if not self._floor_armed and h_m >= self.params["FENCE_ALT_MIN"] + self.params["FENCE_MARGIN"]:
            self._floor_armed = True
        d = self.distances(lat_deg, lon_deg, h_m, home, floor=self._floor_armed and not landing)
        outside = 0
        for b, v in d.items():
            if v > 0.0:
                outside |= b
        if not self.breached:
            if not outside:
                return None
            self.breached = outside
            self.breach_count += 1
            self.breach_time_ms = t_us // 1000
            self.breach_status_type = _STATUS_TYPE[_first_bit(outside)]
            self.action = ACTION_NAMES.get(int(self.params["FENCE_ACTION"]), "report")
            self.breaches.append({"at_s": round(t_us * 1e-6, 3), "type": self.type_name(outside),
                                  "action": self.action, "cleared_s": None})
            return "breach"
        self.breached |= outside
        margin = self.params["FENCE_MARGIN"]
        if all(v < -margin for v in d.values()):
            return self._clear(t_us)
        return None

    def _clear(self, t_us: int) -> str:
        self.breached = 0
        self.action = None
        if self.breaches and self.breaches[-1]["cleared_s"] is None:
            self.breaches[-1]["cleared_s"] = round(t_us * 1e-6, 3)
        return "clear"

    def note_action(self, action: str) -> None:
        """What the vehicle actually did (e.g. RTL refused: reported only)."""
        self.action = action
        if self.breaches:
            self.breaches[-1]["action"] = action

    @staticmethod
    def type_name(bits: int) -> str:
        return "+".join(BREACH_TYPE_NAMES[b] for b in (TYPE_ALT_MAX, TYPE_CIRCLE, TYPE_POLYGON, TYPE_ALT_MIN)
                        if bits & b)

    # ------------------------------------------------------------ destinations ---
    def return_point(self, home_alt_m: float) -> tuple[float, float, float] | None:
        """FENCE_ACTION 6's destination (lat_deg, lon_deg, alt_m MSL; altitude 0: None
        for 'keep the current one'), or None without a return point."""
        rp = self.fence.return_point
        if rp is None:
            return None
        alt = _alt_msl(rp, home_alt_m) if rp.z_alt_m != 0.0 else math.nan
        return (rp.x_lat_deg, rp.y_lon_deg, alt)

    def rally_for_rtl(self, lat_deg: float, lon_deg: float, home) -> tuple[float, float, float] | None:
        """RTL's destination when it is a rally point (lat_deg, lon_deg, alt_m MSL), or
        None for home. ``home``: (lat_deg, lon_deg, alt_m MSL). The nearest rally point
        to the vehicle; home instead when RALLY_INCL_HOME and home is nearer, or when
        that rally point is beyond RALLY_LIMIT_KM and home is nearer (ArduPilot's rules)."""
        pts = self.rally.items
        if not pts or home is None:
            return None
        best = min(pts, key=lambda r: distance_m(lat_deg, lon_deg, r.x_lat_deg, r.y_lon_deg))
        d_r = distance_m(lat_deg, lon_deg, best.x_lat_deg, best.y_lon_deg)
        d_h = distance_m(lat_deg, lon_deg, home[0], home[1])
        limit_m = self.params["RALLY_LIMIT_KM"] * 1000.0
        if d_h < d_r and (self.params["RALLY_INCL_HOME"] >= 1 or (limit_m > 0.0 and d_r > limit_m)):
            return None
        return (best.x_lat_deg, best.y_lon_deg, _alt_msl(best, home[2]))


def _first_bit(bits: int) -> int:
    for b in (TYPE_ALT_MIN, TYPE_ALT_MAX, TYPE_CIRCLE, TYPE_POLYGON):
        if bits & b:
            return b
    return 0
