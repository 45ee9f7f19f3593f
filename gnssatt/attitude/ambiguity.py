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

__all__ = ["ArOutcome", "dd_matrix", "first_fix_groups", "resolve_constrained", "resolve_first_fix",
           "resolve_joint_constrained", "resolve_lambda", "round_newcomers"]


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
    groups: list | None = None    # the groups this outcome fixes when not all of the attempt's (joint search)
    length_note: str = ""         # the single-epoch length (boxes.validation), appended to the fix event


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
    from gnssatt.estimation.lambda_search import AmbiguitySearchError, mlambda

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
    # D x and diag(D P D^T) from the two non-zeros of each row (D has +1 at new, -1 at ref != new): the dense
    # products D @ x, D @ P and the row sums add exact zeros to a single rounded difference, so these are the
    # same numbers without the (n_new, n) x (n, n) product
    d = x[new_idx] - x[ref_idx]
    DP_new = P[new_idx, new_idx] - P[ref_idx, new_idx]           # (D P)[i, new_i]
    DP_ref = P[new_idx, ref_idx] - P[ref_idx, ref_idx]           # (D P)[i, ref]
    var = DP_new - DP_ref
    r = np.round(d)
    ok = (np.sqrt(np.maximum(var, 0.0)) < max_sigma_cyc) & (np.abs(d - r) < max_frac_cyc)
    return D[ok], r[ok], ok


def resolve_constrained(x: np.ndarray, P: np.ndarray, groups: list[tuple[np.ndarray, int]], b_idx: np.ndarray,
                        known_length_m: float, max_length_error_m: float, min_ratio: float = 3.0,
                        max_nodes: int = 50_000) -> ArOutcome:
    """ArOutcome of a baseline-constrained (C-LAMBDA) attempt over the DD ambiguities of `groups`.

    The same DD layout as `resolve_lambda`; the integer search minimises ||a_hat - a||^2_Qa +
    min_{|b| = l} ||b_hat(a) - b||^2_{Q_b|a} (Teunissen 2010, J. Geod. 84:433-447; Buist 2007) with
    gnssatt.estimation.constrained_search. Accepted when the ratio of the constrained objective (second / best)
    reaches `min_ratio` and the integer-conditioned, unconstrained baseline passes the length test (seed 000
    Table 2), so the test still measures the data and not the constraint. The ratio cap of the search is
    max(3, 2 min_ratio): a second candidate beyond it gives a lower-bound ratio that passes.
    """
    from gnssatt.estimation.constrained_search import constrained_search
    from gnssatt.estimation.lambda_search import AmbiguitySearchError

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


def resolve_first_fix(x: np.ndarray, P: np.ndarray, groups: list[tuple[np.ndarray, int]], b_idx: np.ndarray,
                      known_length_m: float, settings) -> ArOutcome:
    """The first-fix attempt of one baseline with the search the settings ask for (``ambiguity_search``):
    ``"lambda"``: `resolve_lambda` (seed 000 sec. 2: MLAMBDA + length, ``min_ratio``); ``"constrained"``:
    `resolve_constrained` (C-LAMBDA with the known length, Teunissen 2010; ratio ``min_ratio_constrained``)."""
    ar = settings.ambiguity
    mode = ar.ambiguity_search
    if mode == "constrained":
        return resolve_constrained(x, P, groups, b_idx, known_length_m, ar.max_length_error_m,
                                   max(ar.min_ratio_constrained, ar.min_ratio))
    if mode != "lambda":
        raise ValueError(f"ambiguity_search {mode!r}: expected 'lambda' or 'constrained'")
    return resolve_lambda(x, P, groups, b_idx, known_length_m, ar.max_length_error_m, ar.min_ratio)


def first_fix_groups(idx: np.ndarray, sig: np.ndarray, elevation: np.ndarray, n_sig: int) -> list:
    """Per signal with >= 2 ambiguities: (state indices of the SD ambiguities observed now, position of the
    reference = the highest local elevation), the DD layout of a first-fix attempt of one baseline."""
    groups = []
    for f in range(n_sig):
        g = idx[sig == f]
        if g.size >= 2:
            groups.append((g, int(np.argmax(elevation[sig == f]))))
    return groups


def resolve_joint_constrained(x: np.ndarray, P: np.ndarray, groups_by_baseline: dict, b_idx: np.ndarray,
                              body_baselines_m: np.ndarray, settings) -> dict:
    """Per baseline j of ``groups_by_baseline`` (>= 2 baselines, none fixed yet): its ArOutcome of one joint
    MC-LAMBDA attempt with the body geometry known and the attitude as unknown.

    The DD float of all baselines (gnssatt.estimation.constrained_search.float_from_single_differences), the exact
    MC-LAMBDA minimiser (constrained_search_by_baselines: Teunissen 2007; Giorgi et al. 2010), accepted for all
    baselines together when the ratio of the constrained objective reaches
    ``settings.ambiguity.min_ratio_constrained_joint``, every integer-conditioned baseline b_hat(a) passes the length
    test and every pair the angle test (``settings.ambiguity.max_length_error_m`` / ``max_angle_error_m``, widened to
    3 sigma of b_hat(a) where that is larger: gnssatt.estimation.ar_validation.geometric_tolerance_m). The same search and validation as the epoch-wise
    ``epoch-constrained`` method of the ttff study (docs/ttff.md). With several signals and no acceptance, the
    first signal's groups alone are tried (the outcome's ``groups`` then names them).
    """

    out = _joint_constrained(x, P, groups_by_baseline, b_idx, body_baselines_m, settings)
    if not next(iter(out.values())).accepted and all(len(g) > 1 for g in groups_by_baseline.values()):
        # several signals and not accepted: the first signal alone (its weaker partners then follow as newcomers
        # of a fixed baseline); the same first-signal fallback as gnssatt.ttff.single_epoch
        first = {j: g[:1] for j, g in groups_by_baseline.items()}
        out1 = _joint_constrained(x, P, first, b_idx, body_baselines_m, settings)
        if next(iter(out1.values())).accepted:
            for j, o in out1.items():
                o.groups = first[j]
            return out1
    return out


def _joint_constrained(x, P, groups_by_baseline, b_idx, body_baselines_m, settings) -> dict:
    from gnssatt.estimation.ar_validation import baseline_angle_test, baseline_length_test
    from gnssatt.estimation.constrained_search import (
        DDBlock, constrained_search_by_baselines, float_from_single_differences,
    )
    from gnssatt.estimation.lambda_search import AmbiguitySearchError
    from gnssatt.estimation.ar_validation import geometric_tolerance_m

    use = sorted(groups_by_baseline)
    Ds, blocks, sd_idx, refs, rows, off = {}, [], [], [], [], 0
    for pos, j in enumerate(use):
        gs = [(g, r) for g, r in groups_by_baseline[j] if g.size >= 2]
        Ds[j] = np.concatenate([dd_matrix(g, r, x.size) for g, r in gs], axis=0)
        start = off
        for g, r in gs:
            blocks.append(DDBlock(pos, str(len(blocks)), 1.0, tuple(int(v) for v in np.delete(g, r)), int(g[r]),
                                  np.zeros((g.size - 1, 3))))
            sd_idx.append(g)
            refs.append(r)
            off += g.size - 1
        rows.append(np.arange(start, off))
    F = np.asarray(body_baselines_m, float)[use]
    sol = float_from_single_differences(x, P, sd_idx, [b_idx[j] for j in use], blocks, refs)
    nan = float("nan")
    try:
        res = constrained_search_by_baselines(sol.a_float_cyc, 0.5 * (sol.Q_a + sol.Q_a.T), sol.b_float_m,
                                              0.5 * (sol.Q_b + sol.Q_b.T), sol.Q_ab, F, rows,
                                              ratio_cap=max(2.0, 1.34 * settings.ambiguity.min_ratio_constrained_joint),
                                              max_nodes=50_000)
    except (AmbiguitySearchError, ValueError, np.linalg.LinAlgError) as exc:
        return {j: ArOutcome(False, Ds[j], None, nan, nan, Ds[j].shape[0], f"MC-LAMBDA failed: {str(exc)[:80]}")
                for j in use}
    B = res.b_unconstrained_m.reshape(-1, 3)
    tol = geometric_tolerance_m(sol, settings.ambiguity.max_length_error_m, 3.0)
    _, len_ok = baseline_length_test(B, np.linalg.norm(F, axis=1), tol)
    ar = settings.ambiguity
    ang_tol = tol * (max(ar.max_angle_error_m, 2.0 * ar.max_length_error_m) / ar.max_length_error_m)
    _, ang_ok = baseline_angle_test(B, F, tol_m=ang_tol)
    ratio = float(res.ratio)
    why = []
    if not ratio >= settings.ambiguity.min_ratio_constrained_joint:
        why.append(f"joint constrained ratio {ratio:.2f} < {settings.ambiguity.min_ratio_constrained_joint:.2f}")
    if not np.all(len_ok):
        why.append("length of b_hat(a) " + ", ".join(f"{np.linalg.norm(b):.4f}" for b in B) + " m")
    if not np.all(ang_ok):
        why.append("angle between the baselines")
    out = {}
    for pos, j in enumerate(use):
        out[j] = ArOutcome(not why, Ds[j], res.fixed[0][rows[pos]].astype(np.float64), ratio,
                           float(np.linalg.norm(B[pos])), Ds[j].shape[0], "; ".join(why))
    return out
