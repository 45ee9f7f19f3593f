"""gnssatt.attitude.kernels (numba) against the library's readable reference (numpy itself for sums and medians,
gnssatt.attitude.reference_noise for the noise estimators, reference_update.measurement_rows for the rows), through
one adapter per kernel (tests/attitude/_kernel_calls.py); floats within tolerances stated beside each test."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.fastops import count_pairs
from gnssatt.attitude.reference_noise import (NoiseEstimates, NoiseSettings, cn0_variance_factor, cn0_weights,
                                              update_cn0_growth, update_white_noise)
from gnssatt.attitude.reference_qc import TripleDifferences
from gnssatt.attitude import reference_update as RU
from tests.attitude._kernel_calls import (call_cn0_growth, call_count_pairs_masked, call_masked_median_axis1,
                                          call_measurement_rows, call_np_sum, call_white_noise, close, same)

NOISE = NoiseSettings(memory_epochs=300.0, min_epochs=10, min_var_ln_factor=0.05)
LAM = np.array([0.19029, 0.24421])


def _nanmedian1(a):
    with np.errstate(all="ignore"), __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("ignore")
        return np.nanmedian(a, axis=1)


def test_np_sum_is_numpys_pairwise_sum():
    """Sums of values spread over 12 decades: within n eps sum|a| (the bound of any summation order)."""
    rng = np.random.default_rng(0)
    eps = np.finfo(float).eps
    for n in list(range(0, 140)) + [255, 256, 257, 1000, 4099]:
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 6, size=n)
        close(call_np_sum(a), a.sum(), atol=max(n, 1) * eps * np.abs(a).sum() + 1e-300, what=str(n))


def _tds(rng, n_bl=2, n_sat=12, n_sig=2):
    shape = (n_bl, n_sat, n_sig)
    td_c, td_p = rng.normal(size=shape) * 0.4, rng.normal(size=shape) * 0.004
    td_p[rng.random(shape) < 0.05] += 0.3                                # a few slips
    ok_c, ok_p = rng.random(shape) < 0.7, rng.random(shape) < 0.7
    td_c[~ok_c & (rng.random(shape) < 0.5)] = np.nan
    td_p[~ok_p & (rng.random(shape) < 0.5)] = np.nan
    ok_c &= np.isfinite(td_c)
    ok_p &= np.isfinite(td_p)
    return td_c, td_p, ok_c, ok_p


def test_masked_median_equals_nanmedian_of_where():
    """Medians of TDs (m): a selection or the mean of two, within 1e-15 m (values ~1 m; NaN where none)."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        td_c, _, ok_c, _ = _tds(rng, n_sat=int(rng.integers(1, 15)))
        close(call_masked_median_axis1(td_c, ok_c), _nanmedian1(np.where(ok_c, td_c, np.nan)), atol=1e-15)


def test_masked_median_2d_and_nan_values():
    rng = np.random.default_rng(7)
    for _ in range(200):
        a = rng.normal(size=(3, int(rng.integers(1, 12))))
        a[rng.random(a.shape) < 0.1] = np.nan                    # NaN values count as missing even where ok
        ok = rng.random(a.shape + (2,)) < 0.7
        ref = _nanmedian1(np.where(ok[:, :, 0], a, np.nan))
        close(call_masked_median_axis1(a[:, :, None], ok[:, :, :1])[:, 0], ref, atol=1e-15)


def test_count_pairs_masked_equals_count_pairs():
    rng = np.random.default_rng(8)
    for n in range(0, 60):
        first, second, mask = rng.integers(0, 3, n), rng.integers(0, 9, n), rng.random(n) < 0.6
        same(call_count_pairs_masked(first, second, mask, 3, 9), count_pairs(first[mask], second[mask], 3, 9))


def test_noise_estimators_equal_numpy_over_many_epochs():
    """400 epochs of the C/N0-growth and white-noise estimators against reference_noise, each side carrying its
    own state: means relative 1e-12, gamma within 1e-9, variances (m^2) relative 1e-9 (exponential means of
    O(1) samples forget rounding errors at the rate of their memory)."""
    rng = np.random.default_rng(2)
    est_ref = NoiseEstimates.initial(2, 0.09, 1e-5)
    est_k = est_ref.copy()
    for _ in range(400):                      # enough epochs for gamma to be estimated (>= min_epochs)
        td_c, td_p, ok_c, ok_p = _tds(rng, n_sat=int(rng.integers(2, 14)))
        cn0 = rng.uniform(30, 52, size=td_c.shape)
        lw = np.log(cn0_variance_factor(cn0))
        td_c *= np.exp(0.5 * lw)
        td = TripleDifferences(td_c, td_p, ok_c, ok_p, _nanmedian1(np.where(ok_c, td_c, np.nan)),
                               _nanmedian1(np.where(ok_p, td_p, np.nan)))
        update_cn0_growth(td, lw, LAM, est_ref, NOISE)
        update_white_noise(td, cn0_weights(est_ref.gamma, lw), est_ref, NOISE)
        call_cn0_growth(td, lw, LAM, est_k, NOISE)
        call_white_noise(td, cn0_weights(est_k.gamma, lw), est_k, NOISE)
        close(est_k.moments, est_ref.moments, rtol=1e-12, atol=1e-12, what="moments")
        close(est_k.gamma, est_ref.gamma, atol=1e-9, what="gamma")
        close(est_k.var_code_m2, est_ref.var_code_m2, rtol=1e-9, what="code variance (m^2)")
        close(est_k.var_phase_m2, est_ref.var_phase_m2, rtol=1e-9, what="phase variance (m^2)")
        same(est_k.n_growth.astype(np.int64), est_ref.n_growth.astype(np.int64), "n_growth")
        same(est_k.n_white.astype(np.int64), est_ref.n_white.astype(np.int64), "n_white")
    assert np.all(est_k.n_growth > NOISE.min_epochs) and np.any(np.abs(est_k.gamma - 1.0) > 1e-3)   # gamma estimated
    assert 0.3 < est_k.gamma[0, 0] < 1.5      # code noise grows with the factor^1 put in (slope of ln|e|)


def test_round_newcomers_equals_the_dense_dd_products():
    """gnssatt.attitude.ambiguity.round_newcomers takes D x and diag(D P D^T) from the two non-zeros of each DD row:
    against the dense products, the accepted DDs exactly, D (entries 0, +-1) and the integers within 1e-12."""
    from gnssatt.attitude.ambiguity import round_newcomers

    rng = np.random.default_rng(9)
    for _ in range(500):
        n = int(rng.integers(10, 70))
        A = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-3, 1)
        P, x = A @ A.T, rng.normal(size=n) * 10.0 ** rng.uniform(-1, 4)
        k = int(rng.integers(1, 8))
        idx = rng.choice(n, size=k + 1, replace=False)
        D = np.zeros((k, n))
        D[np.arange(k), idx[1:]] = 1.0
        D[:, idx[0]] -= 1.0
        d, var = D @ x, np.einsum("ij,ij->i", D @ P, D)
        r = np.round(d)
        ok = (np.sqrt(np.maximum(var, 0.0)) < 0.3) & (np.abs(d - r) < 0.35)
        D1, v1, ok1 = round_newcomers(x, P, idx[1:], int(idx[0]), 0.3, 0.35)
        same(ok1, ok, "accepted")
        close(D1, D[ok], atol=1e-12, what="D")
        close(v1, r[ok], atol=1e-12, what="integers (cycles)")


def test_measurement_rows_equal_the_numpy_assembly():
    """Rows against reference_update.measurement_rows: columns exactly, coefficients and observations (copies and
    one subtraction, m) within 1e-15 relative."""
    rng = np.random.default_rng(10)
    for n_sig in (1, 2, 3):
        n_bl, n_sat = 2, 11
        b_idx = (3 + 8 * np.arange(n_bl))[:, None] + np.arange(3)[None, :]
        clk = b_idx[:, 0] + 3
        bias = np.full((n_bl, n_sig), -1, np.int64)
        bias[:, 1:] = clk[:, None] + 1 + np.arange(n_sig - 1)[None, :]
        pclk = clk[:, None] + n_sig + np.arange(n_sig)[None, :]
        layout = RU.StateLayout(b_idx, clk, pclk, bias, rng.integers(20, 60, size=(n_bl, n_sat, n_sig)), 20)
        u, cfac, lam = rng.normal(size=(n_sat, 3)), 1.0 + rng.normal(size=n_sat) * 1e-6, rng.uniform(0.1, 0.3, n_sig)
        sdc_c, sdp_c, pcv_m = rng.normal(size=(3, n_bl, n_sat, n_sig))
        nan2 = np.full((n_bl, n_sat), np.nan)
        obs = RU.UpdateObs(u, cfac, np.repeat(lam[None, :], n_sat, axis=0), sdc_c, sdp_c, pcv_m, np.full(sdc_c.shape, 45.0), nan2, nan2)
        use_c = rng.random((n_bl, n_sat, n_sig)) < 0.7
        use_p = use_c & (rng.random(use_c.shape) < 0.8)
        rows = RU.UsedRows.from_masks(use_c, use_p)
        cols, coef, z = RU.measurement_rows(rows, layout, obs)
        out = call_measurement_rows(rows, layout, obs)
        same(out[0], cols, "cols")
        close(out[1], coef, rtol=1e-15, what="coef")
        close(out[2], z, rtol=1e-15, atol=1e-15, what="z (m)")
