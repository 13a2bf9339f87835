"""A quadrotor that flies in a formation: the project's quadrotor autopilot
(``autopilot.vehicle_quad.QuadVehicle``: navigation, PID reference angles, PID altitude,
PDD attitude, mixer) with the formation guidance feeding its position / velocity /
acceleration references in GUIDED mode (seed sec. 3.6.2.3: the desired position of
eqs 3.14-3.17 is the next waypoint of the low-level controllers).

Sequence of one vehicle:

1. Held in hover at its start position by the simulator (a hand launch) while its
   navigation aligns; it publishes nothing yet.
2. Navigation healthy for ARM_SETTLE_S: it arms in GUIDED, airborne, and holds its start
   position (the simulator releases it when the HIL answer says armed). From then on it
   publishes its position on the vehicle network at ``network.rate_hz``.
3. It also publishes its setpoint (the virtual target) as POSITION_TARGET_GLOBAL_INT,
   and its guidance keeps its distances to the *setpoints* of the vehicles it follows
   (the seed's virtual target tracking, sec. 3.4): the formation is shaped on smooth
   references, and each vehicle's tracking and navigation errors stay its own instead
   of adding up down the follower chain (what following the estimated positions costs:
   docs/status.md, "Formation flight").
4. At the formation's common start time ``start_s`` (known to every vehicle from the
   formation file, as a synchronised launch time) its guidance starts: the virtual
   target integrates V_i of eq 3.20 and the quadrotor tracks it.

The vehicle reads the other vehicles only through its ``PeerTable`` (bytes received
from the network) and writes only bytes to its ``outbox``: no shared memory.

Frames: the formation's local NED frame (origin from the file) for guidance; the
vehicle's home frame (its arming position) for its loops; they differ by a translation
``home_in_form`` fixed at arming (tangent frames metres apart).

Hook wanted in ``QuadVehicle`` (not ours to change): a setpoint-source interface for
GUIDED (position, velocity, acceleration, yaw per step); until then ``_fly`` is
overridden here and hands the reference to the same controller's loops (``track_mix``,
in one compiled call with the guidance: ``formation_track``).
"""
from __future__ import annotations

import numpy as np

from ..control.multirotor import Y_Q, track_mix
from ..geo import LocalFrame
from ..guidance.multirotor import CopterTarget, new_target
from ..jit import kernel, preload
from ..modes.copter import CopterMode
from ..vehicle_quad import LOOPS_NAV, LOOPS_TRAJ, X_Y, QuadVehicle
from .guidance import G_N, G_NF, VT_A, VT_N, VT_REF, FormationGuidance, VirtualTarget, formation_step
from .peers import ROW_N, PeerTable, PositionPublisher
from .spec import FormationSpec


_GUIDED = CopterMode.GUIDED
# FormationQuad.fs: the guidance's array (G_*), the virtual target's (VT_*), then the
# peer table's rows (ROW_N each, one per followed vehicle): one argument of the kernel
FS_VT, FS_ROWS = G_N, G_N + VT_N


class FormationQuad(QuadVehicle):
    def __init__(self, params, spec: FormationSpec, vid: int, nav_source: str = "ekf",
                 log=None, dt_s: float = 0.008, start_s: float = 8.0, a_max: float = 4.0):
        super().__init__(params, None, nav_source, autostart=False, log=log, dt_s=dt_s)
        self.spec = spec
        self.vid = vid
        self.start_s = start_s
        self.origin = LocalFrame.from_degrees(*spec.origin)
        self.start_ned = spec.vehicle(vid).start_ned
        follows = spec.vehicle(vid).follows
        fs = self.fs = np.zeros(FS_ROWS + len(follows) * ROW_N)
        self.guidance = FormationGuidance(spec, vid, g=fs[:FS_VT])
        self.peers = PeerTable(vid, self.origin, use_targets=True, only=follows,
                               rows=fs[FS_ROWS:].reshape(len(follows), ROW_N))
        self.publisher = PositionPublisher(vid, spec.ground_alt_m)
        self.period_us = int(round(1e6 / spec.network.rate_hz))
        self._next_pub_us = 0
        self.outbox: list[bytes] = []
        self.vt = VirtualTarget(self.start_ned, a_max, start_s=start_s, x=fs[FS_VT:FS_ROWS])
        self.home_in_form = (0.0, 0.0, 0.0)
        self._healthy_since: int | None = None
        # (autopilot.jit.preload: the loops' kernel loaded now, not at the take-off; on
        # copies of the arrays it writes, a unit attitude in the navigation output)
        loops = self._loops.copy()
        loops[LOOPS_NAV + X_Y + Y_Q] = 1.0
        preload(formation_track, fs.copy(), loops, 0.0, 0.0, 0.0, start_s, dt_s, False)

    # -------------------------------------------------------------- arming ---
    def _try_arm(self, t_us: int, truth) -> None:
        nav = self.nav_state
        if nav is None or not (nav.aligned and nav.healthy and self.gps_fix_type >= 3):
            self._healthy_since = None
            return
        if self._healthy_since is None:
            self._healthy_since = t_us
        if (t_us - self._healthy_since) * 1e-6 < self.params["ARM_SETTLE_S"]:
            return
        self.mode = CopterMode.GUIDED
        if self.arm(t_us, truth) is not None:
            return
        # armed in the air: loops live at once
        self.on_ground = False
        self.flying = True
        hf = self.home_frame
        self.home_in_form = tuple(self.origin.to_ned_fast(hf.lat0_rad, hf.lon0_rad, hf.alt0_m).tolist())
        self.vt = VirtualTarget(self.start_ned, self.vt.a_max, home=self.home_in_form,
                                start_s=self.start_s, x=self.vt.x)
        self.log.event(t_us * 1e-6, f"formation vehicle {self.vid} armed (GUIDED, airborne)")

    @property
    def last_guidance(self):
        """The guidance's output at the last GUIDED step after the start (None before)."""
        return self.guidance.output()

    @property
    def p_form(self) -> tuple:
        """Own position estimate in the formation frame."""
        p, h = self.p_home, self.home_in_form
        return (p[0] + h[0], p[1] + h[1], p[2] + h[2])

    # ---------------------------------------------------------------- loop ---
    def step(self, frame, truth=None):
        out = QuadVehicle.step(self, frame, truth)    # (not super(): an object every step)
        t_us = frame.t_us
        if not self.armed:
            self._try_arm(t_us, truth)
        elif t_us >= self._next_pub_us:
            self._next_pub_us = t_us + self.period_us
            hf = self.home_frame
            lat, lon, alt = hf.to_geodetic_fast(self.p_home)
            self.outbox.append(self.publisher.encode(t_us, lat, lon, alt, self.v_ned, self.euler[2]))
            r, h = self.vt.r, self.home_in_form
            lat, lon, alt = hf.to_geodetic_fast((r[0] - h[0], r[1] - h[1], r[2] - h[2]))
            self.outbox.append(self.publisher.encode_target(t_us, lat, lon, alt, self.vt.v, self.vt.a))
        return out

    def _fly(self, dt: float, t_us: int) -> tuple:
        if self.mode is not _GUIDED:
            return super()._fly(dt, t_us)
        # (the target built from vt.ref when asked: _make_target)
        self._target, self._target_of = None, (0, False, True)
        # the controller's record kept as its track() keeps it
        c = self.ctrl
        pn, pe, pd = self.p_home
        c.roll_d, c.pitch_d, c.u, c.motors = formation_track(
            self.fs, self._loops, pn, pe, pd, t_us * 1e-6, dt, not self.flying)
        c.yaw_d = 0.0
        return c.motors

    def _make_target(self, seq: int, hold: bool, formation: bool = False) -> CopterTarget:
        """The step's target: in GUIDED (``formation``) the formation's reference, what
        ``_fly`` handed to the loops; in the other modes (a failsafe's LAND, a ground
        station's RTL) the navigator's, as any quadrotor's."""
        if not formation:
            return super()._make_target(seq, hold)
        ref = self.vt.ref
        tp, tv, ta = (tuple(ref[k:k + 3].tolist()) for k in (0, 3, 6))
        ne = (tp[0], tp[1])
        return new_target(("move", 0, self.vid, tp, tv, ta, 0.0, False, ne, ne))


@kernel
def formation_track(fs, loops, pn, pe, pd, t_s, dt, hold):
    """The formation's guidance step (:func:`~.guidance.formation_step` on the guidance's
    array ``g``, the peer table's ``rows`` and the virtual target's ``x``, all three in
    ``fs``: FormationQuad.fs) and the loops on the reference it leaves there
    (:func:`~..control.multirotor.track_mix` on the controller's array ``cx`` and the
    navigation output ``y``, both parts of ``loops``: QuadVehicle._loops, heading north,
    the altitude integrator held with ``hold``), in one call. Returns track_mix's."""
    cx, y = loops[:LOOPS_TRAJ], loops[LOOPS_NAV + X_Y:]
    g, x = fs[:FS_VT], fs[FS_VT:FS_ROWS]
    formation_step(g, fs[FS_ROWS:].reshape((int(g[G_NF]), ROW_N)), x, t_s, dt)
    return track_mix(cx, x[VT_REF:VT_A + 3], y, pn, pe, pd, 0.0, 0.0, dt, False, hold)
