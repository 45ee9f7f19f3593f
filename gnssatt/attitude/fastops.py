"""Small numpy helpers for the per-epoch loop of the attitude filter: the same results as numpy's general
functions (np.nan_to_num without infinities, np.clip, np.median, np.nanmedian over axis 1, np.unique counts) with
less per-call overhead (the filter calls them ~10^5 times per pass on arrays of a few dozen elements).

Implements: nothing new; each function states which numpy function it replaces, bit for bit on finite input.
"""
from __future__ import annotations

import numpy as np

__all__ = ["nz", "clip", "median1d", "nanmedian1", "count_pairs"]


def nz(a, nan: float = 0.0):
    """np.nan_to_num(a, nan=nan) for arrays without infinities (NaN -> nan)."""
    return np.where(np.isnan(a), nan, a)


def clip(a, lo=None, hi=None):
    """np.clip(a, lo, hi) (NaN propagates, as in np.clip); lo or hi None = unbounded."""
    if lo is not None:
        a = np.maximum(a, lo)
    if hi is not None:
        a = np.minimum(a, hi)
    return a


def median1d(a: np.ndarray) -> float:
    """np.median of a 1-D array without NaN (mean of the two middle values for an even size)."""
    srt = np.sort(a)
    h = srt.size // 2
    return srt[h] if srt.size % 2 else (srt[h - 1] + srt[h]) / 2.0


def nanmedian1(a: np.ndarray) -> np.ndarray:
    """Median over axis 1 ignoring NaN (NaN where a slice has no finite value): np.nanmedian(a, axis=1)."""
    srt = np.sort(a, axis=1)                      # NaN sort last
    n = np.isfinite(a).sum(axis=1)
    lo = np.maximum((n - 1) // 2, 0)
    hi = np.maximum(n // 2, 0)
    if a.ndim == 2:
        r = np.arange(a.shape[0])
        v = 0.5 * (srt[r, lo] + srt[r, hi])
    elif a.ndim == 3:
        r, c = np.arange(a.shape[0])[:, None], np.arange(a.shape[2])[None, :]
        v = 0.5 * (srt[r, lo, c] + srt[r, hi, c])
    else:
        v = 0.5 * (np.take_along_axis(srt, lo[:, None], 1)[:, 0] + np.take_along_axis(srt, hi[:, None], 1)[:, 0])
    return np.where(n > 0, v, np.nan)


def count_pairs(first: np.ndarray, second: np.ndarray, n_first: int, n_second: int) -> np.ndarray:
    """(n_first,) number of distinct `second` values paired with each `first` value (np.unique(second[first == i])
    .size for every i)."""
    occ = np.zeros((n_first, n_second), bool)
    occ[first, second] = True
    return occ.sum(axis=1)
