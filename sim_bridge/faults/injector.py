"""Sensor and actuator fault models between the sensor suite / controls and the HIL link.

``FaultInjector.apply(readings)`` transforms each step's SensorReadings;
``FaultInjector.apply_controls(controls)`` transforms the actuator command tuple
(HIL_ACTUATOR_CONTROLS order: aileron, elevator, rudder, throttle for the plane).
With no fault active both return their input unchanged (one branch per call).

Behaviour per failure type (an "update" is every step for the IMU, and a step whose
``*_updated`` flag is True for baro / mag / airspeed, or a delivered fix for the GPS):

* ``off``: baro / mag / airspeed stop updating (flag False, last good value held);
  gyro / accel read exactly zero on all axes every step (a dead IMU on a live bus: the
  HIL_SENSOR record has no per-IMU update flag, and all-zero specific force is what a
  failed part delivers); the GPS delivers no fixes at all (as PX4 SITL, which stops
  sending HIL_GPS).
* ``stuck``: updates keep coming at the normal rate, with the value held from the last
  output before the fault.
* ``garbage``: extra white noise on each update so the total std is ``noise_scale``
  times the sensor's nominal std (for the GPS: position ``noise_scale``, velocity
  ``vel_noise_scale``, by default the same; the reported eph/epv stay nominal: the
  receiver does not know).
* ``wrong``: a constant ``bias`` (see catalogue for units; ``axis`` selects one body axis
  of gyro / accel / mag, default all); GPS position offset ``north_m`` / ``east_m``
  (``offset_m`` adds to north).
* ``slow``: only every ``rate_div``-th update passes; the others are held (flag False).
* ``delayed``: updates come out ``delay_s`` late; until the delay line has filled, the
  value at the onset is held.
* ``intermittent``: each update is dropped with probability ``drop_prob`` (held, flag
  False; a dropped GPS fix is simply missing).
* actuators: servo (instance = control channel) ``off`` = surface at neutral (0),
  ``stuck`` = held at ``value_rad`` / 0.35 rad (clipped to +-1), or at the normalised
  ``value`` (the throttle's natural unit), or, without either,
  at the command of the step before the fault, ``wrong`` = loss of effectiveness
  (command x ``effectiveness``; for a thrust-scaled motor, see ``thrust_motors``, the
  thrust x ``effectiveness``); motor (instance = index into ``motor_channels``)
  ``off`` = 0, ``stuck`` = held, ``wrong`` = thrust command x ``effectiveness``.
* ``ok`` clears the fault of that unit (for servo / motor: of that instance).

Every random draw (garbage noise, intermittent drops) comes from the injected
Generator, in step order, so a seed reproduces a run.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from autopilot.geo import meridian_radius, prime_vertical_radius

from ..sensors import isa
from ..sensors.params import SensorParams
from ..sensors.readings import GpsReading, SensorReadings
from .catalogue import (
    MAX_DEFLECTION_RAD, SUPPORTED, TYPES, UNITS, FaultSpecError, check_magnitudes,
    type_name, unit_name,
)

_GROUP_FIELDS = {
    "accel": ("accel_b",),
    "gyro": ("gyro_b",),
    "mag": ("mag_b_gauss",),
    "baro": ("pressure_pa", "pressure_alt_m", "temperature_k"),
    "airspeed": ("diff_pressure_pa", "airspeed_mps"),
}
_GROUP_FLAG = {"accel": None, "gyro": None, "mag": "mag_updated",
               "baro": "baro_updated", "airspeed": "airspeed_updated"}
_ZERO3 = (0.0, 0.0, 0.0)


def _frozen(a: np.ndarray) -> tuple:
    """A vector worked out as an array, as the readings hold it (readings.py)."""
    return tuple(a.tolist())


@dataclass
class ActiveFault:
    """One active fault and its running state."""

    unit: str
    type: str
    instance: int
    magnitudes: dict
    held: object = None                       # last output values of the group
    count: int = 0                            # updates seen (slow)
    queue: deque = field(default_factory=deque)  # (t_us, values, updated) (delayed)


class FaultInjector:
    """Applies the active sensor and actuator faults (see the module doc)."""

    def __init__(self, rng: np.random.Generator, params: SensorParams | None = None,
                 dt_s: float = 0.01, motor_channels: tuple[int, ...] = (3,),
                 thrust_motors: bool = False):
        """``params`` / ``dt_s`` must be those of the SensorSuite (garbage noise is
        scaled from its nominal noise); ``motor_channels`` are the control-vector
        indices of motor instances 0, 1, ... (plane: throttle, channel 3).
        ``thrust_motors``: a motor ``wrong`` fault scales the rotor's thrust
        (:meth:`motor_thrust_scales`, applied by the plant) instead of its command
        (the quadrotor: "thrust reduced to 70 %" is 70 % of the thrust at any command)."""
        if params is None:
            params = SensorParams()
        if dt_s <= 0.0:
            raise ValueError("dt_s must be > 0")
        self.params = params
        self._rng = rng
        self.dt_s = float(dt_s)
        self.motor_channels = tuple(motor_channels)
        self.thrust_motors = bool(thrust_motors)
        sq = math.sqrt(self.dt_s)
        self._nominal_sigma = {
            "accel": params.accel_noise_density / sq,
            "gyro": params.gyro_noise_density / sq,
            "mag": params.mag_noise_sigma_gauss,
            "baro": params.baro_noise_sigma_pa,
            "airspeed": params.airspeed_noise_sigma_pa,
        }
        self._sensor_faults: dict[str, ActiveFault] = {}
        self._gps_fault: ActiveFault | None = None
        self._actuator_faults: dict[int, ActiveFault] = {}  # control channel -> fault
        # actuator faults started or cleared so far: what follows them (a plant's
        # thrust scales, ``motor_thrust_scales``) is redone when this count moves
        self.actuator_changes = 0
        self._last: SensorReadings | None = None
        self._last_gps: GpsReading | None = None
        self._last_controls: tuple = ()

    # --- commands ------------------------------------------------------------------

    def inject(self, unit: int | str, type: int | str, instance: int = 0,
               **magnitudes) -> bool:
        """Start (or with type ``ok`` clear) a fault. False = unsupported combination.

        ``unit`` / ``type`` are FAILURE_UNIT / FAILURE_TYPE numbers or their names.
        Sensors have one instance: 0 (MAVLink's "all") or 1. A bad magnitude raises
        FaultSpecError (a ValueError).
        """
        try:
            u, t = unit_name(unit), type_name(type)
        except FaultSpecError:
            return False
        if t not in SUPPORTED.get(u, {}):
            return False
        mags = check_magnitudes(u, t, magnitudes)
        instance = int(instance)
        if u in ("servo", "motor"):
            return self._inject_actuator(u, t, instance, mags)
        if instance not in (0, 1):
            return False
        if u == "gps":
            if t == "ok":
                self._gps_fault = None
            else:
                self._gps_fault = ActiveFault(u, t, instance, mags, held=self._last_gps)
            return True
        if t == "ok":
            self._sensor_faults.pop(u, None)
            return True
        held = (tuple(getattr(self._last, f) for f in _GROUP_FIELDS[u])
                if self._last is not None else None)
        self._sensor_faults[u] = ActiveFault(u, t, instance, mags, held=held)
        return True

    def _inject_actuator(self, u: str, t: str, instance: int, mags: dict) -> bool:
        if u == "servo":
            if not 0 <= instance < 16:
                return False
            channel = instance
        else:
            if not 0 <= instance < len(self.motor_channels):
                return False
            channel = self.motor_channels[instance]
        self.actuator_changes += 1
        if t == "ok":
            self._actuator_faults.pop(channel, None)
            return True
        held = None
        if t == "stuck":
            if u == "servo" and mags.get("value") is not None:
                held = float(mags["value"])
            elif u == "servo" and mags.get("value_rad") is not None:
                held = max(-1.0, min(1.0, mags["value_rad"] / MAX_DEFLECTION_RAD))
            elif channel < len(self._last_controls):
                held = float(self._last_controls[channel])
        self._actuator_faults[channel] = ActiveFault(u, t, instance, mags, held=held)
        return True

    def held_position(self, unit, instance: int) -> float | None:
        """Where a stuck servo or motor of ``instance`` is held (normalised command), or
        None (no such fault, or held at a command not yet seen)."""
        u = unit_name(unit)
        if u == "servo":
            channel = instance
        elif u == "motor" and 0 <= instance < len(self.motor_channels):
            channel = self.motor_channels[instance]
        else:
            return None
        f = self._actuator_faults.get(channel)
        return None if f is None or f.type != "stuck" else f.held

    def clear_all(self) -> None:
        self._sensor_faults.clear()
        self._gps_fault = None
        self._actuator_faults.clear()
        self.actuator_changes += 1

    @property
    def active(self) -> list[tuple[int, int, int, dict]]:
        """Active faults as (FAILURE_UNIT, FAILURE_TYPE, instance, magnitudes)."""
        faults = list(self._sensor_faults.values())
        if self._gps_fault is not None:
            faults.append(self._gps_fault)
        faults += list(self._actuator_faults.values())
        return [(UNITS[f.unit], TYPES[f.type], f.instance, dict(f.magnitudes)) for f in faults]

    # --- sensors -----------------------------------------------------------------

    def apply(self, readings: SensorReadings) -> SensorReadings:
        """The readings as the faulty sensors deliver them."""
        if not self._sensor_faults and self._gps_fault is None:
            self._last = readings
            if readings.gps is not None:
                self._last_gps = readings.gps
            return readings
        changes: dict = {}
        for fault in self._sensor_faults.values():
            self._apply_sensor(fault, readings, changes)
        if self._gps_fault is not None:
            changes["gps"] = self._apply_gps(self._gps_fault, readings)
        out = replace(readings, **changes)
        self._last = out
        if out.gps is not None:
            self._last_gps = out.gps
        return out

    def _apply_sensor(self, f: ActiveFault, r: SensorReadings, changes: dict) -> None:
        names = _GROUP_FIELDS[f.unit]
        flag = _GROUP_FLAG[f.unit]
        values = tuple(getattr(r, n) for n in names)
        updated = True if flag is None else getattr(r, flag)
        if f.held is None:
            f.held = values
        t, m = f.type, f.magnitudes

        if t == "off":
            if flag is None:
                values = tuple(_ZERO3 for _ in names)
            else:
                values, updated = f.held, False
        elif t == "stuck":
            values = f.held
        elif t in ("garbage", "wrong"):
            if updated:
                values = (self._garbage(f.unit, values, m["noise_scale"]) if t == "garbage"
                          else self._wrong(f.unit, values, m))
                f.held = values
            else:
                values = f.held
        elif t == "slow":
            if updated:
                f.count += 1
                if (f.count - 1) % m["rate_div"] == 0:
                    f.held = values
                else:
                    updated = False
            values = f.held
        elif t == "intermittent":
            if updated and self._rng.random() < m["drop_prob"]:
                updated = False
            if updated:
                f.held = values
            values = f.held
        elif t == "delayed":
            f.queue.append((r.t_us, values, updated))
            target = r.t_us - int(round(m["delay_s"] * 1e6))
            out_updated = False
            while f.queue and f.queue[0][0] <= target:
                _, v, u = f.queue.popleft()
                if u:
                    f.held, out_updated = v, True
            values, updated = f.held, out_updated
        for n, v in zip(names, values):
            changes[n] = v
        if flag is not None:
            changes[flag] = updated

    def _garbage(self, unit: str, values: tuple, noise_scale: float) -> tuple:
        k = math.sqrt(noise_scale * noise_scale - 1.0) * self._nominal_sigma[unit]
        if unit in ("accel", "gyro", "mag"):
            return (_frozen(values[0] + k * self._rng.standard_normal(3)),)
        if unit == "baro":
            p = values[0] + k * self._rng.standard_normal()
            return (p, isa.pressure_altitude_m(p), values[2])
        dp = values[0] + k * self._rng.standard_normal()   # airspeed
        return (dp, math.sqrt(2.0 * dp / isa.RHO0_KGM3) if dp > 0.0 else 0.0)

    @staticmethod
    def _wrong(unit: str, values: tuple, m: dict) -> tuple:
        bias = m["bias"]
        if unit in ("accel", "gyro", "mag"):
            v = np.array(values[0], dtype=float)
            if m["axis"] is None:
                v += bias
            else:
                v[m["axis"]] += bias
            return (_frozen(v),)
        if unit == "baro":   # bias in metres of altitude
            alt = isa.pressure_altitude_m(values[0]) + bias
            return (isa.pressure_pa(alt), alt, values[2])
        dp = values[0] + bias  # airspeed: Pa of differential pressure
        return (dp, math.sqrt(2.0 * dp / isa.RHO0_KGM3) if dp > 0.0 else 0.0)

    def _apply_gps(self, f: ActiveFault, r: SensorReadings) -> GpsReading | None:
        fix = r.gps
        t, m = f.type, f.magnitudes
        if t == "off":
            return None
        if t == "delayed":
            if fix is not None:
                f.queue.append((r.t_us + int(round(m["delay_s"] * 1e6)), fix))
            if f.queue and f.queue[0][0] <= r.t_us:
                return replace(f.queue.popleft()[1], t_us=r.t_us)
            return None
        if fix is None:
            return None
        if t == "stuck":
            if f.held is None:
                f.held = fix
            return replace(f.held, t_us=r.t_us)
        if t == "slow":
            f.count += 1
            return fix if (f.count - 1) % m["rate_div"] == 0 else None
        if t == "intermittent":
            return None if self._rng.random() < m["drop_prob"] else fix
        if t == "garbage":
            p = self.params
            k = math.sqrt(m["noise_scale"] ** 2 - 1.0)
            kv = math.sqrt(m["vel_noise_scale"] ** 2 - 1.0)
            n = self._rng.standard_normal(6)
            sh = k * math.hypot(p.gps_pos_gm_sigma_h, p.gps_pos_white_sigma_h)
            sv = k * math.hypot(p.gps_pos_gm_sigma_v, p.gps_pos_white_sigma_v)
            v_ned = fix.v_ned + kv * np.array(
                (p.gps_vel_sigma_h * n[3], p.gps_vel_sigma_h * n[4], p.gps_vel_sigma_v * n[5]))
            return self._shift(fix, sh * n[0], sh * n[1], sv * n[2], _frozen(v_ned))
        # wrong
        return self._shift(fix, m["north_m"] + m["offset_m"], m["east_m"], 0.0, fix.v_ned)

    @staticmethod
    def _shift(fix: GpsReading, dn: float, de: float, dd: float, v_ned) -> GpsReading:
        lat, alt = fix.lat_rad, fix.alt_m
        return replace(
            fix,
            lat_rad=lat + dn / (meridian_radius(lat) + alt),
            lon_rad=fix.lon_rad + de / ((prime_vertical_radius(lat) + alt) * math.cos(lat)),
            alt_m=alt - dd, v_ned=v_ned)

    # --- actuators -----------------------------------------------------------------

    def motor_thrust_scales(self, n: int) -> tuple[float, ...]:
        """Thrust multiplier of control channels 0..n-1: the ``effectiveness`` of a motor
        ``wrong`` fault when ``thrust_motors``, else 1."""
        if not self.thrust_motors or not self._actuator_faults:
            return (1.0,) * n
        return tuple(f.magnitudes["effectiveness"]
                     if (f := self._actuator_faults.get(ch)) is not None and f.unit == "motor"
                     and f.type == "wrong" else 1.0 for ch in range(n))

    def apply_controls(self, controls: tuple) -> tuple:
        """The actuator commands as the faulty actuators execute them."""
        if not self._actuator_faults:
            self._last_controls = controls
            return controls
        out = list(controls)
        for ch, f in self._actuator_faults.items():
            if ch >= len(out):
                continue
            if f.type == "off":
                out[ch] = 0.0
            elif f.type == "wrong":
                if not (self.thrust_motors and f.unit == "motor"):
                    out[ch] = out[ch] * f.magnitudes["effectiveness"]
            elif f.type == "stuck":
                if f.held is None:
                    f.held = (float(self._last_controls[ch])
                              if ch < len(self._last_controls) else float(out[ch]))
                out[ch] = f.held
        out = tuple(out)
        self._last_controls = out
        return out
