"""Nominal-state strapdown mechanisation and initial alignment.

Mechanisation (Groves 2013 ch. 5, simplified to a flat, non-rotating local NED frame;
Sola 2017 eq. 260 for the nominal kinematics), one IMU sample held over ``dt``:

    omega = omega_m - b_g                      bias-corrected body rate
    f     = f_m - b_a                          bias-corrected specific force
    f_n   = R(q) (f + 1/2 dt omega x f)        specific force in NED, rotated to mid-step
    v'    = v + (f_n + g_n) dt                 g_n = [0, 0, g(lat0, alt0)]
    p'    = p + 1/2 (v + v') dt                trapezoidal position
    q'    = q (x) Exp(omega dt)                body-frame rotation increment, renormalised

Earth rate (7.3e-5 rad/s) and transport rate are neglected: they are below the noise of
the MEMS gyros this filter is tuned for and the vehicle stays within tens of km of the
origin. The ``1/2 dt omega x f`` term rotates the specific force to the middle of the
step (the first-order rotation compensation of Savage 1998), which removes a bias of
``|omega| dt / 2 * |f|`` in turns.

Everything here is written on Python floats for the 100 Hz loop: a 3x3 numpy
matrix product costs as much as the whole float version.
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import euler_to_quat, wrap_pi


class Nominal:
    """The nominal (full) navigation state around which the error state is estimated."""

    __slots__ = ("p", "v", "q", "ba", "bg", "bb", "gb", "wind", "R", "f_n", "omega_b")

    def __init__(self):
        self.p = np.zeros(3)          # position NED [m]
        self.v = np.zeros(3)          # velocity NED [m/s]
        self.q = np.array([1.0, 0.0, 0.0, 0.0])  # q_nb
        self.ba = np.zeros(3)         # accelerometer bias, body [m/s^2]
        self.bg = np.zeros(3)         # gyro bias, body [rad/s]
        self.bb = np.zeros(1)         # barometer offset: baro altitude - altitude [m]
        self.gb = np.zeros(3)         # GPS position error, NED [m]
        self.wind = np.zeros(2)       # wind north, east [m/s]
        self.R = np.eye(3)            # R(q_nb), kept in step with q
        self.f_n = np.zeros(3)        # last bias-corrected specific force in NED [m/s^2]
        self.omega_b = np.zeros(3)    # last bias-corrected body rate [rad/s]

    def set_attitude(self, q: np.ndarray) -> None:
        self.q = np.asarray(q, dtype=float).copy()
        self.R = dcm(self.q)

    def copy(self) -> "Nominal":
        n = Nominal()
        for name in self.__slots__:
            setattr(n, name, getattr(self, name).copy())
        return n


def dcm(q: np.ndarray) -> np.ndarray:
    """R(q_nb) (same formula as autopilot.geo.quat_to_dcm, inlined for speed)."""
    w, x, y, z = q.tolist()
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    return np.array([
        [ww + xx - yy - zz, 2.0 * (xy - wz), 2.0 * (xz + wy)],
        [2.0 * (xy + wz), ww - xx + yy - zz, 2.0 * (yz - wx)],
        [2.0 * (xz - wy), 2.0 * (yz + wx), ww - xx - yy + zz],
    ])


def propagate(nom: Nominal, f_m: np.ndarray, omega_m: np.ndarray, dt: float, g: float) -> None:
    """Advance the nominal state by one IMU sample (module docstring), in place."""
    omega = omega_m - nom.bg
    f = f_m - nom.ba
    wx, wy, wz = omega.tolist()
    fx, fy, fz = f.tolist()
    h = 0.5 * dt
    # f + 1/2 dt omega x f  (rotation to mid-step)
    gx = fx + h * (wy * fz - wz * fy)
    gy = fy + h * (wz * fx - wx * fz)
    gz = fz + h * (wx * fy - wy * fx)
    R = nom.R
    f_n = R @ np.array((gx, gy, gz))
    v0 = nom.v
    # v' = v + (f_n + g_n) dt
    v1 = v0 + f_n * dt
    v1[2] += g * dt
    # p' = p + 1/2 (v + v') dt
    nom.p = nom.p + (v0 + v1) * h
    nom.v = v1
    # q' = q (x) Exp(omega dt)
    ax, ay, az = wx * dt, wy * dt, wz * dt
    ang = math.sqrt(ax * ax + ay * ay + az * az)
    if ang > 1e-9:
        s = math.sin(0.5 * ang) / ang
        dw, dx, dy, dz = math.cos(0.5 * ang), ax * s, ay * s, az * s
    else:
        dw, dx, dy, dz = 1.0, 0.5 * ax, 0.5 * ay, 0.5 * az
    qw, qx, qy, qz = nom.q.tolist()
    rw = qw * dw - qx * dx - qy * dy - qz * dz
    rx = qw * dx + qx * dw + qy * dz - qz * dy
    ry = qw * dy - qx * dz + qy * dw + qz * dx
    rz = qw * dz + qx * dy - qy * dx + qz * dw
    n = 1.0 / math.sqrt(rw * rw + rx * rx + ry * ry + rz * rz)
    if rw < 0.0:
        n = -n
    nom.q = np.array((rw * n, rx * n, ry * n, rz * n))
    nom.R = dcm(nom.q)
    nom.f_n = f_n
    nom.omega_b = omega


def inject_attitude(nom: Nominal, dtheta: np.ndarray) -> None:
    """q <- Exp(dtheta) (x) q: apply a global (NED-frame) attitude correction."""
    ax, ay, az = dtheta.tolist()
    ang = math.sqrt(ax * ax + ay * ay + az * az)
    if ang > 1e-9:
        s = math.sin(0.5 * ang) / ang
        dw, dx, dy, dz = math.cos(0.5 * ang), ax * s, ay * s, az * s
    else:
        dw, dx, dy, dz = 1.0, 0.5 * ax, 0.5 * ay, 0.5 * az
    qw, qx, qy, qz = nom.q.tolist()
    rw = dw * qw - dx * qx - dy * qy - dz * qz
    rx = dw * qx + dx * qw + dy * qz - dz * qy
    ry = dw * qy - dx * qz + dy * qw + dz * qx
    rz = dw * qz + dx * qy - dy * qx + dz * qw
    n = 1.0 / math.sqrt(rw * rw + rx * rx + ry * ry + rz * rz)
    if rw < 0.0:
        n = -n
    nom.q = np.array((rw * n, rx * n, ry * n, rz * n))
    nom.R = dcm(nom.q)


def yaw_of(R: np.ndarray) -> float:
    """3-2-1 yaw of R(q_nb) [rad]."""
    return math.atan2(R[1, 0], R[0, 0])


def mag_heading(R: np.ndarray, m_b: np.ndarray, declination_rad: float) -> float:
    """Heading measured by the magnetometer, tilt-compensated with the attitude R.

    The field is rotated into NED with the current estimate, ``m_hat = R m_b``; its
    horizontal direction, corrected for declination, gives the yaw error, so the
    measured heading is ``yaw(R) + dec - atan2(m_hat_e, m_hat_n)``. Roll/pitch errors
    of the estimate leak into it by about tan(inclination) per radian of tilt error
    (modelled as part of EK_MAG_NSE).
    """
    m_hat = R @ m_b
    return wrap_pi(yaw_of(R) + declination_rad - math.atan2(m_hat[1], m_hat[0]))


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
    R_level = dcm(euler_to_quat(roll, pitch, 0.0))
    m_l = R_level @ np.asarray(m_b, dtype=float)
    return wrap_pi(declination_rad - math.atan2(m_l[1], m_l[0]))
