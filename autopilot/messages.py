"""Typed, immutable messages: the only contracts between the autopilot's blocks.

Each field carries its unit and frame in its name or comment. SI units and radians
inside; NED earth frame; FRD body frame; quaternions Hamilton scalar-first [w, x, y, z]
with ``q_nb`` rotating body vectors into NED. Time is integer microseconds ``t_us`` on
the simulation clock.

The same ``NavState`` serves truth and estimate, so every controller can be flown on
truth (``--nav truth``) with a one-line swap while debugging.
"""
from __future__ import annotations

from dataclasses import field

import numpy as np

from autopilot.frozen import message


def _zeros3() -> np.ndarray:
    return np.zeros(3)


@message
class ImuSample:
    t_us: int
    f_b: tuple              # specific force, body FRD [m/s^2]: 3 floats
    omega_b: tuple          # angular rate, body FRD [rad/s]: 3 floats


@message
class MagSample:
    t_us: int
    m_b: tuple              # magnetic field, body FRD [gauss]: 3 floats


@message
class BaroSample:
    t_us: int
    pressure_pa: float      # static pressure [Pa]
    alt_m: float            # pressure altitude [m]
    temperature_k: float    # [K]


@message
class AirspeedSample:
    t_us: int
    diff_pressure_pa: float  # dynamic (pitot - static) pressure [Pa]
    airspeed_mps: float      # indicated-to-true airspeed the sensor reports [m/s]


@message
class GpsFix:
    """One GPS receiver solution. ``t_us`` is when it arrived; the solution itself is
    valid ``latency`` earlier (the navigation filter compensates)."""

    t_us: int
    lat_rad: float
    lon_rad: float
    alt_m: float             # height above MSL [m]
    v_ned: np.ndarray        # [m/s]
    eph_m: float             # horizontal accuracy (1 sigma) [m]
    epv_m: float             # vertical accuracy (1 sigma) [m]
    fix_type: int            # 0-1 no fix, 2 2D, 3 3D (GPS_FIX_TYPE)
    satellites: int


@message
class RangeSample:
    """One rangefinder reading (DISTANCE_SENSOR), as the sensor reports it: the range
    along its axis, and its own limits; whether it is in range is the reader's call
    (RNGFND1_MIN_CM / RNGFND1_MAX_CM, as ArduPilot judges it)."""

    t_us: int
    distance_m: float        # range along the sensor's axis [m]
    min_m: float             # the sensor's shortest and longest range [m]
    max_m: float
    orientation: int         # MAV_SENSOR_ORIENTATION (25: PITCH_270, downward)
    signal_quality: int      # percent; 0 unknown, 1 invalid (no return)


@message
class RpmSample:
    """The propeller's speed as its speed controller reports it (ESC telemetry,
    ESC_TELEMETRY_1_TO_4's ESC 1), at the time of the step it came with."""

    t_us: int
    rpm: float               # [rpm]


@message
class SensorFrame:
    """Everything the simulator delivered for one lockstep step."""

    t_us: int
    imu: ImuSample
    mag: MagSample | None = None
    baro: BaroSample | None = None
    airspeed: AirspeedSample | None = None
    gps: GpsFix | None = None
    range: RangeSample | None = None     # a downward rangefinder's reading, when one arrived
    rpm: RpmSample | None = None         # the propeller's speed (ESC telemetry), when one arrived


@message
class NavState:
    """A navigation solution (estimate or truth), in the local NED frame of ``origin``.

    A navigation filter's p_ned, v_ned, q_nb and omega_b are views of the filter's
    output, written again at its next update (one array for the whole flight, not four
    a step): copy them to keep them."""

    t_us: int
    p_ned: np.ndarray        # position relative to the nav origin [m]
    v_ned: np.ndarray        # velocity over ground [m/s]
    q_nb: np.ndarray         # attitude [w, x, y, z]
    omega_b: np.ndarray      # bias-corrected body rate [rad/s]
    lat_rad: float
    lon_rad: float
    alt_m: float             # height above MSL [m]
    airspeed_mps: float      # best airspeed estimate [m/s]
    wind_ned: np.ndarray = field(default_factory=_zeros3)  # [m/s]
    aligned: bool = True     # attitude/heading initialised
    healthy: bool = True     # innovations within gates, covariance sane
    source: str = "truth"    # "truth" | "ekf" | "ukf"


@message
class AttitudeTarget:
    """What guidance asks of the inner loops."""

    roll_rad: float
    pitch_rad: float
    yaw_rate_rps: float = 0.0
    throttle: float | None = None   # None: the airspeed/energy loop decides


@message
class ActuatorOutputs:
    """Normalised actuator commands sent back in HIL_ACTUATOR_CONTROLS.

    Fixed-wing: [0] aileron (+ roll right), [1] elevator (+ nose up), [2] rudder
    (+ nose right), [3] throttle 0..1. Quadrotor: [0..3] motors 0..1.
    """

    t_us: int
    controls: tuple[float, ...]
    armed: bool = False
