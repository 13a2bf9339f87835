"""Aileron, rudder and throttle actuator faults (autopilot/monitor/lateral.py,
autopilot/monitor/throttle.py): the models carry the shipped aircraft's numbers, each
stuck control is detected, identified and answered (figures: docs/status.md, "Faults
and the monitor": stuck aileron, rudder, throttle)."""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from autopilot.monitor.lateral import AEROSONDE_LAT
from autopilot.monitor.throttle import AEROSONDE_THRUST
from sim_bridge.faults.catalogue import FaultSpecError, check_magnitudes
from sim_bridge.plants.jsbsim_plane import JSBSimPlane
from tools.runner import MISSIONS_DIR, RunConfig, Session
from tools.summary import run_summary

ROOT = Path(__file__).resolve().parent.parent
XML = ROOT / "sim_bridge" / "aircraft" / "aerosonde" / "aerosonde.xml"


def _values(root, name: str) -> list[float]:
    f = root.find(f".//function[@name='{name}']")
    assert f is not None, name
    return [float(v.text) for v in f.iter("value")]


def test_lateral_and_drag_coefficients_are_those_of_the_jsbsim_file():
    # GIVEN the Aerosonde's JSBSim file; THEN the lateral model and the drag polar carry
    # its numbers (the cross inertia with the book's sign: JSBSim's is -0.1204)
    root = ET.parse(XML).getroot()
    m = AEROSONDE_LAT
    assert float(root.find("metrics/wingspan").text) == m.span_m
    assert [float(root.find(f"mass_balance/{k}").text) for k in ("ixx", "iyy", "izz", "ixz")] == \
        [m.Jx, m.Jy, m.Jz, -m.Jxz]
    assert _values(root, "aero/force/side-beta") == [m.CY_b]
    assert _values(root, "aero/force/side-rudder") == [m.CY_dr]
    for axis, coef in (("roll", "Cl"), ("yaw", "Cn")):
        for term, key in (("beta", "b"), ("p", "p"), ("r", "r"), ("aileron", "da"), ("rudder", "dr")):
            assert _values(root, f"aero/moment/{axis}-{term}") == [getattr(m, f"{coef}_{key}")]
    v = _values(root, "aero/aerosonde/CD-alpha")
    assert (v[0], v[2]) == (AEROSONDE_THRUST.CD0, AEROSONDE_THRUST.k_CD)


def test_propeller_power_tables_are_those_of_the_jsbsim_file():
    # GIVEN the propeller's JSBSim file; THEN the rotor model carries its diameter and its
    # C_POWER and CP_RPM_FACTOR tables
    root = ET.parse(XML.parent.parent / "engine" / "APC_18x8E.xml").getroot()
    m = AEROSONDE_THRUST
    assert float(root.find("diameter").text) * 0.0254 == pytest.approx(m.prop_d_m, abs=1e-12)
    assert float(root.find("ixx").text) == m.prop_ixx
    for name, xs, ys in (("C_POWER", m.cp_j, m.cp), ("CP_RPM_FACTOR", m.cp_rpm, m.cp_rpm_k)):
        rows = [[float(v) for v in line.split()]
                for line in root.find(f"table[@name='{name}']/tableData").text.strip().splitlines()]
        assert [r[0] for r in rows] == list(xs) and [r[1] for r in rows] == list(ys)


@pytest.mark.parametrize("speed, throttle", [(20.0, 0.3), (25.0, 0.45), (30.0, 1.0)])
def test_rotor_power_and_spin_up_are_the_plants(speed, throttle):
    # GIVEN the plant trimmed level at 500 m, then the throttle set and held 3 s
    from autopilot.monitor.throttle import _isa_rho
    plant = JSBSimPlane(home=(47.0, 8.0, 500.0, 0.0))
    c = plant.trim(airspeed_mps=speed, height_m=100.0)
    m = AEROSONDE_THRUST
    fdm = plant._fdm
    w = fdm["propulsion/engine/propeller-rpm"] * math.pi / 30.0
    worst = 0.0
    for k in range(30):
        st = plant.step(replace(c, throttle=throttle), n_steps=int(round(0.1 / plant.dt_s)))
        rho = _isa_rho(st.alt_m)
        vt = st.airspeed_mps
        # the model rotor on the command, beside the plant's
        w = m.prop_step(w, throttle, vt, rho, 0.1)
        worst = max(worst, abs(m.prop_throttle(w, vt, rho) - m.prop_throttle(st.rpm * math.pi / 30.0, vt, rho)))
    # THEN the throttle the plant's propeller takes at its speed is the one set, within
    # 0.02 (measured 0.001-0.008), and the model rotor's follows the plant's within 0.05
    # through the step (measured 0.004-0.03)
    assert abs(m.prop_throttle(st.rpm * math.pi / 30.0, vt, rho) - throttle) <= 0.02
    assert worst <= 0.05, worst


@pytest.mark.parametrize("speed, throttle", [(20.0, 0.3), (25.0, 0.45), (30.0, 1.0)])
def test_thrust_curve_is_the_plants_within_half_a_newton(speed, throttle):
    # GIVEN the plant trimmed level, the throttle set and held 1.5 s; THEN its engine's
    # thrust is the model's curve within 0.5 N (the fit's rms: 0.26 N)
    plant = JSBSimPlane(home=(47.0, 8.0, 0.0, 0.0))
    c = plant.trim(airspeed_mps=speed, height_m=300.0)
    plant.step(replace(c, throttle=throttle), n_steps=300)
    thrust = plant._fdm["propulsion/engine/thrust-lbs"] * 4.44822
    v = plant._fdm["velocities/vc-kts"] * 0.514444
    assert abs(AEROSONDE_THRUST.thrust_at(throttle, v) - thrust) <= 0.5


def test_counter_deflection_holds_the_moments_at_zero():
    # GIVEN the aileron stuck at 0.1 rad; THEN the rudder the model gives, with the
    # sideslip it leaves, makes the rolling and yawing moments zero (wings level, no
    # rates): the reaction's feed-forward
    m = AEROSONDE_LAT
    dr = m.counter("aileron", 0.1)
    beta = -(m.Cn_da * 0.1 + m.Cn_dr * -dr) / m.Cn_b
    assert abs(m.Cl_b * beta + m.Cl_da * 0.1 + m.Cl_dr * -dr) < 1e-12
    assert 0.1 < dr < 0.35          # within the rudder's travel: the aircraft can be held


def test_stuck_value_magnitude_is_checked():
    # the throttle's natural unit: a normalised value; refused out of range or with
    # value_rad as well (a clear error, nothing applied)
    assert check_magnitudes("servo", "stuck", {"value": 0.3})["value"] == 0.3
    with pytest.raises(FaultSpecError, match=r"value must be in \[-1, 1\]"):
        check_magnitudes("servo", "stuck", {"value": 1.5})
    with pytest.raises(FaultSpecError, match="not both"):
        check_magnitudes("servo", "stuck", {"value": 0.3, "value_rad": 0.1})


def _scenario(tmp_path, instance: int, key: str, value: float, at_s: float = 60.0) -> Path:
    scen = tmp_path / f"stuck_{instance}_{value}.toml"
    scen.write_text('[wind]\nspeed_mps = 5.0\nfrom_deg = 270.0\nturbulence = "light"\n\n'
                    f'[[event]]\nat_s = {at_s}\nunit = "servo"\ntype = "stuck"\ninstance = {instance}\n'
                    f'{key} = {value}\n')
    return scen


def _fly(scen: Path, duration_s: float, seed: int = 1, **params):
    s = Session(RunConfig(scenario=scen, duration_s=duration_s, seed=seed, param_overrides=params))
    s.run()
    return s, run_summary(s)


@pytest.mark.parametrize("instance, name, value", [(0, "aileron", -0.05), (2, "rudder", 0.1)])
def test_stuck_surface_detected_and_identified(tmp_path, instance, name, value):
    # GIVEN the aileron stuck at -0.05 rad or the rudder at 0.1 rad at 60 s (seed 1)
    s, summ = _fly(_scenario(tmp_path, instance, "value_rad", value), 75.0)
    f = summ["faults"][0]
    # THEN an actuator fault on that surface, detected within 3 s, identified stuck
    #      within 0.015 rad 10 s after the onset (measured: 1.2 s, -0.057; 2.2 s, 0.100),
    #      the other surface countering it, still flying
    assert f["kind"] == "actuator" and f["isolated"] == name and f["isolated_all"] == [name]
    assert f["delay_s"] is not None and f["delay_s"] <= 3.0
    assert abs(f["identified_10s"]["stuck_rad"] - value) <= 0.015, f
    assert s.vehicle.ctrl.surface_out is not None and not s.crashed
    assert summ["false_alarms"] == 0


@pytest.mark.parametrize("instance, name, value, seed", [(0, "aileron", 0.05, 2), (0, "aileron", 0.05, 7),
                                                        (2, "rudder", 0.1, 5)])
def test_small_stuck_offset_with_the_wings_level_detected_within_3s(tmp_path, instance, name, value, seed):
    # GIVEN the aileron stuck 0.05 rad off its trim with the wings level (seeds 2 and 7:
    # the onset at a turn's entry, the command crossing the stuck position within 2.5 s)
    # or the rudder 0.1 rad (seed 5): residuals of 4-6 times a fixed 0.015 rad floor,
    # found after 4.17, 3.81 and 3.19 s with it (measured with the learnt deviation and
    # the 0.005 rad floor: 1.17, 2.81, 1.19 s)
    s, summ = _fly(_scenario(tmp_path, instance, "value_rad", value), 75.0, seed=seed)
    f = summ["faults"][0]
    # THEN detected within 3 s of the onset on that surface, identified within 0.005 rad
    assert f["kind"] == "actuator" and f["isolated_all"] == [name]
    assert f["delay_s"] is not None and f["delay_s"] <= 3.0, f
    assert abs(f["identified_10s"]["stuck_rad"] - value) <= 0.005, f
    assert summ["false_alarms"] == 0 and not s.crashed


def test_lateral_residual_deviation_is_learnt_about_the_fit_from_its_start(tmp_path):
    # GIVEN a fault-free flight (seed 2, the default mission's first 60 s): the warm-up's
    # residual holds the offset not yet learnt (0.010-0.019 rad on the aileron)
    s, summ = _fly(_scenario(tmp_path, 0, "value_rad", 0.05, at_s=500.0), 60.0, seed=2)
    lat = s.vehicle.monitor.lateral
    # THEN 60 s after the launch each axis' deviation is learnt about the fit, at most
    # 0.008 rad (measured aileron 0.0062, rudder 0.0049; 0.0094 and 0.0099 with the
    # warm-up in it, the floor then 0.015), no longer the prior's 0.02
    for n in ("aileron", "rudder"):
        sd = lat.axes[n].r_var ** 0.5
        assert 0.003 <= sd <= 0.008, (n, sd)
    assert summ["false_alarms"] == 0


def test_stuck_aileron_countered_by_the_rudder_or_the_aircraft_is_lost(tmp_path):
    # GIVEN the aileron stuck at 0.1 rad at 60 s: unanswered the aircraft rolls over
    scen = _scenario(tmp_path, 0, "value_rad", 0.1)
    s, summ = _fly(scen, 80.0)
    f = summ["faults"][0]
    # THEN detected within 3 s and identified within 0.015 rad (measured 1.2 s, 0.102),
    assert f["isolated"] == "aileron" and f["delay_s"] <= 3.0
    assert abs(f["identified_10s"]["stuck_rad"] - 0.1) <= 0.015, f
    texts = [e[1] for e in s.log.events]
    assert "aileron out: roll flown on the rudder" in texts
    assert any(t.startswith("FDI: aileron stuck at 0.") and "roll on the rudder" in t for t in texts), texts
    # AND the rudder holds the wings: bank within 60 deg from 3 s after the onset,
    #     the rudder's mean deflection the model's counter (0.12 rad = 0.35) within 0.15
    a = s.log.arrays()
    late = a["t_s"] >= 66.0
    assert np.degrees(np.abs(a["truth_roll_rad"][late])).max() <= 60.0
    assert abs(a["ctl_rudder"][late].mean() - 0.35) <= 0.15
    assert not s.crashed
    # AND without the reaction (LOUT_ENABLE = 0) the same flight is lost
    s0, _ = _fly(scen, 80.0, LOUT_ENABLE=0)
    assert s0.crashed


def test_throttle_stuck_at_full_height_held_airspeed_free(tmp_path):
    # GIVEN the throttle stuck at full at 60 s (seed 1), the whole default mission
    s, summ = _fly(MISSIONS_DIR / "fault_throttle_stuck_full.toml", 420.0)
    f = summ["faults"][0]
    # THEN detected within 3 s, identified stuck within 0.1 of full 10 s after the onset
    #      (measured: 1.7 s, 1.0)
    assert f["isolated"] == "throttle" and f["delay_s"] is not None and f["delay_s"] <= 3.0
    assert f["identified_10s"]["stuck"] >= 0.9, f
    # AND the height is held on the pitch, the airspeed let rise to the full throttle's
    #     level flight (TECS's height priority): from 15 s after the onset within 15 m of
    #     the mission's height (measured -1.0..+5.4 m; with the airspeed flown on the
    #     pitch the aircraft climbed 3 m/s, 638 m over by the mission's end), the airspeed
    #     from 30 m/s (measured 31.7) up to TOUT_ARSPD_MAX and the gusts (measured 41.0)
    a = s.log.arrays()
    late = a["t_s"] >= 75.0
    err = (a["truth_alt_m"] - a["tgt_alt_m"])[late]
    assert np.abs(err).max() <= 15.0, (err.min(), err.max())
    v = a["truth_airspeed_mps"][late]
    assert v.min() >= 30.0 and v.max() <= 42.0, (v.min(), v.max())
    # AND said so: the reaction is the height priority's
    to = s.vehicle.ctrl.throttle_out
    assert to is not None and to["level"] and to["v_top"] is not None
    texts = [e[1] for e in s.log.events]
    assert "throttle out: height held, airspeed free" in texts
    # AND the mission completed, every invariant held, no false alarm
    assert summ["completed"] and summ["invariants_passed"] and not s.crashed
    assert summ["false_alarms"] == 0


def test_throttle_stuck_at_full_without_height_priority_climbs_away(tmp_path):
    # GIVEN the same fault with TOUT_ARSPD_MAX = 0 (the airspeed flown on the pitch, the
    #       height free, as before the height priority), 100 s
    s, _ = _fly(MISSIONS_DIR / "fault_throttle_stuck_full.toml", 100.0, TOUT_ARSPD_MAX=0.0)
    # THEN the airspeed is held within 20-31.5 m/s and the aircraft climbs away from its
    #      mission's height: over 40 m above it 39 s after the onset (measured 70 m)
    a = s.log.arrays()
    late = a["t_s"] >= 70.0
    v = a["truth_airspeed_mps"][late]
    assert v.min() >= 20.0 and v.max() <= 31.5, (v.min(), v.max())
    assert (a["truth_alt_m"] - a["tgt_alt_m"])[a["t_s"] >= 99.0].max() >= 40.0


def test_throttle_stuck_near_cruise_found_once_the_command_leaves_it(tmp_path):
    # GIVEN the throttle stuck at 0.3 at 60 s (cruise needs about 0.4: a tenth of the
    #       throttle is under 3 N of thrust, within the thrust balance's noise), the
    #       propeller's measured speed not used (FDI_THR_RPM 0: the thrust balance alone)
    s, summ = _fly(MISSIONS_DIR / "fault_throttle_stuck_low.toml", 80.0, FDI_THR_RPM=0)
    f = summ["faults"][0]
    # THEN it is found once the airspeed loop has moved the command away from it: within
    #      8 s (measured 5.7 s; the 3 s is not met near the command, docs/status.md),
    #      identified stuck within 0.05 10 s after the onset (measured 0.302)
    assert f["isolated"] == "throttle" and f["delay_s"] is not None and f["delay_s"] <= 8.0
    assert abs(f["identified_10s"]["stuck"] - 0.3) <= 0.05, f
    # AND the model says 0.3 holds level flight slower than the cruise (at most v_top):
    #     the height held, the airspeed free, no RTL, still flying, within 40 m of the
    #     mission's height
    to = s.vehicle.ctrl.throttle_out
    assert to is not None and to["level"] and 19.9 <= to["v_fly"] <= to["v_top"] < 25.0, to
    assert s.vehicle.monitor.failsafe is None and not s.crashed
    a = s.log.arrays()
    late = a["t_s"] >= 70.0
    assert np.abs(a["truth_alt_m"] - a["tgt_alt_m"])[late].max() <= 40.0


@pytest.mark.parametrize("seed", [7, 8])
def test_throttle_stuck_near_cruise_found_within_3s_on_the_rotor_speed(tmp_path, seed):
    # GIVEN the throttle stuck at 0.3 at 60 s, the propeller's speed measured (ESC
    #       telemetry); seeds 7 and 8 the thrust balance's slowest (14.8 and 12.7 s)
    s, summ = _fly(MISSIONS_DIR / "fault_throttle_stuck_low.toml", 100.0, seed=seed)
    f = summ["faults"][0]
    # THEN found on the throttle within 3 s of the onset (whole missions: 2.81 and 2.21 s;
    #      the command within 0.02 of the stuck 0.3 at the onset, no residual until it
    #      moves), identified stuck within 0.03 10 s after it and within 0.02 at the end
    #      (whole missions: 0.293, 0.322; 0.315, 0.291), no false alarm
    assert f["isolated_all"] == ["throttle"] and f["delay_s"] is not None and f["delay_s"] <= 3.0, f
    assert abs(f["identified_10s"]["stuck"] - 0.3) <= 0.03, f
    assert abs(f["identified"]["stuck"] - 0.3) <= 0.02, f
    assert s.vehicle.monitor.throttle.rotor_measured
    assert summ["false_alarms"] == 0 and not s.crashed


def test_throttle_stuck_near_cruise_read_stuck_with_the_command_hardly_moving(tmp_path):
    # GIVEN the throttle stuck at 0.3 at 60 s, seed 10: the command stays 0.48-0.76 over
    #       the 10 s after the onset (the airspeed over the demand at first), far from zero,
    #       so the weakened fit z = k d through zero fits it nearly as well as a constant
    s, summ = _fly(MISSIONS_DIR / "fault_throttle_stuck_low.toml", 75.0, seed=10)
    f = summ["faults"][0]
    # THEN read stuck within 0.03 of 0.3 10 s after the onset (measured: stuck from
    #      +8.75 s, 0.299 at +10 s; the code before read "effectiveness 0.572" then, its
    #      residual ratio 0.059 over the surfaces' 0.05), no false alarm
    assert f["isolated_all"] == ["throttle"] and f["identified_10s"] is not None, f
    assert abs(f["identified_10s"].get("stuck", -1.0) - 0.3) <= 0.03, f
    assert summ["false_alarms"] == 0 and not s.crashed


def test_weakened_throttle_still_read_weakened_on_the_rotor_speed(tmp_path):
    # GIVEN the throttle at 50 % effectiveness from 60 s, seed 2 (of the weakened flights
    #       the one whose command moves least: 0.51-0.66)
    scen = tmp_path / "throttle_loe.toml"
    scen.write_text('[wind]\nspeed_mps = 5.0\nfrom_deg = 270.0\nturbulence = "light"\n\n'
                    '[[event]]\nat_s = 60.0\nunit = "servo"\ntype = "wrong"\ninstance = 3\n'
                    'effectiveness = 0.5\n')
    s, summ = _fly(scen, 75.0, seed=2)
    f = summ["faults"][0]
    # THEN detected on the throttle and read weakened 10 s after the onset, not stuck
    #      (measured effectiveness 0.541; the stuck fit's residual 5.9 times the weakened
    #      fit's at least after the onset's transient, against the 0.1 that reads stuck)
    assert f["isolated_all"] == ["throttle"] and f["delay_s"] is not None and f["delay_s"] <= 3.0, f
    assert abs(f["identified_10s"].get("effectiveness", -1.0) - 0.5) <= 0.06, f
    assert s.vehicle.monitor.throttle.rotor_measured
    assert summ["false_alarms"] == 0 and not s.crashed


def test_throttle_stuck_near_cruise_height_held_mission_completed(tmp_path):
    # GIVEN the throttle stuck at 0.3 at 60 s (seed 1), the whole default mission: the
    #       model says 0.3 holds level flight up to 22 m/s, slower than the cruise
    s, summ = _fly(MISSIONS_DIR / "fault_throttle_stuck_low.toml", 420.0)
    f = summ["faults"][0]
    assert f["isolated"] == "throttle" and f["delay_s"] is not None
    # THEN from 10 s after the detection the height is held on the pitch within 20 m of
    #      the mission's (measured -8.4..+2.9 m; with the airspeed flown on the pitch the
    #      height was free: -26..+85 m), the airspeed over 18.5 m/s (ARSPD_FBW_MIN 20
    #      bounds the climbs; measured 19.9)
    a = s.log.arrays()
    late = a["t_s"] >= f["detected_s"] + 10.0
    err = (a["truth_alt_m"] - a["tgt_alt_m"])[late]
    assert np.abs(err).max() <= 20.0, (err.min(), err.max())
    assert a["truth_airspeed_mps"][late].min() >= 18.5
    # AND the mission completed without an RTL, every invariant held, no false alarm
    assert s.vehicle.monitor.failsafe is None
    assert summ["completed"] and summ["invariants_passed"] and not s.crashed
    assert summ["false_alarms"] == 0


def _stabilised(trim, pitch0_rad, st):
    """The trim's controls with the pitch held at pitch0_rad and the wings level (a
    proportional-derivative stabiliser on the elevator and ailerons)."""
    from autopilot.geo.rotations import quat_to_euler
    roll, pitch, _ = quat_to_euler(st.q_nb)
    p, q, _r = st.omega_b
    return replace(trim, elevator=float(np.clip(trim.elevator + (2.0 * (pitch0_rad - pitch) - 0.5 * q) / 0.35, -1, 1)),
                   aileron=float(np.clip(trim.aileron - (1.5 * roll + 0.3 * p) / 0.35, -1, 1)))


def test_thrust_balance_unbiased_in_gusts_near_the_ground():
    # GIVEN the plant trimmed at 25 m/s 8 m above the ground in moderate turbulence
    # (MIL-F-8785C: the vertical gusts' scale length is the height), the throttle held,
    # the pitch and roll held by a stabiliser, the thrust balance fed as in flight
    from types import SimpleNamespace

    from autopilot.geo.rotations import quat_to_euler
    from autopilot.monitor.throttle import ThrottleIdentifier

    plant = JSBSimPlane(home=(47.0, 8.0, 0.0, 0.0), turbulence="moderate", rng=np.random.default_rng(3))
    trim = plant.trim(airspeed_mps=25.0, height_m=8.0)
    cmd, th0 = trim, quat_to_euler(plant.state().q_nb)[1]
    ident = ThrottleIdentifier(AEROSONDE_THRUST)
    res = []
    for k in range(50 * 25):
        st = plant.step(cmd, 4)
        cmd = _stabilised(trim, th0, st)
        ident.step(k * 20_000, SimpleNamespace(airspeed_mps=st.airspeed_mps, omega_b=st.omega_b),
                   (cmd.aileron, cmd.elevator, cmd.rudder, cmd.throttle), True, st.f_b)
        if k >= 250:
            res.append(ident.axes["throttle"].hist[-1][1] - trim.throttle)
    # THEN the throttle it reads is the one held within 0.035 on average (measured -0.020;
    # without the gusts' second-order terms +0.073, and random-plane trial 315's approach
    # at 3-6 m read 0.15-0.3 high: a false throttle alarm)
    assert abs(np.mean(res)) < 0.035, np.mean(res)


def test_thrust_balance_follows_a_throttle_step_from_idle():
    # GIVEN the plant trimmed at 25 m/s at idle, then the throttle stepped to full (a
    # go-around's, or a climb's after an idle descent), the pitch and roll stabilised
    from types import SimpleNamespace

    from autopilot.geo.rotations import quat_to_euler
    from autopilot.monitor.throttle import ThrottleIdentifier

    plant = JSBSimPlane(home=(47.0, 8.0, 0.0, 0.0))
    trim = plant.trim(airspeed_mps=25.0, height_m=300.0)
    cmd, th0 = replace(trim, throttle=0.0), quat_to_euler(plant.state().q_nb)[1]
    ident = ThrottleIdentifier(AEROSONDE_THRUST)
    res = []
    for k in range(50 * 16):
        st = plant.step(cmd, 4)
        cmd = _stabilised(replace(trim, throttle=0.0 if k < 50 * 8 else 1.0), th0, st)
        ident.step(k * 20_000, SimpleNamespace(airspeed_mps=st.airspeed_mps, omega_b=st.omega_b),
                   (cmd.aileron, cmd.elevator, cmd.rudder, cmd.throttle), True, st.f_b)
        if k >= 50 * 7:
            _t, z, d = ident.axes["throttle"].hist[-1]
            res.append(z - d)
    # THEN the throttle read follows the command within 0.15 through the motor's spin-up
    # (the thrust's lag, ThrustModel.tau_s 0.5 s, the plant's step responses: 63 % in
    # 0.45-0.68 s): measured 0.106; with the thrust taken as instantaneous 0.351 (random-
    # plane trial 84: -0.35 for 2 s at a climb from idle in moderate turbulence, 1.09x)
    assert np.abs(res).max() < 0.15, np.abs(res).max()


def _idle_descent_then_throttle(idle_s: float, throttle: float, stuck: bool, model=AEROSONDE_THRUST):
    """The plant trimmed at 25 m/s 400 m up, 30 s of cruise, then an idle descent (the
    pitch held 0.12 rad lower, about 27 m/s) of ``idle_s`` and the throttle commanded up
    to ``throttle`` over 2 s, the thrust balance fed as in flight; ``stuck``: the plant's
    throttle held at idle from the descent on. Returns the largest statistic over its
    detection level (FDI_ACT_THR 3) from 1 s before the command rises, and the time from
    its rise to the first over 1 (None: never)."""
    from types import SimpleNamespace

    from autopilot.geo.rotations import quat_to_euler
    from autopilot.monitor.throttle import ThrottleIdentifier

    plant = JSBSimPlane(home=(47.0, 8.0, 0.0, 0.0))
    trim = plant.trim(airspeed_mps=25.0, height_m=400.0)
    th0 = quat_to_euler(plant.state().q_nb)[1]
    ident = ThrottleIdentifier(model)
    cmd, peak, t_det, rise = trim, 0.0, None, 30.0 + idle_s
    for k in range(int((rise + 15.0) * 50)):
        t = k * 0.02
        thr = trim.throttle if t < 30.0 else (0.0 if t < rise else min(throttle, throttle * (t - rise) / 2.0))
        st = plant.step(cmd, 4)
        flown = 0.0 if stuck and t >= 30.0 else thr
        cmd = _stabilised(replace(trim, throttle=flown), th0 - (0.12 if 30.0 <= t < rise else 0.0), st)
        ident.step(k * 20_000, SimpleNamespace(airspeed_mps=st.airspeed_mps, omega_b=st.omega_b),
                   (cmd.aileron, cmd.elevator, cmd.rudder, thr), True, st.f_b)
        if t >= rise - 1.0:
            r = ident.axes["throttle"].ratio / 3.0
            peak = max(peak, r)
            if r > 1.0 and t_det is None:
                t_det = t - rise
    return peak, t_det


@pytest.mark.parametrize("idle_s, throttle", [(10.0, 0.55), (40.0, 0.55), (40.0, 1.0)])
def test_throttle_opened_after_an_idle_descent_is_no_fault(idle_s, throttle):
    # GIVEN an idle descent, then the throttle opened: at idle the propeller slows
    # below the speed at which it gives thrust (6000 to 1500 rpm in 40 s on the plant),
    # and opened again it gives none until the motor has spun it back up (1.7 s at 0.55)
    peak, t_det = _idle_descent_then_throttle(idle_s, throttle, stuck=False)
    # THEN the throttle's statistic stays far under its detection level: measured 0.008
    # (10 s, 0.55), 0.007 (40 s, 0.55), 0.056 (40 s, 1.0); with the thrust a first-order
    # lag of the command (ThrustModel.tau_s, prop_ixx 0) 0.29, 0.57, 0.58, and random-
    # plane trial 397's 38 s idle descent read the throttle 0.27 low for 2 s as it opened
    # to 0.5: a false alarm (1.02x), taken for a throttle stuck at full, and the aircraft
    # flew its airspeed on the pitch to 2100 m instead of landing
    assert t_det is None and peak < 0.2, peak
    # AND without the rotor's speed (the lag alone) the same flight comes nearer (the
    #     bound above fails it)
    peak0, _ = _idle_descent_then_throttle(idle_s, throttle, stuck=False,
                                           model=replace(AEROSONDE_THRUST, prop_ixx=0.0))
    assert peak0 > 0.25, peak0


@pytest.mark.parametrize("throttle", [0.55, 1.0])
def test_throttle_stuck_at_idle_found_when_opened_after_a_descent(throttle):
    # GIVEN the throttle stuck at idle from the start of a 40 s idle descent, then
    #       commanded up to 0.55 or full over 2 s
    peak, t_det = _idle_descent_then_throttle(40.0, throttle, stuck=True)
    # THEN detected within 4.5 s of the command's rise (measured 3.92 s at 0.55, 2.92 at
    #      full; with the first-order lag 3.42, 2.42: the rotor's spin-up is waited for)
    assert t_det is not None and t_det <= 4.5, (t_det, peak)
