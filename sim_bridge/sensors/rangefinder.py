"""A downward rangefinder (a lidar under the fuselage): the slant range to the ground
along the body's down axis, from plant truth.

Geometry. The beam points along body +z (MAVLink's MAV_SENSOR_ROTATION_PITCH_270, the
orientation ArduPilot's RNGFND1_ORIENT 25 and PX4 call "downward facing") from the
centre of gravity. Over locally flat ground at height ``h`` below the sensor, the beam
meets it after ``h / cos(tilt)``, where cos(tilt) is the down component of the body z
axis in NED, R(q_nb)[2][2] = 1 - 2 (x^2 + y^2) (roll phi and pitch theta: cos phi cos
theta): the reading grows as the aircraft banks or pitches. Past ``tilt_max_deg`` from
the vertical (or pointing up) the return is lost, and past ``max_m`` (or under
``min_m``) the sensor reports out of range (:class:`RangeReading` ``distance_m`` None).
The ground under the aircraft is the plant's: its terrain callable (``terrain``,
(lat_deg, lon_deg) -> metres MSL or None) else flat at the home altitude, taken as flat
around that point (the slope under a beam a few metres long is not modelled).

Noise and rate. A reading every ``1 / rate_hz`` of simulation time (the first at the
first step): the true slant range plus white noise of ``noise_sigma_m`` (1 sigma),
quantised to the centimetre on the wire (DISTANCE_SENSOR carries cm). Every reading
draws exactly one standard normal from the injected generator, in range or not, so
the noise sequence depends on the seed alone; the generator is the rangefinder's own
stream (``sim_bridge/world.py``), so fitting one leaves every other sensor's draws,
and the flight when the autopilot does not use it, unchanged. (The draws are made in
blocks, ``readings.normals``: the same numbers in the same order.)

The default sensor is a LIDAR-Lite v3 class lidar (Garmin: 5 cm to 40 m, +-2.5 cm
accuracy beyond 1 m), read at 20 Hz.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from autopilot.frozen import message

from .readings import next_due_us, normals, period_us


@dataclass(frozen=True)
class RangefinderParams:
    min_m: float = 0.05           # shortest range reported [m]
    max_m: float = 40.0           # longest range reported [m]
    rate_hz: float = 20.0         # readings per second of simulation time
    noise_sigma_m: float = 0.025  # white noise, 1 sigma [m]
    tilt_max_deg: float = 45.0    # beam further than this from the vertical: no return


@message
class RangeReading:
    t_us: int                     # simulation time of the reading [us]
    distance_m: float | None      # slant range [m]; None out of range (no return)
    min_m: float                  # the sensor's range limits [m] (DISTANCE_SENSOR carries them)
    max_m: float
    noise_sigma_m: float


class Rangefinder:
    """``sample(state)`` once per simulator step: a :class:`RangeReading` when one is
    due (at ``rate_hz``), else None."""

    def __init__(self, params: RangefinderParams, rng, home_alt_m: float, terrain=None):
        self.params = params
        self._rng = rng
        self._noise = normals(rng)
        self.home_alt_m = float(home_alt_m)
        self.terrain = terrain
        self._period_us = period_us(params.rate_hz)
        self._next_us: int | None = None
        self._cos_max = math.cos(math.radians(params.tilt_max_deg))

    def ground_m(self, state) -> float:
        """The ground's height under the aircraft [m MSL]."""
        if self.terrain is not None:
            h = self.terrain(math.degrees(state.lat_rad), math.degrees(state.lon_rad))
            if h is not None:
                return float(h)
        return self.home_alt_m

    def true_range_m(self, state) -> float | None:
        """The noiseless reading at ``state`` (None: out of range, no return)."""
        p = self.params
        w, x, y, z = state.q_nb
        c = 1.0 - 2.0 * (x * x + y * y)
        if c < self._cos_max or c <= 0.0:
            return None
        r = max(state.alt_m - self.ground_m(state), 0.0) / c
        if r > p.max_m:
            return None
        return r

    def sample(self, state) -> RangeReading | None:
        t_us = state.t_us
        if self._next_us is not None and t_us < self._next_us:
            return None
        self._next_us = next_due_us(self._next_us, self._period_us, t_us)
        p = self.params
        n = next(self._noise)                    # one draw per reading, whatever it reads
        r = self.true_range_m(state)
        if r is not None:
            r = r + p.noise_sigma_m * n
            if not p.min_m <= r <= p.max_m:
                r = None
        return RangeReading.make(t_us, r, p.min_m, p.max_m, p.noise_sigma_m)
