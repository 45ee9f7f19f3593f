"""The split between a calibrated baseline and its PCV maps, made explicit.

With body-fixed antennas, a baseline change db moves every single difference by -g.db (g the body-frame unit
line of sight), and g is a function of the direction (az, el) in the first antenna's frame: a map holding
a - g.db is the same model as the baseline shifted by db. Baseline and maps are therefore only defined
together, and the calibration defines the split by a constraint: over the bins with a value, with the bins'
sample weights W_fB, the maps of a baseline (all frequencies together) have no least-squares component of the
form a_f - g_B . db:
    (db, a) = argmin sum_f sum_B W_fB (m_f(B) - a_f + g_B . db)^2,
    b' = b + db,  m'_f(B) = m_f(B) + g_B . db - a_f.
The baseline is then the one that best explains the data without maps (it absorbs the offset-like part of the
PCV, as seed 000's "baseline first" does), the maps hold only what no baseline can, and the split is a property
of the model (b, m) alone, not of how the estimator got there. The same projection of an injected truth
(physical baseline per frequency and PCV) gives the truth in this decomposition (tests, bench).

Implements: the linear least-squares projection above; g at the bin centres, antenna frame of
gnssatt.gnss.geometry.R_antenna_from_body.
"""
from __future__ import annotations

import numpy as np

from gnssatt.calibration.binning import Grid2D

__all__ = ["bin_los_body", "offset_split", "apply_split"]


def bin_los_body(grid: Grid2D, boresight_first_body) -> np.ndarray:
    """(n_bins, 3) body-frame unit line of sight at every bin centre (azimuth x, elevation y of the grid, in the
    antenna frame of the pair's first antenna), in the flat bin order of Grid2D."""
    from gnssatt.gnss.geometry import R_antenna_from_body

    az, el = np.meshgrid(np.radians(grid.x_centres_deg), np.radians(grid.y_centres_deg))
    d_ant = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1).reshape(-1, 3)
    return d_ant @ R_antenna_from_body(np.asarray(boresight_first_body, dtype=np.float64))   # R^T d per row


def offset_split(maps: list[np.ndarray], weights: list[np.ndarray], g_bins: np.ndarray) -> tuple[np.ndarray,
                                                                                                 np.ndarray]:
    """(db (3,), a (n_f,)) of the weighted least-squares fit m_f(B) ~ a_f - g_B . db over the bins where m_f is
    finite and W_fB > 0 (module docstring). Units of the maps (db in the same unit).

    Args:
        maps: per frequency (n_bins,) map values (NaN on empty bins).
        weights: per frequency (n_bins,) bin weights (sum of the samples' weights).
        g_bins: (n_bins, 3) bin_los_body.
    """
    n_f = len(maps)
    N = np.zeros((3 + n_f, 3 + n_f))
    r = np.zeros(3 + n_f)
    for f, (m, w) in enumerate(zip(maps, weights)):
        ok = np.isfinite(m) & (np.asarray(w) > 0)
        if not np.any(ok):
            N[3 + f, 3 + f] = 1.0
            continue
        A = np.zeros((int(ok.sum()), 3 + n_f))
        A[:, :3] = -g_bins[ok]
        A[:, 3 + f] = 1.0
        ww = np.asarray(w, dtype=np.float64)[ok]
        N += A.T @ (A * ww[:, None])
        r += A.T @ (ww * m[ok])
    x = np.linalg.solve(N, r)
    return x[:3], x[3:]


def apply_split(b_body: np.ndarray, maps: list[np.ndarray], g_bins: np.ndarray, db: np.ndarray,
                a: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """(b + db, [m_f + g . db - a_f]) (NaN bins stay NaN): the same model with the split of offset_split."""
    shift = g_bins @ np.asarray(db, dtype=np.float64)
    return np.asarray(b_body, dtype=np.float64) + db, [m + shift - af for m, af in zip(maps, a)]
