"""Fixed-wing mission sequencer: turns the active mission item into a guidance target.

Item 0 is home (ArduPilot convention). Flown: NAV_TAKEOFF, NAV_WAYPOINT,
NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_DELAY,
NAV_RETURN_TO_LAUNCH, NAV_LAND (guidance/landing.py), DO_LAND_START (a marker), DO_JUMP, DO_CHANGE_SPEED (every speed type), DO_SET_HOME,
CONDITION_DELAY, CONDITION_DISTANCE and CONDITION_YAW (ignored with a note, as
ArduPlane does); NAV_SPLINE_WAYPOINT flown as a NAV_WAYPOINT (as ArduPlane flies it);
DO_SET_ROI_LOCATION / DO_SET_ROI / DO_SET_ROI_NONE / DO_SET_ROI_WPNEXT_OFFSET noted for a gimbal the airframe does
not have (said once), and the camera commands of QGroundControl's surveys likewise.
NAV_LOITER_TO_ALT's radius sign is its direction (negative:
counter-clockwise), as for the other loiters.

Leg switching (seed section 1.16, the SLUGS rule): the vehicle's position is projected
onto the leg direction; the waypoint is reached when the projection passes the end of
the leg less a turn-anticipation distance d. The turn itself is flown as a fillet: the
circular arc of radius R tangent to both legs, which starts d = R tan(dchi/2) before the
waypoint and ends d after it on the next leg (dchi the course change). R is the radius
of a coordinated turn at a nominal bank (TURN_BANK_DEG) and the highest ground speed
expected (TURN_GS_FACTOR times the airspeed), shrunk when the legs are too short for it. The arc is tracked by the same L1 law as a
loiter circle, so the vehicle rolls out on the new leg instead of overshooting it; it is
handed over to the next segment the roll's lag (ROLL_LEAD_S, twice that where the next
arc turns the other way) before its end, half the roll flown on each side of the tangent
point.

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
A NaN altitude (MAVLink's "no change"; QGroundControl writes null) is the current
altitude when the item starts.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..geo import LocalFrame, wrap_pi
from ..geo.terrain import height_or
from ..jit import preload
from ..mission.items import (MAV_CMD_CONDITION_DELAY, MAV_CMD_CONDITION_DISTANCE,
                             MAV_CMD_CONDITION_YAW, MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_JUMP,
                             MAV_CMD_DO_SET_HOME, MAV_CMD_NAV_DELAY, MAV_CMD_NAV_LOITER_TIME,
                             MAV_CMD_NAV_LOITER_TO_ALT, MAV_CMD_NAV_LOITER_TURNS,
                             MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                             MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_WAYPOINT, Mission, MissionItem,
                             MAV_CMD_DO_SET_ROI_NONE, MAV_CMD_NAV_SPLINE_WAYPOINT, ROI_COMMANDS,
                             CAMERA_COMMANDS, MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET,
                             MAV_CMD_NAV_LAND, MAV_CMD_DO_LAND_START)
from . import dubins
from .landing import AUTO_ABORTS_MAX, Landing
from .l1 import G

RELATIVE_FRAMES = (3, 6)     # GLOBAL_RELATIVE_ALT(_INT)
TERRAIN_FRAMES = (10, 11)    # GLOBAL_TERRAIN_ALT(_INT)

# (sets: ``in`` is asked every step)
LOITER_COMMANDS = frozenset((MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_LOITER_TURNS, MAV_CMD_NAV_LOITER_TIME,
                             MAV_CMD_NAV_LOITER_TO_ALT))
NAV_ITEMS = frozenset((MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                       MAV_CMD_NAV_DELAY, MAV_CMD_NAV_LAND)) | LOITER_COMMANDS
SEV_WARNING, SEV_NOTICE, SEV_INFO = 4, 5, 6   # MAV_SEVERITY

# no join is planned onto a leg the vehicle already flies: this close to its line and
# its course (the end of a fillet lands well within both)
JOIN_XTRACK_M = 10.0
JOIN_COURSE_RAD = math.radians(20.0)
LOITER_ALT_TOL_M = 5.0          # NAV_LOITER_TO_ALT: the altitude is reached this close
SLOPE_MARGIN = 0.9              # of the steepest slope, for the steepest slope flown
SKIP_CHAIN = 12                 # waypoints of a cluster an arc may turn past
FLY_BACK_MARGIN_M = 10.0        # a waypoint passed within its radius and this much (the
                                # navigation's error) is not flown back to
LOITER_ENTRY_M = 5.0            # the line into a loiter is flown to this far outside its circle
                                # (inside the CAPTURE_M at which its scoring stops)
ARC_FLOOR_SLACK = 0.95          # an arc shrunk to fit its legs is flown down to this
                                # fraction of the radius the bank limit holds over its
                                # courses (a few percent tighter is a moment over the
                                # limit; a third tighter ran 42-58 m wide in 7-10 m/s)
REVERSAL_S = 1.2                # a widened arc that turns the other way from the arc
                                # before it starts this long after it (the bank reversal)
NEAR_MARGIN = 0.8               # an arc that must pass within a radius is planned to pass
                                # within this fraction of it, where the bank limit allows:
NEAR_FLOOR_FACTOR = 1.2         # not tighter for it than this times the arc floor
THROUGH_OFFSET_MAX_FRAC = 0.3   # an arc moved to pass within a radius (_through_arc) runs
                                # at most this fraction of its radius outside the lines,
THROUGH_MAX_TURN = math.radians(90.0)   # on a turn of at most this (past it the vehicle,
                                # flown to the waypoint, heads away along the next line and
                                # loops back onto it from behind: no run beside it)
FILLET_CHECK_US = 1_000_000     # a leg's arc is checked against the wind this often
ROLL_LEAD_S = 0.12               # an arc hands over to the next segment this long (per
                                # change of its bank) before its end: the roll's lag
ROLL_LEAD_MAX_RAD = 0.5         # ... at most this much of its course change
TERRAIN_LEAD_S = 2.0            # terrain following: the ground this far ahead [s of flight]


class NavTarget(NamedTuple):
    """What guidance asks of the control loops, one a step. An immutable record as a
    NamedTuple rather than ``@message`` (autopilot/frozen.py): a tuple is built in one
    call, where a frozen dataclass stores each of these 15 fields through its slot's
    descriptor (about 0.2 us a field); changed copies by ``_replace``. The targets
    built every step pass their fields by position (``NO_NE`` for a point they do not
    use): keywords cost the call a dict, 40 % more than the record itself."""
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
    spd_weight: float = 1.0      # the speed priority's weight (the landing approach: TECS_LAND_SPDWGT)


NO_NE = NavTarget._field_defaults["a_ne"]   # a point a target does not use (the default)
# the targets built by NavTarget's own __new__, without the class call around it
# (type.__call__: about 1 k instructions of the 4 k a target costs; autopilot/frozen.py's
# ``make`` for the same reason): ``_new_target(NavTarget, kind, ...)``
_new_target = NavTarget.__new__


def _path_end(path):
    """Where a planned path ends and on what course [rad]: its last line's end, or its
    last arc's end point."""
    seg = path[-1]
    if seg[0] == "line":
        return seg[2], math.atan2(seg[2][1] - seg[1][1], seg[2][0] - seg[1][0])
    _, centre, r, direction, angle, start = seg
    b = math.atan2(start[1] - centre[1], start[0] - centre[0]) + direction * angle
    return (centre[0] + r * math.cos(b), centre[1] + r * math.sin(b)), b + direction * 0.5 * math.pi


def _passes_within(segments, p, radius: float) -> bool:
    """A planned path comes within ``radius`` of point p."""
    r2 = radius * radius
    return any((n - p[0]) ** 2 + (e - p[1]) ** 2 <= r2 for n, e, _ in dubins.samples(segments))


def _half_turn_tan(u1, u2) -> float:
    """tan of half the turn from unit direction u1 to u2 (a fillet's tangent length
    per metre of radius; large for a reversal)."""
    cross = u1[0] * u2[1] - u1[1] * u2[0]
    dchi = abs(math.atan2(cross, u1[0] * u2[0] + u1[1] * u2[1]))
    return math.tan(min(0.5 * dchi, math.radians(89.0)))


class MissionSequencer:
    def __init__(self, mission: Mission, frame: LocalFrame, params):
        self.params = params
        self.frame = frame
        self.notices: list[tuple[float, int, str]] = []   # (t_s, MAV_SEVERITY, text): STATUSTEXT
        self.terrain = None   # (lat_deg, lon_deg) -> terrain height [m MSL] or None
        self.home_request = None  # DO_SET_HOME: (lat_rad, lon_rad, alt_m) or "here"
        # the nearest rally point for an RTL, or None for home: (lat_deg, lon_deg) of the
        # vehicle -> (lat_deg, lon_deg, alt_m MSL) or None (the vehicle's geofence rules)
        self.rally_point = None
        self.load(mission)
        # the join planner's kernel loaded now, not at the first planned join (autopilot.jit.preload)
        preload(dubins._path_cost, np.zeros((1, 7)), 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0)

    # ------------------------------------------------------------------ set-up ---
    def load(self, mission: Mission) -> None:
        self.mission = mission
        # ArduPlane flies a NAV_SPLINE_WAYPOINT as a NAV_WAYPOINT
        self.items: tuple[MissionItem, ...] = tuple(
            it.replace(command=MAV_CMD_NAV_WAYPOINT, param1=0.0, param2=0.0, param3=0.0, param4=0.0)
            if it.command == MAV_CMD_NAV_SPLINE_WAYPOINT else it for it in mission.items)
        self.home_alt_m = self.frame.alt0_m
        self.roi = None                # DO_SET_ROI_LOCATION: (lat_deg, lon_deg, alt_m) noted
        self.jump_counts: dict[int, int] = {}
        self.reached: list[tuple[int, int]] = []   # (t_us, seq) of every item reached
        self.reached_seqs: set[int] = set()
        self.transitions: list[tuple[int, int, str]] = []  # (t_us, seq, "join"|"fillet") planned
        self.loiter_radii: list[tuple[int, float]] = []     # (seq, radius flown) of every loiter
        self.current = 1 if len(self.items) > 1 else 0
        self.leg_id = 0
        self.airspeed_mps = self.params["TRIM_ARSPD"]
        self.min_groundspeed_mps = 0.0     # DO_CHANGE_SPEED type 1
        self.climb_rate_mps: float | None = None   # DO_CHANGE_SPEED type 2 (None: the vehicle's)
        self.sink_rate_mps: float | None = None    # type 3
        self.finished = False          # past the last item
        self.rtl_established = False
        self._rtl_radius: float | None = None
        self._rtl_dest: tuple | None = None   # RTL's point: ((n, e) of home, alt MSL or None)
        self.launched = False          # left the ground (an item counted on the launcher is not)
        self.landing: Landing | None = None   # the NAV_LAND approach being flown
        self.land_h_corr_m = 0.0       # the rangefinder's correction for it (the vehicle's)
        self.land_complete = False     # landed at the end of the mission (NAV_LAND)
        self.go_arounds = 0            # approaches abandoned (DO_GO_AROUND, automatic abort)
        self.auto_aborts = 0           # of which automatic (landing.AUTO_ABORTS_MAX)
        self._on_circle_since_us = None
        self._prev_wp_ne: tuple | None = None
        self._prev_alt: float | None = None
        self._takeoff_heading: float | None = None
        self._takeoff_start_ne: tuple | None = None
        self._v_ned = np.zeros(3)
        self.ground_speed_mps = 0.0    # the ground speed and course of the step (update)
        self._chi = 0.0
        self._slope_leg = (None, None, (1.0, 0.0))   # (A, B, unit A->B) of _steepest_slope
        self._airspeed_mps = 0.0
        self._wind_ne = (0.0, 0.0)
        self._alt_m = self.home_alt_m
        self._do_pending: list[int] = []      # DO_/CONDITION_ items run alongside the nav item
        self._cond_start_us: int | None = None
        self._warned: set = set()
        self._path: list = []          # segments being flown (a fillet, a join)
        self._through_arcs: dict = {}  # _through_arc's arcs: how far outside the lines they end
        self._path_kind = ""
        self._seg_start = True
        self._seg_angle = 0.0
        self._seg_last: float | None = None
        self._next_wp: tuple | bool | None = None   # (_track_next; None: not looked up yet)
        self._next_min = math.inf
        self._start_item()

    def _start_item(self) -> None:
        """The current item starts afresh (new item, or re-entered)."""
        # the closest the vehicle came to this item's waypoint while the take-off before
        # it flew (a climb-out over it), or an item of the same cluster (``_track_next``)
        nxt = self._next_wp
        self._b_min = self._next_min if nxt and nxt[0] == self.current else math.inf
        self._next_wp = None           # (seq, NE) of the next NAV_WAYPOINT, False: none
        self._next_min = math.inf      # the closest the vehicle came to it so far
        self._leg_start: tuple | None = None
        self._leg_start_alt: float | None = None
        self._leg_along0: float | None = None
        self._joined = False           # the leg's join has been planned (or needs none)
        self._skip_join = False        # a fillet has just put the vehicle on this leg
        self._carry_path = False       # the fillet flies on past the next item (_fillet's skip)
        self._through_tried = False    # a join through B onto the next leg was planned
        self._wide_tried = False       # a pass of B's finish line wide of B was flown back to B
        self._fillet_at = None         # ((A, B), _fillet's answer, |AB|) for the current leg
        self._fillet_check_us = 0      # when its arc was last checked against the wind
        self._join_past = False        # the join rolls out past the start of the next turn
        self._join_run, self._join_last_p = 0.0, None   # distance flown on the join
        self._join_alt_now: float | None = None          # its altitude demand
        self._nav_pos: tuple | None = None     # (b_ne, alt) resolved for the current item
        self._loiter_angle = 0.0
        self._loiter_last_bearing: float | None = None
        self._loiter_start_us: int | None = None
        self._loiter_captured = False
        self._loiter_radius: float | None = None
        self._loiter_entered = False   # the line into the loiter flown to its circle
        self._loiter_exit = None       # (loiter angle to leave at, arc onto the next line)
        self._alt_reached = False
        if getattr(self, "landing", None) is not None and self.landing.phase in ("approach", "descend"):
            self.landing = None        # an approach left (a new item, a jump): flown afresh

    def set_current(self, seq: int) -> None:
        """Jump to item ``seq`` (MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT)."""
        self.current = seq
        self.finished = False
        self.rtl_established = False
        self._rtl_dest = None
        self._on_circle_since_us = None
        self.leg_id += 1
        self._path = []
        self._do_pending = []
        self.landing = None            # a landing jumped to is flown from its approach
        self.auto_aborts = 0
        self._start_item()

    def resume(self) -> None:
        """Back to AUTO after another mode: the current item goes on, but its leg is
        joined again from wherever the vehicle now is (a planned turn, not L1's capture)."""
        self._path = []
        self._joined = False
        self._skip_join = False
        self._leg_along0 = None
        self._loiter_captured = False
        self._loiter_entered = False
        self._loiter_last_bearing = None
        self._loiter_exit = None
        self._carry_path = self._through_tried = False
        self._fillet_at = None
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
        if self._rtl_dest is not None:
            self._rtl_dest = (mv(self._rtl_dest[0]), self._rtl_dest[1])
        if self._nav_pos is not None:
            self._nav_pos = (mv(self._nav_pos[0]), self._nav_pos[1])
        self._path = []
        self._joined = False
        self._fillet_at = None
        self.frame = frame
        dh = frame.alt0_m - self.home_alt_m
        self.home_alt_m = frame.alt0_m
        if self._nav_pos is not None and self.current < len(self.items):
            # the current item's altitude, resolved before the move (a DO_SET_HOME
            # just before it runs in the same step): above the new home, as every
            # later item's is
            it = self.items[self.current]
            current_alt = math.isnan(it.z_alt_m) or (it.z_alt_m == 0 and (
                self._here(it) or it.command in LOITER_COMMANDS))   # (as _resolve reads them)
            if it.frame in RELATIVE_FRAMES and not current_alt:
                self._nav_pos = (self._nav_pos[0], self._nav_pos[1] + dh)

    def say(self, t_us: int, severity: int, text: str, key=None) -> None:
        """A STATUSTEXT-ready event; with ``key``, said once."""
        if key is not None:
            if key in self._warned:
                return
            self._warned.add(key)
        self.notices.append((t_us * 1e-6, severity, text))

    def item_alt_m(self, item: MissionItem) -> float:
        """Item altitude as MSL [m]."""
        if item.frame in TERRAIN_FRAMES:
            return self.terrain_alt_m(item.x_lat_deg, item.y_lon_deg) + item.z_alt_m
        if item.frame in RELATIVE_FRAMES:
            return self.home_alt_m + item.z_alt_m
        return item.z_alt_m

    def terrain_alt_m(self, lat_deg: float, lon_deg: float) -> float:
        """The terrain's height [m MSL] there: from ``terrain`` (a callable (lat_deg,
        lon_deg) -> metres or None, set by the vehicle), else flat at home altitude."""
        return height_or(self.terrain, lat_deg, lon_deg, self.home_alt_m)

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
            if math.isnan(item.z_alt_m):
                # NaN altitude (QGroundControl's null): the current altitude
                b = (float(p_ne[0]), float(p_ne[1])) if self._here(item) else self.item_ne(item)
                alt = alt_m
            elif self._here(item):
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
    def _ground_speed_max_mps(self) -> float:
        """The fastest ground speed at the airspeed the turns are sized for: downwind, in
        the wind estimated now."""
        return self._turn_airspeed_mps() + math.hypot(*self._wind_ne)

    @staticmethod
    def reaction_limits() -> tuple[float | None, float | None]:
        """What a fault's reaction imposes on the turns: (the bank limit below
        ROLL_LIMIT_DEG [rad], the airspeed flown instead of the commanded one [m/s]),
        None each where it imposes nothing: an aileron or rudder flown on the other
        surface, a stuck throttle's level speed (control/fixed_wing.py,
        ``reaction_limits``). The vehicle hands its controller's method over, asked
        when a turn is planned (a few times a leg), not every step; none here."""
        return (None, None)

    def _turn_airspeed_mps(self) -> float:
        """The airspeed the turns are sized for: the commanded one, or the one a reaction
        flies where that is faster (a turn planned at the commanded 45 m/s and flown at
        a stuck full throttle's 70 passed the c172p's waypoints outside their radius)."""
        v = self.airspeed_mps
        r = self.reaction_limits()[1]
        return r if r is not None and r > v else v

    def _banks_deg(self) -> tuple[float, float]:
        """The nominal bank of the turns and the bank limit [deg]: TURN_BANK_DEG and
        ROLL_LIMIT_DEG, or, under a reaction's lower limit (``reaction_limits``), that
        limit and the nominal bank scaled by the same share (the same margin for the
        wind and the roll-in). A turn planned at the parameters' bank with the limit
        lowered is flown wider than planned: a waypoint inside the wider circle was
        circled for 650 s (the c172p with its aileron stuck at 0.1 rad, the turns
        limited to 10 deg)."""
        p = self.params
        turn, limit = p["TURN_BANK_DEG"], p["ROLL_LIMIT_DEG"]
        b = self.reaction_limits()[0]
        if b is not None:
            b = math.degrees(b)
            if b < limit:
                turn, limit = turn * b / limit, b
        return turn, limit

    def turn_radius_m(self, wind: bool = False) -> float:
        """Radius of the fillets: the nominal bank at TURN_GS_FACTOR times the airspeed;
        with ``wind`` (the joins, which may turn through any course), at the airspeed
        plus the wind speed if that is more."""
        v = self._turn_airspeed_mps() * self.params["TURN_GS_FACTOR"]
        if wind:
            v = max(v, self._ground_speed_max_mps())
        return v * v / (G * math.tan(math.radians(self._banks_deg()[0])))

    def min_turn_radius_m(self, wind_ne=None) -> float:
        """The tightest circle the vehicle can hold over the ground: the bank limit at
        the highest ground speed (the airspeed plus the wind)."""
        w = self._wind_ne if wind_ne is None else wind_ne
        v = self._turn_airspeed_mps() + math.hypot(float(w[0]), float(w[1]))
        return v * v / (G * math.tan(math.radians(self._banks_deg()[1])))

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
        h = v * v - w_cross * w_cross
        return w_along + math.sqrt(1.0 if 1.0 > h else h)    # (max spelt out: control/pid.py)

    # ---------------------------------------------------------------- stepping ---
    def _fillet(self, a_ne, b_ne, accept_b: float, p_ne=None):
        """The turn arc at B towards the next leg: (d, arc, skip) with arc a path
        segment starting d before B along A->B, or (0, None, False) when no turn is to
        be filleted. Every arc passes within B's acceptance radius ``accept_b``:
        B counts where the arc starts, and a waypoint counted is one the vehicle went to
        (ArduPlane caps its turn anticipation at WP_RADIUS). A turn too sharp for that
        (the arc of a near-reversal lies far inside the corner) has none: B is flown to
        within its radius and the next leg joined by a planned turn. Where the next
        waypoint C lies within its acceptance radius of B (so C counts the moment B
        does), the arc is the one between A->B and the leg
        after, C->D, at the corner where their lines meet (``_skip_arc``, ``skip``
        True) where one fits: the vehicle turns once onto the line it will fly instead
        of arriving at B along A->B and joining C->D from there, which overshoots C->D
        wherever the short leg turns sharply; likewise a cluster of waypoints within
        each other's radius (the arc onto the line out of it, passing within each one's
        radius), and a leg B->C too short for both its turns at the fillet radius where
        the arc from A->B onto C->D passes within C's radius. ``skip`` is also True for
        an ordinary arc past waypoints on B (duplicates), which count with B."""
        lines = self._lines_after(b_ne, 2 + SKIP_CHAIN)
        if not lines:
            return 0.0, None, False
        ups = [it for it, _ in lines]
        (cn, ce), short = lines[0][1]
        l1 = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        l2 = math.hypot(cn - b_ne[0], ce - b_ne[1])
        if l1 < 1.0 or l2 - short < 1.0:
            return 0.0, None, False
        u1 = ((b_ne[0] - a_ne[0]) / l1, (b_ne[1] - a_ne[1]) / l1)
        u2 = ((cn - b_ne[0]) / l2, (ce - b_ne[1]) / l2)
        # the waypoints after B that lie within their acceptance radius of B (a cluster:
        # each counts the moment the vehicle comes within it, on the way)
        chain = 0
        while chain < len(ups) - 1 and ups[chain] is not None \
                and ups[chain].command == MAV_CMD_NAV_WAYPOINT \
                and math.hypot(lines[chain][1][0][0] - b_ne[0], lines[chain][1][0][1] - b_ne[1]) \
                <= self._accept_radius(ups[chain]):
            chain += 1
        for k in range(chain - 1, -1, -1):
            # C_k counts the moment B does (the ones before it on the way): the turn
            # that matters is onto the line out of the cluster, C_k->D
            skip = self._skip_arc(a_ne, u1, l1, lines[k][1][0], ups[k], lines[k + 1][1],
                                  (b_ne, accept_b))
            if skip is not None and all(
                    _passes_within([skip[1]], lines[i][1][0], 0.9 * self._accept_radius(ups[i]))
                    for i in range(k)):
                return skip
        if chain == 0 and len(ups) > 1 and ups[0] is not None \
                and ups[0].command == MAV_CMD_NAV_WAYPOINT:
            # B->C too short for both its turns at the fillet radius (a reversal, a
            # zig-zag): one arc from A->B onto C->D where it passes within C's radius
            (dn, de), short_d = lines[1][1]
            l3 = math.hypot(dn - cn, de - ce)
            if l3 - short_d >= 1.0:
                u3 = ((dn - cn) / l3, (de - ce) / l3)
                need = self.turn_radius_m() * (_half_turn_tan(u1, u2) + _half_turn_tan(u2, u3))
                if need > l2 - short:
                    skip = self._skip_arc(a_ne, u1, l1, (cn, ce), ups[0], lines[1][1],
                                          (b_ne, accept_b))
                    if skip is not None:
                        return skip
        room1_max = None
        if p_ne is not None:
            # the leg before B still ahead: from the vehicle, or from the end of the
            # path it is flying onto it (the arc of A's turn); with A's arc turning the
            # other way, less a straight for the bank's reversal (random-plane trial
            # 133: an arc widened to begin where A's ended ran 27 m wide)
            ahead = (p_ne[0] - a_ne[0]) * u1[0] + (p_ne[1] - a_ne[1]) * u1[1]
            if self._path:
                end, _ = _path_end(self._path)
                ahead = max(ahead, (end[0] - a_ne[0]) * u1[0] + (end[1] - a_ne[1]) * u1[1])
                last = self._path[-1]
                cross = u1[0] * u2[1] - u1[1] * u2[0]
                if last[0] == "arc" and last[3] != (1 if cross > 0 else -1):
                    ahead += REVERSAL_S * self._ground_speed_max_mps()
            room1_max = l1 - min(max(ahead, 0.0), l1)
        arc = self._corner_arc(b_ne, u1, u2, 0.5 * l1, 0.5 * (l2 - short), near=accept_b,
                               room1_max=room1_max)
        if arc is not None:
            # past waypoints on B (counted at once, with B), the arc flies on
            return arc[0], arc[1], ups[0] is not self._upcoming(1)[0]
        return 0.0, None, False

    def _skip_arc(self, a_ne, u1, l1, c_ne, item_c, line_d, near_b=None):
        """The arc from A->B onto C->D at the corner where their lines meet: at the
        fillet radius where that arc passes within C's acceptance radius (C counts on
        it, as the vehicle comes within it), else starting where C is within its radius
        (C counts with B): (d, arc, True) with d measured back from B, or None where the
        lines do not meet near B and C or no arc fits."""
        cn, ce = c_ne
        (dn, de), short_d = line_d
        l3 = math.hypot(dn - cn, de - ce)
        if l3 - short_d < 1.0:
            return None
        u3 = ((dn - cn) / l3, (de - ce) / l3)
        den = u1[0] * u3[1] - u1[1] * u3[0]
        if abs(den) < math.sin(math.radians(10.0)):
            return None
        # the corner X = A + t u1 = C + s u3
        wn, we = cn - a_ne[0], ce - a_ne[1]
        t = (wn * u3[1] - we * u3[0]) / den
        sc = (wn * u1[1] - we * u1[0]) / den
        x = (a_ne[0] + t * u1[0], a_ne[1] + t * u1[1])
        accept = self._accept_radius(item_c)
        if t > l1 + accept or sc < -accept:
            return None
        rc = 0.9 * accept
        room2 = 0.5 * (l3 - short_d - max(sc, 0.0))
        # (``near_b``: (B, radius) the arc must pass within too, B counting where it
        # starts: tighter radii, down to the bank limit's, until one does)
        r_top = self.turn_radius_m()
        r_min = min(self._arc_floor_m(), r_top)
        r_cap = r_top
        while True:
            arc = self._corner_arc(x, u1, u3, t, room2, r_max=r_cap)
            if arc is not None and t - arc[0] <= l1 and _passes_within([arc[1]], c_ne, rc) \
                    and (near_b is None or _passes_within([arc[1]], *near_b)):
                # the arc passes within C's radius: C counts on it
                return l1 - (t - arc[0]), arc[1], True
            if near_b is None or r_cap <= r_min:
                break
            r_cap = max(0.85 * r_cap, r_min)
        # else the arc starts where C is within (0.9 of) its radius: |C - X + d u1| <= R_c
        c13 = u1[0] * u3[0] + u1[1] * u3[1]
        disc = sc * sc * c13 * c13 - sc * sc + rc * rc
        if disc <= 0.0:
            return None
        d_max = sc * c13 + math.sqrt(disc)
        arc = self._corner_arc(x, u1, u3, min(t, d_max), room2)
        if arc is None:
            return None
        d, seg = arc
        start = seg[5]
        if t - d > l1 or math.hypot(cn - start[0], ce - start[1]) > rc + 1e-6 \
                or (near_b is not None and not _passes_within([seg], *near_b)):
            return None
        return l1 - (t - d), seg, True

    def _arc_floor_m(self) -> float:
        """The tightest arc tightened to pass within a waypoint's radius: the bank limit
        at the highest ground speed (the airspeed plus the wind, at least the fillets'
        TURN_GS_FACTOR times the airspeed): at the limit's radius for the airspeed
        alone the vehicle, downwind, cannot hold the arc (random-plane trial 71: a 71 m
        arc at 28-31 m/s over the ground ran 43 m wide)."""
        return max(self.min_turn_radius_m(),
                   self._bank_limit_radius_m() * self.params["TURN_GS_FACTOR"] ** 2)

    def _bank_limit_radius_m(self) -> float:
        """The turn radius at the bank limit and the airspeed (no wind)."""
        v_air = self._turn_airspeed_mps()
        return v_air * v_air / (G * math.tan(math.radians(self._banks_deg()[1])))

    def _arc_radius_floor_m(self, u1, dchi: float) -> float:
        """The tightest arc the vehicle can hold over the ground through the courses
        from u1 turning by ``dchi``: the bank limit at the highest ground speed on
        them (the airspeed alone in calm air; downwind, airspeed plus wind). A fillet
        shrunk below it to fit short legs is not flown: random-plane trial 54 (10.3 m/s)
        shrank a 91-degree turn downwind to 77 m where 127 m was the least the bank
        limit held, and ran 58 m past the next leg."""
        chi1 = math.atan2(u1[1], u1[0])
        wn, we = self._wind_ne
        w = math.hypot(wn, we)
        v = self._turn_airspeed_mps()
        if w < 0.1:
            vg = v
        else:
            # the downwind course, if the turn sweeps it, else the faster end
            down = math.atan2(we, wn)
            off = wrap_pi(down - chi1) * (1 if dchi > 0 else -1)
            if off < 0.0:
                off += 2.0 * math.pi
            if off <= abs(dchi):
                vg = v + w
            else:
                c2 = chi1 + dchi
                vg = max(self._groundspeed_along((math.cos(chi1), math.sin(chi1))),
                         self._groundspeed_along((math.cos(c2), math.sin(c2))))
            vg = max(vg, v)
        return vg * vg / (G * math.tan(math.radians(self._banks_deg()[1])))

    def _corner_arc(self, x_ne, u1, u2, room1: float, room2: float, near: float | None = None,
                    r_max: float | None = None, room1_max: float | None = None):
        """The fillet at corner X from direction u1 to u2: (d, arc) with d its tangent
        length (at most room1 before X and room2 after it, the radius shrunk to fit; with
        ``near``, shrunk so the arc passes within ``near`` of X: its middle lies
        r (sec(dchi/2) - 1) from the corner), or None for a turn under 5 degrees or one
        with no room at the radius the bank limit holds in the wind over the turn's
        courses (``_arc_radius_floor_m``). With ``room1_max`` (the leg before X still
        ahead of the vehicle), an arc shrunk below that floor is flown at the floor
        instead where the leg before has the room, starting earlier on it."""
        cross = u1[0] * u2[1] - u1[1] * u2[0]
        dchi = math.atan2(cross, u1[0] * u2[0] + u1[1] * u2[1])
        if abs(dchi) < math.radians(5.0):
            return None
        r = self.turn_radius_m() if r_max is None else min(r_max, self.turn_radius_m())
        bulge = 1.0 / math.cos(0.5 * abs(dchi)) - 1.0   # corner to arc middle, per m of radius
        if near is not None:
            r_near = near / bulge
            floor = self._arc_floor_m()
            if r_near < r and r_near < floor:
                # no arc the vehicle can hold in this wind, tangent to both lines,
                # passes so near: one that can, moved towards X until it does
                return self._through_arc(x_ne, u1, u2, dchi, near, room1, room2, room1_max)
            # planned inside the radius where the bank limit allows with room to spare:
            # the arc entered with the bank of the turn before still to reverse runs a
            # few metres wide (random-plane trial 11: an S-turn's second arc, planned at
            # the radius's edge, passed 11 m beyond it), but one planned at the floor
            # itself runs wider still (trial 39: 104 m downwind, 31 m past the line)
            r = min(r, r_near, max(NEAR_MARGIN * r_near, min(r_near, NEAR_FLOOR_FACTOR * floor)))
        t = math.tan(0.5 * abs(dchi))
        d = min(r * t, room1, room2)  # each leg shares its length between its two turns
        if d <= 0.0:
            return None
        r = d / t
        r_min = self._arc_radius_floor_m(u1, dchi)
        if r < r_min:
            # widened (where the leg before has the room) to the floor with the fillets'
            # margin in calm air (TURN_GS_FACTOR): an arc at the bank limit's radius
            # itself, rolled into late, runs wide (random-plane trial 81: 64 m, 26 m
            # past the line)
            r_wide = max(r_min, self._bank_limit_radius_m() * self.params["TURN_GS_FACTOR"] ** 2)
            d_min = r_wide * t
            if room1_max is not None and d_min <= room1_max and d_min <= room2 \
                    and (near is None or r_wide * bulge <= near) \
                    and (r_max is None or r_wide <= r_max):
                r, d = r_wide, d_min   # started earlier on the leg before, at the floor
            elif r < ARC_FLOOR_SLACK * r_min:
                # legs too short for a turn this sharp: no arc can be flown
                return None
        direction = 1 if dchi > 0 else -1
        t1 = (x_ne[0] - d * u1[0], x_ne[1] - d * u1[1])
        centre = (t1[0] - direction * r * u1[1], t1[1] + direction * r * u1[0])
        return d, ("arc", centre, r, direction, abs(dchi), t1)

    def _through_arc(self, x_ne, u1, u2, dchi: float, near: float, room1: float, room2: float,
                     room1_max: float | None = None):
        """A turn at corner X too sharp for any arc the vehicle can hold, tangent to
        both lines, to pass within ``near`` of X (its middle lies r (sec(dchi/2) - 1)
        from X): the arc at NEAR_FLOOR_FACTOR times the floor moved along the bisector
        towards X until its middle passes NEAR_MARGIN ``near`` from it, so that it
        crosses both lines and runs parallel to each ``o`` = the shift times
        cos(dchi/2) outside it where it starts and ends (the vehicle, on A->B where the
        arc begins, is steered out onto it; the line after it is converged on from
        ``o`` beside it). Without it the waypoint was flown to on the old course and
        the next line joined from there, a turn radius and more beyond it
        (random-plane trial 182: a 74-degree turn in 7.3 m/s at a 13.9 m radius, the
        least arc passing 34 m from the waypoint: 81 m past the line). (d, arc) with
        d the distance before X along A->B of the arc's start, or None on a turn of more
        than THROUGH_MAX_TURN, where the shift would put the arc further outside the
        lines than THROUGH_OFFSET_MAX_FRAC of its radius, or where the legs (or the
        part of A->B still ahead, ``room1_max``) lack the room."""
        if abs(dchi) > THROUGH_MAX_TURN:
            return None
        r = NEAR_FLOOR_FACTOR * max(self._arc_radius_floor_m(u1, dchi),
                                    self._bank_limit_radius_m() * self.params["TURN_GS_FACTOR"] ** 2)
        half = 0.5 * abs(dchi)
        shift = r * (1.0 / math.cos(half) - 1.0) - NEAR_MARGIN * near
        offset = shift * math.cos(half)
        if shift <= 0.0 or offset > THROUGH_OFFSET_MAX_FRAC * r:
            return None
        t = math.tan(half)
        d = r * t - shift * math.sin(half)   # the tangent points' distance from X
        if d <= 0.0 or d > room1 or d > room2 or (room1_max is not None and d > room1_max):
            return None
        direction = 1 if dchi > 0 else -1
        # the fillet's centre, moved towards X by the shift
        t1 = (x_ne[0] - r * t * u1[0], x_ne[1] - r * t * u1[1])
        c0 = (t1[0] - direction * r * u1[1], t1[1] + direction * r * u1[0])
        wn, we = x_ne[0] - c0[0], x_ne[1] - c0[1]
        w = math.hypot(wn, we)
        centre = (c0[0] + shift * wn / w, c0[1] + shift * we / w)
        start = (centre[0] + direction * r * u1[1], centre[1] - direction * r * u1[0])
        arc = ("arc", centre, r, direction, abs(dchi), start)
        self._through_arcs[arc] = offset
        return d, arc

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
                # (the roll's lead, at most ROLL_LEAD_MAX_RAD, worked out only that close)
                end = angle - 0.02
                if (self._seg_angle >= end - ROLL_LEAD_MAX_RAD
                        and self._seg_angle >= end - self._roll_lead_rad(r, direction)) \
                        or self._seg_angle < -0.5 * math.pi:
                    self._next_segment()
                    continue
                return _new_target(NavTarget, "loiter", seq, self.leg_id, alt, self.airspeed_mps,
                                   NO_NE, NO_NE, centre, r, direction)
            _, a, b = seg
            ln = math.hypot(b[0] - a[0], b[1] - a[1])
            along = ((p_ne[0] - a[0]) * (b[0] - a[0]) + (p_ne[1] - a[1]) * (b[1] - a[1])) / ln
            self._seg_start = False
            if along >= ln - 0.5:
                self._next_segment()
                continue
            return _new_target(NavTarget, "direct", seq, self.leg_id, alt, self.airspeed_mps, a, b)
        return None

    def _roll_lead_rad(self, r: float, direction: int) -> float:
        """How much of an arc's course change is left to the roll: the bank the arc
        flies is changed to the next segment's (level for a line, the other way for the
        next arc of an S-turn) ROLL_LEAD_S per bank change of the arc's bank before
        the arc's end, half the roll's transition flown on each side of the tangent
        point, so the vehicle neither runs on past it nor under-turns the next arc."""
        gs = self.ground_speed_mps
        nxt = self._path[1] if len(self._path) > 1 else None
        if nxt is not None and nxt[0] == "arc" and nxt[3] == direction:
            return 0.0
        changes = 2.0 if nxt is not None and nxt[0] == "arc" else 1.0
        lead = changes * ROLL_LEAD_S * gs / r
        return ROLL_LEAD_MAX_RAD if ROLL_LEAD_MAX_RAD < lead else lead

    def _next_segment(self) -> None:
        self._path.pop(0)
        self._seg_start = True
        self.leg_id += 1
        if not self._path:
            self._carry_path = False

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
            elif cmd in ROI_COMMANDS or cmd in (MAV_CMD_DO_SET_ROI_NONE, MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET):
                # noted for a gimbal this airframe does not have (ArduPlane points its
                # mount, not the aircraft); said once
                if cmd in (MAV_CMD_DO_SET_ROI_NONE, MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET) or self._here(item):
                    self.roi = None
                else:
                    self.roi = (item.x_lat_deg, item.y_lon_deg, item.z_alt_m)
                self.say(t_us, SEV_INFO, "ROI noted: no gimbal on this airframe to point",
                         key="roi")
            elif cmd in CAMERA_COMMANDS:
                self.say(t_us, SEV_INFO, "Camera commands noted: no camera on this airframe",
                         key="camera")
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
        """The step's target: the current item's, after any items completed (or skipped)
        on this step, each in turn, as the mission goes on within one step. The vehicle
        passes floats (a tuple, lists): nothing to convert."""
        p_ne = (p_ned[0], p_ned[1])
        self._v_ned = v_ned
        # the ground speed, and the course (the heading when slower than 5 m/s), once a step
        vn, ve = v_ned[0], v_ned[1]
        self.ground_speed_mps = gs = math.hypot(vn, ve)
        self._chi = chi = math.atan2(ve, vn) if gs > 5.0 else heading_rad
        if airspeed_mps is not None:
            self._airspeed_mps = airspeed_mps
        if wind_ne is not None:
            self._wind_ne = (wind_ne[0], wind_ne[1])
        if self._prev_alt is None:
            self._prev_alt = alt_m
        self._alt_m = alt_m
        while True:
            if self.current < len(self.items) and self.items[self.current].command not in NAV_ITEMS \
                    and not self.finished:
                self._collect_do_items(t_us)
            if self.finished or self.current >= len(self.items):
                self.finished = True
                self._service_do(t_us, p_ne, None)
                tgt = self._rtl_loiter(t_us, p_ne, alt_m)
                break
            item = self.items[self.current]
            cmd = item.command
            if self._next_wp is not False:       # (False: no waypoint to track this item)
                self._track_next(item, p_ne)
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
                continue
            else:
                # anything else was refused when the mission was loaded; skip defensively
                self.say(t_us, SEV_WARNING, f"Skipping unsupported command #{item.seq} ({cmd})")
                self._advance(t_us)
                continue
            if tgt is not None:
                break
            # (None: the item completed: go on with the next)
        if self.terrain is not None and tgt.kind in ("line", "direct", "loiter") \
                and 0 < tgt.seq < len(self.items) and self.items[tgt.seq].frame in TERRAIN_FRAMES:
            tgt = self._above_terrain(tgt, p_ned, v_ned)
        if self.min_groundspeed_mps > 0 and tgt.kind != "takeoff" and not tgt.land:
            # not on a landing: from its approach on, the landing's own airspeed
            # (TECS_LAND_ARSPD), as ArduPlane's landing stage sets it; a ground-speed
            # minimum raised it past the overspeed abort (random-plane trials 117, 383)
            v = self.commanded_airspeed_mps(chi)
            if v != tgt.airspeed_mps:
                tgt = tgt._replace(airspeed_mps=v)
        return tgt

    def _above_terrain(self, tgt: NavTarget, p_ned, v_ned) -> NavTarget:
        """A terrain-frame item: the altitude demand is its height above the ground
        under the aircraft, taken TERRAIN_LEAD_S ahead along the ground velocity (the
        climb or descent starts before the slope, as the altitude loop lags), not only
        at the waypoint (ArduPlane's terrain following). Without data there: as planned."""
        item = self.items[tgt.seq]
        n = float(p_ned[0]) + TERRAIN_LEAD_S * float(v_ned[0])
        e = float(p_ned[1]) + TERRAIN_LEAD_S * float(v_ned[1])
        lat, lon, _ = self.frame.to_geodetic_fast((n, e, 0.0))
        h = self.terrain(math.degrees(lat), math.degrees(lon))
        if h is None or math.isnan(item.z_alt_m):
            return tgt
        return tgt._replace(alt_m=float(h) + item.z_alt_m)

    def _track_next(self, item, p_ne) -> None:
        """The closest approach to the next NAV_WAYPOINT (with a position of its own)
        while the take-off flies, or an item whose point lies within that waypoint's
        acceptance radius (a cluster: a loiter's centre, a waypoint, the two passed on
        the same turn): a waypoint so passed within its radius is not flown back to
        (``_fly_back_to``). Called while that waypoint is not known to be none."""
        if self._next_wp is None:
            nxt = self._upcoming(1)
            it = nxt[0] if nxt else None
            self._next_wp = False
            if it is not None and it.command == MAV_CMD_NAV_WAYPOINT and not self._here(it):
                b = self.item_ne(it)
                if item.command == MAV_CMD_NAV_TAKEOFF or (
                        not self._here(item) and item.command != MAV_CMD_NAV_RETURN_TO_LAUNCH
                        and math.dist(self.item_ne(item), b) <= self._accept_radius(it)):
                    self._next_wp = (it.seq, b)
        if self._next_wp:
            b = self._next_wp[1]
            d = math.hypot(b[0] - p_ne[0], b[1] - p_ne[1])
            if d < self._next_min:               # min(), spelt out (control/pid.py)
                self._next_min = d

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
        return _new_target(NavTarget, "takeoff", item.seq, self.leg_id, target, self.airspeed_mps,
                           pitch_min_rad=pitch, heading_rad=self._takeoff_heading)

    def _upcoming(self, n: int = 2) -> list:
        """The next ``n`` navigation items after the current one in flying order
        (following the DO_JUMPs that will still be taken); None stands for the end of
        the mission (RTL home), after which nothing follows."""
        out: list = []
        i = self.current + 1
        counts = dict(self.jump_counts)
        for _ in range(n * (len(self.items) + 4)):
            if len(out) >= n:
                break
            if i >= len(self.items):
                out.append(None)
                break
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
            out.append(it)
            if it.command in (MAV_CMD_NAV_RETURN_TO_LAUNCH, MAV_CMD_NAV_LAND):
                break     # the mission ends there
            i += 1
        return out

    def _lines_after(self, b_ne, n: int = 2) -> list:
        """The next ``n`` navigation items that draw a line from the one before (the
        first from B), as (item, line end) with ``_line_end``'s line end; waypoints on
        the point before them (duplicates, a DO_JUMP back to B: zero-length legs, counted
        at once) are passed over. The list stops at an item with no anticipation."""
        out = []
        prev = b_ne
        for it in self._upcoming(n + 4):
            end = self._line_end(it, prev)
            if end is None:
                break
            (pn, pe), short = end
            if it is not None and it.command == MAV_CMD_NAV_WAYPOINT \
                    and math.hypot(pn - prev[0], pe - prev[1]) < 1.0:
                continue
            out.append((it, end))
            if len(out) >= n or it is None or it.command == MAV_CMD_NAV_RETURN_TO_LAUNCH:
                break
            prev = (pn, pe)
        return out

    def _line_end(self, it, from_ne):
        """(point, short) where the line to navigation item ``it`` from ``from_ne`` goes
        and how far before that point it ends (a loiter's line ends outside its circle);
        None where no turn onto it is anticipated. An RTL item's line goes where its RTL
        will (home or the rally point nearest ``from_ne``). The end of the mission with
        no end item (``it`` None) draws no line: the vehicle goes straight into the
        loiter over home (``_rtl_loiter``), as ArduPlane's RTL mode at a mission's end
        does, and an arc planned onto a line home was not flown: the last waypoint
        counted where the arc began and never came within its radius (random-plane
        seed 371334756: 17.8 m beyond its 78.7 m)."""
        if it is None:
            return None
        if it.command == MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._rtl_choice(from_ne)[0], 0.0
        if it.command in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LAND) and not self._here(it):
            return self.item_ne(it), 0.0   # (a landing's line is its approach)
        if it.command in LOITER_COMMANDS and not self._here(it):
            # the line into a loiter is flown to its circle (_loiter_approach): the
            # turn onto it is filleted like any other, on the part outside the circle
            r = it.param2 if it.command == MAV_CMD_NAV_LOITER_TO_ALT else it.param3
            r = abs(r) if abs(r) > 1.0 else self.params["LOITER_RAD"]
            return self.item_ne(it), max(r, self.min_turn_radius_m()) + LOITER_ENTRY_M
        return None   # a point "here", a takeoff, a delay: no anticipation

    def _accept_radius(self, item) -> float:
        acc = item.param2 if item.command == MAV_CMD_NAV_WAYPOINT else 0.0
        return acc if acc > 0 else self.params["WP_RADIUS"]

    def _leg(self, t_us, seq, a_ne, b_ne, p_ne, chi, accept, s_max, alt_b, through=False,
             dist=None):
        """Fly the leg A->B: plan its join, fly the join, then the leg; None once B is
        reached (within ``accept`` of it in any phase). ``dist``: the vehicle's distance
        to B where the caller has it already."""
        if dist is None:
            dist = math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1])
        joined = self._joined
        if dist <= accept and not joined:
            return None   # already there when the item starts: counts at once
        if self._carry_path and self._path and dist <= accept:
            return None   # passed within its radius on an arc carried past it
        if not joined:
            # the leg's first step: where the vehicle is on it decides how it is joined
            length = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
            if length > 1e-3:
                tn, te = (b_ne[0] - a_ne[0]) / length, (b_ne[1] - a_ne[1]) / length
                along = (p_ne[0] - a_ne[0]) * tn + (p_ne[1] - a_ne[1]) * te
                xt = (p_ne[0] - a_ne[0]) * -te + (p_ne[1] - a_ne[1]) * tn
            else:
                along = xt = 0.0
            if self._skip_join and self._path and length > 1e-3 \
                    and not self._path_ends_on(a_ne, b_ne, 3.0 + self._through_arcs.get(self._path[-1], 0.0)) \
                    and not (self._carry_path and _passes_within(self._path, b_ne, accept)):
                # an arc carried past items counted at once (a cluster of waypoints within
                # each other's radius) that turns onto another line than this leg's: the
                # leg is joined by a planned turn instead of left to L1 at a large angle
                self._path = []
                self._skip_join = self._carry_path = False
            self._joined = True
            if length <= 1e-3:
                # a point on the one before (a duplicate, a jump back to it): its finish
                # line is passed at once, as ArduPlane's is
                return None
            elif along >= length and through and dist > accept \
                    and not (self._carry_path and self._path
                             and _passes_within(self._path, b_ne, accept)
                             and self._waypoint_line_follows(b_ne)) \
                    and self._fly_back_to(t_us, p_ne, chi, a_ne, b_ne, accept):
                # (not where the arc carried past a cluster is still to pass within
                # its radius: random-plane trial 172 flew a loop back to a waypoint of
                # the cluster its arc was turning past, 287 m off the next line)
                pass          # past it, not within its radius since the item began: back to it
            elif along >= length and abs(xt) <= accept:
                return None   # already past it, within its radius of its line: passed
            elif not self._skip_join and not dubins.on_leg(p_ne, chi, a_ne, b_ne, JOIN_XTRACK_M,
                                                           JOIN_COURSE_RAD):
                plan = self._plan_join(p_ne, chi, a_ne, b_ne, s_max)
                alt_plan = None
                if plan is not None and plan[0] > s_max + 1e-6 and through:
                    # no room left for B's turn: B would be passed on A->B's course and
                    # the next leg joined from there (a loop where it turns sharply,
                    # and the next join starts as badly: a cascade); through B onto the
                    # next leg instead where that costs less
                    alt_plan = self._plan_through(p_ne, chi, a_ne, b_ne, accept)
                    if alt_plan is not None and alt_plan[0] < plan[4]:
                        self._through_tried = self._carry_path = True
                    else:
                        alt_plan = None
                if alt_plan is not None:
                    self._start_path(alt_plan[1], "join", t_us)
                    self._join_run, self._join_last_p = 0.0, None
                    self._join_past = True
                elif plan is not None:
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

    def _path_ends_on(self, a_ne, b_ne, tol_m: float = 3.0) -> bool:
        """The planned path ends on the line A->B, along it (within ``tol_m`` of the
        line and 5 degrees of its course)."""
        end, chi = _path_end(self._path)
        ln = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        un, ue = (b_ne[0] - a_ne[0]) / ln, (b_ne[1] - a_ne[1]) / ln
        xt = (end[0] - a_ne[0]) * -ue + (end[1] - a_ne[1]) * un
        return abs(xt) <= tol_m and abs(wrap_pi(chi - math.atan2(ue, un))) <= math.radians(5.0)

    def _steepest_slope(self, dh: float, a_ne, b_ne) -> float:
        """The steepest slope the vehicle flies along A->B: its demand slew rate (or the
        DO_CHANGE_SPEED climb / sink rate) over the ground speed along the leg."""
        p = self.params
        rate = (self.climb_rate_mps or p["DEM_CLMB_FRAC"] * p["CLMB_MAX"]) if dh > 0 \
            else (self.sink_rate_mps or p["DEM_CLMB_FRAC"] * p["SINK_MAX"])
        leg = self._slope_leg
        if leg[0] is not a_ne or leg[1] is not b_ne:
            # the leg's direction, once a leg (A and B are the same objects all along it)
            ln = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
            u = ((b_ne[0] - a_ne[0]) / ln, (b_ne[1] - a_ne[1]) / ln) if ln > 1e-3 else (1.0, 0.0)
            leg = self._slope_leg = (a_ne, b_ne, u)
        gs = self._groundspeed_along(leg[2])
        return SLOPE_MARGIN * rate / (1.0 if 1.0 > gs else gs)

    def _join_alt(self, t_us, seq, p_ne, a_ne, b_ne, alt_b) -> float:
        """The altitude demand on a join: towards the waypoint's at the steepest slope,
        by the distance flown since the join began (a plane climbs while it turns)."""
        last = self._join_last_p
        self._join_last_p = p_ne
        if last is not None:
            self._join_run += math.hypot(p_ne[0] - last[0], p_ne[1] - last[1])
        dh = alt_b - self._leg_start_alt
        step = abs(dh)
        if step < 1e-3:
            return alt_b
        slope = self._steepest_slope(dh, a_ne, b_ne)
        rise = slope * self._join_run
        rise = rise if rise < step else step     # min(), spelt out (control/pid.py)
        self._join_alt_now = self._leg_start_alt + math.copysign(rise, dh)
        return self._join_alt_now

    def _join_radii(self):
        """The radii a join is planned at: from the join radius (the nominal bank at the
        airspeed plus the wind) down to the radius of the bank midway between the
        nominal and the limit at that speed (as a fillet shrinks where legs are short)."""
        r = self.turn_radius_m(wind=True)
        v = self._ground_speed_max_mps()
        turn_deg, limit_deg = self._banks_deg()
        bank = math.radians(0.5 * (turn_deg + limit_deg))
        r_floor = min(v * v / (G * math.tan(bank)), r)
        while True:
            yield r
            if r <= r_floor:
                return
            r = max(0.8 * r, r_floor)

    def _plan_join(self, p_ne, chi, a_ne, b_ne, s_max):
        """The join onto A->B at the radius of least cost (``dubins.join_leg``: its
        length, the cross-track it flies once on the line, how far it strays): a tight
        turn saves a long loop or a long run beside the line, a wide one is tracked
        more closely."""
        best = None
        for r in self._join_radii():
            plan = dubins.join_leg(p_ne, chi, a_ne, b_ne, r, s_max)
            if plan is None:
                return None
            if best is None or plan[4] < best[4]:
                best = plan
        return best

    def _plan_through(self, p_ne, chi, a_ne, b_ne, accept: float):
        """A join through B onto the next leg B->C (for a leg A->B too short to be
        joined and turned off again, or a join that leaves no room for B's turn): of the
        paths from here onto B->C (entries from B to two turn radii down the line) that
        pass within 0.9 of B's acceptance radius (so B counts on the way), the one of
        least cost (its length and ``dubins.path_cost`` against both lines: A->B's
        scored until B counts and B->C's after), as (cost, segments); None where no
        line follows or no path passes B."""
        lines = self._lines_after(b_ne, 1)
        if not lines:
            return None
        (cn, ce), short = lines[0][1]
        l2 = math.hypot(cn - b_ne[0], ce - b_ne[1])
        if l2 - short < 1.0:
            return None
        u = ((cn - b_ne[0]) / l2, (ce - b_ne[1]) / l2)
        psi = math.atan2(u[1], u[0])
        l1 = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        u1 = ((b_ne[0] - a_ne[0]) / l1, (b_ne[1] - a_ne[1]) / l1) if l1 > 1e-3 else u

        s1, s2 = dubins.side_of(p_ne, a_ne, u1, 2.0), dubins.side_of(p_ne, b_ne, u, 2.0)
        near2 = (0.9 * accept) ** 2
        best = None
        for r in self._join_radii():
            s_top = min(l2 - short, 2.0 * r)
            step = max(0.25 * r, s_top / 8.0, 1.0)
            for k in range(int(s_top / step) + 1):
                q = (b_ne[0] + k * step * u[0], b_ne[1] + k * step * u[1])
                for length, segs in dubins.csc_words(p_ne, chi, q, psi, r):
                    if dubins.turning(segs) > 2.0 * math.pi:
                        continue    # a loop and more: the ordinary join does better
                    if k and min((n - b_ne[0]) ** 2 + (e - b_ne[1]) ** 2
                                 for n, e, _ in dubins.samples(segs)) > near2:
                        continue    # B not passed within its radius
                    cost = length + dubins.path_cost(segs, b_ne, u, s2, 2.0)[0]
                    if l1 > 1e-3:
                        cost += dubins.path_cost(segs, a_ne, u1, s1, 2.0)[0]
                    if best is None or cost < best[0]:
                        best = (cost, segs)
        return best

    def _waypoint_line_follows(self, b_ne) -> bool:
        """Whether the line after B goes to a waypoint: a path carried past B is flown
        on after B counts, where RTL, a loiter or a landing (which fly to their own
        targets or plan their own entry) would drop it (random-plane trial 76: a
        cluster's arc towards RTL, dropped for the flight home, passed a waypoint 22 m
        beyond its radius plus 10)."""
        nxt = self._lines_after(b_ne, 1)
        return bool(nxt) and nxt[0][0] is not None and nxt[0][0].command == MAV_CMD_NAV_WAYPOINT

    def _fly_back_to(self, t_us, p_ne, chi, a_ne, b_ne, accept: float) -> bool:
        """Once per item, for a waypoint B whose finish line is passed wide of it: the
        planned path to B (turn, straight, turn) of least cost against A->B as the
        mission's cross-track scores it (``dubins.path_cost``) plus its length, over
        the final courses at B in steps of 22.5 degrees and the join radii down to the
        tightest circle held over the ground; where a waypoint's line follows, the
        path through B onto that line instead (``_plan_through``). B counts on the way,
        within its radius (``_leg``). False where none is found
        (B then counts at its finish line, as ArduPlane's rule has it: never a circle
        around a point the vehicle cannot turn onto)."""
        if self._wide_tried or self._b_min <= accept + FLY_BACK_MARGIN_M:
            return False      # (passed within its radius, as far as navigation tells)
        self._wide_tried = True
        length = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        u = ((b_ne[0] - a_ne[0]) / length, (b_ne[1] - a_ne[1]) / length) if length > 1e-3 \
            else (math.cos(chi), math.sin(chi))
        side = dubins.side_of(p_ne, a_ne, u, 2.0)
        # through B onto the line to the next waypoint where there is one (a landing
        # and a loiter plan their own entry): a path that ends at B
        # leaves the next leg to be joined from wherever its loop ends (random-plane
        # trial 44: B reached on a course 72 degrees off the next leg, which was then
        # overshot by 30 m)
        best = self._plan_through(p_ne, chi, a_ne, b_ne, accept) \
            if self._waypoint_line_follows(b_ne) else None
        through = best is not None
        if best is None:
            for r in [*self._join_radii(), self._arc_floor_m()]:
                for k in range(16):
                    psi = k * math.pi / 8.0
                    for n, segs in dubins.csc_words(p_ne, chi, b_ne, psi, r):
                        if dubins.turning(segs) > 2.0 * math.pi:
                            continue
                        cost = n + dubins.path_cost(segs, a_ne, u, side, 2.0)[0]
                        if best is None or cost < best[0]:
                            best = (cost, segs)
        if best is None:
            return False
        self._joined = True
        self._start_path(best[1], "join", t_us)
        self._join_run, self._join_last_p = 0.0, None
        self._join_past = True
        self._skip_join = False
        self._carry_path = through
        self.say(t_us, SEV_INFO, f"Item #{self.current}: passed {math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1]):.0f} m "
                                 f"off; flying back to it", key=("wide", self.current))
        return True

    def _waypoint(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        nav_pos = self._nav_pos               # (resolved at the item's first step)
        b_ne, alt_b = nav_pos if nav_pos is not None else self._resolve(item, p_ne, alt_m)
        d = math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1])
        if d < self._b_min:                  # min(), spelt out (control/pid.py)
            self._b_min = d
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            self._leg_start_alt = self._prev_alt
        a_ne = self._leg_start
        accept = self._accept_radius(item)
        key = (a_ne, b_ne)
        if self._fillet_at is None or self._fillet_at[0] != key:
            # planned once a leg (a fillet depends on the next items, not on the step)
            self._fillet_at = (key, self._fillet(a_ne, b_ne, accept, p_ne),
                               math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1]))
            self._fillet_check_us = t_us
        elif self._fillet_at[1][1] is not None and t_us - self._fillet_check_us >= FILLET_CHECK_US:
            self._fillet_check_us = t_us
            self._refit_fillet(key, a_ne, b_ne, accept, p_ne)
        _, (d_turn, arc, skip), length = self._fillet_at
        # (a leg within the acceptance radius: B would count the moment A did)
        if not self._through_tried and arc is None and length <= accept \
                and accept < d < 4.0 * self.turn_radius_m(wind=True) \
                and not (self._skip_join or dubins.on_leg(p_ne, chi, a_ne, b_ne, JOIN_XTRACK_M,
                                                          JOIN_COURSE_RAD)):
            # (once per item: from as far as 4 join radii; a join planned from further
            # away onto A->B is replaced by this one when the vehicle comes that close)
            self._through_tried = True
            # a leg too short to be joined and turned off again: joined through B onto
            # the leg after it (B counts on the way, within its radius), the path flown
            # on past B
            through = self._plan_through(p_ne, chi, a_ne, b_ne, accept)
            if through is not None:
                self._joined = True
                self._start_path(through[1], "join", t_us)
                self._join_run, self._join_last_p = 0.0, None
                self._join_past = True
                self._carry_path = True
        r = self._leg(t_us, item.seq, a_ne, b_ne, p_ne, chi, accept, length - d_turn, alt_b,
                      through=True, dist=d)
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
        # (_leg moves neither A nor B: the leg's length and the distance to B stand)
        along = 0.0
        if length > 1e-3:
            along = ((p_ne[0] - a_ne[0]) * (b_ne[0] - a_ne[0]) + (p_ne[1] - a_ne[1]) * (b_ne[1] - a_ne[1])) / length
        dist = d
        alt, steep = self._slope_alt(t_us, item.seq, a_ne, b_ne, along, length, d_turn, alt_b)
        # the acceptance radius only stands in for the arc where there is none
        if along >= length - d_turn or (arc is None and dist <= min(accept, 0.5 * length)):
            xtrack = ((p_ne[0] - a_ne[0]) * -(b_ne[1] - a_ne[1]) + (p_ne[1] - a_ne[1]) * (b_ne[0] - a_ne[0])) / length if length > 1e-3 else 0.0
            late = along - (length - d_turn)
            # (the arc, started from here, passes within B's radius; with none, B is
            # within it as the finish line is crossed)
            on_time = late < 0.3 * arc[2] and abs(xtrack) < min(accept, 0.3 * arc[2]) \
                if arc is not None else dist <= accept
            if not on_time and dist > accept \
                    and self._fly_back_to(t_us, p_ne, chi, a_ne, b_ne, accept):
                # its finish line crossed wide of it (a join that rolled out late, a
                # gust in the turn): ArduPlane counts it there; this flies back to it,
                # so that every waypoint counted was passed within its radius
                return self._fly_path(p_ne, alt, item.seq)
            self._reach(t_us, b_ne, alt if steep else alt_b)
            if arc is not None and late < 0.3 * arc[2] and abs(xtrack) < 0.3 * arc[2]:
                # (far off the leg, or far past the arc's start, the arc would start
                # from the wrong place: the next leg is joined by a planned turn instead)
                self._start_path([arc], "fillet", t_us)
                self._skip_join = True
                self._carry_path = skip   # onto C->D: kept when C counts at once
            return None
        return _new_target(NavTarget, "line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne, b_ne)

    def _refit_fillet(self, key, a_ne, b_ne, accept: float, p_ne) -> None:
        """The arc planned when the leg began, checked again while the vehicle is still
        short of its start: where it has become tighter than ARC_FLOOR_SLACK of the
        radius the bank limit holds on its courses in the wind estimated now, the
        fillet is planned again from here (and kept where no arc comes of that). The
        first waypoint's arc is planned at the end of the climb-out, with the wind
        estimate still settling: random-plane trial 234 planned a 115 m arc in 7.8 m/s
        estimated and flew it in 12 m/s (139 m the least), 75 m past the next line;
        trial 198 a 102 m arc in 6.2 m/s, flown in 8.8, 38 m."""
        _, (d_turn, arc, _), length = self._fillet_at
        if length < 1.0:
            return
        u1 = ((b_ne[0] - a_ne[0]) / length, (b_ne[1] - a_ne[1]) / length)
        along = (p_ne[0] - a_ne[0]) * u1[0] + (p_ne[1] - a_ne[1]) * u1[1]
        v = self._ground_speed_max_mps()
        if along > length - d_turn - FILLET_CHECK_US * 1e-6 * v:
            return    # (the arc about to start, or started)
        _, _, r, direction, angle, _ = arc
        if r >= ARC_FLOOR_SLACK * self._arc_radius_floor_m(u1, direction * angle):
            return
        again = self._fillet(a_ne, b_ne, accept, p_ne)
        if again[1] is None and angle > THROUGH_MAX_TURN:
            # none now: past a right angle the waypoint is flown to and the next line
            # looped onto from behind, rather than the arc run wide across it
            self._fillet_at = (key, again, length)
        elif again[1] is not None and along < length - again[0]:
            self._fillet_at = (key, again, length)   # (one that starts ahead)

    def _reach(self, t_us, b_ne, alt) -> None:
        carry = self._path if self._carry_path else []
        self._prev_wp_ne = b_ne
        self._prev_alt = alt
        self._path = []
        self._advance(t_us)
        if carry:
            # the arc from A->B onto C->D flies on past C (counted with B), and on past
            # any item counted at once on the way (a duplicate, a jump back to B)
            self._path = carry
            self._skip_join = True
            self._carry_path = True

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
        if ramp > 1e-3:
            frac = (along - self._leg_along0) / ramp
            frac = 0.0 if 0.0 > frac else frac   # min(max(., 0), 1), spelt out (control/pid.py)
            frac = 1.0 if 1.0 < frac else frac
        else:
            frac = 1.0
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
            self.loiter_radii.append((item.seq, radius))
        return self._loiter_radius, direction

    def _loiter(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        c_ne, alt = self._resolve(item, p_ne, alt_m)
        radius, direction = self._loiter_params(t_us, item)
        if not self._loiter_entered and not self._loiter_captured:
            tgt = self._loiter_approach(t_us, item, c_ne, radius, p_ne, chi, alt)
            if tgt is not None:
                return tgt
            self._loiter_entered = True
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
                if self._loiter_exit is None:
                    self._loiter_exit = self._plan_loiter_exit(c_ne, radius, direction, bearing)
                exit_angle, arc = self._loiter_exit
                if self._loiter_angle >= exit_angle:
                    self._prev_wp_ne = c_ne
                    self._prev_alt = alt
                    self._advance(t_us)
                    if arc is not None:
                        # onto the next line by the planned arc: no join to plan
                        self._start_path([arc], "fillet", t_us)
                        self._skip_join = True
                    return None
        return _new_target(NavTarget, "loiter", item.seq, self.leg_id, alt, self.airspeed_mps,
                           NO_NE, NO_NE, c_ne, radius, direction)

    def _plan_loiter_exit(self, c_ne, radius: float, direction: int, bearing: float):
        """Where a finished loiter is left, as (loiter angle to leave at, arc): the
        line out of a loiter starts at its centre and crosses its circle at right
        angles, so a vehicle that leaves the circle wherever its turns happen to end
        must turn up to 90 degrees or more onto that line and overshoots it by up to a
        turn radius (or loops), scored as cross-track. Instead the circle is flown on,
        at most one more turn, to the point T where an arc of the join radius R
        turning the other way touches both the circle and the line (its centre O is
        R + r from the centre C and R beside the line, on the side the vehicle comes
        from), and that arc puts the vehicle on the line tangentially, sqrt(r^2 + 2rR)
        from C. (ArduPlane leaves at once, or, with the loiter's "heading required"
        flag, once heading towards the next waypoint; either joins the line at an
        angle.) Left at once (arc None) where no line follows or the arc would not end
        on it before its end."""
        now = (self._loiter_angle, None)
        lines = self._lines_after(c_ne, 1)
        if not lines:
            return now
        (pn, pe), short = lines[0][1]
        l2 = math.hypot(pn - c_ne[0], pe - c_ne[1])
        r_arc = self.turn_radius_m(wind=True)
        along = math.sqrt(radius * radius + 2.0 * radius * r_arc)
        if l2 < 1.0 or along > l2 - short - 5.0:
            return now
        u = ((pn - c_ne[0]) / l2, (pe - c_ne[1]) / l2)
        side = -direction          # the side of the line the vehicle comes from
        o = (c_ne[0] + along * u[0] - side * r_arc * u[1], c_ne[1] + along * u[1] + side * r_arc * u[0])
        b_t = math.atan2(o[1] - c_ne[1], o[0] - c_ne[0])
        t = (c_ne[0] + radius * math.cos(b_t), c_ne[1] + radius * math.sin(b_t))
        chi_t = b_t + direction * 0.5 * math.pi
        psi = math.atan2(u[1], u[0])
        angle = (-direction * (psi - chi_t)) % (2.0 * math.pi)
        if angle > math.pi:
            return now
        remaining = (direction * (b_t - bearing)) % (2.0 * math.pi)
        return self._loiter_angle + remaining, ("arc", o, r_arc, -direction, angle, t)

    def _loiter_approach(self, t_us, item, c_ne, radius, p_ne, chi, alt) -> NavTarget | None:
        """The line into a loiter: from the previous item to the loiter's centre, joined
        and flown like a leg until the vehicle is within LOITER_ENTRY_M of the circle it
        will fly (the mission's line is the author's path to the loiter, and leaving it
        early for the circle's tangent strays from it by up to a radius); None once
        there (or when the line is shorter than the circle's radius), and the circle is
        then captured by the L1 loiter law."""
        if self._prev_wp_ne is None:
            return None     # no line drawn to it: the circle from here
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne
            self._leg_start_alt = self._prev_alt
        a_ne = self._leg_start
        reach = radius + LOITER_ENTRY_M
        length = math.hypot(c_ne[0] - a_ne[0], c_ne[1] - a_ne[1])
        if length <= reach:
            return None
        dist = math.hypot(c_ne[0] - p_ne[0], c_ne[1] - p_ne[1])
        if dist <= reach:
            return None
        r = self._leg(t_us, item.seq, a_ne, c_ne, p_ne, chi, reach, length - reach, alt, dist=dist)
        if r is None:
            return None
        if r != "leg":
            return r
        a_ne = self._leg_start
        length = math.hypot(c_ne[0] - a_ne[0], c_ne[1] - a_ne[1])
        along = ((p_ne[0] - a_ne[0]) * (c_ne[0] - a_ne[0]) + (p_ne[1] - a_ne[1]) * (c_ne[1] - a_ne[1])) \
            / max(length, 1e-3)
        if along >= length - reach:
            return None
        return _new_target(NavTarget, "line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne, c_ne)

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
            alt_a = self._approach_start_alt(item, a_ne, b_ne, alt_b)
            self.landing = Landing(self.params, a_ne, b_ne, alt_a, alt_b,
                                   self._groundspeed_along(u))
            self.say(t_us, SEV_INFO, f"Landing approach: {ln:.0f} m from {alt_a - alt_b:.0f} m, "
                                     f"aim {self.landing.shift_m:.0f} m short")
            # too high to fly the approach down from here: the height is lost first
            land = self.landing
            v = land.airspeed_mps + math.hypot(*self._wind_ne)
            r = v * v / (G * math.tan(math.radians(self._banks_deg()[0])))
            sink = self.sink_rate_mps or self.params["DEM_CLMB_FRAC"] * self.params["SINK_MAX"]
            if land.descent_circle(p_ne, alt_m, r, sink, self._groundspeed_along(land.u)):
                self.say(t_us, SEV_INFO, f"Landing: {alt_m - land.alt_a:.0f} m above the approach, "
                                         f"descending on a {r:.0f} m circle first")
        land = self.landing
        # the rangefinder's correction of the landing's heights (guidance/rangefinder.py),
        # set by the vehicle before this update; none in a go-around (ArduPlane's)
        land.h_corr_m = self.land_h_corr_m if land.phase != "go_around" else 0.0
        if land.phase == "go_around":
            return self._go_around_climb(t_us, item, p_ne, alt_m)
        if land.phase == "descend":
            if not land.descent_done(p_ne, chi, alt_m):
                c, r, d = land.descent
                return _new_target(NavTarget, "loiter", item.seq, self.leg_id, land.alt_a, land.airspeed_mps,
                                   c_ne=c, radius_m=r, direction=d, land="descend")
            land.phase = "approach"
            self.resume()                  # the approach line joined afresh, from A
            self._leg_start, self._leg_start_alt = land.a_ne, land.alt_a
        if land.phase == "approach":
            why = land.unsafe(p_ne, alt_m, self._airspeed_mps, t_us) \
                if self.auto_aborts < AUTO_ABORTS_MAX else None
            if why is not None:
                self.auto_aborts += 1
                self.go_around(t_us, f"unsafe approach: {why}")
                return self._go_around_climb(t_us, item, p_ne, alt_m)
            r = self._leg(t_us, item.seq, land.a_ne, land.b_ne, p_ne, chi, 0.0, land.length, alt_b)
            if r is not None and r != "leg":   # joining the approach: at the glide slope's height
                return r._replace(airspeed_mps=land.airspeed_mps, land="approach",
                                  alt_m=land.glide_demand(land.along(p_ne)))
        alt, climb = land.step(t_us, p_ne, alt_m, self._v_ned, self._airspeed_mps)
        if land.phase != "approach" and land.flare_info is not None and land.flare_us == t_us:
            h, s, v, d = land.flare_info
            self.say(t_us, SEV_INFO, f"Flare {h:.1f} m sink {s:.2f} m/s speed {v:.1f} m/s, {d:.0f} m to go")
        if land.phase == "rollout" and land.touch_us == t_us:
            self.say(t_us, SEV_INFO, "Touchdown")
        if land.phase == "ground" and land.landed_us == t_us:
            self.say(t_us, SEV_INFO, "Landed")
        spd_weight = land.speed_weight(land.along(p_ne)) if land.phase == "approach" else 1.0
        return _new_target(NavTarget, "line", item.seq, self.leg_id, alt, land.airspeed_mps, a_ne=land.a_ne,
                           b_ne=land.line_end(), land=land.phase, climb_mps=climb, spd_weight=spd_weight)

    def _approach_start_alt(self, item, a_ne, b_ne, alt_b: float) -> float:
        """The glide slope's start altitude (MSL): the approach's first waypoint's own
        altitude when the approach starts at it (ArduPlane's slope runs from prev_WP_loc,
        the waypoint as planned), not the height the leg to it ended at (a step too steep
        for that leg leaves the aircraft up to 100 m above it); the height flown if
        lower; and no higher than the steepest descent the aircraft flies over the
        approach (``_steepest_slope``). Any height above it is lost before the approach
        (landing.py ``descend``)."""
        alt_a = self._leg_start_alt
        prev = next((self.items[i] for i in range(item.seq - 1, 0, -1)
                     if self.items[i].command in NAV_ITEMS), None)
        if prev is not None and prev.command == MAV_CMD_NAV_WAYPOINT and not self._here(prev):
            q = self.item_ne(prev)
            h = self.item_alt_m(prev)
            if math.hypot(q[0] - a_ne[0], q[1] - a_ne[1]) < 1.0 and math.isfinite(h):
                alt_a = min(alt_a, h)
        ln = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        return min(alt_a, alt_b + self._steepest_slope(-1.0, a_ne, b_ne) * ln)

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
        return _new_target(NavTarget, "line", item.seq, self.leg_id, land.ga_alt, self.params["TRIM_ARSPD"],
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

    def forget_rtl_destination(self) -> None:
        """A new RTL (the mode entered): its point is chosen again from where it starts."""
        self._rtl_dest = None

    def rtl_destination(self, t_us: int, p_ne) -> tuple:
        """Where an RTL goes, chosen once per RTL from where the vehicle is then: the
        nearest rally point when the vehicle's rules pick one (``rally_point``; ArduPlane's
        RTL, mission item or mode, goes to the best rally point or home alike), else home.
        ((n, e) from home [m], altitude MSL, or None for RTL_ALT's)."""
        if self._rtl_dest is None:
            ne, alt, rally = self._rtl_choice(p_ne)
            self._rtl_dest = (ne, alt)
            if rally is not None:
                self.say(t_us, SEV_INFO, f"RTL: to rally point {rally[0]:.7f} {rally[1]:.7f}")
        return self._rtl_dest

    def _rtl_choice(self, p_ne) -> tuple:
        """``rtl_destination``'s choice from ``p_ne``, neither kept nor said: (n, e),
        altitude MSL or None, and the rally point (lat, lon, alt) or None for home."""
        rally = None
        if self.rally_point is not None:
            lat, lon, _ = self.frame.to_geodetic_fast((p_ne[0], p_ne[1], 0.0))
            rally = self.rally_point(math.degrees(lat), math.degrees(lon))
        if rally is None:
            return (0.0, 0.0), None, None
        q = self.frame.to_ned_fast(math.radians(rally[0]), math.radians(rally[1]), self.frame.alt0_m)
        return (float(q[0]), float(q[1])), rally[2], rally

    def _rtl(self, t_us, item, p_ne, chi, alt_m) -> NavTarget | None:
        """Fly the leg to home (or the nearest rally point, ``rtl_destination``), then
        loiter over it (the mission ends there)."""
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            self._leg_start_alt = self._prev_alt
        dest, dest_alt = self.rtl_destination(t_us, p_ne)
        b_ne = dest
        radius = self.home_loiter_radius_m(t_us)
        alt_b = self.rtl_alt_m() if dest_alt is None else dest_alt
        a0 = self._leg_start
        length0 = math.hypot(a0[0] - b_ne[0], a0[1] - b_ne[1])
        r = self._leg(t_us, item.seq, a0, b_ne, p_ne, chi, 1.5 * radius, max(length0 - radius, 0.0), alt_b)
        if r is not None and r != "leg":
            return r
        a_ne = self._leg_start
        length = math.hypot(a_ne[0] - b_ne[0], a_ne[1] - b_ne[1])
        dist = math.hypot(p_ne[0] - b_ne[0], p_ne[1] - b_ne[1])
        along = ((p_ne[0] - a_ne[0]) * (b_ne[0] - a_ne[0]) + (p_ne[1] - a_ne[1]) * (b_ne[1] - a_ne[1])) / length \
            if length > 1e-3 else length
        if r is None or dist <= radius * 1.5 or along >= length - radius:
            self._prev_wp_ne = b_ne
            self._prev_alt = alt_b
            self._advance(t_us)
            self.finished = True
            return self._rtl_loiter(t_us, p_ne, alt_b)
        alt, _ = self._slope_alt(t_us, item.seq, a_ne, b_ne, along, length, radius, alt_b)
        return _new_target(NavTarget, "line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne, b_ne)

    def _rtl_loiter(self, t_us, p_ne, alt_m) -> NavTarget:
        c_ne, dest_alt = self.rtl_destination(t_us, p_ne)
        radius = self.home_loiter_radius_m(t_us)
        r = math.hypot(p_ne[0] - c_ne[0], p_ne[1] - c_ne[1])
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
        alt = dest_alt if dest_alt is not None else self.rtl_alt_m() if self._prev_alt is not None else alt_m
        return _new_target(NavTarget, "loiter", len(self.items), self.leg_id, alt, self.airspeed_mps,
                           NO_NE, NO_NE, c_ne, radius, 1)
