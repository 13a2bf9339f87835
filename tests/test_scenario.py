"""Scenario files: parsing, validation with file:line messages, and driving the injector."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim_bridge.faults import FaultInjector
from sim_bridge.plants.base import PlantState
from sim_bridge.scenario import (
    Event, ScenarioError, Wind, load_scenario, parse_scenario_text, parse_wind_arg,
)
from sim_bridge.sensors import SensorParams, SensorSuite

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data_scenarios"  # not tests/data: test_mission_files lists that folder
MISSIONS = ROOT / "missions"


def test_wind_from_west_blows_east():
    # GIVEN wind of 5 m/s from 270 deg; THEN the air moves east
    np.testing.assert_allclose(Wind(5.0, 270.0, "light").wind_ned(), [0.0, 5.0, 0.0], atol=1e-12)
    # AND from north it moves south, from 45 deg it moves south-west
    np.testing.assert_allclose(Wind(3.0, 0.0).wind_ned(), [-3.0, 0.0, 0.0], atol=1e-12)
    s = 2.0 / math.sqrt(2.0)
    np.testing.assert_allclose(Wind(2.0, 45.0).wind_ned(), [-s, -s, 0.0], atol=1e-12)


def test_default_scenario_file():
    # GIVEN the shipped default scenario; WHEN loaded
    sc = load_scenario(MISSIONS / "default_scenario.toml")
    # THEN 5 m/s from the west, light turbulence, no events
    assert sc.wind == Wind(5.0, 270.0, "light")
    assert sc.events == ()


def test_gps_outage_scenario_file():
    # GIVEN the shipped GPS-outage scenario; WHEN loaded
    sc = load_scenario(MISSIONS / "gps_outage.toml")
    # THEN steady 6 m/s from 250, GPS off at 120 s and back at 150 s
    assert sc.wind == Wind(6.0, 250.0, "none")
    assert sc.events == (Event(120.0, "gps", "off", 0, {}), Event(150.0, "gps", "ok", 0, {}))
    assert (sc.events[0].unit_id, sc.events[0].type_id) == (4, 1)
    assert sc.events[1].type_id == 0


def test_every_event_kind_with_magnitudes_parses_and_sorts_by_time():
    # GIVEN a file with events of every actuator/sensor family out of time order
    sc = load_scenario(DATA / "scenario_good_all_faults.toml")
    # THEN they are sorted by time with their magnitudes as written
    assert [e.at_s for e in sc.events] == [10.0, 20.0, 30.0, 40.0, 50.0]
    assert sc.events[0] == Event(10.0, "gps", "wrong", 0, {"north_m": 15.0, "east_m": -5.0})
    assert sc.events[1] == Event(20.0, "servo", "stuck", 1, {"value_rad": 0.1})
    assert sc.events[2].magnitudes == {"bias": 0.05, "axis": 2}
    assert sc.wind == Wind(4.0, 0.0, "moderate")
    # AND each one is accepted by the fault injector
    inj = FaultInjector(np.random.default_rng(0), SensorParams(), 0.01)
    assert all(inj.inject(e.unit_id, e.type_id, e.instance, **e.magnitudes) for e in sc.events)


@pytest.mark.parametrize("name, line, words", [
    ("scenario_bad_unknown_top.toml", 5, "unknown top-level key 'weather'"),
    ("scenario_bad_wind_key.toml", 4, "unknown key 'gusts' in [wind]"),
    ("scenario_bad_negative_speed.toml", 4, "speed_mps must be >= 0"),
    ("scenario_bad_turbulence.toml", 3, "turbulence must be one of"),
    ("scenario_bad_speed_type.toml", 2, "speed_mps must be a finite number"),
    ("scenario_bad_event_key.toml", 13, "unknown key 'colour' in [[event]]"),
    ("scenario_bad_unit.toml", 3, "unit 'flux_capacitor' is unknown"),
    ("scenario_bad_type.toml", 4, "unknown type 'exploded'"),
    ("scenario_bad_negative_time.toml", 4, "at_s must be >= 0"),
    ("scenario_bad_magnitude.toml", 6, "effectiveness must be in [0, 1]"),
    ("scenario_bad_magnitude_not_applicable.toml", 5, "'noise_scale' does not apply"),
    ("scenario_bad_syntax.toml", 3, "TOML syntax error"),
])
def test_bad_files_name_file_and_line(name, line, words):
    # GIVEN a bad scenario file; WHEN loaded
    path = DATA / name
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    # THEN the message starts with FILE:LINE: and says what is wrong
    msg = str(err.value)
    assert msg.startswith(f"{path}:{line}: "), msg
    assert words in msg
    assert err.value.line == line


def test_errors_in_text_form_and_unsupported_units():
    # GIVEN a unit MAVLink knows but the injector does not model
    text = "[[event]]\nat_s = 1.0\nunit = \"battery\"\ntype = \"off\"\n"
    with pytest.raises(ScenarioError, match=r"^x.toml:3: unit 'battery' is not supported"):
        parse_scenario_text(text, "x.toml")
    # AND a type the unit does not support
    text = "[[event]]\nat_s = 1.0\nunit = \"servo\"\ntype = \"garbage\"\n"
    with pytest.raises(ScenarioError, match=r"^x.toml:4: servo does not support type"):
        parse_scenario_text(text, "x.toml")
    # AND a missing required key points at the event's header
    text = "[wind]\nspeed_mps = 1\n\n[[event]]\nunit = \"gps\"\ntype = \"off\"\n"
    with pytest.raises(ScenarioError, match=r"^x.toml:4: \[\[event\]\] needs 'at_s'"):
        parse_scenario_text(text, "x.toml")
    # AND a bad instance
    text = "[[event]]\nat_s = 1.0\nunit = \"gps\"\ntype = \"off\"\ninstance = -1\n"
    with pytest.raises(ScenarioError, match=r"^x.toml:5: instance"):
        parse_scenario_text(text, "x.toml")
    # AND a missing file
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(DATA / "no_such_scenario.toml")


def test_empty_file_is_calm_and_fault_free():
    sc = parse_scenario_text("# nothing\n")
    assert sc.wind == Wind(0.0, 0.0, "none") and sc.events == ()


def test_parse_wind_arg():
    # GIVEN the CLI's --wind SPEED,FROM_DEG[,TURBULENCE]
    assert parse_wind_arg("5,270") == Wind(5.0, 270.0, "none")
    assert parse_wind_arg(" 7.5 , 90 , moderate") == Wind(7.5, 90.0, "moderate")
    # THEN malformed values are errors (ValueError, so argparse reports them)
    for bad in ("5", "5,270,light,x", "fast,270", "-1,270", "5,400", "5,270,gusty", "nan,0"):
        with pytest.raises(ValueError):
            parse_wind_arg(bad)


def test_gps_outage_scenario_drives_the_injector():
    # GIVEN the GPS-outage scenario applied to a sensor suite at 50 Hz (dt 20 ms)
    sc = load_scenario(MISSIONS / "gps_outage.toml")
    dt = 0.02
    params = SensorParams()
    suite = SensorSuite(params, np.random.default_rng(1), dt)
    inj = FaultInjector(np.random.default_rng(2), params, dt)
    pending = list(sc.events)
    truth = PlantState(0, math.radians(47.0), math.radians(8.0), 500.0, np.zeros(3),
                       np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.array([0, 0, -9.81]),
                       np.zeros(3), 0.0, 0.0, 0.0, True)
    arrivals = []
    # WHEN 170 s are simulated, firing events when their time comes
    for k in range(int(170 / dt)):
        t_us = k * 20_000
        while pending and pending[0].at_s * 1e6 <= t_us:
            e = pending.pop(0)
            assert inj.inject(e.unit_id, e.type_id, e.instance, **e.magnitudes)
        r = inj.apply(suite.sample(PlantState(t_us, *[getattr(truth, f) for f in (
            "lat_rad", "lon_rad", "alt_m", "v_ned", "q_nb", "omega_b", "f_b", "wind_ned",
            "airspeed_mps", "alpha_rad", "beta_rad", "on_ground")])))
        if r.gps is not None:
            arrivals.append(r.gps.t_us * 1e-6)
    arrivals = np.array(arrivals)
    # THEN no fix arrives between 120 s and 150 s, and 5 Hz outside it
    assert not np.any((arrivals >= 120.0) & (arrivals < 150.0))
    assert np.count_nonzero(arrivals < 120.0) == 600
    assert np.count_nonzero(arrivals >= 150.0) == 100


@pytest.mark.parametrize("written, index", [
    ('"x"', 0), ('"y"', 1), ('"z"', 2), ('"Y"', 1), ("0", 0), ("1", 1), ("2", 2)])
def test_axis_by_name_or_index(written, index):
    # GIVEN a gyro 'wrong' event whose axis is written as a name or an index
    text = f'[[event]]\nat_s = 1.0\nunit = "gyro"\ntype = "wrong"\nbias = 0.05\naxis = {written}\n'
    # WHEN loaded
    ev = parse_scenario_text(text, "x.toml").events[0]
    # THEN the event carries the body axis index
    assert ev.magnitudes == {"bias": 0.05, "axis": index}
    # AND the injector biases exactly that axis of the gyro
    dt = 0.02
    params = SensorParams()
    inj = FaultInjector(np.random.default_rng(0), params, dt)
    assert inj.inject(ev.unit_id, ev.type_id, ev.instance, **ev.magnitudes)
    truth = PlantState(0, math.radians(47.0), math.radians(8.0), 500.0, np.zeros(3),
                       np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.array([0, 0, -9.81]),
                       np.zeros(3), 0.0, 0.0, 0.0, True)
    readings = SensorSuite(params, np.random.default_rng(1), dt).sample(truth)
    clean = np.array(readings.gyro_b)
    shift = np.asarray(inj.apply(readings).gyro_b) - clean
    np.testing.assert_allclose(shift, np.eye(3)[index] * 0.05, atol=1e-12)


@pytest.mark.parametrize("written", ['"w"', '"xy"', "3", "-1", "1.0", "true", '""'])
def test_bad_axis_lists_what_is_accepted(written):
    # GIVEN an accel 'wrong' event with an axis that is no body axis
    text = f'[[event]]\nat_s = 1.0\nunit = "accel"\ntype = "wrong"\naxis = {written}\n'
    # WHEN loaded; THEN the error points at the axis line and lists the accepted forms
    with pytest.raises(ScenarioError) as err:
        parse_scenario_text(text, "x.toml")
    msg = str(err.value)
    assert msg.startswith("x.toml:5: axis must be"), msg
    assert '"x", "y", "z" or 0, 1, 2' in msg
