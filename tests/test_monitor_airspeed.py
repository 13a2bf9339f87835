"""The airspeed channel's window test near the ground (autopilot/monitor/monitor.py,
FDI_ARSP_HMIN): there moderate turbulence's gusts are shorter than the wind estimate
follows and the innovations are the gusts, not the sensor (docs/status.md, "Faults and
the monitor": false alarms). A filter stand-in replays airspeed innovations of the size
measured in a landing's last 20 m, so the test is the monitor's alone."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.monitor import FaultMonitor
from autopilot.nav.records import InnovationRecord

SD_S = 0.38              # the filter's airspeed innovation sd in cruise [m/s] (measured)


class _Nav:
    """What the monitor reads of a filter: aligned, healthy, innovations, biases, P, position."""

    def __init__(self):
        self.aligned = self.healthy = True
        self.innovations = []
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.P = np.eye(24) * 1e-8
        self.position_ned = np.zeros(3)


def _fly(height_m: float, gust_rms: float, rng, **params) -> FaultMonitor:
    """60 s of airspeed fusions at 25 Hz at ``height_m`` above home, the innovation a
    gust of ``gust_rms`` (first order, 1.5 s: MIL-F-8785C's low-altitude scale length at
    5 m, 37 m, flown at 25 m/s) over the sensor's noise."""
    nav = _Nav()
    nav.position_ned = np.array((0.0, 0.0, -height_m))
    mon = FaultMonitor({"FDI_START_T": 0.0, **params}, nav)
    a = np.exp(-0.04 / 1.5)
    g = 0.0
    for k in range(25 * 60):
        t_us = 40_000 * k
        g = a * g + gust_rms * np.sqrt(1 - a * a) * rng.standard_normal()
        e = g + 0.3 * rng.standard_normal()
        nav.innovations = [InnovationRecord(t_us, "airspeed", (25.0,), (float(e),), (SD_S ** 2,), (0.0,),
                                            False, True)]
        mon.update(t_us, True)
    return mon


def test_airspeed_gusts_near_the_ground_raise_no_alarm():
    # GIVEN innovations of 2.5 m/s rms (a moderate turbulence's gusts 3-10 m above the
    # ground in a landing, random-plane trial 4: 2.49 m/s rms against 0.38-0.61 from
    # 20 m up) for a minute at 8 m
    mon = _fly(8.0, 2.5, np.random.default_rng(1))
    # THEN no alarm, and the window statistic is not even formed
    assert not mon.detected and not mon.episodes
    assert mon.peaks.get("airspeed", 0.0) == 0.0


def test_airspeed_errors_of_that_size_are_still_found_higher_up():
    # GIVEN the same innovations at 50 m (where the filter follows the gusts and so they
    # are a sensor's error); THEN the channel detects them (the test is not blind)
    mon = _fly(50.0, 2.5, np.random.default_rng(1))
    assert mon.episodes and mon.episodes[0].trigger == "airspeed"
    # AND with FDI_ARSP_HMIN 0 and FDI_ARSP_HREF 0 the near-ground gusts would alarm as
    # before
    mon = _fly(8.0, 2.5, np.random.default_rng(1), FDI_ARSP_HMIN=0.0, FDI_ARSP_HREF=0.0)
    assert mon.detected and mon.episodes[0].trigger == "airspeed"


def test_airspeed_gusts_low_on_an_approach_are_read_against_the_low_altitude_model():
    # GIVEN innovations of 1.0 m/s rms at 30 m above home, 1.5 s correlated (moderate
    # turbulence on random-plane approaches: airspeed alarms 22-45 m up, 1.00-1.09 times
    # the threshold, trials 276, 279, 323, 367), five seeds
    peaks = {}
    for href in (0.0, 100.0):
        peaks[href] = [_fly(30.0, 1.0, np.random.default_rng(s), FDI_ARSP_HREF=href).peaks.get("airspeed", 0.0)
                       for s in range(5)]
    # THEN read as FDI_ARSP_K reads them from 100 m up they alarm on every seed; scaled
    # by the gusts' growth down to 30 m (2.5 times) they stay under 0.6 of the threshold
    assert min(peaks[0.0]) > 1.0, peaks
    assert max(peaks[100.0]) < 0.6, peaks
    # AND at 100 m nothing changes
    a = _fly(100.0, 1.0, np.random.default_rng(0)).peaks["airspeed"]
    b = _fly(100.0, 1.0, np.random.default_rng(0), FDI_ARSP_HREF=0.0).peaks["airspeed"]
    assert a == b
