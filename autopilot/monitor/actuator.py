"""Actuator fault detection and identification for the fixed-wing elevator (seed ch. 8
sec. 2.2.3, eqs 2.18-2.24, and the Q adaptation of sec. 2.3.2, eqs 2.35-2.40).

The seed's equations lost their subscripts in extraction; they are rebuilt here from
Hajiyev & Caliskan (2003), "Fault Diagnosis and Reconfiguration in Flight Control
Systems", ch. 7, and the two-stage Kalman filter of Friedland (1969) / Keller & Darouach
(1997) that the seed's "adaptive TSKF" builds on. The design model (2.18)::

    x_k+1 = A x_k + B u_k + E_k gamma_k + w_k^x
    gamma_k+1 = gamma_k + w_k^gamma
    y_k+1 = C x_k+1 + v_k+1

with the fault vector entering the actuators. For one surface the two fault types of
(2.20)-(2.24) are one affine map of the command::

    delta_act = k delta_cmd + s
    no fault: k = 1, s = 0                                   (2.22)
    loss of effectiveness: k = 1 - loss, s = 0               (2.23)
    stuck at beta: k = 0, s = beta                           (2.24)

Two stages, as the TSKF: the first is the bias-free model of the pitch axis, the second
estimates the fault parameters gamma = [k, s] from the first one's residual.

Stage 1, the pitch moment equation, learnt on line while no fault is suspected. With q
the pitch rate (bias-corrected gyro), V the airspeed and alpha the angle of attack
(from the navigation solution: the air-relative velocity ``R^T (v - w)`` in body axes)::

    q_dot / V^2 = theta_0 + theta_a alpha + theta_q q / V + theta_d delta      (*)

(the moment coefficients of the linearised short-period model times dynamic pressure
over inertia; V^2 carries the dynamic pressure at the near-constant density of a
mission). ``theta`` by recursive least squares with exponential forgetting
(FDI_ACT_FORGET). q_dot is the difference of a low-passed q; every regressor goes
through the same low-pass, so the filter's lag cancels. The aircraft has no actuator
lag model here (JSBSim's aerosonde has none).

Stage 2, the apparent deflection: (*) solved for delta with the learnt theta,

    z = (q_dot / V^2 - theta_0 - theta_a alpha - theta_q q / V) / theta_d   = delta_act + v

and the fault parameters by a Kalman filter over the random-walk state gamma = [k, s]
with the measurement ``z = [delta_cmd, 1] gamma + v`` (R = the healthy residual
variance, learnt as an exponentially weighted mean). Detection: the normalised
residual of the no-fault hypothesis, ``(z - delta_cmd) / sigma``, through the window
chi-square test of :mod:`.stats` (2.12-2.15), decimated to 10 Hz.

Q adaptation (2.35-2.40) on a detected actuator fault: the second stage's covariance is
predicted with a fading factor, ``P = P + Lambda Q``, where, with the window mean of the
squared innovations ``C = 1/M sum e_j^2`` (2.35) and the scalar measurement,

    lambda = max(1, (C - H P H^T - R) / (H Q H^T))                           (2.36-2.39)

so the parameters move as fast as the innovations demand, and back to the optimal
filter (lambda = 1) when the fault has been learnt. Identification: ``k`` below
FDI_ACT_STUCK -> stuck at ``s``; otherwise loss of effectiveness ``k``.

Identification (what ``identified()`` reports): the moment balance, not stage 2.
Stage 1 above is learnt in closed loop, where the pitch loop makes the elevator a
function of q and alpha: its coefficients are not those of the aircraft (measured, seed
1: the damping term comes out positive, theta_d drifts 0.010 -> 0.005 over 40 s of
healthy flight) and during the 2-6 s before a detection the recursion absorbs the fault
(theta_d -> 1e-4), so the stage-2 estimates of [k, s] diverged (k 0.6-3 for a stuck
surface, 45 for a 50 % loss). The identification therefore uses the quasi-steady pitch
moment balance, q_dot ~ 0 in (*) plus the thrust moment, solved for the deflection::

    delta = c_0 + c_a alpha + c_q q / V + c_t throttle / V^2                  (**)

(c_0 = -Cm_0 / Cm_d, c_a = -Cm_a / Cm_d, c_q = -Cm_q cbar / (2 Cm_d), c_t the thrust
moment over dynamic pressure), learnt by least squares in healthy flight on the same
low-passed signals (time constant BAL_TAU_S = 1 s, so the lag cancels) with the
*commanded* deflection as the dependent variable (healthy: actual = commanded), on
samples FIT_DELAY_S old, so that the fault is never in the fit when it is detected, and
not on the first FIT_WARMUP_S of flight (with the take-off and climb-out in the fit the
stuck position came out 0.12 instead of 0.17 rad, measured).
After a detection (**) with the frozen coefficients gives the deflection the aircraft
is actually flying with, z; the two hypotheses of (2.22)-(2.24) are fitted over the
window since the detection (from 1 s before it):

    loss of effectiveness: z = k delta_cmd       k = sum z delta_cmd / sum delta_cmd^2
    stuck:                 z = s                 s = mean of z over the last second

A stuck surface leaves the command free to wander: the loop winds it up (usually into
saturation, often against the side the surface is stuck on), so k outside
[K_MIN, K_MAX] or a command saturated most of the window -> stuck; otherwise loss of
effectiveness. (A stuck surface whose command happens to stay proportional to it is
not distinguishable from a loss of effectiveness without excitation; an elevator doublet
would tell them apart.) Measured, seed 1, default mission: stuck at 0.17 rad (0.05 above
trim) -> stuck, 0.178 rad 10 s after the onset; 50 % loss -> effectiveness 0.46.

Sensor vs actuator (the RAKF's discrimination, 2.44-2.45): the navigation filter is
driven by the IMU, not by the control inputs: its gain has no control distribution
matrix to be sensitive to (the Doyle-Stein condition holds trivially, Bs = 0), so an
actuator fault leaves its innovations white while a sensor fault does not. An elevator
residual over its threshold while the navigation innovations are quiet is an actuator
fault; with a sensor fault running, the stage-1 model's inputs are suspect and the
actuator test is held.

Limits: the model (*) holds in coordinated flight at moderate alpha; the RLS needs the
excitation that turbulence and the pitch loop give (light turbulence is enough); the
estimates of a stuck surface are those of (*) about the airspeed it was learnt at.
"""
from __future__ import annotations

import math

import numpy as np

from .stats import WindowChi2

MAX_DEFLECTION_RAD = 0.35      # elevator deflection at a normalised command of 1 [rad]
BAL_TAU_S = 1.0                 # low-pass of the moment-balance signals [s]
BAL_PERIOD_US = 100_000         # moment-balance samples every 0.1 s [us]
FIT_DELAY_S = 10.0              # the balance is fitted on samples this old [s]
FIT_WARMUP_S = 30.0             # ... and not on the first seconds of flight (take-off,
                                # climb-out at full throttle: not quasi-steady) [s]
K_MIN, K_MAX = 0.05, 1.2        # a loss-of-effectiveness k outside this: stuck
SAT_SHARE = 0.5                 # command saturated this share of the window: stuck


class MomentBalance:
    """The quasi-steady pitch-moment balance (**) of the module docstring: recursive
    least squares of the commanded deflection on [1, alpha, q / V, throttle / V^2],
    fitted on samples FIT_DELAY_S old while ``frozen`` is false. The regressors are
    scaled by V_REF (``q V_REF / V``, ``throttle (V_REF / V)^2``) so that all are of
    order one and the nearly uninformative prior (P = 1e4 I) shrinks none of them."""

    N = 4
    V_REF = 25.0                      # [m/s]

    def __init__(self):
        self.c = np.zeros(self.N)
        self.P = np.eye(self.N) * 1e4
        self.n = 0
        self._lp = None
        self._t_us = None
        self._t0_us = None
        self._next_us = 0
        self._queue: list = []        # (t_us, phi, delta_cmd) waiting FIT_DELAY_S
        self.hist: list = []          # (t_us, z, delta_cmd) of the last 20 s
        self.frozen = False

    @property
    def ready(self) -> bool:
        return self.n >= 300          # 30 s of fitted samples

    def step(self, t_us: int, alpha: float, q: float, V: float, throttle: float, d_cmd: float) -> None:
        r = self.V_REF / V
        x = (1.0, alpha, q * r, throttle * r * r, d_cmd)
        if self._lp is None:
            self._lp, self._t_us = list(x), t_us
            if self._t0_us is None:
                self._t0_us = t_us
            return
        dt = (t_us - self._t_us) * 1e-6
        self._t_us = t_us
        if dt <= 0.0:
            return
        a = dt / (BAL_TAU_S + dt)
        lp = self._lp
        for i in range(5):
            lp[i] += a * (x[i] - lp[i])
        if t_us < self._next_us:
            return
        self._next_us = t_us + BAL_PERIOD_US
        phi = np.array(lp[:4])
        d = lp[4]
        if not self.frozen and t_us - self._t0_us >= FIT_WARMUP_S * 1e6:
            q_ = self._queue
            q_.append((t_us, phi, d))
            while q_ and t_us - q_[0][0] >= FIT_DELAY_S * 1e6:
                _, ph, dd = q_.pop(0)
                P = self.P
                Pp = P @ ph
                g = Pp / (1.0 + ph @ Pp)
                self.c = self.c + g * (dd - ph @ self.c)
                self.P = P - np.outer(g, Pp)
                self.n += 1
        if self.ready:
            h = self.hist
            h.append((t_us, float(phi @ self.c), d))
            while h and t_us - h[0][0] > 20e6:
                h.pop(0)

    def freeze(self) -> None:
        """At a detection: the fit stops, and the samples not yet fitted (which may
        hold the fault) are dropped."""
        self.frozen = True
        self._queue.clear()

    def identify(self, since_us: int) -> dict | None:
        """The two hypotheses (2.23, 2.24) over the samples since ``since_us``."""
        h = [r for r in self.hist if r[0] >= since_us]
        if len(h) < 10:
            return None
        z = np.array([r[1] for r in h])
        d = np.array([r[2] for r in h])
        dd = float(d @ d)
        k = float(z @ d) / dd if dd > 0.0 else 0.0
        sat = float(np.mean(np.abs(d) >= 0.98 * MAX_DEFLECTION_RAD))
        s_now = float(np.mean(z[-10:]))
        if k < K_MIN or k > K_MAX or sat >= SAT_SHARE:
            return {"stuck_rad": round(s_now, 4)}
        return {"effectiveness": round(k, 3)}


class ElevatorIdentifier:
    """Two-stage elevator fault detection and identification (module docstring).

    ``step(t_us, nav, elevator_cmd, flying)`` once per vehicle step with the navigation
    state and the normalised elevator command (+1 nose up). Outputs: ``ratio`` (window
    statistic / threshold), ``k``, ``s_rad``, ``lam`` (fading factor), ``frozen``.
    """

    def __init__(self, alpha: float = 1e-4, window: int = 10, forget: float = 0.9995,
                 q_gamma: float = 1e-7, warmup_s: float = 30.0, lp_tau_s: float = 0.05):
        self.win = WindowChi2(1, window, alpha)
        self.forget = forget
        self.q_gamma = q_gamma
        self.warmup_us = int(warmup_s * 1e6)
        self.lp_tau = lp_tau_s
        self.reset()

    def reset(self) -> None:
        self.theta = np.zeros(4)
        self.P_theta = np.eye(4) * 1e3
        self._lp = None               # low-passed [q, 1, alpha, q/V, delta]
        self._q_prev = None
        self._t_prev = None
        self._start_us = None
        self.r_var = None             # healthy residual variance of z [rad^2]
        self.gamma = np.array([1.0, 0.0])
        self.P_gamma = np.eye(2) * 1e-4
        self._e2 = []                 # squared innovations of stage 2 (window)
        self.frozen = False           # stage 1 frozen (fault suspected)
        self.adapt = False            # Q adaptation on
        self.ratio = 0.0
        self.lam = 1.0
        self._k = 0
        self.ready = False
        self.balance = MomentBalance()
        self._fault_us = None

    @property
    def k(self) -> float:
        return float(self.gamma[0])

    @property
    def s_rad(self) -> float:
        return float(self.gamma[1])

    def freeze(self, t_us: int) -> None:
        """A fault is detected: stage 1 and the moment balance stop learning, the
        fault parameters adapt (Q adaptation) and identification starts."""
        self.frozen = self.adapt = True
        self.balance.freeze()
        self._fault_us = t_us - 1_000_000

    def step(self, t_us: int, nav, elevator_cmd: float, flying: bool, throttle: float = 0.0) -> None:
        v = nav.v_ned
        w = nav.wind_ned
        V = nav.airspeed_mps
        if not flying or V < 10.0:
            self._lp = None
            return
        # body-axis air velocity: R^T (v - w)
        qw, qx, qy, qz = (float(c) for c in nav.q_nb)
        ax, ay, az = float(v[0] - w[0]), float(v[1] - w[1]), float(v[2])
        # third column / first column of R(q) for the body x and z axes in NED
        r00 = 1 - 2 * (qy * qy + qz * qz)
        r10 = 2 * (qx * qy + qw * qz)
        r20 = 2 * (qx * qz - qw * qy)
        r02 = 2 * (qx * qz + qw * qy)
        r12 = 2 * (qy * qz - qw * qx)
        r22 = 1 - 2 * (qx * qx + qy * qy)
        u = r00 * ax + r10 * ay + r20 * az
        wb = r02 * ax + r12 * ay + r22 * az
        alpha = math.atan2(wb, u)
        q = float(nav.omega_b[1])
        d = elevator_cmd * MAX_DEFLECTION_RAD
        self.balance.step(t_us, alpha, q, V, throttle, d)
        x = (q, 1.0, alpha, q / V, d)
        if self._lp is None or self._t_prev is None:
            self._lp = list(x)
            self._t_prev = t_us
            self._start_us = t_us if self._start_us is None else self._start_us
            self._q_prev = None
            return
        dt = (t_us - self._t_prev) * 1e-6
        self._t_prev = t_us
        if dt <= 0.0:
            return
        a = dt / (self.lp_tau + dt)
        lp = self._lp
        for i in range(5):
            lp[i] += a * (x[i] - lp[i])
        qf = lp[0]
        if self._q_prev is None:
            self._q_prev = qf
            return
        qdot = (qf - self._q_prev) / dt
        self._q_prev = qf
        y = qdot / (V * V)
        phi = np.array(lp[1:5])
        # ---- stage 1: q_dot / V^2 = theta^T phi  (RLS, forgetting) ----------------
        th = self.theta
        if not self.frozen:
            P = self.P_theta
            Pphi = P @ phi
            g = Pphi / (self.forget + phi @ Pphi)
            th += g * (y - phi @ th)
            self.P_theta = (P - np.outer(g, Pphi)) / self.forget
        if t_us - self._start_us < self.warmup_us or abs(th[3]) < 1e-6:
            return
        # ---- stage 2: apparent deflection z = delta_act + v --------------------------
        dcmd = lp[4]
        z = (y - th[0] - th[1] * lp[2] - th[2] * lp[3]) / th[3]
        r = z - dcmd                          # residual of the no-fault hypothesis
        if not self.frozen:
            # healthy residual variance (exponentially weighted, ~10 s)
            self.r_var = r * r if self.r_var is None else self.r_var + 0.001 * (r * r - self.r_var)
        if self.r_var is None or self.r_var <= 0.0:
            return
        self.ready = True
        R = self.r_var
        # detection: window chi-square of the normalised residual at 10 Hz  (2.12-2.15)
        self._k += 1
        if self._k >= 10:
            self._k = 0
            self.win.push([r / math.sqrt(R)])
            self.ratio = self.win.ratio_det
        # gamma = [k, s]: P = P + Lambda Q (2.40); H = [delta_cmd, 1]
        H = np.array([dcmd, 1.0])
        Pg = self.P_gamma
        e = z - H @ self.gamma
        e2 = self._e2
        e2.append(e * e)
        if len(e2) > 100:
            e2.pop(0)
        lam = 1.0
        if self.adapt and len(e2) >= 20:
            # lambda = max(1, (C - H P H^T - R) / (H Q H^T))   (2.35-2.39, scalar)
            C = sum(e2) / len(e2)
            hqh = self.q_gamma * (dcmd * dcmd + 1.0)
            lam = max(1.0, (C - float(H @ Pg @ H) - R) / hqh)
            lam = min(lam, 1e6)
        self.lam = lam
        Pg = Pg + np.eye(2) * (self.q_gamma * lam)
        S = float(H @ Pg @ H) + R
        K = Pg @ H / S
        self.gamma = self.gamma + K * e
        A = np.eye(2) - np.outer(K, H)
        self.P_gamma = A @ Pg @ A.T + np.outer(K, K) * R

    def identified(self, stuck_below: float = 0.25) -> dict:
        """The fault parameters as the summary reports them: from the moment balance
        (module docstring) once a fault is detected and the balance is fitted; the
        stage-2 [k, s] otherwise."""
        if self._fault_us is not None and self.balance.ready:
            r = self.balance.identify(self._fault_us)
            if r is not None:
                return r
        if self.k < stuck_below:
            return {"stuck_rad": round(self.s_rad + self.k * 0.0, 4), "k": round(self.k, 3)}
        return {"effectiveness": round(self.k, 3), "s_rad": round(self.s_rad, 4)}
