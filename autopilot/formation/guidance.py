"""Formation guidance of one vehicle: desired position by role, relative trajectory,
switching term and velocity command (seed ch. 9 secs. 3.5.2 and 3.6.1, eqs 3.13-3.22).

The seed's equations lost their subscripts and fractions in our copy; they are rebuilt
from the text and from its source (Bayezit & Fidan, "Distributed cohesive motion control
of flight vehicle formations", IEEE Trans. Ind. Electron. 60(12), 2013, and the cohesive
motion laws of Sandeep, Fidan & Yu, "Decentralized cohesive motion control of
multi-agent formations", Mediterranean Conf. Control and Automation, 2006):

Desired positions (vehicle i, followed vehicles j, k, l; f the desired final positions
of ``spec.FormationSpec.final_positions``)

    p_bar_i(t) = p_id(t) - p_i(t)                                      (3.13)
    leader:           p_1d(t) = p_1f                                   (3.14)
    first follower:   p_2d(t) = p_1(t) + p_12,  p_12 = p_2f - p_1f      (3.15)
    second follower:  p_3d(t) = p_1(t) + p_13,  p_13 = p_3f - p_1f      (3.16)
    ordinary:         p_id(t) = the point of S(p_j, d_ij) n S(p_k, d_ik) n S(p_l, d_il)
                      nearer p_i(t)                                    (3.17)

The first follower's offset has length d_12 (the final positions are made consistent),
so eq 3.15 is also the point of S(p_1, d_12) nearest p_1 + p_12. The second follower
keeps *both* its distances: its desired position is the point of the circle
S(p_1, d_13) n S(p_2, d_23) nearest p_1 + p_13 (eq 3.16 when the first follower is in
place).

Reshaping. When a formation starts in another orientation than its final one (the
seed's case turns by about 70 degrees), the straight chord from a follower to
p_1 + p_12 cuts through the sphere around the leader and crosses the other followers'
paths. So the reference point is approached along the constraint instead: the first
and second followers take the point at most ``reshape_step_m`` from their own position
towards p_1 + p_1i (a carrot) and project *that* on their sphere / circle. They keep
their distances while they turn, and eqs 3.15 / 3.16 hold once the carrot reaches the
reference point. Positions of other vehicles are the latest received from the vehicle network
(``peers.PeerTable``), extrapolated to now.

Switching term (3.21), zero inside the tolerance epsilon, one outside 2 epsilon:

    sigma_i = 0                          |p_bar_i| < eps
            = (|p_bar_i| - eps) / eps     eps <= |p_bar_i| <= 2 eps
            = 1                          |p_bar_i| > 2 eps

Velocity law (3.18-3.20, 3.22). The seed's point vehicle is P_i' = V_i (3.18) with the
leader at the constant speed v_bar (3.19); the law (3.20) steers each vehicle along
p_bar_i at speed v_bar, switched by sigma_i, and the applied signal (3.22) is the PI
compensation of the point case (K_P = 1, K_I = 0.05 in the seed, sec. 3.7.2). Rebuilt:

    u_i = K_P p_bar_i + K_I int sigma_i p_bar_i dt      (3.22; integrator frozen while
                                                         the speed limit holds: anti-windup)
    V_i = V_ff,i + sigma_i sat_vmax_i(u_i)               (3.20)

with sat_v(u) = u min(1, v / |u|). The leader has V_ff = 0 and vmax = v_bar, so it flies
at the constant speed v_bar until it is v_bar / K_P from its goal and then settles on it.
A follower whose desired point moves with the leader needs the leader's velocity to
keep up, which a bounded law of speed v_bar alone cannot give when the leader flies at
v_bar: V_ff,i is the mean reported velocity of the vehicles it follows (exact in a rigid
translation), and its speed limit is ``follower_speed_factor`` v_bar. This feed-forward
is our addition to the seed's law, stated here.

The same object serves both vehicle models: the point vehicle applies V_i to its
integrator; the quadrotor integrates it into a virtual target (the seed's "virtual
target tracking", sec. 3.4) with an acceleration limit and tracks that target with its
position, altitude and attitude loops (sec. 3.6.2.3: the desired position is the next
waypoint of the low-level controllers).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .geometry import intersection_near, nearest_on_circle, nearest_on_sphere
from .spec import FormationSpec


def sigma(err_m: float, eps: float) -> float:
    """Eq 3.21."""
    if err_m < eps:
        return 0.0
    if err_m <= 2.0 * eps:
        return (err_m - eps) / eps
    return 1.0


@dataclass(slots=True)
class GuidanceOutput:
    p_des: tuple          # p_id(t), local NED [m]
    v_cmd: tuple          # V_i(t) [m/s]
    a_ff: tuple           # mean reported acceleration of the followed vehicles [m/s^2]
    err_m: float          # |p_bar_i|
    sigma: float
    status: str           # "ok" | geometry status | "waiting" (followed vehicle not heard yet)


class FormationGuidance:
    """Guidance of vehicle ``vid`` of ``spec`` (module docstring).
    ``update(t_s, dt, p_own, peers) -> GuidanceOutput``; ``peers.get(j, t_s)`` gives
    ``(p, v, age)`` of vehicle j or None."""

    def __init__(self, spec: FormationSpec, vid: int):
        self.spec = spec
        self.vid = vid
        v = spec.vehicle(vid)
        self.role = v.role
        self.follows = v.follows
        self.leader_id = spec.leader.id
        finals = spec.final_positions()
        self.p_final = finals[vid]
        self.offset = spec.offsets().get(vid)
        self.d = {j: spec.d(vid, j) for j in v.follows}
        c = spec.control
        self.k_p = c.gain_p
        self.k_i = c.gain_i
        self.v_max = spec.speed_mps if v.role == "leader" else c.follower_speed_factor * spec.speed_mps
        self.eps = spec.epsilon
        self.step_m = c.reshape_step_m
        self.integ = [0.0, 0.0, 0.0]
        self.degenerate_events = 0
        self.last_status = "ok"
        self._p_des = tuple(v.start_ned)
        # the distances to the followed vehicles in the order of ``follows``, and for a
        # second follower which of its two is the leader
        self._d_follows = tuple(self.d[j] for j in v.follows)
        self._lead_k = v.follows.index(self.leader_id) if v.role == "second" else 0

    def desired(self, t_s: float, p_own, peers):
        """(p_id, v_ff, a_ff, status) from eqs 3.14-3.17."""
        if self.role == "leader":
            return self.p_final, _ZERO, _ZERO, "ok"
        get = peers.get
        got = [get(j, t_s) for j in self.follows]
        if None in got:
            return self._p_des, _ZERO, _ZERO, "waiting"
        v_ff, a_ff = _means(got)
        d = self._d_follows
        if self.role == "first":
            p1 = got[0][0]
            p, status = nearest_on_sphere(p1, d[0], self._carrot(p1, p_own))
        elif self.role == "second":
            lead_k = self._lead_k
            p1, p2 = got[lead_k][0], got[1 - lead_k][0]
            p, status = nearest_on_circle(p1, d[lead_k], p2, d[1 - lead_k], self._carrot(p1, p_own))
        else:
            p, status = intersection_near(got[0][0], d[0], got[1][0], d[1], got[2][0], d[2], p_own)
        return p, v_ff, a_ff, status

    def _carrot(self, p1, p_own):
        """p_1 + p_1i (eqs 3.15, 3.16), approached at most ``reshape_step_m`` at a time."""
        o, step = self.offset, self.step_m
        wn, we, wd = p1[0] + o[0] - p_own[0], p1[1] + o[1] - p_own[1], p1[2] + o[2] - p_own[2]
        n = math.sqrt(wn * wn + we * we + wd * wd)
        if n > step:
            wn, we, wd = wn * step / n, we * step / n, wd * step / n
        return (p_own[0] + wn, p_own[1] + we, p_own[2] + wd)

    def update(self, t_s: float, dt: float, p_own, peers) -> GuidanceOutput:
        p_des, v_ff, a_ff, status = self.desired(t_s, p_own, peers)
        if status not in _REGULAR:
            self.degenerate_events += 1
        self.last_status = status
        self._p_des = p_des
        pn, pe, pd = (p_des[0] - p_own[0], p_des[1] - p_own[1], p_des[2] - p_own[2])   # eq 3.13
        e = math.sqrt(pn * pn + pe * pe + pd * pd)
        s = sigma(e, self.eps)                                                   # eq 3.21
        ig = self.integ
        k_p, k_i = self.k_p, self.k_i
        un, ue, ud = k_p * pn + k_i * ig[0], k_p * pe + k_i * ig[1], k_p * pd + k_i * ig[2]   # eq 3.22
        u_abs = math.sqrt(un * un + ue * ue + ud * ud)
        v_max = self.v_max
        if u_abs > v_max:                                                        # sat, no integration
            un, ue, ud = un * v_max / u_abs, ue * v_max / u_abs, ud * v_max / u_abs
        elif dt > 0.0:
            ig[0] += s * pn * dt
            ig[1] += s * pe * dt
            ig[2] += s * pd * dt
        v_cmd = (v_ff[0] + s * un, v_ff[1] + s * ue, v_ff[2] + s * ud)          # eq 3.20
        return GuidanceOutput(tuple(p_des), v_cmd, a_ff, e, s, status)


_ZERO = (0.0, 0.0, 0.0)
_REGULAR = frozenset(("ok", "waiting", "tangent"))     # statuses that are no degenerate event


def _means(got) -> tuple:
    """The mean reported velocity and acceleration of the followed vehicles (``got``:
    ``peers.get``'s answers), each component summed in order from 0.0 (as ``sum`` does)."""
    x = y = z = ax = ay = az = 0.0
    for g in got:
        v, a = g[1], g[3]
        x += v[0]
        y += v[1]
        z += v[2]
        ax += a[0]
        ay += a[1]
        az += a[2]
    n = len(got)
    return (x / n, y / n, z / n), (ax / n, ay / n, az / n)


class VirtualTarget:
    """The quadrotor's reference (the virtual target of the module docstring): its
    velocity follows V_i of eq 3.20 through a first-order lag ``tau_s`` whose
    acceleration is limited to ``a_max`` and whose jerk to ``j_max``, so the reference
    asks nothing of the attitude loop that a quadrotor cannot give (a step of the
    commanded velocity would ask for an instant tilt). ``a_ff``, the followed
    vehicles' reported setpoint acceleration, passes the lag by, so that in a rigid
    translation each follower's reference reproduces its leaders' and the lag does not
    grow down the follower chain. ``step(v_cmd, dt, a_ff) -> (r, v, a)``."""

    def __init__(self, p0, a_max: float = 4.0, j_max: float = 20.0, tau_s: float = 0.2):
        self.r = tuple(float(c) for c in p0)
        self.v = (0.0, 0.0, 0.0)
        self.a = (0.0, 0.0, 0.0)
        self.a_max = a_max
        self.j_max = j_max
        self.tau = tau_s

    def step(self, v_cmd, dt: float, a_ff=(0.0, 0.0, 0.0)):
        if dt <= 0.0:
            return tuple(self.r), tuple(self.v), tuple(self.a)
        (vn, ve, vd), (an, ae, ad), tau = self.v, self.a, self.tau
        xn = a_ff[0] + (v_cmd[0] - vn) / tau
        xe = a_ff[1] + (v_cmd[1] - ve) / tau
        xd = a_ff[2] + (v_cmd[2] - vd) / tau
        n = math.sqrt(xn * xn + xe * xe + xd * xd)
        a_max = self.a_max
        if n > a_max:
            xn, xe, xd = xn * a_max / n, xe * a_max / n, xd * a_max / n
        dn, de, dd = xn - an, xe - ae, xd - ad
        n = math.sqrt(dn * dn + de * de + dd * dd)
        lim = self.j_max * dt
        if n > lim:
            dn, de, dd = dn * lim / n, de * lim / n, dd * lim / n
        a = (an + dn, ae + de, ad + dd)
        v = (vn + a[0] * dt, ve + a[1] * dt, vd + a[2] * dt)
        r = self.r
        r = (r[0] + 0.5 * (vn + v[0]) * dt, r[1] + 0.5 * (ve + v[1]) * dt, r[2] + 0.5 * (vd + v[2]) * dt)
        self.r, self.v, self.a = r, v, a
        return r, v, a
