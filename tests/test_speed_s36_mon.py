"""The fault monitor's balances in compiled calls (stop 36): the kernels bit for bit against
the Python they replaced."""
from __future__ import annotations

import math
import random
from types import SimpleNamespace

import numpy as np

from autopilot.monitor.actuator import BAL_PERIOD_US, BAL_TAU_S, RESTART_HOLD_S, lowpass_advance, lowpass_state
from autopilot.monitor.airframe import AEROSONDE, C172P, gyro_elevator, prop_momentum
from autopilot.monitor.lateral import AEROSONDE_LAT, C172P_LAT, LateralIdentifier


def _prop_momentum_py(rpm_fit, sense, ixx, throttle, v):
    """PitchAero.prop_momentum / LateralAero.prop_momentum as they were written."""
    if ixx <= 0.0:
        return 0.0
    if len(rpm_fit) == 4:
        a, b, c, d = rpm_fit
        rpm = a + b * throttle + c * v + d * throttle * v
        rpm = 0.0 if 0.0 > rpm else rpm
    else:
        a, b, c, d, e = rpm_fit
        rpm = max(a + b * throttle + c * v + d * throttle * v + e * throttle * throttle, 0.0)
    return sense * ixx * rpm * (2.0 * math.pi / 60.0)


def test_propeller_kernels_bit_identical():
    rng = random.Random(5)
    for _ in range(3000):
        thr, v, r = rng.uniform(-0.1, 1.1), rng.uniform(8.0, 70.0), rng.gauss(0.0, 0.3)
        h = _prop_momentum_py(AEROSONDE.rpm, AEROSONDE.prop_sense, AEROSONDE.prop_ixx, thr, v)
        assert prop_momentum(AEROSONDE.gyro_coefs, thr, v) == h
        assert AEROSONDE.prop_momentum(thr, v) == h
        qbar = 0.5 * 1.225 * v * v
        g = (h * r / (qbar * AEROSONDE.wing_area_m2 * AEROSONDE.chord_m)) / AEROSONDE.D
        assert gyro_elevator(AEROSONDE.gyro_coefs, r, thr, v) == g
        assert C172P.gyro_elevator(r, thr, v) == 0.0 and C172P.prop_momentum(thr, v) == 0.0
        assert C172P_LAT.prop_momentum(thr, v) == _prop_momentum_py(C172P_LAT.rpm, C172P_LAT.prop_sense,
                                                                     C172P_LAT.prop_ixx, thr, v)


def test_lowpass_bit_identical_with_restarts():
    """lowpass_advance against the low-pass loop the balances ran: starts, gaps, dt 0."""
    rng = random.Random(11)
    lp, st = np.zeros(8), lowpass_state()          # four signals low-passed, then the four
    ref, t_ref, start, nxt, t0 = None, None, None, 0, None
    t = 1_000_000
    for k in range(4000):
        t += rng.choice((20_000, 20_000, 20_000, 0, 40_000))
        x = tuple(rng.gauss(0.0, 1.0) for _ in range(4))
        if k % 700 == 0:
            st[0] = 0                       # started again (not flying)
            ref = None
        lp[4:] = x
        due = lowpass_advance(lp, st, 4, t)
        # the Python of before
        want = False
        if ref is None:
            ref, t_ref, start = list(x), t, t
            t0 = t if t0 is None else t0
        else:
            dt = (t - t_ref) * 1e-6
            t_ref = t
            if dt > 0.0:
                a = dt / (BAL_TAU_S + dt)
                ref = [lo + a * (xi - lo) for lo, xi in zip(ref, x)]
                if t >= nxt:
                    nxt = t + BAL_PERIOD_US
                    want = not t - start < RESTART_HOLD_S * 1e6
        assert due == want and lp[:4].tolist() == ref and int(st[4]) == t0


def test_lateral_square_is_the_interpreters():
    """(V_REF / V) ** 2 inside the lateral balance's kernel is libm's pow, as the
    interpreter's ``** 2``: x * x differs in the last bit about once in 1200 (so some of
    these 5000 would)."""
    ident = LateralIdentifier(AEROSONDE_LAT, prop=AEROSONDE)
    rng = random.Random(2)
    differ = 0
    for k in range(5000):
        V = rng.uniform(10.0, 40.0)
        nav = SimpleNamespace(airspeed_mps=V, omega_b=np.array((0.1, 0.05, -0.02)))
        ident._st[0] = 0                 # (re)started: the low-pass takes the signal as it is
        ident.step(20_000 * k, nav, (0.1, 0.0, -0.05, 1.0), True, (0.0, 0.1, -9.8))
        assert ident._lp[7] == (25.0 / V) ** 2
        differ += (25.0 / V) * (25.0 / V) != (25.0 / V) ** 2
    assert differ > 0
