"""The launch pose taken from a mission (autopilot/mission/home.py), which the simulator
program and the in-process runs both use."""
from __future__ import annotations

from pathlib import Path

import pytest

from autopilot.mission.files import load_mission
from autopilot.mission.home import mission_home
from tools import runner

MISSIONS = Path(__file__).resolve().parent.parent / "missions"


def test_home_is_item_0_heading_towards_the_first_positioned_item():
    # GIVEN the default mission: item 0 at -35.363262, 149.165237, 584 m; the takeoff item
    # 300 m north and 12 m west of it
    lat, lon, alt, hdg = mission_home(load_mission(MISSIONS / "default.waypoints"))
    # THEN home is item 0 and the launch heads a few degrees west of north
    assert (lat, lon, alt) == (-35.363262, 149.165237, 584.0)
    assert 350.0 < hdg < 360.0


def test_a_mission_whose_items_all_sit_at_lat_lon_0_heads_north(tmp_path):
    f = tmp_path / "m.waypoints"
    f.write_text("QGC WPL 110\n"
                 "0\t1\t0\t16\t0\t0\t0\t0\t-35.0\t149.0\t584\t1\n"
                 "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1\n"
                 "2\t0\t3\t21\t0\t0\t0\t0\t0\t0\t0\t1\n")
    assert mission_home(load_mission(f))[3] == 0.0


@pytest.mark.parametrize("path", sorted(MISSIONS.glob("*.waypoints")) + sorted(MISSIONS.glob("*.plan")),
                         ids=lambda p: p.name)
def test_sim_bridge_and_sitl_run_start_from_the_same_pose(path):
    m = load_mission(path)
    assert mission_home(m) == runner.mission_home(m)
