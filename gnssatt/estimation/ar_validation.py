"""Validation of integer ambiguity candidates: ratio test, fixed baseline and its length / angle tests,
bootstrapped success rate and partial fixing.

Units: ambiguities in cycles (covariances cycles^2), baselines in metres (covariances m^2), angles in degrees.
A float solution of q baselines stacks them as ``b = [b_0; b_1; ...]`` (3q,), ECEF metres, with ``Q_ab``
(n, 3q) the covariance of the ambiguities with it (the layout of ``constrained_search.FloatSolution``).

References:
- P.J.G. Teunissen (1995) J. Geodesy 70:65-82 (conditional adjustment b(a) = b_hat - Q_ba Q_a^-1 (a_hat - a)).
- P.J.G. Teunissen (1998) Success probability of integer GPS ambiguity rounding and bootstrapping.
  J. Geodesy 72:606-612 (P_B = prod_i (2 Phi(1 / (2 sigma_i|I)) - 1)).
- P.J.G. Teunissen, P. Joosten, C. Tiberius (1999) Geometry-free ambiguity success rates in case of
  partial fixing. Proc. ION NTM (fix the subset whose bootstrapped success rate stays above P_0).
- H.-J. Euler, B. Schaffrin (1991) On a measure for the discernibility between different ambiguity solutions
  in the static-kinematic GPS mode (ratio test); RTKLIB 2.4.3 ``rtkpos.c`` (``thresar[0]`` = 3 by default).
- Seed 000 (CASSIOPE/GAP) sec. 2: acceptance by the length of the baseline solved with the candidate integers
  against the known length, Table 2 threshold 3 cm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from gnssatt.estimation.lambda_search import MAX_NODES_DEFAULT, check_covariance, decorrelate, search

__all__ = [
    "RATIO_THRESHOLD_DEFAULT", "LENGTH_TOLERANCE_M_DEFAULT",
    "ratio_test", "fixed_baseline", "baseline_length_test", "baseline_angle_test",
    "bootstrap_success_rate", "PartialFix", "partial_fix",
]

#: RTKLIB's default ratio threshold (``pos2-arthres=3``): second-best / best squared norm.
RATIO_THRESHOLD_DEFAULT = 3.0
#: Seed 000 Table 2, "max. baseline length difference": 3 cm.
LENGTH_TOLERANCE_M_DEFAULT = 0.03


def ratio_test(sqnorm: np.ndarray, threshold: float = RATIO_THRESHOLD_DEFAULT) -> tuple[float, bool]:
    """Return ``(ratio, passed)`` with ratio = sqnorm[1] / sqnorm[0] and passed = ratio >= threshold.

    Args:
        sqnorm: (m >= 2,) ascending squared norms of the best candidates (``LambdaResult.sqnorm``).
        threshold: acceptance threshold (RTKLIB default 3).

    Implements: the ratio test (Euler & Schaffrin 1991) as RTKLIB computes ``sol.ratio``; a zero best norm
    gives an infinite ratio.
    """
    s = np.asarray(sqnorm, dtype=float)
    if s.size < 2:
        raise ValueError("the ratio test needs the two best candidates")
    ratio = float(s[1] / s[0]) if s[0] > 0.0 else math.inf
    return ratio, bool(ratio >= threshold)


def fixed_baseline(b_float_m: np.ndarray, a_float_cyc: np.ndarray, Q_ba: np.ndarray, Q_aa: np.ndarray,
                   a_fixed_cyc: np.ndarray, Q_bb: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """Return the baseline(s) conditioned on integer ambiguities and, if ``Q_bb`` is given, their covariance.

    ``b_fixed = b_float - Q_ba Q_aa^-1 (a_float - a_fixed)``,  ``Q_b|a = Q_bb - Q_ba Q_aa^-1 Q_ab``.

    Args:
        b_float_m: (3q,) float baseline(s), metres (any frame; the result is in the same frame).
        a_float_cyc: (n,) float ambiguities, cycles. Q_ba: (3q, n) m*cycles. Q_aa: (n, n) cycles^2.
        a_fixed_cyc: (n,) or (k, n) candidate integers.
        Q_bb: optional (3q, 3q) m^2.

    Returns:
        b_fixed: (3q,) or (k, 3q) metres; Q_b_given_a: (3q, 3q) or None.

    Implements: Teunissen (1995) eq. 5 (conditional least-squares adjustment). Works for any linear functions of
    the ambiguities too: pass ``z = Z^T a``, ``Q_bz = Q_ba Z`` and ``Q_zz = Z^T Q_aa Z`` for a partial fix.
    """
    Q_aa = check_covariance(Q_aa, "Q_aa")
    C = np.linalg.cholesky(Q_aa)
    da = np.asarray(a_float_cyc, float) - np.asarray(a_fixed_cyc, float)      # (n,) or (k, n)
    # K = Q_ba Q_aa^-1 via two triangular solves (Q_aa = C C^T)
    K = np.linalg.solve(C.T, np.linalg.solve(C, np.asarray(Q_ba, float).T)).T
    b_fixed = np.asarray(b_float_m, float) - da @ K.T
    Q_cond = None
    if Q_bb is not None:
        Q_cond = np.asarray(Q_bb, float) - K @ np.asarray(Q_ba, float).T
        Q_cond = 0.5 * (Q_cond + Q_cond.T)
    return b_fixed, Q_cond


def baseline_length_test(b_fixed_m: np.ndarray, known_length_m: float | np.ndarray,
                         tol_m: float = LENGTH_TOLERANCE_M_DEFAULT) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(length_error_m, passed)`` with error = |b_fixed| - known length and passed = |error| < tol.

    Args:
        b_fixed_m: (..., 3) fixed baseline vector(s), metres.
        known_length_m: known length(s), metres (broadcast against ``b_fixed_m[..., 0]``).
        tol_m: acceptance threshold, metres (seed 000 Table 2: 3 cm).

    Implements: seed 000 sec. 2 (ambiguity acceptance by the baseline length).
    """
    err = np.linalg.norm(np.asarray(b_fixed_m, float), axis=-1) - np.asarray(known_length_m, float)
    return err, np.abs(err) < tol_m


def baseline_angle_test(b_fixed_m: np.ndarray, body_baselines_m: np.ndarray, tol_deg: float | None = None,
                        tol_m: float | np.ndarray = LENGTH_TOLERANCE_M_DEFAULT) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(angle_error_deg, passed)`` for every pair of baselines: the angle between two fixed baselines
    minus the angle between the same two in the body frame.

    Args:
        b_fixed_m: (q, 3) fixed baselines (any one frame), metres, q >= 2.
        body_baselines_m: (q, 3) the same baselines in the body frame, metres.
        tol_deg: acceptance threshold per pair; default: the angle a ``tol_m`` error subtends at the shorter
            baseline of the pair, ``atan(tol_m / l_min)`` (1.6 deg for 3 cm at 1.05 m); ``tol_m`` may be one
            value per baseline (q,), a pair then uses the larger of its two.

    Returns:
        angle_error_deg: (q*(q-1)/2,) in the pair order (0,1), (0,2), ..., (1,2), ...; passed: same shape.

    Implements: the geometric validation of seed 000 sec. 2 extended from the length to the inter-baseline
    angle (a wrong integer on one baseline moves its direction by about lambda / l rad).
    """
    B = np.asarray(b_fixed_m, float).reshape(-1, 3)
    F = np.asarray(body_baselines_m, float).reshape(-1, 3)
    if B.shape != F.shape or B.shape[0] < 2:
        raise ValueError("need the same q >= 2 baselines in both frames")
    tols_m = np.broadcast_to(np.asarray(tol_m, float), (B.shape[0],))
    errs, oks = [], []
    for i in range(B.shape[0]):
        for j in range(i + 1, B.shape[0]):
            ang_b = _angle_deg(B[i], B[j])
            ang_f = _angle_deg(F[i], F[j])
            lmin = min(np.linalg.norm(F[i]), np.linalg.norm(F[j]))
            tol = tol_deg if tol_deg is not None else math.degrees(math.atan(max(tols_m[i], tols_m[j]) / lmin))
            errs.append(ang_b - ang_f)
            oks.append(abs(ang_b - ang_f) < tol)
    return np.array(errs), np.array(oks)


def _angle_deg(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two vectors in degrees, by atan2(|u x v|, u.v) (accurate near 0 and 180 deg)."""
    return math.degrees(math.atan2(np.linalg.norm(np.cross(u, v)), float(np.dot(u, v))))


def bootstrap_success_rate(d_cyc2: np.ndarray) -> float:
    """Return the bootstrapped success rate ``prod_i (2 Phi(1 / (2 sqrt(d_i))) - 1)``.

    Args:
        d_cyc2: (n,) conditional variances of the (decorrelated) ambiguities, cycles^2
            (``LambdaResult.d``; for the ILS estimator this is a sharp lower bound of its success rate).

    Implements: Teunissen (1998) J. Geodesy 72:606-612, eq. 19.
    """
    d = np.asarray(d_cyc2, float)
    return float(np.prod(2.0 * ndtr(0.5 / np.sqrt(d)) - 1.0))


@dataclass(frozen=True)
class PartialFix:
    """A fixed subset of decorrelated ambiguities: ``Z_sub^T a = z_fixed`` holds for the fixed combinations."""

    Z_sub: np.ndarray        # (n, k) int64, the k fixed integer combinations (columns of Z)
    z_fixed: np.ndarray      # (m, k) int64, m best values of Z_sub^T a, best first
    z_float: np.ndarray      # (k,) float values of Z_sub^T a, cycles
    Q_z: np.ndarray          # (k, k) covariance of z_float, cycles^2
    sqnorm: np.ndarray       # (m,)
    ratio: float
    success_rate: float      # bootstrapped success rate of the subset
    n_total: int             # n, the number of ambiguities offered


def partial_fix(a_float_cyc: np.ndarray, Q_aa: np.ndarray, min_success_rate: float = 0.999, m: int = 2,
                max_nodes: int = MAX_NODES_DEFAULT) -> PartialFix | None:
    """Return the largest set of decorrelated ambiguities whose bootstrapped success rate >= ``min_success_rate``,
    fixed by MLAMBDA, or None when not even one reaches it.

    After the LAMBDA reduction ``Q_z = L^T D L`` the trailing block ``z_{k..n-1}`` has covariance
    ``L[k:,k:]^T D[k:] L[k:,k:]``, so its search reuses the factors, and its success rate is
    ``prod_{i>=k} (2 Phi(1/(2 sqrt(d_i))) - 1)``; k is the smallest index that keeps the rate above the target.

    Args:
        a_float_cyc: (n,) cycles. Q_aa: (n, n) cycles^2.
        min_success_rate: target probability of a correct subset (e.g. 0.999).
        m: candidates for the ratio test.

    Implements: partial ambiguity resolution (Teunissen, Joosten & Tiberius 1999) with the bootstrapped rate of
    Teunissen (1998); the fixed combinations constrain the filter as pseudo-measurements ``Z_sub^T a = z``.
    """
    a = np.asarray(a_float_cyc, float)
    dec = decorrelate(Q_aa)
    n = a.size
    p_each = 2.0 * ndtr(0.5 / np.sqrt(dec.d)) - 1.0
    tail = np.cumprod(p_each[::-1])[::-1]          # tail[k] = prod_{i>=k} p_i
    ok = np.nonzero(tail >= min_success_rate)[0]
    if ok.size == 0:
        return None
    k = int(ok[0])
    Z_sub = dec.Z[:, k:]
    z_float = Z_sub.T.astype(float) @ a
    z_fixed, sqnorm, _ = search(z_float, dec.L[k:, k:], dec.d[k:], m=m, max_nodes=max_nodes)
    ratio = float(sqnorm[1] / sqnorm[0]) if m >= 2 and sqnorm[0] > 0 else (math.inf if m >= 2 else math.nan)
    Q_z = dec.L[k:, k:].T @ np.diag(dec.d[k:]) @ dec.L[k:, k:]
    return PartialFix(Z_sub=Z_sub, z_fixed=z_fixed, z_float=z_float, Q_z=Q_z, sqnorm=sqnorm, ratio=ratio,
                      success_rate=float(tail[k]), n_total=n)


def geometric_tolerance_m(sol, tol_m: float, n_sigma: float) -> np.ndarray:
    """Per baseline (q,): ``max(tol_m, n_sigma sqrt(lambda_max(Q_b|a)))``, the length/angle test tolerance.

    ``sol``: a ``constrained_search.FloatSolution`` (``n_baselines``, ``Q_a``, ``Q_ab``, ``Q_b``).

    ``Q_b|a = Q_b - Q_ba Q_a^-1 Q_ab`` (Teunissen 1995 eq. 4) is the covariance of the integer-conditioned baseline:
    a fixed test tolerance below its spread rejects right integers for nothing (10 cm CubeSat baselines with a
    weak single-epoch geometry have sigma of several cm), while above it the test keeps its meaning.
    """
    q = sol.n_baselines
    if n_sigma <= 0.0:
        return np.full(q, float(tol_m))
    C = np.linalg.cholesky(sol.Q_a)
    K = np.linalg.solve(C.T, np.linalg.solve(C, sol.Q_ab)).T
    Qc = sol.Q_b - K @ sol.Q_ab
    lam = np.array([np.linalg.eigvalsh(0.5 * (Qc[3 * j:3 * j + 3, 3 * j:3 * j + 3]
                                              + Qc[3 * j:3 * j + 3, 3 * j:3 * j + 3].T))[-1] for j in range(q)])
    return np.maximum(float(tol_m), n_sigma * np.sqrt(np.maximum(lam, 0.0)))
