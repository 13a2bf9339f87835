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

import numpy as np
from numba.extending import register_jitable as jitable

from ..jit import kernel
from .geometry import OK, STATUS, WAITING, on_circle, on_sphere, three_spheres_near
from .peers import NOT_HEARD, ROW_A, ROW_KIND, ROW_P, ROW_T, ROW_V, TARGET, extrapolated
from .spec import FormationSpec


@jitable
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


ROLES = ("leader", "first", "second", "ordinary")
LEADER, FIRST, SECOND = 0, 1, 2          # G_ROLE: the index in ROLES (3: ordinary)
# FormationGuidance.g: its parameters, then its state (what update() leaves)
(G_ROLE, G_KP, G_KI, G_VMAX, G_EPS, G_STEP, G_NF, G_LEAD, G_FINAL, G_OFFSET, G_D,
 G_INTEG, G_PDES, G_VCMD, G_AFF, G_ERR, G_SIGMA, G_STATUS, G_EVENTS, G_PEERS,
 G_N) = (0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 14, 17, 20, 23, 26, 29, 30, 31, 32, 33, 42)


class FormationGuidance:
    """Guidance of vehicle ``vid`` of ``spec`` (module docstring).
    ``update(t_s, dt, p_own, peers) -> GuidanceOutput``, on the rows of ``peers``, a
    ``peers.PeerTable`` of the vehicles this one follows (``only=follows``). Its
    parameters and state are one array, ``g`` (G_*), where the kernel ``guide`` works."""

    def __init__(self, spec: FormationSpec, vid: int, g=None):
        """``g``: where its array lives (zeros of G_N; a formation quadrotor's state
        array, ``autopilot.formation.quad``), else its own."""
        self.spec = spec
        self.vid = vid
        v = spec.vehicle(vid)
        self.role = v.role
        self.follows = v.follows
        offset = spec.offsets().get(vid)
        c = spec.control
        g = self.g = np.zeros(G_N) if g is None else g
        g[G_ROLE] = ROLES.index(v.role)
        g[G_KP], g[G_KI] = c.gain_p, c.gain_i
        g[G_VMAX] = spec.speed_mps if v.role == "leader" else c.follower_speed_factor * spec.speed_mps
        g[G_EPS] = spec.epsilon
        g[G_STEP] = c.reshape_step_m
        g[G_NF] = len(v.follows)
        # for a second follower, which of its two is the leader
        g[G_LEAD] = v.follows.index(spec.leader.id) if v.role == "second" else 0
        g[G_FINAL:G_FINAL + 3] = spec.final_positions()[vid]
        if offset is not None:
            g[G_OFFSET:G_OFFSET + 3] = offset
        g[G_D:G_D + len(v.follows)] = [spec.d(vid, j) for j in v.follows]   # in their order
        g[G_PDES:G_PDES + 3] = v.start_ned
        g[G_STATUS] = -1.0                  # (no update yet)

    @property
    def degenerate_events(self) -> int:
        return int(self.g[G_EVENTS])

    @property
    def last_status(self) -> str:
        s = int(self.g[G_STATUS])
        return STATUS[s] if s >= 0 else "ok"

    def update(self, t_s: float, dt: float, p_own, peers) -> GuidanceOutput:
        guide(self.g, peers.rows, t_s, dt, p_own[0], p_own[1], p_own[2])
        return self.output()

    def output(self) -> GuidanceOutput | None:
        """What the last update left (None before the first)."""
        g = self.g.tolist()
        if g[G_STATUS] < 0.0:
            return None
        return GuidanceOutput(tuple(g[G_PDES:G_PDES + 3]), tuple(g[G_VCMD:G_VCMD + 3]),
                              tuple(g[G_AFF:G_AFF + 3]), g[G_ERR], g[G_SIGMA],
                              STATUS[int(g[G_STATUS])])


@jitable
def _desired(g, rows, t_s, p_own):
    """(p_id, status) from eqs 3.14-3.17; the means of the followed vehicles' reported
    velocity (v_ff) and acceleration written in G_VCMD and G_AFF, their positions
    extrapolated to ``t_s`` in G_PEERS."""
    role = g[G_ROLE]
    if role == LEADER:
        g[G_VCMD:G_VCMD + 3] = 0.0
        g[G_AFF:G_AFF + 3] = 0.0
        return (g[G_FINAL], g[G_FINAL + 1], g[G_FINAL + 2]), OK
    nf = int(g[G_NF])
    for k in range(nf):
        if rows[k, ROW_KIND] == NOT_HEARD:
            g[G_VCMD:G_VCMD + 3] = 0.0
            g[G_AFF:G_AFF + 3] = 0.0
            return (g[G_PDES], g[G_PDES + 1], g[G_PDES + 2]), WAITING
    # their positions now, and their mean velocity and acceleration, each component
    # summed in order from 0.0 (as ``sum`` does)
    x = y = z = ax = ay = az = 0.0
    for k in range(nf):
        r = rows[k]
        a = (r[ROW_A], r[ROW_A + 1], r[ROW_A + 2])
        p, v = extrapolated(t_s - r[ROW_T], (r[ROW_P], r[ROW_P + 1], r[ROW_P + 2]),
                            (r[ROW_V], r[ROW_V + 1], r[ROW_V + 2]), a, r[ROW_KIND] == TARGET)
        j = G_PEERS + 3 * k
        g[j], g[j + 1], g[j + 2] = p
        x += v[0]
        y += v[1]
        z += v[2]
        ax += a[0]
        ay += a[1]
        az += a[2]
    g[G_VCMD], g[G_VCMD + 1], g[G_VCMD + 2] = x / nf, y / nf, z / nf
    g[G_AFF], g[G_AFF + 1], g[G_AFF + 2] = ax / nf, ay / nf, az / nf
    p0 = (g[G_PEERS], g[G_PEERS + 1], g[G_PEERS + 2])
    p1 = (g[G_PEERS + 3], g[G_PEERS + 4], g[G_PEERS + 5])
    d = G_D
    if role == FIRST:
        return on_sphere(p0, g[d], _carrot(g, p0, p_own))
    if role == SECOND:
        if g[G_LEAD] == 0.0:                      # the leader first in follows
            return on_circle(p0, g[d], p1, g[d + 1], _carrot(g, p0, p_own))
        return on_circle(p1, g[d + 1], p0, g[d], _carrot(g, p1, p_own))
    p2 = (g[G_PEERS + 6], g[G_PEERS + 7], g[G_PEERS + 8])         # ordinary
    return three_spheres_near(p0, g[d], p1, g[d + 1], p2, g[d + 2], p_own)


@jitable
def _carrot(g, p1, p_own):
    """p_1 + p_1i (eqs 3.15, 3.16), approached at most ``reshape_step_m`` at a time."""
    o, step = G_OFFSET, g[G_STEP]
    wn, we, wd = p1[0] + g[o] - p_own[0], p1[1] + g[o + 1] - p_own[1], p1[2] + g[o + 2] - p_own[2]
    n = math.sqrt(wn * wn + we * we + wd * wd)
    if n > step:
        wn, we, wd = wn * step / n, we * step / n, wd * step / n
    return (p_own[0] + wn, p_own[1] + we, p_own[2] + wd)


@kernel
def guide(g, rows, t_s, dt, pn_own, pe_own, pd_own):
    """FormationGuidance.update on its array ``g`` (G_*) from the rows of its
    ``PeerTable`` and its own position: p_id, V_i (eq 3.20), the followed vehicles'
    mean acceleration, |p_bar_i|, sigma_i and the status written in ``g``; a status
    that is no regular one (OK, TANGENT, WAITING) counted in G_EVENTS."""
    p_own = (pn_own, pe_own, pd_own)
    p_des, status = _desired(g, rows, t_s, p_own)
    g[G_STATUS] = status
    if status > WAITING:
        g[G_EVENTS] += 1.0
    g[G_PDES], g[G_PDES + 1], g[G_PDES + 2] = p_des
    pn, pe, pd = (p_des[0] - p_own[0], p_des[1] - p_own[1], p_des[2] - p_own[2])   # eq 3.13
    e = math.sqrt(pn * pn + pe * pe + pd * pd)
    s = sigma(e, g[G_EPS])                                                   # eq 3.21
    g[G_ERR], g[G_SIGMA] = e, s
    k_p, k_i, ig = g[G_KP], g[G_KI], G_INTEG
    un, ue, ud = k_p * pn + k_i * g[ig], k_p * pe + k_i * g[ig + 1], k_p * pd + k_i * g[ig + 2]   # eq 3.22
    u_abs = math.sqrt(un * un + ue * ue + ud * ud)
    v_max = g[G_VMAX]
    if u_abs > v_max:                                                        # sat, no integration
        un, ue, ud = un * v_max / u_abs, ue * v_max / u_abs, ud * v_max / u_abs
    elif dt > 0.0:
        g[ig] += s * pn * dt
        g[ig + 1] += s * pe * dt
        g[ig + 2] += s * pd * dt
    v = G_VCMD                                   # (v_ff there: _desired)
    g[v], g[v + 1], g[v + 2] = g[v] + s * un, g[v + 1] + s * ue, g[v + 2] + s * ud   # eq 3.20


# VirtualTarget.x: its state r, v, a (formation frame), with the loops' reference (r less
# home's place in the formation frame, v, a: home NED) around v and a, then its limits,
# home's place and the formation's start time
(VT_R, VT_REF, VT_V, VT_A, VT_AMAX, VT_JMAX, VT_TAU, VT_HOME, VT_START, VT_N) = (
    0, 3, 6, 9, 12, 13, 14, 15, 18, 19)


class VirtualTarget:
    """The quadrotor's reference (the virtual target of the module docstring): its
    velocity follows V_i of eq 3.20 through a first-order lag ``tau_s`` whose
    acceleration is limited to ``a_max`` and whose jerk to ``j_max``, so the reference
    asks nothing of the attitude loop that a quadrotor cannot give (a step of the
    commanded velocity would ask for an instant tilt). ``a_ff``, the followed
    vehicles' reported setpoint acceleration, passes the lag by, so that in a rigid
    translation each follower's reference reproduces its leaders' and the lag does not
    grow down the follower chain. Its state is the array ``x`` (VT_*), stepped from the
    formation's start time ``start_s`` on (``formation_step``), held at ``p0`` before;
    ``ref`` is the loops' reference in the frame of ``home`` (home's place in the
    formation frame): p, v, a."""

    def __init__(self, p0, a_max: float = 4.0, j_max: float = 20.0, tau_s: float = 0.2,
                 home=(0.0, 0.0, 0.0), start_s: float = 0.0, x=None):
        # (``x``: where its array lives, VT_N long, a formation quadrotor's; started afresh)
        x = self.x = np.zeros(VT_N) if x is None else x
        x[:] = 0.0
        x[VT_R:VT_R + 3] = p0
        x[VT_AMAX], x[VT_JMAX], x[VT_TAU], x[VT_START] = a_max, j_max, tau_s, start_s
        x[VT_HOME:VT_HOME + 3] = home
        x[VT_REF:VT_REF + 3] = x[VT_R:VT_R + 3] - x[VT_HOME:VT_HOME + 3]
        self.ref = x[VT_REF:VT_A + 3]            # (a view)
        self.a_max = a_max

    @property
    def r(self) -> tuple:
        return tuple(self.x[VT_R:VT_R + 3].tolist())

    @property
    def v(self) -> tuple:
        return tuple(self.x[VT_V:VT_V + 3].tolist())

    @property
    def a(self) -> tuple:
        return tuple(self.x[VT_A:VT_A + 3].tolist())


@jitable
def target_step(x, v_cmd, dt, a_ff):
    """The virtual target's step on the command ``v_cmd`` (VirtualTarget), and the
    loops' reference from it."""
    if dt <= 0.0:
        return
    vn, ve, vd, an, ae, ad, tau = x[VT_V], x[VT_V + 1], x[VT_V + 2], x[VT_A], x[VT_A + 1], x[VT_A + 2], x[VT_TAU]
    xn = a_ff[0] + (v_cmd[0] - vn) / tau
    xe = a_ff[1] + (v_cmd[1] - ve) / tau
    xd = a_ff[2] + (v_cmd[2] - vd) / tau
    n = math.sqrt(xn * xn + xe * xe + xd * xd)
    a_max = x[VT_AMAX]
    if n > a_max:
        xn, xe, xd = xn * a_max / n, xe * a_max / n, xd * a_max / n
    dn, de, dd = xn - an, xe - ae, xd - ad
    n = math.sqrt(dn * dn + de * de + dd * dd)
    lim = x[VT_JMAX] * dt
    if n > lim:
        dn, de, dd = dn * lim / n, de * lim / n, dd * lim / n
    a0, a1, a2 = an + dn, ae + de, ad + dd
    v0, v1, v2 = vn + a0 * dt, ve + a1 * dt, vd + a2 * dt
    r, h = VT_R, VT_HOME
    x[r] = x[r] + 0.5 * (vn + v0) * dt
    x[r + 1] = x[r + 1] + 0.5 * (ve + v1) * dt
    x[r + 2] = x[r + 2] + 0.5 * (vd + v2) * dt
    x[VT_V], x[VT_V + 1], x[VT_V + 2] = v0, v1, v2
    x[VT_A], x[VT_A + 1], x[VT_A + 2] = a0, a1, a2
    x[VT_REF], x[VT_REF + 1], x[VT_REF + 2] = x[r] - x[h], x[r + 1] - x[h + 1], x[r + 2] - x[h + 2]


@jitable
def formation_step(g, rows, x, t_s, dt):
    """A formation quadrotor's guidance step (FormationQuad._fly) from the formation's
    start on: ``guide`` from the virtual target's position (``x``, VirtualTarget's),
    then the virtual target's step on V_i and the followed vehicles' acceleration, which
    leaves the loops' reference in ``x``."""
    if t_s < x[VT_START]:
        return
    guide(g, rows, t_s, dt, x[VT_R], x[VT_R + 1], x[VT_R + 2])
    target_step(x, (g[G_VCMD], g[G_VCMD + 1], g[G_VCMD + 2]), dt,
                (g[G_AFF], g[G_AFF + 1], g[G_AFF + 2]))
