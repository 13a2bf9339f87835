"""The fault monitor's airframe model (autopilot/monitor/airframe.py): its coefficients
are the shipped aircraft's, and the moment balance they predict is the plant's trim."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from autopilot.monitor.airframe import AEROSONDE
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
    plant = JSBSimPlane(home=HOME)
    rho = 1.225 * (1.0 - 2.25577e-5 * 600.0) ** 4.2559
    tas = 1.0 / np.sqrt(rho / 1.225)
    # THEN it trims level just inside the model's limits and not 1 m/s beyond them
    c = plant.trim(airspeed_mps=(AEROSONDE.v_level_max_mps - 0.5) * tas, height_m=100.0)
    assert c.throttle <= 1.0
    plant.trim(airspeed_mps=(AEROSONDE.v_level_min_mps + 0.5) * tas, height_m=100.0)
    for v in (AEROSONDE.v_level_max_mps + 1.0, AEROSONDE.v_level_min_mps - 1.0):
        with pytest.raises(RuntimeError):
            plant.trim(airspeed_mps=v * tas, height_m=100.0)


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
