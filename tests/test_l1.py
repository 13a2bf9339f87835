"""L1 guidance geometry against hand-computed cases (Park, Deyst & How 2004)."""
import math

import pytest

from autopilot.guidance.l1 import G, L1Guidance


def test_l1_distance_from_period_and_damping():
    g = L1Guidance(period_s=20.0, damping=0.75)
    # L1 = zeta * T * V / pi
    assert g.l1_distance(20.0) == pytest.approx(0.75 * 20 * 20 / math.pi)
    assert g.k == pytest.approx(4 * 0.75 ** 2)


def test_on_the_line_and_aligned_commands_nothing():
    g = L1Guidance(17, 0.75)
    cmd = g.line((0, 0), (20, 0), (-100, 0), (500, 0))
    assert cmd.xtrack_m == pytest.approx(0.0)
    assert cmd.accel_mps2 == pytest.approx(0.0, abs=1e-12)


def test_hand_computed_offset_case():
    # GIVEN K = 2 (zeta = 1/sqrt 2), V = 20 m/s north, 10 m left of a northbound line
    g = L1Guidance(period_s=math.pi * 50 / (20 / math.sqrt(2)) / 1.0, damping=1 / math.sqrt(2))
    l1 = g.l1_distance(20.0)
    assert l1 == pytest.approx(50.0)
    cmd = g.line((0, -10), (20, 0), (-100, 0), (500, 0))
    # THEN the L1 point is sqrt(50^2 - 10^2) ahead on the line: sin(eta) = 10/50
    assert cmd.xtrack_m == pytest.approx(-10.0)
    assert math.sin(cmd.eta_rad) == pytest.approx(10 / 50)
    # a = 2 V^2 / L1 sin(eta) = 2 * 400 / 50 * 0.2 = 3.2 m/s^2, to the right
    assert cmd.accel_mps2 == pytest.approx(3.2)
    assert cmd.bank_rad == pytest.approx(math.atan(3.2 / G))


def test_right_of_line_turns_left_and_ground_track_counts():
    g = L1Guidance(17, 0.75)
    cmd = g.line((0, 30), (20, 0), (-100, 0), (500, 0))
    assert cmd.xtrack_m == pytest.approx(30.0)
    assert cmd.accel_mps2 < 0
    # crab: heading into a crosswind does not matter, the ground track is what is steered
    cmd2 = g.line((0, 0), (20, 0), (0, 0), (500, 0), heading_rad=math.radians(-20))
    assert cmd2.accel_mps2 == pytest.approx(0.0, abs=1e-12)


def test_flying_away_commands_the_full_turn():
    g = L1Guidance(17, 0.75)
    cmd = g.line((0, 1), (-20, 0.1), (0, 0), (500, 0))   # flying south on a northbound leg
    l1 = g.l1_distance(20.0)
    assert abs(cmd.accel_mps2) == pytest.approx(g.k * 20.0 ** 2 / l1, rel=1e-3)


def test_far_from_the_line_intercepts_at_a_bounded_angle():
    g = L1Guidance(17, 0.75)
    # 2 km left of the line, flying along it: commands a right turn towards it
    cmd = g.line((0, -2000), (20, 0), (-100, 0), (5000, 0))
    assert cmd.accel_mps2 > 0
    # heading already at the 60 deg intercept: no further turn
    v = (20 * math.cos(math.radians(60)), 20 * math.sin(math.radians(60)))
    cmd = g.line((0, -2000), v, (-100, 0), (5000, 0))
    assert abs(cmd.accel_mps2) < 1e-9


def test_degenerate_inputs():
    g = L1Guidance(17, 0.75)
    # zero-length leg: steer at the point, no NaN
    cmd = g.line((0, 0), (20, 0), (100, 100), (100, 100))
    assert math.isfinite(cmd.accel_mps2) and cmd.accel_mps2 > 0
    # zero ground speed: falls back on heading and airspeed
    cmd = g.line((0, -10), (0, 0), (-100, 0), (500, 0), heading_rad=0.0, airspeed_mps=18.0)
    assert math.isfinite(cmd.accel_mps2) and cmd.accel_mps2 > 0


def test_loiter_on_circle_feeds_forward_centripetal():
    g = L1Guidance(17, 0.75)
    # on an 80 m clockwise circle, at its north point flying east at 20 m/s
    cmd = g.loiter((80, 0), (0, 20), (0, 0), 80.0, +1)
    assert cmd.xtrack_m == pytest.approx(0.0)
    assert cmd.accel_mps2 == pytest.approx(20 ** 2 / 80)
    # counter-clockwise at the same point flying west
    cmd = g.loiter((80, 0), (0, -20), (0, 0), 80.0, -1)
    assert cmd.accel_mps2 == pytest.approx(-(20 ** 2) / 80)
    # outside the circle: turn more towards it than the feed-forward alone
    cmd = g.loiter((100, 0), (0, 20), (0, 0), 80.0, +1)
    assert cmd.xtrack_m == pytest.approx(20.0)
    assert cmd.accel_mps2 > 20 ** 2 / 80 * (1 - 20 / g.l1_distance(20))
