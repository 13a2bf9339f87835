"""Nominal-state strapdown mechanisation and initial alignment.

Mechanisation (Groves 2013 ch. 5, local-navigation-frame equations, simplified to a
flat local NED frame; Sola 2017 for the nominal-state kinematics), one step ``dt``:

    omega = omega_m - b_g - R^T w_ie           body rate relative to the NED frame
    f     = f_m - b_a                          bias-corrected specific force
    f_n   = R(q) (f + 1/2 dt omega x f)        specific force in NED, rotated to mid-step
    v'    = v + (f_n + g_n - 2 w_ie x v) dt    g_n = [0, 0, g(lat0, alt0) + 3.086e-6 p_D]
    p'    = p + 1/2 (v + v') dt                trapezoidal position
    q'    = q (x) Exp(omega dt)                body-frame rotation increment, renormalised

``w_ie = Omega_E [cos(lat0), 0, -sin(lat0)]`` is the Earth rate in NED at the origin. A
gyro measures rotation relative to inertial space, so the Earth rate (7.3e-5 rad/s,
0.004 deg/s) is in every sample: fixed in NED, it turns in the body frame as the vehicle
turns, and a gyro-bias state cannot follow it (removing it took the closed loop's gyro
residual down by an order of magnitude: docs/status.md, "Navigation"). ``2 w_ie x v`` is
the Coriolis acceleration (3 mm/s^2 at 25 m/s). The transport rate (v / R_E, 4e-6 rad/s)
is neglected: the vehicle stays within tens of km of the origin.
The ``1/2 dt omega x f`` term rotates the specific force to the middle of the step
(the first-order rotation compensation of Savage 1998), which removes a bias of
``|omega| dt / 2 * |f|`` in turns.

Time alignment of the IMU samples (the caller's choice, see base.py): the specific
force ``f_m`` is the sample at the end of the step; ``omega_m`` is the mean of the
samples at both ends (point samples, integrated by the trapezoidal rule as PX4's
sensor integrator does).

The nominal state is one float array (:class:`Nominal`, layout ``X_*`` below) that the
filters' per-step kernel (base.py, ``imu_step``) reads and writes in place: one compiled
call a step instead of the state handed over as floats and written back as lists. The
Python side reads it through ``Nominal``'s attributes (lists of floats, as before).
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import euler_to_quat, wrap_pi
from autopilot.geo.rotations import exp_rotvec, quat_dcm, quat_step, unit_positive
from autopilot.jit import kernel

#: Earth rotation rate (WGS-84) [rad/s].
EARTH_RATE = 7.292115e-5
#: Free-air gravity gradient: g grows by this per metre of descent [1/s^2].
GRAVITY_GRADIENT = 3.086e-6


def earth_rate_ned(lat_rad: float) -> tuple[float, float, float]:
    """The Earth's rotation in the local NED frame at latitude ``lat_rad`` [rad/s]."""
    return (EARTH_RATE * math.cos(lat_rad), 0.0, -EARTH_RATE * math.sin(lat_rad))


def dcm9(q) -> tuple:
    """R(q_nb) of a 4-sequence q as a row-major 9-tuple (autopilot.geo.rotations.quat_dcm)."""
    w, x, y, z = q
    return quat_dcm(float(w), float(x), float(y), float(z))


# The nominal state's layout in Nominal.x: p, v, q and then mechanise's other outputs
# in its order (R(q) row-major, f_n, omega), so that its 25 floats land at X_P: +25
# (base.imu_step writes them there).
X_P, X_V, X_Q, X_R, X_FN, X_W = 0, 3, 6, 10, 19, 22
X_BG, X_BA, X_BB, X_GB, X_WIND = 25, 28, 31, 32, 35
X_SIZE = 37


def _block(i: int, n: int):
    """A Nominal attribute: x[i:i + n] read as a list of floats, written from a sequence."""
    def get(self):
        return self.x[i:i + n].tolist()

    def put(self, value):
        self.x[i:i + n] = value
    return property(get, put)


class Nominal:
    """The nominal (full) navigation state around which the error state is estimated:
    the array ``x`` (layout ``X_*``), read and written in place by the filters' kernels;
    its parts as attributes (lists of floats; ``R`` a tuple, ``bb`` a float). ``R`` is
    R(q_nb) row-major, kept in step with ``q`` (set both, as ``set_attitude`` does: the
    mechanisation reads q and recomputes R)."""

    __slots__ = ("x",)

    p = _block(X_P, 3)            # position NED [m]
    v = _block(X_V, 3)            # velocity NED [m/s]
    q = _block(X_Q, 4)            # q_nb
    f_n = _block(X_FN, 3)         # last bias-corrected specific force, NED [m/s^2]
    omega_b = _block(X_W, 3)      # last bias-corrected body rate [rad/s]
    bg = _block(X_BG, 3)          # gyro bias, body [rad/s]
    ba = _block(X_BA, 3)          # accelerometer bias, body [m/s^2]
    gb = _block(X_GB, 3)          # GPS position error, NED [m]
    wind = _block(X_WIND, 2)      # wind north, east [m/s]

    def __init__(self, x: np.ndarray | None = None):
        """``x``: the array to hold the state in (X_SIZE zeros; the filters' is a view
        of their buffer, base.py), else a new one."""
        self.x = np.zeros(X_SIZE) if x is None else x
        self.set_attitude((1.0, 0.0, 0.0, 0.0))

    @property
    def R(self) -> tuple:
        return tuple(self.x[X_R:X_R + 9].tolist())

    @property
    def bb(self) -> float:
        """Barometer offset: baro altitude - altitude [m]."""
        return self.x.item(X_BB)

    @bb.setter
    def bb(self, value: float) -> None:
        self.x[X_BB] = value

    def set_attitude(self, q) -> None:
        q = [float(c) for c in q]
        self.q = q
        self.x[X_R:X_R + 9] = dcm9(q)

    def R_matrix(self) -> np.ndarray:
        return self.x[X_R:X_R + 9].reshape(3, 3).copy()

    def copy(self) -> "Nominal":
        n = Nominal()
        n.x[:] = self.x
        return n


@kernel
def mechanise(px, py, pz, vx, vy, vz, qw, qx, qy, qz, bgx, bgy, bgz, bax, bay, baz,
              fmx, fmy, fmz, omx, omy, omz, dt, g, ex, ey, ez):
    """One step of the mechanisation (module docstring) on floats (a kernel's arguments
    cost least as floats): the nominal position, velocity and attitude q_nb, the gyro and
    accelerometer biases, the samples f_m and omega_m, dt, gravity and the Earth rate in
    NED. Returns the 25 floats of p', v', q', R(q') (row-major), f_n and omega."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = quat_dcm(qw, qx, qy, qz)
    # omega = omega_m - b_g - R^T w_ie
    wx = omx - bgx - (r00 * ex + r10 * ey + r20 * ez)
    wy = omy - bgy - (r01 * ex + r11 * ey + r21 * ez)
    wz = omz - bgz - (r02 * ex + r12 * ey + r22 * ez)
    fx = fmx - bax
    fy = fmy - bay
    fz = fmz - baz
    h = 0.5 * dt
    # f + 1/2 dt omega x f  (rotation to mid-step)
    gx = fx + h * (wy * fz - wz * fy)
    gy = fy + h * (wz * fx - wx * fz)
    gz = fz + h * (wx * fy - wy * fx)
    fnx = r00 * gx + r01 * gy + r02 * gz
    fny = r10 * gx + r11 * gy + r12 * gz
    fnz = r20 * gx + r21 * gy + r22 * gz
    # v' = v + (f_n + g_n - 2 w_ie x v) dt ;  p' = p + 1/2 (v + v') dt
    ux = vx + (fnx - 2.0 * (ey * vz - ez * vy)) * dt
    uy = vy + (fny - 2.0 * (ez * vx - ex * vz)) * dt
    uz = vz + (fnz + g + GRAVITY_GRADIENT * pz - 2.0 * (ex * vy - ey * vx)) * dt
    # q' = q (x) Exp(omega dt)
    sw, sx, sy, sz = quat_step(qw, qx, qy, qz, wx * dt, wy * dt, wz * dt)
    R = quat_dcm(sw, sx, sy, sz)
    return (px + (vx + ux) * h, py + (vy + uy) * h, pz + (vz + uz) * h, ux, uy, uz,
            sw, sx, sy, sz, R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8],
            fnx, fny, fnz, wx, wy, wz)


@kernel
def rotate_global(q, ax, ay, az):
    """q <- Exp(dtheta) (x) q for a global (NED-frame) rotation vector dtheta = (ax, ay,
    az). Returns (q', R(q'))."""
    dw, dx, dy, dz = exp_rotvec(ax, ay, az)
    qw, qx, qy, qz = q
    q1 = unit_positive(dw * qw - dx * qx - dy * qy - dz * qz,
                       dw * qx + dx * qw + dy * qz - dz * qy,
                       dw * qy - dx * qz + dy * qw + dz * qx,
                       dw * qz + dx * qy - dy * qx + dz * qw)
    return q1, quat_dcm(q1[0], q1[1], q1[2], q1[3])


@kernel
def mag_ned(R, mx, my, mz):
    """The measured field (mx, my, mz) rotated into NED by the attitude R (9 floats,
    row-major)."""
    return (R[0] * mx + R[1] * my + R[2] * mz, R[3] * mx + R[4] * my + R[5] * mz,
            R[6] * mx + R[7] * my + R[8] * mz)


def level_from_accel(f_b: np.ndarray) -> tuple[float, float]:
    """Roll and pitch [rad] of a vehicle at rest from its mean specific force
    (at rest f_b = -R^T g_n = g [sin th, -sin ph cos th, -cos ph cos th])."""
    fx, fy, fz = float(f_b[0]), float(f_b[1]), float(f_b[2])
    roll = math.atan2(-fy, -fz)
    pitch = math.atan2(fx, math.sqrt(fy * fy + fz * fz))
    return roll, pitch


def heading_from_mag(m_b: np.ndarray, roll: float, pitch: float, declination_rad: float) -> float:
    """Tilt-compensated magnetic heading [rad]: rotate m_b into the level frame
    (m_l = Ry(pitch) Rx(roll) m_b = Rz(-yaw) m_n) and read yaw = dec - atan2(m_l_y, m_l_x)."""
    R_level = np.array(dcm9(euler_to_quat(roll, pitch, 0.0))).reshape(3, 3)
    m_l = R_level @ np.asarray(m_b, dtype=float)
    return wrap_pi(declination_rad - math.atan2(m_l[1], m_l[0]))
