"""INS/GPS error-state unscented Kalman filter (seed ch. 8 sec. 2.1.3), built on filterpy.

The same model as :mod:`.ekf` -- nominal state, error-state layout (:mod:`.layout`),
aiding sources, GPS latency, gating, resets, alignment (:mod:`.base`) -- with the
error covariance carried by an unscented transform instead of Jacobians.

Formulation: a UKF over the *error state* with the nominal state propagated separately
(error-state UKF; Sola 2017 for the error definitions, R. van der Merwe's 2004 thesis
"Sigma-point Kalman filters for probabilistic inference in dynamic state-space models"
for the scaled sigma points). filterpy's ``UnscentedKalmanFilter`` with
``MerweScaledSigmaPoints`` holds ``x = dx`` and ``P``. Because the attitude error is a
rotation vector in the tangent space of the nominal attitude, sigma points, means and
residuals are plain vectors: no ``residual_x`` / ``x_mean_fn`` hooks are needed.

* Predict: each sigma point ``dx_i`` is turned into a full state ``x_i = x_nom (+) dx_i``
  (``q_i = Exp(dtheta_i) (x) q``), propagated through the *nonlinear* strapdown
  mechanisation with its own biases, and mapped back against the propagated nominal,
  ``dtheta_i' = Log(q_i' (x) q'^*)``. All sigma points at once (vectorised override of
  ``compute_process_sigmas``). Q is the EKF's (additive). The mean of the propagated
  error is folded into the nominal state and the sigma points re-centred.
* Update: linear rows (GPS, baro) are evaluated on the sigma points through the EKF's
  H; the nonlinear ones (magnetic heading, airspeed, sideslip) exactly (the heading
  about the smoothed Earth field, as the EKF's H, see base.py). One stacked
  filterpy ``update`` per step with the rows that passed their gates (filterpy reuses
  the prior sigma points for every update of a step, so several updates per predict
  would be wrong); then the mean is folded into the nominal state, ``x = 0``.
* P is symmetrised, its diagonal kept within the same floor and ceiling as the EKF.

Sigma-point scaling: alpha = 0.5, beta = 2, kappa = 0 (spread sqrt(n + lambda) = 2.3
sigma for 21 states; a spread of sqrt(n) = 4.6 sigma put attitude sigma points beyond
60 deg right after an in-flight alignment).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from . import qbatch
from .base import Batch, NavFilterBase
from .layout import ABIAS, ATT, BBIAS, GBIAS, GPSB, POS, VEL, WIND
from .strapdown import GRAVITY_GRADIENT

UKF_ALPHA = 0.5
UKF_BETA = 2.0
UKF_KAPPA = 0.0


def _robust_sqrt(A: np.ndarray) -> np.ndarray:
    """U with U^T U = A: Cholesky, or a symmetric eigen square root when A has lost
    positive definiteness to rounding."""
    try:
        return scipy.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (A + A.T))
        return (V * np.sqrt(np.maximum(w, 0.0))).T


class _ErrorStateUKF(UnscentedKalmanFilter):
    """filterpy's UKF with the process model applied to all sigma points at once and a
    vectorised cross-covariance (same results as the per-point loops)."""

    def compute_process_sigmas(self, dt, fx=None, **fx_args):
        fx = self.fx if fx is None else fx
        sigmas = self.points_fn.sigma_points(self.x, self.P)
        self.sigmas_f = fx(sigmas, dt, **fx_args)

    def cross_variance(self, x, z, sigmas_f, sigmas_h):
        # P_xz = sum_i Wc_i (X_i - x)(Z_i - z)^T
        return ((sigmas_f - x) * self.Wc[:, None]).T @ (sigmas_h - z)


class InsGpsUkf(NavFilterBase):
    """INS/GPS error-state UKF; the same interface as :class:`~autopilot.nav.ekf.InsGpsEkf`."""

    SOURCE = "ukf"

    def _reset_covariance_model(self) -> None:
        n = self.n
        points = MerweScaledSigmaPoints(n, alpha=UKF_ALPHA, beta=UKF_BETA, kappa=UKF_KAPPA,
                                        sqrt_method=_robust_sqrt)
        ukf = _ErrorStateUKF(dim_x=n, dim_z=1, dt=0.01, hx=None, fx=self._fx, points=points)
        ukf.x = np.zeros(n)
        ukf.P = np.eye(n)
        self._ukf = ukf
        self._Wm = np.asarray(points.Wm)
        self._Wc = np.asarray(points.Wc)
        self._q_dt = -1.0
        self._Zs = None

    @property
    def P(self) -> np.ndarray:
        return self._ukf.P

    def _set_P(self, P: np.ndarray) -> None:
        self._ukf.P = P

    def _init_covariance(self, sd: np.ndarray) -> None:
        self._ukf.x = np.zeros(self.n)
        self._ukf.P = np.diag(np.asarray(sd, dtype=float) ** 2)

    def _process_noise(self, dt: float) -> None:
        prm = self.params
        q = np.zeros(self.n)
        q[VEL] = (prm["EK_ACC_NSE"] * dt) ** 2
        q[ATT] = (prm["EK_GYR_NSE"] * dt) ** 2
        q[ABIAS] = prm["EK_ACCB_NSE"] ** 2 * dt
        q[GBIAS] = prm["EK_GYRB_NSE"] ** 2 * dt
        q[BBIAS] = prm["EK_BAROB_NSE"] ** 2 * dt
        a = np.exp(-dt / prm["EK_GPSB_TAU"])
        q[GPSB] = np.array(self._gm_sd()) ** 2 * (1.0 - a * a)
        if self.is_plane:
            q[WIND] = prm["EK_WIND_NSE"] ** 2 * dt
        self._ukf.Q = np.diag(q)
        self._q_dt = dt

    # ------------------------------------------------------------------- predict --
    def _fx(self, sig: np.ndarray, dt: float, nom0, nom1, f_m, omega_m, a_gm) -> np.ndarray:
        """Propagate error-state sigma points (rows) through the nonlinear mechanisation
        (strapdown.py's equations, every sigma point with its own attitude and biases)."""
        g = self._g
        w_ie = np.asarray(self._w_ie)
        p = np.asarray(nom0.p) + sig[:, POS]
        v = np.asarray(nom0.v) + sig[:, VEL]
        q = qbatch.mul(qbatch.from_rotvec(sig[:, ATT]), np.asarray(nom0.q))
        Rs = qbatch.to_dcm(q)
        # omega = omega_m - b_g - R^T w_ie
        w = np.asarray(omega_m) - (np.asarray(nom0.bg) + sig[:, GBIAS]) - np.einsum("nji,j->ni", Rs, w_ie)
        f = np.asarray(f_m) - (np.asarray(nom0.ba) + sig[:, ABIAS])
        # f + 1/2 dt omega x f, rotated to NED
        fg = f + 0.5 * dt * qbatch.cross(w, f)
        f_n = np.einsum("nij,nj->ni", Rs, fg)
        # v' = v + (f_n + g_n - 2 w_ie x v) dt
        v1 = v + (f_n - 2.0 * qbatch.cross(w_ie, v)) * dt
        v1[:, 2] += (g + GRAVITY_GRADIENT * p[:, 2]) * dt
        p1 = p + 0.5 * (v + v1) * dt
        q1 = qbatch.mul(q, qbatch.from_rotvec(w * dt))
        out = sig.copy()
        out[:, POS] = p1 - np.asarray(nom1.p)
        out[:, VEL] = v1 - np.asarray(nom1.v)
        out[:, ATT] = qbatch.to_rotvec(qbatch.mul(q1, qbatch.conj(np.asarray(nom1.q))))
        out[:, GPSB] = sig[:, GPSB] * a_gm
        return out

    def _predict(self, dt: float, f_m: np.ndarray, omega_m: np.ndarray) -> None:
        if dt != self._q_dt:
            self._process_noise(dt)
        nom0 = self.nom.copy()
        a = self._propagate_nominal(dt, f_m, omega_m)
        ukf = self._ukf
        lam = self.q_scale_hook(dt) if self.q_scale_hook is not None else None
        if lam is None:
            ukf.predict(dt=dt, nom0=nom0, nom1=self.nom, f_m=f_m, omega_m=omega_m, a_gm=a)
        else:
            # additive Lambda Q (fading matrix, seed eq 2.40; base.py hooks)
            Q = ukf.Q
            ukf.Q = Q * np.asarray(lam, dtype=float)[:, None]
            try:
                ukf.predict(dt=dt, nom0=nom0, nom1=self.nom, f_m=f_m, omega_m=omega_m, a_gm=a)
            finally:
                ukf.Q = Q
        if self._q_sample is not None:            # sampling error of the IMU samples (base.py)
            ukf.P.flat[self._qs_idx] += self._q_sample
        ukf.P = self._condition(ukf.P)
        # fold the mean error into the nominal state; re-centre the sigma points on it
        x = ukf.x
        self._inject(x)
        ukf.sigmas_f = ukf.sigmas_f - x
        ukf.x = np.zeros(self.n)

    # -------------------------------------------------------------------- update --
    def _sigma_measurements(self, batch: Batch, sig: np.ndarray) -> np.ndarray:
        """Predicted measurements of every sigma point, shape (N, m)."""
        Zs = batch.h0 + sig @ batch.H.T               # linear rows: h(x_nom) + H dx_i
        nom = self.nom
        for k, name in enumerate(batch.src):
            r = batch.start[k]
            if name == "mag":
                # h_i = yaw + (g(x_i) - g(x_nom)),  g = heading of the field rotated into NED;
                # about the smoothed field, as the EKF's H (noise in the spread of the
                # sigma points would correlate with the noise of the innovation)
                m = np.asarray(self._m_ref)
                m_i = np.einsum("nij,j->ni", qbatch.to_dcm(qbatch.from_rotvec(sig[:, ATT])), m)
                dg = np.arctan2(m_i[:, 1], m_i[:, 0]) - np.arctan2(m[1], m[0])
                Zs[:, r] = batch.h0[r] + (dg + np.pi) % (2.0 * np.pi) - np.pi
            elif name == "airspeed":
                vr = np.asarray(nom.v) + sig[:, VEL]
                vr[:, :2] -= np.asarray(nom.wind) + sig[:, WIND]
                Zs[:, r] = np.sqrt(np.einsum("ni,ni->n", vr, vr))
            elif name == "sideslip":
                vr = np.asarray(nom.v) + sig[:, VEL]
                vr[:, :2] -= np.asarray(nom.wind) + sig[:, WIND]
                c1 = np.array(nom.R[1::3])            # body y axis in NED
                c1_i = np.einsum("nij,j->ni", qbatch.to_dcm(qbatch.from_rotvec(sig[:, ATT])), c1)
                Zs[:, r] = np.einsum("ni,ni->n", c1_i, vr)
        return Zs

    def _gate_stats(self, batch: Batch) -> None:
        ukf = self._ukf
        Zs = self._sigma_measurements(batch, ukf.sigmas_f)
        # z_pred = sum Wm_i Z_i;  S = sum Wc_i (Z_i - z_pred)(Z_i - z_pred)^T + R
        zp = self._Wm @ Zs
        dZ = Zs - zp
        batch.Sd = np.einsum("i,ij,ij->j", self._Wc, dZ, dZ) + batch.R
        batch.y = batch.z - zp
        self._Zs = Zs

    def _fuse_rows(self, batch: Batch, rows) -> None:
        Zs, z, R = self._Zs, batch.z, batch.R
        if rows is not None:
            Zs, z, R = Zs[:, rows], z[rows], R[rows]
        rows_iter = iter(Zs)
        ukf = self._ukf
        try:
            # filterpy evaluates hx on its sigma points in order: hand it the rows above
            ukf.update(z, R=np.diag(R), hx=lambda s: next(rows_iter))
        except np.linalg.LinAlgError:
            return
        ukf.P = self._condition(ukf.P)
        self._inject(ukf.x)
        ukf.x = np.zeros(self.n)
