"""Baseline DOPs and the yaw / pitch / roll sigmas they imply (seed 000 sec. 4.1, eq. 3-4, Table 4).

A baseline estimated from single-difference carrier phases with a common receiver clock term has the
design rows g_i = [-e_i^T, 1] (e_i the unit line of sight), Q = (G^T W G)^-1 sigma_Phi^2. In a frame with
z vertical (orbital frame: z nadir; NED: z down) HDOP = sqrt(Q_xx + Q_yy) and VDOP = sqrt(Q_zz) (unit
sigma). Eq. 3: sigma_H = HDOP sigma_Phi, sigma_V = VDOP sigma_Phi; eq. 4: sigma_y = arcsin(sigma_H / b),
sigma_p,r = arcsin(sigma_V / b) for a horizontal baseline of length b (along x: pitch; along y: roll).
`snapshot_euler_sigma_deg` goes further: the Fisher information of the small rotation from all baselines'
full 3x3 covariances, which is how both baselines together determine yaw (seed 000: "both baselines
contribute to this parameter through the QUEST algorithm").

Implements: seed 000 eq. 3-4 and Table 4; the DOP definition of Misra & Enge (2006) sec. 6.1.
Neglects: time correlation (a filter averages epochs; these are per-epoch, snapshot sigmas), carrier-phase
multipath and PCV, elevation weighting (seed 000 uses none), the ambiguities (assumed fixed).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class BaselineDop(NamedTuple):
    """(...,) arrays: hdop, vdop, pdop and q_frame (..., 3, 3) the unit-sigma position covariance."""

    hdop: np.ndarray
    vdop: np.ndarray
    pdop: np.ndarray
    q_frame: np.ndarray


def baseline_dop(los_frame, use=None) -> BaselineDop:
    """DOPs of a single-difference baseline from unit lines of sight los_frame (..., n, 3) in a frame whose
    z axis is vertical (orbital frame or NED). NaN where fewer than 4 usable lines of sight."""
    e = np.asarray(los_frame, dtype=np.float64)
    use = np.isfinite(e).all(-1) if use is None else (np.asarray(use, bool) & np.isfinite(e).all(-1))
    G = np.concatenate([-np.where(use[..., None], e, 0.0), use[..., None].astype(float)], axis=-1)
    N = np.einsum("...ni,...nj->...ij", G, G)
    ok = (use.sum(-1) >= 4) & (np.linalg.cond(N) < 1e10)
    Q = np.linalg.inv(np.where(ok[..., None, None], N, np.eye(4)))[..., :3, :3]
    Q = np.where(ok[..., None, None], Q, np.nan)
    h = np.sqrt(Q[..., 0, 0] + Q[..., 1, 1])
    v = np.sqrt(Q[..., 2, 2])
    return BaselineDop(h, v, np.sqrt(np.trace(Q, axis1=-2, axis2=-1)), Q)


class Table4Row(NamedTuple):
    """Per baseline: sigma_h_m, sigma_v_m (eq. 3) and sigma_yaw_deg, sigma_tilt_deg (eq. 4: the pitch for
    a baseline along body x, the roll for one along body y)."""

    sigma_h_m: np.ndarray
    sigma_v_m: np.ndarray
    sigma_yaw_deg: np.ndarray
    sigma_tilt_deg: np.ndarray


def euler_sigma_from_dops(hdop, vdop, sigma_phase_m, baseline_m) -> Table4Row:
    """Seed 000 eq. 3-4: sigma_H = HDOP sigma_Phi, sigma_V = VDOP sigma_Phi; sigma_y = arcsin(sigma_H / b),
    sigma_p,r = arcsin(sigma_V / b)."""
    sh = np.asarray(hdop) * sigma_phase_m
    sv = np.asarray(vdop) * sigma_phase_m
    b = np.asarray(baseline_m, dtype=np.float64)
    return Table4Row(sh, sv, np.degrees(np.arcsin(sh / b)), np.degrees(np.arcsin(sv / b)))


def snapshot_covariance_rad2(baselines_body_m, q_frame, sigma_phase_m) -> np.ndarray:
    """(..., 3, 3) covariance (rad^2) of the small rotation dtheta (about the frame's x, y, z) from all
    baselines at once, as a least-squares snapshot, the baselines given in that frame.

    Each baseline k measured with covariance C = sigma_Phi^2 Q: b_meas = b + dtheta x b, so the design block
    is -[b x] and the information J = sum_k [b_k x]^T C^-1 [b_k x]. baselines_body_m: (k, 3); q_frame:
    (..., 3, 3) unit-sigma covariance of one baseline (the same for all baselines of one epoch: they see the
    same satellites). NaN where J is singular (one baseline: the rotation about it is unobservable).
    """
    bl = np.asarray(baselines_body_m, dtype=np.float64)
    Q = np.asarray(q_frame, dtype=np.float64) * sigma_phase_m ** 2
    ok = np.isfinite(Q).all((-1, -2))
    Ci = np.linalg.inv(np.where(ok[..., None, None], Q, np.eye(3)))
    J = np.zeros(Q.shape)
    for b in bl:
        X = np.array([[0.0, -b[2], b[1]], [b[2], 0.0, -b[0]], [-b[1], b[0], 0.0]])
        J = J + X.T @ Ci @ X
    good = ok & (np.linalg.cond(J) < 1e12)
    P = np.linalg.inv(np.where(good[..., None, None], J, np.eye(3)))
    return np.where(good[..., None, None], P, np.nan)


def snapshot_euler_sigma_deg(baselines_body_m, q_frame, sigma_phase_m) -> np.ndarray:
    """(..., 3) 1-sigma (deg) about x (roll), y (pitch), z (yaw) of `snapshot_covariance_rad2`, body near
    the frame (small Euler angles)."""
    P = snapshot_covariance_rad2(baselines_body_m, q_frame, sigma_phase_m)
    return np.degrees(np.sqrt(np.diagonal(P, axis1=-2, axis2=-1)))
