"""Quadrotor motor fault detection, isolation and identification (course text ch. 8
sec. 2.2.3, the two-stage filter of eqs 2.18-2.24, with the Q adaptation of sec. 2.3.2,
eqs 2.35-2.40; rebuilt from Hajiyev & Caliskan 2003, ch. 7, and Friedland 1969 /
Keller & Darouach 1997).

The fault vector is the effectiveness of the four rotors, gamma = [k_1 .. k_4] (k = 1
healthy, 0.7 = thrust reduced to 70 %, eq 2.23's loss of effectiveness). The design
model is the rotor forces and moments of the course text's quadrotor (eqs 3.23-3.26,
the "+" layout of control/mixer.py) against what the IMU shows:

1. Stage 1, no fault: gamma = c (1, 1, 1, 1), c learnt in healthy flight; the three
   moment residuals, normalised by their learnt variance plus a relative model error,
   go into the window chi-square test (eqs 2.12-2.15) and detect.
2. Stage 2: a Kalman filter over gamma on the residual, faded (eqs 2.36-2.39) after a
   detection; the rotor farthest below the others is isolated and identified.

Reactions: the identified effectiveness goes to the mixer (FDI_MOT_COMP), a rotor below
FDI_MOT_MIN of its thrust makes the vehicle land (FDI_MOT_FS). An actuator fault leaves
the navigation innovations white (the Doyle-Stein condition of eqs 2.44-2.45 holds
trivially: the filter is driven by the IMU, not by the controls).

The model, the filtering and each choice with its reason: docs/monitor.md, "The
quadrotor's rotors". How well it works: docs/status.md, "Faults and the monitor".
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from autopilot.control.mixer import K_N, rotor_thrust
from autopilot.control.multirotor import Y_N, Y_W
from autopilot.jit import kernel, preload
from autopilot.params import Param

from .monitor import SEV_CRITICAL, SEV_NOTICE, SEV_WARNING, Episode
from .stats import WindowChi2, chi2_threshold, family_alpha, stage2_update

LP_TAU_S = 0.1            # low-pass of every balance signal [s]
KF_PERIOD_S = 0.1         # stage 2 (Kalman filter) period [s]
TEST_PERIOD_S = 0.2       # window chi-square sample period [s]
VAR_TAU_S = 20.0          # healthy residual variance, exponential weighting [s]
SCALE_TAU_S = 10.0        # common thrust scale c, exponential weighting [s]
Q_RATE = 0.005            # gamma random walk [1/sqrt(s)]
IDENT_MIN_S = 1.0         # identification reported this long after isolation [s]
MODEL_REL = 0.15          # relative error of the modelled moments (thrust curve slope)
MIN_THRUST_SHARE = 0.8    # balance used while the modelled thrust is this share of the weight
# MotorMonitor._s, the per-step part's state (motor_lowpass): the modelled rotor thrusts
# (lagged), the low-passed balance signals (T1..T4, f_z, p, q, r, qr, pr, pq), whether
# they have started, the seconds of flight, the steps since stage 2 ran; then its
# constants: the rotors' lag, the low-pass factor, the step, the steps between stage 2;
# then stage 1's (balance_step): the mass, the moments of inertia, the arm, the reaction
# moment coefficient, the weights of the scale c and of the residual variances
S_T, S_LP, S_HAS_LP, S_FLIGHT, S_K = 0, 4, 15, 16, 17
S_LAG, S_B, S_DT, S_KF_N = 18, 19, 20, 21
S_M, S_IXX, S_IYY, S_IZZ, S_L, S_KM, S_CW, S_VW = range(22, 30)
S_N = 30

MOTOR_PARAMS = (
    Param("FDI_MOT_ENABLE", 1.0, 0.0, 1.0, "bool", "quadrotor motor fault monitor", is_int=True,
          at_start=True),
    Param("FDI_MOT_FS", 1.0, 0.0, 1.0, "", "motor fault failsafe: 0 report only, 1 LAND", is_int=True),
    Param("FDI_MOT_COMP", 1.0, 0.0, 1.0, "bool", "compensate an identified weak rotor in the mixer",
          is_int=True),
    Param("FDI_MOT_MIN", 0.9, 0.1, 1.0, "", "a rotor identified below this share of its thrust "
          "triggers the motor fault failsafe"),
    Param("FDI_MOT_HAGL", 1.5, 0.0, 20.0, "m", "motor test runs only above this height over home "
          "(ground contact, ground effect)"),
    Param("FDI_MOT_WARM", 10.0, 1.0, 120.0, "s", "seconds of flight that teach the healthy "
          "residual before the motor test runs"),
)



class MotorMonitor:
    """``update(t_us, flying, motors, f_z, y, k)`` on the steps it is due (``due()``).

    ``motors`` are the commands the rotors flew with since the previous step (the
    previous step's output), ``f_z`` the IMU's specific force (body z) less the filter's
    bias estimate, ``y`` the navigation output the loops read (control.multirotor.Y_*:
    its rates, Y_W, are the IMU's less the filter's gyro bias), ``k`` the mixer's
    constants (``QuadPlusMixer.k``), whose thrust curve (``rotor_thrust``) gives the
    modelled thrust of a command. Outputs:
    ``episodes`` (the monitor's :class:`~.monitor.Episode` records, kind "actuator"),
    ``events`` (t_s, MAV_SEVERITY, text), ``failsafe`` ("LAND" or None), ``gamma``,
    ``peak`` (largest detection statistic / threshold while healthy)."""

    def __init__(self, params, dt_s: float, alpha: float = 1e-4, p_fa: float = 0.01,
                 window: int = 10, clear_s: float = 2.0, div: int = 1):
        g = lambda n, d: float(params[n]) if params is not None and n in params else d  # noqa: E731
        self.enabled = g("FDI_MOT_ENABLE", 1.0) >= 1.0
        self.fs_action = int(g("FDI_MOT_FS", 1.0))
        self.k_min = g("FDI_MOT_MIN", 0.9)
        self.comp = g("FDI_MOT_COMP", 1.0) >= 1.0
        self.warm_s = g("FDI_MOT_WARM", 10.0)
        self.alpha = g("FDI_ALPHA", alpha)
        p_fa = g("FDI_PFA", p_fa)
        window = int(g("FDI_WIN", window))
        self.clear_s = g("FDI_CLR_T", clear_s)
        # the balance runs every ``div``-th vehicle step (``due()``), dt_s apart each
        self.div = max(1, int(div))
        # due(), called once per vehicle step: True on the steps the monitor runs (a C
        # iterator's step, not a Python call at every vehicle step)
        self.due = itertools.cycle((False,) * (self.div - 1) + (self.enabled,)).__next__
        dt_s = self._dt_s = dt_s * self.div
        self._s = np.zeros(S_N)
        self._model(g)
        self._test_n = max(1, int(round(TEST_PERIOD_S / KF_PERIOD_S)))
        # the window test runs every TEST_PERIOD_S of a whole flight: level per test from
        # the family-wise false-alarm probability per hour (stats.family_alpha)
        self.win = WindowChi2(3, window, self.alpha, family_alpha(p_fa, 3600.0 / TEST_PERIOD_S))
        self.thr_iso = chi2_threshold(self.alpha, 1)
        self.reset()
        # (autopilot.jit.preload: the stage-2 step's kernel loaded now, not at the first balance)
        preload(stage2_update, self.gamma, self.P, np.eye(4), np.zeros(4), np.ones(4), 0.0)
        preload(balance_step, self._s.copy(), np.zeros(Y_N), 1.0, False, np.ones(4), np.ones(4),
                True, True)
        preload(isolation, np.ones(4), np.eye(4), 1.0)
        preload(motor_lowpass, self._s.copy(), np.zeros(K_N), 0.5, 0.5, 0.5, 0.5, -9.8,
                np.zeros(Y_N), True)

    def _model(self, g) -> None:
        """The airframe's model and the filters' constants into the balance's array
        (``g(name, default)``: a parameter's value)."""
        dt_s = self._dt_s
        self._s[S_LAG:] = (1.0 - math.exp(-dt_s / g("QD_TAU", 0.055)),
                           1.0 - math.exp(-dt_s / LP_TAU_S), dt_s,
                           max(1, int(round(KF_PERIOD_S / dt_s))),
                           g("QD_MASS", 1.4), g("QD_IXX", 0.019), g("QD_IYY", 0.019),
                           g("QD_IZZ", 0.0252), g("QD_ARM", 0.2335), g("QD_KM", 0.0197),
                           1.0 - math.exp(-KF_PERIOD_S / SCALE_TAU_S),
                           1.0 - math.exp(-KF_PERIOD_S / VAR_TAU_S))

    def configure(self, params) -> None:
        """Re-read, after a parameter change in flight (the vehicle's ``_param_changed``),
        what takes effect at once: the failsafe, compensation, warm-up and clearance
        settings and the airframe's model. Its window, levels and whether it runs at all
        (FDI_WIN, FDI_ALPHA, FDI_PFA, FDI_ENABLE, FDI_MOT_ENABLE) are the start's."""
        g = lambda n, d: float(params[n]) if n in params else d  # noqa: E731
        self.fs_action = int(g("FDI_MOT_FS", 1.0))
        self.k_min = g("FDI_MOT_MIN", 0.9)
        self.comp = g("FDI_MOT_COMP", 1.0) >= 1.0
        self.warm_s = g("FDI_MOT_WARM", 10.0)
        self.clear_s = g("FDI_CLR_T", self.clear_s)
        self._model(g)

    def reset(self) -> None:
        self._s[:S_LAG] = 0.0                      # (motor_lowpass's state, S_*)
        self._kt = 0
        self.c = 1.0                               # common thrust scale (stage 1)
        self._c_ok = False
        self.var = np.ones(4)                      # healthy residual variances
        self._var_n = 0
        self.gamma = np.ones(4)                    # stage 2 state: rotor effectiveness
        self.P = np.eye(4) * 0.01
        self._e_ring: list[np.ndarray] = []        # stage-2 innovations for (2.35)
        self.lam = 1.0
        self.ratio = 0.0                           # window statistic / threshold
        self.iso_ratio = 0.0
        self.detected = False
        self.isolated: str | None = None
        self.episodes: list = []
        self.events: list[tuple[float, int, str]] = []
        self.failsafe: str | None = None
        self.accommodation: tuple[float, ...] | None = None   # rotor effectiveness for the mixer
        self._quiet_s: float | None = None
        self._ident_next_s = 0.0
        self._fs_done = False
        self.peak = 0.0

    @property
    def peaks(self) -> dict[str, float]:
        """Largest detection statistic / threshold while no fault was detected."""
        return {"motors": self.peak}

    # ------------------------------------------------------------------- step ---
    def update(self, t_us: int, flying: bool, motors, f_z, y, k) -> bool:
        """True on the steps its stage ran: the only ones that change its events,
        ``accommodation`` and ``failsafe``."""
        if not self.enabled:
            return False
        if motor_lowpass(self._s, k, *motors, f_z, y, flying):
            self._stage(t_us, y)
            return True
        return False

    def _stage(self, t_us: int, y) -> None:
        """Stages 1 and 2 on the low-passed signals, the rates of the navigation output
        ``y`` (Y_W) with them."""
        healthy = not self.detected
        # stage 1: common scale and the no-fault residual, its variances, stage 2's
        # innovation (nothing while the rotors carry too little of the weight)
        ran, self.c, H, z, r, e = balance_step(self._s, y, self.c, self._c_ok, self.gamma,
                                                self.var, healthy, self._var_n == 0)
        if not ran:
            return
        if healthy:
            self._c_ok = True
            self._var_n += 1
        t_s = t_us * 1e-6
        kf = KF_PERIOD_S
        # stage 2: Kalman filter over gamma, measurement y / c = H gamma, R = diag(r)
        q = Q_RATE * Q_RATE * kf                  # Q = q I
        lam = 1.0
        if self.detected and self._e_ring:
            # fading factor (2.35-2.39) from the window of innovations, on innovations
            # whitened by R^-1/2 so that the rows (newtons of thrust and of moment / arm)
            # weigh alike: tr(W C W) = sum_i C_ii / R_ii
            w = 1.0 / r
            C = sum(v * v for v in self._e_ring) / len(self._e_ring)      # diag of (2.35)
            hph = np.einsum("ij,jk,ik->i", H, self.P, H)
            hqh = float(np.einsum("ij,jk,ik->i", H, np.eye(4) * q, H) @ w)
            if hqh > 0.0:
                lam = max(1.0, (float(C @ w) - float(hph @ w) - 4.0) / hqh)
        self.lam = lam
        self.gamma, self.P = stage2_update(self.gamma, self.P, H, e, r, lam * q)   # (2.40), Joseph
        self._e_ring.append(e)
        if len(self._e_ring) > self.win.M:
            self._e_ring.pop(0)
        # detection: window chi-square of the normalised no-fault residual
        self._kt += 1
        if self._kt >= self._test_n:
            self._kt = 0
            if self._s[S_FLIGHT] >= self.warm_s:
                self.win.push(z.tolist())
                self.ratio = self.win.ratio_det
                if not self.detected:
                    self.peak = max(self.peak, self.ratio)
        self._decide(t_s)

    # --------------------------------------------------------------- decision ---
    def _decide(self, t_s: float) -> None:
        # each rotor against the mean of the other three (the common-mode model error,
        # which moves them all, cancels), in its own standard deviations
        j, self.iso_ratio, weak = isolation(self.gamma, self.P, self.thr_iso)
        if not self.detected:
            if self.ratio > 1.0:
                self.detected = True
                self._quiet_s = None
                self.episodes.append(Episode(t_s, "motors", kind="actuator", ident_log=[]))
                self.events.append((t_s, SEV_WARNING, "FDI: fault detected on the motors"))
            return
        ep = self.episodes[-1]
        if self.isolated is None and self.iso_ratio > 1.0 and weak:
            self.isolated = f"motor_{j + 1}"
            ep.isolated, ep.isolated_s = self.isolated, t_s
            ep.isolated_all = [self.isolated]
            self._ident_next_s = t_s + IDENT_MIN_S
            self.events.append((t_s, SEV_CRITICAL, f"FDI: {self.isolated} fault isolated"))
        if self.isolated is not None and t_s >= self._ident_next_s:
            self._ident_next_s = t_s + 1.0
            i = int(self.isolated[-1]) - 1
            g = self.gamma
            k = float(g[i]) * 3.0 / (float(g.sum()) - float(g[i]))
            ep.identified = {"effectiveness": round(k, 3)}
            ep.ident_log.append((t_s, dict(ep.identified)))
            if self.comp:
                acc = [1.0, 1.0, 1.0, 1.0]
                acc[i] = min(k, 1.0)
                if self.accommodation is None:
                    self.events.append((t_s, SEV_NOTICE, f"FDI: {self.isolated} compensated "
                                        f"(thrust {100.0 * k:.0f} %)"))
                self.accommodation = tuple(acc)
            if k < self.k_min and self.fs_action == 1 and self.failsafe is None \
                    and not self._fs_done:
                self._fs_done = True
                self.failsafe = "LAND"
                self.events.append((t_s, SEV_CRITICAL, f"FDI: {self.isolated} thrust "
                                    f"{100.0 * k:.0f} %: failsafe LAND"))
        # clearance: the no-fault residual quiet for FDI_CLR_T and every rotor near 1
        quiet = self.ratio < 1.0 and self.iso_ratio < 1.0
        if quiet:
            if self._quiet_s is None:
                self._quiet_s = t_s
            elif t_s - self._quiet_s >= self.clear_s:
                ep.end_s = t_s
                self.detected = False
                self.isolated = None
                self.events.append((t_s, SEV_NOTICE, "FDI: motor fault cleared"))
                self.accommodation = None
        else:
            self._quiet_s = None


@kernel
def matvec4(H, v):
    """``H @ v`` for a 4 x 4 ``H`` as numpy sums it on this build (checked against numpy
    in the tests): each row's products of the even columns and of the odd ones, then
    the two."""
    out = np.empty(4)
    for i in range(4):
        out[i] = (H[i, 0] * v[0] + H[i, 2] * v[2]) + (H[i, 1] * v[1] + H[i, 3] * v[3])
    return out


@kernel
def balance_step(s, y, c, c_ok, gamma, var, learn, first):
    """Stage 1 of :meth:`MotorMonitor._stage` in one call, on the low-passed balance
    signals in ``s`` (S_LP: T_1..T_4, f_z, p, q, r, qr, pr, pq; the airframe's constants
    from S_M) and the rates of the navigation output ``y`` (Y_W), nothing while the
    modelled thrust sum T_i is under MIN_THRUST_SHARE of the weight (c m g once c is
    learnt):

        p' = (p - p_lp) / LP_TAU_S  (q', r' alike)
        y_b = (-m f_z, (I_xx p' + (I_zz - I_yy) q r) / l,
               (I_yy q' + (I_xx - I_zz) p r) / l, (I_zz r' + (I_yy - I_xx) p q) / k_M)
        H = ((T1, T2, T3, T4), (0, T2, 0, -T4), (-T1, 0, T3, 0), (T1, -T2, T3, -T4))
        c <- c + (-m f_z / sum T_i - c) w     (healthy: ``learn``; w = 1 the first time)

    then :func:`balance_residuals` on H 1 and H gamma (``var`` updated in place).
    Returns (ran, c, H, the moment rows of the no-fault residual over their standard
    deviations, R's diagonal, e)."""
    t1, t2, t3, t4 = s[S_LP], s[S_LP + 1], s[S_LP + 2], s[S_LP + 3]
    fz, pf, qf, rf = s[S_LP + 4], s[S_LP + 5], s[S_LP + 6], s[S_LP + 7]
    qr, pr, pq = s[S_LP + 8], s[S_LP + 9], s[S_LP + 10]
    m, ixx, iyy, izz, arm, km = s[S_M], s[S_IXX], s[S_IYY], s[S_IZZ], s[S_L], s[S_KM]
    tsum = t1 + t2 + t3 + t4
    if tsum < MIN_THRUST_SHARE * m * 9.80665 * (c if c_ok else 1.0):
        return False, c, np.empty((4, 4)), np.empty(3), np.empty(4), np.empty(4)
    inv = 1.0 / LP_TAU_S
    pd, qd, rd = (y[Y_W] - pf) * inv, (y[Y_W + 1] - qf) * inv, (y[Y_W + 2] - rf) * inv
    thrust = -m * fz
    yb = np.empty(4)
    yb[0] = thrust
    yb[1] = (ixx * pd + (izz - iyy) * qr) / arm
    yb[2] = (iyy * qd + (ixx - izz) * pr) / arm
    yb[3] = (izz * rd + (iyy - ixx) * pq) / km
    H = np.empty((4, 4))
    H[0, 0], H[0, 1], H[0, 2], H[0, 3] = t1, t2, t3, t4
    H[1, 0], H[1, 1], H[1, 2], H[1, 3] = 0.0, t2, 0.0, -t4
    H[2, 0], H[2, 1], H[2, 2], H[2, 3] = -t1, 0.0, t3, 0.0
    H[3, 0], H[3, 1], H[3, 2], H[3, 3] = t1, -t2, t3, -t4
    if learn:
        c += (thrust / tsum - c) * (s[S_CW] if c_ok else 1.0)
    r1, sd, r, e = balance_residuals(yb, matvec4(H, np.ones(4)), matvec4(H, gamma), c, var,
                                     learn, first, s[S_VW])
    return True, c, H, r1[1:] / sd[1:], r, e


@kernel
def isolation(gamma, P, thr):
    """Each rotor against the mean of the other three (:meth:`MotorMonitor._decide`), in
    its own standard deviations: dev_j = (g_j - o_j)^2 / (max(P_jj, 1e-12) 4/3) / thr
    with o_j = (sum g - g_j) / 3 (the sum in order, as numpy's of four). Returns (j, dev_j,
    g_j < o_j) for the largest dev_j (the first of equal ones; a NaN first one kept, as
    Python's max())."""
    total = ((gamma[0] + gamma[1]) + gamma[2]) + gamma[3]
    j, best, weak = 0, 0.0, False
    for i in range(4):
        gi = gamma[i]
        oi = (total - gi) / 3.0
        pii = P[i, i]
        dev = (gi - oi) * (gi - oi) / ((pii if not pii < 1e-12 else 1e-12) * (4.0 / 3.0)) / thr
        if i == 0 or dev > best:
            j, best, weak = i, dev, gi < oi
    return j, best, weak


@kernel
def balance_residuals(y, hsum, hg, c, var, learn, first, w):
    """Stage 1's no-fault residual and stage 2's innovation (:meth:`MotorMonitor._stage`)
    from the balance ``y``, ``hsum`` = H 1 and ``hg`` = H gamma:

        m1 = c H 1,   r1 = y - m1
        var <- var + (r1 r1 - var) w        (healthy: ``learn``; the first r1 r1 + 1e-6)
        R = diag(max(var, 1e-6) + (MODEL_REL m1)^2) / c^2   (the thrust row: var only)
        e = y / c - H gamma

    ``var`` is updated in place. Returns r1, the residual's standard deviations
    sqrt(c^2 R), R's diagonal and e (numpy's arrays operations, element by element)."""
    m1 = c * hsum
    r1 = y - m1
    if learn:
        if first:
            var[:] = r1 * r1 + 1e-6
        else:
            var += (r1 * r1 - var) * w
    rel = MODEL_REL * m1
    rel[0] = 0.0
    v = np.maximum(var, 1e-6) + rel * rel
    return r1, np.sqrt(v), v / (c * c), y / c - hg


@kernel
def motor_lowpass(s, k, m1, m2, m3, m4, fz, y, flying):
    """The monitor's per-step part (:meth:`MotorMonitor.update`) on its state ``s``
    (S_*): the modelled thrusts of the commands m1..m4 flown (the mixer's thrust curve on
    its constants ``k``) through the rotors' lag; in flight the low-pass of every balance
    signal (T1..T4, f_z, p, q, r, qr, pr, pq; the rates from the navigation output ``y``),
    started from the first values and stopped on the ground (the seconds of flight with
    it). True on the steps stage 2 is due (every KF_PERIOD_S of flight)."""
    a = s[S_LAG]
    t1 = s[S_T] + (rotor_thrust(k, m1) - s[S_T]) * a
    t2 = s[S_T + 1] + (rotor_thrust(k, m2) - s[S_T + 1]) * a
    t3 = s[S_T + 2] + (rotor_thrust(k, m3) - s[S_T + 2]) * a
    t4 = s[S_T + 3] + (rotor_thrust(k, m4) - s[S_T + 3]) * a
    s[S_T], s[S_T + 1], s[S_T + 2], s[S_T + 3] = t1, t2, t3, t4
    if not flying:
        s[S_HAS_LP] = 0.0
        s[S_FLIGHT] = 0.0
        return False
    p, q, r = y[Y_W], y[Y_W + 1], y[Y_W + 2]
    signals = (t1, t2, t3, t4, fz, p, q, r, q * r, p * r, p * q)
    if s[S_HAS_LP] == 0.0:
        for i in range(11):
            s[S_LP + i] = signals[i]
        s[S_HAS_LP] = 1.0
        return False
    b = s[S_B]
    for i in range(11):
        s[S_LP + i] += (signals[i] - s[S_LP + i]) * b
    s[S_FLIGHT] += s[S_DT]
    s[S_K] += 1.0
    if s[S_K] < s[S_KF_N]:
        return False
    s[S_K] = 0.0
    return True
