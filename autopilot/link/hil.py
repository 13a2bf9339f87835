"""The PX4 simulator interface (HIL lockstep), wire format and the autopilot's end.

Exchange per lockstep step k (simulation time t_k), as PX4 SITL defines it
(docs.px4.io, "Simulation": the simulator MAVLink API):

    simulator -> autopilot   HIL_GPS (when a fix arrives), HIL_STATE_QUATERNION (truth,
                             for logging and scoring only), then HIL_SENSOR(t_k)
    autopilot -> simulator   HIL_ACTUATOR_CONTROLS(time_usec = t_k)
    simulator                advances the plant from t_k to t_k+1 with those controls

HIL_SENSOR closes the step: the autopilot runs one loop per HIL_SENSOR and answers it
with exactly one HIL_ACTUATOR_CONTROLS carrying the same ``time_usec``. A repeated
HIL_SENSOR (same time, the simulator retrying after a lost answer) is answered again
with the same controls without running the loop twice. Units on the wire are the
message definitions' (hPa, degC, 1e7 deg, mm, cm/s); they are converted to SI here and
nowhere else.
"""
from __future__ import annotations

import math

import numpy as np

from ..messages import (AirspeedSample, ActuatorOutputs, BaroSample, GpsFix, ImuSample,
                        MagSample, SensorFrame)
from .codec import MAV, Codec

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


class TruthSample:
    """Truth from HIL_STATE_QUATERNION, in SI (for logging and scoring only)."""

    __slots__ = ("t_us", "q_nb", "omega_b", "lat_rad", "lon_rad", "alt_m", "v_ned",
                 "airspeed_mps", "f_b")

    def __init__(self, msg):
        self.t_us = int(msg.time_usec)
        self.q_nb = np.array(msg.attitude_quaternion, dtype=float)
        self.omega_b = np.array([msg.rollspeed, msg.pitchspeed, msg.yawspeed])
        self.lat_rad = msg.lat / RAD_TO_E7
        self.lon_rad = msg.lon / RAD_TO_E7
        self.alt_m = msg.alt * 1e-3
        self.v_ned = np.array([msg.vx, msg.vy, msg.vz]) * 0.01
        self.airspeed_mps = msg.true_airspeed * 0.01
        self.f_b = np.array([msg.xacc, msg.yacc, msg.zacc]) * (9.80665e-3)


def sensor_frame_from(msg, mag_prev: MagSample | None, gps: GpsFix | None) -> SensorFrame:
    """HIL_SENSOR (+ a pending HIL_GPS) -> SensorFrame in SI."""
    t_us = int(msg.time_usec)
    flags = msg.fields_updated
    imu = ImuSample(t_us, np.array([msg.xacc, msg.yacc, msg.zacc]),
                    np.array([msg.xgyro, msg.ygyro, msg.zgyro]))
    mag = MagSample(t_us, np.array([msg.xmag, msg.ymag, msg.zmag])) if flags & MAG_FLAGS else None
    baro = (BaroSample(t_us, msg.abs_pressure * 100.0, float(msg.pressure_alt),
                       msg.temperature + 273.15) if flags & BARO_FLAGS else None)
    air = None
    if flags & DIFF_FLAG:
        dp_pa = msg.diff_pressure * 100.0
        air = AirspeedSample(t_us, dp_pa, math.sqrt(max(0.0, 2.0 * dp_pa / RHO0)))
    return SensorFrame(t_us, imu, mag, baro, air, gps)


def gps_fix_from(msg) -> GpsFix:
    v = np.array([msg.vn, msg.ve, msg.vd]) * 0.01
    return GpsFix(int(msg.time_usec), msg.lat / RAD_TO_E7, msg.lon / RAD_TO_E7, msg.alt * 1e-3,
                  v, msg.eph * 0.01, msg.epv * 0.01, int(msg.fix_type), int(msg.satellites_visible))


class AutopilotHilEnd:
    """The autopilot's end of the lockstep link: turns bytes into SensorFrames and
    answers each one with HIL_ACTUATOR_CONTROLS.

    ``poll()`` returns the new steps to run as ``(SensorFrame, TruthSample | None)``;
    after running one, call ``answer(outputs)``. Other messages from the simulator (for
    instance COMMAND_ACK of a relayed fault injection) are kept in ``self.other``.
    """

    def __init__(self, transport, codec: Codec | None = None):
        self.transport = transport
        self.codec = codec or Codec(1, MAV.MAV_COMP_ID_AUTOPILOT1)
        self._gps: GpsFix | None = None
        self._truth: TruthSample | None = None
        self._last_t_us: int | None = None
        self._last_answer: bytes | None = None
        self.duplicates = 0
        self.other: list = []

    def poll(self, timeout_s: float = 0.0) -> list[tuple[SensorFrame, TruthSample | None]]:
        steps = []
        data = self.transport.recv(timeout_s)
        for msg in self.codec.decode(data):
            mtype = msg.get_type()
            if mtype == "HIL_SENSOR":
                t_us = int(msg.time_usec)
                if t_us == self._last_t_us:
                    # the simulator did not get our answer: repeat it, do not re-run
                    self.duplicates += 1
                    if self._last_answer is not None:
                        self.transport.send(self._last_answer)
                    continue
                if self._last_t_us is not None and t_us < self._last_t_us:
                    continue  # stale (late duplicate of an older step)
                truth = self._truth if self._truth is not None and self._truth.t_us == t_us else None
                steps.append((sensor_frame_from(msg, None, self._gps), truth))
                self._gps = None
                self._last_t_us = t_us
            elif mtype == "HIL_GPS":
                self._gps = gps_fix_from(msg)
            elif mtype == "HIL_STATE_QUATERNION":
                self._truth = TruthSample(msg)
            else:
                self.other.append(msg)
        return steps

    def answer(self, outputs: ActuatorOutputs) -> None:
        controls = list(outputs.controls) + [0.0] * (16 - len(outputs.controls))
        mode = MAV.MAV_MODE_FLAG_SAFETY_ARMED if outputs.armed else 0
        msg = self.codec.mav.hil_actuator_controls_encode(outputs.t_us, controls, mode, 0)
        buf = self.codec.encode(msg)
        self._last_answer = buf
        self.transport.send(buf)
