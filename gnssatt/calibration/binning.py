"""Generic binning of samples on a 2-D grid (azimuth x elevation for antenna PCV, or azimuth x off-boresight
angle for the GNSS-satellite maps of seed 004): additive per-bin sums, then value, count and sigma per bin, with
bins of too few samples left empty (NaN -> null), never filled in.

Sums are additive, so each set (a fan-out task) bins its own samples and the campaign adds the sums in set
order; the same inputs give bit-identical sums whatever the order in which tasks finish. Within a call the sums
use np.bincount over the samples in their given order (sequential, deterministic).

Sigma of a bin mean. Samples in one bin are correlated in time (one satellite crosses a 1 deg x 2.5 deg bin in
tens of seconds while multipath decorrelates over ~60 s), so the bin sigma is cluster-robust: samples sharing a
cluster id (e.g. a satellite of a set) within a bin form one cluster c with weight W_c and mean m_c, and
    var(M) = n_c / (n_c - 1) * sum_c W_c^2 (m_c - M)^2 / W^2,
accumulated through the additive sums A = sum W_c^2, B = sum W_c^2 m_c, C = sum W_c^2 m_c^2
(sum_c W_c^2 (m_c - M)^2 = C - 2 M B + M^2 A). A bin holding a single cluster reports the weighted standard
deviation of its samples (a conservative stand-in: its mean is as uncertain as one sample track).

Implements: seed 000 sec. 3.2 (averaged residuals per azimuth/elevation bin, 2.5 deg x 1 deg); cluster-robust
variance of a weighted mean (Cameron & Miller 2015).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DEFAULT_AZIMUTH_STEP_DEG = 2.5
DEFAULT_ELEVATION_STEP_DEG = 1.0
DEFAULT_MIN_COUNT = 30


@dataclass(frozen=True)
class Grid2D:
    """A grid of bins: x (azimuth-like, periodic when x_period is set) by y (elevation-like).

    x_edges_deg: (n_x + 1,), y_edges_deg: (n_y + 1,) increasing. Values are laid out (n_y, n_x) as in
    CONVENTIONS.md (values[i][j]: y bin i, x bin j). Flat bin index = i * n_x + j.
    """

    x_edges_deg: tuple
    y_edges_deg: tuple
    x_period_deg: float | None = 360.0
    #: (x_step_deg, y_step_deg, x_range_deg, y_range_deg) as given to `regular` (None for explicit edges), so a
    #: summary reports the steps asked for, not differences of the edges rounded to 1e-10 deg; not compared
    regular_deg: tuple | None = field(default=None, compare=False)

    @classmethod
    def regular(cls, x_step_deg: float = DEFAULT_AZIMUTH_STEP_DEG, y_step_deg: float = DEFAULT_ELEVATION_STEP_DEG,
                x_range_deg: tuple[float, float] = (0.0, 360.0), y_range_deg: tuple[float, float] = (0.0, 90.0),
                x_period_deg: float | None = 360.0) -> "Grid2D":
        """Uniform bins of x_step_deg by y_step_deg over the given ranges (each range a whole number of steps)."""
        def edges(lo, hi, step):
            n = int(round((hi - lo) / step))
            if n < 1 or abs(lo + n * step - hi) > 1e-9 * max(1.0, abs(hi)):
                raise ValueError(f"range [{lo:g}, {hi:g}] is not a whole number of {step:g} deg steps")
            return tuple(float(v) for v in np.round(lo + step * np.arange(n + 1), 10))
        return cls(edges(*x_range_deg, x_step_deg), edges(*y_range_deg, y_step_deg), x_period_deg,
                   (x_step_deg, y_step_deg, tuple(x_range_deg), tuple(y_range_deg)))

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.y_edges_deg) - 1, len(self.x_edges_deg) - 1

    @property
    def n_bins(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def x_centres_deg(self) -> np.ndarray:
        e = np.asarray(self.x_edges_deg)
        return np.round(0.5 * (e[:-1] + e[1:]), 10)

    @property
    def y_centres_deg(self) -> np.ndarray:
        e = np.asarray(self.y_edges_deg)
        return np.round(0.5 * (e[:-1] + e[1:]), 10)

    def index(self, x_deg, y_deg) -> np.ndarray:
        """Flat bin index (...,) int64 of samples, -1 outside the grid or NaN. x wraps by x_period_deg; the top
        y edge is inside (elevation 90 deg falls in the last bin)."""
        x = np.asarray(x_deg, dtype=np.float64)
        y = np.asarray(y_deg, dtype=np.float64)
        xe = np.asarray(self.x_edges_deg)
        ye = np.asarray(self.y_edges_deg)
        if self.x_period_deg:
            x = xe[0] + np.mod(x - xe[0], self.x_period_deg)
        with np.errstate(invalid="ignore"):
            j = np.searchsorted(xe, x, side="right") - 1
            i = np.searchsorted(ye, y, side="right") - 1
            i = np.where(y == ye[-1], len(ye) - 2, i)
            j = np.where(x == xe[-1], len(xe) - 2, j)
            ok = np.isfinite(x) & np.isfinite(y) & (i >= 0) & (i < len(ye) - 1) & (j >= 0) & (j < len(xe) - 1)
        n_x = len(xe) - 1
        return np.where(ok, i * n_x + j, -1).astype(np.int64)


@dataclass
class BinSums:
    """Additive per-bin sums (n_bins,) of one grid; see the module docstring."""

    count: np.ndarray  # int64 samples
    sum_w: np.ndarray
    sum_wv: np.ndarray
    sum_wv2: np.ndarray
    n_clusters: np.ndarray  # int64
    cl_a: np.ndarray  # sum over clusters of W_c^2
    cl_b: np.ndarray  # sum W_c^2 m_c
    cl_c: np.ndarray  # sum W_c^2 m_c^2

    @classmethod
    def zeros(cls, n_bins: int) -> "BinSums":
        z = np.zeros(n_bins)
        return cls(np.zeros(n_bins, np.int64), z.copy(), z.copy(), z.copy(), np.zeros(n_bins, np.int64),
                   z.copy(), z.copy(), z.copy())

    def __add__(self, other: "BinSums") -> "BinSums":
        return BinSums(*(getattr(self, f) + getattr(other, f) for f in self.__dataclass_fields__))

    @classmethod
    def total(cls, parts: list["BinSums"], n_bins: int) -> "BinSums":
        """Sum of parts in the given order (deterministic)."""
        out = cls.zeros(n_bins)
        for p in parts:
            out = out + p
        return out


def accumulate(grid: Grid2D, x_deg, y_deg, value, weight=None, cluster=None) -> BinSums:
    """BinSums of samples (x, y, value, weight) on `grid`; `cluster` (int ids, e.g. satellite index) groups
    correlated samples within a bin (None: every sample its own cluster). NaN values and samples outside the grid
    are skipped."""
    idx = grid.index(x_deg, y_deg).ravel()
    v = np.asarray(value, dtype=np.float64).ravel()
    w = np.ones_like(v) if weight is None else np.broadcast_to(np.asarray(weight, dtype=np.float64), v.shape).ravel()
    ok = (idx >= 0) & np.isfinite(v) & np.isfinite(w) & (w > 0)
    n = grid.n_bins
    if not np.any(ok):
        return BinSums.zeros(n)
    idx, v, w = idx[ok], v[ok], w[ok]
    count = np.bincount(idx, minlength=n).astype(np.int64)
    sw = np.bincount(idx, weights=w, minlength=n)
    swv = np.bincount(idx, weights=w * v, minlength=n)
    swv2 = np.bincount(idx, weights=w * v * v, minlength=n)
    if cluster is None:
        cl_w, cl_wv, cl_bin = w, w * v, idx
    else:
        c = np.asarray(cluster, dtype=np.int64).ravel()[ok]
        c = c - int(c.min())
        span = int(c.max()) + 1
        uniq, inv = np.unique(idx * span + c, return_inverse=True)
        cl_w = np.bincount(inv, weights=w, minlength=len(uniq))
        cl_wv = np.bincount(inv, weights=w * v, minlength=len(uniq))
        cl_bin = uniq // span
    m_c = cl_wv / cl_w
    n_cl = np.bincount(cl_bin, minlength=n).astype(np.int64)
    a = np.bincount(cl_bin, weights=cl_w ** 2, minlength=n)
    b = np.bincount(cl_bin, weights=cl_w ** 2 * m_c, minlength=n)
    cc = np.bincount(cl_bin, weights=cl_w ** 2 * m_c ** 2, minlength=n)
    return BinSums(count, sw, swv, swv2, n_cl, a, b, cc)


@dataclass
class BinnedMap:
    """Per-bin results on a grid, each (n_y, n_x): value (NaN where empty), count (int), sigma (NaN where empty)."""

    grid: Grid2D
    value: np.ndarray
    count: np.ndarray
    sigma: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.value)


def finalize(grid: Grid2D, sums: BinSums, min_count: int = DEFAULT_MIN_COUNT) -> BinnedMap:
    """BinnedMap of the weighted mean per bin; bins with count < min_count are empty (NaN), their count kept."""
    n = grid.n_bins
    ok = (sums.count >= max(int(min_count), 1)) & (sums.sum_w > 0)
    mean = np.full(n, np.nan)
    sigma = np.full(n, np.nan)
    W = np.where(ok, sums.sum_w, 1.0)
    mean[ok] = sums.sum_wv[ok] / W[ok]
    M = np.where(ok, mean, 0.0)
    nc = sums.n_clusters
    multi = ok & (nc >= 2)
    robust = (sums.cl_c - 2 * M * sums.cl_b + M * M * sums.cl_a) / (W * W)
    robust = np.maximum(robust, 0.0) * np.where(nc >= 2, nc / np.maximum(nc - 1, 1), 1.0)
    scatter = np.maximum(sums.sum_wv2 / W - M * M, 0.0)  # weighted variance of the samples
    sigma[multi] = np.sqrt(robust[multi])
    single = ok & (nc < 2)
    sigma[single] = np.sqrt(scatter[single])
    shape = grid.shape
    return BinnedMap(grid, mean.reshape(shape), sums.count.reshape(shape), sigma.reshape(shape))


__all__ = ["Grid2D", "BinSums", "accumulate", "BinnedMap", "finalize", "DEFAULT_MIN_COUNT",
           "DEFAULT_AZIMUTH_STEP_DEG", "DEFAULT_ELEVATION_STEP_DEG"]
