"""The fault monitor's airframe model (autopilot/monitor/airframe.py): its coefficients
are the shipped aircraft's, and the moment balance they predict is the plant's trim."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from autopilot.monitor.airframe import AEROSONDE, C172P, MODELS
from sim_bridge.plants.jsbsim_plane import JSBSimPlane

ROOT = Path(__file__).resolve().parent.parent
XML = ROOT / "sim_bridge" / "aircraft" / "aerosonde" / "aerosonde.xml"
HOME = (47.0, 8.0, 500.0, 270.0)


def _function_values(root, name: str) -> list[float]:
    f = root.find(f".//function[@name='{name}']")
    assert f is not None, name
    return [float(v.text) for v in f.iter("value")]


def test_coefficients_are_those_of_the_jsbsim_file():
    # GIVEN the Aerosonde's JSBSim file; THEN the monitor's model carries its numbers
    root = ET.parse(XML).getroot()
    assert float(root.find("metrics/wingarea").text) == AEROSONDE.wing_area_m2
    assert float(root.find("metrics/chord").text) == AEROSONDE.chord_m
    assert float(root.find("mass_balance/emptywt").text) == AEROSONDE.mass_kg
    assert _function_values(root, "aero/aerosonde/CL-linear") == [AEROSONDE.CL0, AEROSONDE.CLa]
    assert _function_values(root, "aero/force/lift-elevator") == [AEROSONDE.CLde]
    assert _function_values(root, "aero/moment/pitch-basic") == [AEROSONDE.Cm0, AEROSONDE.Cma]
    assert _function_values(root, "aero/moment/pitch-elevator") == [AEROSONDE.Cmde]
    assert _function_values(root, "aero/moment/pitch-q") == [AEROSONDE.Cmq]
    assert float(root.find("mass_balance/iyy").text) == AEROSONDE.Iyy
    # AND the thrust line passes through the CG (no thrust moment: c_t = 0)
    thr = root.find(".//thruster/location")
    cg = root.find("mass_balance/location")
    assert float(thr.find("z").text) == float(cg.find("z").text)
    assert AEROSONDE.thrust_z_m == 0.0 and AEROSONDE.balance(25.0)[2] == 0.0


@pytest.mark.parametrize("speed", [18.0, 25.0, 30.0, 35.0])
def test_predicted_level_elevator_is_the_plants_trim(speed):
    # GIVEN the JSBSim plant trimmed level at an airspeed; THEN the model's balance at
    # n = 1 gives its elevator within 0.006 rad (the pitch damping and the stall blend the
    # model leaves out; 100 m above a 500 m home: density 5 % under sea level's, the
    # equivalent airspeed the balance takes is sqrt(rho / rho0) V)
    plant = JSBSimPlane(home=HOME)
    c = plant.trim(airspeed_mps=speed, height_m=100.0)
    rho = 1.225 * (1.0 - 2.25577e-5 * 600.0) ** 4.2559
    v_eas = speed * np.sqrt(rho / 1.225)
    predicted = AEROSONDE.elevator_for(1.0, v_eas)
    assert abs(c.elevator * 0.35 - predicted) <= 0.006, (c.elevator * 0.35, predicted)


def test_trim_airspeed_inverts_the_balance():
    # GIVEN a stuck elevator; THEN the level trim airspeed the model gives balances it
    for delta in (0.03, 0.05, 0.1, 0.17):
        v = AEROSONDE.trim_airspeed(delta)
        assert v is not None and abs(AEROSONDE.elevator_for(1.0, v) - delta) < 1e-9
    # nose-down of trim -> faster than the 25 m/s cruise, nose-up -> slower
    assert AEROSONDE.trim_airspeed(0.05) > 30.0 > 25.0 > AEROSONDE.trim_airspeed(0.17)
    # AND a deflection no airspeed balances (lift would have to be negative): none
    assert AEROSONDE.trim_airspeed(-0.05) is None


def test_level_flight_limits_are_the_plants():
    # GIVEN the plant 100 m above a 500 m home (equivalent airspeed sqrt(rho / rho0) V)
    # THEN it trims level just inside the model's limits and not 1 m/s beyond them
    _trims_within_the_limits(JSBSimPlane(home=HOME), AEROSONDE, 100.0)


def _trims_within_the_limits(plant, model, height_m: float) -> None:
    """The plant trims level 0.5 m/s inside the model's level-flight limits (equivalent
    airspeeds, at ``height_m`` above HOME) and not 1 m/s beyond them."""
    rho = 1.225 * (1.0 - 2.25577e-5 * (HOME[2] + height_m)) ** 4.2559
    tas = 1.0 / np.sqrt(rho / 1.225)
    c = plant.trim(airspeed_mps=(model.v_level_max_mps - 0.5) * tas, height_m=height_m)
    assert c.throttle <= 1.0
    plant.trim(airspeed_mps=(model.v_level_min_mps + 0.5) * tas, height_m=height_m)
    for v in (model.v_level_max_mps + 1.0, model.v_level_min_mps - 1.0):
        with pytest.raises(RuntimeError):
            plant.trim(airspeed_mps=v * tas, height_m=height_m)


def test_pitch_rate_terms():
    # GIVEN a steady pull-up at 0.2 rad/s, 25 m/s; THEN the damping asks for more nose-up
    # elevator, Cmq cbar q / (2 V) / D (D = Cmde - Cma CLde / CLa)
    D = AEROSONDE.Cmde - AEROSONDE.Cma / AEROSONDE.CLa * AEROSONDE.CLde
    damping = AEROSONDE.Cmq * AEROSONDE.chord_m * 0.2 / (2.0 * 25.0) / D
    assert AEROSONDE.dynamic_elevator(0.2, 0.0, 25.0) == pytest.approx(damping)
    assert damping > 0.0
    # AND a nose-up pitch acceleration too, Iyy q_dot / (qbar S cbar) / -D
    qbar = 0.5 * 1.225 * 25.0 ** 2
    inertia = AEROSONDE.Iyy * 1.0 / (qbar * AEROSONDE.wing_area_m2 * AEROSONDE.chord_m) / -D
    assert AEROSONDE.dynamic_elevator(0.0, 1.0, 25.0) == pytest.approx(inertia)
    assert inertia > 0.0


ENGINE = ROOT / "sim_bridge" / "aircraft" / "engine" / "APC_18x8E.xml"


@pytest.mark.parametrize("throttle, rudder", [(0.3, 0.3), (0.8, -0.3)])
def test_propeller_gyroscopic_moment_is_the_plants(throttle, rudder):
    # GIVEN the propeller's inertia of the engine file, and the plant trimmed at 25 m/s,
    #       then yawing on a held rudder (either way) at a held throttle for 3 s
    assert float(ET.parse(ENGINE).getroot().find("ixx").text) == AEROSONDE.prop_ixx
    from dataclasses import replace
    plant = JSBSimPlane(home=HOME)
    c = plant.trim(airspeed_mps=25.0, height_m=300.0)
    plant.step(replace(c, throttle=throttle, rudder=rudder), n_steps=600)
    fdm = plant._fdm
    r = fdm["velocities/r-aero-rad_sec"]
    v = fdm["velocities/vc-kts"] * 0.514444
    m_prop = fdm["moments/m-prop-lbsft"] * 1.35582
    # THEN the pitch moment the model's elevator term stands for (H r from the model's
    # rpm at that throttle and airspeed) is the plant's propeller moment within 10 %
    # (and of its sign: nose up in a right yaw), and the rpm within 300
    D = AEROSONDE.Cmde - AEROSONDE.Cma / AEROSONDE.CLa * AEROSONDE.CLde
    qbar = 0.5 * 1.225 * v * v
    m_model = AEROSONDE.gyro_elevator(r, throttle, v) * D * qbar * AEROSONDE.wing_area_m2 * AEROSONDE.chord_m
    assert abs(r) > 0.05
    assert m_model == pytest.approx(m_prop, rel=0.10), (m_model, m_prop, r)
    a, b, cc, d = AEROSONDE.rpm
    assert abs(a + b * throttle + cc * v + d * throttle * v - fdm["propulsion/engine/propeller-rpm"]) <= 300.0
    # AND its yawing part, -H q (the lateral balance's n_gyro), within 10 % (measured 1-3 %)
    q = fdm["velocities/q-aero-rad_sec"]
    n_prop = fdm["moments/n-prop-lbsft"] * 1.35582
    assert abs(q) > 0.1
    assert -AEROSONDE.prop_momentum(throttle, v) * q == pytest.approx(n_prop, rel=0.10), (q, n_prop)


# ---------------------------------------------------------------- the c172p

import jsbsim  # noqa: E402

C172P_XML = Path(jsbsim.__file__).resolve().parent / "aircraft" / "c172p" / "c172p.xml"
LB_KG, FT_M, IN_M, SLUGFT2 = 0.45359237, 0.3048, 0.0254, 1.3558179


def _c172p_mass(root):
    """Weight [lb] and CG (x, z) [in] of the empty aircraft, its point masses and fuel."""
    items = [(float(root.find("mass_balance/emptywt").text), root.find("mass_balance/location"))]
    for pm in root.findall("mass_balance/pointmass"):
        items.append((float(pm.find("weight").text), pm.find("location")))
    for tank in root.findall("propulsion/tank"):
        items.append((float(tank.find("contents").text), tank.find("location")))
    w = sum(m for m, _ in items)
    x = sum(m * float(loc.find("x").text) for m, loc in items) / w
    z = sum(m * float(loc.find("z").text) for m, loc in items) / w
    return w, x, z


def _product_value(root, name: str) -> float:
    f = root.find(f".//function[@name='{name}']")
    assert f is not None, name
    return float(f.find("product/value").text)


def _table(root, name: str, column: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A coefficient's table in alpha (its first data column after the row breakpoint:
    the flaps-up column of a 2-D table)."""
    f = root.find(f".//function[@name='{name}']")
    rows = [r.split() for r in f.find(".//tableData").text.strip().splitlines()]
    two_d = len(rows[0]) < len(rows[1])
    data = np.array([[float(v) for v in r] for r in (rows[1:] if two_d else rows)])
    return data[:, 0], data[:, 1 + column]


def test_c172p_coefficients_are_those_of_its_jsbsim_file():
    # GIVEN the c172p's JSBSim file, the one the simulator flies (jsbsim's package path)
    root = ET.parse(C172P_XML).getroot()
    # THEN the model's wing, mass (empty, the point masses and the fuel), lift and
    #      elevator are its numbers, in SI units
    assert float(root.find("metrics/wingarea").text) * FT_M ** 2 == pytest.approx(C172P.wing_area_m2)
    assert float(root.find("metrics/chord").text) * FT_M == pytest.approx(C172P.chord_m)
    w, cg_x, cg_z = _c172p_mass(root)
    assert w * LB_KG == pytest.approx(C172P.mass_kg)
    a, cl = _table(root, "aero/coefficient/CLwbh")
    cl0, cl9 = np.interp([0.0, 0.09], a, cl)           # the linear range's ends
    assert (cl0, (cl9 - cl0) / 0.09) == pytest.approx((C172P.CL0, C172P.CLa))
    assert _product_value(root, "aero/coefficient/CLDe") == C172P.CLde
    assert _product_value(root, "aero/coefficient/Cmde") == C172P.Cmde
    assert _product_value(root, "aero/coefficient/Cmq") == C172P.Cmq
    # AND the elevator acts on the dynamic pressure with the propeller's slipstream
    cmde = root.find(".//function[@name='aero/coefficient/Cmde']")
    assert "aero/function/qbar-induced-psf" in [p.text.strip() for p in cmde.iter("property")]
    # AND Cmo, Cmalpha (about the aerodynamic reference point) moved to the CG: the lift
    #     behind it, the drag above it (CDo and the CDwbh table), a line over alpha
    #     0..0.09, within 5e-4 of the model's Cm0, Cma
    rp = root.find("metrics/location[@name='AERORP']")
    xa = (float(rp.find("x").text) - cg_x) * IN_M
    za = (float(rp.find("z").text) - cg_z) * IN_M
    cbar = C172P.chord_m
    al = np.linspace(0.0, 0.09, 10)
    ad, cd = _table(root, "aero/coefficient/CDwbh")
    CD = _product_value(root, "aero/coefficient/CDo") + np.interp(al, ad, cd)
    CL = np.interp(al, a, cl)
    cm = (_product_value(root, "aero/coefficient/Cmo") + _product_value(root, "aero/coefficient/Cmalpha") * al
          - xa / cbar * (CL * np.cos(al) + CD * np.sin(al)) + za / cbar * (CD * np.cos(al) - CL * np.sin(al)))
    cma, cm0 = np.polyfit(al, cm, 1)
    assert abs(cm0 - C172P.Cm0) <= 5e-4 and abs(cma - C172P.Cma) <= 5e-4, (cm0, cma)
    # AND the thrust line lies that far below the CG (a nose-up moment)
    thr = root.find(".//thruster/location")
    assert (cg_z - float(thr.find("z").text)) * IN_M == pytest.approx(C172P.thrust_z_m, abs=1e-4)
    # AND the autopilot's nose-down elevator (-1: fcs/elevator-cmd-norm +1) is the FCS's
    #     23 deg, 0.35 rad of the monitor's for each (nose up it is 28 deg: docs/monitor.md)
    el = root.find(".//aerosurface_scale[@name='Elevator Control']")
    assert float(el.find("range/max").text) * float(el.find("gain").text) == pytest.approx(
        C172P.de_per_rad * 0.35)
    assert float(el.find("range/min").text) == -28.0
    assert MODELS[2] is C172P


def test_c172p_inertia_and_slipstream_are_the_plants():
    # GIVEN the plant trimmed level at the circuit's 45 m/s (equivalent), 300 m up
    plant = JSBSimPlane("c172p", home=HOME)
    rho = 1.225 * (1.0 - 2.25577e-5 * 800.0) ** 4.2559
    plant.trim(airspeed_mps=45.0 / np.sqrt(rho / 1.225), height_m=300.0)
    fdm = plant._fdm
    # THEN its pitch inertia (the point masses and the fuel with it) is the model's
    assert fdm["inertia/iyy-slugs_ft2"] * SLUGFT2 == pytest.approx(C172P.Iyy, rel=1e-3)
    # AND so is the elevator's dynamic pressure over the free stream's (the slipstream)
    assert fdm["aero/function/qbar-induced-psf"] / fdm["aero/qbar-psf"] == pytest.approx(C172P.wash, abs=0.005)


@pytest.mark.parametrize("eas", [35.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0])
def test_c172p_predicted_level_elevator_is_the_plants_trim(eas):
    # GIVEN the c172p trimmed level at an equivalent airspeed of its range (ARSPD_FBW_MIN
    #       35 to 65 m/s), 300 m above a 500 m home
    plant = JSBSimPlane("c172p", home=HOME)
    rho = 1.225 * (1.0 - 2.25577e-5 * 800.0) ** 4.2559
    c = plant.trim(airspeed_mps=eas / np.sqrt(rho / 1.225), height_m=300.0)
    # THEN the model's balance at n = 1 and that throttle gives its elevator (the
    #      monitor's rad, 0.35 per normalised command) within 0.005 rad (measured
    #      0.0045 at 35 m/s, where the slipstream is 12 % over the cruise's, 0.0036 at
    #      40, under 0.003 from 45 up)
    predicted = C172P.elevator_for(1.0, eas, c.throttle)
    assert abs(c.elevator * 0.35 - predicted) <= 0.005, (c.elevator * 0.35, predicted)


def test_c172p_level_flight_limits_are_the_plants():
    _trims_within_the_limits(JSBSimPlane("c172p", home=HOME), C172P, 300.0)
