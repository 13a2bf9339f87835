"""INS/GPS error-state unscented Kalman filter (seed ch. 8 sec. 2.1.3).

The same model as :mod:`.ekf` -- nominal state, error-state layout (:mod:`.layout`),
aiding sources, GPS latency, gating, resets, alignment (:mod:`.base`) -- with the
error covariance carried by an unscented transform instead of Jacobians.

Formulation: a UKF over the *error state* with the nominal state propagated separately
(error-state UKF; Sola 2017 for the error definitions, R. van der Merwe's 2004 thesis
"Sigma-point Kalman filters for probabilistic inference in dynamic state-space models"
for the scaled sigma points). filterpy's ``UnscentedKalmanFilter`` with
``MerweScaledSigmaPoints`` holds ``x = dx``, ``P``, Q and the weights; the equations
themselves are the compiled kernels below (autopilot/jit.py: one call per predict and
per update instead of some forty numpy calls). Because the attitude error is a
rotation vector in the tangent space of the nominal attitude, sigma points, means and
residuals are plain vectors: no ``residual_x`` / ``x_mean_fn`` hooks are needed.

* Predict: each sigma point ``dx_i`` is turned into a full state ``x_i = x_nom (+) dx_i``
  (``q_i = Exp(dtheta_i) (x) q``), propagated through the *nonlinear* strapdown
  mechanisation with its own biases, and mapped back against the propagated nominal,
  ``dtheta_i' = Log(q_i' (x) q'^*)`` (:func:`propagate_sigmas`). Q is the EKF's
  (additive). The mean of the propagated error is folded into the nominal state and
  the sigma points re-centred (:func:`ukf_moments`).
* Update: linear rows (GPS, baro) are evaluated on the sigma points through the EKF's
  H; the nonlinear ones (magnetic heading, airspeed, sideslip) exactly (the heading
  about the smoothed Earth field, as the EKF's H, see base.py; :func:`sigma_heading`,
  :func:`sigma_airspeed`, :func:`sigma_sideslip`). One stacked update per step with the
  rows that passed their gates (:func:`ukf_update`; it reuses the prior sigma points,
  so several updates per predict would be wrong); then the mean is folded into the
  nominal state, ``x = 0``.
* P is symmetrised, its diagonal kept within the same floor and ceiling as the EKF.

Sigma-point scaling: alpha = 0.5, beta = 2, kappa = 0 (spread sqrt(n + lambda) = 2.3
sigma for 21 states; a spread of sqrt(n) = 4.6 sigma put attitude sigma points beyond
60 deg right after an in-flight alignment).
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from autopilot.jit import kernel

from .base import S_MREF, S_W0, Batch, NavFilterBase
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


@kernel
def _exp_q(ax, ay, az):
    """Exp: rotation vector -> unit quaternion (qbatch.from_rotvec)."""
    ang = math.sqrt(ax * ax + ay * ay + az * az)
    s = 0.5 if ang < 1e-9 else math.sin(0.5 * ang) / ang
    return math.cos(0.5 * ang), ax * s, ay * s, az * s


@kernel
def _mul_q(pw, px, py, pz, qw, qx, qy, qz):
    """Hamilton product p (x) q (qbatch.mul)."""
    return (pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw)


@kernel
def propagate_sigmas(sig, dt, c, out):
    """The sigma points ``sig`` (rows: error states) through the strapdown mechanisation
    (strapdown.py's equations; Sola 2017 eqs 260-266 for the nominal-state kinematics,
    eq 169 for ``(+)``), each with its own attitude and biases, back to error states
    about the propagated nominal in ``out``. ``c``: nominal before (p, v, q, b_g, b_a)
    and after (p, v, q), f_m, omega_m, w_ie, g, the Gauss-Markov decay a."""
    p0, v0, q0, bg0, ba0 = c[0:3], c[3:6], c[6:10], c[10:13], c[13:16]
    p1n, v1n, q1n = c[16:19], c[19:22], c[22:26]
    f_m, om, w_ie, g, a_gm = c[26:29], c[29:32], c[32:35], c[35], c[36]
    ex, ey, ez = w_ie[0], w_ie[1], w_ie[2]
    h = 0.5 * dt
    for i in range(sig.shape[0]):
        s = sig[i]
        o = out[i]
        for k in range(sig.shape[1]):
            o[k] = s[k]
        # x_i = x_nom (+) dx_i:  p, v added;  q = Exp(dtheta_i) (x) q
        px, py, pz = p0[0] + s[0], p0[1] + s[1], p0[2] + s[2]
        vx, vy, vz = v0[0] + s[3], v0[1] + s[4], v0[2] + s[5]
        dw, dx, dy, dz = _exp_q(s[6], s[7], s[8])
        qw, qx, qy, qz = _mul_q(dw, dx, dy, dz, q0[0], q0[1], q0[2], q0[3])
        ww, xx, yy, zz = qw * qw, qx * qx, qy * qy, qz * qz
        r00, r01, r02 = ww + xx - yy - zz, 2.0 * (qx * qy - qw * qz), 2.0 * (qx * qz + qw * qy)
        r10, r11, r12 = 2.0 * (qx * qy + qw * qz), ww - xx + yy - zz, 2.0 * (qy * qz - qw * qx)
        r20, r21, r22 = 2.0 * (qx * qz - qw * qy), 2.0 * (qy * qz + qw * qx), ww - xx - yy + zz
        # omega = omega_m - b_g - R^T w_ie
        wx = om[0] - (bg0[0] + s[12]) - (r00 * ex + r10 * ey + r20 * ez)
        wy = om[1] - (bg0[1] + s[13]) - (r01 * ex + r11 * ey + r21 * ez)
        wz = om[2] - (bg0[2] + s[14]) - (r02 * ex + r12 * ey + r22 * ez)
        # f = f_m - b_a;  f_n = R (f + 1/2 dt omega x f)
        fx = f_m[0] - (ba0[0] + s[9])
        fy = f_m[1] - (ba0[1] + s[10])
        fz = f_m[2] - (ba0[2] + s[11])
        gx = fx + h * (wy * fz - wz * fy)
        gy = fy + h * (wz * fx - wx * fz)
        gz = fz + h * (wx * fy - wy * fx)
        fnx = r00 * gx + r01 * gy + r02 * gz
        fny = r10 * gx + r11 * gy + r12 * gz
        fnz = r20 * gx + r21 * gy + r22 * gz
        # v' = v + (f_n + g_n - 2 w_ie x v) dt;  p' = p + 1/2 (v + v') dt
        ux = vx + (fnx - 2.0 * (ey * vz - ez * vy)) * dt
        uy = vy + (fny - 2.0 * (ez * vx - ex * vz)) * dt
        uz = vz + (fnz - 2.0 * (ex * vy - ey * vx)) * dt + (g + GRAVITY_GRADIENT * pz) * dt
        o[0] = px + 0.5 * (vx + ux) * dt - p1n[0]
        o[1] = py + 0.5 * (vy + uy) * dt - p1n[1]
        o[2] = pz + 0.5 * (vz + uz) * dt - p1n[2]
        o[3], o[4], o[5] = ux - v1n[0], uy - v1n[1], uz - v1n[2]
        # q' = q (x) Exp(omega dt);  dtheta' = Log(q' (x) q_nom'^*)
        ew, ex_, ey_, ez_ = _exp_q(wx * dt, wy * dt, wz * dt)
        aw, ax, ay, az = _mul_q(qw, qx, qy, qz, ew, ex_, ey_, ez_)
        bw, bx, by, bz = _mul_q(aw, ax, ay, az, q1n[0], -q1n[1], -q1n[2], -q1n[3])
        if bw < 0.0:
            bw, bx, by, bz = -bw, -bx, -by, -bz
        sn = math.sqrt(bx * bx + by * by + bz * bz)
        kk = 2.0 if sn < 1e-12 else 2.0 * math.atan2(sn, bw) / sn
        o[6], o[7], o[8] = bx * kk, by * kk, bz * kk
        # GPS error: Gauss-Markov, b' = a b
        for k in range(16, 19):
            o[k] = s[k] * a_gm


@kernel
def _rotate_exp(ax, ay, az, x, y, z):
    """R(Exp(a)) v: the vector v turned by the rotation vector a (qbatch.to_dcm of
    qbatch.from_rotvec)."""
    w, qx, qy, qz = _exp_q(ax, ay, az)
    ww, xx, yy, zz = w * w, qx * qx, qy * qy, qz * qz
    return ((ww + xx - yy - zz) * x + 2.0 * (qx * qy - w * qz) * y + 2.0 * (qx * qz + w * qy) * z,
            2.0 * (qx * qy + w * qz) * x + (ww - xx + yy - zz) * y + 2.0 * (qy * qz - w * qx) * z,
            2.0 * (qx * qz - w * qy) * x + 2.0 * (qy * qz + w * qx) * y + (ww - xx - yy + zz) * z)


@kernel
def sigma_heading(sig, h0, m, out):
    """Magnetic heading of each sigma point: h_i = h0 + wrap(g(Exp(dtheta_i) m) - g(m)),
    g(m) = atan2(m_E, m_N), the heading of the (smoothed) field turned into NED."""
    g0 = math.atan2(m[1], m[0])
    for i in range(sig.shape[0]):
        mn, me, _ = _rotate_exp(sig[i, 6], sig[i, 7], sig[i, 8], m[0], m[1], m[2])
        out[i] = h0 + ((math.atan2(me, mn) - g0 + math.pi) % (2.0 * math.pi) - math.pi)


@kernel
def sigma_airspeed(sig, v, wind, out):
    """True airspeed of each sigma point: |v + dv_i - (w + dw_i, 0)|."""
    for i in range(sig.shape[0]):
        an = v[0] + sig[i, 3] - (wind[0] + sig[i, 19])
        ae = v[1] + sig[i, 4] - (wind[1] + sig[i, 20])
        ad = v[2] + sig[i, 5]
        out[i] = math.sqrt(an * an + ae * ae + ad * ad)


@kernel
def sigma_sideslip(sig, v, wind, c1, out):
    """Body-y air velocity of each sigma point: (Exp(dtheta_i) c1) . (v_i - w_i), c1 the
    nominal body y axis in NED (the synthetic sideslip measurement, base.py)."""
    for i in range(sig.shape[0]):
        an = v[0] + sig[i, 3] - (wind[0] + sig[i, 19])
        ae = v[1] + sig[i, 4] - (wind[1] + sig[i, 20])
        ad = v[2] + sig[i, 5]
        cx, cy, cz = _rotate_exp(sig[i, 6], sig[i, 7], sig[i, 8], c1[0], c1[1], c1[2])
        out[i] = cx * an + cy * ae + cz * ad


@kernel
def ukf_moments(sf, Wm, Wc, q, qs, qs_idx, floor, ceil, x, P):
    """The unscented transform of the propagated sigma points ``sf`` (van der Merwe 2004
    eqs 3.86-3.87) with the additive process noise and the filter's conditioning:

        x = sum_i Wm_i X_i,   P = sum_i Wc_i (X_i - x)(X_i - x)^T + diag(q) (+ qs at qs_idx)

    then P symmetrised and its diagonal kept within [floor, ceil] (base.py's
    _condition); the sigma points are re-centred on x in place. ``qs``: the IMU
    sampling error (base.py), empty if none."""
    m, n = sf.shape
    x[:] = np.dot(Wm, sf)
    for i in range(m):
        for j in range(n):
            sf[i, j] -= x[j]
    W = np.empty((n, m))
    for i in range(m):
        for j in range(n):
            W[j, i] = sf[i, j] * Wc[i]
    C = np.dot(W, sf)
    for k in range(n):
        C[k, k] += q[k]
    for k in range(qs.shape[0]):
        C.flat[qs_idx[k]] += qs[k]
    for a in range(n):
        for b in range(n):
            P[a, b] = 0.5 * (C[a, b] + C[b, a])
        P[a, a] = min(max(P[a, a], floor[a]), ceil[a])


@kernel
def ukf_update(sf, Zs, Wm, Wc, z, R, floor, ceil, P):
    """The UKF measurement update (van der Merwe 2004 eqs 3.88-3.93) from the sigma points
    ``sf`` (centred on the prior error x = 0) and their predicted measurements ``Zs``:

        z_pred = sum_i Wm_i Z_i,   S = sum_i Wc_i (Z_i - z_pred)(Z_i - z_pred)^T + diag(R)
        P_xz = sum_i Wc_i X_i (Z_i - z_pred)^T,   K = P_xz S^-1
        x = K (z - z_pred),   P' = P - K S K^T

    then P' symmetrised and its diagonal kept within [floor, ceil] (base.py's
    _condition). Returns (x, P'); raises LinAlgError when S is singular."""
    m, n = sf.shape
    zp = np.dot(Wm, Zs)
    dz = Zs - zp
    dzT = np.ascontiguousarray(dz.T)
    WdzT = dzT * Wc
    S = np.dot(WdzT, dz)
    for k in range(S.shape[0]):
        S[k, k] += R[k]
    Pxz = np.dot(np.ascontiguousarray(sf.T) * Wc, dz)
    K = np.dot(Pxz, np.linalg.inv(S))
    x = np.dot(K, z - zp)
    C = P - np.dot(np.dot(K, S), np.ascontiguousarray(K.T))
    out = np.empty((n, n))
    for a in range(n):
        for b in range(n):
            out[a, b] = 0.5 * (C[a, b] + C[b, a])
        out[a, a] = min(max(out[a, a], floor[a]), ceil[a])
    return x, out


# the kernels index the error state by number: the layout it was written for
assert ((POS.start, VEL.start, ATT.start, ABIAS.start, GBIAS.start, GPSB.start, WIND.start)
        == (0, 3, 6, 9, 12, 16, 19))


@kernel
def _sigma_rows(x, A, out):
    """Scaled sigma points (van der Merwe 2004 eqs 3.82-3.85) of mean ``x`` and
    ``A = (n + lambda) P``: chi_0 = x, chi_k = x + U_k, chi_{n+k} = x - U_k with U the
    upper Cholesky factor (U^T U = A, the rows of U = the columns of the lower factor).
    Raises LinAlgError when A is not positive definite."""
    n = x.shape[0]
    L = np.linalg.cholesky(A)
    for j in range(n):
        out[0, j] = x[j]
    for k in range(n):
        for j in range(n):
            u = L[j, k]
            out[k + 1, j] = x[j] + u
            out[n + k + 1, j] = x[j] - u


@kernel
def ukf_predict(x, P, scale, dt, c, Wm, Wc, q, qs, qs_idx, floor, ceil, sig, sf, x_out, P_out):
    """The whole unscented prediction as one call: the sigma points of (x, P) with
    ``A = scale P``, ``scale = alpha^2 (n + kappa)`` (:func:`_sigma_rows`), through the
    mechanisation (:func:`propagate_sigmas`, into ``sf``) and back to (x, P) with the
    process noise and the conditioning (:func:`ukf_moments`, into ``x_out``, ``P_out``).
    ``sig``: scratch for the sigma points. Raises LinAlgError when A is not positive
    definite (the caller then takes the eigen square root)."""
    _sigma_rows(x, scale * P, sig)
    propagate_sigmas(sig, dt, c, sf)
    ukf_moments(sf, Wm, Wc, q, qs, qs_idx, floor, ceil, x_out, P_out)


class _SigmaPoints(MerweScaledSigmaPoints):
    """filterpy's scaled sigma points, built by one kernel (a symmetric eigen square
    root when the covariance has lost positive definiteness to rounding)."""

    def sigma_points(self, x, P):
        n = self.n
        A = (self.alpha ** 2 * (n + self.kappa)) * P
        sigmas = np.empty((2 * n + 1, n))
        try:
            _sigma_rows(x, A, sigmas)
        except np.linalg.LinAlgError:
            U = _robust_sqrt(A)
            sigmas[0] = x
            np.subtract(x, -U, out=sigmas[1:n + 1])
            np.subtract(x, U, out=sigmas[n + 1:])
        return sigmas


class _ErrorStateUKF(UnscentedKalmanFilter):
    """filterpy's UKF as the holder of x, P, Q, the weights and the sigma points, its
    predict done by the kernels (:func:`propagate_sigmas`, :func:`ukf_moments`)."""

    def __init__(self, dim_x, points, **kw):
        super().__init__(dim_x=dim_x, points=points, **kw)
        self._sig = np.empty((2 * dim_x + 1, dim_x))            # scratch: the sigma points
        self._scale = points.alpha ** 2 * (dim_x + points.kappa)  # A = scale P (sigma_points)

    def predict(self, dt=None, c=None, q=None, qs=None, floor=None, ceil=None, qs_idx=None):
        """Sigma points of (x, P), through the process model, and back to (x, P) with
        the process noise ``q`` (diagonal) and the conditioning (:func:`ukf_moments`);
        ``sigmas_f`` are left centred on the new x. One kernel call
        (:func:`ukf_predict`) unless the covariance has lost positive definiteness."""
        n = self._dim_x
        sf = np.empty((2 * n + 1, n))
        x = np.empty(n)
        P = np.empty((n, n))
        try:
            ukf_predict(self.x, self.P, self._scale, dt, c, self.Wm, self.Wc,
                        q, qs, qs_idx, floor, ceil, self._sig, sf, x, P)
        except np.linalg.LinAlgError:
            propagate_sigmas(self.points_fn.sigma_points(self.x, self.P), dt, c, sf)
            ukf_moments(sf, self.Wm, self.Wc, q, qs, qs_idx, floor, ceil, x, P)
        self.sigmas_f = sf
        self.x, self.P = x, P


class InsGpsUkf(NavFilterBase):
    """INS/GPS error-state UKF; the same interface as :class:`~autopilot.nav.ekf.InsGpsEkf`."""

    SOURCE = "ukf"

    def _reset_covariance_model(self) -> None:
        n = self.n
        points = _SigmaPoints(n, alpha=UKF_ALPHA, beta=UKF_BETA, kappa=UKF_KAPPA,
                              sqrt_method=_robust_sqrt)
        ukf = _ErrorStateUKF(n, points, dim_z=1, dt=0.01, hx=None, fx=None)
        ukf.x = np.zeros(n)
        self._ukf = ukf
        self._set_P(np.eye(n))
        self._Wm = np.asarray(points.Wm)
        self._Wc = np.asarray(points.Wc)
        self._q_dt = -1.0
        self._Zs = None
        self._zero = np.zeros(n)                  # dx after every injection (never written)
        self._zero.flags.writeable = False
        self._qs_idx_a = np.array(self._qs_idx, dtype=np.int64)

    @property
    def P(self) -> np.ndarray:
        return self._ukf.P

    def _set_P(self, P: np.ndarray) -> None:
        self._ukf.P = P
        self._P_ver += 1

    def _init_covariance(self, sd: np.ndarray) -> None:
        self._ukf.x = np.zeros(self.n)
        self._set_P(np.diag(np.asarray(sd, dtype=float) ** 2))

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
        self._qdiag = q
        self._q_dt = dt

    # ------------------------------------------------------------------- predict --
    def _predict(self, dt: float, f1, w1, t: int) -> None:
        if dt != self._q_dt:
            self._process_noise(dt)
        nom = self.nom
        c = [*nom.p, *nom.v, *nom.q, *nom.bg, *nom.ba]          # the nominal before ...
        w0 = self._s[S_W0:S_W0 + 3].tolist()                    # (the last step's rate)
        a = self._propagate_nominal(dt, f1, w1, t)
        # ... and after, the IMU samples as the mechanisation took them (the specific
        # force at the step's end, the trapezoid of the rates), w_ie, g, the Gauss-Markov decay
        c = np.array(c + nom.p + nom.v + nom.q
                     + [*f1, 0.5 * (w0[0] + w1[0]), 0.5 * (w0[1] + w1[1]), 0.5 * (w0[2] + w1[2]),
                        *self._w_ie, self._g, a])
        ukf = self._ukf
        lam = self.q_scale_hook(dt) if self.q_scale_hook is not None else None
        # additive (Lambda) Q: the fading matrix of seed eq 2.40 (base.py hooks) scales it
        q = self._qdiag if lam is None else self._qdiag * np.asarray(lam, dtype=float)
        # the sampling error of the IMU samples (base.py) where it exceeds Q
        qs = self._take_sampling_error()
        ukf.predict(dt=dt, c=c, q=q, qs=qs, floor=self._floor, ceil=self._ceil, qs_idx=self._qs_idx_a)
        self._P_ver += 1
        # fold the mean error into the nominal state (the sigma points are centred on it)
        self._inject(ukf.x)
        ukf.x = self._zero
        self._rewrite_history(t)

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
                col = np.empty(len(sig))
                sigma_heading(sig, float(batch.h0[r]), self._s[S_MREF:S_MREF + 3].copy(), col)
                Zs[:, r] = col
            elif name == "airspeed":
                col = np.empty(len(sig))
                sigma_airspeed(sig, np.array(nom.v), np.array(nom.wind), col)
                Zs[:, r] = col
            elif name == "sideslip":
                col = np.empty(len(sig))
                sigma_sideslip(sig, np.array(nom.v), np.array(nom.wind), np.array(nom.R[1::3]), col)
                Zs[:, r] = col
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
        ukf = self._ukf
        try:
            x, ukf.P = ukf_update(ukf.sigmas_f, np.ascontiguousarray(Zs), self._Wm, self._Wc, z, R,
                                  self._floor, self._ceil, ukf.P)
        except np.linalg.LinAlgError:
            return
        self._P_ver += 1
        self._inject(x)
