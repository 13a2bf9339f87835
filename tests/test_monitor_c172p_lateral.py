"""The c172p's aileron and rudder watched from the climb-out on with its own lateral
model (autopilot/monitor/lateral.py C172P_LAT, LAT_MODELS[2], chosen by FDI_EL_MODEL 2
in missions/params/c172p.parm): the model carries its JSBSim file's numbers, solves
the plant's own motion for the deflections flown, and a stuck aileron is found."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from autopilot.monitor.lateral import C172P_LAT, LAT_MODELS
from test_monitor_airframe import C172P_XML, FT_M, IN_M, LB_KG, SLUGFT2, _c172p_mass


def _fn(root, name: str):
    f = root.find(f".//function[@name='{name}']")
    assert f is not None, name
    return f


def _value(root, name: str) -> float:
    return float(_fn(root, name).find("product/value").text)


def _table(root, name: str) -> tuple[np.ndarray, np.ndarray]:
    """A coefficient's table: its breakpoints and first data column (flaps up)."""
    rows = [r.split() for r in _fn(root, name).find(".//tableData").text.strip().splitlines()]
    two_d = len(rows[0]) < len(rows[1])
    data = np.array([[float(v) for v in r] for r in (rows[1:] if two_d else rows)])
    return data[:, 0], data[:, 1]


def _slope(root, name: str) -> float:
    x, y = _table(root, name)
    return (y[-1] - y[0]) / (x[-1] - x[0])


def _props(root, name: str) -> list[str]:
    return [p.text.strip() for p in _fn(root, name).iter("property")]


def test_c172p_lateral_coefficients_are_those_of_its_jsbsim_file():
    # GIVEN the c172p's JSBSim file, the one the simulator flies (jsbsim's package path)
    root = ET.parse(C172P_XML).getroot()
    m = C172P_LAT
    assert LAT_MODELS[2] is m
    # THEN the wing and the mass (empty, the point masses, the fuel) are its numbers
    assert float(root.find("metrics/wingspan").text) * FT_M == pytest.approx(m.span_m)
    assert float(root.find("metrics/wingarea").text) * FT_M ** 2 == pytest.approx(m.wing_area_m2)
    w, cg_x, cg_z = _c172p_mass(root)
    assert w * LB_KG == pytest.approx(m.mass_kg)
    # AND the side force, rolling and yawing moments' derivatives (the beta tables'
    #     slopes, the damping's values, the alpha tables' ends and slopes)
    assert _slope(root, "aero/coefficient/CYb") == pytest.approx(m.CY_b)
    assert _slope(root, "aero/coefficient/Clb") == pytest.approx(m.Cl_b)
    assert _slope(root, "aero/coefficient/Cnb") == pytest.approx(m.Cn_b)
    assert _value(root, "aero/coefficient/CDbeta") == m.CD_beta
    assert _value(root, "aero/coefficient/CDo") == m.CD0
    a, c = _table(root, "aero/coefficient/CDwbh")
    assert np.interp(m.CD_alpha[0], a, c) == pytest.approx(m.CD_alpha[1], abs=1e-12)
    for name, v in (("CYdr", m.CY_dr), ("Clp", m.Cl_p), ("ClDa", m.Cl_da), ("Cldr", m.Cl_dr),
                    ("Cnp", m.Cn_p), ("Cnr", m.Cn_r), ("Cnda", m.Cn_da), ("Cndr", m.Cn_dr)):
        assert _value(root, f"aero/coefficient/{name}") == v, name
    assert _value(root, "aero/coefficient/CYda") == 0.0
    for name, v0, va in (("CYp", m.CY_p, m.CY_p_a), ("CYr", m.CY_r, m.CY_r_a), ("Clr", m.Cl_r, m.Cl_r_a)):
        a, c = _table(root, f"aero/coefficient/{name}")
        assert (a[0], a[-1]) == (0.0, m.alpha_max)
        assert (c[0], (c[-1] - c[0]) / a[-1]) == pytest.approx((v0, va)), name
    # AND the aileron's moments act on the left aileron alone, the rudder's yaw on the
    #     slipstream's dynamic pressure, its side force and roll on the free stream's
    for name in ("ClDa", "Cnda"):
        assert "fcs/left-aileron-pos-rad" in _props(root, f"aero/coefficient/{name}")
    assert "aero/function/qbar-induced-psf" in _props(root, "aero/coefficient/Cndr")
    for name in ("CYdr", "Cldr"):
        assert "aero/qbar-psf" in _props(root, f"aero/coefficient/{name}")
    # AND the aerodynamic reference point lies that far behind and above the CG
    rp = root.find("metrics/location[@name='AERORP']")
    assert (float(rp.find("x").text) - cg_x) * IN_M == pytest.approx(m.arp_x_m, abs=2e-4)
    assert (float(rp.find("z").text) - cg_z) * IN_M == pytest.approx(m.arp_z_m, abs=2e-4)
    # AND the accelerometer (JSBSim's a-pilot, the plant's) sits at the eyepoint: ahead
    #     of and above the CG
    eye = root.find("metrics/location[@name='EYEPOINT']")
    assert (cg_x - float(eye.find("x").text)) * IN_M == pytest.approx(m.imu_x_m, abs=2e-4)
    assert -(float(eye.find("z").text) - cg_z) * IN_M == pytest.approx(m.imu_z_m, abs=2e-4)
    # AND the propeller's rotating inertia and spin are its file's and the thruster's
    prop = ET.parse(C172P_XML.parent.parent.parent / "engine" / "prop_75in2f.xml").getroot()
    assert float(prop.find("ixx").text) * SLUGFT2 == pytest.approx(m.prop_ixx)
    assert float(root.find(".//thruster/sense").text) == m.prop_sense
    # AND the FCS moves the left aileron 15 deg for aileron +1 (roll right) and 20 deg
    #     for -1, the rudder 16 deg, per 0.35 autopilot rad
    la = root.find(".//aerosurface_scale[@name='Left Aileron Control']")
    g = float(la.find("gain").text)
    assert float(la.find("range/max").text) * g == pytest.approx(m.da_right * 0.35)
    assert -float(la.find("range/min").text) * g == pytest.approx(m.da_left * 0.35)
    ru = root.find(".//aerosurface_scale[@name='Rudder Control']")
    assert float(ru.find("range/max").text) * float(ru.find("gain").text) == pytest.approx(m.dr_gain * 0.35)


def _plant_solution(hold: list[tuple[float, float, float]]):
    """The plant trimmed level at 45 m/s (equivalent) 300 m up, then each (aileron,
    rudder, seconds) held (autopilot rad, the pitch held by a stabiliser, the roll
    free); every 0.1 s the model solves the plant's own state (body rates, their
    derivatives, the specific force at the accelerometer, the equivalent airspeed, the
    propeller's momentum at the throttle held) for the deflections. Returns rows of
    (aileron commanded, solved, rudder commanded, solved) and the plant's inertia."""
    from dataclasses import replace

    from autopilot.geo.rotations import quat_to_euler
    from sim_bridge.plants.jsbsim_plane import JSBSimPlane

    m = C172P_LAT
    plant = JSBSimPlane("c172p", home=(47.0, 8.0, 500.0, 0.0))
    rho = 1.225 * (1.0 - 2.25577e-5 * 800.0) ** 4.2559
    trim = plant.trim(airspeed_mps=45.0 / np.sqrt(rho / 1.225), height_m=300.0)
    fdm = plant._fdm
    th0 = quat_to_euler(plant.state().q_nb)[1]
    cmd, rows = trim, []
    for da, dr, secs in hold:
        for k in range(int(round(secs / 0.02))):
            st = plant.step(cmd, int(round(0.02 / plant.dt_s)))
            pitch = quat_to_euler(st.q_nb)[1]
            p, q, r = st.omega_b
            cmd = replace(trim, aileron=da / 0.35, rudder=dr / 0.35,
                          elevator=float(np.clip(trim.elevator + (2.0 * (th0 - pitch) - 0.5 * q) / 0.35, -1, 1)))
            if k % 5 == 4:
                ve = fdm["velocities/vc-kts"] * 0.514444
                n_gyro = -m.prop_momentum(trim.throttle, ve) * q
                za, zr = m.deflections(ve, p, q, r, fdm["accelerations/pdot-rad_sec2"],
                                       fdm["accelerations/rdot-rad_sec2"], st.f_b[1], n_gyro, st.f_b[2])
                rows.append((cmd.aileron * 0.35, za, cmd.rudder * 0.35, zr))
    inertia = [fdm[f"inertia/{k}-slugs_ft2"] * SLUGFT2 for k in ("ixx", "iyy", "izz", "ixz")]
    return np.array(rows), inertia


def test_c172p_lateral_model_solves_the_plants_motion_for_its_deflections():
    # GIVEN the plant in level flight at the circuit's 45 m/s, then the aileron and the
    #       rudder held off their trim, each way (a roll and a sideslip building up)
    m = C172P_LAT
    hold = [(0.0, 0.0, 2.0), (0.08, 0.0, 1.5), (-0.08, 0.0, 1.5), (0.0, 0.0, 2.0),
            (0.0, 0.1, 1.5), (0.0, -0.1, 1.5), (0.03, 0.05, 2.0)]
    rows, inertia = _plant_solution(hold)
    # THEN its inertia (the point masses and the fuel with it) is the model's
    assert inertia[:3] == pytest.approx([m.Jx, m.Jy, m.Jz], rel=1e-3)
    assert -inertia[3] == pytest.approx(m.Jxz, rel=1e-2)
    # AND the deflections solved from the plant's motion are those commanded, less an
    #     offset the model leaves out (the engine's torque and what the offset fit learns
    #     in flight; measured aileron -0.010, rudder -0.005 rad at the trim's 0.64
    #     throttle): each within 0.012 rad of it as the surfaces move (measured aileron
    #     0.0094, 0.0022 rms; rudder 0.0058, 0.0025 rms; without the sideslip's drag,
    #     CDbeta, the rudder's was 0.022: with a rudder held 0.1 rad the sideslip builds
    #     to 0.08 rad and the side force's equation was 1.3e-3 short, the sideslip 9 %
    #     high)
    err_a = rows[:, 1] - rows[:, 0]
    err_r = rows[:, 3] - rows[:, 2]
    off_a, off_r = err_a[:20].mean(), err_r[:20].mean()
    assert abs(off_a) <= 0.02 and abs(off_r) <= 0.02, (off_a, off_r)
    assert np.abs(err_a - off_a).max() <= 0.012, np.abs(err_a - off_a).max()
    assert np.abs(err_r - off_r).max() <= 0.012, np.abs(err_r - off_r).max()


def _fly_c172p(tmp_path, duration_s: float, stuck_rad: float | None = None, seed: int = 1, **params):
    """The c172p's circuit in light turbulence and 5 m/s down the runway (from 270),
    the aileron stuck at ``stuck_rad`` 60 s after the start (None: no fault)."""
    from tools.runner import MISSIONS_DIR, RunConfig, Session
    from tools.summary import run_summary

    text = '[wind]\nspeed_mps = 5.0\nfrom_deg = 270.0\nturbulence = "light"\n'
    if stuck_rad is not None:
        text += ('\n[[event]]\nat_s = 60.0\nunit = "servo"\ntype = "stuck"\ninstance = 0\n'
                 f'value_rad = {stuck_rad}\n')
    scen = tmp_path / "c172p_lat.toml"
    scen.write_text(text)
    s = Session(RunConfig(airframe="c172p", mission=MISSIONS_DIR / "c172p_circuit.waypoints", scenario=scen,
                          seed=seed, duration_s=duration_s, param_overrides=params))
    s.run()
    return s, run_summary(s)


def test_c172p_climb_out_in_gusts_raises_no_rudder_alarm(tmp_path):
    # GIVEN the c172p's runway take-off and climb-out in light turbulence with 5 m/s
    #       down the runway (seed 1): on the ground roll the navigation filter's
    #       synthetic sideslip read the side forces as an accelerometer bias of 0.2-0.3
    #       m/s^2 (true 0.03-0.07), which the bias-corrected specific force carried into
    #       the side-force equation: the rudder read -0.11 rad after the lift-off, a false
    #       rudder alarm at 29.6 s (1.17x)
    s, summ = _fly_c172p(tmp_path, 100.0)
    assert s.vehicle.monitor.lateral is not None and s.vehicle.monitor.lateral_model.name == "c172p"
    # THEN on the accelerometer as measured, no alarm, both statistics far under their
    #      threshold (measured aileron 0.27, rudder 0.10)
    assert summ["false_alarms"] == 0 and summ["fdi_episodes"] == [], summ["fdi_episodes"]
    assert summ["fdi_peak_ratio"]["aileron"] <= 0.6 and summ["fdi_peak_ratio"]["rudder"] <= 0.6
    assert not s.crashed


def test_c172p_stuck_aileron_found_and_flown_on_the_rudder(tmp_path):
    # GIVEN the c172p's aileron stuck at 0.1 rad 60 s after the start (seed 1), in the
    #       turn after the climb-out; unanswered it rolls past 60 deg and is lost
    s, summ = _fly_c172p(tmp_path, 80.0, stuck_rad=0.1)
    f = summ["faults"][0]
    # THEN an actuator fault of the aileron, detected within 3 s (measured 1.57 s),
    #      identified stuck within 0.03 rad 10 s after the onset (measured 0.078: the
    #      rudder's counter-deflection, 0.26 rad, and its sideslip), no false alarm
    assert f["kind"] == "actuator" and f["isolated"] == "aileron", f
    assert f["delay_s"] is not None and f["delay_s"] <= 3.0, f
    assert abs(f["identified_10s"]["stuck_rad"] - 0.1) <= 0.03, f
    assert summ["false_alarms"] == 0
    # AND the roll flown on the rudder: still flying, the bank within 45 deg from 5 s
    #     after the onset
    texts = [e[1] for e in s.log.events]
    assert "aileron out: roll flown on the rudder" in texts
    a = s.log.arrays()
    late = a["t_s"] >= 65.0
    assert np.degrees(np.abs(a["truth_roll_rad"][late])).max() <= 45.0
    assert not s.crashed
