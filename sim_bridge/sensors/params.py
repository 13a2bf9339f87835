"""Noise and timing parameters of the sensor models, with where each default comes from.

All values are SI: m, s, rad, Pa, K; magnetic field in gauss (1 G = 100 uT = 1e5 nT).
"Density" values are continuous-time spectral densities; the models discretise them
with the step ``dt``:  white sigma = density / sqrt(dt) (= density * sqrt(rate)),
random-walk increment sigma = density * sqrt(dt).

Sources of the defaults (datasheet figures, then the margin we add for an airframe):

* IMU, MEMS class: TDK InvenSense ICM-20602 (gyro 0.004 deg/s/sqrt(Hz), accel
  100 ug/sqrt(Hz), gyro zero-rate offset +-1 deg/s, accel zero-g offset +-25 mg) and
  Bosch BMI088 (gyro 0.014 deg/s/sqrt(Hz), accel 175 ug/sqrt(Hz)). The defaults sit
  between the two. Turn-on biases are the residuals left after the usual level/gyro
  calibration at boot, not the raw datasheet offsets. Bias random walk densities
  correspond to a few deg/h of in-run instability, typical of these parts.
* GPS: u-blox M8N / M9N class receiver, open sky, on an airframe. Its position error
  has three parts, told apart by their time scales:

  - hours (satellite clock and ephemeris, ionosphere, troposphere): metres. This is
    what the data sheet's accuracy measures: NEO-M8 data sheet (UBX-15031086), 2.5 m
    CEP GPS+GLONASS, 2.0 m with SBAS, footnote "CEP, 50 %, 24 hours static, -130 dBm,
    > 6 SVs". Over a flight of minutes it is an almost constant offset of the whole
    frame: no GPS/IMU filter can observe it, and waypoints surveyed with the same kind
    of receiver share it. The defaults leave it out; :data:`GPS_LONG_HORIZON` puts it
    back (pessimistically: at the minute time scale).
  - minutes (multipath and satellite-geometry changes): a first-order Gauss-Markov
    process with tau 60 s -- multi-day static tests of consumer receivers with SA off
    (D. L. Wilson, "Correlation of errors" and "GPS error when averaging position",
    users.erols.com/dlwilson/gpscorr.htm and gpsavg.htm) show the error's
    autocorrelation bending at about 1 min before the long-term part takes over;
    stationary L1 receivers are fitted better by an Ornstein-Uhlenbeck process than by
    white noise (Soundy et al., Sensors 20(21) 6050, 2020). Size: a few decimetres,
    0.2 m per horizontal axis (0.28 m radial RMS, 0.5 m at 95 %), twice that
    vertically (VDOP about 1.4 HDOP: per axis a factor of about 2).
  - fix to fix (receiver noise; multipath of a moving antenna, which decorrelates
    within about a second): white, 0.3 m per horizontal axis and 0.6 m vertically --
    receiver noise of 0.6 m (1 sigma) per pseudorange (NRC, "The Global Positioning
    System: A Shared National Asset", 1995, table C-1) times HDOP 0.7 / sqrt(2) per
    horizontal axis and VDOP 1.0.

  Together 0.36 m per horizontal axis (CEP 0.42 m) over a flight, the size of what the
  reference autopilots' filters assume of such a receiver on their time scale of
  seconds to a minute: ArduPilot EK3_POSNE_M_NSE = 0.5 m (AP_NavEKF3.cpp,
  POSNE_M_NSE_DEFAULT), PX4 EKF2_GPS_P_NOISE = 0.5 m (params_gnss.yaml), both white
  noise (floors under the receiver's reported accuracy). Velocity:
  0.05 m/s speed accuracy (50 %) in the data sheet; 0.1 m/s white per horizontal axis
  with a margin for the airframe. Navigation rate 5-10 Hz, latency ~100-200 ms.

  The reference SITLs simulate less. ArduPilot's (libraries/SITL/SIM_GPS.cpp) adds no
  horizontal position error by default: SIM_GPS1_NOISE (an altitude sine of that
  amplitude), _DRFTALT, _GLTCH and _VERR all default to 0. PX4's Gazebo Classic plugin
  (PX4-SITL_gazebo-classic, src/gazebo_gps_plugin.cpp) runs
  ``bias += random_walk * dt - bias / gps_corellation_time`` once per 4 ms physics
  step: the decay is per step, not per second (PX4-SITL_gazebo-classic issue #816), so
  its "60 s" correlation time is 60 steps = 0.24 s, and with gpsXYRandomWalk = 2
  (m/s)/sqrt(Hz) the bias settles at 2 * 0.004^1.5 * sqrt(60 / 2) = 3 mm per axis, plus
  2e-4 m/sqrt(Hz) * sqrt(0.004 s) = 13 um white. Our earlier default took that "60 s"
  as PX4's value and paired it with the data sheet's 24-hour error (1.2 m per axis
  wandering at minute rate): the model of neither the receiver nor PX4.
* Barometer: TE MS5611 (RMS resolution 0.012 mbar = 1.2 Pa at OSR 4096, ~1 cm of
  altitude per 0.12 Pa); we use 3 Pa (about 0.25 m) to include airframe and propwash
  pressure noise. Drift: the weather's pressure tendency, a constant rate over a flight
  drawn once per run with sigma 1 hPa per 3 h (0.0093 Pa/s, 0.8 mm/s of altitude; the
  Met Office's shipping-forecast terms call 0.1-1.5 hPa in 3 h "rising/falling
  slowly" and 1.6-3.5 hPa plain "rising/falling"), so about 0.5 m after 10 min at one
  sigma. The reference SITLs default to no drift at all: PX4's Gazebo Classic
  barometer (gazebo_barometer_plugin.cpp) adds 1 Pa white noise and a linear drift
  baroDriftPaPerSec that defaults to 0; ArduPilot's SIM_BARO_DRIFT defaults to 0 and its
  board-temperature factor SIM_TEMP_BFACTOR too. A random-walk drift
  (``baro_drift_rw_density``, Pa/sqrt(s)) is kept for studies, default 0: our earlier
  default of 0.3 Pa/sqrt(s) had no source, and with it the quadrotor's altitude hold
  was set by the simulated sensor's wander, not by the autopilot.
* Magnetometer: Honeywell HMC5883L (noise floor 2 mG) and iSentek IST8310 (0.3 uT =
  3 mG resolution); default 5 mG per axis including airframe currents. Hard-iron
  offset is a parameter, default 0 (a calibrated installation).
* Airspeed: TE MS4525DO, +-1 psi differential (14 bit over 13.8 kPa span = 0.84 Pa per
  count); default 1.5 Pa (about two counts) white noise, zero offset (calibrated at
  boot, as ArduPilot and PX4 do).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

_DEG = math.pi / 180.0

# The pessimistic long-horizon GPS model (the defaults before the time scales were told
# apart): the data sheet's 24-hour error -- per horizontal axis sqrt(1.2^2 + 0.3^2) =
# 1.24 m, CEP 1.46 m; vertical about twice -- but wandering with the minute-scale
# correlation time, so that a flight of minutes sees all of it move. No filter can
# average it out: with it the EKF's horizontal error is about 0.85 of the receiver's
# (default fixed-wing mission) and a hovering quadrotor wanders by about a metre.
# ``SensorParams(**GPS_LONG_HORIZON)``; the navigation filter's matching parameters
# are ``autopilot.nav.config.NAV_GPS_LONG_HORIZON``.
GPS_LONG_HORIZON = {
    "gps_pos_white_sigma_h": 0.3, "gps_pos_white_sigma_v": 0.5,
    "gps_pos_gm_sigma_h": 1.2, "gps_pos_gm_sigma_v": 2.5, "gps_pos_gm_tau_s": 60.0,
}

# An RTK-fixed receiver (u-blox ZED-F9P class: data sheet UBX-17051259, RTK 0.01 m +
# 1 ppm CEP horizontal, 0.01 m + 1 ppm R50 vertical, 20 Hz navigation rate, velocity
# 0.05 m/s): 1 cm white + 1 cm Gauss-Markov per horizontal axis, 1.5 / 2 cm vertically,
# 50 ms latency. The navigation filter's matching parameters are
# ``autopilot.nav.config.NAV_GPS_RTK``. Used by the formation's quadrotors and by
# ``sitl run --gps rtk``.
GPS_RTK = {
    "gps_rate_hz": 20.0, "gps_latency_s": 0.05, "gps_pos_white_sigma_h": 0.01,
    "gps_pos_white_sigma_v": 0.015, "gps_pos_gm_sigma_h": 0.01, "gps_pos_gm_sigma_v": 0.02,
    "gps_vel_sigma_h": 0.03, "gps_vel_sigma_v": 0.05,
}

# Receiver models by name (``sitl run --gps NAME``): the sensor parameters that differ
# from the defaults.
GPS_PRESETS = {"standard": {}, "rtk": GPS_RTK, "long-horizon": GPS_LONG_HORIZON}


@dataclass(frozen=True, slots=True)
class SensorParams:
    """Noise, bias and timing of the sensor suite (defaults: see the module doc)."""

    # --- IMU (sampled every simulation step) -------------------------------------
    accel_noise_density: float = 1.5e-3      # [m/s^2/sqrt(Hz)]   (150 ug/sqrt(Hz))
    gyro_noise_density: float = 0.01 * _DEG  # [rad/s/sqrt(Hz)]   (0.01 deg/s/sqrt(Hz))
    accel_bias_turn_on_sigma: float = 0.03   # [m/s^2]   (~3 mg after calibration)
    gyro_bias_turn_on_sigma: float = 0.1 * _DEG  # [rad/s] (0.1 deg/s after calibration)
    accel_bias_rw_density: float = 1.0e-3    # [m/s^3/sqrt(Hz)]   bias random walk
    gyro_bias_rw_density: float = 3.0e-5     # [rad/s^2/sqrt(Hz)] bias random walk

    # --- GPS ------------------------------------------------------------------
    gps_rate_hz: float = 5.0                 # fix rate [Hz]
    gps_latency_s: float = 0.15              # fix delivered at t is valid at t - latency [s]
    gps_pos_white_sigma_h: float = 0.3       # white position error, per horizontal axis [m]
    gps_pos_white_sigma_v: float = 0.6       # white position error, vertical [m]
    gps_pos_gm_sigma_h: float = 0.2          # Gauss-Markov (minutes) sigma, per horiz. axis [m]
    gps_pos_gm_sigma_v: float = 0.4          # Gauss-Markov (minutes) sigma, vertical [m]
    gps_pos_gm_tau_s: float = 60.0           # Gauss-Markov correlation time [s]
    gps_vel_sigma_h: float = 0.1             # white velocity error, per horizontal axis [m/s]
    gps_vel_sigma_v: float = 0.15            # white velocity error, vertical [m/s]
    gps_fix_type: int = 3                    # GPS_FIX_TYPE_3D_FIX
    gps_satellites_initial: int = 12         # visible satellites at start
    gps_satellites_min: int = 10
    gps_satellites_max: int = 14
    gps_satellite_change_per_s: float = 0.05  # mean rate of +-1 changes of the count [1/s]

    # --- barometer ------------------------------------------------------------
    baro_rate_hz: float = 50.0               # update rate [Hz]
    baro_noise_sigma_pa: float = 3.0         # white pressure noise per sample [Pa]
    baro_tendency_sigma_pa_s: float = 1e2 / (3 * 3600.0)  # weather drift rate, 1 sigma [Pa/s]
    baro_drift_rw_density: float = 0.0      # pressure drift random walk [Pa/sqrt(s)]
    baro_temperature_sigma_k: float = 0.05   # temperature noise per sample [K]

    # --- magnetometer ----------------------------------------------------------
    mag_rate_hz: float = 50.0                # update rate [Hz]
    mag_noise_sigma_gauss: float = 0.005     # white noise per axis per sample [gauss]
    mag_hard_iron_gauss: tuple[float, float, float] = (0.0, 0.0, 0.0)  # body-axis offset [gauss]
    mag_epoch_year: float = 2025.0           # decimal year for IGRF-13 (2020.0 .. 2025.0)

    # --- airspeed (pitot-static differential pressure) -------------------------------
    airspeed_rate_hz: float = 50.0           # update rate [Hz]
    airspeed_noise_sigma_pa: float = 1.5     # white differential-pressure noise [Pa]
    airspeed_offset_pa: float = 0.0          # constant differential-pressure offset [Pa]

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "mag_hard_iron_gauss":
                if len(v) != 3:
                    raise ValueError("mag_hard_iron_gauss needs 3 components")
                continue
            if f.name == "airspeed_offset_pa":
                continue
            if not math.isfinite(v) or v < 0:
                raise ValueError(f"SensorParams.{f.name} must be finite and >= 0, not {v}")
        for rate in ("gps_rate_hz", "baro_rate_hz", "mag_rate_hz", "airspeed_rate_hz"):
            if getattr(self, rate) <= 0.0:
                raise ValueError(f"SensorParams.{rate} must be > 0")
        if self.gps_pos_gm_tau_s <= 0.0:
            raise ValueError("SensorParams.gps_pos_gm_tau_s must be > 0")
        if not (self.gps_satellites_min <= self.gps_satellites_initial
                <= self.gps_satellites_max):
            raise ValueError("gps_satellites_initial must lie in [min, max]")
