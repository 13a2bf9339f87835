"""The navigation filters' error-state layout: the one place that defines it.

Both :class:`~autopilot.nav.ekf.InsGpsEkf` and :class:`~autopilot.nav.ukf.InsGpsUkf`
carry a *nominal* state (position, velocity, attitude quaternion, biases, wind) and
estimate a small *error* state ``dx`` around it (error-state / multiplicative filter,
Sola 2017, "global angular error" formulation; Groves 2013 ch. 14). The error state holds
what seed eq 1.22 holds (position, NED velocity, attitude, three accelerometer and three
gyro biases), plus two error models of the aiding sensors (barometer offset, GPS
position error) and, for the fixed-wing, the north/east wind:

==========  =======  ======================================================  =========
slice       indices  meaning                                                 unit
==========  =======  ======================================================  =========
``POS``     0:3      position error, NED, relative to the nav origin         m
``VEL``     3:6      velocity error, NED                                     m/s
``ATT``     6:9      attitude error, a small rotation vector in NED:          rad
                     ``q_true = Exp(dtheta) (x) q_nb`` (global error)
``ABIAS``   9:12     accelerometer bias error, body FRD                      m/s^2
``GBIAS``   12:15    gyro bias error, body FRD                               rad/s
``BBIAS``   15:16    barometer offset (baro altitude - true altitude)        m
``GPSB``    16:19    GPS position error, NED, first-order Gauss-Markov       m
``WIND``    19:21    wind error, north and east (fixed-wing only)            m/s
==========  =======  ======================================================  =========

``BBIAS`` and ``GPSB`` are additions to eq 1.22, both measured necessities:

* A barometer reads pressure altitude, whose datum differs from the GPS's by metres
  and drifts with the weather. Frozen from one GPS altitude, the offset's error became
  the vertical error while the covariance claimed centimetres (hardly a sample inside
  3 sigma in simulation).
* A GPS position error is mostly slow (Gauss-Markov, tau ~ a minute), not white. A
  filter that treats it as white averages successive fixes as if independent and claims
  a position sigma well below the error it actually has (far fewer than 99 % of samples
  inside 3 sigma); inflating R enough to fix that (x600 for tau = 60 s at 5 Hz) makes
  the re-acquisition after an outage take minutes. Augmenting the state with the
  coloured measurement noise (Bryson & Henrikson 1968, "Estimation using sampled data
  containing sequentially correlated noise") is exact for that model and costs three
  states.

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
BBIAS = slice(15, 16)
GPSB = slice(16, 19)
WIND = slice(19, 21)

#: Error-state dimension without / with the wind states.
N_BASE = 19
N_WIND = 21

#: Names of the error-state components in index order (for logs and plots).
STATE_NAMES = (
    "p_n", "p_e", "p_d",
    "v_n", "v_e", "v_d",
    "att_n", "att_e", "att_d",
    "ba_x", "ba_y", "ba_z",
    "bg_x", "bg_y", "bg_z",
    "baro_b",
    "gps_b_n", "gps_b_e", "gps_b_d",
    "wind_n", "wind_e",
)

#: Vehicle kinds the filters accept; the fixed-wing carries the wind states.
PLANE_NAMES = ("plane", "fixed_wing", "fixedwing")
COPTER_NAMES = ("copter", "quad", "quadrotor", "multirotor")


def error_state_size(vehicle: str) -> int:
    """Number of error states for a vehicle kind ("plane" -> 21, "copter" -> 19)."""
    v = vehicle.lower()
    if v in PLANE_NAMES:
        return N_WIND
    if v in COPTER_NAMES:
        return N_BASE
    raise ValueError(f"unknown vehicle {vehicle!r}: expected one of {PLANE_NAMES + COPTER_NAMES}")
