"""Fixed-wing mission sequencer: turns the active mission item into a guidance target.

Item 0 is home (ArduPilot convention). Supported: NAV_TAKEOFF, NAV_WAYPOINT,
NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_RETURN_TO_LAUNCH, DO_JUMP,
DO_CHANGE_SPEED (and DO_SET_HOME, which moves home).

Leg switching (seed section 1.16, the SLUGS rule): the vehicle's position is projected
onto the leg direction; the waypoint is reached when the projection passes the end of
the leg less a turn-anticipation distance d, or when the vehicle is inside the
acceptance radius. The turn itself is flown as a fillet: the circular arc of radius R
tangent to both legs, which starts d = R tan(dchi/2) before the waypoint and ends d
after it on the next leg (dchi the course change). R is the radius of a coordinated
turn at a nominal bank (TURN_BANK_DEG) and the expected ground speed, shrunk when the
legs are too short for it. The arc is tracked by the same L1 law as a loiter circle,
so the vehicle rolls out on the new leg instead of overshooting it.

Altitude along a leg follows a straight glide slope from the previous altitude target
to the waypoint's, so a change of height is flown as a climb or descent along the leg.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geo import LocalFrame, wrap_pi
from ..mission.items import (MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_JUMP, MAV_CMD_DO_SET_HOME,
                             MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_LOITER_TURNS,
                             MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                             MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_WAYPOINT, Mission, MissionItem)
from .l1 import G

RELATIVE_FRAMES = (3, 6, 11)  # GLOBAL_RELATIVE_ALT, GLOBAL_RELATIVE_ALT_INT, TERRAIN (as rel.)


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


class MissionSequencer:
    def __init__(self, mission: Mission, frame: LocalFrame, params):
        self.params = params
        self.frame = frame
        self.load(mission)

    # ------------------------------------------------------------------ set-up ---
    def load(self, mission: Mission) -> None:
        self.mission = mission
        self.items: tuple[MissionItem, ...] = tuple(mission.items)
        self.home_alt_m = self.frame.alt0_m
        self.jump_counts: dict[int, int] = {}
        self.reached: list[tuple[int, int]] = []   # (t_us, seq) of every item reached
        self.reached_seqs: set[int] = set()
        self.current = 1 if len(self.items) > 1 else 0
        self.leg_id = 0
        self.airspeed_mps = self.params["TRIM_ARSPD"]
        self.finished = False          # past the last item
        self.rtl_established = False
        self._on_circle_since_us = None
        self._leg_start: tuple | None = None
        self._leg_start_alt: float | None = None
        self._prev_wp_ne: tuple | None = None
        self._prev_alt: float | None = None
        self._loiter_angle = 0.0
        self._loiter_last_bearing: float | None = None
        self._loiter_start_us: int | None = None
        self._loiter_captured = False
        self._takeoff_heading: float | None = None
        self._leg_along0: float | None = None
        self._v_ned = np.zeros(3)
        self._direct = False      # turning towards the waypoint before joining its leg
        self._arc = None          # the fillet being flown: (centre, radius, dir, angle, B)
        self._arc_angle = 0.0
        self._arc_last: float | None = None

    def set_current(self, seq: int) -> None:
        """Jump to item ``seq`` (MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT)."""
        self.current = seq
        self.finished = False
        self.rtl_established = False
        self._on_circle_since_us = None
        self.leg_id += 1
        self._arc = None
        self._leg_start = None
        self._leg_along0 = None
        self._loiter_captured = False
        self._loiter_angle = 0.0
        self._loiter_last_bearing = None

    def item_alt_m(self, item: MissionItem) -> float:
        """Item altitude as MSL [m]."""
        if item.frame in RELATIVE_FRAMES:
            return self.home_alt_m + item.z_alt_m
        return item.z_alt_m

    def item_ne(self, item: MissionItem) -> tuple[float, float]:
        p = self.frame.to_ned_fast(math.radians(item.x_lat_deg), math.radians(item.y_lon_deg),
                              self.frame.alt0_m)
        return float(p[0]), float(p[1])

    @property
    def total_items(self) -> int:
        return max(len(self.items) - 1, 0)

    # ---------------------------------------------------------------- stepping ---
    def _fillet(self, a_ne, b_ne):
        """The turn arc at B towards the next leg: (d, arc) with arc = (centre, radius,
        direction, turn angle) or None when no turn is to be filleted."""
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
        v = self.airspeed_mps * self.params["TURN_GS_FACTOR"]
        r = v * v / (G * math.tan(math.radians(self.params["TURN_BANK_DEG"])))
        t = math.tan(0.5 * abs(dchi))
        d = min(r * t, 0.5 * l2, 0.5 * l1)  # each leg shares its length between its two turns
        r = d / t
        v_air = self.airspeed_mps
        r_min = v_air * v_air / (G * math.tan(math.radians(self.params["ROLL_LIMIT_DEG"])))
        if r < r_min:
            # legs too short for a turn this sharp: no arc can be flown; fly over the
            # waypoint and let L1 turn back onto the next leg
            return 0.0, None
        direction = 1 if dchi > 0 else -1
        t1 = (b_ne[0] - d * u1[0], b_ne[1] - d * u1[1])
        centre = (t1[0] - direction * r * u1[1], t1[1] + direction * r * u1[0])
        return d, (centre, r, direction, abs(dchi), b_ne)

    def _fly_arc(self, t_us, p_ne) -> NavTarget | None:
        centre, r, direction, dchi, b_ne = self._arc
        bearing = math.atan2(p_ne[1] - centre[1], p_ne[0] - centre[0])
        if self._arc_last is None:
            self._arc_last = bearing
        self._arc_angle += direction * wrap_pi(bearing - self._arc_last)
        self._arc_last = bearing
        if self._arc_angle >= dchi - 0.02 or self._arc_angle < -0.5 * math.pi:
            self._arc = None
            self.leg_id += 1
            return None
        return NavTarget("loiter", self.current, self.leg_id, self._prev_alt, self.airspeed_mps,
                         c_ne=centre, radius_m=r, direction=direction)

    def _advance(self, t_us: int, to_seq: int | None = None) -> None:
        seq = self.current
        self.reached.append((t_us, seq))
        self.reached_seqs.add(seq)
        self.current = seq + 1 if to_seq is None else to_seq
        self.leg_id += 1
        self._loiter_angle = 0.0
        self._loiter_last_bearing = None
        self._loiter_start_us = None
        self._loiter_captured = False
        self._leg_start = None
        self._leg_along0 = None

    def _run_do_items(self, t_us: int) -> None:
        """Execute DO_ commands at the current index until a NAV command is current."""
        for _ in range(len(self.items) * 4 + 8):  # bounded: DO_JUMP loops cannot hang
            if self.current >= len(self.items):
                self.finished = True
                return
            item = self.items[self.current]
            if item.command == MAV_CMD_DO_JUMP:
                target, repeat = int(item.param1), int(item.param2)
                done = self.jump_counts.get(item.seq, 0)
                if repeat < 0 or done < repeat:
                    self.jump_counts[item.seq] = done + 1
                    self.reached.append((t_us, item.seq))
                    self.reached_seqs.add(item.seq)
                    self.current = target
                else:
                    self.reached_seqs.add(item.seq)
                    self.current += 1
            elif item.command == MAV_CMD_DO_CHANGE_SPEED:
                if item.param2 > 0:
                    lo, hi = self.params["ARSPD_FBW_MIN"], self.params["ARSPD_FBW_MAX"]
                    self.airspeed_mps = min(max(item.param2, lo), hi)
                self._advance(t_us)
                self.leg_id -= 1  # not a leg
            elif item.command == MAV_CMD_DO_SET_HOME:
                self._advance(t_us)
                self.leg_id -= 1
            else:
                return

    def update(self, t_us: int, p_ned: np.ndarray, v_ned: np.ndarray, heading_rad: float,
               alt_m: float) -> NavTarget:
        p_ne = (float(p_ned[0]), float(p_ned[1]))
        self._v_ned = v_ned
        if self._arc is not None:
            arc_target = self._fly_arc(t_us, p_ne)
            if arc_target is not None:
                return arc_target
        self._run_do_items(t_us)
        if self.finished or self.current >= len(self.items):
            self.finished = True
            return self._rtl_loiter(t_us, p_ne, alt_m)
        item = self.items[self.current]
        cmd = item.command
        if self._prev_alt is None:
            self._prev_alt = alt_m
        if cmd == MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(t_us, item, p_ne, heading_rad, alt_m)
        if cmd == MAV_CMD_NAV_WAYPOINT:
            return self._waypoint(t_us, item, p_ne, v_ned)
        if cmd in (MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_LOITER_TURNS, MAV_CMD_NAV_LOITER_TIME):
            return self._loiter(t_us, item, p_ne)
        if cmd == MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._rtl(t_us, item, p_ne, v_ned)
        # anything else was refused when the mission was loaded; skip defensively
        self._advance(t_us)
        return self.update(t_us, p_ned, v_ned, heading_rad, alt_m)

    def _takeoff(self, t_us, item, p_ne, heading_rad, alt_m) -> NavTarget:
        if self._takeoff_heading is None:
            self._takeoff_heading = heading_rad
        target = self.item_alt_m(item)
        if alt_m >= target - self.params["TKOFF_ALT_TOL"]:
            self._prev_alt = target
            # the next leg starts at the takeoff item's location when it has one (the
            # line the mission's author drew), else where the climb ended
            # (unless the climb ended far from it, e.g. after a launch into the wind)
            has_pos = not (item.x_lat_deg == 0 and item.y_lon_deg == 0)
            t_ne = self.item_ne(item) if has_pos else p_ne
            near = math.hypot(t_ne[0] - p_ne[0], t_ne[1] - p_ne[1]) <= self.params["WP_RADIUS"]
            self._prev_wp_ne = t_ne if near else p_ne
            self._advance(t_us)
            return self.update(t_us, np.array([p_ne[0], p_ne[1], 0.0]), self._v_ned,
                               heading_rad, alt_m)
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
            if it.command in (MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_SET_HOME):
                i += 1
                continue
            if it.command == MAV_CMD_NAV_RETURN_TO_LAUNCH:
                return (0.0, 0.0)
            if it.command == MAV_CMD_NAV_WAYPOINT:
                return self.item_ne(it)
            return None  # loiters etc.: no anticipation
        return None

    def _waypoint(self, t_us, item, p_ne, v_ned) -> NavTarget:
        b_ne = self.item_ne(item)
        if self._leg_start is None:
            a_ne = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            # joining a leg while flying the other way (after a takeoff into the wind, a
            # loiter, a skipped arc): first turn towards the waypoint ("direct"), then
            # start the leg where the turn ends, so the leg is not flown backwards
            chi_leg = math.atan2(b_ne[1] - a_ne[1], b_ne[0] - a_ne[0])
            gs = math.hypot(float(v_ned[0]), float(v_ned[1]))
            if gs > 5.0:
                chi = math.atan2(float(v_ned[1]), float(v_ned[0]))
                chi_direct = math.atan2(b_ne[1] - p_ne[1], b_ne[0] - p_ne[0])
                if self._direct or abs(wrap_pi(chi_leg - chi)) > math.radians(90.0):
                    if abs(wrap_pi(chi_direct - chi)) > math.radians(5.0):
                        self._direct = True
                        return NavTarget("direct", item.seq, self.leg_id, self._prev_alt,
                                         self.airspeed_mps, a_ne=p_ne, b_ne=b_ne)
                    a_ne = p_ne
            self._direct = False
            self._leg_start = a_ne
            self._leg_start_alt = self._prev_alt
        a_ne = self._leg_start
        alt_b = self.item_alt_m(item)
        length = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        along = 0.0
        if length > 1e-3:
            along = ((p_ne[0] - a_ne[0]) * (b_ne[0] - a_ne[0]) + (p_ne[1] - a_ne[1]) * (b_ne[1] - a_ne[1])) / length
        dist = math.hypot(b_ne[0] - p_ne[0], b_ne[1] - p_ne[1])
        accept = max(item.param2, 0.0) or self.params["WP_RADIUS"]
        d_turn, arc = self._fillet(a_ne, b_ne)
        # the acceptance radius only stands in for the arc where there is none
        if along >= length - d_turn or (arc is None and dist <= min(accept, self.params["WP_RADIUS"], 0.5 * length)):
            self._prev_wp_ne = b_ne
            self._prev_alt = alt_b
            self._advance(t_us)
            xtrack = ((p_ne[0] - a_ne[0]) * -(b_ne[1] - a_ne[1]) + (p_ne[1] - a_ne[1]) * (b_ne[0] - a_ne[0])) / length if length > 1e-3 else 0.0
            if arc is not None and along >= length - d_turn and abs(xtrack) < 0.3 * arc[1]:
                # (far off the leg the arc would start from the wrong place: let L1
                # capture the next leg directly instead)
                self._arc, self._arc_angle, self._arc_last = arc, 0.0, None
            return self.update(t_us, np.array([p_ne[0], p_ne[1], 0.0]), v_ned, 0.0, alt_b)
        # glide slope: from where this leg was joined (the end of the previous turn arc)
        # to where the turn onto the next leg starts
        if self._leg_along0 is None:
            self._leg_along0 = min(max(along, 0.0), max(length - d_turn, 0.0))
        ramp = length - d_turn - self._leg_along0
        frac = min(max((along - self._leg_along0) / ramp, 0.0), 1.0) if ramp > 1e-3 else 1.0
        alt = self._leg_start_alt + (alt_b - self._leg_start_alt) * frac
        return NavTarget("line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne=a_ne, b_ne=b_ne)

    def _loiter_params(self, item) -> tuple[float, int]:
        r = item.param3 if item.command != MAV_CMD_NAV_LOITER_UNLIM else item.param3
        radius = abs(r) if abs(r) > 1.0 else self.params["LOITER_RAD"]
        direction = -1 if r < 0 else 1
        return radius, direction

    def _loiter(self, t_us, item, p_ne) -> NavTarget:
        c_ne = self.item_ne(item)
        radius, direction = self._loiter_params(item)
        alt = self.item_alt_m(item) if item.z_alt_m != 0 or item.frame not in RELATIVE_FRAMES else self._prev_alt
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
            if done:
                self._prev_wp_ne = c_ne
                self._prev_alt = alt
                self._advance(t_us)
                return self.update(t_us, np.array([p_ne[0], p_ne[1], 0.0]), self._v_ned, 0.0, alt)
        return NavTarget("loiter", item.seq, self.leg_id, alt, self.airspeed_mps,
                         c_ne=c_ne, radius_m=radius, direction=direction)

    def rtl_alt_m(self) -> float:
        rtl = self.params["RTL_ALT"]
        return self.home_alt_m + rtl if rtl > 0 else self._prev_alt

    def _rtl(self, t_us, item, p_ne, v_ned) -> NavTarget:
        """Fly the leg to home, then loiter over it (the mission ends there)."""
        if self._leg_start is None:
            self._leg_start = self._prev_wp_ne if self._prev_wp_ne is not None else p_ne
            self._leg_start_alt = self._prev_alt
        a_ne = self._leg_start
        b_ne = (0.0, 0.0)
        length = math.hypot(a_ne[0], a_ne[1])
        dist = math.hypot(p_ne[0], p_ne[1])
        along = ((p_ne[0] - a_ne[0]) * (-a_ne[0]) + (p_ne[1] - a_ne[1]) * (-a_ne[1])) / length if length > 1e-3 else length
        alt_b = self.rtl_alt_m()
        radius = self.params["LOITER_RAD"]
        if dist <= radius * 1.5 or along >= length - radius:
            self._prev_wp_ne = b_ne
            self._prev_alt = alt_b
            self._advance(t_us)
            self.finished = True
            return self._rtl_loiter(t_us, p_ne, alt_b)
        # glide slope: reach the RTL altitude where the loiter over home begins
        ramp = length - radius
        frac = min(max(along / ramp, 0.0), 1.0) if ramp > 1e-3 else 1.0
        alt = self._leg_start_alt + (alt_b - self._leg_start_alt) * frac
        return NavTarget("line", item.seq, self.leg_id, alt, self.airspeed_mps, a_ne=a_ne, b_ne=b_ne)

    def _rtl_loiter(self, t_us, p_ne, alt_m) -> NavTarget:
        radius = self.params["LOITER_RAD"]
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
