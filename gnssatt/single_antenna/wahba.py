"""Wahba's problem by the SVD, with Markley's covariance, degeneracy flags and the q-method as a check.

Loss L(R) = 1/2 sum_i a_i |b_i - R r_i|^2 over unit vectors b_i (body) and r_i (reference), weights
a_i = 1 / sigma_i^2 (sigma_i the isotropic angular noise of b_i, rad). With the attitude profile matrix
B = sum_i a_i b_i r_i^T = U S V^T, the optimum is R = U diag(1, 1, d) V^T, d = det(U) det(V), and the
covariance of the small body-frame rotation error dtheta (R_est = (I - [dtheta x]) R_true) is
P = U diag(1/(s2 + s3'), 1/(s3' + s1), 1/(s1 + s2)) U^T with s3' = d s3.

Implements: Wahba (1965) SIAM Rev. 7(3) 409; Markley (1988) J. Astronaut. Sci. 36(3) 245-258 ("Attitude
determination using vector observations and the singular value decomposition", eqs. 8-11 and the covariance
eq. 23); the q-method check is gnssatt.gnss.rotations.quest (Davenport, Shuster & Oh 1981).
Neglects: non-isotropic vector noise (each vector has one angular sigma).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssatt.gnss.rotations import attitude_error_deg, dcm_to_quat, quest

#: flag bits of a Wahba solution (per epoch)
FLAG_OK = 0
FLAG_TOO_FEW = 1          # fewer than two finite vectors of positive weight: no attitude (NaN)
FLAG_NEAR_PARALLEL = 2    # the vectors span less than `min_angle_deg` (body or reference): no attitude (NaN)
FLAG_QMETHOD_MISMATCH = 4  # SVD and q-method disagree by more than `check_tol_deg` (solution kept)

#: q-method vs SVD tolerance: both are exact optimisers; 1e-6 deg is far above float64 round-off for any
#: well-conditioned problem and far below any sensor's noise
CHECK_TOL_DEG = 1e-6


class WahbaSolution(NamedTuple):
    """Per epoch (...): R_body_from_ref (..., 3, 3), q_body_from_ref (..., 4, w >= 0), cov_body_rad2
    (..., 3, 3) (Markley), loss (...), min_angle_deg (...) (smallest angle spanned by the vectors, 0-90 deg),
    qmethod_diff_deg (...) (rotation angle SVD vs q-method), flags (...) (FLAG_* bits)."""

    R_body_from_ref: np.ndarray
    q_body_from_ref: np.ndarray
    cov_body_rad2: np.ndarray
    loss: np.ndarray
    min_angle_deg: np.ndarray
    qmethod_diff_deg: np.ndarray
    flags: np.ndarray


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def spanned_angle_deg(v: np.ndarray, use: np.ndarray) -> np.ndarray:
    """Smallest angle (deg, 0-90) between the used unit vectors v (..., n, 3) and the line of the dominant one.

    The second singular value of the stacked used unit vectors over the first is the sine of the spread
    about their principal axis (for two vectors exactly |sin| of the angle between them, folded to 0-90 deg).
    """
    m = np.where(use[..., None], v, 0.0)
    s = np.linalg.svd(np.swapaxes(m, -1, -2) @ m, compute_uv=False)   # eigenvalues of sum v v^T
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(np.clip(s[..., 1] / s[..., 0], 0.0, 1.0))
    # two vectors at angle t: eigenvalues 1 +- cos t, ratio^2 = (1 - |cos t|)/(1 + |cos t|) = tan^2(t/2)
    return np.degrees(2.0 * np.arctan(ratio))


def wahba_svd(v_body, v_ref, weights=None, *, min_angle_deg: float = 5.0,
              check_tol_deg: float = CHECK_TOL_DEG) -> WahbaSolution:
    """Optimal R_body_from_ref of Wahba's problem by the SVD, Markley's covariance and flags.

    Args:
        v_body: (..., n, 3) observed vectors in the body frame (normalised here).
        v_ref: (..., n, 3) the same vectors in the reference frame.
        weights: (..., n) a_i = 1 / sigma_i^2 (rad^-2) for a covariance in rad^2; None = all 1.
            A vector with weight 0 or any NaN is not used.
        min_angle_deg: below this angle between the vectors (in the body or the reference frame) the
            rotation about their common direction is not observable: FLAG_NEAR_PARALLEL and NaN.
        check_tol_deg: the q-method's answer must agree within this (FLAG_QMETHOD_MISMATCH otherwise).
    Implements: Markley (1988) eqs. 8-11 and 23.
    """
    b = _unit(np.asarray(v_body, dtype=np.float64))
    r = _unit(np.asarray(v_ref, dtype=np.float64))
    b, r = np.broadcast_arrays(b, r)
    a = np.ones(b.shape[:-1]) if weights is None else np.broadcast_to(np.asarray(weights, float), b.shape[:-1])
    use = np.isfinite(b).all(-1) & np.isfinite(r).all(-1) & np.isfinite(a) & (a > 0)
    a0 = np.where(use, a, 0.0)
    b0 = np.where(use[..., None], b, 0.0)
    r0 = np.where(use[..., None], r, 0.0)
    B = np.einsum("...n,...ni,...nj->...ij", a0, b0, r0)          # attitude profile matrix
    U, s, Vt = np.linalg.svd(B)
    d = np.linalg.det(U) * np.linalg.det(Vt)
    D = np.zeros(B.shape)
    D[..., 0, 0] = 1.0
    D[..., 1, 1] = 1.0
    D[..., 2, 2] = d
    R = U @ D @ Vt                                                   # R = U diag(1, 1, d) V^T
    s1, s2, s3 = s[..., 0], s[..., 1], d * s[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.stack([1.0 / (s2 + s3), 1.0 / (s3 + s1), 1.0 / (s1 + s2)], axis=-1)
    P = np.einsum("...ik,...k,...jk->...ij", U, lam, U)              # Markley eq. 23
    lam0 = a0.sum(-1)
    loss = lam0 - (s1 + s2 + s3)                                     # 2 L = lambda_0 - tr(S') (Markley eq. 12)
    angle = np.minimum(spanned_angle_deg(b, use), spanned_angle_deg(r, use))
    flags = np.where(use.sum(-1) < 2, FLAG_TOO_FEW, FLAG_OK)
    flags = flags | np.where((flags == 0) & ~(angle >= min_angle_deg), FLAG_NEAR_PARALLEL, 0)
    bad = flags != 0
    R = np.where(bad[..., None, None], np.nan, R)
    P = np.where(bad[..., None, None], np.nan, P)
    q = np.where(bad[..., None], np.nan, dcm_to_quat(np.where(bad[..., None, None], np.eye(3), R)))
    q_check, _ = quest(b, r, np.where(use, a0, 0.0))
    diff = attitude_error_deg(q, q_check)
    flags = flags | np.where(~bad & ~(diff <= check_tol_deg), FLAG_QMETHOD_MISMATCH, 0)
    return WahbaSolution(R, q, P, np.where(bad, np.nan, loss), angle, diff, flags.astype(np.int64))


def euler_sigma_of_cov_deg(cov_body_rad2: np.ndarray) -> np.ndarray:
    """(..., 3) 1-sigma (deg) of the small body-frame rotation about body x, y, z (sqrt of the diagonal)."""
    return np.degrees(np.sqrt(np.diagonal(cov_body_rad2, axis1=-2, axis2=-1)))
