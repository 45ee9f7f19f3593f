"""The split between a calibrated baseline and its PCV maps, as CONVENTIONS.md fixes it ("Output: calibrated
baselines").

With body-fixed antennas, a baseline change db moves every single difference by -g.db (g the body-frame unit
line of sight), and g is a function of the direction (az, el) in the first antenna's frame: a map holding
a - g.db is the same model as the baseline shifted by db. Baseline and maps are therefore only defined
together, and the split is fixed by a constraint: the maps of a baseline (all frequencies together, one db, one
constant a_f per frequency) have no least-squares part a_f - g . db, solid-angle weighted over the elevations
SPLIT_ELEVATION_RANGE_DEG (-10 to 90 deg) of the first antenna's frame:
    (db, a) = argmin sum_f sum_B W_B (m_f(B) - a_f + g_B . db)^2,   W_B = solid angle of bin B,
    b' = b + db,  m'_f(B) = m_f(B) + g_B . db - a_f.
A map estimated over part of that sky is extended by its fitted model for this purpose: with the fitted model
a_f - g.db itself in the bins without a value, those bins add nothing to the normal equations at the solution,
so the fit is the solid-angle-weighted fit over the bins with a value (`split_weights`), and the report states
which part of the sky that was (`observed_sky`). The baseline is then the one that best explains the data
without maps (it absorbs the offset-like part of the PCV, as seed 000's "baseline first" does), the maps hold
only what no baseline can, and the split is a property of the model (b, m) and of the observed sky alone, not of
how the estimator got there or of the sample counts. The same projection of an injected truth (physical baseline
per frequency and PCV) on the same bins gives the truth in this split (tests, bench).

Implements: the linear least-squares projection above; g at the bin centres, antenna frame of
gnssatt.gnss.geometry.R_antenna_from_body; bin solid angle d_az (sin el_top - sin el_bottom).
"""
from __future__ import annotations

import numpy as np

from gnssatt.calibration.binning import Grid2D

__all__ = ["SPLIT_ELEVATION_RANGE_DEG", "bin_los_body", "bin_solid_angle_sr", "split_weights", "observed_sky",
           "offset_split", "apply_split"]

#: antenna-frame elevations (deg) over which the split is defined (CONVENTIONS.md "Output: calibrated baselines")
SPLIT_ELEVATION_RANGE_DEG = (-10.0, 90.0)


def bin_solid_angle_sr(az_centres_deg, el_centres_deg) -> np.ndarray:
    """(n_el, n_az) solid angle (sr) of each bin of a regular grid given by its centres, clipped to
    SPLIT_ELEVATION_RANGE_DEG (0 outside): d_az (sin el_top - sin el_bottom)."""
    az = np.asarray(az_centres_deg, dtype=np.float64)
    el = np.asarray(el_centres_deg, dtype=np.float64)
    d_az = np.radians(az[1] - az[0]) if az.size > 1 else 2 * np.pi
    d_el = el[1] - el[0] if el.size > 1 else 1.0
    lo, hi = SPLIT_ELEVATION_RANGE_DEG
    top = np.radians(np.clip(el + d_el / 2, lo, hi))
    bottom = np.radians(np.clip(el - d_el / 2, lo, hi))
    return np.broadcast_to((d_az * (np.sin(top) - np.sin(bottom)))[:, None], (el.size, az.size)).copy()


def split_weights(grid: Grid2D, map_values: np.ndarray) -> np.ndarray:
    """(n_bins,) weights of the split for one map on `grid`: the bin's solid angle where the map has a value, 0
    where it has none (the model extension, module docstring)."""
    w = bin_solid_angle_sr(grid.x_centres_deg, grid.y_centres_deg).ravel()
    return np.where(np.isfinite(np.asarray(map_values, dtype=np.float64).ravel()), w, 0.0)


def observed_sky(grid: Grid2D, map_values: np.ndarray) -> dict:
    """Which part of the split's sky a map covers: {"elevation_range_deg" (the split's), "observed_elevation_deg"
    [lowest, highest bin centre with a value], "observed_solid_angle_fraction" (of the split's range)}."""
    w_all = bin_solid_angle_sr(grid.x_centres_deg, grid.y_centres_deg)
    full = 2 * np.pi * (np.sin(np.radians(SPLIT_ELEVATION_RANGE_DEG[1])) - np.sin(np.radians(SPLIT_ELEVATION_RANGE_DEG[0])))
    have = np.isfinite(np.asarray(map_values, dtype=np.float64).reshape(w_all.shape))
    rows = np.flatnonzero(have.any(axis=1))
    el = np.asarray(grid.y_centres_deg, dtype=np.float64)
    return {"elevation_range_deg": list(SPLIT_ELEVATION_RANGE_DEG),
            "observed_elevation_deg": [float(el[rows[0]]), float(el[rows[-1]])] if rows.size else None,
            "observed_solid_angle_fraction": round(float(w_all[have].sum() / full), 4)}


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
