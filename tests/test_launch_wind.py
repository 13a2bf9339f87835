"""The catapult launch in light wind from behind (tools/runner.py): the launcher is turned
into any wind that would blow along the shot, as an operator would, so the aircraft
leaves the rail with the catapult's speed through the air and climbs away."""
import pytest

from tools.runner import RunConfig, Session

HOME = "0\t1\t0\t16\t0\t0\t0\t0\t-35.363262\t149.165237\t584\t1\n"
# a take-off to 60 m towards the north, then a waypoint 1.1 km north and RTL
ROWS = ("1\t0\t3\t22\t12\t0\t0\t0\t0\t0\t60\t1\n",
        "2\t0\t3\t16\t0\t0\t0\t0\t-35.353262\t149.165237\t60\t1\n",
        "3\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1\n")


@pytest.mark.parametrize("tailwind_mps", [1.5, 2.5])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_launch_with_wind_behind_it_is_turned_into_the_wind_and_climbs(tmp_path, seed, tailwind_mps):
    path = tmp_path / "north.waypoints"
    path.write_text("QGC WPL 110\n" + HOME + "".join(ROWS))
    # wind from the south: straight behind a launch towards the first waypoint
    s = Session(RunConfig(mission=path, seed=seed, duration_s=40.0, wind=(tailwind_mps, 180.0),
                          turbulence="moderate"))
    assert s.home[3] == pytest.approx(180.0)                   # the launcher faces the wind
    left = False
    while s.t_s < 40.0:
        s.step()
        st = s.bridge.state
        left = left or (not st.on_ground and not s.plant.on_launcher)
        if left:
            assert not st.on_ground, f"back on the ground at {s.t_s:.1f} s"
    v = s.vehicle
    assert left and v.crash is None and v.armed
    assert v.nav_state.alt_m - v._launch_alt_m > 20.0          # climbing out
