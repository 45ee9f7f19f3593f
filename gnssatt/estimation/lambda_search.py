"""Integer least squares for carrier-phase ambiguities: LAMBDA decorrelation and MLAMBDA search.

Solves  min_{a in Z^n} (a_hat - a)^T Q^-1 (a_hat - a)  for the m best integer vectors.

Conventions (the same as RTKLIB ``src/lambda.c``, so its known-answer vectors carry over):
- ``Q = L^T diag(d) L`` with ``L`` unit *lower* triangular; the factorisation runs from the last index
  down, so ``d[n-1] = Q[n-1, n-1]`` and ``d[k]`` is the variance of ``a_k`` conditioned on ``a_{k+1..n-1}``.
- The decorrelating transform is ``z = Z^T a``, ``Q_z = Z^T Q Z = L^T diag(d) L`` (Teunissen 1995 eq. 12).
- The search descends from level ``n-1`` to ``0``; at level ``k`` the conditional float value is
  ``zb_k = z_hat_k - sum_{i>k} L[i,k] (zb_i - z_i)`` and the partial squared norm adds ``(zb_k - z_k)^2 / d_k``
  (Teunissen 1995 eq. 21-23; Chang, Yang & Zhou 2005 sec. 3).
- Ambiguities in cycles, covariances in cycles^2.

References:
- P.J.G. Teunissen (1995) The least-squares ambiguity decorrelation adjustment: a method for fast GPS
  integer ambiguity estimation. J. Geodesy 70:65-82.
- P. de Jonge, C. Tiberius (1996) The LAMBDA method for integer ambiguity estimation: implementation
  aspects. LGR series 12, Delft.
- X.-W. Chang, X. Yang, T. Zhou (2005) MLAMBDA: a modified LAMBDA method for integer least-squares
  estimation. J. Geodesy 79:552-565 (symmetric pivoting, lazy size reduction, shrinking search).
- T. Takasu, RTKLIB 2.4.3 ``src/lambda.c`` (same factorisation order; ``test/utest/t_lambda.c`` vectors).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LambdaResult", "Decorrelation", "AmbiguitySearchError",
    "ldl_decompose", "decorrelate", "search", "mlambda", "check_covariance", "integer_bootstrap",
]

#: Relative tolerance of the permutation test d_new < d_old (1 - PERM_RTOL). Any strict decrease keeps the
#: reduction finite (LLL argument); a relative margin (RTKLIB uses an absolute 1e-6 cycles^2) makes it
#: independent of the scale of Q and stops swaps that only trade rounding error.
PERM_RTOL = 1e-9

#: Default cap on visited search-tree nodes per call. A decorrelated problem of n = 40 visits a few hundred;
#: the cap only turns a pathological input (float values far outside their covariance) into an error.
MAX_NODES_DEFAULT = 2_000_000


class AmbiguitySearchError(RuntimeError):
    """The integer search visited more nodes than allowed; the caller should treat the epoch as unfixed."""


@dataclass(frozen=True)
class Decorrelation:
    """A LAMBDA-reduced problem: ``z = Z^T a``, ``Z^T Q Z = L^T diag(d) L``, ``Z_inv = Z^-1`` (both integer)."""

    Z: np.ndarray       # (n, n) int64, unimodular
    Z_inv: np.ndarray   # (n, n) int64, exact inverse of Z
    L: np.ndarray       # (n, n) float, unit lower triangular factor of Q_z
    d: np.ndarray       # (n,) cycles^2, conditional variances of z (d[k] given z_{k+1..n-1})


@dataclass(frozen=True)
class LambdaResult:
    """The m best integer vectors of an ILS problem, best first."""

    fixed: np.ndarray   # (m, n) int64 cycles, candidates in the original ambiguity order, best first
    sqnorm: np.ndarray  # (m,) squared Q^-1 norms (a_hat - fixed_i)^T Q^-1 (a_hat - fixed_i), ascending
    Z: np.ndarray       # (n, n) int64 decorrelating transform, z = Z^T a
    ratio: float        # sqnorm[1] / sqnorm[0] (RTKLIB's ratio; inf when sqnorm[0] == 0, nan when m == 1)
    d: np.ndarray       # (n,) conditional variances of the decorrelated ambiguities, cycles^2
    n_nodes: int        # search-tree nodes visited (cost measure)


def check_covariance(Q: np.ndarray, name: str = "Q") -> np.ndarray:
    """Return ``Q`` symmetrised as float64 after checking it is a finite, square, positive definite matrix.

    Args:
        Q: (n, n) covariance matrix.
        name: name used in the error message.

    Raises:
        ValueError: not square, not finite, asymmetric beyond 1e-8 relative, or not positive definite
            (the message gives the smallest eigenvalue and the condition number).
    """
    Q = np.asarray(Q, dtype=float)
    if Q.ndim != 2 or Q.shape[0] != Q.shape[1] or Q.shape[0] == 0:
        raise ValueError(f"{name} must be a non-empty square matrix, got shape {Q.shape}")
    if not np.all(np.isfinite(Q)):
        raise ValueError(f"{name} has non-finite entries")
    scale = float(np.max(np.abs(np.diag(Q)))) or 1.0
    asym = float(np.max(np.abs(Q - Q.T)))
    if asym > 1e-8 * scale:
        raise ValueError(f"{name} is not symmetric: max |Q - Q^T| = {asym:.3g} (diagonal scale {scale:.3g})")
    Q = 0.5 * (Q + Q.T)
    try:
        np.linalg.cholesky(Q)
    except np.linalg.LinAlgError:
        w = np.linalg.eigvalsh(Q)
        raise ValueError(f"{name} is not positive definite: smallest eigenvalue {w[0]:.3g}, largest {w[-1]:.3g}; "
                         "drop the ambiguities that are not estimable or add their a priori variance") from None
    return Q


def ldl_decompose(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(L, d)`` with ``Q = L^T diag(d) L``, ``L`` unit lower triangular (factorised from the last index).

    Args:
        Q: (n, n) symmetric positive definite covariance, cycles^2.

    Returns:
        L: (n, n) unit lower triangular. d: (n,) cycles^2; ``d[k]`` is the variance of ``a_k`` conditioned on
        ``a_{k+1..n-1}``.

    Implements: Teunissen (1995) eq. 12 / de Jonge & Tiberius (1996) sec. 3.3 (the ``L^T D L`` order used by
    RTKLIB ``LD()``).

    Raises:
        ValueError: Q is not symmetric positive definite (see ``check_covariance``).
    """
    A = check_covariance(Q).copy()
    n = A.shape[0]
    L = np.zeros((n, n))
    d = np.empty(n)
    for i in range(n - 1, -1, -1):
        d[i] = A[i, i]
        if not d[i] > 0.0:  # cannot happen after the Cholesky check except by rounding on a singular Q
            raise ValueError(f"Q lost positive definiteness in the factorisation at index {i} (d = {d[i]:.3g})")
        row = A[i, : i + 1] / d[i]
        L[i, : i + 1] = row
        # A_{:i,:i} <- A_{:i,:i} - d_i l l^T  (Schur complement: condition on a_i)
        A[:i, :i] -= d[i] * np.outer(row[:i], row[:i])
    return L, d


def _ldl_pivoted(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(L, d, perm)`` with ``Q[perm][:, perm] = L^T diag(d) L`` choosing at each step the smallest pivot.

    Implements: Chang, Yang & Zhou (2005) sec. 2.1 "symmetric pivoting": the last index gets the ambiguity with
    the smallest (conditional) variance, which leaves fewer permutations to the reduction.
    """
    A = Q.copy()
    n = A.shape[0]
    perm = np.arange(n)
    L = np.zeros((n, n))
    d = np.empty(n)
    for i in range(n - 1, -1, -1):
        p = int(np.argmin(np.diag(A)[: i + 1]))
        if p != i:  # symmetric swap of p and i in the remaining block, the computed rows of L and the order
            A[[p, i], :] = A[[i, p], :]
            A[:, [p, i]] = A[:, [i, p]]
            L[:, [p, i]] = L[:, [i, p]]
            perm[[p, i]] = perm[[i, p]]
        d[i] = A[i, i]
        if not d[i] > 0.0:
            raise ValueError(f"Q lost positive definiteness in the factorisation (pivot {d[i]:.3g})")
        row = A[i, : i + 1] / d[i]
        L[i, : i + 1] = row
        A[:i, :i] -= d[i] * np.outer(row[:i], row[:i])
    return L, d, perm


#: Largest Gauss-transform multiplier kept: beyond 2**40 the int64 Z and its inverse can overflow in a few steps
#: and float64 stops representing integers exactly; a covariance that needs it is numerically singular.
_MAX_GAUSS_MU = 2.0 ** 40


def _gauss(L: np.ndarray, Z: np.ndarray, Z_inv: np.ndarray, i: int, j: int) -> None:
    """Integer Gauss transformation making |L[i, j]| <= 1/2 (in place).

    ``Z <- Z (I - mu e_i e_j^T)``, ``L <- L (I - mu e_i e_j^T)`` with ``mu = round(L[i, j])``, so column j of L
    loses mu times column i (Teunissen 1995 eq. 27; de Jonge & Tiberius 1996 sec. 3.4). The inverse
    ``Z^-1 <- (I + mu e_i e_j^T) Z^-1`` is kept exactly in integers.
    """
    if not abs(L[i, j]) < _MAX_GAUSS_MU:  # NaN/inf or beyond exact integers: Q is numerically singular
        raise AmbiguitySearchError(f"decorrelation diverged (L[{i},{j}] = {L[i, j]!r}): the ambiguity covariance is "
                                   "too ill-conditioned to search; leave this epoch float")
    mu = math.floor(L[i, j] + 0.5)
    if mu != 0:
        L[i:, j] -= mu * L[i:, i]
        Z[:, j] -= mu * Z[:, i]
        Z_inv[i, :] += mu * Z_inv[j, :]


def _permute(L: np.ndarray, d: np.ndarray, Z: np.ndarray, Z_inv: np.ndarray, j: int, delta: float) -> None:
    """Swap ambiguities j and j+1 and update the ``L^T D L`` factors (in place).

    With ``delta = d_j + L[j+1,j]^2 d_{j+1}`` (the new d_{j+1}), ``eta = d_j / delta`` and
    ``lam = d_{j+1} L[j+1,j] / delta``: ``d_j <- eta d_{j+1}``, ``d_{j+1} <- delta``, rows j, j+1 of the columns
    before j mix as ``[[-L[j+1,j], 1], [eta, lam]]``, and the two columns swap below j+1
    (de Jonge & Tiberius 1996 eq. 3.19-3.21; Teunissen 1995 sec. 3.3).
    """
    eta = d[j] / delta
    lam = d[j + 1] * L[j + 1, j] / delta
    d[j] = eta * d[j + 1]
    d[j + 1] = delta
    if j > 0:
        a0 = L[j, :j].copy()
        a1 = L[j + 1, :j].copy()
        L[j, :j] = a1 - L[j + 1, j] * a0
        L[j + 1, :j] = eta * a0 + lam * a1
    L[j + 1, j] = lam
    _swap(L[j + 2:, j], L[j + 2:, j + 1])
    _swap(Z[:, j], Z[:, j + 1])
    _swap(Z_inv[j], Z_inv[j + 1])


def _swap(u: np.ndarray, v: np.ndarray) -> None:
    """Swap the contents of two equal-shape views in place (cheaper than fancy indexing)."""
    t = u.copy()
    u[...] = v
    v[...] = t


def decorrelate(Q: np.ndarray) -> Decorrelation:
    """Return the LAMBDA reduction of ``Q``: an integer unimodular ``Z`` with ``Z^T Q Z = L^T diag(d) L``.

    The reduction makes ``d`` as close to ascending-from-the-last-index as the lattice allows ("d_{j+1} <= d_j"
    wherever a swap lowers d_{j+1}) and every ``|L[i,j]| <= 1/2`` for ``i > j``.

    Args:
        Q: (n, n) symmetric positive definite covariance, cycles^2.

    Implements: Teunissen (1995) sec. 3 (integer Gauss transformations and permutations); Chang, Yang & Zhou
    (2005) sec. 2 (symmetric pivoting in the factorisation, size reduction of L[j+1,j] only during the
    permutation sweep, full size reduction once at the end). The permutation test is de Jonge & Tiberius
    (1996) eq. 3.22 with a relative tolerance ``PERM_RTOL``.

    Raises:
        ValueError: Q is not symmetric positive definite.
    """
    Q = check_covariance(Q)
    n = Q.shape[0]
    L, d, perm = _ldl_pivoted(Q)
    Z = np.zeros((n, n), dtype=np.int64)
    Z[perm, np.arange(n)] = 1            # Z^T Q Z = Q[perm][:, perm]
    Z_inv = Z.T.copy()
    j = n - 2
    while j >= 0:
        if abs(L[j + 1, j]) > 0.5:                   # (the test avoids a call for mu = 0)
            _gauss(L, Z, Z_inv, j + 1, j)
        delta = d[j] + L[j + 1, j] ** 2 * d[j + 1]   # the conditional variance z_{j+1} would get after a swap
        if delta < d[j + 1] * (1.0 - PERM_RTOL):
            _permute(L, d, Z, Z_inv, j, delta)
            j = min(j + 1, n - 2)                    # the swap may break the pair above; look again there
        else:
            j -= 1
    for j in range(n - 2, -1, -1):                   # full size reduction: does not change d
        for i in range(j + 1, n):
            if abs(L[i, j]) > 0.5:
                _gauss(L, Z, Z_inv, i, j)
    return Decorrelation(Z=Z, Z_inv=Z_inv, L=L, d=d)


def integer_bootstrap(a_float: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Integer bootstrapping after decorrelation: sequential conditional rounding of ``z = Z^T a`` from the last
    index down, ``zb_k = z_hat_k - sum_{i>k} L[i,k] (zb_i - z_i)``, ``z_k = round(zb_k)``, back-transformed to a.
    A baseline for the success rates of ILS (the estimator whose success rate
    ar_validation.bootstrap_success_rate gives).

    Implements: Teunissen (1998) "Success probability of integer GPS ambiguity rounding and bootstrapping",
    J. Geodesy 72:606-612, eq. 4 (on the LAMBDA-decorrelated ambiguities, sec. 3 of Teunissen 1995).
    """
    dec = decorrelate(Q)
    zs = dec.Z.T.astype(float) @ a_float
    n = a_float.size
    z = np.zeros(n)
    zb = np.zeros(n)
    for k in range(n - 1, -1, -1):
        zb[k] = zs[k] - dec.L[k + 1:, k] @ (zb[k + 1:] - z[k + 1:])
        z[k] = np.floor(zb[k] + 0.5)
    return z.astype(np.int64) @ dec.Z_inv


def search(z_float: np.ndarray, L: np.ndarray, d: np.ndarray, m: int = 2,
           max_nodes: int = MAX_NODES_DEFAULT) -> tuple[np.ndarray, np.ndarray, int]:
    """Return the m integer vectors with the smallest ``(z_hat - z)^T (L^T D L)^-1 (z_hat - z)``, best first.

    Depth-first search from level n-1 to 0 with Schnorr-Euchner zig-zag enumeration around the conditional
    value ``zb_k`` and a shrinking ellipsoid: the radius is infinite until m leaves are found, then always the
    largest squared norm among the m kept (Chang, Yang & Zhou 2005 Algorithm 2.2; RTKLIB ``search()``).

    Args:
        z_float: (n,) float ambiguities, cycles (decorrelated or not: any ``L, d`` factorisation of their Q).
        L: (n, n) unit lower triangular, d: (n,) cycles^2, with ``Q_z = L^T diag(d) L``.
        m: number of candidates (>= 1).
        max_nodes: cap on visited nodes.

    Returns:
        z_fixed: (m, n) int64, sqnorm: (m,) ascending, n_nodes: int.

    Raises:
        AmbiguitySearchError: more than ``max_nodes`` nodes.
    """
    zs = [float(v) for v in np.asarray(z_float, dtype=float)]
    n = len(zs)
    if m < 1:
        raise ValueError("m must be >= 1")
    Lt = [[float(v) for v in row] for row in np.asarray(L, dtype=float).T]   # Lt[k][i] = L[i, k]
    inv_d = [1.0 / float(v) for v in d]
    floor = math.floor
    dist = [0.0] * (n + 1)                      # dist[k]: partial squared norm of levels k+1..n-1
    zb = [0.0] * n
    z = [0] * n
    step = [0] * n
    best_z: list[list[int]] = []
    best_s: list[float] = []
    max_dist = math.inf
    k = n - 1
    zb[k] = zs[k]
    z[k] = floor(zb[k] + 0.5)
    y = zb[k] - z[k]
    step[k] = 1 if y > 0.0 else -1
    nodes = 0
    while True:
        nodes += 1
        if nodes > max_nodes:
            raise AmbiguitySearchError(f"integer search exceeded {max_nodes} nodes (n = {n}); "
                                       "the float solution is far from any integer within its covariance")
        new_dist = dist[k + 1] + y * y * inv_d[k]   # partial squared norm with level k (Teunissen 1995 eq. 23)
        if new_dist < max_dist:
            if k != 0:
                dist[k] = new_dist
                k -= 1
                # zb_k = zs_k - sum_{i>k} L[i,k] (zb_i - z_i)  (conditional LS value, Chang et al. eq. 2.10)
                zb[k] = zs[k] + _cond_sum(Lt[k], z, zb, k, n)
                z[k] = floor(zb[k] + 0.5)
                y = zb[k] - z[k]
                step[k] = 1 if y > 0.0 else -1
            else:
                # a leaf: keep it among the m best, then shrink the ellipsoid to the worst kept
                if len(best_s) < m:
                    best_z.append(z.copy())
                    best_s.append(new_dist)
                    if len(best_s) == m:
                        max_dist = max(best_s)
                else:
                    imax = best_s.index(max(best_s))
                    best_z[imax] = z.copy()
                    best_s[imax] = new_dist
                    max_dist = max(best_s)
                z[0] += step[0]                     # next integer on level 0 in zig-zag order
                y = zb[0] - z[0]
                step[0] = -step[0] - (1 if step[0] > 0 else -1)
        else:
            if k == n - 1:
                break
            k += 1
            z[k] += step[k]
            y = zb[k] - z[k]
            step[k] = -step[k] - (1 if step[k] > 0 else -1)
    order = sorted(range(len(best_s)), key=lambda i: best_s[i])
    return (np.array([best_z[i] for i in order], dtype=np.int64).reshape(len(order), n),
            np.array([best_s[i] for i in order]), nodes)


def _cond_sum(lt: list[float], z: list[int], zb: list[float], k: int, n: int) -> float:
    """Return sum_{i>k} L[i,k] (z_i - zb_i) for one level (lt = column k of L)."""
    s = 0.0
    for i in range(k + 1, n):
        s += lt[i] * (z[i] - zb[i])
    return s


def mlambda(a_float: np.ndarray, Q: np.ndarray, m: int = 2, max_nodes: int = MAX_NODES_DEFAULT) -> LambdaResult:
    """Return the m best integer ambiguity vectors of ``min (a_hat - a)^T Q^-1 (a_hat - a)``, best first.

    Args:
        a_float: (n,) float ambiguities, cycles (e.g. double differences).
        Q: (n, n) their covariance, cycles^2; symmetrised, must be positive definite.
        m: number of candidates (2 gives the ratio test).
        max_nodes: cap on search nodes (``AmbiguitySearchError`` beyond).

    Returns:
        LambdaResult: ``fixed`` (m, n) int64, ``sqnorm`` (m,), ``Z`` (n, n) int64 with z = Z^T a,
        ``ratio = sqnorm[1] / sqnorm[0]``, ``d`` conditional variances of z, ``n_nodes``.

    Implements: LAMBDA reduction (Teunissen 1995; de Jonge & Tiberius 1996) with MLAMBDA's pivoting and search
    (Chang, Yang & Zhou 2005); ``a = Z^-T z`` back-transformation exact in integers (RTKLIB ``lambda()``).

    Raises:
        ValueError: bad shapes, non-finite input, Q not symmetric positive definite.
        AmbiguitySearchError: search too large.
    """
    a = np.asarray(a_float, dtype=float).reshape(-1)
    n = a.size
    if n == 0:
        raise ValueError("no ambiguities")
    if not np.all(np.isfinite(a)):
        raise ValueError("a_float has non-finite entries")
    if np.shape(Q) != (n, n):
        raise ValueError(f"Q has shape {np.shape(Q)}, expected ({n}, {n})")
    dec = decorrelate(Q)
    z_float = dec.Z.T.astype(float) @ a                  # z = Z^T a  (Teunissen 1995 eq. 12)
    z_fixed, sqnorm, nodes = search(z_float, dec.L, dec.d, m, max_nodes)
    fixed = z_fixed @ dec.Z_inv                          # a = Z^-T z, row-wise: a^T = z^T Z^-1
    if m >= 2:
        ratio = float(sqnorm[1] / sqnorm[0]) if sqnorm[0] > 0.0 else math.inf
    else:
        ratio = math.nan
    return LambdaResult(fixed=fixed, sqnorm=sqnorm, Z=dec.Z, ratio=ratio, d=dec.d.copy(), n_nodes=nodes)
