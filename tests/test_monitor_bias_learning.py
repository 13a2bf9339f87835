"""The bias-estimate change test of the gyros and accelerometers
(autopilot/monitor/monitor.py, ``_bias_stats``) while the filter is still learning a
bias: a consistent filter's estimate moves over T by about sqrt(sigma(t - T)^2 -
sigma(t)^2 + q T), the sigma it had before, not the smaller one it has after. In
random-plane trial 84 (moderate turbulence) the lateral accelerometer bias became
observable in the first turn, 58-60 s after alignment: its estimate moved 0.055 m/s^2 in
2 s while its sigma fell from 0.033 to 0.010 m/s^2, and the test, armed at 60 s
(FDI_BIAS_WU) and normalised by the present sigma, read 1.1 times its threshold: an
`accel_y` alarm with no fault. A filter stand-in plays the bias estimate and its
variance, so the test is the monitor's alone."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.monitor import FaultMonitor
from test_monitor_airspeed import _Nav

ACC_Y = 10          # the accelerometer-bias y state in the filter's layout (layout.ABIAS)


def _fly(track, seconds: float = 90.0) -> FaultMonitor:
    """``track(t_s) -> (estimate, sigma)`` of the lateral accelerometer bias [m/s^2],
    the monitor stepped at 100 Hz from alignment (t = 0)."""
    nav = _Nav()
    nav.position_ned = np.array((0.0, 0.0, -100.0))
    nav.P = np.eye(24) * 1e-6
    mon = FaultMonitor({"FDI_START_T": 0.0}, nav)
    for k in range(int(100 * seconds)):
        t_s = 0.01 * k
        b, sd = track(t_s)
        nav.accel_bias = np.array((0.0, b, 0.0))
        nav.P[ACC_Y, ACC_Y] = sd * sd
        mon.update(10_000 * k, True)
    return mon


def _ramp(t_s: float, t0: float, t1: float, a: float, b: float) -> float:
    return a + (b - a) * min(max((t_s - t0) / (t1 - t0), 0.0), 1.0)


def test_a_bias_learnt_as_the_test_arms_is_no_fault():
    # GIVEN the estimate moving 0.055 m/s^2 in the 2 s before the test arms (58-60 s
    #       after alignment), its sigma falling from 0.033 to 0.010 m/s^2 meanwhile, then
    #       steady (trial 84's first turn)
    mon = _fly(lambda t: (_ramp(t, 58.0, 60.0, -0.063, -0.008), _ramp(t, 58.0, 60.0, 0.033, 0.0104)))
    # THEN no alarm: the change is what the sigma before allowed (its peak 0.14 of the
    #      threshold; with the present sigma alone 1.38: an `accel_y` alarm)
    assert not mon.episodes, mon.events
    assert mon.peaks.get("accel_y", 0.0) < 0.5, mon.peaks


def test_an_accelerometer_bias_step_in_steady_state_is_still_detected():
    # GIVEN a steady estimate (sigma 0.0075 m/s^2) that takes a 0.05 m/s^2 step over 1 s
    #       at 100 s (a bias fault the filter absorbs)
    mon = _fly(lambda t: (_ramp(t, 100.0, 101.0, -0.02, 0.03), 0.0075), seconds=110.0)
    # THEN detected as before, within 1 s of the step's start, isolated to accel_y
    ep = mon.episodes[0]
    assert ep.trigger == "accel_y" and ep.isolated == "accel_y", mon.events
    assert 100.0 <= ep.start_s <= 101.0, ep.start_s
