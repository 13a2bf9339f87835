"""Sphere intersection (eqs 3.1-3.12), nearer choice (3.17), switching term (3.21)."""
import math

import numpy as np
import pytest

from autopilot.formation import (intersection_near, nearest_on_circle, nearest_on_sphere, sigma,
                                 sphere_intersection)
from autopilot.formation.geometry import dist


def test_tetrahedron_apexes():
    p1, p2, p3 = (1.0, 0.0, 0.0), (0.5, 0.866025403784, 0.0), (0.0, 0.0, 0.0)
    a, b, status = sphere_intersection(p1, 1.0, p2, 1.0, p3, 1.0)
    assert status == "ok"
    h = math.sqrt(2.0 / 3.0)
    apexes = sorted([a, b], key=lambda p: p[2])
    assert np.allclose(apexes[0], (0.5, 0.288675, -h), atol=1e-6)
    assert np.allclose(apexes[1], (0.5, 0.288675, h), atol=1e-6)


def test_random_configurations_solve_all_three_spheres():
    rng = np.random.default_rng(3)
    for _ in range(200):
        c = rng.normal(size=(3, 3)) * 3.0
        q = rng.normal(size=3) * 3.0
        r = [float(np.linalg.norm(q - ci)) for ci in c]
        a, b, status = sphere_intersection(tuple(c[0]), r[0], tuple(c[1]), r[1], tuple(c[2]), r[2])
        assert status in ("ok", "tangent")
        for p in (a, b):
            for ci, ri in zip(c, r):
                assert abs(dist(p, ci) - ri) < 1e-6
        # eq 3.17: the solution nearer a reference close to q is q
        p, _ = intersection_near(tuple(c[0]), r[0], tuple(c[1]), r[1], tuple(c[2]), r[2],
                                 tuple(q + rng.normal(size=3) * 1e-3))
        if dist(a, b) > 0.05:
            assert dist(p, q) < 1e-6


def test_collinear_and_empty_are_reported_never_nan():
    a, b, status = sphere_intersection((0, 0, 0), 1.0, (1, 0, 0), 1.0, (2, 0, 0), 1.0)
    assert status == "collinear" and all(math.isfinite(x) for x in a + b)
    p, status = intersection_near((0, 0, 0), 1.0, (1, 0, 0), 1.0, (2, 0, 0), 1.0, (0.5, 0.0, 2.0))
    assert status == "collinear" and all(math.isfinite(x) for x in p)
    assert abs(dist(p, (0, 0, 0)) - 1.0) < 1e-9      # on the first two spheres' circle
    p, status = intersection_near((0, 0, 0), 1.0, (5, 0, 0), 1.0, (2, 4, 0), 1.0, (1.0, 1.0, 0.7))
    assert status == "empty" and all(math.isfinite(x) for x in p)
    assert p[2] == pytest.approx(0.7)                 # keeps its side of the plane
    a, b, status = sphere_intersection((0, 0, 0), 1.0, (0, 0, 0), 1.0, (1, 1, 0), 1.0)
    assert status == "collinear"


def test_sphere_and_circle_nearest_points():
    p, st = nearest_on_sphere((1, 1, 1), 2.0, (1, 1, 5))
    assert st == "ok" and np.allclose(p, (1, 1, 3))
    p, st = nearest_on_sphere((1, 1, 1), 2.0, (1, 1, 1))
    assert st == "degenerate" and abs(dist(p, (1, 1, 1)) - 2.0) < 1e-12
    p, st = nearest_on_circle((0, 0, 0), 1.0, (1, 0, 0), 1.0, (0.5, 3.0, 0.0))
    assert st == "ok" and np.allclose(p, (0.5, math.sqrt(0.75), 0.0))
    p, st = nearest_on_circle((0, 0, 0), 1.0, (3, 0, 0), 1.0, (0.5, 3.0, 0.0))
    assert st == "empty" and all(math.isfinite(x) for x in p)
    p, st = nearest_on_circle((0, 0, 0), 1.0, (1, 0, 0), 1.0, (0.5, 0.0, 0.0))
    assert st == "degenerate" and abs(dist(p, (0, 0, 0)) - 1.0) < 1e-12


def test_sigma_eq_3_21():
    eps = 0.01
    assert sigma(0.005, eps) == 0.0
    assert sigma(0.015, eps) == pytest.approx(0.5)
    assert sigma(0.02, eps) == pytest.approx(1.0)
    assert sigma(3.0, eps) == 1.0
