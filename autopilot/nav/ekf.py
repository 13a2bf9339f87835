"""INS/GPS error-state extended Kalman filter (seed ch. 7 sec. 1.12-1.13, eq 1.22; ch. 8 sec. 2.1.2).

Formulation: error-state (multiplicative, "indirect") EKF. A nominal state -- position,
NED velocity, attitude quaternion q_nb, accelerometer and gyro biases, barometer offset,
GPS position error, north/east wind (fixed-wing) -- is propagated by the strapdown mechanisation (:mod:`.strapdown`) at
the IMU rate; the filter estimates the error state ``dx`` (layout in :mod:`.layout`)
whose attitude part is a 3-element rotation vector in NED, ``q_true = Exp(dtheta) (x)
q``. After each update ``dx`` is folded into the nominal state and reset to zero (the
reset Jacobian ``I + [dtheta/2 x]`` is taken as I). References: J. Sola, "Quaternion
kinematics for the error-state Kalman filter", arXiv:1711.02508 (2017), the ESKF with
global angular errors; P. D. Groves, "Principles of GNSS, Inertial, and Multisensor
Integrated Navigation Systems", 2nd ed. (2013), ch. 14 (INS/GNSS integration); D.
Simon, "Optimal State Estimation" (2006) (the seed's reference for fig 1.21).

The seed's eq 1.22 lost its subscripts in extraction. Rebuilt, it is the 15-state
vector ``x = [L, lambda, h, V_N, V_E, V_D, phi, theta, psi, b_ax, b_ay, b_az, b_gx,
b_gy, b_gz]``; we hold the same quantities with position in local NED and the attitude
as a quaternion plus a rotation-vector error (see :mod:`.layout`).

Continuous error dynamics (Sola 2017, global angular error; f_n = R (f_m - b_a)):

    d(dp)/dt     = dv
    d(dv)/dt     = -[f_n x] dtheta - R db_a - R n_a
    d(dtheta)/dt = -R db_g - R n_g
    d(db_a)/dt   = n_ba,   d(db_g)/dt = n_bg,   d(db_baro)/dt = n_bb,   d(dw)/dt = n_w
    d(db_gps)/dt = -db_gps / tau + n_gps                     (Gauss-Markov)

discretised to first order, F = I + F_c dt, with a diagonal Q (the NED-frame images
R n of isotropic body noises are isotropic), plus the sampling error of the IMU samples
where it exceeds Q (base.py). The mechanisation's Earth-rate and Coriolis terms
(strapdown.py) are left out of F: their error terms are 1e-4 of the others. Updates use the Joseph form; P is
symmetrised and its diagonal kept within a floor and ceiling after every update. All
measurements present in one step are gated one source at a time and then fused in one
stacked update (equivalent to sequential updates for independent noises, and cheaper).
Aiding sources, GPS latency and alignment: see :mod:`.base`.

Cost (campaigns pay every microsecond of the loop): the prediction and the update are
compiled kernels (``predict_covariance_into``, ``joseph_update_into``; autopilot/jit.py),
writing into two covariance arrays used in turn (no allocation per call). F is
never formed: its nonzero blocks (30 of 441 entries off the identity) multiply P
directly, a few thousand multiplications instead of two dense 21 x 21 products; the
Joseph form likewise uses the few states each row of H touches, and the gain comes from
a Cholesky solve instead of an explicit inverse. Q is a constant diagonal for a given
dt; the aux sensors are fused at 25 Hz as means (base.py), so an update runs on every
other step at most (its time per step: ``sitl bench``, docs/status.md). The kernels sum
in another order than the numpy products they replaced: on a recorded 120 s flight the
states agree to 1e-13 and P to 2e-9 relative (docs/status.md, "Speed").

Covariance rate (``cov_div``, 1 by default; the fixed-wing flies with 4). The nominal
state is propagated at every IMU step and measurements are fused at the step they
arrive, as above; the covariance prediction ``P = F P F^T + Q`` may instead run every
``cov_div``-th step over the steps since the last one, and always right before a
fusion. Over those steps F is the first-order transition of the whole interval (its
dynamic entries are the sums of the per-step ones: ``-[sum f_n dt x]``, ``-sum R dt``;
``F[POS, VEL] = sum dt``, the Gauss-Markov decay the product of the per-step ones) and
Q the sum of the per-step noises (the Gauss-Markov part decayed exactly), plus the
sampling errors of every step: the terms left out are second order in the interval
(40 ms at 100 Hz with 4), as the per-step F already leaves out its own; on the
navigation simulator the figures are those of every-step prediction
(tests/test_nav_ekf.py). With the aux sensors fused every 4th step, the fixed-wing's
predictions are in effect those before its fusions. Between two predictions ``P`` is
the covariance at the last one (at most ``cov_div - 1`` steps old).
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.jit import cholesky_gain, cholesky_lower, kernel

from .base import (_B_H, _B_O, _B_S, _IA, _IV, _P_CEIL, _P_FLOOR, S_ACC, S_ACC_HAS, S_QS_HAS,
                   NavFilterBase, inject_into, output_into)
from .config import NAV_PARAMS  # noqa: F401  (re-exported: the filter's parameters beside it)
from .layout import ABIAS, ATT, BBIAS, GBIAS, GPSB, POS, VEL, WIND


# ------------------------------------------------------------------ kernels --
# They index the error state by number: the layout they were written for.
assert ((POS.start, VEL.start, ATT.start, ABIAS.start, GBIAS.start, GPSB.start)
        == (0, 3, 6, 9, 12, 16))


@kernel
def _transition_times(X, T, S, Rs, a, Y):
    """Y = F X for the error-state transition over an interval T (module docstring),
    F = I + F_c T with only its nonzero blocks multiplied out:

        F[POS, VEL] = T I,   F[VEL, ATT] = -[S x],   F[VEL, ABIAS] = F[ATT, GBIAS] = -Rs,
        F[GPSB, GPSB] = a I

    S = sum f_n dt (3 floats), Rs = sum R dt (9 floats, row-major), a the Gauss-Markov
    decay over the interval."""
    n = X.shape[0]
    for c in range(X.shape[1]):
        for r in range(n):
            Y[r, c] = X[r, c]
        x3, x4, x5 = X[3, c], X[4, c], X[5, c]
        x6, x7, x8 = X[6, c], X[7, c], X[8, c]
        x9, x10, x11 = X[9, c], X[10, c], X[11, c]
        x12, x13, x14 = X[12, c], X[13, c], X[14, c]
        Y[0, c] += T * x3
        Y[1, c] += T * x4
        Y[2, c] += T * x5
        # -[S x] = [[0, S_z, -S_y], [-S_z, 0, S_x], [S_y, -S_x, 0]]
        Y[3, c] += (S[2] * x7 - S[1] * x8) - (Rs[0] * x9 + Rs[1] * x10 + Rs[2] * x11)
        Y[4, c] += (S[0] * x8 - S[2] * x6) - (Rs[3] * x9 + Rs[4] * x10 + Rs[5] * x11)
        Y[5, c] += (S[1] * x6 - S[0] * x7) - (Rs[6] * x9 + Rs[7] * x10 + Rs[8] * x11)
        Y[6, c] -= Rs[0] * x12 + Rs[1] * x13 + Rs[2] * x14
        Y[7, c] -= Rs[3] * x12 + Rs[4] * x13 + Rs[5] * x14
        Y[8, c] -= Rs[6] * x12 + Rs[7] * x13 + Rs[8] * x14
        Y[16, c] = a * X[16, c]
        Y[17, c] = a * X[17, c]
        Y[18, c] = a * X[18, c]


@kernel
def predict_covariance_into(P, T, s, a, q, out):
    """Covariance prediction over an interval T (module docstring; Sola 2017 eq 269):

        P' = F P F^T + diag(q)   (+ the IMU sampling error q_s on the velocity and
                                  attitude blocks, base.py, where the interval has one)

    computed as F (F P)^T transposed, F's blocks as in ``_transition_times``, written
    into ``out`` (n x n, not P itself: a kernel that hands back a new array costs the
    loop more than the prediction's arithmetic). S = sum f_n dt, Rs = sum R dt and q_s
    are the interval's sums in the filter's per-step array ``s`` (base.imu_step, S_ACC),
    taken here: the next interval starts afresh (S_ACC_HAS, S_QS_HAS cleared)."""
    n = P.shape[0]
    S, Rs = s[S_ACC:S_ACC + 3], s[S_ACC + 3:S_ACC + 12]
    Y = np.empty((n, n))
    _transition_times(P, T, S, Rs, a, Y)          # Y = F P
    _transition_times(Y.T, T, S, Rs, a, out.T)    # out^T = F Y^T = (F P F^T)^T
    for r in range(n):
        out[r, r] += q[r]
    if s[S_QS_HAS] != 0.0:
        # q_s: the velocity block's 3 x 3 (row-major), then the attitude block's
        k = S_ACC + 12
        for b0 in (_IV, _IA):
            for i in range(3):
                for j in range(3):
                    out[b0 + i, b0 + j] += s[k]
                    k += 1
    s[S_ACC_HAS] = 0.0
    s[S_QS_HAS] = 0.0


@kernel
def joseph_update_into(P, H, PHt, S, R, y, floor, ceil, dx, out):
    """The measurement update in Joseph form (Simon 2006 eq 5.19; Groves 2013 eq 3.25):

        S = H P H^T + R,   K = P H^T S^-1   (Cholesky: S = L L^T)
        dx = K y
        P' = (I - K H) P (I - K H)^T + K R K^T
           = A - (A H^T) K^T + K R K^T,   A = (I - K H) P = P - K (H P)

    then P' symmetrised and its diagonal kept within [floor, ceil] (base.py's
    _condition). ``PHt`` = P H^T and ``S`` = H P H^T (without R) as the gate computed
    them; R diagonal. dx and P' are written into ``dx`` (n) and ``out`` (n x n, not P
    itself; as predict_covariance_into). Returns ok: False (nothing written) when S is
    not positive definite."""
    n = P.shape[0]
    m = H.shape[0]
    # S + R = L L^T;  K^T = (L L^T)^-1 (P H^T)^T
    L = np.zeros((m, m))
    if not cholesky_lower(S, R, L):
        return False
    KT = np.empty((m, n))
    cholesky_gain(L, PHt, KT)
    # dx = K y
    for r in range(n):
        dx[r] = 0.0
    for k in range(m):
        yk = y[k]
        for r in range(n):
            dx[r] += KT[k, r] * yk
    # H P (H is sparse: a few states per row)
    HP = np.zeros((m, n))
    for k in range(m):
        for c in range(n):
            h = H[k, c]
            if h != 0.0:
                for j in range(n):
                    HP[k, j] += h * P[c, j]
    # A = P - K (H P)
    A = P.copy()
    for r in range(n):
        for k in range(m):
            kr = KT[k, r]
            for j in range(n):
                A[r, j] -= kr * HP[k, j]
    # A H^T
    AHt = np.zeros((n, m))
    for k in range(m):
        for c in range(n):
            h = H[k, c]
            if h != 0.0:
                for r in range(n):
                    AHt[r, k] += A[r, c] * h
    # P' = A + sum_k (K[:, k] R_k - (A H^T)[:, k]) K[:, k]^T
    for r in range(n):
        for k in range(m):
            w = KT[k, r] * R[k] - AHt[r, k]
            for j in range(n):
                A[r, j] += w * KT[k, j]
    for r in range(n):
        for c in range(n):
            out[r, c] = 0.5 * (A[r, c] + A[c, r])
        out[r, r] = min(max(out[r, r], floor[r]), ceil[r])
    return True


@kernel
def fuse_into(P, H, PHt, S, R, y, out, b):
    """The update (:func:`joseph_update_into`: P' into ``out``, P's diagonal kept within
    base.py's floor and ceiling) with dx folded into the nominal state (base.inject_into;
    ``b``: the filter's buffer of the nominal state, the per-step array and the output,
    base._B_*), and the output of the new nominal state (base.output_into). Returns (ok,
    and output_into's six floats); ok False: S not positive definite, nothing written."""
    n = P.shape[0]
    dx = np.empty(n)
    if not joseph_update_into(P, H, PHt, S, R, y, _P_FLOOR[:n], _P_CEIL[:n], dx, out):
        return False, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    x, s = b[:_B_S], b[_B_S:_B_H]
    inject_into(x, s, dx)
    return True, output_into(x, s, b[_B_O:])


class InsGpsEkf(NavFilterBase):
    """INS/GPS error-state EKF.

    ``InsGpsEkf(params=None, vehicle="plane", origin=None, cov_div=1)``; ``update(frame)
    -> NavState`` once per IMU step; ``innovations`` (records of the latest update),
    ``P``, ``sigma()``, ``reset()``. The origin is the vehicle's home if given, else the
    first 3D GPS fix. ``cov_div``: covariance prediction every N-th step (module
    docstring).
    """

    SOURCE = "ekf"

    def __init__(self, params=None, vehicle: str = "plane", origin=None, cov_div: int = 1):
        self.cov_div = max(1, int(cov_div))
        super().__init__(params, vehicle, origin)

    def _reset_covariance_model(self) -> None:
        self._clear_pending()
        n = self.n
        self._set_P(np.eye(n))
        # the kernels write the next P here; the P they read becomes the next spare
        # (two arrays in turn: no allocation per prediction or update)
        self._P_spare = np.empty((n, n))
        self._q = np.zeros(n)        # diag Q of a step of _q_dt
        self._a_gm = 1.0             # the Gauss-Markov decay over _q_dt
        self._q_dt = -1.0
        self._interval_cache: dict = {}   # (dt, dt, ...) -> (diag Q, Gauss-Markov decay, T)

    @property
    def P(self) -> np.ndarray:
        """The error covariance (the filter's own array: read it, or copy it to keep it;
        the kernels reuse its memory two predictions or updates later)."""
        return self._P

    def _set_P(self, P: np.ndarray) -> None:
        self._P = P
        self._P_ver += 1

    def _next_P(self, out: np.ndarray) -> None:
        """``out`` (the spare, now written) becomes P; the old P the spare."""
        self._P_spare = self._P
        self._P = out
        self._P_ver += 1

    def _init_covariance(self, sd: np.ndarray) -> None:
        self._set_P(np.diag(np.asarray(sd, dtype=float) ** 2))

    def _process_noise(self, dt: float) -> None:
        """diag Q and the Gauss-Markov decay for a step of dt."""
        prm = self.params
        q = np.zeros(self.n)
        q[VEL] = (prm["EK_ACC_NSE"] * dt) ** 2
        q[ATT] = (prm["EK_GYR_NSE"] * dt) ** 2
        q[ABIAS] = prm["EK_ACCB_NSE"] ** 2 * dt
        q[GBIAS] = prm["EK_GYRB_NSE"] ** 2 * dt
        q[BBIAS] = prm["EK_BAROB_NSE"] ** 2 * dt
        # first-order Gauss-Markov GPS error: b' = a b + w, a = exp(-dt/tau), var(w) = sd^2 (1 - a^2)
        a = math.exp(-dt / prm["EK_GPSB_TAU"])
        q[GPSB] = np.array(self._gm_sd()) ** 2 * (1.0 - a * a)
        if self.is_plane:
            q[WIND] = prm["EK_WIND_NSE"] ** 2 * dt
        self._q = q
        self._a_gm = a
        self._q_dt = dt

    def _noise(self, q: np.ndarray, T: float) -> np.ndarray:
        """diag Q, scaled by the fading hook's Lambda if one is attached (P = F P F^T +
        Lambda Q, seed eq 2.40; base.py hooks)."""
        lam = self.q_scale_hook(T) if self.q_scale_hook is not None else None
        return q if lam is None else q * lam

    def _predict(self, dt: float, f1, w1, t: int) -> None:
        self._propagate_nominal(dt, f1, w1, t)
        if self.cov_div > 1:
            self._pend.append(dt)
            if len(self._pend) >= self.cov_div:
                self._sync_covariance()
            return
        if dt != self._q_dt:
            self._process_noise(dt)
        # P = F P F^T + Q (+ the sampling error of this step's IMU samples, base.py);
        # f_n dt and R dt of this step (base.imu_step)
        out = self._P_spare
        predict_covariance_into(self._P, dt, self._s, self._a_gm, self._noise(self._q, dt), out)
        self._next_P(out)

    # ------------------------------------------- covariance every cov_div steps --
    def _clear_pending(self) -> None:
        # the steps not yet in P: their dt (their f_n dt, R dt and sampling errors are
        # summed meanwhile, base.imu_step)
        self._pend: list[float] = []

    def _interval_noise(self, dts: tuple) -> tuple:
        """(diag Q, Gauss-Markov decay, T) over the steps ``dts``: the per-step noises
        summed, the Gauss-Markov part decayed exactly (b' = a b + w per step), the
        interval T = sum dts."""
        key = dts
        hit = self._interval_cache.get(key)
        if hit is not None:
            return hit
        q = np.zeros(self.n)
        a_tot = 1.0
        for dt in dts:
            self._process_noise(dt)
            a = self._a_gm
            q[GPSB] *= a * a                          # earlier steps' GPS noise decays
            q += self._q
            a_tot *= a
        if len(self._interval_cache) > 16:
            self._interval_cache.clear()
        self._interval_cache[key] = hit = (q, a_tot, math.fsum(dts))
        return hit

    def _sync_covariance(self) -> None:
        """P = F P F^T + Q over the steps not yet in P (module docstring)."""
        pend = self._pend
        if not pend:
            return
        self._pend = []
        q, a, T = self._interval_noise(tuple(pend))
        # F = I + F_c T:  F[VEL, ATT] = -[sum f_n dt x],  F[VEL, ABIAS] = F[ATT, GBIAS] = -sum R dt,
        #                 F[POS, VEL] = T I,  F[GPSB, GPSB] = (product of the decays) I
        out = self._P_spare
        predict_covariance_into(self._P, T, self._s, a, self._noise(q, T), out)
        self._next_P(out)

    def _gate_stats(self, batch) -> None:
        H = batch.H
        # P H^T, S = H P H^T (+ R below); np.dot: the same BLAS product as @ without the
        # generalised ufunc's set-up (a few k instructions a call)
        PHt = np.dot(self._P, H.T)
        S = np.dot(H, PHt)
        # y = z - h(x)
        batch.y = batch.y0
        batch.Sd = S.diagonal() + batch.R
        self._PHt, self._S = PHt, S

    def _fuse_rows(self, batch, rows) -> None:
        H, PHt, S, R, y = batch.H, self._PHt, self._S, batch.R, batch.y
        if rows is not None:
            # (one memory layout for every call: one compiled kernel)
            H, PHt, R, y = H[rows], np.ascontiguousarray(PHt[:, rows]), R[rows], y[rows]
            S = S[np.ix_(rows, rows)]
        # K = P H^T (H P H^T + R)^-1, dx = K y, Joseph-form P, dx into the nominal
        # state, the output of it (kernel above)
        out = self._P_spare
        ok, geo = fuse_into(self._P, H, PHt, S, R, y, out, self._buf)
        if not ok:
            return                           # S not positive definite: skip this update
        self._next_P(out)
        self._geo = geo
        self._wind_ned = None                # (the wind changed: as _inject)
