"""The contract between a plant and the rest of sim_bridge.

Every plant (the JSBSim fixed-wing, the quadrotor model) exposes the same truth record,
so that the sensor models, the HIL link and the scoring code never ask which plant they
are talking to. Units are SI, angles radians, frames NED (earth) and FRD (body);
``q_nb`` is a Hamilton scalar-first quaternion that rotates body vectors into NED.
"""
from __future__ import annotations

from typing import Protocol

from autopilot.frozen import message


@message
class PlantState:
    """True state of the vehicle at one instant (the plant's output). The vectors are
    tuples of floats: their readers (the sensors, the HIL link's truth) take them
    element by element, and an array with its views cost more to build than they
    did with it."""

    t_us: int               # simulation time [us]
    lat_rad: float          # geodetic latitude [rad]
    lon_rad: float          # longitude, wrapped to (-pi, pi] [rad]
    alt_m: float            # height above the WGS-84 ellipsoid / MSL (same here) [m]
    v_ned: tuple            # velocity over ground, NED [m/s], 3 floats
    q_nb: tuple             # attitude, body->NED, [w, x, y, z]
    omega_b: tuple          # inertial angular rate in body axes (gyro truth) [rad/s]
    f_b: tuple              # specific force in body axes (accelerometer truth) [m/s^2]
    wind_ned: tuple         # air velocity over ground at the vehicle, NED [m/s]
    airspeed_mps: float     # true airspeed [m/s]
    alpha_rad: float        # angle of attack [rad]
    beta_rad: float         # sideslip [rad]
    on_ground: bool         # resting on ground or launcher
    rho_kgm3: float = 1.225  # air density at the vehicle [kg/m^3]
    pressure_pa: float = 101325.0  # static pressure at the vehicle [Pa]
    temperature_k: float = 288.15  # static air temperature [K]
    rpm: float = 0.0        # the propeller's speed [rpm] (0: a plant without one)


@message
class PlaneControls:
    """Normalised fixed-wing commands, as carried in HIL_ACTUATOR_CONTROLS [0..3].

    aileron  +1 rolls right (right wing down)
    elevator +1 pitches the nose up
    rudder   +1 yaws the nose right
    throttle 0..1
    """

    aileron: float = 0.0
    elevator: float = 0.0
    rudder: float = 0.0
    throttle: float = 0.0


class Plant(Protocol):
    """What sim_bridge needs of a plant."""

    dt_s: float  # integration step of the plant [s]

    def state(self) -> PlantState: ...

    def step(self, controls, n_steps: int = 1) -> PlantState: ...
