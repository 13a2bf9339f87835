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
climb to Q_RTL_ALT above home (if lower), fly home (or to the rally point the vehicle
chose, autopilot/fence), land; with RTL_ALT_FINAL > 0 hold that height over it instead.

Mission items (item 0 is home): NAV_TAKEOFF (vertical, param7 altitude; its lat/lon are
ignored, as ArduCopter does), NAV_WAYPOINT (param1 hold time [s], param2 acceptance
radius [m], param4 heading [deg]), NAV_LOITER_TIME (param1 seconds), NAV_LOITER_UNLIM,
NAV_LOITER_TURNS (a hold of param1 x 20 s: no circling), NAV_LOITER_TO_ALT (to the place
and its altitude, as ArduCopter), NAV_DELAY (hold where the vehicle can stop, param1
seconds), NAV_LAND (lat/lon 0: here), NAV_RETURN_TO_LAUNCH, DO_JUMP, DO_CHANGE_SPEED
(param2 [m/s], clamped to the parameter's range with a warning, replaces WPNAV_SPEED --
speed types 0 and 1 --, WPNAV_SPEED_UP -- 2 -- or WPNAV_SPEED_DN -- 3 -- for the rest of
the flight; -2 restores the parameter), DO_SET_HOME (param1 1 or all zero: here),
CONDITION_DELAY / CONDITION_DISTANCE / CONDITION_YAW (``CopterMissionSequencer``),
NAV_SPLINE_WAYPOINT (a curve through the points, ``CopterMissionSequencer._spline``),
DO_SET_ROI_LOCATION / DO_SET_ROI (the nose on the place until DO_SET_ROI_NONE or a ROI
at latitude and longitude 0), DO_SET_ROI_WPNEXT_OFFSET (the nose towards the next
waypoint turned by its yaw offset, as a structure scan asks), and the camera commands of QGroundControl's surveys
(noted once: no camera).
Latitude and longitude 0 mean "here" and altitude 0 or NaN "this height" (``item_ned``);
a NaN heading (param4, QGroundControl's null) leaves the heading to the legs.
A waypoint is reached when the reference has arrived and the vehicle is within the
acceptance radius (default WPNAV_RADIUS); the hold time starts then. Timed holds and
loiters are flagged ``hold`` in the target (scored as hold_pos_rms_m). A mission that
ends without landing returns to launch and lands (as the fixed-wing returns home).
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from ..control.multirotor import hypot
from ..geo import LocalFrame, wrap_pi
from ..geo.rotations import PI, TWO_PI
from ..geo.terrain import height_or
from ..jit import kernel, preload
from ..mission.items import (CONDITION_COMMANDS, MAV_CMD_CONDITION_DELAY,
                             MAV_CMD_CONDITION_DISTANCE, MAV_CMD_CONDITION_YAW,
                             MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_DO_JUMP, MAV_CMD_DO_SET_HOME,
                             MAV_CMD_NAV_DELAY, MAV_CMD_NAV_LAND, MAV_CMD_NAV_LOITER_TIME,
                             MAV_CMD_NAV_LOITER_TO_ALT, MAV_CMD_NAV_LOITER_TURNS,
                             MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                             MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_WAYPOINT, NAV_COMMANDS, Mission,
                             MissionItem, MAV_CMD_DO_SET_ROI_NONE, MAV_CMD_NAV_SPLINE_WAYPOINT,
                             ROI_COMMANDS, CAMERA_COMMANDS, MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET)
from ..params import Param

RELATIVE_FRAMES = (3, 6)      # GLOBAL_RELATIVE_ALT(_INT)
TERRAIN_FRAMES = (10, 11)     # GLOBAL_TERRAIN_ALT(_INT)
LOITER_TURN_S = 20.0
SPLINE_SAMPLES = 64           # points a spline leg is sampled at
YAW_MIN_LEG_M = 5.0           # shorter moves keep the heading
YAW_DONE_DEG = 5.0            # CONDITION_YAW holds with the heading this close

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
    Param("RTL_ALT_FINAL", 0.0, 0.0, 300.0, "m", "RTL (home or a rally point) ends holding this height "
          "above home instead of landing (0: land; ArduCopter's, in metres)"),
    Param("LAND_SPEED", 0.5, 0.1, 3.0, "m/s", "final descent speed"),
    Param("LAND_ALT_LOW", 5.0, 0.0, 50.0, "m", "height above home where the final descent starts"),
    Param("WPNAV_TKOFF_TOL", 0.5, 0.05, 5.0, "m", "takeoff complete this close to its height"),
)


class CopterTarget(NamedTuple):
    """What guidance asks of the position and altitude loops (home NED frame). A named
    tuple, not an ``@message`` record (autopilot/frozen.py): one is built at every step,
    and a tuple's constructor costs half the record's."""

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


#: ``new_target((kind, seq, ..., leg_a))``: a CopterTarget of all its fields in order, by
#: tuple's own constructor (the named tuple's generated ``__new__`` is a Python-level call
#: of ten arguments: about half again the cost of the target built every step)
new_target = functools.partial(tuple.__new__, CopterTarget)


# the navigation items flown to a goal (and held there) by CopterMissionSequencer._step_nav
_GOAL_COMMANDS = frozenset((MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_LOITER_UNLIM,
                            MAV_CMD_NAV_LOITER_TURNS, MAV_CMD_NAV_LOITER_TO_ALT, MAV_CMD_NAV_DELAY,
                            MAV_CMD_NAV_SPLINE_WAYPOINT))

# what the position loops are doing in each navigator phase (CopterTarget.kind)
PHASE_KIND = {"idle": "hold", "takeoff": "takeoff", "goto": "move", "hold": "hold",
               "rtl_climb": "move", "rtl_return": "move", "land_approach": "move",
               "land_descend": "land", "landed": "idle"}


# Trajectory.x, the trajectory's state in one array (read and written in place by
# trajectory_step): the raw profile's position and velocity, the reference model's p,
# v and a (the loops' reference, read by them from here: Trajectory.ref), the direction
# of the line (of the curve's segment being flown), the line's start, the goal; distance
# and speed along the path; and the leg's constants the step reads, written when a leg
# starts or changes (length, speed and acceleration limits, end speed, descent speed,
# open-ended descent, the model's w)
_RAW, _VRAW, _P, _V, _A, _U, _START, _GOAL = 0, 3, 6, 9, 12, 15, 18, 21
_S, _VS, _LEN, _VMAX, _AMAX, _VEND, _VDESC, _DESC, _W = range(24, 33)
_NX = 33
#: the trajectory's array's length (``Trajectory(x=...)``: a part of a larger array)
TRAJ_N = _NX
#: where the reference (p, v, a) lies in the array (``Trajectory.ref``)
REF_START, REF_END = _P, _A + 3
#: a curve's rows (Trajectory.curve_to): a sample point (NED), the distance along the
#: curve to it, the direction of the segment from it to the next point (the last row
#: repeats the one before); a straight line has this one row
_NO_CURVE = np.zeros((1, 7))


class _Part:
    """A named part of ``Trajectory.x``: a float, or (``n`` > 0) a list of n floats."""

    __slots__ = ("i", "n")

    def __init__(self, i: int, n: int = 0):
        self.i, self.n = i, n

    def __get__(self, tr, owner=None):
        if tr is None:
            return self
        i, n = self.i, self.n
        return tr.x[i:i + n].tolist() if n else float(tr.x[i])

    def __set__(self, tr, value) -> None:
        i, n = self.i, self.n
        if n:
            tr.x[i:i + n] = value
        else:
            tr.x[i] = value


class _Vector(_Part):
    """A named vector of ``Trajectory.x`` as a tuple (the reference's, as the target
    hands them on)."""

    __slots__ = ()

    def __get__(self, tr, owner=None):
        if tr is None:
            return self
        return tuple(tr.x[self.i:self.i + self.n].tolist())


class Trajectory:
    """The moving reference point: a raw profile along straight lines (trapezoidal
    speed, leash) smoothed by a critically damped second-order reference model,

        a = w^2 (p_raw - p) - 2 w v,

    so the acceleration fed forward changes smoothly (the raw profile's acceleration
    jumps between +a_max and -a_max; through the model it rises and falls within
    about 1/w s, never exceeding a_max, and the jerk stays below 2 a_max w / e).
    ``p``, ``v``, ``a`` are the model's output: the reference of the loops, which read
    it from ``ref``. The state is one array, ``x`` (stepped in place by
    :func:`trajectory_step`, one call a step); its parts by name below. ``x``: where
    that array lives, if not its own (TRAJ_N floats, zeros)."""

    raw = _Part(_RAW, 3)              # raw profile position
    _vraw = _Part(_VRAW, 3)
    p = _Vector(_P, 3)                # smoothed reference (the model's output)
    v = _Vector(_V, 3)
    a = _Vector(_A, 3)
    p_down = _Part(_P + 2)            # (p's depth alone: read at every step of a landing)
    start = _Vector(_START, 3)        # the line's start
    goal = _Part(_GOAL, 3)
    _s = _Part(_S)                    # distance along the line
    _vs = _Part(_VS)                  # speed along the line
    _len = _Part(_LEN)
    _vmax = _Part(_VMAX)
    _amax = _Part(_AMAX)
    _v_end = _Part(_VEND)             # speed kept at the end of a curve (flown through)
    _vdesc = _Part(_VDESC)
    w = _Part(_W)

    def __init__(self, smooth_rad_s: float = 4.0, x=None):
        self.x = np.zeros(_NX) if x is None else x
        self.x[_AMAX] = 1.0
        self.ref = self.x[REF_START:REF_END]  # (p, v, a): the loops' reference, a view of x
        self.w = smooth_rad_s
        self._poly = _NO_CURVE        # a curve (spline): its rows (_NO_CURVE: a line)
        self.curving = False          # flying one (read at every step)
        self.arrived = True           # (trajectory_arrived, kept by every change)
        # the kernels loaded now, not in flight (autopilot.jit.preload; on a copy of x)
        # (trajectory_step: in flight inside guidance_step's call, not one of its own)
        preload(trajectory_arrived, self.x)
        preload(curve_point, _NO_CURVE, 0.0)
        preload(guidance_step, self.x.copy(), _NO_CURVE, 0.004, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0,
                0.01, False)

    @property
    def descending(self) -> bool:
        """An open-ended descent (landing)."""
        return self.x[_DESC] != 0.0

    @property
    def _u(self) -> tuple:
        """Unit direction of the line (of the curve's segment at the raw reference)."""
        return tuple(self.x[_U:_U + 3].tolist())

    def _settled(self) -> None:
        """``arrived`` after a change made here rather than by the step."""
        self.arrived = trajectory_arrived(self.x)

    def reset(self, p) -> None:
        """Stationary at p."""
        p = (float(p[0]), float(p[1]), float(p[2]))
        self.p = self.raw = self.goal = self.start = p
        self.v = self.a = self._vraw = (0.0, 0.0, 0.0)
        self._len = self._s = self._vs = 0.0
        self.x[_DESC] = 0.0
        self._poly = _NO_CURVE
        self.curving = False
        self._v_end = 0.0
        self._settled()

    def line_to(self, goal, v_h: float, v_up: float, v_dn: float, a_h: float, a_z: float) -> None:
        """From the raw reference's current position to ``goal`` (NED)."""
        r = self.raw
        d = [goal[0] - r[0], goal[1] - r[1], goal[2] - r[2]]
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        self.start = r
        self.goal = (float(goal[0]), float(goal[1]), float(goal[2]))
        self.x[_DESC] = 0.0
        self._poly = _NO_CURVE
        self.curving = False
        self._v_end = 0.0
        if length < 1e-6:
            self._len = self._s = self._vs = 0.0
            self._vraw = (0.0, 0.0, 0.0)
            self._settled()
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
        self.x[_U:_U + 3] = u
        self._len, self._s, self._vs = length, 0.0, min(vs, vmax)
        self._vmax, self._amax = vmax, amax
        self._settled()

    def curve_to(self, points, v_h: float, v_up: float, v_dn: float, a_h: float, a_z: float,
                 v_end: float = 0.0) -> None:
        """Along the curve sampled by ``points`` (NED; the first is the raw reference's
        position), with the speed and acceleration limits of the straight line between
        its ends, the speed also held to sqrt(a_h R) on its tightest bend of radius R
        (the lateral acceleration), ending at ``v_end`` (> 0: flown through, the next
        curve goes on from there at that speed)."""
        pts = [tuple(float(c) for c in q) for q in points]
        self.line_to(pts[-1], v_h, v_up, v_dn, a_h, a_z)
        if self._len <= 0.0 or len(pts) < 3:
            return
        cum = [0.0]
        for a, b in zip(pts, pts[1:]):
            cum.append(cum[-1] + math.dist(a, b))
        if cum[-1] < 1e-3:
            return
        r_min = math.inf
        for a, b, c in zip(pts, pts[1:], pts[2:]):
            u1 = (b[0] - a[0], b[1] - a[1])
            u2 = (c[0] - b[0], c[1] - b[1])
            l1, l2 = math.hypot(*u1), math.hypot(*u2)
            if l1 > 1e-6 and l2 > 1e-6:
                turn = abs(math.atan2(u1[0] * u2[1] - u1[1] * u2[0], u1[0] * u2[0] + u1[1] * u2[1]))
                if turn > 1e-6:
                    r_min = min(r_min, 0.5 * (l1 + l2) / turn)
        self._vmax = min(self._vmax, math.sqrt(a_h * r_min))
        # each segment's direction once, here (the step looks it up)
        dirs = []
        for a, b in zip(pts, pts[1:]):
            ln = max(math.dist(a, b), 1e-9)
            dirs.append(((b[0] - a[0]) / ln, (b[1] - a[1]) / ln, (b[2] - a[2]) / ln))
        dirs.append(dirs[-1])
        self._poly = np.array([(*q, c, *u) for q, c, u in zip(pts, cum, dirs)])
        self._len = cum[-1]
        self.curving = True
        self._v_end = min(max(v_end, 0.0), self._vmax)
        u = dirs[0]
        vr = self._vraw
        self.x[_U:_U + 3] = u
        self._vs = min(max(0.0, vr[0] * u[0] + vr[1] * u[1] + vr[2] * u[2]), self._vmax)
        self._settled()

    def shift(self, d) -> None:
        """Move every position by ``d`` (NED) without changing the motion: the same
        reference in a frame whose origin moved by -d (home moved)."""
        for part in ("p", "raw", "goal", "start"):
            v = getattr(self, part)
            setattr(self, part, (v[0] + d[0], v[1] + d[1], v[2] + d[2]))
        if self.curving:
            q = self._poly
            q[:, 0] += d[0]
            q[:, 1] += d[1]
            q[:, 2] += d[2]
        self._settled()

    def retune(self, v_h: float, v_up: float, v_dn: float) -> None:
        """New speed limits for the line being flown (a speed change in flight: the
        profile slows down at its acceleration limit or speeds up)."""
        if self.descending or self._len <= 0.0:
            return
        if self.curving:
            self._vmax = min(self._vmax, v_h)
            return
        u = self._u
        uh, uz = math.hypot(u[0], u[1]), abs(u[2])
        vz = v_up if u[2] < 0.0 else v_dn
        self._vmax = min(v_h / uh if uh > 1e-9 else math.inf, vz / uz if uz > 1e-9 else math.inf)

    def stopping_point(self) -> tuple[float, float, float]:
        """Where the raw profile stops if it brakes now at its acceleration limit."""
        r = self.raw
        vs = self._vs
        if self.descending or self._len <= 0.0 or vs <= 0.0:
            return (r[0], r[1], r[2])
        d = min(vs * vs / (2.0 * self._amax), self._len - self._s)
        if self.curving:
            return curve_point(self._poly, self._s + d)[1:]
        u = self._u
        return (r[0] + u[0] * d, r[1] + u[1] * d, r[2] + u[2] * d)

    def descend(self, speed: float, accel: float) -> None:
        """Open-ended vertical descent at ``speed`` (landing); horizontal held."""
        self.x[_DESC] = 1.0
        self._vdesc = speed
        self._amax = accel
        self._len = self._s = self._vs = 0.0
        self.arrived = False

    def set_descent_speed(self, speed: float) -> None:
        self._vdesc = speed

    def update(self, dt: float, p_vehicle, leash: float) -> None:
        """One step of the raw profile and the reference model (:func:`trajectory_step`)."""
        self.arrived = trajectory_step(self.x, self._poly, dt, p_vehicle[0], p_vehicle[1],
                                       p_vehicle[2], leash)


@kernel
def curve_point(poly, s):
    """The segment i and the point at distance ``s`` along a sampled curve (its rows:
    ``Trajectory.curve_to``), the distance held to the curve."""
    n = poly.shape[0]
    lo, hi = 0, n                   # bisect_right on the distances
    while lo < hi:
        mid = (lo + hi) // 2
        if s < poly[mid, 3]:
            hi = mid
        else:
            lo = mid + 1
    i = lo - 1                      # min(max(lo - 1, 0), n - 2)
    i = 0 if i < 0 else i
    i = n - 2 if i > n - 2 else i
    seg = poly[i + 1, 3] - poly[i, 3]
    f = 1.0
    if seg > 1e-9:                  # min(max(f, 0), 1), as Python's
        f = (s - poly[i, 3]) / seg
        f = 0.0 if 0.0 > f else f
        f = 1.0 if 1.0 < f else f
    return (i, poly[i, 0] + f * (poly[i + 1, 0] - poly[i, 0]),
            poly[i, 1] + f * (poly[i + 1, 1] - poly[i, 1]),
            poly[i, 2] + f * (poly[i + 1, 2] - poly[i, 2]))


@kernel
def trajectory_arrived(x):
    """The raw profile is at its goal and the smoothed reference has settled on it
    (``Trajectory.x``)."""
    if x[_DESC] != 0.0 or x[_S] < x[_LEN]:
        return False
    if x[_VEND] > 0.0:
        return True                 # a curve flown through: done when its end is passed
    if x[_VS] != 0.0:
        return False
    return (abs(x[_P] - x[_GOAL]) + abs(x[_P + 1] - x[_GOAL + 1]) + abs(x[_P + 2] - x[_GOAL + 2])
            < 0.03 and abs(x[_V]) + abs(x[_V + 1]) + abs(x[_V + 2]) < 0.05)


@kernel
def trajectory_step(x, poly, dt, pv_n, pv_e, pv_d, leash):
    """One step of :class:`Trajectory` on its state ``x`` (in place), ``poly`` the curve
    flown (``_NO_CURVE``: a line), the vehicle at (pv_n, pv_e, pv_d): the reference's
    p, v, a written in ``x``. Returns whether it has arrived (:func:`trajectory_arrived`).
    (min / max spelt out as Python's.)"""
    if x[_DESC] != 0.0:
        # open-ended descent at the descent speed, reached at the acceleration limit
        vd0 = x[_VRAW + 2]
        dv = x[_VDESC] - vd0
        lim = x[_AMAX] * dt
        vd1 = vd0 + (lim if dv > lim else -lim if dv < -lim else dv)
        # leash: the reference may not get more than 1 m below the vehicle
        if x[_RAW + 2] - pv_d > 1.0 and vd1 > 0.0:
            vd1 = 0.0
        x[_RAW + 2] += 0.5 * (vd0 + vd1) * dt
        x[_VRAW], x[_VRAW + 1], x[_VRAW + 2] = 0.0, 0.0, vd1
    elif x[_LEN] <= 0.0:
        x[_VRAW], x[_VRAW + 1], x[_VRAW + 2] = 0.0, 0.0, 0.0
    else:
        length, v_end = x[_LEN], x[_VEND]
        vs0 = x[_VS]
        remaining = length - x[_S]
        lim = x[_AMAX] * dt
        # braking curve v = sqrt(2 a d): followed exactly (the discrete steps need a
        # little more than a_max at its very end), so the profile stops on the goal
        v_brake = math.sqrt(2.0 * x[_AMAX] * (0.0 if 0.0 > remaining else remaining)
                            + v_end * v_end)
        v_goal = v_brake if v_brake < x[_VMAX] else x[_VMAX]
        # leash: beyond it from the vehicle the raw profile brakes and waits
        ex, ey, ez = x[_RAW] - pv_n, x[_RAW + 1] - pv_e, x[_RAW + 2] - pv_d
        if ex * ex + ey * ey + ez * ez > leash * leash:
            v_goal = 0.0
        dv = v_goal - vs0
        vs1 = vs0 + (lim if dv > lim else -lim if dv < -lim else dv)
        if vs1 > v_brake:
            vs1 = v_brake
        s = x[_S] + 0.5 * (vs0 + vs1) * dt
        if s >= length or (vs1 <= 0.0 and remaining < 1e-3):
            vs1 = v_end if v_end > 0.0 and s >= length else 0.0
            s = length
        x[_S], x[_VS] = s, vs1
        if poly.shape[0] > 1:
            # along a curve: the point at s, the direction of its segment
            i, rn, re, rd = curve_point(poly, s)
            x[_U], x[_U + 1], x[_U + 2] = poly[i, 4], poly[i, 5], poly[i, 6]
        else:
            rn = x[_START] + x[_U] * s
            re = x[_START + 1] + x[_U + 1] * s
            rd = x[_START + 2] + x[_U + 2] * s
        x[_RAW], x[_RAW + 1], x[_RAW + 2] = rn, re, rd
        x[_VRAW], x[_VRAW + 1], x[_VRAW + 2] = x[_U] * vs1, x[_U + 1] * vs1, x[_U + 2] * vs1
    # reference model: a = w^2 (p_raw - p) - 2 w v  (semi-implicit Euler)
    w = x[_W]
    w2, w2x = w * w, 2.0 * w
    a0 = w2 * (x[_RAW] - x[_P]) - w2x * x[_V]
    a1 = w2 * (x[_RAW + 1] - x[_P + 1]) - w2x * x[_V + 1]
    a2 = w2 * (x[_RAW + 2] - x[_P + 2]) - w2x * x[_V + 2]
    v0, v1, v2 = x[_V] + a0 * dt, x[_V + 1] + a1 * dt, x[_V + 2] + a2 * dt
    p0, p1, p2 = x[_P] + v0 * dt, x[_P + 1] + v1 * dt, x[_P + 2] + v2 * dt
    x[_P], x[_P + 1], x[_P + 2] = p0, p1, p2
    x[_V], x[_V + 1], x[_V + 2] = v0, v1, v2
    x[_A], x[_A + 1], x[_A + 2] = a0, a1, a2
    return trajectory_arrived(x)


@kernel
def guidance_step(x, poly, dt, pv_n, pv_e, pv_d, leash, yaw_ref, goal, yaw_step, follow):
    """One step of the navigator's reference (:meth:`CopterNavigator.update`): the
    trajectory (:func:`trajectory_step`), then the heading reference ``yaw_ref`` slewed
    towards ``goal`` by at most ``yaw_step`` (YAW_RATE_MAX dt; ``goal`` NaN: none), or
    with ``follow`` towards the path's course after the step (the direction of the
    curve's segment at the raw reference) where that is not near vertical. Returns
    (arrived, yaw_ref)."""
    arrived = trajectory_step(x, poly, dt, pv_n, pv_e, pv_d, leash)
    if follow and hypot(x[_U], x[_U + 1]) > 0.2:
        goal = math.atan2(x[_U + 1], x[_U])
    if goal == goal:
        # max(-step, min(step, wrap_pi(goal - yaw_ref))) spelt out; wrap_pi written out
        err = (goal - yaw_ref + PI) % TWO_PI - PI
        err = err if err < yaw_step else yaw_step
        yaw_ref = (yaw_ref + (err if err > -yaw_step else -yaw_step) + PI) % TWO_PI - PI
    return arrived, yaw_ref


class CopterNavigator:
    """One guidance action at a time on top of :class:`Trajectory`.

    Phases: ``idle``, ``takeoff``, ``goto``, ``hold``, ``rtl_climb``, ``rtl_return``,
    ``land_approach``, ``land_descend``, ``landed``. ``traj_x``: where the trajectory's
    array lives, if not its own (Trajectory)."""

    def __init__(self, params, traj_x=None):
        self.params = params
        self.traj = Trajectory(params["WPNAV_SMOOTH"], traj_x)
        self.phase = "idle"
        self.leg_id = 0
        self.yaw_ref = 0.0
        self._yaw_goal: float | None = None
        self.hold_scored = False
        self.goal_ne = (0.0, 0.0)
        self.land_ne = (0.0, 0.0)
        self.speed_mps: float | None = None   # DO_CHANGE_SPEED override of WPNAV_SPEED
        self.speed_up_mps: float | None = None   # ... of WPNAV_SPEED_UP
        self.speed_dn_mps: float | None = None   # ... of WPNAV_SPEED_DN
        # CONDITION_YAW: the heading still to turn through [rad, signed] at a rate [rad/s];
        # None when the heading follows the legs
        self._yaw_left: float | None = None
        self._yaw_fix_rate = 0.0
        self.yaw_fix_target = 0.0
        self.roi_ne: tuple | None = None   # DO_SET_ROI_LOCATION: the nose points there
        self.roi_wpnext_deg: float | None = None   # DO_SET_ROI_WPNEXT_OFFSET: yaw offset
        # a terrain-frame leg: (ground_d(n, e), start NE, goal NE, ground depth at start,
        # at goal); the reference's depth follows the ground between them (``target``)
        self.terrain_leg = None

    # ----------------------------------------------------------------- actions --
    def init(self, p_ned, yaw: float) -> None:
        """Take over a vehicle at p_ned (a mode change from a manual mode, arming)."""
        self.traj.reset(p_ned)
        self.yaw_ref = yaw
        self._yaw_goal = None
        self._yaw_left = None
        self.phase = "idle"

    def shift(self, d) -> None:
        """Home moved: every position by ``d`` (NED), the motion unchanged."""
        self.traj.shift(d)
        self.goal_ne = (self.goal_ne[0] + d[0], self.goal_ne[1] + d[1])
        self.land_ne = (self.land_ne[0] + d[0], self.land_ne[1] + d[1])
        self.rtl_ne = (self.rtl_ne[0] + d[0], self.rtl_ne[1] + d[1])

    def fix_yaw(self, turn_rad: float, rate_rad_s: float) -> None:
        """Turn the heading reference through ``turn_rad`` (signed: + clockwise seen from
        above) at ``rate_rad_s``, then hold it, whatever the legs flown meanwhile
        (CONDITION_YAW, ArduCopter's fixed-yaw mode) until `release_yaw`."""
        self._yaw_left = turn_rad
        self._yaw_fix_rate = rate_rad_s
        self.yaw_fix_target = wrap_pi(self.yaw_ref + turn_rad)

    def release_yaw(self) -> None:
        """The heading follows the legs again."""
        self._yaw_left = None

    @property
    def yaw_fixed(self) -> bool:
        return self._yaw_left is not None

    @property
    def yaw_fix_turned(self) -> bool:
        """The fixed heading's reference has turned all the way."""
        return self._yaw_left == 0.0

    def speeds(self) -> tuple[float, float, float]:
        """Horizontal, climb and descent speed limits: DO_CHANGE_SPEED's, else WPNAV_*."""
        p = self.params
        return (self.speed_mps if self.speed_mps is not None else p["WPNAV_SPEED"],
                self.speed_up_mps if self.speed_up_mps is not None else p["WPNAV_SPEED_UP"],
                self.speed_dn_mps if self.speed_dn_mps is not None else p["WPNAV_SPEED_DN"])

    def _line(self, goal) -> None:
        p = self.params
        self.terrain_leg = None
        self.traj.line_to(goal, *self.speeds(), p["WPNAV_ACCEL"], p["WPNAV_ACCEL_Z"])
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

    def spline(self, points, v_end: float = 0.0) -> None:
        """Along a curve sampled by ``points`` (NED, from the raw reference), ending at
        ``v_end`` (NAV_SPLINE_WAYPOINT); the heading follows the path."""
        p = self.params
        self.terrain_leg = None
        self.traj.curve_to(points, *self.speeds(), p["WPNAV_ACCEL"], p["WPNAV_ACCEL_Z"], v_end)
        self.leg_id += 1
        goal = points[-1]
        self.goal_ne = (goal[0], goal[1])
        self._yaw_goal = None
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

    def rtl(self, p_vehicle, rally=None) -> None:
        """Climb to Q_RTL_ALT (if lower), return home, land. ``rally``: (north, east,
        height above home) of the rally point to return to instead of home (at its
        height, then the same landing: ArduCopter's RTL to a rally point); None: what
        ``rally_source`` (the vehicle) chooses, home when it chooses none."""
        h_rtl = self.params["Q_RTL_ALT"]
        p = self.traj.raw
        h = -p[2]
        if rally is None and self.rally_source is not None:
            rally = self.rally_source()       # the vehicle's choice (autopilot/fence)
        ne = (0.0, 0.0) if rally is None else (rally[0], rally[1])
        if rally is not None and rally[2] > 0.0:
            h_rtl = max(h_rtl, rally[2])
        self.land_ne = self.rtl_ne = ne
        far = math.hypot(p[0] - ne[0], p[1] - ne[1]) > self.params["WPNAV_RADIUS"]
        if h_rtl > 0.0 and h < h_rtl - 0.2 and far:
            self._line((p[0], p[1], -h_rtl))
            self._yaw_goal = None
            self.phase = "rtl_climb"
        else:
            self._line((ne[0], ne[1], -max(h, h_rtl) if h_rtl > 0.0 else p[2]))
            self.phase = "rtl_return"

    rtl_ne = (0.0, 0.0)        # where RTL returns to (home, or a rally point)
    rally_source = None        # () -> (north, east, height) of the rally point for RTL, or None

    def touchdown(self) -> None:
        """The land detector saw the touchdown."""
        self.traj.reset(self.traj.p)
        self.phase = "landed"
        self.leg_id += 1

    # ----------------------------------------------------------------- stepping --
    def update(self, dt: float, p_vehicle, yaw: float) -> None:
        """One step: the phase's changes, then the reference and the heading
        (:func:`guidance_step` on the trajectory's array and :meth:`step_inputs`)."""
        self.traj.arrived, self.yaw_ref = guidance_step(self.traj.x,
                                                        *self.step_inputs(dt, p_vehicle))

    def step_inputs(self, dt: float, p_vehicle) -> tuple:
        """The first half of :meth:`update`: the phase's changes at this step (an
        arrival starts the next part of a return or a landing), then the arguments of
        this step's :func:`guidance_step` after the trajectory's array (its (arrived,
        yaw_ref) go to ``traj.arrived`` and ``yaw_ref``): the vehicle's loops may take
        them into their own call (vehicle_quad.guide_track)."""
        prm = self.params
        traj = self.traj
        ph = self.phase
        if ph in ("rtl_climb",) and traj.arrived:
            self._line((self.rtl_ne[0], self.rtl_ne[1], traj.p[2]))
            self.phase = ph = "rtl_return"
        if ph == "rtl_return" and traj.arrived and prm["RTL_ALT_FINAL"] > 0.0:
            # landing disabled: hold over the return point at RTL_ALT_FINAL
            self._line((self.rtl_ne[0], self.rtl_ne[1], -prm["RTL_ALT_FINAL"]))
            self._yaw_goal = None
            self.hold_scored = False
            self.phase = ph = "hold"
        if ph in ("rtl_return", "land_approach") and traj.arrived:
            traj.descend(prm["WPNAV_SPEED_DN"], prm["WPNAV_ACCEL_Z"])
            self.leg_id += 1
            self._yaw_goal = None
            self.phase = ph = "land_descend"
        if ph == "land_descend":
            low = -traj.p_down <= prm["LAND_ALT_LOW"]
            traj.set_descent_speed(prm["LAND_SPEED"] if low else prm["WPNAV_SPEED_DN"])
        dz = 0.0 if self.terrain_leg is None else self.terrain_offset(p_vehicle[0], p_vehicle[1])
        if dz:
            # the vehicle follows the ground: its leash to the straight line's reference
            # is measured without the ground's offset
            p_vehicle = (p_vehicle[0], p_vehicle[1], p_vehicle[2] - dz)
        # heading reference slewed towards its goal: a fixed heading (CONDITION_YAW),
        # else the region of interest, else along a curve (its course after the step:
        # ``follow``), else towards the leg's end; NaN for none (guidance_step)
        goal = self._yaw_goal
        follow = False
        if self.roi_ne is not None and ph not in ("idle", "landed", "takeoff"):
            dn, de = self.roi_ne[0] - p_vehicle[0], self.roi_ne[1] - p_vehicle[1]
            goal = math.atan2(de, dn) if math.hypot(dn, de) > 1.0 else None
        else:
            follow = ph == "goto" and traj.curving
        if self.roi_wpnext_deg is not None and self.roi_ne is None and ph == "goto":
            # towards the next waypoint, turned by the offset (a structure scan's camera
            # looks sideways at the structure)
            dn, de = self.goal_ne[0] - traj.start[0], self.goal_ne[1] - traj.start[1]
            if math.hypot(dn, de) > YAW_MIN_LEG_M:
                goal = wrap_pi(math.atan2(de, dn) + math.radians(self.roi_wpnext_deg))
                follow = False
        if self._yaw_left is not None:
            step = self._yaw_fix_rate * dt
            turn = max(-step, min(step, self._yaw_left))
            self._yaw_left = 0.0 if abs(self._yaw_left - turn) < 1e-9 else self._yaw_left - turn
            self.yaw_ref = self.yaw_fix_target if self._yaw_left == 0.0 else wrap_pi(self.yaw_ref + turn)
            goal, follow = None, False
        return (traj._poly, dt, p_vehicle[0], p_vehicle[1], p_vehicle[2],
                prm["WPNAV_LEASH"], self.yaw_ref, math.nan if goal is None else goal,
                math.radians(prm["YAW_RATE_MAX"]) * dt, follow)

    @property
    def arrived(self) -> bool:
        return self.traj.arrived

    def terrain_offset(self, n: float, e: float) -> float:
        """On a terrain-frame leg (``terrain_leg``, not None: the callers ask, as this is
        asked every step), the depth to add at (n, e) to the straight line's: the
        ground's rise or fall there against the straight line between the ground at the
        leg's ends, so the reference keeps its height above the ground; 0 outside the
        goto and hold phases or without data."""
        if self.phase not in ("goto", "hold"):
            return 0.0
        ground_d, a, b, d_a, d_b = self.terrain_leg
        ln = math.hypot(b[0] - a[0], b[1] - a[1])
        f = ((n - a[0]) * (b[0] - a[0]) + (e - a[1]) * (b[1] - a[1])) / (ln * ln) if ln > 1e-3 else 1.0
        f = min(max(f, 0.0), 1.0)
        g = ground_d(n, e)
        return 0.0 if g is None else g - (d_a + f * (d_b - d_a))

    def target(self, seq: int, hold: bool = False) -> CopterTarget:
        tr = self.traj
        kind = PHASE_KIND[self.phase]
        goal = self.land_ne if self.phase in ("land_descend", "landed") else self.goal_ne
        # p, v, a (the reference) and the leg's start in one read of the array (the
        # line's direction between them)
        pn, pe, pd, vn, ve, vd, an, ae, ad, _, _, _, sn, se = tr.x[_P:_START + 2].tolist()
        dz = 0.0 if self.terrain_leg is None else self.terrain_offset(pn, pe)
        if dz:
            pd += dz
        return new_target((kind, seq, self.leg_id, (pn, pe, pd), (vn, ve, vd), (an, ae, ad),
                           self.yaw_ref, hold, goal, (sn, se)))


class CopterMissionSequencer:
    """Mission items -> navigator actions (module docstring).

    DO items run in mission order when the navigation item before them completes
    (DO_JUMP follows its target, DO_CHANGE_SPEED, DO_SET_HOME). A condition
    (CONDITION_DELAY / _DISTANCE / _YAW) gates only the DO items after it, as AP_Mission
    does: the next navigation item starts at once, the gated items wait in ``pending``
    until the condition holds, and those still waiting when that navigation item
    completes are dropped (said in ``notices``). CONDITION_YAW turns the nose and holds
    it for the navigation item it belongs to; the condition holds once the vehicle's
    heading is within YAW_DONE_DEG of the fixed heading.

    ``notices``: (t_s, MAV_SEVERITY, text) for the vehicle to announce (STATUSTEXT);
    ``home_request``: (lat_rad, lon_rad, alt_m) or "here", a DO_SET_HOME for the vehicle
    to apply (the next navigation item starts only after it did)."""

    def __init__(self, mission: Mission, frame: LocalFrame, params, nav: CopterNavigator):
        self.params = params
        self.frame = frame
        self.nav = nav
        self.notices: list[tuple[float, int, str]] = []
        self.terrain = None   # (lat_deg, lon_deg) -> terrain height [m MSL] or None
        self.load(mission)

    def load(self, mission: Mission) -> None:
        self.mission = mission
        self.items: tuple[MissionItem, ...] = tuple(mission.items)
        self.home_alt_m = self.frame.alt0_m
        self.jump_counts: dict[int, int] = {}
        self.reached: list[tuple[int, int]] = []
        self.reached_seqs: set[int] = set()
        self.skipped_seqs: set[int] = set()   # DO items dropped behind a condition (never run)
        self.current = 1 if len(self.items) > 1 else 0
        self.finished = False
        self.landed = False          # the mission's landing (NAV_LAND / RTL) is done
        self.rtl_established = False  # (fixed-wing name kept for the runner) = landed
        self._entered: int | None = None
        self._hold_start_us: int | None = None
        self._hold_s = 0.0
        self._end_rtl = False
        self._goal = (0.0, 0.0, 0.0)
        self.pending: list[MissionItem] = []     # DO items waiting behind a condition
        self._cond_start_us: int | None = None   # when the first pending condition started
        self._yaw_owner: int | None = None       # nav item a CONDITION_YAW belongs to (-1: next)
        self.home_request = None
        self.nav.roi_ne = None
        self.nav.roi_wpnext_deg = None
        self._camera_said = False

    def set_current(self, seq: int) -> None:
        self.current = seq
        self.finished = False
        self._entered = None
        self._hold_start_us = None
        self.pending = []
        self._cond_start_us = None

    @property
    def total_items(self) -> int:
        return max(len(self.items) - 1, 0)

    def shift(self, d) -> None:
        """Home moved: the goal being flown moves by ``d`` (NED) in the new frame."""
        g = self._goal
        self._goal = (g[0] + d[0], g[1] + d[1], g[2] + d[2])
        if self.nav.roi_ne is not None:
            r = self.nav.roi_ne
            self.nav.roi_ne = (r[0] + d[0], r[1] + d[1])

    def _say(self, t_us: int, severity: int, text: str) -> None:
        self.notices.append((t_us * 1e-6, severity, text))

    # ------------------------------------------------------------- geometry ---
    def item_alt_m(self, item: MissionItem) -> float:
        if item.frame in TERRAIN_FRAMES:
            return self.terrain_alt_m(item.x_lat_deg, item.y_lon_deg) + item.z_alt_m
        if item.frame in RELATIVE_FRAMES:
            return self.home_alt_m + item.z_alt_m
        return item.z_alt_m

    def terrain_alt_m(self, lat_deg: float, lon_deg: float) -> float:
        """The terrain's height [m MSL] there: from ``terrain`` (a callable (lat_deg,
        lon_deg) -> metres or None, set by the vehicle), else flat at home altitude."""
        return height_or(self.terrain, lat_deg, lon_deg, self.home_alt_m)

    def item_ned(self, item: MissionItem, p_now) -> tuple[float, float, float]:
        """Item position in home NED. As ArduCopter reads a location (loc_from_cmd):
        latitude and longitude 0 mean "here", altitude 0 (any frame) "this height";
        "here" is ``p_now``, the reference's position (the last destination)."""
        if item.x_lat_deg == 0.0 and item.y_lon_deg == 0.0:
            n, e = p_now[0], p_now[1]
        else:
            q = self.frame.to_ned_fast(math.radians(item.x_lat_deg), math.radians(item.y_lon_deg),
                                       self.frame.alt0_m)
            n, e = float(q[0]), float(q[1])
        if math.isnan(item.z_alt_m) or (item.z_alt_m == 0.0 and item.command != MAV_CMD_NAV_LAND):
            d = p_now[2]                         # altitude 0 or NaN: keep the height
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

    def _nav_done(self, t_us: int) -> None:
        """The current navigation item completed: DO items still gated are dropped."""
        self._drop_pending(t_us, f"item {self.current} done")
        self._advance(t_us)

    def _drop_pending(self, t_us: int, why: str) -> None:
        """DO items a condition still holds back are dropped (AP_Mission), and said."""
        if self.pending:
            self.skipped_seqs.update(it.seq for it in self.pending)
            names = ", ".join(f"{it.seq} {it.command_name}" for it in self.pending)
            self._say(t_us, 4, f"Mission: {why} before its conditions held; skipped {names}")
            self.pending = []
            self._cond_start_us = None

    def _jump(self, item: MissionItem, t_us: int) -> None:
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

    def _run_do_items(self, t_us: int, yaw: float) -> bool:
        """DO items at the current index until a navigation item is current. A condition
        moves the DO items after it (to the next navigation item, jumps followed) to
        ``pending``. False when a DO_SET_HOME waits for the vehicle."""
        gating = False
        for _ in range(len(self.items) * 4 + 8):
            if self.current >= len(self.items):
                return True
            item = self.items[self.current]
            cmd = item.command
            if cmd == MAV_CMD_DO_JUMP:
                self._jump(item, t_us)
            elif cmd in NAV_COMMANDS:
                return True
            elif gating or cmd in CONDITION_COMMANDS:
                gating = True
                self.pending.append(item)
                self.current += 1
            else:
                self._do(item, t_us, yaw)
                self._advance(t_us)
                if self.home_request is not None:
                    return False
        return False            # a long run of DO items and jumps: on at the next step

    def _do(self, item: MissionItem, t_us: int, yaw: float) -> None:
        """Execute one DO item (conditions start here)."""
        cmd = item.command
        nav = self.nav
        prm = self.params
        if cmd == MAV_CMD_DO_CHANGE_SPEED:
            kind = int(item.param1)
            v = item.param2
            name, attr = {2: ("WPNAV_SPEED_UP", "speed_up_mps"),
                          3: ("WPNAV_SPEED_DN", "speed_dn_mps")}.get(kind, ("WPNAV_SPEED", "speed_mps"))
            if math.isfinite(item.param3) and item.param3 > 0.0:
                # ArduCopter ignores it too; said, not silently dropped
                self._say(t_us, 4, f"Mission: item {item.seq} throttle {item.param3:g} % not "
                                   "used: the quadrotor's loops set the thrust")
            if v == -2.0:
                setattr(nav, attr, None)        # back to the parameter
            elif v > 0.0:
                spec = prm.declaration(name)
                lo, hi = spec.min, spec.max
                if not lo <= v <= hi:
                    self._say(t_us, 4, f"Mission: item {item.seq} speed {v:g} m/s outside "
                                       f"{name} {lo:g}..{hi:g}: {min(max(v, lo), hi):g} m/s")
                setattr(nav, attr, min(max(v, lo), hi))
            nav.traj.retune(*nav.speeds())       # the leg being flown too
        elif cmd in ROI_COMMANDS or cmd == MAV_CMD_DO_SET_ROI_NONE:
            # the nose points at the region of interest for the rest of the mission
            # (ArduCopter's auto-yaw ROI); DO_SET_ROI_NONE or a location at 0, 0 clears it
            nav.roi_wpnext_deg = None
            if cmd == MAV_CMD_DO_SET_ROI_NONE or (item.x_lat_deg == 0.0 and item.y_lon_deg == 0.0):
                nav.roi_ne = None
            else:
                q = self.frame.to_ned_fast(math.radians(item.x_lat_deg),
                                           math.radians(item.y_lon_deg), self.frame.alt0_m)
                nav.roi_ne = (float(q[0]), float(q[1]))
        elif cmd == MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET:
            # the nose towards the next waypoint turned by param7 (yaw offset, deg)
            nav.roi_ne = None
            nav.roi_wpnext_deg = item.z_alt_m if math.isfinite(item.z_alt_m) else 0.0
        elif cmd in CAMERA_COMMANDS:
            if not self._camera_said:
                self._camera_said = True
                self._say(t_us, 6, "Mission: camera commands noted: no camera on this airframe")
        elif cmd == MAV_CMD_DO_SET_HOME:
            use_here = item.param1 == 1.0 or (item.x_lat_deg == 0.0 and item.y_lon_deg == 0.0
                                              and item.z_alt_m == 0.0)
            if use_here:
                self.home_request = "here"
            else:
                self.home_request = (math.radians(item.x_lat_deg), math.radians(item.y_lon_deg),
                                     self.item_alt_m(item))

    def _start_yaw(self, item: MissionItem, yaw: float) -> None:
        """CONDITION_YAW: the signed turn as ArduCopter's fixed yaw computes it."""
        angle = math.radians(item.param1)
        direction = int(item.param3)
        if item.param4 == 1.0:                   # relative to the heading
            turn = angle * (direction if direction != 0 else 1)
        else:
            turn = wrap_pi(angle - self.nav.yaw_ref)
            if direction < 0 and turn > 0.0:
                turn -= 2.0 * math.pi
            elif direction > 0 and turn < 0.0:
                turn += 2.0 * math.pi
        rate_max = self.params["YAW_RATE_MAX"]
        rate = item.param2 if math.isfinite(item.param2) and item.param2 > 0.0 else rate_max
        self.nav.fix_yaw(turn, math.radians(min(rate, rate_max)))
        self._yaw_owner = self._entered if self._entered == self.current else -1

    def _condition_holds(self, item: MissionItem, t_us: int, p_ned, yaw: float) -> bool:
        if self._cond_start_us is None:
            self._cond_start_us = t_us
            if item.command == MAV_CMD_CONDITION_YAW:
                self._start_yaw(item, yaw)
        if item.command == MAV_CMD_CONDITION_DELAY:
            return (t_us - self._cond_start_us) * 1e-6 >= item.param1
        if item.command == MAV_CMD_CONDITION_DISTANCE:
            g = self._goal                       # horizontal, as ArduCopter's wp_distance
            return math.hypot(p_ned[0] - g[0], p_ned[1] - g[1]) <= item.param1
        # CONDITION_YAW
        return (self.nav.yaw_fix_turned and abs(wrap_pi(yaw - self.nav.yaw_fix_target))
                <= math.radians(YAW_DONE_DEG))

    def _run_pending(self, t_us: int, p_ned, yaw: float) -> None:
        """The gated DO items, in order, as far as their conditions allow."""
        while self.pending:
            item = self.pending[0]
            if item.command in CONDITION_COMMANDS:
                if not self._condition_holds(item, t_us, p_ned, yaw):
                    return
                self._cond_start_us = None
            else:
                self._do(item, t_us, yaw)
            self.pending.pop(0)
            self.reached.append((t_us, item.seq))
            self.reached_seqs.add(item.seq)

    def _entering(self, seq: int) -> None:
        """A navigation item starts: a fixed heading belongs to the item it was set
        for (or, set between items, to this one); any other is released."""
        if self.nav.yaw_fixed and self._yaw_owner not in (-1, seq):
            self.nav.release_yaw()
        elif self.nav.yaw_fixed:
            self._yaw_owner = seq

    def update(self, t_us: int, p_ned, touchdown: bool) -> CopterTarget:
        """Advance the mission; the target of the current action (reference not stepped)."""
        seq, hold = self.advance(t_us, p_ned, touchdown)
        return self.nav.target(seq, hold)

    def advance(self, t_us: int, p_ned, touchdown: bool, yaw: float | None = None) -> tuple[int, bool]:
        """Advance the mission: start the actions of new items, detect their ends.
        Returns (seq being flown, timed hold running). ``touchdown``: the vehicle's land
        detector saw the ground this step; ``yaw``: the vehicle's heading (default the
        reference's)."""
        if yaw is None:
            yaw = self.nav.yaw_ref
        if self.landed:
            return self.current, False
        if self.home_request is not None:
            return self.current, False          # the vehicle moves home first
        # (the navigation item entered: no DO item before it left to run)
        if self._entered != self.current and not self._run_do_items(t_us, yaw):
            return self.current, False
        seq, hold = self._step_nav(t_us, p_ned, touchdown, yaw)
        if self.pending and not self.landed:
            self._run_pending(t_us, p_ned, yaw)
        return seq, hold

    def _step_nav(self, t_us: int, p_ned, touchdown: bool, yaw: float) -> tuple[int, bool]:
        nav = self.nav
        if self.current >= len(self.items):
            # past the last item without a landing: return to launch and land
            if not self._end_rtl:
                self._end_rtl = True
                self._entering(len(self.items))
                nav.rtl(p_ned)
            if touchdown:
                nav.touchdown()
                self._drop_pending(t_us, "landed")
                self.finished = self.landed = self.rtl_established = True
            return len(self.items), False
        item = self.items[self.current]
        cmd = item.command
        seq = self.current
        entering = self._entered != seq
        self._entered = seq
        if entering:
            self._entering(seq)
        if cmd == MAV_CMD_NAV_TAKEOFF:
            goal_d = self.frame.alt0_m - self.item_alt_m(item)
            if entering:
                self._goal = (nav.traj.raw[0], nav.traj.raw[1], goal_d)
                if nav.phase in ("idle", "landed"):
                    nav.takeoff(p_ned, -goal_d)
                else:
                    nav.goto((nav.traj.raw[0], nav.traj.raw[1], min(goal_d, nav.traj.raw[2])))
            if nav.arrived and abs(p_ned[2] - nav.traj.p[2]) <= self.params["WPNAV_TKOFF_TOL"]:
                return self._next(t_us, p_ned, touchdown, yaw)
            return seq, False
        if cmd in _GOAL_COMMANDS:
            if entering:
                if cmd == MAV_CMD_NAV_DELAY:
                    # hold where the reference can stop, for param1 seconds
                    stop = nav.traj.stopping_point()
                    self._goal = stop
                    nav.hold(stop, scored=True)
                    self._hold_s = item.param1
                    self._hold_start_us = t_us
                    self._say(t_us, 6, f"Mission: delaying {item.param1:g} s")
                else:
                    self._goal = goal = self.item_ned(item, nav.traj.raw)
                    yaw_wp = None
                    if cmd == MAV_CMD_NAV_WAYPOINT and math.isfinite(item.param4) and item.param4 != 0.0:
                        yaw_wp = math.radians(item.param4)
                    start = (nav.traj.raw[0], nav.traj.raw[1])
                    if cmd == MAV_CMD_NAV_SPLINE_WAYPOINT:
                        self._spline(item, goal)
                    else:
                        nav.goto(goal, yaw_wp)
                    if item.frame in TERRAIN_FRAMES and self.terrain is not None:
                        self._follow_terrain(start, goal)
                    if cmd in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_SPLINE_WAYPOINT):
                        self._hold_s = max(item.param1, 0.0) if math.isfinite(item.param1) else 0.0
                    elif cmd == MAV_CMD_NAV_LOITER_TIME:
                        self._hold_s = max(item.param1, 0.0)
                    elif cmd == MAV_CMD_NAV_LOITER_TURNS:
                        self._hold_s = max(item.param1, 0.0) * LOITER_TURN_S
                    elif cmd == MAV_CMD_NAV_LOITER_TO_ALT:
                        self._hold_s = 0.0
                    else:
                        self._hold_s = math.inf
            if self._hold_start_us is None and nav.traj.arrived:
                if nav.traj._v_end > 0.0:
                    # a spline flown through: done when the reference passes its end
                    # (ArduCopter counts a waypoint it does not stop at by its target)
                    return self._next(t_us, p_ned, touchdown, yaw)
                goal = self._goal
                radius = self.params["WPNAV_RADIUS"]
                if cmd == MAV_CMD_NAV_WAYPOINT and math.isfinite(item.param2) and item.param2 > 0.0:
                    radius = item.param2
                if (math.hypot(p_ned[0] - goal[0], p_ned[1] - goal[1]) <= radius
                        and abs(p_ned[2] - goal[2]) <= max(radius, 1.0)):
                    self._hold_start_us = t_us
                    if self._hold_s > 0.0 and cmd != MAV_CMD_NAV_DELAY:
                        nav.hold(None, scored=True)
            if self._hold_start_us is not None:
                if (t_us - self._hold_start_us) * 1e-6 >= self._hold_s:
                    return self._next(t_us, p_ned, touchdown, yaw)
                return seq, self._hold_s > 0.0
            return seq, False
        if cmd in (MAV_CMD_NAV_LAND, MAV_CMD_NAV_RETURN_TO_LAUNCH):
            if entering:
                if cmd == MAV_CMD_NAV_LAND:
                    goal = self.item_ned(item, nav.traj.raw)
                    self._goal = (goal[0], goal[1], 0.0)
                    nav.land((goal[0], goal[1]))
                else:
                    nav.rtl(p_ned)
                    self._goal = (nav.rtl_ne[0], nav.rtl_ne[1], 0.0)   # home, or a rally point
            if touchdown and nav.phase == "land_descend":
                nav.touchdown()
                self._drop_pending(t_us, "landed")
                self._advance(t_us)
                self.finished = self.landed = self.rtl_established = True
            return seq, False
        raise AssertionError(f"{item.command_name} at item {seq} is not flown by the quadrotor "
                             "and should have been refused when the mission was loaded")

    def ground_d(self, n: float, e: float) -> float | None:
        """The ground's depth below home [m, NED down] at (north, east) of home, from
        ``terrain``; None where it has no data."""
        lat, lon, _ = self.frame.to_geodetic_fast((n, e, 0.0))
        h = self.terrain(math.degrees(lat), math.degrees(lon))
        return None if h is None else self.home_alt_m - h

    def _follow_terrain(self, start, goal) -> None:
        """A terrain-frame leg: the reference keeps its height above the ground along
        the leg, not only at its ends (as ArduCopter flies terrain-frame waypoints).
        Where the start has no data, the goal's ground is used for both ends."""
        d_b = self.ground_d(goal[0], goal[1])
        if d_b is None:
            return
        d_a = self.ground_d(start[0], start[1])
        self.nav.terrain_leg = (self.ground_d, tuple(start), (goal[0], goal[1]),
                                d_b if d_a is None else d_a, d_b)

    def _next_nav_item(self) -> MissionItem | None:
        """The navigation item after the current one (DO items passed, a DO_JUMP that
        will be taken followed), or None."""
        i = self.current + 1
        counts = dict(self.jump_counts)
        for _ in range(len(self.items) + 4):
            if i >= len(self.items):
                return None
            it = self.items[i]
            if it.command == MAV_CMD_DO_JUMP:
                done = counts.get(it.seq, 0)
                if int(it.param2) < 0 or done < int(it.param2):
                    counts[it.seq] = done + 1
                    i = int(it.param1)
                    continue
            elif it.command in NAV_COMMANDS:
                return it
            i += 1
        return None

    def _spline(self, item: MissionItem, goal) -> None:
        """NAV_SPLINE_WAYPOINT as ArduCopter flies it (AC_WPNav's spline legs): a cubic
        Hermite curve from where the reference is to the waypoint. Its tangent at the
        start, when the reference is moving on from a previous leg, that of Catmull-Rom
        (from the previous leg's start to this waypoint), else the chord; at
        the end, towards the next waypoint when there is one (Catmull-Rom: this leg's
        start to the next point), else the chord. Into a following spline the curve is
        flown through without stopping; otherwise (or with a hold time) it stops there."""
        nav = self.nav
        p0 = tuple(nav.traj.raw)
        p1 = tuple(goal)
        chord = tuple(b - a for a, b in zip(p0, p1))
        # moving on from the previous leg: its start is the point before this one
        moving = math.hypot(nav.traj._vraw[0], nav.traj._vraw[1]) > 0.5
        prev = nav.traj.start
        m0 = tuple(0.5 * (b - a) for a, b in zip(prev, p1)) if moving else chord
        nxt = self._next_nav_item()
        stop = (math.isfinite(item.param1) and item.param1 > 0.0)
        m1 = chord
        v_end = 0.0
        if nxt is not None and nxt.command in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_SPLINE_WAYPOINT):
            pn = self.item_ned(nxt, p1)
            m1 = tuple(0.5 * (b - a) for a, b in zip(p0, pn))
            if nxt.command == MAV_CMD_NAV_SPLINE_WAYPOINT and not stop:
                v_end = nav.speeds()[0]
        pts = []
        for k in range(SPLINE_SAMPLES + 1):
            u = k / SPLINE_SAMPLES
            h00, h10 = 2 * u ** 3 - 3 * u ** 2 + 1, u ** 3 - 2 * u ** 2 + u
            h01, h11 = -2 * u ** 3 + 3 * u ** 2, u ** 3 - u ** 2
            pts.append(tuple(h00 * a + h10 * ta + h01 * b + h11 * tb
                             for a, ta, b, tb in zip(p0, m0, p1, m1)))
        nav.spline(pts, v_end)

    def _next(self, t_us: int, p_ned, touchdown: bool, yaw: float) -> tuple[int, bool]:
        """The navigation item completed: on to the next one at once."""
        self._nav_done(t_us)
        if not self._run_do_items(t_us, yaw):
            return self.current, False
        return self._step_nav(t_us, p_ned, touchdown, yaw)
