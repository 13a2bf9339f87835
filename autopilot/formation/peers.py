"""The vehicle-to-vehicle MAVLink link of a formation (sans-IO: bytes in, bytes out).

Each vehicle publishes its own navigation solution as GLOBAL_POSITION_INT (the standard
message ArduPilot streams and MAVProxy / QGroundControl show for every vehicle on a
link) and keeps, from the messages it receives, the latest position and velocity of
every other system id: its ``PeerTable``. Nothing else passes between vehicles.

A quadrotor also publishes its current setpoint (its virtual target: position, velocity,
acceleration) as POSITION_TARGET_GLOBAL_INT, which ArduPilot streams in GUIDED; its
followers then keep their distances to the leaders' targets, each vehicle tracking its
own (``PeerTable(use_targets=True)``; module ``autopilot.formation.quad``).

Time: all vehicles of one SITL boot at simulation time 0, so ``time_boot_ms`` is a
common clock; a receiver extrapolates a peer's position to its own time with the
reported velocity, ``p(t) = p_msg + v_msg (t - t_msg)`` (the age is capped at
``MAX_EXTRAPOLATION_S``). Units at this boundary: lat/lon in 1e-7 deg, altitudes in
mm, velocities in cm/s (the message's); inside, metres in the formation's local NED
frame.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable as jitable

from ..geo import LocalFrame
from ..link.codec import MAV, Codec

MSG_ID = MAV.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
TARGET_ID = MAV.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT
_RAW = frozenset((MSG_ID, TARGET_ID))
# POSITION_TARGET_GLOBAL_INT: position, velocity and acceleration set, yaw ignored
_TARGET_MASK = (MAV.POSITION_TARGET_TYPEMASK_YAW_IGNORE | MAV.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE)
MAX_EXTRAPOLATION_S = 1.0
_DEG_E7 = 1e7 * 180.0 / math.pi
_ZERO = (0.0, 0.0, 0.0)
# a MAVLink 2 frame's bytes besides its payload (unsigned), its message id's (bytes 7-9)
_FRAME_BYTES = 12
_POSITION_ID = MSG_ID.to_bytes(3, "little")
# ``PeerTable.rows``, one per vehicle of ``only``: what ``get`` extrapolates, as numbers
ROW_KIND, ROW_T, ROW_P, ROW_V, ROW_A, ROW_N = 0, 1, 2, 5, 8, 11
NOT_HEARD, POSITION, TARGET = 0.0, 1.0, 2.0          # ROW_KIND


class PositionPublisher:
    """Encodes this vehicle's position for the vehicle network (own codec: own
    system id and sequence numbers)."""

    def __init__(self, system_id: int, ground_alt_m: float = 0.0):
        self.codec = Codec(system_id, MAV.MAV_COMP_ID_AUTOPILOT1)
        self.ground_alt_m = ground_alt_m

    def encode_target(self, t_us: int, lat_rad: float, lon_rad: float, alt_m: float,
                      v_ned, a_ned) -> bytes:
        """POSITION_TARGET_GLOBAL_INT: the vehicle's current position / velocity /
        acceleration setpoint (its virtual target), as ArduPilot streams in GUIDED."""
        return self.codec.encode_values(TARGET_ID, (
            int(t_us // 1000) & 0xFFFFFFFF, MAV.MAV_FRAME_GLOBAL_INT, _TARGET_MASK,
            int(round(lat_rad * _DEG_E7)), int(round(lon_rad * _DEG_E7)), float(alt_m),
            float(v_ned[0]), float(v_ned[1]), float(v_ned[2]),
            float(a_ned[0]), float(a_ned[1]), float(a_ned[2]), 0.0, 0.0))

    def encode(self, t_us: int, lat_rad: float, lon_rad: float, alt_m: float,
               v_ned, yaw_rad: float = 0.0) -> bytes:
        hdg_cdeg = int(round(math.degrees(yaw_rad) % 360.0 * 100.0)) % 36000
        return self.codec.encode_values(MSG_ID, (
            int(t_us // 1000) & 0xFFFFFFFF,
            int(round(lat_rad * _DEG_E7)), int(round(lon_rad * _DEG_E7)),
            int(round(alt_m * 1000.0)), int(round((alt_m - self.ground_alt_m) * 1000.0)),
            _cm(v_ned[0]), _cm(v_ned[1]), _cm(v_ned[2]), hdg_cdeg))


def _cm(v: float) -> int:
    return max(-32767, min(32767, int(round(v * 100.0))))


class PeerTable:
    """Latest position of every other vehicle, from received bytes; with ``only``, of
    those vehicles only (the ones a vehicle follows: a datagram from any other is
    dropped on its MAVLink 2 header's system id, byte 5, undecoded, and ``rows`` holds
    what ``get`` would extrapolate for each of them, in the order of ``only``: the
    formation guidance's kernel reads them there; ``rows``: where that array lives, if
    not its own: zeros, one row of ROW_N per vehicle of ``only``)."""

    def __init__(self, own_id: int, frame: LocalFrame, use_targets: bool = False,
                 only=None, rows=None):
        self.own_id = own_id
        self.frame = frame
        self.use_targets = use_targets
        self.only = None if only is None else frozenset(only)
        self._row = {} if only is None else {j: k for k, j in enumerate(only)}
        self.rows = np.zeros((len(self._row), ROW_N)) if rows is None else rows   # ROW_*; all NOT_HEARD
        self.codec = Codec(own_id, MAV.MAV_COMP_ID_AUTOPILOT1)
        self.latest: dict[int, tuple[float, tuple, tuple]] = {}   # id -> (t_s, p_ned, v_ned)
        self.targets: dict[int, tuple[float, tuple, tuple, tuple]] = {}  # + a_ned
        self.received = 0

    def receive(self, data: bytes) -> None:
        if len(data) > 9 and data[0] == 0xFD:              # a MAVLink 2 frame first
            only = self.only
            if only is not None and data[5] not in only:
                return
            if (self.use_targets and len(data) == data[1] + _FRAME_BYTES
                    and data[7:10] == _POSITION_ID and data[5] in self.targets):
                return    # one unsigned GLOBAL_POSITION_INT, which get() would not read
        for m in self.codec.decode(data, _RAW):
            if m.src_system == self.own_id:
                continue
            if m.msg_id == TARGET_ID:
                t_ms, _, _, lat, lon, alt, vx, vy, vz, ax, ay, az, _, _ = m.values
                t_s = t_ms * 1e-3
                prev = self.targets.get(m.src_system)
                if prev is not None and prev[0] > t_s:
                    continue
                p = self.frame.to_ned_fast(lat / _DEG_E7, lon / _DEG_E7, alt).tolist()
                self.targets[m.src_system] = (t_s, tuple(p), (vx, vy, vz), (ax, ay, az))
                if self.use_targets:
                    self._set_row(m.src_system, TARGET, t_s, p, (vx, vy, vz), (ax, ay, az))
                self.received += 1
                continue
            if m.msg_id != MSG_ID or (self.use_targets and m.src_system in self.targets):
                continue        # (with a setpoint heard, get() answers from the setpoints)
            t_ms, lat, lon, alt, _, vx, vy, vz, _ = m.values
            t_s = t_ms * 1e-3
            prev = self.latest.get(m.src_system)
            if prev is not None and prev[0] > t_s:
                continue                       # an older message overtaken by a newer one
            p = self.frame.to_ned_fast(lat / _DEG_E7, lon / _DEG_E7, alt * 1e-3).tolist()
            v = (vx * 0.01, vy * 0.01, vz * 0.01)
            self.latest[m.src_system] = (t_s, tuple(p), v)
            self._set_row(m.src_system, POSITION, t_s, p, v, _ZERO)
            self.received += 1

    def _set_row(self, vid: int, kind: float, t_s: float, p, v, a) -> None:
        k = self._row.get(vid)
        if k is not None:
            self.rows[k] = (kind, t_s, *p, *v, *a)

    def get(self, vid: int, t_s: float):
        """(p_ned extrapolated to ``t_s``, v_ned, age_s, a_ned) or None if never heard
        (a_ned is zero from GLOBAL_POSITION_INT). With
        ``use_targets``, the peer's setpoint (POSITION_TARGET_GLOBAL_INT) where one was
        received, extrapolated with its velocity and acceleration (``extrapolated``)."""
        if self.use_targets:
            e = self.targets.get(vid)
            if e is not None:
                t, p, v, a = e
                p, v = extrapolated(t_s - t, p, v, a, True)
                return p, v, t_s - t, a
        e = self.latest.get(vid)
        if e is None:
            return None
        t, p, v = e
        p, _ = extrapolated(t_s - t, p, v, _ZERO, False)
        return p, v, t_s - t, _ZERO


@jitable
def extrapolated(age, p, v, a, accelerated):
    """A peer's reported position and velocity carried ``age`` seconds on (at most
    MAX_EXTRAPOLATION_S, never back): with its acceleration ``a`` for a setpoint
    (``accelerated``), at constant velocity for a position."""
    h = MAX_EXTRAPOLATION_S if MAX_EXTRAPOLATION_S < age else age   # max(0, min(age, MAX)),
    h = h if h > 0.0 else 0.0                                       # spelt out: the builtins' cost
    if not accelerated:
        return (p[0] + v[0] * h, p[1] + v[1] * h, p[2] + v[2] * h), v
    hh = 0.5 * h * h
    return ((p[0] + v[0] * h + a[0] * hh, p[1] + v[1] * h + a[1] * hh, p[2] + v[2] * h + a[2] * hh),
            (v[0] + a[0] * h, v[1] + a[1] * h, v[2] + a[2] * h))
