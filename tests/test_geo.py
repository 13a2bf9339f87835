"""Frames, quaternions and WGS-84 / NED conversions (seed eqs 1.6-1.17)."""
import math

import numpy as np
import pytest

from autopilot.geo import (LocalFrame, dcm_to_quat, ecef_to_geodetic, euler_to_quat, from_scipy,
                           geodetic_to_ecef, quat_from_rotvec, quat_integrate, quat_multiply,
                           quat_to_dcm, quat_to_euler, quat_to_rotvec, to_scipy, wrap_pi)


def random_euler(rng, n):
    return np.column_stack([rng.uniform(-math.pi, math.pi, n), rng.uniform(-1.5, 1.5, n),
                            rng.uniform(-math.pi, math.pi, n)])


def test_known_quaternions():
    # GIVEN a pure yaw of 90 deg WHEN the body x axis is rotated THEN it points east
    q = euler_to_quat(0.0, 0.0, math.pi / 2)
    assert np.allclose(q, [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)])
    assert np.allclose(quat_to_dcm(q) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    # a pitch up of 30 deg puts the nose above the horizon (negative down component)
    q = euler_to_quat(0.0, math.radians(30), 0.0)
    assert np.allclose(quat_to_dcm(q) @ [1, 0, 0], [math.cos(math.radians(30)), 0, -0.5], atol=1e-12)
    # a right roll puts the right wing (body y) down
    q = euler_to_quat(math.radians(90), 0.0, 0.0)
    assert np.allclose(quat_to_dcm(q) @ [0, 1, 0], [0, 0, 1], atol=1e-12)


def test_euler_quaternion_dcm_round_trips():
    rng = np.random.default_rng(3)
    for r, p, y in random_euler(rng, 500):
        q = euler_to_quat(r, p, y)
        assert np.allclose(quat_to_euler(q), (r, p, wrap_pi(y)), atol=1e-9)
        assert np.allclose(dcm_to_quat(quat_to_dcm(q)), q, atol=1e-12)
        R = quat_to_dcm(q)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.allclose(from_scipy(to_scipy(q)), q, atol=1e-12)
        # scipy agrees on the rotation itself (intrinsic ZYX = 3-2-1)
        assert np.allclose(to_scipy(q).as_matrix(), R, atol=1e-12)


def test_hamilton_product_composes_rotations():
    rng = np.random.default_rng(4)
    for _ in range(100):
        a = euler_to_quat(*random_euler(rng, 1)[0])
        b = euler_to_quat(*random_euler(rng, 1)[0])
        assert np.allclose(quat_to_dcm(quat_multiply(a, b)), quat_to_dcm(a) @ quat_to_dcm(b), atol=1e-12)


def test_rotvec_and_integration():
    phi = np.array([0.1, -0.2, 0.3])
    assert np.allclose(quat_to_rotvec(quat_from_rotvec(phi)), phi)
    # constant yaw rate of 0.5 rad/s for 2 s in 1000 steps gives 1 rad of yaw, unit norm kept
    q = np.array([1.0, 0, 0, 0])
    for _ in range(1000):
        q = quat_integrate(q, np.array([0, 0, 0.5]), 0.002)
    assert abs(np.linalg.norm(q) - 1) < 1e-12
    assert quat_to_euler(q)[2] == pytest.approx(1.0, abs=1e-9)


def test_wgs84_known_values():
    # the equator at the prime meridian is one semi-major axis out on x
    assert np.allclose(geodetic_to_ecef(0, 0, 0), [6378137.0, 0, 0])
    # the north pole is one semi-minor axis out on z
    assert np.allclose(geodetic_to_ecef(math.pi / 2, 0, 0), [0, 0, 6356752.314245], atol=1e-6)
    # a published point: lat 45, lon 45, h 0 -> x = y = 3194419.145, z = 4487348.409
    r = geodetic_to_ecef(math.radians(45), math.radians(45), 0.0)
    assert np.allclose(r, [3194419.145, 3194419.145, 4487348.409], atol=1e-2)


def test_geodetic_ecef_round_trip():
    rng = np.random.default_rng(5)
    for _ in range(300):
        lat, lon, h = rng.uniform(-1.55, 1.55), rng.uniform(-math.pi, math.pi), rng.uniform(-100, 20000)
        lat2, lon2, h2 = ecef_to_geodetic(geodetic_to_ecef(lat, lon, h))
        assert abs(lat2 - lat) < 1e-11 and abs(wrap_pi(lon2 - lon)) < 1e-11 and abs(h2 - h) < 1e-5


def test_ned_across_the_180_meridian():
    # GIVEN an origin just west of the antimeridian in the southern hemisphere
    f = LocalFrame.from_degrees(-41.0, 179.999, 10.0)
    # WHEN a point just east of it (lon -179.999) is converted
    p = f.to_ned(math.radians(-41.0), math.radians(-179.999), 10.0)
    # THEN it is ~168 m east, not 30 000 km west
    east = 2 * 0.001 * math.pi / 180 * 6378137.0 * math.cos(math.radians(41)) / math.sqrt(1 - 0.00669438 * math.sin(math.radians(41)) ** 2)
    assert p[1] == pytest.approx(east, rel=1e-4)
    assert abs(p[0]) < 0.01
    assert np.allclose(f.to_ned_fast(math.radians(-41.0), math.radians(-179.999), 10.0)[:2], p[:2], atol=0.01)
    lat, lon, alt = f.to_geodetic(p)
    assert math.degrees(lon) == pytest.approx(-179.999, abs=1e-9)
    lat, lon, alt = f.to_geodetic_fast(np.array([0.0, 500.0, 0.0]))
    assert -180 <= math.degrees(lon) < -179.99


def test_fast_ned_matches_exact_within_a_few_km():
    f = LocalFrame.from_degrees(-35.36, 149.16, 584.0)
    rng = np.random.default_rng(6)
    # (the fast chart maps a latitude/longitude to the same horizontal point at every
    # height, as guidance wants; so compare at the origin's height)
    for _ in range(100):
        p = np.array([rng.uniform(-5000, 5000), rng.uniform(-5000, 5000), 0.0])
        lat, lon, alt = f.to_geodetic_fast(p)
        exact = f.to_ned(lat, lon, alt)
        assert np.allclose(exact[:2], p[:2], atol=0.05)  # horizontal: centimetres over 5 km
        assert np.allclose(f.to_ned_fast(lat, lon, alt), p, atol=1e-6)  # fast round trip


def test_ned_fast_is_to_ned_fast_as_a_tuple():
    # GIVEN an origin and points around it (and across the 180-degree meridian)
    rng = np.random.default_rng(7)
    for lat0, lon0 in ((-35.36, 149.16), (-41.0, 179.999)):
        f = LocalFrame.from_degrees(lat0, lon0, 584.0)
        for _ in range(50):
            lat = math.radians(lat0 + rng.uniform(-0.05, 0.05))
            lon = math.radians(lon0 + rng.uniform(-0.05, 0.05))
            alt = rng.uniform(0.0, 3000.0)
            # THEN the tuple holds exactly the array's numbers, as Python floats
            t = f.ned_fast(lat, lon, alt)
            assert type(t) is tuple and all(type(x) is float for x in t)
            assert t == tuple(f.to_ned_fast(lat, lon, alt).tolist())


def test_the_float_kernels_are_the_numpy_formulas():
    """rotations.quat_dcm and quat_step (the kernels the plants, the vehicles and the
    navigation call) against quat_to_dcm and quat_integrate, both branches of Exp."""
    from autopilot.geo.rotations import quat_dcm, quat_step
    rng = np.random.default_rng(5)
    for k in range(300):
        q = rng.standard_normal(4)
        q /= np.linalg.norm(q)
        assert np.allclose(np.reshape(quat_dcm(*q), (3, 3)), quat_to_dcm(q), rtol=0.0, atol=1e-15)
        a = rng.uniform(-0.5, 0.5, 3) * (1e-11 if k % 5 == 0 else 1.0)   # first-order branch too
        got = np.array(quat_step(*q, *a))
        want = quat_integrate(q, a, 1.0)
        want = want if want[0] >= 0.0 else -want          # the kernel's sign: w >= 0
        assert got[0] >= 0.0 and abs(np.linalg.norm(got) - 1.0) < 1e-15
        assert np.abs(got - want).max() < 1e-15
