"""The fault monitor skips its evaluation on steps where nothing it reads has changed
(autopilot/monitor/monitor.py, ``FaultMonitor.update``: no window pushed or reset, no
fault detected, the bias test not due, armed as before, no channel able to fall silent
yet), and its scan of the aiding channels where only the bias test is due. The skip must change nothing: a monitor that evaluates at every step, fed the same
records, gives the same statistics, peaks, episodes and messages at every step, through
a silence, a detection, its clearance and a change of the armed state. A filter
stand-in replays the records, so the test is the monitor's alone."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.monitor import FaultMonitor
from autopilot.nav.records import InnovationRecord
from test_monitor_airspeed import _Nav


class _EveryStep(FaultMonitor):
    """The same monitor, its skip disabled: every step evaluates."""

    def update(self, t_us: int, armed: bool = True) -> None:
        self._eval_armed = None        # (no armed state matches None: evaluated)
        super().update(t_us, armed)


def _record(t_us: int, source: str, y, sd2) -> InnovationRecord:
    y = tuple(np.atleast_1d(np.asarray(y, dtype=float)).tolist())
    m = len(y)
    return InnovationRecord(t_us, source, (0.0,) * m, y, (float(sd2),) * m, (0.0,) * m, False, True)


def _stream(seconds: float = 90.0):
    """(t_us, armed, records) at 100 Hz: GPS position and velocity (silent from 30 to
    45 s), the magnetometer and the barometer (a 2 m step from 60 to 70 s: a detection
    that clears) at 10 Hz each, in different steps; disarmed for 1 s at 80 s. Six steps
    in ten bring no record: a silence falls due in one of those."""
    rng = np.random.default_rng(7)
    for k in range(int(100 * seconds)):
        t_us = 10_000 * k
        t_s = t_us * 1e-6
        recs = []
        if k % 10 == 0 and not 30.0 <= t_s < 45.0:
            recs.append(_record(t_us, "gps_pos", 0.5 * rng.standard_normal(3), 0.25))
            recs.append(_record(t_us, "gps_vel", 0.1 * rng.standard_normal(3), 0.01))
        if k % 10 == 3:
            recs.append(_record(t_us, "mag", 0.01 * rng.standard_normal(), 1e-4))
        if k % 10 == 6:
            step = 2.0 if 60.0 <= t_s < 70.0 else 0.0
            recs.append(_record(t_us, "baro", step + 0.3 * rng.standard_normal(), 0.09))
        yield t_us, not 80.0 <= t_s < 81.0, recs


def _state(mon: FaultMonitor) -> tuple:
    return (mon.log_row(), dict(mon.peaks), mon.detected, mon.isolated,
            [(e.start_s, e.trigger, e.isolated, e.end_s) for e in mon.episodes], list(mon.events))


def test_the_skipped_evaluation_changes_nothing():
    navs = (_Nav(), _Nav())
    for nav in navs:
        nav.position_ned = np.array((0.0, 0.0, -100.0))
    skip = FaultMonitor({"FDI_START_T": 0.0}, navs[0])
    every = _EveryStep({"FDI_START_T": 0.0}, navs[1])
    evaluated = {"n": 0, "scans": 0}
    evaluate = skip._evaluate

    def counted(t_us, armed, scan):
        evaluated["n"] += 1
        evaluated["scans"] += scan
        evaluate(t_us, armed, scan)

    skip._evaluate = counted
    steps = 0
    for t_us, armed, recs in _stream():
        for nav in navs:
            nav.innovations = recs
        skip.update(t_us, armed)
        every.update(t_us, armed)
        steps += 1
        assert _state(skip) == _state(every), t_us
    # the stream did what it is for: a silent GPS flagged and a barometer step, each
    # detected and cleared
    triggers = [e.trigger for e in every.episodes]
    assert "gps_pos" in triggers and "baro" in triggers, every.events
    assert all(e.end_s is not None for e in every.episodes), every.events
    # and the skip skipped: most steps brought nothing new
    assert evaluated["n"] < 0.6 * steps, (evaluated["n"], steps)
    # and where only the bias test was due, the aiding channels' scan was not repeated
    assert evaluated["scans"] < evaluated["n"], evaluated
