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
runs on every other step at most (50 us per step on average in the closed loop).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lapack

from .base import NavFilterBase
from .config import NAV_PARAMS  # noqa: F401  (autopilot.vehicle declares them from here)
from .layout import ABIAS, ATT, BBIAS, GBIAS, GPSB, VEL, WIND


class InsGpsEkf(NavFilterBase):
    """INS/GPS error-state EKF.

    ``InsGpsEkf(params=None, vehicle="plane", origin=None)``; ``update(frame) -> NavState``
    once per IMU step; ``innovations`` (records of the latest update), ``P``,
    ``sigma()``, ``reset()``. The origin is the vehicle's home if given, else the
    first 3D GPS fix.
    """

    SOURCE = "ekf"

    def _reset_covariance_model(self) -> None:
        n = self.n
        self._P = np.eye(n)
        self._F = np.eye(n)          # preallocated; only the dynamic entries are rewritten
        self._I = np.eye(n)
        self._Q = np.zeros((n, n))
        self._q_dt = -1.0
        # flat indices of F's dynamic entries: -[f_n x] dt (6 off-diagonal), -R dt (2 x 9)
        a, b, g, v = ATT.start, ABIAS.start, GBIAS.start, VEL.start
        idx = [(v + 0) * n + a + 1, (v + 0) * n + a + 2, (v + 1) * n + a + 0,
               (v + 1) * n + a + 2, (v + 2) * n + a + 0, (v + 2) * n + a + 1]
        idx += [(v + i) * n + b + j for i in range(3) for j in range(3)]
        idx += [(a + i) * n + g + j for i in range(3) for j in range(3)]
        self._F_idx = np.array(idx)

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

    def _gate_stats(self, batch) -> None:
        H = batch.H
        # P H^T, S = H P H^T (+ R below)
        PHt = self._P @ H.T
        S = H @ PHt
        # y = z - h(x)
        batch.y = batch.z - batch.h0
        batch.Sd = S.diagonal() + batch.R
        self._PHt, self._S = PHt, S

    def _fuse_rows(self, batch, rows) -> None:
        H, PHt, S, R, y = batch.H, self._PHt, self._S, batch.R, batch.y
        if rows is not None:
            H, PHt, R, y = H[rows], PHt[:, rows], R[rows], y[rows]
            S = S[np.ix_(rows, rows)]
        # S = H P H^T + R
        S.flat[:: S.shape[0] + 1] += R
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
