"""Stop 36's structural rewrites of the quadrotor's per-step code give the same bits as
the code they replaced: the trajectory's step as one kernel on its state array (against
its Python step written out here as it was), a correctly rounded hypot in a kernel, and the
position, altitude and attitude loops with the mixer in one kernel (against the three
controllers called in turn)."""
import bisect
import math
import random
from types import SimpleNamespace

import numpy as np

from autopilot.control.multirotor import MultirotorController, hypot
from autopilot.guidance.multirotor import Trajectory
from autopilot.params import ParamStore
from autopilot.vehicle_quad import quad_param_declarations

DT = 0.004


# ------------------------------------------------------------------ trajectory ---
def _snapshot(tr):
    """The Python trajectory's state (as it was kept) of a Trajectory now."""
    poly = tr._poly
    return SimpleNamespace(
        raw=tr.raw, vraw=tr._vraw, p=tr.p, v=tr.v, start=tr.start, u=tr._u, len=tr._len,
        s=tr._s, vs=tr._vs, vmax=tr._vmax, amax=tr._amax, v_end=tr._v_end,
        descending=tr.descending, vdesc=tr._vdesc, w=tr.w, goal=tr.goal,
        poly=[tuple(r) for r in poly[:, :3].tolist()] if tr.curving else None,
        cum=poly[:, 3].tolist() if tr.curving else None)


def _old_at(st, s):
    cum, pts = st.cum, st.poly
    i = min(max(bisect.bisect_right(cum, s) - 1, 0), len(pts) - 2)
    seg = cum[i + 1] - cum[i]
    f = min(max((s - cum[i]) / seg, 0.0), 1.0) if seg > 1e-9 else 1.0
    a, b = pts[i], pts[i + 1]
    ln = max(math.dist(a, b), 1e-9)
    st.u = ((b[0] - a[0]) / ln, (b[1] - a[1]) / ln, (b[2] - a[2]) / ln)
    return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]))


def _old_step(st, dt, pv, leash):
    """Trajectory.update (_raw_step, _at) as it was, on the namespace ``st``."""
    r = st.raw
    if st.descending:
        vd0 = st.vraw[2]
        dv = st.vdesc - vd0
        lim = st.amax * dt
        vd1 = vd0 + (lim if dv > lim else -lim if dv < -lim else dv)
        if r[2] - pv[2] > 1.0:
            vd1 = min(vd1, 0.0)
        r[2] += 0.5 * (vd0 + vd1) * dt
        st.vraw = [0.0, 0.0, vd1]
    elif st.len <= 0.0:
        st.vraw = [0.0, 0.0, 0.0]
    else:
        vs0 = st.vs
        remaining = st.len - st.s
        lim = st.amax * dt
        v_brake = math.sqrt(2.0 * st.amax * max(0.0, remaining) + st.v_end * st.v_end)
        v_goal = min(v_brake, st.vmax)
        ex, ey, ez = r[0] - pv[0], r[1] - pv[1], r[2] - pv[2]
        if ex * ex + ey * ey + ez * ez > leash * leash:
            v_goal = 0.0
        dv = v_goal - vs0
        vs1 = vs0 + (lim if dv > lim else -lim if dv < -lim else dv)
        if vs1 > v_brake:
            vs1 = v_brake
        s = st.s + 0.5 * (vs0 + vs1) * dt
        if s >= st.len or (vs1 <= 0.0 and remaining < 1e-3):
            s, vs1 = st.len, (st.v_end if st.v_end > 0.0 and s >= st.len else 0.0)
        st.s, st.vs = s, vs1
        if st.poly is not None:
            st.raw = list(_old_at(st, s))
        else:
            u, a = st.u, st.start
            st.raw = [a[0] + u[0] * s, a[1] + u[1] * s, a[2] + u[2] * s]
        u = st.u
        st.vraw = [u[0] * vs1, u[1] * vs1, u[2] * vs1]
    w = st.w
    w2, w2x = w * w, 2.0 * w
    r, p, v = st.raw, st.p, st.v
    a = tuple(w2 * (r[k] - p[k]) - w2x * v[k] for k in range(3))
    v = tuple(v[k] + a[k] * dt for k in range(3))
    st.p, st.v, st.a = tuple(p[k] + v[k] * dt for k in range(3)), v, a


def _old_arrived(st):
    if st.descending or st.s < st.len:
        return False
    if st.v_end > 0.0:
        return True
    if st.vs != 0.0:
        return False
    p, g, v = st.p, st.goal, st.v
    return (abs(p[0] - g[0]) + abs(p[1] - g[1]) + abs(p[2] - g[2]) < 0.03
            and abs(v[0]) + abs(v[1]) + abs(v[2]) < 0.05)


def _fly_both(tr, steps, vehicle=None, leash=8.0):
    """Step the kernel and the old Python step side by side; every output equal."""
    st = _snapshot(tr)
    for k in range(steps):
        pv = vehicle(k) if vehicle else tr.p
        tr.update(DT, pv, leash)
        _old_step(st, DT, pv, leash)
        assert (tr.p, tr.v, tr.a) == (st.p, st.v, st.a)
        assert tr.raw == st.raw and tr._vraw == st.vraw and (tr._s, tr._vs) == (st.s, st.vs)
        assert tr.arrived == _old_arrived(st)
    return st


def _spline(p0, p1, m0, m1, n=64):
    pts = []
    for k in range(n + 1):
        u = k / n
        h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
        pts.append(tuple(h00 * a + h10 * ta + h01 * b + h11 * tb
                         for a, ta, b, tb in zip(p0, m0, p1, m1)))
    return pts


def test_trajectory_kernel_is_the_python_step_bit_for_bit():
    """Lines (followed, and with a vehicle stuck behind the leash), curves flown to a stop
    and through, a speed change, a home shift and the landing's open-ended descent: the
    kernel's p, v, a, raw profile, distance, speed and arrival are the old step's."""
    tr = Trajectory(4.0)
    tr.reset((0.0, 0.0, -10.0))
    tr.line_to((60.0, 25.0, -20.0), 5.0, 2.5, 1.5, 2.5, 1.5)
    st = _fly_both(tr, 1500)
    assert not tr.arrived and st.s > 20.0
    tr.retune(3.0, 2.5, 1.5)
    _fly_both(tr, 4000)
    assert tr.arrived                                      # flown to its end
    tr.line_to((200.0, 0.0, -10.0), 5.0, 2.5, 1.5, 2.5, 1.5)
    _fly_both(tr, 1500, vehicle=lambda k: (60.0, 25.0, -20.0))   # stuck: the leash holds it
    # a curve flown through, then one to a stop, a home shift half way
    p0 = tuple(tr.raw)
    tr.curve_to(_spline(p0, (100.0, 40.0, -15.0), (30.0, 10.0, 0.0), (0.0, 40.0, 0.0)),
                5.0, 2.5, 1.5, 2.5, 1.5, v_end=4.0)
    assert tr.curving
    _fly_both(tr, 2500)
    p0 = tuple(tr.raw)
    tr.curve_to(_spline(p0, (60.0, 90.0, -25.0), (0.0, 40.0, 0.0), (-30.0, 0.0, -5.0)),
                5.0, 2.5, 1.5, 2.5, 1.5)
    _fly_both(tr, 1200)
    tr.shift((3.0, -2.0, 0.5))
    _fly_both(tr, 6000)
    assert tr.arrived                                      # stopped at the curve's end
    tr.descend(1.5, 1.5)
    _fly_both(tr, 800)
    tr.set_descent_speed(0.5)
    d = tr.raw[2] + 2.0                                    # a vehicle 2 m below
    _fly_both(tr, 3000, vehicle=lambda k: (60.0, 90.0, d))
    assert 1.0 < tr.raw[2] - d < 1.01 and tr._vraw[2] == 0.0   # held 1 m below it


def test_hypot_kernel_is_pythons_hypot_bit_for_bit():
    rng = random.Random(3)
    vals = [0.0, -0.0, 1e-300, 3.0, -4.0, 1e300, 0.5, 0.1, -0.7]
    pairs = [(a, b) for a in vals for b in vals]
    for _ in range(200000):
        a = rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-12, 4)
        b = rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-12, 4)
        pairs.append((a, b))
    bad = [(a, b) for a, b in pairs if hypot(a, b) != math.hypot(a, b)]
    assert not bad, bad[:5]


# ------------------------------------------------------------------- control -----
def test_track_is_the_position_altitude_and_attitude_loops_in_turn():
    """MultirotorController.track (one kernel call, track_mix) gives, bit for bit, what
    pos.update, the altitude loop (its anti-windup from the last mixing) and attitude
    gave called one after the other, and leaves the same states and records behind:
    tilt and integrator limits, a saturating mixer and a weak rotor included."""
    p = ParamStore(quad_param_declarations())
    new, old = MultirotorController(p, DT), MultirotorController(p, DT)
    rng = np.random.default_rng(11)
    for k in range(3000):
        if k == 1500:
            for c in (new, old):
                c.mixer.set_effectiveness((1.0, 0.6, 1.0, 0.8))
        big = 30.0 if k % 7 == 0 else 2.0               # tilt and thrust saturated at times
        q = (np.array((1.0, *rng.uniform(-0.2, 0.2, 3))) / 1.05).tolist()
        w = tuple(rng.uniform(-1.0, 1.0, 3).tolist())
        tp, tv, ta = (tuple(rng.uniform(-big, big, 3).tolist()) for _ in range(3))
        pos, v = tuple(rng.uniform(-2.0, 2.0, 3).tolist()), tuple(rng.uniform(-2.0, 2.0, 3).tolist())
        yaw, roll, pitch, yaw_d = rng.uniform(-3.0, 3.0, 4).tolist()
        hold_pos, hold_alt = bool(k % 11 == 0), bool(k % 13 == 0)
        y = np.array((*v, *q, *w, roll, pitch, yaw))                   # (Y_*)
        got = new.track(y, pos, np.array((*tp, *tv, *ta)), yaw_d, DT, hold_pos, hold_alt)
        r_d, p_d = old.pos.update(tp[0] - pos[0], tp[1] - pos[1], tv[0] - v[0], tv[1] - v[1],
                                  ta[0], ta[1], yaw, DT, hold_pos)
        m = old.mixer
        sat = m.saturated[2]
        req = old.u[0]
        tilt_cos = math.cos(roll) * math.cos(pitch)
        u_z = old.alt.update(-tp[2], -tv[2], -ta[2], -pos[2], -v[2], tilt_cos, DT, hold_alt,
                             sat and m.collective < req - 1e-6, sat and m.collective > req + 1e-6)
        want = old.attitude(q, w, r_d, p_d, yaw_d, u_z)
        assert got == want and new.u == old.u and (new.roll_d, new.pitch_d, new.yaw_d) == (
            old.roll_d, old.pitch_d, old.yaw_d)
        assert np.array_equal(new.x, old.x) and new.att.error == old.att.error
        assert (new.mixer.saturated, new.mixer.collective, new.mixer.thrusts) == (
            m.saturated, m.collective, m.thrusts)


def test_controller_parts_are_views_of_its_array():
    """The loops' gains and states live in the controller's one array (the kernels'
    argument): writing through a part is seen there."""
    c = MultirotorController(ParamStore(quad_param_declarations()), DT)
    for part in (c.att.x, c.att.coef, c.att.state, c.mixer.k, c.pos.g, c.alt.g):
        assert np.shares_memory(part, c.x)
    c.pos.i_n = 0.25
    c.alt.reset(1.5)
    assert 0.25 in c.x.tolist() and 1.5 in c.x.tolist() and c.alt.integ == 1.5
