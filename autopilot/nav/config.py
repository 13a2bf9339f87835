"""Parameters of the navigation filters (EKF and UKF share them).

Declared once here as :data:`NAV_PARAMS`; the vehicle collects them into its
:class:`~autopilot.params.ParamStore`. A filter takes any mapping of names to values
(a ParamStore, a dict with a few overrides, or None for the defaults).

Noise conventions (as PX4 EKF2's): ``*_NSE`` of an IMU channel is the 1-sigma white
noise of one sample at the IMU rate (the filter adds ``(sigma dt)^2`` of velocity /
angle variance per step); ``*B_NSE`` and ``EK_WIND_NSE`` are random-walk rates
(variance grows ``sigma^2`` per second); measurement ``*_NSE`` are 1-sigma in the
measurement's unit. Gates are in standard deviations of the innovation.

GPS position error = Gauss-Markov part (EK_GPSB_*, an error state) + white part. The
white sigma of a fix is ``max(EK_GPS_P_NSE, sqrt(eph^2 / 2 - EK_GPSB_SD^2))`` (eph is
the radial horizontal accuracy), so a receiver reporting a worse eph than the model's
total is weighted down accordingly.

Defaults: the sensor models the filters fly with (``sim_bridge/sensors/params.py``;
u-blox M8/M9, ICM-20602/BMI088, MS5611, MS4525DO classes), raised where the closed loop
adds to them (the measurements: docs/status.md, "Navigation"):

* IMU white noise: the sensors' 1.5e-3 m/s^2/sqrt(Hz) and 0.01 deg/s/sqrt(Hz) are
  0.015 m/s^2 and 1.7e-3 rad/s per 100 Hz sample; integrating point samples through
  turbulence adds about as much again (residuals of the truth's velocity and attitude
  against the mechanised samples): 0.05 and 0.003.
* Bias random walks: the sensors' 1e-3 m/s^3/sqrt(Hz) and 3e-5 rad/s^2/sqrt(Hz).
* Barometer offset: the sensors' drift is the weather's pressure tendency, a constant
  rate with sigma 0.8 mm/s of altitude; 0.01 m/sqrt(s) is the random walk with the
  same spread after 2-3 minutes (a larger one lets the GPS's vertical wander leak into
  the quadrotor's hover altitude).
* Wind: light Dryden turbulence moves the wind about half a metre per second in a
  second (1-s increments of the true wind): 0.5 m/s^2/sqrt(Hz). With less the wind
  states lag the gusts, and the airspeed and sideslip residuals go into velocity and
  attitude instead (velocity errors of several sigma in turns).
* GPS: white 0.3 m / 0.6 m (receiver noise, airborne multipath), Gauss-Markov 0.2 m /
  0.4 m with tau 60 s (the minute-scale wander; the hours-scale error, a constant
  offset over a flight, is left out as the sensor model leaves it out), velocity
  0.1 m/s horizontal (0.15 m/s vertical: 1.5 times, base.py). The pessimistic
  long-horizon sensor model (``sim_bridge.sensors.params.GPS_LONG_HORIZON``) has its
  matching values in :data:`NAV_GPS_LONG_HORIZON` (``--param`` each of them).
* Barometer: 3 Pa white is 0.26 m at 700 m (0.3 m). Height reference: the barometer
  (EK_HGT_REF = 0, base.py; the GPS for RTK receivers). Magnetometer: 5 mG per axis
  over the 0.24 G horizontal field at home is 0.021 rad of heading (0.03).
* Airspeed 0.3 m/s and sideslip 0.5 m/s: not the pitot's 1.5 Pa (0.05 m/s) but what
  the wind states cannot follow of the turbulence (residuals of a few tenths of a metre
  per second, correlated over seconds).
* Wind reset after EK_ARSP_RST_T = 2 s of airspeed rejection (base.py, ``_reset_wind``):
  without the airspeed the wind wanders off in a few seconds (a launch's wrong initial
  wind, a gust) and the gate then refuses the airspeed for good. 2 s rather than the
  GPS's 5 s: the fault monitor's airspeed window holds 8 s (FDI_WIN x FDI_DECIM
  fusions at EK_AUX_HZ), and random-plane trial 13 (moderate turbulence, a gust at
  11 s) still alarmed with 4 s (window statistic 1.03 x threshold; 0.75 with 3 s,
  0.09 with 2 s).
"""
from __future__ import annotations

import math
from typing import Mapping

from autopilot.params import Param

NAV_PARAMS: tuple[Param, ...] = (
    # --- process noise -------------------------------------------------------------
    Param("EK_ACC_NSE", 0.05, 0.001, 2.0, "m/s^2", "accelerometer white noise, 1 sigma per IMU sample"),
    Param("EK_GYR_NSE", 0.003, 1e-5, 0.5, "rad/s", "gyro white noise, 1 sigma per IMU sample"),
    Param("EK_ACCB_NSE", 1e-3, 0.0, 0.1, "m/s^3", "accelerometer bias random walk rate"),
    Param("EK_GYRB_NSE", 3e-5, 0.0, 0.01, "rad/s^2", "gyro bias random walk rate"),
    Param("EK_WIND_NSE", 0.5, 0.0, 5.0, "m/s^2", "wind random walk rate (fixed-wing)"),
    Param("EK_BAROB_NSE", 0.01, 0.0, 1.0, "m/s", "barometer offset random walk rate"),
    # --- GPS ----------------------------------------------------------------------
    Param("EK_GPS_P_NSE", 0.3, 0.01, 50.0, "m", "GPS horizontal position white noise, 1 sigma (floor)"),
    Param("EK_GPS_Z_NSE", 0.6, 0.01, 50.0, "m", "GPS vertical position white noise, 1 sigma (floor)"),
    Param("EK_GPSB_SD", 0.2, 0.0, 50.0, "m", "GPS horizontal Gauss-Markov position error, 1 sigma"),
    Param("EK_GPSB_Z_SD", 0.4, 0.0, 50.0, "m", "GPS vertical Gauss-Markov position error, 1 sigma"),
    Param("EK_GPSB_TAU", 60.0, 1.0, 3600.0, "s", "GPS position error correlation time"),
    Param("EK_GPS_V_NSE", 0.1, 0.01, 10.0, "m/s", "GPS velocity noise, 1 sigma"),
    Param("EK_GPS_P_GATE", 5.0, 1.0, 100.0, "SD", "GPS position innovation gate"),
    Param("EK_GPS_V_GATE", 5.0, 1.0, 100.0, "SD", "GPS velocity innovation gate"),
    Param("EK_GPS_DELAY", 0.15, 0.0, 0.5, "s", "GPS latency: a fix arriving at t is valid at t - delay",
          at_start=True),
    Param("EK_GPS_RST_T", 5.0, 0.5, 60.0, "s", "reset position/velocity to GPS after this long rejected"),
    # --- barometer, magnetometer --------------------------------------------------
    Param("EK_AUX_HZ", 12.5, 1.0, 100.0, "Hz", "baro, magnetometer and airspeed fused as means at this rate",
          at_start=True),
    Param("EK_BARO_NSE", 0.3, 0.01, 20.0, "m", "barometric altitude noise, 1 sigma"),
    Param("EK_HGT_REF", 0.0, 0.0, 1.0, "enum", "height reference: 0 barometer (GPS height estimates its offset), 1 GPS",
          is_int=True, at_start=True),
    Param("EK_BARO_GATE", 5.0, 1.0, 100.0, "SD", "barometric altitude innovation gate"),
    Param("EK_MAG_NSE", 0.03, 0.001, 1.0, "rad", "magnetic heading noise, 1 sigma"),
    Param("EK_MAG_GATE", 5.0, 1.0, 100.0, "SD", "magnetic heading innovation gate"),
    Param("EK_MAG_DEC", 0.0, -math.pi, math.pi, "rad", "magnetic declination (east positive), used when EK_MAG_AUTODEC = 0"),
    Param("EK_MAG_AUTODEC", 1.0, 0.0, 1.0, "bool", "1: declination from the IGRF model at the navigation origin",
          is_int=True, at_start=True),
    # --- airspeed and synthetic sideslip (fixed-wing) ----------------------------
    Param("EK_ARSP_NSE", 0.3, 0.01, 10.0, "m/s", "true airspeed noise, 1 sigma"),
    Param("EK_ARSP_GATE", 5.0, 1.0, 100.0, "SD", "airspeed innovation gate"),
    Param("EK_ARSP_RST_T", 2.0, 0.5, 60.0, "s", "reset the wind to the airspeed after this long rejected"),
    Param("EK_ARSP_MIN", 8.0, 0.0, 50.0, "m/s", "fuse airspeed and sideslip above this airspeed"),
    Param("EK_BETA_NSE", 0.5, 0.01, 10.0, "m/s", "synthetic sideslip: body-y air velocity noise"),
    Param("EK_BETA_GATE", 5.0, 1.0, 100.0, "SD", "synthetic sideslip innovation gate"),
    # --- alignment and health ----------------------------------------------------
    Param("EK_ALIGN_T", 1.5, 0.2, 10.0, "s", "stationary averaging time of the ground alignment"),
    Param("EK_ALIGN_GSPD", 5.0, 1.0, 50.0, "m/s", "minimum GPS ground speed for in-flight alignment"),
    Param("EK_HPOS_MAX", 50.0, 1.0, 10000.0, "m", "healthy only while horizontal position sigma is below"),
    Param("EK_REJ_TOUT", 1.0, 0.1, 60.0, "s", "unhealthy when a source is rejected this long"),
)

_DEFAULTS = {p.name: float(p.default) for p in NAV_PARAMS}
# the filter's parameters that take effect at the next start only (NavFilterBase.set_param)
AT_START = {p.name: p.at_start for p in NAV_PARAMS}

# The filters' GPS parameters for the pessimistic long-horizon receiver model
# (sim_bridge.sensors.params.GPS_LONG_HORIZON: 1.2 m / 2.5 m Gauss-Markov, tau 60 s).
NAV_GPS_LONG_HORIZON = {"EK_GPS_P_NSE": 0.3, "EK_GPS_Z_NSE": 0.5, "EK_GPSB_SD": 1.2,
                        "EK_GPSB_Z_SD": 2.5, "EK_GPSB_TAU": 60.0}

# ... and for the RTK receiver (sim_bridge.sensors.params.GPS_RTK): its noise, the
# barometer trusted less (1 m: the GPS height is now the better one) and the GPS as the
# height reference, as PX4 (EKF2_HGT_REF = GNSS) and ArduPilot (EK3_SRC1_POSZ = GPS)
# are set up for RTK.
NAV_GPS_RTK = {"EK_GPS_P_NSE": 0.01, "EK_GPS_Z_NSE": 0.015, "EK_GPSB_SD": 0.01,
               "EK_GPSB_Z_SD": 0.02, "EK_GPS_V_NSE": 0.03, "EK_GPS_DELAY": 0.05,
               "EK_BARO_NSE": 1.0, "EK_HGT_REF": 1}

# Filter parameters by receiver name (``sitl run --gps NAME``).
NAV_GPS_PRESETS = {"standard": {}, "rtk": NAV_GPS_RTK, "long-horizon": NAV_GPS_LONG_HORIZON}


def resolve(params: Mapping[str, float] | None) -> dict[str, float]:
    """Defaults overridden by ``params`` (a dict or a ParamStore); unknown EK_ names
    are refused so that a typo does not silently leave a default in place."""
    values = dict(_DEFAULTS)
    if params is None:
        return values
    names = params.names() if hasattr(params, "names") else list(params.keys())
    for name in names:
        if name in values:
            values[name] = float(params[name])
        elif name.startswith("EK_"):
            raise KeyError(f"unknown navigation parameter {name}")
    return values
