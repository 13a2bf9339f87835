"""Quaternion operations on stacks of quaternions / rotation vectors (numpy, vectorised).

Same convention as :mod:`autopilot.geo.rotations` (Hamilton, scalar first, q_nb);
used by the UKF (all sigma points at once) and the sensor simulator.
Shapes: quaternions (N, 4), vectors (N, 3); a single (4,) operand broadcasts.
"""
from __future__ import annotations

import numpy as np


def mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product p (x) q, row by row."""
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(np.broadcast_shapes(p.shape, q.shape))
    out[..., 0] = pw * qw - px * qx - py * qy - pz * qz
    out[..., 1] = pw * qx + px * qw + py * qz - pz * qy
    out[..., 2] = pw * qy - px * qz + py * qw + pz * qx
    out[..., 3] = pw * qz + px * qy - py * qx + pz * qw
    return out


def conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def from_rotvec(phi: np.ndarray) -> np.ndarray:
    """Exp: rotation vectors -> unit quaternions."""
    ang = np.sqrt(np.einsum("...i,...i->...", phi, phi))
    half = 0.5 * ang
    small = ang < 1e-9
    s = np.where(small, 0.5, np.sin(half) / np.where(small, 1.0, ang))
    out = np.empty(phi.shape[:-1] + (4,))
    out[..., 0] = np.cos(half)
    out[..., 1:] = phi * s[..., None]
    return out


def to_rotvec(q: np.ndarray) -> np.ndarray:
    """Log: unit quaternions -> rotation vectors (shortest rotation)."""
    q = np.where(q[..., :1] < 0.0, -q, q)
    v = q[..., 1:]
    s = np.sqrt(np.einsum("...i,...i->...", v, v))
    small = s < 1e-12
    ang = 2.0 * np.arctan2(s, q[..., 0])
    k = np.where(small, 2.0, ang / np.where(small, 1.0, s))
    return v * k[..., None]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a x b of (N, 3) stacks (np.cross is several times slower)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = ay * bz - az * by
    out[..., 1] = az * bx - ax * bz
    out[..., 2] = ax * by - ay * bx
    return out


def normalize(q: np.ndarray) -> np.ndarray:
    q = q / np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]
    return np.where(q[..., :1] < 0.0, -q, q)


def to_dcm(q: np.ndarray) -> np.ndarray:
    """R(q_nb) for each row, shape (N, 3, 3)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = ww + xx - yy - zz
    R[..., 0, 1] = 2.0 * (x * y - w * z)
    R[..., 0, 2] = 2.0 * (x * z + w * y)
    R[..., 1, 0] = 2.0 * (x * y + w * z)
    R[..., 1, 1] = ww - xx + yy - zz
    R[..., 1, 2] = 2.0 * (y * z - w * x)
    R[..., 2, 0] = 2.0 * (x * z - w * y)
    R[..., 2, 1] = 2.0 * (y * z + w * x)
    R[..., 2, 2] = ww - xx - yy + zz
    return R


def from_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """q_nb of 3-2-1 Euler angles, vectorised (same formula as geo.euler_to_quat)."""
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    q = np.stack((
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ), axis=-1)
    return normalize(q)


def to_euler(q: np.ndarray) -> np.ndarray:
    """(roll, pitch, yaw) columns, shape (N, 3)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return np.stack((roll, pitch, yaw), axis=-1)
