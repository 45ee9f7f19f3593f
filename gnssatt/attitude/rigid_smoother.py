"""The backward (RTS) step of the smoother for rigid baselines (settings.baseline_update "rigid"): the recursion of
gnssatt.attitude.smoother in the tangent space of each baseline, with the forward update's retraction.

The forward filter with the rigid update (gnssatt.attitude.rigid_update) keeps each baseline where a rotation and a
length change put it, and its covariance in the frame of the current direction. The linear RTS step
x_k|N = x_k|k + C_k (x_k+1|N - x_k+1|k) does not: the difference of two baselines of the same length is a chord,
whose part along b is -|d_t|^2 / (2 |b|); C_k shrinks the across-b part where the angular-velocity noise lets the
direction move but passes the along-b part (no process noise on a length) unchanged, so each step shortens the
smoothed baseline by (1 - c^2) |d_t|^2 / (2 |b|) and the deficit is carried back through every earlier epoch
(measured: -13.2 mm in the 5-minute means of the realistic 106-min pass, docs/attitude.md). Here, per baseline:

    d_k+1 = b_k+1|N [-] b_k+1|k        tangent coordinates at b_k+1|k: (|b_s| - |b_p|) r_p + |b_p| theta t_p
                                       (theta the angle from r_p to r_s, t_p the unit vector across r_p towards r_s)
    delta = C_k d_k+1                  (omega [, alpha] linear as before)
    b_k|N = b_k|k [+] delta            length |b_k|k| + r . delta, direction turned by |delta across r| / |b_k|k|

([+] and [-] are inverses: b [+] (c [-] b) = c.) As in the forward update (gnssatt.attitude.rigid_update), the
baselines of one body are moved together: [+] applies the common rotation phi of delta (least squares over the
baselines) exactly, exp(phi), after each baseline's remainder delta_j - phi x b_j by the per-baseline [+] above, and
[-] is its inverse (phi by a fixed-point iteration); per baseline on its own the common rotation is a second-order
shear of the body that the recursion carries back through every earlier epoch (measured on the clean 106-min pass:
the angle between the two baselines +0.12 deg at the start of the run, -0.09 at its end, and a smoothed yaw mean of
+0.03 deg over the first 20 minutes; with the body rotation the angle is one number, -0.003 deg).
The covariances are those of the errors at the forward estimates;
P_k+1|N, at b_k+1|N, is turned to b_k+1|k's direction before the step and P_k|N from b_k|k's to b_k|N's after it,
as the forward filter turns P with the estimate (gnssatt.attitude.rigid_update).

Implements: the RTS smoother on a manifold (Rauch, Tung & Striebel 1965 with the box-plus / box-minus operators of
Hertzberg, Wagner, Frese & Schroeder 2013, "Integrating generic sensor fusion algorithms with sound state
representations through encapsulation of manifolds", Inf. Fusion 14(1), sec. 3-4), here on R^3 x SO(3)-moved (S^2 x R+)^n,
consistent with the forward filter's multiplicative reset (Markley 2003; Sola 2017 sec. 7.2).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.rigid_kernels import rts_rigid_kernel
from gnssatt.attitude.rigid_update import common_rotation, rotation_between, rotation_exp
from gnssatt.attitude.rts_links import rts_links

__all__ = ["boxminus", "boxplus", "boxminus_body", "boxplus_body", "rts_smooth_rigid", "rts_smooth_rigid_reference",
           "rts_gains"]

#: epochs per batched solve of the gains (bounds the temporaries: 4096 x m x m floats, m <= 3 + 3 + 3 n_bl)
GAIN_CHUNK = 4096


def boxminus(b1_m: np.ndarray, b0_m: np.ndarray) -> np.ndarray:
    """(n, 3) tangent coordinates of b1_m (n, 3) at b0_m (n, 3), m: the length difference along b0 and |b0| x the
    angle from b0 to b1 along the great circle, across b0 towards b1 (module doc)."""
    n0 = np.linalg.norm(b0_m, axis=-1, keepdims=True)
    n1 = np.linalg.norm(b1_m, axis=-1, keepdims=True)
    u0, u1 = b0_m / n0, b1_m / n1
    c = np.sum(u0 * u1, axis=-1, keepdims=True)
    t = u1 - c * u0
    s = np.linalg.norm(t, axis=-1, keepdims=True)
    ang = np.arctan2(s, c)
    tang = np.where(s > 0, t / np.where(s > 0, s, 1.0), 0.0) * ang * n0
    return (n1 - n0) * u0 + tang


def boxplus(b0_m: np.ndarray, d_m: np.ndarray) -> np.ndarray:
    """(n, 3) baselines b0_m (n, 3) moved by the tangent coordinates d_m (n, 3), m: length |b0| + d . r0, direction
    turned from r0 by |d across r0| / |b0| towards d (the inverse of boxminus)."""
    n0 = np.linalg.norm(b0_m, axis=-1, keepdims=True)
    u0 = b0_m / n0
    dr = np.sum(u0 * d_m, axis=-1, keepdims=True)
    dt = d_m - dr * u0
    s = np.linalg.norm(dt, axis=-1, keepdims=True)
    ang = s / n0
    e = np.where(s > 0, dt / np.where(s > 0, s, 1.0), 0.0)
    return (n0 + dr) * (np.cos(ang) * u0 + np.sin(ang) * e)


def boxplus_body(b0_m: np.ndarray, d_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((n, 3) baselines, (3, 3) R): the baselines b0_m (n, 3) of one body moved by d_m (n, 3), m: the common rotation
    of d (gnssatt.attitude.rigid_update.common_rotation) applied exactly, R = exp(phi), after each baseline's
    remainder d_j - phi x b0_j by boxplus (module doc)."""
    phi = common_rotation(b0_m, d_m)
    R = rotation_exp(phi)
    return boxplus(b0_m, d_m - np.cross(phi, b0_m)) @ R.T, R


def boxminus_body(b1_m: np.ndarray, b0_m: np.ndarray, iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """((n, 3) d, (3, 3) R): the inverse of boxplus_body, boxplus_body(b0_m, d) = (b1_m, R): phi such that the
    remainder e = boxminus(R(phi)^T b1, b0) has no common rotation (fixed-point iteration, converging as |phi|),
    d = phi x b0 + e."""
    phi = np.zeros(3)
    for _ in range(iterations):
        R = rotation_exp(phi)
        e = boxminus(b1_m @ R, b0_m)
        psi = common_rotation(b0_m, e)
        phi = phi + psi
        if float(psi @ psi) < 1e-30:
            break
    R = rotation_exp(phi)
    e = boxminus(b1_m @ R, b0_m)
    return np.cross(phi, b0_m) + e, R


def _turn(P: np.ndarray, b_from_m: np.ndarray, b_to_m: np.ndarray, r0: int, R: np.ndarray) -> np.ndarray:
    """P (m, m) with each baseline's rows and columns (3 from r0 on per baseline) turned with the body: by R (the
    body rotation from b_from_m (n_bl, 3) to b_to_m (n_bl, 3)), then by the rotation that takes R's image of each
    direction of b_from_m to that of b_to_m."""
    T = np.eye(P.shape[0])
    for j in range(b_from_m.shape[0]):
        u0 = R @ b_from_m[j] / np.linalg.norm(b_from_m[j])
        u1 = b_to_m[j] / np.linalg.norm(b_to_m[j])
        if u0 @ u1 > -0.5:
            T[r0 + 3 * j:r0 + 3 * j + 3, r0 + 3 * j:r0 + 3 * j + 3] = rotation_between(u0, u1) @ R
    return T @ P @ T.T


def rts_gains(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray, Phi: np.ndarray,
              start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(linked (n,) bool, C (n, m, m)): the links and gains of gnssatt.attitude.rts_links (k links to k+1 unless
    start[k+1], non-finite inputs at k or k+1, or a singular P_k+1|k; C_k = P_k|k Phi_k+1^T P_k+1|k^-1, 0 where
    not linked), solved in batches (they need only the forward filter's records)."""
    n = x_post.shape[0]
    fin_post = np.isfinite(x_post).all(1) & np.isfinite(P_post).all((1, 2))
    fin_prior = np.isfinite(x_prior).all(1) & np.isfinite(P_prior).all((1, 2)) & np.isfinite(Phi).all((1, 2))
    linked = np.zeros(n, bool)
    linked[:-1] = ~start[1:] & fin_post[:-1] & fin_post[1:] & fin_prior[1:]
    C = np.zeros(P_post.shape)
    ks = np.flatnonzero(linked)
    for c0 in range(0, ks.size, GAIN_CHUNK):
        k = ks[c0:c0 + GAIN_CHUNK]
        try:
            C[k] = np.linalg.solve(P_prior[k + 1], Phi[k + 1] @ P_post[k]).transpose(0, 2, 1)
        except np.linalg.LinAlgError:                  # a singular prior in the batch: one by one
            for kk in k:
                try:
                    C[kk] = np.linalg.solve(P_prior[kk + 1], Phi[kk + 1] @ P_post[kk]).T
                except np.linalg.LinAlgError:
                    linked[kk] = False
    return linked, C


def rts_smooth_rigid(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray,
                     Phi: np.ndarray, start: np.ndarray, n_bl: int):
    """rts_smooth_rigid_reference (same arguments and result) with the gains solved in batches (rts_gains) and the
    backward loop compiled (gnssatt.attitude.rigid_kernels.rts_rigid_kernel: ~150 numpy calls per epoch in the
    reference)."""
    linked, C = rts_gains(x_post, P_post, x_prior, P_prior, Phi, start)
    xs = np.ascontiguousarray(x_post, dtype=np.float64).copy()
    Ps = np.ascontiguousarray(P_post, dtype=np.float64).copy()
    rts_rigid_kernel(np.ascontiguousarray(x_post, dtype=np.float64), np.ascontiguousarray(P_post, dtype=np.float64),
                     np.ascontiguousarray(x_prior, dtype=np.float64), np.ascontiguousarray(P_prior, dtype=np.float64),
                     C, linked, int(n_bl), xs, Ps)
    return xs, Ps


def rts_smooth_rigid_reference(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray,
                               Phi: np.ndarray, start: np.ndarray, n_bl: int):
    """(x_k|N (n, m), P_k|N (n, m, m)) as gnssatt.attitude.smoother.rts_smooth (same arguments, same segments and
    cuts), the last 3 n_bl states being rigid baselines smoothed in their tangent space (module doc)."""
    r0 = x_post.shape[1] - 3 * n_bl
    xs, Ps = x_post.copy(), P_post.copy()
    for k, C in rts_links(x_post, P_post, x_prior, P_prior, Phi, start):
        j = k + 1
        bs_j, bp_j = xs[j, r0:].reshape(n_bl, 3), x_prior[j, r0:].reshape(n_bl, 3)
        d_b, R_ps = boxminus_body(bs_j, bp_j)
        delta = C @ np.concatenate([xs[j, :r0] - x_prior[j, :r0], d_b.ravel()])
        bf_k = x_post[k, r0:].reshape(n_bl, 3)
        b_new, R_fs = boxplus_body(bf_k, delta[r0:].reshape(n_bl, 3))
        xs[k, :r0] = x_post[k, :r0] + delta[:r0]
        xs[k, r0:] = b_new.ravel()
        Pk = P_post[k] + C @ (_turn(Ps[j], bs_j, bp_j, r0, R_ps.T) - P_prior[j]) @ C.T
        Pk = _turn(Pk, bf_k, b_new, r0, R_fs)
        Ps[k] = 0.5 * (Pk + Pk.T)
    return xs, Ps
