"""Wrong fixes of an attitude solution against a reference: the one definition used by summary.json's `quality`
block, its `reference` statistics and the calibration's held-out comparison.

A wrong fix is a fixed epoch whose error on some axis is beyond WRONG_FIX_SIGMAS times its own predicted 1-sigma
on that axis and over WRONG_FIX_MIN_DEG. Fixed epochs merely over WRONG_FIX_MIN_DEG on some axis are counted
apart (`over_1deg`) and labelled "noise" where the error is within WRONG_FIX_SIGMAS sigma (the sigma says such an
error is expected), "large" otherwise.

Implements: issue 24 item 2 (the quality summary's wrong-fix definition); errors are estimate minus reference in
3-2-1 Euler angles (CONVENTIONS.md "Euler angles"), sigma the filter's formal 1-sigma per epoch and axis.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["WRONG_FIX_SIGMAS", "WRONG_FIX_MIN_DEG", "DEFINITIONS", "FixedErrorClasses", "classify_fixed_errors",
           "over_1deg_label"]

#: a fixed epoch is a wrong fix when an axis error exceeds this many of its own sigmas ...
WRONG_FIX_SIGMAS = 6.0
#: ... and this many degrees
WRONG_FIX_MIN_DEG = 1.0
#: the definitions in words, as summary.json carries them
DEFINITIONS = {
    "wrong_fix": f"fixed epoch with an axis error beyond {WRONG_FIX_SIGMAS:g} x its own predicted sigma and "
                 f"over {WRONG_FIX_MIN_DEG:g} deg",
    "over_1deg": f"fixed epochs over {WRONG_FIX_MIN_DEG:g} deg that are not wrong fixes; label noise = within the "
                 "sigma bound",
}


class FixedErrorClasses(NamedTuple):
    """Per epoch (n,): wrong fix; over 1 deg on some axis but not a wrong fix; the axis (0 yaw, 1 pitch, 2 roll)
    with the largest error in sigmas, the one a listing names."""
    wrong: np.ndarray
    over_1deg: np.ndarray
    worst_axis: np.ndarray


def classify_fixed_errors(error_deg: np.ndarray, sigma_deg: np.ndarray) -> FixedErrorClasses:
    """Classify fixed epochs by their Euler-angle errors [deg] (n, 3) and predicted 1-sigma [deg] (n, 3), see the
    module docstring; NaN errors (no reference) are neither wrong nor over 1 deg."""
    e = np.abs(np.asarray(error_deg, float).reshape(-1, 3))
    s = np.asarray(sigma_deg, float).reshape(-1, 3)
    with np.errstate(invalid="ignore"):
        big = e > WRONG_FIX_MIN_DEG
        wrong = (big & (e > WRONG_FIX_SIGMAS * s)).any(axis=1)
        ratio = np.where(np.isfinite(e), e, -1.0) / np.maximum(np.nan_to_num(s, nan=np.inf), 1e-12)
    over = big.any(axis=1) & ~wrong
    return FixedErrorClasses(wrong, over, np.argmax(ratio, axis=1) if len(e) else np.zeros(0, int))


def over_1deg_label(error_deg: float, sigma_deg: float) -> str:
    """"noise" when an error over 1 deg is within WRONG_FIX_SIGMAS of its own sigma, "large" otherwise."""
    return "noise" if abs(error_deg) <= WRONG_FIX_SIGMAS * sigma_deg else "large"
