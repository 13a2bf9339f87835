"""The strapdown kernels (autopilot/nav/strapdown.py) against the mechanisation's
equations written out once more here in numpy (the slow twin lives only in the tests)."""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import quat_to_dcm
from autopilot.geo.rotations import quat_dcm as dcm
from autopilot.nav import qbatch
from autopilot.nav.strapdown import (GRAVITY_GRADIENT, X_P, X_SIZE, Nominal, earth_rate_ned,
                                     mechanise, rotate_global)


def _mechanise_numpy(p, v, q, bg, ba, f_m, omega_m, dt, g, w_ie):
    """strapdown.py's module docstring, in numpy."""
    R = qbatch.to_dcm(q)
    omega = omega_m - bg - R.T @ w_ie
    f = f_m - ba
    f_n = R @ (f + 0.5 * dt * np.cross(omega, f))
    g_n = np.array((0.0, 0.0, g + GRAVITY_GRADIENT * p[2]))
    v1 = v + (f_n + g_n - 2.0 * np.cross(w_ie, v)) * dt
    p1 = p + 0.5 * (v + v1) * dt
    q1 = qbatch.normalize(qbatch.mul(q, qbatch.from_rotvec(omega * dt)))
    return p1, v1, q1, f_n, omega


def _random_state(rng):
    q = rng.standard_normal(4)
    q /= np.linalg.norm(q)
    return (rng.uniform(-1e3, 1e3, 3), rng.uniform(-30.0, 30.0, 3), q, rng.uniform(-0.01, 0.01, 3),
            rng.uniform(-0.1, 0.1, 3), rng.uniform(-20.0, 20.0, 3), rng.uniform(-2.0, 2.0, 3))


def test_mechanise_matches_the_equations():
    rng = np.random.default_rng(11)
    for k in range(200):
        p, v, q, bg, ba, f_m, omega_m = _random_state(rng)
        if k % 10 == 0:
            omega_m = bg + 1e-13                           # the small-angle branch of Exp
        w_ie = np.array(earth_rate_ned(rng.uniform(-1.2, 1.2)))
        dt, g = float(rng.choice([0.004, 0.01, 0.016])), 9.79
        o = mechanise(*p, *v, *q, *bg, *ba, *f_m, *omega_m, dt, g, *w_ie)
        p1, v1, q1, f_n, omega = _mechanise_numpy(p, v, q, bg, ba, f_m, omega_m, dt, g, w_ie)
        assert np.allclose(o[0:3], p1, rtol=0.0, atol=1e-9)
        assert np.allclose(o[3:6], v1, rtol=0.0, atol=1e-11)
        assert np.allclose(o[6:10], q1, rtol=0.0, atol=1e-14)
        assert o[6] >= 0.0
        assert np.allclose(np.array(o[10:19]).reshape(3, 3), qbatch.to_dcm(q1), rtol=0.0, atol=1e-14)
        assert np.allclose(o[19:22], f_n, rtol=0.0, atol=1e-12)
        assert np.allclose(o[22:25], omega, rtol=0.0, atol=1e-15)


def test_the_nominal_state_reads_the_kernel_result_written_into_its_array():
    rng = np.random.default_rng(5)
    p, v, q, bg, ba, f_m, omega_m = _random_state(rng)
    nom = Nominal()
    nom.p, nom.v, nom.bg, nom.ba = p.tolist(), v.tolist(), bg.tolist(), ba.tolist()
    nom.bb, nom.gb, nom.wind = 3.0, [0.5, -0.3, 1.0], [3.0, -2.0]
    nom.set_attitude(q)
    w_ie = earth_rate_ned(0.6)
    before = nom.x.copy()
    o = mechanise(*nom.p, *nom.v, *nom.q, *nom.bg, *nom.ba, *f_m.tolist(), *omega_m.tolist(),
                  0.01, 9.8, *w_ie)
    nom.x[X_P:X_P + 25] = o                 # (as base.imu_step writes it)
    assert nom.x[X_P + 25:X_SIZE].tolist() == before[X_P + 25:].tolist()
    p1, v1, q1, f_n, omega = _mechanise_numpy(p, v, q, bg, ba, f_m, omega_m, 0.01, 9.8, np.array(w_ie))
    assert all(isinstance(x, list) for x in (nom.p, nom.v, nom.q, nom.f_n, nom.omega_b))
    assert np.allclose(nom.p, p1, atol=1e-9) and np.allclose(nom.v, v1, atol=1e-11)
    assert np.allclose(nom.q, q1, atol=1e-14) and np.allclose(nom.f_n, f_n, atol=1e-12)
    assert np.allclose(nom.omega_b, omega, atol=1e-15)
    assert nom.R == dcm(*nom.q)
    assert (nom.bb, nom.gb, nom.wind) == (3.0, [0.5, -0.3, 1.0], [3.0, -2.0])


def test_dcm_and_the_global_rotation_match_the_quaternion_algebra():
    rng = np.random.default_rng(3)
    for k in range(100):
        q = rng.standard_normal(4)
        q /= np.linalg.norm(q)
        assert np.allclose(np.array(dcm(*q)).reshape(3, 3), quat_to_dcm(q), rtol=0.0, atol=1e-15)
        d = rng.uniform(-0.1, 0.1, 3) if k % 10 else np.array((1e-11, -2e-11, 0.0))
        q1, R1 = rotate_global(tuple(q), *d)
        ref = qbatch.normalize(qbatch.mul(qbatch.from_rotvec(d), q))
        assert np.allclose(q1, ref, rtol=0.0, atol=1e-15)
        assert R1 == dcm(*q1)
    q1, R1 = rotate_global(tuple(Nominal().q), 0.0, 0.0, math.pi / 2)   # a quarter turn about down
    assert np.allclose(q1, (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)), atol=1e-15)
    assert np.allclose(np.array(R1).reshape(3, 3), ((0, -1, 0), (1, 0, 0), (0, 0, 1)), atol=1e-15)
