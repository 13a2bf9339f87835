"""Multi-channel isolation in a long episode (autopilot/monitor/monitor.py,
``Episode.isolated_all``): a channel joins an open episode only over its own detection
threshold. The isolation test (2.16-2.17) is taken at FDI_ALPHA per test; repeated at
every GPS sample of an actuator episode, which stays open to the flight's end, a healthy
channel crossed it by chance: the stuck aileron (`fault_aileron_stuck.toml`, seeds 2,
3, 7, 9) named gps_vel / gps_pos 20-300 s into the episode with their detection
statistics never over 0.7 of threshold. A filter stand-in replays white, unit-variance
GPS innovations, so the test is the monitor's alone (the flights: docs/status.md,
"Faults and the monitor")."""
from __future__ import annotations

import numpy as np

from autopilot.monitor.monitor import Episode, FaultMonitor
from autopilot.nav.records import InnovationRecord
from test_monitor_airspeed import _Nav


def _actuator_episode(noisy_vel_from_s: float | None = None, minutes: float = 20.0, seed: int = 7,
                      accel_z_step_s: float | None = None, name: str = "aileron"):
    """An actuator episode (``name``) opened at 0 s, then ``minutes`` of GPS position and
    velocity innovations at 5 Hz, white with unit normalised variance (the velocity's 7
    times noisier from ``noisy_vel_from_s`` when given; the filter's vertical
    accelerometer bias estimate stepping by 0.05 m/s^2 at ``accel_z_step_s``)."""
    nav = _Nav()
    nav.position_ned = np.array((0.0, 0.0, -100.0))
    nav.r_scale_hook = None           # a filter that takes R scale factors (radapt.attach)
    mon = FaultMonitor({"FDI_START_T": 0.0}, nav)
    assert mon.radapt_ok
    mon.detected = True
    mon.isolated = name
    mon.episodes.append(Episode(0.0, name, name, 0.0, kind="actuator", isolated_all=[name]))
    rng = np.random.default_rng(seed)
    one, zero = (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)
    for k in range(int(5 * 60 * minutes)):
        t_us = 200_000 * k
        sd = 7.0 if noisy_vel_from_s is not None and t_us * 1e-6 >= noisy_vel_from_s else 1.0
        if accel_z_step_s is not None and t_us * 1e-6 >= accel_z_step_s:
            nav.accel_bias = np.array((0.0, 0.0, 0.05))
        nav.innovations = [
            InnovationRecord(t_us, "gps_pos", zero, tuple(rng.standard_normal(3).tolist()), one, zero, False, True),
            InnovationRecord(t_us, "gps_vel", zero, tuple((sd * rng.standard_normal(3)).tolist()), one, zero,
                             False, True)]
        mon.update(t_us, True)
    return mon


def test_healthy_gps_not_named_in_a_long_actuator_episode():
    # GIVEN an aileron episode and 20 minutes of healthy GPS innovations (6000 samples a
    # channel: the isolation test at 1e-4 per component is crossed by chance a few times)
    mon = _actuator_episode()
    ep = mon.episodes[-1]
    # THEN the episode still names the aileron alone, and its isolation stands
    #      (the code before named gps_vel at 747 s)
    assert ep.isolated == "aileron" and ep.kind == "actuator"
    assert ep.isolated_all == ["aileron"], mon.events
    assert not any("isolated too" in t for _t, _s, t in mon.events)
    # AND the navigation filter is left optimal: no R adaptation (the code before
    #     switched it on at per-step crossings, gps_vel's at 330 s, gps_pos's at 1104 s,
    #     and left it on)
    assert not mon.radapt.active and not any("adaptation on" in t for _t, _s, t in mon.events), mon.events


def test_a_gps_fault_during_an_actuator_episode_is_still_named():
    # GIVEN the same episode, the GPS velocity 7 times noisier from 300 s
    mon = _actuator_episode(noisy_vel_from_s=300.0, minutes=6.0)
    ep = mon.episodes[-1]
    # THEN it joins the episode within 2 s of its onset (over its detection threshold),
    #      the aileron still the one most to blame, the position not named
    assert ep.isolated == "aileron" and ep.isolated_all == ["aileron", "gps_vel"], mon.events
    t_join = next(t for t, _s, txt in mon.events if "gps_vel fault isolated too" in txt)
    assert 300.0 <= t_join <= 302.0, t_join
    # AND from then its R is adapted (the RAKF), the healthy position's not
    assert mon.radapt.active == {"gps_vel"}, mon.events


def test_an_inertial_channel_joins_an_actuator_episode_without_taking_it_over():
    # GIVEN a stuck elevator's episode, and 90 s in (after the bias test's warm-up) the
    # filter's vertical accelerometer bias estimate stepping (fault_elevator_stuck_launch
    # trial 7: accel_z over its threshold in the dive, 8.8 s after the detection)
    mon = _actuator_episode(minutes=1.75, accel_z_step_s=90.0, name="elevator")
    ep = mon.episodes[-1]
    # THEN the episode stays the elevator's, open, an actuator's, accel_z named with it
    #      (the code before made it an inertial episode isolated to accel_z, which then
    #      cleared: the elevator's identification stopped)
    assert ep.isolated == "elevator" and ep.kind == "actuator" and ep.end_s is None, mon.events
    assert ep.isolated_all == ["elevator", "accel_z"], mon.events
    assert mon.detected and mon.isolated == "elevator"
