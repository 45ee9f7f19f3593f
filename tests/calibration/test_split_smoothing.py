"""The baseline/map split (gnssatt.calibration.decomposition), the Zernike map smoothing
(gnssatt.calibration.smoothing) and the C/N0 weights of the extraction, against constructed truths."""
from __future__ import annotations

import numpy as np

from gnssatt.calibration.binning import Grid2D
from gnssatt.calibration.decomposition import apply_split, bin_los_body, offset_split
from gnssatt.calibration.extract import cn0_variance_factor
from gnssatt.calibration.smoothing import smooth_map, zernike_basis

GRID = Grid2D.regular(2.5, 1.0)
BORESIGHT = np.array([0.0, 0.0, -1.0])


def _pattern_mm(grid: Grid2D, phase: float) -> np.ndarray:
    az, el = np.meshgrid(np.radians(grid.x_centres_deg), np.radians(grid.y_centres_deg))
    return (10.0 * np.cos(el) ** 1.5 * np.cos(az + phase) + 6.0 * np.cos(el) ** 2 * np.sin(2 * az - phase)
            + 9.0 * (1 - np.sin(el)) ** 2).ravel()


def test_split_is_a_property_of_the_model_not_of_the_starting_baseline():
    g = bin_los_body(GRID, BORESIGHT)
    rng = np.random.default_rng(2)
    w = [rng.integers(30, 300, GRID.n_bins).astype(float) for _ in range(2)]
    holes = rng.random(GRID.n_bins) < 0.2
    b_true_mm = np.array([1000.0, 5.0, -3.0])
    pcv = [_pattern_mm(GRID, 0.3), 1.3 * _pattern_mm(GRID, 1.1)]
    splits = []
    for b0 in (b_true_mm, b_true_mm + [2.0, -4.0, 1.5]):
        # the same single-difference model -g.b_true + pcv_f expressed with baseline b0: m_f = pcv_f - g.(b_true - b0)
        maps = [np.where(holes, np.nan, p - g @ (b_true_mm - b0) + c) for p, c in zip(pcv, (7.0, -2.0))]
        db, a = offset_split(maps, w, g)
        b1, m1 = apply_split(b0, maps, g, db, a)
        # the split maps hold no part a_f - g.db any more, and the model is unchanged
        db2, _ = offset_split(m1, w, g)
        assert np.max(np.abs(db2)) < 1e-9
        for m, mm, af in zip(maps, m1, a):
            ok = np.isfinite(m)
            np.testing.assert_allclose((-(g @ b1) + mm)[ok], (-(g @ b0) + m - af)[ok], atol=1e-9)
        splits.append((b1, m1))
    np.testing.assert_allclose(splits[0][0], splits[1][0], atol=1e-9)
    for m_a, m_b in zip(splits[0][1], splits[1][1]):
        np.testing.assert_allclose(m_a, m_b, atol=1e-9)
    # a PCV with a large offset-like part moves the baseline: the split baseline is not the physical one
    assert np.linalg.norm(splits[0][0] - b_true_mm) > 0.5


def test_smoothing_recovers_a_smooth_pattern_from_noisy_bins_and_keeps_empty_bins_empty():
    g = bin_los_body(GRID, BORESIGHT)
    az, el = np.meshgrid(GRID.x_centres_deg, GRID.y_centres_deg)
    truth = _pattern_mm(GRID, 0.7)
    rng = np.random.default_rng(4)
    count = rng.integers(30, 400, GRID.n_bins).astype(float)
    noisy = truth + rng.normal(0, 1, GRID.n_bins) * 20.0 / np.sqrt(count) * (1 + 2 * (el.ravel() < 15))
    noisy[rng.random(GRID.n_bins) < 0.25] = np.nan
    for order in (8, 12):
        sm = smooth_map(noisy, count, az.ravel(), el.ravel(), order, g)
        assert np.array_equal(np.isnan(sm), np.isnan(noisy))
        ok = np.isfinite(noisy)
        raw = np.sqrt(np.mean((noisy - truth)[ok] ** 2))
        err = np.sqrt(np.mean((sm - truth)[ok] ** 2))
        assert err < 0.3 * raw, (order, raw, err)
    np.testing.assert_array_equal(smooth_map(noisy, count, az.ravel(), el.ravel(), 0), noisy)


def test_smoothing_reproduces_its_own_span_and_the_offset_space():
    """A map that is a Zernike polynomial plus a baseline-like term a - g.db is returned unchanged (the split and
    the smoothing commute)."""
    g = bin_los_body(GRID, BORESIGHT)
    az, el = np.meshgrid(GRID.x_centres_deg, GRID.y_centres_deg)
    Z = zernike_basis(az.ravel(), el.ravel(), 6)
    rng = np.random.default_rng(9)
    m = Z @ rng.normal(0, 2, Z.shape[1]) + 4.0 - g @ np.array([3.0, -2.0, 1.0])
    np.testing.assert_allclose(smooth_map(m, np.ones_like(m), az.ravel(), el.ravel(), 6, g), m, atol=1e-3)  # ridge: < 1 um


def test_cn0_variance_factor():
    f = cn0_variance_factor(np.array([45.0, 35.0, 25.0, np.nan]), np.array([45.0, 45.0, 60.0, 45.0]))
    np.testing.assert_allclose(f, [1.0, 0.5 * (10.0 + 1.0), 0.5 * (16.0 + 0.25), 1.0])
