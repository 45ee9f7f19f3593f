"""Attitude increments of the estimators, the attitude error, and the paper's Euler matrix D (seed 003 eq. 26).

Rotations are written target_from_source (docs/ARCHITECTURE.md); `R_body_from_ecef` is CONVENTIONS.md's
ECEF->body matrix. An increment eps_body (3,) rad rotates the body axes by |eps| about eps (body components):
R_new = A(eps)^T R_old with A(eps) = exp([eps x]) (Rodrigues).
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.rotations import skew

__all__ = ["rotation_matrix", "rotvec_of", "perturb_body", "error_rotvec_body", "D_eq26", "LARGE_ANGLE_RAD"]

#: rotation vectors longer than this are wrapped (2 pi - |eps|) by rotvec_of
LARGE_ANGLE_RAD = np.pi


def rotation_matrix(rotvec_rad: np.ndarray) -> np.ndarray:
    """A = exp([w x]) (..., 3, 3), the active rotation by |w| about w (Rodrigues' formula)."""
    w = np.asarray(rotvec_rad, dtype=np.float64)
    angle = np.linalg.norm(w, axis=-1)[..., None, None]
    K = skew(w)
    small = angle < 1e-8
    a = np.where(small, 1.0, angle)
    s = np.where(small, 1.0 - angle ** 2 / 6.0, np.sin(a) / a)
    c = np.where(small, 0.5 - angle ** 2 / 24.0, (1.0 - np.cos(a)) / a ** 2)
    return np.eye(3) + s * K + c * (K @ K)


def rotvec_of(A: np.ndarray) -> np.ndarray:
    """Rotation vector (..., 3) of a rotation matrix A = exp([w x]), |w| in [0, pi]."""
    A = np.asarray(A, dtype=np.float64)
    cos_a = np.clip((np.trace(A, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos_a)
    vee = np.stack([A[..., 2, 1] - A[..., 1, 2], A[..., 0, 2] - A[..., 2, 0], A[..., 1, 0] - A[..., 0, 1]], -1)
    s = np.sin(angle)
    scale = np.where(s > 1e-9, angle / (2.0 * np.where(s > 1e-9, s, 1.0)), 0.5)
    return vee * scale[..., None]


def perturb_body(R_body_from_ecef: np.ndarray, eps_body_rad: np.ndarray) -> np.ndarray:
    """R_body_from_ecef of the body rotated by eps (body axes): A(eps)^T R."""
    return np.swapaxes(rotation_matrix(eps_body_rad), -1, -2) @ R_body_from_ecef


def error_rotvec_body(R_est_body_from_ecef: np.ndarray, R_true_body_from_ecef: np.ndarray) -> np.ndarray:
    """eps (..., 3) with R_est = perturb_body(R_true, eps): the estimate's error as a body rotation vector, rad."""
    return rotvec_of(np.swapaxes(R_est_body_from_ecef @ np.swapaxes(R_true_body_from_ecef, -1, -2), -1, -2))


def D_eq26(alpha_rad, beta_rad, gamma_rad) -> np.ndarray:
    """The receiver attitude matrix D_ik = a_i . e_k of seed 003 eq. 26 (z-y-z Euler angles alpha, beta, gamma),
    (..., 3, 3): rows are the body axes a_i in the inertial (here: ECEF) basis, i.e. R_body_from_ecef."""
    ca, sa, cb, sb, cg, sg = (np.cos(alpha_rad), np.sin(alpha_rad), np.cos(beta_rad), np.sin(beta_rad),
                              np.cos(gamma_rad), np.sin(gamma_rad))
    return np.stack([
        np.stack([cb * ca * cg - sa * sg, cb * sa * cg + ca * sg, -sb * cg], -1),
        np.stack([-cb * ca * sg - sa * cg, -cb * sa * sg + ca * cg, sb * sg], -1),
        np.stack([sb * ca, sb * sa, cb], -1)], -2)
