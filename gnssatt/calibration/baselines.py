"""Baseline calibration (seed 000 sec. 3.1): epoch-wise baselines rotated into the body frame with the reference
attitude, averaged with weights over all epochs of all sets, with an honest sigma; Table 3 rows and products.

Reduction in two stages so that a campaign fans out: each set is cut into time batches (default 300 s, never
spanning two sets) and reduced to per-batch sums (sum of weights, sum of weighted values, per component); the
campaign adds the batches of all sets in set order. The weighted mean is M = sum W_b m_b / sum W_b.

Sigma. The formal sigma 1/sqrt(sum w) assumes independent epochs; epoch-wise baselines are not (multipath with a
60 s correlation time, PCV along slowly moving lines of sight), so it is far too optimistic. The reported sigma is
the batch-means (cluster-robust) estimate
    var(M) = n_b / (n_b - 1) * sum_b W_b^2 (m_b - M)^2 / (sum_b W_b)^2,
which holds for any correlation shorter than a batch; the formal value is reported alongside.

Implements: seed 000 sec. 3.1 and Table 3; batch means: Law & Kelton, "Simulation Modeling and Analysis", sec.
9.5.3; the weighted cluster-robust variance of a weighted mean (Cameron & Miller 2015, J. Human Resources 50(2),
eq. for the sandwich estimator with one regressor). Neglects: correlation between batches (batches of 300 s are
5 correlation times of the simulator's multipath).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DEFAULT_BATCH_S = 300.0
DEFAULT_MAX_DEVIATION_M = 0.05  # an epoch-wise baseline 5 cm off the a priori is a wrong fix, not a calibration


def body_from_ecef(b_ecef_m: np.ndarray, cov_ecef_m2: np.ndarray | None, R_body_from_ecef: np.ndarray):
    """(b_body_m (..., 3), cov_body_m2 (..., 3, 3) or None) of ECEF baselines rotated into the body frame.

    Args:
        b_ecef_m: (n_ep, n_bl, 3) or (n_ep, 3) baselines in ECEF, m.
        cov_ecef_m2: matching (..., 3, 3) covariance in ECEF, m^2, or None.
        R_body_from_ecef: (n_ep, 3, 3) attitude (reference) at the same epochs.
    Implements: b_body = R b_ecef; C_body = R C_ecef R^T.
    """
    R = np.asarray(R_body_from_ecef, dtype=np.float64)
    b = np.asarray(b_ecef_m, dtype=np.float64)
    if b.ndim == 3:
        R = R[:, None]
    b_body = np.einsum("...ij,...j->...i", R, b)
    if cov_ecef_m2 is None:
        return b_body, None
    cov = np.einsum("...ij,...jk,...lk->...il", R, np.asarray(cov_ecef_m2, dtype=np.float64), R)
    return b_body, cov


@dataclass
class BatchSums:
    """Per-batch sums of one baseline (additive over sets: concatenate in set order).

    n_epochs: (n_b,) int; sum_w: (n_b, 3) sum of weights 1/sigma^2 (m^-2); sum_wx: (n_b, 3) (m^-1).
    """

    n_epochs: np.ndarray
    sum_w: np.ndarray
    sum_wx: np.ndarray

    @classmethod
    def empty(cls) -> "BatchSums":
        return cls(np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)))

    @classmethod
    def concatenate(cls, parts: list["BatchSums"]) -> "BatchSums":
        """One BatchSums of several, in the given order (the campaign's set order)."""
        if not parts:
            return cls.empty()
        return cls(np.concatenate([p.n_epochs for p in parts]), np.concatenate([p.sum_w for p in parts]),
                   np.concatenate([p.sum_wx for p in parts]))


def batch_sums(t_s: np.ndarray, x_m: np.ndarray, sigma_m: np.ndarray, batch_s: float = DEFAULT_BATCH_S) -> BatchSums:
    """BatchSums of epoch-wise body-frame baselines of one set.

    Args:
        t_s: (n,) epoch times, s (any origin), increasing.
        x_m: (n, 3) body-frame baseline, m; rows with NaN are skipped.
        sigma_m: (n, 3) per-component 1-sigma, m (weights 1/sigma^2).
        batch_s: batch length, s; batch k holds t in [t0 + k batch_s, t0 + (k+1) batch_s).
    """
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(x_m, dtype=np.float64)
    s = np.asarray(sigma_m, dtype=np.float64)
    ok = np.isfinite(x).all(-1) & np.isfinite(s).all(-1) & (s > 0).all(-1)
    if not np.any(ok):
        return BatchSums.empty()
    t, x, s = t[ok], x[ok], s[ok]
    k = np.floor((t - t[0]) / batch_s).astype(np.int64)
    uniq, inv = np.unique(k, return_inverse=True)
    w = 1.0 / (s * s)
    n_b = len(uniq)
    sum_w = np.stack([np.bincount(inv, weights=w[:, c], minlength=n_b) for c in range(3)], axis=-1)
    sum_wx = np.stack([np.bincount(inv, weights=w[:, c] * x[:, c], minlength=n_b) for c in range(3)], axis=-1)
    return BatchSums(np.bincount(inv, minlength=n_b).astype(np.int64), sum_w, sum_wx)


@dataclass
class BaselineEstimate:
    """Weighted mean of one baseline over a campaign.

    mean_m, sigma_m (batch means, the reported sigma), sigma_formal_m: (3,) body frame, m.
    n_epochs, n_batches: counts used.
    """

    mean_m: np.ndarray
    sigma_m: np.ndarray
    sigma_formal_m: np.ndarray
    n_epochs: int
    n_batches: int


def combine(sums: BatchSums) -> BaselineEstimate:
    """BaselineEstimate of all batches (see the module docstring for the sigma). NaN with fewer than 2 batches."""
    W = sums.sum_w.sum(axis=0)
    if sums.sum_w.shape[0] == 0 or not np.all(W > 0):
        nan = np.full(3, np.nan)
        return BaselineEstimate(nan, nan, nan, int(sums.n_epochs.sum()), int(len(sums.n_epochs)))
    mean = sums.sum_wx.sum(axis=0) / W
    formal = 1.0 / np.sqrt(W)
    nb = sums.sum_w.shape[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        m_b = sums.sum_wx / sums.sum_w
    if nb >= 2:
        var = nb / (nb - 1) * np.sum(sums.sum_w ** 2 * (m_b - mean) ** 2, axis=0) / W ** 2
        sigma = np.sqrt(var)
    else:
        sigma = np.full(3, np.nan)
    return BaselineEstimate(mean, sigma, formal, int(sums.n_epochs.sum()), nb)


def gate_epochs(b_body_m: np.ndarray, apriori_body_m: np.ndarray,
                max_deviation_m: float = DEFAULT_MAX_DEVIATION_M) -> np.ndarray:
    """(n,) bool: epochs whose body-frame baseline lies within max_deviation_m of the a priori in every component.

    An epoch-wise baseline centimetres off the drawing is a wrong integer fix or a bad reference epoch; the
    calibrations of seed 000 Table 3 move components by < 1 cm.
    """
    d = np.abs(np.asarray(b_body_m) - np.asarray(apriori_body_m))
    return np.isfinite(d).all(-1) & (d <= max_deviation_m).all(-1)


# --- products ----------------------------------------------------------------------------------------

@dataclass
class BaselineRow:
    first: str
    second: str
    a_priori_m: np.ndarray
    estimate: BaselineEstimate
    n_sets: int = 0
    split: dict | None = None  # the baseline/map split and the sky it was made over (campaign.split_baselines)


def baselines_document(platform: str, rows: list[BaselineRow]) -> dict:
    """baselines.json (CONVENTIONS.md "Output: calibrated baselines"), with extra keys sigma_formal_m, n_batches,
    n_sets and (when the split was made) `split`, the part of the sky the split was made over, after the fixed
    ones."""
    out = []
    for r in rows:
        e = r.estimate
        out.append({"from": r.first, "to": r.second,
                    "a_priori_m": [round(float(v), 6) for v in r.a_priori_m],
                    "calibrated_m": [round(float(v), 7) for v in e.mean_m],
                    "sigma_m": [round(float(v), 7) for v in e.sigma_m],
                    "n_epochs": int(e.n_epochs),
                    "sigma_formal_m": [round(float(v), 8) for v in e.sigma_formal_m],
                    "n_batches": int(e.n_batches), "n_sets": int(r.n_sets)})
        if r.split is not None:
            out[-1]["split"] = r.split
    return {"platform": platform, "frames": "body", "baselines": out}


def baselines_table_csv(rows: list[BaselineRow]) -> str:
    """baselines.csv in the layout of seed 000 Table 3: rows a_priori, calibrated, difference, sigma,
    sigma_formal (mm); one column per baseline and body component (e.g. `GPS-2>GPS-0_x_mm`)."""
    cols = [f"{r.first}>{r.second}_{c}_mm" for r in rows for c in "xyz"]
    lines = ["row," + ",".join(cols)]

    def line(name, vecs):
        lines.append(name + "," + ",".join(f"{v * 1e3:.3f}" for vec in vecs for v in vec))

    line("a_priori", [r.a_priori_m for r in rows])
    line("calibrated", [r.estimate.mean_m for r in rows])
    line("difference", [r.estimate.mean_m - r.a_priori_m for r in rows])
    line("sigma", [r.estimate.sigma_m for r in rows])
    line("sigma_formal", [r.estimate.sigma_formal_m for r in rows])
    lines.append("n_epochs," + ",".join(str(r.estimate.n_epochs) for r in rows for _ in "xyz"))
    return "\n".join(lines) + "\n"


__all__ = ["body_from_ecef", "BatchSums", "batch_sums", "BaselineEstimate", "combine", "gate_epochs",
           "BaselineRow", "baselines_document", "baselines_table_csv", "DEFAULT_BATCH_S"]
