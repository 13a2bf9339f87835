"""Formation files: the graph checks and the consistent final positions."""
import copy
import math
import tomllib
from pathlib import Path

import pytest

from autopilot.formation import FormationError, load_formation, parse_formation
from autopilot.formation.geometry import dist

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
SEED_POINT = MISSIONS / "formation_seed_point.toml"


def seed_data() -> dict:
    with open(SEED_POINT, "rb") as f:
        return tomllib.load(f)


def vehicle(data, vid):
    return next(v for v in data["vehicle"] if v["id"] == vid)


def test_seed_file_loads_with_consistent_final_positions():
    spec = load_formation(SEED_POINT)
    assert len(spec.vehicles) == 5 and spec.epsilon == 0.01 and spec.speed_mps == 1.0
    f = spec.final_positions()
    # every constrained pair at its distance in the desired final positions
    for a, b, d in spec.pairs:
        assert abs(dist(f[a], f[b]) - d) < 1e-9
    assert f[1] == (-3.9697, 2.7428, 1.0)
    # the file's (inconsistent) goals of 2 and 3 are close to the consistent ones
    assert dist(f[2], spec.vehicle(2).goal_ned) < 0.1
    assert dist(f[3], spec.vehicle(3).goal_ned) < 0.13
    # vehicles 4 and 5 stay on their sides of the leaders' plane (above / below)
    assert f[4][2] > 1.5 and f[5][2] < 0.5


def test_quad_seed_file_loads():
    spec = load_formation(MISSIONS / "formation_seed_quad.toml")
    assert spec.model == "quad" and spec.speed_mps == 2.0 and len(spec.pairs) == 9


def _bad(mutate, match):
    data = seed_data()
    mutate(data)
    with pytest.raises(FormationError, match=match):
        parse_formation(data)


def test_cycle_is_an_error():
    def m(d):
        vehicle(d, 2)["follows"] = [3]
        vehicle(d, 3)["follows"] = [1, 2]
        d["distance"] = [x for x in d["distance"] if {x["a"], x["b"]} != {1, 2}]
    _bad(m, "cycle: 2 -> 3 -> 2")


def test_follower_of_a_later_vehicle_is_an_error():
    def m(d):
        vehicle(d, 4)["follows"] = [1, 2, 5]
        d["distance"].append({"a": 4, "b": 5, "d_m": 1.633})
    _bad(m, "follows later vehicle")


@pytest.mark.parametrize("vid, follows, match", [
    (4, [1, 2], "follows 2 vehicle"),              # under-constrained: not rigid
    (2, [], "follows 0 vehicle"),                  # first follower following nobody
    (3, [1], "follows 1 vehicle"),
])
def test_non_persistent_graph_is_an_error(vid, follows, match):
    def m(d):
        vehicle(d, vid)["follows"] = follows
    _bad(m, "not minimally persistent: .*" + match)


def test_two_leaders_is_an_error():
    def m(d):
        vehicle(d, 2)["role"] = "leader"
        vehicle(d, 2)["follows"] = []
    _bad(m, "not minimally persistent: 2 vehicles with role leader")


def test_second_follower_must_follow_leader_and_first():
    def m(d):
        vehicle(d, 4)["role"] = "second"
        vehicle(d, 4)["follows"] = [1, 3]
    _bad(m, "not minimally persistent")


def test_missing_distance_is_an_error():
    def m(d):
        d["distance"] = [x for x in d["distance"] if {x["a"], x["b"]} != {2, 5}]
    _bad(m, r"missing distance for the pair \(2, 5\)")


def test_distance_without_edge_is_an_error():
    def m(d):
        d["distance"].append({"a": 4, "b": 5, "d_m": 1.633})
    _bad(m, r"pair \(4, 5\), which no vehicle follows")


def test_collinear_leaders_are_an_error():
    def m(d):
        vehicle(d, 3)["start_ned"] = [0.0, -0.866 * 2, 0.0]     # 1, 2, 3 on one line
        vehicle(d, 2)["start_ned"] = [0.5, 0.866, 0.0]
        vehicle(d, 3)["start_ned"] = [1.5, -0.866, 0.0]
    _bad(m, "start collinear")


def test_unsatisfiable_distances_are_an_error():
    def m(d):
        for x in d["distance"]:
            if {x["a"], x["b"]} == {2, 3}:
                x["d_m"] = 3.0              # triangle inequality with d12 = d13 = 1
    _bad(m, "triangle inequality")


def test_leader_needs_a_goal_and_ids_are_1_to_n():
    def m(d):
        del vehicle(d, 1)["goal_ned"]
    _bad(m, "needs goal_ned")

    def m2(d):
        vehicle(d, 5)["id"] = 7
    _bad(m2, "ids must be 1..5")


def test_bad_values_are_errors():
    def m(d):
        d["model"] = "plane"
    _bad(m, "model must be")

    def m2(d):
        d["network"]["loss"] = 1.5
    _bad(m2, "loss")
