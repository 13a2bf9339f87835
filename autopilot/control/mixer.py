"""Quadrotor rotor mixing (seed eq 3.30) with attitude-first saturation, and the
thrust-to-command map of the motors.

Eq 3.30 lost its subscripts in our copy of the seed; rebuilt (Hoffmann et al. 2007,
Bayezit & Fidan 2013) for rotors on the body axes ("+" layout) it reads

    T1 = -u_theta + u_psi + u_z/4        rotor 1  aft      (channel 0)
    T2 =  u_phi   - u_psi + u_z/4        rotor 2  left     (channel 1)
    T3 =  u_theta + u_psi + u_z/4        rotor 3  front    (channel 2)
    T4 = -u_phi   - u_psi + u_z/4        rotor 4  right    (channel 3)

with u_phi, u_theta, u_psi the effective roll, pitch and yaw inputs [N per rotor] and
u_z the total thrust [N] of eq 3.27 (the seed adds u_z to every rotor; written per rotor
here so that eq 3.27's u_z stays the total). With arm length l and reaction-moment
coefficient k_M this gives the moments (2 l u_phi, 2 l u_theta, 4 k_M u_psi): positive
inputs roll right, pitch nose up and yaw nose right (FRD). Rotors 1 and 3 spin
counter-clockwise seen from above. The rotor order is the plant's
(``sim_bridge/plants/quadrotor.py``).

Saturation keeps attitude authority first (as ArduCopter's and PX4's mixers do):
each rotor's thrust must stay within [T_lo, T_hi] (T_lo the thrust at the minimum
spinning command, T_hi the full-command thrust). If the roll/pitch differential alone
does not fit it is scaled down; yaw is then scaled to what is left; only then is the
collective moved (up or down) so that the differential fits, i.e. height is given up
before attitude. ``saturated`` reports which of these happened (for anti-windup).

Fault accommodation: ``set_effectiveness(k)`` tells the mixer that rotor j gives only
k_j of its modelled thrust (the motor fault monitor's identification,
autopilot/monitor/motors.py). Each rotor's thrust limits become k_j [T_lo, T_hi], the
saturation logic above works within them, and the command of rotor j is that of the
thrust T_j / k_j. With every k_j = 1 (the default) the mixer is the plain one, bit for
bit.

Thrust to command: the motors' static thrust is modelled as ArduCopter's
MOT_THST_EXPO curve, T / (T_max rho/rho0) = (1 - e) u + e u^2, inverted per rotor.
Density scaling (rho/rho0) comes from the barometer (thrust at full command scales
with air density).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import kernel

# channel order of eq 3.30's rotors: (roll sign, pitch sign, yaw sign)
ROTOR_SIGNS = ((0.0, -1.0, 1.0), (1.0, 0.0, -1.0), (0.0, 1.0, 1.0), (-1.0, 0.0, -1.0))


class QuadPlusMixer:
    """``mix(u_z, u_phi, u_theta, u_psi) -> (c1, c2, c3, c4)`` commands 0..1 (the law:
    :func:`mix_rotors`). Its constants and the record of its last mixing are in ``k``
    (K_*), the constants rewritten in place when a parameter changes: ``k`` may be a
    part of the controller's array, given here."""

    __slots__ = ("t_max", "expo", "spin_min", "rho_ratio", "eff", "k")

    def __init__(self, t_max_n: float, expo: float, spin_min: float, k=None):
        self.k = np.zeros(K_N) if k is None else k
        self.t_max = t_max_n
        self.expo = expo
        self.spin_min = spin_min
        self.rho_ratio = 1.0
        self.eff: tuple[float, float, float, float] | None = None   # None: all healthy
        self._limits()

    def configure(self, t_max_n: float, expo: float, spin_min: float) -> None:
        self.t_max, self.expo, self.spin_min = t_max_n, expo, spin_min
        self._limits()

    def set_effectiveness(self, eff) -> None:
        """Rotor effectiveness k_1..k_4 (0.2..1); all 1 (or None) restores the plain mixer."""
        if eff is None or all(k >= 1.0 for k in eff):
            self.eff = None
        else:
            self.eff = tuple(min(max(float(k), 0.2), 1.0) for k in eff)
        self._limits()

    def set_density_ratio(self, rho_ratio: float) -> None:
        # min(max(rho_ratio, 0.5), 1.3), spelt out (the builtins' cost: control/pid.py)
        r = 0.5 if rho_ratio < 0.5 else 1.3 if rho_ratio > 1.3 else rho_ratio
        if r != self.rho_ratio:
            # the one constant that follows the air density (each barometer sample
            # changes it a little), in place; the thrust limits follow from it in the
            # mixing (thrust_limits), not at every sample
            self.rho_ratio = r
            self.k[K_FULL] = self.t_max * r

    def _limits(self) -> None:
        # the kernels' constants (K_* below), each as its formula writes it
        e = self.expo
        eff = self.eff
        self.k[:K_COLL] = ((self.spin_min, self.t_max * self.rho_ratio,
                            1.0 if e < 1e-6 else 0.0, e - 1.0, (1.0 - e) ** 2, 4.0 * e, 2.0 * e,
                            0.0 if eff is None else 1.0) + (eff if eff is not None else (1.0,) * 4))

    # ------------------------------------------------- the last mixing's record --
    @property
    def saturated(self) -> tuple[bool, bool, bool]:
        """(roll/pitch, yaw, collective) saturated."""
        return tuple(s != 0.0 for s in self.k[K_SAT:K_SAT + 3].tolist())

    @property
    def collective(self) -> float:
        """The collective given, 4 c [N]."""
        return float(self.k[K_COLL])

    @property
    def thrusts(self) -> tuple[float, float, float, float]:
        """The rotor thrusts [N]."""
        return tuple(self.k[K_T:K_T + 4].tolist())

    # -------------------------------------------------------------- thrust curve --
    @property
    def t_lo(self) -> float:
        """A rotor's thrust at the lowest spinning command [N]."""
        return thrust_limits(self.k)[0]

    @property
    def t_hi(self) -> float:
        """A rotor's thrust at full command [N]."""
        return thrust_limits(self.k)[1]

    def thrust_of(self, u: float) -> float:
        """Modelled static thrust of one rotor at command u [N] (:func:`rotor_thrust`)."""
        return rotor_thrust(self.k, u)

    def command_of(self, thrust_n: float) -> float:
        """Inverse of :meth:`thrust_of`, clipped to [0, 1]."""
        return command_of_thrust(self.k, thrust_n)

    # ----------------------------------------------------------------- mixing ---
    def mix_thrusts(self, u_z: float, u_phi: float, u_theta: float,
                    u_psi: float) -> tuple[float, float, float, float]:
        """Rotor thrusts [N] of eq 3.30 after the attitude-first saturation."""
        self.mix(u_z, u_phi, u_theta, u_psi)
        return self.thrusts

    def mix(self, u_z: float, u_phi: float, u_theta: float, u_psi: float) -> tuple:
        return mix_rotors(u_z, u_phi, u_theta, u_psi, self.k)


# QuadPlusMixer.k: the lowest spinning command, T_max rho/rho0, the thrust curve's
# inverse (linear flag, e - 1, (1 - e)^2, 4 e, 2 e), the effectiveness flag and
# k_1..k_4; then the last mixing's record (mix_rotors writes it): the collective, the
# three saturation flags (1.0 or 0.0), the rotor thrusts
K_SPIN, K_FULL, K_LINEAR, K_EM1, K_E1SQ, K_E4, K_E2, K_HAS_EFF, K_EFF = range(9)
K_COLL = K_EFF + 4
K_SAT = K_COLL + 1
K_T = K_SAT + 3
K_N = K_T + 4


@kernel
def rotor_thrust(k, u):
    """Modelled static thrust of one rotor at command u [N], on the constants ``k`` of
    :class:`QuadPlusMixer`: T_max rho/rho0 ((1 - e) u + e u^2), with 1 - e = -(e - 1) and
    e = 2 e / 2 from k (both exact)."""
    return k[K_FULL] * (-k[K_EM1] * u + 0.5 * k[K_E2] * u * u)


@kernel
def thrust_limits(k):
    """A rotor's thrust limits on the constants ``k``: (at the lowest spinning command
    K_SPIN, at full command)."""
    return rotor_thrust(k, k[K_SPIN]), rotor_thrust(k, 1.0)


@kernel
def command_of_thrust(k, thrust_n):
    """The command of a rotor thrust [N]: the thrust curve T / (T_max rho/rho0) =
    (1 - e) u + e u^2 inverted, clipped to [0, 1]."""
    t = thrust_n / k[K_FULL]
    if t <= 0.0:
        return 0.0
    if k[K_LINEAR] != 0.0:           # e = 0
        u = t
    else:                            # ((e - 1) + sqrt((1 - e)^2 + 4 e t)) / (2 e)
        u = (k[K_EM1] + math.sqrt(k[K_E1SQ] + k[K_E4] * t)) / k[K_E2]
    return 1.0 if u > 1.0 else u


@kernel
def _low_high(a, b, c, d):
    """(min, max) of four values, spelt out as Python's min / max (the first of equal
    values)."""
    lo = hi = a
    for x in (b, c, d):
        if x < lo:
            lo = x
        if x > hi:
            hi = x
    return lo, hi


@kernel
def mix_rotors(u_z, u_phi, u_theta, u_psi, k):
    """Eq 3.30 with the attitude-first saturation and the effectiveness (module
    docstring): the commands c_1..c_4; the thrusts T_1..T_4 [N], the collective 4 c [N]
    and which of roll/pitch, yaw, collective saturated recorded in ``k``. (min / max
    spelt out as Python's: the first of equal values.)"""
    t_lo, t_hi = thrust_limits(k)
    lo, hi = t_lo, t_hi
    healthy = k[K_HAS_EFF] == 0.0
    e1, e2, e3, e4 = k[K_EFF], k[K_EFF + 1], k[K_EFF + 2], k[K_EFF + 3]
    if not healthy:
        # a weak rotor's limits shrink to k_j [T_lo, T_hi]: the differential has to fit
        # the narrowest span, the collective the tightest rotor (below)
        e_min, e_max = _low_high(e1, e2, e3, e4)
        hi = e_min * t_hi
        lo = e_max * t_lo
    span = hi - lo
    sat_rp = sat_y = sat_c = False
    # roll / pitch differential: rotor pairs (2, 4) and (3, 1)
    rp, rt = abs(u_phi), abs(u_theta)
    rp = rt if rt > rp else rp
    if 2.0 * rp > span:
        s = 0.5 * span / rp
        u_phi, u_theta = u_phi * s, u_theta * s
        sat_rp = True
    # yaw: every rotor carries +-u_psi on top of its roll/pitch share
    rp, rt = abs(u_phi), abs(u_theta)
    room = 0.5 * span - (rt if rt > rp else rp)
    ay = abs(u_psi)
    if ay > room:
        u_psi = math.copysign(0.0 if 0.0 > room else room, u_psi)
        sat_y = True
    d1 = -u_theta + u_psi
    d2 = u_phi - u_psi
    d3 = u_theta + u_psi
    d4 = -u_phi - u_psi
    c = 0.25 * u_z
    if healthy:
        d_min, d_max = _low_high(d1, d2, d3, d4)
        if c + d_max > hi:
            c = hi - d_max
            sat_c = True
        if c + d_min < lo:
            c = lo - d_min
            sat_c = True
    else:
        th, tl = t_hi, t_lo
        c_hi = e1 * th - d1
        c_lo = e1 * tl - d1
        for e, d in ((e2, d2), (e3, d3), (e4, d4)):
            x = e * th - d
            if x < c_hi:
                c_hi = x
            x = e * tl - d
            if x > c_lo:
                c_lo = x
        if c > c_hi:
            c = c_hi
            sat_c = True
        if c < c_lo:
            c = c_lo
            sat_c = True
    t1, t2, t3, t4 = c + d1, c + d2, c + d3, c + d4
    if healthy:
        m1, m2, m3, m4 = (command_of_thrust(k, t1), command_of_thrust(k, t2),
                          command_of_thrust(k, t3), command_of_thrust(k, t4))
    else:
        m1, m2, m3, m4 = (command_of_thrust(k, t1 / e1), command_of_thrust(k, t2 / e2),
                          command_of_thrust(k, t3 / e3), command_of_thrust(k, t4 / e4))
    k[K_COLL] = 4.0 * c
    k[K_SAT] = 1.0 if sat_rp else 0.0
    k[K_SAT + 1] = 1.0 if sat_y else 0.0
    k[K_SAT + 2] = 1.0 if sat_c else 0.0
    k[K_T], k[K_T + 1], k[K_T + 2], k[K_T + 3] = t1, t2, t3, t4
    return m1, m2, m3, m4
