"""gnssatt.attitude.fastops gives numpy's results bit for bit (the filter's speed helpers must not change it)."""
import numpy as np
import pytest

from gnssatt.attitude.fastops import clip, count_pairs, median1d, nanmedian1, nz


@pytest.mark.parametrize("shape", [(3, 7), (2, 9, 2), (4, 1)])
def test_nanmedian1_equals_numpy(shape):
    rng = np.random.default_rng(1)
    for _ in range(50):
        a = rng.normal(size=shape)
        a[rng.random(shape) < 0.4] = np.nan
        with np.errstate(all="ignore"), __import__("warnings").catch_warnings():
            __import__("warnings").simplefilter("ignore")
            ref = np.nanmedian(a, axis=1)
        assert np.array_equal(nanmedian1(a), ref, equal_nan=True)


def test_median_clip_nz_count_equal_numpy():
    rng = np.random.default_rng(2)
    for n in range(1, 40):
        a = rng.normal(size=n)
        assert median1d(a) == np.median(a)
        b = np.where(rng.random(n) < 0.3, np.nan, a)
        assert np.array_equal(nz(b), np.nan_to_num(b)) and np.array_equal(nz(b, 45.0), np.nan_to_num(b, nan=45.0))
        assert np.array_equal(clip(b, -0.5, 0.7), np.clip(b, -0.5, 0.7), equal_nan=True)
        assert np.array_equal(clip(b, 0.05, None), np.clip(b, 0.05, None), equal_nan=True)
        first, second = rng.integers(0, 3, n), rng.integers(0, 5, n)
        assert count_pairs(first, second, 3, 5).tolist() == [np.unique(second[first == i]).size for i in range(3)]
