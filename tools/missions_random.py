"""Random missions: valid QGC WPL 110 missions drawn from a broad distribution.

``random_mission(vehicle, rng)`` draws one mission with the injected
``numpy.random.Generator``; ``mission_for_seed(vehicle, seed)`` is the pure function of
(vehicle, seed) behind ``sitl missions random`` and the ``random:VEHICLE:SEED`` mission
source of ``sitl run``. What is drawn (the classes users' missions fall into):

* home anywhere: latitudes to +-80 degrees, a share of homes within a few kilometres of
  the equator or of the 180-degree meridian so that the mission crosses them, ground
  0 to 1500 m above mean sea level;
* a NAV_TAKEOFF (plane 30-150 m, quad 3-50 m above home), its position "here"
  (latitude and longitude 0) or a point along a drawn launch heading (which sets the
  launch direction of a headless run, ``tools.runner.mission_home``);
* the first waypoint anywhere relative to the launch: ahead, behind, inside the
  climb-out (ahead, closer than the climb takes), at home;
* legs from 30 m (quad 3 m) to 3 km, log-uniform; turns from 0 to 180 degrees with
  extra weight on straight-on and reversals; consecutive duplicate waypoints; height
  steps larger than the leg can climb;
* NAV_LOITER_TURNS / NAV_LOITER_TIME with radii from 10 m (below the minimum turn
  radius) to 1 km, both directions (negative radius: counter-clockwise);
* DO_JUMP backwards with repeat 0-3, jumps over jumps; DO_CHANGE_SPEED in and out of
  the airframe's limits (and -1, no change);
* the end: RTL, NAV_LAND, or nothing; the plane's NAV_LAND is a landing sequence
  (DO_LAND_START, a waypoint abeam the approach at the mission's last height, a base leg
  descending at 6 % to the approach's first point 800-1500 m out on a 3.5-5 % glide slope, NAV_LAND
  on the ground at home's elevation within 300 m of home, from any direction; the way
  back to it is a return home's, of any length), drawn in
  ``PLANE_LANDING_P`` of the missions on a stream of its own (``mission_for_seed``): a
  seed that does not draw it keeps the mission it had before landings existed, one that
  does keeps its home, take-off and first waypoint, its body drawn for the longer end;
* in one mission in twenty, a waypoint at home on the ground before the take-off (a
  file's home line uploaded as an item, as MAVSDK does for ArduPilot).

Everything drawn is accepted by ``autopilot.mission.files.load_mission`` (the tests load
every sample). Missions are kept short enough to fly in a campaign: an estimate of the
still-air flight time (``estimate_time_s``) is held under ``TIME_BUDGET_S`` (plane 12
minutes, which stays under about 20 minutes in 12 m/s of wind; quad 7 minutes). Wind and
turbulence are the campaign's to disperse, not the mission's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.geo import LocalFrame
from autopilot.mission.files import dumps_waypoints
from autopilot.mission.items import (CONDITION_DELAY, CONDITION_DISTANCE, CONDITION_YAW,
                                     DO_CHANGE_SPEED, DO_JUMP, DO_LAND_START, FRAME_GLOBAL,
                                     FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_RELATIVE_ALT_INT,
                                     FRAME_MISSION, NAV_COMMANDS, NAV_DELAY, NAV_LAND,
                                     NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_LOITER_TURNS,
                                     NAV_RETURN_TO_LAUNCH, NAV_TAKEOFF, NAV_WAYPOINT,
                                     POSITION_COMMANDS, RELATIVE_ALT_FRAMES, Mission, MissionItem)

VEHICLES = ("plane", "quad")
TIME_BUDGET_S = {"plane": 720.0, "quad": 420.0}
LEG_MIN_M = {"plane": 30.0, "quad": 3.0}
LEG_MAX_M = 3000.0
ITEMS_MIN, ITEMS_MAX = 2, 20      # items after home
GROUND_WAYPOINT_P = 0.05          # a waypoint at home on the ground before the take-off
PLANE_LANDING_P = 0.3             # a plane's mission ends in a landing sequence
LAND_APPROACH_M = (800.0, 1500.0)  # the plane's final approach: its length
LAND_SLOPE = (0.035, 0.05)        # and glide slope (the Aerosonde's 1 km from 45 m: 4.5 %)
LAND_NEAR_HOME_M = 300.0          # the land point within this of home (on home's ground)
LAND_POINT_H_M = -1.5             # its height above home: the ground under the catapult rail
LAND_DESCENT = 0.06               # the descent (climb) to the approach's height: its slope
LAND_LINE_UP_M = 300.0            # and a straight line-up before it

# Performance assumed by the time estimate (the default parameters of the airframes).
PLANE_TRIM_MPS, PLANE_SPEED_LIMITS = 25.0, (20.0, 30.0)   # TRIM_ARSPD, ARSPD_FBW_MIN/MAX
PLANE_CLIMB_MPS, PLANE_SINK_MPS = 2.5, 3.0                 # CLMB_MAX, SINK_MAX
PLANE_R_MIN_M = PLANE_TRIM_MPS ** 2 / (9.80665 * math.tan(math.radians(45.0)))
PLANE_LOITER_RAD_M, PLANE_RTL_ALT_M = 80.0, 100.0           # LOITER_RAD, RTL_ALT
QUAD_SPEED_MPS, QUAD_SPEED_LIMITS = 5.0, (0.5, 20.0)       # WPNAV_SPEED; the sequencer's clamp
QUAD_SPEED_BUDGET_MAX = 8.0                                 # faster is not counted on
QUAD_UP_MPS, QUAD_DN_MPS, QUAD_ACCEL = 2.5, 1.5, 2.5
QUAD_LOITER_TURN_S, QUAD_RTL_ALT_M = 20.0, 15.0


@dataclass
class _Draft:
    """The mission being drawn, in home's NED frame (heights above home)."""

    vehicle: str
    items: list            # (command, frame, p1..p4, n, e, h) with n/e None for "here"
    notes: list


def mission_for_seed(vehicle: str, seed: int, budget_s: float | None = None
                     ) -> tuple[Mission, list[str]]:
    """The random mission of (vehicle, seed) and the notes of what was drawn;
    ``budget_s``: the still-air flight time to stay under (default TIME_BUDGET_S)."""
    if vehicle not in VEHICLES:
        raise ValueError(f"unknown vehicle {vehicle!r} (plane, quad)")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    rng = np.random.default_rng([int(seed), VEHICLES.index(vehicle)])
    ground_rng = np.random.default_rng([int(seed), VEHICLES.index(vehicle), 2])
    land_rng = np.random.default_rng([int(seed), VEHICLES.index(vehicle), 3])
    return random_mission(vehicle, rng, budget_s, ground_rng, land_rng)


def random_mission(vehicle: str, rng: np.random.Generator, budget_s: float | None = None,
                   ground_rng: np.random.Generator | None = None,
                   land_rng: np.random.Generator | None = None) -> tuple[Mission, list[str]]:
    """Draw one valid mission (item 0 = home) and notes saying what was drawn;
    ``ground_rng`` draws whether a waypoint at home on the ground comes first, and
    ``land_rng`` whether (and where) a plane's mission ends in a landing sequence (their
    own streams, so that the missions drawn without them stay the same draws)."""
    plane = vehicle == "plane"
    budget = TIME_BUDGET_S[vehicle] if budget_s is None else float(budget_s)
    lat, lon, alt0, home_note = _draw_home(rng)
    frame = LocalFrame.from_degrees(lat, lon, alt0)
    d = _Draft(vehicle, [], [home_note])
    n_target = int(rng.integers(ITEMS_MIN, ITEMS_MAX + 1))
    if ground_rng is not None and ground_rng.random() < GROUND_WAYPOINT_P:
        # the file's home line uploaded as an item (MAVSDK puts its own home at 0): a
        # waypoint at home, on the ground, before the take-off
        d.items.append((NAV_WAYPOINT, FRAME_GLOBAL, 0.0, 0.0, 0.0, 0.0, (0.0, 0.0), 0.0))
        d.notes.append("item 1: a waypoint at home on the ground (frame 0, home's altitude) "
                       "before the take-off")

    # take-off, and the launch heading it implies
    h_to = float(rng.uniform(30.0, 150.0) if plane else rng.uniform(3.0, 50.0))
    psi = float(rng.uniform(0.0, 2 * math.pi))
    if rng.random() < 0.5:
        r = float(rng.uniform(20.0, 300.0))
        to_ne = (r * math.cos(psi), r * math.sin(psi))
        d.notes.append(f"takeoff to {h_to:.0f} m at a point {r:.0f} m along the launch heading "
                       f"{math.degrees(psi):.0f} deg")
    else:
        to_ne = None
        d.notes.append(f"takeoff to {h_to:.0f} m, position 'here'")
    d.items.append((NAV_TAKEOFF, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, to_ne, h_to))

    # the first waypoint relative to the launch
    cls = str(rng.choice(["ahead", "behind", "climb-out", "home", "anywhere"],
                         p=[0.3, 0.2, 0.2, 0.1, 0.2]))
    if to_ne is None and cls != "home":
        cls = "ahead (the launch points at it)" if cls != "anywhere" else "anywhere"
    leg = _leg_length(rng, vehicle)
    if cls.startswith("ahead") or cls == "anywhere":
        bearing = psi + (rng.uniform(-1.0, 1.0) * math.radians(60.0) if cls != "anywhere"
                         else rng.uniform(0.0, 2 * math.pi))
    elif cls == "behind":
        bearing = psi + math.pi + rng.uniform(-1.0, 1.0) * math.radians(60.0)
    elif cls == "climb-out":
        bearing = psi + rng.uniform(-1.0, 1.0) * math.radians(10.0)
        # closer than the climb to the take-off height takes
        climb_len = h_to / (PLANE_CLIMB_MPS / PLANE_TRIM_MPS) if plane else h_to
        leg = float(rng.uniform(0.1, 1.0) * climb_len)
    else:
        bearing, leg = psi, 0.0
    h1 = _height(rng, vehicle)
    wp1 = _waypoint(rng, vehicle, (0.0, 0.0), h1)
    for _ in range(30):   # a first leg that fits the budget
        first = (leg * math.cos(bearing), leg * math.sin(bearing))
        d.items.append(wp1[:6] + (first, h1))
        if leg < 1.0 or estimate_time_s(_to_mission(d, frame), vehicle) <= budget:
            break
        d.items.pop()
        leg *= 0.5
    d.notes.append(f"item 2, the first waypoint, {cls}: {leg:.0f} m from home at bearing "
                   f"{math.degrees(bearing) % 360:.0f} deg, {h1:.0f} m")
    course = bearing if leg > 1.0 else psi

    ending = str(rng.choice(["rtl", "land", "none"], p=[0.35, 0.35, 0.3]) if not plane
                 else rng.choice(["rtl", "none"], p=[0.6, 0.4]))
    if plane and land_rng is not None and land_rng.random() < PLANE_LANDING_P:
        ending = "landing"
    n_end = {"none": 0, "rtl": 1, "land": 1, "landing": 4}[ending]
    land_draw = _draw_landing(land_rng) if ending == "landing" else None
    n_body = max(n_target - n_end, len(d.items))
    item_notes: dict[int, str] = {}      # seq -> what was drawn there
    for _ in range(200):
        if len(d.items) >= n_body:
            break
        if plane:
            kind = str(rng.choice(["waypoint", "duplicate", "loiter_turns", "loiter_time", "speed",
                                   "jump"], p=[0.52, 0.07, 0.1, 0.1, 0.1, 0.11]))
        else:   # the quadrotor also flies what ArduCopter missions carry
            kind = str(rng.choice(["waypoint", "duplicate", "loiter_turns", "loiter_time", "speed",
                                   "jump", "condition", "nav_delay", "loiter_to_alt", "vertical"],
                                  p=[0.4, 0.06, 0.07, 0.07, 0.08, 0.1, 0.08, 0.04, 0.05, 0.05]))
        for attempt in range(4):
            cand, note, extra = _draw_item(rng, d, kind, course, 0.25 ** attempt)
            if cand is None:
                break
            d.items.append(cand)
            if estimate_time_s(_to_mission(d, frame), vehicle) <= budget:
                break
            d.items.pop()
            cand = None
            if kind in ("speed", "jump", "duplicate", "condition", "nav_delay", "vertical"):
                break
        if cand is None:
            if kind in ("waypoint", "loiter_turns", "loiter_time", "loiter_to_alt"):
                break                     # the time budget is spent
            continue
        if note:
            item_notes[len(d.items)] = note
        if extra is not None and extra[2] > 1.0:
            course = extra[0]
    if ending == "rtl":
        d.items.append((NAV_RETURN_TO_LAUNCH, FRAME_MISSION, 0.0, 0.0, 0.0, 0.0, (0.0, 0.0), 0.0))
    elif ending == "land":
        here = rng.random() < 0.5
        pos = None if here else _offset(_last_position(d), _leg_length(rng, vehicle) * 0.2,
                                        float(rng.uniform(0.0, 2 * math.pi)))
        d.items.append((NAV_LAND, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, pos, 0.0))
    elif ending == "landing":
        d.items += _landing_sequence(land_draw, _last_height(d))
    mission = _to_mission(d, frame)
    while estimate_time_s(mission, vehicle) > budget and len(d.items) > 2 + n_end:
        # the end took it over: give up the last items before it (jumps only go
        # backwards, so no jump loses its target)
        del d.items[-(n_end + 1)]
        if ending == "landing":   # the descent to the approach starts at the new last height
            d.items[-n_end:] = _landing_sequence(land_draw, _last_height(_Draft(vehicle, d.items[:-n_end], [])))
        mission = _to_mission(d, frame)
    d.notes += [f"item {seq}: {note}" for seq, note in sorted(item_notes.items())
                if seq < len(mission) - n_end]
    d.notes.append(_geometry_note(mission, vehicle))
    d.notes.append({"rtl": "ends in RTL", "land": "ends in NAV_LAND "
                    + ("here" if ending == "land" and d.items[-1][6] is None else "at a point"),
                    "landing": "ends in a landing sequence: "
                    + (_landing_note(d.items[-2:]) if ending == "landing" else ""),
                    "none": "ends with no end item"}[ending])
    d.notes.append(f"{len(mission) - 1} items; estimated {estimate_time_s(mission, vehicle):.0f} s "
                   f"in still air")
    return mission, d.notes


def _draw_landing(rng) -> tuple:
    """The landing's draws: land point, approach length, course, glide slope."""
    b = _offset((0.0, 0.0), float(rng.uniform(0.0, LAND_NEAR_HOME_M)), float(rng.uniform(0.0, 2 * math.pi)))
    return b, float(rng.uniform(*LAND_APPROACH_M)), float(rng.uniform(0.0, 2 * math.pi)), \
        float(rng.uniform(*LAND_SLOPE)), float(rng.choice([-1.0, 1.0]))


def _landing_sequence(draw, h_prev: float) -> list:
    """The plane's landing as ArduPlane users plan it: DO_LAND_START (where RTL_AUTOLAND
    and a go-around join it), a waypoint abeam the approach's first point (a base leg,
    left or right) at the height flown before, from which the aircraft descends (or
    climbs) at LAND_DESCENT to that point, then NAV_LAND on home's ground near home: the
    final approach is joined at its height, whatever height the mission ended at. (On the
    extended centreline instead, the base leg and the final are one line, and the
    aircraft joins the final before it has descended.)"""
    b, length, course, slope, side = draw
    h_a = round(LAND_POINT_H_M + length * slope, 1)
    a = _offset(b, -length, course)
    d = _offset(a, abs(h_prev - h_a) / LAND_DESCENT + LAND_LINE_UP_M, course + side * math.pi / 2)
    return [(DO_LAND_START, FRAME_MISSION, 0.0, 0.0, 0.0, 0.0, (0.0, 0.0), 0.0),
            (NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, d, round(h_prev, 1)),
            (NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, a, h_a),
            (NAV_LAND, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, b, LAND_POINT_H_M)]


def _landing_note(items) -> str:
    (_, _, _, _, _, _, a, h_a), (_, _, _, _, _, _, b, _) = items
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    course = math.degrees(math.atan2(b[1] - a[1], b[0] - a[0])) % 360.0
    return (f"approach {length:.0f} m on course {course:.0f} deg from {h_a:.0f} m, NAV_LAND "
            f"{math.hypot(*b):.0f} m from home")


def _geometry_note(mission: Mission, vehicle: str) -> str:
    """Waypoints, duplicates, leg lengths, turns, reversals and steep height steps of
    the mission as written (jumps not followed)."""
    home = mission.home
    frame = LocalFrame.from_degrees(home.x_lat_deg, home.y_lon_deg, home.z_alt_m)
    pts = [(0.0, 0.0, 0.0)]
    n_wp = 0
    for it in mission.items[1:]:
        if it.command in (NAV_WAYPOINT, NAV_LOITER_TURNS, NAV_LOITER_TIME):
            n_wp += it.command == NAV_WAYPOINT
            pts.append(item_ne_h(mission, it.seq, frame) or pts[-1])
    legs = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:])]
    dup = sum(L < 0.5 for L in legs[1:])
    slope = PLANE_CLIMB_MPS / PLANE_TRIM_MPS if vehicle == "plane" else 1.0
    steep = sum(abs(b[2] - a[2]) > slope * max(L, 1.0)
                for a, b, L in zip(pts[1:], pts[2:], legs[1:]) if L >= 0.5)
    turns = []
    real = [(a, b) for a, b, L in zip(pts, pts[1:], legs) if L >= 0.5]
    for (a1, b1), (a2, b2) in zip(real, real[1:]):
        c1 = math.atan2(b1[1] - a1[1], b1[0] - a1[0])
        c2 = math.atan2(b2[1] - a2[1], b2[0] - a2[0])
        turns.append(abs(math.degrees((c2 - c1 + math.pi) % (2 * math.pi) - math.pi)))
    nz = [L for L in legs if L >= 0.5]
    return (f"{n_wp} waypoints, {dup} duplicates, legs "
            + (f"{min(nz):.0f}-{max(nz):.0f} m" if nz else "none")
            + (f", turns {min(turns):.0f}-{max(turns):.0f} deg, "
               f"{sum(t > 179.0 for t in turns)} reversals" if turns else ", no turns")
            + f", {steep} height steps steeper than the vehicle climbs")


# --- drawing ---------------------------------------------------------------------------

def _draw_home(rng) -> tuple[float, float, float, str]:
    lat = float(rng.uniform(-80.0, 80.0))
    lon = float(rng.uniform(-180.0, 180.0))
    where = "anywhere"
    u = rng.random()
    if u < 0.15:
        lat = float(rng.uniform(-0.03, 0.03))
        where = "by the equator"
    elif u < 0.3:
        lon = float(math.copysign(180.0 - rng.uniform(0.0, 0.03), rng.uniform(-1, 1)))
        where = "by the 180-degree meridian"
    alt = float(np.round(rng.uniform(0.0, 1500.0), 1))
    return lat, lon, alt, f"home {where}: {lat:.5f} {lon:.5f}, {alt:.0f} m AMSL"


def _leg_length(rng, vehicle: str) -> float:
    lo = LEG_MIN_M[vehicle]
    return float(math.exp(rng.uniform(math.log(lo), math.log(LEG_MAX_M))))


def _height(rng, vehicle: str) -> float:
    return float(rng.uniform(40.0, 300.0) if vehicle == "plane" else rng.uniform(3.0, 80.0))


def _offset(ne, dist: float, bearing: float) -> tuple[float, float]:
    return (ne[0] + dist * math.cos(bearing), ne[1] + dist * math.sin(bearing))


def _last_position(d: _Draft) -> tuple[float, float]:
    for it in reversed(d.items):
        if it[6] is not None and it[0] in (NAV_TAKEOFF, NAV_WAYPOINT, NAV_LOITER_TURNS,
                                           NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_LAND):
            return it[6]
    return (0.0, 0.0)


def _last_height(d: _Draft) -> float:
    for it in reversed(d.items):
        if it[0] in (NAV_WAYPOINT, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LOITER_TO_ALT,
                     NAV_TAKEOFF):
            return it[7]
    return 0.0


def _waypoint(rng, vehicle: str, ne, h: float) -> tuple:
    plane = vehicle == "plane"
    accept = 0.0
    hold = 0.0
    yaw = 0.0
    if rng.random() < 0.25:
        accept = float(np.round(rng.uniform(10.0, 100.0) if plane else rng.uniform(0.5, 5.0), 1))
    if not plane and rng.random() < 0.2:
        hold = float(np.round(rng.uniform(1.0, 10.0), 1))
    if not plane and rng.random() < 0.2:
        yaw = float(np.round(rng.uniform(1.0, 359.0)))
    return (NAV_WAYPOINT, _frame(rng), hold, accept, 0.0, yaw, ne, h)


def _frame(rng) -> int:
    return int(rng.choice([FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT_INT],
                          p=[0.7, 0.2, 0.1]))


def _draw_item(rng, d: _Draft, kind: str, course: float, shrink: float):
    """One candidate item: (item, note, (course, turn, length, steep) or None)."""
    plane = d.vehicle == "plane"
    prev = _last_position(d)
    h_prev = _last_height(d)
    if kind == "speed" and not plane and rng.random() < 0.3:
        stype = float(rng.choice([2.0, 3.0]))
        v = float(np.round(rng.uniform(0.2, 12.0), 1))
        return ((DO_CHANGE_SPEED, FRAME_MISSION, stype, v, -1.0, 0.0, (0.0, 0.0), 0.0),
                f"DO_CHANGE_SPEED {'climb' if stype == 2 else 'descent'} {v:g} m/s", None)
    if kind == "speed":
        if plane:
            v = float(np.round(rng.uniform(10.0, 40.0), 1))
            lo, hi = PLANE_SPEED_LIMITS
        else:
            v = float(np.round(rng.uniform(1.0, 15.0), 1))
            lo, hi = 1.0, 10.0
        if rng.random() < 0.1:
            v = -1.0
        where = "no change" if v < 0 else ("within limits" if lo <= v <= hi else "outside limits")
        stype = float(rng.integers(0, 2))
        return ((DO_CHANGE_SPEED, FRAME_MISSION, stype, v, -1.0, 0.0, (0.0, 0.0), 0.0),
                f"DO_CHANGE_SPEED {v:g} m/s ({where})", None)
    if kind == "jump":
        seq_now = len(d.items) + 1           # the jump's own seq (home is 0)
        after_takeoff = next(i for i, it in enumerate(d.items) if it[0] == NAV_TAKEOFF) + 2
        targets = [s for s in range(after_takeoff, seq_now)
                   if any(it[0] in (NAV_WAYPOINT, NAV_LOITER_TURNS, NAV_LOITER_TIME,
                                    NAV_LOITER_TO_ALT, NAV_DELAY) for it in d.items[s - 1:])]
        if not targets:
            return None, "", None
        target = int(rng.choice(targets))
        repeat = int(rng.integers(0, 4))
        over = any(it[0] == DO_JUMP for it in d.items[target - 1:])
        return ((DO_JUMP, FRAME_MISSION, float(target), float(repeat), 0.0, 0.0, (0.0, 0.0), 0.0),
                f"DO_JUMP at {seq_now} to {target}, repeat {repeat}" + (" (over a jump)" if over else ""),
                None)
    if kind == "condition":
        c = str(rng.choice(["delay", "distance", "yaw"]))
        if c == "delay":
            t = float(np.round(rng.uniform(0.0, 10.0), 1))
            return ((CONDITION_DELAY, FRAME_MISSION, t, 0.0, 0.0, 0.0, (0.0, 0.0), 0.0),
                    f"CONDITION_DELAY {t:g} s", None)
        if c == "distance":
            dist = float(np.round(rng.uniform(1.0, 50.0), 1))
            return ((CONDITION_DISTANCE, FRAME_MISSION, dist, 0.0, 0.0, 0.0, (0.0, 0.0), 0.0),
                    f"CONDITION_DISTANCE {dist:g} m", None)
        angle = float(np.round(rng.uniform(0.0, 359.0)))
        rate = float(rng.choice([0.0, 10.0, 30.0, 90.0]))
        direction = float(rng.choice([-1.0, 0.0, 1.0]))
        relative = float(rng.integers(0, 2))
        return ((CONDITION_YAW, FRAME_MISSION, angle, rate, direction, relative, (0.0, 0.0), 0.0),
                f"CONDITION_YAW {angle:g} deg ({'relative' if relative else 'absolute'}, "
                f"direction {direction:g}, {rate:g} deg/s)", None)
    if kind == "nav_delay":
        t = float(np.round(rng.uniform(0.0, 10.0), 1))
        return ((NAV_DELAY, FRAME_MISSION, t, -1.0, -1.0, -1.0, (0.0, 0.0), 0.0),
                f"NAV_DELAY {t:g} s", None)
    if kind == "vertical":
        h = _height(rng, d.vehicle)
        return ((NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, None, h),
                f"waypoint 'here' (latitude and longitude 0) at {h:.0f} m", (course, 0.0, 0.0, 0))
    if kind == "duplicate":
        return ((NAV_WAYPOINT, _frame(rng), 0.0, 0.0, 0.0, 0.0, prev, h_prev),
                "", (course, 0.0, 0.0, 0))
    # a new position: waypoint or loiter
    u = rng.random()
    if u < 0.12:
        turn = math.pi
    elif u < 0.2:
        turn = 0.0
    else:
        turn = float(rng.uniform(0.0, math.pi))
    turn *= 1.0 if rng.random() < 0.5 else -1.0
    new_course = course + turn
    length = _leg_length(rng, d.vehicle) * shrink
    length = max(length, LEG_MIN_M[d.vehicle])
    ne = _offset(prev, length, new_course)
    h = _height(rng, d.vehicle)
    steep = 0
    if rng.random() < 0.15:
        # a height step larger than this leg can climb (plane: steeper than CLMB_MAX at
        # cruise; quad: more than the leg is long)
        slope = PLANE_CLIMB_MPS / PLANE_TRIM_MPS if plane else 1.0
        step = float(rng.uniform(1.5, 4.0) * slope * length)
        hi = 400.0 if plane else 100.0
        lo = 40.0 if plane else 3.0
        h = min(max(h_prev + (step if rng.random() < 0.5 else -step), lo), hi)
        steep = int(abs(h - h_prev) > slope * length)
    if kind == "waypoint":
        return _waypoint(rng, d.vehicle, ne, h), "", (new_course, turn, length, steep)
    if kind == "loiter_to_alt":
        return ((NAV_LOITER_TO_ALT, _frame(rng), 0.0, 0.0, 0.0, 0.0, ne, h),
                f"LOITER_TO_ALT {h:.0f} m", (new_course, turn, length, steep))
    radius = float(math.exp(rng.uniform(math.log(10.0), math.log(1000.0))))
    if not plane:
        radius = float(rng.uniform(2.0, 50.0))
    radius = float(np.round(radius * (1.0 if rng.random() < 0.5 else -1.0), 1))
    below = plane and abs(radius) < PLANE_R_MIN_M
    if kind == "loiter_turns":
        n = float(rng.choice([0.5, 1.0, 1.5, 2.0, 3.0]))
        item = (NAV_LOITER_TURNS, _frame(rng), n, 0.0, radius, 0.0, ne, h)
        note = f"LOITER_TURNS {n:g} r={radius:g} m" + (" (below the minimum turn radius)" if below else "")
    else:
        t = float(np.round(rng.uniform(0.0, 120.0 if plane else 30.0)))
        item = (NAV_LOITER_TIME, _frame(rng), t, 0.0, radius, 0.0, ne, h)
        note = f"LOITER_TIME {t:g} s r={radius:g} m" + (" (below the minimum turn radius)" if below else "")
    return item, note, (new_course, turn, length, steep)


def _to_mission(d: _Draft, frame: LocalFrame) -> Mission:
    home_lat, home_lon = math.degrees(frame.lat0_rad), math.degrees(frame.lon0_rad)
    items = [MissionItem(seq=0, frame=FRAME_GLOBAL, command=NAV_WAYPOINT, current=1, autocontinue=1,
                         param1=0.0, param2=0.0, param3=0.0, param4=0.0, x_lat_deg=round(home_lat, 7),
                         y_lon_deg=round(home_lon, 7), z_alt_m=frame.alt0_m)]
    for seq, (cmd, fr, p1, p2, p3, p4, ne, h) in enumerate(d.items, start=1):
        if fr == FRAME_MISSION:
            lat = lon = alt = 0.0
        elif ne is None:
            lat = lon = 0.0
            alt = round(h if fr in RELATIVE_ALT_FRAMES else frame.alt0_m + h, 2)
        else:
            la, lo, _ = frame.to_geodetic(np.array([ne[0], ne[1], 0.0]))
            lat, lon = round(math.degrees(la), 7), round(math.degrees(lo), 7)
            alt = round(h if fr in RELATIVE_ALT_FRAMES else frame.alt0_m + h, 2)
        items.append(MissionItem(seq=seq, frame=fr, command=cmd, current=0, autocontinue=1,
                                 param1=p1, param2=p2, param3=p3, param4=p4,
                                 x_lat_deg=lat, y_lon_deg=lon, z_alt_m=alt))
    return Mission(tuple(items))


# --- the mission as it will be flown --------------------------------------------------

# the navigation items: one flown at a time (autopilot.mission.items.NAV_COMMANDS)
NAV_FLOWN = NAV_COMMANDS


def resolve_order(mission: Mission, limit: int = 10000) -> list[int]:
    """The seqs of the items executed, in order, DO_JUMPs resolved as the sequencers do
    (a jump is taken while it has been taken fewer than its repeat count times, for
    ever with repeat -1; counts are never reset). DO_JUMP items themselves are left out;
    everything else (DO_, CONDITION_ and NAV_ items) is in. Stops at a NAV_LOITER_UNLIM,
    which never ends, after an RTL or a landing, and after ``limit`` items (a jump
    repeated for ever)."""
    from autopilot.mission.items import NAV_LOITER_UNLIM
    out: list[int] = []
    counts: dict[int, int] = {}
    i = 1
    items = mission.items
    for _ in range(100 * limit):
        if i >= len(items) or len(out) >= limit:
            break
        it = items[i]
        if it.command == DO_JUMP:
            done = counts.get(i, 0)
            if int(it.param2) < 0 or done < int(it.param2):
                counts[i] = done + 1
                i = int(it.param1)
            else:
                i += 1
            continue
        out.append(i)
        if it.command == NAV_LOITER_UNLIM or it.command in (NAV_RETURN_TO_LAUNCH, NAV_LAND):
            break   # the mission ends here (RTL and LAND end the flight)
        i += 1
    return out


def item_ne_h(mission: Mission, seq: int, frame: LocalFrame) -> tuple[float, float, float] | None:
    """(north, east, height above home) of an item with a position, None for "here"
    (latitude and longitude 0, or a command without a position)."""
    it = mission[seq]
    if it.command not in POSITION_COMMANDS or (it.x_lat_deg == 0.0 and it.y_lon_deg == 0.0):
        return None
    p = frame.to_ned_fast(math.radians(it.x_lat_deg), math.radians(it.y_lon_deg), frame.alt0_m)
    h = it.z_alt_m if it.frame in RELATIVE_ALT_FRAMES else it.z_alt_m - mission.home.z_alt_m
    return float(p[0]), float(p[1]), float(h)


def _item_height(mission: Mission, it: MissionItem, h_now: float) -> float:
    """An item's height above home; altitude 0 keeps ``h_now`` (ArduPilot's "this
    height")."""
    if it.z_alt_m == 0.0 and it.command != NAV_LAND:
        return h_now
    return it.z_alt_m if it.frame in RELATIVE_ALT_FRAMES else it.z_alt_m - mission.home.z_alt_m


def estimate_time_s(mission: Mission, vehicle: str, ground_speed_factor: float = 1.0) -> float:
    """Still-air flight time of the mission (``ground_speed_factor`` < 1 scales every
    speed down, e.g. for a headwind), from the take-off to the end of the mission: legs
    at the commanded speed, climbs and descents at the vehicle's rates, a turn per
    waypoint, loiters as commanded, the return home (and the quad's landing)."""
    home = mission.home
    frame = LocalFrame.from_degrees(home.x_lat_deg, home.y_lon_deg, home.z_alt_m)
    plane = vehicle == "plane"
    k = ground_speed_factor
    v = PLANE_TRIM_MPS if plane else QUAD_SPEED_MPS
    v_up, v_dn = QUAD_UP_MPS, QUAD_DN_MPS
    pos, h = (0.0, 0.0), 0.0
    t = 0.0
    ended = False
    for seq in resolve_order(mission):
        it = mission[seq]
        cmd = it.command
        if cmd == DO_CHANGE_SPEED:
            if not plane and it.param1 in (2.0, 3.0):      # the quad's climb / descent speed
                vz = min(max(it.param2, 0.2), 10.0) if it.param2 > 0 else \
                    (QUAD_UP_MPS if it.param1 == 2.0 else QUAD_DN_MPS)
                if it.param2 > 0 or it.param2 == -2.0:
                    v_up, v_dn = (vz, v_dn) if it.param1 == 2.0 else (v_up, vz)
                continue
            if it.param2 > 0 and it.param1 in (0.0, 1.0):
                lo, hi = PLANE_SPEED_LIMITS if plane else QUAD_SPEED_LIMITS
                v = min(max(it.param2, lo), hi)
            elif it.param2 == -2.0:
                v = PLANE_TRIM_MPS if plane else QUAD_SPEED_MPS
            continue
        if cmd == CONDITION_DELAY:
            t += max(it.param1, 0.0)        # gates what follows: counted as time, to be safe
            continue
        if cmd not in NAV_FLOWN:
            continue
        if cmd == NAV_DELAY:
            t += max(it.param1, 0.0) + 2.0
            continue
        vh = min(v, QUAD_SPEED_BUDGET_MAX) * k if not plane else v * k
        p = item_ne_h(mission, seq, frame)
        if cmd == NAV_TAKEOFF:
            h = p[2] if p is not None else (it.z_alt_m if it.frame in RELATIVE_ALT_FRAMES
                                            else it.z_alt_m - home.z_alt_m)
            t += h / (PLANE_CLIMB_MPS if plane else QUAD_UP_MPS) + (5.0 if plane else 3.0)
            continue
        if cmd == NAV_RETURN_TO_LAUNCH or (cmd == NAV_LAND and p is None):
            target = (0.0, 0.0) if cmd == NAV_RETURN_TO_LAUNCH else pos
            h_new = (PLANE_RTL_ALT_M if plane else max(h, QUAD_RTL_ALT_M)) \
                if cmd == NAV_RETURN_TO_LAUNCH else h
        else:
            target = pos if p is None else (p[0], p[1])
            h_new = _item_height(mission, it, h)
        dist = math.hypot(target[0] - pos[0], target[1] - pos[1])
        dh = h_new - h
        if plane:
            t_leg = max(dist / vh, dh / PLANE_CLIMB_MPS, -dh / PLANE_SINK_MPS)
            t_leg += 2 * math.pi * PLANE_R_MIN_M / vh * 0.5   # the turn onto the next leg
        else:
            t_leg = max(dist / vh, dh / v_up, -dh / v_dn) + 2 * vh / QUAD_ACCEL + 1.0
        t += t_leg
        pos, h = target, h_new
        if cmd in (NAV_LOITER_TURNS, NAV_LOITER_TIME):
            if plane:
                r = abs(it.param3) if abs(it.param3) > 1.0 else PLANE_LOITER_RAD_M
                r = max(r, PLANE_R_MIN_M)
                t += 2 * math.pi * r / vh      # capturing the circle
                t += (it.param1 * 2 * math.pi * r / vh if cmd == NAV_LOITER_TURNS else it.param1)
            else:
                t += it.param1 * QUAD_LOITER_TURN_S if cmd == NAV_LOITER_TURNS else it.param1
        elif cmd == NAV_WAYPOINT and not plane and math.isfinite(it.param1):
            t += max(it.param1, 0.0)
        if cmd in (NAV_RETURN_TO_LAUNCH, NAV_LAND):
            ended = True
            break
    if not ended:   # past the last item: home (plane: loiter there; quad: RTL and land)
        dist = math.hypot(pos[0], pos[1])
        vh = (v if plane else min(v, QUAD_SPEED_BUDGET_MAX)) * k
        if plane:
            t += max(dist / vh, abs(PLANE_RTL_ALT_M - h) / PLANE_CLIMB_MPS)
        else:
            t += dist / vh + max(QUAD_RTL_ALT_M - h, 0.0) / v_up + 2 * vh / QUAD_ACCEL
            h = max(h, QUAD_RTL_ALT_M)
    if plane:
        t += 0.5 * math.pi * PLANE_LOITER_RAD_M / (v * k) + 2 * math.pi * PLANE_LOITER_RAD_M / (v * k)
    else:
        t += max(h - 5.0, 0.0) / v_dn + min(h, 5.0) / 0.5 + 5.0
    return t


# --- CLI ------------------------------------------------------------------------------

def write_random(vehicle: str, seed: int, path, budget_s: float | None = None) -> list[str]:
    """Write the (vehicle, seed) mission as QGC WPL 110; return the notes."""
    mission, notes = mission_for_seed(vehicle, seed, budget_s)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(dumps_waypoints(mission))
    return notes


def describe(vehicle: str, seed: int, notes: list[str]) -> str:
    return "\n".join([f"# random {vehicle} mission, seed {seed}"] + [f"#   {n}" for n in notes])


# --- the random:VEHICLE:SEED mission source ---------------------------------------------

SOURCE_PREFIX = "random:"


def is_random_source(spec) -> bool:
    return str(spec).startswith(SOURCE_PREFIX)


def parse_source(spec) -> tuple[str, int, float | None]:
    """``random:VEHICLE:SEED[:BUDGET_S]`` -> (vehicle, seed, budget or None);
    MissionFileError if malformed."""
    from autopilot.mission.files import MissionFileError
    parts = str(spec).split(":")
    ok = len(parts) in (3, 4) and parts[1] in VEHICLES and parts[2].isdigit()
    budget = None
    if ok and len(parts) == 4:
        try:
            budget = float(parts[3])
        except ValueError:
            ok = False
        else:
            ok = math.isfinite(budget) and budget > 0
    if not ok:
        raise MissionFileError(str(spec), None, "a random mission source is random:VEHICLE:SEED"
                                                "[:BUDGET_S] (VEHICLE plane or quad, SEED an "
                                                "integer >= 0, BUDGET_S seconds > 0)")
    return parts[1], int(parts[2]), budget


def load_source(spec) -> tuple[Mission, list[str] | None]:
    """A mission file, or ``random:VEHICLE:SEED[:BUDGET_S]`` (the mission of
    ``mission_for_seed``, shortened to BUDGET_S of estimated flight time): (mission,
    notes of the draw or None)."""
    if is_random_source(spec):
        vehicle, seed, budget = parse_source(spec)
        return mission_for_seed(vehicle, seed, budget)
    from autopilot.mission.files import load_mission
    return load_mission(spec), None


# --- flying a sample ---------------------------------------------------------------------

WIND_MAX_MPS = {"plane": 12.0, "quad": 8.0}
TURBULENCE_LEVELS = ("none", "light", "moderate")


def sample_weather(vehicle: str, seed: int) -> tuple[float, float, str]:
    """Wind (speed m/s, from deg) and turbulence of a sample flight: uniform up to
    WIND_MAX_MPS of the vehicle, any direction, turbulence none to moderate; a pure
    function of (vehicle, seed), drawn apart from the mission's own draw."""
    rng = np.random.default_rng([int(seed), VEHICLES.index(vehicle), 1])
    speed = float(np.round(rng.uniform(0.0, WIND_MAX_MPS[vehicle]), 1))
    frm = float(np.round(rng.uniform(0.0, 360.0)))
    return speed, frm, str(rng.choice(TURBULENCE_LEVELS))


def sample_command(vehicle: str, seed: int, budget_s: float | None = None, weather: bool = True) -> str:
    """The ``sitl run`` command line that flies the sample of ``fly_sample``."""
    from .invariants import time_bound_s
    mission, _ = mission_for_seed(vehicle, seed, budget_s)
    w = sample_weather(vehicle, seed) if weather else (0.0, 0.0, "none")
    src = f"random:{vehicle}:{seed}" + (f":{budget_s:g}" if budget_s is not None else "")
    duration = time_bound_s(mission, vehicle, w[0], None) + 60.0
    return (f"sitl run --vehicle {vehicle} --mission {src} --wind {w[0]:g},{w[1]:g} "
            f"--turbulence {w[2]} --seed {seed} --duration {duration:.0f}")


def fly_sample(vehicle: str, seed: int, budget_s: float | None = None, weather: bool = True) -> dict:
    """Fly the (vehicle, seed) random mission (shortened to ``budget_s`` of estimated
    still-air time) headless in the sample's weather, for at most its time bound plus
    a minute (``sample_command`` is the same flight from the command line); the run's
    summary (with ``invariants``)."""
    from pathlib import Path

    from .invariants import time_bound_s
    from .runner import RunConfig, Session
    from .summary import run_summary

    mission, _notes = mission_for_seed(vehicle, seed, budget_s)
    w = sample_weather(vehicle, seed) if weather else (0.0, 0.0, "none")
    src = f"random:{vehicle}:{seed}" + (f":{budget_s:g}" if budget_s is not None else "")
    cfg = RunConfig(vehicle=vehicle, airframe="aerosonde" if vehicle == "plane" else "f450",
                    mission=Path(src), wind=(w[0], w[1]), turbulence=w[2], seed=seed,
                    duration_s=round(time_bound_s(mission, vehicle, w[0], None) + 60.0))
    session = Session(cfg)
    session.run()
    return run_summary(session)


# --- a sample of flights, one after the other ------------------------------------------

SAMPLE_FIGURES = ("xtrack_mission_rms_m", "xtrack_mission_max_m", "xtrack_rms_m", "xtrack_max_m")


def sample_record(vehicle: str, seed: int, budget_s: float | None, summary: dict) -> dict:
    """One line of ``sitl missions sample``: the flight's key figures, every invariant as
    [passed, figure, seq], and the command that flies it again."""
    rec = {k: summary.get(k) for k in ("vehicle", "seed", "completed", "crashed",
                                       "invariants_passed", "sim_time_s", "wind_speed_mps",
                                       "wind_from_deg", "turbulence", "false_alarms",
                                       "xtrack_mission_worst_leg") + SAMPLE_FIGURES}
    rec["invariants"] = {k: [v["passed"], v["figure"], v.get("seq")]
                         for k, v in summary["invariants"].items()}
    rec["command"] = sample_command(vehicle, seed, budget_s)
    return rec


def sample_statistics(records: list[dict]) -> str:
    """Pass counts per invariant and p50/p95/p99/max of the cross-track figures."""
    out = []
    for vehicle in VEHICLES:
        rs = [r for r in records if r["vehicle"] == vehicle]
        if not rs:
            continue
        out.append(f"{vehicle}: {len(rs)} flights, every invariant held on "
                   f"{sum(bool(r['invariants_passed']) for r in rs)}")
        names = list(rs[0]["invariants"])
        out.append("  held: " + ", ".join(
            f"{n} {sum(bool(r['invariants'][n][0]) for r in rs)}" for n in names))
        for key in SAMPLE_FIGURES:
            x = np.array([r[key] for r in rs if r[key] is not None], dtype=float)
            if x.size:
                p50, p95, p99 = np.percentile(x, [50, 95, 99])
                out.append(f"  {key:21s} n={x.size:4d}  p50 {p50:8.2f}  p95 {p95:8.2f}  "
                           f"p99 {p99:8.2f}  max {x.max():8.2f}")
        failed = [r for r in rs if not r["invariants_passed"]]
        for r in failed:
            why = ", ".join(f"{n} {f[1]:.4g}" + (f" at item {f[2]}" if f[2] is not None else "")
                            for n, f in r["invariants"].items() if not f[0] and f[1] is not None)
            out.append(f"  FAILED seed {r['seed']}: {why}  ({r['command']})")
    return "\n".join(out)
