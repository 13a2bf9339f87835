"""The navigation filters' error-state layout: the one place that defines it.

Both :class:`~autopilot.nav.ekf.InsGpsEkf` and :class:`~autopilot.nav.ukf.InsGpsUkf`
carry a *nominal* state (position, velocity, attitude quaternion, biases, wind) and
estimate a small *error* state ``dx`` around it (error-state / multiplicative filter,
Sola 2017 sec. 7 "global angular error"; Groves 2013 sec. 14.2). The error state holds
what seed eq 1.22 holds (position, NED velocity, attitude, three accelerometer and three
gyro biases), plus the north/east wind for the fixed-wing:

==========  =======  ======================================================  =========
slice       indices  meaning                                                 unit
==========  =======  ======================================================  =========
``POS``     0:3      position error, NED, relative to the nav origin         m
``VEL``     3:6      velocity error, NED                                     m/s
``ATT``     6:9      attitude error, a small rotation vector in NED:          rad
                     ``q_true = Exp(dtheta) (x) q_nb`` (global error)
``ABIAS``   9:12     accelerometer bias error, body FRD                      m/s^2
``GBIAS``   12:15    gyro bias error, body FRD                               rad/s
``WIND``    15:17    wind error, north and east (fixed-wing only)            m/s
==========  =======  ======================================================  =========

The seed writes position as latitude, longitude and height and attitude as Euler
angles; we carry position in the local NED frame of the nav origin (small-area
curvilinear frame of :class:`autopilot.geo.LocalFrame`, ``p_D = alt0 - alt``) and
attitude as a quaternion with a 3-element rotation-vector error, which has no gimbal
lock and keeps the covariance 3x3 for attitude.
"""
from __future__ import annotations

POS = slice(0, 3)
VEL = slice(3, 6)
ATT = slice(6, 9)
ABIAS = slice(9, 12)
GBIAS = slice(12, 15)
WIND = slice(15, 17)

#: Error-state dimension without / with the wind states.
N_BASE = 15
N_WIND = 17

#: Names of the error-state components in index order (for logs and plots).
STATE_NAMES = (
    "p_n", "p_e", "p_d",
    "v_n", "v_e", "v_d",
    "att_n", "att_e", "att_d",
    "ba_x", "ba_y", "ba_z",
    "bg_x", "bg_y", "bg_z",
    "wind_n", "wind_e",
)

#: Vehicle kinds the filters accept; the fixed-wing carries the wind states.
PLANE_NAMES = ("plane", "fixed_wing", "fixedwing")
COPTER_NAMES = ("copter", "quad", "quadrotor", "multirotor")


def error_state_size(vehicle: str) -> int:
    """Number of error states for a vehicle kind ("plane" -> 17, "copter" -> 15)."""
    v = vehicle.lower()
    if v in PLANE_NAMES:
        return N_WIND
    if v in COPTER_NAMES:
        return N_BASE
    raise ValueError(f"unknown vehicle {vehicle!r}: expected one of {PLANE_NAMES + COPTER_NAMES}")
