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

Cost (the closed loop must run >= 30x real time in Python): F is preallocated and only
its 24 dynamic entries are rewritten each step (one ``put``); Q is a constant diagonal
matrix for a given dt; the gain is solved with LAPACK ``dposv`` (Cholesky) instead of an
explicit inverse; the aux sensors are fused at 25 Hz as means (base.py), so an update
runs on every other step at most (its time per step: ``sitl bench``, docs/status.md).

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
from scipy.linalg import lapack

from .base import NavFilterBase
from .config import NAV_PARAMS  # noqa: F401  (re-exported: the filter's parameters beside it)
from .layout import ABIAS, ATT, BBIAS, GBIAS, GPSB, POS, VEL, WIND


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
        self._P = np.eye(n)
        self._F = np.eye(n)          # preallocated; only the dynamic entries are rewritten
        self._I = np.eye(n)
        self._Q = np.zeros((n, n))
        self._q_dt = -1.0
        self._interval_cache: dict = {}   # (dt, dt, ...) -> (diag Q, Gauss-Markov decay)
        # flat indices of F's dynamic entries: -[f_n x] dt (6 off-diagonal), -R dt (2 x 9)
        a, b, g, v = ATT.start, ABIAS.start, GBIAS.start, VEL.start
        idx = [(v + 0) * n + a + 1, (v + 0) * n + a + 2, (v + 1) * n + a + 0,
               (v + 1) * n + a + 2, (v + 2) * n + a + 0, (v + 2) * n + a + 1]
        idx += [(v + i) * n + b + j for i in range(3) for j in range(3)]
        idx += [(a + i) * n + g + j for i in range(3) for j in range(3)]
        self._F_idx = np.array(idx)
        # ... and those plus the interval's constant entries: F[POS, VEL], the Gauss-Markov decay
        p, m = POS.start, GPSB.start
        self._F_idx_all = np.array(idx + [(p + i) * n + v + i for i in range(3)]
                                   + [(m + i) * n + m + i for i in range(3)])

    @property
    def P(self) -> np.ndarray:
        return self._P

    def _set_P(self, P: np.ndarray) -> None:
        self._P = P

    def _init_covariance(self, sd: np.ndarray) -> None:
        self._P = np.diag(np.asarray(sd, dtype=float) ** 2)

    def _process_noise(self, dt: float) -> None:
        """Q (diagonal) and the constant entries of F for a step of dt."""
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
        self._Q = np.diag(q)
        F = self._F
        F[0, 3] = F[1, 4] = F[2, 5] = dt
        i = GPSB.start
        F[i, i] = F[i + 1, i + 1] = F[i + 2, i + 2] = a
        self._q_dt = dt

    def _predict(self, dt: float, f_m: np.ndarray, omega_m: np.ndarray) -> None:
        nom = self.nom
        self._propagate_nominal(dt, f_m, omega_m)
        if self.cov_div > 1:
            self._accumulate(dt)
            return
        if dt != self._q_dt:
            self._process_noise(dt)
        fx, fy, fz = nom.f_n
        r = nom.R
        m = -dt
        # F = I + F_c dt:  F[VEL, ATT] = -[f_n x] dt,  F[VEL, ABIAS] = F[ATT, GBIAS] = -R dt
        self._F.put(self._F_idx, (
            fz * dt, m * fy, m * fz, fx * dt, fy * dt, m * fx,
            m * r[0], m * r[1], m * r[2], m * r[3], m * r[4], m * r[5], m * r[6], m * r[7], m * r[8],
            m * r[0], m * r[1], m * r[2], m * r[3], m * r[4], m * r[5], m * r[6], m * r[7], m * r[8]))
        F = self._F
        # P = F P F^T + Q  (+ the sampling error of this step's IMU samples, base.py)
        P = F @ self._P @ F.T
        lam = self.q_scale_hook(dt) if self.q_scale_hook is not None else None
        if lam is None:
            P += self._Q
        else:
            # P = F P F^T + Lambda Q   (fading matrix, seed eq 2.40; base.py hooks)
            P.flat[:: self.n + 1] += self._Q.diagonal() * lam
        if self._q_sample is not None:
            P.flat[self._qs_idx] += self._q_sample
        self._P = P

    # ------------------------------------------- covariance every cov_div steps --
    def _clear_pending(self) -> None:
        self._pend: list[tuple] = []               # (dt, f_n, R, sampling error) per step

    def _accumulate(self, dt: float) -> None:
        """Keep one step's share of the interval's F and Q (module docstring)."""
        nom = self.nom
        pend = self._pend
        pend.append((dt, nom.f_n, nom.R, self._q_sample))   # (fresh objects every step)
        if len(pend) >= self.cov_div:
            self._sync_covariance()

    def _interval_noise(self, dts: tuple) -> tuple:
        """(diag Q, Gauss-Markov decay) over the steps ``dts``: the per-step noises
        summed, the Gauss-Markov part decayed exactly (b' = a b + w per step)."""
        key = dts
        hit = self._interval_cache.get(key)
        if hit is not None:
            return hit
        q = np.zeros(self.n)
        a_tot = 1.0
        g = GPSB.start
        for dt in dts:
            self._process_noise(dt)
            a = self._F[g, g]
            q[GPSB] *= a * a                          # earlier steps' GPS noise decays
            q += self._Q.diagonal()
            a_tot *= a
        if len(self._interval_cache) > 16:
            self._interval_cache.clear()
        self._interval_cache[key] = hit = (q, a_tot)
        return hit

    def _sync_covariance(self) -> None:
        """P = F P F^T + Q over the steps not yet in P (module docstring)."""
        pend = self._pend
        if not pend:
            return
        self._pend = []
        # sums over the steps of f_n dt and R dt
        dt, (fx, fy, fz), r, qs = pend[0]
        if len(pend) == 1:
            dts = (dt,)
            T = dt
            fx, fy, fz = fx * dt, fy * dt, fz * dt
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = (r0 * dt, r1 * dt, r2 * dt, r3 * dt, r4 * dt,
                                                  r5 * dt, r6 * dt, r7 * dt, r8 * dt)
        else:
            dts = tuple([e[0] for e in pend])
            T = math.fsum(dts)
            fx, fy, fz = fx * dt, fy * dt, fz * dt
            r = [c * dt for c in r]
            for dt, f, rk, qk in pend[1:]:
                fx, fy, fz = fx + f[0] * dt, fy + f[1] * dt, fz + f[2] * dt
                r = [c + ck * dt for c, ck in zip(r, rk)]
                if qk is not None:
                    qs = qk if qs is None else [c + ck for c, ck in zip(qs, qk)]
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
        q, a = self._interval_noise(dts)
        self._q_dt = -1.0                             # F's constant entries are the interval's
        # F = I + F_c T:  F[VEL, ATT] = -[sum f_n dt x],  F[VEL, ABIAS] = F[ATT, GBIAS] = -sum R dt,
        #                 F[POS, VEL] = T I,  F[GPSB, GPSB] = (product of the decays) I
        F = self._F
        F.put(self._F_idx_all, (
            fz, -fy, -fz, fx, fy, -fx,
            -r0, -r1, -r2, -r3, -r4, -r5, -r6, -r7, -r8,
            -r0, -r1, -r2, -r3, -r4, -r5, -r6, -r7, -r8, T, T, T, a, a, a))
        P = F @ self._P @ F.T
        lam = self.q_scale_hook(T) if self.q_scale_hook is not None else None
        d = P.reshape(-1)[:: self.n + 1]              # the diagonal, as a writeable view
        if lam is None:
            d += q
        else:
            d += q * lam
        if qs is not None:
            P.flat[self._qs_idx] += qs
        self._P = P

    def _gate_stats(self, batch) -> None:
        H = batch.H
        # P H^T, S = H P H^T (+ R below)
        PHt = self._P @ H.T
        S = H @ PHt
        # y = z - h(x)
        batch.y = batch.y0
        batch.Sd = S.diagonal() + batch.R
        self._PHt, self._S = PHt, S

    def _fuse_rows(self, batch, rows) -> None:
        H, PHt, S, R, y = batch.H, self._PHt, self._S, batch.R, batch.y
        if rows is not None:
            H, PHt, R, y = H[rows], PHt[:, rows], R[rows], y[rows]
            S = S[np.ix_(rows, rows)]
        # S = H P H^T + R
        S += np.diag(R)
        # K = P H^T S^-1   (Cholesky solve of S K^T = H P)
        _, KT, info = lapack.dposv(S, PHt.T)
        if info != 0:
            return                           # S not positive definite: skip this update
        K = KT.T
        # dx = K y
        dx = K @ y
        # P = (I - K H) P (I - K H)^T + K R K^T      (Joseph form)
        A = self._I - K @ H
        P = A @ self._P @ A.T
        P += (K * R) @ KT
        self._P = self._condition(P)
        self._inject(dx)
