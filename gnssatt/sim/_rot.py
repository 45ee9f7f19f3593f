"""Rotation helpers exactly per ../shared/CONVENTIONS.md (private until gnssatt/gnss/rotations.py lands).

Quaternions are scalar first (w, x, y, z), w >= 0, passive ("Shuster") convention:
R(q) = (w^2 - |u|^2) I + 2 u u^T - 2 w [u x], v_body = R(q) v_ref.
Euler 3-2-1: R_body_from_ref = Rx(roll) Ry(pitch) Rz(yaw), frame (passive) rotations.

Implements: Shuster 1993, "A survey of attitude representations", eq. 159 (R from q), Shepperd 1978
(q from R); minimum-jerk profile of Flash & Hogan 1985.
"""
from __future__ import annotations

import numpy as np


def dcm_from_quat(q: np.ndarray) -> np.ndarray:
    """R(q), shape (..., 3, 3), of scalar-first unit quaternions q (..., 4) (passive, CONVENTIONS.md)."""
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = w * w + x * x - y * y - z * z
    R[..., 1, 1] = w * w - x * x + y * y - z * z
    R[..., 2, 2] = w * w - x * x - y * y + z * z
    R[..., 0, 1] = 2 * (x * y + w * z)
    R[..., 1, 0] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z - w * y)
    R[..., 2, 0] = 2 * (x * z + w * y)
    R[..., 1, 2] = 2 * (y * z + w * x)
    R[..., 2, 1] = 2 * (y * z - w * x)
    return R


def quat_from_dcm(R: np.ndarray) -> np.ndarray:
    """Scalar-first quaternion (..., 4) with w >= 0 of passive rotation matrices R (..., 3, 3).

    Implements: Shepperd's method (largest-pivot branch, no loss of precision near 180 deg).
    """
    R = np.asarray(R, dtype=np.float64)
    tr = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    cand = np.stack([tr, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1)
    k = np.argmax(cand, axis=-1)
    q = np.empty(R.shape[:-2] + (4,))
    # passive: R01 - R10 = 4 w z, R12 - R21 = 4 w x, R20 - R02 = 4 w y
    d01, s01 = R[..., 0, 1] - R[..., 1, 0], R[..., 0, 1] + R[..., 1, 0]
    d12, s12 = R[..., 1, 2] - R[..., 2, 1], R[..., 1, 2] + R[..., 2, 1]
    d20, s20 = R[..., 2, 0] - R[..., 0, 2], R[..., 2, 0] + R[..., 0, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        w4 = 2 * np.sqrt(np.maximum(1 + tr, 0))
        x4 = 2 * np.sqrt(np.maximum(1 + 2 * R[..., 0, 0] - tr, 0))
        y4 = 2 * np.sqrt(np.maximum(1 + 2 * R[..., 1, 1] - tr, 0))
        z4 = 2 * np.sqrt(np.maximum(1 + 2 * R[..., 2, 2] - tr, 0))
        qa = np.stack([w4 / 4, d12 / w4, d20 / w4, d01 / w4], -1)
        qb = np.stack([d12 / x4, x4 / 4, s01 / x4, s20 / x4], -1)
        qc = np.stack([d20 / y4, s01 / y4, y4 / 4, s12 / y4], -1)
        qd = np.stack([d01 / z4, s20 / z4, s12 / z4, z4 / 4], -1)
    q = np.where((k == 0)[..., None], qa, np.where((k == 1)[..., None], qb,
                 np.where((k == 2)[..., None], qc, qd)))
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Quaternion r with R(r) = R(p) R(q) (passive composition: q first, then p); w >= 0 not enforced."""
    pw, pv = p[..., :1], p[..., 1:]
    qw, qv = q[..., :1], q[..., 1:]
    w = pw * qw - np.sum(pv * qv, axis=-1, keepdims=True)
    v = pw * qv + qw * pv - np.cross(pv, qv)
    return np.concatenate([w, v], axis=-1)


def _frame_rot(axis: int, angle_rad: np.ndarray) -> np.ndarray:
    a = np.asarray(angle_rad, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = s
    R[..., j, i] = -s
    return R


def dcm_from_euler321_deg(yaw_deg, pitch_deg, roll_deg) -> np.ndarray:
    """R_body_from_ref = Rx(roll) Ry(pitch) Rz(yaw), frame rotations, (..., 3, 3) (CONVENTIONS.md)."""
    d = np.pi / 180.0
    return (_frame_rot(0, np.asarray(roll_deg) * d) @ _frame_rot(1, np.asarray(pitch_deg) * d)
            @ _frame_rot(2, np.asarray(yaw_deg) * d))


def euler321_deg_from_dcm(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(yaw, pitch, roll) in degrees of R_body_from_ref (3-2-1; yaw, roll in (-180, 180], pitch [-90, 90])."""
    yaw = np.degrees(np.arctan2(R[..., 0, 1], R[..., 0, 0]))
    pitch = np.degrees(np.arcsin(np.clip(-R[..., 0, 2], -1.0, 1.0)))
    roll = np.degrees(np.arctan2(R[..., 1, 2], R[..., 2, 2]))
    yaw = np.where(yaw <= -180.0, yaw + 360.0, yaw)
    roll = np.where(roll <= -180.0, roll + 360.0, roll)
    return yaw, pitch, roll


def slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Spherical interpolation between unit quaternions q0 and q1 (shortest arc) at fractions s (n,) -> (n, 4)."""
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    s = np.asarray(s, dtype=np.float64)[..., None]
    if d > 1 - 1e-12:
        q = q0 + s * (q1 - q0)
    else:
        th = np.arccos(d)
        q = (np.sin((1 - s) * th) * q0 + np.sin(s * th) * q1) / np.sin(th)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def min_jerk(tau: np.ndarray) -> np.ndarray:
    """Minimum-jerk position profile s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 on tau clipped to [0, 1].

    Peak rate is 1.875 / duration times the total angle (Flash & Hogan 1985).
    """
    t = np.clip(tau, 0.0, 1.0)
    return t * t * t * (10.0 - 15.0 * t + 6.0 * t * t)


def rotation_angle_deg(R: np.ndarray) -> np.ndarray:
    """Rotation angle in degrees of rotation matrices (..., 3, 3)."""
    c = (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
