"""Chi-square statistics of the normalised innovation (seed ch. 8 sec. 2.2.1-2.2.2, 2.3.3.1).

The seed's equations lost their subscripts in extraction; they are rebuilt here from
C. Hajiyev and F. Caliskan, "Fault Diagnosis and Reconfiguration in Flight Control
Systems", Kluwer (2003), ch. 5-6 (and Hajiyev & Caliskan 2000, "Sensor/actuator fault
diagnosis based on statistical analysis of innovation sequence and robust Kalman
filtering", Aerosp. Sci. Technol. 4), which the seed's sections 2.2-2.3 summarise.

Normalised innovation (eq 2.13), with ``e_k = z_k - h(x_k|k-1)`` and
``S_k = H_k P_k|k-1 H_k^T + R_k``::

    Delta_k = S_k^(-1/2) e_k                       ~ N(0, I_s) under H0

The innovation records carry diag(S) only, so ``S^(-1/2)`` is taken as
``diag(S)^(-1/2)`` (the cross-covariance of a GPS fix's three axes is neglected).

Detection over a sliding window of the last M samples (eqs 2.12, 2.14, 2.15)::

    beta_k = sum_{j=k-M+1..k} Delta_j^T Delta_j     ~ chi2(M s)
    P(beta_k > chi2_{alpha, M s}) = alpha;   H1 (fault) if beta_k > chi2_{alpha, M s}

The detection test is repeated at every sample for a whole flight, so its alpha is set
from a family-wise false-alarm probability per flight hour (:func:`family_alpha`).

Per-step statistic of the RAKF (eqs 2.41-2.43)::

    chi_k = e_k^T (H P H^T + R)^-1 e_k = Delta_k^T Delta_k   ~ chi2(s)
    H1 if chi_k > chi2_{alpha, s}

Isolation (eqs 2.16-2.17), per one-dimensional component i of the innovation::

    mean_k(i)     = 1/M sum_j Delta_j(i)
    sigma2_k(i)   = 1/(M-1) sum_j (Delta_j(i) - mean_k(i))^2       (sample variance)
    gamma_k(i)    = (M - 1) sigma2_k(i) / sigma2(i)                 ~ chi2(M-1)  (2.16)
                  = (M - 1) sigma2_k(i)   since sigma2(i) = 1 for Delta (2.17)

The channel whose ``gamma / chi2_{alpha, M-1}`` is the largest and above 1 is the faulty
one (the seed's ``max gamma_k(i) = gamma_k(m)`` rule, with the statistics divided by
their own thresholds so that channels of different dimension compare).

Cost: every statistic is a running sum over a ring of M samples (one add, one
subtract per sample; re-summed every 64 windows against round-off). The chi-square
quantiles are computed once, at construction (scipy.stats.chi2.ppf's own formula,
``2 gammaincinv(dof / 2, 1 - alpha)``, from scipy.special: importing scipy.stats costs
more start-up time than the rest of the autopilot).
"""
from __future__ import annotations

import math

import numpy as np
from numba.core import types
from numba.extending import intrinsic
from scipy.special import gammaincinv as _gammaincinv

from autopilot.jit import cholesky_gain, cholesky_lower, kernel


def chi2_threshold(alpha: float, dof: int) -> float:
    """chi2_{alpha, dof}: the (1 - alpha) quantile (eqs 2.14, 2.42)."""
    return float(2.0 * _gammaincinv(0.5 * dof, 1.0 - alpha))


def family_alpha(p_fa: float, tests: float) -> float:
    """Level of significance of one test such that ``tests`` of them together raise a
    false alarm with probability at most ``p_fa`` (Bonferroni: ``alpha = p_fa / tests``).

    The seed's alpha (2.14) is the probability that *one* window test exceeds its
    threshold under H0. A monitor repeats the test at every sample of every channel:
    about 6e4 tests per flight hour here, so alpha = 1e-4 means a few false alarms per
    flight hour however well the filter's innovation covariance is modelled. The
    windows overlap (successive tests share M-1 samples), which makes the bound
    conservative: for white innovations, M = 10, s = 3, 18000 windows, the Monte-Carlo
    family-wise rate is 0.55 of the bound (effective number of independent tests
    ~1e4 of 1.8e4; 400 simulated hours, see tests/test_monitor_stats.py)."""
    return min(max(p_fa / max(tests, 1.0), 1e-15), 0.5)


class WindowChi2:
    """Sliding-window statistics of one s-dimensional innovation channel.

    ``push(delta)`` takes one normalised innovation (a list of s floats) and updates
    beta (2.12), chi (2.41) and the per-component gamma (2.16-2.17). ``ratio_det``,
    ``ratio_step`` and ``ratio_iso`` are the statistics divided by their thresholds
    (> 1: hypothesis H1). ``full`` once M samples have been seen. ``alpha`` is the level
    of the per-step and isolation tests; ``alpha_det`` (default ``alpha``) that of the
    window detection test, which runs at every sample of a whole flight (see
    :func:`family_alpha`).
    """

    __slots__ = ("s", "M", "thr_det", "thr_step", "thr_iso", "_q", "_x", "_i", "n",
                 "_sq", "_sx", "_sxx", "beta", "chi", "gamma", "_resum")

    def __init__(self, s: int, M: int, alpha: float, alpha_det: float | None = None):
        self.s, self.M = s, M
        self.thr_det = chi2_threshold(alpha if alpha_det is None else alpha_det, M * s)  # (2.14)
        self.thr_step = chi2_threshold(alpha, s)         # chi2_{alpha, s}     (2.42)
        self.thr_iso = chi2_threshold(alpha, M - 1)      # chi2_{alpha, M-1}   (2.17)
        self.reset()

    def reset(self) -> None:
        M, s = self.M, self.s
        self._q = [0.0] * M                 # Delta_j^T Delta_j of the window
        self._x = [[0.0] * s for _ in range(M)]
        self._i = 0
        self.n = 0
        self._sq = 0.0
        self._sx = [0.0] * s
        self._sxx = [0.0] * s
        self.beta = 0.0
        self.chi = 0.0
        self.gamma = 0.0                    # max over components
        self._resum = 0

    @property
    def full(self) -> bool:
        return self.n >= self.M

    def push(self, d: list[float]) -> None:
        i = self._i
        old = self._x[i]
        # chi_k = Delta_k^T Delta_k   (2.41)
        q = 0.0
        sx, sxx = self._sx, self._sxx
        for c in range(self.s):
            v = d[c]
            q += v * v
            o = old[c]
            sx[c] += v - o
            sxx[c] += v * v - o * o
        self._sq += q - self._q[i]
        self._q[i] = q
        self._x[i] = d
        self._i = (i + 1) % self.M
        self.n += 1
        self.chi = q
        if self._i == 0:
            self._resum += 1
            if self._resum >= 64:           # running sums: bound the round-off
                self._resum = 0
                self._sq = math.fsum(self._q)
                for c in range(self.s):
                    self._sx[c] = math.fsum(x[c] for x in self._x)
                    self._sxx[c] = math.fsum(x[c] * x[c] for x in self._x)
        if self.n < self.M:
            return
        # beta_k = sum_{j=k-M+1..k} Delta_j^T Delta_j   (2.12)
        self.beta = self._sq
        # gamma_k(i) = (M-1) sigma2_k(i) = sum Delta^2 - (sum Delta)^2 / M   (2.16-2.17)
        M = self.M
        g = 0.0
        for c in range(self.s):
            v = sxx[c] - sx[c] * sx[c] / M
            if v > g:
                g = v
        self.gamma = g

    @property
    def mean_share(self) -> float:
        """Share of the window statistic beta held by the window means: sum_i M
        mean_k(i)^2 / beta (the rest, sum_i gamma_k(i), is the spread about them). About
        1/M for white innovations; over 1/2 for a drift (a mean that moves slowly)."""
        if self.n < self.M or self._sq <= 0.0:
            return 0.0
        m2 = 0.0
        for c in range(self.s):
            m2 += self._sx[c] * self._sx[c]
        return m2 / self.M / self._sq

    @property
    def ratio_det(self) -> float:
        return self.beta / self.thr_det if self.n >= self.M else 0.0

    @property
    def ratio_step(self) -> float:
        return self.chi / self.thr_step

    @property
    def ratio_iso(self) -> float:
        return self.gamma / self.thr_iso if self.n >= self.M else 0.0


# ---- small products summed as numpy's BLAS sums them ------------------------------
# numpy's ``a.dot(b)`` and ``np.linalg.solve`` run OpenBLAS, whose x86-64 kernels (the
# ones it picks on a CPU with FMA, as every machine this project is measured on) sum
# these small products with fused multiply-adds (one rounding for a product and its
# sum): the kernels below sum in the same order with the same operation, so that moving
# a 10 Hz sample's products from numpy into one compiled call left the flights bit for
# bit as they were there. Their results no longer depend on which kernel OpenBLAS picks
# on a CPU (tests/test_speed_s38_mon.py checks them against numpy to rounding error)

@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM's fused multiply-add)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)
    return sig, codegen


@kernel
def blas_dot(x, y):
    """``x.dot(y)`` of two vectors: the products summed in order, each with its sum
    (ddot)."""
    d = 0.0
    for i in range(x.shape[0]):
        d = fma(x[i], y[i], d)
    return d


@kernel
def blas_matvec(P, x, out):
    """``out = P.dot(x)`` for a 2 x 2 or 3 x 3 ``P`` (the only sizes here): each row's
    products as dgemv's short rows sum them, the first with the second's product, then
    the third's."""
    for i in range(P.shape[0]):
        if P.shape[1] == 2:
            out[i] = fma(P[i, 0], x[0], P[i, 1] * x[1])
        else:
            out[i] = fma(P[i, 2], x[2], fma(P[i, 0], x[0], P[i, 1] * x[1]))


@kernel
def solve3(A, y0, y1, y2):
    """``np.linalg.solve(A, (y0, y1, y2))`` for a 3 x 3 ``A``, as a tuple: its LU
    factorisation with partial pivoting, left-looking (each column brought up to date by
    the columns before it, then its pivot, the largest magnitude, swapped up, the column
    under it scaled by the pivot's reciprocal; dgetf2), then the forward substitution
    with the unit lower factor and the back substitution with the upper one, each solved
    entry taken out of those still to solve (dgetrs). (A singular: ZeroDivisionError.)"""
    a = A.copy()
    piv = np.empty(3, np.int64)
    for j in range(3):
        for i in range(j):                      # the earlier columns' swaps on this one
            p = piv[i]
            if p != i:
                a[i, j], a[p, j] = a[p, j], a[i, j]
        for i in range(1, j):                   # the unit lower factor's solve above the pivot
            d = 0.0
            for k in range(i):
                d = fma(a[i, k], a[k, j], d)
            a[i, j] = a[i, j] - d
        for i in range(j, 3):                   # the rows from the pivot's down
            t = 0.0
            for k in range(j):
                t = fma(a[i, k], a[k, j], t)
            a[i, j] = a[i, j] - t
        p = j
        for i in range(j + 1, 3):
            if abs(a[i, j]) > abs(a[p, j]):
                p = i
        piv[j] = p
        r = 1.0 / a[p, j]
        if p != j:
            for k in range(j + 1):
                a[j, k], a[p, k] = a[p, k], a[j, k]
        for i in range(j + 1, 3):
            a[i, j] = r * a[i, j]
    x = np.array((y0, y1, y2))
    for i in range(3):
        p = piv[i]
        if p != i:
            x[i], x[p] = x[p], x[i]
    for i in range(3):
        for k in range(i + 1, 3):
            x[k] = fma(-x[i], a[k, i], x[k])
    for i in range(2, -1, -1):
        x[i] = x[i] / a[i, i]
        for k in range(i):
            x[k] = fma(-x[i], a[k, i], x[k])
    return x[0], x[1], x[2]


@kernel
def stage2_update(gamma, P, H, e, r, q):
    """Stage 2 of the two-stage filters (the elevator's [k, s], actuator.py; the rotors'
    effectiveness, motors.py): one Kalman step over the fault parameters gamma (eqs
    2.20-2.24) with the faded process noise of eq 2.40, innovation ``e`` = z - H gamma:

        P- = P + q I                       (q = lambda Q, Q = q0 I)
        S = H P- H^T + diag(r),   K = P- H^T S^-1
        gamma' = gamma + K e
        P' = (I - K H) P- (I - K H)^T + K diag(r) K^T     (Joseph form), symmetrised

    H is m x n (m measurements of n parameters). Returns (gamma', P'); unchanged copies
    when S is not positive definite (it always is: r > 0)."""
    n = gamma.shape[0]
    m = H.shape[0]
    Pm = P.copy()
    for i in range(n):
        Pm[i, i] += q
    PHt = np.zeros((n, m))                      # P- H^T
    for i in range(n):
        for k in range(m):
            acc = 0.0
            for j in range(n):
                acc += Pm[i, j] * H[k, j]
            PHt[i, k] = acc
    S = np.zeros((m, m))                        # H P- H^T
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for k in range(n):
                acc += H[i, k] * PHt[k, j]
            S[i, j] = acc
    L = np.zeros((m, m))
    if not cholesky_lower(S, r, L):
        return gamma.copy(), P.copy()           # not positive definite: no update
    KT = np.empty((m, n))                       # K^T = S^-1 (P- H^T)^T
    cholesky_gain(L, PHt, KT)
    g = gamma.copy()
    A = np.eye(n)                               # I - K H
    for k in range(m):
        for i in range(n):
            g[i] += KT[k, i] * e[k]
            for j in range(n):
                A[i, j] -= KT[k, i] * H[k, j]
    AP = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            a = A[i, k]
            for j in range(n):
                AP[i, j] += a * Pm[k, j]
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += AP[i, k] * A[j, k]
            for k in range(m):
                acc += KT[k, i] * r[k] * KT[k, j]
            out[i, j] = acc
    for i in range(n):
        for j in range(i + 1, n):
            v = 0.5 * (out[i, j] + out[j, i])
            out[i, j] = v
            out[j, i] = v
    return g, out
