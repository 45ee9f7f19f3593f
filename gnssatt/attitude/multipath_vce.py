"""Variance component of the time-correlated phase error from the lag-1 autocovariance of post-fit residuals.

The phase error of one SD is white noise w (independent between epochs; its variance is what the triple differences
estimate) plus a slowly varying part m (multipath, uncalibrated PCV at the passing geometry; a Gauss-Markov process
of tau ~60 s: rho(1 epoch) = exp(-dt / tau) ~ 1). The filter models var(m) = s x v_mp (v_mp the configured
off-boresight profile); s is the variance component sought. A product of one SD's post-fit residuals at two
consecutive epochs holds no white noise at all, so (Helmert-type variance-component estimation, with the lag-1
product as the quadratic form; e.g. Koch 1999, Parameter Estimation and Hypothesis Testing, sec. 3.6, and the
autocovariance least squares of Odelson, Rajamani & Rawlings 2006, Automatica 42, 303):

    r_k = M_k e_k,   M_k = I - A_k (A_k^T W_k A_k)^+ A_k^T W_k
    E[sum_i r_k,i r_k-1,i] = s x sum_{i, j} (M_k)_ij (M_k-1)_ij v_mp,j        (i, j: fixed rows of both epochs)

A_k: the epoch's fixed phase rows' columns that absorb a slowly varying error (baseline, phase clock; the ambiguity
is fixed), W_k = 1 / the filter's variances: the share of m an epoch-by-epoch solution takes into the state. The
estimate s = sum(products) / sum(expected per unit s), the sums averaged over an exponential memory, is:
- unbiased whatever the white variance and whatever R the filter assumes (W enters only M, the absorbed share);
- zero in expectation on white-noise data (the clean passes: no multipath);
- biased low by rho(1) (1.7 % for tau = 60 s at 1 Hz), and high by up to 1 / (1 - absorbed share) where a dynamic
  filter absorbs less of m than an epoch-by-epoch solution (measured on the simulator's Gauss-Markov multipath alone,
  truth 0.98: 0.97 kinematic, 1.06 dynamic over 30 minutes; tests/attitude/test_multipath_vce.py).
The lag-0 sums then give the white part as a diagnostic (summary.json noise_model "white_phase_scale_residuals"):
E[sum_i r_k,i^2] = s_w x sum_ij (M_k)_ij^2 v_white,j + s x sum_ij (M_k)_ij^2 v_mp,j, s_w the white variance over
the filter's (1: the triple differences' estimate is right); for epoch-by-epoch solutions (kinematic mode) high
only by the correlated variance's 1 - rho(1), in dynamic mode also where the filter absorbs less noise than M.
Measured (seed-0 106-min passes, kinematic / dynamic): clean 1.07 / 1.19 (the simulator's white variance over the
triple differences' estimate: 1.13), slew 1.12 / 1.30, realistic 0.88 / 0.97, hard 0.87 / 0.98.

The leverage formula (multipath_adaptive_method "leverage", gnssatt.attitude.reference_update.multipath_scale_sums)
solves E[r^2] = R (1 - h) for s instead, which holds only where the filter's R is right (docs/attitude.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LagEpoch", "residual_maker", "lag_epoch", "lag1_sums", "lag0_sums", "MultipathVce"]


@dataclass
class LagEpoch:
    """One epoch's fixed phase rows as the lag-1 sums need them."""
    t_s: float
    key: np.ndarray        # (n,) int64 the rows' arcs, e.g. (baseline, satellite, signal) codes
    resid_m: np.ndarray    # (n,) post-fit residuals (m)
    v_mp_m2: np.ndarray    # (n,) configured correlated variance v_mp (m^2, before any scale)
    M: np.ndarray          # (n, n) residual maker I - A (A^T W A)^+ A^T W
    v_white_m2: np.ndarray | None = None   # (n,) the filter's white variance (m^2), for the lag-0 sums


def residual_maker(A: np.ndarray, var_m2: np.ndarray) -> np.ndarray:
    """(n, n) M = I - A (A^T W A)^+ A^T W, W = diag(1 / var_m2): the residuals of a weighted least-squares fit of
    the columns A (n, p) to e are M e (pseudo-inverse: a rank-deficient A absorbs what it can)."""
    w = 1.0 / var_m2
    AtW = A.T * w[None, :]
    N = AtW @ A
    try:
        X = np.linalg.solve(N, AtW)
    except np.linalg.LinAlgError:
        X = np.linalg.pinv(N) @ AtW
    return np.eye(A.shape[0]) - A @ X


def lag_epoch(t_s: float, key: np.ndarray, cols: np.ndarray, coef: np.ndarray, var_m2: np.ndarray,
              v_mp_m2: np.ndarray, post_m: np.ndarray, sel: np.ndarray, mp_mult: float = 0.0) -> LagEpoch:
    """The LagEpoch of the rows sel of an update (update_records.UpdateOutputs: cols / coef (m, 5), columns 0..3
    baseline and phase clock), key (m,) int64 the rows' arcs (unique within an epoch): A the dense columns 0..3 of
    those rows; the white variance var - mp_mult x v_mp (mp_mult the update's multipath multiplier)."""
    rows = np.flatnonzero(sel)
    c, a = cols[rows, :4], coef[rows, :4]
    uniq, inv = np.unique(c, return_inverse=True)          # phase rows: every one of the 4 columns is set
    A = np.zeros((rows.size, uniq.size))
    A[np.repeat(np.arange(rows.size), 4), inv.ravel()] = a.ravel()        # the 4 columns of a row differ
    return LagEpoch(float(t_s), key[rows].astype(np.int64), post_m[rows].copy(), v_mp_m2[rows].copy(),
                    residual_maker(A, var_m2[rows]), var_m2[rows] - mp_mult * v_mp_m2[rows])


def lag0_sums(cur: LagEpoch) -> tuple[float, float, float]:
    """(sum r_i^2, sum_ij M_ij^2 v_white,j, sum_ij M_ij^2 v_mp,j) of one epoch (module doc)."""
    M2 = cur.M * cur.M
    return float(np.dot(cur.resid_m, cur.resid_m)), float(np.sum(M2 @ cur.v_white_m2)), float(np.sum(M2 @ cur.v_mp_m2))


def lag1_sums(prev: LagEpoch, cur: LagEpoch) -> tuple[float, float, int]:
    """(sum r_k,i r_k-1,i, sum_{i,j} (M_k)_ij (M_k-1)_ij v_mp,j, pairs) over the rows (arcs) of both epochs (module
    doc: the first sum's expectation is s x the second)."""
    common, ia, ib = np.intersect1d(cur.key, prev.key, assume_unique=True, return_indices=True)
    if not common.size:
        return 0.0, 0.0, 0
    num = float(np.dot(cur.resid_m[ia], prev.resid_m[ib]))
    den = float(np.sum(cur.M[np.ix_(ia, ia)] * prev.M[np.ix_(ib, ib)] * cur.v_mp_m2[ia][None, :]))
    return num, den, int(common.size)


class MultipathVce:
    """The running estimate of s (module doc): the two lag-1 sums averaged with weight 1 / min(epochs + 1,
    memory_epochs), s = their ratio clipped to [s_min, s_max]; epochs further apart than max_dt_s or with fewer
    than min_pairs pairs are skipped."""

    def __init__(self, memory_epochs: float, s_min: float, s_max: float, max_dt_s: float, min_pairs: int = 6):
        self.memory, self.s_min, self.s_max, self.max_dt_s, self.min_pairs = (memory_epochs, s_min, s_max,
                                                                              max_dt_s, min_pairs)
        self.num = self.den = 0.0
        self.n_ep = 0
        self.prev: LagEpoch | None = None
        self.sq = np.zeros(3)          # averaged lag-0 sums (lag0_sums), same weights

    def add(self, cur: LagEpoch) -> bool:
        """Add one epoch (a LagEpoch, or None: the arcs break); True when the sums changed."""
        prev, self.prev = self.prev, cur
        if prev is None or cur is None or not 0 < cur.t_s - prev.t_s <= self.max_dt_s:
            return False
        num, den, n = lag1_sums(prev, cur)
        if n < self.min_pairs or den <= 0:
            return False
        a = 1.0 / min(self.n_ep + 1.0, self.memory)
        self.num += a * (num - self.num)
        self.den += a * (den - self.den)
        if cur.v_white_m2 is not None:
            self.sq += a * (np.array(lag0_sums(cur)) - self.sq)
        self.n_ep += 1
        return True

    def white_scale(self) -> float | None:
        """s_w of the module doc from the averaged sums (with the clipped s), or None before any epoch."""
        if self.n_ep == 0 or self.sq[1] <= 0:
            return None
        return float((self.sq[0] - self.scale(0.0) * self.sq[2]) / self.sq[1])

    def scale(self, default: float) -> float:
        """The estimate s, or default before any epoch was added."""
        if self.n_ep == 0 or self.den <= 0:
            return default
        return float(min(max(self.num / self.den, self.s_min), self.s_max))

    def state(self) -> dict:
        """The averaged sums and their count (a second pass starts from them; the arcs restart)."""
        return {"num": self.num, "den": self.den, "n_ep": self.n_ep, "sq": self.sq.copy()}

    def start_from(self, state: dict) -> None:
        """Continue from state()."""
        self.num, self.den, self.n_ep, self.prev = float(state["num"]), float(state["den"]), int(state["n_ep"]), None
        self.sq = np.array(state["sq"], float)
