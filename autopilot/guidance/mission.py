"""Fixed-wing mission sequencer: turns the active mission item into a guidance target.

Item 0 is home (ArduPilot convention). Flown: NAV_TAKEOFF, NAV_WAYPOINT,
NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_DELAY,
NAV_RETURN_TO_LAUNCH, NAV_LAND (guidance/landing.py), DO_LAND_START (a marker), DO_JUMP,
DO_CHANGE_SPEED (every speed type), DO_SET_HOME, CONDITION_DELAY, CONDITION_DISTANCE and
CONDITION_YAW (ignored with a note, as ArduPlane does).

Leg switching (seed section 1.16, the SLUGS rule): the vehicle's position is projected
onto the leg direction; the waypoint is reached when the projection passes the end of
the leg less a turn-anticipation distance d. The turn itself is flown as a fillet: the
circular arc of radius R tangent to both legs, which starts d = R tan(dchi/2) before the
waypoint and ends d after it on the next leg (dchi the course change). R is the radius
of a coordinated turn at a nominal bank (TURN_BANK_DEG) and the highest ground speed
expected (TURN_GS_FACTOR times the airspeed), shrunk when the legs are too short for it. The arc is tracked by the same L1 law as a
loiter circle, so the vehicle rolls out on the new leg instead of overshooting it.

Joins: every other transition onto a leg (after a takeoff, a loiter, a DO_JUMP whose
turn could not be filleted, RTL, a mode change back to AUTO, MISSION_SET_CURRENT) is
planned as a turn-straight-turn path of the same radius from the current position and
course to an entry point on the leg (``dubins.join_leg``), so a leg joined at a large
angle is rolled out on like a fillet instead of being captured by L1 from its start.
The leg stays the one the mission draws (from the previous item to this one).

Acceptance: a waypoint counts when the vehicle is within its acceptance radius (param2,
else WP_RADIUS), in whatever phase it is (on the leg, on a join, at the start when it is
already there, as ArduPlane counts a waypoint it is within WP_RADIUS of), or when the
projection passes the end of the leg (less d) while on the leg. On a leg the radius
only stands in for a fillet where there is none, and at most half the leg.

Altitude along a leg follows a straight slope from the previous altitude target to the
waypoint's, so a change of height is flown as a climb or descent along the leg; a step
steeper than the vehicle can fly (its demand slew rate over the ground speed along the
leg) is flown at the steepest slope it can, and the height still missing carries over
to the next leg. Items that cannot be flown as written are flown as ArduPilot would and
said once (STATUSTEXT warnings in ``notices``): a loiter radius under the minimum turn
radius, a speed outside the airframe's limits, a step too steep for its leg.

Latitude and longitude 0 mean "here" (the position when the item starts) for the
navigation items ArduPlane reads so, and then altitude 0 means the current altitude; a
loiter's relative altitude 0 means the current altitude (ArduPilot's Location::sanitize).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..geo import LocalFrame, wrap_pi
from ..mission.items import (MAV_CMD_CONDITION_DELAY, MAV_CMD_CONDITION_DISTANCE,
                             MAV_CMD_CONDITION_YAW, MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_JUMP,
                             MAV_CMD_DO_SET_HOME, MAV_CMD_NAV_DELAY, MAV_CMD_NAV_LOITER_TIME,
                             MAV_CMD_NAV_LOITER_TO_ALT, MAV_CMD_NAV_LOITER_TURNS,
                             MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                             MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LAND,
                             MAV_CMD_DO_LAND_START, Mission, MissionItem)
from . import dubins
from .landing import Landing
from .l1 import G

RELATIVE_FRAMES = (3, 6, 11)  # GLOBAL_RELATIVE_ALT, GLOBAL_RELATIVE_ALT_INT, TERRAIN (as rel.)

LOITER_COMMANDS = (MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_LOITER_TURNS, MAV_CMD_NAV_LOITER_TIME,
                   MAV_CMD_NAV_LOITER_TO_ALT)
NAV_ITEMS = (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_RETURN_TO_LAUNCH,
             MAV_CMD_NAV_DELAY, MAV_CMD_NAV_LAND) + LOITER_COMMANDS
SEV_WARNING, SEV_NOTICE, SEV_INFO = 4, 5, 6   # MAV_SEVERITY

# no join is planned onto a leg the vehicle already flies: this close to its line and
# its course (the end of a fillet lands well within both)
JOIN_XTRACK_M = 10.0
JOIN_COURSE_RAD = math.radians(20.0)
LOITER_ALT_TOL_M = 5.0          # NAV_LOITER_TO_ALT: the altitude is reached this close
SLOPE_MARGIN = 0.9              # of the steepest slope, for the steepest slope flown


@dataclass(frozen=True, slots=True)
class NavTarget:
    kind: str                    # "idle" | "takeoff" | "line" | "loiter" | "direct"
    seq: int                     # mission item being flown
    leg_id: int                  # increments at every new leg/loiter (for scoring)
    alt_m: float                 # altitude target, MSL [m]
    airspeed_mps: float
    a_ne: tuple = (0.0, 0.0)     # line start [m, NE of home]
    b_ne: tuple = (0.0, 0.0)     # line end
    c_ne: tuple = (0.0, 0.0)     # loiter centre
    radius_m: float = 0.0
    direction: int = 1           # +1 clockwise
    pitch_min_rad: float = 0.0   # takeoff climb pitch
    heading_rad: float = 0.0     # takeoff heading hold
    land: str = ""               # NAV_LAND phase: "approach" | "flare" | "rollout" | "ground" (landing.py)
    climb_mps: float | None = None   # flare: the climb-rate demand (negative: sink)


class MissionSequencer:
    def __init__(self, mission: Mission, frame: LocalFrame, params):
        self.params = params
        self.frame = frame
        self.notices: list[tuple[float, int, str]] = []   # (t_s, MAV_SEVERITY, text): STATUSTEXT
        self.home_request = None  # DO_SET_HOME: (lat_rad, lon_rad, alt_m) or "here"
        self.load(mission)

    # ------------------------------------------------------------------ set-up ---
    def load(self, mission: Mission) -> None:
        self.mission = mission
        self.items: tuple[MissionItem, ...] = tuple(mission.items)
        self.home_alt_m = self.frame.alt0_m
        self.jump_counts: dict[int, int] = {}
        self.reached: list[tuple[int, int]] = []   # (t_us, seq) of every item reached
        self.reached_seqs: set[int] = set()
        self.transitions: list[tuple[int, int, str]] = []  # (t_us, seq, "join"|"fillet") planned
        self.current = 1 if len(self.items) > 1 else 0
        self.leg_id = 0
        self.airspeed_mps = self.params["TRIM_ARSPD"]
        self.min_groundspeed_mps = 0.0     # DO_CHANGE_SPEED type 1
        self.climb_rate_mps: float | None = None   # DO_CHANGE_SPEED type 2 (None: the vehicle's)
        self.sink_rate_mps: float | None = None    # type 3
        self.finished = False          # past the last item
        self.rtl_established = False
        self._rtl_radius: float | None = None
        self.launched = False          # left the ground (an item counted on the launcher is not)
        self.landing: Landing | None = None   # the NAV_LAND approach being flown
        self.land_complete = False     # landed at the end of the mission (NAV_LAND)
        self.go_arounds = 0            # approaches abandoned (DO_GO_AROUND, automatic abort)
        self._on_circle_since_us = None
        self._prev_wp_ne: tuple | None = None
        self._prev_alt: float | None = None
        self._takeoff_heading: float | None = None
        self._takeoff_start_ne: tuple | None = None
        self._v_ned = np.zeros(3)
        self._airspeed_mps = 0.0
        self._wind_ne = (0.0, 0.0)
        self._alt_m = self.home_alt_m
        self._do_pending: list[int] = []      # DO_/CONDITION_ items run alongside the nav item
        self._cond_start_us: int | None = None
        self._warned: set = set()
        self._path: list = []          # segments being flown (a fillet, a join)
        self._path_kind = ""
        self._seg_start = True
        self._seg_angle = 0.0
        self._seg_last: float | None = None
        self._start_item()

    def _start_item(self) -> None:
        """The current item starts afresh (new item, or re-entered)."""
        self._leg_start: tuple | None = None
        self._leg_start_alt: float | None = None
        self._leg_along0: float | None = None
        self._joined = False           # the leg's join has been planned (or needs none)
        self._skip_join = False        # a fillet has just put the vehicle on this leg
        self._join_past = False        # the join rolls out past the start of the next turn
        self._join_run, self._join_last_p = 0.0, None   # distance flown on the join
        self._join_alt_now: float | None = None          # its altitude demand
        self._nav_pos: tuple | None = None     # (b_ne, alt) resolved for the current item
        self._loiter_angle = 0.0
        self._loiter_last_bearing: float | None = None
        self._loiter_start_us: int | None = None
        self._loiter_captured = False
        self._loiter_radius: float | None = None
        self._alt_reached = False
        if getattr(self, "landing", None) is not None and self.landing.phase == "approach":
            self.landing = None        # an approach left (a new item, a jump): flown afresh

    def set_current(self, seq: int) -> None:
        """Jump to item ``seq`` (MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT)."""
        self.current = seq
        self.finished = False
        self.rtl_established = False
        self._on_circle_since_us = None
        self.leg_id += 1
        self._path = []
        self._do_pending = []
        self.landing = None            # a landing jumped to is flown from its approach
        self._start_item()

    def resume(self) -> None:
        """Back to AUTO after another mode: the current item goes on, but its leg is
        joined again from wherever the vehicle now is (a planned turn, not L1's capture)."""
        self._path = []
        self._joined = False
        self._skip_join = False
        self._leg_along0 = None
        self._loiter_captured = False
        self._loiter_last_bearing = None
        if self.landing is not None and self.landing.phase in ("flare", "go_around"):
            # left in the flare or the go-around's climb: the approach is flown afresh
            # (joined from here; too low or off it below LAND_AB_CHK_ALT, it is abandoned)
            self.landing = None
        self.leg_id += 1

    def move_home(self, frame: LocalFrame) -> None:
        """Home moved (DO_SET_HOME, SET_HOME): the points kept in the old home's frame
        are carried over to the new one."""
        old = self.frame
        shift = frame.to_ned_fast(old.lat0_rad, old.lon0_rad, frame.alt0_m)
        dn, de = float(shift[0]), float(shift[1])

        def mv(p):
            return None if p is None else (p[0] + dn, p[1] + de)

        self._prev_wp_ne = mv(self._prev_wp_ne)
        self._leg_start = mv(self._leg_start)
        self._takeoff_start_ne = mv(self._takeoff_start_ne)
        if self._nav_pos is not None:
            self._nav_pos = (mv(self._nav_pos[0]), self._nav_pos[1])
        self._path = []
        self._joined = False
        self.frame = frame
        self.home_alt_m = frame.alt0_m

    def say(self, t_us: int, severity: int, text: str, key=None) -> None:
        """A STATUSTEXT-ready event; with ``key``, said once."""
        if key is not None:
            if key in self._warned:
                return
            self._warned.add(key)
        self.notices.append((t_us * 1e-6, severity, text))

    def item_alt_m(self, item: MissionItem) -> float:
        """Item altitude as MSL [m]."""
        if item.frame in RELATIVE_FRAMES:
            return self.home_alt_m + item.z_alt_m
        return item.z_alt_m

    def item_ne(self, item: MissionItem) -> tuple[float, float]:
        p = self.frame.to_ned_fast(math.radians(item.x_lat_deg), math.radians(item.y_lon_deg),
                                   self.frame.alt0_m)
        return float(p[0]), float(p[1])

    @staticmethod
    def _here(item: MissionItem) -> bool:
        return item.x_lat_deg == 0 and item.y_lon_deg == 0

    def _resolve(self, item: MissionItem, p_ne, alt_m: float) -> tuple[tuple, float]:
        """(position NE, altitude MSL) of a navigation item, read as ArduPlane reads it
        when the item starts: latitude and longitude 0 mean here, and then altitude 0
        means the current altitude; a loiter's relative altitude 0 means the current
        altitude."""
        if self._nav_pos is None:
            if self._here(item):
                b = (float(p_ne[0]), float(p_ne[1]))
                alt = alt_m if item.z_alt_m == 0 else self.item_alt_m(item)
            else:
                b = self.item_ne(item)
                alt = self.item_alt_m(item)
                if item.command in LOITER_COMMANDS and item.z_alt_m == 0 \
                        and item.frame in RELATIVE_FRAMES:
                    alt = self._prev_alt if self._prev_alt is not None else alt_m
            self._nav_pos = (b, alt)
        return self._nav_pos

    @property
    def total_items(self) -> int:
        return max(len(self.items) - 1, 0)

    # ------------------------------------------------------------- turn sizes ---
    def turn_radius_m(self, wind: bool = False) -> float:
        """Radius of the fillets: the nominal bank at TURN_GS_FACTOR times the airspeed;
        with ``wind`` (the joins, which may turn through any course), at the airspeed
        plus the wind speed if that is more."""
        v = self.airspeed_mps * self.params["TURN_GS_FACTOR"]
        if wind:
            v = max(v, self.airspeed_mps + math.hypot(*self._wind_ne))
        return v * v / (G * math.tan(math.radians(self.params["TURN_BANK_DEG"])))

    def min_turn_radius_m(self, wind_ne=None) -> float:
        """The tightest circle the vehicle can hold over the ground: the bank limit at
        the highest ground speed (the airspeed plus the wind)."""
        w = self._wind_ne if wind_ne is None else wind_ne
        v = self.airspeed_mps + math.hypot(float(w[0]), float(w[1]))
        return v * v / (G * math.tan(math.radians(self.params["ROLL_LIMIT_DEG"])))

    def home_loiter_radius_m(self, t_us: int) -> float:
        """The loiter over home (RTL): LOITER_RAD, or the minimum turn radius if that is
        more (said once), fixed when first flown."""
        if self._rtl_radius is None:
            r, r_min = self.params["LOITER_RAD"], self.min_turn_radius_m()
            if r < r_min:
                self.say(t_us, SEV_WARNING, f"RTL loiter: LOITER_RAD {r:.0f} m below the minimum "
                                            f"turn radius; flown at {r_min:.0f} m")
                r = r_min
            self._rtl_radius = r
        return self._rtl_radius

    def _groundspeed_along(self, u) -> float:
        """Ground speed along the unit direction u at the commanded airspeed in the
        estimated wind (the wind triangle)."""
        wn, we = self._wind_ne
        w_along = wn * u[0] + we * u[1]
        w_cross = -wn * u[1] + we * u[0]
        v = self.airspeed_mps
        return w_along + math.sqrt(max(v * v - w_cross * w_cross, 1.0))

    # ---------------------------------------------------------------- stepping ---
    def _fillet(self, a_ne, b_ne):
        """The turn arc at B towards the next leg: (d, arc) with arc a path segment, or
        (0, None) when no turn is to be filleted."""
        nxt = self._next_nav_point()
        if nxt is None:
            return 0.0, None
        l1 = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        l2 = math.hypot(nxt[0] - b_ne[0], nxt[1] - b_ne[1])
        if l1 < 1.0 or l2 < 1.0:
            return 0.0, None
        u1 = ((b_ne[0] - a_ne[0]) / l1, (b_ne[1] - a_ne[1]) / l1)
        u2 = ((nxt[0] - b_ne[0]) / l2, (nxt[1] - b_ne[1]) / l2)
        cross = u1[0] * u2[1] - u1[1] * u2[0]
        dchi = math.atan2(cross, u1[0] * u2[0] + u1[1] * u2[1])
        if abs(dchi) < math.radians(5.0):
            return 0.0, None
        r = self.turn_radius_m()
        t = math.tan(0.5 * abs(dchi))
        d = min(r * t, 0.5 * l2, 0.5 * l1)  # each leg shares its length between its two turns
        r = d / t
        v_air = self.airspeed_mps
        r_min = v_air * v_air / (G * math.tan(math.radians(self.params["ROLL_LIMIT_DEG"])))
        if r < r_min:
            # legs too short for a turn this sharp: no arc can be flown; the next leg is
            # joined by a planned turn once the waypoint is reached
            return 0.0, None
        direction = 1 if dchi > 0 else -1
        t1 = (b_ne[0] - d * u1[0], b_ne[1] - d * u1[1])
        centre = (t1[0] - direction * r * u1[1], t1[1] + direction * r * u1[0])
        return d, ("arc", centre, r, direction, abs(dchi), t1)

    def _start_path(self, segments, kind: str, t_us: int = 0) -> None:
        self._path = list(segments)
        self._path_kind = kind
        self.transitions.append((t_us, self.current, kind))
        self._seg_start = True
        self.leg_id += 1

    def _fly_path(self, p_ne, alt: float, seq: int) -> NavTarget | None:
        """The target on the planned path, or None once it has been flown."""
        while self._path:
            seg = self._path[0]
            if seg[0] == "arc":
                _, centre, r, direction, angle, start = seg
                bearing = math.atan2(p_ne[1] - centre[1], p_ne[0] - centre[0])
                if self._seg_start:
                    # the turn counted from where the vehicle starts it: a vehicle that
                    # lags its arc turns the whole angle before it is handed to L1
                    self._seg_angle = 0.0
                    self._seg_last = bearing
                    self._seg_start = False
                self._seg_angle += direction * wrap_pi(bearing - self._seg_last)
                self._seg_last = bearing
                if self._seg_angle >= angle - 0.02 or self._seg_angle < -0.5 * math.pi:
                    self._next_segment()
                    continue
                return NavTarget("loiter", seq, self.leg_id, alt, self.airspeed_mps,
                                 c_ne=centre, radius_m=r, direction=direction)
            _, a, b = seg
            ln = math.hypot(b[0] - a[0], b[1] - a[1])
            along = ((p_ne[0] - a[0]) * (b[0] - a[0]) + (p_ne[1] - a[1]) * (b[1] - a[1])) / ln
            self._seg_start = False
            if along >= ln - 0.5:
                self._next_segment()
                continue
            return NavTarget("direct", seq, self.leg_id, alt, self.airspeed_mps, a_ne=a, b_ne=b)
        return None

    def _next_segment(self) -> None:
        self._path.pop(0)
        self._seg_start = True
        self.leg_id += 1

    def _advance(self, t_us: int, to_seq: int | None = None) -> None:
        seq = self.current
        if self._alt_m - self.home_alt_m > 2.0:
            self.launched = True
        self.reached.append((t_us, seq))
        self.reached_seqs.add(seq)
        if self._do_pending:
            names = ", ".join(f"#{i}" for i in self._do_pending)
            self.say(t_us, SEV_INFO, f"Item #{seq} done before its conditions: {names} skipped")
            self._do_pending = []
        self.current = seq + 1 if to_seq is None else to_seq
        self.leg_id += 1
        self._start_item()
        self._collect_do_items(t_us)

    def _collect_do_items(self, t_us: int) -> None:
        """Move ``current`` past the DO_/CONDITION_ items to the next navigation item,
        following DO_JUMPs; the items passed run alongside it (``_service_do``), as
        ArduPilot runs the commands after a navigation command while flying the next."""
        for _ in range(len(self.items) * 4 + 8):  # bounded: DO_JUMP loops cannot hang
            if self.current >= len(self.items):
                self.finished = True
                return
            item = self.items[self.current]
            if item.command == MAV_CMD_DO_JUMP:
                target, repeat = int(item.param1), int(item.param2)
                done = self.jump_counts.get(item.seq, 0)
                self.reached_seqs.add(item.seq)
                if repeat < 0 or done < repeat:
                    self.jump_counts[item.seq] = done + 1
                    self.reached.append((t_us, item.seq))
                    self.current = target
                else:
                    self.current += 1
            elif item.command in NAV_ITEMS:
                return
            else:
                self._do_pending.append(item.seq)
                self.current += 1

    def _service_do(self, t_us: int, p_ne, b_ne) -> None:
        """Run the pending DO_/CONDITION_ items in order; a condition holds back the
        items after it until it is met."""
        while self._do_pending:
            item = self.items[self._do_pending[0]]
            cmd = item.command
            if cmd == MAV_CMD_CONDITION_DELAY:
                if self._cond_start_us is None:
                    self._cond_start_us = t_us
                if (t_us - self._cond_start_us) * 1e-6 < max(item.param1, 0.0):
                    return
            elif cmd == MAV_CMD_CONDITION_DISTANCE:
                if b_ne is None or math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1]) >= max(item.param1, 0.0):
                    return
            elif cmd == MAV_CMD_CONDITION_YAW:
                self.say(t_us, SEV_INFO, f"CONDITION_YAW #{item.seq} ignored: a plane flies its course")
            elif cmd == MAV_CMD_DO_CHANGE_SPEED:
                self._change_speed(t_us, item)
            elif cmd == MAV_CMD_DO_LAND_START:
                pass           # a marker: where RTL_AUTOLAND and a go-around join the landing
            elif cmd == MAV_CMD_DO_SET_HOME:
                if item.param1 == 1 or self._here(item):
                    self.home_request = "here"
                else:
                    self.home_request = (math.radians(item.x_lat_deg), math.radians(item.y_lon_deg),
                                         self.item_alt_m(item))
            else:
                self.say(t_us, SEV_WARNING, f"Skipping unsupported command #{item.seq} ({cmd})")
            self._do_pending.pop(0)
            self._cond_start_us = None
            self.reached.append((t_us, item.seq))
            self.reached_seqs.add(item.seq)

    def change_speed(self, t_us: int, speed_type: int, speed: float, throttle: float = -1.0) -> str | None:
        """DO_CHANGE_SPEED: type 0 airspeed, 1 ground speed (the airspeed is raised so the
        ground speed along the course is at least this, as ArduPlane's MIN_GNDSPD), 2
        climb rate, 3 sink rate (the altitude slopes flown), each clamped to what the
        airframe can do, with a warning when clamped. Speed -1: no change; -2
        (airspeed): back to TRIM_ARSPD. A throttle is not used (the airspeed loop sets
        it). Returns a refusal reason or None."""
        p = self.params
        if speed_type == 0:
            if speed == -2:
                self.airspeed_mps = p["TRIM_ARSPD"]
            elif speed > 0:
                lo, hi = p["ARSPD_FBW_MIN"], p["ARSPD_FBW_MAX"]
                v = min(max(speed, lo), hi)
                if v != speed:
                    self.say(t_us, SEV_WARNING, f"Airspeed {speed:g} m/s outside {lo:g}-{hi:g}: {v:g} m/s flown")
                self.airspeed_mps = v
        elif speed_type == 1:
            if speed >= 0:
                self.min_groundspeed_mps = speed
        elif speed_type in (2, 3):
            if speed > 0:
                name = "CLMB_MAX" if speed_type == 2 else "SINK_MAX"
                top = p["DEM_CLMB_FRAC"] * p[name]
                v = min(speed, top)
                if v != speed:
                    self.say(t_us, SEV_WARNING, f"{'Climb' if speed_type == 2 else 'Sink'} rate "
                                                f"{speed:g} m/s above the airframe's {top:.2g}: {v:.2g} m/s flown")
                if speed_type == 2:
                    self.climb_rate_mps = v
                else:
                    self.sink_rate_mps = v
        else:
            return f"speed type {speed_type} unknown"
        if throttle is not None and throttle > 0:
            self.say(t_us, SEV_INFO, "DO_CHANGE_SPEED throttle ignored: the airspeed loop sets the throttle")
        return None

    def _change_speed(self, t_us: int, item: MissionItem) -> None:
        self.change_speed(t_us, int(item.param1), item.param2, item.param3)

    def commanded_airspeed_mps(self, chi: float | None) -> float:
        """The airspeed demand: the set airspeed, raised to hold the minimum ground
        speed (DO_CHANGE_SPEED type 1) along the course chi in the estimated wind."""
        v = self.airspeed_mps
        gmin = self.min_groundspeed_mps
        if gmin > 0 and chi is not None:
            wn, we = self._wind_ne
            u = (math.cos(chi), math.sin(chi))
            w_along = wn * u[0] + we * u[1]
            w_cross = -wn * u[1] + we * u[0]
            need = math.hypot(gmin - w_along, w_cross)
            v = min(max(v, need), self.params["ARSPD_FBW_MAX"])
        return v

    def update(self, t_us: int, p_ned: np.ndarray, v_ned: np.ndarray, heading_rad: float,
               alt_m: float, wind_ne=None, airspeed_mps: float | None = None) -> NavTarget:
        tgt = self._update(t_us, p_ned, v_ned, heading_rad, alt_m, wind_ne, airspeed_mps)
        if self.min_groundspeed_mps > 0 and tgt.kind != "takeoff":
            chi = self._course(v_ned, heading_rad)
            v = self.commanded_airspeed_mps(chi)
            if v != tgt.airspeed_mps:
                tgt = dataclasses.replace(tgt, airspeed_mps=v)
        return tgt

    @staticmethod
    def _course(v_ned, heading_rad: float) -> float:
        vn, ve = float(v_ned[0]), float(v_ned[1])
        return math.atan2(ve, vn) if math.hypot(vn, ve) > 5.0 else heading_rad

    def _update(self, t_us, p_ned, v_ned, heading_rad, alt_m, wind_ne, airspeed_mps=None) -> NavTarget:
        p_ne = (float(p_ned[0]), float(p_ned[1]))
        self._v_ned = v_ned
        if airspeed_mps is not None:
            self._airspeed_mps = airspeed_mps
        if wind_ne is not None:
            self._wind_ne = (float(wind_ne[0]), float(wind_ne[1]))
        if self._prev_alt is None:
            self._prev_alt = alt_m
        self._alt_m = alt_m
        if self.current < len(self.items) and self.items[self.current].command not in NAV_ITEMS \
                and not self.finished:
            self._collect_do_items(t_us)
        if self.finished or self.current >= len(self.items):
            self.finished = True
            self._service_do(t_us, p_ne, None)
            return self._rtl_loiter(t_us, p_ne, alt_m)
        item = self.items[self.current]
        cmd = item.command
        chi = self._course(v_ned, heading_rad)
        if self._do_pending:
            # the DO items before this navigation item run first (a condition holds back
            # those after it): CONDITION_DISTANCE measures to this item's place
            b = None
            if cmd in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LAND) or cmd in LOITER_COMMANDS:
                b = self._resolve(item, p_ne, alt_m)[0]
            elif cmd == MAV_CMD_NAV_RETURN_TO_LAUNCH:
                b = (0.0, 0.0)
            self._service_do(t_us, p_ne, b)
        if cmd == MAV_CMD_NAV_TAKEOFF:
            tgt = self._takeoff(t_us, item, p_ne, heading_rad, alt_m)
        elif cmd == MAV_CMD_NAV_WAYPOINT:
            tgt = self._waypoint(t_us, item, p_ne, chi, alt_m)
        elif cmd in LOITER_COMMANDS:
            tgt = self._loiter(t_us, item, p_ne, chi, alt_m)
        elif cmd == MAV_CMD_NAV_RETURN_TO_LAUNCH:
            tgt = self._rtl(t_us, item, p_ne, chi, alt_m)
        elif cmd == MAV_CMD_NAV_LAND:
            tgt = self._land(t_us, item, p_ne, chi, alt_m)
        elif cmd == MAV_CMD_NAV_DELAY:
            # ArduPlane does not delay while armed (a plane cannot stop): done at once
            self.say(t_us, SEV_INFO, f"NAV_DELAY #{item.seq}: no delay in flight")
            self._advance(t_us)
            return self._update(t_us, p_ned, v_ned, heading_rad, alt_m, None)
        else:
            # anything else was refused when the mission was loaded; skip defensively
            self.say(t_us, SEV_WARNING, f"Skipping unsupported command #{item.seq} ({cmd})")
            self._advance(t_us)
            return self._update(t_us, p_ned, v_ned, heading_rad, alt_m, None)
        if tgt is None:   # the item completed: go on with the next
            return self._update(t_us, p_ned, v_ned, heading_rad, alt_m, None)
        return tgt

    def _takeoff(self, t_us, item, p_ne, heading_rad, alt_m) -> NavTarget | None:
        if self._takeoff_heading is None:
            self._takeoff_heading = heading_rad
        if self._takeoff_start_ne is None:
            self._takeoff_start_ne = p_ne
        target = self.item_alt_m(item)
        if alt_m >= target - self.params["TKOFF_ALT_TOL"]:
            self._prev_alt = target
            # the next leg starts at the takeoff point (the item's location when it has
            # one, else where the takeoff began): the line the mission's author drew; the
            # vehicle joins it from wherever the climb ended
            self._prev_wp_ne = self._takeoff_start_ne if self._here(item) else self.item_ne(item)
            self._advance(t_us)
            return None
        pitch = math.radians(item.param1) if item.param1 > 0 else math.radians(self.params["TKOFF_PITCH"])
        return NavTarget("takeoff", item.seq, self.leg_id, target, self.airspeed_mps,
                         pitch_min_rad=pitch, heading_rad=self._takeoff_heading)

    def _next_nav_point(self):
        """Where the leg after the current waypoint goes, following a DO_JUMP that
        will still be taken."""
        i = self.current + 1
        counts = dict(self.jump_counts)
        for _ in range(len(self.items) + 4):
            if i >= len(self.items):
                return (0.0, 0.0)  # end of mission: RTL to home
            it = self.items[i]
            if it.command == MAV_CMD_DO_JUMP:
                done = counts.get(it.seq, 0)
                if int(it.param2) < 0 or done < int(it.param2):
                    counts[it.seq] = done + 1
                    i = int(it.param1)
                else:
                    i += 1
                continue
            if it.command not in NAV_ITEMS:
                i += 1
                continue
            if it.command == MAV_CMD_NAV_RETURN_TO_LAUNCH:
                return (0.0, 0.0)
            if it.command in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LAND) and not self._here(it):
                return self.item_ne(it)
            return None  # loiters etc.: no anticipation
        return None

    def _accept_radius(self, item) -> float:
        acc = item.param2 if item.command == MAV_CMD_NAV_WAYPOINT else 0.0
        return acc if acc > 0 else self.params["WP_RADIUS"]

    def _leg(self, t_us, seq, a_ne, b_ne, p_ne, chi, accept, s_max, alt_b):
        """Fly the leg A->B: plan its join, fly the join, then the leg; None once B is
        reached (within ``accept`` of it in any phase)."""
        dist = math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1])
        length = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        if dist <= accept and not self._joined:
            return None   # already there when the item starts: counts at once
        if length > 1e-3:
            tn, te = (b_ne[0] - a_ne[0]) / length, (b_ne[1] - a_ne[1]) / length
            along = (p_ne[0] - a_ne[0]) * tn + (p_ne[1] - a_ne[1]) * te
            xt = (p_ne[0] - a_ne[0]) * -te + (p_ne[1] - a_ne[1]) * tn
        else:
            along = xt = 0.0
        if not self._joined:
            self._joined = True
            if length <= 1e-3:
                a_ne = p_ne   # a point, not a leg: the leg from here
                self._leg_start = a_ne
            elif along >= length and abs(xt) <= accept:
                return None   # already past it, within its radius of its line: passed
            elif not self._skip_join and not dubins.on_leg(p_ne, chi, a_ne, b_ne, JOIN_XTRACK_M,
                                                           JOIN_COURSE_RAD):
                plan = self._plan_join(p_ne, chi, a_ne, b_ne, s_max)
                if plan is not None:
                    self._start_path(plan[2], "join", t_us)
                    self._join_run, self._join_last_p = 0.0, None
                    # rolling out past where the next turn starts: B is passed on the
                    # way, and counted there (within its radius)
                    self._join_past = plan[0] > s_max + 1e-6
        if self._path:
            alt = self._leg_start_alt
            if self._path_kind == "join":
                alt = self._join_alt(t_us, seq, p_ne, a_ne, b_ne, alt_b)
                if self._join_past and dist <= accept:
                    return None
            tgt = self._fly_path(p_ne, alt, seq)
            if tgt is not None:
                return tgt
            if self._path_kind == "join":
                self._leg_start_alt = alt    # the leg's slope goes on from here
        return "leg"

    def _steepest_slope(self, dh: float, a_ne, b_ne) -> float:
        """The steepest slope the vehicle flies along A->B: its demand slew rate (or the
        DO_CHANGE_SPEED climb / sink rate) over the ground speed along the leg."""
        p = self.params
        rate = (self.climb_rate_mps or p["DEM_CLMB_FRAC"] * p["CLMB_MAX"]) if dh > 0 \
            else (self.sink_rate_mps or p["DEM_CLMB_FRAC"] * p["SINK_MAX"])
        ln = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        u = ((b_ne[0] - a_ne[0]) / ln, (b_ne[1] - a_ne[1]) / ln) if ln > 1e-3 else (1.0, 0.0)
        return SLOPE_MARGIN * rate / max(self._groundspeed_along(u), 1.0)

    def _join_alt(self, t_us, seq, p_ne, a_ne, b_ne, alt_b) -> float:
        """The altitude demand on a join: towards the waypoint's at the steepest slope,
        by the distance flown since the join began (a plane climbs while it turns)."""
        last = self._join_last_p
        self._join_last_p = p_ne
        if last is not None:
            self._join_run += math.hypot(p_ne[0] - last[0], p_ne[1] - last[1])
        dh = alt_b - self._leg_start_alt
        if abs(dh) < 1e-3:
            return alt_b
        slope = self._steepest_slope(dh, a_ne, b_ne)
        self._join_alt_now = self._leg_start_alt + math.copysign(min(abs(dh), slope * self._join_run), dh)
        return self._join_alt_now

    def _plan_join(self, p_ne, chi, a_ne, b_ne, s_max):
        """The join onto A->B, planned at radii from the join radius (the nominal bank at
        the airspeed plus the wind) down to the radius of the bank midway between the
        nominal and the limit at that speed (as a fillet shrinks where legs are short).
        Of the joins that roll out on the leg before the next turn starts without
        crossing it, the widest no more than a
        quarter longer than the shortest (a wide turn is tracked more closely; a tight
        one saves a long loop where the leg must be joined the other way round); if none
        does, the best at the tightest radius (which may roll out past that point)."""
        r = self.turn_radius_m(wind=True)
        p = self.params
        v = self.airspeed_mps + math.hypot(*self._wind_ne)
        bank = math.radians(0.5 * (p["TURN_BANK_DEG"] + p["ROLL_LIMIT_DEG"]))
        r_floor = min(v * v / (G * math.tan(bank)), r)
        valid, plan = [], None
        while True:
            plan = dubins.join_leg(p_ne, chi, a_ne, b_ne, r, s_max)
            if plan is None:
                return None
            if plan[0] <= s_max + 1e-6 and plan[3] <= 2.0:
                valid.append(plan)             # widest first
            if r <= r_floor:
                break
            r = max(0.8 * r, r_floor)
        if not valid:
            return plan
        shortest = min(p[1] for p in valid)
        return next(p for p in valid if p[1] <= 1.25 * shortest)

    def _waypoint(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        b_ne, alt_b = self._resolve(item, p_ne, alt_m)
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            self._leg_start_alt = self._prev_alt
        a_ne = self._leg_start
        accept = self._accept_radius(item)
        d_turn, arc = self._fillet(a_ne, b_ne)
        length = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        r = self._leg(t_us, item.seq, a_ne, b_ne, p_ne, chi, accept, length - d_turn, alt_b)
        if r is None:
            alt = alt_b
            if self._join_alt_now is not None and abs(alt_b - self._join_alt_now) > 0.5:
                # counted on the way onto its leg, short of its height: the rest of the
                # step carries over to the next leg, flown at the steepest slope
                alt = self._join_alt_now
                self.say(t_us, SEV_WARNING, f"Item #{item.seq}: {abs(alt_b - alt):.0f} m of its "
                                            f"height step still to fly at the steepest slope",
                         key=("slope", item.seq))
            self._reach(t_us, b_ne, alt)
            return None
        if r != "leg":
            return r
        a_ne = self._leg_start
        length = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        along = 0.0
        if length > 1e-3:
            along = ((p_ne[0] - a_ne[0]) * (b_ne[0] - a_ne[0]) + (p_ne[1] - a_ne[1]) * (b_ne[1] - a_ne[1])) / length
        dist = math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1])
        alt, steep = self._slope_alt(t_us, item.seq, a_ne, b_ne, along, length, d_turn, alt_b)
        # the acceptance radius only stands in for the arc where there is none
        if along >= length - d_turn or (arc is None and dist <= min(accept, 0.5 * length)):
            xtrack = ((p_ne[0] - a_ne[0]) * -(b_ne[1] - a_ne[1]) + (p_ne[1] - a_ne[1]) * (b_ne[0] - a_ne[0])) / length if length > 1e-3 else 0.0
            self._reach(t_us, b_ne, alt if steep else alt_b)
            if arc is not None and along - (length - d_turn) < 0.3 * arc[2] \
                    and abs(xtrack) < 0.3 * arc[2]:
                # (far off the leg, or far past the arc's start, the arc would start
                # from the wrong place: the next leg is joined by a planned turn instead)
                self._start_path([arc], "fillet", t_us)
                self._skip_join = True
            return None
        return NavTarget("line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne=a_ne, b_ne=b_ne)

    def _reach(self, t_us, b_ne, alt) -> None:
        self._prev_wp_ne = b_ne
        self._prev_alt = alt
        self._path = []
        self._advance(t_us)

    def _slope_alt(self, t_us, seq, a_ne, b_ne, along, length, d_turn, alt_b) -> tuple[float, bool]:
        """The altitude demand on the leg and whether the step is too steep: a straight
        slope from where the leg was joined (the end of the previous turn) to where the
        turn onto the next leg starts; a step steeper over the whole leg than the
        vehicle can fly (its demand slew rate over the ground speed along the leg) is
        flown at that steepest slope from the leg's start, and the height still missing
        at the waypoint carries over to the next leg."""
        if self._leg_along0 is None:
            self._leg_along0 = min(max(along, 0.0), max(length - d_turn, 0.0))
        ramp = length - d_turn - self._leg_along0
        dh = alt_b - self._leg_start_alt
        frac = min(max((along - self._leg_along0) / ramp, 0.0), 1.0) if ramp > 1e-3 else 1.0
        alt = self._leg_start_alt + dh * frac
        if abs(dh) > 0.5 and length > 1e-3:
            slope = self._steepest_slope(dh, a_ne, b_ne)
            if abs(dh) > slope * length:
                self.say(t_us, SEV_WARNING,
                         f"Item #{seq}: {abs(dh):.0f} m {'climb' if dh > 0 else 'descent'} over "
                         f"{length:.0f} m too steep; flown at {100 * slope:.1f} %", key=("slope", seq))
                return self._leg_start_alt + math.copysign(slope * max(along, 0.0), dh), True
        return alt, False

    def _loiter_params(self, t_us, item) -> tuple[float, int]:
        r = item.param2 if item.command == MAV_CMD_NAV_LOITER_TO_ALT else item.param3
        if math.isnan(r):
            r = 0.0
        radius = abs(r) if abs(r) > 1.0 else self.params["LOITER_RAD"]
        direction = -1 if r < 0 else 1
        if self._loiter_radius is None:
            r_min = self.min_turn_radius_m()
            if radius < r_min:
                self.say(t_us, SEV_WARNING, f"Loiter #{item.seq}: radius {radius:.0f} m below the "
                                            f"minimum turn radius; flown at {r_min:.0f} m")
                radius = r_min
            self._loiter_radius = radius
        return self._loiter_radius, direction

    def _loiter(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        c_ne, alt = self._resolve(item, p_ne, alt_m)
        radius, direction = self._loiter_params(t_us, item)
        r = math.hypot(p_ne[0] - c_ne[0], p_ne[1] - c_ne[1])
        bearing = math.atan2(p_ne[1] - c_ne[1], p_ne[0] - c_ne[0])
        if not self._loiter_captured and abs(r - radius) < 0.25 * radius + 10.0:
            self._loiter_captured = True
            self._loiter_start_us = t_us
            self._loiter_last_bearing = bearing
        if self._loiter_captured:
            d = wrap_pi(bearing - self._loiter_last_bearing)
            self._loiter_angle += d * direction
            self._loiter_last_bearing = bearing
            done = False
            if item.command == MAV_CMD_NAV_LOITER_TURNS:
                done = self._loiter_angle >= 2 * math.pi * max(item.param1, 0.0)
            elif item.command == MAV_CMD_NAV_LOITER_TIME:
                done = (t_us - self._loiter_start_us) * 1e-6 >= max(item.param1, 0.0)
            elif item.command == MAV_CMD_NAV_LOITER_TO_ALT:
                self._alt_reached = self._alt_reached or abs(alt_m - alt) <= LOITER_ALT_TOL_M
                done = self._alt_reached
            if done:
                self._prev_wp_ne = c_ne
                self._prev_alt = alt
                self._advance(t_us)
                return None
        return NavTarget("loiter", item.seq, self.leg_id, alt, self.airspeed_mps,
                         c_ne=c_ne, radius_m=radius, direction=direction)

    def _land(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        """NAV_LAND (autopilot/guidance/landing.py): join the approach leg from the
        previous waypoint to the land point, then fly it down; the item never counts as
        reached in the air. Once down, the mission is over (``land_complete`` is set by
        the vehicle when it disarms)."""
        b_ne, alt_b = self._resolve(item, p_ne, alt_m)
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            self._leg_start_alt = self._prev_alt
        if self.landing is None:
            a_ne = self._leg_start
            ln = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
            u = ((b_ne[0] - a_ne[0]) / ln, (b_ne[1] - a_ne[1]) / ln) if ln > 1e-3 else (1.0, 0.0)
            self.landing = Landing(self.params, a_ne, b_ne, self._leg_start_alt, alt_b,
                                   self._groundspeed_along(u))
            self.say(t_us, SEV_INFO, f"Landing approach: {ln:.0f} m from {self._leg_start_alt - alt_b:.0f} m, "
                                     f"aim {self.landing.shift_m:.0f} m short")
        land = self.landing
        if land.phase == "go_around":
            return self._go_around_climb(t_us, item, p_ne, alt_m)
        if land.phase == "approach":
            why = land.unsafe(p_ne, alt_m, self._airspeed_mps, t_us)
            if why is not None:
                self.go_around(t_us, f"unsafe approach: {why}")
                return self._go_around_climb(t_us, item, p_ne, alt_m)
            r = self._leg(t_us, item.seq, land.a_ne, land.b_ne, p_ne, chi, 0.0, land.length, alt_b)
            if r is not None and r != "leg":   # joining the approach: at the glide slope's height
                return dataclasses.replace(r, airspeed_mps=land.airspeed_mps,
                                           alt_m=land.glide_alt(land.along(p_ne)))
        alt, climb = land.step(t_us, p_ne, alt_m, self._v_ned, self._airspeed_mps)
        if land.phase != "approach" and land.flare_info is not None and land.flare_us == t_us:
            h, s, v, d = land.flare_info
            self.say(t_us, SEV_INFO, f"Flare {h:.1f} m sink {s:.2f} m/s speed {v:.1f} m/s, {d:.0f} m to go")
        if land.phase == "rollout" and land.touch_us == t_us:
            self.say(t_us, SEV_INFO, "Touchdown")
        if land.phase == "ground" and land.landed_us == t_us:
            self.say(t_us, SEV_INFO, "Landed")
        return NavTarget("line", item.seq, self.leg_id, alt, land.airspeed_mps, a_ne=land.a_ne,
                         b_ne=land.line_end(), land=land.phase, climb_mps=climb)

    def go_around(self, t_us: int, why: str, alt_m: float | None = None) -> str | None:
        """Abandon the approach (MAV_CMD_DO_GO_AROUND, or an unsafe approach): climb
        straight ahead on the approach line to ``alt_m`` above home (else the NAV_LAND's
        param1, else LAND_ABORT_ALT), then fly the landing again (``_go_around_climb``).
        Refused (a reason) when no landing is flown or the aircraft is already down."""
        land = self.landing
        if land is None or self.finished:
            return "no landing in progress"
        if land.phase in ("rollout", "ground"):
            return "already landed"
        if land.phase == "go_around":
            return None
        item = self.items[self.current]
        if alt_m is None or not alt_m > 0:
            alt_m = item.param1 if item.param1 > 0 else self.params["LAND_ABORT_ALT"]
        land.phase = "go_around"
        land.ga_alt = self.home_alt_m + alt_m
        self.go_arounds += 1
        self.leg_id += 1
        self._path = []
        self.say(t_us, SEV_NOTICE, f"Go around ({why}): climbing to {alt_m:.0f} m")
        return None

    def _go_around_climb(self, t_us, item, p_ne, alt_m) -> NavTarget | None:
        """The go-around's climb, on the approach line; at its altitude, the landing is
        flown again: the items after the NAV_LAND if there are any (as ArduPlane goes on
        with the mission), else from the nearest DO_LAND_START before it, else from the
        navigation item before it (the approach's first waypoint)."""
        land = self.landing
        if alt_m >= land.ga_alt - self.params["TKOFF_ALT_TOL"]:
            nxt = item.seq + 1
            if nxt >= len(self.items):
                nxt = self.landing_start_seq(p_ne, before=item.seq)
                if nxt is None:
                    nxt = max((i for i in range(1, item.seq) if self.items[i].command in NAV_ITEMS),
                              default=item.seq)
            self.say(t_us, SEV_INFO, f"Go around complete: landing again from item #{nxt}")
            self._prev_wp_ne = (float(p_ne[0]), float(p_ne[1]))
            self._prev_alt = land.ga_alt
            self.landing = None
            self.current = nxt
            self.leg_id += 1
            self._do_pending = []
            self._start_item()
            self._collect_do_items(t_us)
            return None
        return NavTarget("line", item.seq, self.leg_id, land.ga_alt, self.params["TRIM_ARSPD"],
                         a_ne=land.a_ne, b_ne=land.line_end(), land="go_around")

    def landing_start_seq(self, p_ne, before: int | None = None) -> int | None:
        """The DO_LAND_START nearest to p_ne (NE of home) (of those before item
        ``before`` if given), or None: where RTL_AUTOLAND and a go-around join a landing.
        Its place is its own latitude/longitude, else that of the first navigation item
        with a place after it (AP_Mission's nearest landing sequence, by distance)."""
        best, best_d = None, math.inf
        end = len(self.items) if before is None else before
        for i in range(1, end):
            it = self.items[i]
            if it.command != MAV_CMD_DO_LAND_START:
                continue
            where = it if not self._here(it) else next(
                (n for n in self.items[i + 1:] if n.command in NAV_ITEMS and not self._here(n)
                 and n.command != MAV_CMD_NAV_RETURN_TO_LAUNCH), None)
            if where is None:
                continue
            q = self.item_ne(where)
            d = math.hypot(q[0] - p_ne[0], q[1] - p_ne[1])
            if d < best_d:
                best, best_d = i, d
        return best

    def rtl_alt_m(self) -> float:
        rtl = self.params["RTL_ALT"]
        return self.home_alt_m + rtl if rtl > 0 else self._prev_alt

    def _rtl(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        """Fly the leg to home, then loiter over it (the mission ends there)."""
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            self._leg_start_alt = self._prev_alt
        b_ne = (0.0, 0.0)
        radius = self.home_loiter_radius_m(t_us)
        alt_b = self.rtl_alt_m()
        a0 = self._leg_start
        length0 = math.hypot(a0[0], a0[1])
        r = self._leg(t_us, item.seq, a0, b_ne, p_ne, chi, 1.5 * radius, max(length0 - radius, 0.0), alt_b)
        if r is not None and r != "leg":
            return r
        a_ne = self._leg_start
        length = math.hypot(a_ne[0], a_ne[1])
        dist = math.hypot(p_ne[0], p_ne[1])
        along = ((p_ne[0] - a_ne[0]) * (-a_ne[0]) + (p_ne[1] - a_ne[1]) * (-a_ne[1])) / length if length > 1e-3 else length
        if r is None or dist <= radius * 1.5 or along >= length - radius:
            self._prev_wp_ne = b_ne
            self._prev_alt = alt_b
            self._advance(t_us)
            self.finished = True
            return self._rtl_loiter(t_us, p_ne, alt_b)
        alt, _ = self._slope_alt(t_us, item.seq, a_ne, b_ne, along, length, radius, alt_b)
        return NavTarget("line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne=a_ne, b_ne=b_ne)

    def _rtl_loiter(self, t_us, p_ne, alt_m) -> NavTarget:
        radius = self.home_loiter_radius_m(t_us)
        r = math.hypot(p_ne[0], p_ne[1])
        # established: on the circle (within 20 % of its radius) for the time a quarter
        # turn takes, so the summary and the end of a run see the loiter actually flown
        if abs(r - radius) < 0.2 * radius:
            if self._on_circle_since_us is None:
                self._on_circle_since_us = t_us
            quarter_s = 0.5 * math.pi * radius / max(self.airspeed_mps, 1.0)
            if t_us - self._on_circle_since_us >= quarter_s * 1e6:
                self.rtl_established = True
        elif not self.rtl_established:
            self._on_circle_since_us = None
        alt = self.rtl_alt_m() if self._prev_alt is not None else alt_m
        return NavTarget("loiter", len(self.items), self.leg_id, alt, self.airspeed_mps,
                         c_ne=(0.0, 0.0), radius_m=radius, direction=1)
