"""End to end: the quadrotor flies missions headless over the memory-pipe HIL link at
250 Hz (sensors, INS/GPS EKF, guidance, PDD/PID control, mixer, plant), scored from
truth (tools/summary.py quad_figures).

Absolute figures (``hold_pos_rms_m``, ``land_error_m``, ...) include the navigation
solution's own error. In height the filter flies the barometer (EK_HGT_REF = 0), and
the hover's absolute height error is within the issue's 0.15 m with the EKF. Horizontally
the simulated u-blox-class GPS wanders 0.2 m per axis over a minute (Gauss-Markov, 60 s;
0.28 m radial RMS expected), which no filter removes, about the issue's 0.3 m bound: the
horizontal bounds are therefore asserted (a) on truth navigation (``--nav truth``), where
the figures are the guidance/control/plant performance itself, and (b) with the EKF on
the ``*_ctl`` figures (navigation solution against the target); the absolute EKF
figures are checked against the navigation error."""
import math

import numpy as np
import pytest

from autopilot.geo import quat_to_euler
from autopilot.modes.copter import CopterMode
from tools.runner import DEFAULT_SCENARIO, MISSIONS_DIR, QUAD_DEFAULT_MISSION, RunConfig, Session
from tools.summary import run_summary, without_timing

HOVER = MISSIONS_DIR / "quad_hover.waypoints"


def fly(**kw):
    s = Session(RunConfig(vehicle="quad", airframe="f450", **kw))
    s.run()
    return s, run_summary(s)


def test_hover_in_3_mps_wind_and_light_turbulence_on_truth_meets_the_issue_bounds():
    s, m = fly(mission=HOVER, wind=(3.0, 270.0), turbulence="light", nav="truth", seed=1)
    assert m["completed"] is True and not m["crashed"]
    assert m["mission_items_reached"] == m["mission_items_total"] == 3
    assert m["hold_time_s"] == pytest.approx(60.0, abs=0.1)
    assert m["hold_pos_rms_m"] <= 0.3
    assert m["hold_alt_rms_m"] <= 0.15
    assert m["land_error_m"] <= 1.0
    assert m["max_tilt_deg"] <= 20.0
    assert m["lockstep_missed"] == 0
    # in the hold the motors sit at the model's hover command (weight / thrust curve)
    a = s.log.arrays()
    hold = a["hold"] > 0
    mean_cmd = np.mean([a[f"motor_{k}"][hold] for k in range(1, 5)])
    assert mean_cmd == pytest.approx(s.plant.af.hover_command(s.plant.rho, s.plant.g), abs=0.01)


def test_hover_with_the_ekf_holds_where_it_believes_the_point_is():
    s, m = fly(mission=HOVER, wind=(3.0, 270.0), turbulence="light", nav="ekf", seed=1)
    assert m["completed"] is True and not m["crashed"]
    assert m["nav_source"] == "ekf"
    assert m["hold_pos_ctl_rms_m"] <= 0.3
    assert m["hold_alt_ctl_rms_m"] <= 0.15
    assert m["hold_alt_rms_m"] <= 0.15          # absolute: the barometric height reference
    assert m["land_error_ctl_m"] <= 1.0
    # the absolute figures differ from those by the navigation error, no more
    assert m["hold_pos_rms_m"] <= m["hold_pos_ctl_rms_m"] + m["nav_pos_h_err_max_m"]
    assert m["land_error_m"] <= m["land_error_ctl_m"] + m["nav_pos_h_err_max_m"]


def test_default_quad_mission_completes_every_item_and_lands_on_home():
    s, m = fly(mission=QUAD_DEFAULT_MISSION, scenario=DEFAULT_SCENARIO, seed=1)
    assert m["completed"] is True and not m["crashed"]
    assert m["mission_items_reached"] == m["mission_items_total"] == 8
    assert m["land_error_ctl_m"] <= 1.0
    assert m["land_error_m"] <= 1.0 + m["nav_pos_h_err_max_m"]
    assert m["hold_pos_ctl_rms_m"] <= 0.5
    # the motor fault monitor stays quiet (figures: docs/status.md, "Quadrotor")
    assert m["false_alarms"] == 0 and m["fdi_peak_ratio"]["motors"] < 1.0
    assert m["max_tilt_deg"] <= 30.0 + 1.0
    assert m["xtrack_rms_m"] <= 1.5
    # DO_JUMP (item 7 -> 4, once): items 4 .. 6 flown twice
    seqs = [q for _, q in s.vehicle.reached_events()]
    assert seqs.count(4) == seqs.count(6) == 2 and seqs.count(7) == 1 and seqs[-1] == 8
    assert not s.vehicle.armed


def test_user_mission_across_the_antimeridian_lands_on_its_land_point():
    s, m = fly(mission=MISSIONS_DIR / "quad_dateline.waypoints", wind=(4.0, 120.0),
               turbulence="light", seed=3)
    assert m["completed"] is True and not m["crashed"]
    assert m["mission_items_reached"] == m["mission_items_total"] == 5
    assert m["land_error_ctl_m"] <= 1.0
    assert m["land_error_m"] <= 1.0 + m["nav_pos_h_err_max_m"]
    assert m["xtrack_max_m"] <= 4.0
    a = s.log.arrays()
    # it really flew east of 180 deg: the legs cross it (east of home by 40-80 m)
    assert np.nanmax(a["truth_e_m"]) > 70.0


def _stabilize_roll_step(nav: str, seed: int):
    """Hover (AUTO hold), switch to STABILIZE with the hover throttle, step the pilot's
    roll to 10 deg; the true roll for 2 s after the step (time, roll, roll before)."""
    s = Session(RunConfig(vehicle="quad", airframe="f450", mission=HOVER, seed=seed,
                          duration_s=60.0, nav=nav))
    v = s.vehicle
    while not (v.target is not None and v.target.hold) and s.t_s < 40.0:
        s.step()
    t_hold = s.t_s
    while s.t_s < t_hold + 3.0:
        s.step()
    assert v.set_mode(CopterMode.STABILIZE, int(s.t_s * 1e6)) is None
    v.pilot.throttle = v.ctrl.mixer.command_of(v.params["QD_MASS"] * 9.80665 / 4.0)
    while s.t_s < t_hold + 5.0:
        s.step()
    r0 = math.degrees(quat_to_euler(s.plant.state().q_nb)[0])
    v.pilot.roll_rad = math.radians(10.0)
    t0 = s.t_s
    rolls, ts = [], []
    while s.t_s < t0 + 2.0:
        s.step()
        rolls.append(math.degrees(quat_to_euler(s.plant.state().q_nb)[0]))
        ts.append(s.t_s - t0)
    assert v.mode == CopterMode.STABILIZE and v.armed
    return np.array(ts), np.array(rolls), r0


def test_stabilize_attitude_step_of_10_deg_in_the_full_loop():
    """GIVEN the vehicle hovering (AUTO hold) on the debugging aid ``--nav truth`` WHEN
    switched to STABILIZE with the hover throttle and the pilot's roll stepped to 10 deg
    THEN the true roll overshoots by at most 10 % and settles (2 % band) within 1 s:
    the whole loop (HIL link, mode, pilot input, PDD, mixer, plant) without the
    estimator's error."""
    ts, rolls, r0 = _stabilize_roll_step("truth", 2)
    y = (rolls - r0) / (10.0 - r0)
    assert y.max() - 1.0 <= 0.10
    outside = np.flatnonzero(np.abs(y - 1.0) > 0.02)
    assert ts[outside[-1]] < 1.0


def test_stabilize_attitude_step_of_10_deg_on_the_ekf():
    """The same step flown on the EKF: the loop holds the *estimated* roll at 10 deg, so
    the true roll ends 10 deg plus the filter's roll error, which moves by a few tenths
    of a degree while the vehicle accelerates sideways (so the true roll's settling
    into a 2 % band of its own final value is not a bound here; figures:
    docs/status.md, "Quadrotor"). THEN the true roll overshoots
    10 deg by at most 10 % and is within the issue-3 attitude accuracy (0.5 deg, plus
    its own 0.5 deg start offset at most) of 10 deg from 1 s on."""
    ts, rolls, r0 = _stabilize_roll_step("ekf", 2)
    assert abs(r0) <= 1.0
    assert rolls.max() <= 10.0 + 0.10 * 10.0 + abs(r0)
    late = rolls[ts >= 1.0]
    assert np.all(np.abs(late - 10.0) <= 1.0), (late.min(), late.max())


def test_modes_guided_then_rtl_land_at_home_and_disarm():
    s = Session(RunConfig(vehicle="quad", airframe="f450", mission=HOVER, seed=4, duration_s=200.0))
    v = s.vehicle
    while not (v.target is not None and v.target.hold) and s.t_s < 40.0:
        s.step()
    t = int(s.t_s * 1e6)
    assert v.set_mode(CopterMode.GUIDED, t) is None
    hf = v.home_frame
    lat, lon, _ = hf.to_geodetic(np.array([0.0, 25.0, 0.0]))
    assert v.set_guided_target(lat, lon, hf.alt0_m + 12.0, t) is None
    t_start = s.t_s
    while s.t_s < t_start + 15.0:
        s.step()
    assert v.p_home[1] == pytest.approx(25.0, abs=1.0) and -v.p_home[2] == pytest.approx(12.0, abs=0.5)
    assert v.set_mode(CopterMode.RTL, int(s.t_s * 1e6)) is None
    assert v.set_mode(99, int(s.t_s * 1e6)) is not None            # not a copter mode
    while v.armed and s.t_s < 150.0:
        s.step()
    assert not v.armed and v.landed and not s.plant.crashed
    assert math.hypot(v.p_home[0], v.p_home[1]) < 1.0               # home, as it believes


def test_same_seed_same_quad_flight():
    runs = []
    for seed in (7, 7):
        s, m = fly(mission=HOVER, wind=(3.0, 90.0), turbulence="light", seed=seed, duration_s=25.0)
        runs.append((s.log.arrays(), without_timing(m)))
    (a, ma), (b, mb) = runs
    for col in a:
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)
    assert ma == mb


def test_cli_builds_a_quad_run_from_vehicle_quad():
    from tools.sitl import _config, build_parser
    cfg = _config(build_parser().parse_args(["run", "--vehicle", "quad"]))
    assert cfg.vehicle == "quad" and cfg.airframe == "f450"
    assert cfg.mission == QUAD_DEFAULT_MISSION and cfg.scenario == DEFAULT_SCENARIO


def test_hover_with_an_rtk_receiver_meets_the_issue_bounds_absolutely():
    # GIVEN the hover in 3 m/s wind and light turbulence, flown on the EKF with the RTK
    #       receiver model (`sitl run --gps rtk`: centimetres, 20 Hz; the filter told so)
    s, m = fly(mission=HOVER, wind=(3.0, 270.0), turbulence="light", nav="ekf", seed=2, gps="rtk")
    # THEN the absolute hold figures meet the issue's bounds, which the standard
    #      receiver's wander of decimetres does not always allow (figures:
    #      docs/status.md, "Quadrotor", hover with --gps rtk)
    assert m["completed"] is True and not m["crashed"] and m["gps"] == "rtk"
    assert m["hold_pos_rms_m"] <= 0.3 and m["hold_alt_rms_m"] <= 0.15
    assert m["land_error_m"] <= 0.5
    # AND the filter flew with the receiver's parameters (GPS height reference)
    assert s.params["EK_HGT_REF"] == 1 and s.params["EK_GPS_P_NSE"] == pytest.approx(0.01)
    assert m["gps_pos_h_rms_m"] <= 0.05
