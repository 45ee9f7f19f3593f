"""Attitude from estimated baselines, Euler angles, and formal sigmas propagated from the baseline covariance.

Conventions (../shared/CONVENTIONS.md): q_body_from_ecef is passive (v_body = R(q) v_ecef), scalar first, w >= 0;
Euler 3-2-1 R_body_from_ref = Rx(roll) Ry(pitch) Rz(yaw) relative to the orbital frame (spacecraft) or NED
(terrestrial); small attitude errors are body-frame rotations R_est = (I - [dtheta x]) R_true.

Implements: QUEST/q-method with weights by baseline length (seed 000 sec. 2) via gnssatt.gnss.rotations.quest, or
TRIAD (Shuster & Oh 1981), or the maximum-likelihood attitude with the baselines' full joint covariance
(method "ml", `attitude_ml`); first-order covariance of the Wahba solution
    dtheta = -M^-1 sum_i w_i [b_i x]^T R (I - r_i r_i^T) e_i / |r_i|,  M = sum_i w_i (I - b_i b_i^T)
with e_i the ECEF baseline errors of joint covariance C (cross-covariances between baselines kept);
Euler-angle covariance B^-1 P B^-T with dtheta = B d(yaw, pitch, roll),
B = [[-sin p, 0, 1], [sin r cos p, cos r, 0], [cos r cos p, -sin r, 0]].
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss import rotations as rot
from gnssatt.gnss.rotations import skew

__all__ = ["attitude_from_baselines", "attitude_ml", "attitude_quaternion", "euler_and_sigma", "baseline_az_el"]

ML_ITERATIONS = 3       # Gauss-Newton steps from the QUEST start (the second already changes < 1e-9 rad)
ML_BODY_SIGMA_M = 1e-3  # uncertainty of each body-frame baseline component (a priori / calibrated), added to the
                        # covariance: without it the dynamic filter's baselines, whose shape it knows to ~0.1 mm,
                        # are fitted to the body geometry in the directions where the two disagree (tested)


def attitude_from_baselines(b_ecef_m: np.ndarray, P_b_m2: np.ndarray, b_body_m: np.ndarray,
                            method: str = "quest", body_sigma_m: float = ML_BODY_SIGMA_M
                            ) -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_ecef (n, 4), P_theta_rad2 (n, 3, 3)) from n epochs of n_bl >= 2 ECEF baselines.

    Args:
        b_ecef_m: (n, n_bl, 3) estimated baselines; P_b_m2: (n, 3 n_bl, 3 n_bl) their joint covariance.
        b_body_m: (n_bl, 3) the same baselines in the body frame.
        method: "quest" (weights proportional to length, seed 000), "triad" (first baseline exact) or "ml"
            (maximum likelihood with the full joint covariance, `attitude_ml`, started from QUEST).
        body_sigma_m: "ml" only: the body baselines' own uncertainty per component (see attitude_ml).
    Rows with NaN give NaN.
    """
    if method == "ml":
        q0, _ = attitude_quaternion(b_ecef_m, b_body_m, "quest")
        return attitude_ml(b_ecef_m, P_b_m2, b_body_m, q0, body_sigma_m=body_sigma_m)
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
    antenna-frame mask needs only the attitude). QUEST with weights by length (seed 000 sec. 2) or TRIAD; "ml"
    needs the covariance and gives QUEST here."""
    n, n_bl, _ = b_ecef_m.shape
    L = np.linalg.norm(b_body_m, axis=1)
    if method == "triad":
        q = rot.triad(b_body_m[0], b_body_m[1], b_ecef_m[:, 0], b_ecef_m[:, 1])
        w = np.array([1e6] + [1.0] * (n_bl - 1))          # TRIAD = the limit of a dominant first weight
    else:
        w = L / L.sum()
        q, _ = rot.quest(np.broadcast_to(b_body_m, b_ecef_m.shape), b_ecef_m, np.broadcast_to(w, (n, n_bl)))
    return q, w


def attitude_ml(b_ecef_m: np.ndarray, P_b_m2: np.ndarray, b_body_m: np.ndarray, q0_body_from_ecef: np.ndarray,
                iterations: int = ML_ITERATIONS, body_sigma_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_ecef (n, 4), P_theta_rad2 (n, 3, 3)): maximum-likelihood attitude from n epochs of baselines.

    Minimises e^T C^-1 e over the rotation, e = stacked (b_ecef_j - R^T b_body_j), C = P_b_m2 the baselines' joint
    covariance (cross-covariances kept) + body_sigma_m^2 I (the body baselines' own uncertainty, isotropic so
    frame-free): the weighted orthogonal Procrustes problem, solved by Gauss-Newton on SO(3)
    from q0 with the body-frame small rotation R = (I - [dtheta x]) R0 (CONVENTIONS.md), Jacobian
    d e_j / d dtheta = R0^T [b_body_j x]; the covariance is the inverse Fisher information (J^T C^-1 J)^-1.
    With isotropic per-baseline covariances sigma_j^2 I it is Wahba's problem with weights |b_j| |B_j| / sigma_j^2
    (tested against rotations.quest). Unlike QUEST's scalar weights it uses that a baseline's direction is known
    better across the line of sight geometry than along it (e.g. horizontal vs vertical for zenith antennas).
    Implements: maximum-likelihood attitude from vector observations with a full covariance (Crassidis & Junkins,
    Optimal Estimation of Dynamic Systems, ch. 5, the nonlinear least-squares attitude solution).
    Args:
        b_ecef_m: (n, n_bl, 3); P_b_m2: (n, 3 n_bl, 3 n_bl); b_body_m: (n_bl, 3); q0_body_from_ecef: (n, 4).
    Rows with a NaN or a singular covariance give NaN.
    """
    n, n_bl, _ = b_ecef_m.shape
    b = b_ecef_m.reshape(n, 3 * n_bl)
    ok = np.isfinite(b).all(-1) & np.isfinite(P_b_m2).all((-2, -1)) & np.isfinite(q0_body_from_ecef).all(-1)
    C = np.where(ok[:, None, None], P_b_m2 + np.eye(3 * n_bl) * body_sigma_m ** 2, np.eye(3 * n_bl))
    try:
        L = np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        d = np.linalg.eigvalsh(C)[:, 0] > 0
        ok &= d
        L = np.linalg.cholesky(np.where(d[:, None, None], C, np.eye(3 * n_bl)))
    Linv = np.linalg.inv(L)                                             # C^-1 = Linv^T Linv (whitening)
    q = np.where(ok[:, None], q0_body_from_ecef, np.array([1.0, 0.0, 0.0, 0.0]))
    Bx = skew(b_body_m)                                                 # (n_bl, 3, 3)
    for _ in range(max(int(iterations), 1)):
        R = rot.quat_to_dcm(q)
        Rt = np.swapaxes(R, -1, -2)
        e = b - np.einsum("nji,bj->nbi", R, b_body_m).reshape(n, 3 * n_bl)      # b_ecef - R^T b_body
        J = np.einsum("nij,bjk->nbik", Rt, Bx).reshape(n, 3 * n_bl, 3)        # d e / d dtheta = R^T [B x]
        Jw = Linv @ J
        ew = np.einsum("nij,nj->ni", Linv, e)
        F = np.swapaxes(Jw, -1, -2) @ Jw                                        # Fisher information (3, 3)
        dth = -np.linalg.solve(F, np.einsum("nji,nj->ni", Jw, ew)[..., None])[..., 0]
        # R = (I - [dth x]) R0 to first order: R(q(dth)) = I - [dth x] + ... (passive), so q = q(dth) (x) q0
        q = rot.quat_multiply(rot.quat_from_rotvec(dth), q)
    P = np.linalg.inv(F)
    q = np.where(ok[:, None], q, np.nan)
    P = np.where(ok[:, None, None], 0.5 * (P + np.swapaxes(P, -1, -2)), np.nan)
    return q, P


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
