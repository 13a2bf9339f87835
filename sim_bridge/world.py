"""Assemble the simulated world of a run: plant, sensors, fault injector, wind, events.

One ``numpy.random.SeedSequence(seed)`` is split into independent streams for the plant
(turbulence), the sensors, the fault models, the rangefinder and the ESC's rpm
telemetry, so the same seed gives bit-identical runs whichever transport carries the
HIL link. (``spawn(n + 1)``'s first n children are ``spawn(n)``'s: fitting the
rangefinder, then the rpm telemetry, left the other streams' draws as they were.)

Rangefinders fitted per airframe (``RANGEFINDERS``): the Aerosonde carries a downward
lidar (``sensors/rangefinder.py``, sent as DISTANCE_SENSOR); the c172p and the
quadrotor carry none. The Aerosonde's motor reports its propeller's speed
(``RPM_SENSORS``: ``sensors/rpm.py``, ESC telemetry sent as ESC_TELEMETRY_1_TO_4); the
c172p's engine tachometer reports its own (the IO-320 drives the propeller directly),
read as the same message; the quadrotor reports none.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .faults import FaultInjector
from .hil import SimulatorHilEnd
from .bridge import SimBridge
from .scenario import Wind, load_scenario
from .sensors import SensorParams, SensorSuite
from .sensors.rangefinder import Rangefinder, RangefinderParams
from .sensors.rpm import RpmParams, RpmSensor

QUAD_DT_S = 0.004          # quadrotor plant step = its HIL period (250 Hz)
QUAD_HIL_RATE_HZ = 250.0
RANGEFINDERS = {"aerosonde": RangefinderParams()}   # airframe -> its downward rangefinder
# airframe -> its rpm telemetry: the Aerosonde's ESC; the c172p's tachometer (an engine
# monitor's magneto-pulse reading, as ArduPilot's RPM library takes a pulse input), the
# same rate and noise
RPM_SENSORS = {"aerosonde": RpmParams(), "c172p": RpmParams()}


@dataclass
class World:
    plant: object
    sensors: SensorSuite
    faults: FaultInjector
    events: list
    wind: Wind
    rangefinder: Rangefinder | None = None
    rpm: RpmSensor | None = None

    def bridge(self, transport, vehicle: str = "plane", hil_rate_hz: float = 100.0,
               answer_timeout_s: float = 1.0) -> SimBridge:
        link = SimulatorHilEnd(transport, answer_timeout_s=answer_timeout_s)
        return SimBridge(self.plant, self.sensors, link, self.faults, self.events,
                         hil_rate_hz=hil_rate_hz, vehicle=vehicle, rangefinder=self.rangefinder,
                         rpm=self.rpm)


def build_world(home: tuple[float, float, float, float], seed: int, airframe: str = "aerosonde",
                scenario: Path | None = None, wind: tuple[float, float] | None = None,
                turbulence: str | None = None, vehicle: str = "plane",
                sensor_params: SensorParams | None = None, terrain=None,
                rangefinder: RangefinderParams | None | str = "airframe",
                rpm: RpmParams | None | str = "airframe") -> World:
    """``home`` = (lat_deg, lon_deg, alt_m, heading_deg). ``wind`` = (speed, from_deg)
    overrides the scenario's steady wind; ``turbulence`` overrides its level.
    ``terrain``: the ground's height, a callable (lat_deg, lon_deg) -> metres MSL or None
    (autopilot.geo.terrain); None: flat at home altitude. ``rangefinder``: the downward
    rangefinder's parameters, None for none, "airframe" (default) the airframe's own
    (``RANGEFINDERS``; a plane only). ``rpm``: the ESC's rpm telemetry, likewise
    (``RPM_SENSORS``)."""
    events: list = []
    w = Wind(0.0, 0.0, "none")
    if scenario is not None:
        sc = load_scenario(scenario)
        events = list(sc.events)
        if sc.wind is not None:
            w = sc.wind
    if wind is not None:
        w = Wind(wind[0], wind[1], turbulence or w.turbulence)
    elif turbulence is not None:
        w = Wind(w.speed_mps, w.from_deg, turbulence)

    root = np.random.SeedSequence(seed)
    rng_plant, rng_sensors, rng_faults, rng_range, rng_rpm = (np.random.default_rng(s)
                                                              for s in root.spawn(5))
    sp = sensor_params or SensorParams()
    if vehicle == "quad":
        # the seed's quadrotor model (plants/quadrotor.py), 4 ms steps: one per 250 Hz
        # HIL period; motor instances 0..3 are control channels 0..3
        from .plants.quadrotor import QuadrotorPlant
        quad_airframe = "f450" if airframe == "aerosonde" else airframe
        plant = QuadrotorPlant(home, quad_airframe, dt_s=QUAD_DT_S, wind_ned=tuple(w.wind_ned()),
                               turbulence=w.turbulence, rng=rng_plant)
        plant.terrain = terrain
        sensors = SensorSuite(sp, rng_sensors, dt_s=QUAD_DT_S)
        sensors.set_home(math.radians(home[0]), math.radians(home[1]), home[2])
        return World(plant, sensors, FaultInjector(rng_faults, sp, dt_s=QUAD_DT_S,
                                                   motor_channels=(0, 1, 2, 3), thrust_motors=True),
                     events, w)
    if vehicle != "plane":
        raise ValueError(f"vehicle {vehicle!r} is not implemented (plane, quad)")
    from .plants.jsbsim_plane import JSBSimPlane
    plant = JSBSimPlane(airframe, home=home, wind_ned=tuple(w.wind_ned()),
                        turbulence=w.turbulence, rng=rng_plant)
    plant.terrain = terrain
    sensors = SensorSuite(sp, rng_sensors, dt_s=0.01)
    sensors.set_home(math.radians(home[0]), math.radians(home[1]), home[2])
    if isinstance(rangefinder, str):
        rangefinder = RANGEFINDERS.get(airframe)
    rf = Rangefinder(rangefinder, rng_range, home[2], terrain) if rangefinder is not None else None
    if isinstance(rpm, str):
        rpm = RPM_SENSORS.get(airframe)
    rs = RpmSensor(rpm, rng_rpm) if rpm is not None else None
    return World(plant, sensors, FaultInjector(rng_faults, sp, dt_s=0.01), events, w, rf, rs)
