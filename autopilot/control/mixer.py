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

# channel order of eq 3.30's rotors: (roll sign, pitch sign, yaw sign)
ROTOR_SIGNS = ((0.0, -1.0, 1.0), (1.0, 0.0, -1.0), (0.0, 1.0, 1.0), (-1.0, 0.0, -1.0))


class QuadPlusMixer:
    """``mix(u_z, u_phi, u_theta, u_psi) -> (c1, c2, c3, c4)`` commands 0..1."""

    __slots__ = ("t_max", "expo", "spin_min", "rho_ratio", "t_lo", "t_hi", "saturated",
                 "thrusts", "collective", "eff", "_t_full", "_inv")

    def __init__(self, t_max_n: float, expo: float, spin_min: float):
        self.t_max = t_max_n
        self.expo = expo
        self.spin_min = spin_min
        self.rho_ratio = 1.0
        self.saturated = (False, False, False)    # (roll/pitch, yaw, collective)
        self.thrusts = (0.0, 0.0, 0.0, 0.0)
        self.collective = 0.0
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

    def set_density_ratio(self, rho_ratio: float) -> None:
        r = min(max(rho_ratio, 0.5), 1.3)
        if r != self.rho_ratio:
            self.rho_ratio = r
            self._limits()

    def _limits(self) -> None:
        # the thrust curve's constants, for command_of (each as its formula writes it)
        e = self.expo
        self._t_full = self.t_max * self.rho_ratio
        self._inv = None if e < 1e-6 else (e - 1.0, (1.0 - e) ** 2, 4.0 * e, 2.0 * e)
        self.t_hi = self.thrust_of(1.0)
        self.t_lo = self.thrust_of(self.spin_min)

    # -------------------------------------------------------------- thrust curve --
    def thrust_of(self, u: float) -> float:
        """Modelled static thrust of one rotor at command u [N]."""
        e = self.expo
        return self.t_max * self.rho_ratio * ((1.0 - e) * u + e * u * u)

    def command_of(self, thrust_n: float) -> float:
        """Inverse of :meth:`thrust_of`, clipped to [0, 1]."""
        t = thrust_n / self._t_full
        if t <= 0.0:
            return 0.0
        inv = self._inv
        if inv is None:                  # e = 0: linear
            u = t
        else:                            # ((e - 1) + sqrt((1 - e)^2 + 4 e t)) / (2 e)
            em1, e1sq, e4, e2 = inv
            u = (em1 + math.sqrt(e1sq + e4 * t)) / e2
        return 1.0 if u > 1.0 else u

    # ----------------------------------------------------------------- mixing ---
    def mix_thrusts(self, u_z: float, u_phi: float, u_theta: float,
                    u_psi: float) -> tuple[float, float, float, float]:
        """Rotor thrusts [N] of eq 3.30 after the attitude-first saturation."""
        lo, hi = self.t_lo, self.t_hi
        eff = self.eff
        if eff is not None:
            # a weak rotor's limits shrink to k_j [T_lo, T_hi]: the differential has to
            # fit the narrowest span, the collective the tightest rotor (below)
            hi = min(eff) * self.t_hi
            lo = max(eff) * self.t_lo
        span = hi - lo
        sat_rp = sat_y = sat_c = False
        # roll / pitch differential: rotor pairs (2, 4) and (3, 1)
        # max(a, b) spelt out here and below: the builtin's cost (control/pid.py)
        rp, rt = abs(u_phi), abs(u_theta)
        rp = rt if rt > rp else rp
        if 2.0 * rp > span:
            k = 0.5 * span / rp
            u_phi, u_theta = u_phi * k, u_theta * k
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
        if eff is None:
            dmin = min(d1, d2, d3, d4)
            dmax = max(d1, d2, d3, d4)
            if c + dmax > hi:
                c = hi - dmax
                sat_c = True
            if c + dmin < lo:
                c = lo - dmin
                sat_c = True
        else:
            th, tl = self.t_hi, self.t_lo
            c_hi = min(k * th - d for k, d in zip(eff, (d1, d2, d3, d4)))
            c_lo = max(k * tl - d for k, d in zip(eff, (d1, d2, d3, d4)))
            if c > c_hi:
                c = c_hi
                sat_c = True
            if c < c_lo:
                c = c_lo
                sat_c = True
        self.saturated = (sat_rp, sat_y, sat_c)
        self.collective = 4.0 * c
        t = (c + d1, c + d2, c + d3, c + d4)
        self.thrusts = t
        return t

    def mix(self, u_z: float, u_phi: float, u_theta: float, u_psi: float) -> tuple:
        t1, t2, t3, t4 = self.mix_thrusts(u_z, u_phi, u_theta, u_psi)
        cmd = self.command_of
        eff = self.eff
        if eff is not None:
            return (cmd(t1 / eff[0]), cmd(t2 / eff[1]), cmd(t3 / eff[2]), cmd(t4 / eff[3]))
        return (cmd(t1), cmd(t2), cmd(t3), cmd(t4))
