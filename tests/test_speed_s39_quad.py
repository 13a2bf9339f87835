"""Stop 39: the formation guidance, the virtual target and the loops in one compiled call
(``formation_track``; the point vehicles' ``guide``) on the guidance's array and the
peer table's rows, against the law as Python computed it before (written out here), bit
for bit."""
import math

import numpy as np
import pytest

from autopilot.control.multirotor import Y_N, Y_Q, MultirotorController, track_mix
from autopilot.formation import load_formation
from autopilot.formation.geometry import intersection_near, nearest_on_circle, nearest_on_sphere
from autopilot.formation.guidance import FormationGuidance, VirtualTarget, sigma
from autopilot.formation.peers import ROW_N, PeerTable, PositionPublisher
from autopilot.formation.quad import FS_ROWS, FS_VT, formation_track
from autopilot.geo import LocalFrame
from autopilot.params import ParamStore
from autopilot.vehicle_quad import LOOPS_N, LOOPS_NAV, LOOPS_TRAJ, X_Y, quad_param_declarations

SEED = "missions/formation_seed_quad.toml"
_REGULAR = ("ok", "waiting", "tangent")


class OldGuidance:
    """FormationGuidance.update and VirtualTarget.step as Python computed them (stop 38)."""

    def __init__(self, spec, vid, a_max=4.0, j_max=20.0, tau=0.2):
        v = spec.vehicle(vid)
        self.role, self.follows = v.role, v.follows
        self.p_final = spec.final_positions()[vid]
        self.offset = spec.offsets().get(vid)
        self.d = tuple(spec.d(vid, j) for j in v.follows)
        c = spec.control
        self.k_p, self.k_i, self.eps, self.step_m = c.gain_p, c.gain_i, spec.epsilon, c.reshape_step_m
        self.v_max = spec.speed_mps if v.role == "leader" else c.follower_speed_factor * spec.speed_mps
        self.lead_k = v.follows.index(spec.leader.id) if v.role == "second" else 0
        self.integ = [0.0, 0.0, 0.0]
        self.p_des = tuple(v.start_ned)
        self.events = 0
        self.r, self.v, self.a = tuple(float(x) for x in v.start_ned), (0.0,) * 3, (0.0,) * 3
        self.a_max, self.j_max, self.tau = a_max, j_max, tau

    def _carrot(self, p1, p_own):
        o, step = self.offset, self.step_m
        wn, we, wd = p1[0] + o[0] - p_own[0], p1[1] + o[1] - p_own[1], p1[2] + o[2] - p_own[2]
        n = math.sqrt(wn * wn + we * we + wd * wd)
        if n > step:
            wn, we, wd = wn * step / n, we * step / n, wd * step / n
        return (p_own[0] + wn, p_own[1] + we, p_own[2] + wd)

    def desired(self, t_s, p_own, peers):
        z = (0.0, 0.0, 0.0)
        if self.role == "leader":
            return self.p_final, z, z, "ok"
        got = [peers.get(j, t_s) for j in self.follows]
        if None in got:
            return self.p_des, z, z, "waiting"
        n = len(got)
        v_ff = tuple(sum(g[1][k] for g in got) / n for k in range(3))
        a_ff = tuple(sum(g[3][k] for g in got) / n for k in range(3))
        d = self.d
        if self.role == "first":
            p, status = nearest_on_sphere(got[0][0], d[0], self._carrot(got[0][0], p_own))
        elif self.role == "second":
            k = self.lead_k
            p1, p2 = got[k][0], got[1 - k][0]
            p, status = nearest_on_circle(p1, d[k], p2, d[1 - k], self._carrot(p1, p_own))
        else:
            p, status = intersection_near(got[0][0], d[0], got[1][0], d[1], got[2][0], d[2], p_own)
        return p, v_ff, a_ff, status

    def update(self, t_s, dt, p_own, peers):
        p_des, v_ff, a_ff, status = self.desired(t_s, p_own, peers)
        if status not in _REGULAR:
            self.events += 1
        self.p_des = p_des
        pn, pe, pd = (p_des[0] - p_own[0], p_des[1] - p_own[1], p_des[2] - p_own[2])
        e = math.sqrt(pn * pn + pe * pe + pd * pd)
        s = sigma(e, self.eps)
        ig, k_p, k_i = self.integ, self.k_p, self.k_i
        un, ue, ud = k_p * pn + k_i * ig[0], k_p * pe + k_i * ig[1], k_p * pd + k_i * ig[2]
        u_abs = math.sqrt(un * un + ue * ue + ud * ud)
        if u_abs > self.v_max:
            un, ue, ud = un * self.v_max / u_abs, ue * self.v_max / u_abs, ud * self.v_max / u_abs
        elif dt > 0.0:
            ig[0] += s * pn * dt
            ig[1] += s * pe * dt
            ig[2] += s * pd * dt
        v_cmd = (v_ff[0] + s * un, v_ff[1] + s * ue, v_ff[2] + s * ud)
        return tuple(p_des), v_cmd, a_ff, e, s, status

    def target_step(self, v_cmd, dt, a_ff):
        (vn, ve, vd), (an, ae, ad), tau = self.v, self.a, self.tau
        xn = a_ff[0] + (v_cmd[0] - vn) / tau
        xe = a_ff[1] + (v_cmd[1] - ve) / tau
        xd = a_ff[2] + (v_cmd[2] - vd) / tau
        n = math.sqrt(xn * xn + xe * xe + xd * xd)
        if n > self.a_max:
            xn, xe, xd = xn * self.a_max / n, xe * self.a_max / n, xd * self.a_max / n
        dn, de, dd = xn - an, xe - ae, xd - ad
        n = math.sqrt(dn * dn + de * de + dd * dd)
        lim = self.j_max * dt
        if n > lim:
            dn, de, dd = dn * lim / n, de * lim / n, dd * lim / n
        a = (an + dn, ae + de, ad + dd)
        v = (vn + a[0] * dt, ve + a[1] * dt, vd + a[2] * dt)
        r = self.r
        self.r = (r[0] + 0.5 * (vn + v[0]) * dt, r[1] + 0.5 * (ve + v[1]) * dt,
                  r[2] + 0.5 * (vd + v[2]) * dt)
        self.v, self.a = v, a


def _fill(table, pub, origin, vid, rng, t_ms, centre, spread, target):
    """One message of vehicle ``vid`` near ``centre`` (``spread`` 0: exactly there, at
    rest)."""
    p = tuple(c + spread * x for c, x in zip(centre, rng.normal(size=3).tolist()))
    lat, lon, alt = origin.to_geodetic_fast(p)
    v = tuple((spread * rng.normal(size=3)).tolist())
    if target:
        data = pub[vid].encode_target(t_ms * 1000, lat, lon, alt, v,
                                      tuple((spread * rng.normal(size=3)).tolist()))
    else:
        data = pub[vid].encode(t_ms * 1000, lat, lon, alt, v)
    table.receive(data)


@pytest.mark.parametrize("use_targets", [True, False])
def test_formation_track_is_the_python_law(use_targets):
    """Every role of the seed formation, its followed vehicles heard in random places
    (nearby, coincident, collinear: the degenerate statuses), by setpoints or by
    positions, partly not heard yet: the kernel's p_des, V_i, a_ff, |p_bar|, sigma,
    status, degenerate events, integrator and the virtual target's step (and the loops'
    reference from it) are the Python law's, bit for bit, nothing stepped before the
    start time; the loops' output and state are track_mix's on that reference."""
    spec = load_formation(SEED)
    origin = LocalFrame.from_degrees(*spec.origin)
    pub = {v.id: PositionPublisher(v.id, spec.ground_alt_m) for v in spec.vehicles}
    rng = np.random.default_rng(39)
    statuses = set()
    events = 0
    for v in spec.vehicles:
        # (the three arrays in one, as FormationQuad.fs)
        fs = np.zeros(FS_ROWS + len(v.follows) * ROW_N)
        new = FormationGuidance(spec, v.id, g=fs[:FS_VT])
        old = OldGuidance(spec, v.id)
        table = PeerTable(v.id, origin, use_targets=use_targets, only=v.follows,
                          rows=fs[FS_ROWS:].reshape(len(v.follows), ROW_N))
        home = tuple(rng.normal(size=3).tolist())
        vt = VirtualTarget(v.start_ned, home=home, start_s=0.05, x=fs[FS_VT:FS_ROWS])
        # (the controller's array and the navigation output in one, as QuadVehicle._loops)
        loops = np.zeros(LOOPS_N)
        ctrl = MultirotorController(ParamStore(quad_param_declarations()), 0.004,
                                    loops[:LOOPS_TRAJ])
        y = loops[LOOPS_NAV + X_Y:]
        t_ms = 0
        for k in range(400):
            t_ms += 4
            if k >= 20 and v.follows and k % 3 == 0:      # (the first 20 steps: waiting)
                case = k % 5
                for i, j in enumerate(v.follows):
                    if case == 0:
                        centre, spread = (0.0, 0.0, -10.0), 0.0           # all coincident
                    elif case == 1:
                        centre, spread = (float(i), 0.0, -10.0), 0.0      # collinear
                    else:
                        centre, spread = spec.vehicle(j).start_ned, 1.0
                    _fill(table, pub, origin, j, rng, t_ms, centre, spread, use_targets)
            t_s = t_ms * 1e-3 + 0.002
            dt = 0.0 if k == 30 else 0.004
            y[:] = rng.normal(scale=0.1, size=Y_N)
            y[Y_Q] = 1.0
            pn, pe, pd = (np.array(old.r) - home + rng.normal(scale=0.2, size=3)).tolist()
            cx = ctrl.x.copy()
            hold = k % 7 == 0
            out = formation_track(fs, loops, pn, pe, pd, t_s, dt, hold)
            assert out == track_mix(cx, vt.ref.copy(), y, pn, pe, pd, 0.0, 0.0, dt, False, hold)
            assert cx.tolist() == ctrl.x.tolist()
            if t_s < 0.05:
                assert new.output() is None and vt.r == tuple(float(c) for c in v.start_ned)
                continue
            p_des, v_cmd, a_ff, e, s, status = old.update(t_s, dt, old.r, table)
            old.target_step(v_cmd, dt, a_ff) if dt > 0.0 else None
            g = new.output()
            assert (g.p_des, g.v_cmd, g.a_ff, g.err_m, g.sigma, g.status) == \
                (p_des, v_cmd, a_ff, e, s, status)
            assert new.degenerate_events == old.events and new.last_status == status
            assert (vt.r, vt.v, vt.a) == (old.r, old.v, old.a)
            ref = vt.ref.tolist()
            assert ref == [old.r[i] - home[i] for i in range(3)] + list(old.v) + list(old.a)
            statuses.add(status)
        events += new.degenerate_events
    assert {"ok", "waiting", "collinear", "empty"} <= statuses and events > 0


def test_point_guidance_update_is_the_python_law():
    """``FormationGuidance.update`` (the point vehicles' call) on a vehicle's own
    position, positions heard only: the Python law's output."""
    spec = load_formation("missions/formation_seed_point.toml")
    origin = LocalFrame.from_degrees(*spec.origin)
    pub = {v.id: PositionPublisher(v.id, spec.ground_alt_m) for v in spec.vehicles}
    rng = np.random.default_rng(7)
    for v in spec.vehicles:
        new, old = FormationGuidance(spec, v.id), OldGuidance(spec, v.id)
        table = PeerTable(v.id, origin, only=v.follows)
        for k in range(100):
            for j in v.follows:
                _fill(table, pub, origin, j, rng, 10 * k, spec.vehicle(j).start_ned, 0.5, False)
            p_own = tuple((np.array(v.start_ned) + rng.normal(size=3)).tolist())
            g = new.update(0.01 * k + 0.005, 0.01, p_own, table)
            assert (g.p_des, g.v_cmd, g.a_ff, g.err_m, g.sigma, g.status) == \
                old.update(0.01 * k + 0.005, 0.01, p_own, table)


def test_peer_rows_hold_what_get_extrapolates():
    """The rows the kernel reads: one per followed vehicle in the order of ``only``, a
    setpoint's row kept when positions follow it, other vehicles' messages dropped."""
    spec = load_formation(SEED)
    origin = LocalFrame.from_degrees(*spec.origin)
    pub = {j: PositionPublisher(j, spec.ground_alt_m) for j in (1, 2, 3)}
    table = PeerTable(4, origin, use_targets=True, only=(3, 1))
    assert table.rows.shape == (2, 11) and not table.rows.any()
    lat, lon, alt = origin.to_geodetic_fast((1.0, 2.0, -3.0))
    table.receive(pub[1].encode(1_000_000, lat, lon, alt, (0.5, 0.0, 0.0)))
    table.receive(pub[2].encode(1_000_000, lat, lon, alt, (0.5, 0.0, 0.0)))
    assert not table.rows[0].any() and table.rows[1, 0] == 1.0 and 2 not in table.latest
    table.receive(pub[3].encode_target(2_000_000, lat, lon, alt, (0.5, 0.25, 0.0), (0.0, 0.0, 1.0)))
    table.receive(pub[3].encode(3_000_000, lat, lon, alt, (9.0, 9.0, 9.0)))
    row = table.rows[0].tolist()
    assert row[0] == 2.0 and row[1] == 2.0 and row[5:] == [0.5, 0.25, 0.0, 0.0, 0.0, 1.0]
    p, v, age, a = table.get(3, 2.5)
    assert age == 0.5 and v == (0.5, 0.25, 0.5) and p[2] == pytest.approx(row[4] + 0.125)


def test_restart_output_is_the_python_restart():
    """The output predictor's restart after a filter update (DecimatedNav.update) in one
    call: x and y as the Python code before wrote them (the output's p, v, q, the
    nominal state's biases and g, the sums at zero; the rate less the gyro bias, the
    angles), and the returned p and angles."""
    from autopilot.geo.rotations import euler_321
    from autopilot.nav.strapdown import X_BA, X_BG, X_SIZE
    from autopilot.vehicle_quad import X_N, X_Y, restart_output
    rng = np.random.default_rng(5)
    for _ in range(50):
        p, v = rng.normal(size=3) * 50.0, rng.normal(size=3)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        nom = rng.normal(size=X_SIZE) * 0.01
        g, w = 9.8 + rng.normal() * 0.01, rng.normal(size=3).tolist()
        x = rng.normal(size=X_N)
        y = x[X_Y:]
        pl, vl, ql = p.tolist(), v.tolist(), q.tolist()
        ba, bg = nom[X_BA:X_BA + 3].tolist(), nom[X_BG:X_BG + 3].tolist()
        euler = euler_321(*ql)
        assert restart_output(x, p, v, q, nom, g, *w) == (tuple(pl), euler)
        assert x[:X_Y].tolist() == pl + vl + ql + ba + bg + [g] + [0.0] * 6
        assert y.tolist() == vl + ql + [w[i] - bg[i] for i in range(3)] + list(euler)


def test_position_of_a_vehicle_heard_by_setpoint_is_not_decoded():
    """With setpoints heard from a vehicle, its lone GLOBAL_POSITION_INT datagrams are
    dropped on their header (get() would not read them); a datagram that holds more
    than that frame, or one from a vehicle not heard by setpoint, is decoded."""
    origin = LocalFrame.from_degrees(-35.36, 149.16, 600.0)
    pub = PositionPublisher(3, ground_alt_m=580.0)
    lat, lon, alt = origin.to_geodetic_fast((1.0, 2.0, -3.0))
    table = PeerTable(1, origin, use_targets=True)
    decoded = []
    decode = table.codec.decode
    table.codec.decode = lambda data, ids: decoded.append(data) or decode(data, ids)
    pos = pub.encode(1_000_000, lat, lon, alt, (0.5, 0.0, 0.0))
    table.receive(pos)
    assert len(decoded) == 1 and 3 in table.latest
    table.receive(pub.encode_target(1_000_000, lat, lon, alt, (0.5, 0.0, 0.0), (0.0, 0.0, 0.0)))
    assert len(decoded) == 2 and 3 in table.targets
    table.receive(pub.encode(1_100_000, lat, lon, alt, (0.5, 0.0, 0.0)))
    assert len(decoded) == 2
    two = pub.encode(1_200_000, lat, lon, alt, (0.5, 0.0, 0.0)) + \
        pub.encode_target(1_200_000, lat, lon, alt, (0.5, 0.0, 0.0), (0.0, 0.0, 0.0))
    table.receive(two)
    assert len(decoded) == 3 and table.targets[3][0] == 1.2
    p, v, age, a = table.get(3, 1.2)
    assert age == 0.0 and v == (0.5, 0.0, 0.0)
