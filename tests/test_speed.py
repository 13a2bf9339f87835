"""The compiled kernels (autopilot/jit.py) against the equations they compute, written
out once more here in numpy (the slow twin lives only in the tests)."""
from __future__ import annotations

import math

import numpy as np

from autopilot.nav import qbatch
from autopilot.nav.layout import ABIAS, ATT, GBIAS, GPSB, POS, VEL
from autopilot.nav.strapdown import GRAVITY_GRADIENT, Nominal, earth_rate_ned, mechanise
from autopilot.nav.ukf import propagate_sigmas


def _fx_numpy(sig, dt, nom0, nom1, f_m, omega_m, w_ie, g, a_gm):
    """strapdown.py's mechanisation on every sigma point (the UKF's process model)."""
    w_ie = np.asarray(w_ie)
    p = np.asarray(nom0.p) + sig[:, POS]
    v = np.asarray(nom0.v) + sig[:, VEL]
    q = qbatch.mul(qbatch.from_rotvec(sig[:, ATT]), np.asarray(nom0.q))
    Rs = qbatch.to_dcm(q)
    w = np.asarray(omega_m) - (np.asarray(nom0.bg) + sig[:, GBIAS]) - np.einsum("nji,j->ni", Rs, w_ie)
    f = np.asarray(f_m) - (np.asarray(nom0.ba) + sig[:, ABIAS])
    fg = f + 0.5 * dt * qbatch.cross(w, f)
    f_n = np.einsum("nij,nj->ni", Rs, fg)
    v1 = v + (f_n - 2.0 * qbatch.cross(w_ie, v)) * dt
    v1[:, 2] += (g + GRAVITY_GRADIENT * p[:, 2]) * dt
    p1 = p + 0.5 * (v + v1) * dt
    q1 = qbatch.mul(q, qbatch.from_rotvec(w * dt))
    out = sig.copy()
    out[:, POS] = p1 - np.asarray(nom1.p)
    out[:, VEL] = v1 - np.asarray(nom1.v)
    out[:, ATT] = qbatch.to_rotvec(qbatch.mul(q1, qbatch.conj(np.asarray(nom1.q))))
    out[:, GPSB] = sig[:, GPSB] * a_gm
    return out


def test_ukf_sigma_propagation_matches_the_equations():
    rng = np.random.default_rng(7)
    nom0 = Nominal()
    nom0.p = [120.0, -40.0, -95.0]
    nom0.v = [18.0, 9.0, -1.5]
    nom0.set_attitude(qbatch.from_euler(np.array(0.4), np.array(0.1), np.array(2.0)))
    nom0.ba = [0.05, -0.02, 0.1]
    nom0.bg = [0.001, -0.002, 0.0005]
    nom1 = nom0.copy()
    f_m, omega_m = [0.8, 0.3, -9.6], [0.05, 0.2, -0.3]
    w_ie, g, dt = earth_rate_ned(math.radians(-35.0)), 9.797, 0.01
    nom1.x[:25] = mechanise(*nom1.p, *nom1.v, *nom1.q, *nom1.bg, *nom1.ba, *f_m, *omega_m, dt, g, *w_ie)
    sd = np.array([2, 2, 3, .5, .5, .5, .05, .05, .3, .1, .1, .1, .01, .01, .01, 1, 1, 1, 1, 2, 2])
    sig = rng.standard_normal((43, 21)) * sd
    sig[0] = 0.0
    sig[1, ATT] = 1e-12                                  # the small-angle branches
    ref = _fx_numpy(sig, dt, nom0, nom1, f_m, omega_m, w_ie, g, 0.99)
    out = np.empty_like(sig)
    propagate_sigmas(sig, dt, np.array((*nom0.p, *nom0.v, *nom0.q, *nom0.bg, *nom0.ba, *nom1.p,
                                        *nom1.v, *nom1.q, *f_m, *omega_m, *w_ie, g, 0.99)), out)
    assert np.max(np.abs(out - ref)) < 1e-12
    # the central point propagates with the nominal state: zero error after
    assert np.max(np.abs(out[0, :9])) < 1e-9


def test_message_records_are_frozen_dataclasses_with_the_same_constructor():
    import copy
    import dataclasses
    import inspect

    import pytest

    from autopilot.frozen import message
    from autopilot.messages import NavState

    @message
    class Rec:
        t_us: int
        v: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
        ok: bool = True

    r = Rec(5)
    assert (r.t_us, r.v.tolist(), r.ok) == (5, [0.0, 0.0, 0.0], True)
    assert Rec(1).v is not Rec(1).v                       # a fresh default every time
    assert (Rec(t_us=2, ok=False).ok, Rec(t_us=2, ok=False).t_us) == (False, 2)
    assert list(inspect.signature(Rec).parameters) == ["t_us", "v", "ok"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.t_us = 6
    with pytest.raises(TypeError):
        Rec()                                             # a field without default is required
    n = NavState(1, np.zeros(3), np.zeros(3), np.array([1.0, 0, 0, 0]), np.zeros(3), 0.1, 0.2, 3.0, 4.0)
    assert (n.source, n.aligned, n.wind_ned.tolist()) == ("truth", True, [0.0, 0.0, 0.0])
    assert dataclasses.replace(n, alt_m=5.0).alt_m == 5.0
    assert type(r) is Rec and type(copy.copy(n)) is NavState and copy.copy(n) == n
    with pytest.raises(TypeError):
        class Sub(Rec):                                   # the mutable twin's layout is Rec's
            pass
    with pytest.raises(TypeError):
        @message
        class Bad:
            a: int

            def __post_init__(self):
                pass


def test_ukf_sigma_measurements_match_the_equations():
    from autopilot.nav.layout import WIND
    from autopilot.nav.ukf import sigma_airspeed, sigma_heading, sigma_sideslip
    rng = np.random.default_rng(3)
    sig = rng.standard_normal((43, 21)) * 0.3
    sig[1, ATT] = 1e-12
    sig[2, ATT] = (0.0, 0.0, 3.0)                         # a heading across the +-pi wrap
    m = np.array([0.22, 0.05, -0.5])
    v, wind = np.array([20.0, -3.0, 1.0]), np.array([4.0, 2.0])
    c1 = np.array([0.1, 0.98, 0.17])
    R_i = qbatch.to_dcm(qbatch.from_rotvec(sig[:, ATT]))
    # heading: h0 + wrap(atan2 of the turned field - atan2 of the field)
    m_i = np.einsum("nij,j->ni", R_i, m)
    dg = np.arctan2(m_i[:, 1], m_i[:, 0]) - np.arctan2(m[1], m[0])
    ref = 0.5 + (dg + np.pi) % (2.0 * np.pi) - np.pi
    out = np.empty(43)
    sigma_heading(sig, 0.5, m, out)
    assert np.max(np.abs(out - ref)) < 1e-12
    vr = v + sig[:, VEL]
    vr[:, :2] -= wind + sig[:, WIND]
    sigma_airspeed(sig, v, wind, out)
    assert np.max(np.abs(out - np.sqrt(np.einsum("ni,ni->n", vr, vr)))) < 1e-12
    sigma_sideslip(sig, v, wind, c1, out)
    assert np.max(np.abs(out - np.einsum("ni,ni->n", np.einsum("nij,j->ni", R_i, c1), vr))) < 1e-12


def test_codec_lockstep_fast_path_gives_what_the_general_path_gives():
    """Codec.decode's fast path (whole unsigned frames of raw_ids) against the general
    loop, on a stream cut at every byte and spiked with garbage and another message."""
    from autopilot.link.codec import MAV, Codec
    from autopilot.link.hil import HIL_IDS, ID_SENSOR, ID_STATE
    enc = Codec(1, 25)
    s_vals = (123456789, 0.1, 0.2, -9.8, 0.01, 0.02, 0.03, 0.2, 0.05, -0.4, 950.0, 3.0, 500.0,
              15.0, 7167, 0)
    t_vals = (123456789, 1.0, 0.0, 0.0, 0.0, 0.01, 0.02, 0.03, -353600000, 1491700000, 600000,
              2000, 100, -50, 2500, 2600, 10, 20, -1000)
    hb = enc.encode(MAV.MAVLink_heartbeat_message(1, 3, 0, 0, 4, 3))
    frames = [enc.encode_values(ID_STATE, t_vals), enc.encode_values(ID_SENSOR, s_vals)]
    stream = frames[0] + frames[1] + b"\x00\xfdjunk" + hb + frames[1] + frames[0]
    want = [(ID_STATE, t_vals), (ID_SENSOR, s_vals), "HEARTBEAT", (ID_SENSOR, s_vals), (ID_STATE, t_vals)]

    def seen(msgs):
        return [(m.msg_id, tuple(m.values)) if hasattr(m, "msg_id") else m.get_type() for m in msgs]

    for cut in range(len(stream) + 1):
        c = Codec(1, 1)
        got = seen(c.decode(stream[:cut], HIL_IDS)) + seen(c.decode(stream[cut:], HIL_IDS))
        assert [g if isinstance(g, str) else (g[0], tuple(round(x, 4) for x in g[1])) for g in got] == \
            [w if isinstance(w, str) else (w[0], tuple(round(x, 4) for x in w[1])) for w in want]
        assert c.pending == 0 and c.bad_frames >= 1
    bad = bytearray(frames[1])
    bad[-1] ^= 0xFF                                       # a CRC error costs only that frame
    c = Codec(1, 1)
    assert seen(c.decode(frames[0] + bytes(bad) + frames[0], HIL_IDS)) == [seen([m])[0] for m in
                                                                            Codec(1, 1).decode(frames[0] * 2, HIL_IDS)]


def test_ukf_moments_match_the_unscented_transform():
    from autopilot.nav.ukf import ukf_moments
    rng = np.random.default_rng(5)
    n, m = 21, 43
    sf = rng.standard_normal((m, n))
    Wm = np.full(m, 0.5 / (m - 1) * 1.3)
    Wm[0] = 1.0 - Wm[1:].sum()
    Wc = Wm.copy()
    Wc[0] += 1.2
    q = rng.random(n) * 1e-3
    idx = np.array([3 * n + 4, 4 * n + 3, 5 * n + 5])
    qs = np.array([0.01, 0.01, 0.02])
    floor, ceil = np.full(n, 1e-9), np.full(n, 10.0)
    ceil[2] = 0.05                                       # a clamped diagonal entry
    x_ref = Wm @ sf
    y = sf - x_ref
    P_ref = (y.T * Wc) @ y + np.diag(q)
    P_ref.flat[idx] += qs
    P_ref = 0.5 * (P_ref + P_ref.T)
    d = P_ref.reshape(-1)[:: n + 1]
    np.clip(d, floor, ceil, out=d)
    x, P, s = np.empty(n), np.empty((n, n)), sf.copy()
    ukf_moments(s, Wm, Wc, q, qs, idx, floor, ceil, x, P)
    assert np.max(np.abs(x - x_ref)) < 1e-12
    assert np.max(np.abs(P - P_ref)) < 1e-12 and P[2, 2] == 0.05 and (P == P.T).all()
    assert np.max(np.abs(s - y)) < 1e-12                # re-centred in place


def test_ukf_update_matches_the_equations():
    from autopilot.nav.ukf import ukf_update
    rng = np.random.default_rng(9)
    n, m, k = 21, 43, 4
    sf = rng.standard_normal((m, n)) * 0.1
    Zs = sf[:, :k] @ rng.standard_normal((k, k)) + rng.standard_normal((m, k)) * 0.01
    Wm = np.full(m, 1.0 / m)
    Wc = Wm.copy()
    Wc[0] += 0.7
    z, R = rng.standard_normal(k) * 0.1, np.full(k, 0.05)
    A = rng.standard_normal((n, n))
    P = A @ A.T * 0.01 + np.eye(n)
    floor, ceil = np.full(n, 1e-9), np.full(n, 1e6)
    zp = Wm @ Zs
    dz = Zs - zp
    S = (dz.T * Wc) @ dz + np.diag(R)
    K = ((sf.T * Wc) @ dz) @ np.linalg.inv(S)
    P_ref = P - K @ S @ K.T
    P_ref = 0.5 * (P_ref + P_ref.T)
    x, P1 = ukf_update(sf, Zs, Wm, Wc, z, R, floor, ceil, P)
    assert np.max(np.abs(x - K @ (z - zp))) < 1e-12
    assert np.max(np.abs(P1 - P_ref)) < 1e-12 and (P1 == P1.T).all()


def test_quadrotor_flight_step_is_the_plants_law():
    """The quadrotor plant's compiled step against eqs 3.23-3.26 written out here: a
    tilted, spinning, climbing vehicle in wind, one 4 ms step."""
    from sim_bridge.plants.quadrotor import QuadrotorPlant, flight_step
    pl = QuadrotorPlant(home=(-35.36, 149.17, 584.0, 0.0))
    af, dt = pl.af, pl.dt_s
    p, v = np.array([3.0, -2.0, -15.0]), np.array([4.0, 1.0, -0.5])
    q = qbatch.from_euler(np.array(0.2), np.array(-0.1), np.array(1.0))
    w, T = np.array([0.3, -0.2, 0.1]), np.array([3.0, 3.5, 3.2, 3.4])
    u, k = (0.62, 0.55, 0.58, 0.52), (1.0, 0.7, 1.0, 0.9)      # commands, motor faults' shares
    T_ss = np.array(pl.static_thrusts(u)) * k
    wind = np.array([2.0, -1.0, 0.3])
    out = np.concatenate((p, v, q, w, np.full(3, np.nan), np.full(3, np.nan), T))
    code = flight_step(out, pl._consts, *u, *k, *wind, False, 1e3)
    assert code == 0                                  # flew (far above the ground)
    T1 = T + (T_ss - T) * pl._lag
    R = qbatch.to_dcm(q)
    va = v - wind
    drag = -(af.drag_lin + 0.5 * pl.rho * af.drag_area_m2 * np.linalg.norm(va)) * va
    F = -T1.sum() * R[:, 2] + drag + np.array([0.0, 0.0, af.mass_kg * pl.g])
    M = np.array([af.arm_m * (T1[1] - T1[3]), af.arm_m * (T1[2] - T1[0]),
                  pl._km * (T1[0] + T1[2] - T1[1] - T1[3])])
    I = np.array([af.ixx, af.iyy, af.izz])
    w1 = w + (M - np.cross(w, I * w)) / I * dt
    v1 = v + F / af.mass_kg * dt
    q1 = qbatch.mul(q, qbatch.from_rotvec(0.5 * (w + w1) * dt))
    assert np.max(np.abs(out[19:23] - T1)) < 1e-12
    assert np.max(np.abs(out[10:13] - w1)) < 1e-12
    assert np.max(np.abs(out[3:6] - v1)) < 1e-12
    assert np.max(np.abs(out[0:3] - (p + 0.5 * (v + v1) * dt))) < 1e-12
    assert np.max(np.abs(out[6:10] - q1 / np.linalg.norm(q1))) < 1e-12
    assert np.max(np.abs(out[13:16] - R.T @ (drag - T1.sum() * R[:, 2]) / af.mass_kg)) < 1e-12


def test_settled_heap_freezes_for_the_flight_and_gives_every_object_back():
    """autopilot/heap.py: inside the block the objects that existed are frozen (the
    collector skips them) while what the block allocates is collected as usual; after
    it nothing stays frozen, so a reference cycle dropped during the flight is
    reclaimed (a campaign worker flying run after run does not grow)."""
    import gc
    import weakref

    from autopilot.heap import settled_heap

    class Node:
        pass

    before = Node()
    before.self = before                       # a cycle: only the collector frees it
    gone_before = weakref.ref(before)
    assert gc.get_freeze_count() == 0
    with settled_heap():
        assert gc.get_freeze_count() > 1000    # the interpreter's and numpy's objects at least
        del before
        gc.collect()
        assert gone_before() is not None       # frozen: not scanned, not freed
        during = Node()
        during.self = during
        gone_during = weakref.ref(during)
        del during
        gc.collect()
        assert gone_during() is None           # allocated in the block: collected as usual
    assert gc.get_freeze_count() == 0
    gc.collect()
    assert gone_before() is None               # given back: reclaimed


def _spd(rng, n):
    A = rng.standard_normal((n, n))
    return A @ A.T + n * np.eye(n)


def test_rotor_effectiveness_update_matches_the_equation():
    """monitor/stats.stage2_update against stage 2's Kalman step written in numpy: the
    rotors' 4 x 4 (motors.py) and the elevator's one row over [k, s] (actuator.py)."""
    from autopilot.monitor.stats import stage2_update
    rng = np.random.default_rng(13)
    t = rng.uniform(1.0, 3.0, 4)
    H = np.array(((t[0], t[1], t[2], t[3]), (0.0, t[1], 0.0, -t[3]), (-t[0], 0.0, t[2], 0.0),
                  (t[0], -t[1], t[2], -t[3])))
    P = _spd(rng, 4) * 1e-3
    gamma = rng.uniform(0.6, 1.1, 4)
    e = rng.standard_normal(4) * 0.1
    r = rng.uniform(0.01, 0.1, 4)
    q = 3e-5
    Pm = P + q * np.eye(4)
    S = H @ Pm @ H.T + np.diag(r)
    K = Pm @ H.T @ np.linalg.inv(S)
    A = np.eye(4) - K @ H
    want_P = A @ Pm @ A.T + K @ np.diag(r) @ K.T
    want_P = 0.5 * (want_P + want_P.T)
    g, P1 = stage2_update(gamma, P, H, e, r, q)
    assert np.abs(g - (gamma + K @ e)).max() <= 1e-12
    assert np.abs(P1 - want_P).max() <= 1e-12 * np.abs(want_P).max()
    assert (P1 == P1.T).all()
    # the elevator's: H = [delta_cmd, 1], scalar R (actuator.py before the kernel)
    Hr, Pg, R = np.array([0.3, 1.0]), np.array([[2e-4, 1e-5], [1e-5, 3e-4]]), 0.02
    gam, e1 = np.array([0.9, 0.01]), 0.05
    Pq = Pg + np.eye(2) * q
    K = Pq @ Hr / (float(Hr @ Pq @ Hr) + R)
    A = np.eye(2) - np.outer(K, Hr)
    want_P = A @ Pq @ A.T + np.outer(K, K) * R
    g, P1 = stage2_update(gam, Pg, Hr.reshape(1, 2), np.array((e1,)), np.array((R,)), q)
    assert np.abs(g - (gam + K * e1)).max() <= 1e-15
    assert np.abs(P1 - want_P).max() <= 1e-12 * np.abs(want_P).max()


def test_ukf_predict_is_sigma_points_then_propagation_then_moments():
    """The one-call prediction gives bit for bit what its three steps give (filterpy's
    sigma points, the mechanisation, the unscented transform), and the eigen square
    root's path when the covariance is not positive definite."""
    from autopilot.nav.ukf import (UKF_ALPHA, UKF_BETA, UKF_KAPPA, _SigmaPoints, _robust_sqrt,
                                   ukf_moments, ukf_predict)
    rng = np.random.default_rng(11)
    n = 21
    pts = _SigmaPoints(n, alpha=UKF_ALPHA, beta=UKF_BETA, kappa=UKF_KAPPA, sqrt_method=_robust_sqrt)
    A = rng.standard_normal((n, n)) * 0.05
    P = A @ A.T + np.diag(np.full(n, 1e-3))
    x = rng.standard_normal(n) * 1e-3
    nom = (120.0, -40.0, -95.0, 18.0, 9.0, -1.5, 0.9, 0.1, 0.2, 0.37, 1e-3, -2e-3, 5e-4, .05, -.02, .1)
    c = np.array(nom + (120.18, -39.91, -95.015, 18.01, 9.0, -1.49, 0.9, 0.1, 0.2, 0.37,
                        0.8, 0.3, -9.6, 0.05, 0.2, -0.3, 0.0, 5e-5, -4e-5, 9.797, 0.99))
    q, floor, ceil = rng.random(n) * 1e-6, np.full(n, 1e-12), np.full(n, 1e4)
    qs, idx = np.array([1e-5]), np.array([6 * n + 6])
    sf_ref, x_ref, P_ref = np.empty((2 * n + 1, n)), np.empty(n), np.empty((n, n))
    propagate_sigmas(pts.sigma_points(x, P), 0.01, c, sf_ref)
    ukf_moments(sf_ref, pts.Wm, pts.Wc, q, qs, idx, floor, ceil, x_ref, P_ref)
    sig, sf, x1, P1 = (np.empty((2 * n + 1, n)), np.empty((2 * n + 1, n)), np.empty(n),
                       np.empty((n, n)))
    ukf_predict(x, P, UKF_ALPHA ** 2 * (n + UKF_KAPPA), 0.01, c, pts.Wm, pts.Wc, q, qs, idx,
                floor, ceil, sig, sf, x1, P1)
    assert np.array_equal(sf, sf_ref) and np.array_equal(x1, x_ref) and np.array_equal(P1, P_ref)
    P[3, 3] = -1e-9                                      # not positive definite: refused
    try:
        ukf_predict(x, P, 1.0, 0.01, c, pts.Wm, pts.Wc, q, qs, idx, floor, ceil, sig, sf, x1, P1)
    except np.linalg.LinAlgError:
        pass
    else:
        raise AssertionError("a covariance that is not positive definite was accepted")


def test_join_cost_is_scored_on_the_paths_samples():
    """dubins.path_cost, written without the generator, scores exactly what the
    mission's cross-track scores on ``samples()`` (the rule written out once more
    here), for joins from every side and course."""
    from autopilot.guidance import dubins
    rng = np.random.default_rng(4)

    def ref(segments, a, u, side, tol):
        psi = math.atan2(u[1], u[0])
        cross = after = xt2 = 0.0
        captured = False
        for n, e, chi in dubins.samples(segments):
            x = (n - a[0]) * -u[1] + (e - a[1]) * u[0]
            if not captured:
                if side != 0.0:
                    cross = max(cross, -side * x)
                if abs(x) <= dubins.CAPTURE_M and math.cos(chi - psi) > 0.0:
                    captured = True
            if captured:
                after = max(after, abs(x))
                xt2 += x * x * dubins.SAMPLE_M
        stray = max(max(cross - tol, 0.0), after - dubins.CAPTURE_M)
        return dubins.STRAY_WEIGHT * stray + dubins.XT2_WEIGHT * xt2, stray

    scored = 0
    for _ in range(40):
        p = tuple(rng.uniform(-400.0, 400.0, 2))
        chi = rng.uniform(-math.pi, math.pi)
        a, b = (0.0, 0.0), tuple(rng.uniform(-600.0, 600.0, 2))
        ln = math.hypot(*b)
        u = (b[0] / ln, b[1] / ln)
        for side in (-1.0, 0.0, 1.0):
            for s in (0.0, 0.5 * ln, ln):
                q = (s * u[0], s * u[1])
                for _, segs in dubins.csc_words(p, chi, q, math.atan2(u[1], u[0]), 80.0):
                    got = dubins.path_cost(segs, a, u, side, 2.0)
                    assert got == ref(segs, a, u, side, 2.0)
                    scored += got[0] > 0.0
    assert scored > 100                                  # the paths did cost something


def _fly_split(seconds: float, split: bool):
    """The default mission's first ``seconds`` in one process, each step run as
    ``step`` or as ``control_step``, the answer, then ``finish_step`` (autopilot/cli.py)."""
    from tools.runner import DEFAULT_SCENARIO, RunConfig, Session
    s = Session(RunConfig(scenario=DEFAULT_SCENARIO, duration_s=seconds, seed=2))
    v = s.vehicle
    answered_before_log = []
    while s.t_s < seconds:
        s.bridge.send_current()
        for frame, truth in s.ap_end.poll():
            if split:
                out = v.control_step(frame, truth)
                rows = len(v.log.rows)
                s.ap_end.answer(out)
                v.finish_step()
                answered_before_log.append(len(v.log.rows) - rows)
            else:
                s.ap_end.answer(v.step(frame, truth))
        s.bridge.advance(s.sim_end.poll_answer(s.bridge.t_us))
    return v.log, answered_before_log


def test_a_step_answered_before_it_finishes_flies_and_logs_as_one_step():
    # GIVEN the default mission flown 12 s (launch at 3 s of healthy navigation), once
    # with step() and once answering after control_step and finishing after the answer
    whole, _ = _fly_split(12.0, split=False)
    split, added = _fly_split(12.0, split=True)
    # THEN the log rows were written by finish_step (after the answer) ...
    assert sum(added) == len(split.rows) > 300
    # ... and the flight, its log and its events are the same, bit for bit
    assert len(whole.rows) == len(split.rows)
    a, b = whole.arrays(), split.arrays()
    for c in whole.columns:
        assert np.array_equal(a[c], b[c], equal_nan=True), c
    assert whole.events == split.events
    assert any("armed" in e[1] for e in whole.events)


def test_sim_bridge_truth_div_option_paces_truth():
    from sim_bridge.cli import build_parser
    assert build_parser().parse_args([]).truth_div == 1          # every step by default
    assert build_parser().parse_args(["--truth-div", "2"]).truth_div == 2


def test_bench_memory_reports_its_best_window_beside_the_mean():
    from tools.bench import WINDOW_S, bench_memory
    # GIVEN two windows' worth of flight after arming
    rtf, s = bench_memory(2 * WINDOW_S, "ekf")
    # THEN the best window is at least the mean over both (they cover the whole run)
    assert rtf > 0.0
    assert s.bench_best_window_rtf >= rtf * 0.999


def test_link_floor_flies_each_plant_on_the_links_own_frames():
    """The bench's link floor: every step's answer comes back through both codecs with
    that step's time, for the fixed-wing and the quadrotor plant."""
    from tools.bench import bench_link_floor
    for vehicle, seconds, steps in (("plane", 0.5, 50), ("quad", 0.4, 100)):
        rtf, n, answered = bench_link_floor(seconds, vehicle)
        assert (n, answered) == (steps, steps)
        assert rtf > 1.0
