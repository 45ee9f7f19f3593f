"""gnssatt.attitude.kernels (numba) give the bits of the numpy code of run_filter they replace, on random inputs."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.fastops import count_pairs, median1d, nanmedian1, nz
from gnssatt.attitude.kernels import (POW2, cn0_growth_samples, cn0_growth_update, count_pairs_masked,
                                     masked_median_axis1, measurement_rows, np_sum, white_noise_update)

NOISE_EPOCHS, MIN_EPOCHS = 300.0, 10


def test_np_sum_is_numpys_pairwise_sum():
    rng = np.random.default_rng(0)
    for n in list(range(0, 140)) + [255, 256, 257, 1000, 4099]:
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 6, size=n)
        assert np_sum(a) == a.sum()


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
    rng = np.random.default_rng(1)
    for _ in range(300):
        td_c, _, ok_c, _ = _tds(rng, n_sat=int(rng.integers(1, 15)))
        ref = nanmedian1(np.where(ok_c, td_c, np.nan))
        assert np.array_equal(masked_median_axis1(td_c, ok_c), ref, equal_nan=True)


def test_masked_median_2d_and_nan_values():
    rng = np.random.default_rng(7)
    for _ in range(200):
        a = rng.normal(size=(3, int(rng.integers(1, 12))))
        a[rng.random(a.shape) < 0.1] = np.nan                    # NaN values count as missing even where ok
        ok = rng.random(a.shape + (2,)) < 0.7
        ref = nanmedian1(np.where(ok[:, :, 0], a, np.nan))
        assert np.array_equal(masked_median_axis1(a[:, :, None], ok[:, :, :1])[:, 0], ref, equal_nan=True)


def test_count_pairs_masked_equals_count_pairs():
    rng = np.random.default_rng(8)
    for n in range(0, 60):
        first, second, mask = rng.integers(0, 3, n), rng.integers(0, 9, n), rng.random(n) < 0.6
        assert np.array_equal(count_pairs_masked(first, second, mask, 3, 9),
                              count_pairs(first[mask], second[mask], 3, 9))


def _numpy_noise(td_c, td_p, ok_c, ok_p, mc, mp, lw, lam, mom, gam_n, gamma, est_var_c, est_var_p, est_n):
    """run_filter's estimators as they were written in numpy."""
    n_sig = lam.size
    for f in range(n_sig):
        for kk, td, okk, mref, big in ((0, td_c, ok_c, mc, 5.0), (1, td_p, ok_p, mp, lam[f])):
            sel = okk[..., f]
            r = np.abs((td[..., f] - nz(mref[:, f])[:, None])[sel])
            x = lw[..., f][sel]
            keep = (r < big) & (r > 0)
            if keep.sum() >= 3:
                x, y = x[keep], np.log(r[keep])
                a = 1.0 / min(gam_n[kk, f] + 1.0, NOISE_EPOCHS)
                nx = x.size
                mom[kk, f] += a * (np.array([x.sum() / nx, y.sum() / nx, (x * x).sum() / nx,
                                             (x * y).sum() / nx]) - mom[kk, f])
                gam_n[kk, f] += 1
                vx = mom[kk, f, 2] - mom[kk, f, 0] ** 2
                if gam_n[kk, f] >= MIN_EPOCHS and vx > 0.05:
                    gamma[kk, f] = np.minimum(np.maximum(2.0 * (mom[kk, f, 3] - mom[kk, f, 0] * mom[kk, f, 1]) / vx,
                                                         0.0), 1.5)
    wfac_c = np.exp(gamma[0][None, None, :] * lw)
    wfac_p = np.exp(gamma[1][None, None, :] * lw)
    dc_all = (td_c - nz(mc)[:, None, :]) / np.sqrt(wfac_c)
    dp_all = (td_p - nz(mp)[:, None, :]) / np.sqrt(wfac_p)
    for f in range(n_sig):
        dc, dp = dc_all[..., f][ok_c[..., f]], dp_all[..., f][ok_p[..., f]]
        if dp.size >= 3 and dc.size >= 3:
            a = 1.0 / min(est_n[f] + 1.0, NOISE_EPOCHS)
            vp = (median1d(np.abs(dp)) / 0.6745) ** 2 / 2.0
            vc = (median1d(np.abs(dc)) / 0.6745) ** 2 / 2.0
            est_var_p[f] += a * (vp - est_var_p[f])
            est_var_c[f] += a * (vc - est_var_c[f])
            est_n[f] += 1
    return wfac_c, wfac_p


def test_noise_estimators_equal_numpy_over_many_epochs():
    rng = np.random.default_rng(2)
    lam = np.array([0.19029, 0.24421])
    st_ref = [np.zeros((2, 2, 4)), np.zeros((2, 2)), np.ones((2, 2)), np.full(2, 0.09), np.full(2, 1e-5), np.zeros(2)]
    st_k = [a.copy() for a in st_ref]
    for _ in range(400):                      # enough epochs for gamma to be estimated (>= MIN_EPOCHS)
        td_c, td_p, ok_c, ok_p = _tds(rng, n_sat=int(rng.integers(2, 14)))
        cn0 = rng.uniform(30, 52, size=td_c.shape)
        lw = np.log(np.minimum(np.maximum(10.0 ** ((45.0 - cn0) / 10.0), 0.25), 16.0))
        td_c *= np.exp(0.5 * lw)
        mc = nanmedian1(np.where(ok_c, td_c, np.nan))
        mp = nanmedian1(np.where(ok_p, td_p, np.nan))
        _numpy_noise(td_c, td_p, ok_c, ok_p, mc, mp, lw, lam, *st_ref)
        mom, gam_n, gamma, est_var_c, est_var_p, est_n = st_k
        xs, rs, off = cn0_growth_samples(td_c, td_p, ok_c, ok_p, mc, mp, lw, lam)
        cn0_growth_update(xs, np.log(rs), off, mom, gam_n, gamma, NOISE_EPOCHS, MIN_EPOCHS, 0.05, POW2)
        wfac_c, wfac_p = np.exp(gamma[0][None, None, :] * lw), np.exp(gamma[1][None, None, :] * lw)
        white_noise_update(td_c, td_p, ok_c, ok_p, mc, mp, wfac_c, wfac_p, est_var_c, est_var_p, est_n,
                           NOISE_EPOCHS, POW2)
        for a, b in zip(st_ref, st_k):
            assert np.array_equal(a, b)
    assert np.all(st_k[1] > MIN_EPOCHS) and not np.all(st_k[2] == 1.0)    # gamma was estimated
    assert 0.3 < st_k[2][0, 0] < 1.5          # code noise grows with the factor^1 put in (slope of ln|e|)


def test_round_newcomers_equals_the_dense_dd_products():
    """gnssatt.attitude.ambiguity.round_newcomers takes D x and diag(D P D^T) from the two non-zeros of each DD row:
    the same bits as the dense products (which only add exact zeros), on random states."""
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
        assert np.array_equal(ok1, ok) and np.array_equal(D1, D[ok]) and np.array_equal(v1, r[ok])


def test_measurement_rows_equal_the_numpy_assembly():
    rng = np.random.default_rng(10)
    for n_sig in (1, 2, 3):
        n_bl, n_sat = 2, 11
        b_idx = (3 + 8 * np.arange(n_bl))[:, None] + np.arange(3)[None, :]
        clk = b_idx[:, 0] + 3
        bias = np.full((n_bl, n_sig), -1, np.int64)
        bias[:, 1:] = clk[:, None] + 1 + np.arange(n_sig - 1)[None, :]
        pclk = clk[:, None] + n_sig + np.arange(n_sig)[None, :]
        amb_index = rng.integers(20, 60, size=(n_bl, n_sat, n_sig))
        u, cfac, lam = rng.normal(size=(n_sat, 3)), 1.0 + rng.normal(size=n_sat) * 1e-6, rng.uniform(0.1, 0.3, n_sig)
        sdc_c, sdp_c, pcv_m = rng.normal(size=(3, n_bl, n_sat, n_sig))
        use_c = rng.random((n_bl, n_sat, n_sig)) < 0.7
        use_p = use_c & (rng.random(use_c.shape) < 0.8)
        jc, sc, fc = np.nonzero(use_c)
        jp, sp, fp = np.nonzero(use_p)
        mc_n, m = jc.size, jc.size + jp.size
        cols = np.full((m, 5), -1, dtype=np.int64)
        coef = np.zeros((m, 5))
        jb, sb = np.concatenate([jc, jp]), np.concatenate([sc, sp])
        cols[:, 0:3], coef[:, 0:3] = b_idx[jb], -u[sb]
        cols[:mc_n, 3], cols[mc_n:, 3], coef[:, 3] = clk[jc], pclk[jp, fp], cfac[sb]
        if n_sig > 1:
            cols[:mc_n, 4], coef[:mc_n, 4] = bias[jc, fc], 1.0
        cols[mc_n:, 4], coef[mc_n:, 4] = amb_index[jp, sp, fp], lam[fp]
        z = np.concatenate([sdc_c[jc, sc, fc], sdp_c[jp, sp, fp] - pcv_m[jp, sp, fp]])
        out = measurement_rows(jc, sc, fc, jp, sp, fp, b_idx, u, cfac, clk, pclk, bias, amb_index, lam, sdc_c, sdp_c,
                               pcv_m)
        for a, b in zip(out, (cols, coef, z)):
            assert np.array_equal(a, b)
