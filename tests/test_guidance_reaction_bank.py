"""The mission's turns planned at the bank a fault's reaction leaves (guidance/mission.py
``reaction_limits``, control/fixed_wing.py ``reaction_bank_limit_rad``).

An aileron flown on the rudder, or the elevator out, lowers the controller's bank
limit; the sequencer planned its fillets, joins and arc floors at TURN_BANK_DEG and
ROLL_LIMIT_DEG all the same, so the turns were flown wider than planned and the
waypoints after them passed far outside their radius."""
import math

import numpy as np

from autopilot.control.fixed_wing import EOUT_BANK_MIN_DEG, LAT_DEFLECTION_RAD, FixedWingController
from autopilot.guidance.mission import G, MissionSequencer
from autopilot.geo.wgs84 import LocalFrame
from autopilot.mission.files import load_mission
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations
from tools.invariants import mission_legs
from tools.runner import MISSIONS_DIR, RunConfig, Session


def _params(**values):
    p = ParamStore(plane_param_declarations())
    for k, v in values.items():
        p.set(k, v)
    return p


def test_the_turn_radii_follow_a_reactions_bank_limit():
    # GIVEN the default mission's sequencer, turns at 22 deg nominal, 30 deg the limit
    p = _params(TURN_BANK_DEG=22.0, ROLL_LIMIT_DEG=30.0)
    m = load_mission(MISSIONS_DIR / "default.waypoints")
    home = m.items[0]
    seq = MissionSequencer(m, LocalFrame(math.radians(home.x_lat_deg), math.radians(home.y_lon_deg), home.z_alt_m), p)
    v = seq.airspeed_mps * p["TURN_GS_FACTOR"]
    assert math.isclose(seq.turn_radius_m(), v * v / (G * math.tan(math.radians(22.0))), rel_tol=1e-12)
    r_lim = seq.min_turn_radius_m()
    # WHEN a reaction limits the bank to 10 deg
    seq.reaction_limits = lambda: (math.radians(10.0), None)
    # THEN the fillets are planned at the nominal bank scaled by the same share (22 x 10 /
    #      30 deg) and the tightest circle at 10 deg
    assert math.isclose(seq.turn_radius_m(), v * v / (G * math.tan(math.radians(22.0 * 10.0 / 30.0))),
                        rel_tol=1e-9)
    assert math.isclose(seq.min_turn_radius_m(),
                        r_lim * math.tan(math.radians(30.0)) / math.tan(math.radians(10.0)), rel_tol=1e-9)
    # AND a limit above the parameters' changes nothing
    seq.reaction_limits = lambda: (math.radians(40.0), None)
    assert math.isclose(seq.min_turn_radius_m(), r_lim, rel_tol=1e-12)


def test_the_controllers_reaction_limit_is_the_bank_it_flies():
    p = _params(ROLL_LIMIT_DEG=30.0)
    ctrl = FixedWingController(p)
    assert ctrl.reaction_bank_limit_rad() is None
    # an aileron out, its counter taking 60 % of the rudder's travel: 40 % of 30 deg = 12 deg
    ctrl.surface_out = {"surface": "aileron", "stuck_rad": 0.1, "counter_rad": -0.6 * LAT_DEFLECTION_RAD}
    assert math.isclose(ctrl.reaction_bank_limit_rad(), math.radians(12.0), rel_tol=1e-9)
    assert math.isclose(ctrl.roll_limit_rad(), math.radians(12.0), rel_tol=1e-9)
    # 90 %: not under EOUT_BANK_MIN_DEG
    ctrl.surface_out["counter_rad"] = 0.9 * LAT_DEFLECTION_RAD
    assert math.isclose(ctrl.reaction_bank_limit_rad(), math.radians(EOUT_BANK_MIN_DEG), rel_tol=1e-9)
    ctrl.surface_out = None
    assert ctrl.reaction_bank_limit_rad() is None


def test_c172p_with_a_stuck_aileron_passes_its_waypoints_within_their_radius(tmp_path):
    # GIVEN the c172p's circuit, its aileron stuck at -0.05 rad 60 s after the start
    #       (light turbulence, 5 m/s down the runway, seed 1): flown on the rudder, the
    #       bank limited to 15 deg (the counter takes half the rudder's travel). With the
    #       turns planned at 22 deg the turn onto the second leg ran wide and waypoint 2
    #       was passed 132 m outside its 400 m radius (seeds 2 and 3: 401 and 340 m)
    scen = tmp_path / "ail.toml"
    scen.write_text('[wind]\nspeed_mps = 5.0\nfrom_deg = 270.0\nturbulence = "light"\n\n'
                    '[[event]]\nat_s = 60.0\nunit = "servo"\ntype = "stuck"\ninstance = 0\n'
                    'value_rad = -0.05\n')
    s = Session(RunConfig(airframe="c172p", mission=MISSIONS_DIR / "c172p_circuit.waypoints",
                          scenario=scen, seed=1, duration_s=360.0))
    s.run()
    v = s.vehicle
    assert not s.crashed
    bank_limit_rad = v.sequencer.reaction_limits()[0]
    assert v.ctrl.surface_out is not None and bank_limit_rad is not None
    assert math.degrees(bank_limit_rad) < 20.0
    # THEN waypoints 2 and 3 (counted by 360 s) passed within 10 m of their radius
    #      (measured: inside it by 222 and 266 m; 132 m outside before)
    a = s.log.arrays()
    legs = {g["seq"]: g for g in mission_legs(v.mission, v.home_frame, "plane", s.params)}
    reached = [seq for _, seq in v.reached_events()]
    radius = s.params["WP_RADIUS"]
    for k in (2, 3):
        assert k in reached, reached
        b = legs[k]["b"]
        miss = float(np.nanmin(np.hypot(a["truth_n_m"] - b[0], a["truth_e_m"] - b[1]))) - radius
        assert miss <= 10.0, (k, miss)
