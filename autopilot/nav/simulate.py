"""A small, fast sensor simulator for testing the navigation filters.

Not the product's plant (that is sim_bridge/): a kinematic fixed-wing flying
coordinated turns, climbs and straight legs in a steady wind, with the sensor error
models the filters are designed for. Every random draw comes from the injected
``numpy.random.Generator``, so a seed gives a bit-identical run.

Truth is generated first as arrays (air-relative heading, bank and flight-path angle
integrated with rate limits; attitude = wind axes rotated by a constant angle of
attack, so sideslip is zero; position integrated trapezoidally). The IMU is derived
from the truth so that a perfect mechanisation (:mod:`.strapdown`) reproduces it, and
its samples are timed as the simulator's (JSBSim's) are: frame k carries the truth at
t_k, the gyro as a point sample at t_k (the mean rate of the two steps around t_k, so
that the trapezoid of two samples is the rotation of the step between them) and the
specific force over the step [t_(k-1), t_k] (at its middle). The gyro measures the
rotation relative to inertial space (plus the Earth rate), the accelerometer the
specific force in the rotating frame (Coriolis included), gravity falls off with
height: the same physics as the mechanisation and the flight simulator.

Sensor models: the defaults of :class:`SimConfig` are those of the flight simulator's
sensor suite (``sim_bridge/sensors/params.py``), so that the filters' defaults
(config.py) are tested against the sensors they fly with:

* IMU 100 Hz: accelerometer 1.5e-3 m/s^2/sqrt(Hz) (0.015 m/s^2 per sample), gyro
  0.01 deg/s/sqrt(Hz) (1.75e-3 rad/s per sample); constant biases (the flight
  simulator's also wander: the filters' bias random walks are its values).
* GPS 5 Hz, 150 ms latency (a fix arriving at t describes t - 0.15 s); horizontal
  error = first-order Gauss-Markov (0.2 m per axis, tau 60 s) + 0.3 m white per axis;
  vertical GM 0.4 m + 0.6 m white; velocity white 0.1 m/s per horizontal axis and
  0.15 m/s vertical. Reported eph = the radial horizontal 1-sigma
  sqrt(2 (gm^2 + white^2)), epv the vertical one (as the flight simulator's).
* Baro: 0.3 m white (3 Pa), a datum offset from the GPS altitude and a random-walk
  drift of 0.008 m/sqrt(s) (the flight simulator's weather tendency, 0.8 mm/s at one
  sigma, has this spread after about 100 s).
* Magnetometer: 0.5 gauss field, inclination -66 deg, declination 12 deg, 0.005 gauss noise.
* Airspeed: a pitot's dynamic pressure 1/2 rho V^2 (rho of the ISA atmosphere at the
  altitude, as the baro's pressure and temperature) with 1.5 Pa white noise; the
  reported airspeed is the equivalent airspeed sqrt(2 q / 1.225).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import numpy as np

from autopilot.geo import LocalFrame, euler_to_quat, gravity_m_s2
from autopilot.messages import (AirspeedSample, BaroSample, GpsFix, ImuSample, MagSample,
                                SensorFrame)

from . import qbatch
from .strapdown import GRAVITY_GRADIENT, earth_rate_ned


@dataclass(frozen=True)
class SimConfig:
    dt_s: float = 0.01
    origin_lat_deg: float = -35.363
    origin_lon_deg: float = 149.165
    origin_alt_m: float = 584.0
    airspeed_mps: float = 22.0
    alpha_rad: float = 0.05
    roll_rate_max: float = math.radians(15.0)       # [rad/s]
    gamma_rate_max: float = 0.05                    # [rad/s]
    wind_ned: tuple[float, float, float] = (3.0, 4.0, 0.0)
    # IMU
    accel_noise: float = 0.015                      # [m/s^2] per sample (1.5e-3 /sqrt(Hz))
    gyro_noise: float = 1.745e-3                    # [rad/s] per sample (0.01 deg/s /sqrt(Hz))
    accel_bias: tuple[float, float, float] = (0.05, -0.04, 0.06)
    gyro_bias: tuple[float, float, float] = (0.002, -0.003, 0.002)
    # GPS
    gps_rate_hz: float = 5.0
    gps_latency_s: float = 0.15
    gps_gm_sigma_m: float = 0.2                     # per horizontal axis
    gps_gm_tau_s: float = 60.0
    gps_white_m: float = 0.3                        # per horizontal axis
    gps_vert_gm_m: float = 0.4
    gps_vert_white_m: float = 0.6
    gps_vel_sigma: float = 0.1                      # per horizontal axis
    gps_vel_sigma_v: float = 0.15                   # vertical
    # other sensors
    baro_rate_hz: float = 50.0
    baro_sigma: float = 0.3
    baro_offset_m: float = 4.0
    baro_drift: float = 0.008                       # random walk [m/sqrt(s)]
    mag_rate_hz: float = 50.0
    mag_gauss: float = 0.5
    mag_inclination_deg: float = -66.0
    mag_declination_deg: float = 12.0
    mag_sigma: float = 0.005
    airspeed_rate_hz: float = 50.0
    airspeed_sigma_pa: float = 1.5                  # dynamic pressure noise [Pa]

    def origin(self) -> LocalFrame:
        return LocalFrame.from_degrees(self.origin_lat_deg, self.origin_lon_deg, self.origin_alt_m)

    def earth_rate_ned(self) -> tuple[float, float, float]:
        return earth_rate_ned(math.radians(self.origin_lat_deg))

    def mag_ned(self) -> np.ndarray:
        inc = math.radians(self.mag_inclination_deg)
        dec = math.radians(self.mag_declination_deg)
        return self.mag_gauss * np.array([math.cos(inc) * math.cos(dec),
                                          math.cos(inc) * math.sin(dec), math.sin(inc)])


#: A manoeuvring fixed-wing profile: (duration [s], bank [deg], climb rate [m/s]).
DEFAULT_SEGMENTS: tuple[tuple[float, float, float], ...] = (
    (20.0, 0.0, 0.0), (25.0, 28.0, 0.0), (15.0, 0.0, 2.0), (30.0, -25.0, 0.0),
    (20.0, 0.0, -1.5), (20.0, 30.0, 1.0), (20.0, 0.0, 0.0), (25.0, -28.0, 0.0),
)


@dataclass
class SimRun:
    """Truth arrays (index k <-> t_us[k]) and the sensor frames of one run."""

    cfg: SimConfig
    t_us: np.ndarray                  # (N,)
    p_ned: np.ndarray                 # (N, 3)
    v_ned: np.ndarray                 # (N, 3)
    q_nb: np.ndarray                  # (N, 4)
    omega_b: np.ndarray               # (N, 3) true rate over [t_k, t_k+1]
    wind_ned: np.ndarray              # (3,)
    gps_err_ned: np.ndarray           # (N, 3) GPS position error of a fix valid at t_k (NaN if none)
    _imu_f: np.ndarray = field(repr=False, default=None)
    _imu_w: np.ndarray = field(repr=False, default=None)
    _gps: dict = field(repr=False, default_factory=dict)
    _baro: dict = field(repr=False, default_factory=dict)
    _mag: dict = field(repr=False, default_factory=dict)
    _arsp: dict = field(repr=False, default_factory=dict)

    def __len__(self) -> int:
        return len(self.t_us)

    def frames(self, start: int = 0, stop: int | None = None) -> Iterator[SensorFrame]:
        stop = len(self.t_us) if stop is None else stop
        for k in range(start, stop):
            t = int(self.t_us[k])
            yield SensorFrame(
                t_us=t,
                imu=ImuSample(t, tuple(self._imu_f[k].tolist()), tuple(self._imu_w[k].tolist())),
                mag=self._mag.get(k), baro=self._baro.get(k),
                airspeed=self._arsp.get(k), gps=self._gps.get(k))


_R_AIR = 287.05287     # specific gas constant of dry air [J/(kg K)]
_RHO0 = 1.225          # sea-level ISA density [kg/m^3]


def _isa(alt_m: float) -> tuple[float, float]:
    """ISA troposphere: (pressure [Pa], temperature [K]) at a pressure altitude."""
    return 101325.0 * (1.0 - 2.25577e-5 * alt_m) ** 5.25588, 288.15 - 0.0065 * alt_m


def _gauss_markov(rng: np.random.Generator, n: int, sigma: float, tau: float, dt: float) -> np.ndarray:
    e = np.empty(n)
    if n == 0:
        return e
    a = math.exp(-dt / tau)
    b = sigma * math.sqrt(1.0 - a * a)
    w = rng.standard_normal(n)
    e[0] = sigma * w[0]
    for i in range(1, n):
        e[i] = a * e[i - 1] + b * w[i]
    return e


def simulate_flight(rng: np.random.Generator, cfg: SimConfig = SimConfig(),
                    segments: Sequence[tuple[float, float, float]] = DEFAULT_SEGMENTS,
                    heading0_rad: float = 0.0, repeat: int = 1, duration_s: float | None = None,
                    gps_outages: Sequence[tuple[float, float]] = (),
                    gps_glitches: Sequence[tuple[float, float, Sequence[float]]] = (),
                    start_alt_m: float = 100.0) -> SimRun:
    """A fixed-wing flight through ``segments`` (repeated ``repeat`` times, or cycled
    and cut to ``duration_s`` when given).

    ``gps_outages``: (t0, t1) [s] windows without GPS fixes (by arrival time);
    ``gps_glitches``: (t0, t1, offset_ned [m]) windows whose fixes are shifted.
    """
    dt = cfg.dt_s
    segs = list(segments) * repeat
    if duration_s is not None:
        segs, total = [], 0.0
        while total < duration_s - 1e-9:
            for d, b, c in segments:
                d = min(d, duration_s - total)
                if d <= 1e-9:
                    break
                segs.append((d, b, c))
                total += d
    steps = [int(round(d / dt)) for d, _, _ in segs]
    n = sum(steps) + 1
    bank_tgt = np.repeat([math.radians(b) for _, b, _ in segs], steps)
    climb_tgt = np.repeat([c for _, _, c in segs], steps)
    va = cfg.airspeed_mps
    g = gravity_m_s2(math.radians(cfg.origin_lat_deg), cfg.origin_alt_m)

    # --- truth: bank, flight-path angle, air-relative heading -------------------------
    phi = np.zeros(n)
    gam = np.zeros(n)
    chi = np.zeros(n)
    chi[0] = heading0_rad
    droll = cfg.roll_rate_max * dt
    dgam = cfg.gamma_rate_max * dt
    ph, ga, ch = 0.0, 0.0, heading0_rad
    for k in range(n - 1):
        ph_new = ph + min(max(bank_tgt[k] - ph, -droll), droll)
        gt = math.asin(climb_tgt[k] / va)
        ga += min(max(gt - ga, -dgam), dgam)
        ch += g * math.tan(0.5 * (ph + ph_new)) / (va * math.cos(ga)) * dt
        ph = ph_new
        phi[k + 1], gam[k + 1], chi[k + 1] = ph, ga, ch
    q_w = qbatch.from_euler(phi, gam, chi)                 # wind axes
    q_a = np.array([math.cos(0.5 * cfg.alpha_rad), 0.0, math.sin(0.5 * cfg.alpha_rad), 0.0])
    q = qbatch.normalize(qbatch.mul(q_w, q_a))             # body = wind axes pitched by alpha
    wind = np.array(cfg.wind_ned, dtype=float)
    v_air = va * np.stack((np.cos(gam) * np.cos(chi), np.cos(gam) * np.sin(chi), -np.sin(gam)), axis=-1)
    v = v_air + wind
    p = np.empty((n, 3))
    p[0] = (0.0, 0.0, -start_alt_m)
    p[1:] = p[0] + np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)
    return _sensors(rng, cfg, p, v, q, wind, np.full(n, va), g, gps_outages, gps_glitches)


def simulate_static(rng: np.random.Generator, cfg: SimConfig = SimConfig(), duration_s: float = 3.0,
                    roll_rad: float = 0.02, pitch_rad: float = -0.03, yaw_rad: float = 1.0,
                    with_gps: bool = True) -> SimRun:
    """A vehicle resting on the ground at the origin (zero airspeed, zero wind)."""
    n = int(round(duration_s / cfg.dt_s)) + 1
    g = gravity_m_s2(math.radians(cfg.origin_lat_deg), cfg.origin_alt_m)
    q = np.tile(euler_to_quat(roll_rad, pitch_rad, yaw_rad), (n, 1))
    p = np.zeros((n, 3))
    v = np.zeros((n, 3))
    outages = () if with_gps else ((0.0, duration_s + 1.0),)
    return _sensors(rng, cfg, p, v, q, np.zeros(3), np.zeros(n), g, outages, ())


def _sensors(rng, cfg: SimConfig, p, v, q, wind, airspeed, g, gps_outages, gps_glitches) -> SimRun:
    n = len(p)
    dt = cfg.dt_s
    t_us = np.arange(n, dtype=np.int64) * int(round(dt * 1e6))
    # true body rate over [t_k, t_k+1]: q_k+1 = q_k (x) Exp(omega_k dt)
    omega = np.zeros((n, 3))
    omega[:-1] = qbatch.to_rotvec(qbatch.mul(qbatch.conj(q[:-1]), q[1:])) / dt
    omega[-1] = omega[-2] if n > 1 else 0.0
    # specific force at mid-step, body axes, in the rotating Earth frame:
    # f_n = dv/dt - g_n + 2 w_ie x v  (g_n grows with depth below the origin)
    w_ie = np.array(cfg.earth_rate_ned())
    a = np.zeros((n, 3))
    a[:-1] = (v[1:] - v[:-1]) / dt
    v_mid = v.copy()
    v_mid[:-1] = 0.5 * (v[1:] + v[:-1])
    pd_mid = p[:, 2].copy()
    pd_mid[:-1] = 0.5 * (p[1:, 2] + p[:-1, 2])
    a[:, 2] -= g + GRAVITY_GRADIENT * pd_mid
    a += 2.0 * qbatch.cross(w_ie, v_mid)
    q_mid = qbatch.mul(q, qbatch.from_rotvec(0.5 * dt * omega))
    f = np.einsum("nji,nj->ni", qbatch.to_dcm(q_mid), a)
    # frame k carries the specific force of [t_k-1, t_k] and the gyro's point sample at
    # t_k: the mean rate of the steps before and after it, plus the Earth rate
    f_true = np.vstack((f[:1], f[:-1]))
    w_true = np.vstack((omega[:1], 0.5 * (omega[:-1] + omega[1:])))
    w_true += np.einsum("nji,j->ni", qbatch.to_dcm(q), w_ie)
    imu_f = f_true + np.array(cfg.accel_bias) + cfg.accel_noise * rng.standard_normal((n, 3))
    imu_w = w_true + np.array(cfg.gyro_bias) + cfg.gyro_noise * rng.standard_normal((n, 3))

    origin = cfg.origin()
    # --- GPS --------------------------------------------------------------------------
    every = int(round(1.0 / (cfg.gps_rate_hz * dt)))
    lag = int(round(cfg.gps_latency_s / dt))
    ks = np.arange(every, n, every)
    ks = ks[ks - lag >= 0]
    m = len(ks)
    gdt = every * dt
    err = np.empty((m, 3))
    for axis, (gm, white) in enumerate(((cfg.gps_gm_sigma_m, cfg.gps_white_m),
                                        (cfg.gps_gm_sigma_m, cfg.gps_white_m),
                                        (cfg.gps_vert_gm_m, cfg.gps_vert_white_m))):
        err[:, axis] = _gauss_markov(rng, m, gm, cfg.gps_gm_tau_s, gdt)   # draw order matters:
        err[:, axis] += white * rng.standard_normal(m)                     # golden runs use it
    verr = rng.standard_normal((m, 3)) * np.array([cfg.gps_vel_sigma, cfg.gps_vel_sigma, cfg.gps_vel_sigma_v])
    eph = math.sqrt(2.0) * math.hypot(cfg.gps_gm_sigma_m, cfg.gps_white_m)   # radial
    epv = math.hypot(cfg.gps_vert_gm_m, cfg.gps_vert_white_m)
    gps = {}
    gps_err = np.full((n, 3), np.nan)
    for j, k in enumerate(ks):
        t_s = k * dt
        if any(t0 <= t_s < t1 for t0, t1 in gps_outages):
            continue
        e = err[j].copy()
        for t0, t1, off in gps_glitches:
            if t0 <= t_s < t1:
                e = e + np.asarray(off, dtype=float)
        kv = k - lag
        lat, lon, alt = origin.to_geodetic_fast(p[kv] + e)
        gps[int(k)] = GpsFix(int(t_us[k]), lat, lon, alt, v[kv] + verr[j], eph, epv, 3, 12)
        gps_err[kv] = e

    # --- baro, magnetometer, airspeed -------------------------------------------------
    def ticks(rate):
        step = max(1, int(round(1.0 / (rate * dt))))
        return np.arange(0, n, step)

    baro = {}
    kb = ticks(cfg.baro_rate_hz)
    nb = cfg.baro_sigma * rng.standard_normal(len(kb))
    drift = np.cumsum(cfg.baro_drift * math.sqrt(dt * (kb[1] - kb[0] if len(kb) > 1 else 1))
                      * rng.standard_normal(len(kb)))
    for j, k in enumerate(kb):
        alt = cfg.origin_alt_m - p[k, 2] + cfg.baro_offset_m + drift[j] + nb[j]
        pres, temp = _isa(alt)
        baro[int(k)] = BaroSample(int(t_us[k]), pres, float(alt), temp)
    mag = {}
    km = ticks(cfg.mag_rate_hz)
    R = qbatch.to_dcm(q[km])
    m_b = np.einsum("nji,j->ni", R, cfg.mag_ned()) + cfg.mag_sigma * rng.standard_normal((len(km), 3))
    for j, k in enumerate(km):
        mag[int(k)] = MagSample(int(t_us[k]), tuple(m_b[j].tolist()))
    arsp = {}
    ka = ticks(cfg.airspeed_rate_hz)
    na = cfg.airspeed_sigma_pa * rng.standard_normal(len(ka))
    for j, k in enumerate(ka):
        if airspeed[k] > 0.0:
            pres, temp = _isa(cfg.origin_alt_m - p[k, 2])
            rho = pres / (_R_AIR * temp)
            qbar = 0.5 * rho * float(airspeed[k]) ** 2 + na[j]
            arsp[int(k)] = AirspeedSample(int(t_us[k]), qbar, math.sqrt(2.0 * max(qbar, 0.0) / _RHO0))
    return SimRun(cfg, t_us, p, v, q, omega, wind, gps_err, imu_f, imu_w, gps, baro, mag, arsp)


# --------------------------------------------------------------------------- scoring --

@dataclass
class FilterTrace:
    """A filter run against a simulation: errors (estimate - truth) and 1-sigmas."""

    t_s: np.ndarray          # (N,)
    aligned: np.ndarray      # (N,) bool
    healthy: np.ndarray      # (N,) bool
    p_err: np.ndarray        # (N, 3) [m]
    v_err: np.ndarray        # (N, 3) [m/s]
    att_err: np.ndarray      # (N, 3) rotation vector of q_true (x) q_est^*, NED [rad]
    euler_err: np.ndarray    # (N, 3) roll, pitch, yaw (wrapped) [rad]
    sigma: np.ndarray        # (N, 9) 1-sigma of p, v, att
    records: list            # per step: the filter's innovation records (if kept)

    def after(self, t_from_s: float) -> np.ndarray:
        return (self.t_s >= t_from_s) & self.aligned


def run_filter(filt, sim: SimRun, start: int = 0, stop: int | None = None,
               keep_records: bool = True) -> FilterTrace:
    """Feed ``sim``'s frames to ``filt`` (anything with ``update(frame) -> NavState``
    and ``P``) and collect errors against the truth. Position is the filter's own
    estimate (``position_ned``, the state P describes) where it has one: under the
    barometric height reference the output's height is on the barometer's datum."""
    stop = len(sim) if stop is None else stop
    n = stop - start
    p = np.full((n, 3), np.nan)
    v = np.full((n, 3), np.nan)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    sig = np.full((n, 9), np.nan)
    aligned = np.zeros(n, dtype=bool)
    healthy = np.zeros(n, dtype=bool)
    records = []
    state_pos = hasattr(filt, "position_ned")
    for i, frame in enumerate(sim.frames(start, stop)):
        s = filt.update(frame)
        aligned[i] = s.aligned
        healthy[i] = s.healthy
        if keep_records:
            records.append(filt.innovations)
        if s.aligned:
            p[i], v[i], q[i] = (filt.position_ned if state_pos else s.p_ned), s.v_ned, s.q_nb
            sig[i] = np.sqrt(np.diagonal(filt.P)[:9])
    sl = slice(start, stop)
    att = qbatch.to_rotvec(qbatch.mul(sim.q_nb[sl], qbatch.conj(q)))
    de = qbatch.to_euler(q) - qbatch.to_euler(sim.q_nb[sl])
    de = (de + np.pi) % (2.0 * np.pi) - np.pi
    att[~aligned] = np.nan
    de[~aligned] = np.nan
    return FilterTrace(sim.t_us[sl] * 1e-6, aligned, healthy, p - sim.p_ned[sl], v - sim.v_ned[sl],
                       att, de, sig, records)


def accuracy(trace: FilterTrace, sim: SimRun, t_from_s: float) -> dict[str, float]:
    """The product's acceptance figures over samples after ``t_from_s``:
    nav_pos_h_rms, gps_pos_h_rms (of the fixes valid in the same window), their ratio,
    roll/pitch/yaw RMS [deg], and the fraction of samples with |error| <= 3 sigma for
    each position, velocity and attitude component (worst component and all nine)."""
    m = trace.after(t_from_s)
    pe = trace.p_err[m]
    nav_h = float(np.sqrt(np.mean(pe[:, 0] ** 2 + pe[:, 1] ** 2)))
    t0_us = t_from_s * 1e6
    ge = sim.gps_err_ned[(sim.t_us >= t0_us) & ~np.isnan(sim.gps_err_ned[:, 0])]
    gps_h = float(np.sqrt(np.mean(ge[:, 0] ** 2 + ge[:, 1] ** 2)))
    err = np.hstack((trace.p_err[m], trace.v_err[m], trace.att_err[m]))
    inside = np.mean(np.abs(err) <= 3.0 * trace.sigma[m], axis=0)
    rpy = np.degrees(np.sqrt(np.mean(trace.euler_err[m] ** 2, axis=0)))
    return {"nav_pos_h_rms": nav_h, "gps_pos_h_rms": gps_h, "ratio": nav_h / gps_h,
            "roll_rms_deg": float(rpy[0]), "pitch_rms_deg": float(rpy[1]), "yaw_rms_deg": float(rpy[2]),
            "inside_3sigma_min": float(inside.min()), "inside_3sigma": inside}


def golden_numbers(filt, trace: FilterTrace) -> dict[str, list[float]]:
    """Numbers that pin a run down for a golden regression: the final nominal state,
    the diagonal of P, and per source the sum of innovations, of test ratios and the
    number of rejections over the run."""
    nom = filt.nom
    out = {"p": list(nom.p), "v": list(nom.v), "q": list(nom.q), "ba": list(nom.ba),
           "bg": list(nom.bg), "bb": [nom.bb], "gb": list(nom.gb), "wind": list(nom.wind),
           "P_diag": np.diagonal(filt.P).tolist()}
    sums: dict[str, list[float]] = {}
    for recs in trace.records:
        for r in recs:
            s = sums.setdefault(r.source, [0.0, 0.0, 0.0, 0.0])
            s[0] += float(np.sum(r.innovation))
            s[1] += float(np.sum(r.test_ratio))
            s[2] += float(r.rejected)
            s[3] += 1.0
    for name, s in sorted(sums.items()):
        out["innov_" + name] = s
    return out
