"""The L1 laws' kernels (autopilot/guidance/l1.py) against the same laws written out in
Python, bit for bit: the kernels replaced this Python, and every flight stayed the same."""
import math
import random

import pytest

from autopilot.guidance.l1 import G, MIN_GROUNDSPEED_MPS, L1Guidance

_TAN_INTERCEPT = math.tan(math.radians(60.0))


def _ground_velocity(v_ne, heading_rad, airspeed_mps):
    vn, ve = v_ne
    gs = math.hypot(vn, ve)
    if gs < MIN_GROUNDSPEED_MPS:
        s = max(MIN_GROUNDSPEED_MPS, airspeed_mps)
        return s * math.cos(heading_rad), s * math.sin(heading_rad), s
    return vn, ve, gs


def _accel(k, vn, ve, gs, ln, le, l1):
    eta = math.atan2(vn * le - ve * ln, vn * ln + ve * le)                 # eq 1.26
    s = math.copysign(1.0, eta) if abs(eta) > 0.5 * math.pi else math.sin(eta)
    return k * gs * gs / l1 * s, eta                                       # eq 1.25


def _line(zeta, period, p_ne, v_ne, a_ne, b_ne, heading_rad, airspeed_mps):
    k = 4.0 * zeta * zeta
    vn, ve, gs = _ground_velocity(v_ne, heading_rad, airspeed_mps)
    l1 = max(zeta * period * gs / math.pi, 1.0)
    dn, de = b_ne[0] - a_ne[0], b_ne[1] - a_ne[1]
    length = math.hypot(dn, de)
    pn, pe = p_ne[0] - a_ne[0], p_ne[1] - a_ne[1]
    if length < 1e-3:
        a, eta = _accel(k, vn, ve, gs, -pn, -pe, l1)
        return a, math.atan(a / G), 0.0, 0.0, eta, l1
    tn, te = dn / length, de / length
    nn, ne = -te, tn
    xtrack = pn * nn + pe * ne
    along = pn * tn + pe * te
    ahead = max(math.sqrt(max(l1 * l1 - xtrack * xtrack, 0.0)), abs(xtrack) / _TAN_INTERCEPT)
    a, eta = _accel(k, vn, ve, gs, tn * ahead - nn * xtrack, te * ahead - ne * xtrack, l1)
    return a, math.atan(a / G), xtrack, along, eta, l1


def _loiter(zeta, period, p_ne, v_ne, c_ne, radius_m, direction, heading_rad, airspeed_mps):
    k = 4.0 * zeta * zeta
    vn, ve, gs = _ground_velocity(v_ne, heading_rad, airspeed_mps)
    l1 = max(zeta * period * gs / math.pi, 1.0)
    rn, re = p_ne[0] - c_ne[0], p_ne[1] - c_ne[1]
    r = math.hypot(rn, re)
    if r < 1e-3:
        rn, re, r = -vn, -ve, gs
    urn, ure = rn / r, re / r
    tn, te = -direction * ure, direction * urn
    nn, ne = -te, tn
    radial_err = r - radius_m
    xtrack = -direction * radial_err
    ahead = max(math.sqrt(max(l1 * l1 - xtrack * xtrack, 0.0)), abs(xtrack) / _TAN_INTERCEPT)
    a, eta = _accel(k, vn, ve, gs, tn * ahead - nn * xtrack, te * ahead - ne * xtrack, l1)
    if abs(radial_err) < l1 and radius_m > 1.0:
        a = a + (1.0 - abs(radial_err) / l1) * direction * gs * gs / radius_m
    return a, math.atan(a / G), radial_err, 0.0, eta, l1


def _cases(seed: int, n: int):
    rnd = random.Random(seed)
    for i in range(n):
        u = lambda s: rnd.uniform(-s, s)   # noqa: E731
        speed = rnd.choice((0.0, 1e-3, 2.0, 2.999, 15.0, 25.0, 40.0))
        chi = u(math.pi)
        v = (speed * math.cos(chi) + (u(0.5) if i % 3 else 0.0), speed * math.sin(chi))
        p = (u(3000.0), u(3000.0))
        a = (u(3000.0), u(3000.0))
        # zero-length legs, the vehicle at the circle's centre, far off, on the path
        b = a if i % 17 == 0 else (a[0] + u(2000.0), a[1] + u(2000.0))
        c = p if i % 19 == 0 else (p[0] + u(400.0), p[1] + u(400.0))
        yield p, v, a, b, c, rnd.choice((0.0, 0.5, 60.0, 80.0, 150.0, 1500.0)), \
            rnd.choice((1, -1)), u(math.pi), rnd.uniform(0.0, 35.0)


@pytest.mark.parametrize("period, zeta", [(17.0, 0.75), (5.0, 0.6), (60.0, 1.0)])
def test_l1_kernels_are_the_laws_bit_for_bit(period, zeta):
    g = L1Guidance(period, zeta)
    n = 0
    for p, v, a, b, c, radius, direction, heading, airspeed in _cases(int(period), 4000):
        assert tuple(g.line(p, v, a, b, heading, airspeed)) == \
            _line(zeta, period, p, v, a, b, heading, airspeed)
        assert tuple(g.loiter(p, v, c, radius, direction, heading, airspeed)) == \
            _loiter(zeta, period, p, v, c, radius, direction, heading, airspeed)
        n += 1
    assert n == 4000
