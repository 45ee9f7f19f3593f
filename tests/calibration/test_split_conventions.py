"""The baseline/map split of CONVENTIONS.md ("Output: calibrated baselines"): after the split the maps have no
solid-angle-weighted least-squares c0_f + c . e part over the bins with a value, and the report's observed sky."""
from __future__ import annotations

import numpy as np

from gnssatt.calibration.binning import Grid2D
from gnssatt.calibration.decomposition import (apply_split, bin_los_body, bin_solid_angle_sr, observed_sky,
                                               offset_split, split_weights)


def test_bin_solid_angles_sum_to_the_hemisphere():
    grid = Grid2D.regular(2.5, 1.0, y_range_deg=(0.0, 90.0))
    w = bin_solid_angle_sr(grid.x_centres_deg, grid.y_centres_deg)
    assert abs(w.sum() - 2 * np.pi) < 1e-9          # 0..90 deg: exactly 2 pi sr
    low = Grid2D.regular(10.0, 5.0, y_range_deg=(-20.0, 90.0))
    w_low = bin_solid_angle_sr(low.x_centres_deg, low.y_centres_deg)
    # bins below -10 deg are outside the split's range; -10..90 is 2 pi (1 + sin 10 deg)
    assert np.all(w_low[low.y_centres_deg < -10.0] == 0.0)
    assert abs(w_low.sum() - 2 * np.pi * (1 + np.sin(np.radians(10.0)))) < 1e-9


def test_split_leaves_no_offset_part_under_solid_angle_weights():
    grid = Grid2D.regular(5.0, 2.0, y_range_deg=(0.0, 90.0))
    g = bin_los_body(grid, (0.0, 0.0, -1.0))
    az, el = np.meshgrid(np.radians(grid.x_centres_deg), np.radians(grid.y_centres_deg))
    pattern = 5.0 * np.cos(2 * az) * np.cos(el) ** 2 + 3.0 * np.sin(3 * az) * np.sin(2 * el)   # mm
    db_true = np.array([1.5, -2.0, 4.0])                                                          # mm
    maps = []
    for k, a in enumerate((0.7, -1.1)):
        m = (pattern * (1 + 0.3 * k)).ravel() + a - g @ db_true
        m[(el.ravel() > np.radians(80.0)) & (az.ravel() < np.pi)] = np.nan   # a hole near the zenith
        maps.append(m)
    w = [split_weights(grid, m) for m in maps]
    db, a = offset_split(maps, w, g)
    b_new, new = apply_split(np.zeros(3), maps, g, db, a)
    # the new maps: solid-angle-weighted fit of (1, g) is zero, per frequency constant and jointly for c
    A = np.concatenate([np.ones((g.shape[0], 1)), g], axis=1)
    total_c = np.zeros(3)
    for m, ww in zip(new, w):
        ok = np.isfinite(m)
        assert abs(np.sum(ww[ok] * m[ok])) < 1e-9 * np.sum(ww[ok])
        total_c += (A[ok, 1:] * ww[ok, None]).T @ m[ok]
    assert np.all(np.abs(total_c) < 1e-9)
    # the pattern itself has an offset-like part over this sky, so db is near, not equal to, -db_true
    assert np.all(np.abs(b_new - db) < 1e-12) and np.linalg.norm(db - db_true) < 3.0
    sky = observed_sky(grid, new[0])
    assert sky["elevation_range_deg"] == [-10.0, 90.0] and sky["observed_elevation_deg"] == [1.0, 89.0]
    assert 0.8 < sky["observed_solid_angle_fraction"] < 1 / (1 + np.sin(np.radians(10.0)))
