"""Actuator fault detection and identification for the fixed-wing elevator (course text
ch. 8 sec. 2.2.3, eqs 2.18-2.24, with the Q adaptation of sec. 2.3.2, eqs 2.35-2.40;
rebuilt from Hajiyev & Caliskan 2003, ch. 7, and the two-stage Kalman filter of
Friedland 1969 / Keller & Darouach 1997).

For one surface both fault types are one affine map of the command,
``delta_act = k delta_cmd + s`` (no fault k = 1, s = 0; loss of effectiveness k < 1;
stuck k = 0, s = beta: eqs 2.22-2.24). Two stages, as the TSKF:

1. :class:`MomentBalance`: the quasi-steady pitch-moment balance, learnt by recursive
   least squares in healthy flight, gives z, the deflection the aircraft is flying with,
   from the measured load factor, the airspeed and the throttle. Its normalised residual
   ``z - delta_cmd`` goes into the window chi-square test (eqs 2.12-2.15) and detects.
2. :class:`ElevatorIdentifier`: a Kalman filter over gamma = [k, s] with the measurement
   ``z = [delta_cmd, 1] gamma + v``, its covariance faded (eqs 2.36-2.39) on a detected
   fault; the identification chooses stuck or weakened by the two hypotheses' residuals.

The balance's regressors, the filtering, the stuck/weakened decision and the limits,
each with its reason: docs/monitor.md, "Elevator identification". How well it works:
docs/status.md, "Faults and the monitor".
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.jit import kernel, preload

from .airframe import gyro_elevator
from .stats import WindowChi2, blas_dot, blas_matvec, family_alpha, stage2_update

MAX_DEFLECTION_RAD = 0.35      # elevator deflection at a normalised command of 1 [rad]
BAL_TAU_S = 1.0                 # low-pass of the moment-balance signals [s]
BAL_PERIOD_US = 100_000         # moment-balance samples every 0.1 s [us]
FIT_DELAY_S = 10.0              # the balance is fitted on samples this old [s]
FIT_WARMUP_S = 30.0             # ... and not on the first seconds of flight (take-off,
                                # climb-out at full throttle: not quasi-steady) [s]
K_MIN, K_MAX = 0.05, 1.2        # a loss-of-effectiveness k outside this: stuck
SAT_SHARE = 0.5                 # command saturated this share of the window: stuck
RSS_STUCK = 0.05                # stuck fit's residual under this share of the other's: stuck
SETTLE_S = 3.0                  # the stuck-or-weakened test also on the samples this long
                                # after the window's start (1 s before the detection) [s]
IDENT_WIN_S = 4.0               # identification over the last seconds of the fault [s]
TEST_DIV = 5                    # detection test on every 5th balance sample (2 Hz)
RES_TAU_S = 60.0                # healthy residual variance, exponential weighting [s]
RES_WARMUP_N = 200              # residual samples (20 s) learnt before the test runs
PRIOR_SD = (0.02, 0.03, 0.05)   # trust in the model's c_0, c_L, c_t [rad]
BAL_NOISE_RAD = 0.1             # the noise each 10 Hz sample of the fit is weighed with against
                                # the prior [rad]: the low-passed samples are correlated and the
                                # model's own errors systematic (with 0.01 the fit chased a
                                # climb-out and read a steep turn as an elevator fault)
V_REF = 25.0                    # the moment balance's reference airspeed [m/s]
RESTART_GAP_S = 0.25            # signals missing this long (the monitor paused: a go-around's
                                # climb, the flare): the low-passes start again [s]
RESTART_HOLD_S = 3.0            # ... and nothing is tested or learnt for 3 BAL_TAU_S after a
                                # (re)start: the derivative of a low-passed rate reads zero at
                                # its start, whatever the rate's real derivative, and the error
                                # decays as exp(-t / BAL_TAU_S) (resuming after a go-around's
                                # climb in a turn: the aileron read 0.22 rad off, the elevator
                                # 0.18, false alarms)
RES_FLOOR_RAD = 0.01            # floor of the residual standard deviation [rad]: 0.02 while the
                                # balance missed the propeller's gyroscopic moment (0.01 let the
                                # steep idle descending turns after a GPS fault read 6 sigma);
                                # with it the healthy residual is 0.0008 rad sd, 0.005 at most
                                # (default mission seed 1), 0.013 rms in the worst 5 s of
                                # moderate turbulence (false_alarms.toml's first 16 trials)


@kernel
def rls_update(c, P, phi, y):
    """One step of recursive least squares on the regressor ``phi`` and the measurement
    ``y``, in place: the prediction error ``e = y - phi^T c``, ``Pp = P phi``,
    ``s = 1 + phi^T Pp``, the gain ``g = Pp / s``, then ``c += g e`` and ``P -= g Pp^T``.
    Returns e (the residual the fit leaves before this step). The products summed as
    numpy's ``.dot`` sums them (stats.blas_dot, blas_matvec), which they were before."""
    n = c.shape[0]
    e = y - blas_dot(phi, c)
    Pp = np.empty(n)
    blas_matvec(P, phi, Pp)
    s = 1.0 + blas_dot(phi, Pp)
    for i in range(n):
        g = Pp[i] / s
        c[i] += g * e
        for j in range(n):
            P[i, j] -= g * Pp[j]
    return e


# offset_step's work on the sample FIT_DELAY_S old: none, the least-squares step, the
# residual the fit leaves
NO_FIT, FIT, LEFT = 0, 1, 2


@kernel
def offset_step(fit, x1, x2, y1, y2, y, mode):
    """A balance's fit at one sample (the moment balance's, lateral._Axis's): ``phi^T c``
    on the sample's regressor ``phi = (1, x1[, x2])``, then on the sample FIT_DELAY_S old,
    ``(1, y1[, y2])`` with its measurement ``y``: with ``mode`` FIT the least-squares step
    (rls_update, in place), its prediction error e returned; LEFT the residual the fit
    leaves, ``y - phi^T c``; NO_FIT nothing (e = 0); then ``phi^T c`` again: (before, e,
    after) the fit (an axis takes its offset out of z before, the moment balance its z
    after). ``fit``: the n terms c (row 0), then P (rows 1..n); n is 2 or 3. (One call,
    not a dot and an update with a new regressor array each: each compiled call costs
    1-2 k instructions of dispatch, each array argument 1.1 k.)"""
    c, P = fit[0], fit[1:]
    n = c.shape[0]
    phi = np.empty(n)
    phi[0], phi[1] = 1.0, x1
    if n == 3:
        phi[2] = x2
    before = blas_dot(phi, c)
    e = 0.0
    if mode != NO_FIT:
        ph = phi.copy()
        ph[1] = y1
        if n == 3:
            ph[2] = y2
        e = rls_update(c, P, ph, y) if mode == FIT else y - blas_dot(ph, c)
    return before, e, blas_dot(phi, c)


# a balance's low-pass state (``st``, int64): signals held (0: none, start again), the latest
# sample's time, the low-passes' latest (re)start, the next balance sample's, the first
# sample's (-1: none yet) [us]
LP_ON, LP_T, LP_START, LP_NEXT, LP_T0 = range(5)


def lowpass_state() -> np.ndarray:
    """A balance's low-pass state (:func:`lowpass_advance`) holding no signals."""
    return np.array((0, 0, 0, 0, -1), dtype=np.int64)


@kernel
def lowpass_advance(lp, st, n, t_us):
    """The balances' step (MomentBalance, lateral.LateralIdentifier,
    throttle.ThrottleIdentifier): their ``n`` signals, written in ``lp``'s last ``n``
    places, low-passed over BAL_TAU_S into its first ``n``, in place, ``lp + a (x - lp)``
    with ``a = dt / (BAL_TAU_S + dt)``; where none are held (``st[LP_ON]`` 0) they start on
    the signals. True where a balance sample is due: every BAL_PERIOD_US, and not within
    RESTART_HOLD_S of the (re)start. (One array, not a tuple of signals: one compiled
    specialisation for the three balances.)"""
    k = lp.shape[0] - n
    if st[LP_ON] == 0:
        for i in range(n):
            lp[i] = lp[k + i]
        st[LP_ON] = 1
        st[LP_T] = t_us
        st[LP_START] = t_us
        if st[LP_T0] < 0:
            st[LP_T0] = t_us
        return False
    dt = (t_us - st[LP_T]) * 1e-6
    st[LP_T] = t_us
    if dt <= 0.0:
        return False
    a = dt / (BAL_TAU_S + dt)
    for i in range(n):
        lp[i] = lp[i] + a * (lp[k + i] - lp[i])
    if t_us < st[LP_NEXT]:
        return False
    st[LP_NEXT] = t_us + BAL_PERIOD_US
    return not t_us - st[LP_START] < RESTART_HOLD_S * 1e6


@kernel
def pitch_front(lp, st, t_us, V, flying, throttle, d_cmd, n, q, r_yaw, pc):
    """The moment balance's signals (1, n (V_REF / V)^2 - 1, throttle (V_REF / V)^2,
    delta_cmd, q, the propeller's gyroscopic elevator) low-passed (:func:`lowpass_advance`;
    started again after a gap over RESTART_GAP_S), flying at 10 m/s or more: True where a
    sample is due (MomentBalance.sample), with the pitch acceleration in ``lp[6]``. ``pc``:
    airframe.PitchAero.gyro_coefs (None: no model, no gyroscopic term)."""
    if not flying or V < 10.0:
        return False
    r = V_REF / V
    g = 0.0 if pc is None else gyro_elevator(pc, r_yaw, throttle, V)
    if st[LP_ON] != 0 and (t_us - st[LP_T]) * 1e-6 > RESTART_GAP_S:
        st[LP_ON] = 0             # the monitor paused: start the low-passes again
    x = lp[7:]
    x[0], x[1], x[2], x[3], x[4], x[5] = 1.0, n * r * r - 1.0, throttle * r * r, d_cmd, q, g
    if not lowpass_advance(lp, st, 6, t_us):
        return False
    # the derivative of a first-order low-passed rate is (x - x_lp) / tau, exactly
    lp[6] = (q - lp[4]) / BAL_TAU_S
    return True


class MomentBalance:
    """The quasi-steady pitch-moment balance (**) of the module docstring: recursive
    least squares of the commanded deflection on [1, n / V^2, throttle / V^2],
    fitted on samples FIT_DELAY_S old while ``frozen`` is false. The regressors are
    scaled by V_REF (``n (V_REF / V)^2 - 1``, ``throttle (V_REF / V)^2``) so that all are of
    order one and the nearly uninformative prior (P = 1e4 I) shrinks none of them."""

    N = 3
    V_REF = V_REF

    def __init__(self, prior: np.ndarray | None = None, model=None):
        # with the airframe's model (airframe.py) the fit starts from its prediction,
        # trusted to PRIOR_SD (in units of the fit's own noise, BAL_NOISE_RAD), and z is
        # available from the first sample; without it, from nothing after 30 s of fit
        self.prior = prior is not None
        # the fit's terms c and their covariance P, one array (offset_step)
        self._fit = np.zeros((self.N + 1, self.N))
        self.c, self.P = self._fit[0], self._fit[1:]
        if prior is not None:
            self.c[:] = prior
            self.P[:] = np.diag((np.array(PRIOR_SD) / BAL_NOISE_RAD) ** 2)
        else:
            self.P[:] = np.eye(self.N) * 1e4
        self.model = model            # airframe.PitchAero: the pitch rate's terms (or None)
        self.n = 0
        self._lp = np.zeros(13)       # the signals low-passed (pitch_front), the pitch
                                      # acceleration, the signals; their state below
        self._st = lowpass_state()
        self._pc = None if model is None else model.gyro_coefs
        self._queue: list = []        # (t_us, phi[1], phi[2], delta_cmd) waiting FIT_DELAY_S
        self.hist: list = []          # (t_us, z, delta_cmd) of the last 20 s
        self.frozen = False
        self.suspended = False        # a sensor fault is running: nothing is learnt
        # (autopilot.jit.preload: a speed, a throttle, a command, a load factor, two rates)
        preload(offset_step, self._fit.copy(), 0.0, 0.0, 0.0, 0.0, 0.0, FIT)
        preload(pitch_front, self._lp.copy(), self._st.copy(), 0, 20.0, True, 0.5, 0.0, 1.0, 0.0, 0.0, self._pc)

    @property
    def ready(self) -> bool:
        return self.prior or self.n >= 300   # the model, or 30 s of fitted samples

    def sample(self, t_us: int, V: float) -> tuple[float, float] | None:
        """A sample due (:func:`pitch_front` on ``_lp``, ``_st``); once fitted: (z,
        delta_cmd) low-passed, z the deflection the balance says the aircraft flies with.
        With the airframe's model the pitch rate q adds its damping and, through the
        derivative of its low-passed value ((q - q_lp) / BAL_TAU_S, exact for the
        first-order filter), its inertia, and the yaw rate r the propeller's gyroscopic
        moment (``PitchAero.gyro_elevator``): known terms, not fitted."""
        lp = self._lp.tolist()
        # the regressor (1, lp[1], lp[2]): lp[0] is the constant 1 low-passed, which starts
        # at 1 and stays there to the bit
        d = lp[3]
        z_dyn = 0.0
        if self.model is not None:
            z_dyn = self.model.dynamic_elevator(lp[4], lp[6], V) + lp[5]
        fitted = None                  # phi^T c after this sample's fit
        if not self.frozen and not self.suspended and t_us - int(self._st[LP_T0]) >= FIT_WARMUP_S * 1e6:
            q_ = self._queue
            while q_ and t_us - q_[0][0] >= FIT_DELAY_S * 1e6:
                _, y1, y2, dd = q_.pop(0)
                _, _, fitted = offset_step(self._fit, lp[1], lp[2], y1, y2, dd, FIT)
                self.n += 1
            q_.append((t_us, lp[1], lp[2], d - z_dyn))
        if self.ready:
            if fitted is None:
                fitted = offset_step(self._fit, lp[1], lp[2], 0.0, 0.0, 0.0, NO_FIT)[0]
            z = fitted + z_dyn
            h = self.hist
            h.append((t_us, z, d))
            while h and t_us - h[0][0] > 20e6:
                h.pop(0)
            return z, d
        return None

    def freeze(self) -> None:
        """At a detection: the fit stops, and the samples not yet fitted (which may
        hold the fault) are dropped."""
        self.frozen = True
        self._queue.clear()

    def suspend(self, on: bool) -> None:
        """While ``on`` nothing is fitted; the samples waiting at its start are dropped."""
        if on and not self.suspended:
            self._queue.clear()
        self.suspended = on

    def identify(self, since_us: int, stuck: bool = False, recent_us: int | None = None) -> dict | None:
        """The two hypotheses (2.23, 2.24) over the samples since ``since_us``
        (:func:`identify_hist`)."""
        return identify_hist(self.hist, since_us, stuck, recent_us)


def identify_hist(hist: list, since_us: int, stuck: bool = False,
                  recent_us: int | None = None, d_max: float = MAX_DEFLECTION_RAD,
                  rss_share: float = RSS_STUCK, sat_late: bool = False,
                  settle_s: float = SETTLE_S) -> dict | None:
    """The two hypotheses (2.23, 2.24) over the (t_us, z, delta_cmd) samples of ``hist``
    since ``since_us``; only the stuck one with ``stuck`` (a surface already found stuck). The stuck position is
    the mean of z since ``recent_us`` (the samples after the onset's transient) when
    given and at least 10 samples hold it; ``d_max`` the command's full travel (its
    saturation counts for the stuck hypothesis); ``rss_share`` the stuck fit's residual
    sum of squares under this share of the weakened fit's reads stuck (RSS_STUCK, the
    surfaces'; the throttle on the rotor's speed its own, throttle.RPM_RSS_STUCK);
    ``sat_late``: the command's saturation counted over the samples after the onset's
    transient (``settle_s`` on, as the late test below), not the whole window (a piston
    engine's throttle: the command runs up to full over the seconds the rotor takes to
    spin down, throttle.ThrottleIdentifier.identified); ``settle_s`` the transient's
    length (SETTLE_S; the piston's rotor its own)."""
    h = [r for r in hist if r[0] >= since_us]
    if len(h) < 10:
        return None
    z = np.array([r[1] for r in h])
    d = np.array([r[2] for r in h])
    dd = float(d @ d)
    k = float(z @ d) / dd if dd > 0.0 else 0.0
    sat = float(np.mean(np.abs(d) >= 0.98 * d_max))
    s_now = float(np.mean(z))
    recent = [r[1] for r in h if recent_us is not None and r[0] >= recent_us]
    s_pos = float(np.mean(recent)) if len(recent) >= 10 else s_now
    # the two fits' residual sums of squares: a stuck surface explains z far better
    # than a loss of effectiveness when the command moves and z does not
    rss_stuck = float(np.sum((z - s_now) ** 2))
    rss_loe = float(np.sum((z - k * d) ** 2))
    # the same test after the onset's transient (SETTLE_S after the window's start):
    # z settles on a stuck position a few BAL_TAU_S after the onset, and the
    # transient's spread counted against the stuck hypothesis
    late = np.array([r[0] >= since_us + settle_s * 1e6 for r in h])
    if late.sum() >= 20:
        zl, dl = z[late], d[late]
        ddl = float(dl @ dl)
        kl = float(zl @ dl) / ddl if ddl > 0.0 else 0.0
        if float(np.sum((zl - zl.mean()) ** 2)) < rss_share * float(np.sum((zl - kl * dl) ** 2)):
            rss_stuck = 0.0
        if sat_late:
            sat = float(np.mean(np.abs(dl) >= 0.98 * d_max))
    if (stuck or k < K_MIN or k > K_MAX or sat >= SAT_SHARE
            or rss_stuck < rss_share * rss_loe):
        return {"stuck_rad": round(s_pos, 4)}
    return {"effectiveness": round(k, 3)}


class ElevatorIdentifier:
    """Two-stage elevator fault detection and identification (module docstring).

    ``step(t_us, nav, elevator_cmd, flying, throttle)`` once per vehicle step with the
    navigation state and the normalised elevator command (+1 nose up). Outputs:
    ``ratio`` (window statistic / threshold), ``k``, ``s_rad`` (stage 2), ``lam``
    (fading factor), ``frozen``, ``ready``.
    """

    def __init__(self, alpha: float = 1e-4, window: int = 10, p_fa: float = 0.01,
                 q_gamma: float = 1e-6, model=None):
        # the window test runs every TEST_DIV-th balance sample of a whole flight: its
        # level from the family-wise false-alarm probability per hour (stats.family_alpha)
        tests_per_hour = 3600e6 / (BAL_PERIOD_US * TEST_DIV)
        self.win = WindowChi2(1, window, alpha, family_alpha(p_fa, tests_per_hour))
        self.q_gamma = q_gamma
        # the airframe's model (airframe.PitchAero): the balance's prior and its pitch-
        # rate terms; None: the balance is learnt in flight from nothing
        self.model = model
        self.prior = None if model is None else model.balance(MomentBalance.V_REF)
        self.reset()
        # (autopilot.jit.preload: the stage-2 step's kernel loaded now, not when the test arms)
        preload(stage2_update, self.gamma, self.P_gamma, self._H, self._e, self._r, 0.0)

    def reset(self) -> None:
        self.suspended = False        # a sensor fault running (suspend)
        self.r_var = None             # healthy residual variance of the balance [rad^2]
        self._n_var = 0
        if self.prior is not None:
            # the model's residual is trusted at the floor from the first sample: the
            # test is armed at once, the variance learnt on as without it
            self.r_var = RES_FLOOR_RAD * RES_FLOOR_RAD
            self._n_var = RES_WARMUP_N
        self._r_queue: list[float] = []
        self._r_delay_n = int(FIT_DELAY_S * 1e6 / BAL_PERIOD_US)
        self.gamma = np.array([1.0, 0.0])
        self.P_gamma = np.eye(2) * 1e-4
        # stage 2's measurement row [delta_cmd, 1], innovation and variance, rewritten in
        # place at each sample (new small arrays cost more than the update's arithmetic)
        self._H = np.array(((0.0, 1.0),))
        self._e = np.zeros(1)
        self._r = np.ones(1)
        self._e2 = []                 # squared innovations of stage 2 (window)
        self.frozen = False           # fault suspected: the balance and R stop learning
        self.adapt = False            # Q adaptation on
        self.ratio = 0.0
        self.residual = 0.0           # latest balance residual z - delta_cmd [rad]
        self.lam = 1.0
        self._k = 0
        self.ready = False
        self.balance = MomentBalance(self.prior, self.model)
        self._fault_us = None

    @property
    def k(self) -> float:
        return float(self.gamma[0])

    @property
    def s_rad(self) -> float:
        return float(self.gamma[1])

    def suspend(self, on: bool) -> None:
        """While the navigation has a sensor fault the balance's inputs (alpha, airspeed,
        wind) are suspect: nothing is learnt, and the samples still waiting FIT_DELAY_S
        for the fit or the residual variance are dropped (they may already hold it)."""
        if on and not self.suspended:
            self._r_queue.clear()
        self.suspended = on
        self.balance.suspend(on)

    def freeze(self, t_us: int) -> None:
        """A fault is detected: the moment balance and the residual variance stop
        learning, the fault parameters adapt (Q adaptation) and identification starts."""
        self.frozen = self.adapt = True
        self.balance.freeze()
        self._fault_us = t_us - 1_000_000

    def step(self, t_us: int, nav, elevator_cmd: float, flying: bool, throttle: float = 0.0,
             n_meas: float | None = None, q: float | None = None) -> bool:
        """True where ``ratio`` was renewed (its window test ran: 2 Hz)."""
        V = nav.airspeed_mps
        _p, q_b, r_b = nav.omega_b.tolist()     # body rates, bias-corrected
        if q is None:
            q = q_b                    # pitch rate
        b = self.balance
        if not pitch_front(b._lp, b._st, t_us, V, flying, throttle, elevator_cmd * MAX_DEFLECTION_RAD,
                           self.load_factor(nav) if n_meas is None else n_meas, q, r_b, b._pc):
            return False
        return self.sample(t_us, V)

    @staticmethod
    def load_factor(nav) -> float:
        """The normal load factor of a coordinated turn, 1 / cos(bank) (navigation without an
        IMU, truth: the accelerometer's otherwise)."""
        qw, qx, qy, qz = (float(c) for c in nav.q_nb)
        c_bank = math.cos(math.atan2(2.0 * (qw * qx + qy * qz), 1.0 - 2.0 * (qx * qx + qy * qy)))
        return 1.0 / max(c_bank, 0.5)

    def sample(self, t_us: int, V: float) -> bool:
        """The balance's sample due (:func:`pitch_front`): the residual, its window test
        and stage 2. True where ``ratio`` was renewed."""
        sample = self.balance.sample(t_us, V)
        if sample is None:
            return False
        z, dcmd = sample
        # ---- stage 1: residual of the no-fault hypothesis, delta_act = delta_cmd -------
        r = z - dcmd
        self.residual = r
        # the healthy residual variance: of this residual itself, learnt FIT_DELAY_S late
        # (as the balance) so that a fault is not in it when it is detected -- the
        # balance's own fit residuals are 2-3 times smaller than its prediction
        # residuals, which wander with the manoeuvres (measured)
        if not self.frozen and not self.suspended:
            q_ = self._r_queue
            q_.append(r)
            if len(q_) > self._r_delay_n:
                ro = q_.pop(0)
                self._n_var += 1
                a = max(1.0 / self._n_var, BAL_PERIOD_US * 1e-6 / RES_TAU_S)
                self.r_var = ro * ro if self.r_var is None else self.r_var + a * (ro * ro - self.r_var)
        if self._n_var < RES_WARMUP_N:
            return False
        self.ready = True
        R = max(self.r_var, RES_FLOOR_RAD * RES_FLOOR_RAD)
        # detection: window chi-square of the normalised residual  (2.12-2.15)
        self._k += 1
        renewed = self._k >= TEST_DIV
        if renewed:
            self._k = 0
            self.win.push([r / math.sqrt(R)])
            self.ratio = self.win.ratio_det
        # ---- stage 2: gamma = [k, s], z = [delta_cmd, 1] gamma + v (2.20-2.24) ----------
        # P = P + Lambda Q (2.40), Lambda from the innovations' excess (2.35-2.39)
        g_k, g_s = self.gamma.tolist()
        e = z - (dcmd * g_k + g_s)         # (as numpy's [delta_cmd, 1].dot(gamma) sums it)
        e2 = self._e2
        e2.append(e * e)
        if len(e2) > self.win.M:
            e2.pop(0)
        lam = 1.0
        if self.adapt and len(e2) >= self.win.M:
            C = sum(e2) / len(e2)
            hqh = self.q_gamma * (dcmd * dcmd + 1.0)
            H = np.array([dcmd, 1.0])
            lam = min(max(1.0, (C - float(H.dot(self.P_gamma).dot(H)) - R) / hqh), 1e6)
        self.lam = lam
        # P = P + Lambda Q, K = P H^T / S, gamma += K e, Joseph form (stats.stage2_update)
        self._H[0, 0] = dcmd
        self._e[0] = e
        self._r[0] = R
        self.gamma, self.P_gamma = stage2_update(self.gamma, self.P_gamma, self._H, self._e, self._r,
                                                 self.q_gamma * lam)
        return renewed

    def identified(self, stuck_below: float = 0.25, stuck: bool = False) -> dict:
        """The fault parameters as the summary reports them: from the moment balance
        (module docstring) once a fault is detected and the balance is fitted; the
        stage-2 [k, s] otherwise. ``stuck``: the surface was found stuck before, report
        the stuck hypothesis only."""
        if self._fault_us is not None and self.balance.ready:
            # the stuck position over the last IDENT_WIN_S once that many seconds have
            # passed since the detection: the balance's low-passed z settles on it a few
            # BAL_TAU_S after the onset, and its transient biased the estimate; stuck or
            # weakened is decided on every sample since the detection
            recent = None
            if self.balance._st[LP_T0] >= 0:
                recent = int(self.balance._st[LP_T]) - int(IDENT_WIN_S * 1e6)
            r = self.balance.identify(self._fault_us, stuck, recent)
            if r is not None:
                return r
        if self.k < stuck_below:
            return {"stuck_rad": round(self.s_rad, 4), "k": round(self.k, 3)}
        return {"effectiveness": round(self.k, 3), "s_rad": round(self.s_rad, 4)}
