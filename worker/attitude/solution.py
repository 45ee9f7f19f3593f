"""Attitude from estimated baselines, Euler angles, and formal sigmas propagated from the baseline covariance.

Conventions (../shared/CONVENTIONS.md): q_body_from_ecef is passive (v_body = R(q) v_ecef), scalar first, w >= 0;
Euler 3-2-1 R_body_from_ref = Rx(roll) Ry(pitch) Rz(yaw) relative to the orbital frame (spacecraft) or NED
(terrestrial); small attitude errors are body-frame rotations R_est = (I - [dtheta x]) R_true.

Implements: QUEST/q-method with weights by baseline length (seed 000 sec. 2) via worker.gnss.rotations.quest, or
TRIAD (Shuster & Oh 1981); first-order covariance of the Wahba solution
    dtheta = -M^-1 sum_i w_i [b_i x]^T R (I - r_i r_i^T) e_i / |r_i|,  M = sum_i w_i (I - b_i b_i^T)
with e_i the ECEF baseline errors of joint covariance C (cross-covariances between baselines kept);
Euler-angle covariance B^-1 P B^-T with dtheta = B d(yaw, pitch, roll),
B = [[-sin p, 0, 1], [sin r cos p, cos r, 0], [cos r cos p, -sin r, 0]].
"""
from __future__ import annotations

import numpy as np

from worker.gnss import rotations as rot

__all__ = ["attitude_from_baselines", "attitude_quaternion", "euler_and_sigma", "baseline_az_el", "skew"]


def skew(v: np.ndarray) -> np.ndarray:
    """[v x] (..., 3, 3) of vectors (..., 3)."""
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1), np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def attitude_from_baselines(b_ecef_m: np.ndarray, P_b_m2: np.ndarray, b_body_m: np.ndarray,
                            method: str = "quest") -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_ecef (n, 4), P_theta_rad2 (n, 3, 3)) from n epochs of n_bl >= 2 ECEF baselines.

    Args:
        b_ecef_m: (n, n_bl, 3) estimated baselines; P_b_m2: (n, 3 n_bl, 3 n_bl) their joint covariance.
        b_body_m: (n_bl, 3) the same baselines in the body frame.
        method: "quest" (weights proportional to length, seed 000) or "triad" (first baseline exact).
    Rows with NaN give NaN.
    """
    n, n_bl, _ = b_ecef_m.shape
    L = np.linalg.norm(b_body_m, axis=1)
    q, w = attitude_quaternion(b_ecef_m, b_body_m, method)
    R = rot.quat_to_dcm(q)                                                      # (n, 3, 3) body <- ecef
    bh = b_body_m / L[:, None]                                                  # (n_bl, 3)
    M = np.einsum("i,ijk->jk", w, np.eye(3)[None] - np.einsum("ij,ik->ijk", bh, bh))
    Minv = np.linalg.inv(M)
    rlen = np.linalg.norm(b_ecef_m, axis=-1)                                    # (n, n_bl)
    rh = b_ecef_m / rlen[..., None]
    G = np.zeros((n, 3, 3 * n_bl))
    for i in range(n_bl):
        proj = np.eye(3)[None] - np.einsum("ni,nj->nij", rh[:, i], rh[:, i])
        Gi = -w[i] * Minv @ skew(bh[i]).T @ R @ proj / rlen[:, i, None, None]
        G[:, :, 3 * i:3 * i + 3] = Gi
    P = G @ P_b_m2 @ np.swapaxes(G, -1, -2)
    return q, 0.5 * (P + np.swapaxes(P, -1, -2))


def attitude_quaternion(b_ecef_m: np.ndarray, b_body_m: np.ndarray, method: str = "quest"):
    """(q_body_from_ecef (n, 4), weights (n_bl,)) of n epochs of baselines b_ecef_m (n, n_bl, 3) with the known
    body baselines (n_bl, 3): the attitude part of `attitude_from_baselines` without its covariance (the filter's
    antenna-frame mask needs only the attitude). QUEST with weights by length (seed 000 sec. 2) or TRIAD."""
    n, n_bl, _ = b_ecef_m.shape
    L = np.linalg.norm(b_body_m, axis=1)
    if method == "triad":
        q = rot.triad(b_body_m[0], b_body_m[1], b_ecef_m[:, 0], b_ecef_m[:, 1])
        w = np.array([1e6] + [1.0] * (n_bl - 1))          # TRIAD = the limit of a dominant first weight
    else:
        w = L / L.sum()
        q, _ = rot.quest(np.broadcast_to(b_body_m, b_ecef_m.shape), b_ecef_m, np.broadcast_to(w, (n, n_bl)))
    return q, w


def euler_and_sigma(R_body_from_ref: np.ndarray, P_theta_rad2: np.ndarray):
    """(yaw, pitch, roll (n,) deg, sigma_yaw, sigma_pitch, sigma_roll (n,) deg) of attitudes R (n, 3, 3)."""
    yaw, pitch, roll = rot.dcm_to_euler321(R_body_from_ref)
    p, r = np.radians(pitch), np.radians(roll)
    B = np.zeros(R_body_from_ref.shape)
    B[:, 0, 0] = -np.sin(p)
    B[:, 0, 2] = 1.0
    B[:, 1, 0] = np.sin(r) * np.cos(p)
    B[:, 1, 1] = np.cos(r)
    B[:, 2, 0] = np.cos(r) * np.cos(p)
    B[:, 2, 1] = -np.sin(r)
    with np.errstate(all="ignore"):
        Binv = np.linalg.inv(np.where(np.isfinite(B), B, 0.0) + np.where(np.abs(np.cos(p))[:, None, None] < 1e-9,
                                                                         np.eye(3) * 1e-9, 0.0))
        Pe = Binv @ P_theta_rad2 @ np.swapaxes(Binv, -1, -2)
        sig = np.degrees(np.sqrt(np.maximum(np.diagonal(Pe, axis1=-2, axis2=-1), 0.0)))
    return yaw, pitch, roll, sig[:, 0], sig[:, 1], sig[:, 2]


def baseline_az_el(b_ecef_m: np.ndarray, P_m2: np.ndarray, R_enu_from_ecef: np.ndarray):
    """(length_m, azimuth_deg [0, 360), elevation_deg, sigma_length_m, sigma_az_deg, sigma_el_deg) of baselines.

    Args: b_ecef_m (n, 3), P_m2 (n, 3, 3), R_enu_from_ecef (n, 3, 3) at the first antenna.
    Implements: CONVENTIONS.md baselines.csv (azimuth clockwise from north, elevation up positive), first-order
    propagation with J = d(az, el, L)/d(e, n, u).
    """
    enu = np.einsum("nij,nj->ni", R_enu_from_ecef, b_ecef_m)
    Pl = R_enu_from_ecef @ P_m2 @ np.swapaxes(R_enu_from_ecef, -1, -2)
    e, nn, u = enu[:, 0], enu[:, 1], enu[:, 2]
    h2 = e * e + nn * nn
    h = np.sqrt(h2)
    L2 = h2 + u * u
    L = np.sqrt(L2)
    az = np.mod(np.degrees(np.arctan2(e, nn)), 360.0)
    el = np.degrees(np.arctan2(u, h))
    J = np.zeros((b_ecef_m.shape[0], 3, 3))
    with np.errstate(all="ignore"):
        J[:, 0, 0] = nn / h2
        J[:, 0, 1] = -e / h2
        J[:, 1, 0] = -u * e / (h * L2)
        J[:, 1, 1] = -u * nn / (h * L2)
        J[:, 1, 2] = h / L2
        J[:, 2] = enu / L[:, None]
    C = J @ Pl @ np.swapaxes(J, -1, -2)
    sd = np.sqrt(np.maximum(np.diagonal(C, axis1=-2, axis2=-1), 0.0))
    return L, az, el, sd[:, 2], np.degrees(sd[:, 0]), np.degrees(sd[:, 1])
