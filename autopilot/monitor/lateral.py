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
airframe's (the Aerosonde's JSBSim file, Table E.2 of the book; :data:`AEROSONDE_LAT`),
so the test is armed from the launch. What the model leaves out (the propeller's torque,
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

import numpy as np

from .actuator import (BAL_PERIOD_US, BAL_TAU_S, FIT_DELAY_S, FIT_WARMUP_S, IDENT_WIN_S,
                       MAX_DEFLECTION_RAD, RES_TAU_S, RESTART_HOLD_S, identify_hist)
from .stats import WindowChi2, family_alpha

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

    def deflections(self, V: float, p: float, q: float, r: float, pd: float, rd: float,
                    a_y: float, n_gyro: float = 0.0) -> tuple[float, float]:
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
        A = np.array(((self.CY_b, 0.0, self.CY_dr),
                      (self.Cl_b, self.Cl_da, self.Cl_dr),
                      (self.Cn_b, self.Cn_da, self.Cn_dr)))
        y = np.array((self.mass_kg * a_y / qS,
                      L / qSb - self.Cl_p * k * p - self.Cl_r * k * r,
                      (N - n_gyro) / qSb - self.Cn_p * k * p - self.Cn_r * k * r))
        _beta, da, dr = np.linalg.solve(A, y)
        return float(da), float(-dr)

    def counter(self, stuck: str, value: float) -> float:
        """The other surface's deflection (autopilot convention, rad) that holds the
        wings level with no rates against ``stuck`` ("aileron" or "rudder") held at
        ``value`` [rad]: the rolling and yawing moments both zero, the sideslip free (its
        side force then banks the aircraft a little)."""
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

LAT_MODELS = {1: AEROSONDE_LAT}

AXES = ("aileron", "rudder")


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
        self.prior_n = prior_n
        self.refit = prior is not None
        self.fitting = False
        self.win = WindowChi2(1, M, alpha, alpha_det)
        self.c = np.zeros(n_phi)       # the offset's terms (n_phi regressors, 2 but the rotor's)
        self.P = np.eye(n_phi) * (offset_sd / fit_noise) ** 2
        self.r_var = (floor if prior is None else prior) ** 2
        self.n_var = 0
        self.queue: list = []          # (t_us, phi, residual) waiting FIT_DELAY_S
        self.hist: list = []           # (t_us, z, delta_cmd) of the last 20 s
        self.ratio = 0.0
        self.residual = 0.0

    def step(self, t_us: int, phi: np.ndarray, z: float, d: float, learn: bool | None, k_test: bool) -> None:
        """``learn``: True the offset and the variance are learnt, False the variance only
        (the first FIT_WARMUP_S of flight), None nothing (frozen or suspended)."""
        raw = z - d
        zc = z - float(phi @ self.c)            # z with the learnt offset removed
        r = zc - d
        self.residual = r
        h = self.hist
        h.append((t_us, zc, d))
        while h and t_us - h[0][0] > 20e6:
            h.pop(0)
        if learn is not None:
            q = self.queue
            q.append((t_us, phi, raw, r))
            while q and t_us - q[0][0] >= FIT_DELAY_S * 1e6:
                _, ph, rw, ro = q.pop(0)
                if self.refit:
                    ro = rw - float(ph @ self.c)        # the residual the fit leaves
                    if learn and not self.fitting:
                        self.fitting = True             # the warm-up's variance, now a prior
                        self.n_var = 0
                if learn:
                    Pp = self.P @ ph
                    g = Pp / (1.0 + ph @ Pp)
                    self.c = self.c + g * (rw - ph @ self.c)
                    self.P = self.P - np.outer(g, Pp)
                self.n_var += 1
                # the running mean of r^2 with the prior as prior_n samples, then
                # exponentially weighted over RES_TAU_S
                a = max(1.0 / (self.n_var + self.prior_n), BAL_PERIOD_US * 1e-6 / RES_TAU_S)
                self.r_var += a * (ro * ro - self.r_var)
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
                 prop=None):
        self.model = model
        self.prop = prop               # airframe.PitchAero: the propeller's momentum (or None)
        tests_per_hour = 3600e6 / (BAL_PERIOD_US * TEST_DIV)
        a_det = family_alpha(p_fa, 2 * tests_per_hour)     # two axes share the budget
        self.axes = {n: _Axis(n, window, alpha, a_det, prior=LAT_RES_PRIOR_RAD, prior_n=LAT_RES_PRIOR_N)
                     for n in AXES}
        self._lp = None
        self._t_us = None
        self._start_us = None          # the low-passes' latest (re)start
        self._next_us = 0
        self._k = 0
        self._t0_us = None
        self.frozen = False
        self.suspended = False
        self._fault_us = None

    def freeze(self, t_us: int) -> None:
        """A fault detected: nothing is learnt any more; identification from 1 s before."""
        self.frozen = True
        for ax in self.axes.values():
            ax.queue.clear()
        self._fault_us = t_us - 1_000_000

    def suspend(self, on: bool) -> None:
        """A sensor fault running: nothing is learnt, the waiting samples dropped."""
        if on and not self.suspended:
            for ax in self.axes.values():
                ax.queue.clear()
        self.suspended = on

    def step(self, t_us: int, nav, controls: tuple, flying: bool, f_b) -> None:
        V = nav.airspeed_mps
        if not flying or V < 10.0 or f_b is None:
            self._lp = None
            return
        w = nav.omega_b
        x = [float(w[0]), float(w[1]), float(w[2]), float(f_b[1]), V,
             float(controls[0]) * MAX_DEFLECTION_RAD, float(controls[2]) * MAX_DEFLECTION_RAD,
             float(controls[3]) * (V_REF / V) ** 2,
             0.0 if self.prop is None else -self.prop.prop_momentum(float(controls[3]), V) * float(w[1])]
        if self._lp is None:
            self._lp, self._t_us = list(x), t_us
            self._start_us = t_us
            if self._t0_us is None:
                self._t0_us = t_us
            return
        dt = (t_us - self._t_us) * 1e-6
        self._t_us = t_us
        if dt <= 0.0:
            return
        a = dt / (BAL_TAU_S + dt)
        lp = self._lp
        for i in range(len(x)):
            lp[i] += a * (x[i] - lp[i])
        if t_us < self._next_us:
            return
        self._next_us = t_us + BAL_PERIOD_US
        if t_us - self._start_us < RESTART_HOLD_S * 1e6:
            return            # the low-passes' start (actuator.RESTART_HOLD_S)
        # the derivative of a first-order low-passed rate is (x - x_lp) / tau, exactly
        pd = (x[0] - lp[0]) / BAL_TAU_S
        rd = (x[2] - lp[2]) / BAL_TAU_S
        za, zr = self.model.deflections(lp[4], lp[0], lp[1], lp[2], pd, rd, lp[3], lp[8])
        phi = np.array((1.0, lp[7]))
        self._k += 1
        k_test = self._k >= TEST_DIV
        if k_test:
            self._k = 0
        # not learnt on the first FIT_WARMUP_S of flight (the launch and the climb-out at
        # full throttle: not quasi-steady, and one throttle only), as the elevator's balance
        # (the residual's variance is learnt from the start: with the floor alone, moderate
        # turbulence in the climb-out read 1.4 times the threshold 7 s after the launch)
        learn = (None if self.frozen or self.suspended
                 else t_us - self._t0_us >= FIT_WARMUP_S * 1e6)
        self.axes["aileron"].step(t_us, phi, za, lp[5], learn, k_test)
        self.axes["rudder"].step(t_us, phi, zr, lp[6], learn, k_test)

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
        recent = None if self._t_us is None else self._t_us - int(IDENT_WIN_S * 1e6)
        return identify_hist(ax.hist, self._fault_us, stuck, recent)
