"""The fault monitor's per-step work cut (stop 41), nothing else changed: an actuator
axis' sample (lateral._Axis: the offset fit on the samples FIT_DELAY_S old, the
residual's variance, the 20 s history) in one compiled call (lateral.axis_step) against
the lists and calls it replaced, written out here, bit for bit."""
from __future__ import annotations

import math
import random

import numpy as np
import pytest

from autopilot.monitor.actuator import BAL_PERIOD_US, FIT, FIT_DELAY_S, LEFT, NO_FIT, RES_TAU_S, offset_step
from autopilot.monitor.lateral import LAT_RES_FLOOR_RAD, _Axis


class _ListAxis:
    """The axis' sample as it was (stop 40): Python lists and one compiled call a fit."""

    def __init__(self, floor, prior, prior_n, n_phi, offset_sd=0.05, fit_noise=0.1):
        self.prior_n, self.refit, self.fitting = prior_n, prior is not None, False
        self._fit = np.zeros((n_phi + 1, n_phi))
        self._fit[1:] = np.eye(n_phi) * (offset_sd / fit_noise) ** 2
        self.r_var = (floor if prior is None else prior) ** 2
        self.n_var = 0
        self.queue, self.hist = [], []

    def step(self, t_us, x1, x2, z, d, learn):
        raw = z - d
        zc = None
        if learn is not None:
            q = self.queue
            while q and t_us - q[0][0] >= FIT_DELAY_S * 1e6:
                _, y1, y2, rw, ro = q.pop(0)
                if self.refit and learn and not self.fitting:
                    self.fitting = True
                    self.n_var = 0
                dot, e, _ = offset_step(self._fit, x1, x2, y1, y2, rw,
                                        FIT if learn else LEFT if self.refit else NO_FIT)
                if zc is None:
                    zc = z - dot
                if self.refit:
                    ro = e
                self.n_var += 1
                a = max(1.0 / (self.n_var + self.prior_n), BAL_PERIOD_US * 1e-6 / RES_TAU_S)
                self.r_var += a * (ro * ro - self.r_var)
        if zc is None:
            zc = z - offset_step(self._fit, x1, x2, 0.0, 0.0, 0.0, NO_FIT)[0]
        r = zc - d
        h = self.hist
        h.append((t_us, zc, d))
        while h and t_us - h[0][0] > 20e6:
            h.pop(0)
        if learn is not None:
            self.queue.append((t_us, x1, x2, raw, r))
        return r


@pytest.mark.parametrize("prior, prior_n, n_phi", [(0.02, 50, 2), (None, 0, 2), (0.01, 20, 3)])
def test_axis_step_is_the_lists_bit_for_bit(prior, prior_n, n_phi):
    # GIVEN an axis and the lists' version of it, on the same wandering samples every
    # 0.1 s (gaps, the variance alone at first, then the fit, frozen, the waiting samples
    # dropped now and then)
    rng = random.Random(41)
    ax = _Axis("aileron", 10, 1e-4, 1e-7, floor=LAT_RES_FLOOR_RAD, prior=prior, prior_n=prior_n, n_phi=n_phi)
    ref = _ListAxis(LAT_RES_FLOOR_RAD, prior, prior_n, n_phi)
    t = 5_000_000
    z = d = 0.0
    for k in range(3000):
        t += BAL_PERIOD_US if k % 211 else 2_300_000
        d = 0.9 * d + rng.gauss(0.0, 0.02)
        z = d + 0.01 + rng.gauss(0.0, 0.005)
        x1, x2 = rng.uniform(0.2, 1.2), rng.gauss(0.5, 0.1)
        learn = None if 2400 < k < 2600 else k > 400
        if k % 733 == 0:
            ax.drop_waiting()
            ref.queue.clear()
        # WHEN both step
        r = ref.step(t, x1, x2, z, d, learn)
        ax.step(t, x1, x2, z, d, learn, k % 5 == 0)
        # THEN the residual, the variance, the fit and the history are the same
        assert ax.residual == r, k
        assert ax.r_var == ref.r_var and ax.fitting == ref.fitting, k
        assert ax._fit.tolist() == ref._fit.tolist(), k
        if k % 97 == 0:
            assert ax.hist == ref.hist, k
    assert ax.hist == ref.hist and len(ref.hist) > 150
    assert ref.fitting == (prior is not None) and ref.n_var > 1000
    assert ax.win.n > 500 and math.isfinite(ax.ratio)


def test_axis_step_says_when_its_rings_would_overflow():
    # GIVEN an axis stepped faster than its 10 Hz (its rings hold 0.1 s apart samples)
    ax = _Axis("rudder", 10, 1e-4, 1e-7, prior=0.02, prior_n=50)
    # THEN it says so rather than dropping samples
    with pytest.raises(ValueError):
        for k in range(400):
            ax.step(1_000_000 + 1000 * k, 0.5, 0.0, 0.01, 0.0, True, False)
