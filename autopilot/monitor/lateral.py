"""Actuator fault detection and identification for the fixed-wing aileron and rudder:
the lateral-directional counterpart of :mod:`.actuator` (course text ch. 8 sec. 2.2.3,
eqs 2.18-2.24; the same two stages).

Stage 1, the lateral balance: the side-force, rolling-moment and yawing-moment equations
(Beard & McLain, Small Unmanned Aircraft, 2012, eqs 3.15 and 5.10-5.12, body axes, the
cross-product of inertia Jxz kept)::

    m a_y               = qbar S (CY_b beta + CY_dr dr)
    Jx p' - Jxz (r' + p q) + (Jz - Jy) q r    = qbar S b (Cl_b beta + Cl_p p b/2V + Cl_r r b/2V + Cl_da da + Cl_dr dr) + L_0
    Jz r' - Jxz (p' - q r) + (Jy - Jx) p q    = qbar S b (Cn_b beta + Cn_p p b/2V + Cn_r r b/2V + Cn_da da + Cn_dr dr) + N_0

are three linear equations in the three unknowns beta, da, dr given the measured body
rates, their derivatives and the lateral specific force a_y: solved every sample, they
give z = (da, dr), the deflections the aircraft flies with. The coefficients are the
airframe's (the Aerosonde's JSBSim file, Table E.2 of the book; :data:`AEROSONDE_LAT`;
JSBSim's Cessna 172P, :data:`C172P_LAT`, with the terms its file and the plant need: the
side force's moments about the CG, the sideslip's drag, the surfaces' gains, the
accelerometer's lever arm, the propeller's gyroscopic yaw, docs/monitor.md), so the
test is armed from the launch. What the model leaves out (the propeller's torque,
which grows with the throttle, and the small asymmetries of the airframe) is the
residual's offset, learnt online per axis on ``[1, throttle (V_ref / V)^2]`` by
recursive least squares with a prior of zero (the balance's refinement, as the
elevator's), FIT_DELAY_S late so a fault is not learnt before it is detected, and not
in the first FIT_WARMUP_S of flight.

The residual's variance (the window test's normalisation, eq 2.13) is learnt on the
same samples FIT_DELAY_S old: its running mean of r^2 starts from LAT_RES_PRIOR_RAD^2
worth LAT_RES_PRIOR_N samples, alone for the first FIT_DELAY_S of flight (moderate turbulence in the climb-out read
1.37 times the threshold 7 s after the launch with 0.01 rad there), and restarts when
the offset fit does (FIT_WARMUP_S), on the residual the fit leaves, with the warm-up's
mean square (which holds the offset not yet learnt: 0.010-0.019 rad on the aileron) as
its prior worth LAT_RES_PRIOR_N samples; the floor LAT_RES_FLOOR_RAD under it. In light
turbulence, 60 s after the launch, the deviations are then 0.006 rad (aileron) and
0.005 rad (rudder); with the warm-up kept in the mean they were 0.009-0.010 rad, and a
fixed floor of 0.015 rad over them made a stuck aileron's 0.05 rad a residual of 3.3
deviations: under the 3.8 a steady residual needs to cross the window test's threshold,
sqrt(FDI_ACT_THR chi2_{alpha_det, M} / M) (3 x 47.7 / 10), however long it lasts. With
the wings level it was found only once the roll loop's command had swung to the other
side of the stuck position (default mission, seed 2: the onset at a turn's roll-in, the
command 0.18 rad, then -0.18 rad as the stuck aileron rolled the aircraft on past the
bank asked; 4.17 s), a stuck rudder's 0.1 rad in 2.6-3.2 s. Now 1.13-2.81 s and
0.67-1.81 s on seeds 1-10 (docs/status.md, stuck aileron, rudder, throttle).

Stage 2 (identification): once detected, the two hypotheses of :mod:`.actuator` over the
samples since the detection: stuck (z constant while the command moves) or weakened
(z = k delta_cmd), the stuck position the mean of z after the onset's transient.

Sign conventions are the autopilot's: aileron +1 rolls right, rudder +1 yaws the nose
right. The book's rudder (and JSBSim's) is positive trailing edge left, nose left:
``dr_book = -rudder``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from autopilot.jit import kernel, preload

from .actuator import (BAL_PERIOD_US, BAL_TAU_S, FIT, FIT_DELAY_S, FIT_WARMUP_S, IDENT_WIN_S, LEFT, LP_ON,
                       LP_T, LP_T0, MAX_DEFLECTION_RAD, NO_FIT, RES_TAU_S, identify_hist, lowpass_advance,
                       lowpass_state, offset_step)
from .airframe import prop_momentum
from .stats import WindowChi2, family_alpha, solve3

RHO0 = 1.225
LAT_RES_FLOOR_RAD = 0.005      # floor of each axis' residual standard deviation [rad]
LAT_RES_PRIOR_RAD = 0.02       # that deviation before any sample is learnt [rad]
LAT_RES_PRIOR_N = 50           # the warm-up's mean square, once the offset fit starts, is
                               # worth this many 10 Hz samples (5 s) in the running mean
LAT_OFFSET_SD_RAD = 0.05       # prior standard deviation of the learnt offset terms [rad]
LAT_FIT_NOISE_RAD = 0.1        # each 10 Hz fit sample's weight against that prior [rad]: the
                               # low-passed samples are correlated (as the elevator's
                               # BAL_NOISE_RAD); with 0.02 a few seconds of climb-out at full
                               # throttle set the throttle term, read 0.12 rad off at 0.2
TEST_DIV = 5                   # the window test on every 5th balance sample (2 Hz)
V_REF = 25.0                   # [m/s]


@dataclass(frozen=True)
class LateralAero:
    """Lateral-directional model of an airframe (the book's sign convention, per rad)."""

    name: str
    mass_kg: float
    wing_area_m2: float
    span_m: float
    Jx: float
    Jy: float
    Jz: float
    Jxz: float
    CY_b: float
    CY_dr: float
    Cl_b: float
    Cl_p: float
    Cl_r: float
    Cl_da: float
    Cl_dr: float
    Cn_b: float
    Cn_p: float
    Cn_r: float
    Cn_da: float
    Cn_dr: float
    # the c172p's further terms (0 / 1: the Aerosonde's model as it was)
    CY_p: float = 0.0              # side force per p b/2V and r b/2V
    CY_r: float = 0.0
    CY_p_a: float = 0.0            # slopes in alpha of CY_p, CY_r, Cl_r [per rad of alpha]
    CY_r_a: float = 0.0            # over 0..alpha_max (JSBSim's tables, held outside)
    Cl_r_a: float = 0.0
    alpha_max: float = 0.0
    CL0: float = 0.0               # the lift's linear range, for alpha from the measured
    CLa: float = 0.0               # normal force (only where a slope above is not 0)
    arp_x_m: float = 0.0           # the aerodynamic reference point behind the CG [m]
    arp_z_m: float = 0.0           # and above it [m]: the side force's rolling and yawing
                                   # moments about the CG
    da_right: float = 1.0          # the aileron's surface rad per autopilot rad, rolling
    da_left: float = 1.0           # right (+) and left (-): the FCS's 15 and 20 deg
    dr_gain: float = 1.0           # the rudder's surface rad per autopilot rad
    wash_dr: float = 1.0           # the rudder's yawing moment's dynamic pressure over the
                                   # free stream's (the propeller's slipstream on the fin)
    CD0: float = 0.0               # the drag (CD0 + the table CD_alpha over alpha), whose
    CD_alpha: tuple = ()           # body-y part in a sideslip is -CD beta
    CD_beta: float = 0.0           # and the sideslip's drag, CD_beta |beta|
    imu_x_m: float = 0.0           # the accelerometer ahead of the CG [m]
    imu_z_m: float = 0.0           # and below it [m] (body axes: above is negative)
    prop_ixx: float = 0.0          # the propeller's rotating inertia [kg m^2] (0: the
    prop_sense: float = 1.0        # identifier's ``prop`` gives its momentum), its spin
    rpm: tuple = (0.0,) * 5        # rpm ~ a + b thr + c V + d thr V + e thr^2
    rudder_roll_gain: float = 0.0  # the roll loop's aileron onto the rudder with the aileron
                                   # out (0: Cl_da / -Cl_dr, the rudder's direct roll). The
                                   # c172p's rudder rolls the other way directly (Cl_dr) and
                                   # through the sideslip later (the dihedral): its steady
                                   # ratio (steady_roll_ratio) 3.17 made the roll loop
                                   # limit-cycle at full rudder (bank +-50 deg, the aircraft
                                   # lost with 0.05 rad stuck); a decision: 1.0
    raw_accel: bool = False        # the accelerometer as measured, not less the navigation
                                   # filter's bias estimate: its synthetic sideslip (zero,
                                   # EK_BETA_NSE) reads a sideslip's side force as a bias
                                   # (the c172p's ground roll in light turbulence and 5 m/s:
                                   # 0.2-0.3 m/s^2 against a true 0.03-0.07, 0.1 rad of
                                   # rudder; a stuck rudder's sideslip would be absorbed too)

    @cached_property
    def prop_coefs(self) -> np.ndarray:
        """The propeller's numbers as :func:`.airframe.prop_momentum` takes them."""
        return np.array((*self.rpm, self.prop_sense * self.prop_ixx if self.prop_ixx > 0.0 else 0.0))

    def prop_momentum(self, throttle: float, v_mps: float) -> float:
        """The propeller's angular momentum H [N m s] at that throttle and airspeed: its
        gyroscopic yawing moment is ``-H q`` (:func:`.airframe.prop_momentum`)."""
        return prop_momentum(self.prop_coefs, throttle, v_mps)

    def deflections(self, V: float, p: float, q: float, r: float, pd: float, rd: float,
                    a_y: float, n_gyro: float = 0.0, a_z: float | None = None) -> tuple[float, float]:
        """(aileron, rudder) in the autopilot's convention [rad] that balance the
        measured motion (module docstring); rates [rad/s], their derivatives [rad/s^2],
        a_y the lateral specific force [m/s^2]; ``n_gyro`` the propeller's gyroscopic
        yawing moment ``-H q`` [N m] (airframe.PitchAero.prop_momentum): in the
        Aerosonde's turns (q 0.1-0.17 rad/s, H 2.2 N m s) 0.2-0.4 N m, about 0.02 rad of
        rudder."""
        qS = 0.5 * RHO0 * V * V * self.wing_area_m2
        qSb = qS * self.span_m
        k = self.span_m / (2.0 * V)
        L = self.Jx * pd - self.Jxz * (rd + p * q) + (self.Jz - self.Jy) * q * r
        N = self.Jz * rd - self.Jxz * (pd - q * r) + (self.Jy - self.Jx) * p * q
        if self._simple:
            # the Aerosonde's (bit for bit as before)
            _beta, da, dr = solve3(self._A_simple, self.mass_kg * a_y / qS,
                                   L / qSb - self.Cl_p * k * p - self.Cl_r * k * r,
                                   (N - n_gyro) / qSb - self.Cn_p * k * p - self.Cn_r * k * r)
            return da, -dr
        # the rate derivatives at the angle of attack the measured normal force gives
        al = 0.0
        if a_z is not None and self.CLa > 0.0:
            al = min(max((-self.mass_kg * a_z / qS - self.CL0) / self.CLa, 0.0), self.alpha_max)
        # the specific force at the CG: the accelerometer's less the lever arm's
        # rotation terms, (w' x r + w x (w x r))_y
        rx, rz = self.imu_x_m, self.imu_z_m
        a_y = a_y - (rd * rx - pd * rz) - q * (p * rx + r * rz)
        CY_b, Cl_b, Cl_dr, Cn_b, Cn_dr = self._about_cg(al)
        CY_p = self.CY_p + self.CY_p_a * al
        CY_r = self.CY_r + self.CY_r_a * al
        Cl_r = self.Cl_r + self.Cl_r_a * al
        # the side force acts at the aerodynamic reference point: about the CG it rolls
        # (arp_z_m above) and yaws (arp_x_m behind) (_about_cg)
        zb, xb = self.arp_z_m / self.span_m, self.arp_x_m / self.span_m
        A = np.array(((CY_b, 0.0, self.CY_dr),
                      (Cl_b, self.Cl_da, Cl_dr),
                      (Cn_b, self.Cn_da, Cn_dr)))
        cy_rates = CY_p * k * p + CY_r * k * r
        y = (self.mass_kg * a_y / qS - cy_rates,
             L / qSb - self.Cl_p * k * p - Cl_r * k * r - zb * cy_rates,
             (N - n_gyro) / qSb - self.Cn_p * k * p - self.Cn_r * k * r + xb * cy_rates)
        beta, sa, sr = solve3(A, *y)
        if self.CD_beta:
            # the sideslip's own drag (CD_beta |beta|): its side part -CD_beta |beta| beta,
            # taken at the sideslip first solved, and solved again
            e = self.CD_beta * abs(beta)
            A[0, 0] -= e
            A[1, 0] -= zb * e
            A[2, 0] += xb * e
            _beta, sa, sr = solve3(A, *y)
        # the surfaces' deflections back to the autopilot's rad
        da = sa / (self.da_right if sa >= 0.0 else self.da_left)
        return float(da), float(-sr / self.dr_gain)

    @cached_property
    def _A_simple(self) -> np.ndarray:
        """The Aerosonde's (:attr:`_simple`) matrix of the balance in (beta, da, dr_book):
        its coefficients alone, the same at every sample."""
        return np.array(((self.CY_b, 0.0, self.CY_dr),
                         (self.Cl_b, self.Cl_da, self.Cl_dr),
                         (self.Cn_b, self.Cn_da, self.Cn_dr)))

    @cached_property
    def _simple(self) -> bool:
        """The Aerosonde's model: no term beyond the book's (read at every sample: once)."""
        return self.arp_z_m == 0.0 and self.CY_p == 0.0 and self.CY_r == 0.0 and self.Cl_r_a == 0.0

    def _about_cg(self, al: float) -> tuple[float, float, float, float, float]:
        """(CY_b, Cl_b, Cl_dr, Cn_b, Cn_dr) about the CG at angle of attack ``al``: the
        drag's part of the side force in a sideslip (-CD beta), the side force's moments
        from the aerodynamic reference point, the slipstream on the rudder's yaw."""
        CD = self.CD0
        if self.CD_alpha:
            CD += float(np.interp(al, self.CD_alpha[0], self.CD_alpha[1]))
        CY_b = self.CY_b - CD
        zb, xb = self.arp_z_m / self.span_m, self.arp_x_m / self.span_m
        return (CY_b, self.Cl_b + zb * CY_b, self.Cl_dr + zb * self.CY_dr,
                self.Cn_b - xb * CY_b, self.Cn_dr * self.wash_dr - xb * self.CY_dr)

    def _aileron_gain(self, value: float) -> float:
        return self.da_right if value >= 0.0 else self.da_left

    def steady_roll_ratio(self) -> float:
        """The aileron's rolling moment (at its mean gain) over the rudder's steady one
        with the yawing moment balanced, ``Cl_dr - Cl_b Cn_dr / Cn_b`` (the roll through
        the sideslip the rudder yaws the aircraft into), per autopilot rad."""
        _CY_b, Cl_b, Cl_dr, Cn_b, Cn_dr = self._about_cg(0.03)
        per_rudder = -(Cl_dr - Cl_b * Cn_dr / Cn_b) * self.dr_gain
        return self.Cl_da * 0.5 * (self.da_right + self.da_left) / per_rudder

    def counter(self, stuck: str, value: float) -> float:
        """The other surface's deflection (autopilot convention, rad) that holds the
        wings level with no rates against ``stuck`` ("aileron" or "rudder") held at
        ``value`` [rad]: the rolling and yawing moments both zero, the sideslip free (its
        side force then banks the aircraft a little)."""
        if not self._simple:
            # the c172p's: about the CG (at the cruise's angle of attack, 0.03 rad), the
            # surfaces' gains between the autopilot's rad and the surface's
            _CY_b, Cl_b, Cl_dr, Cn_b, Cn_dr = self._about_cg(0.03)
            if stuck == "aileron":
                sa = value * self._aileron_gain(value)
                A = np.array(((Cl_b, Cl_dr), (Cn_b, Cn_dr)))
                _beta, sr = np.linalg.solve(A, np.array((-self.Cl_da * sa, -self.Cn_da * sa)))
                return float(-sr / self.dr_gain)
            sr = -value * self.dr_gain
            A = np.array(((Cl_b, self.Cl_da), (Cn_b, self.Cn_da)))
            _beta, sa = np.linalg.solve(A, np.array((-Cl_dr * sr, -Cn_dr * sr)))
            return float(sa / self._aileron_gain(sa))
        if stuck == "aileron":
            A = np.array(((self.Cl_b, self.Cl_dr), (self.Cn_b, self.Cn_dr)))
            _beta, dr = np.linalg.solve(A, np.array((-self.Cl_da * value, -self.Cn_da * value)))
            return float(-dr)
        A = np.array(((self.Cl_b, self.Cl_da), (self.Cn_b, self.Cn_da)))
        dr = -value
        _beta, da = np.linalg.solve(A, np.array((-self.Cl_dr * dr, -self.Cn_dr * dr)))
        return float(da)

    def roll_gain(self, stuck: str) -> float:
        """Rolling moment of the other surface per unit of the stuck one's (autopilot
        convention): the factor that maps the roll loop's aileron onto the rudder."""
        if stuck == "aileron" and self.rudder_roll_gain:
            return self.rudder_roll_gain
        if stuck == "aileron":
            return self.Cl_da / -self.Cl_dr
        return 1.0


# the Aerosonde (sim_bridge/aircraft/aerosonde/aerosonde.xml: mass_balance, side-beta,
# side-rudder, roll-*, yaw-*; Jxz 0.1204 the book's, JSBSim's -0.1204 in its convention)
AEROSONDE_LAT = LateralAero("aerosonde", mass_kg=13.5, wing_area_m2=0.55, span_m=2.8956,
                            Jx=0.8244, Jy=1.135, Jz=1.759, Jxz=0.1204,
                            CY_b=-0.98, CY_dr=-0.17,
                            Cl_b=-0.12, Cl_p=-0.26, Cl_r=0.14, Cl_da=0.08, Cl_dr=0.105,
                            Cn_b=0.25, Cn_p=0.022, Cn_r=-0.35, Cn_da=0.06, Cn_dr=-0.032)

# JSBSim's Cessna 172P (the jsbsim package's aircraft/c172p/c172p.xml; tests/
# test_monitor_lateral.py reads the file and checks these): the SIDE, ROLL and YAW axes
# flaps up, per rad (CYb -0.137, Clb -0.0322, Cnb 0.0205 at beta 0.349; CYp, CYr, Clr
# tables in alpha 0..0.094, held outside), about the aerodynamic reference point (x 43.2
# in, z 59.4 in), 1.08 in behind and 21.66 in above the CG with the point masses and
# the fuel (x 42.12, z 37.74 in): the side force's moment about the CG moved in
# (arp_x_m, arp_z_m). Inertia with the point masses and the fuel (JSBSim's
# inertia/i*-slugs_ft2: ixx 1524.4, iyy 1384.3, izz 2525.5, ixz -16.69, the book's Jxz
# +16.69). The aerodynamic moments act on the left aileron's deflection alone, which
# the FCS moves 15 deg up (fcs/aileron-cmd-norm +1, roll right) and 20 deg down (-1) per
# normalised command (0.35 autopilot rad); the rudder 16 deg each way. Cndr acts on
# aero/function/qbar-induced-psf (the slipstream: wash_dr, as the elevator's).
_LB, _FT, _IN, _SLUGFT2 = 0.45359237, 0.3048, 0.0254, 1.3558179
C172P_LAT = LateralAero("c172p", mass_kg=1880 * _LB, wing_area_m2=174 * _FT ** 2, span_m=35.8 * _FT,
                        Jx=1524.4 * _SLUGFT2, Jy=1384.3 * _SLUGFT2, Jz=2525.5 * _SLUGFT2,
                        Jxz=16.69 * _SLUGFT2,
                        CY_b=-0.137 / 0.349, CY_dr=0.187,
                        Cl_b=-0.0322 / 0.349, Cl_p=-0.484, Cl_r=0.0798, Cl_da=0.229, Cl_dr=0.0147,
                        Cn_b=0.0205 / 0.349, Cn_p=-0.0278, Cn_r=-0.0937, Cn_da=-0.0053, Cn_dr=-0.043,
                        CY_p=-0.075, CY_r=0.214,
                        CY_p_a=(-0.145 + 0.075) / 0.094, CY_r_a=(0.267 - 0.214) / 0.094,
                        Cl_r_a=(0.1869 - 0.0798) / 0.094, alpha_max=0.094,
                        CL0=0.25, CLa=(0.73 - 0.25) / 0.09,
                        arp_x_m=(43.2 - 42.12) * _IN, arp_z_m=(59.4 - 37.74) * _IN,
                        da_right=15.0 * 0.01745 / 0.35, da_left=20.0 * 0.01745 / 0.35,
                        dr_gain=16.0 * 0.01745 / 0.35, wash_dr=1.245,
                        CD0=0.027, CD_alpha=((-0.0175, 0.0, 0.0175, 0.0349, 0.0524, 0.0698, 0.0873, 0.1047),
                                             (0.0020, 0.0052, 0.0099, 0.0162, 0.0240, 0.0334, 0.0442, 0.0566)),
                        CD_beta=0.17, imu_x_m=(42.12 - 37.0) * _IN, imu_z_m=-(48.0 - 37.74) * _IN,
                        prop_ixx=1.67 * _SLUGFT2, prop_sense=1.0,
                        rpm=(477.99, 957.93, 19.38, -8.27, 776.39), raw_accel=True,
                        rudder_roll_gain=1.0)

LAT_MODELS = {1: AEROSONDE_LAT, 2: C172P_LAT}

AXES = ("aileron", "rudder")


NO_FORCE = (0.0, 0.0, 0.0)      # the specific force of a step without one (flying False)
NO_BIAS = np.zeros(0)           # no accelerometer bias to add (lateral_front)


@kernel
def lateral_front(lp, st, t_us, V, flying, w, f_b, ba, aileron, rudder, throttle, hc, two):
    """The lateral balance's signals (the body rates ``w``, the lateral and normal
    specific force ``f_b`` (plus the accelerometer bias estimate ``ba`` where the model
    wants it raw, LateralAero.raw_accel; empty: not), V, the aileron and rudder commands
    [rad], throttle (V_REF / V)^2 and the propeller's gyroscopic yawing moment -H q,
    ``hc`` its numbers or None) low-passed (actuator.lowpass_advance), flying at 10 m/s or
    more (else they start again): True where a balance sample is due, with the roll and
    yaw accelerations in ``lp[10]``, ``lp[11]`` (LateralIdentifier.sample). (``two``: 2.0,
    the square taken by libm's pow as the interpreter's ``** 2`` takes it; x * x differs
    in the last bit now and then.)"""
    if not flying or V < 10.0:
        st[LP_ON] = 0
        return False
    fy, fz = f_b[1], f_b[2]
    if ba.shape[0]:
        fy, fz = fy + ba[1], fz + ba[2]
    w0, w1, w2 = w[0], w[1], w[2]
    x = lp[12:]
    x[0], x[1], x[2], x[3], x[4] = w0, w1, w2, fy, V
    x[5], x[6] = aileron * MAX_DEFLECTION_RAD, rudder * MAX_DEFLECTION_RAD
    x[7] = throttle * (V_REF / V) ** two
    x[8] = 0.0 if hc is None else -prop_momentum(hc, throttle, V) * w1
    x[9] = fz
    if not lowpass_advance(lp, st, 10, t_us):
        return False
    # the derivative of a first-order low-passed rate is (x - x_lp) / tau, exactly
    lp[10] = (w0 - lp[0]) / BAL_TAU_S
    lp[11] = (w2 - lp[2]) / BAL_TAU_S
    return True


# an axis' state (axis_step's ``st``): the residual's variance and the samples in it, the
# fit started (1: the warm-up's variance now a prior), the variance restarted with the fit
# (1: a prior was given), the prior's weight in samples; then the first row and the length
# of its two rings in ``ring``: the samples waiting FIT_DELAY_S (t_us, x1, x2, raw residual,
# residual; _Q_ROWS rows) and the last 20 s of (t_us, z, delta_cmd) (_H_ROWS rows after them)
_R_VAR, _N_VAR, _FITTING, _REFIT, _PRIOR_N, _Q0, _QN, _H0, _HN = range(9)
_Q_ROWS, _H_ROWS = 128, 256     # (at most 101 waiting and 201 kept: one sample each 0.1 s)
# axis_step's ``learn``: nothing (frozen or suspended), the variance only, the offset too
LEARN_NONE, LEARN_VAR, LEARN_ALL = -1, 0, 1


@kernel
def axis_step(fit, st, ring, t_us, x1, x2, z, d, learn):
    """One sample of an axis (:class:`_Axis`, whose ``step`` says what each input is): the
    samples FIT_DELAY_S old fitted (offset_step) and their residuals' variance learnt, in
    ``fit`` and ``st``; the offset taken out of z; (t_us, z, d) kept 20 s and the sample
    queued for its fit, in ``ring``. Returns the residual r. (One call a sample, not a
    list's pops and pushes and a compiled call for each fit, around it.)"""
    raw = z - d
    zc = 0.0
    have_zc = False                # z with the learnt offset removed (before this sample's fit)
    refit = st[_REFIT] != 0.0
    if learn != LEARN_NONE:
        while st[_QN] > 0 and t_us - ring[int(st[_Q0]), 0] >= FIT_DELAY_S * 1e6:
            i = int(st[_Q0])
            st[_Q0] = (i + 1) % _Q_ROWS
            st[_QN] -= 1
            if refit and learn == LEARN_ALL and st[_FITTING] == 0.0:
                st[_FITTING] = 1.0              # the warm-up's variance, now a prior
                st[_N_VAR] = 0.0
            # (the prediction error of the fit: with refit the residual it leaves)
            dot, e, _ = offset_step(fit, x1, x2, ring[i, 1], ring[i, 2], ring[i, 3],
                                    FIT if learn == LEARN_ALL else LEFT if refit else NO_FIT)
            if not have_zc:
                zc = z - dot
                have_zc = True
            ro = e if refit else ring[i, 4]
            st[_N_VAR] += 1.0
            # the running mean of r^2 with the prior as prior_n samples, then
            # exponentially weighted over RES_TAU_S
            a = max(1.0 / (st[_N_VAR] + st[_PRIOR_N]), BAL_PERIOD_US * 1e-6 / RES_TAU_S)
            st[_R_VAR] += a * (ro * ro - st[_R_VAR])
    if not have_zc:
        # (the mode as an int64: numba would compile offset_step again for a literal 0)
        zc = z - offset_step(fit, x1, x2, 0.0, 0.0, 0.0, np.int64(NO_FIT))[0]
    r = zc - d
    if st[_HN] >= _H_ROWS or st[_QN] >= _Q_ROWS:
        raise ValueError("axis_step: samples closer than 0.1 s")
    j = _Q_ROWS + (int(st[_H0]) + int(st[_HN])) % _H_ROWS
    ring[j, 0], ring[j, 1], ring[j, 2] = t_us, zc, d
    st[_HN] += 1
    while t_us - ring[_Q_ROWS + int(st[_H0]), 0] > 20e6:
        st[_H0] = (int(st[_H0]) + 1) % _H_ROWS
        st[_HN] -= 1
    if learn != LEARN_NONE:
        i = (int(st[_Q0]) + int(st[_QN])) % _Q_ROWS
        ring[i, 0], ring[i, 1], ring[i, 2], ring[i, 3], ring[i, 4] = t_us, x1, x2, raw, r
        st[_QN] += 1
    return r


class _Axis:
    """One control's residual z - delta_cmd: its offset fit, variance and window test."""

    def __init__(self, name: str, M: int, alpha: float, alpha_det: float,
                 floor: float = LAT_RES_FLOOR_RAD, offset_sd: float = LAT_OFFSET_SD_RAD,
                 fit_noise: float = LAT_FIT_NOISE_RAD, prior: float | None = None, prior_n: int = 0,
                 n_phi: int = 2):
        """``prior``: the residual's standard deviation before any sample (``floor``
        if None), worth ``prior_n`` samples in the variance's running mean. With a
        prior, the variance is that of the residual the offset fit leaves, restarted
        when the fit starts with the warm-up's mean square (which holds the offset not
        yet learnt) as the prior. The throttle's (no prior) is as before."""
        self.name = name
        self.floor = floor
        self.refit = prior is not None
        self.fitting = False           # (the state's _FITTING, read by the throttle's each step)
        self.win = WindowChi2(1, M, alpha, alpha_det)
        # the offset's terms c (n_phi regressors, 2 but the rotor's) and their covariance P,
        # one array (offset_step)
        self._fit = np.zeros((n_phi + 1, n_phi))
        self.c, self.P = self._fit[0], self._fit[1:]
        self.P[:] = np.eye(n_phi) * (offset_sd / fit_noise) ** 2
        self._st = np.zeros(9)         # (axis_step)
        self._st[_R_VAR] = (floor if prior is None else prior) ** 2
        self._st[_REFIT] = float(self.refit)
        self._st[_PRIOR_N] = prior_n
        self._ring = np.zeros((_Q_ROWS + _H_ROWS, 5))
        self.ratio = 0.0
        self.residual = 0.0
        # (autopilot.jit.preload)
        preload(axis_step, self._fit.copy(), self._st.copy(), self._ring.copy(), 0, 0.0, 0.0,
                0.0, 0.0, LEARN_ALL)

    @property
    def r_var(self) -> float:
        """The residual's variance [rad^2, or full throttle^2]."""
        return float(self._st[_R_VAR])

    @property
    def hist(self) -> list:
        """(t_us, z, delta_cmd) of the last 20 s, oldest first (z less the learnt offset)."""
        h0, n = int(self._st[_H0]), int(self._st[_HN])
        rows = self._ring[_Q_ROWS:][(h0 + np.arange(n)) % _H_ROWS, :3].tolist()
        return [(int(t), z, d) for t, z, d in rows]

    def drop_waiting(self) -> None:
        """The samples waiting for their fit dropped (they may hold a fault)."""
        self._st[_QN] = 0.0

    def step(self, t_us: int, x1: float, x2: float, z: float, d: float, learn: bool | None,
             k_test: bool) -> None:
        """``(1, x1[, x2])`` the offset's regressor (x2 where it has three terms);
        ``learn``: True the offset and the variance are learnt, False the variance only
        (the first FIT_WARMUP_S of flight), None nothing (frozen or suspended)."""
        mode = LEARN_NONE if learn is None else LEARN_ALL if learn else LEARN_VAR
        r = self.residual = axis_step(self._fit, self._st, self._ring, t_us, x1, x2, z, d, mode)
        if self.refit and not self.fitting and learn:
            self.fitting = self._st[_FITTING] != 0.0
        if k_test:
            R = max(self.r_var, self.floor ** 2)
            self.win.push([r / math.sqrt(R)])
            self.ratio = self.win.ratio_det


class LateralIdentifier:
    """Aileron and rudder fault detection and identification (module docstring).

    ``step(t_us, nav, controls, flying, f_b)`` once per (monitor) step with the normalised
    commands (aileron, elevator, rudder, throttle) and the specific force (body FRD).
    Outputs: ``ratio`` (per axis, window statistic / threshold), ``worst()``."""

    def __init__(self, model: LateralAero, alpha: float = 1e-4, window: int = 10, p_fa: float = 0.01,
                 prop=None, nav=None):
        self.model = model
        self.prop = prop               # airframe.PitchAero: the propeller's momentum (or None)
        # the navigation filter, whose accelerometer bias estimate a model with raw_accel
        # adds back to the specific force it is given (LateralAero.raw_accel)
        self._nav = nav if model.raw_accel else None
        tests_per_hour = 3600e6 / (BAL_PERIOD_US * TEST_DIV)
        a_det = family_alpha(p_fa, 2 * tests_per_hour)     # two axes share the budget
        self.axes = {n: _Axis(n, window, alpha, a_det, prior=LAT_RES_PRIOR_RAD, prior_n=LAT_RES_PRIOR_N)
                     for n in AXES}
        # the propeller's gyroscopic yawing moment: the model's, or the pitch model's propeller
        self._hc = (model.prop_coefs if model.prop_ixx > 0.0 else None if prop is None
                    else prop.gyro_coefs)
        self._lp = np.zeros(22)        # the signals low-passed (lateral_front), the roll and yaw
                                       # accelerations, the signals; their state below
        self._st = lowpass_state()
        self._k = 0
        self.frozen = False
        self.suspended = False
        self._fault_us = None
        # (autopilot.jit.preload: the balance's kernel loaded now, not on leaving the ground)
        preload(lateral_front, self._lp.copy(), self._st.copy(), 0, 20.0, True, np.zeros(3), NO_FORCE,
                np.zeros(3) if model.raw_accel else NO_BIAS, 0.0, 0.0, 0.5, self._hc, 2.0)
        preload(solve3, np.eye(3), 0.0, 0.0, 0.0)

    def freeze(self, t_us: int) -> None:
        """A fault detected: nothing is learnt any more; identification from 1 s before."""
        self.frozen = True
        for ax in self.axes.values():
            ax.drop_waiting()
        self._fault_us = t_us - 1_000_000

    def suspend(self, on: bool) -> None:
        """A sensor fault running: nothing is learnt, the waiting samples dropped."""
        if on and not self.suspended:
            for ax in self.axes.values():
                ax.drop_waiting()
        self.suspended = on

    def step(self, t_us: int, nav, controls: tuple, flying: bool, f_b) -> bool:
        """True where the axes' ``ratio`` were renewed (their window tests ran: 2 Hz)."""
        if not lateral_front(self._lp, self._st, t_us, nav.airspeed_mps, flying and f_b is not None, nav.omega_b,
                             NO_FORCE if f_b is None else f_b, self.accel_bias(), controls[0],
                             controls[2], controls[3], self._hc, 2.0):
            return False
        return self.sample(t_us)

    def accel_bias(self) -> np.ndarray:
        """The navigation's accelerometer bias estimate, added back where the model wants
        the specific force raw (LateralAero.raw_accel); NO_BIAS otherwise."""
        ba = None if self._nav is None else getattr(self._nav, "accel_bias", None)
        return NO_BIAS if ba is None else ba

    def sample(self, t_us: int) -> bool:
        """The balance's sample due (:func:`lateral_front`): the deflections it says the
        aircraft flies with, each axis' residual and test. True where the axes' ``ratio``
        were renewed."""
        lp = self._lp.tolist()
        pd, rd = lp[10], lp[11]
        za, zr = self.model.deflections(lp[4], lp[0], lp[1], lp[2], pd, rd, lp[3], lp[8], lp[9])
        self._k += 1
        k_test = self._k >= TEST_DIV
        if k_test:
            self._k = 0
        # not learnt on the first FIT_WARMUP_S of flight (the launch and the climb-out at
        # full throttle: not quasi-steady, and one throttle only), as the elevator's balance
        # (the residual's variance is learnt from the start: with the floor alone, moderate
        # turbulence in the climb-out read 1.4 times the threshold 7 s after the launch)
        learn = (None if self.frozen or self.suspended
                 else t_us - int(self._st[LP_T0]) >= FIT_WARMUP_S * 1e6)
        # the offsets' regressor (1, throttle (V_REF / V)^2)
        self.axes["aileron"].step(t_us, lp[7], 0.0, za, lp[5], learn, k_test)
        self.axes["rudder"].step(t_us, lp[7], 0.0, zr, lp[6], learn, k_test)
        return k_test

    def worst(self) -> tuple[str, float]:
        """The axis whose statistic is the largest, and that ratio."""
        name = max(self.axes, key=lambda n: self.axes[n].ratio)
        return name, self.axes[name].ratio

    def identified(self, name: str, stuck: bool = False) -> dict | None:
        """Stuck (at what position) or weakened (what effectiveness), as the elevator's
        identification, over the samples since the detection."""
        if self._fault_us is None:
            return None
        ax = self.axes[name]
        recent = None if self._st[LP_T0] < 0 else int(self._st[LP_T]) - int(IDENT_WIN_S * 1e6)
        return identify_hist(ax.hist, self._fault_us, stuck, recent)
