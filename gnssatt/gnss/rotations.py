"""Quaternions, direction cosine matrices and Euler angles exactly as CONVENTIONS.md fixes them; Wahba solvers.

Conventions (CONVENTIONS.md "Quaternions", "Euler angles"):
- q = (w, x, y, z), scalar first, unit norm, w >= 0 on output. A quaternion "A->body" maps components:
  v_body = R(q) v_A with the passive ("Shuster") attitude matrix
      R(q) = (w^2 - |u|^2) I + 2 u u^T - 2 w [u x],   u = (x, y, z).
  So q = (cos(a/2), sin(a/2) e) is a rotation of the *frame* by angle a about axis e; e.g. R about z is
  Rz(a) = [[cos a, sin a, 0], [-sin a, cos a, 0], [0, 0, 1]].
- Products compose like the matrices: R(quat_multiply(p, q)) = R(p) @ R(q), so
  q_C_from_A = quat_multiply(q_C_from_B, q_B_from_A), as R_C_from_A = R_C_from_B @ R_B_from_A.
  With p = (p_w, p_u), q = (q_w, q_u):  p (x) q = (p_w q_w - p_u.q_u,  p_w q_u + q_w p_u - p_u x q_u)
  (Shuster 1993, "A survey of attitude representations", eq. 169, the "natural" order).
- Euler 3-2-1: R_body_from_ref = Rx(roll) Ry(pitch) Rz(yaw) with frame (passive) rotations, degrees,
  yaw in (-180, 180], pitch in [-90, 90], roll in (-180, 180].
Arrays: quaternions (..., 4), vectors (..., 3), matrices (..., 3, 3); every function is vectorised.

Implements: Shuster (1993) J. Astronaut. Sci. 41(4) 439-517; Shepperd (1978) J. Guid. Control 1(3) 223;
Shuster & Oh (1981) J. Guid. Control 4(1) 70-77 (TRIAD, QUEST and its covariance); Davenport q-method
(Keat 1977) solved by a symmetric eigen-decomposition.
"""
from __future__ import annotations

import numpy as np


def _asq(q) -> np.ndarray:
    return np.asarray(q, dtype=np.float64)


def skew(v) -> np.ndarray:
    """[v x] (..., 3, 3) of vectors (..., 3): skew(a) @ b == np.cross(a, b)."""
    v = np.asarray(v, dtype=np.float64)
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return S


def quat_normalize(q) -> np.ndarray:
    """Unit quaternions (..., 4) with w >= 0 (the canonical sign of CONVENTIONS.md)."""
    q = _asq(q)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0.0, -q, q)


def quat_conjugate(q) -> np.ndarray:
    """Conjugate (= inverse for unit q) (w, -x, -y, -z), shape (..., 4): R(q*) = R(q)^T."""
    q = _asq(q)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def quat_multiply(p, q, canonical: bool = True) -> np.ndarray:
    """Quaternion product p (x) q, shape (..., 4), with R(p (x) q) = R(p) @ R(q).

    p (x) q = (p_w q_w - p_u.q_u, p_w q_u + q_w p_u - p_u x q_u).
    Args:
        p, q: (..., 4) quaternions (broadcast).
        canonical: flip the sign of results with w < 0 (same rotation) to keep CONVENTIONS.md's w >= 0.
    Implements: Shuster (1993) eq. 169.
    """
    p, q = np.broadcast_arrays(_asq(p), _asq(q))
    pw, pu = p[..., 0], p[..., 1:]
    qw, qu = q[..., 0], q[..., 1:]
    w = pw * qw - np.sum(pu * qu, axis=-1)
    u = pw[..., None] * qu + qw[..., None] * pu - np.cross(pu, qu)
    out = np.concatenate([w[..., None], u], axis=-1)
    if canonical:
        out = np.where(out[..., :1] < 0.0, -out, out)
    return out


def quat_to_dcm(q) -> np.ndarray:
    """Attitude matrices R(q) (..., 3, 3) = (w^2 - |u|^2) I + 2 u u^T - 2 w [u x] (q normalised first)."""
    q = _asq(q)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([w * w + x * x - y * y - z * z, 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=-1),
        np.stack([2 * (x * y - w * z), w * w - x * x + y * y - z * z, 2 * (y * z + w * x)], axis=-1),
        np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), w * w - x * x - y * y + z * z], axis=-1),
    ], axis=-2)


def dcm_to_quat(R) -> np.ndarray:
    """Unit quaternions (..., 4), w >= 0, of attitude matrices R (..., 3, 3) (inverse of quat_to_dcm).

    Shepperd's method: of 4w^2 = 1 + tr R, 4x^2 = 1 + R11 - R22 - R33, 4y^2 = ..., 4z^2 = ..., take the
    square root of the largest and the other three components from the off-diagonal sums/differences
    (4wx = R23 - R32, 4wy = R31 - R13, 4wz = R12 - R21, 4xy = R12 + R21, 4xz = R13 + R31, 4yz = R23 + R32),
    so no division by a small number; the result is renormalised (tolerates slightly non-orthogonal R).
    Implements: Shepperd (1978); Shuster (1993) eq. 163-168 for this passive R(q).
    """
    R = np.asarray(R, dtype=np.float64)
    r11, r12, r13 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    r21, r22, r23 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    r31, r32, r33 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    tr = r11 + r22 + r33
    d = np.stack([tr, r11, r22, r33], axis=-1)
    k = np.argmax(d, axis=-1)
    # four candidate (unnormalised, scaled by 4*pivot) quaternions
    c0 = np.stack([1 + tr, r23 - r32, r31 - r13, r12 - r21], axis=-1)
    c1 = np.stack([r23 - r32, 1 + r11 - r22 - r33, r12 + r21, r13 + r31], axis=-1)
    c2 = np.stack([r31 - r13, r12 + r21, 1 - r11 + r22 - r33, r23 + r32], axis=-1)
    c3 = np.stack([r12 - r21, r13 + r31, r23 + r32, 1 - r11 - r22 + r33], axis=-1)
    cand = np.stack([c0, c1, c2, c3], axis=-2)
    q = np.take_along_axis(cand, k[..., None, None], axis=-2)[..., 0, :]
    return quat_normalize(q)


def quat_from_axis_angle(axis, angle_rad) -> np.ndarray:
    """Quaternions (..., 4) of a frame rotation by angle_rad about axis (..., 3): (cos(a/2), sin(a/2) e), w >= 0.

    R of the result is the passive rotation, e.g. axis z gives Rz(a) = [[c, s, 0], [-s, c, 0], [0, 0, 1]].
    """
    axis = np.asarray(axis, dtype=np.float64)
    e = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = 0.5 * np.asarray(angle_rad, dtype=np.float64)
    return quat_normalize(np.concatenate([np.cos(half)[..., None], np.sin(half)[..., None] * e], axis=-1))


def quat_from_rotvec(theta_rad) -> np.ndarray:
    """Quaternions (..., 4) of rotation vectors theta (..., 3) (frame rotation by |theta| about theta/|theta|).

    Exact for any angle, and well conditioned at 0 (sin(a/2)/a by its series below 1e-4 rad).
    """
    th = np.asarray(theta_rad, dtype=np.float64)
    a = np.linalg.norm(th, axis=-1)
    small = a < 1e-4
    a_safe = np.where(small, 1.0, a)
    s_over_a = np.where(small, 0.5 - a * a / 48.0, np.sin(0.5 * a_safe) / a_safe)
    return quat_normalize(np.concatenate([np.cos(0.5 * a)[..., None], s_over_a[..., None] * th], axis=-1))


def quat_to_rotvec(q) -> np.ndarray:
    """Rotation vectors (..., 3) (rad) of quaternions (inverse of quat_from_rotvec, angle in [0, pi])."""
    q = quat_normalize(q)
    w, u = q[..., 0], q[..., 1:]
    s = np.linalg.norm(u, axis=-1)
    a = 2.0 * np.arctan2(s, w)
    small = s < 1e-12
    scale = np.where(small, 2.0, a / np.where(small, 1.0, s))
    return scale[..., None] * u


def rotate(R_or_q, v) -> np.ndarray:
    """Components R v (..., 3) of vectors v, given R (..., 3, 3) or a quaternion (..., 4)."""
    A = np.asarray(R_or_q, dtype=np.float64)
    if A.shape[-1] == 4:
        A = quat_to_dcm(A)
    return np.einsum("...ij,...j->...i", A, np.asarray(v, dtype=np.float64))


# --- Euler 3-2-1 ------------------------------------------------------------------------------------

def Rx(angle_rad) -> np.ndarray:
    """Frame (passive) rotation about x: [[1, 0, 0], [0, c, s], [0, -s, c]], shape (..., 3, 3)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, s], -1), np.stack([z, -s, c], -1)], -2)


def Ry(angle_rad) -> np.ndarray:
    """Frame (passive) rotation about y: [[c, 0, -s], [0, 1, 0], [s, 0, c]], shape (..., 3, 3)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([c, z, -s], -1), np.stack([z, o, z], -1), np.stack([s, z, c], -1)], -2)


def Rz(angle_rad) -> np.ndarray:
    """Frame (passive) rotation about z: [[c, s, 0], [-s, c, 0], [0, 0, 1]], shape (..., 3, 3)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1), np.stack([z, z, o], -1)], -2)


def euler321_to_dcm(yaw_deg, pitch_deg, roll_deg) -> np.ndarray:
    """R_body_from_ref (..., 3, 3) = Rx(roll) Ry(pitch) Rz(yaw) (frame rotations), angles in degrees.

    Written out (c = cos, s = sin; psi yaw, theta pitch, phi roll):
        [[c.th c.psi,                    c.th s.psi,                    -s.th     ],
         [s.phi s.th c.psi - c.phi s.psi, s.phi s.th s.psi + c.phi c.psi, s.phi c.th],
         [c.phi s.th c.psi + s.phi s.psi, c.phi s.th s.psi - s.phi c.psi, c.phi c.th]]
    Implements: CONVENTIONS.md "Euler angles"; Shuster (1993) eq. 93 for the 3-2-1 sequence.
    """
    psi, th, phi = (np.radians(np.asarray(a, dtype=np.float64)) for a in (yaw_deg, pitch_deg, roll_deg))
    return Rx(phi) @ Ry(th) @ Rz(psi)


def dcm_to_euler321(R) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(yaw_deg in (-180, 180], pitch_deg in [-90, 90], roll_deg in (-180, 180]) of R_body_from_ref (..., 3, 3).

    pitch = atan2(-R13, hypot(R11, R12)), yaw = atan2(R12, R11), roll = atan2(R23, R33). At gimbal lock
    (|pitch| = 90 deg, hypot(R11, R12) < 1e-12) only yaw - roll (pitch +90) or yaw + roll (pitch -90) is
    defined; roll is then set to 0 and yaw = atan2(-R21, R22).
    Implements: inverse of euler321_to_dcm (CONVENTIONS.md).
    """
    R = np.asarray(R, dtype=np.float64)
    c_th = np.hypot(R[..., 0, 0], R[..., 0, 1])
    pitch = np.arctan2(-R[..., 0, 2], c_th)
    lock = c_th < 1e-12
    yaw = np.where(lock, np.arctan2(-R[..., 1, 0], R[..., 1, 1]), np.arctan2(R[..., 0, 1], R[..., 0, 0]))
    roll = np.where(lock, 0.0, np.arctan2(R[..., 1, 2], R[..., 2, 2]))
    yaw_deg, roll_deg = np.degrees(yaw), np.degrees(roll)
    # (-180, 180]: atan2 may return exactly -180
    yaw_deg = np.where(yaw_deg <= -180.0, yaw_deg + 360.0, yaw_deg)
    roll_deg = np.where(roll_deg <= -180.0, roll_deg + 360.0, roll_deg)
    return yaw_deg, np.degrees(pitch), roll_deg


def attitude_error_deg(q_est, q_true) -> np.ndarray:
    """Rotation angle (deg, [0, 180]) of R(q_est) R(q_true)^T, shape (...,).

    Computed as 2 atan2(|u|, |w|) of q_est (x) q_true*, accurate for tiny and large angles alike.
    Implements: CONVENTIONS.md "attitude error".
    """
    d = quat_multiply(_asq(q_est), quat_conjugate(q_true), canonical=False)
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0])))


# --- Wahba's problem ------------------------------------------------------------------------------------

def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def quest(v_body, v_ref, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_ref (..., 4), cov_body_rad2 (..., 3, 3)) minimising sum_i w_i |b_i - R(q) r_i|^2.

    Args:
        v_body: (..., n, 3) observed directions in the body frame (normalised here).
        v_ref: (..., n, 3) the same directions in the reference frame.
        weights: (..., n) non-negative; for a meaningful covariance give 1 / sigma_i^2 with sigma_i the
            (isotropic) angular noise of b_i in rad. None = all 1. Vectors with weight 0 or any NaN are ignored.
    Returns the optimal quaternion (w >= 0) and the covariance of the small body-frame rotation delta_theta
    with R(q_est) = (I - [delta_theta x]) R(q_true):  P = [sum_i w_i (I - b_i b_i^T)]^-1  (Shuster & Oh 1981
    eq. 53 / Shuster 1989), with b_i = R(q_est) r_i. Fewer than two non-parallel vectors -> NaN outputs.
    Implements: Davenport's q-method (K matrix, Keat 1977; Shuster & Oh 1981 eqs. 36-44) by a batched
    symmetric eigen-decomposition (robust where QUEST's Newton iteration on the characteristic polynomial
    is fragile, e.g. at 180 deg rotations), and the QUEST covariance of Shuster & Oh (1981).
    """
    b = _unit(v_body)
    r = _unit(v_ref)
    b, r = np.broadcast_arrays(b, r)
    w = np.ones(b.shape[:-1]) if weights is None else np.broadcast_to(np.asarray(weights, dtype=np.float64),
                                                                      b.shape[:-1])
    ok = np.isfinite(b).all(-1) & np.isfinite(r).all(-1) & np.isfinite(w) & (w > 0)
    w = np.where(ok, w, 0.0)
    b = np.where(ok[..., None], b, 0.0)
    r = np.where(ok[..., None], r, 0.0)
    # attitude profile matrix B = sum w b r^T
    B = np.einsum("...n,...ni,...nj->...ij", w, b, r)
    S = B + np.swapaxes(B, -1, -2)
    sigma = np.trace(B, axis1=-2, axis2=-1)
    zv = np.stack([B[..., 1, 2] - B[..., 2, 1], B[..., 2, 0] - B[..., 0, 2], B[..., 0, 1] - B[..., 1, 0]], -1)
    K = np.zeros(B.shape[:-2] + (4, 4))
    # K for q = (w, u) scalar first: [[sigma, z^T], [z, S - sigma I]]
    K[..., 0, 0] = sigma
    K[..., 0, 1:] = zv
    K[..., 1:, 0] = zv
    K[..., 1:, 1:] = S - sigma[..., None, None] * np.eye(3)
    _, vecs = np.linalg.eigh(K)
    q = quat_normalize(vecs[..., :, -1])
    # covariance: Fisher information of the body-frame rotation error
    bh = rotate(quat_to_dcm(q)[..., None, :, :], r)
    info = np.einsum("...n,...nij->...ij", w, np.eye(3) - np.einsum("...ni,...nj->...nij", bh, bh))
    with np.errstate(all="ignore"):
        # NaN where singular (one direction, or parallel directions)
        cond_ok = np.linalg.cond(info) < 1e12
        P = np.linalg.inv(np.where(cond_ok[..., None, None], info, np.eye(3)))
    P = np.where(cond_ok[..., None, None], P, np.nan)
    q = np.where(cond_ok[..., None], q, np.nan)
    return q, P


def triad(v1_body, v2_body, v1_ref, v2_ref) -> np.ndarray:
    """q_body_from_ref (..., 4) by TRIAD: v1 is matched exactly, v2 only fixes the rotation about v1.

    t1 = v1, t2 = (v1 x v2)/|v1 x v2|, t3 = t1 x t2 in both frames; R = [t1b t2b t3b] [t1r t2r t3r]^T.
    Parallel v1, v2 give NaN.
    Implements: Black (1964); Shuster & Oh (1981) sec. II.
    """
    def basis(v1, v2):
        t1 = _unit(v1)
        c = np.cross(t1, np.asarray(v2, dtype=np.float64))
        n = np.linalg.norm(c, axis=-1, keepdims=True)
        with np.errstate(all="ignore"):
            t2 = np.where(n > 1e-12 * np.linalg.norm(v2, axis=-1, keepdims=True), c / n, np.nan)
        return np.stack([t1, t2, np.cross(t1, t2)], axis=-1)  # columns

    Mb = basis(v1_body, v2_body)
    Mr = basis(v1_ref, v2_ref)
    return dcm_to_quat(Mb @ np.swapaxes(Mr, -1, -2))


__all__ = [
    "quat_normalize", "quat_conjugate", "quat_multiply", "quat_to_dcm", "dcm_to_quat", "quat_from_axis_angle",
    "quat_from_rotvec", "quat_to_rotvec", "rotate", "Rx", "Ry", "Rz", "euler321_to_dcm", "dcm_to_euler321",
    "attitude_error_deg", "quest", "triad",
]
