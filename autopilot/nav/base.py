"""What the EKF and the UKF share: alignment, GPS latency, measurement models, gating,
resets, health and the NavState output. The two filters differ only in how they
propagate and update the error covariance (``_predict``, ``_innovation_stats``,
``_fuse_blocks``).

Aiding, one :class:`Block` per source and step (y = z - h(x), H = dh/d(dx)):

* ``gps_pos`` z = NED position of the fix, valid at ``t - EK_GPS_DELAY``. The innovation
  is formed against the nominal state of that instant, kept in a short history (a ring
  of the last 1.28 s; corrections fused since are added back, so the history is always
  in the current estimate's frame). The correction is applied to the current error
  state through the inverse transition over the delay, ``H = H_0 Phi(t, t-L)^-1 ~
  H_0 (I - F L)``: for position ``H = [I, -L I, 0 ...]``. This is the delayed-state
  innovation of Larsen et al. 1998 ("Incorporation of time delayed measurements in a
  discrete-time Kalman filter") without the extra covariance bookkeeping; the process
  noise over 0.15 s is neglected. The slow part of the GPS error is the Gauss-Markov
  error state (layout.GPSB): ``h = p(t-L) + b_gps``, ``H[:, GPSB] = I``; R holds the white
  part only (config.py).
* ``gps_vel`` the same for NED velocity: ``H = [0, I, L [f_n x], L R, 0 ...]``.
* ``baro`` pressure altitude, ``h = alt0 - p_D + b_baro``: the barometer offset is an
  error state (layout.BBIAS), initialised from the first GPS altitude with the GPS's
  vertical variance, then estimated against GPS altitude.
* ``mag`` tilt-compensated magnetic heading (3-axis mag is not fused, so a disturbed
  field cannot pull roll and pitch): ``h = yaw(q)``, with the global attitude error
  ``H_att = [-R00 R20 / d, -R10 R20 / d, 1]``, ``d = R00^2 + R10^2``.
* ``airspeed`` (fixed-wing) true airspeed ``h = |v - w|`` with ``w = [w_N, w_E, 0]``;
  ``sideslip`` (fixed-wing) the synthetic zero body-y air velocity
  ``h = e_y^T R^T (v - w)``. Together with the heading they make velocity observable
  without GPS (dead reckoning on air data and the wind estimate).
* ``fake_pos`` position hold (1 m) after a ground alignment until the first GPS fix,
  so the unaided INS cannot run away on the ground (PX4 does the same).

Gating: every component's test ratio ``y^2 / (gate^2 S)`` must be <= 1, else the whole
source is rejected for this step. Reset rule: if GPS position (velocity) has been
rejected continuously for EK_GPS_RST_T seconds, position (velocity) is reset to the GPS
(latency compensated) and its covariance to R, cross-covariances zeroed; the record of
that fix says ``rejected=True, fused=True``. After an outage the dead-reckoning
covariance has grown, so a returning GPS normally passes the gate and is fused at once;
the reset is for the case where it does not, so the filter never rejects GPS forever.

Alignment: on the ground, from EK_ALIGN_T seconds of stationary samples (|omega| <
0.05 rad/s, ||f| - g| < 0.5 m/s^2): roll/pitch from the mean specific force, heading
from the tilt-compensated mean magnetometer, gyro bias from the mean rate. In flight
(or moving), from a 3D GPS fix with ground speed >= EK_ALIGN_GSPD: yaw from the ground
track, pitch from the flight-path angle, roll zero, with wide attitude covariance.
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from autopilot.geo import G0, LocalFrame, euler_to_quat, gravity_m_s2, wrap_pi
from autopilot.messages import NavState, SensorFrame

from . import config
from .layout import ABIAS, ATT, BBIAS, GBIAS, GPSB, N_WIND, POS, VEL, WIND, error_state_size
from .records import InnovationRecord
from .strapdown import (Nominal, heading_from_mag, inject_attitude, level_from_accel,
                        mag_heading, yaw_of)

_HIST = 128                   # history ring length [samples] (1.28 s at 100 Hz)
_MAX_DT = 0.1                 # longer IMU gaps are integrated as this [s]
_FAKE_POS_SD = 1.0            # [m]
_STATIC_GYRO = 0.05           # [rad/s]
_STATIC_ACC = 0.5             # [m/s^2]
_AIRSPEED_HOLD_US = 500_000   # a measured airspeed is reported this long [us]
_MAX_PITCH_FOR_MAG = 0.1      # skip heading fusion when d = cos^2(pitch) < this

# Diagonal floor and ceiling of P, per error state (variances).
_P_FLOOR = np.array([1e-4] * 3 + [1e-6] * 3 + [1e-10] * 3 + [1e-12] * 3 + [1e-16] * 3
                    + [1e-4] + [1e-6] * 3 + [1e-6] * 2)
_P_CEIL = np.array([1e8] * 3 + [1e4] * 3 + [10.0] * 3 + [4.0] * 3 + [0.01] * 3
                   + [1e6] + [1e4] * 3 + [1e4] * 2)
_BARO_INIT_SD = 100.0         # baro offset sigma before the first GPS fix [m]
_BA_MAX = 2.0                 # accelerometer bias estimate limit [m/s^2]
_BG_MAX = 0.2                 # gyro bias estimate limit [rad/s]


def skew(v) -> np.ndarray:
    x, y, z = v[0], v[1], v[2]
    return np.array(((0.0, -z, y), (z, 0.0, -x), (-y, x, 0.0)))


class Block:
    """One source's measurement for one step (see the module docstring)."""

    __slots__ = ("source", "obs", "z", "h0", "H", "R", "gate", "aux",
                 "y", "S", "ratio", "rejected", "reset")

    def __init__(self, source, obs, z, h0, H, R, gate, aux=None):
        self.source = source
        self.obs = obs        # the observation as recorded
        self.z = z            # measurement in filter form (angles unwrapped around h0)
        self.h0 = h0          # h(nominal)
        self.H = H            # dh/d(dx), (m, n)
        self.R = R            # measurement variances, (m,)
        self.gate = gate      # [standard deviations]
        self.aux = aux        # what the UKF needs to evaluate h on sigma points
        self.y = None
        self.S = None
        self.ratio = None
        self.rejected = False
        self.reset = False    # forced reset of the state to this measurement


class NavFilterBase:
    """Shared shell of :class:`InsGpsEkf` and :class:`InsGpsUkf`."""

    SOURCE = "ekf"

    def __init__(self, params: Mapping[str, float] | None = None, vehicle: str = "plane",
                 origin: LocalFrame | None = None):
        self.params = config.resolve(params)
        self.vehicle = vehicle
        self.n = error_state_size(vehicle)
        self.is_plane = self.n == N_WIND
        self._home = origin
        self.reset()

    # ------------------------------------------------------------------ lifecycle --
    def reset(self) -> None:
        """Forget everything; the filter re-aligns from the next samples."""
        prm = self.params
        self.origin: LocalFrame | None = self._home
        self._g = gravity_m_s2(self.origin.lat0_rad, self.origin.alt0_m) if self.origin else G0
        self.nom = Nominal()
        self.aligned = False
        self.healthy = False
        self.innovations: list[InnovationRecord] = []
        self._t_us: int | None = None
        self._pos_src: str | None = None      # None -> "fake" -> "gps"
        self._fake_hold = np.zeros(3)
        self._baro_ok = False                 # baro offset initialised from GPS
        self._last_baro_alt: float | None = None
        self._airspeed: tuple[int, float] | None = None
        self._rej_since: dict[str, int] = {}
        self._gps_delay = prm["EK_GPS_DELAY"]
        # alignment accumulators
        self._al_n = 0
        self._al_f = np.zeros(3)
        self._al_w = np.zeros(3)
        self._al_m = np.zeros(3)
        self._al_nm = 0
        self._al_t0: int | None = None
        # history ring of the nominal state for the GPS latency
        self._h_t = np.full(_HIST, np.iinfo(np.int64).min // 2, dtype=np.int64)
        self._h_p = np.zeros((_HIST, 3))
        self._h_v = np.zeros((_HIST, 3))
        self._h_i = 0
        self._c_p = np.zeros(3)   # corrections applied since start (added back on lookup)
        self._c_v = np.zeros(3)
        self._reset_covariance_model()

    def _reset_covariance_model(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    # -------------------------------------------------------------------- helpers --
    def sigma(self) -> dict[str, np.ndarray]:
        """1-sigma of the error states, for logging: p_ned [m], v_ned [m/s], att [rad]
        (NED-frame rotation vector: ~roll, ~pitch, yaw error when level), accel_bias
        [m/s^2], gyro_bias [rad/s], wind [m/s] (fixed-wing)."""
        s = np.sqrt(np.maximum(np.diag(self.P), 0.0))
        out = {"p_ned": s[POS], "v_ned": s[VEL], "att": s[ATT],
               "accel_bias": s[ABIAS], "gyro_bias": s[GBIAS], "baro_bias": s[BBIAS],
               "gps_bias": s[GPSB]}
        if self.is_plane:
            out["wind"] = s[WIND]
        return out

    @property
    def P(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    # --------------------------------------------------------------------- update --
    def update(self, frame: SensorFrame) -> NavState:
        """One 100 Hz step: predict with frame.imu, then fuse what else is present."""
        t = frame.t_us
        self.innovations = []
        dt = 0.0 if self._t_us is None else min(max((t - self._t_us) * 1e-6, 0.0), _MAX_DT)
        self._t_us = t
        imu = frame.imu
        if frame.airspeed is not None:
            self._airspeed = (t, frame.airspeed.airspeed_mps)
        if frame.baro is not None:
            self._last_baro_alt = frame.baro.alt_m
        gps = frame.gps if (frame.gps is not None and frame.gps.fix_type >= 3) else None
        if gps is not None and self.origin is None:
            self._set_origin(LocalFrame(gps.lat_rad, gps.lon_rad, gps.alt_m))

        if not self.aligned:
            self._align_step(frame, gps)
            if not self.aligned:
                self.nom.omega_b = imu.omega_b - self.nom.bg
                return self._output(t)
            self._push_history(t)
            if self._pos_src == "gps":   # aligned in flight on this very fix
                self._update_health(t)
                return self._output(t)
        else:
            if dt > 0.0:
                self._predict(dt, imu.f_b, imu.omega_b)
            self._push_history(t)

        blocks = self._blocks(frame, gps)
        if blocks:
            self._fuse(blocks, t)
        self._update_health(t)
        return self._output(t)

    # ------------------------------------------------------------------ alignment --
    def _set_origin(self, origin: LocalFrame) -> None:
        self.origin = origin
        self._g = gravity_m_s2(origin.lat0_rad, origin.alt0_m)

    def _align_step(self, frame: SensorFrame, gps) -> None:
        imu = frame.imu
        f, w = imu.f_b, imu.omega_b
        if gps is not None and math.hypot(gps.v_ned[0], gps.v_ned[1]) >= self.params["EK_ALIGN_GSPD"]:
            # moving (a straight, unaccelerated leg looks static to the IMU)
            self._align_in_flight(gps, frame)
            return
        static = (float(np.dot(w, w)) < _STATIC_GYRO ** 2
                  and abs(math.sqrt(float(np.dot(f, f))) - self._g) < _STATIC_ACC)
        if not static:
            self._al_n = self._al_nm = 0
            self._al_f[:] = 0.0
            self._al_w[:] = 0.0
            self._al_m[:] = 0.0
            self._al_t0 = None
            return
        if self._al_t0 is None:
            self._al_t0 = frame.t_us
        self._al_n += 1
        self._al_f += f
        self._al_w += w
        if frame.mag is not None:
            self._al_m += frame.mag.m_b
            self._al_nm += 1
        if (frame.t_us - self._al_t0) * 1e-6 >= self.params["EK_ALIGN_T"] and self._al_nm > 0:
            self._align_on_ground(gps)

    def _align_on_ground(self, gps) -> None:
        f_mean = self._al_f / self._al_n
        roll, pitch = level_from_accel(f_mean)
        yaw = heading_from_mag(self._al_m / self._al_nm, roll, pitch, self.params["EK_MAG_DEC"])
        nom = self.nom
        nom.set_attitude(euler_to_quat(roll, pitch, yaw))
        nom.bg = self._al_w / self._al_n
        nom.ba = np.zeros(3)
        nom.v = np.zeros(3)
        nom.p = np.zeros(3)
        nom.wind = np.zeros(2)
        sd = np.concatenate([[_FAKE_POS_SD] * 3, [0.5] * 3, [0.02, 0.02, 0.1],
                             [0.2] * 3, [0.003] * 3, [_BARO_INIT_SD], self._gm_sd(), [8.0] * 2])[: self.n]
        self._init_covariance(sd)
        self.aligned = True
        self._pos_src = "fake"
        self._fake_hold = nom.p.copy()

    def _align_in_flight(self, gps, frame: SensorFrame) -> None:
        if self.origin is None:
            return
        v = np.asarray(gps.v_ned, dtype=float)
        yaw = math.atan2(v[1], v[0])
        pitch = math.atan2(-v[2], math.hypot(v[0], v[1]))
        nom = self.nom
        nom.set_attitude(euler_to_quat(0.0, pitch, yaw))
        nom.v = v.copy()
        nom.p = self.origin.to_ned_fast(gps.lat_rad, gps.lon_rad, gps.alt_m) + v * self._gps_delay
        nom.ba = np.zeros(3)
        nom.bg = np.zeros(3)
        nom.wind = np.zeros(2)
        nom.gb = np.zeros(3)
        baro_sd = _BARO_INIT_SD
        if self._last_baro_alt is not None:
            nom.bb = np.array((self._last_baro_alt - (self.origin.alt0_m - nom.p[2]),))
            baro_sd = float(np.hypot(self._gm_sd()[2], self._gps_white(gps)[2]))
            self._baro_ok = True
        sd = np.concatenate([[1.0] * 3, [1.0] * 3, [0.3, 0.3, 0.4],
                             [0.2] * 3, [0.02] * 3, [baro_sd], self._gm_sd(), [8.0] * 2])[: self.n]
        self._init_covariance(sd)
        self._position_from_gps_covariance(self._gps_white(gps) ** 2)
        self.aligned = True
        self._pos_src = "gps"
        # the history must not hold the unaligned zeros
        self._h_t[:] = np.iinfo(np.int64).min // 2

    def _init_covariance(self, sd: np.ndarray) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _gm_sd(self) -> np.ndarray:
        """Stationary sigma of the GPS Gauss-Markov error states (N, E, D)."""
        h, v = self.params["EK_GPSB_SD"], self.params["EK_GPSB_Z_SD"]
        return np.array((h, h, v))

    def _gps_white(self, gps) -> np.ndarray:
        """White-noise sigma (N, E, D) of a fix: the part of eph/epv the Gauss-Markov
        state does not explain, floored by EK_GPS_P_NSE / EK_GPS_Z_NSE."""
        prm = self.params
        gh, gv = prm["EK_GPSB_SD"], prm["EK_GPSB_Z_SD"]
        sh = max(prm["EK_GPS_P_NSE"], math.sqrt(max(gps.eph_m * gps.eph_m - gh * gh, 0.0)))
        sv = max(prm["EK_GPS_Z_NSE"], math.sqrt(max(gps.epv_m * gps.epv_m - gv * gv, 0.0)))
        return np.array((sh, sh, sv))

    def _position_from_gps_covariance(self, white_var: np.ndarray) -> None:
        """Covariance after setting p = z - b_gps: dp = -db - w, so
        P_pp = P_bb + R_w and P_pb = -P_bb; position decorrelated from the rest."""
        P = self.P
        Pbb = P[GPSB, GPSB].copy()
        P[POS, :] = 0.0
        P[:, POS] = 0.0
        P[POS, POS] = Pbb + np.diag(white_var)
        P[POS, GPSB] = -Pbb
        P[GPSB, POS] = -Pbb
        self._set_P(P)

    # -------------------------------------------------------------------- history --
    def _push_history(self, t: int) -> None:
        i = self._h_i
        self._h_t[i] = t
        self._h_p[i] = self.nom.p - self._c_p
        self._h_v[i] = self.nom.v - self._c_v
        self._h_i = (i + 1) % _HIST

    def _delayed(self, t_valid: int) -> tuple[np.ndarray, np.ndarray]:
        k = int(np.argmin(np.abs(self._h_t - t_valid)))
        return self._h_p[k] + self._c_p, self._h_v[k] + self._c_v

    # ----------------------------------------------------------- measurement models --
    def _blocks(self, frame: SensorFrame, gps) -> list[Block]:
        prm = self.params
        nom = self.nom
        n = self.n
        blocks: list[Block] = []
        if gps is not None:
            L = self._gps_delay
            p_d, v_d = self._delayed(frame.t_us - int(round(L * 1e6)))
            z = self.origin.to_ned_fast(gps.lat_rad, gps.lon_rad, gps.alt_m)
            sw = self._gps_white(gps)
            H = np.zeros((3, n))
            H[0, 0] = H[1, 1] = H[2, 2] = 1.0
            H[0, 3] = H[1, 4] = H[2, 5] = -L
            H[:, GPSB] = np.eye(3)
            b = Block("gps_pos", z, z, p_d + nom.gb, H, sw * sw, prm["EK_GPS_P_GATE"], (L,))
            b.reset = self._pos_src != "gps"
            blocks.append(b)
            v = np.asarray(gps.v_ned, dtype=float)
            H = np.zeros((3, n))
            H[0, 3] = H[1, 4] = H[2, 5] = 1.0
            H[:, ATT] = L * skew(nom.f_n)
            H[:, ABIAS] = L * nom.R
            sv = prm["EK_GPS_V_NSE"] ** 2
            b = Block("gps_vel", v, v, v_d, H, np.array((sv, sv, sv)), prm["EK_GPS_V_GATE"], (L,))
            b.reset = self._pos_src != "gps"
            blocks.append(b)
        elif self._pos_src == "fake":
            H = np.zeros((3, n))
            H[0, 0] = H[1, 1] = H[2, 2] = 1.0
            s2 = _FAKE_POS_SD ** 2
            blocks.append(Block("fake_pos", self._fake_hold.copy(), self._fake_hold.copy(),
                                nom.p.copy(), H, np.array((s2, s2, s2)), 1e3))

        if frame.baro is not None and self._baro_ok:
            alt = np.array((frame.baro.alt_m,))
            H = np.zeros((1, n))
            H[0, 2] = -1.0
            H[0, BBIAS.start] = 1.0
            s = prm["EK_BARO_NSE"]
            blocks.append(Block("baro", alt, alt, np.array((self.origin.alt0_m - nom.p[2] + nom.bb[0],)),
                                H, np.array((s * s,)), prm["EK_BARO_GATE"]))

        if frame.mag is not None:
            R = nom.R
            d = R[0, 0] * R[0, 0] + R[1, 0] * R[1, 0]
            if d > _MAX_PITCH_FOR_MAG:
                yaw_m = mag_heading(R, frame.mag.m_b, prm["EK_MAG_DEC"])
                yaw0 = yaw_of(R)
                H = np.zeros((1, n))
                H[0, 6] = -R[0, 0] * R[2, 0] / d
                H[0, 7] = -R[1, 0] * R[2, 0] / d
                H[0, 8] = 1.0
                s = prm["EK_MAG_NSE"]
                blocks.append(Block("mag", np.array((yaw_m,)), np.array((yaw0 + wrap_pi(yaw_m - yaw0),)),
                                    np.array((yaw0,)), H, np.array((s * s,)), prm["EK_MAG_GATE"]))

        if (self.is_plane and frame.airspeed is not None
                and frame.airspeed.airspeed_mps >= prm["EK_ARSP_MIN"] and self._pos_src == "gps"):
            R = nom.R
            w = nom.wind
            vr = nom.v - (w[0], w[1], 0.0)
            tas = math.sqrt(float(vr @ vr))
            if tas > 1.0:
                u = vr / tas
                H = np.zeros((1, n))
                H[0, VEL] = u
                H[0, WIND] = -u[:2]
                s = prm["EK_ARSP_NSE"]
                z = np.array((frame.airspeed.airspeed_mps,))
                blocks.append(Block("airspeed", z, z, np.array((tas,)), H, np.array((s * s,)),
                                    prm["EK_ARSP_GATE"]))
                ey = R[:, 1]
                H = np.zeros((1, n))
                H[0, ATT] = np.cross(ey, vr)
                H[0, VEL] = ey
                H[0, WIND] = -ey[:2]
                s = prm["EK_BETA_NSE"]
                zero = np.zeros(1)
                blocks.append(Block("sideslip", zero, zero, np.array((float(ey @ vr),)), H,
                                    np.array((s * s,)), prm["EK_BETA_GATE"]))
        return blocks

    # --------------------------------------------------------------------- fusion --
    def _fuse(self, blocks: list[Block], t: int) -> None:
        self._innovation_stats(blocks)
        rst_us = self.params["EK_GPS_RST_T"] * 1e6
        accepted: list[Block] = []
        resets: list[Block] = []
        for b in blocks:
            gate2 = b.gate * b.gate
            b.ratio = b.y * b.y / (gate2 * b.S)
            b.rejected = bool(np.any(b.ratio > 1.0))
            if b.rejected:
                since = self._rej_since.setdefault(b.source, t)
                if b.source in ("gps_pos", "gps_vel") and t - since >= rst_us:
                    b.reset = True
            else:
                self._rej_since.pop(b.source, None)
            if b.reset:
                resets.append(b)
            elif not b.rejected:
                accepted.append(b)
        if accepted:
            self._fuse_blocks(accepted)
        for b in resets:
            self._reset_to(b)
        rec = self.innovations
        for b in blocks:
            rec.append(InnovationRecord(t, b.source, b.obs, b.y, b.S, b.ratio, b.rejected,
                                        b.reset or not b.rejected))

    def _reset_to(self, b: Block) -> None:
        """Reset position or velocity to the (latency-compensated) GPS."""
        nom = self.nom
        if b.source == "gps_pos":
            dp = b.z - b.h0
            nom.p = nom.p + dp
            self._c_p += dp
            self._position_from_gps_covariance(b.R)
            self._rej_since.pop("gps_pos", None)
            if self._pos_src != "gps":
                self._pos_src = "gps"
            if not self._baro_ok and self._last_baro_alt is not None:
                nom.bb = np.array((self._last_baro_alt - (self.origin.alt0_m - nom.p[2]),))
                self._reset_covariance_block(BBIAS, np.array((self.P[2, 2],)))
                self._baro_ok = True
        elif b.source == "gps_vel":
            dv = b.z - b.h0
            nom.v = nom.v + dv
            self._c_v += dv
            self._reset_covariance_block(VEL, b.R)
            self._rej_since.pop("gps_vel", None)

    def _inject(self, dx: np.ndarray) -> None:
        """Fold an error-state estimate into the nominal state (dx is then zero)."""
        nom = self.nom
        dp = dx[POS]
        dv = dx[VEL]
        nom.p = nom.p + dp
        nom.v = nom.v + dv
        self._c_p += dp
        self._c_v += dv
        inject_attitude(nom, dx[ATT])
        nom.ba = np.clip(nom.ba + dx[ABIAS], -_BA_MAX, _BA_MAX)
        nom.bg = np.clip(nom.bg + dx[GBIAS], -_BG_MAX, _BG_MAX)
        nom.bb = nom.bb + dx[BBIAS]
        nom.gb = nom.gb + dx[GPSB]
        if self.is_plane:
            nom.wind = nom.wind + dx[WIND]

    def _reset_covariance_block(self, sl: slice, var: np.ndarray) -> None:
        P = self.P
        P[sl, :] = 0.0
        P[:, sl] = 0.0
        P[sl, sl] = np.diag(var)
        self._set_P(P)

    def _condition(self, P: np.ndarray) -> np.ndarray:
        """Symmetrise and keep the diagonal inside [floor, ceiling]."""
        P = 0.5 * (P + P.T)
        d = np.diagonal(P)
        n = self.n
        if np.any(d < _P_FLOOR[:n]) or np.any(d > _P_CEIL[:n]):
            idx = np.arange(n)
            P[idx, idx] = np.clip(d, _P_FLOOR[:n], _P_CEIL[:n])
        return P

    # --------------------------------------------------------------------- output --
    def _update_health(self, t: int) -> None:
        tout = self.params["EK_REJ_TOUT"] * 1e6
        P = self.P
        ok = (self.aligned and self._pos_src == "gps"
              and bool(np.isfinite(P[0, 0] + P[1, 1] + P[6, 6] + P[8, 8]))
              and P[0, 0] + P[1, 1] <= self.params["EK_HPOS_MAX"] ** 2)
        if ok:
            for since in self._rej_since.values():
                if t - since > tout:
                    ok = False
                    break
        self.healthy = ok

    def _output(self, t: int) -> NavState:
        nom = self.nom
        p = nom.p.copy()
        if self.origin is not None:
            lat, lon, alt = self.origin.to_geodetic_fast(p)
        else:
            lat, lon, alt = 0.0, 0.0, -float(p[2])
        wind = np.zeros(3)
        if self.is_plane:
            wind[0], wind[1] = nom.wind
        if self._airspeed is not None and t - self._airspeed[0] <= _AIRSPEED_HOLD_US:
            airspeed = float(self._airspeed[1])
        else:
            vr = nom.v - wind
            airspeed = math.sqrt(float(vr @ vr))
        return NavState(t_us=t, p_ned=p, v_ned=nom.v.copy(), q_nb=nom.q.copy(),
                        omega_b=nom.omega_b.copy(), lat_rad=lat, lon_rad=lon, alt_m=alt,
                        airspeed_mps=airspeed, wind_ned=wind, aligned=self.aligned,
                        healthy=self.healthy, source=self.SOURCE)

    # ---------------------------------------------------------- filter-specific --
    def _predict(self, dt: float, f_m: np.ndarray, omega_m: np.ndarray) -> None:  # pragma: no cover
        raise NotImplementedError

    def _innovation_stats(self, blocks: list[Block]) -> None:  # pragma: no cover
        raise NotImplementedError

    def _fuse_blocks(self, blocks: list[Block]) -> None:  # pragma: no cover
        raise NotImplementedError

    def _set_P(self, P: np.ndarray) -> None:  # pragma: no cover
        raise NotImplementedError
