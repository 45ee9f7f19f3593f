"""Compiled (numba) kernels of the rigid baseline update (settings.baseline_update "rigid"): the forward filter's
retraction per epoch and the smoother's backward recursion in the baselines' tangent space.

Each does in one call what ~30 (forward) or ~150 (backward, per epoch) numpy calls on 3-vectors did: the readable
numpy versions took 0.2 ms per epoch forward and ~0.7 ms per backward step (the rigid smoother cost 4-5x the
linear one; docs/BENCHMARKS.md "Rigid update: compiled kernels"). The least-squares common rotation solves its
3 x 3 normal equations by the adjugate, or by numpy's lstsq (rcond 1e-10, as the reference) when they are
singular (one baseline, or parallel ones).

Specification: gnssatt.attitude.rigid_update.rigid_retract_reference (the retraction: Markley 2003; Sola 2017 sec.
7.2) and gnssatt.attitude.rigid_smoother.rts_smooth_rigid_reference (the RTS step with box-plus / box-minus,
Hertzberg et al. 2013 sec. 3-4); tests/attitude/test_rigid_kernels.py checks each kernel against its reference
with tolerances in physical units.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from gnssatt.estimation.ekf_kernels import _skew3

__all__ = ["rigid_retract_kernel", "rts_rigid_kernel", "warm_up"]


@njit(cache=True, nogil=True)
def _cross(a, b):
    """a x b of two 3-vectors."""
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@njit(cache=True, nogil=True)
def _rotation_exp(phi):
    """rigid_update.rotation_exp: Rodrigues' formula, second order below 1e-8 rad."""
    a = np.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    K = _skew3(phi)
    K2 = K @ K
    if a < 1e-8:
        return np.eye(3) + K + 0.5 * K2
    return np.eye(3) + np.sin(a) / a * K + (1.0 - np.cos(a)) / (a * a) * K2


@njit(cache=True, nogil=True)
def _rotation_between(u0, u1):
    """rigid_update.rotation_between: the rotation about u0 x u1 taking u0 to u1 (Rodrigues)."""
    vx = _skew3(_cross(u0, u1))
    c = u0[0] * u1[0] + u0[1] * u1[1] + u0[2] * u1[2]
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


@njit(cache=True, nogil=True)
def _common_rotation(B0, D):
    """rigid_update.common_rotation: min sum_j |d_j - phi x b_j|^2, normal equations sum_j (|b_j|^2 I - b_j b_j^T)
    phi = sum_j b_j x d_j, solved by lstsq (rcond 1e-10: minimum norm for one or parallel baselines)."""
    N = np.zeros((3, 3))
    rhs = np.zeros(3)
    for j in range(B0.shape[0]):
        b = B0[j]
        nb2 = b @ b
        for r in range(3):
            N[r, r] += nb2
            for c in range(3):
                N[r, c] -= b[r] * b[c]
        rhs += _cross(b, D[j])
    return _solve_normal(N, rhs)


@njit(cache=True, nogil=True)
def _solve_normal(N, rhs):
    """N^-1 rhs of the symmetric 3 x 3 N by its adjugate (Cramer) where det N > 1e-9 trace^3 (two baselines at an
    angle: ~1e-2), else np.linalg.lstsq with rcond 1e-10 as the reference (one baseline or parallel ones: rank 2).
    lstsq (gelsd, an SVD with its workspace) was most of the kernels' time."""
    a, b, c, d, e, f = N[0, 0], N[0, 1], N[0, 2], N[1, 1], N[1, 2], N[2, 2]
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * c00 + b * c01 + c * c02
    tr = a + d + f
    if not det > 1e-9 * tr * tr * tr:
        return np.linalg.lstsq(N, rhs, 1e-10)[0]
    out = np.empty(3)
    out[0] = (c00 * rhs[0] + c01 * rhs[1] + c02 * rhs[2]) / det
    out[1] = (c01 * rhs[0] + c11 * rhs[1] + c12 * rhs[2]) / det
    out[2] = (c02 * rhs[0] + c12 * rhs[1] + c22 * rhs[2]) / det
    return out


@njit(cache=True, nogil=True)
def rigid_retract_kernel(x, P, b_prior_m, b_idx, active, out):
    """rigid_update.rigid_retract_reference in place on x (m,), P (m, m); out (n_bl,) the length changes removed (m,
    0 where not active). b_idx (n_bl, 3) int64, active (n_bl,) bool."""
    n_bl = b_idx.shape[0]
    out[:] = 0.0
    act = np.zeros(n_bl, np.bool_)
    na = 0
    for j in range(n_bl):
        if active[j]:
            s0 = 0.0
            s1 = 0.0
            for a in range(3):
                s0 += b_prior_m[j, a] ** 2
                s1 += x[b_idx[j, a]] ** 2
            if s0 > 0 and s1 > 0:
                act[j] = True
                na += 1
    if na == 0:
        return
    B0 = np.empty((na, 3))
    D = np.empty((na, 3))
    i = 0
    for j in range(n_bl):
        if act[j]:
            for a in range(3):
                B0[i, a] = b_prior_m[j, a]
                D[i, a] = x[b_idx[j, a]] - b_prior_m[j, a]
            i += 1
    phi = _common_rotation(B0, D)
    R = _rotation_exp(phi)
    m = P.shape[0]
    rows = np.empty((3, m))
    i = 0
    for j in range(n_bl):
        if not act[j]:
            continue
        ix = b_idx[j]
        b0, d = B0[i], D[i]
        i += 1
        n0 = np.sqrt(b0 @ b0)
        u0 = b0 / n0
        c = R @ (b0 + d - _cross(phi, b0))
        n_new = n0 + u0 @ d
        u1 = c / np.sqrt(c @ c)
        bd = b0 + d
        out[j] = np.sqrt(bd @ bd) - n_new
        for a in range(3):
            x[ix[a]] = u1[a] * n_new
        Ru0 = R @ u0
        if Ru0 @ u1 > -0.5:
            T = _rotation_between(Ru0, u1) @ R
            for a in range(3):                       # P[ix, :] = T P[ix, :]
                for col in range(m):
                    rows[a, col] = T[a, 0] * P[ix[0], col] + T[a, 1] * P[ix[1], col] + T[a, 2] * P[ix[2], col]
            for a in range(3):
                for col in range(m):
                    P[ix[a], col] = rows[a, col]
            for r in range(m):                       # P[:, ix] = P[:, ix] T^T
                p0, p1, p2 = P[r, ix[0]], P[r, ix[1]], P[r, ix[2]]
                for a in range(3):
                    P[r, ix[a]] = p0 * T[a, 0] + p1 * T[a, 1] + p2 * T[a, 2]


@njit(cache=True, nogil=True)
def _boxminus(b1, b0):
    """rigid_smoother.boxminus of (n, 3) baselines."""
    out = np.empty_like(b0)
    for j in range(b0.shape[0]):
        n0 = np.sqrt(b0[j] @ b0[j])
        n1 = np.sqrt(b1[j] @ b1[j])
        u0, u1 = b0[j] / n0, b1[j] / n1
        c = u0 @ u1
        t = u1 - c * u0
        s = np.sqrt(t @ t)
        ang = np.arctan2(s, c)
        f = ang * n0 / s if s > 0 else 0.0
        out[j] = (n1 - n0) * u0 + f * t
    return out


@njit(cache=True, nogil=True)
def _boxplus(b0, d):
    """rigid_smoother.boxplus of (n, 3) baselines."""
    out = np.empty_like(b0)
    for j in range(b0.shape[0]):
        n0 = np.sqrt(b0[j] @ b0[j])
        u0 = b0[j] / n0
        dr = u0 @ d[j]
        dt = d[j] - dr * u0
        s = np.sqrt(dt @ dt)
        ang = s / n0
        e = dt / s if s > 0 else np.zeros(3)
        out[j] = (n0 + dr) * (np.cos(ang) * u0 + np.sin(ang) * e)
    return out


@njit(cache=True, nogil=True)
def _cross_rows(phi, B):
    """phi x b_j for the rows of B (n, 3)."""
    out = np.empty_like(B)
    for j in range(B.shape[0]):
        out[j] = _cross(phi, B[j])
    return out


@njit(cache=True, nogil=True)
def _boxplus_body(b0, d):
    """rigid_smoother.boxplus_body: ((n, 3) baselines, R)."""
    phi = _common_rotation(b0, d)
    R = _rotation_exp(phi)
    return _boxplus(b0, d - _cross_rows(phi, b0)) @ R.T, R


@njit(cache=True, nogil=True)
def _boxminus_body(b1, b0, iterations):
    """rigid_smoother.boxminus_body: ((n, 3) d, R), phi by the same fixed-point iteration."""
    phi = np.zeros(3)
    for _ in range(iterations):
        R = _rotation_exp(phi)
        e = _boxminus(b1 @ R, b0)
        psi = _common_rotation(b0, e)
        phi = phi + psi
        if psi @ psi < 1e-30:
            break
    R = _rotation_exp(phi)
    e = _boxminus(b1 @ R, b0)
    return _cross_rows(phi, b0) + e, R


@njit(cache=True, nogil=True)
def _turn(P, b_from, b_to, r0, R):
    """rigid_smoother._turn: T P T^T with T the identity but for each baseline's block (rotation_between(R u_from,
    u_to) R where R u_from . u_to > -0.5)."""
    m = P.shape[0]
    T = np.eye(m)
    for j in range(b_from.shape[0]):
        u0 = R @ (b_from[j] / np.sqrt(b_from[j] @ b_from[j]))
        u1 = b_to[j] / np.sqrt(b_to[j] @ b_to[j])
        if u0 @ u1 > -0.5:
            T[r0 + 3 * j:r0 + 3 * j + 3, r0 + 3 * j:r0 + 3 * j + 3] = _rotation_between(u0, u1) @ R
    return T @ P @ T.T


@njit(cache=True, nogil=True)
def rts_rigid_kernel(x_post, P_post, x_prior, P_prior, C_all, linked, n_bl, xs, Ps):
    """rigid_smoother.rts_smooth_rigid_reference's loop, in place on xs, Ps (copies of x_post, P_post): for k from
    the last epoch back where linked[k] (k links to k+1 with the gain C_all[k], rts_links)."""
    m = x_post.shape[1]
    r0 = m - 3 * n_bl
    for k in range(x_post.shape[0] - 2, -1, -1):
        if not linked[k]:
            continue
        j = k + 1
        C = C_all[k]
        bs_j = np.ascontiguousarray(xs[j, r0:]).reshape(n_bl, 3)
        bp_j = np.ascontiguousarray(x_prior[j, r0:]).reshape(n_bl, 3)
        d_b, R_ps = _boxminus_body(bs_j, bp_j, 8)
        v = np.empty(m)
        v[:r0] = xs[j, :r0] - x_prior[j, :r0]
        v[r0:] = d_b.ravel()
        delta = C @ v
        bf_k = np.ascontiguousarray(x_post[k, r0:]).reshape(n_bl, 3)
        b_new, R_fs = _boxplus_body(bf_k, np.ascontiguousarray(delta[r0:]).reshape(n_bl, 3))
        xs[k, :r0] = x_post[k, :r0] + delta[:r0]
        xs[k, r0:] = b_new.ravel()
        Pj = _turn(np.ascontiguousarray(Ps[j]), bs_j, bp_j, r0, np.ascontiguousarray(R_ps.T))
        Pk = P_post[k] + C @ (Pj - P_prior[j]) @ C.T
        Pk = _turn(Pk, bf_k, b_new, r0, R_fs)
        Ps[k] = 0.5 * (Pk + Pk.T)


def warm_up() -> None:
    """Compile (or load from the cache) both kernels once on tiny inputs of the filter's and smoother's types."""
    x, P = np.zeros(6), np.eye(6)
    x[3] = 1.0
    rigid_retract_kernel(x, P, np.array([[1.0, 0.0, 0.0]]), np.array([[3, 4, 5]], np.int64), np.ones(1, np.bool_),
                         np.zeros(1))
    xs = np.zeros((2, 6))
    xs[:, 3] = 1.0
    Ps = np.repeat(np.eye(6)[None], 2, 0)
    rts_rigid_kernel(xs.copy(), Ps.copy(), xs.copy(), Ps.copy(), Ps.copy(), np.array([True, False]), 1, xs, Ps)
