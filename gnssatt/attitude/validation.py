"""Extra validation of a first integer fix of a baseline, beyond seed 000's length test (gnssatt.attitude.ambiguity):
the ratio of the two best MLAMBDA candidates and the angle between the candidate's fixed baseline and every other
baseline already fixed, against the same angle in the body frame.

Why: on the realistic earth-pointing preset (C/N0-dependent noise, multipath) a 6-DD MLAMBDA candidate with ratio
1.4 passed the 3 cm length test with wrong integers (attitude error 57 deg, caught by the residual monitor only
8 epochs later). A wrong integer vector moves the baseline direction by about lambda / l rad (~10 deg at 1 m);
the sphere |b| = l of the length test does not see a direction error, the angle to a fixed partner does.

Implements: Teunissen (1995) eq. 4 (b_fix = b - Q_ba Q_aa^-1 (a - a_fix)); the inter-baseline angle test of
gnssatt.estimation.ar_validation.baseline_angle_test (tolerance atan(tol_m / l_min)); the ratio test
(Euler & Schaffrin 1991, RTKLIB's sqnorm2 / sqnorm1).
"""
from __future__ import annotations

import numpy as np

from gnssatt.estimation.ar_validation import baseline_angle_test

__all__ = ["fixed_baseline_vector", "angle_test_against_fixed"]


def fixed_baseline_vector(x: np.ndarray, P: np.ndarray, D: np.ndarray, a_fix: np.ndarray,
                          b_idx: np.ndarray) -> np.ndarray:
    """The baseline (3,) m, state frame (ECEF), conditioned on the DD integers a_fix (n_dd,) of rows D (n_dd, n).

    Args:
        x, P: filter state and covariance; b_idx: (3,) state indices of the baseline.
    """
    a = D @ x
    DP = D @ P
    Qa = DP @ D.T
    Qa = 0.5 * (Qa + Qa.T)
    return x[b_idx] - DP[:, b_idx].T @ np.linalg.solve(Qa, a - a_fix)


def angle_test_against_fixed(b_cand_m: np.ndarray, body_cand_m: np.ndarray, b_fixed_m: np.ndarray,
                             body_fixed_m: np.ndarray, tol_m: float) -> tuple[bool, float]:
    """(passed, worst |angle error| deg) of a candidate baseline against the baselines already fixed.

    Args:
        b_cand_m: (3,) candidate fixed baseline (ECEF); body_cand_m: (3,) the same baseline in the body frame.
        b_fixed_m: (m, 3) baselines already fixed (ECEF); body_fixed_m: (m, 3) in the body frame. m = 0: passes.
        tol_m: the length tolerance that sets the angle tolerance atan(tol_m / l_min) per pair.
    """
    worst = 0.0
    ok = True
    for bf, ff in zip(np.atleast_2d(b_fixed_m), np.atleast_2d(body_fixed_m)):
        if not np.all(np.isfinite(bf)):
            continue
        err, passed = baseline_angle_test(np.stack([b_cand_m, bf]), np.stack([body_cand_m, ff]), tol_m=tol_m)
        worst = max(worst, float(abs(err[0])))
        ok = ok and bool(passed[0])
    return ok, worst
