"""A sensor channel falling silent (autopilot/monitor/monitor.py, FDI_TOUT, SILENT_RUN):
flagged when a channel that had been updating regularly stops, not when the filter fuses
a source only now and then (the magnetometer where the field is nearly vertical: the
filter's heading fusion needs B_h^2 / |B|^2 over 0.05; random-plane trials 89 and 112,
homes at 64 and 71 deg N, raised a `mag` alarm 16 s after the start that never
cleared), nor when the sensor still delivers while the filter declines its samples
(nav.heard_us: trials 327 and 454, inclination 77.5 deg, runs of fusions longer than
SILENT_RUN between gaps over FDI_TOUT, 16 `mag` alarms). A filter stand-in replays the
records, so the test is the monitor's alone."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.monitor import FaultMonitor
from autopilot.nav.records import InnovationRecord
from test_monitor_airspeed import _Nav




def _fly(fused, heard=None) -> FaultMonitor:
    """60 s of steps at 100 Hz; ``fused(t_s)``: a mag record at this 25 Hz slot;
    ``heard(t_s)``: the magnetometer delivers a sample at this 50 Hz slot (nav.heard_us;
    None: a filter that does not say)."""
    nav = _Nav()
    if heard is not None:
        nav.heard_us = {}
    nav.position_ned = np.array((0.0, 0.0, -100.0))
    mon = FaultMonitor({"FDI_START_T": 0.0}, nav)
    rng = np.random.default_rng(1)
    for k in range(100 * 60):
        t_us = 10_000 * k
        nav.innovations = []
        if heard is not None and k % 2 == 0 and heard(t_us * 1e-6):
            nav.heard_us["mag"] = t_us
        if k % 4 == 0 and fused(t_us * 1e-6):
            nav.innovations = [InnovationRecord(t_us, "mag", (0.0,), (0.01 * float(rng.standard_normal()),),
                                                (1e-4,), (0.0,), False, True)]
        mon.update(t_us, True)
    return mon


def test_a_source_fused_now_and_then_is_not_a_silent_sensor():
    # GIVEN mag fusions in bursts of 0.2-0.3 s with gaps of 0.6-1.5 s (the horizontal
    # field's share hovering about the filter's limit)
    gaps = np.random.default_rng(2)
    plan, t = [], 0.0
    while t < 60.0:
        plan.append((t, t + gaps.uniform(0.2, 0.3)))
        t = plan[-1][1] + gaps.uniform(0.6, 1.5)
    mon = _fly(lambda s: any(a <= s < b for a, b in plan))
    # THEN no alarm (at the code before, the first gap over FDI_TOUT was a `mag` fault)
    assert not mon.episodes, mon.events


def test_a_regular_source_that_stops_is_still_flagged():
    # GIVEN mag fusions at 25 Hz for 30 s, then none
    mon = _fly(lambda s: s < 30.0)
    # THEN silent mag detected FDI_TOUT (0.5 s) after its last update, isolated to it
    assert mon.episodes and mon.episodes[0].trigger == "mag"
    assert 30.4 <= mon.episodes[0].start_s <= 30.6, mon.episodes[0].start_s
    assert mon.episodes[0].isolated == "mag"


def _bursts(rng, on, off):
    plan, t = [], 0.0
    while t < 60.0:
        plan.append((t, t + rng.uniform(*on)))
        t = plan[-1][1] + rng.uniform(*off)
    return lambda s: any(a <= s < b for a, b in plan)


def test_a_delivering_sensor_whose_samples_the_filter_declines_is_not_silent():
    # GIVEN the magnetometer delivering at 50 Hz throughout, the filter fusing it in runs
    # of 3-8 s (over SILENT_RUN) with gaps of 0.6-2 s (over FDI_TOUT) between them
    fused = _bursts(np.random.default_rng(3), (3.0, 8.0), (0.6, 2.0))
    # WHEN the filter says what it hears
    mon = _fly(fused, heard=lambda s: True)
    # THEN no alarm
    assert not mon.episodes, mon.events
    # AND a filter that does not say is flagged silent at the first long gap (the class
    # the heard time fixes)
    mon = _fly(fused)
    assert mon.episodes and mon.episodes[0].trigger == "mag", mon.events


def test_a_sensor_that_stops_delivering_is_flagged_though_heard_before():
    # GIVEN mag samples heard and fused for 30 s, then neither
    mon = _fly(lambda s: s < 30.0, heard=lambda s: s < 30.0)
    # THEN silent mag FDI_TOUT after the last sample, isolated to it
    assert mon.episodes and mon.episodes[0].trigger == "mag"
    assert 30.4 <= mon.episodes[0].start_s <= 30.6, mon.episodes[0].start_s
    assert mon.episodes[0].isolated == "mag"
