"""Integer ambiguity resolution for one baseline: double differences from the float single-difference ambiguities
of the filter, MLAMBDA, validation by the baseline length, and bootstrapping of newcomers on a fixed baseline.

Implements: seed 000 sec. 2 ("double-differences are formed from the float single-difference ambiguities and their
associated covariance matrix ... MLAMBDA ... validation ... by the length of the baseline"); the fixed baseline
b_fix = b_float - Q_ba Q_aa^-1 (a_float - a_fix) (Teunissen 1995 eq. 4, conditional adjustment) whose length is
compared with the known length (Table 2: 3 cm); the ratio test (RTKLIB's sqnorm2 / sqnorm1) reported.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ArOutcome", "dd_matrix", "resolve_constrained", "resolve_lambda", "round_newcomers"]


@dataclass
class ArOutcome:
    """One ambiguity-resolution attempt on one baseline.

    accepted: validated; D (n_dd, n_state) DD rows over the state; a_fix (n_dd,) integers; ratio (nan if one
    candidate); length_m of the fixed baseline; n_dd; reason: text for events.csv when rejected.
    """

    accepted: bool
    D: np.ndarray | None
    a_fix: np.ndarray | None
    ratio: float
    length_m: float
    n_dd: int
    reason: str = ""


def dd_matrix(amb_idx: np.ndarray, ref_pos: int, n_state: int) -> np.ndarray:
    """DD rows (n-1, n_state): state[amb_idx[i]] - state[amb_idx[ref_pos]] for every i != ref_pos."""
    others = np.delete(amb_idx, ref_pos)
    D = np.zeros((others.size, n_state))
    D[np.arange(others.size), others] = 1.0
    D[:, amb_idx[ref_pos]] = -1.0
    return D


def resolve_lambda(x: np.ndarray, P: np.ndarray, groups: list[tuple[np.ndarray, int]], b_idx: np.ndarray,
                   known_length_m: float, max_length_error_m: float, min_ratio: float = 0.0) -> ArOutcome:
    """ArOutcome of an MLAMBDA attempt over the DD ambiguities of `groups`.

    Args:
        x, P: filter state and covariance.
        groups: per signal, (state indices of the SD ambiguities observed now, position of the reference).
        b_idx: (3,) state indices of the baseline.
        known_length_m, max_length_error_m: validation by length (seed 000 Table 2).
        min_ratio: also require ratio >= this (0: only reported).
    """
    from worker.estimation.lambda_search import AmbiguitySearchError, mlambda

    D = np.concatenate([dd_matrix(idx, ref, x.size) for idx, ref in groups if idx.size >= 2], axis=0)
    a = D @ x
    DP = D @ P
    Qa = DP @ D.T
    Qa = 0.5 * (Qa + Qa.T)
    try:
        res = mlambda(a, Qa, m=2)
    except (AmbiguitySearchError, ValueError, OverflowError, np.linalg.LinAlgError) as exc:
        return ArOutcome(False, None, None, float("nan"), float("nan"), D.shape[0], f"search failed: {exc}")
    a_fix = np.asarray(res.fixed[0], dtype=np.float64)
    Qba = DP[:, b_idx].T                                              # (3, n_dd)
    try:
        b_fix = x[b_idx] - Qba @ np.linalg.solve(Qa, a - a_fix)
    except np.linalg.LinAlgError:
        return ArOutcome(False, None, None, float(res.ratio), float("nan"), D.shape[0], "singular Q_aa")
    length = float(np.linalg.norm(b_fix))
    ratio = float(res.ratio)
    if abs(length - known_length_m) > max_length_error_m:
        return ArOutcome(False, D, a_fix, ratio, length, D.shape[0],
                         f"length {length:.4f} m vs known {known_length_m:.4f} m")
    if min_ratio > 0 and not (ratio >= min_ratio):
        return ArOutcome(False, D, a_fix, ratio, length, D.shape[0], f"ratio {ratio:.2f} < {min_ratio:.2f}")
    return ArOutcome(True, D, a_fix, ratio, length, D.shape[0])


def round_newcomers(x: np.ndarray, P: np.ndarray, new_idx: np.ndarray, ref_idx: int, max_sigma_cyc: float,
                    max_frac_cyc: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(D rows, integer values, accepted mask) for DDs new - ref that can be fixed by rounding.

    A newcomer on a baseline already fixed is determined to a few mm by the fixed baseline; its DD float is
    rounded when its sigma < max_sigma_cyc and it lies within max_frac_cyc of an integer (bootstrapping,
    Teunissen 1998: success rate > 99.99 % for sigma < 0.08 cycles).
    """
    D = np.zeros((new_idx.size, x.size))
    D[np.arange(new_idx.size), new_idx] = 1.0
    D[:, ref_idx] -= 1.0
    d = D @ x
    var = np.einsum("ij,ij->i", D @ P, D)
    r = np.round(d)
    ok = (np.sqrt(np.maximum(var, 0.0)) < max_sigma_cyc) & (np.abs(d - r) < max_frac_cyc)
    return D[ok], r[ok], ok


def resolve_constrained(x: np.ndarray, P: np.ndarray, groups: list[tuple[np.ndarray, int]], b_idx: np.ndarray,
                        known_length_m: float, max_length_error_m: float, min_ratio: float = 3.0,
                        max_nodes: int = 50_000) -> ArOutcome:
    """ArOutcome of a baseline-constrained (C-LAMBDA) attempt over the DD ambiguities of `groups`.

    The same DD layout as `resolve_lambda`; the integer search minimises ||a_hat - a||^2_Qa +
    min_{|b| = l} ||b_hat(a) - b||^2_{Q_b|a} (Teunissen 2010, J. Geod. 84:433-447; Buist 2007) with
    worker.estimation.constrained_search. Accepted when the ratio of the constrained objective (second / best)
    reaches `min_ratio` and the integer-conditioned, unconstrained baseline passes the length test (seed 000
    Table 2), so the test still measures the data and not the constraint. The ratio cap of the search is
    max(3, 2 min_ratio): a second candidate beyond it gives a lower-bound ratio that passes.
    """
    from worker.estimation.constrained_search import constrained_search
    from worker.estimation.lambda_search import AmbiguitySearchError

    D = np.concatenate([dd_matrix(idx, ref, x.size) for idx, ref in groups if idx.size >= 2], axis=0)
    a = D @ x
    DP = D @ P
    Qa = DP @ D.T
    Qa = 0.5 * (Qa + Qa.T)
    b = x[b_idx]
    Qb = P[np.ix_(b_idx, b_idx)]
    Qab = DP[:, b_idx]
    try:
        res = constrained_search(a, Qa, b, 0.5 * (Qb + Qb.T), Qab, np.array([[known_length_m, 0.0, 0.0]]), m=2,
                                 ratio_cap=max(3.0, 2.0 * min_ratio), max_nodes=max_nodes)
    except (AmbiguitySearchError, ValueError, np.linalg.LinAlgError) as exc:
        return ArOutcome(False, None, None, float("nan"), float("nan"), D.shape[0], f"search failed: {exc}")
    a_fix = np.asarray(res.fixed[0], dtype=np.float64)
    length = float(np.linalg.norm(res.b_unconstrained_m))
    ratio = float(res.ratio)
    if abs(length - known_length_m) > max_length_error_m:
        return ArOutcome(False, D, a_fix, ratio, length, D.shape[0],
                         f"length {length:.4f} m vs known {known_length_m:.4f} m")
    if not (ratio >= min_ratio):
        return ArOutcome(False, D, a_fix, ratio, length, D.shape[0], f"constrained ratio {ratio:.2f} < {min_ratio:.2f}")
    return ArOutcome(True, D, a_fix, ratio, length, D.shape[0])
