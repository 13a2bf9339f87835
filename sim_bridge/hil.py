"""The simulator's end of the PX4 HIL lockstep link (see ``autopilot/link/hil.py`` for
the exchange). Packs sensor readings and truth into HIL_GPS, HIL_STATE_QUATERNION,
DISTANCE_SENSOR (a rangefinder reading), ESC_TELEMETRY_1_TO_4 (the propeller's rpm) and
HIL_SENSOR, and waits for the
HIL_ACTUATOR_CONTROLS that answers the step.

Truth: HIL_STATE_QUATERNION goes out every ``truth_div``-th step (1: every step, the
default, which ``--nav truth`` needs) and with every HIL_GPS; ``truth_div = 0``: never
(a run that scores from the plant itself). It is for logging and
scoring only, and the autopilot's flight log takes its rows on the steps that bring it
(``autopilot.log.flightlog.RowSchedule``), so a headless run sets ``truth_div`` to the
log's step divisor and encodes no truth the log would not keep.

Lost or late answers: the simulator waits ``answer_timeout_s`` (wall time) for the
answer whose ``time_usec`` matches the step; stale answers (older time) are dropped. On
a timeout it sends the same HIL_SENSOR again (the autopilot repeats its answer without
re-running its loop), up to ``retries`` times; after that it advances holding the last
controls and counts a ``missed`` step, so a dead autopilot cannot hang the simulator.
"""
from __future__ import annotations

import math
import struct
import time
from functools import lru_cache
from math import ceil, floor

from autopilot.jit import kernel
from autopilot.link.codec import MAV, Codec, Routes
from autopilot.link.hil import (BARO_FLAGS, DIFF_FLAG, HIL_IDS, ID_ACTUATORS, ID_DISTANCE,
                                ID_ESC, ID_GPS, ID_SENSOR, ID_STATE, IMU_FLAGS, MAG_FLAGS, RAD_TO_E7,
                                SIM_COMPONENT_ID, SIM_SYSTEM_ID)

G0 = 9.80665


MG_PER_MS2 = 1000.0 / G0
_ARMED = MAV.MAV_MODE_FLAG_SAFETY_ARMED
# the payloads packed straight from the values (the messages' own layouts; one call each)
_SENSOR = MAV.mavlink_map[ID_SENSOR].unpacker.pack
_STATE = MAV.mavlink_map[ID_STATE].unpacker.pack


@kernel
def round_sat(v, lo, hi):
    """``v`` rounded half away from zero and saturated to the field's range [lo, hi]
    (integers, given as floats). Saturated first: for integer bounds the same result,
    and no float beyond the field's integers (an infinity) is ever converted. A NaN has
    no integer: refused (compiled, its conversion would give an out-of-range one)."""
    if v != v:
        raise ValueError("NaN in a MAVLink integer field")
    v = lo if v < lo else (hi if v > hi else v)
    return floor(v + 0.5) if v >= 0.0 else ceil(v - 0.5)


# one value at a time, interpreted: a kernel call costs more than the work
_round_sat = round_sat.py_func


@kernel
def truth_ints(lat_rad, lon_rad, alt_m, vn, ve, vd, airspeed_mps, rho_kgm3, fx, fy, fz):
    """HIL_STATE_QUATERNION's integer fields of a PlantState, in the message's order:
    lat, lon [degE7], alt [mm], vx, vy, vz [cm/s], ind_airspeed (from the true airspeed
    and the density), true_airspeed [cm/s], xacc, yacc, zacc [mG]."""
    ias = airspeed_mps * math.sqrt(rho_kgm3 / 1.225)
    return (round_sat(lat_rad * RAD_TO_E7, -900000000.0, 900000000.0),
            round_sat(lon_rad * RAD_TO_E7, -1800000000.0, 1800000000.0),
            round_sat(alt_m * 1000.0, -2147483648.0, 2147483647.0),
            round_sat(vn * 100.0, -32767.0, 32767.0), round_sat(ve * 100.0, -32767.0, 32767.0),
            round_sat(vd * 100.0, -32767.0, 32767.0),
            round_sat(ias * 100.0, 0.0, 65535.0), round_sat(airspeed_mps * 100.0, 0.0, 65535.0),
            round_sat(fx * MG_PER_MS2, -32767.0, 32767.0), round_sat(fy * MG_PER_MS2, -32767.0, 32767.0),
            round_sat(fz * MG_PER_MS2, -32767.0, 32767.0))


@lru_cache(maxsize=4)
def _range_fields(min_m: float, max_m: float, noise_sigma_m: float) -> tuple:
    """DISTANCE_SENSOR's fields a sensor fixes (min_distance, max_distance [cm], the
    variance [cm^2]): the same at every reading, worked out once per sensor."""
    return (_round_sat(min_m * 100.0, 0.0, 65534.0), _round_sat(max_m * 100.0, 0.0, 65534.0),
            _round_sat((noise_sigma_m * 100.0) ** 2, 0.0, 254.0))


# DISTANCE_SENSOR's payload (autopilot/link/hil.py: the field order) packed from the
# fields a reading sets: time_boot_ms, min/max/current distance, type, orientation,
# covariance and signal_quality; the id, the fovs and the quaternion 0, as pad bytes
_DISTANCE = struct.Struct("<IHHHBxBB24xB").pack
_LASER, _DOWNWARD = MAV.MAV_DISTANCE_SENSOR_LASER, MAV.MAV_SENSOR_ROTATION_PITCH_270


def distance_sensor_payload(reading) -> bytes:
    """DISTANCE_SENSOR's payload (autopilot/link/hil.py: the out-of-range convention) of
    a ``sim_bridge.sensors.rangefinder.RangeReading``."""
    lo, hi, var = _range_fields(reading.min_m, reading.max_m, reading.noise_sigma_m)
    if reading.distance_m is None:
        cur, quality = hi + 1, 1                    # no return: over range, invalid signal
    else:
        cur, quality = _round_sat(reading.distance_m * 100.0, 0.0, hi), 100
    return _DISTANCE(reading.t_us // 1000, lo, hi, cur, _LASER, _DOWNWARD, var, quality)


# ESC_TELEMETRY_1_TO_4's payload (wire order: voltage[4], current[4], totalcurrent[4],
# rpm[4], count[4], temperature[4]) packed from ESC 1's rpm and count; the rest 0 (not
# measured), as pad bytes
_ESC = struct.Struct("<24xH6xH6x4x").pack


def esc_telemetry_payload(reading, count: int) -> bytes:
    """ESC_TELEMETRY_1_TO_4's payload of a ``sim_bridge.sensors.rpm.RpmReading``: ESC 1's
    rpm (rounded, saturated to the field's uint16) and its rolling frame ``count``."""
    return _ESC(_round_sat(reading.rpm, 0.0, 65535.0), count & 0xFFFF)


class SimulatorHilEnd:
    def __init__(self, transport, codec: Codec | None = None, answer_timeout_s: float = 1.0,
                 retries: int = 3):
        self.transport = transport
        self.codec = codec or Codec(SIM_SYSTEM_ID, SIM_COMPONENT_ID)
        self.answer_timeout_s = answer_timeout_s
        self.retries = retries
        self._sensor_buf: bytes = b""
        self.missed = 0
        self.retried = 0
        self.stale = 0
        self.commands: list = []   # COMMAND_LONG from the autopilot (fault relay)
        self.armed = False
        self.truth_div = 1         # HIL_STATE_QUATERNION every truth_div-th step (and with GPS); 0 never
        self._steps_sent = 0
        self._esc_count = 0        # ESC_TELEMETRY_1_TO_4 frames sent (its ``count``)
        self._asked_t_us = None    # poll_answer's step, and its answer when it came
        self._answer = None
        self._routes = Routes({i: self._on_actuators if i == ID_ACTUATORS else self._on_other
                               for i in HIL_IDS})

    # --- sending ---------------------------------------------------------------------
    def send_step(self, readings, truth, range_reading=None, rpm_reading=None) -> None:
        """HIL_GPS (if a fix arrives), HIL_STATE_QUATERNION (module docstring: truth),
        DISTANCE_SENSOR (if ``range_reading``), ESC_TELEMETRY_1_TO_4 (if
        ``rpm_reading``), then HIL_SENSOR, in one write."""
        out = b""                 # the frames before HIL_SENSOR
        gps = readings.gps
        if gps is not None:
            vn, ve, vd = gps.v_ned
            vel = math.hypot(vn, ve)
            cog_cdeg = (math.degrees(math.atan2(ve, vn)) % 360.0) * 100.0
            out += self.codec.encode_values(ID_GPS, (
                gps.t_us, int(gps.fix_type),
                _round_sat(gps.lat_rad * RAD_TO_E7, -900000000.0, 900000000.0),
                _round_sat(gps.lon_rad * RAD_TO_E7, -1800000000.0, 1800000000.0),
                _round_sat(gps.alt_m * 1000.0, -2147483648.0, 2147483647.0),
                _round_sat(gps.eph_m * 100.0, 0.0, 65534.0), _round_sat(gps.epv_m * 100.0, 0.0, 65534.0),
                _round_sat(vel * 100.0, 0.0, 65534.0),
                _round_sat(vn * 100.0, -32767.0, 32767.0), _round_sat(ve * 100.0, -32767.0, 32767.0),
                _round_sat(vd * 100.0, -32767.0, 32767.0),
                _round_sat(cog_cdeg, 0.0, 35999.0), int(gps.satellites), 0, 0))
        self._steps_sent = k = self._steps_sent + 1
        div = self.truth_div
        if div == 1 or (div > 1 and (gps is not None or k % div == 0)):
            out += self._truth_message(truth)
        if range_reading is not None:
            out += self.codec.frame(ID_DISTANCE, distance_sensor_payload(range_reading))
        if rpm_reading is not None:
            self._esc_count += 1
            out += self.codec.frame(ID_ESC, esc_telemetry_payload(rpm_reading, self._esc_count))
        flags = IMU_FLAGS
        if readings.mag_updated:
            flags |= MAG_FLAGS
        if readings.baro_updated:
            flags |= BARO_FLAGS
        if readings.airspeed_updated:
            flags |= DIFF_FLAG
        ax, ay, az = readings.accel_b
        gx, gy, gz = readings.gyro_b
        mx, my, mz = readings.mag_b_gauss
        self._sensor_buf = buf = self.codec.frame(ID_SENSOR, _SENSOR(
            readings.t_us, ax, ay, az, gx, gy, gz, mx, my, mz,
            readings.pressure_pa * 0.01, readings.diff_pressure_pa * 0.01,
            readings.pressure_alt_m, readings.temperature_k - 273.15, flags, 0))
        self.transport.send(out + buf)

    def _truth_message(self, truth) -> bytes:
        """HIL_STATE_QUATERNION of a PlantState."""
        qw, qx, qy, qz = truth.q_nb
        wx, wy, wz = truth.omega_b
        vn, ve, vd = truth.v_ned
        fx, fy, fz = truth.f_b
        return self.codec.frame(ID_STATE, _STATE(truth.t_us, qw, qx, qy, qz, wx, wy, wz, *truth_ints(
            truth.lat_rad, truth.lon_rad, truth.alt_m, vn, ve, vd, truth.airspeed_mps,
            truth.rho_kgm3, fx, fy, fz)))

    def send_battery(self, battery) -> None:
        """BATTERY_STATUS of the simulated pack (``sim_bridge.battery.Battery``)."""
        cells = [min(int(battery.voltage_v / battery.cells * 1000.0), 65534)] * battery.cells
        cells += [65535] * (10 - len(cells))
        self.transport.send(self.codec.encode(MAV.MAVLink_battery_status_message(
            0, MAV.MAV_BATTERY_FUNCTION_ALL, MAV.MAV_BATTERY_TYPE_LIPO, 32767, cells,
            min(int(battery.current_a * 100.0), 32767), int(battery.consumed_mah),
            int(battery.energy_j / 100.0), battery.remaining_pct, 0, MAV.MAV_BATTERY_CHARGE_STATE_OK,
            [0, 0, 0, 0], 0, 0)))

    def send_command_ack(self, command: int, result: int, target_system: int, target_component: int):
        mav = self.codec.mav
        self.transport.send(self.codec.encode(mav.command_ack_encode(
            command, result, 0, 0, target_system, target_component)))

    # --- receiving -------------------------------------------------------------------
    def poll_answer(self, t_us: int, timeout_s: float = 0.0):
        """Controls answering step ``t_us`` if they arrived (else None)."""
        data = self.transport.recv(timeout_s)
        if not data:
            return None
        self._asked_t_us = t_us
        self._answer = None
        for msg in self.codec.dispatch(data, self._routes):   # not a lockstep message
            if msg.get_type() == "COMMAND_LONG":
                self.commands.append(msg)
        return self._answer

    def _on_actuators(self, v) -> None:
        """HIL_ACTUATOR_CONTROLS (wire order: time_usec, flags, controls[16], mode)."""
        if v[0] == self._asked_t_us:
            self._answer = v[2:18]
            self.armed = (v[18] & _ARMED) != 0
        else:
            self.stale += 1

    def _on_other(self, v) -> None:
        """The autopilot's end of the link's messages (a looped-back link): not for us."""

    def wait_answer(self, t_us: int):
        """Block (wall time) for the answer to step ``t_us``, retrying; None if the
        autopilot stayed silent through every retry."""
        for attempt in range(self.retries + 1):
            if attempt:
                self.retried += 1
                self.transport.send(self._sensor_buf)
            deadline = time.monotonic() + self.answer_timeout_s
            while True:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                controls = self.poll_answer(t_us, remaining)
                if controls is not None:
                    return controls
        self.missed += 1
        return None
