"""Differential PCV maps (seed 000 sec. 3.2): single-difference phase residuals with the calibrated baselines,
binned in the antenna frame of the baseline's first antenna, iterated with the previous map applied.

Samples. For one baseline and frequency, a `FixedPhases` table holds every single-difference carrier phase with
its ambiguity fixed (so in metres, no integer left), on the model
    y_i = -g_i . b_body + c_e(i) + PCV(az_i, el_i) + noise,
g_i the unit line of sight in the body frame (reference attitude), b_body the baseline, c_e one differential
clock per epoch (it also absorbs the receivers' fractional phase biases). The residual of a sample for a
baseline b and a map m (applied by subtracting it from the single difference, CONVENTIONS.md) is
    r_i = y_i + g_i . b - m(bin_i) - c_e,   c_e = sum_{j in e} w_j (y_j + g_j . b - m(bin_j)) / W_e.

Iteration. The bin mean of the residuals is linear in b and in the map:
    rho_B(b, m) = [s0_B + G_B . b - W_B m_B + (C m)_B] / W_B,
with s0_B = sum_{i in B} w_i (y_i - ybar_e), G_B = sum_{i in B} w_i (g_i - gbar_e), W_B = sum_{i in B} w_i and
C_{B,B'} = sum_e (sum_{i in B, e} w_i)(sum_{j in B', e} w_j) / W_e. Each set reduces its samples to these
additive statistics once (`MapNormal`), and "recompute the residuals with the previous map applied, average
them per bin, add to the map" (seed 000: the previous map "used for the computation of the residuals and then
also as a priori information") is then exactly m <- m + rho(b, m) on the bins with enough samples, repeated
until the update is < tolerance RMS or after max_iterations; no set is read again per iteration. Bins below
min_count keep no value (0 applied, null in the product). The map's datum is the weighted mean over the samples
(the per-epoch clock takes any constant): sum_B W_B rho_B = 0.

Implements: seed 000 sec. 3.2 (1 deg x 2.5 deg bins, iterations with the previous map applied); CONVENTIONS.md
PCV map sign (subtract from the second-minus-first single difference).
Neglects: a change of the fixed integers between iterations (they are fixed once per set from the a priori model
and gated), so the iteration is the linear one above.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from gnssatt.calibration.binning import BinSums, Grid2D, accumulate

DEFAULT_TOLERANCE_MM = 0.1
DEFAULT_MAX_ITERATIONS = 10


@dataclass
class FixedPhases:
    """Fixed single-difference phases of one baseline and frequency in one set (n samples).

    epoch: (n,) int epoch index (one clock per epoch); sat: (n,) int satellite index (cluster id for sigmas);
    y_m: (n,) single difference minus the fixed ambiguity, m; g_body: (n, 3) unit line of sight, body frame;
    az_deg, el_deg: (n,) in the antenna frame of the baseline's first antenna; weight: (n,) 1/sigma^2, m^-2.
    """

    epoch: np.ndarray
    sat: np.ndarray
    y_m: np.ndarray
    g_body: np.ndarray
    az_deg: np.ndarray
    el_deg: np.ndarray
    weight: np.ndarray

    def __len__(self) -> int:
        return len(self.y_m)

    def subset(self, keep: np.ndarray) -> "FixedPhases":
        return FixedPhases(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))


def _epoch_groups(epoch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inverse index into unique epochs, number of unique epochs)."""
    uniq, inv = np.unique(epoch, return_inverse=True)
    return inv, len(uniq)


def epoch_mean(values: np.ndarray, weight: np.ndarray, epoch: np.ndarray) -> np.ndarray:
    """(n, ...) weighted mean over the samples of each sample's epoch, broadcast back to the samples."""
    inv, n_e = _epoch_groups(epoch)
    W = np.bincount(inv, weights=weight, minlength=n_e)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        return (np.bincount(inv, weights=weight * v, minlength=n_e) / W)[inv]
    cols = [np.bincount(inv, weights=weight * v[:, k], minlength=n_e) / W for k in range(v.shape[1])]
    return np.stack(cols, axis=-1)[inv]


def residuals_m(fp: FixedPhases, b_body_m: np.ndarray, map_m: np.ndarray | None = None) -> np.ndarray:
    """(n,) residuals r_i = y_i + g_i . b - m_i - c_e (see the module docstring), m.

    Args:
        b_body_m: (3,) baseline in the body frame, m.
        map_m: (n,) map value applied to each sample, m (0 where the map is empty), or None.
    """
    z = fp.y_m + fp.g_body @ np.asarray(b_body_m, dtype=np.float64)
    if map_m is not None:
        z = z - map_m
    return z - epoch_mean(z, fp.weight, fp.epoch)


def map_lookup(grid: Grid2D, values: np.ndarray, az_deg, el_deg) -> np.ndarray:
    """Map value (...,) of the bin holding each (az, el); 0 outside the grid and in empty (NaN) bins.

    Args: values (n_y, n_x) or flat (n_bins,), any unit (returned in the same).
    """
    flat = np.asarray(values, dtype=np.float64).ravel()
    idx = grid.index(az_deg, el_deg)
    out = np.where(idx >= 0, flat[np.maximum(idx, 0)], 0.0)
    return np.where(np.isfinite(out), out, 0.0)


@dataclass
class MapNormal:
    """Additive statistics of one baseline/frequency for the map iteration (see the module docstring).

    s0: (n_bins,) m^-1; G: (n_bins, 3) m^-2 (unit LOS times weight); W: (n_bins,) m^-2; count: (n_bins,) int;
    C: (n_bins, n_bins) scipy CSR, m^-2.
    """

    s0: np.ndarray
    G: np.ndarray
    W: np.ndarray
    count: np.ndarray
    C: sp.csr_matrix

    @classmethod
    def zeros(cls, n_bins: int) -> "MapNormal":
        return cls(np.zeros(n_bins), np.zeros((n_bins, 3)), np.zeros(n_bins), np.zeros(n_bins, np.int64),
                   sp.csr_matrix((n_bins, n_bins)))

    def __add__(self, other: "MapNormal") -> "MapNormal":
        return MapNormal(self.s0 + other.s0, self.G + other.G, self.W + other.W, self.count + other.count,
                         (self.C + other.C).tocsr())

    @classmethod
    def total(cls, parts: list["MapNormal"], n_bins: int) -> "MapNormal":
        """Sum in the given order (deterministic)."""
        out = cls.zeros(n_bins)
        for p in parts:
            out = out + p
        return out

    def mean_residual_m(self, b_body_m: np.ndarray, map_flat_m: np.ndarray) -> np.ndarray:
        """(n_bins,) bin-mean residual rho_B(b, m), m; NaN where W_B = 0."""
        num = self.s0 + self.G @ np.asarray(b_body_m, dtype=np.float64) - self.W * map_flat_m + self.C @ map_flat_m
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.W > 0, num / np.where(self.W > 0, self.W, 1.0), np.nan)


def map_normal(grid: Grid2D, fp: FixedPhases) -> MapNormal:
    """MapNormal of one set's samples of one baseline/frequency. Samples outside the grid count in the epoch
    means (their clock) but have no bin."""
    n_bins = grid.n_bins
    if len(fp) == 0:
        return MapNormal.zeros(n_bins)
    w = fp.weight
    bins = grid.index(fp.az_deg, fp.el_deg)
    y_t = fp.y_m - epoch_mean(fp.y_m, w, fp.epoch)
    g_t = fp.g_body - epoch_mean(fp.g_body, w, fp.epoch)
    inb = bins >= 0
    bi = bins[inb]
    s0 = np.bincount(bi, weights=(w * y_t)[inb], minlength=n_bins)
    G = np.stack([np.bincount(bi, weights=(w * g_t[:, k])[inb], minlength=n_bins) for k in range(3)], axis=-1)
    W = np.bincount(bi, weights=w[inb], minlength=n_bins)
    count = np.bincount(bi, minlength=n_bins).astype(np.int64)
    # C: all pairs of in-grid samples sharing an epoch, value w_i w_j / W_e
    inv, n_e = _epoch_groups(fp.epoch)
    W_e = np.bincount(inv, weights=w, minlength=n_e)
    sel = np.flatnonzero(inb)
    order = sel[np.argsort(inv[sel], kind="stable")]
    g_of = inv[order]
    k_e = np.bincount(g_of, minlength=n_e)
    start_e = np.concatenate([[0], np.cumsum(k_e)[:-1]])
    k_i = k_e[g_of]  # partners of each sample (itself included)
    rows = np.repeat(np.arange(len(order)), k_i)
    block_start = np.repeat(np.cumsum(k_i) - k_i, k_i)
    cols = np.repeat(start_e[g_of], k_i) + (np.arange(len(rows)) - block_start)
    oi, oj = order[rows], order[cols]
    vals = w[oi] * w[oj] / W_e[inv[oi]]
    keys = bins[oi] * np.int64(n_bins) + bins[oj]
    uniq, kinv = np.unique(keys, return_inverse=True)
    summed = np.bincount(kinv, weights=vals, minlength=len(uniq))
    C = sp.csr_matrix((summed, (uniq // n_bins, uniq % n_bins)), shape=(n_bins, n_bins))
    return MapNormal(s0, G, W, count, C)


@dataclass
class IterationResult:
    """Map (n_bins,) m (NaN on inactive bins), the RMS change of every iteration (mm), whether it converged."""

    map_m: np.ndarray
    changes_mm: list = field(default_factory=list)
    converged: bool = False
    active: np.ndarray | None = None


def solve_map(normal: MapNormal, b_body_m: np.ndarray, active: np.ndarray, *, rtol: float = 1e-10,
              max_cg: int = 5000) -> np.ndarray:
    """(n_bins,) the fixed point of the iteration (rho = 0 on the active bins, 0 elsewhere), m, by preconditioned
    conjugate gradients on (diag W - C)_AA m_A = (s0 + G b)_A, datum: weighted mean 0.

    The plain iteration m <- m + rho is Jacobi on this symmetric system: it removes most of the map in a few steps
    but its slowest modes (large-scale patterns, half of which look like a baseline change) shrink by only ~0.8
    per step, so stopping when the step is < 0.1 mm RMS can leave ~0.5 mm of a coherent pattern. CG converges
    on them; iterate_map then starts from this solution and shows the remaining step.
    Implements: conjugate gradients with a Jacobi preconditioner (Saad 2003, alg. 9.1) on the normal equations
    of the module docstring.
    """
    from scipy.sparse.linalg import LinearOperator, cg

    idx = np.flatnonzero(active & (normal.W > 0))
    out = np.zeros(len(normal.W))
    if idx.size == 0:
        return out
    A = (sp.diags(normal.W[idx]) - normal.C[idx][:, idx]).tocsr()
    rhs = normal.s0[idx] + normal.G[idx] @ np.asarray(b_body_m, dtype=np.float64)
    d = np.asarray(A.diagonal())
    d = np.where(d > 0, d, 1.0)
    M = LinearOperator(A.shape, matvec=lambda v: v / d, dtype=np.float64)
    x, _ = cg(A, rhs, M=M, rtol=rtol, atol=0.0, maxiter=max_cg)
    x = x - np.sum(normal.W[idx] * x) / np.sum(normal.W[idx])
    out[idx] = x
    return out


def iterate_map(normal: MapNormal, b_body_m: np.ndarray, active: np.ndarray, *,
                tolerance_mm: float = DEFAULT_TOLERANCE_MM, max_iterations: int = DEFAULT_MAX_ITERATIONS,
                initial_m: np.ndarray | None = None) -> IterationResult:
    """IterationResult of m <- m + rho(b, m) on the `active` bins (module docstring), from `initial_m` (0).

    Stops when the RMS of the update over the active bins is below tolerance_mm, or after max_iterations.
    Implements: seed 000 sec. 3.2 iteration; the stopping rule of issue 8 (< 0.1 mm RMS or N iterations).
    """
    n = len(normal.W)
    m = np.zeros(n) if initial_m is None else np.where(np.isfinite(initial_m), initial_m, 0.0).copy()
    m[~active] = 0.0
    out = IterationResult(m, [], False, active)
    if not np.any(active):
        out.map_m = np.full(n, np.nan)
        out.converged = True
        return out
    for _ in range(max(int(max_iterations), 1)):
        rho = normal.mean_residual_m(b_body_m, m)
        step = np.where(active, rho, 0.0)
        m = m + step
        change = float(np.sqrt(np.mean(step[active] ** 2)) * 1e3)
        out.changes_mm.append(change)
        if change < tolerance_mm:
            out.converged = True
            break
    out.map_m = np.where(active, m, np.nan)
    return out


def map_change_rms_mm(previous_m: np.ndarray, new_m: np.ndarray) -> float:
    """RMS (mm) of the difference of two maps (m) over the bins valid in both; NaN if none."""
    a = np.asarray(previous_m, dtype=np.float64).ravel()
    b = np.asarray(new_m, dtype=np.float64).ravel()
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.sqrt(np.mean((a[ok] - b[ok]) ** 2)) * 1e3) if np.any(ok) else float("nan")


def residual_bin_sums(grid: Grid2D, fp: FixedPhases, b_body_m: np.ndarray, map_flat_m: np.ndarray | None) -> BinSums:
    """BinSums of (map + residual) per bin, mm, with satellites as clusters: the bin estimate and its sigma
    after the final iteration (the map value plus the bin-mean residual of the final model)."""
    applied = None if map_flat_m is None else map_lookup(grid, map_flat_m, fp.az_deg, fp.el_deg)
    r = residuals_m(fp, b_body_m, applied)
    value = (r if applied is None else r + applied) * 1e3
    return accumulate(grid, fp.az_deg, fp.el_deg, value, fp.weight, cluster=fp.sat)


def residual_stats(r_m: np.ndarray) -> dict:
    """{'n', 'mean_mm', 'std_mm', 'rms_mm', 'p95_abs_mm'} of residuals (m)."""
    r = np.asarray(r_m, dtype=np.float64)
    r = r[np.isfinite(r)]
    if r.size == 0:
        return {"n": 0, "mean_mm": None, "std_mm": None, "rms_mm": None, "p95_abs_mm": None}
    return {"n": int(r.size), "mean_mm": round(float(r.mean() * 1e3), 4), "std_mm": round(float(r.std() * 1e3), 4),
            "rms_mm": round(float(np.sqrt(np.mean(r * r)) * 1e3), 4),
            "p95_abs_mm": round(float(np.percentile(np.abs(r), 95) * 1e3), 4)}


__all__ = ["FixedPhases", "epoch_mean", "residuals_m", "map_lookup", "MapNormal", "map_normal", "IterationResult",
           "iterate_map", "solve_map", "map_change_rms_mm", "residual_bin_sums", "residual_stats", "DEFAULT_TOLERANCE_MM",
           "DEFAULT_MAX_ITERATIONS"]
