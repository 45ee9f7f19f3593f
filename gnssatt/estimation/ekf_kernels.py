"""Compiled (numba) kernels of the EKF building blocks in gnssatt.estimation.ekf: the sparse-row gathers of the
Joseph update and the rotation propagation of the dynamic attitude filter (state, transition, covariance).

Each kernel is a small pure function over arrays that replaces a handful of numpy calls on small arrays (a few
microseconds of call overhead each, ~10^4 calls per pass); tests/attitude/test_ekf_kernels.py compares every
kernel with the straightforward numpy version on random inputs. Compiled with ``cache=True``: the first call in
a fresh environment compiles (see `warm_up` and docs/attitude.md "Speed"), later processes load the cache.

Implements: nothing new; each kernel cites the equation of the numpy code it replaces.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["gather_AHt", "gather_HA", "joseph_combine", "symmetric_plus_diag", "propagate_rotation_cov", "rotation_rk4_stm_kernel",
           "sequential_update_sparse", "warm_up"]


@njit(cache=True, nogil=True)
def gather_AHt(A, cols, coef):
    """A H^T (n, m) for H given by sparse rows: out[i, r] = sum_j coef[r, j] A[i, cols[r, j]] over cols >= 0.

    A (n, n_state) C-contiguous; cols (m, k) int64 (-1 = no term); coef (m, k). The gather
    `np.einsum("nmk,mk->nm", A[:, c], w)` of gnssatt.estimation.ekf.joseph_update_sparse (P H^T, (A P) H^T).
    """
    n = A.shape[0]
    m, kk = cols.shape
    out = np.zeros((m, n))                # returned transposed: Fortran order, as the einsum it replaces
    for r in range(m):
        for i in range(n):
            acc = 0.0
            for j in range(kk):
                c = cols[r, j]
                if c >= 0:
                    acc += coef[r, j] * A[i, c]
            out[r, i] = acc
    return out.T


@njit(cache=True, nogil=True)
def gather_HA(A, cols, coef):
    """H A (m, n) for H given by sparse rows: out[r, :] = sum_j coef[r, j] A[cols[r, j], :] over cols >= 0.

    The row gather `np.einsum("mkj,mk->mj", A[c, :], w)` of gnssatt.estimation.ekf.joseph_update_sparse
    (S = H (P H^T)).
    """
    m, kk = cols.shape
    n = A.shape[1]
    out = np.zeros((m, n))
    for r in range(m):
        for j in range(kk):
            c = cols[r, j]
            if c >= 0:
                w = coef[r, j]
                for i in range(n):
                    out[r, i] += w * A[c, i]
    return out


@njit(cache=True, nogil=True)
def symmetric_plus_diag(S, R):
    """0.5 (S + S^T) + diag(R) (m, m): joseph_update_sparse's `S = 0.5 * (S + S.T); S[diag] += R`."""
    m = S.shape[0]
    out = np.empty((m, m))
    for i in range(m):
        for j in range(m):
            out[i, j] = 0.5 * (S[i, j] + S[j, i])
    for i in range(m):
        out[i, i] += R[i]
    return out


@njit(cache=True, nogil=True)
def joseph_combine(AP, X, Y):
    """0.5 (Q + Q^T) with Q = AP - X + Y (n, n): the last step of the Joseph form in joseph_update_sparse,
    P+ = (A P) - (A P H^T) K^T + K R K^T, symmetrised (Gelb 1974 eq. 4.2-21)."""
    n = AP.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(i + 1):
            v = 0.5 * ((AP[i, j] - X[i, j] + Y[i, j]) + (AP[j, i] - X[j, i] + Y[j, i]))
            out[i, j] = v
            out[j, i] = v                      # the same sum: IEEE addition is commutative
    return out


@njit(cache=True, nogil=True)
def _skew3(v):
    """[v x] (3, 3), as gnssatt.gnss.rotations.skew."""
    W = np.zeros((3, 3))
    W[0, 1], W[0, 2] = -v[2], v[1]
    W[1, 0], W[1, 2] = v[2], -v[0]
    W[2, 0], W[2, 1] = -v[1], v[0]
    return W


@njit(cache=True, nogil=True)
def _einsum33(A, B):
    """A B (3, 3) summed in index order, as np.einsum("ij,jk->ik") does (np.dot is kept where numpy used @)."""
    out = np.zeros((3, 3))
    for i in range(3):
        for k in range(3):
            acc = 0.0
            for j in range(3):
                acc += A[i, j] * B[j, k]
            out[i, k] = acc
    return out


@njit(cache=True, nogil=True)
def rotation_rk4_stm_kernel(b, w, dt_s, max_step_s):
    """(b(t + dt) (n_b, 3), Phi_bb (3, 3), Phi_bw (n_b, 3, 3)) of b' = omega x b, omega' = 0 by fixed-step RK4.

    gnssatt.estimation.ekf.rotation_rk4_stm operation for operation (seed 000 sec. 2 eq. 2; one RK4 step of the
    linear system is T = sum_k (hW)^k / k!, k = 0..4, Butcher 2008 sec. 238; the omega partials by the
    variational equations, Montenbruck & Gill 2000 sec. 7.1): np.dot (BLAS) where it uses @, index-order sums
    where it uses einsum, so the results are the same bits. Phi_bb is returned once (the same for every b).
    """
    nb = b.shape[0]
    n = max(1, int(np.ceil(abs(dt_s) / max_step_s - 1e-12)))
    h = dt_s / n
    W = _skew3(w)
    hW = h * W
    hW2 = np.dot(hW, hW)
    T = np.eye(3) + hW + hW2 / 2.0 + np.dot(hW2, hW) / 6.0 + np.dot(hW2, hW2) / 24.0
    coef = np.array([1.0, h, h * h / 2.0, h ** 3 / 6.0, h ** 4 / 24.0])
    Phi_bb = np.eye(3)
    Phi_bw = np.zeros((nb, 3, 3))
    y = b.copy()
    for _ in range(n):
        yk = y
        Jk = np.zeros((nb, 3, 3))
        acc = np.empty((nb, 3, 3))
        for q in range(nb):
            acc[q] = _einsum33(T, Phi_bw[q])
        for k in range(1, 5):
            for q in range(nb):
                Jk[q] = -_skew3(yk[q]) + _einsum33(W, Jk[q])
            yk = np.dot(yk, W.T)
            acc += coef[k] * Jk
        y = np.dot(y, T.T)
        Phi_bw = acc
        Phi_bb = np.dot(T, Phi_bb)
    return y, Phi_bb, Phi_bw


@njit(cache=True, nogil=True)
def propagate_rotation_cov(P, w_idx, b_idx, Phi_bb, Phi_bw, Qw, b1, dt):
    """P <- Phi P Phi^T + Q in place, for the dynamic attitude filter (gnssatt.attitude.filter.run_filter).

    Phi is the identity except on the rows of the baselines b_j (state indices b_idx[j], (n_b, 3)): Phi_bb on b_j
    and Phi_bw[j] on omega (w_idx (3,)); it is applied to the rows, then the columns of the omega and baseline
    states (the filter's former `P[sub] = Phi @ P[sub]`, `P[:, sub] = P[:, sub] @ Phi.T`, same BLAS products).
    Q is the discrete noise of the omega random walk with rate Qw (3, 3) over dt and its effect on b:
    Q_ww = Qw dt, Q_bw = B_j Qw dt^2 / 2, Q_bb = B_j Qw B_i^T dt^3 / 3, B_j = -[b1_j x] (Van Loan 1978, to
    the leading order in dt).
    """
    nb = b_idx.shape[0]
    ns = 3 + 3 * nb
    sub = np.empty(ns, np.int64)
    sub[:3] = w_idx
    for j in range(nb):
        sub[3 + 3 * j:6 + 3 * j] = b_idx[j]
    Phi = np.eye(ns)
    for j in range(nb):
        r = 3 + 3 * j
        Phi[r:r + 3, r:r + 3] = Phi_bb
        Phi[r:r + 3, 0:3] = Phi_bw[j]
    n = P.shape[0]
    rows = np.empty((ns, n))
    for a in range(ns):
        rows[a] = P[sub[a]]
    rows = np.dot(Phi, rows)
    for a in range(ns):
        P[sub[a]] = rows[a]
    cols = np.empty((n, ns))
    for c in range(n):
        for a in range(ns):
            cols[c, a] = P[c, sub[a]]
    cols = np.dot(cols, Phi.T)
    for c in range(n):
        for a in range(ns):
            P[c, sub[a]] = cols[c, a]
    Q = np.zeros((ns, ns))
    Q[0:3, 0:3] = Qw * dt
    Bx = np.empty((nb, 3, 3))
    for j in range(nb):
        Bx[j] = -_skew3(b1[j])
    for j in range(nb):
        r = 3 + 3 * j
        Q[r:r + 3, 0:3] = np.dot(Bx[j], Qw) * dt ** 2 / 2
        Q[0:3, r:r + 3] = Q[r:r + 3, 0:3].T
        for i in range(nb):
            ri = 3 + 3 * i
            Q[r:r + 3, ri:ri + 3] = np.dot(np.dot(Bx[j], Qw), Bx[i].T) * dt ** 3 / 3
    for a in range(ns):
        for c in range(ns):
            P[sub[a], sub[c]] += Q[a, c]


@njit(cache=True, nogil=True)
def sequential_update_sparse(x, P, cols, coef, R, z, joseph_ratio):
    """In place: x, P after the update with the m scalar measurements z_r = h_r . x + e_r, var(e_r) = R[r]
    (diagonal R), h_r given by sparse rows (cols (m, k) int64, -1 = no term; coef (m, k)); True if every
    innovation variance was positive, else False with x and P left as they were.

    Implements: the Kalman update with a diagonal R as m scalar updates in turn (Maybeck 1979 sec. 7.4;
    Gelb 1974 sec. 4.2), mathematically the batch update of gnssatt.estimation.ekf.joseph_update_sparse (the
    Cholesky pivots of its S are these s): s = h P h^T + r, k = P h^T / s, x += k (z - h x), and
        P -= (P h^T)(P h^T)^T / s                         if h P h^T <= joseph_ratio r (O(n^2 / 2)),
        P = A - (A h^T) k^T + r k k^T, A = P - k (P h^T)^T  otherwise (Joseph form, Gelb 1974 eq. 4.2-21),
    symmetrised: where a row collapses a large prior variance (a white clock, a new ambiguity) the Joseph form
    keeps the rounding error of that collapse out of P (the error of A is projected out by I - k h), where the
    short form would leave an absolute error ~ 1e-16 x the prior variance. P is kept as its lower triangle
    (symmetrised on entry, mirrored on exit), and the gathers P h^T read the lower triangle only.
    """
    n = x.size
    m, kk = cols.shape
    x0 = x.copy()
    P0 = P.copy()
    # symmetrise into the lower triangle (the caller's P may differ from its transpose in the last bits)
    for i in range(n):
        for j in range(i):
            P[i, j] = 0.5 * (P[i, j] + P[j, i])
    ph = np.empty(n)
    kg = np.empty(n)
    ah = np.empty(n)
    for r in range(m):
        for i in range(n):
            ph[i] = 0.0
        hx = 0.0
        for a in range(kk):
            c = cols[r, a]
            if c < 0:
                continue
            w = coef[r, a]
            hx += w * x[c]
            for i in range(c):                 # P[c, i] = P[i, c] (lower triangle, row c)
                ph[i] += w * P[c, i]
            for i in range(c, n):
                ph[i] += w * P[i, c]
        hph = 0.0
        for a in range(kk):
            c = cols[r, a]
            if c >= 0:
                hph += coef[r, a] * ph[c]
        rr = R[r]
        s = hph + rr
        if not (s > 0.0):
            x[:] = x0
            P[:, :] = P0
            return False
        gain = (z[r] - hx) / s
        for i in range(n):
            x[i] += ph[i] * gain
        if hph <= joseph_ratio * rr:
            q = 1.0 / np.sqrt(s)
            for i in range(n):
                kg[i] = ph[i] * q
            for i in range(n):
                gi = kg[i]
                for j in range(i + 1):
                    P[i, j] -= gi * kg[j]
            continue
        for i in range(n):
            kg[i] = ph[i] / s
        # A h^T with A = P - k (P h^T)^T, column by column as A's elements are rounded
        for i in range(n):
            ah[i] = 0.0
        for a in range(kk):
            c = cols[r, a]
            if c < 0:
                continue
            w = coef[r, a]
            pc = ph[c]
            for i in range(c):
                ah[i] += w * (P[c, i] - kg[i] * pc)
            for i in range(c, n):
                ah[i] += w * (P[i, c] - kg[i] * pc)
        for i in range(n):
            ki, pi, ai = kg[i], ph[i], ah[i]
            for j in range(i + 1):
                pij = P[i, j]
                kj = kg[j]
                v1 = (pij - ki * ph[j]) - ai * kj + rr * (ki * kj)
                v2 = (pij - kj * pi) - ah[j] * ki + rr * (kj * ki)
                P[i, j] = 0.5 * (v1 + v2)
    for i in range(n):
        for j in range(i):
            P[j, i] = P[i, j]
    return True


def warm_up() -> None:
    """Compile (or load from the cache) every kernel once on tiny inputs: at worker start or image build, so a
    job does not pay the compilation."""
    P = np.eye(9)
    cols = np.array([[0, 1, -1]], dtype=np.int64)
    S = gather_HA(gather_AHt(P, cols, np.ones((1, 3))), cols, np.ones((1, 3)))
    symmetric_plus_diag(S, np.ones(1))
    # the layouts of joseph_update_sparse with several rows: P H^T in Fortran order, R a read-only broadcast
    cols2 = np.array([[0, 1, -1], [2, -1, -1]], dtype=np.int64)
    S2 = gather_HA(gather_AHt(P, cols2, np.ones((2, 3))), cols2, np.ones((2, 3)))
    symmetric_plus_diag(S2, np.broadcast_to(np.ones(2), (2,)))
    joseph_combine(P, P, P)
    y, pbb, pbw = rotation_rk4_stm_kernel(np.ones((2, 3)), np.full(3, 1e-3), 1.0, 1.0)
    propagate_rotation_cov(P, np.arange(3), np.arange(3, 9).reshape(2, 3), pbb, pbw, np.eye(3), y, 1.0)
    sequential_update_sparse(np.zeros(9), np.eye(9), cols, np.ones((1, 3)), np.ones(1), np.ones(1), 1e3)
