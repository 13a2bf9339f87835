"""The ground-station protocol core, sans-IO: decoded messages in, messages out.

No sockets and no codec here (``service.py`` has those). The core keeps one
:class:`Client` per ground-station peer, and everything it wants sent goes into
``outbox`` as ``(client id or None for every client, message, is_telemetry)``.
Time comes in two kinds: simulation time ``t_us`` (streams, log entries) passed to
every call, and the wall clock ``clock()`` (protocol timeouts, the heartbeat-loss
failsafe), injectable so tests run on a fake one.

Identity on the wire is an ArduPilot vehicle's (docs/ground-stations.md): HEARTBEAT with
MAV_AUTOPILOT_ARDUPILOTMEGA and ArduPlane / ArduCopter mode numbers, item 0 = home,
COMMAND_ACK for every COMMAND_LONG / COMMAND_INT addressed to us (target system 0 or
ours, target component 0 or ours), exactly one each, and silence towards anything
addressed to another system.

Commands (MAV_CMD) and what they answer:

=====================================  ===========================================
ARM_DISARM 400                          ACCEPTED; FAILED + "PreArm: <reason>"
DO_SET_MODE 176 (and SET_MODE)          ACCEPTED; UNSUPPORTED for a mode not implemented
NAV_TAKEOFF 22                          vehicle.takeoff, if it has one
NAV_RETURN_TO_LAUNCH 20, NAV_LAND 21    mode RTL / LAND (UNSUPPORTED where no LAND mode)
DO_GO_AROUND 191                        vehicle.go_around (param1: altitude above home, 0:
                                        the landing's); FAILED + STATUSTEXT when no
                                        landing is flown; UNSUPPORTED without one
MISSION_START 300                       mode AUTO from param1 (FAILED without a mission)
DO_SET_HOME 179                         vehicle.set_home; HOME_POSITION to all
DO_CHANGE_SPEED 178                     vehicle.set_speed, if it has one
DO_REPOSITION 192                       mode GUIDED + vehicle.set_guided_target
DO_SET_MISSION_CURRENT 224              set current mission item
GET_HOME_POSITION 410                   HOME_POSITION (FAILED before home is known)
REQUEST_AUTOPILOT_CAPABILITIES 520      AUTOPILOT_VERSION
REQUEST_MESSAGE 512                     the message once (UNSUPPORTED if unknown)
SET_MESSAGE_INTERVAL 511                per-client stream rate
GET_MESSAGE_INTERVAL 510                MESSAGE_INTERVAL
INJECT_FAILURE 420                      relayed to the simulator; its answer, or FAILED
                                        after ``relay_timeout_s``
anything else                           UNSUPPORTED
=====================================  ===========================================

SETUP_SIGNING (no reply, as in the protocol) sets the signing key, or removes it with an
all-zero key; refused while armed (as ArduPilot) and with an initial timestamp that does
not fit the signature's 48 bits. The check of every incoming signature is the service's
(``service.py``).

TERRAIN_DATA and TERRAIN_CHECK go to the terrain server (``terrain.py``: TERRAIN_REQUEST
for what the vehicle lacks, TERRAIN_REPORT streamed in the EXTRA3 group).

Optional vehicle methods beyond ``VehicleApi`` (used when present, else UNSUPPORTED):
``takeoff(alt_m, t_us)``, ``set_speed(speed_mps, t_us)``,
``set_guided_target(lat_rad, lon_rad, alt_m, t_us)``, each returning None or a reason.

Failsafe: once a ground-station HEARTBEAT (type MAV_TYPE_GCS) has been seen, no such
heartbeat for FS_GCS_TIMEOUT seconds of wall time while armed and flying switches to RTL
(or LAND where RTL is refused or absent), announced "GCS Failsafe On". When heartbeats
return ("GCS Failsafe Off"), control returns to the ground station: if the mode is still
the one the failsafe chose, the mode (and mission item) from before is restored.
"""
from __future__ import annotations

import math

from ..link.codec import MAV
from ..link.signing import TIMESTAMP_MAX
from .mission import MissionServer
from .params import ParamServer
from .terrain import TerrainServer
from .telemetry import MIN_INTERVAL_US, NAME_BY_ID, ONE_SHOT, STREAMS, Telemetry

R = MAV
ACCEPTED, TEMP_REJECTED, DENIED = R.MAV_RESULT_ACCEPTED, R.MAV_RESULT_TEMPORARILY_REJECTED, R.MAV_RESULT_DENIED
UNSUPPORTED, FAILED = R.MAV_RESULT_UNSUPPORTED, R.MAV_RESULT_FAILED
FORCE_DISARM = 21196
SEV_CRITICAL, SEV_WARNING, SEV_NOTICE, SEV_INFO = 2, 4, 5, 6
RELAY_TIMEOUT_S = 3.0
FTP_NAK, FTP_ERR_UNKNOWN_COMMAND = 129, 7


def _finite(*vals) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in vals)


def _as_int(v) -> int | None:
    return int(v) if _finite(v) and abs(v) < 2**31 else None


class Cmd:
    """A COMMAND_LONG or COMMAND_INT, normalised: lat/lon in degrees (NaN if absent)."""

    __slots__ = ("command", "p1", "p2", "p3", "p4", "lat_deg", "lon_deg", "alt", "frame", "is_int",
                 "sysid", "compid", "confirmation")

    def __init__(self, msg):
        self.command = int(msg.command)
        self.p1, self.p2, self.p3, self.p4 = (float(msg.param1), float(msg.param2),
                                              float(msg.param3), float(msg.param4))
        self.sysid, self.compid = msg.get_srcSystem(), msg.get_srcComponent()
        self.is_int = msg.get_type() == "COMMAND_INT"
        if self.is_int:
            self.lat_deg = msg.x * 1e-7 if msg.x != 0 or msg.y != 0 else math.nan
            self.lon_deg = msg.y * 1e-7 if msg.x != 0 or msg.y != 0 else math.nan
            self.alt = float(msg.z)
            self.frame = int(msg.frame)
            self.confirmation = 0
        else:
            self.lat_deg, self.lon_deg, self.alt = float(msg.param5), float(msg.param6), float(msg.param7)
            self.frame = R.MAV_FRAME_GLOBAL
            self.confirmation = int(msg.confirmation)


class Client:
    __slots__ = ("cid", "name", "sysid", "compid", "v1", "streaming", "intervals", "due",
                 "last_heartbeat", "is_gcs")

    def __init__(self, cid: int, name: str, streaming: bool):
        self.cid = cid
        self.name = name
        self.sysid = 255
        self.compid = 190
        self.v1 = False                 # answer in MAVLink 1 (it has only spoken MAVLink 1)
        self.streaming = streaming      # full telemetry (else heartbeats only)
        self.intervals = {n: int(1e6 / v[1]) for n, v in STREAMS.items()}
        self.due: dict[str, int] = {}
        self.last_heartbeat: float | None = None
        self.is_gcs = False


class GcsCore:
    def __init__(self, vehicle, clock, relay=None, battery=None, persist=None,
                 system_id: int = 1, component_id: int = 1, mission_timeout_s: float = 1.5,
                 mission_retries: int = 5, relay_timeout_s: float = RELAY_TIMEOUT_S):
        self.vehicle = vehicle
        self.clock = clock
        self.relay = relay                      # HIL end: relay_command(...), take_command_acks()
        self.system_id = system_id
        self.component_id = component_id
        self.relay_timeout_s = relay_timeout_s
        self.outbox: list[tuple[int | None, object, bool]] = []
        self.clients: dict[int, Client] = {}
        self.tm = Telemetry(vehicle, battery)
        self.missions = MissionServer(vehicle, self._send, self.say, self.tm.home_item, clock,
                                      mission_timeout_s, mission_retries)
        self.params = ParamServer(vehicle, self._send, self._broadcast, self.say, clock, persist)
        self.terrain = TerrainServer(vehicle, self._send, self._broadcast)
        self.t_us = 0
        self.pending_relays: list[tuple[int, int, int, int, float]] = []
        self.gcs_seen = False
        self.last_gcs_heartbeat: float | None = None
        self.failsafe_mode = None
        self.failsafe_saved: tuple | None = None
        self.errors = 0
        self.ignored = 0
        self._armed = vehicle.armed
        self._mode = vehicle.mode
        self._reached_n = len(vehicle.reached_events())
        self._fdi_n = self._fdi_count()
        self._notice_n = len(getattr(vehicle, "notices", ()))
        self._home_key = None
        self.signing = None                     # link/signing.Signing (service.py), if any
        self.on_signing_change = None           # called after SETUP_SIGNING changed the key

    # ------------------------------------------------------------------- output ---
    def _send(self, cid: int, msg) -> None:
        self.outbox.append((cid, msg, False))

    def _broadcast(self, msg) -> None:
        self.outbox.append((None, msg, False))

    def say(self, severity: int, text: str) -> None:
        """STATUSTEXT to every client, in 50-character chunks if it is longer."""
        text = text.encode("ascii", "replace").decode("ascii")
        if len(text) <= 50:
            self._broadcast(R.MAVLink_statustext_message(severity, text.encode(), 0, 0))
            return
        self._say_id = getattr(self, "_say_id", 0) % 65535 + 1
        chunks = [text[i:i + 50] for i in range(0, len(text), 50)]
        for k, c in enumerate(chunks):
            self._broadcast(R.MAVLink_statustext_message(severity, c.encode(), self._say_id, k))

    def _ack(self, cmd: Cmd, result: int) -> None:
        self.outbox.append((self._cid, R.MAVLink_command_ack_message(cmd.command, result, 0, 0,
                                                                     cmd.sysid, cmd.compid), False))

    # ------------------------------------------------------------------ clients ---
    def add_client(self, cid: int, name: str, streaming: bool = True) -> None:
        self.clients[cid] = Client(cid, name, streaming)

    def remove_client(self, cid: int) -> None:
        self.clients.pop(cid, None)
        self.missions.client_gone(cid)
        self.params.client_gone(cid)

    def heard(self, cid: int) -> None:
        c = self.clients.get(cid)
        if c is not None and not c.streaming:
            c.streaming = True

    # -------------------------------------------------------------------- input ---
    def receive(self, cid: int, msg, t_us: int, mavlink1: bool = False) -> None:
        """One decoded message from client ``cid``. Never raises: a message that breaks
        a handler is counted in ``errors`` and dropped."""
        self.t_us = t_us
        c = self.clients.get(cid)
        if c is None:
            return
        c.v1 = mavlink1
        self._cid = cid
        try:
            self._dispatch(c, msg, t_us)
        except Exception:  # noqa: BLE001 - a hostile message must never stop the vehicle
            self.errors += 1

    def _for_us(self, msg) -> bool:
        ts = getattr(msg, "target_system", 0)
        tc = getattr(msg, "target_component", 0)
        return ts in (0, self.system_id) and tc in (0, self.component_id)

    def _dispatch(self, c: Client, msg, t_us: int) -> None:
        name = msg.get_type()
        if name == "BAD_DATA":
            return
        src = msg.get_srcSystem()
        if name == "HEARTBEAT":
            c.sysid, c.compid = src, msg.get_srcComponent()
            if msg.type == R.MAV_TYPE_GCS:
                now = self.clock()
                c.is_gcs = True
                c.last_heartbeat = now
                self.gcs_seen = True
                self.last_gcs_heartbeat = now
                if self.failsafe_mode is not None:
                    self._failsafe_off(t_us)
            return
        if not self._for_us(msg):
            self.ignored += 1
            return
        if name in ("COMMAND_LONG", "COMMAND_INT"):
            self._command(c, Cmd(msg), t_us)
        elif self.missions.handle(c.cid, msg, t_us) or self.params.handle(c.cid, msg, t_us) \
                or self.terrain.handle(c.cid, msg, t_us):
            pass
        elif name == "REQUEST_DATA_STREAM":
            self._request_data_stream(c, msg)
        elif name == "SET_MODE":
            if msg.base_mode & R.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                self._set_mode(int(msg.custom_mode), t_us, quiet=False)
        elif name == "SET_POSITION_TARGET_GLOBAL_INT":
            self._position_target(msg, t_us)
        elif name == "FILE_TRANSFER_PROTOCOL":
            self._ftp_nak(c, msg)
        elif name == "SETUP_SIGNING":
            self._setup_signing(msg)
        elif name == "TIMESYNC":
            if msg.tc1 == 0:
                self._send(c.cid, R.MAVLink_timesync_message(t_us * 1000, msg.ts1))
        else:
            self.ignored += 1

    def _setup_signing(self, msg) -> None:
        """SETUP_SIGNING (no reply in the protocol): a key sets signing up (or changes
        the key); the all-zero key removes it. With a key set, only a correctly signed
        message gets here (service.py), so a key is changed or removed over a signed
        link only."""
        if self.signing is None:
            self.ignored += 1
            return
        if self.vehicle.armed:                      # as ArduPilot: never in flight
            self.say(SEV_WARNING, "Won't setup signing when armed")
            return
        if not 0 <= int(msg.initial_timestamp) <= TIMESTAMP_MAX:
            self.say(SEV_WARNING, "Signing: initial timestamp out of range")
            return
        key = bytes(int(b) & 0xFF for b in msg.secret_key)
        if not any(key):
            if not self.signing.active:
                return
            self.signing.set_key(None)
            self.say(SEV_NOTICE, "Signing off: key removed")
        else:
            self.signing.set_key(key, int(msg.initial_timestamp))
            self.say(SEV_NOTICE, "Signing on: key set")
        if self.on_signing_change is not None:
            self.on_signing_change()

    # ----------------------------------------------------------------- streams ---
    def _request_data_stream(self, c: Client, msg) -> None:
        group, rate, on = msg.req_stream_id, msg.req_message_rate, msg.start_stop
        for name, (_, _, g) in STREAMS.items():
            if g is None or (group != R.MAV_DATA_STREAM_ALL and g != group):
                continue
            if not on or rate == 0:
                c.intervals[name] = 0
            else:
                c.intervals[name] = max(int(1e6 / rate), MIN_INTERVAL_US)
                c.due.pop(name, None)

    def _message_interval(self, c: Client, cmd: Cmd) -> int:
        mid = _as_int(cmd.p1)
        name = NAME_BY_ID.get(mid) if mid is not None else None
        if name is None:
            return UNSUPPORTED
        if not _finite(cmd.p2):
            return DENIED
        if cmd.p2 < 0:
            c.intervals[name] = 0
        elif cmd.p2 == 0:
            c.intervals[name] = int(1e6 / STREAMS[name][1])
        else:
            c.intervals[name] = max(int(cmd.p2), MIN_INTERVAL_US)
        c.due.pop(name, None)
        return ACCEPTED

    def observe(self, frame=None, outputs=None) -> None:
        """After every vehicle step: what the telemetry needs from the step itself."""
        try:
            self.tm.observe(frame, outputs)
        except Exception:  # noqa: BLE001
            self.errors += 1

    def tick(self, t_us: int) -> None:
        """Between lockstep steps: streams due at ``t_us``, vehicle events, protocol timers."""
        self.t_us = t_us
        try:
            self._tick(t_us)
        except Exception:  # noqa: BLE001
            self.errors += 1

    def timers(self) -> None:
        """The wall-time protocol timers only (between steps, while waiting)."""
        try:
            self.missions.tick()
            self.params.tick()
        except Exception:  # noqa: BLE001
            self.errors += 1

    def _tick(self, t_us: int) -> None:
        self._relay_acks()
        self.timers()
        self._failsafe_check(t_us)
        if not self.clients:
            self._sync_events()
            return
        self._events(t_us)
        self.terrain.tick(t_us)
        built: dict[str, object] = {}
        for c in self.clients.values():
            for name, interval in c.intervals.items():
                if interval <= 0 or (not c.streaming and name != "HEARTBEAT"):
                    continue
                due = c.due.get(name)
                if due is None:
                    due = t_us
                if due > t_us:
                    continue
                due += interval
                c.due[name] = due if due > t_us else t_us + interval  # behind: skip ahead
                if name in built:
                    msg = built[name]
                elif name == "TERRAIN_REPORT":
                    msg = built[name] = self.terrain.report()
                else:
                    msg = built[name] = self.tm.build(name, t_us)
                if msg is not None:
                    self.outbox.append((c.cid, msg, True))

    # ------------------------------------------------------------------ events ---
    def _sync_events(self) -> None:
        v = self.vehicle
        self._armed, self._mode = v.armed, v.mode
        self._reached_n = len(v.reached_events())
        self._fdi_n = self._fdi_count()
        self._notice_n = len(getattr(v, "notices", ()))

    def _fdi_count(self) -> int:
        mon = getattr(self.vehicle, "monitor", None)
        return len(mon.events) if mon is not None else 0

    def _events(self, t_us: int) -> None:
        v = self.vehicle
        if v.armed != self._armed:
            self._armed = v.armed
            self.say(SEV_INFO, "Arming motors" if v.armed else "Disarming motors")
        if v.mode != self._mode:
            self._mode = v.mode
            self.say(SEV_INFO, f"Mode {v.mode.name}")
        reached = v.reached_events()
        if len(reached) < self._reached_n:
            self._reached_n = 0  # a new mission started
        for _, seq in reached[self._reached_n:]:
            self._broadcast(R.MAVLink_mission_item_reached_message(seq))
            self.say(SEV_INFO, f"Reached waypoint #{seq}")
        self._reached_n = len(reached)
        notices = getattr(v, "notices", None)
        if notices:
            # the vehicle's own announcements (mission warnings, crash detection)
            for _t_s, severity, text in notices[self._notice_n:]:
                self.say(severity, text)
            self._notice_n = len(notices)
        mon = getattr(v, "monitor", None)
        if mon is not None and len(mon.events) > self._fdi_n:
            # fault monitor: detection, isolation, adaptation, failsafe, clearance
            for _t_s, severity, text in mon.events[self._fdi_n:]:
                self.say(severity, text)
            self._fdi_n = len(mon.events)
        h = v.home_frame
        key = None if h is None else (h.lat0_rad, h.lon0_rad, h.alt0_m)
        if key != self._home_key:
            self._home_key = key
            msg = self.tm.home_position(t_us)
            if msg is not None:
                self._broadcast(msg)

    # ---------------------------------------------------------------- failsafe ---
    def _failsafe_check(self, t_us: int) -> None:
        if self.failsafe_mode is not None or not self.gcs_seen:
            return
        v = self.vehicle
        p = v.params
        if "FS_GCS_ENABL" not in p or p["FS_GCS_ENABL"] < 1 or not v.armed or v.landed:
            return
        if self.clock() - self.last_gcs_heartbeat < p["FS_GCS_TIMEOUT"]:
            return
        saved = (v.mode, v.current_seq())
        for name in ("RTL", "LAND"):
            mode = v.modes.__members__.get(name)
            if mode is None or mode not in v.implemented_modes:
                continue
            if v.mode == mode or v.set_mode(mode, t_us) is None:
                self.failsafe_mode = mode
                self.failsafe_saved = saved
                self.tm.failsafe = True
                self.say(SEV_CRITICAL, f"GCS Failsafe On: {name}")
                return

    def _failsafe_off(self, t_us: int) -> None:
        v = self.vehicle
        mode, seq = self.failsafe_saved
        restored = ""
        if v.mode == self.failsafe_mode and mode != self.failsafe_mode:
            if v.set_mode(mode, t_us) is None:
                restored = f", {mode.name} resumed"
                if mode.name == "AUTO" and v.mission is not None and 0 < seq < len(v.mission):
                    v.set_current(seq, t_us)
        self.failsafe_mode = None
        self.failsafe_saved = None
        self.tm.failsafe = False
        self.say(SEV_WARNING, f"GCS Failsafe Off{restored}")

    # ---------------------------------------------------------------- commands ---
    def _command(self, c: Client, cmd: Cmd, t_us: int) -> None:
        fn = _COMMANDS.get(cmd.command)
        if fn is None:
            self._ack(cmd, UNSUPPORTED)
            return
        try:
            result = fn(self, c, cmd, t_us)
        except Exception:  # noqa: BLE001 - still exactly one answer
            self.errors += 1
            result = FAILED
        if result is not None:
            self._ack(cmd, result)

    def _mode_by_name(self, name: str):
        v = self.vehicle
        mode = v.modes.__members__.get(name)
        return mode if mode is not None and mode in v.implemented_modes else None

    def _set_mode(self, number, t_us: int, quiet: bool = True) -> int:
        v = self.vehicle
        n = _as_int(number)
        try:
            mode = v.modes(n)
        except ValueError:
            mode = None
        if mode is None or mode not in v.implemented_modes:
            self.say(SEV_WARNING, f"Mode {number} not available")
            return UNSUPPORTED
        reason = v.set_mode(mode, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Mode change to {mode.name} failed: {reason}")
            return FAILED
        return ACCEPTED

    def _c_arm(self, c, cmd, t_us):
        v = self.vehicle
        if cmd.p1 == 1.0:
            if v.armed:
                return ACCEPTED
            reason = v.arm(t_us)
            if reason is not None:
                self.say(SEV_CRITICAL, f"PreArm: {reason}")
                return FAILED
            return ACCEPTED
        if cmd.p1 == 0.0:
            if not v.armed:
                return ACCEPTED
            reason = v.disarm(t_us, force=cmd.p2 == FORCE_DISARM)
            if reason is not None:
                self.say(SEV_WARNING, reason)
                return FAILED
            return ACCEPTED
        return DENIED

    def _c_set_mode(self, c, cmd, t_us):
        base = _as_int(cmd.p1)
        if base is None or not base & R.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return UNSUPPORTED  # only ArduPilot custom modes
        return self._set_mode(cmd.p2, t_us)

    def _c_rtl(self, c, cmd, t_us):
        mode = self._mode_by_name("RTL")
        return UNSUPPORTED if mode is None else self._set_mode(int(mode), t_us)

    def _c_land(self, c, cmd, t_us):
        mode = self._mode_by_name("LAND")
        return UNSUPPORTED if mode is None else self._set_mode(int(mode), t_us)

    def _c_go_around(self, c, cmd, t_us):
        fn = getattr(self.vehicle, "go_around", None)
        if fn is None:
            return UNSUPPORTED
        if not _finite(cmd.p1) or not 0.0 <= cmd.p1 < 50000.0:
            return DENIED
        reason = fn(cmd.p1, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Go around refused: {reason}")
            return FAILED
        return ACCEPTED

    def _c_takeoff(self, c, cmd, t_us):
        v = self.vehicle
        fn = getattr(v, "takeoff", None)
        if not _finite(cmd.alt) or not -1000.0 < cmd.alt < 50000.0:
            return DENIED if fn is not None or v.mav_type != R.MAV_TYPE_FIXED_WING else UNSUPPORTED
        if fn is None:
            # a multirotor without its own: ArduCopter's GUIDED takeoff, straight up to
            # param7 metres above home
            nav, h = v.nav_state, self.tm.home()
            if v.mav_type == R.MAV_TYPE_FIXED_WING or self._mode_by_name("GUIDED") is None \
                    or getattr(v, "set_guided_target", None) is None:
                return UNSUPPORTED
            if v.mode != self._mode_by_name("GUIDED") or not v.armed or nav is None or h is None:
                self.say(SEV_WARNING, "Takeoff refused: arm in GUIDED first")
                return FAILED
            return self._guided(math.degrees(nav.lat_rad), math.degrees(nav.lon_rad), cmd.alt,
                                R.MAV_FRAME_GLOBAL_RELATIVE_ALT, t_us)
        reason = fn(cmd.alt, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Takeoff refused: {reason}")
            return FAILED
        return ACCEPTED

    def _c_mission_start(self, c, cmd, t_us):
        v = self.vehicle
        mode = self._mode_by_name("AUTO")
        if mode is None:
            return UNSUPPORTED
        if v.mission is None or len(v.mission) < 2:
            self.say(SEV_WARNING, "Mission start refused: no mission")
            return FAILED
        first = _as_int(cmd.p1)
        if first is not None and first > 0:
            reason = self.missions.set_current(first, t_us)
            if reason is not None:
                self.say(SEV_WARNING, f"Mission start refused: {reason}")
                return DENIED
        return self._set_mode(int(mode), t_us)

    def _c_set_home(self, c, cmd, t_us):
        v = self.vehicle
        if cmd.p1 == 1.0:
            nav = v.nav_state
            if nav is None or not nav.aligned:
                return TEMP_REJECTED
            lat, lon, alt = nav.lat_rad, nav.lon_rad, nav.alt_m
        else:
            if not (_finite(cmd.lat_deg, cmd.lon_deg, cmd.alt) and abs(cmd.lat_deg) <= 90
                    and abs(cmd.lon_deg) <= 180 and -1000 < cmd.alt < 50000):
                return DENIED
            alt = cmd.alt
            if cmd.is_int and cmd.frame in (R.MAV_FRAME_GLOBAL_RELATIVE_ALT, R.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
                h = self.tm.home()
                if h is None:
                    return TEMP_REJECTED
                alt += h.alt0_m
            lat, lon = math.radians(cmd.lat_deg), math.radians(cmd.lon_deg)
        reason = v.set_home(lat, lon, alt, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Set home refused: {reason}")
            return FAILED
        return ACCEPTED

    def _c_change_speed(self, c, cmd, t_us):
        fn = getattr(self.vehicle, "set_speed", None)
        if fn is None:
            return UNSUPPORTED
        if not _finite(cmd.p2) or not (cmd.p2 == -1.0 or 0.0 < cmd.p2 <= 100.0):
            return DENIED
        if cmd.p2 == -1.0:
            return ACCEPTED
        reason = fn(cmd.p2, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Speed change refused: {reason}")
            return FAILED
        return ACCEPTED

    def _guided(self, lat_deg, lon_deg, alt, frame, t_us) -> int:
        """Fly to (and hold at) a position in GUIDED; NaN keeps the current value."""
        v = self.vehicle
        fn = getattr(v, "set_guided_target", None)
        mode = self._mode_by_name("GUIDED")
        if fn is None or mode is None:
            return UNSUPPORTED
        nav = v.nav_state
        h = self.tm.home()
        if not v.armed or nav is None or h is None:
            self.say(SEV_WARNING, "Guided refused: not armed")
            return FAILED
        if not _finite(lat_deg, lon_deg):
            if math.isnan(lat_deg) and math.isnan(lon_deg):
                lat_deg, lon_deg = math.degrees(nav.lat_rad), math.degrees(nav.lon_rad)
            else:
                return DENIED
        if not (abs(lat_deg) <= 90 and abs(lon_deg) <= 180):
            return DENIED
        if math.isnan(alt):
            alt_msl = nav.alt_m
        elif not _finite(alt) or not -1000 < alt < 50000:
            return DENIED
        elif frame in (R.MAV_FRAME_GLOBAL, R.MAV_FRAME_GLOBAL_INT):
            alt_msl = alt
        else:
            alt_msl = alt + h.alt0_m
        if v.mode != mode:
            reason = v.set_mode(mode, t_us)
            if reason is not None:
                self.say(SEV_WARNING, f"Guided refused: {reason}")
                return FAILED
        reason = fn(math.radians(lat_deg), math.radians(lon_deg), alt_msl, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Guided refused: {reason}")
            return FAILED
        return ACCEPTED

    def _c_reposition(self, c, cmd, t_us):
        frame = cmd.frame if cmd.is_int else R.MAV_FRAME_GLOBAL
        return self._guided(cmd.lat_deg, cmd.lon_deg, cmd.alt, frame, t_us)

    def _position_target(self, msg, t_us) -> None:
        v = self.vehicle
        guided = self._mode_by_name("GUIDED")
        if guided is None or v.mode != guided:
            return  # only in GUIDED, as ArduPilot
        if msg.type_mask & 0b111:
            return  # position ignored: velocity / acceleration targets are not implemented
        self._guided(msg.lat_int * 1e-7, msg.lon_int * 1e-7, float(msg.alt), msg.coordinate_frame, t_us)

    def _c_set_current(self, c, cmd, t_us):
        seq = _as_int(cmd.p1)
        if seq is None:
            return DENIED
        reason = self.missions.set_current(seq, t_us)
        if reason is not None:
            self.say(SEV_WARNING, f"Set current refused: {reason}")
            return DENIED
        return ACCEPTED

    def _c_get_home(self, c, cmd, t_us):
        msg = self.tm.home_position(t_us)
        if msg is None:
            return FAILED
        self._ack(cmd, ACCEPTED)
        self._send(c.cid, msg)
        return None

    def _c_capabilities(self, c, cmd, t_us):
        self._ack(cmd, ACCEPTED)
        self._send(c.cid, self.tm.autopilot_version())
        return None

    def _c_request_message(self, c, cmd, t_us):
        mid = _as_int(cmd.p1)
        name = NAME_BY_ID.get(mid) or ONE_SHOT.get(mid) if mid is not None else None
        if name is None:
            return UNSUPPORTED
        msg = self.tm.build(name, t_us)
        if msg is None:
            return TEMP_REJECTED
        self._ack(cmd, ACCEPTED)
        self._send(c.cid, msg)
        return None

    def _c_set_interval(self, c, cmd, t_us):
        return self._message_interval(c, cmd)

    def _c_get_interval(self, c, cmd, t_us):
        mid = _as_int(cmd.p1)
        name = NAME_BY_ID.get(mid) if mid is not None else None
        if name is None:
            return UNSUPPORTED
        iv = c.intervals.get(name, 0)
        self._ack(cmd, ACCEPTED)
        self._send(c.cid, R.MAVLink_message_interval_message(mid, iv if iv > 0 else -1))
        return None

    def _c_inject_failure(self, c, cmd, t_us):
        if self.relay is None:
            return UNSUPPORTED
        if not _finite(cmd.p1, cmd.p2, cmd.p3):
            return DENIED
        self.relay.relay_command(cmd.command, (cmd.p1, cmd.p2, cmd.p3, cmd.p4, 0.0, 0.0, 0.0))
        self.pending_relays.append((c.cid, cmd.sysid, cmd.compid, cmd.command,
                                    self.clock() + self.relay_timeout_s))
        return None  # answered when the simulator answers

    def _relay_acks(self) -> None:
        if self.relay is None:
            return
        for ack in self.relay.take_command_acks():
            for k, (cid, sysid, compid, command, _) in enumerate(self.pending_relays):
                if command == ack.command:
                    del self.pending_relays[k]
                    if cid in self.clients:
                        self.outbox.append((cid, R.MAVLink_command_ack_message(
                            command, ack.result, 0, 0, sysid, compid), False))
                    break
        if self.pending_relays:
            now = self.clock()
            keep = []
            for p in self.pending_relays:
                if now >= p[4]:
                    if p[0] in self.clients:
                        self.outbox.append((p[0], R.MAVLink_command_ack_message(
                            p[3], FAILED, 0, 0, p[1], p[2]), False))
                else:
                    keep.append(p)
            self.pending_relays = keep

    def _ftp_nak(self, c: Client, msg) -> None:
        """MAVFTP is not implemented: NAK every request at once (so MAVProxy and QGC
        fall back to the parameter protocol without waiting for their timeouts)."""
        p = bytes(msg.payload)
        seq = (p[0] | p[1] << 8) if len(p) >= 2 else 0
        session = p[2] if len(p) > 2 else 0
        req_op = p[3] if len(p) > 3 else 0
        out = bytearray(251)
        out[0:2] = ((seq + 1) & 0xFFFF).to_bytes(2, "little")
        out[2] = session
        out[3] = FTP_NAK
        out[4] = 1                      # size of the data: one error code
        out[5] = req_op
        out[12] = FTP_ERR_UNKNOWN_COMMAND
        self._send(c.cid, R.MAVLink_file_transfer_protocol_message(
            0, msg.get_srcSystem(), msg.get_srcComponent(), list(out)))


_COMMANDS = {
    R.MAV_CMD_COMPONENT_ARM_DISARM: GcsCore._c_arm,
    R.MAV_CMD_DO_SET_MODE: GcsCore._c_set_mode,
    R.MAV_CMD_NAV_RETURN_TO_LAUNCH: GcsCore._c_rtl,
    R.MAV_CMD_NAV_LAND: GcsCore._c_land,
    R.MAV_CMD_DO_GO_AROUND: GcsCore._c_go_around,
    R.MAV_CMD_NAV_TAKEOFF: GcsCore._c_takeoff,
    R.MAV_CMD_MISSION_START: GcsCore._c_mission_start,
    R.MAV_CMD_DO_SET_HOME: GcsCore._c_set_home,
    R.MAV_CMD_DO_CHANGE_SPEED: GcsCore._c_change_speed,
    R.MAV_CMD_DO_REPOSITION: GcsCore._c_reposition,
    R.MAV_CMD_DO_SET_MISSION_CURRENT: GcsCore._c_set_current,
    R.MAV_CMD_GET_HOME_POSITION: GcsCore._c_get_home,
    R.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: GcsCore._c_capabilities,
    R.MAV_CMD_REQUEST_MESSAGE: GcsCore._c_request_message,
    R.MAV_CMD_SET_MESSAGE_INTERVAL: GcsCore._c_set_interval,
    R.MAV_CMD_GET_MESSAGE_INTERVAL: GcsCore._c_get_interval,
    R.MAV_CMD_INJECT_FAILURE: GcsCore._c_inject_failure,
}
