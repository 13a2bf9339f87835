"""Stop 35's rewrites of the quadrotor's per-step code for speed give the same bits as
the code they replaced (written out here as it was)."""
import math
import random

import numpy as np

from autopilot.control.mixer import QuadPlusMixer
from autopilot.control.multirotor import G, Y_N, Y_W, ReferenceAngleGenerator
from autopilot.monitor.motors import S_B, S_HAS_LP, S_KF_N, S_LAG, S_LP, S_T, MotorMonitor
from autopilot.params import ParamStore
from autopilot.vehicle_quad import quad_param_declarations


def _params():
    return ParamStore(quad_param_declarations())


def _reference_angles_before(gen, e_n, e_e, ev_n, ev_e, a_n, a_e, yaw, dt, hold):
    """ReferenceAngleGenerator.update as it was (rotations with -s first)."""
    c, s = math.cos(yaw), math.sin(yaw)
    ex, ey = c * e_n + s * e_e, -s * e_n + c * e_e
    vx, vy = c * ev_n + s * ev_e, -s * ev_n + c * ev_e
    ax, ay = c * a_n + s * a_e, -s * a_n + c * a_e
    ix, iy = c * gen.i_n + s * gen.i_e, -s * gen.i_n + c * gen.i_e
    kpp, kip, kdp = gen.pitch
    kpr, kir, kdr = gen.roll
    theta = -(kpp * ex + kip * ix + kdp * vx) - ax / G
    phi = (kpr * ey + kir * iy + kdr * vy) + ay / G
    tilt = math.hypot(phi, theta)
    saturated = tilt > gen.angle_max
    if saturated:
        k = gen.angle_max / tilt
        phi, theta = phi * k, theta * k
    if not hold and not saturated:
        gen.i_n += e_n * dt
        gen.i_e += e_e * dt
        lim_n = gen.i_lim
        m = math.hypot(gen.i_n, gen.i_e)
        if m > lim_n:
            gen.i_n *= lim_n / m
            gen.i_e *= lim_n / m
    return phi, theta


def test_reference_angles_bit_identical():
    rng = random.Random(35)
    new, old = ReferenceAngleGenerator(_params()), ReferenceAngleGenerator(_params())
    saturated = limited = 0
    for k in range(20000):
        # small errors over long steps (the integral's limit), large ones (the tilt's)
        scale, dt = ((0.02, 2.0), (1.0, 0.004), (30.0, 0.004))[k % 3]
        args = [rng.gauss(0.0, scale) for _ in range(6)] + [rng.uniform(-4.0, 4.0), dt,
                                                            rng.random() < 0.1]
        got = new.update(*args)
        want = _reference_angles_before(old, *args)
        assert got == want and (new.i_n, new.i_e) == (old.i_n, old.i_e)
        saturated += math.hypot(*got) >= new.angle_max * (1.0 - 1e-12)
        limited += math.hypot(new.i_n, new.i_e) >= new.i_lim * (1.0 - 1e-12)
    assert saturated > 1000 and limited > 100     # both limits were exercised


def test_motor_monitor_lowpass_bit_identical():
    """MotorMonitor.update's thrust lag and low-passes against the loop they replaced."""
    rng = random.Random(7)
    mixer = QuadPlusMixer(15.7, 0.78, 0.1)
    mon = MotorMonitor(_params(), 0.004, div=2)
    mon._s[S_KF_N] = 10 ** 9                     # the balance itself is not under test here
    lag, b = mon._s[S_LAG], mon._s[S_B]
    T, lp = [0.0] * 4, None
    y = np.zeros(Y_N)                            # (the navigation output: its rates)
    for k in range(5000):
        motors = tuple(rng.uniform(0.1, 1.0) for _ in range(4))
        f_b = (rng.gauss(0, 1), rng.gauss(0, 1), rng.gauss(-9.8, 1))
        omega = tuple(rng.gauss(0, 0.5) for _ in range(3))
        flying = k % 500 > 20
        y[Y_W:Y_W + 3] = omega
        mon.update(k * 8000, flying, motors, f_b[2], y, mixer.k)
        for i in range(4):
            T[i] += (mixer.thrust_of(motors[i]) - T[i]) * lag
        if not flying:
            lp = None
        else:
            p, q, r = omega
            x = (T[0], T[1], T[2], T[3], f_b[2], p, q, r, q * r, p * r, p * q)
            if lp is None:
                lp = list(x)
            else:
                for i in range(11):
                    lp[i] += (x[i] - lp[i]) * b
        assert mon._s[S_T:S_LP].tolist() == T
        assert (mon._s[S_LP:S_HAS_LP].tolist() if mon._s[S_HAS_LP] else None) == lp
    assert lp is not None


def test_motor_monitor_isolation_statistic_bit_identical():
    """MotorMonitor._decide's isolation statistic on floats against the array formula."""
    import numpy as np
    rng = np.random.default_rng(3)
    mon = MotorMonitor(_params(), 0.004, div=2)
    for _ in range(2000):
        mon.gamma = 1.0 + rng.normal(0.0, 0.05, 4)
        A = rng.normal(0.0, 0.01, (4, 4))
        mon.P = A @ A.T + np.diag(rng.choice((0.0, 1e-13, 1e-4), 4))
        mon.ratio = 0.0
        mon._decide(1.0)
        g = mon.gamma
        others = (float(g.sum()) - g) / 3.0
        dev = (g - others) ** 2 / (np.maximum(np.diag(mon.P), 1e-12) * (4.0 / 3.0)) / mon.thr_iso
        assert mon.iso_ratio == float(dev[int(np.argmax(dev))])
    assert not mon.detected


def test_balance_residuals_bit_identical():
    """motors.balance_residuals against the numpy array formulas it replaced."""
    import numpy as np
    from autopilot.monitor.motors import MODEL_REL, balance_residuals
    rng = np.random.default_rng(11)
    var_k = np.ones(4)
    var_n = np.ones(4)
    floored = 0
    for k in range(3000):
        H = rng.normal(3.4, 0.3, (4, 4)) * rng.choice((-1.0, 0.0, 1.0), (4, 4))
        c = float(rng.uniform(0.8, 1.2))
        # every other 50 steps residuals so small that the learnt variances fall below
        # the floor (learning starts again at the first of them)
        tiny = k // 50 % 2 == 1
        y = c * (H @ np.ones(4)) + rng.normal(0.0, 1e-5 if tiny else 1.0, 4)
        gamma = 1.0 + rng.normal(0.0, 0.02, 4)
        learn, first, w = k % 50 != 7, k % 100 in (0, 50), 1.0 - math.exp(-0.1 / 20.0)
        got = balance_residuals(y, H @ np.ones(4), H @ gamma, c, var_k, learn, first, w)
        m1 = c * (H @ np.ones(4))
        r1 = y - m1
        if learn:
            if first:
                var_n = r1 * r1 + 1e-6
            else:
                var_n += (r1 * r1 - var_n) * w
        rel = MODEL_REL * m1
        rel[0] = 0.0
        var = np.maximum(var_n, 1e-6) + rel * rel
        want = (r1, np.sqrt(var), var / (c * c), y / c - H @ gamma)
        assert all((a == b).all() for a, b in zip(got, want)) and (var_k == var_n).all()
        floored += int((var_k < 1e-6).sum())
    assert 1000 < floored < 10000                 # both sides of the variance floor
