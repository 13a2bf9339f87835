"""The PX4 simulator interface (HIL lockstep), wire format and the autopilot's end.

Exchange per lockstep step k (simulation time t_k), as PX4 SITL defines it
(docs.px4.io, "Simulation": the simulator MAVLink API):

    simulator -> autopilot   HIL_GPS (when a fix arrives), HIL_STATE_QUATERNION (truth,
                             for logging and scoring only), DISTANCE_SENSOR (when a
                             rangefinder reading is due), ESC_TELEMETRY_1_TO_4 (when
                             an rpm reading is due), then HIL_SENSOR(t_k)
    autopilot -> simulator   HIL_ACTUATOR_CONTROLS(time_usec = t_k)
    simulator                advances the plant from t_k to t_k+1 with those controls

HIL_SENSOR closes the step: the autopilot runs one loop per HIL_SENSOR and answers it
with exactly one HIL_ACTUATOR_CONTROLS carrying the same ``time_usec``. A repeated
HIL_SENSOR (same time, the simulator retrying after a lost answer) is answered again
with the same controls without running the loop twice. Units on the wire are the
message definitions' (hPa, degC, 1e7 deg, mm, cm/s); they are converted to SI here and
nowhere else.

DISTANCE_SENSOR is what PX4's simulator interface sends for a rangefinder (its
SimulatorMavlink reads it from the simulator next to HIL_SENSOR and HIL_GPS). Fields
as the MAVLink common message defines them: ``time_boot_ms`` (the simulation time),
``min_distance`` / ``max_distance`` / ``current_distance`` in cm, ``type``
MAV_DISTANCE_SENSOR_LASER, ``orientation`` MAV_SENSOR_ROTATION_PITCH_270 (downward),
``covariance`` the variance in cm^2, ``signal_quality`` 100 for a return and 1 ("invalid
signal") with ``current_distance`` = ``max_distance`` + 1 for none (out of range). It
belongs to the step whose HIL_SENSOR follows it.

ESC_TELEMETRY_1_TO_4 (ardupilotmega #11030; the dialect has no common ESC_STATUS) is
what ArduPilot sends for its ESCs' telemetry (AP_ESC_Telem, BLHeli_32 / DShot): per ESC
1-4 ``temperature`` [degC], ``voltage`` [cV], ``current`` [cA], ``totalcurrent`` [mAh],
``rpm`` and ``count`` (the ESC's telemetry frames, rolling). The simulator fills ESC 1
(the plane's one motor, servo instance 3): its ``rpm`` the propeller's speed
(sim_bridge/sensors/rpm.py) and its ``count``; the rest 0, not measured. It has no
time field: like DISTANCE_SENSOR it belongs to the step whose HIL_SENSOR follows it, and
that step's time is its time (:class:`~autopilot.messages.RpmSample`).
"""
from __future__ import annotations

import math
import struct

import numpy as np

from ..messages import (AirspeedSample, ActuatorOutputs, BaroSample, GpsFix, ImuSample,
                        MagSample, RangeSample, RpmSample, SensorFrame)
from .codec import MAV, Codec, Routes

DEG_E7 = 1e7
RAD_TO_E7 = 180.0 / math.pi * 1e7

U = MAV
IMU_FLAGS = (U.HIL_SENSOR_UPDATED_XACC | U.HIL_SENSOR_UPDATED_YACC | U.HIL_SENSOR_UPDATED_ZACC
             | U.HIL_SENSOR_UPDATED_XGYRO | U.HIL_SENSOR_UPDATED_YGYRO | U.HIL_SENSOR_UPDATED_ZGYRO)
MAG_FLAGS = U.HIL_SENSOR_UPDATED_XMAG | U.HIL_SENSOR_UPDATED_YMAG | U.HIL_SENSOR_UPDATED_ZMAG
BARO_FLAGS = (U.HIL_SENSOR_UPDATED_ABS_PRESSURE | U.HIL_SENSOR_UPDATED_PRESSURE_ALT
              | U.HIL_SENSOR_UPDATED_TEMPERATURE)
DIFF_FLAG = U.HIL_SENSOR_UPDATED_DIFF_PRESSURE
RHO0 = 1.225  # sea-level density for indicated airspeed [kg/m^3]

SIM_SYSTEM_ID = 1
SIM_COMPONENT_ID = U.MAV_COMP_ID_USER1  # the simulator's identity on the HIL link


ID_SENSOR = MAV.MAVLINK_MSG_ID_HIL_SENSOR
ID_GPS = MAV.MAVLINK_MSG_ID_HIL_GPS
ID_STATE = MAV.MAVLINK_MSG_ID_HIL_STATE_QUATERNION
ID_ACTUATORS = MAV.MAVLINK_MSG_ID_HIL_ACTUATOR_CONTROLS
ID_DISTANCE = MAV.MAVLINK_MSG_ID_DISTANCE_SENSOR
ID_ESC = MAV.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4
HIL_IDS = frozenset({ID_SENSOR, ID_GPS, ID_STATE, ID_ACTUATORS, ID_DISTANCE, ID_ESC})
# The lockstep messages travel through the codec's flat fast path: field values, arrays
# flattened, packed with one struct call each (the payload's own order, Codec.frame; or
# the declared order, Codec.encode_values) and received in the payload's own order by
# each message id's handler (Codec.dispatch with the end's Routes: no reordering).
# The two orders agree for the first three of these and differ for the last three:
#   HIL_SENSOR:  time_usec, xacc, yacc, zacc, xgyro, ygyro, zgyro, xmag, ymag, zmag,
#                abs_pressure, diff_pressure, pressure_alt, temperature, fields_updated, id
#   HIL_STATE_QUATERNION: time_usec, q[4], rollspeed, pitchspeed, yawspeed, lat, lon,
#                alt, vx, vy, vz, ind_airspeed, true_airspeed, xacc, yacc, zacc
#   DISTANCE_SENSOR: time_boot_ms, min_distance, max_distance, current_distance, type, id,
#                orientation, covariance, horizontal_fov, vertical_fov, quaternion[4],
#                signal_quality
#   HIL_GPS      declared: time_usec, fix_type, lat, lon, alt, eph, epv, vel, vn, ve, vd,
#                cog, satellites_visible, id, yaw
#                wire: time_usec, lat, lon, alt, eph, epv, vel, vn, ve, vd, cog, fix_type,
#                satellites_visible, id, yaw
#   HIL_ACTUATOR_CONTROLS declared: time_usec, controls[16], mode, flags
#                wire: time_usec, flags, controls[16], mode
#   ESC_TELEMETRY_1_TO_4 declared: temperature[4], voltage[4], current[4], totalcurrent[4],
#                rpm[4], count[4]
#                wire: voltage[4], current[4], totalcurrent[4], rpm[4], count[4],
#                temperature[4]
ESC_RPM = 12          # ESC 1's rpm in ESC_TELEMETRY_1_TO_4's wire-order values
# (the codec hands integer fields as ints and float fields as floats: no conversion)


_MG_TO_MS2 = 9.80665e-3

# The records' constructors under module names: Python 3.11 compiles ``Cls.make(...)`` of
# an imported class as an attribute load it never specialises (about 180 instructions a
# call more than a global's load).
_imu_sample, _mag_sample, _baro_sample, _airspeed_sample, _rpm_sample, _range_sample = (
    ImuSample.make, MagSample.make, BaroSample.make, AirspeedSample.make, RpmSample.make,
    RangeSample.make)
_sensor_frame, _gps_fix = SensorFrame.make, GpsFix.make


class TruthSample:
    """Truth from HIL_STATE_QUATERNION, in SI (for logging and scoring only). The
    vectors are tuples of floats: the flight log reads them element by element, and
    ``--nav truth`` makes its own arrays of them (autopilot/vehicle_base.py)."""

    __slots__ = ("t_us", "q_nb", "omega_b", "lat_rad", "lon_rad", "alt_m", "v_ned",
                 "airspeed_mps", "f_b")

    def __init__(self, v):
        # (one unpacking of the payload's values: cheaper than slicing out the vectors)
        self.t_us, qw, qx, qy, qz, p, q, r, lat, lon, alt, vn, ve, vd, _, tas, ax, ay, az = v
        self.q_nb = (qw, qx, qy, qz)
        self.omega_b = (p, q, r)
        self.lat_rad = lat / RAD_TO_E7
        self.lon_rad = lon / RAD_TO_E7
        self.alt_m = alt * 1e-3
        self.v_ned = (vn * 0.01, ve * 0.01, vd * 0.01)
        self.airspeed_mps = tas * 0.01
        self.f_b = (ax * _MG_TO_MS2, ay * _MG_TO_MS2, az * _MG_TO_MS2)


def range_sample_from(v) -> RangeSample:
    """DISTANCE_SENSOR values -> RangeSample in SI (time from ``time_boot_ms``)."""
    return _range_sample(v[0] * 1000, v[3] * 0.01, v[1] * 0.01, v[2] * 0.01, v[6], v[14])


def gps_fix_from(v) -> GpsFix:
    """HIL_GPS values (wire order) -> GpsFix in SI."""
    return _gps_fix(v[0], v[1] / RAD_TO_E7, v[2] / RAD_TO_E7, v[3] * 1e-3,
                    np.array((v[7] * 0.01, v[8] * 0.01, v[9] * 0.01)), v[4] * 0.01, v[5] * 0.01,
                    v[11], v[12])


class AutopilotHilEnd:
    """The autopilot's end of the lockstep link: turns bytes into SensorFrames and
    answers each one with HIL_ACTUATOR_CONTROLS.

    ``poll()`` returns the new steps to run as ``(SensorFrame, TruthSample | None)``;
    after running one, call ``answer(outputs)``. The simulator's battery (BATTERY_STATUS,
    1 Hz) is kept as ``self.battery``; ``relay_command`` sends a COMMAND_LONG (fault
    injection from a ground station) and ``take_command_acks`` returns the simulator's
    COMMAND_ACKs. Other messages from the simulator are kept in ``self.other``.
    """

    def __init__(self, transport, codec: Codec | None = None):
        self.transport = transport
        self.codec = codec or Codec(1, MAV.MAV_COMP_ID_AUTOPILOT1)
        self._gps: GpsFix | None = None
        self._truth: TruthSample | None = None
        self._range: RangeSample | None = None
        self._esc = None                 # ESC_TELEMETRY_1_TO_4's values, for the next step
        self._last_t_us: int | None = None
        self._last_answer: bytes | None = None
        self.duplicates = 0
        self.other: list = []
        self.acks: list = []
        self.battery = None
        self._steps: list = []
        self._routes = Routes({ID_SENSOR: self._on_sensor, ID_STATE: self._on_state, ID_GPS: self._on_gps,
                               ID_DISTANCE: self._on_range, ID_ESC: self._on_esc,
                               ID_ACTUATORS: self._on_actuators})

    def poll(self, timeout_s: float = 0.0) -> list[tuple[SensorFrame, TruthSample | None]]:
        data = self.transport.recv(timeout_s)
        if not data:
            return []
        self._steps = steps = []        # (_on_sensor appends the new steps)
        for msg in self.codec.dispatch(data, self._routes):   # not a lockstep message
            kind = msg.get_type()
            if kind == "BATTERY_STATUS":
                self.battery = msg
            elif kind == "COMMAND_ACK":
                self.acks.append(msg)
            else:
                self.other.append(msg)
        return steps

    # --- the lockstep messages' handlers (values in the payload's own order) ----------
    def _on_sensor(self, v) -> None:
        """HIL_SENSOR's values (+ the pending HIL_GPS, DISTANCE_SENSOR and
        ESC_TELEMETRY_1_TO_4) -> the step's SensorFrame in SI, built here (not by a
        function this one would only pass the values to)."""
        t_us, ax, ay, az, gx, gy, gz, mx, my, mz, p_hpa, dp_hpa, alt_m, temp_c, flags, _ = v
        last = self._last_t_us
        if t_us == last:
            # the simulator did not get our answer: repeat it, do not re-run
            self.duplicates += 1
            if self._last_answer is not None:
                self.transport.send(self._last_answer)
            return
        if last is not None and t_us < last:
            return  # stale (late duplicate of an older step)
        truth = self._truth
        if truth is not None and truth.t_us != t_us:
            truth = None
        imu = _imu_sample(t_us, (ax, ay, az), (gx, gy, gz))   # (the readers take the vectors' floats)
        mag = _mag_sample(t_us, (mx, my, mz)) if flags & MAG_FLAGS else None
        baro = _baro_sample(t_us, p_hpa * 100.0, alt_m, temp_c + 273.15) if flags & BARO_FLAGS else None
        air = None
        if flags & DIFF_FLAG:
            dp_pa = dp_hpa * 100.0
            q = 2.0 * dp_pa / RHO0
            air = _airspeed_sample(t_us, dp_pa, math.sqrt(q if q > 0.0 else 0.0))   # (max(0, q) spelt out)
        esc = self._esc
        rpm = None if esc is None else _rpm_sample(t_us, float(esc[ESC_RPM]))
        self._steps.append((_sensor_frame(t_us, imu, mag, baro, air, self._gps, self._range, rpm), truth))
        self._gps = None
        self._range = None
        self._esc = None
        self._last_t_us = t_us

    def _on_state(self, v) -> None:
        self._truth = TruthSample(v)

    def _on_gps(self, v) -> None:
        self._gps = gps_fix_from(v)

    def _on_range(self, v) -> None:
        self._range = range_sample_from(v)

    def _on_esc(self, v) -> None:
        self._esc = v

    def _on_actuators(self, v) -> None:
        """Our own message (a looped-back link): not for us."""

    def relay_command(self, command: int, params) -> None:
        """COMMAND_LONG to the simulator (MAV_CMD_INJECT_FAILURE from a ground station)."""
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        self.transport.send(self.codec.encode(MAV.MAVLink_command_long_message(
            SIM_SYSTEM_ID, SIM_COMPONENT_ID, command, 0, *p[:7])))

    def take_command_acks(self) -> list:
        acks, self.acks = self.acks, []
        return acks

    def answer(self, outputs: ActuatorOutputs) -> None:
        c = outputs.controls
        buf = self.codec.frame(ID_ACTUATORS, _ACTUATORS[len(c)].pack(outputs.t_us, *c,
                                                                    _ARMED if outputs.armed else 0))
        self._last_answer = buf
        self.transport.send(buf)


# HIL_ACTUATOR_CONTROLS's payload (wire order: time_usec, flags, controls[16], mode) packed
# from k given controls: flags and the 16 - k controls after them 0, as pad bytes
_ACTUATORS = tuple(struct.Struct(f"<Q8x{k}f{4 * (16 - k)}xB") for k in range(17))
_ARMED = MAV.MAV_MODE_FLAG_SAFETY_ARMED
