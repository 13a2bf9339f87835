"""What the EKF and the UKF share: alignment, GPS latency, measurement models, gating,
resets, health and the NavState output. The two filters differ only in how they
propagate and update the error covariance (``_predict``, ``_gate_stats``,
``_fuse_rows``).

* IMU: point samples; the rotation over a step from the trapezoid of the gyro samples
  at its two ends, the velocity change from the specific force at its end; where a
  sample's change over a step exceeds the process noise (a catapult stroke), the
  difference is added to P (``_propagate_nominal``).
* Aiding: all measurements of one step stacked in one :class:`Batch`, gated one source
  at a time and fused together; barometer, magnetometer and airspeed as means at
  EK_AUX_HZ. Sources: ``gps_pos`` and ``gps_vel`` (delayed-state innovations over
  EK_GPS_DELAY, Larsen et al. 1998; the GPS's slow error a Gauss-Markov state),
  ``baro`` (with an offset state; the height handed out follows EK_HGT_REF), ``mag``
  (the horizontal direction of the field only, once roll and pitch are known),
  ``airspeed`` and synthetic ``sideslip`` (fixed-wing: dead reckoning on air data),
  ``fake_pos`` (a position hold on the ground before the first fix).
* Gating on each component's test ratio; position and velocity reset to the GPS after
  EK_GPS_RST_T of rejection, the wind to the airspeed after EK_ARSP_RST_T; health from
  alignment, a fused fix, P and the rejections.
* Alignment on the ground from stationary samples, or in flight from a GPS fix with
  ground speed.

Each measurement model, its Jacobian and the reason for each choice: docs/navigation.md.
The state layout: :mod:`.layout`; the parameters: :mod:`.config`.
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from autopilot.geo import G0, LocalFrame, euler_to_quat, gravity_m_s2, wrap_pi
from autopilot.geo.rotations import quat_dcm
from autopilot.geo.wgs84 import geodetic_fast
from autopilot.jit import kernel
from autopilot.messages import NavState, SensorFrame

from . import config
from .layout import (ABIAS, ATT, BBIAS, GBIAS, GPSB, N_WIND, POS, VEL, WIND,
                     error_state_size)
from .records import InnovationRecord
from .strapdown import (X_BA, X_BB, X_BG, X_FN, X_GB, X_P, X_Q, X_R, X_SIZE, X_V, X_WIND,
                        Nominal, earth_rate_ned, heading_from_mag, level_from_accel, mag_ned,
                        mechanise, rotate_global)

_HIST = 128                   # history ring length [samples] (1.28 s at 100 Hz)
_MAX_DT = 0.1                 # longer IMU gaps are integrated as this [s]
_FAKE_POS_SD = 1.0            # [m]
_STATIC_GYRO = 0.05           # [rad/s]
_STATIC_ACC = 0.5             # [m/s^2]
_AIRSPEED_HOLD_US = 500_000   # a measured airspeed is reported this long [us]
_MIN_HORIZ_FIELD = 0.05       # no heading fusion when B_h^2 / |B|^2 is below (13 deg from vertical)
_MAG_TILT_VAR = 0.05 ** 2     # heading fusion starts when roll/pitch variances are below [rad^2]
_MAG_REF_GAIN = 0.01          # per-sample gain of the smoothed NED field used in the mag H
_MAX_ROWS = 12                # measurement rows in one step (GPS 6 + baro, mag, airspeed, sideslip)
_AUX_PERIOD_TOL_US = 5_000    # ... of samples that arrive on a clock a little off ours [us]
_BARO_INIT_SD = 100.0         # baro offset sigma before the first GPS fix [m]
_BG_ALIGN_SD_MIN = 1e-4      # gyro bias sigma after a ground alignment, at least [rad/s]
_BA_INIT_SD = 0.2             # accelerometer bias sigma at alignment [m/s^2] (PX4's EKF2_ABIAS_INIT)
_TILT_ALIGN_SD = 1e-3         # tilt sigma of the levelling itself (mean of the samples) [rad]
_GPS_VD_SCALE2 = 1.5 ** 2     # GPS vertical velocity variance / horizontal (as PX4 EKF2)
_R_AIR = 287.05287            # specific gas constant of dry air [J/(kg K)]
_BA_MAX = 2.0                 # accelerometer bias estimate limit [m/s^2]
_BG_MAX = 0.2                 # gyro bias estimate limit [rad/s]
_WIND_RESET_SD = 2.0          # wind sigma added at a reset from the airspeed, per axis [m/s]

# Diagonal floor and ceiling of P (variances) per error-state block.
_P_LIMITS = ((POS, 1e-4, 1e8), (VEL, 1e-6, 1e4), (ATT, 1e-10, 10.0), (ABIAS, 1e-12, 4.0),
             (GBIAS, 1e-16, 0.01), (BBIAS, 1e-4, 1e6), (GPSB, 1e-6, 1e4), (WIND, 1e-6, 1e4))
_P_FLOOR = np.zeros(N_WIND)
_P_CEIL = np.zeros(N_WIND)
for _sl, _lo, _hi in _P_LIMITS:
    _P_FLOOR[_sl], _P_CEIL[_sl] = _lo, _hi

# Columns of H's nonzeros per source, (row, column), from the layout.
_IP, _IV, _IA, _IBA = POS.start, VEL.start, ATT.start, ABIAS.start
_IBG, _IBB, _IGB, _IW = GBIAS.start, BBIAS.start, GPSB.start, WIND.start
_POS_COLS = tuple((i, _IP + i) for i in range(3))
_ATT_COLS = tuple((0, _IA + i) for i in range(3))
_GPS_POS_COLS = tuple(c for i in range(3) for c in ((i, _IP + i), (i, _IV + i), (i, _IGB + i)))
_GPS_VEL_COLS = (tuple((i, _IV + i) for i in range(3))
                 + ((0, _IA + 1), (0, _IA + 2), (1, _IA), (1, _IA + 2), (2, _IA), (2, _IA + 1))
                 + tuple((i, _IBA + j) for i in range(3) for j in range(3)))
_BARO_COLS = ((0, _IP + 2), (0, _IBB))
_AIRSPEED_COLS = ((0, _IV), (0, _IV + 1), (0, _IV + 2), (0, _IW), (0, _IW + 1))
_SIDESLIP_COLS = _ATT_COLS + _AIRSPEED_COLS
_H_COLS = {"gps_pos": _GPS_POS_COLS, "gps_vel": _GPS_VEL_COLS, "fake_pos": _POS_COLS,
           "baro": _BARO_COLS, "mag": _ATT_COLS, "airspeed": _AIRSPEED_COLS,
           "sideslip": _SIDESLIP_COLS}
_BLOCKS = {"pos": POS, "vel": VEL, "att": ATT, "abias": ABIAS, "gbias": GBIAS, "bbias": BBIAS,
           "gpsb": GPSB, "wind": WIND}
# inject_into reads dx in this order; a layout change must be mirrored there
assert (POS.start, VEL.start, ATT.start, ABIAS.start, GBIAS.start, BBIAS.start, GPSB.start,
        WIND.start) == (0, 3, 6, 9, 12, 15, 16, 19)


_NO_QS = np.zeros(0)


@kernel
def sampling_error_into(dt, f0x, f0y, f0z, f1x, f1y, f1z, w0x, w0y, w0z, w1x, w1y, w1z,
                        R, thr_f, thr_w, qs, add):
    """The sampling error of one step's point samples (NavFilterBase._propagate_nominal):

        e = R (f1 - f0) dt / 2,   c = R (w1 - w0) dt / 2,   q_s = (e e^T, c c^T)

    where |f1 - f0|^2 > thr_f or |w1 - w0|^2 > thr_w: the 18 entries of q_s (row-major)
    written into ``qs``, or added to it when ``add``; returns (True, e_N^2, e_E^2, e_D^2).
    Otherwise nothing is written and the first element is False. R: R(q_nb), 9 floats
    row-major."""
    df0, df1, df2 = f1x - f0x, f1y - f0y, f1z - f0z
    dw0, dw1, dw2 = w1x - w0x, w1y - w0y, w1z - w0z
    if (df0 * df0 + df1 * df1 + df2 * df2 <= thr_f
            and dw0 * dw0 + dw1 * dw1 + dw2 * dw2 <= thr_w):
        return False, 0.0, 0.0, 0.0
    h = 0.5 * dt
    a0, a1, a2 = h * df0, h * df1, h * df2
    b0, b1, b2 = h * dw0, h * dw1, h * dw2
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    e = (r00 * a0 + r01 * a1 + r02 * a2, r10 * a0 + r11 * a1 + r12 * a2,
         r20 * a0 + r21 * a1 + r22 * a2)
    c = (r00 * b0 + r01 * b1 + r02 * b2, r10 * b0 + r11 * b1 + r12 * b2,
         r20 * b0 + r21 * b1 + r22 * b2)
    for i in range(3):
        for j in range(3):
            k = 3 * i + j
            if add:
                qs[k] += e[i] * e[j]
                qs[9 + k] += c[i] * c[j]
            else:
                qs[k] = e[i] * e[j]
                qs[9 + k] = c[i] * c[j]
    return True, e[0] * e[0], e[1] * e[1], e[2] * e[2]


# The filter's per-step array (NavFilterBase._s), beside the nominal state (Nominal.x):
# what the step kernels read and write in place. Offsets:
S_F0, S_W0 = 0, 3       # the IMU samples of the last step (specific force, rate)
S_G, S_WIE = 6, 7       # gravity, the Earth rate in NED (3) at the origin
S_THR = 10              # sampling-error thresholds (2): |df|^2, |dw|^2 (_propagate_nominal)
S_GM = 12               # Gauss-Markov decay of the GPS error over one step, exp(-dt / tau)
S_SF, S_QS = 13, 16     # running sums (GPS latency): f_n dt, velocity sampling variances
S_CP, S_CV = 19, 22     # corrections of p and v since the start (added back on lookup)
S_ACC = 25              # sums since the last covariance prediction (30): f_n dt, R dt, q_s
S_ACC_HAS, S_QS_HAS = 55, 56  # whether that interval has a step, a sampling error
S_HI = 57               # history ring: the next row to write
S_ORG = 58              # origin (7): known (1/0), lat0, lon0, alt0, R_M, R_N, bend (wgs84.py)
S_BHGT, S_BB0 = 65, 66  # output height from the baro (1/0), the baro datum [m]
# the aux sensors' samples since their last fusion (aux_into): the sums and counts of
# baro altitudes [m], NED field N, E [gauss], true airspeeds [m/s]; the smoothed NED
# field (3, the mag H) and whether it is set
S_BARO, S_N_BARO, S_MAG, S_N_MAG, S_AIR, S_N_AIR = 67, 68, 69, 71, 72, 73
S_MREF, S_MREF_SET = 74, 77
S_SIZE = 78
# which samples aux_into is given (bits)
_AUX_BARO, _AUX_MAG, _AUX_AIR = 1, 2, 4
# history rows: t, p, v, c_p, c_v, running f_n dt, running sampling variance (_delayed)
_H_T, _H_P, _H_V, _H_CP, _H_CV, _H_SF, _H_QS, _H_SIZE = 0, 1, 4, 7, 10, 13, 16, 19
# the output (output_into): p, v, q, omega_b
_O_SIZE = 13
# The nominal state (X_SIZE), the per-step array (S_SIZE), the history ring (_HIST rows)
# and the output (_O_SIZE) are views of one buffer (NavFilterBase._buf), in this order:
# the kernels called on most steps (imu_step, aux_into) take the buffer as one argument
# (a kernel's array argument costs more than views taken of it inside), the other
# kernels and the Python side take the views.
_B_S, _B_H = X_SIZE, X_SIZE + S_SIZE
_B_O = _B_H + _HIST * _H_SIZE
_B_SIZE = _B_O + _O_SIZE


@kernel
def push_history(x, s, hist, t):
    """Row S_HI of the history ring: t, the nominal p, v, the corrections so far and the
    running sums (NavFilterBase._delayed reads it)."""
    i = int(s[S_HI])
    hist[i, _H_T] = t
    for k in range(3):
        hist[i, _H_P + k] = x[X_P + k]
        hist[i, _H_V + k] = x[X_V + k]
        hist[i, _H_CP + k] = s[S_CP + k]
        hist[i, _H_CV + k] = s[S_CV + k]
        hist[i, _H_SF + k] = s[S_SF + k]
        hist[i, _H_QS + k] = s[S_QS + k]
    s[S_HI] = (i + 1) % _HIST


@kernel
def delayed(hist, s, t_valid):
    """(p, v, dv_f, q_s), 12 floats, of the history row nearest to t_valid with the later
    corrections added (NavFilterBase._delayed)."""
    i = (int(s[S_HI]) - 1) % _HIST
    for _ in range(_HIST - 1):
        j = (i - 1) % _HIST
        # (an empty row's t is -inf: never nearer)
        if abs(hist[j, _H_T] - t_valid) > abs(hist[i, _H_T] - t_valid):
            break
        i = j
    h = hist[i]
    return ((h[_H_P] - h[_H_CP]) + s[S_CP], (h[_H_P + 1] - h[_H_CP + 1]) + s[S_CP + 1],
            (h[_H_P + 2] - h[_H_CP + 2]) + s[S_CP + 2],
            (h[_H_V] - h[_H_CV]) + s[S_CV], (h[_H_V + 1] - h[_H_CV + 1]) + s[S_CV + 1],
            (h[_H_V + 2] - h[_H_CV + 2]) + s[S_CV + 2],
            s[S_SF] - h[_H_SF], s[S_SF + 1] - h[_H_SF + 1], s[S_SF + 2] - h[_H_SF + 2],
            s[S_QS] - h[_H_QS], s[S_QS + 1] - h[_H_QS + 1], s[S_QS + 2] - h[_H_QS + 2])


@kernel
def output_into(x, s, a):
    """The output of the nominal state (NavFilterBase._output): ``a`` (13) = p, v, q,
    omega_b = gyro - b_g; returns (lat, lon, alt, a_N, a_E, a_D), a = v - (w_N, w_E, 0)
    the air velocity of the wind estimate (the dead-reckoned airspeed's). Under the
    baro height reference the height is the one the barometer and the IMU give, on the
    datum of the offset's initialisation (module docstring)."""
    pd = x[X_P + 2]
    if s[S_BHGT] != 0.0:
        pd = pd - (x[X_BB] - s[S_BB0])
    for k in range(10):
        a[k] = x[X_P + k]
    a[2] = pd
    for k in range(3):
        a[10 + k] = s[S_W0 + k] - x[X_BG + k]
    an, ae, ad = x[X_V] - x[X_WIND], x[X_V + 1] - x[X_WIND + 1], x[X_V + 2]
    if s[S_ORG] == 0.0:
        return 0.0, 0.0, -pd, an, ae, ad
    lat, lon, alt = geodetic_fast(s[S_ORG + 1], s[S_ORG + 2], s[S_ORG + 3], s[S_ORG + 4],
                                  s[S_ORG + 5], s[S_ORG + 6], x[X_P], x[X_P + 1], pd)
    return lat, lon, alt, an, ae, ad


@kernel
def imu_step(b, f1x, f1y, f1z, w1x, w1y, w1z, dt, t):
    """One IMU step of the nominal state ``x`` (Nominal.x) and the filter's per-step
    array ``s`` (offsets S_*), in place (NavFilterBase._propagate_nominal), from the
    samples at the step's two ends (the last step's, in ``s``, and these); ``b``: the
    buffer of x, s and the history ring (_B_*):

    * the sampling error of the two samples, at the attitude before the step
      (:func:`sampling_error_into`), into the interval's q_s (added when one is there),
      its velocity part into the running sum;
    * the mechanisation (strapdown.py) with the specific force at the end of the step
      and the trapezoid of the rates at its two ends;
    * the sums over the steps since the last covariance prediction of f_n dt and R dt
      (F's dynamic entries over the interval, ekf.py module docstring), and the running
      sum of f_n dt; the Gauss-Markov decay of the GPS error, b' = a b;
    * the history row of this step (:func:`push_history`) and the output
      (:func:`output_into`, into the buffer's last _O_SIZE; returns what it returns)."""
    x, s, hist = b[:_B_S], b[_B_S:_B_H], b[_B_H:_B_O].reshape((_HIST, _H_SIZE))
    f0x, f0y, f0z = s[S_F0], s[S_F0 + 1], s[S_F0 + 2]
    w0x, w0y, w0z = s[S_W0], s[S_W0 + 1], s[S_W0 + 2]
    sampled, e0, e1, e2 = sampling_error_into(
        dt, f0x, f0y, f0z, f1x, f1y, f1z, w0x, w0y, w0z, w1x, w1y, w1z,
        quat_dcm(x[X_Q], x[X_Q + 1], x[X_Q + 2], x[X_Q + 3]), s[S_THR], s[S_THR + 1],
        s[S_ACC + 12:S_ACC + 30], s[S_QS_HAS] != 0.0)
    if sampled:
        s[S_QS] = s[S_QS] + e0
        s[S_QS + 1] = s[S_QS + 1] + e1
        s[S_QS + 2] = s[S_QS + 2] + e2
        s[S_QS_HAS] = 1.0
    o = mechanise(x[X_P], x[X_P + 1], x[X_P + 2], x[X_V], x[X_V + 1], x[X_V + 2],
                  x[X_Q], x[X_Q + 1], x[X_Q + 2], x[X_Q + 3],
                  x[X_BG], x[X_BG + 1], x[X_BG + 2], x[X_BA], x[X_BA + 1], x[X_BA + 2],
                  f1x, f1y, f1z, 0.5 * (w0x + w1x), 0.5 * (w0y + w1y), 0.5 * (w0z + w1z),
                  dt, s[S_G], s[S_WIE], s[S_WIE + 1], s[S_WIE + 2])
    for k in range(25):                    # (the layout puts mechanise's outputs in its order)
        x[X_P + k] = o[k]
    summing = s[S_ACC_HAS] != 0.0
    for k in range(3):                     # f_n dt
        v = x[X_FN + k] * dt
        s[S_ACC + k] = s[S_ACC + k] + v if summing else v
    for k in range(9):                     # R dt, R(q') row-major
        v = x[X_R + k] * dt
        s[S_ACC + 3 + k] = s[S_ACC + 3 + k] + v if summing else v
    s[S_ACC_HAS] = 1.0
    for k in range(3):
        s[S_SF + k] = s[S_SF + k] + x[X_FN + k] * dt
        x[X_GB + k] = x[X_GB + k] * s[S_GM]
    s[S_F0], s[S_F0 + 1], s[S_F0 + 2] = f1x, f1y, f1z
    s[S_W0], s[S_W0 + 1], s[S_W0 + 2] = w1x, w1y, w1z
    push_history(x, s, hist, t)
    return output_into(x, s, b[_B_O:])


@kernel
def inject_into(x, s, dx):
    """Fold an error-state estimate ``dx`` (layout.py order) into the nominal state ``x``
    (NavFilterBase._inject); the position and velocity parts also into the corrections
    (S_CP, S_CV). Biases kept within _BA_MAX and _BG_MAX."""
    for k in range(3):
        x[X_P + k] = x[X_P + k] + dx[_IP + k]
        x[X_V + k] = x[X_V + k] + dx[_IV + k]
        s[S_CP + k] = s[S_CP + k] + dx[_IP + k]
        s[S_CV + k] = s[S_CV + k] + dx[_IV + k]
    q, R = rotate_global((x[X_Q], x[X_Q + 1], x[X_Q + 2], x[X_Q + 3]),
                         dx[_IA], dx[_IA + 1], dx[_IA + 2])
    for k in range(4):
        x[X_Q + k] = q[k]
    for k in range(9):
        x[X_R + k] = R[k]
    for k in range(3):
        x[X_BA + k] = x[X_BA + k] + dx[_IBA + k]
        x[X_BG + k] = x[X_BG + k] + dx[_IBG + k]
        # min(max(b, -limit), limit), as Python's builtins compare (NaN kept)
        c = x[X_BA + k]
        c = -_BA_MAX if -_BA_MAX > c else c
        x[X_BA + k] = _BA_MAX if _BA_MAX < c else c
        c = x[X_BG + k]
        c = -_BG_MAX if -_BG_MAX > c else c
        x[X_BG + k] = _BG_MAX if _BG_MAX < c else c
    x[X_BB] = x[X_BB] + dx[_IBB]
    for k in range(3):
        x[X_GB + k] = x[X_GB + k] + dx[_IGB + k]
    for k in range(dx.shape[0] - _IW):
        x[X_WIND + k] = x[X_WIND + k] + dx[_IW + k]


@kernel
def aux_into(b, which, alt, mx, my, mz, tas):
    """Add this step's barometer altitude, magnetometer field and true airspeed (those
    ``which`` names, bits _AUX_*) to the running sums (NavFilterBase._accumulate_aux); the
    field rotated into NED, and only where its horizontal part is large enough to give a
    heading, also into the smoothed field. ``b``: the buffer of the nominal state and
    the per-step array (_B_*). Returns whether the sums hold a sample."""
    x, s = b[:_B_S], b[_B_S:_B_H]
    if which & _AUX_BARO:
        s[S_BARO] += alt
        s[S_N_BARO] += 1.0
    if which & _AUX_MAG:
        mn, me, md = mag_ned(x[X_R:X_R + 9], mx, my, mz)
        bh2 = mn * mn + me * me
        if bh2 > _MIN_HORIZ_FIELD * (bh2 + md * md):
            if s[S_MREF_SET] == 0.0:
                s[S_MREF], s[S_MREF + 1], s[S_MREF + 2] = mn, me, md
                s[S_MREF_SET] = 1.0
            else:
                s[S_MREF] += (mn - s[S_MREF]) * _MAG_REF_GAIN
                s[S_MREF + 1] += (me - s[S_MREF + 1]) * _MAG_REF_GAIN
                s[S_MREF + 2] += (md - s[S_MREF + 2]) * _MAG_REF_GAIN
            s[S_MAG] += mn
            s[S_MAG + 1] += me
            s[S_N_MAG] += 1.0
    if which & _AUX_AIR:
        s[S_AIR] += tas
        s[S_N_AIR] += 1.0
    return s[S_N_BARO] + s[S_N_MAG] + s[S_N_AIR] > 0.0


class Batch:
    """The measurements of one step: per source a name and its rows; stacked ``z``
    (observation, angles unwrapped to within pi of the prediction), ``h0 = h(x)``,
    ``R`` (variances), ``g2`` (gate^2, a list: the gate reads it as floats) and ``H``
    (rows of a preallocated buffer)."""

    __slots__ = ("src", "start", "size", "reset", "m", "R", "g2", "H", "y", "Sd", "z_tuple",
                 "y0", "_h0", "_zh")

    def __init__(self, src, start, size, reset, z, h0, R, g2, H):
        self.src, self.start, self.size, self.reset = src, start, size, reset
        m = self.m = len(z)
        self.g2 = g2
        self.z_tuple = tuple(z)          # (the records' observations are sliced from it)
        # R and y0 = z - h0 (the EKF's innovation): one allocation, handed out as views;
        # z and h0 as arrays only when asked (a reset, the UKF)
        # (np.fromiter with the count: np.array would first discover the floats' type)
        a = np.fromiter(R + [zi - hi for zi, hi in zip(z, h0)], float, 2 * m)
        self.R = a[:m]
        self.y0 = a[m:]
        self._h0 = h0
        self._zh = None
        self.H = H
        self.y = None         # z - h(x)
        self.Sd = None        # diag(H P H^T) + R

    def _z_h0(self) -> np.ndarray:
        zh = self._zh
        if zh is None:
            zh = self._zh = np.fromiter(self.z_tuple + tuple(self._h0), float, 2 * self.m)
        return zh

    @property
    def z(self) -> np.ndarray:
        return self._z_h0()[:self.m]

    @property
    def h0(self) -> np.ndarray:
        return self._z_h0()[self.m:]


class NavFilterBase:
    """Shared shell of :class:`InsGpsEkf` and :class:`InsGpsUkf`.

    Adaptation hooks (for the fault monitor's robust adaptive filter, autopilot/monitor;
    None by default, and a filter whose hooks are None or return None runs exactly the
    optimal filter, bit for bit):

    * ``r_scale_hook(source, y, hph_diag, r_diag) -> factors | None``: called once per
      source and update, after ``y = z - h(x)`` and ``diag(H P H^T)`` are known and
      before the gate, with that source's rows (tuples of floats). Returned factors (one per row, >= 1)
      multiply those rows of R, and so of diag(S): the gate, the gain, the Joseph update
      and the record's innovation variance all use the scaled R (seed eqs 2.25-2.34).
    * ``q_scale_hook(dt) -> factors | None``: called once per prediction; returned
      factors (one per error state, >= 1) multiply the diagonal process noise of that
      step, ``P = F P F^T + Lambda Q`` (the fading matrix of seed eqs 2.35-2.40).
    """

    SOURCE = "ekf"
    r_scale_hook = None
    q_scale_hook = None

    def __init__(self, params: Mapping[str, float] | None = None, vehicle: str = "plane",
                 origin: LocalFrame | None = None):
        self.params = config.resolve(params)
        # aux sensors fused as means over this period (EK_AUX_HZ, module docstring) [us]
        self._aux_period_us = int(round(1e6 / self.params["EK_AUX_HZ"]))
        self.vehicle = vehicle
        self.n = error_state_size(vehicle)
        self.is_plane = self.n == N_WIND
        self._home = origin
        self._Hbuf = np.zeros((_MAX_ROWS, self.n))
        # flat offsets row * n + col of each source's H nonzeros
        self._h_offsets = {name: tuple(row * self.n + col for row, col in cols)
                           for name, cols in _H_COLS.items()}
        self._h_index: dict[tuple, np.ndarray] = {}   # sources of a batch -> H's flat indices
        # flat indices of P's diagonal entries the health reads: p_N, p_E, att_N, att_D
        self._health_idx = tuple(i * (self.n + 1) for i in (_IP, _IP + 1, _IA, _IA + 2))
        self._floor = _P_FLOOR[: self.n].copy()
        self._ceil = _P_CEIL[: self.n].copy()
        self.reset()

    # ------------------------------------------------------------------ lifecycle --
    def reset(self) -> None:
        """Forget everything; the filter re-aligns from the next samples."""
        # the per-step array the kernels read and write in place (offsets S_*), the
        # history ring for the GPS latency (rows: _H_*; an empty row's t is -inf) and the
        # output: views of one buffer with the nominal state (_B_*)
        b = self._buf = np.zeros(_B_SIZE)
        s = self._s = b[_B_S:_B_H]
        self._hist = b[_B_H:_B_O].reshape(_HIST, _H_SIZE)
        # the output's vectors (p, v, q, omega_b), written in place at every step and
        # handed out in every NavState (its vectors are the filter's: copy to keep)
        o = self._o = b[_B_O:]
        self._o_views = (o[0:3], o[3:6], o[6:10], o[10:13])
        self._hist[:, _H_T] = -math.inf
        self.origin: LocalFrame | None = None
        self._g = G0
        self._w_ie = (0.0, 0.0, 0.0)          # Earth rate in NED at the origin [rad/s]
        s[S_G] = G0
        self._declination: float | None = None
        if self._home is not None:
            self._set_origin(self._home)
        self.nom = Nominal(b[:_B_S])
        # output_into's (lat, lon, alt, air velocity) of the output written for this
        # step's nominal state (imu_step's), None when it has not been written (a step
        # without imu_step) or the nominal state has changed since
        self._geo: tuple | None = None
        self._wind_ned: np.ndarray | None = None   # the output's wind, None when it has changed
        self.aligned = False
        self.healthy = False
        self.innovations: list[InnovationRecord] = []
        # the last sample each aiding sensor delivered [us], fused or not: the filter
        # declines some (the heading where the field is nearly vertical, the airspeed under
        # EK_ARSP_MIN), and a sensor that delivers is not a silent one (the monitor's
        # FDI_TOUT test reads this)
        self.heard_us: dict[str, int] = {}
        self._t_us: int | None = None
        self._accel_prev: tuple | None = None  # the last specific-force sample [m/s^2]
        # the sampling error summed since the last covariance prediction (imu_step), as
        # a view (_take_sampling_error hands it out)
        self._acc_qs = s[S_ACC + 12:S_ACC + 30]
        s[S_THR] = (2.0 * self.params["EK_ACC_NSE"]) ** 2
        s[S_THR + 1] = (2.0 * self.params["EK_GYR_NSE"]) ** 2
        n = self.n
        # flat indices of P's velocity and attitude 3x3 blocks (the sampling error's entries)
        self._qs_idx = [i * n + j for blk in (VEL, ATT) for i in range(blk.start, blk.stop)
                        for j in range(blk.start, blk.stop)]
        self._gm_step = (-1.0, -1.0, 1.0)     # (dt, tau, exp(-dt / tau)) of the last step
        self._air: tuple[float, float] | None = None  # last baro (pressure [Pa], temperature [K])
        self._pos_src: str | None = None      # None -> "fake" (ground, before GPS) -> "gps"
        self._fake_hold = [0.0, 0.0, 0.0]
        self._baro_ok = False                 # baro offset initialised from GPS (the datum: S_BB0)
        self._bb0_var = 0.0                   # ... known to this variance [m^2]
        self._hgt_baro = int(self.params["EK_HGT_REF"]) == 0
        self._last_baro_alt: float | None = None
        self._airspeed: tuple[int, float] | None = None
        self._rej_since: dict[str, int] = {}
        self._gps_delay = self.params["EK_GPS_DELAY"]
        self._gps_delay_us = int(round(self._gps_delay * 1e6))
        # alignment accumulators
        self._al_n = 0
        self._al_f = np.zeros(3)
        self._al_w = np.zeros(3)
        self._al_w2 = np.zeros(3)
        self._al_m = np.zeros(3)
        self._al_nm = 0
        self._al_t0: int | None = None
        self._f_lp: np.ndarray | None = None  # low-passed specific force for in-flight alignment
        self._tilt_ok = False                 # roll/pitch converged: heading fusion may start
        self._aux_due_us = self._aux_period_us - _AUX_PERIOD_TOL_US
        self._clear_aux(-(1 << 62))
        # P's version: every change of P counts it up (the filters' _set_P, predictions
        # and updates); the health's P test of version _sane_ver and EK_HPOS_MAX _sane_hmax
        self._P_ver = 0
        self._sane_ver, self._sane_hmax, self._sane = -1, None, False
        self._sig9_ver, self._sig9 = -1, ()          # output_sigmas9 of P's version _sig9_ver
        self._reset_covariance_model()

    # ----------------------------------------------------------- public helpers --
    def sigma(self) -> dict[str, np.ndarray]:
        """1-sigma of the error states, for logging: p_ned [m], v_ned [m/s], att [rad]
        (NED-frame rotation vector: ~roll, ~pitch, yaw error when level), accel_bias
        [m/s^2], gyro_bias [rad/s], baro_bias [m], gps_bias [m], wind [m/s] (fixed-wing)."""
        s = np.sqrt(np.maximum(np.diag(self.P), 0.0))
        out = {"p_ned": s[POS], "v_ned": s[VEL], "att": s[ATT],
               "accel_bias": s[ABIAS], "gyro_bias": s[GBIAS], "baro_bias": s[BBIAS],
               "gps_bias": s[GPSB]}
        if self.is_plane:
            out["wind"] = s[WIND]
        return out

    def output_sigmas9(self) -> tuple:
        """1-sigma of the output's position, velocity and attitude errors (the first nine
        error states). Under the barometric height reference the output's height is
        ``p_D - b_baro`` on the datum ``b_baro0``: its variance is that of ``p_D - b_baro``
        plus the datum's, the offset's variance when it was initialised.

        Worked out again only when P has changed (its version, as the health's test; the
        flight log asks at 50 Hz, the fixed-wing's P changes every cov_div-th step)."""
        if self._sig9_ver != self._P_ver:
            P = self.P
            d = P.diagonal()[:9].tolist()
            if self._hgt_baro and self._baro_ok:
                item = P.item
                d[2] = item(_IP + 2, _IP + 2) + item(_IBB, _IBB) - 2.0 * item(_IP + 2, _IBB) + self._bb0_var
            self._sig9 = tuple([math.sqrt(x) if x > 0.0 else 0.0 for x in d])  # NaN: 0
            self._sig9_ver = self._P_ver
        return self._sig9

    @property
    def specific_force_b(self) -> tuple | None:
        """The last accelerometer sample less the bias estimate, body axes [m/s^2]."""
        f = self._accel_prev
        if f is None:
            return None
        ba = self.nom.x[X_BA:X_BA + 3].tolist()
        return f[0] - ba[0], f[1] - ba[1], f[2] - ba[2]

    @property
    def position_ned(self) -> np.ndarray:
        """The filter's NED position estimate, the state its covariance describes. The
        output (NavState.p_ned) differs from it in height under the barometric height
        reference (EK_HGT_REF = 0) by the offset estimate's change since its datum."""
        return self.nom.x[X_P:X_P + 3].copy()

    @property
    def accel_bias(self) -> np.ndarray:
        """Accelerometer bias estimate, body [m/s^2]."""
        return self.nom.x[X_BA:X_BA + 3].copy()

    @property
    def gyro_bias(self) -> np.ndarray:
        """Gyro bias estimate, body [rad/s]."""
        return self.nom.x[X_BG:X_BG + 3].copy()

    @property
    def baro_bias(self) -> float:
        """Barometer offset estimate (baro altitude - altitude) [m]."""
        return self.nom.bb

    @property
    def gps_bias(self) -> np.ndarray:
        """Estimate of the slow (Gauss-Markov) GPS position error, NED [m]."""
        return self.nom.x[X_GB:X_GB + 3].copy()

    @property
    def P(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    # --------------------------------------------------------------------- update --
    def update(self, frame: SensorFrame) -> NavState:
        """One IMU step: predict with frame.imu, then fuse what else is present."""
        t = frame.t_us
        self.innovations = []
        dt = 0.0 if self._t_us is None else (t - self._t_us) * 1e-6
        dt = 0.0 if 0.0 > dt else dt                # min(max(dt, 0), _MAX_DT) spelt out
        dt = _MAX_DT if _MAX_DT < dt else dt        # (the builtins' cost: control/pid.py)
        self._t_us = t
        imu = frame.imu
        if frame.airspeed is not None:
            self._airspeed = (t, frame.airspeed.airspeed_mps)
            self.heard_us["airspeed"] = t
        if frame.baro is not None:
            self._last_baro_alt = frame.baro.alt_m
            self.heard_us["baro"] = t
        if frame.mag is not None:
            self.heard_us["mag"] = t
        gps = frame.gps if (frame.gps is not None and frame.gps.fix_type >= 3) else None
        if gps is not None and self.origin is None:
            self._set_origin(LocalFrame(gps.lat_rad, gps.lon_rad, gps.alt_m))

        w1 = imu.omega_b
        f1 = self._accel_prev = imu.f_b
        self._geo = None
        if not self.aligned:
            self._hold_samples(f1, w1)
            self._align_step(frame, gps)
            if not self.aligned:
                return self._output(t)
            self._push_history(t)
            if self._pos_src == "gps":   # aligned in flight on this very fix
                return self._output(t)
        elif dt > 0.0:
            # the rotation over [t - dt, t]: trapezoid of the rate samples at both ends
            # (strapdown.py); the specific force: the sample at t. The history row and
            # the output with it (imu_step).
            self._predict(dt, f1, w1, t)
        else:
            self._hold_samples(f1, w1)
            self._push_history(t)

        aux_due = self._accumulate_aux(frame)
        if gps is not None or aux_due or self._pos_src == "fake":   # else nothing to fuse
            batch = self._assemble(frame, gps, aux_due)
            if batch is not None:
                self._fuse(batch, t)
        return self._output(t)

    # ------------------------------------------------------------------ alignment --
    def _hold_samples(self, f1, w1) -> None:
        """Keep this step's IMU samples for the next step's (imu_step does it itself)."""
        s = self._s
        s[S_F0:S_F0 + 3] = f1
        s[S_W0:S_W0 + 3] = w1

    def _set_origin(self, origin: LocalFrame) -> None:
        self.origin = origin
        self._g = gravity_m_s2(origin.lat0_rad, origin.alt0_m)
        self._w_ie = earth_rate_ned(origin.lat0_rad)
        s = self._s
        s[S_G] = self._g
        s[S_WIE:S_WIE + 3] = self._w_ie
        s[S_ORG] = 1.0
        s[S_ORG + 1:S_ORG + 7] = origin.fast_constants()
        if self.params["EK_MAG_AUTODEC"]:
            # as ArduPilot's COMPASS_AUTODEC: the declination of the place, from the
            # IGRF main-field model, once the origin (first GPS fix) is known
            from ..geo.magfield import declination_inclination_rad, igrf_field_ned_gauss
            self._declination = declination_inclination_rad(
                igrf_field_ned_gauss(origin.lat0_rad, origin.lon0_rad, origin.alt0_m))[0]

    def set_param(self, name: str, value: float) -> None:
        """A parameter changed in flight (the vehicle's ``_param_follow``): the filter's
        own copy takes it, and what was worked out from it (the process noise, the
        sampling-error thresholds) is worked out again now, so that it applies from the
        next step; the rest the filter reads from its copy where it uses it. The ones
        that cannot change mid-flight (EK_AUX_HZ, EK_HGT_REF, EK_GPS_DELAY,
        EK_MAG_AUTODEC: ``at_start``) are left as they were started."""
        if name not in self.params or config.AT_START.get(name, False):
            return
        self.params[name] = float(value)
        if name in ("EK_ACC_NSE", "EK_GYR_NSE"):
            s = self._s
            s[S_THR] = (2.0 * self.params["EK_ACC_NSE"]) ** 2
            s[S_THR + 1] = (2.0 * self.params["EK_GYR_NSE"]) ** 2
        cache = getattr(self, "_interval_cache", None)
        if cache is not None:
            cache.clear()                     # (the EKF's noise over several steps)
        if self._q_dt > 0.0:
            self._process_noise(self._q_dt)   # diag Q of the step length in use

    @property
    def declination_rad(self) -> float | None:
        """The declination in use (None while it waits for a position)."""
        if self.params["EK_MAG_AUTODEC"]:
            return self._declination
        return self.params["EK_MAG_DEC"]

    def _align_step(self, frame: SensorFrame, gps) -> None:
        imu = frame.imu
        f, w = np.array(imu.f_b), np.array(imu.omega_b)
        # specific force low-passed over ~0.3 s (30 samples at 100 Hz)
        self._f_lp = f.copy() if self._f_lp is None else self._f_lp + (f - self._f_lp) / 30.0
        if gps is not None and math.hypot(gps.v_ned[0], gps.v_ned[1]) >= self.params["EK_ALIGN_GSPD"]:
            # moving (a straight, unaccelerated leg looks static to the IMU)
            self._align_in_flight(gps)
            return
        static = (float(np.dot(w, w)) < _STATIC_GYRO ** 2
                  and abs(math.sqrt(float(np.dot(f, f))) - self._g) < _STATIC_ACC)
        if not static:
            self._al_n = self._al_nm = 0
            self._al_f[:] = 0.0
            self._al_w[:] = 0.0
            self._al_w2[:] = 0.0
            self._al_m[:] = 0.0
            self._al_t0 = None
            return
        if self._al_t0 is None:
            self._al_t0 = frame.t_us
        self._al_n += 1
        self._al_f += f
        self._al_w += w
        self._al_w2 += w * w
        if frame.mag is not None:
            self._al_m += frame.mag.m_b        # (a tuple added to the array)
            self._al_nm += 1
        if (frame.t_us - self._al_t0) * 1e-6 >= self.params["EK_ALIGN_T"] and self._al_nm > 0 \
                and self.declination_rad is not None:
            self._align_on_ground()

    def _align_on_ground(self) -> None:
        f_mean = self._al_f / self._al_n
        roll, pitch = level_from_accel(f_mean)
        yaw = heading_from_mag(self._al_m / self._al_nm, roll, pitch, self.declination_rad)
        nom = self.nom
        nom.set_attitude(euler_to_quat(roll, pitch, yaw))
        # gyro bias = mean rate - the Earth rate in body axes; known to the standard
        # error of that mean (floored for the bias drift over the average)
        n = self._al_n
        w_mean = self._al_w / n
        w_ie_b = nom.R_matrix().T @ np.array(self._w_ie)
        nom.bg = (w_mean - w_ie_b).tolist()
        bg_sd = np.maximum(np.sqrt(np.maximum(self._al_w2 / n - w_mean * w_mean, 0.0) / n), _BG_ALIGN_SD_MIN)
        nom.omega_b = [0.0, 0.0, 0.0]
        self._init_covariance(self._sd_vector(
            pos=_FAKE_POS_SD, vel=0.5, att=(0.0, 0.0, 0.1), abias=_BA_INIT_SD, gbias=bg_sd,
            bbias=_BARO_INIT_SD, gpsb=self._gm_sd(), wind=8.0))
        # Levelling on the mean specific force puts the accelerometer bias into the
        # tilt: the estimated f_n is vertical, so the velocity drift g x dtheta - R db_a
        # is zero. The tilt error is the horizontal NED bias over g (dtheta_N = (R b)_E / g,
        # dtheta_E = -(R b)_N / g), plus the noise of the mean: correlated, not
        # independent, or GPS velocity noise on the ground would move the tilt along
        # the direction it cannot observe until the vehicle turns.
        R = nom.R_matrix()
        T = np.vstack((R[1], -R[0])) / self._g
        P = self.P.copy()
        Pbb = P[ABIAS, ABIAS]
        tilt = slice(ATT.start, ATT.start + 2)
        P[tilt, tilt] = T @ Pbb @ T.T + np.eye(2) * _TILT_ALIGN_SD ** 2
        P[tilt, ABIAS] = T @ Pbb
        P[ABIAS, tilt] = (T @ Pbb).T
        self._set_P(P)
        self.aligned = True
        self._pos_src = "fake"
        self._fake_hold = list(nom.p)

    def _align_in_flight(self, gps) -> None:
        if self.origin is None:
            return
        v = [float(c) for c in gps.v_ned]
        yaw = math.atan2(v[1], v[0])
        roll, pitch = level_from_accel(self._f_lp)
        nom = self.nom
        nom.set_attitude(euler_to_quat(roll, pitch, yaw))
        nom.v = v
        z = list(self.origin.ned_fast(gps.lat_rad, gps.lon_rad, gps.alt_m))
        L = self._gps_delay
        nom.p = [z[0] + v[0] * L, z[1] + v[1] * L, z[2] + v[2] * L]
        nom.gb = [0.0, 0.0, 0.0]
        white = self._gps_white(gps)
        baro_sd = _BARO_INIT_SD
        if self._last_baro_alt is not None:
            self._set_baro_datum(self._last_baro_alt - (self.origin.alt0_m - nom.p[2]))
            baro_sd = math.hypot(self._gm_sd()[2], white[2])
            self._bb0_var = baro_sd * baro_sd
        self._init_covariance(self._sd_vector(
            pos=1.0, vel=1.0, att=(0.3, 0.3, 0.35), abias=_BA_INIT_SD, gbias=0.02,
            bbias=baro_sd, gpsb=self._gm_sd(), wind=8.0))
        self._position_from_gps_covariance(np.array(white) ** 2)
        self.aligned = True
        self._pos_src = "gps"
        self._hist[:, _H_T] = -math.inf   # the history must not hold the unaligned state

    def _sd_vector(self, **blocks) -> np.ndarray:
        """Initial 1-sigmas by layout block name (pos=..., att=(r, p, y), ...)."""
        sd = np.zeros(self.n)
        for name, value in blocks.items():
            sl = _BLOCKS[name]
            if sl.start < self.n:
                sd[sl] = value
        return sd

    def _gm_sd(self) -> list[float]:
        """Stationary sigma of the GPS Gauss-Markov error states (N, E, D)."""
        h, v = self.params["EK_GPSB_SD"], self.params["EK_GPSB_Z_SD"]
        return [h, h, v]

    def _gps_white(self, gps) -> tuple[float, float, float]:
        """White-noise sigma (N, E, D) of a fix: the part of eph/epv the Gauss-Markov
        state does not explain, floored by EK_GPS_P_NSE / EK_GPS_Z_NSE. ``eph`` is the
        radial horizontal accuracy, sqrt(s_N^2 + s_E^2): per axis eph / sqrt(2)."""
        prm = self.params
        gh, gv = prm["EK_GPSB_SD"], prm["EK_GPSB_Z_SD"]
        sh = max(prm["EK_GPS_P_NSE"], math.sqrt(max(0.5 * gps.eph_m * gps.eph_m - gh * gh, 0.0)))
        sv = max(prm["EK_GPS_Z_NSE"], math.sqrt(max(gps.epv_m * gps.epv_m - gv * gv, 0.0)))
        return sh, sh, sv

    def _position_from_gps_covariance(self, white_var: np.ndarray) -> None:
        """Covariance after setting p = z - b_gps: dp = -db - w, so
        P_pp = P_bb + R_w and P_pb = -P_bb; position decorrelated from the rest."""
        P = self.P.copy()
        Pbb = P[GPSB, GPSB].copy()
        P[POS, :] = 0.0
        P[:, POS] = 0.0
        P[POS, POS] = Pbb + np.diag(white_var)
        P[POS, GPSB] = -Pbb
        P[GPSB, POS] = -Pbb
        self._set_P(P)

    def _reset_covariance_block(self, sl: slice, var) -> None:
        P = self.P.copy()
        P[sl, :] = 0.0
        P[:, sl] = 0.0
        P[sl, sl] = np.diag(np.atleast_1d(var))
        self._set_P(P)

    # -------------------------------------------------------------------- history --
    def _push_history(self, t: int) -> None:
        push_history(self.nom.x, self._s, self._hist, t)

    def _rewrite_history(self, t: int) -> None:
        """This step's history row written again, after a change of the nominal state
        within the step's prediction (the UKF folds its mean into it)."""
        s = self._s
        s[S_HI] = (s[S_HI] - 1.0) % _HIST
        self._push_history(t)

    def _delayed(self, t_valid: int) -> tuple:
        """(p, v, dv_f, q_s) of the nominal state nearest to t_valid, with later
        corrections; dv_f = integral of f_n dt from then to now, q_s = the velocity
        sampling variances (N, E, D) added since (:func:`delayed`)."""
        o = delayed(self._hist, self._s, t_valid)
        return o[0:3], o[3:6], o[6:9], o[9:12]

    # ----------------------------------------------------------- measurement models --
    def _accumulate_aux(self, frame: SensorFrame) -> bool:
        """Add this step's barometer, magnetometer and airspeed samples to the running
        sums (:func:`aux_into`); True when they are due for fusion (module docstring:
        aux sensors). The magnetometer once roll and pitch are known, the airspeed on
        the fixed-wing above EK_ARSP_MIN once the GPS fixes the position."""
        which, alt, mx, my, mz, tas = 0, 0.0, 0.0, 0.0, 0.0, 0.0
        baro, mag, air = frame.baro, frame.mag, frame.airspeed
        if baro is not None:
            which, alt = _AUX_BARO, baro.alt_m
            self._air = (baro.pressure_pa, baro.temperature_k)
        if mag is not None and self._tilt_aligned():
            which |= _AUX_MAG
            mx, my, mz = mag.m_b
        if (self.is_plane and air is not None and self._pos_src == "gps"
                and air.airspeed_mps >= self.params["EK_ARSP_MIN"]):
            which |= _AUX_AIR
            tas = self._true_airspeed(air)
        if which:
            self._aux_any = aux_into(self._buf, which, alt, mx, my, mz, tas)
        return self._aux_any and frame.t_us - self._aux_t >= self._aux_due_us

    def _clear_aux(self, t: int) -> None:
        """The aux sums start afresh at t (their fusion)."""
        self._s[S_BARO:S_N_AIR + 1] = 0.0
        self._aux_t = t              # time of the last fusion [us]
        self._aux_any = False        # whether the sums hold a sample

    def _assemble(self, frame: SensorFrame, gps, aux_due: bool = True) -> Batch | None:
        """Stack this step's measurements: z, h(x), R, gate^2 and the nonzeros of H
        (as flat indices into the (rows, n) buffer, written with one ``put``); the aux
        sensors' means when ``aux_due``."""
        prm = self.params
        n = self.n
        xs = self.nom.x.tolist()              # the nominal state as floats, read once
        p, v = xs[X_P:X_P + 3], xs[X_V:X_V + 3]
        Rm = xs[X_R:X_R + 9]
        src, start, size, reset = [], [], [], []
        z, h0, R, g2 = [], [], [], []
        hv = []

        def add(name, zs, hs, var, gate, vals, forced=False):
            """Append one source at row r: z, h, R; H[r + row, col] = val for the
            (row, col) pairs of _H_COLS[name] (flat offsets row * n + col, below)."""
            m = len(zs)
            src.append(name)
            start.append(len(z))
            size.append(m)
            reset.append(forced)
            z.extend(zs)
            h0.extend(hs)
            R.extend(var)
            g2.extend((gate * gate,) * m)
            hv.extend(vals)

        if gps is not None:
            L = self._gps_delay
            pd, vd, (fx, fy, fz), qs = self._delayed(frame.t_us - self._gps_delay_us)
            sh, _, sv = self._gps_white(gps)
            gb = xs[X_GB:X_GB + 3]
            forced = self._pos_src != "gps"
            # gps_pos: h = p(t-L) + b_gps,  H = [I, -L I, 0 ..., I (GPSB), 0]
            add("gps_pos", list(self.origin.ned_fast(gps.lat_rad, gps.lon_rad, gps.alt_m)),
                (pd[0] + gb[0], pd[1] + gb[1], pd[2] + gb[2]), (sh * sh, sh * sh, sv * sv),
                prm["EK_GPS_P_GATE"], (1.0, -L, 1.0) * 3, forced)
            # gps_vel: h = v(t-L),  H = [0, I, [dv_f x], L R, 0 ...]
            #   (dv_f = integral of f_n over the latency, ~ L f_n; exact through a launch)
            #   R += the velocity sampling noise added since t - L (the delayed-state H
            #   neglects process noise over the latency: right unless a launch is in it)
            s2 = prm["EK_GPS_V_NSE"] ** 2
            add("gps_vel", gps.v_ned.tolist(), vd, (s2 + qs[0], s2 + qs[1], _GPS_VD_SCALE2 * s2 + qs[2]),
                prm["EK_GPS_V_GATE"],
                (1.0, 1.0, 1.0, -fz, fy, fz, -fx, -fy, fx)
                + tuple([L * c for c in Rm]), forced)
        elif self._pos_src == "fake":
            # fake_pos: h = p,  H = [I, 0 ...]
            s2 = _FAKE_POS_SD ** 2
            add("fake_pos", self._fake_hold, p, (s2, s2, s2), 1e3, (1.0, 1.0, 1.0))

        if aux_due:
            baro, n_baro, mn, me, n_mag, air, n_air = self._s[S_BARO:S_N_AIR + 1].tolist()
            if n_baro and self._baro_ok:
                # baro: h = alt0 - p_D + b_baro  (mean of the samples since the last fusion)
                add("baro", (baro / n_baro,), (self.origin.alt0_m - p[2] + xs[X_BB],),
                    (prm["EK_BARO_NSE"] ** 2 / n_baro,), prm["EK_BARO_GATE"], (-1.0, 1.0))
            if n_mag:
                # mag: y = wrap(dec - atan2(m_E, m_N)) against h = yaw(q), m = the mean of the
                #      samples rotated into NED,  H_att = [-m_D m_N / B_h^2, -m_D m_E / B_h^2, 1]
                #      about the smoothed field, not this sample (module docstring)
                rn, re, rd = self._s[S_MREF:S_MREF + 3].tolist()
                rh2 = rn * rn + re * re
                yaw0 = math.atan2(Rm[3], Rm[0])
                add("mag", (yaw0 + wrap_pi(self.declination_rad - math.atan2(me, mn)),), (yaw0,),
                    (prm["EK_MAG_NSE"] ** 2 / n_mag,), prm["EK_MAG_GATE"],
                    (-rd * rn / rh2, -rd * re / rh2, 1.0))
            if n_air:
                w = xs[X_WIND:X_WIND + 2]
                ax, ay, az = v[0] - w[0], v[1] - w[1], v[2]
                tas = math.sqrt(ax * ax + ay * ay + az * az)
                if tas > 1.0:
                    # airspeed: h = |v - w|,  H_v = u^T, H_w = -u_NE^T  (u = (v - w) / |v - w|);
                    #   R not divided by the samples: turbulence, not the sensor, is its error
                    ux, uy, uz = ax / tas, ay / tas, az / tas
                    add("airspeed", (air / n_air,), (tas,), (prm["EK_ARSP_NSE"] ** 2,),
                        prm["EK_ARSP_GATE"], (ux, uy, uz, -ux, -uy))
                    # sideslip: h = e_y^T R^T (v - w) = c1 . (v - w)  (c1 = body y axis in NED)
                    #   H_att = (c1 x (v - w))^T, H_v = c1^T, H_w = -c1_NE^T
                    cx, cy, cz = Rm[1], Rm[4], Rm[7]
                    add("sideslip", (0.0,), (cx * ax + cy * ay + cz * az,), (prm["EK_BETA_NSE"] ** 2,),
                        prm["EK_BETA_GATE"],
                        (cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax, cx, cy, cz, -cx, -cy))
            self._clear_aux(frame.t_us)

        if not z:
            return None
        key = tuple(src)
        idx = self._h_index.get(key)
        if idx is None:
            # H's flat indices for this sequence of sources: row r of source k is its
            # start row + the row of its (row, col) pairs
            offsets = self._h_offsets
            hi = [r * n + o for name, r in zip(src, start) for o in offsets[name]]
            idx = self._h_index[key] = np.array(hi, dtype=np.intp)
        Hb = self._Hbuf
        Hb.fill(0.0)
        Hb.put(idx, hv)
        return Batch(src, start, size, reset, z, h0, R, g2, Hb[:len(z)])

    def _take_sampling_error(self) -> np.ndarray:
        """The sampling error over the steps since the last covariance prediction
        (imu_step; the entries at ``_qs_idx``, empty when none), for this prediction;
        the next interval starts afresh. (The EKF's kernel takes the interval's sums
        from the per-step array itself: ekf.predict_covariance_into.)"""
        s = self._s
        s[S_ACC_HAS] = 0.0
        if s[S_QS_HAS]:
            s[S_QS_HAS] = 0.0
            return self._acc_qs
        return _NO_QS

    def _true_airspeed(self, air) -> float:
        """True airspeed [m/s] from the pitot's dynamic pressure and the air density of
        the last barometer sample, rho = p / (R T): TAS = sqrt(2 q / rho). The sensor's
        own airspeed is the equivalent airspeed sqrt(2 q / rho0), 3.5 % below the true
        one at 700 m; used as such only before the first barometer sample."""
        if self._air is None or air.diff_pressure_pa <= 0.0:
            return air.airspeed_mps
        p, temp = self._air
        return math.sqrt(2.0 * air.diff_pressure_pa * _R_AIR * temp / p)

    def _propagate_nominal(self, dt: float, f1, w1, t: int) -> float:
        """Strapdown step of the nominal state from the IMU samples at the step's two ends
        (the last step's and f1, w1; :func:`imu_step`, with the history row and the
        output of step t), and the mean decay of the Gauss-Markov GPS error (b' = a b,
        a = exp(-dt / tau)). Returns a.

        The sampling error of the samples: the integrals of point samples err by up to
        half the change between two samples, along that change: ``e e^T``, e = R (x1 -
        x0) dt / 2. Added to P (ekf.predict_covariance_into, :meth:`_take_sampling_error`)
        where it exceeds the white noise (EK_ACC_NSE / EK_GYR_NSE per sample, which covers
        the sampling error of ordinary flight, turbulence included): a change of more than
        2 EK_ACC_NSE or 2 EK_GYR_NSE in one step. Through a catapult stroke's onset and
        end (75 m/s^2 in one step) it is 0.35 m/s along the stroke, where otherwise the
        GPS velocity would turn the error into an attitude or bias correction."""
        tau = self.params["EK_GPSB_TAU"]
        if dt != self._gm_step[0] or tau != self._gm_step[1]:
            self._gm_step = (dt, tau, math.exp(-dt / tau))   # the same dt every step
            self._s[S_GM] = self._gm_step[2]
        self._geo = imu_step(self._buf, *f1, *w1, dt, t)
        return self._gm_step[2]

    def _tilt_aligned(self) -> bool:
        """Start predicate of heading fusion: roll and pitch known to 3 deg."""
        if not self._tilt_ok:
            P = self.P
            self._tilt_ok = P[_IA, _IA] < _MAG_TILT_VAR and P[_IA + 1, _IA + 1] < _MAG_TILT_VAR
        return self._tilt_ok

    # --------------------------------------------------------------------- fusion --
    def _fuse(self, batch: Batch, t: int) -> None:
        """Gate each source, fuse the accepted rows, apply resets, write the records."""
        self._sync_covariance()
        self._gate_stats(batch)                       # sets batch.y, batch.Sd
        # the records' vectors: tuples of floats, sliced from the batch's (records.py)
        y = tuple(batch.y.tolist())
        adapted = ()
        if self.r_scale_hook is not None:
            adapted = self._scale_r(batch, self.r_scale_hook, y)
        Sd = tuple(batch.Sd.tolist())
        # test ratio = y^2 / (gate^2 S)
        ratio = tuple([yi * yi / (gi * si) for yi, gi, si in zip(y, batch.g2, Sd)])
        src, start, size, forced = batch.src, batch.start, batch.size, batch.reset
        if max(ratio) <= 1.0 and not self._rej_since and True not in forced:
            # every row within its gate, no source rejected before, none forced (most
            # fusions): all rows fused, nothing reset
            self._fuse_rows(batch, None)
            rejected = (False,) * len(src)
        else:
            rejected = self._gate_sources(batch, ratio, adapted, t)
        z = batch.z_tuple
        rec = self.innovations
        for k, name in enumerate(src):
            a = start[k]
            e = a + size[k]
            rec.append(InnovationRecord.make(t, name, z[a:e], y[a:e], Sd[a:e], ratio[a:e],
                                             rejected[k], forced[k] or not rejected[k]))

    def _gate_sources(self, batch: Batch, ratio: tuple, adapted, t: int) -> list[bool]:
        """The gate one source at a time: the rows of the sources within their gates
        fused, a source rejected for EK_GPS_RST_T (GPS) or EK_ARSP_RST_T (airspeed) reset
        (batch.reset set), the others left out. Returns whether each was rejected."""
        rst_us = self.params["EK_GPS_RST_T"] * 1e6
        arsp_rst_us = self.params["EK_ARSP_RST_T"] * 1e6
        src, start, size, forced = batch.src, batch.start, batch.size, batch.reset
        rejected = []
        resets = []
        rows = None
        for k, name in enumerate(src):
            a, m = start[k], size[k]
            rej = max(ratio[a:a + m]) > 1.0
            rejected.append(rej)
            if rej:
                since = self._rej_since.setdefault(name, t)
                if name in ("gps_pos", "gps_vel") and t - since >= rst_us:
                    forced[k] = True
                elif name == "airspeed" and t - since >= arsp_rst_us and name not in adapted:
                    # not while the fault monitor adapts the airspeed's R: it holds the
                    # sensor suspect, and the wind must not absorb the sensor's error
                    forced[k] = True
            else:
                self._rej_since.pop(name, None)
            if forced[k]:
                resets.append(k)
            if rej or forced[k]:
                if rows is None:
                    rows = list(range(a))
            elif rows is not None:
                rows.extend(range(a, a + m))
        if rows is None:
            self._fuse_rows(batch, None)
        elif rows:
            self._fuse_rows(batch, rows)
        for k in resets:
            self._reset_to(src[k], batch, start[k])
        return rejected

    @staticmethod
    def _scale_r(batch: Batch, hook, y: tuple) -> list[str]:
        """R adaptation hook (class docstring): S_ii = (H P H^T)_ii + s_i R_ii for the
        rows whose factors the hook returns (factors all 1 change nothing); the batch's
        R and Sd are copied first (never written in place). ``y``: batch.y as a tuple.
        Returns the sources the hook returned factors for (the ones being adapted)."""
        R, Sd = batch.R, batch.Sd
        copied = False
        adapted = []
        hph_all = Sd - R                              # diag(H P H^T)
        hph_t, r_t = tuple(hph_all.tolist()), tuple(R.tolist())   # the hook's
        for k, name in enumerate(batch.src):
            a = batch.start[k]
            b = a + batch.size[k]
            s = hook(name, y[a:b], hph_t[a:b], r_t[a:b])
            if s is None:
                continue
            adapted.append(name)
            r = R[a:b]
            s = np.asarray(s, dtype=float)
            if (s == 1.0).all():
                continue                              # the optimal filter, bit for bit
            if not copied:
                copied = True
                R = batch.R = R.copy()
                Sd = batch.Sd = Sd.copy()
            rs = r * s
            R[a:b] = rs
            Sd[a:b] = hph_all[a:b] + rs
        return adapted

    def _reset_to(self, source: str, batch: Batch, a: int) -> None:
        """Reset position or velocity to the (latency-compensated) GPS, or the wind to
        the airspeed (:meth:`_reset_wind`)."""
        if source == "airspeed":
            self._reset_wind(float(batch.z[a]), float(batch.R[a]))
            return
        nom = self.nom
        s = self._s
        dz = (batch.z[a:a + 3] - batch.h0[a:a + 3]).tolist()
        self._geo = None
        if source == "gps_pos":
            p, cp = nom.p, s[S_CP:S_CP + 3].tolist()
            nom.p = [p[i] + dz[i] for i in range(3)]
            s[S_CP:S_CP + 3] = [cp[i] + dz[i] for i in range(3)]
            self._position_from_gps_covariance(batch.R[a:a + 3])
            self._rej_since.pop("gps_pos", None)
            self._pos_src = "gps"
            if not self._baro_ok and self._last_baro_alt is not None:
                self._set_baro_datum(self._last_baro_alt - (self.origin.alt0_m - nom.p[2]))
                self._reset_covariance_block(BBIAS, self.P[_IP + 2, _IP + 2])
                self._bb0_var = float(self.P[_IBB, _IBB])
        elif source == "gps_vel":
            v, cv = nom.v, s[S_CV:S_CV + 3].tolist()
            nom.v = [v[i] + dz[i] for i in range(3)]
            s[S_CV:S_CV + 3] = [cv[i] + dz[i] for i in range(3)]
            self._reset_covariance_block(VEL, batch.R[a:a + 3])
            self._rej_since.pop("gps_vel", None)

    def _set_baro_datum(self, bb: float) -> None:
        """The baro offset initialised (from the GPS height) to ``bb``, the datum of the
        output's height under the baro height reference."""
        self.nom.bb = bb
        s = self._s
        s[S_BB0] = bb
        s[S_BHGT] = 1.0 if self._hgt_baro else 0.0
        self._baro_ok = True

    def _reset_wind(self, tas: float, r_tas: float) -> None:
        """Re-initialise the wind from the airspeed ``tas`` (variance ``r_tas``), the
        velocity and the heading, assuming zero sideslip and no vertical wind: the air
        velocity is ``tas_h`` along the heading psi, tas_h = sqrt(tas^2 - v_D^2), so
        w = v_NE - tas_h (cos psi, sin psi) and the airspeed's innovation is zero. After
        a long rejection the wind states have wandered off on the sideslip and GPS alone
        and the gate would refuse the airspeed for good; this lets it in again. PX4's EKF2
        sets its wind the same way (airspeed, ground velocity and yaw, zero sideslip) when
        airspeed fusion starts with the wind uncertain; ArduPilot's EKF3, when it starts
        using its wind states, from the same inputs with the wind taken along the heading,
        and after a timed-out airspeed rejection it fuses the airspeed past the gate only
        while the position aiding has timed out as well.

        Covariance: dw = dv_NE - u dtas_h - tas_h u_perp dpsi (u = (cos psi, sin psi),
        u_perp = (-sin psi, cos psi)), with the sideslip assumption's error (EK_BETA_NSE,
        body-y air velocity) along u_perp, plus _WIND_RESET_SD^2 on each axis for the gust
        in the one airspeed sample the reset takes; decorrelated from the other states."""
        nom = self.nom
        v = nom.v
        Rm = nom.R
        psi = math.atan2(Rm[3], Rm[0])
        c, s = math.cos(psi), math.sin(psi)
        tas_h = math.sqrt(max(tas * tas - v[2] * v[2], 0.0))
        nom.wind = [v[0] - tas_h * c, v[1] - tas_h * s]
        self._geo = self._wind_ned = None     # (the output's air velocity and wind)
        P = self.P
        u = np.array((c, s))
        up = np.array((-s, c))
        var_perp = tas_h * tas_h * float(P[_IA + 2, _IA + 2]) + self.params["EK_BETA_NSE"] ** 2
        Pw = (P[_IV:_IV + 2, _IV:_IV + 2] + r_tas * np.outer(u, u) + var_perp * np.outer(up, up)
              + np.eye(2) * _WIND_RESET_SD ** 2)
        P = P.copy()
        P[WIND, :] = 0.0
        P[:, WIND] = 0.0
        P[WIND, WIND] = Pw
        self._set_P(P)
        self._rej_since.pop("airspeed", None)

    def _inject(self, dx: np.ndarray) -> None:
        """Fold an error-state estimate into the nominal state (dx is then zero;
        :func:`inject_into`)."""
        inject_into(self.nom.x, self._s, dx)
        self._geo = self._wind_ned = None

    def _condition(self, P: np.ndarray) -> np.ndarray:
        """Symmetrise P and keep its diagonal inside [floor, ceiling]."""
        P = P + P.T
        P *= 0.5
        d = P.reshape(-1)[:: self.n + 1]              # the diagonal, as a writeable view
        np.maximum(d, self._floor, out=d)
        np.minimum(d, self._ceil, out=d)
        return P

    # --------------------------------------------------------------------- output --
    def _output(self, t: int) -> NavState:
        """The step's NavState: the health (aligned, on GPS, P's position and attitude
        variances finite and the horizontal within EK_HPOS_MAX, no source rejected for
        longer than EK_REJ_TOUT) and the output of the nominal state."""
        ok = False
        if self.aligned and self._pos_src == "gps":
            hmax = self.params["EK_HPOS_MAX"]
            if self._sane_ver != self._P_ver or self._sane_hmax != hmax:
                # P's part, read again only when P has changed (the fixed-wing's P
                # changes every cov_div-th step and in fusions)
                item = self.P.item             # (4 entries: not the whole diagonal)
                d = self._health_idx
                pn, pe = item(d[0]), item(d[1])
                self._sane = (math.isfinite(pn + pe + item(d[2]) + item(d[3]))
                              and pn + pe <= hmax ** 2)
                self._sane_ver, self._sane_hmax = self._P_ver, hmax
            ok = self._sane
        if ok and self._rej_since:
            tout = self.params["EK_REJ_TOUT"] * 1e6
            for since in self._rej_since.values():
                if t - since > tout:
                    ok = False
                    break
        self.healthy = ok
        x = self.nom.x
        if self._geo is None:
            # a step without imu_step, or the nominal state changed since it wrote the
            # output (a fusion, a reset): written again
            self._geo = output_into(x, self._s, self._o)
        lat, lon, alt, an, ae, ad = self._geo
        if self._wind_ned is None:
            # one array per wind estimate (it changes in a fusion), handed to every
            # output until the next
            self._wind_ned = np.array((x.item(X_WIND), x.item(X_WIND + 1), 0.0))
        if self._airspeed is not None and t - self._airspeed[0] <= _AIRSPEED_HOLD_US:
            airspeed = float(self._airspeed[1])
        else:
            airspeed = math.sqrt(an ** 2 + ae ** 2 + ad ** 2)
        p, v, q, w = self._o_views
        return NavState.make(t, p, v, q, w, lat, lon, alt, airspeed, self._wind_ned,
                             self.aligned, ok, self.SOURCE)

    # ---------------------------------------------------------- filter-specific --
    def _sync_covariance(self) -> None:
        """Bring P up to the present before a fusion (a filter that propagates its
        covariance every few steps catches up here; the default propagates every step)."""

    def _reset_covariance_model(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _init_covariance(self, sd: np.ndarray) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _set_P(self, P: np.ndarray) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _predict(self, dt: float, f1, w1, t: int) -> None:  # pragma: no cover - overridden
        """Propagate over dt to step t from the IMU samples at the step's two ends (the
        last step's and f1, w1: :meth:`_propagate_nominal`), and the covariance."""
        raise NotImplementedError

    def _gate_stats(self, batch: Batch) -> None:  # pragma: no cover - overridden
        """Set batch.y = z - h(x) and batch.Sd = diag(H P H^T) + R."""
        raise NotImplementedError

    def _fuse_rows(self, batch: Batch, rows: list[int] | None) -> None:  # pragma: no cover
        """Fuse the given rows of the batch (None: all) and inject the correction."""
        raise NotImplementedError
