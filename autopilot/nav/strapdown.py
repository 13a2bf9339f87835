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

The nominal state is kept in lists of Python floats (in the 100 Hz loop one numpy call on a
3-vector costs as much as the whole float mechanisation); the mechanisation is a kernel
(autopilot/jit.py) on tuples of those floats, cheaper than the same arithmetic in the
interpreter, with the same operations in the same order.
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


class Nominal:
    """The nominal (full) navigation state around which the error state is estimated.
    Lists of floats; ``R`` is R(q_nb) row-major, kept in step with ``q`` (set both, as
    ``set_attitude`` does: the mechanisation reads q and recomputes R)."""

    __slots__ = ("p", "v", "q", "ba", "bg", "bb", "gb", "wind", "R", "f_n", "omega_b")

    def __init__(self):
        self.p = [0.0, 0.0, 0.0]          # position NED [m]
        self.v = [0.0, 0.0, 0.0]          # velocity NED [m/s]
        self.q = [1.0, 0.0, 0.0, 0.0]     # q_nb
        self.ba = [0.0, 0.0, 0.0]         # accelerometer bias, body [m/s^2]
        self.bg = [0.0, 0.0, 0.0]         # gyro bias, body [rad/s]
        self.bb = 0.0                     # barometer offset: baro altitude - altitude [m]
        self.gb = [0.0, 0.0, 0.0]         # GPS position error, NED [m]
        self.wind = [0.0, 0.0]            # wind north, east [m/s]
        self.R = dcm9(self.q)
        self.f_n = [0.0, 0.0, 0.0]        # last bias-corrected specific force, NED [m/s^2]
        self.omega_b = [0.0, 0.0, 0.0]    # last bias-corrected body rate [rad/s]

    def set_attitude(self, q) -> None:
        self.q = [float(c) for c in q]
        self.R = dcm9(self.q)

    def R_matrix(self) -> np.ndarray:
        return np.array(self.R).reshape(3, 3)

    def copy(self) -> "Nominal":
        n = Nominal()
        for name in self.__slots__:
            v = getattr(self, name)
            setattr(n, name, list(v) if isinstance(v, list) else v)
        return n


def set_mechanised(nom: Nominal, o: tuple) -> None:
    """Write :func:`mechanise`'s 25 floats into ``nom``: one IMU step of the nominal
    state is ``set_mechanised(nom, mechanise(*nom.p, *nom.v, *nom.q, *nom.bg, *nom.ba,
    *f_m, *omega_m, dt, g, *w_ie))`` (the filters take it through ``base.imu_step``)."""
    (p0, p1, p2, v0, v1, v2, q0, q1, q2, q3, _, _, _, _, _, _, _, _, _,
     f0, f1, f2, w0, w1, w2) = o                  # (one unpacking: cheaper than slices)
    nom.p = [p0, p1, p2]
    nom.v = [v0, v1, v2]
    nom.q = [q0, q1, q2, q3]
    nom.R = o[10:19]
    nom.f_n = [f0, f1, f2]
    nom.omega_b = [w0, w1, w2]


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


def inject_attitude(nom: Nominal, ax: float, ay: float, az: float) -> None:
    """q <- Exp(dtheta) (x) q: apply a global (NED-frame) attitude correction."""
    q, R = rotate_global(tuple(nom.q), ax, ay, az)
    nom.q = list(q)
    nom.R = R


def mag_ned(R: tuple, m_b: tuple) -> tuple[float, float, float]:
    """The measured field m_b (3 floats) rotated into NED by the attitude R (row-major
    9-tuple)."""
    mx, my, mz = m_b
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = R
    return (r00 * mx + r01 * my + r02 * mz, r10 * mx + r11 * my + r12 * mz,
            r20 * mx + r21 * my + r22 * mz)


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
