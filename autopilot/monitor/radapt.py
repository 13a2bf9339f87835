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

The navigation filter hook
--------------------------
The factors must be applied inside the filter's update, after ``e`` and ``H P H^T`` are
known and before the gate. ``autopilot/nav`` has no such hook yet; the one this
package needs (to be added there) is::

    NavFilterBase.r_scale_hook: Callable[[str, np.ndarray, np.ndarray, np.ndarray],
                                         np.ndarray | None] | None = None
        # called once per source and step in _fuse, after _gate_stats and before the
        # gate test, as hook(source, y, hph_diag, r_diag) with y = z - h(x),
        # hph_diag = diag(H P H^T), r_diag = diag(R) of that source's rows; a returned
        # array of factors (>= 1, one per row) multiplies those rows of R (and of
        # diag(S), so the gate and the Joseph update both use the scaled R).

Until it exists, :func:`attach` installs the same behaviour by wrapping the filter
instance's ``_gate_stats`` (no file of autopilot/nav is touched; a filter without that
method, or a future one with ``r_scale_hook``, is handled). Both paths call
:meth:`RAdapter.scale`.
"""
from __future__ import annotations

import numpy as np

R_OFF, R_SINGLE, R_MULTIPLE = 0, 1, 2


class RAdapter:
    """Computes the R scale factors of the sources named in ``active``.

    ``mode``: 0 off (OKF), 1 single factor (2.29), 2 multiple factors (2.33).
    ``active``: the set of source names being adapted (the fault monitor fills it).
    ``last``: source -> the factors of the latest step (for the log); ``okf_sd``:
    source -> diag(H P H^T + R) with the unscaled R, so the monitor keeps testing the
    optimal filter's statistic while the adapted filter runs (otherwise the adaptation
    would hide the fault from the test that switches it off).
    """

    def __init__(self, mode: int = R_MULTIPLE):
        self.mode = int(mode)
        self.active: set[str] = set()
        self.last: dict[str, np.ndarray] = {}
        self.okf_sd: dict[str, np.ndarray] = {}
        self.attached = False

    def scale(self, source: str, y: np.ndarray, hph: np.ndarray, r: np.ndarray):
        """Factors for one source's rows, or None (optimal filter)."""
        if self.mode == R_OFF or source not in self.active:
            return None
        if self.mode == R_SINGLE:
            # S = (e^T e - tr(H P H^T)) / tr(R),  max(1, S)            (2.29)
            s = (float(y @ y) - float(hph.sum())) / float(r.sum())
            return np.full(len(y), max(1.0, s))
        # S_ii = (e_i^2 - (H P H^T)_ii) / R_ii,  s_i = max(1, S_ii)    (2.31-2.33)
        return np.maximum(1.0, (y * y - hph) / r)


def attach(nav, adapter: RAdapter) -> bool:
    """Connect ``adapter`` to a navigation filter; False if it offers no way in."""
    if hasattr(nav, "r_scale_hook"):                 # the requested nav API
        def hook(source, y, hph, r):
            out = adapter.scale(source, y, hph, r)
            if out is not None:
                adapter.last[source] = out
                adapter.okf_sd[source] = hph + r
            return out
        nav.r_scale_hook = hook
        adapter.attached = True
        return True
    gate = getattr(nav, "_gate_stats", None)
    if gate is None:
        return False

    def gate_stats(batch, _orig=gate):
        # shim until nav has r_scale_hook: scale R rows after y and diag(S) are known
        _orig(batch)
        adapter.last.clear()
        adapter.okf_sd.clear()
        if not adapter.active or adapter.mode == R_OFF:
            return
        y, sd, R = batch.y, batch.Sd, batch.R
        copied = False
        for k, name in enumerate(batch.src):
            if name not in adapter.active:
                continue
            a = batch.start[k]
            b = a + batch.size[k]
            r = R[a:b]
            hph = sd[a:b] - r
            s = adapter.scale(name, y[a:b], hph, r)
            if s is None:
                continue
            adapter.okf_sd[name] = sd[a:b].copy()
            adapter.last[name] = s
            if not copied:               # never write into arrays nav may share
                copied = True
                R = batch.R = R.copy()
                sd = batch.Sd = sd.copy()
            R[a:b] = r * s
            sd[a:b] = hph + r * s

    nav._gate_stats = gate_stats
    adapter.attached = True
    return True
