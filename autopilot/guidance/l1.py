"""L1 nonlinear lateral guidance for straight legs and loiter circles.

Park, Deyst & How, "A New Nonlinear Guidance Logic for Trajectory Tracking", AIAA GNC
2004 (seed eqs 1.23-1.27, whose subscripts were lost in extraction; rebuilt from that
paper). A reference point is chosen on the desired path at distance L1 ahead of the
vehicle; with eta the angle from the ground velocity V_g to the L1 vector,

    sin(eta) = (V_g x L1) / (|V_g| |L1|)                    (eq 1.26)
    a_cmd    = K |V_g|^2 / L1 * sin(eta),  K = 2 in the paper  (eq 1.25)
    phi_cmd  = atan(a_cmd / g)                               (eq 1.27)

Linearised about a straight path the cross-track error obeys a second-order system with
natural frequency sqrt(K) V / L1 and damping sqrt(K)/2, so the user tunes a period T and
a damping zeta (as ArduPilot's NAVL1_PERIOD / NAVL1_DAMPING) and we derive

    K = 4 zeta^2,   L1 = zeta T |V_g| / pi.

Degenerate cases handled on purpose: a zero-length leg (fly to its end point), near-zero
ground speed (use the heading and airspeed instead), flying away from the path
(|eta| > 90 deg: command the full turn in the shorter direction), far from the path
(|d| > L1: intercept at a bounded angle instead of a complex square root).

Loiter circles are flown by the same law on the circle's tangent at the closest point,
plus the centripetal feed-forward V_g^2 / R once near the circle.

Vectors are horizontal (north, east) pairs in metres. Positive lateral acceleration and
positive bank turn right (clockwise seen from above).

The laws are compiled kernels on floats (autopilot/jit.py: one a step, where the Python
arithmetic cost more than a call). The two norms of a step are taken before the kernel,
by Python's ``math.hypot``: numba's is the C library's, which differs from Python's in
the last bit of about 0.4 % of the pairs.
"""
from __future__ import annotations

import math
from functools import partial
from typing import NamedTuple

from ..jit import kernel, preload

G = 9.80665
MIN_GROUNDSPEED_MPS = 3.0
MAX_INTERCEPT_RAD = math.radians(60.0)  # capture angle when far from the path
_TAN_INTERCEPT = math.tan(MAX_INTERCEPT_RAD)


class LateralCommand(NamedTuple):
    """The lateral guidance's answer, one a step. An immutable record as a NamedTuple
    rather than ``@message`` (autopilot/frozen.py): a tuple is built in one call, where
    a frozen dataclass stores each field through its slot's descriptor (about 0.2 us a
    field: more than the law itself)."""
    accel_mps2: float        # lateral acceleration, + right [m/s^2]
    bank_rad: float          # bank command (before the roll limit) [rad]
    xtrack_m: float          # cross-track error, + right of the path [m]
    along_m: float           # along-track distance from the leg start [m]
    eta_rad: float           # L1 angle
    l1_m: float              # L1 distance used


# a LateralCommand of a kernel's 6-tuple, built at C speed (``_make`` is a Python call,
# for a length check the kernels' fixed answers do not need)
_command = partial(tuple.__new__, LateralCommand)


@kernel
def _l1_distance(zeta_t, groundspeed_mps):
    """L1 = zeta T |V_g| / pi (``zeta_t``: zeta T)."""
    return zeta_t * groundspeed_mps / math.pi


@kernel
def _ground_velocity(vn, ve, gs, heading_rad, airspeed_mps):
    """(vn, ve, |V_g|); near-zero or unreliable ground speed: along the heading at the
    airspeed instead."""
    if gs < MIN_GROUNDSPEED_MPS:
        s = MIN_GROUNDSPEED_MPS if MIN_GROUNDSPEED_MPS > airspeed_mps else airspeed_mps
        return s * math.cos(heading_rad), s * math.sin(heading_rad), s
    return vn, ve, gs


@kernel
def _accel(vn, ve, gs, ln, le, l1, k):
    """(lateral acceleration, eta) towards the L1 point (ln, le) ahead."""
    # eq 1.26: sin(eta) from the cross product of V_g and L1 (z of NED = down)
    cross = vn * le - ve * ln
    dot = vn * ln + ve * le
    eta = math.atan2(cross, dot)
    s = math.sin(eta)
    if abs(eta) > 0.5 * math.pi:
        s = math.copysign(1.0, eta)  # pointing away: full turn the short way
    # eq 1.25 with K = 4 zeta^2
    return k * gs * gs / l1 * s, eta


@kernel
def _l1_point(tn, te, xtrack, l1):
    """The L1 point (north, east) from the vehicle, for the path's unit tangent (tn, te)
    and the vehicle ``xtrack`` to the right of it: where a circle of radius L1 about the
    vehicle meets the path, no nearer along it than the capture angle allows."""
    nn, ne = -te, tn                     # unit normal, to the right of the path
    ahead = l1 * l1 - xtrack * xtrack
    ahead = math.sqrt(0.0 if 0.0 > ahead else ahead)
    steep = abs(xtrack) / _TAN_INTERCEPT
    ahead = steep if steep > ahead else ahead
    return tn * ahead - nn * xtrack, te * ahead - ne * xtrack


@kernel
def _line(vn, ve, gs, dn, de, length, pn, pe, heading_rad, airspeed_mps, zeta_t, k):
    """:meth:`L1Guidance.line` on floats: V_g (vn, ve), |V_g| ``gs``; the leg A->B
    (dn, de), its ``length``; the vehicle from A (pn, pe)."""
    vn, ve, gs = _ground_velocity(vn, ve, gs, heading_rad, airspeed_mps)
    l1 = _l1_distance(zeta_t, gs)
    l1 = 1.0 if 1.0 > l1 else l1
    if length < 1e-3:
        # zero-length leg: fly straight at the point
        a, eta = _accel(vn, ve, gs, -pn, -pe, l1, k)
        return a, math.atan(a / G), 0.0, 0.0, eta, l1      # eq 1.27
    tn, te = dn / length, de / length
    nn, ne = -te, tn                     # unit normal, to the right of the track
    xtrack = pn * nn + pe * ne           # + right of the path
    along = pn * tn + pe * te
    ln, le = _l1_point(tn, te, xtrack, l1)
    a, eta = _accel(vn, ve, gs, ln, le, l1, k)
    return a, math.atan(a / G), xtrack, along, eta, l1     # eq 1.27


@kernel
def _loiter(vn, ve, gs, rn, re, r, radius_m, direction, heading_rad, airspeed_mps, zeta_t, k):
    """:meth:`L1Guidance.loiter` on floats: V_g (vn, ve), |V_g| ``gs``; the vehicle from
    the centre (rn, re), at ``r``."""
    vn, ve, gs = _ground_velocity(vn, ve, gs, heading_rad, airspeed_mps)
    l1 = _l1_distance(zeta_t, gs)
    l1 = 1.0 if 1.0 > l1 else l1
    if r < 1e-3:
        rn, re, r = -vn, -ve, gs  # at the centre: any radial direction will do
    urn, ure = rn / r, re / r
    tn, te = -direction * ure, direction * urn      # tangent in the flight direction
    radial_err = r - radius_m                        # + outside the circle
    xtrack = -direction * radial_err                 # + right of the tangent
    ln, le = _l1_point(tn, te, xtrack, l1)
    a, eta = _accel(vn, ve, gs, ln, le, l1, k)
    if abs(radial_err) < l1 and radius_m > 1.0:
        # centripetal feed-forward for the circle itself
        blend = 1.0 - abs(radial_err) / l1
        a = a + blend * direction * gs * gs / radius_m
    return a, math.atan(a / G), radial_err, 0.0, eta, l1   # eq 1.27


class L1Guidance:
    def __init__(self, period_s: float = 17.0, damping: float = 0.75):
        self.set_design(period_s, damping)
        # (the kernels flown on the types flight passes, loaded now: autopilot.jit.preload)
        preload(_line, 20.0, 0.0, 20.0, 100.0, 0.0, 100.0, 0.0, 0.0, 0.0, 20.0, self._zeta_t, self.k)
        preload(_loiter, 20.0, 0.0, 20.0, 80.0, 0.0, 80.0, 80.0, 1, 0.0, 20.0, self._zeta_t, self.k)

    def set_design(self, period_s: float, damping: float) -> None:
        self.period_s = period_s
        self.damping = damping
        self.k = 4.0 * damping * damping
        self._zeta_t = damping * period_s

    def l1_distance(self, groundspeed_mps: float) -> float:
        return _l1_distance(self._zeta_t, groundspeed_mps)

    def line(self, p_ne, v_ne, a_ne, b_ne, heading_rad: float = 0.0,
             airspeed_mps: float = 0.0) -> LateralCommand:
        """Track the straight line from A through B."""
        vn, ve = v_ne
        return _command(self.steer_line(p_ne, v_ne, math.hypot(vn, ve), a_ne, b_ne,
                                        heading_rad, airspeed_mps))

    def loiter(self, p_ne, v_ne, c_ne, radius_m: float, direction: int,
               heading_rad: float = 0.0, airspeed_mps: float = 0.0) -> LateralCommand:
        """Circle C with radius R; direction +1 clockwise, -1 counter-clockwise (seen
        from above). ``xtrack_m`` is the radial error, + outside."""
        vn, ve = v_ne
        return _command(self.steer_loiter(p_ne, v_ne, math.hypot(vn, ve), c_ne, radius_m,
                                          direction, heading_rad, airspeed_mps))

    # The laws as the vehicle flies them, every step: the kernel's tuple, LateralCommand's
    # fields in order (the record costs about 1.4 k instructions, and the vehicle reads
    # two of its fields), with the ground speed ``gs`` = hypot(v_ne) the vehicle has.
    def steer_line(self, p_ne, v_ne, gs: float, a_ne, b_ne, heading_rad: float,
                   airspeed_mps: float) -> tuple:
        """:meth:`line` as a plain tuple."""
        an, ae = a_ne
        dn, de = b_ne[0] - an, b_ne[1] - ae
        return _line(v_ne[0], v_ne[1], gs, dn, de, math.hypot(dn, de),
                     p_ne[0] - an, p_ne[1] - ae, heading_rad, airspeed_mps, self._zeta_t, self.k)

    def steer_loiter(self, p_ne, v_ne, gs: float, c_ne, radius_m: float, direction: int,
                     heading_rad: float, airspeed_mps: float) -> tuple:
        """:meth:`loiter` as a plain tuple."""
        rn, re = p_ne[0] - c_ne[0], p_ne[1] - c_ne[1]
        return _loiter(v_ne[0], v_ne[1], gs, rn, re, math.hypot(rn, re), radius_m, direction,
                       heading_rad, airspeed_mps, self._zeta_t, self.k)
