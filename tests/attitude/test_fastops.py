"""gnssatt.attitude.fastops (the filter's numpy speed helpers) against numpy's general functions: medians are
selections or the mean of two values (within 1e-15 of values ~1), the rest selections and counts."""
import warnings

import numpy as np
import pytest

from gnssatt.attitude.fastops import clip, count_pairs, median1d, nanmedian1, nz
from tests.attitude._kernel_calls import close, same


@pytest.mark.parametrize("shape", [(3, 7), (2, 9, 2), (4, 1)])
def test_nanmedian1_equals_numpy(shape):
    rng = np.random.default_rng(1)
    for _ in range(50):
        a = rng.normal(size=shape)
        a[rng.random(shape) < 0.4] = np.nan
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = np.nanmedian(a, axis=1)
        close(nanmedian1(a), ref, atol=1e-15)


def test_median_clip_nz_count_equal_numpy():
    rng = np.random.default_rng(2)
    for n in range(1, 40):
        a = rng.normal(size=n)
        close(median1d(a), np.median(a), atol=1e-15, what="median")
        b = np.where(rng.random(n) < 0.3, np.nan, a)
        close(nz(b), np.nan_to_num(b), atol=1e-15, what="nz")
        close(nz(b, 45.0), np.nan_to_num(b, nan=45.0), atol=1e-15, what="nz 45")
        close(clip(b, -0.5, 0.7), np.clip(b, -0.5, 0.7), atol=1e-15, what="clip")
        close(clip(b, 0.05, None), np.clip(b, 0.05, None), atol=1e-15, what="clip lower")
        first, second = rng.integers(0, 3, n), rng.integers(0, 5, n)
        same(count_pairs(first, second, 3, 5), np.array([np.unique(second[first == i]).size for i in range(3)]))
