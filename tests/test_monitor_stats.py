"""Unit tests of the fault monitor's statistics (seed eqs 2.12-2.17, 2.29-2.33) and of
the summary's fault figures."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from autopilot.monitor import WindowChi2, chi2_threshold
from autopilot.monitor.monitor import Episode
from autopilot.monitor.radapt import R_MULTIPLE, R_SINGLE, RAdapter
from tools.summary import fault_figures


def test_thresholds_are_chi2_quantiles():
    w = WindowChi2(3, 10, 1e-3)
    assert w.thr_det == pytest.approx(chi2.ppf(0.999, 30))
    assert w.thr_step == pytest.approx(chi2.ppf(0.999, 3))
    assert w.thr_iso == pytest.approx(chi2.ppf(0.999, 9))
    assert chi2_threshold(0.05, 1) == pytest.approx(3.841, abs=1e-3)


def test_window_statistics_match_their_definitions():
    rng = np.random.default_rng(0)
    w = WindowChi2(2, 8, 1e-3)
    xs = rng.normal(size=(50, 2))
    for x in xs:
        w.push(x.tolist())
    last = xs[-8:]
    assert w.beta == pytest.approx(np.sum(last ** 2))                    # 2.12
    assert w.chi == pytest.approx(np.sum(xs[-1] ** 2))                   # 2.41
    assert w.gamma == pytest.approx(max(7 * np.var(last, axis=0, ddof=1)))  # 2.16-2.17


def test_false_alarm_rate_is_alpha_on_white_noise_and_a_shift_is_detected():
    rng = np.random.default_rng(1)
    alpha, M = 0.01, 10
    w = WindowChi2(1, M, alpha)
    over = 0
    n = 20000
    for k, v in enumerate(rng.normal(size=n)):
        w.push([float(v)])
        if k >= M and k % M == 0:        # independent windows
            over += w.beta > w.thr_det
    rate = over / (n / M)
    assert 0.3 * alpha < rate < 2.5 * alpha
    for v in rng.normal(3.0, 1.0, size=M):   # a 3-sigma mean shift fills the window
        w.push([float(v)])
    assert w.ratio_det > 1.0


def test_noise_scale_factors():
    y, hph, r = np.array([3.0, 0.5]), np.array([1.0, 1.0]), np.array([2.0, 2.0])
    a = RAdapter(R_MULTIPLE)
    assert a.scale("gps_pos", y, hph, r) is None            # not active: the OKF
    a.active.add("gps_pos")
    # s_i = max(1, (e_i^2 - HPH_ii) / R_ii)    (2.31-2.33)
    assert a.scale("gps_pos", y, hph, r).tolist() == [4.0, 1.0]
    a.mode = R_SINGLE
    # S = (e^T e - tr HPH) / tr R = (9.25 - 2) / 4    (2.29)
    assert a.scale("gps_pos", y, hph, r).tolist() == pytest.approx([7.25 / 4] * 2)


class _R:
    def __init__(self, at_s, unit, type, instance=0, accepted=True, held=None):
        self.at_s, self.unit, self.type, self.instance, self.accepted = at_s, unit, type, instance, accepted
        self.held = held


def test_fault_figures_pair_injections_with_detections():
    log = [_R(100.0, "gps", "garbage"), _R(130.0, "gps", "ok")]
    eps = [Episode(20.0, "baro", end_s=25.0), Episode(100.4, "gps_pos", "gps_pos", 100.4, 133.0),
           Episode(138.0, "gps_vel"), Episode(200.0, "mag")]
    f = fault_figures(log, eps, 300.0)
    assert f["faults"][0]["detected_s"] == 100.4
    assert f["faults"][0]["delay_s"] == pytest.approx(0.4)
    assert f["faults"][0]["isolated"] == "gps_pos"
    assert f["faults"][1]["cleared_s"] == 133.0
    assert f["false_alarms"] == 2          # 20 s and 200 s; 138 s is the fault's aftermath


def test_a_stuck_surface_is_timed_from_when_the_command_leaves_it():
    # GIVEN the elevator stuck at 0.10 rad (0.2857 of its travel) from 100 s, the
    # command within 0.015 rad of it until 104 s and 0.03 rad away from then, and the
    # detection at 105.5 s; an aileron stuck where the command never goes
    t = np.arange(0.0, 200.0, 0.02)
    held = 0.10 / 0.35
    elev = np.where(t < 104.0, held + 0.015 / 0.35, held + 0.03 / 0.35)
    ail = np.full_like(t, -0.2)
    log = [_R(100.0, "servo", "stuck", 1, held=held), _R(150.0, "servo", "stuck", 0, held=0.2)]
    eps = [Episode(105.5, "elevator", "elevator", 105.5, 140.0)]
    f = fault_figures(log, eps, 200.0, t, None, None, (ail, elev, ail, ail))
    # THEN the elevator's delay is 5.5 s from the onset and 1.5 s from the departure
    e = f["faults"][0]
    assert e["delay_s"] == pytest.approx(5.5)
    assert e["departed_s"] == pytest.approx(4.0) and e["delay_departed_s"] == pytest.approx(1.5)
    # and the aileron's command was 0.4 of travel away at once: departed at the onset
    a = f["faults"][1]
    assert a["departed_s"] == pytest.approx(0.0) and a["delay_departed_s"] is None


def test_family_alpha_bounds_the_false_alarms_of_repeated_overlapping_window_tests():
    # GIVEN white normalised innovations and a window test repeated at every sample,
    # WHEN its alpha is set for a family-wise false-alarm probability p over n tests,
    # THEN the probability that any of the n overlapping tests alarms is at most p
    # (Bonferroni), and not far under it (the overlap makes the bound ~2x conservative)
    from autopilot.monitor.stats import family_alpha
    rng = np.random.default_rng(3)
    M, s, n, p, runs = 10, 3, 2000, 0.2, 400
    alpha = family_alpha(p, n)
    assert alpha == pytest.approx(1e-4)
    thr = chi2.ppf(1.0 - alpha, M * s)
    hits = 0
    for _ in range(runs):
        q = (rng.standard_normal((n + M - 1, s)) ** 2).sum(axis=1)
        c = np.concatenate(([0.0], np.cumsum(q)))
        hits += (c[M:] - c[:-M]).max() > thr
    rate = hits / runs
    assert 0.05 < rate <= p


def test_monitor_detection_threshold_is_set_per_flight_hour():
    from autopilot.monitor.monitor import FaultMonitor, window_tests_per_hour
    m = FaultMonitor({"FDI_PFA": 0.01, "FDI_DECIM": 10, "FDI_ALPHA": 1e-4})
    n = window_tests_per_hour(10)
    assert n == pytest.approx(3600 * (5 + 5 + 3 * 2.5))
    w = m.aiding["gps_pos"].win
    assert w.thr_det == pytest.approx(chi2.ppf(1.0 - 0.01 / n, 30))
    # the per-step and isolation tests keep the per-test level FDI_ALPHA
    assert w.thr_step == pytest.approx(chi2.ppf(1.0 - 1e-4, 3))
    assert w.thr_iso == pytest.approx(chi2.ppf(1.0 - 1e-4, 9))
