"""R adaptation: the robust Kalman filter with noise scale factors (seed ch. 8 sec. 2.3.1).

Rebuilt from Hajiyev & Caliskan (2003), "Fault Diagnosis and Reconfiguration in Flight
Control Systems", ch. 6 (the seed's eqs 2.25-2.34 lost their subscripts). With
``e_k`` the innovation and ``P_k/k-1`` the predicted covariance, a sensor fault shows
as a real innovation covariance larger than the theoretical one; a scale factor on R
restores the balance::

    E[e_k e_k^T] = H P_k/k-1 H^T + S_k R_k                                    (2.25)

Single measurement noise scale factor (SNSF, eqs 2.26-2.29), taking traces of the one-
sample estimate ``e_k e_k^T`` of the left side::

    tr(e_k e_k^T) = tr(H P H^T) + S_k tr(R_k)                                 (2.28)
    S_k = (e_k^T e_k - tr(H P H^T)) / tr(R_k),  used as max(1, S_k)           (2.29)

Multiple measurement noise scale factors (MMNSF, eqs 2.30-2.34)::

    e_k e_k^T - H P H^T = S_k R_k                                             (2.30)
    S_k = (e_k e_k^T - H P H^T) R_k^-1                                        (2.31)
    S*_k = diag(s_1 .. s_n),  s_i = max(1, S_ii)                              (2.32-2.33)
    K_k = P H^T (H P H^T + S*_k R_k)^-1                                       (2.34)

With a diagonal R the diagonal of (2.31) is ``S_ii = (e_i^2 - (H P H^T)_ii) / R_ii``.
Outside a detected fault the factors are 1: the optimal filter (OKF).

The innovation covariance over a window (``window`` > 1, FDI_RWIN, the default): the
one-sample estimate ``e_k e_k^T`` of (2.25) is the seed's; Hajiyev & Caliskan's Q
adaptation (eq 2.35) and the isolation statistic (2.16) use the sample over the last M
innovations instead, and so does this module for R: ``e_i^2`` is replaced by the
sample variance of component i over the last M innovations (mean removed)::

    sigma2_k(i) = 1/(M-1) sum_{j=k-M+1..k} (e_j(i) - mean_k(i))^2
    S_ii = (sigma2_k(i) - (H P H^T)_ii) / R_ii,  s_i = max(1, S_ii)
    single factor: S = (sum_i sigma2_k(i) - tr(H P H^T)) / tr(R)

Why: the one-sample factor is a chi2(1) draw times the true factor, so single fixes
with a small draw enter with almost their nominal weight; and it counts the filter's own
slowly varying error (the mean of the innovations) as measurement noise, so while dead
reckoning drifts the factor grows with the drift and keeps the filter from correcting
it: after a GPS-noise fault ended, the drift held the statistics over their thresholds
and the adaptation on, and the robust filter did no better than the plain EKF
(docs/status.md, "Why the monitor is built as it is"). The windowed variance measures
the noise and leaves the mean, the filter's error, to be corrected; its factor returns
to about 1 within M samples of the fault's end.

The navigation filter hook
--------------------------
The factors are applied inside the filter's update, after ``e`` and ``H P H^T`` are
known and before the gate, through ``NavFilterBase.r_scale_hook`` (autopilot/nav/base.py):
``hook(source, y, hph_diag, r_diag)`` (tuples of floats) returns the factors of that
source's rows or None (the optimal filter, bit for bit). :func:`attach` installs :meth:`RAdapter.scale` there.
"""
from __future__ import annotations

import numpy as np

R_OFF, R_SINGLE, R_MULTIPLE = 0, 1, 2


class RAdapter:
    """Computes the R scale factors of the sources named in ``active``.

    ``mode``: 0 off (OKF), 1 single factor (2.29), 2 multiple factors (2.33).
    ``window``: innovations in the covariance estimate (1: the one-sample form of the
    seed; M > 1: the sample variance over the last M, module docstring).
    ``active``: the set of source names being adapted (the fault monitor fills it).
    ``last``: source -> the factors of the latest step (for the log); ``okf_sd``:
    source -> diag(H P H^T + R) with the unscaled R (a tuple of floats, as the innovation
    records' vectors, autopilot/nav/records.py), so the monitor keeps testing the
    optimal filter's statistic while the adapted filter runs (otherwise the adaptation
    would hide the fault from the test that switches it off). ``hook``: the filter's hook
    (:func:`attach`); with no source adapted its owner may take it off the filter and
    hand the fusions' records to :meth:`observe` instead.
    """

    def __init__(self, mode: int = R_MULTIPLE, window: int = 1,
                 watch: tuple[str, ...] = ("gps_pos", "gps_vel", "baro", "mag", "airspeed")):
        self.mode = int(mode)
        self.window = max(1, int(window))
        self.active: set[str] = set()
        self.last: dict[str, np.ndarray] = {}
        self.okf_sd: dict[str, tuple] = {}
        self.attached = False
        self._watch = frozenset(watch) if self.window > 1 else frozenset()
        # source -> [M rows (tuples of s floats), next index, count]: kept at every fusion and
        # read only while adapting, so its rows are the cheaper tuples, made an array then
        self._ring: dict[str, list] = {}
        self.hook = None

    def observe(self, records) -> None:
        """The filter's innovation records of a step it fused with no hook (no source
        adapted): what the hook returns None for does with them, each innovation
        remembered and an earlier adaptation's factors of its source forgotten."""
        watch, okf_sd = self._watch, self.okf_sd
        for rec in records:
            if rec.source in watch:
                self._remember(rec.source, rec.innovation)
            if okf_sd:                    # (as the hook: empty but after adapting)
                okf_sd.pop(rec.source, None)
                self.last.pop(rec.source, None)

    def _remember(self, source: str, y) -> None:
        ring = self._ring.get(source)
        if ring is None or len(ring[0][0]) != len(y):
            ring = self._ring[source] = [[[0.0] * len(y)] * self.window, 0, 0]
        rows, i, n = ring
        rows[i] = tuple(y)
        ring[1] = (i + 1) % self.window
        ring[2] = n + 1

    def _second_moment(self, source: str, y: np.ndarray) -> np.ndarray:
        """Per component: the window's sample variance, or e_i^2 (one sample)."""
        ring = self._ring.get(source)
        if ring is None or ring[2] < 3:
            return y * y
        buf = np.array(ring[0] if ring[2] >= self.window else ring[0][: ring[2]])
        return buf.var(axis=0, ddof=1)

    def scale(self, source: str, y, hph, r):
        """Factors for one source's rows (y, hph, r: sequences of floats, the filter's
        tuples), or None (optimal filter)."""
        if source in self._watch:
            self._remember(source, y)
        if self.mode == R_OFF or source not in self.active:
            return None
        y, hph, r = np.asarray(y, dtype=float), np.asarray(hph, dtype=float), np.asarray(r, dtype=float)
        e2 = self._second_moment(source, y) if self.window > 1 else y * y
        if self.mode == R_SINGLE:
            # S = (tr(C) - tr(H P H^T)) / tr(R),  max(1, S);  C = e e^T or the window's (2.29)
            s = (float(e2.sum()) - float(hph.sum())) / float(r.sum())
            return np.full(len(y), max(1.0, s))
        # S_ii = (C_ii - (H P H^T)_ii) / R_ii,  s_i = max(1, S_ii)    (2.31-2.33)
        return np.maximum(1.0, (e2 - hph) / r)


def attach(nav, adapter: RAdapter) -> bool:
    """Install ``adapter`` as the filter's R-scale hook; False if it has none."""
    if not hasattr(nav, "r_scale_hook"):
        return False
    okf_sd, last = adapter.okf_sd, adapter.last

    def hook(source, y, hph, r):
        out = adapter.scale(source, y, hph, r)
        if out is None:
            if okf_sd:                    # (both hold the same sources: empty but while adapting)
                okf_sd.pop(source, None)
                last.pop(source, None)
        else:
            last[source] = out
            okf_sd[source] = tuple([h + q for h, q in zip(hph, r)])   # diag(S) of the optimal filter
        return out

    nav.r_scale_hook = adapter.hook = hook
    adapter.attached = True
    return True
