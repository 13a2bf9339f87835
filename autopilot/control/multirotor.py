"""Multirotor control: PDD attitude loops, PID altitude loop and the reference-angle
generator of the seed (ch. 9 sec. 3.6.2.2, eqs 3.30-3.41), for the quadrotor of
``sim_bridge/plants/quadrotor.py``.

Our copy of the seed lost the subscripts, the fractions and some brackets of these
equations; they are rebuilt from its references (Hoffmann, Huang, Waslander & Tomlin,
AIAA GNC 2007; Bayezit & Fidan, IEEE TIE 60(12) 2013), and where the text still left a
choice, the choice was made by checking stability on this airframe:

* attitude (eqs 3.32-3.36): ``U = Cbar(s) [k_P e - F(s) omega]``,
  ``F(s) = (k_D (s + p_d) + k_DD s) / (s + p_d)^2``, derivative actions on the gyro
  rates (no kick), discretised by Tustin; the default gains place three closed-loop
  poles from design inputs (QD_RP_*, QD_YAW_*: :func:`place_pdd`), the seed's set is
  ``QD_GAIN_SET = 1`` (its yaw set is unstable on an F450);
* altitude (eq 3.37): PID on height and climb rate plus the nominal thrust
  ``m (g + zddot_d)``, divided by ``cos phi cos theta``; the seed's gains;
* reference angles (eqs 3.38-3.41): PID from the position error in the heading frame
  (derivative on the velocity error, integral rotated with the yaw) plus the reference
  acceleration over g, the tilt limited to ANGLE_MAX_DEG; the default places the
  position loop's poles (QD_POS_*).

The reconstruction, the readings the text allows and why each was chosen, the root loci
and the gains: docs/quadrotor-control.md. The step responses: docs/status.md,
"Quadrotor".
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import kernel, preload
from ..params import Param
from .mixer import K_COLL, K_N, K_SAT, QuadPlusMixer, mix_rotors

G = 9.80665

#: the seed's numbers (sec. 3.7.1), with the assignment argued above
SEED_ROLL_PITCH = dict(k_p=0.99, k_d=1.48, k_dd=0.83, p_d=100.0, lead=(2.7872, 3.57, 21.3))
SEED_YAW = dict(k_p=0.99, k_d=0.67, k_dd=1.11, p_d=100.0, lead=(0.0187, 1.0, 0.27))
SEED_ALT = dict(k_d=7.0, k_p=7.5, k_i=6.0)
SEED_POS_PITCH = dict(k_p=0.72, k_i=0.72, k_d=0.3)
SEED_POS_ROLL = dict(k_p=0.6, k_i=0.6, k_d=0.42)
NO_LEAD = (1.0, 1.0, 1.0)   # Cbar(s) = 1 (s + 1)/(s + 1)

MULTIROTOR_PARAMS = (
    # --- the airframe as the autopilot knows it (design inputs of the loops) -----------
    Param("QD_MASS", 1.4, 0.1, 50.0, "kg", "vehicle mass"),
    Param("QD_ARM", 0.2335, 0.05, 2.0, "m", "rotor distance from the centre of gravity"),
    Param("QD_IXX", 0.019, 1e-4, 10.0, "kg m^2", "roll moment of inertia"),
    Param("QD_IYY", 0.019, 1e-4, 10.0, "kg m^2", "pitch moment of inertia"),
    Param("QD_IZZ", 0.0252, 1e-4, 10.0, "kg m^2", "yaw moment of inertia"),
    Param("QD_KM", 0.0197, 1e-4, 0.2, "m", "rotor reaction moment per newton of thrust"),
    Param("QD_TAU", 0.055, 0.001, 0.5, "s", "rotor thrust time constant"),
    Param("QD_THST_MAX", 15.7, 1.0, 500.0, "N", "static thrust of one rotor at full command, sea level"),
    Param("QD_THST_EXPO", 0.78, 0.0, 1.0, "", "thrust curve: T/T_max = (1-e) u + e u^2"),
    Param("QD_SPIN_ARM", 0.08, 0.0, 0.3, "", "motor command when armed on the ground"),
    Param("QD_SPIN_MIN", 0.10, 0.0, 0.3, "", "lowest motor command in flight"),
    # --- attitude (PDD) ---------------------------------------------------------
    Param("QD_GAIN_SET", 0, 0, 1, "", "0: gains from the design inputs; 1: the seed's numbers", is_int=True),
    Param("QD_RP_WN", 12.0, 1.0, 60.0, "rad/s", "roll/pitch closed-loop natural frequency"),
    Param("QD_RP_ZETA", 0.8, 0.3, 1.5, "", "roll/pitch closed-loop damping"),
    Param("QD_RP_P3", 25.0, 1.0, 200.0, "rad/s", "roll/pitch third closed-loop pole"),
    Param("QD_YAW_WN", 4.0, 0.5, 30.0, "rad/s", "yaw closed-loop natural frequency"),
    Param("QD_YAW_ZETA", 0.9, 0.3, 1.5, "", "yaw closed-loop damping"),
    Param("QD_YAW_P3", 15.0, 1.0, 200.0, "rad/s", "yaw third closed-loop pole"),
    Param("QD_PDD_PD", 100.0, 10.0, 500.0, "rad/s", "pole p_d of the derivative filters"),
    Param("ANGLE_MAX_DEG", 30.0, 5.0, 60.0, "deg", "maximum tilt (roll/pitch reference)"),
    Param("YAW_RATE_MAX", 90.0, 5.0, 360.0, "deg/s", "heading reference slew rate"),
    # --- altitude (PID, eq 3.37) -------------------------------------------------
    Param("QD_ALT_KD", 7.0, 0.0, 100.0, "N s/m", "altitude: climb-rate error to thrust"),
    Param("QD_ALT_KP", 7.5, 0.0, 100.0, "N/m", "altitude: height error to thrust"),
    Param("QD_ALT_KI", 6.0, 0.0, 100.0, "N/(m s)", "altitude: integral of height error to thrust"),
    Param("QD_ALT_IMAX", 5.0, 0.0, 100.0, "N", "altitude integrator limit"),
    # --- position to reference angles (PID, eqs 3.38-3.40) -------------------------
    Param("QD_POS_WN", 1.4, 0.1, 5.0, "rad/s", "position loop natural frequency"),
    Param("QD_POS_ZETA", 0.9, 0.3, 1.5, "", "position loop damping"),
    Param("QD_POS_P3", 0.5, 0.0, 5.0, "rad/s", "position loop integrator pole"),
    Param("QD_POS_IMAX", 20.0, 0.0, 45.0, "deg", "position integrator limit (tilt)"),
)


# --------------------------------------------------------------------- design ------
def axis_gains(params) -> dict[str, float]:
    """K of eq 3.31 for each axis [(rad/s^2)/N] and tau, from the airframe parameters."""
    two_l = 2.0 * params["QD_ARM"]
    return {"roll": two_l / params["QD_IXX"], "pitch": two_l / params["QD_IYY"],
            "yaw": 4.0 * params["QD_KM"] / params["QD_IZZ"], "tau": params["QD_TAU"]}


def _char_parts(K: float, tau: float, p_d: float, lead: tuple):
    """Polynomials (highest power first) of the characteristic equation
    A(s) + K [k_P B_P(s) + k_D B_D(s) + k_DD B_DD(s)] = 0."""
    g, z, p = lead
    fil = np.polymul([1.0, p_d], [1.0, p_d])
    den, num = ([1.0], np.array([g])) if z == p else ([1.0, p], g * np.array([1.0, z]))
    A = np.polymul(np.polymul(den, fil), np.polymul([1.0, 0.0, 0.0], [tau, 1.0]))
    B_P = np.polymul(num, fil)
    B_D = np.polymul(num, np.polymul([1.0, 0.0], [1.0, p_d]))
    B_DD = np.polymul(num, [1.0, 0.0, 0.0])
    return A, B_P, B_D, B_DD


def closed_loop_poles(K: float, tau: float, k_p: float, k_d: float, k_dd: float,
                      p_d: float, lead: tuple = NO_LEAD) -> np.ndarray:
    """Roots of 1 + C(s) G(s) (eq 3.31 with the PDD of eq 3.33), slowest first."""
    A, B_P, B_D, B_DD = _char_parts(K, tau, p_d, lead)
    char = np.polyadd(A, K * (k_p * np.pad(B_P, (len(A) - len(B_P), 0))
                              + k_d * np.pad(B_D, (len(A) - len(B_D), 0))
                              + k_dd * np.pad(B_DD, (len(A) - len(B_DD), 0))))
    r = np.roots(char)
    return r[np.argsort(-r.real)]


def place_pdd(K: float, tau: float, wn: float, zeta: float, p3: float, p_d: float,
              lead: tuple = NO_LEAD) -> tuple[float, float, float]:
    """(k_P, k_D, k_DD) of eq 3.33 placing closed-loop poles at
    wn (-zeta +- j sqrt(1 - zeta^2)) and -p3 (for zeta >= 1: -wn (zeta +- sqrt(zeta^2 - 1)))."""
    if zeta < 1.0:
        lam = [complex(-zeta * wn, wn * math.sqrt(1.0 - zeta * zeta))]
    else:
        d = wn * math.sqrt(zeta * zeta - 1.0)
        lam = [complex(-zeta * wn + d, 0.0), complex(-zeta * wn - d, 0.0)]
    lam.append(complex(-p3, 0.0))
    A, B_P, B_D, B_DD = _char_parts(K, tau, p_d, lead)
    rows, rhs = [], []
    for s in lam:
        a = np.polyval(A, s)
        b = [K * np.polyval(B, s) for B in (B_P, B_D, B_DD)]
        rows.append([x.real for x in b])
        rhs.append(-a.real)
        if abs(s.imag) > 0.0:
            rows.append([x.imag for x in b])
            rhs.append(-a.imag)
    k = np.linalg.solve(np.array(rows), np.array(rhs))
    return float(k[0]), float(k[1]), float(k[2])


def place_position(wn: float, zeta: float, p3: float) -> tuple[float, float, float]:
    """(k_P, k_I, k_D) of eq 3.38 [rad/m, rad/(m s), rad s/m] for x'' = g theta_cmd:
    s^3 + g k_D s^2 + g k_P s + g k_I = (s^2 + 2 zeta wn s + wn^2)(s + p3)."""
    return ((wn * wn + 2.0 * zeta * wn * p3) / G, wn * wn * p3 / G, (2.0 * zeta * wn + p3) / G)


def _tustin(num, den, dt: float) -> tuple[list[float], list[float]]:
    from scipy.signal import cont2discrete
    b, a, _ = cont2discrete((np.atleast_1d(num), np.atleast_1d(den)), dt, method="bilinear")
    b = np.atleast_1d(np.squeeze(b)).astype(float)
    a = np.atleast_1d(np.squeeze(a)).astype(float)
    return (b / a[0]).tolist(), (a / a[0]).tolist()


@kernel
def pdd_step(c, s, e, omega):
    """One axis of eqs 3.32-3.36 on its difference equations: ``c`` = (b0, b1, b2, a1, a2)
    of F(z), (b0, b1, a1) of Cbar(z), k_P; ``s`` = the filter states (f1, f2, l1),
    updated. Returns u [N per rotor]."""
    # F(z) omega, transposed direct form II
    f = c[0] * omega + s[0]
    s[0] = c[1] * omega - c[3] * f + s[1]
    s[1] = c[2] * omega - c[4] * f
    # u = Cbar(z) [k_P e - F omega]
    v = c[8] * e - f
    u = c[5] * v + s[2]
    s[2] = c[6] * v - c[7] * u
    return u


class DiscretePdd:
    """One axis of eq 3.32-3.36: ``u = Cbar(s) [k_P e - F(s) omega]`` as difference
    equations (Tustin at ``dt``). ``update(e, omega) -> u`` [N per rotor]. Its
    coefficients and states are arrays for :func:`pdd_step` (the attitude controller
    keeps the three axes' states in one array: ``state`` is then a row of it)."""

    __slots__ = ("k_p", "k_d", "k_dd", "p_d", "lead", "dt", "_fb", "_fa", "_lb", "_la",
                 "coef", "state")

    def __init__(self, k_p: float, k_d: float, k_dd: float, p_d: float, lead: tuple, dt: float):
        self.k_p, self.k_d, self.k_dd, self.p_d, self.lead, self.dt = k_p, k_d, k_dd, p_d, lead, dt
        # F(s) = ((k_D + k_DD) s + k_D p_d) / (s + p_d)^2
        self._fb, self._fa = _tustin([k_d + k_dd, k_d * p_d], [1.0, 2.0 * p_d, p_d * p_d], dt)
        g, z, p = lead
        self._lb, self._la = _tustin([g, g * z], [1.0, p], dt)
        self.coef = np.array((*self._fb, *self._fa[1:], *self._lb, self._la[1], k_p))
        self.state = np.zeros(3)
        self.reset()

    def reset(self, omega: float = 0.0, e: float = 0.0) -> None:
        """Filter states at the steady state of a constant rate ``omega`` and error ``e``
        (F(0) = k_D / p_d, Cbar(0) = g z / p)."""
        b0, b1, b2 = self._fb
        _, a1, a2 = self._fa
        y = (self.k_d / self.p_d) * omega
        f2 = b2 * omega - a2 * y
        f1 = b1 * omega - a1 * y + f2
        v = self.k_p * e - y
        lb0, lb1 = self._lb
        _, la1 = self._la
        u = v * (self.lead[0] * self.lead[1] / self.lead[2])
        s = self.state
        s[0], s[1], s[2] = f1, f2, lb1 * v - la1 * u

    def update(self, e: float, omega: float) -> float:
        return pdd_step(self.coef, self.state, e, omega)


# ----------------------------------------------------------------- attitude --------
@kernel
def _euler_quat(roll, pitch, yaw):
    """q_nb of 3-2-1 Euler angles (autopilot.geo.euler_to_quat, on floats)."""
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


def attitude_error(q, roll_d: float, pitch_d: float, yaw_d: float) -> tuple[float, float, float]:
    """Attitude error in body axes: (phi_d - phi, theta_d - theta, psi_d - psi) to first
    order. The tilt part is the body-frame rotation vector of q^-1 (x) q_d with q_d built
    from (phi_d, theta_d) and the *current* heading -- the frame the reference-angle
    generator computed them in -- so a heading still turning towards psi_d does not
    turn the tilt; the yaw part is wrap(psi_d - psi). (Tilt and heading decoupled, as
    ArduCopter's and PX4's attitude controllers do.)"""
    return _attitude_error(q[0], q[1], q[2], q[3], roll_d, pitch_d, yaw_d)


@kernel
def _attitude_error(qw, qx, qy, qz, roll_d, pitch_d, yaw_d):
    """:func:`attitude_error` on the quaternion's components."""
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    dw, dx, dy, dz = _euler_quat(roll_d, pitch_d, yaw)
    # conj(q) (x) q_d
    ew = qw * dw + qx * dx + qy * dy + qz * dz
    ex = qw * dx - qx * dw - qy * dz + qz * dy
    ey = qw * dy + qx * dz - qy * dw - qz * dx
    ez = qw * dz - qx * dy + qy * dx - qz * dw
    if ew < 0.0:
        ew, ex, ey, ez = -ew, -ex, -ey, -ez
    s = math.sqrt(ex * ex + ey * ey + ez * ez)
    k = 2.0 * math.atan2(s, ew) / s if s > 1e-9 else 2.0
    e_yaw = (yaw_d - yaw + math.pi) % (2.0 * math.pi) - math.pi
    return ex * k, ey * k, ez * k + e_yaw


# MultirotorController.x: the loops' coefficients and states in one array (one argument
# of the kernels, written in place): the attitude loops' (AttitudeController.x: the
# rows of pdd_step's coefficients 3 x 9, of its states 3 x 3, the attitude error), the
# mixer's constants and record (mixer.K_*), the reference-angle generator's gains and
# integral (P_*), the altitude loop's gains and integral (A_*), and the thrust asked of
# the mixer last (the altitude loop's anti-windup compares the collective given with it)
ATT_STATE, ATT_ERR, ATT_N = 27, 36, 39
X_ATT, X_MIX = 0, ATT_N
X_POS = X_MIX + K_N
X_ALT = X_POS + 10
X_REQ = X_ALT + 6
X_N = X_REQ + 1
P_KPP, P_KIP, P_KDP, P_KPR, P_KIR, P_KDR, P_ANG, P_ILIM, P_IN, P_IE = range(10)
A_KD, A_KP, A_KI, A_IMAX, A_MASS, A_INTEG = range(6)

# the vehicle's motion as the loops read it (MultirotorController.track): the navigation
# output in one array, written by the navigation's output predictor (vehicle_quad.py):
# velocity (NED), attitude q_nb, rate (body, bias-corrected), Euler angles (roll, pitch,
# yaw). (The position is the caller's, in home's frame.)
Y_V, Y_Q, Y_W, Y_EULER = 0, 3, 7, 10
Y_N = 13


@kernel
def attitude_step(a, qw, qx, qy, qz, wx, wy, wz, roll_d, pitch_d, yaw_d):
    """The three PDD loops on the attitude error (:class:`AttitudeController`): ``a``
    holds the roll, pitch and yaw rows of :func:`pdd_step`'s coefficients, then of its
    states, then the error (written). Returns (u_phi, u_theta, u_psi)."""
    ex, ey, ez = _attitude_error(qw, qx, qy, qz, roll_d, pitch_d, yaw_d)
    a[ATT_ERR], a[ATT_ERR + 1], a[ATT_ERR + 2] = ex, ey, ez
    s = ATT_STATE
    return (pdd_step(a[0:9], a[s:s + 3], ex, wx), pdd_step(a[9:18], a[s + 3:s + 6], ey, wy),
            pdd_step(a[18:27], a[s + 6:s + 9], ez, wz))


@kernel
def attitude_mix(x, qw, qx, qy, qz, wx, wy, wz, roll_d, pitch_d, yaw_d, u_z):
    """The attitude loops (:func:`attitude_step`) and the mixer (:func:`mix_rotors`) on
    the controller's array ``x`` in one call (:meth:`MultirotorController.attitude`),
    their records (the error, the mixing's) kept in ``x``: (u_z, u_phi, u_theta, u_psi)
    and the motor commands, two tuples (the caller's records)."""
    u_phi, u_theta, u_psi = attitude_step(x[X_ATT:X_MIX], qw, qx, qy, qz, wx, wy, wz, roll_d,
                                          pitch_d, yaw_d)
    x[X_REQ] = u_z
    return (u_z, u_phi, u_theta, u_psi), mix_rotors(u_z, u_phi, u_theta, u_psi, x[X_MIX:X_POS])


@kernel
def _exact_product(a, b):
    """a * b as an unevaluated pair (p, e), p + e exactly (Dekker's product: each factor
    split by 2**27 + 1 into halves whose products are exact)."""
    p = a * b
    t = a * 134217729.0
    a_hi = t - (t - a)
    a_lo = a - a_hi
    t = b * 134217729.0
    b_hi = t - (t - b)
    b_lo = b - b_hi
    return p, ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo


@kernel
def hypot(x, y):
    """sqrt(x**2 + y**2) correctly rounded, as Python's ``math.hypot`` gives it (the
    loops called that before they were compiled; the C library's hypot, numba's, can
    differ in the last bit). Scaled by a power of two (exact) so that nothing overflows;
    the sum of the squares carried exactly as a pair of doubles, its root then corrected
    by one Newton step on the exact residual. tests/test_speed_s36_quad.py compares it
    with ``math.hypot`` bit for bit."""
    x, y = abs(x), abs(y)
    if x < y:
        x, y = y, x
    if math.isinf(x):
        return x                                  # (even with a NaN, as math.hypot)
    if math.isnan(x) or math.isnan(y):
        return math.nan
    if x == 0.0:
        return 0.0
    e = math.frexp(x)[1]
    x, y = math.ldexp(x, -e), math.ldexp(y, -e)
    xx, xx_err = _exact_product(x, x)
    yy, yy_err = _exact_product(y, y)
    s = xx + yy
    s_err = (xx - s) + yy + xx_err + yy_err       # xx >= yy: (xx - s) + yy is exact
    h = math.sqrt(s + s_err)
    hh, hh_err = _exact_product(h, h)
    return math.ldexp(h + ((s - hh) + (s_err - hh_err)) / (2.0 * h), e)


class AttitudeController:
    """Roll, pitch and yaw PDD loops: ``update(q, omega_b, roll_d, pitch_d, yaw_d)``
    -> (u_phi, u_theta, u_psi) [N per rotor]. Coefficients, states and the error in
    ``x`` (the controller's array's part, given, or its own), ``coef`` and ``state``
    its rows."""

    def __init__(self, params, dt: float, x=None):
        self.params = params
        self.dt = dt
        self.x = np.zeros(ATT_N) if x is None else x
        self.coef = self.x[:ATT_STATE].reshape(3, 9)
        self.state = self.x[ATT_STATE:ATT_ERR].reshape(3, 3)
        self.configure()

    def gains(self) -> dict:
        """The gains in use per axis: dict(k_p, k_d, k_dd, p_d, lead)."""
        p = self.params
        if int(p["QD_GAIN_SET"]) == 1:
            return {"roll": dict(SEED_ROLL_PITCH), "pitch": dict(SEED_ROLL_PITCH), "yaw": dict(SEED_YAW)}
        ax = axis_gains(p)
        pd = p["QD_PDD_PD"]
        out = {}
        for axis, (wn, zeta, p3) in (("roll", ("QD_RP_WN", "QD_RP_ZETA", "QD_RP_P3")),
                                     ("pitch", ("QD_RP_WN", "QD_RP_ZETA", "QD_RP_P3")),
                                     ("yaw", ("QD_YAW_WN", "QD_YAW_ZETA", "QD_YAW_P3"))):
            k = place_pdd(ax[axis], ax["tau"], p[wn], p[zeta], p[p3], pd)
            out[axis] = dict(k_p=k[0], k_d=k[1], k_dd=k[2], p_d=pd, lead=NO_LEAD)
        return out

    def configure(self) -> None:
        g = self.gains()
        self.loops = tuple(DiscretePdd(dt=self.dt, **g[a]) for a in ("roll", "pitch", "yaw"))
        # the three loops' coefficients and states as rows of ``x`` (the loops' own
        # ``state`` are views of these rows)
        for k, loop in enumerate(self.loops):
            self.coef[k] = loop.coef
            self.state[k] = loop.state
            loop.state = self.state[k]
        self.x[ATT_ERR:] = 0.0

    @property
    def error(self) -> tuple[float, float, float]:
        """The last attitude error in body axes (:func:`attitude_error`) [rad]."""
        return tuple(self.x[ATT_ERR:].tolist())

    def reset(self) -> None:
        for loop in self.loops:
            loop.reset()

    def update(self, q, omega_b, roll_d: float, pitch_d: float, yaw_d: float) -> tuple:
        return attitude_step(self.x, q[0], q[1], q[2], q[3], omega_b[0], omega_b[1],
                             omega_b[2], roll_d, pitch_d, yaw_d)


# ----------------------------------------------------------------- altitude --------
@kernel
def altitude_thrust(g, h_d, hdot_d, hddot_d, h, hdot, tilt_cos, dt, hold_integrator,
                    sat_hi, sat_lo):
    """Eq 3.37 with tilt compensation (:class:`AltitudeController`) on its gains and
    integral ``g`` (A_*; the integral updated in place): u_z total thrust [N]."""
    e = h_d - h
    t_nom = g[A_MASS] * (G + hddot_d)
    u = g[A_KD] * (hdot_d - hdot) + g[A_KP] * e + g[A_INTEG] + t_nom
    u /= tilt_cos if tilt_cos > 0.5 else 0.5
    if not hold_integrator and not ((sat_hi and e > 0.0) or (sat_lo and e < 0.0)):
        i = g[A_INTEG] + g[A_KI] * e * dt
        i_max = g[A_IMAX]
        g[A_INTEG] = i if -i_max <= i <= i_max else math.copysign(i_max, i)
    return u if u > 0.0 else 0.0


@kernel
def altitude_step(x, h_d, hdot_d, hddot_d, h, hdot, roll, pitch, dt, hold_integrator):
    """:func:`altitude_thrust` on the controller's array ``x``, its integral held while
    the last mixing moved the collective against the error (below the thrust asked
    with the height low, above it with the height high)."""
    sat = x[X_MIX + K_SAT + 2] != 0.0
    req, coll = x[X_REQ], x[X_MIX + K_COLL]
    return altitude_thrust(x[X_ALT:X_REQ], h_d, hdot_d, hddot_d, h, hdot,
                           math.cos(roll) * math.cos(pitch), dt, hold_integrator,
                           sat and coll < req - 1e-6, sat and coll > req + 1e-6)


class AltitudeController:
    """Eq 3.37 with tilt compensation: ``update(h_d, hdot_d, hddot_d, h, hdot, tilt_cos,
    dt, hold_integrator)`` -> u_z total thrust [N] (:func:`altitude_thrust`; gains and
    integral in ``g``, the controller's array's part, given, or its own)."""

    def __init__(self, params, g=None):
        self.params = params
        self.g = np.zeros(X_REQ - X_ALT) if g is None else g
        self.configure()

    @property
    def integ(self) -> float:
        return float(self.g[A_INTEG])

    def configure(self) -> None:
        p = self.params
        if int(p["QD_GAIN_SET"]) == 1:
            s = SEED_ALT
            self.k_d, self.k_p, self.k_i = s["k_d"], s["k_p"], s["k_i"]
        else:
            self.k_d, self.k_p, self.k_i = p["QD_ALT_KD"], p["QD_ALT_KP"], p["QD_ALT_KI"]
        self.i_max = p["QD_ALT_IMAX"]
        self.mass = p["QD_MASS"]
        self.g[:A_INTEG] = (self.k_d, self.k_p, self.k_i, self.i_max, self.mass)

    def reset(self, integ: float = 0.0) -> None:
        self.g[A_INTEG] = integ

    def update(self, h_d: float, hdot_d: float, hddot_d: float, h: float, hdot: float,
               tilt_cos: float, dt: float, hold_integrator: bool = False,
               sat_hi: bool = False, sat_lo: bool = False) -> float:
        return altitude_thrust(self.g, h_d, hdot_d, hddot_d, h, hdot, tilt_cos, dt,
                               hold_integrator, sat_hi, sat_lo)


# ------------------------------------------------------ reference-angle generator ---
@kernel
def reference_angles(g, e_n, e_e, ev_n, ev_e, a_n, a_e, yaw, dt, hold_integrator):
    """Eqs 3.38-3.41 (:class:`ReferenceAngleGenerator`) on its gains and integral ``g``
    (P_*; the integral updated in place): (phi_d, theta_d)."""
    c, s = math.cos(yaw), math.sin(yaw)
    # into the heading frame (c e_e - s e_n: -s e_n + c e_e to the bit, one negation less)
    ex, ey = c * e_n + s * e_e, c * e_e - s * e_n
    vx, vy = c * ev_n + s * ev_e, c * ev_e - s * ev_n
    ax, ay = c * a_n + s * a_e, c * a_e - s * a_n
    i_n, i_e = g[P_IN], g[P_IE]
    ix, iy = c * i_n + s * i_e, c * i_e - s * i_n
    theta = -(g[P_KPP] * ex + g[P_KIP] * ix + g[P_KDP] * vx) - ax / G
    phi = (g[P_KPR] * ey + g[P_KIR] * iy + g[P_KDR] * vy) + ay / G
    tilt = hypot(phi, theta)
    saturated = tilt > g[P_ANG]
    if saturated:
        k = g[P_ANG] / tilt
        phi, theta = phi * k, theta * k
    if not hold_integrator and not saturated:
        i_n += e_n * dt
        i_e += e_e * dt
        lim_n = g[P_ILIM]
        m = hypot(i_n, i_e)
        if m > lim_n:
            k = lim_n / m
            i_n *= k
            i_e *= k
        g[P_IN], g[P_IE] = i_n, i_e
    return phi, theta


class ReferenceAngleGenerator:
    """Eqs 3.38-3.41: ``update(e_ne, ev_ne, a_ne, yaw, dt)`` -> (phi_d, theta_d)
    (:func:`reference_angles`; gains and integral in ``g``, the controller's array's
    part, given, or its own)."""

    def __init__(self, params, g=None):
        self.params = params
        self.g = np.zeros(X_ALT - X_POS) if g is None else g
        self.configure()

    @property
    def i_n(self) -> float:
        return float(self.g[P_IN])

    @i_n.setter
    def i_n(self, value: float) -> None:
        self.g[P_IN] = value

    @property
    def i_e(self) -> float:
        return float(self.g[P_IE])

    @i_e.setter
    def i_e(self, value: float) -> None:
        self.g[P_IE] = value

    def configure(self) -> None:
        p = self.params
        if int(p["QD_GAIN_SET"]) == 1:
            pt, rl = SEED_POS_PITCH, SEED_POS_ROLL
            self.pitch = (pt["k_p"], pt["k_i"], pt["k_d"])
            self.roll = (rl["k_p"], rl["k_i"], rl["k_d"])
        else:
            k = place_position(p["QD_POS_WN"], p["QD_POS_ZETA"], p["QD_POS_P3"])
            self.pitch = self.roll = k
        self.angle_max = math.radians(p["ANGLE_MAX_DEG"])
        self.i_max = math.radians(p["QD_POS_IMAX"])
        # keep each axis' integral action within QD_POS_IMAX: |i_ne| <= i_lim
        self.i_lim = self.i_max / max(self.pitch[1], self.roll[1], 1e-6)
        self.g[:P_IN] = (*self.pitch, *self.roll, self.angle_max, self.i_lim)

    def reset(self) -> None:
        self.g[P_IN] = self.g[P_IE] = 0.0

    def update(self, e_n: float, e_e: float, ev_n: float, ev_e: float, a_n: float, a_e: float,
               yaw: float, dt: float, hold_integrator: bool = False) -> tuple[float, float]:
        return reference_angles(self.g, e_n, e_e, ev_n, ev_e, a_n, a_e, yaw, dt, hold_integrator)


@kernel
def track_mix(x, ref, y, pn, pe, pd, dz, yaw_d, dt, hold_pos, hold_alt):
    """The loops of Fig 3.6 end to end on the controller's array ``x``
    (:meth:`MultirotorController.track`): the reference angles (eqs 3.38-3.41) from the
    reference's position, velocity and acceleration (``ref``: p, v, a in home NED, its
    depth moved by ``dz`` where that is not 0) against the estimate's (the position
    pn, pe, pd in home NED, the rest in ``y``: Y_*), the thrust of the altitude loop
    (eq 3.37), then the attitude loops and the mixer (:func:`attitude_mix`). Returns
    phi_d, theta_d and attitude_mix's."""
    pd_d = ref[2] + dz if dz != 0.0 else ref[2]
    vn, ve, vd = y[Y_V], y[Y_V + 1], y[Y_V + 2]
    roll, pitch, yaw = y[Y_EULER], y[Y_EULER + 1], y[Y_EULER + 2]
    roll_d, pitch_d = reference_angles(x[X_POS:X_ALT], ref[0] - pn, ref[1] - pe, ref[3] - vn,
                                       ref[4] - ve, ref[6], ref[7], yaw, dt, hold_pos)
    u_z = altitude_step(x, -pd_d, -ref[5], -ref[8], -pd, -vd, roll, pitch, dt, hold_alt)
    u, motors = attitude_mix(x, y[Y_Q], y[Y_Q + 1], y[Y_Q + 2], y[Y_Q + 3], y[Y_W], y[Y_W + 1],
                             y[Y_W + 2], roll_d, pitch_d, yaw_d, u_z)
    return roll_d, pitch_d, u, motors


class MultirotorController:
    """The loops of Fig 3.6 end to end: reference angles or a thrust, the attitude and
    altitude loops, the mixer. Outputs are the four motor commands 0..1. The loops'
    coefficients and states are parts of one array, ``x`` (X_*; where it lives, if not
    its own: X_N floats, zeros)."""

    def __init__(self, params, dt: float, x=None):
        self.params = params
        self.dt = dt
        self.x = np.zeros(X_N) if x is None else x
        self.att = AttitudeController(params, dt, self.x[X_ATT:X_MIX])
        self.alt = AltitudeController(params, self.x[X_ALT:X_REQ])
        self.pos = ReferenceAngleGenerator(params, self.x[X_POS:X_ALT])
        self.mixer = QuadPlusMixer(params["QD_THST_MAX"], params["QD_THST_EXPO"],
                                   params["QD_SPIN_MIN"], self.x[X_MIX:X_POS])
        self.roll_d = self.pitch_d = self.yaw_d = 0.0
        self.u = (0.0, 0.0, 0.0, 0.0)       # (u_z, u_phi, u_theta, u_psi) before mixing
        self.motors = (0.0, 0.0, 0.0, 0.0)
        # the kernels loaded now, not at the take-off (autopilot.jit.preload; on a copy of
        # the array, which the loops write)
        preload(attitude_mix, self.x.copy(), 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                0.0)
        y = np.zeros(Y_N)
        y[Y_Q] = 1.0
        preload(track_mix, self.x.copy(), np.zeros(9), y, 0.0, 0.0, 0.0, 0.0, 0.0, 0.004, False,
                False)
        preload(altitude_step, self.x.copy(), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.004, False)

    def configure(self) -> None:
        """Re-derive every gain after a parameter change."""
        p = self.params
        self.att.configure()
        self.alt.configure()
        self.pos.configure()
        self.mixer.configure(p["QD_THST_MAX"], p["QD_THST_EXPO"], p["QD_SPIN_MIN"])

    def reset(self) -> None:
        self.att.reset()
        self.alt.reset()
        self.pos.reset()

    def hover_thrust(self) -> float:
        return self.params["QD_MASS"] * G

    def attitude(self, q, omega_b, roll_d: float, pitch_d: float, yaw_d: float,
                 u_z: float) -> tuple:
        """Attitude loops and mixer for given reference angles and total thrust: what
        ``att.update`` and ``mixer.mix`` do, in one kernel call (:func:`attitude_mix`)."""
        self.roll_d, self.pitch_d, self.yaw_d = roll_d, pitch_d, yaw_d
        self.u, self.motors = attitude_mix(self.x, q[0], q[1], q[2], q[3], omega_b[0],
                                           omega_b[1], omega_b[2], roll_d, pitch_d, yaw_d, u_z)
        return self.motors

    def altitude(self, h_d: float, hdot_d: float, hddot_d: float, h: float, hdot: float,
                 roll: float, pitch: float, dt: float, hold_integrator: bool) -> float:
        """The altitude loop's thrust [N] (:func:`altitude_step`: its anti-windup from
        the last mixing)."""
        return altitude_step(self.x, h_d, hdot_d, hddot_d, h, hdot, roll, pitch, dt,
                             hold_integrator)

    def track(self, y, p, ref, yaw_d: float, dt: float, hold_pos: bool, hold_alt: bool,
              dz: float = 0.0) -> tuple:
        """Position, altitude and attitude loops and the mixer for a reference (``ref``:
        an array of its position, velocity and acceleration in home NED, the
        trajectory's own; its depth moved by ``dz``) and heading ``yaw_d``, the vehicle
        at p (home NED), its motion as the navigation's output array ``y`` (Y_*: the
        predictor's own) gives it: ``pos.update``, ``altitude``, then ``attitude``, in
        one kernel call (:func:`track_mix`). Integrators held with ``hold_*``."""
        self.roll_d, self.pitch_d, self.u, self.motors = track_mix(
            self.x, ref, y, p[0], p[1], p[2], dz, yaw_d, dt, hold_pos, hold_alt)
        self.yaw_d = yaw_d
        return self.motors

    def idle(self, spin: float) -> tuple:
        """Armed on the ground: every motor at ``spin``, loops held at rest."""
        self.att.reset()
        self.u = (0.0, 0.0, 0.0, 0.0)
        self.x[X_REQ] = 0.0
        self.motors = (spin, spin, spin, spin)
        return self.motors
