"""The fence's geometry and breach logic on their own (autopilot/fence/geofence.py):
signed distances of polygons (concave too) and circles, the altitude band and its
floor, the FENCE_MARGIN hysteresis, and ArduPilot's rally-point rules."""
import math

import pytest

from autopilot.fence.geofence import FENCE_PARAMS, Geofence, distance_m, rally_params
from autopilot.mission.items import MissionItem
from autopilot.params import ParamStore

LAT0, LON0 = -35.36, 149.16
M_LAT = 1.0 / 111_319.49                         # degrees of latitude per metre (R = 6378137)
M_LON = M_LAT / math.cos(math.radians(LAT0))


def at(n_m, e_m):
    return LAT0 + n_m * M_LAT, LON0 + e_m * M_LON


def poly(cmd, pts):
    return [MissionItem(k, 0, cmd, 0, 1, len(pts), 0, 0, 0, *at(*p), 0, 1) for k, p in enumerate(pts)]


def fence(items, kind="plane", **params):
    p = ParamStore(list(FENCE_PARAMS) + list(rally_params(kind)))
    p.set("FENCE_ENABLE", 1)
    for k, v in params.items():
        p.set(k, v)
    g = Geofence(p, kind)
    assert g.set_fence(items) is None
    return g


# an L-shaped (concave) inclusion polygon: the notch at north > 100, east > 100 is outside
L_SHAPE = [(0, 0), (200, 0), (200, 100), (100, 100), (100, 200), (0, 200)]


@pytest.mark.parametrize("n, e, d", [
    (50, 50, -50.0),        # inside, 50 m from the nearest edges
    (150, 150, 50.0),       # in the notch: outside, 50 m from the nearest edge
    (-10, 50, 10.0),        # south of the polygon
    (150, 90, -10.0),       # inside the northern arm, 10 m from the notch
])
def test_signed_distance_of_a_concave_inclusion_polygon(n, e, d):
    g = fence(poly(5001, L_SHAPE), FENCE_TYPE=4)
    assert g.fence.outside_m(*at(n, e)) == pytest.approx(d, abs=0.05)


def test_exclusion_zones_and_the_intersection_of_inclusions():
    circle = MissionItem(0, 0, 5004, 0, 1, 30.0, 0, 0, 0, *at(50, 50), 0, 1)
    second = MissionItem(0, 0, 5003, 0, 1, 280.0, 0, 0, 0, *at(300, 0), 0, 1)
    g = fence(poly(5001, L_SHAPE) + [circle, second], FENCE_TYPE=4)
    assert g.fence.outside_m(*at(50, 50)) == pytest.approx(30.0, abs=0.05)     # circle centre
    assert g.fence.outside_m(*at(10, 190)) > 0.0     # in the polygon, out of the second inclusion
    assert g.fence.outside_m(*at(150, 10)) < 0.0     # in both, out of the exclusion


def test_breach_clears_only_fence_margin_back_inside_and_the_floor_arms_after_takeoff():
    g = fence(poly(5001, L_SHAPE), FENCE_TYPE=4 | 8, FENCE_ALT_MIN=10, FENCE_MARGIN=3)
    home = at(0, 0)
    # on the way up below the floor: no breach, the floor is not armed yet
    assert g.update(1_000_000, *at(50, 50), 5.0, home, flying=True) is None
    assert g.update(2_000_000, *at(50, 50), 20.0, home, flying=True) is None
    assert g.update(3_000_000, *at(50, -1), 20.0, home, flying=True) == "breach"
    assert g.breaches[-1]["type"] == "polygon"
    assert g.update(4_000_000, *at(50, 2), 20.0, home, flying=True) is None    # 2 m in: still breached
    assert g.update(5_000_000, *at(50, 4), 20.0, home, flying=True) == "clear"  # 4 m > margin
    # the floor, once armed: a breach below it, none while landing
    assert g.update(6_000_000, *at(50, 50), 8.0, home, flying=True, landing=True) is None
    assert g.update(7_000_000, *at(50, 50), 8.0, home, flying=True) == "breach"
    assert g.breaches[-1] == {"at_s": 7.0, "type": "min_alt", "action": "RTL", "cleared_s": None}


def test_the_circle_around_home_and_the_ceiling():
    g = fence([], FENCE_TYPE=1 | 2, FENCE_RADIUS=100, FENCE_ALT_MAX=50)
    home = at(0, 0)
    d = g.distances(*at(0, 130), 60.0, home)
    assert d[2] == pytest.approx(30.0, abs=0.05) and d[1] == pytest.approx(10.0)
    # a waypoint within FENCE_MARGIN of the circle is refused; at arming home is here
    assert g.position_problem(*at(0, 99), None, home) == "outside the fence (circle)"
    assert g.position_problem(*at(0, 50), 40.0, home) is None
    assert g.position_problem(*at(0, 50), 49.0, home) == "outside the fence (max_alt)"
    assert g.arm_problem(*at(0, 500)) is None


@pytest.mark.parametrize("incl_home, limit_km, where, expect", [
    (1, 5.0, (0, 900), "east"),       # the east rally point is nearer than home
    (1, 5.0, (0, 300), None),         # home is nearer
    (0, 5.0, (0, 300), "east"),       # home not counted: the nearest rally point
    (0, 0.5, (0, -100), None),        # nearest (west) is beyond the limit and home nearer
    (0, 0.0, (0, -100), "west"),      # no limit
])
def test_rally_point_choice(incl_home, limit_km, where, expect):
    g = fence([], RALLY_INCL_HOME=incl_home, RALLY_LIMIT_KM=limit_km)
    pts = {"east": at(0, 1000), "west": at(0, -1000)}
    g.set_rally([MissionItem(k, 3, 5100, 0, 1, 0, 0, 0, 0, *pts[name], 80, 2) for k, name in enumerate(pts)])
    r = g.rally_for_rtl(*at(*where), (LAT0, LON0, 584.0))
    if expect is None:
        assert r is None
    else:
        assert r[:2] == pytest.approx(pts[expect]) and r[2] == 664.0
    assert distance_m(*at(0, 0), *at(0, 1000)) == pytest.approx(1000.0, abs=0.01)


def test_fence_watching_is_what_fence_step_has_to_do():
    # GIVEN a fence, enabled, then disabled with and without a breach standing
    from autopilot.fence.actions import fence_step, fence_watching
    g = fence(poly(5001, L_SHAPE))
    assert fence_watching(g)                       # enabled: checked every step
    g.params.set("FENCE_ENABLE", 0)
    assert not fence_watching(g)                   # off, nothing breached: nothing to do
    g.breached = 1
    assert fence_watching(g)                       # off with a breach: still to be cleared

    # THEN fence_step does nothing exactly where fence_watching says so (no look at the
    # vehicle at all: a vehicle without a navigation state would fail)
    class NoVehicle:
        geofence = g

    g.breached = 0
    fence_step(NoVehicle(), 0, True)
    g.breached = 1
    with pytest.raises(AttributeError):
        fence_step(NoVehicle(), 0, True)
