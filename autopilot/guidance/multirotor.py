"""Multirotor guidance: a reference point that moves with limited speed and
acceleration, the actions built on it (take off, go to, hold, land, return to launch),
and the mission sequencer that turns mission items into those actions.

Reference trajectory
--------------------
The seed's reference-angle generator (eqs 3.38-3.40, control/multirotor.py) is a PID
on the position error. Fed a far waypoint directly it would saturate the tilt at once
(0.3 rad per metre of error) and fly at whatever speed that gives. Waypoint flight
therefore moves the *reference* instead (as ArduCopter's AC_WPNav and PX4's trajectory
generator do): a point travels along the straight 3-D line from where the reference is
to the goal with a trapezoidal speed profile -- speed at most WPNAV_SPEED horizontally,
WPNAV_SPEED_UP / WPNAV_SPEED_DN vertically, acceleration at most WPNAV_ACCEL (horizontal) and
WPNAV_ACCEL_Z (vertical), braking as v = sqrt(2 a d) so that it stops exactly at the goal.
Its position, velocity and acceleration, smoothed by a second-order reference model
(``Trajectory``), are the PID's reference, velocity reference and feed-forward. A leash
keeps the reference from running away from a vehicle that cannot follow (a headwind
beyond its tilt limit): beyond WPNAV_LEASH metres from the vehicle the raw profile brakes
and waits. Every waypoint is flown to a stop (no corner cutting), so
a mission is a sequence of straight legs whose ends are exact.

Heading (eq 3.41 generalised): towards the goal on legs longer than 5 m, else held;
slewed at YAW_RATE_MAX. A NAV_WAYPOINT's param4 (degrees, not NaN) fixes the heading.

Landing: the reference flies to the land point at the current height, then descends at
WPNAV_SPEED_DN down to LAND_ALT_LOW above home, then at LAND_SPEED, and keeps descending
until the vehicle's land detector reports the touchdown (vehicle_quad.py), so the
touchdown is a gentle, constant-rate contact wherever the ground is. Return to launch:
climb to Q_RTL_ALT above home (if lower), fly home, land.

Mission items (item 0 is home): NAV_TAKEOFF (vertical, param7 altitude; its lat/lon are
ignored, as ArduCopter does), NAV_WAYPOINT (param1 hold time [s], param2 acceptance
radius [m], param4 heading [deg]), NAV_LOITER_TIME (param1 seconds), NAV_LOITER_UNLIM,
NAV_LOITER_TURNS (a hold of param1 x 20 s: no circling), NAV_LAND (lat/lon 0: here),
NAV_RETURN_TO_LAUNCH, DO_JUMP, DO_CHANGE_SPEED (param2 [m/s] replaces WPNAV_SPEED for the
rest of the flight), DO_SET_HOME.
A waypoint is reached when the reference has arrived and the vehicle is within the
acceptance radius (default WPNAV_RADIUS); the hold time starts then. Timed holds and
loiters are flagged ``hold`` in the target (scored as hold_pos_rms_m). A mission that
ends without landing returns to launch and lands (as the fixed-wing returns home).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..geo import LocalFrame, wrap_pi
from ..mission.items import (MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_JUMP, MAV_CMD_DO_SET_HOME,
                             MAV_CMD_NAV_LAND, MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_LOITER_TURNS,
                             MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                             MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_WAYPOINT, Mission, MissionItem)
from ..params import Param

RELATIVE_FRAMES = (3, 6, 11)
LOITER_TURN_S = 20.0
YAW_MIN_LEG_M = 5.0           # shorter moves keep the heading

COPTER_GUIDANCE_PARAMS = (
    Param("WPNAV_SPEED", 5.0, 0.5, 20.0, "m/s", "horizontal speed between waypoints"),
    Param("WPNAV_SPEED_UP", 2.5, 0.2, 10.0, "m/s", "climb speed"),
    Param("WPNAV_SPEED_DN", 1.5, 0.2, 10.0, "m/s", "descent speed"),
    Param("WPNAV_ACCEL", 2.5, 0.2, 10.0, "m/s^2", "horizontal acceleration of the reference"),
    Param("WPNAV_ACCEL_Z", 1.5, 0.2, 10.0, "m/s^2", "vertical acceleration of the reference"),
    Param("WPNAV_RADIUS", 2.0, 0.1, 50.0, "m", "default waypoint acceptance radius"),
    Param("WPNAV_LEASH", 8.0, 0.5, 50.0, "m", "raw reference brakes beyond this distance from the vehicle"),
    Param("WPNAV_SMOOTH", 4.0, 0.5, 20.0, "rad/s", "natural frequency of the reference model (jerk limit)"),
    Param("Q_RTL_ALT", 15.0, 0.0, 300.0, "m", "return-to-launch height above home (0: current)"),
    Param("LAND_SPEED", 0.5, 0.1, 3.0, "m/s", "final descent speed"),
    Param("LAND_ALT_LOW", 5.0, 0.0, 50.0, "m", "height above home where the final descent starts"),
    Param("WPNAV_TKOFF_TOL", 0.5, 0.05, 5.0, "m", "takeoff complete this close to its height"),
)


@dataclass(frozen=True, slots=True)
class CopterTarget:
    """What guidance asks of the position and altitude loops (home NED frame)."""

    kind: str                       # "idle" | "takeoff" | "move" | "hold" | "land"
    seq: int                        # mission item being flown (0: none)
    leg_id: int                     # increments at every new action (scoring)
    p_ned: tuple                    # reference position [m]
    v_ned: tuple                    # reference velocity [m/s]
    a_ned: tuple                    # reference acceleration (feed-forward) [m/s^2]
    yaw_rad: float                  # heading reference
    hold: bool = False              # a timed hold / loiter is running (scored)
    goal_ne: tuple = (0.0, 0.0)     # the goal / hold / land point (north, east)
    leg_a: tuple = (0.0, 0.0)       # the straight leg being flown (north, east)


# what the position loops are doing in each navigator phase (CopterTarget.kind)
_PHASE_KIND = {"idle": "hold", "takeoff": "takeoff", "goto": "move", "hold": "hold",
               "rtl_climb": "move", "rtl_return": "move", "land_approach": "move",
               "land_descend": "land", "landed": "idle"}


class Trajectory:
    """The moving reference point: a raw profile along straight lines (trapezoidal
    speed, leash) smoothed by a critically damped second-order reference model,

        a = w^2 (p_raw - p) - 2 w v,

    so the acceleration fed forward changes smoothly (the raw profile's acceleration
    jumps between +a_max and -a_max; through the model it rises and falls within
    about 1/w s, never exceeding a_max, and the jerk stays below 2 a_max w / e).
    ``p``, ``v``, ``a`` are the model's output: the reference of the loops."""

    def __init__(self, smooth_rad_s: float = 4.0):
        self.w = smooth_rad_s
        self.p = [0.0, 0.0, 0.0]      # smoothed reference (output)
        self.v = [0.0, 0.0, 0.0]
        self.a = [0.0, 0.0, 0.0]
        self.raw = [0.0, 0.0, 0.0]    # raw profile position
        self._vraw = [0.0, 0.0, 0.0]
        self.goal = [0.0, 0.0, 0.0]
        self._u = (0.0, 0.0, 0.0)     # unit direction of the line
        self._len = 0.0
        self._s = 0.0                 # distance along the line
        self._vs = 0.0                # speed along the line
        self._vmax = 0.0
        self._amax = 1.0
        self.start = (0.0, 0.0, 0.0)
        self.descending = False       # open-ended descent (landing)
        self._vdesc = 0.0

    @property
    def arrived(self) -> bool:
        """The raw profile is at its goal and the smoothed reference has settled on it."""
        if self.descending or self._s < self._len or self._vs != 0.0:
            return False
        p, g, v = self.p, self.goal, self.v
        return (abs(p[0] - g[0]) + abs(p[1] - g[1]) + abs(p[2] - g[2]) < 0.03
                and abs(v[0]) + abs(v[1]) + abs(v[2]) < 0.05)

    def reset(self, p) -> None:
        """Stationary at p."""
        self.p = [float(p[0]), float(p[1]), float(p[2])]
        self.v = [0.0, 0.0, 0.0]
        self.a = [0.0, 0.0, 0.0]
        self.raw = list(self.p)
        self._vraw = [0.0, 0.0, 0.0]
        self.goal = list(self.p)
        self.start = tuple(self.p)
        self._len = self._s = self._vs = 0.0
        self.descending = False

    def line_to(self, goal, v_h: float, v_up: float, v_dn: float, a_h: float, a_z: float) -> None:
        """From the raw reference's current position to ``goal`` (NED)."""
        r = self.raw
        d = [goal[0] - r[0], goal[1] - r[1], goal[2] - r[2]]
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        self.start = tuple(r)
        self.goal = [float(goal[0]), float(goal[1]), float(goal[2])]
        self.descending = False
        if length < 1e-6:
            self._len = self._s = self._vs = 0.0
            self._vraw = [0.0, 0.0, 0.0]
            return
        u = (d[0] / length, d[1] / length, d[2] / length)
        uh = math.hypot(u[0], u[1])
        uz = abs(u[2])
        vz = v_up if u[2] < 0.0 else v_dn
        vmax = min(v_h / uh if uh > 1e-9 else math.inf, vz / uz if uz > 1e-9 else math.inf)
        amax = min(a_h / uh if uh > 1e-9 else math.inf, a_z / uz if uz > 1e-9 else math.inf)
        # carry on with the part of the current raw velocity along the new line
        vr = self._vraw
        vs = max(0.0, vr[0] * u[0] + vr[1] * u[1] + vr[2] * u[2])
        self._u, self._len, self._s, self._vs = u, length, 0.0, min(vs, vmax)
        self._vmax, self._amax = vmax, amax

    def stopping_point(self) -> tuple[float, float, float]:
        """Where the raw profile stops if it brakes now at its acceleration limit."""
        r = self.raw
        if self.descending or self._len <= 0.0 or self._vs <= 0.0:
            return (r[0], r[1], r[2])
        d = min(self._vs * self._vs / (2.0 * self._amax), self._len - self._s)
        u = self._u
        return (r[0] + u[0] * d, r[1] + u[1] * d, r[2] + u[2] * d)

    def descend(self, speed: float, accel: float) -> None:
        """Open-ended vertical descent at ``speed`` (landing); horizontal held."""
        self.descending = True
        self._vdesc = speed
        self._amax = accel
        self._len = self._s = self._vs = 0.0

    def set_descent_speed(self, speed: float) -> None:
        self._vdesc = speed

    def update(self, dt: float, p_vehicle, leash: float) -> None:
        self._raw_step(dt, p_vehicle, leash)
        # reference model: a = w^2 (p_raw - p) - 2 w v  (semi-implicit Euler)
        w = self.w
        w2, w2x = w * w, 2.0 * w
        r, p, v = self.raw, self.p, self.v
        a0 = w2 * (r[0] - p[0]) - w2x * v[0]
        a1 = w2 * (r[1] - p[1]) - w2x * v[1]
        a2 = w2 * (r[2] - p[2]) - w2x * v[2]
        v0, v1, v2 = v[0] + a0 * dt, v[1] + a1 * dt, v[2] + a2 * dt
        self.p = [p[0] + v0 * dt, p[1] + v1 * dt, p[2] + v2 * dt]
        self.v = [v0, v1, v2]
        self.a = [a0, a1, a2]

    def _raw_step(self, dt: float, p_vehicle, leash: float) -> None:
        r = self.raw
        if self.descending:
            vd0 = self._vraw[2]
            dv = self._vdesc - vd0
            lim = self._amax * dt
            vd1 = vd0 + (lim if dv > lim else -lim if dv < -lim else dv)
            # leash: the reference may not get more than 1 m below the vehicle
            if r[2] - p_vehicle[2] > 1.0:
                vd1 = min(vd1, 0.0)
            r[2] += 0.5 * (vd0 + vd1) * dt
            self._vraw = [0.0, 0.0, vd1]
            return
        if self._len <= 0.0:
            self._vraw = [0.0, 0.0, 0.0]
            return
        vs0 = self._vs
        remaining = self._len - self._s
        lim = self._amax * dt
        # braking curve v = sqrt(2 a d): followed exactly (the discrete steps need a
        # little more than a_max at its very end), so the profile stops on the goal
        v_brake = math.sqrt(2.0 * self._amax * max(remaining, 0.0))
        v_goal = min(self._vmax, v_brake)
        ex, ey, ez = r[0] - p_vehicle[0], r[1] - p_vehicle[1], r[2] - p_vehicle[2]
        if ex * ex + ey * ey + ez * ez > leash * leash:
            v_goal = 0.0
        dv = v_goal - vs0
        vs1 = vs0 + (lim if dv > lim else -lim if dv < -lim else dv)
        if vs1 > v_brake:
            vs1 = v_brake
        s = self._s + 0.5 * (vs0 + vs1) * dt
        if s >= self._len or (vs1 <= 0.0 and remaining < 1e-3):
            s, vs1 = self._len, 0.0
        self._s, self._vs = s, vs1
        u = self._u
        st = self.start
        self.raw = [st[0] + u[0] * s, st[1] + u[1] * s, st[2] + u[2] * s]
        self._vraw = [u[0] * vs1, u[1] * vs1, u[2] * vs1]


class CopterNavigator:
    """One guidance action at a time on top of :class:`Trajectory`.

    Phases: ``idle``, ``takeoff``, ``goto``, ``hold``, ``rtl_climb``, ``rtl_return``,
    ``land_approach``, ``land_descend``, ``landed``."""

    def __init__(self, params):
        self.params = params
        self.traj = Trajectory(params["WPNAV_SMOOTH"])
        self.phase = "idle"
        self.leg_id = 0
        self.yaw_ref = 0.0
        self._yaw_goal: float | None = None
        self.hold_scored = False
        self.goal_ne = (0.0, 0.0)
        self.land_ne = (0.0, 0.0)
        self.speed_mps: float | None = None   # DO_CHANGE_SPEED override of WPNAV_SPEED

    # ----------------------------------------------------------------- actions --
    def init(self, p_ned, yaw: float) -> None:
        """Take over a vehicle at p_ned (a mode change from a manual mode, arming)."""
        self.traj.reset(p_ned)
        self.yaw_ref = yaw
        self._yaw_goal = None
        self.phase = "idle"

    def _line(self, goal) -> None:
        p = self.params
        v_h = self.speed_mps if self.speed_mps is not None else p["WPNAV_SPEED"]
        self.traj.line_to(goal, v_h, p["WPNAV_SPEED_UP"], p["WPNAV_SPEED_DN"],
                          p["WPNAV_ACCEL"], p["WPNAV_ACCEL_Z"])
        self.leg_id += 1
        self.goal_ne = (goal[0], goal[1])
        dn, de = goal[0] - self.traj.start[0], goal[1] - self.traj.start[1]
        self._yaw_goal = math.atan2(de, dn) if math.hypot(dn, de) > YAW_MIN_LEG_M else None

    def takeoff(self, p_ned, height_m: float) -> None:
        """Vertical climb from p_ned to ``height_m`` above home."""
        self.traj.reset(p_ned)
        self._line((p_ned[0], p_ned[1], -height_m))
        self._yaw_goal = None
        self.phase = "takeoff"

    def goto(self, goal, yaw: float | None = None) -> None:
        self._line(goal)
        if yaw is not None:
            self._yaw_goal = yaw
        self.phase = "goto"

    def hold(self, p=None, scored: bool = False) -> None:
        """Stop at p (default: where the reference can stop, braking at its acceleration
        limit) and stay."""
        if p is None:
            p = self.traj.stopping_point()
        self._line(p)
        self._yaw_goal = None
        self.hold_scored = scored
        self.phase = "hold"

    def land(self, ne=None) -> None:
        """Land at (north, east) (default: where the reference can stop, braking at its
        acceleration limit, as ``hold``; stopping the raw reference where it is would
        brake at the reference model's rate instead, 30 deg of tilt from 5 m/s)."""
        p = self.traj.raw
        if ne is None:
            ne = self.traj.stopping_point()
        self.land_ne = (float(ne[0]), float(ne[1]))
        self._line((ne[0], ne[1], p[2]))
        self.phase = "land_approach"

    def rtl(self, p_vehicle) -> None:
        """Climb to Q_RTL_ALT (if lower), return home, land."""
        h_rtl = self.params["Q_RTL_ALT"]
        p = self.traj.raw
        h = -p[2]
        self.land_ne = (0.0, 0.0)
        if h_rtl > 0.0 and h < h_rtl - 0.2 and math.hypot(p[0], p[1]) > self.params["WPNAV_RADIUS"]:
            self._line((p[0], p[1], -h_rtl))
            self._yaw_goal = None
            self.phase = "rtl_climb"
        else:
            self._line((0.0, 0.0, -max(h, h_rtl) if h_rtl > 0.0 else p[2]))
            self.phase = "rtl_return"

    def touchdown(self) -> None:
        """The land detector saw the touchdown."""
        self.traj.reset(self.traj.p)
        self.phase = "landed"
        self.leg_id += 1

    # ----------------------------------------------------------------- stepping --
    def update(self, dt: float, p_vehicle, yaw: float) -> None:
        prm = self.params
        traj = self.traj
        ph = self.phase
        if ph in ("rtl_climb",) and traj.arrived:
            self._line((0.0, 0.0, traj.p[2]))
            self.phase = ph = "rtl_return"
        if ph in ("rtl_return", "land_approach") and traj.arrived:
            traj.descend(prm["WPNAV_SPEED_DN"], prm["WPNAV_ACCEL_Z"])
            self.leg_id += 1
            self._yaw_goal = None
            self.phase = ph = "land_descend"
        if ph == "land_descend":
            low = -traj.p[2] <= prm["LAND_ALT_LOW"]
            traj.set_descent_speed(prm["LAND_SPEED"] if low else prm["WPNAV_SPEED_DN"])
        traj.update(dt, p_vehicle, prm["WPNAV_LEASH"])
        # heading reference slewed towards its goal
        if self._yaw_goal is not None:
            err = wrap_pi(self._yaw_goal - self.yaw_ref)
            step = math.radians(prm["YAW_RATE_MAX"]) * dt
            self.yaw_ref = wrap_pi(self.yaw_ref + max(-step, min(step, err)))

    @property
    def arrived(self) -> bool:
        return self.traj.arrived

    def target(self, seq: int, hold: bool = False) -> CopterTarget:
        tr = self.traj
        kind = _PHASE_KIND[self.phase]
        goal = self.land_ne if self.phase in ("land_descend", "landed") else self.goal_ne
        return CopterTarget(kind, seq, self.leg_id, tuple(tr.p), tuple(tr.v), tuple(tr.a),
                            self.yaw_ref, hold, goal, (tr.start[0], tr.start[1]))


class CopterMissionSequencer:
    """Mission items -> navigator actions (module docstring)."""

    def __init__(self, mission: Mission, frame: LocalFrame, params, nav: CopterNavigator):
        self.params = params
        self.frame = frame
        self.nav = nav
        self.load(mission)

    def load(self, mission: Mission) -> None:
        self.mission = mission
        self.items: tuple[MissionItem, ...] = tuple(mission.items)
        self.home_alt_m = self.frame.alt0_m
        self.jump_counts: dict[int, int] = {}
        self.reached: list[tuple[int, int]] = []
        self.reached_seqs: set[int] = set()
        self.current = 1 if len(self.items) > 1 else 0
        self.finished = False
        self.landed = False          # the mission's landing (NAV_LAND / RTL) is done
        self.rtl_established = False  # (fixed-wing name kept for the runner) = landed
        self._entered: int | None = None
        self._hold_start_us: int | None = None
        self._hold_s = 0.0
        self._end_rtl = False
        self._goal = (0.0, 0.0, 0.0)

    def set_current(self, seq: int) -> None:
        self.current = seq
        self.finished = False
        self._entered = None
        self._hold_start_us = None

    @property
    def total_items(self) -> int:
        return max(len(self.items) - 1, 0)

    # ------------------------------------------------------------- geometry ---
    def item_alt_m(self, item: MissionItem) -> float:
        if item.frame in RELATIVE_FRAMES:
            return self.home_alt_m + item.z_alt_m
        return item.z_alt_m

    def item_ned(self, item: MissionItem, p_now) -> tuple[float, float, float]:
        """Item position in home NED; lat/lon 0 means "here" (ArduCopter)."""
        if item.x_lat_deg == 0.0 and item.y_lon_deg == 0.0:
            n, e = p_now[0], p_now[1]
        else:
            q = self.frame.to_ned_fast(math.radians(item.x_lat_deg), math.radians(item.y_lon_deg),
                                       self.frame.alt0_m)
            n, e = float(q[0]), float(q[1])
        if item.frame in RELATIVE_FRAMES and item.z_alt_m == 0.0 and item.command != MAV_CMD_NAV_LAND:
            d = p_now[2]                         # relative altitude 0: keep the height
        else:
            d = self.frame.alt0_m - self.item_alt_m(item)
        return n, e, d

    # ------------------------------------------------------------- stepping ---
    def _advance(self, t_us: int, to_seq: int | None = None) -> None:
        self.reached.append((t_us, self.current))
        self.reached_seqs.add(self.current)
        self.current = self.current + 1 if to_seq is None else to_seq
        self._entered = None
        self._hold_start_us = None

    def _run_do_items(self, t_us: int) -> None:
        for _ in range(len(self.items) * 4 + 8):
            if self.current >= len(self.items):
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
                self._entered = None
            elif item.command == MAV_CMD_DO_CHANGE_SPEED:
                if item.param2 > 0:
                    self.nav.speed_mps = min(max(item.param2, 0.5), 20.0)
                self._advance(t_us)
            elif item.command == MAV_CMD_DO_SET_HOME:
                self._advance(t_us)
            else:
                return

    def update(self, t_us: int, p_ned, touchdown: bool) -> CopterTarget:
        """Advance the mission; the target of the current action (reference not stepped)."""
        seq, hold = self.advance(t_us, p_ned, touchdown)
        return self.nav.target(seq, hold)

    def advance(self, t_us: int, p_ned, touchdown: bool) -> tuple[int, bool]:
        """Advance the mission: start the actions of new items, detect their ends.
        Returns (seq being flown, timed hold running). ``touchdown``: the vehicle's land
        detector saw the ground this step."""
        nav = self.nav
        if self.landed:
            return self.current, False
        self._run_do_items(t_us)
        if self.current >= len(self.items):
            # past the last item without a landing: return to launch and land
            if not self._end_rtl:
                self._end_rtl = True
                nav.rtl(p_ned)
            if touchdown:
                nav.touchdown()
                self.finished = self.landed = self.rtl_established = True
            return len(self.items), False
        item = self.items[self.current]
        cmd = item.command
        seq = self.current
        entering = self._entered != seq
        self._entered = seq
        if cmd == MAV_CMD_NAV_TAKEOFF:
            goal_d = self.frame.alt0_m - self.item_alt_m(item)
            if entering:
                if nav.phase in ("idle", "landed"):
                    nav.takeoff(p_ned, -goal_d)
                else:
                    nav.goto((nav.traj.raw[0], nav.traj.raw[1], min(goal_d, nav.traj.raw[2])))
            if nav.arrived and abs(p_ned[2] - nav.traj.p[2]) <= self.params["WPNAV_TKOFF_TOL"]:
                self._advance(t_us)
                return self.advance(t_us, p_ned, touchdown)
            return seq, False
        if cmd in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_LOITER_UNLIM,
                   MAV_CMD_NAV_LOITER_TURNS):
            if entering:
                self._goal = goal = self.item_ned(item, nav.traj.raw)
                yaw = None
                if cmd == MAV_CMD_NAV_WAYPOINT and math.isfinite(item.param4) and item.param4 != 0.0:
                    yaw = math.radians(item.param4)
                nav.goto(goal, yaw)
                if cmd == MAV_CMD_NAV_WAYPOINT:
                    self._hold_s = max(item.param1, 0.0) if math.isfinite(item.param1) else 0.0
                elif cmd == MAV_CMD_NAV_LOITER_TIME:
                    self._hold_s = max(item.param1, 0.0)
                elif cmd == MAV_CMD_NAV_LOITER_TURNS:
                    self._hold_s = max(item.param1, 0.0) * LOITER_TURN_S
                else:
                    self._hold_s = math.inf
            goal = self._goal
            radius = self.params["WPNAV_RADIUS"]
            if cmd == MAV_CMD_NAV_WAYPOINT and math.isfinite(item.param2) and item.param2 > 0.0:
                radius = item.param2
            if self._hold_start_us is None:
                dist = math.hypot(p_ned[0] - goal[0], p_ned[1] - goal[1])
                if nav.arrived and dist <= radius and abs(p_ned[2] - goal[2]) <= max(radius, 1.0):
                    self._hold_start_us = t_us
                    if self._hold_s > 0.0:
                        nav.hold(None, scored=True)
            if self._hold_start_us is not None:
                if (t_us - self._hold_start_us) * 1e-6 >= self._hold_s:
                    self._advance(t_us)
                    return self.advance(t_us, p_ned, touchdown)
                return seq, self._hold_s > 0.0
            return seq, False
        if cmd in (MAV_CMD_NAV_LAND, MAV_CMD_NAV_RETURN_TO_LAUNCH):
            if entering:
                if cmd == MAV_CMD_NAV_LAND:
                    goal = self.item_ned(item, nav.traj.raw)
                    nav.land((goal[0], goal[1]))
                else:
                    nav.rtl(p_ned)
            if touchdown and nav.phase == "land_descend":
                nav.touchdown()
                self._advance(t_us)
                self.finished = self.landed = self.rtl_established = True
            return seq, False
        # refused at load time; skip defensively
        self._advance(t_us)
        return self.advance(t_us, p_ned, touchdown)
