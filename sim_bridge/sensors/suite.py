"""The sensor suite: IMU, GPS, barometer, magnetometer and airspeed from plant truth.

Models (parameters and their sources in :mod:`sim_bridge.sensors.params`):

* IMU, every step (``dt``):  ``accel = f_b + b_a + w_a``,  ``gyro = omega_b + b_g + w_g``
  with white noise ``w ~ N(0, (N / sqrt(dt))^2)`` from the noise density ``N``, and
  biases ``b = b_turn_on + random walk``, ``b_k+1 = b_k + K sqrt(dt) n``.
* GPS at ``gps_rate_hz`` (5 Hz): position error ``e = m + w`` with ``m`` a first-order
  Gauss-Markov process per NED axis, exactly discretised over the fix interval ``T``:
  ``m_k+1 = exp(-T/tau) m_k + sigma sqrt(1 - exp(-2T/tau)) n``, and ``w`` white. Velocity
  error white. The fix computed from the truth at ``t`` is delivered at the first step
  with time ``>= t + gps_latency_s`` (a delay line). ``eph_m = sqrt(2 (s_gm_h^2 +
  s_w_h^2))`` and ``epv_m = sqrt(s_gm_v^2 + s_w_v^2)`` are the 1-sigma accuracies of
  exactly this error model. The satellite count wanders by +-1 within [min, max].
* Barometer at ``baro_rate_hz`` (50 Hz, MS5611's usual rate with OSR 4096 alternating
  pressure and temperature conversions): ``p = p_true + drift + w``, drift a random
  walk. ``p_true`` is the plant's ``pressure_pa``; a plant that leaves the field at its
  default (101325 Pa exactly) gets the ISA pressure at its altitude instead (at sea
  level the two agree). Likewise temperature (default 288.15 K) and density
  (default 1.225 kg/m^3). Pressure altitude = ISA altitude of the measured pressure.
* Magnetometer at ``mag_rate_hz``: ``m_b = R(q_nb)^T B_ned + hard_iron + w``; ``B_ned`` is
  the IGRF-13 field evaluated once at home (the first sampled position, or
  :meth:`SensorSuite.set_home`); the field is constant over the flight area.
* Airspeed at ``airspeed_rate_hz``: ``dp = 1/2 rho V_true^2 + offset + w``; reported
  ``airspeed_mps = sqrt(2 max(dp, 0) / rho0)``, rho0 = 1.225 kg/m^3: the equivalent
  airspeed (EAS), which is what an uncorrected pitot gives and what ArduPilot and PX4
  report as indicated airspeed.

Randomness: one injected ``numpy.random.Generator``. Construction draws the turn-on
biases and the initial Gauss-Markov state; then ``sample`` takes one row of a
pre-drawn block of ``_NCOL`` standard normals per step, whatever sensors update at that
step (fixed column per use), so a seed reproduces bit-identical output and the noise of
one sensor does not depend on the rates of the others.
"""
from __future__ import annotations

import math
from collections import deque
from statistics import NormalDist

import numpy as np

from autopilot.geo import meridian_radius, prime_vertical_radius

from . import isa
from autopilot.geo.magfield import igrf_field_ned_gauss
from .params import SensorParams
from .readings import GpsReading, SensorReadings, next_due_us
from .readings import period_us as _period_us

# Column layout of one step's row of standard normals.
_IMU_WHITE = slice(0, 6)      # accel xyz, gyro xyz
_IMU_RW = slice(6, 12)        # accel bias xyz, gyro bias xyz increments
_N_IMU = 12
# the remaining columns, as offsets into the Python list of the row:
_BARO_W, _BARO_RW, _TEMP_W = 0, 1, 2
_MAG_W = 3                    # 3, 4, 5
_DP_W = 6
_GPS_POS_W = 7                # 7, 8, 9
_GPS_GM = 10                  # 10, 11, 12
_GPS_VEL = 13                 # 13, 14, 15
_GPS_SATS = 16
_NCOL = _N_IMU + 17
_BLOCK_ROWS = 512

# Sentinels: PlantState's default values mean "the plant did not provide this".
_DEFAULT_PRESSURE_PA = 101325.0
_DEFAULT_TEMPERATURE_K = 288.15
_DEFAULT_RHO_KGM3 = 1.225


class SensorSuite:
    """IMU + GPS + baro + mag + airspeed; ``sample(state)`` once per plant step."""

    def __init__(self, params: SensorParams, rng: np.random.Generator, dt_s: float):
        if dt_s <= 0.0:
            raise ValueError("dt_s must be > 0")
        self.params = p = params
        self.dt_s = float(dt_s)
        self._rng = rng

        # IMU: per-step white sigma and random-walk increment sigma
        sq = math.sqrt(self.dt_s)
        self._imu_white_scale = np.array(
            [p.accel_noise_density / sq] * 3 + [p.gyro_noise_density / sq] * 3)
        self._imu_rw_scale = np.array(
            [p.accel_bias_rw_density * sq] * 3 + [p.gyro_bias_rw_density * sq] * 3)

        # Draws at construction, in this fixed order: turn-on biases, GM initial state,
        # the barometer's weather tendency.
        turn_on = rng.standard_normal(6)
        turn_on[:3] *= p.accel_bias_turn_on_sigma
        turn_on[3:] *= p.gyro_bias_turn_on_sigma
        self._bias_carry = turn_on               # bias after the last row of the last block
        gm0 = rng.standard_normal(3)
        self._gm_sigma = (p.gps_pos_gm_sigma_h, p.gps_pos_gm_sigma_h, p.gps_pos_gm_sigma_v)
        self._gps_gm = [gm0[i] * self._gm_sigma[i] for i in range(3)]
        self._baro_tendency_pa_s = float(rng.standard_normal()) * p.baro_tendency_sigma_pa_s

        # Noise block state
        self._imu_err = np.zeros((0, 6))         # white + bias per row
        self._imu_bias = np.zeros((0, 6))        # bias per row
        self._block = np.zeros((0, _NCOL))
        self._row = _BLOCK_ROWS                  # forces a draw at the first sample

        # Schedules (set at the first sample)
        self._baro_period_us = _period_us(p.baro_rate_hz)
        self._mag_period_us = _period_us(p.mag_rate_hz)
        self._arsp_period_us = _period_us(p.airspeed_rate_hz)
        self._gps_period_us = _period_us(p.gps_rate_hz)
        self._gps_latency_us = int(round(p.gps_latency_s * 1e6))
        self._next_baro_us = self._next_mag_us = self._next_arsp_us = None
        self._next_gps_us = None
        # the first of those and of the queued fix's delivery: before it, a step is
        # the IMU's alone
        self._next_due_us = -1

        # Baro
        self._baro_drift_pa = 0.0
        self._baro_drift_k = p.baro_drift_rw_density * math.sqrt(self._baro_period_us * 1e-6)
        self._pressure_pa = isa.P0_PA
        self._pressure_alt_m = 0.0
        self._temperature_k = isa.T0_K

        # Mag
        self._b_ned: tuple[float, float, float] | None = None
        self._hard_iron = tuple(float(v) for v in p.mag_hard_iron_gauss)
        self._mag_b = (0.0, 0.0, 0.0)

        # Airspeed
        self._dp_pa = 0.0
        self._airspeed_mps = 0.0

        # GPS
        T = self._gps_period_us * 1e-6
        self._gm_a = math.exp(-T / p.gps_pos_gm_tau_s)
        qa = math.sqrt(max(0.0, 1.0 - self._gm_a * self._gm_a))
        self._gm_q = tuple(s * qa for s in self._gm_sigma)
        self._gps_white = (p.gps_pos_white_sigma_h, p.gps_pos_white_sigma_h,
                           p.gps_pos_white_sigma_v)
        self._gps_vel = (p.gps_vel_sigma_h, p.gps_vel_sigma_h, p.gps_vel_sigma_v)
        self.eph_m = math.sqrt(2.0 * (p.gps_pos_gm_sigma_h ** 2 + p.gps_pos_white_sigma_h ** 2))
        self.epv_m = math.sqrt(p.gps_pos_gm_sigma_v ** 2 + p.gps_pos_white_sigma_v ** 2)
        self._sats = int(p.gps_satellites_initial)
        p_change = p.gps_satellite_change_per_s * T
        self._sats_z = (NormalDist().inv_cdf(1.0 - 0.5 * p_change)
                        if 0.0 < p_change < 1.0 else (0.0 if p_change >= 1.0 else math.inf))
        self._gps_queue: deque = deque()

    # --- home and introspection --------------------------------------------------

    def set_home(self, lat_rad: float, lon_rad: float, alt_m: float) -> None:
        """Evaluate the IGRF-13 field at home (done at the first sample otherwise)."""
        self._b_ned = igrf_field_ned_gauss(lat_rad, lon_rad, alt_m, self.params.mag_epoch_year)

    @property
    def mag_field_ned_gauss(self) -> tuple[float, float, float] | None:
        """The Earth field used by the magnetometer model, NED [gauss]."""
        return self._b_ned

    @property
    def imu_bias(self) -> tuple[np.ndarray, np.ndarray]:
        """True (accel [m/s^2], gyro [rad/s]) biases in effect at the last sample."""
        b = self._imu_bias[self._row - 1] if self._row > 0 and len(self._imu_bias) else self._bias_carry
        return b[:3].copy(), b[3:].copy()

    @property
    def gps_error_gm_ned(self) -> tuple[float, float, float]:
        """Current Gauss-Markov part of the GPS position error, NED [m] (truth, for tests)."""
        return tuple(self._gps_gm)

    # --- the per-step call -------------------------------------------------------

    def _draw_block(self) -> None:
        block = self._rng.standard_normal((_BLOCK_ROWS, _NCOL))
        bias = np.cumsum(block[:, _IMU_RW] * self._imu_rw_scale, axis=0)
        bias += self._bias_carry
        self._bias_carry = bias[-1].copy()
        self._imu_bias = bias
        self._imu_err = block[:, _IMU_WHITE] * self._imu_white_scale + bias
        # one flat list of floats: the cyclic garbage collector tracks every list, and
        # the block's 512 row lists were 512 objects in its young generation (most of
        # what its collections walked in flight); one flat list is one
        self._imu_err_flat = self._imu_err.ravel().tolist()
        # the slower sensors' columns are read row by row at the steps where one of them
        # updates (converting the whole block cost more than the reads it spared)
        self._block = block
        self._row = 0

    def sample(self, state) -> SensorReadings:
        """Readings at ``state.t_us`` from the truth ``state`` (a PlantState)."""
        i = self._row
        if i >= _BLOCK_ROWS:
            self._draw_block()
            i = 0
        self._row = i + 1
        t_us = state.t_us

        # IMU (truth + this row's white noise and bias)
        fx, fy, fz = state.f_b
        wx, wy, wz = state.omega_b
        ex, ey, ez, egx, egy, egz = self._imu_err_flat[6 * i:6 * i + 6]
        accel = (fx + ex, fy + ey, fz + ez)
        gyro = (wx + egx, wy + egy, wz + egz)

        if t_us < self._next_due_us:            # the IMU's step alone: the others held
            return SensorReadings.make(
                t_us, accel, gyro, self._mag_b,
                self._pressure_pa, self._pressure_alt_m, self._temperature_k,
                self._dp_pa, self._airspeed_mps, False, False, False, None)

        nxt = self._next_baro_us
        baro_updated = nxt is None or t_us >= nxt
        nxt = self._next_mag_us
        mag_updated = nxt is None or t_us >= nxt
        nxt = self._next_arsp_us
        arsp_updated = nxt is None or t_us >= nxt
        nxt = self._next_gps_us
        gps_epoch = nxt is None or t_us >= nxt
        if baro_updated or mag_updated or arsp_updated or gps_epoch:
            n = self._block[i, _N_IMU:].tolist()  # this step's normals of those sensors

        # Barometer
        if baro_updated:
            self._next_baro_us = self._advance(self._next_baro_us, self._baro_period_us, t_us)
            alt = state.alt_m
            p_true = state.pressure_pa
            if p_true == _DEFAULT_PRESSURE_PA:
                p_true = isa.pressure_pa(alt)
            temp = state.temperature_k
            if temp == _DEFAULT_TEMPERATURE_K:
                temp = isa.temperature_k(alt)
            prm = self.params
            self._baro_drift_pa += self._baro_drift_k * n[_BARO_RW]
            pres = (p_true + self._baro_drift_pa + self._baro_tendency_pa_s * t_us * 1e-6
                    + prm.baro_noise_sigma_pa * n[_BARO_W])
            self._pressure_pa = pres
            self._pressure_alt_m = isa.pressure_altitude_m(pres)
            self._temperature_k = temp + prm.baro_temperature_sigma_k * n[_TEMP_W]

        # Magnetometer
        if mag_updated:
            self._next_mag_us = self._advance(self._next_mag_us, self._mag_period_us, t_us)
            if self._b_ned is None:
                self.set_home(state.lat_rad, state.lon_rad, state.alt_m)
            bn, be, bd = self._b_ned
            w, x, y, z = state.q_nb
            hx, hy, hz = self._hard_iron
            s = self.params.mag_noise_sigma_gauss
            # m_b = R(q_nb)^T B_ned (columns of R as rows)
            self._mag_b = (
                (w * w + x * x - y * y - z * z) * bn + 2.0 * (x * y + w * z) * be
                + 2.0 * (x * z - w * y) * bd + hx + s * n[_MAG_W],
                2.0 * (x * y - w * z) * bn + (w * w - x * x + y * y - z * z) * be
                + 2.0 * (y * z + w * x) * bd + hy + s * n[_MAG_W + 1],
                2.0 * (x * z + w * y) * bn + 2.0 * (y * z - w * x) * be
                + (w * w - x * x - y * y + z * z) * bd + hz + s * n[_MAG_W + 2],
            )

        # Airspeed
        if arsp_updated:
            self._next_arsp_us = self._advance(self._next_arsp_us, self._arsp_period_us, t_us)
            rho = state.rho_kgm3
            if rho == _DEFAULT_RHO_KGM3:
                rho = isa.density_kgm3(state.alt_m)
            v = state.airspeed_mps
            dp = (0.5 * rho * v * v + self.params.airspeed_offset_pa
                  + self.params.airspeed_noise_sigma_pa * n[_DP_W])
            self._dp_pa = dp
            self._airspeed_mps = math.sqrt(2.0 * dp / isa.RHO0_KGM3) if dp > 0.0 else 0.0

        # GPS: compute a fix at its epoch, deliver it after the latency
        if gps_epoch:
            self._next_gps_us = self._advance(self._next_gps_us, self._gps_period_us, t_us)
            self._gps_epoch(state, n)
        gps = None
        q = self._gps_queue
        if q and q[0][0] <= t_us:
            _, t_valid, lat, lon, alt, v_ned, sats = q.popleft()
            gps = GpsReading.make(t_us, lat, lon, alt, v_ned, self.eph_m, self.epv_m,
                                  self.params.gps_fix_type, sats, t_valid)
        nxt = min(self._next_baro_us, self._next_mag_us, self._next_arsp_us,
                  self._next_gps_us)
        self._next_due_us = q[0][0] if q and q[0][0] < nxt else nxt

        return SensorReadings.make(
            t_us, accel, gyro, self._mag_b,
            self._pressure_pa, self._pressure_alt_m, self._temperature_k,
            self._dp_pa, self._airspeed_mps,
            baro_updated, mag_updated, arsp_updated, gps)

    _advance = staticmethod(next_due_us)

    def _gps_epoch(self, state, n: list[float]) -> None:
        gm, a, qs = self._gps_gm, self._gm_a, self._gm_q
        for k in range(3):
            gm[k] = a * gm[k] + qs[k] * n[_GPS_GM + k]
        wn, we, wd = self._gps_white
        en = gm[0] + wn * n[_GPS_POS_W]
        ee = gm[1] + we * n[_GPS_POS_W + 1]
        ed = gm[2] + wd * n[_GPS_POS_W + 2]
        lat, alt = state.lat_rad, state.alt_m
        lat_fix = lat + en / (meridian_radius(lat) + alt)
        lon_fix = state.lon_rad + ee / ((prime_vertical_radius(lat) + alt) * math.cos(lat))
        lon_fix = (lon_fix + math.pi) % (2.0 * math.pi) - math.pi
        alt_fix = alt - ed
        vn, ve, vd = state.v_ned
        sh, _, sv = self._gps_vel
        v_ned = (vn + sh * n[_GPS_VEL], ve + sh * n[_GPS_VEL + 1], vd + sv * n[_GPS_VEL + 2])
        # satellites: a +-1 step with probability p per epoch, reflected at the bounds
        zs = n[_GPS_SATS]
        if abs(zs) > self._sats_z:
            prm = self.params
            step = 1 if zs > 0.0 else -1
            s = self._sats + step
            if s > prm.gps_satellites_max or s < prm.gps_satellites_min:
                s = self._sats - step
            self._sats = min(max(s, prm.gps_satellites_min), prm.gps_satellites_max)
        self._gps_queue.append((state.t_us + self._gps_latency_us, state.t_us,
                                lat_fix, lon_fix, alt_fix, v_ned, self._sats))
