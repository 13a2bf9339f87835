"""The sensor records that leave the sensor models (and the fault injector).

Immutable: the vectors inside are tuples of floats (their one reader, the HIL link,
takes them element by element; an array with its views cost more to build than the
link did with it).
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.frozen import message

def normals(rng: np.random.Generator, block: int = 256):
    """The standard normals of ``rng`` one at a time (``next()``), drawn ``block`` at a
    time: the same numbers in the same order as one ``float(rng.standard_normal())``
    each (a Generator fills an array number by number with its scalar routine), without
    a Generator call (0.6 us) per number. For a generator nothing else draws from (the
    draws run ahead of their use); nothing is drawn before the first number is asked
    for."""
    while True:
        yield from rng.standard_normal(block).tolist()


def period_us(rate_hz: float) -> int:
    """A sensor's sample period at ``rate_hz`` [us], at least 1."""
    return max(1, int(round(1e6 / rate_hz)))


def next_due_us(next_us: int | None, period: int, t_us: int) -> int:
    """The time of a sensor's next sample after one taken at ``t_us`` [us]: one period
    after the one that fell due (its own schedule, not the step's), or after ``t_us``
    where that is already past (a step longer than the period)."""
    nxt = (t_us if next_us is None else next_us) + period
    return nxt if nxt > t_us else t_us + period


@message
class GpsReading:
    """One GNSS fix as the receiver delivers it."""

    t_us: int               # arrival time at the autopilot side [us]
    lat_rad: float          # geodetic latitude [rad]
    lon_rad: float          # longitude [rad]
    alt_m: float            # altitude MSL [m]
    v_ned: tuple            # velocity over ground, NED [m/s], 3 floats
    eph_m: float            # 1-sigma horizontal position accuracy (radial, sqrt(sN^2+sE^2)) [m]
    epv_m: float            # 1-sigma vertical position accuracy [m]
    fix_type: int           # GPS_FIX_TYPE: 3 = 3D fix
    satellites: int         # satellites used
    t_valid_us: int = -1    # time of validity of the solution (t_us - latency) [us]

    @property
    def ground_speed_mps(self) -> float:
        """Horizontal speed over ground from v_ned [m/s]."""
        return math.hypot(float(self.v_ned[0]), float(self.v_ned[1]))

    @property
    def cog_rad(self) -> float:
        """Course over ground from v_ned, [0, 2 pi) clockwise from true north [rad]."""
        return math.atan2(float(self.v_ned[1]), float(self.v_ned[0])) % (2.0 * math.pi)


@message
class SensorReadings:
    """Everything the sensors produce at one simulation step.

    Fields of the slower sensors keep their last value between updates; the
    ``*_updated`` flags say which ones are new at this step (HIL_SENSOR fields_updated).
    """

    t_us: int                  # simulation time of the step [us]
    accel_b: tuple             # specific force, body FRD [m/s^2], 3 floats
    gyro_b: tuple              # angular rate, body FRD [rad/s], 3 floats
    mag_b_gauss: tuple         # magnetic field, body FRD [gauss], 3 floats
    pressure_pa: float         # static pressure [Pa]
    pressure_alt_m: float      # ISA pressure altitude of pressure_pa [m]
    temperature_k: float       # barometer temperature [K]
    diff_pressure_pa: float    # pitot differential (dynamic) pressure [Pa]
    airspeed_mps: float        # equivalent airspeed sqrt(2 dp / rho0), rho0 = 1.225 [m/s]
    baro_updated: bool         # pressure/pressure_alt/temperature are new this step
    mag_updated: bool          # mag_b_gauss is new this step
    airspeed_updated: bool     # diff_pressure/airspeed are new this step
    gps: GpsReading | None     # a fix arriving at this step, else None
