"""Noise and timing parameters of the sensor models, with where each default comes from.

All values are SI: m, s, rad, Pa, K; magnetic field in gauss (1 G = 100 uT = 1e5 nT).
"Density" values are continuous-time spectral densities; the models discretise them
with the step ``dt``:  white sigma = density / sqrt(dt) (= density * sqrt(rate)),
random-walk increment sigma = density * sqrt(dt).

The defaults are data-sheet figures of the usual parts (IMU: ICM-20602 / BMI088; GPS:
u-blox M8N / M9N; barometer: MS5611; magnetometer: HMC5883L / IST8310; airspeed:
MS4525DO) with a margin for the airframe. The GPS error is told apart by time scale:
white fix to fix, a first-order Gauss-Markov wander over minutes, and the hours-scale
offset the data sheet's accuracy measures, left out of the defaults (no filter can
observe it over a flight) and put back, pessimistically, by :data:`GPS_LONG_HORIZON`.
The barometer drifts with the weather's pressure tendency, a constant rate per flight.
``GPS_PRESETS`` names the receiver models ``--gps`` chooses.

Each default with its source, and how the reference SITLs (ArduPilot's, PX4's Gazebo
plugins) model the same sensor: docs/simulator.md, "The sensor models".
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
