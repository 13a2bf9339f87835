"""Rotations: the one module that fixes the quaternion convention.

Convention (docs/architecture.md, "Conventions"): Hamilton quaternions, scalar first ``[w, x, y, z]``;
``q_nb`` rotates body (FRD) vectors into the NED frame, ``v_ned = R(q_nb) @ v_b``.
Euler angles are the aerospace 3-2-1 sequence (yaw psi, pitch theta, roll phi), seed
eqs 1.6-1.10 (Beard & McLain 2012, ch. 2 and app. B). Quaternion kinematics
``q_dot = 1/2 q (x) [0, omega_b]`` with renormalisation, seed eqs 1.13-1.14.

scipy's ``Rotation`` uses scalar-last order; conversion to and from it happens here
and nowhere else (:func:`to_scipy`, :func:`from_scipy`).

The functions are written on plain floats/NumPy for speed in the per-step loop; the
kernels at the end (:func:`quat_dcm`, :func:`quat_step` and their parts) are the same
formulas on floats, compiled, for the other kernels (the vehicles' and the plants').
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import kernel

PI = math.pi            # (a module constant: one load where math.pi takes two)
TWO_PI = 2.0 * math.pi


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + PI) % TWO_PI - PI


def wrap_2pi(angle_rad: float) -> float:
    """Wrap an angle to [0, 2 pi)."""
    return angle_rad % TWO_PI


def quat_normalize(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    q = q / n
    # Keep w >= 0 so that equal rotations compare equal.
    return q if q[0] >= 0.0 else -q


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product p (x) q."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return np.array([
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    ])


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_to_dcm(q: np.ndarray) -> np.ndarray:
    """R(q_nb): the matrix with v_ned = R @ v_b."""
    w, x, y, z = q
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    return np.array([
        [ww + xx - yy - zz, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), ww - xx + yy - zz, 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), ww - xx - yy + zz],
    ])


def dcm_to_quat(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`quat_to_dcm` (Shepperd's method, numerically safe)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    return quat_normalize(np.array(q))


def euler_to_quat(roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """q_nb from 3-2-1 Euler angles (yaw, then pitch, then roll)."""
    cr, sr = math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad)
    cp, sp = math.cos(0.5 * pitch_rad), math.sin(0.5 * pitch_rad)
    cy, sy = math.cos(0.5 * yaw_rad), math.sin(0.5 * yaw_rad)
    return quat_normalize(np.array([
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]))


def quat_to_euler(q: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of q_nb; yaw in [-pi, pi) (:func:`euler_321`). Cheapest
    on a list or tuple of floats (``q.tolist()``): the kernel's call unboxes numpy's
    scalars slowly."""
    w, x, y, z = q
    return euler_321(w, x, y, z)


def quat_from_rotvec(phi: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation vector (axis * angle) [rad]."""
    angle = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    if angle < 1e-9:
        return quat_normalize(np.array([1.0, 0.5 * phi[0], 0.5 * phi[1], 0.5 * phi[2]]))
    s = math.sin(0.5 * angle) / angle
    return np.array([math.cos(0.5 * angle), phi[0] * s, phi[1] * s, phi[2] * s])


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    q = quat_normalize(q)
    v = q[1:]
    s = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if s < 1e-12:
        return 2.0 * v
    angle = 2.0 * math.atan2(s, q[0])
    return v * (angle / s)


def quat_integrate(q_nb: np.ndarray, omega_b: np.ndarray, dt: float) -> np.ndarray:
    """Propagate q_nb by a body rate held over dt (seed eqs 1.13-1.14), renormalised."""
    return quat_normalize(quat_multiply(q_nb, quat_from_rotvec(np.asarray(omega_b) * dt)))


def rotate(q_nb: np.ndarray, v_b: np.ndarray) -> np.ndarray:
    """v_ned = R(q_nb) v_b."""
    return quat_to_dcm(q_nb) @ v_b


def skew(v: np.ndarray) -> np.ndarray:
    """[v x], so that skew(a) @ b == cross(a, b)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


# --- the single place that speaks scipy's scalar-last order -------------------------

def to_scipy(q_nb: np.ndarray):
    """scipy.spatial.transform.Rotation of q_nb."""
    from scipy.spatial.transform import Rotation
    w, x, y, z = q_nb
    return Rotation.from_quat([x, y, z, w])


def from_scipy(rot) -> np.ndarray:
    x, y, z, w = rot.as_quat()
    return quat_normalize(np.array([w, x, y, z]))


# --- the same formulas on floats, compiled (called from other kernels) ----------------

@kernel
def euler_321(w, x, y, z):
    """(roll, pitch, yaw) of q = (w, x, y, z) (:func:`quat_to_euler`; the vehicles call it
    every step, where the Python arithmetic cost more than this call)."""
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = 2.0 * (w * y - z * x)
    s = s if s < 1.0 else 1.0                      # max(-1.0, min(1.0, s))
    pitch = math.asin(s if s > -1.0 else -1.0)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, (yaw + PI) % TWO_PI - PI   # wrap_pi


@kernel
def quat_dcm(w, x, y, z):
    """R(q_nb) of q = (w, x, y, z) as a row-major 9-tuple (:func:`quat_to_dcm`)."""
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    return (ww + xx - yy - zz, 2.0 * (xy - wz), 2.0 * (xz + wy),
            2.0 * (xy + wz), ww - xx + yy - zz, 2.0 * (yz - wx),
            2.0 * (xz - wy), 2.0 * (yz + wx), ww - xx - yy + zz)


@kernel
def exp_rotvec(ax, ay, az):
    """Exp: a rotation vector to its unit quaternion (:func:`quat_from_rotvec`; below
    1e-9 rad, the first order)."""
    ang = math.sqrt(ax * ax + ay * ay + az * az)
    if ang > 1e-9:
        s = math.sin(0.5 * ang) / ang
        return math.cos(0.5 * ang), ax * s, ay * s, az * s
    return 1.0, 0.5 * ax, 0.5 * ay, 0.5 * az


@kernel
def unit_positive(rw, rx, ry, rz):
    """The quaternion (rw, rx, ry, rz) normalised, with a non-negative scalar part."""
    n = 1.0 / math.sqrt(rw * rw + rx * rx + ry * ry + rz * rz)
    if rw < 0.0:
        n = -n
    return rw * n, rx * n, ry * n, rz * n


@kernel
def quat_step(qw, qx, qy, qz, ax, ay, az):
    """q (x) Exp([ax, ay, az]) renormalised, w >= 0: a body rotation vector (omega dt)
    applied to q_nb (seed eqs 1.13-1.14; :func:`quat_integrate`)."""
    dw, dx, dy, dz = exp_rotvec(ax, ay, az)
    return unit_positive(qw * dw - qx * dx - qy * dy - qz * dz,
                         qw * dx + qx * dw + qy * dz - qz * dy,
                         qw * dy - qx * dz + qy * dw + qz * dx,
                         qw * dz + qx * dy - qy * dx + qz * dw)
