"""Telemetry: what each streamed message says, built from the vehicle on demand.

Only ``autopilot.vehicle_api.VehicleApi`` is read (plus the navigation filter's
innovation records, ``vehicle.nav.innovations``, when the filter has them), so the same
code serves the fixed-wing and the quadrotor. Units are converted here, at the wire.

Streams and their default rates (Hz, on simulation time; see ``service.py`` for what
happens faster than real time), the REQUEST_DATA_STREAM group each belongs to (as
ArduPilot groups them), and which are sent before a ground station is heard on a
``udpout`` link (the heartbeat only).
"""
from __future__ import annotations

import math

from ..geo import LocalFrame, quat_to_euler
from ..link.codec import MAV
from ..mission.items import POSITION_COMMANDS, NAV_RETURN_TO_LAUNCH, MissionItem, FRAME_GLOBAL, NAV_WAYPOINT

S = MAV.MAV_DATA_STREAM_EXTENDED_STATUS
# name: (message id, default rate Hz, REQUEST_DATA_STREAM group)
STREAMS = {
    "HEARTBEAT": (MAV.MAVLINK_MSG_ID_HEARTBEAT, 1.0, None),
    "SYS_STATUS": (MAV.MAVLINK_MSG_ID_SYS_STATUS, 1.0, S),
    "EXTENDED_SYS_STATE": (MAV.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 1.0, S),
    "GPS_RAW_INT": (MAV.MAVLINK_MSG_ID_GPS_RAW_INT, 2.0, S),
    "NAV_CONTROLLER_OUTPUT": (MAV.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, 2.0, S),
    "MISSION_CURRENT": (MAV.MAVLINK_MSG_ID_MISSION_CURRENT, 1.0, S),
    "GLOBAL_POSITION_INT": (MAV.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 5.0, MAV.MAV_DATA_STREAM_POSITION),
    "ATTITUDE": (MAV.MAVLINK_MSG_ID_ATTITUDE, 10.0, MAV.MAV_DATA_STREAM_EXTRA1),
    "VFR_HUD": (MAV.MAVLINK_MSG_ID_VFR_HUD, 4.0, MAV.MAV_DATA_STREAM_EXTRA2),
    "EKF_STATUS_REPORT": (MAV.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 1.0, MAV.MAV_DATA_STREAM_EXTRA3),
    "ESTIMATOR_STATUS": (MAV.MAVLINK_MSG_ID_ESTIMATOR_STATUS, 1.0, MAV.MAV_DATA_STREAM_EXTRA3),
    "BATTERY_STATUS": (MAV.MAVLINK_MSG_ID_BATTERY_STATUS, 1.0, MAV.MAV_DATA_STREAM_EXTRA3),
    "HOME_POSITION": (MAV.MAVLINK_MSG_ID_HOME_POSITION, 0.2, None),
    # only while the fence is enabled (autopilot/fence), as ArduPilot sends it
    "FENCE_STATUS": (MAV.MAVLINK_MSG_ID_FENCE_STATUS, 1.0, S),
    # built by the terrain server (gcs/terrain.py), as ArduPilot's EXTRA3 group has it
    "TERRAIN_REPORT": (MAV.MAVLINK_MSG_ID_TERRAIN_REPORT, 1.0, MAV.MAV_DATA_STREAM_EXTRA3),
    # once the motor's ESC has reported its rpm (the vehicle's ``rpm``), as ArduPilot
    # sends its ESC telemetry in the EXTRA3 group
    "ESC_TELEMETRY_1_TO_4": (MAV.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4, 1.0, MAV.MAV_DATA_STREAM_EXTRA3),
}
NAME_BY_ID = {v[0]: k for k, v in STREAMS.items()}
ONE_SHOT = {MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION: "AUTOPILOT_VERSION"}
MIN_INTERVAL_US = 10_000   # the lockstep period: nothing can be fresher than one step

CAPABILITIES = (MAV.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | MAV.MAV_PROTOCOL_CAPABILITY_MISSION_INT
                | MAV.MAV_PROTOCOL_CAPABILITY_COMMAND_INT | MAV.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | MAV.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                | MAV.MAV_PROTOCOL_CAPABILITY_MAVLINK2
                | MAV.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE | MAV.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY)
# what we claim to be: ArduPilot 4.5.7, official release (major, minor, patch, type)
FLIGHT_SW_VERSION = (4 << 24) | (5 << 16) | (7 << 8) | MAV.FIRMWARE_VERSION_TYPE_OFFICIAL
UID = int.from_bytes(b"pysitl\x00\x01", "big")

_SENSORS = {  # SYS_STATUS bit: innovation source that judges its health
    MAV.MAV_SYS_STATUS_SENSOR_3D_GYRO: None,
    MAV.MAV_SYS_STATUS_SENSOR_3D_ACCEL: None,
    MAV.MAV_SYS_STATUS_SENSOR_3D_MAG: "mag",
    MAV.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE: "baro",
    MAV.MAV_SYS_STATUS_SENSOR_GPS: "gps_pos",
}
# the fault monitor's isolated channel (autopilot/monitor CHANNELS) -> the SYS_STATUS bit
# it makes unhealthy
_FAULT_BITS = {
    **{f"gyro_{a}": MAV.MAV_SYS_STATUS_SENSOR_3D_GYRO for a in "xyz"},
    **{f"accel_{a}": MAV.MAV_SYS_STATUS_SENSOR_3D_ACCEL for a in "xyz"},
    "mag": MAV.MAV_SYS_STATUS_SENSOR_3D_MAG,
    "baro": MAV.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
    "airspeed": MAV.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE,
    "gps_pos": MAV.MAV_SYS_STATUS_SENSOR_GPS, "gps_vel": MAV.MAV_SYS_STATUS_SENSOR_GPS,
    **{name: MAV.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
       for name in ("aileron", "elevator", "rudder", "throttle", "motor_1", "motor_2", "motor_3",
                    "motor_4")},
}
_CONTROL = (MAV.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | MAV.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
            | MAV.MAV_SYS_STATUS_SENSOR_YAW_POSITION | MAV.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
            | MAV.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL | MAV.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS)
_E7 = 1e7


def _i(v: float, lo: int, hi: int) -> int:
    """Round and saturate to an integer field (NaN -> 0)."""
    if v != v:
        return 0
    return max(lo, min(hi, int(round(v))))


class Telemetry:
    """Builds the messages. ``observe(frame, outputs)`` is called after every vehicle
    step (cheap); everything else only when a message is due."""

    def __init__(self, vehicle, battery_source=None):
        self.vehicle = vehicle
        self.battery_source = battery_source      # () -> BATTERY_STATUS message or None
        self.gps = None                           # last GpsFix
        self.controls: tuple = ()
        self.ratios: dict[str, tuple[float, bool]] = {}   # source -> (max test ratio, rejected)
        self.is_plane = vehicle.mav_type == MAV.MAV_TYPE_FIXED_WING
        self.failsafe = False

    # ------------------------------------------------------------------ inputs ---
    def observe(self, frame=None, outputs=None) -> None:
        if frame is not None and frame.gps is not None:
            self.gps = frame.gps
        if outputs is not None:
            self.controls = outputs.controls
        nav = getattr(self.vehicle, "nav", None)
        recs = getattr(nav, "innovations", None)
        if recs:
            for r in recs:
                tr = r.test_ratio
                m = float(max(tr)) if len(tr) else 0.0
                if r.source == "gps_pos" and len(tr) == 3:
                    self.ratios["gps_pos_h"] = (float(max(tr[0], tr[1])), bool(r.rejected))
                    self.ratios["gps_pos_v"] = (float(tr[2]), bool(r.rejected))
                self.ratios[r.source] = (m, bool(r.rejected))

    # ---------------------------------------------------------------- geometry ---
    def home(self) -> LocalFrame | None:
        """Home: the vehicle's, else (as ArduPilot before arming) where the navigation
        solution is once it is aligned."""
        v = self.vehicle
        if v.home_frame is not None:
            return v.home_frame
        nav = v.nav_state
        if nav is not None and nav.aligned and v.gps_fix_type >= 3:
            return LocalFrame(nav.lat_rad, nav.lon_rad, nav.alt_m)
        return None

    def home_item(self) -> MissionItem | None:
        h = self.home()
        if h is None:
            return None
        return MissionItem(0, FRAME_GLOBAL, NAV_WAYPOINT, 0, 1, 0.0, 0.0, 0.0, 0.0,
                           round(math.degrees(h.lat0_rad), 7), round(math.degrees(h.lon0_rad), 7),
                           round(h.alt0_m, 2))

    # ---------------------------------------------------------------- messages ---
    def heartbeat(self):
        v = self.vehicle
        base = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if v.armed:
            base |= MAV.MAV_MODE_FLAG_SAFETY_ARMED
        name = v.mode.name
        if name in ("MANUAL", "STABILIZE", "ACRO"):
            base |= MAV.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        else:
            base |= MAV.MAV_MODE_FLAG_STABILIZE_ENABLED
            if name in ("AUTO", "GUIDED", "RTL", "LOITER", "LAND", "TAKEOFF"):
                base |= MAV.MAV_MODE_FLAG_GUIDED_ENABLED
            if name in ("AUTO", "RTL", "LAND", "TAKEOFF"):
                base |= MAV.MAV_MODE_FLAG_AUTO_ENABLED
        if v.nav_state is None:
            state = MAV.MAV_STATE_BOOT
        elif self.failsafe:
            state = MAV.MAV_STATE_CRITICAL
        elif v.armed:
            state = MAV.MAV_STATE_ACTIVE
        else:
            state = MAV.MAV_STATE_STANDBY
        return MAV.MAVLink_heartbeat_message(v.mav_type, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                             int(v.mode), state, 3)

    def autopilot_version(self):
        return MAV.MAVLink_autopilot_version_message(
            CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, list(b"pysitl\x00\x00"), [0] * 8, [0] * 8,
            0, 0, UID, [0] * 18)

    def sys_status(self):
        v = self.vehicle
        present = _CONTROL | MAV.MAV_SYS_STATUS_AHRS | MAV.MAV_SYS_STATUS_PREARM_CHECK
        health = _CONTROL
        for bit, src in _SENSORS.items():
            present |= bit
            r = self.ratios.get(src) if src else None
            if r is None or not r[1]:
                health |= bit
        if self.gps is None or v.gps_fix_type < 3:
            health &= ~MAV.MAV_SYS_STATUS_SENSOR_GPS
        if self.is_plane:
            present |= MAV.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE
            r = self.ratios.get("airspeed")
            if r is None or not r[1]:
                health |= MAV.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE
        nav = v.nav_state
        if nav is not None and nav.aligned and nav.healthy:
            health |= MAV.MAV_SYS_STATUS_AHRS
        if v.arm_checks() is None:
            health |= MAV.MAV_SYS_STATUS_PREARM_CHECK
        iso = self._isolated()
        if iso is not None:
            health &= ~_FAULT_BITS.get(iso, 0)
        enabled = present & ~MAV.MAV_SYS_STATUS_PREARM_CHECK
        if not v.armed or v.mode.name in ("MANUAL",):
            enabled &= ~_CONTROL
        if not v.armed:
            enabled &= ~MAV.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
        enabled |= MAV.MAV_SYS_STATUS_PREARM_CHECK if not v.armed else 0
        g = getattr(v, "geofence", None)
        if g is not None:
            # the geofence: present once configured, enabled by FENCE_ENABLE, healthy
            # unless breached (as ArduPilot reports it: MAVProxy says "fence breach" when
            # the health bit drops, present or not)
            if g.enabled or g.fence_items:
                present |= MAV.MAV_SYS_STATUS_GEOFENCE
            if g.enabled:
                enabled |= MAV.MAV_SYS_STATUS_GEOFENCE
            if not g.breached:
                health |= MAV.MAV_SYS_STATUS_GEOFENCE
        volt, cur, rem = 0xFFFF, -1, -1
        bat = self.battery()
        if bat is not None:
            present |= MAV.MAV_SYS_STATUS_SENSOR_BATTERY
            enabled |= MAV.MAV_SYS_STATUS_SENSOR_BATTERY
            if bat.battery_remaining > 20 or bat.battery_remaining < 0:
                health |= MAV.MAV_SYS_STATUS_SENSOR_BATTERY
            volt = _i(sum(c for c in bat.voltages if c != 0xFFFF), 0, 0xFFFE)
            cur, rem = bat.current_battery, bat.battery_remaining
        return MAV.MAVLink_sys_status_message(present, enabled, health, 0, volt, cur, rem,
                                              0, 0, 0, 0, 0, 0, 0, 0, 0)

    def battery(self):
        return self.battery_source() if self.battery_source is not None else None

    def battery_status(self):
        return self.battery()

    def extended_sys_state(self):
        landed = MAV.MAV_LANDED_STATE_ON_GROUND if self.vehicle.landed else MAV.MAV_LANDED_STATE_IN_AIR
        if landed == MAV.MAV_LANDED_STATE_IN_AIR and getattr(self.vehicle, "landing_phase", None) \
                in ("descend", "approach", "flare", "rollout"):
            landed = MAV.MAV_LANDED_STATE_LANDING      # a NAV_LAND being flown (as ArduPlane says)
        return MAV.MAVLink_extended_sys_state_message(MAV.MAV_VTOL_STATE_UNDEFINED, landed)

    def home_position(self, t_us: int):
        h = self.home()
        if h is None:
            return None
        return MAV.MAVLink_home_position_message(
            _i(math.degrees(h.lat0_rad) * _E7, -900000000, 900000000),
            _i(math.degrees(h.lon0_rad) * _E7, -1800000000, 1800000000),
            _i(h.alt0_m * 1000.0, -2**31, 2**31 - 1), 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0],
            0.0, 0.0, 0.0, t_us)

    def attitude(self, t_us: int):
        nav = self.vehicle.nav_state
        if nav is None:
            return None
        r, p, y = quat_to_euler(nav.q_nb.tolist())
        w = nav.omega_b
        return MAV.MAVLink_attitude_message(t_us // 1000 & 0xFFFFFFFF, r, p, y,
                                            float(w[0]), float(w[1]), float(w[2]))

    def global_position_int(self, t_us: int):
        nav = self.vehicle.nav_state
        if nav is None:
            return None
        h = self.home()
        rel = nav.alt_m - h.alt0_m if h is not None else 0.0
        vn, ve, vd = (float(x) for x in nav.v_ned)
        yaw = quat_to_euler(nav.q_nb.tolist())[2]
        return MAV.MAVLink_global_position_int_message(
            t_us // 1000 & 0xFFFFFFFF, _i(math.degrees(nav.lat_rad) * _E7, -900000000, 900000000),
            _i(math.degrees(nav.lon_rad) * _E7, -1800000000, 1800000000),
            _i(nav.alt_m * 1000, -2**31, 2**31 - 1), _i(rel * 1000, -2**31, 2**31 - 1),
            _i(vn * 100, -32767, 32767), _i(ve * 100, -32767, 32767), _i(vd * 100, -32767, 32767),
            _i(math.degrees(yaw) % 360.0 * 100, 0, 35999))

    def gps_raw_int(self, t_us: int):
        g = self.gps
        if g is None:
            return MAV.MAVLink_gps_raw_int_message(t_us, MAV.GPS_FIX_TYPE_NO_GPS, 0, 0, 0, 0xFFFF, 0xFFFF,
                                                   0xFFFF, 0xFFFF, 0, 0, 0, 0, 0, 0, 0)
        vn, ve = float(g.v_ned[0]), float(g.v_ned[1])
        return MAV.MAVLink_gps_raw_int_message(
            g.t_us, g.fix_type, _i(math.degrees(g.lat_rad) * _E7, -900000000, 900000000),
            _i(math.degrees(g.lon_rad) * _E7, -1800000000, 1800000000), _i(g.alt_m * 1000, -2**31, 2**31 - 1),
            _i(g.eph_m * 100, 0, 65534), _i(g.epv_m * 100, 0, 65534), _i(math.hypot(vn, ve) * 100, 0, 65534),
            _i(math.degrees(math.atan2(ve, vn)) % 360.0 * 100, 0, 35999), _i(g.satellites, 0, 255),
            0, _i(g.eph_m * 1000, 0, 2**32 - 1), _i(g.epv_m * 1000, 0, 2**32 - 1), 0, 0, 0)

    def vfr_hud(self):
        nav = self.vehicle.nav_state
        if nav is None:
            return None
        vn, ve, vd = (float(x) for x in nav.v_ned)
        c = self.controls
        if self.is_plane:
            thr = c[3] if len(c) > 3 else 0.0
        else:
            thr = sum(c[:4]) / 4.0 if len(c) >= 4 else 0.0
        yaw = quat_to_euler(nav.q_nb.tolist())[2]
        return MAV.MAVLink_vfr_hud_message(float(nav.airspeed_mps), math.hypot(vn, ve),
                                           _i(math.degrees(yaw) % 360.0, 0, 359),
                                           _i(thr * 100, 0, 100), float(nav.alt_m), -vd)

    def _target(self):
        """(target, leg start, target alt MSL) of the item being flown, in home NE, or None."""
        v = self.vehicle
        h = self.home()
        m = v.mission
        if h is None or m is None or v.nav_state is None:
            return None
        name = v.mode.name
        if name == "RTL":
            return (0.0, 0.0), None, None
        if name != "AUTO":
            return None
        seq = v.current_seq()
        if not 0 < seq < len(m):
            return None
        it = m[seq]
        if it.command == NAV_RETURN_TO_LAUNCH:
            return (0.0, 0.0), None, None
        if it.command not in POSITION_COMMANDS:
            return None

        def ne(item):
            p = h.to_ned_fast(math.radians(item.x_lat_deg), math.radians(item.y_lon_deg), h.alt0_m)
            return float(p[0]), float(p[1])

        prev = None
        for k in range(seq - 1, 0, -1):
            if m[k].command in POSITION_COMMANDS and (m[k].x_lat_deg, m[k].y_lon_deg) != (0.0, 0.0):
                prev = ne(m[k])
                break
        alt = it.z_alt_m + (h.alt0_m if it.frame in (3, 6, 10, 11) else 0.0)
        terrain = getattr(v, "terrain", None)
        if it.frame in (10, 11) and terrain is not None:
            ground = terrain(it.x_lat_deg, it.y_lon_deg)     # above the terrain there
            alt = it.z_alt_m + ground if ground is not None else alt
        return ne(it), prev, alt

    def nav_controller_output(self):
        v = self.vehicle
        nav = v.nav_state
        if nav is None:
            return None
        r, p, y = quat_to_euler(nav.q_nb.tolist())
        wp_dist = 0.0
        xtrack = 0.0
        bearing = math.degrees(y)
        alt_err = 0.0
        tgt = self._target()
        if tgt is not None:
            (tn, te), prev, alt = tgt
            h = self.home()
            pos = h.to_ned_fast(nav.lat_rad, nav.lon_rad, nav.alt_m)
            pn, pe = float(pos[0]), float(pos[1])
            wp_dist = math.hypot(tn - pn, te - pe)
            bearing = math.degrees(math.atan2(te - pe, tn - pn))
            if prev is not None:
                ln, le = tn - prev[0], te - prev[1]
                length = math.hypot(ln, le)
                if length > 1e-3:
                    xtrack = ((pn - prev[0]) * -le + (pe - prev[1]) * ln) / length
            if alt is not None and math.isfinite(alt):   # (NaN: "the current altitude")
                alt_err = alt - nav.alt_m
        return MAV.MAVLink_nav_controller_output_message(
            math.degrees(r), math.degrees(p), _i(bearing, -180, 360), _i(bearing, -180, 360),
            _i(wp_dist, 0, 65535), alt_err, 0.0, xtrack)

    def mission_current(self):
        v = self.vehicle
        m = v.mission
        n = len(m) - 1 if m is not None else 0
        seq = v.current_seq()
        reached = v.reached_events() if n > 0 else []
        auto = v.mode.name == "AUTO"
        if n <= 0:
            state = MAV.MISSION_STATE_NO_MISSION
        elif reached and reached[-1][1] >= n:
            state = MAV.MISSION_STATE_COMPLETE
        elif v.armed and auto:
            state = MAV.MISSION_STATE_ACTIVE
        elif reached:
            state = MAV.MISSION_STATE_PAUSED
        else:
            state = MAV.MISSION_STATE_NOT_STARTED
        return MAV.MAVLink_mission_current_message(min(seq, 0xFFFF), n if n > 0 else 0xFFFF, state,
                                                   1 if auto else 2)

    def _isolated(self) -> str | None:
        """The channel the fault monitor has isolated, if any."""
        mon = getattr(self.vehicle, "monitor", None)
        return getattr(mon, "isolated", None) if mon is not None else None

    def _ratio(self, src: str) -> float:
        r = self.ratios.get(src)
        return r[0] if r is not None else 0.0

    def _est_flags(self, ekf: bool) -> int:
        v = self.vehicle
        nav = v.nav_state
        if nav is None or not nav.aligned:
            return 0
        P = (MAV.EKF_ATTITUDE, MAV.EKF_VELOCITY_HORIZ, MAV.EKF_VELOCITY_VERT, MAV.EKF_POS_HORIZ_REL,
             MAV.EKF_POS_HORIZ_ABS, MAV.EKF_POS_VERT_ABS, MAV.EKF_PRED_POS_HORIZ_REL,
             MAV.EKF_PRED_POS_HORIZ_ABS)
        flags = MAV.EKF_ATTITUDE
        mon = getattr(v, "monitor", None)
        if getattr(mon, "dead_reckoning", False):
            # GPS lost in flight: velocity and position carried on air data and the wind
            # estimate, relative only (as ArduPilot's EKF reports dead reckoning)
            flags |= (MAV.EKF_VELOCITY_HORIZ | MAV.EKF_VELOCITY_VERT | MAV.EKF_POS_HORIZ_REL
                      | MAV.EKF_POS_VERT_ABS | MAV.EKF_PRED_POS_HORIZ_REL)
        elif v.gps_fix_type >= 3 and nav.healthy:
            for f in P:
                flags |= f
        else:
            flags |= MAV.EKF_VELOCITY_VERT | MAV.EKF_POS_VERT_ABS | MAV.EKF_CONST_POS_MODE
        r = self.ratios.get("gps_pos")
        if (r is not None and r[1]) or (self._isolated() in ("gps_pos", "gps_vel")
                                         and not getattr(mon, "dead_reckoning", False)):
            flags |= MAV.EKF_GPS_GLITCHING
        return flags  # ESTIMATOR_STATUS_FLAGS have the same bit values

    def ekf_status_report(self):
        # ArduPilot reports the square roots of the test ratios in the "variance" fields
        s = math.sqrt
        return MAV.MAVLink_ekf_status_report_message(
            self._est_flags(True), s(self._ratio("gps_vel")), s(self._ratio("gps_pos_h")),
            s(max(self._ratio("baro"), self._ratio("gps_pos_v"))), s(self._ratio("mag")), 0.0,
            s(self._ratio("airspeed")))

    def estimator_status(self, t_us: int):
        g = self.gps
        return MAV.MAVLink_estimator_status_message(
            t_us, self._est_flags(False), self._ratio("gps_vel"), self._ratio("gps_pos_h"),
            max(self._ratio("baro"), self._ratio("gps_pos_v")), self._ratio("mag"), 0.0,
            self._ratio("airspeed"), g.eph_m if g is not None else 0.0, g.epv_m if g is not None else 0.0)

    def build(self, name: str, t_us: int):
        """The message ``name`` now, or None when there is nothing to say yet."""
        if name == "HEARTBEAT":
            return self.heartbeat()
        if name == "ATTITUDE":
            return self.attitude(t_us)
        if name == "GLOBAL_POSITION_INT":
            return self.global_position_int(t_us)
        if name == "VFR_HUD":
            return self.vfr_hud()
        if name == "SYS_STATUS":
            return self.sys_status()
        if name == "EXTENDED_SYS_STATE":
            return self.extended_sys_state()
        if name == "GPS_RAW_INT":
            return self.gps_raw_int(t_us)
        if name == "NAV_CONTROLLER_OUTPUT":
            return self.nav_controller_output()
        if name == "MISSION_CURRENT":
            return self.mission_current()
        if name == "EKF_STATUS_REPORT":
            return self.ekf_status_report()
        if name == "ESTIMATOR_STATUS":
            return self.estimator_status(t_us)
        if name == "BATTERY_STATUS":
            return self.battery_status()
        if name == "HOME_POSITION":
            return self.home_position(t_us)
        if name == "AUTOPILOT_VERSION":
            return self.autopilot_version()
        if name == "FENCE_STATUS":
            return self.fence_status()
        if name == "ESC_TELEMETRY_1_TO_4":
            return self.esc_telemetry()
        return None

    def esc_telemetry(self):
        """ESC_TELEMETRY_1_TO_4 with ESC 1's rpm as the motor's ESC last reported it (the
        HIL link's, autopilot/link/hil.py); None before any (or none fitted)."""
        rpm = getattr(self.vehicle, "rpm", -1.0)
        if rpm is None or rpm < 0.0:
            return None
        return MAV.MAVLink_esc_telemetry_1_to_4_message([0] * 4, [0] * 4, [0] * 4, [0] * 4,
                                                        [_i(rpm, 0, 65535), 0, 0, 0], [0] * 4)

    def fence_status(self):
        """FENCE_STATUS while the fence is enabled: breached now, how many breaches, the
        type and time (ms of simulation time) of the last."""
        g = getattr(self.vehicle, "geofence", None)
        if g is None or not g.enabled:
            return None
        # FENCE_MITIGATE names no mode change: an action taken is "unknown" (0)
        mitigation = MAV.FENCE_MITIGATE_NONE if not g.breached or g.action == "report" \
            else MAV.FENCE_MITIGATE_UNKNOWN
        return MAV.MAVLink_fence_status_message(1 if g.breached else 0, min(g.breach_count, 0xFFFF),
                                                g.breach_status_type, g.breach_time_ms & 0xFFFFFFFF,
                                                mitigation)
