"""Which faults exist, what they are called and which magnitudes each one takes.

Units and types are MAVLink's FAILURE_UNIT and FAILURE_TYPE (MAV_CMD_INJECT_FAILURE);
the numbers come from pymavlink's generated dialect, the names are the lower-case
suffixes (``FAILURE_UNIT_SENSOR_GPS`` -> ``gps``, ``FAILURE_TYPE_OFF`` -> ``off``).
This table is shared by the injector (``inject``) and the scenario loader, so a scenario
file is checked against exactly what the injector can do.

Magnitudes (all optional; the default applies when absent, as for a fault that
arrives over MAVLink, which carries none):

============  ==========================================  ===========================
key           meaning                                     default
============  ==========================================  ===========================
noise_scale   garbage: noise std becomes noise_scale x    10
              the sensor's nominal std (>= 1); for the
              GPS its position noise
vel_noise_    gps garbage: the same for the velocity      noise_scale
scale         noise (1: position noise only)
bias          wrong: constant offset; gyro rad/s, accel   gyro 0.1, accel 1.0,
              m/s^2, mag gauss, baro metres of altitude,  mag 0.2, baro 20,
              airspeed Pa of differential pressure        airspeed 50
axis          wrong (gyro/accel/mag): body axis "x",     all three axes
              "y", "z" or 0/1/2
rate_div      slow: only every rate_div-th update passes  5
delay_s       delayed: extra delay [s]                    0.5
drop_prob     intermittent: probability an update drops   0.5
offset_m      gps wrong: position offset to the north [m] (see north_m)
north_m       gps wrong: position offset north [m]        20 if no offset given
east_m        gps wrong: position offset east [m]         0
value_rad     servo stuck: surface deflection [rad],      the last command
              normalised by the 0.35 rad max deflection
value         servo stuck: the normalised command held    the last command
              (-1..1; the throttle, channel 3, 0..1);
              not with value_rad
effectiveness servo/motor wrong: command multiplier 0..1  0.5
============  ==========================================  ===========================
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as _mav


class FaultSpecError(ValueError):
    """A fault request that names an unknown unit/type or carries a bad magnitude.
    ``key`` is the offending magnitude key ("unit", "type", or a magnitude name)."""

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


def _suffix_names(enum_name: str, prefixes: tuple[str, ...]) -> dict[str, int]:
    names = {}
    for value, entry in _mav.enums[enum_name].items():
        if entry.name.endswith("_ENUM_END"):
            continue
        name = entry.name
        for prefix in prefixes:
            if name.startswith(prefix):
                name = name[len(prefix):]
                break
        names[name.lower()] = int(value)
    return names


# name -> MAVLink number, e.g. UNITS["gps"] == FAILURE_UNIT_SENSOR_GPS == 4
UNITS: dict[str, int] = _suffix_names(
    "FAILURE_UNIT", ("FAILURE_UNIT_SENSOR_", "FAILURE_UNIT_SYSTEM_"))
TYPES: dict[str, int] = _suffix_names("FAILURE_TYPE", ("FAILURE_TYPE_",))
UNIT_NAMES: dict[int, str] = {v: k for k, v in UNITS.items()}
TYPE_NAMES: dict[int, str] = {v: k for k, v in TYPES.items()}

MAX_DEFLECTION_RAD = 0.35  # surface deflection at a normalised command of 1 [rad]

_SENSOR_TYPES = {
    "ok": (), "off": (), "stuck": (), "garbage": ("noise_scale",),
    "wrong": ("bias", "axis"), "slow": ("rate_div",), "delayed": ("delay_s",),
    "intermittent": ("drop_prob",),
}
_SCALAR_SENSOR_TYPES = dict(_SENSOR_TYPES, wrong=("bias",))

# unit name -> {type name -> allowed magnitude keys}
SUPPORTED: dict[str, dict[str, tuple[str, ...]]] = {
    "gyro": _SENSOR_TYPES,
    "accel": _SENSOR_TYPES,
    "mag": _SENSOR_TYPES,
    "baro": _SCALAR_SENSOR_TYPES,
    "airspeed": _SCALAR_SENSOR_TYPES,
    "gps": dict(_SENSOR_TYPES, garbage=("noise_scale", "vel_noise_scale"),
                wrong=("offset_m", "north_m", "east_m")),
    "servo": {"ok": (), "off": (), "stuck": ("value_rad", "value"), "wrong": ("effectiveness",)},
    "motor": {"ok": (), "off": (), "stuck": (), "wrong": ("effectiveness",)},
}

ALL_MAGNITUDES = ("bias", "noise_scale", "vel_noise_scale", "value_rad", "value", "axis", "effectiveness", "delay_s",
                  "offset_m", "north_m", "east_m", "rate_div", "drop_prob")

DEFAULT_BIAS = {"gyro": 0.1, "accel": 1.0, "mag": 0.2, "baro": 20.0, "airspeed": 50.0}
DEFAULTS = {"noise_scale": 10.0, "vel_noise_scale": None, "axis": None, "rate_div": 5, "delay_s": 0.5,
            "drop_prob": 0.5, "effectiveness": 0.5, "value_rad": None, "value": None,
            "offset_m": 0.0, "north_m": 0.0, "east_m": 0.0}
DEFAULT_GPS_OFFSET_NORTH_M = 20.0


def unit_name(unit: int | str) -> str:
    """Canonical unit name from a MAVLink number or a name; FaultSpecError if unknown."""
    if isinstance(unit, str):
        if unit.lower() not in UNITS:
            raise FaultSpecError(
                f"unknown failure unit {unit!r} (known: {', '.join(UNITS)})", "unit")
        return unit.lower()
    if isinstance(unit, bool) or int(unit) != unit or int(unit) not in UNIT_NAMES:
        raise FaultSpecError(f"unknown failure unit {unit!r}", "unit")
    return UNIT_NAMES[int(unit)]


def type_name(ftype: int | str) -> str:
    """Canonical type name from a MAVLink number or a name; FaultSpecError if unknown."""
    if isinstance(ftype, str):
        if ftype.lower() not in TYPES:
            raise FaultSpecError(
                f"unknown failure type {ftype!r} (known: {', '.join(TYPES)})", "type")
        return ftype.lower()
    if isinstance(ftype, bool) or int(ftype) != ftype or int(ftype) not in TYPE_NAMES:
        raise FaultSpecError(f"unknown failure type {ftype!r}", "type")
    return TYPE_NAMES[int(ftype)]


def is_supported(unit: int | str, ftype: int | str) -> bool:
    try:
        return type_name(ftype) in SUPPORTED.get(unit_name(unit), {})
    except FaultSpecError:
        return False


def _number(key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise FaultSpecError(f"{key} must be a finite number, not {value!r}", key)
    return float(value)


def _integer(key: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise FaultSpecError(f"{key} must be an integer, not {value!r}", key)
    return value


AXES = {"x": 0, "y": 1, "z": 2}   # body axis names (forward, right, down) -> index


def axis_index(value) -> int:
    """A body axis given as "x"/"y"/"z" (any case) or 0/1/2 -> 0/1/2; FaultSpecError
    listing what is accepted for anything else."""
    if isinstance(value, str) and value.strip().lower() in AXES:
        return AXES[value.strip().lower()]
    if not isinstance(value, bool) and isinstance(value, int) and value in (0, 1, 2):
        return value
    raise FaultSpecError(
        f'axis must be "x", "y", "z" or 0, 1, 2 (body forward, right, down), not {value!r}',
        "axis")


def check_magnitudes(unit: str, ftype: str, magnitudes: dict) -> dict:
    """Validate the magnitudes of a supported (unit, type) and fill in the defaults.

    Returns a new dict with every allowed key present. Raises FaultSpecError (with
    ``key``) for a key this fault does not take or a value of bad type or range.
    """
    allowed = SUPPORTED[unit][ftype]
    for key in magnitudes:
        if key not in allowed:
            what = "takes no magnitudes" if not allowed else f"takes {', '.join(allowed)}"
            raise FaultSpecError(f"{key!r} does not apply: {unit} {ftype} {what}", key)
    out = {}
    for key in allowed:
        v = magnitudes.get(key)
        if v is None:
            v = DEFAULT_BIAS[unit] if key == "bias" else DEFAULTS[key]
            out[key] = v
            continue
        if key == "axis":
            v = axis_index(v)
        elif key == "rate_div":
            v = _integer(key, v)
            if v < 1:
                raise FaultSpecError(f"rate_div must be >= 1, not {v}", key)
        else:
            v = _number(key, v)
            if key in ("noise_scale", "vel_noise_scale") and v < 1.0:
                raise FaultSpecError(f"{key} must be >= 1, not {v}", key)
            if key == "delay_s" and not 0.0 <= v <= 60.0:
                raise FaultSpecError(f"delay_s must be in [0, 60], not {v}", key)
            if key == "value" and not -1.0 <= v <= 1.0:
                raise FaultSpecError(f"value must be in [-1, 1], not {v}", key)
            if key in ("drop_prob", "effectiveness") and not 0.0 <= v <= 1.0:
                raise FaultSpecError(f"{key} must be in [0, 1], not {v}", key)
        out[key] = v
    if magnitudes.get("value") is not None and magnitudes.get("value_rad") is not None:
        raise FaultSpecError("give value_rad or value, not both", "value")
    if unit == "gps" and ftype == "wrong" and not any(
            k in magnitudes for k in ("offset_m", "north_m", "east_m")):
        out["north_m"] = DEFAULT_GPS_OFFSET_NORTH_M
    if out.get("vel_noise_scale", 0.0) is None:
        out["vel_noise_scale"] = out["noise_scale"]
    return out
