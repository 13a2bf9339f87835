"""The propeller's speed as the motor's speed controller reports it (ESC telemetry), from
plant truth.

What real autopilots read: ArduPilot's ESC telemetry (AP_ESC_Telem: BLHeli_32 / DShot
telemetry, the RPM library's ``RPM1_TYPE`` 5 "ESC telemetry motors") and PX4's
``esc_status``; ArduPilot sends it to the ground as ESC_TELEMETRY_1_TO_4, whose ``rpm``
field (uint16, rpm) carries it here too (sim_bridge/hil.py, autopilot/link/hil.py). An
electronic speed controller measures the motor's commutation period, so the rotor's
true speed is read with a small relative error and reported to the rpm.

The plant's speed is its propeller's (JSBSim ``propulsion/engine/propeller-rpm``, the
plant's ``PlantState.rpm``): the Aerosonde's electric motor drives the propeller
directly, so the motor's speed is the propeller's; so does the c172p's piston engine,
whose tachometer (an engine monitor counting the magneto's pulses; ArduPilot's RPM
library reads such a pulse input) this sensor stands for there, the same wire message.

Noise and rate. A reading every ``1 / rate_hz`` of simulation time (the first at the
first step): the true speed times ``1 + noise_frac n`` (n standard normal), rounded to
the rpm on the wire. Every reading draws exactly one standard normal from the injected
generator, the sensor's own stream (``sim_bridge/world.py``), so the noise depends on
the seed alone and fitting the sensor leaves every other sensor's draws, and the
flight when the autopilot does not use it, unchanged. (The draws are made in blocks,
``readings.normals``: the same numbers in the same order.)

The default is a BLHeli_32-class ESC's telemetry, read at 20 Hz (its telemetry is
requested motor by motor, a few tens of frames a second) with 0.5 % of the reading
(1 sigma): at the Aerosonde's cruise, about 6000 rpm, 30 rpm; at the c172p's, about
1900 rpm, 10 rpm.
"""
from __future__ import annotations

from dataclasses import dataclass

from autopilot.frozen import message

from .readings import next_due_us, normals, period_us


@dataclass(frozen=True)
class RpmParams:
    rate_hz: float = 20.0         # readings per second of simulation time
    noise_frac: float = 0.005     # white noise, 1 sigma, as a fraction of the reading


@message
class RpmReading:
    t_us: int                     # simulation time of the reading [us]
    rpm: float                    # the rotor's speed [rpm] (>= 0)


class RpmSensor:
    """``sample(state)`` once per simulator step: an :class:`RpmReading` when one is due
    (at ``rate_hz``), else None."""

    def __init__(self, params: RpmParams, rng):
        self.params = params
        self._rng = rng
        self._noise = normals(rng)
        self._period_us = period_us(params.rate_hz)
        self._next_us: int | None = None

    def sample(self, state) -> RpmReading | None:
        t_us = state.t_us
        if self._next_us is not None and t_us < self._next_us:
            return None
        self._next_us = next_due_us(self._next_us, self._period_us, t_us)
        n = next(self._noise)                     # one draw per reading
        return RpmReading.make(t_us, max(state.rpm * (1.0 + self.params.noise_frac * n), 0.0))
