"""gnssatt.attitude.update_kernels and gnssatt.estimation.ekf_kernels.sequential_update_sparse (numba) against
independent numpy references: the filter's former numpy code, the batch Joseph update, gnssatt.gnss.rotations.quest."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.ambiguity import round_newcomers
from gnssatt.attitude.filter import _cn0_factor, _mp_var
from gnssatt.attitude.kernels import measurement_rows
from gnssatt.attitude.update_kernels import (measurement_update, measurement_variances, phase_row_stats,
                                            quest_dcm, round_newcomers_rows, white_variances, warm_up)
from gnssatt.estimation.ekf import joseph_update, joseph_update_sparse, sparse_rows_to_dense
from gnssatt.estimation.ekf_kernels import sequential_update_sparse
from gnssatt.gnss import rotations as rot


def _spd(rng, n, scales):
    A = rng.normal(size=(n, n)) * scales[:, None]
    return A @ A.T + np.diag(scales ** 2) * 1e-3


def _rows(rng, n, m, k=5):
    cols = np.stack([rng.choice(n, size=k, replace=False) for _ in range(m)]).astype(np.int64)
    cols[rng.random((m, k)) < 0.15] = -1
    return cols, rng.normal(size=(m, k))


def test_sequential_update_equals_batch_update():
    """m scalar updates in turn = the batch Kalman update (textbook form and the sparse Joseph form), for either
    choice of the per-row form (joseph_ratio 0: all Joseph, inf: all short form, 1e3: mixed)."""
    rng = np.random.default_rng(0)
    for n, m in ((6, 1), (12, 7), (40, 30), (57, 80)):
        P = _spd(rng, n, 10.0 ** rng.uniform(-2, 1, n))
        x = rng.normal(size=n)
        cols, coef = _rows(rng, n, m)
        R = rng.uniform(0.01, 1.0, m) * 10.0 ** rng.uniform(-2, 0, m)
        z = rng.normal(size=m)
        H = sparse_rows_to_dense(cols, coef, n)
        x_ref, P_ref, _ = joseph_update(x, P, H, R, z - H @ x)
        x_sp, P_sp, _, ok = joseph_update_sparse(x, P, cols, coef, R, z - H @ x)
        assert ok
        for jr in (0.0, 1e3, np.inf):
            x1, P1 = x.copy(), P.copy()
            assert sequential_update_sparse(x1, P1, cols, coef, R, z, jr)
            assert np.array_equal(P1, P1.T)
            scale = np.sqrt(np.outer(np.diag(P_ref), np.diag(P_ref)))
            assert np.max(np.abs(P1 - P_ref) / scale) < 1e-9
            assert np.max(np.abs(P1 - P_sp) / scale) < 1e-9
            assert np.allclose(x1, x_ref, rtol=1e-9, atol=1e-9 * np.sqrt(np.diag(P_ref)).max())


def test_sequential_update_collapsing_a_large_variance_is_accurate_in_joseph_form():
    """A white clock of 300 m sigma fixed by mm-level phases (the filter's case): the Joseph rows keep P accurate
    to ~1e-9 of the posterior sigmas (compared with a long-double update)."""
    rng = np.random.default_rng(1)
    n, m = 20, 12
    P = _spd(rng, n, np.full(n, 1e-2))
    P[0, :] = P[:, 0] = 0.0
    P[0, 0] = 9e4
    cols = np.zeros((m, 3), np.int64)
    cols[:, 0] = 0
    cols[:, 1:] = np.stack([rng.choice(np.arange(1, n), 2, replace=False) for _ in range(m)])
    coef = rng.normal(size=(m, 3))
    coef[:, 0] = 1.0
    R = np.full(m, 1e-5)
    z = rng.normal(size=m)
    x = np.zeros(n)
    xl, Pl = x.astype(np.longdouble), P.astype(np.longdouble)
    for r in range(m):
        h = np.zeros(n, np.longdouble)
        h[cols[r]] += coef[r]
        ph = Pl @ h
        s = h @ ph + R[r]
        xl = xl + ph * ((z[r] - h @ xl) / s)
        Pl = Pl - np.outer(ph, ph) / s
    d = np.sqrt(np.diag(Pl).astype(float))
    x1, P1 = x.copy(), P.copy()
    assert sequential_update_sparse(x1, P1, cols, coef, R, z, 1e3)
    err_P = np.max(np.abs(P1 - Pl.astype(float)) / np.outer(d, d))
    err_x = np.max(np.abs(x1 - xl.astype(float)) / d)
    # the batch Joseph update of the same rows, for scale
    H = sparse_rows_to_dense(cols, coef, n)
    x2, P2, _, ok = joseph_update_sparse(x, P, cols, coef, R, z - H @ x)
    err_P2 = np.max(np.abs(P2 - Pl.astype(float)) / np.outer(d, d))
    err_x2 = np.max(np.abs(x2 - xl.astype(float)) / d)
    assert err_P < 1e-8 and err_x < 1e-6
    assert err_P < 3 * err_P2 and err_x < err_x2       # as accurate as the batch Joseph form (its x: S ill-conditioned)
    assert np.linalg.eigvalsh(P1).min() > -1e-12
    # the short form on every row loses more of P (the clock's 9e4 m^2 x 1e-16)
    x3, P3 = x.copy(), P.copy()
    assert sequential_update_sparse(x3, P3, cols, coef, R, z, np.inf)
    assert np.max(np.abs(P3 - Pl.astype(float)) / np.outer(d, d)) > 3 * err_P


def test_sequential_update_not_positive_leaves_the_prior():
    rng = np.random.default_rng(2)
    n = 8
    P = _spd(rng, n, np.ones(n))
    P[2, :] = P[:, 2] = 0.0                      # a row on state 2 alone with zero variance: s = 0
    P[0, 1] += 1e-17                             # not exactly symmetric: restored as given
    x = rng.normal(size=n)
    cols = np.array([[0, 1], [2, -1]], np.int64)
    coef = np.ones((2, 2))
    x1, P1 = x.copy(), P.copy()
    assert not sequential_update_sparse(x1, P1, cols, coef, np.array([1.0, 0.0]), np.ones(2), 1e3)
    assert np.array_equal(x1, x) and np.array_equal(P1, P)


def test_measurement_variances_equal_the_numpy_formulas():
    rng = np.random.default_rng(3)
    n_bl, n_sat, n_sig = 2, 12, 2
    for _ in range(50):
        use_c = rng.random((n_bl, n_sat, n_sig)) < 0.7
        use_p = use_c & (rng.random(use_c.shape) < 0.8)
        jc, sc, fc = np.nonzero(use_c)
        jp, sp, fp = np.nonzero(use_p)
        cn0 = rng.uniform(20, 55, (n_bl, n_sat, n_sig))
        cn0[rng.random(cn0.shape) < 0.1] = np.nan
        gamma = rng.uniform(0, 1.5, (2, n_sig))
        vc_f, vp_f = rng.uniform(0.01, 0.2, n_sig), rng.uniform(1e-6, 1e-5, n_sig)
        el_e = rng.uniform(-0.3, 1.6, (n_bl, n_sat))
        el_w = rng.uniform(-0.8, 1.6, (n_bl, n_sat))
        el_e[rng.random(el_e.shape) < 0.1] = np.nan
        el_w[rng.random(el_w.shape) < 0.1] = np.nan
        mp_sig = np.array([0.15, 0.9, 0.0015, 0.006])
        mult = rng.uniform(0.1, 3.0)
        for growth, elev, mp in ((True, False, True), (False, True, False), (True, True, True)):
            var = np.concatenate([vc_f[fc], vp_f[fp]])
            if growth:
                var = var * np.concatenate([_cn0_factor(cn0[jc, sc, fc]) ** gamma[0, fc],
                                            _cn0_factor(cn0[jp, sp, fp]) ** gamma[1, fp]])
            if elev:
                e = np.concatenate([el_e[jc, sc], el_e[jp, sp]])
                var = var * np.clip(1.0 / np.sin(np.maximum(np.nan_to_num(e, nan=0.5), 0.05)) ** 2, 1.0, 16.0)
            v_mp = np.zeros(var.size)
            if mp:
                v_mp = np.concatenate([_mp_var(np.pi / 2 - el_w[jc, sc], *mp_sig[:2]),
                                       _mp_var(np.pi / 2 - el_w[jp, sp], *mp_sig[2:])])
            out = measurement_variances(jc, sc, fc, jp, sp, fp, vc_f, vp_f, cn0, gamma, growth, el_e, elev, el_w, mp,
                                        mp_sig, mult)
            assert np.allclose(out[1], var, rtol=1e-14, atol=0)
            assert np.allclose(out[2], v_mp, rtol=1e-14, atol=0)
            assert np.allclose(out[0], var + v_mp * mult, rtol=1e-14, atol=0)


def test_white_variances():
    est, n = np.array([0.5, 0.01, 0.2]), np.array([20.0, 20.0, 3.0])
    assert np.array_equal(white_variances(est, n, 0.09, 10, True), [0.5, 0.09, 0.09])
    assert np.array_equal(white_variances(est, n, 0.09, 10, False), [0.09, 0.09, 0.09])


def _filter_epoch(rng, n_sig=2, n_bl=2, n_sat=10):
    """A random epoch in the filter's state layout: (args of measurement_update, pieces for the references)."""
    b_idx = (3 + 8 * np.arange(n_bl))[:, None] + np.arange(3)[None, :]
    clk = b_idx[:, 0] + 3
    bias = np.full((n_bl, n_sig), -1, np.int64)
    bias[:, 1:] = clk[:, None] + 1 + np.arange(n_sig - 1)[None, :]
    pclk = clk[:, None] + n_sig + np.arange(n_sig)[None, :]
    nfp = 3 + 8 * n_bl
    use_c = rng.random((n_bl, n_sat, n_sig)) < 0.8
    use_p = use_c & (rng.random(use_c.shape) < 0.9)
    n_amb = int(use_p.sum())
    amb_index = np.full((n_bl, n_sat, n_sig), -1, np.int64)
    amb_index[use_p] = nfp + rng.permutation(n_amb)
    n = nfp + n_amb
    P = _spd(rng, n, 10.0 ** rng.uniform(-2, 0, n))
    x = rng.normal(size=n)
    u = rng.normal(size=(n_sat, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    cfac, lam = 1.0 + rng.normal(size=n_sat) * 1e-6, np.array([0.19, 0.244, 0.25])[:n_sig]
    sdc_c, sdp_c = rng.normal(size=(2, n_bl, n_sat, n_sig))
    pcv_m = rng.normal(size=(n_bl, n_sat, n_sig)) * 1e-3
    jc, sc, fc = np.nonzero(use_c)
    jp, sp, fp = np.nonzero(use_p)
    cn0 = rng.uniform(30, 50, (n_bl, n_sat, n_sig))
    el_w = rng.uniform(0.1, 1.5, (n_bl, n_sat))
    amb_fixed = rng.random(n_amb) < 0.7
    amb_key = np.zeros((n_amb, 3), np.int64)
    amb_key[amb_index[use_p] - nfp] = np.stack(np.nonzero(use_p), 1)
    args = (x, P, jc, sc, fc, jp, sp, fp, b_idx, u, cfac, clk, pclk, bias, amb_index, lam, sdc_c, sdp_c, pcv_m,
            np.full(n_sig, 0.09), np.full(n_sig, 1e-5), cn0, np.ones((2, n_sig)), True, el_w, False, el_w, True,
            np.array([0.15, 0.9, 0.0015, 0.006]), 1.3, amb_fixed, nfp, np.zeros(n_amb), 7.0, 1e3, amb_key, n_bl, n_sat)
    return args


def test_measurement_update_equals_rows_variances_batch_update_and_postfit():
    rng = np.random.default_rng(4)
    for _ in range(20):
        args = _filter_epoch(rng)
        x, P = args[0].copy(), args[1].copy()
        amb_fixed, nfp, last_t = args[30], args[31], args[32]
        cols, coef, z = measurement_rows(*args[2:19])
        var, v_white, v_mp = measurement_variances(*args[2:8], *args[19:30])
        H = sparse_rows_to_dense(cols, coef, x.size)
        x_ref, P_ref, _ = joseph_update(x, P, H, var, z - H @ x)
        out = measurement_update(*args)
        assert out[6]
        for a, b in zip(out[:3], (cols, coef, z)):
            assert np.array_equal(a, b)
        assert np.array_equal(out[3], var) and np.array_equal(out[4], v_mp)
        sd = np.sqrt(np.diag(P_ref))
        assert np.max(np.abs(args[1] - P_ref) / np.outer(sd, sd)) < 1e-9            # P updated in place
        assert np.max(np.abs(args[0] - x_ref) / sd) < 1e-9
        post_ref = z - H @ x_ref
        assert np.allclose(out[5], post_ref, rtol=0, atol=1e-9)
        mc_n = args[2].size
        rows = mc_n + np.flatnonzero(amb_fixed[cols[mc_n:, 4] - nfp])
        hph = np.einsum("ij,jk,ik->i", H[rows], P_ref, H[rows])
        one_h = np.clip(1.0 - hph / var[rows], 0.05, 1.0)
        assert out[9] == rows.size
        assert np.isclose(out[7], np.sum(post_ref[rows] ** 2 / one_h - v_white[rows]), rtol=1e-7)
        assert np.isclose(out[8], np.sum(v_mp[rows]), rtol=1e-13)
        assert np.all(last_t[cols[mc_n:, 4] - nfp] == 7.0)
        stats = phase_row_stats(args[5], args[6], cols, mc_n, amb_fixed, nfp, out[5], args[36], args[37])
        for a, b in zip(out[10:15], stats):
            assert np.array_equal(a, b, equal_nan=True)
        has_fix = np.zeros(args[36], bool)
        has_fix[args[35][amb_fixed, 0]] = True
        assert np.array_equal(out[15], has_fix)


def test_phase_row_stats_equal_numpy_counts():
    rng = np.random.default_rng(5)
    for _ in range(100):
        n_bl, n_sat = 3, 9
        mp_n = int(rng.integers(0, 30))
        jp, sp = rng.integers(0, n_bl, mp_n), rng.integers(0, n_sat, mp_n)
        mc_n = int(rng.integers(0, 5))
        nfp = 10
        cols = np.full((mc_n + mp_n, 5), -1, np.int64)
        cols[mc_n:, 4] = nfp + rng.permutation(mp_n)
        amb_fixed = rng.random(mp_n) < 0.6
        post = rng.normal(size=mc_n + mp_n)
        n_used, n_fixed, n_unfixed, n_fix_rows, ms = phase_row_stats(jp, sp, cols, mc_n, amb_fixed, nfp, post, n_bl,
                                                                     n_sat)
        fx = amb_fixed[cols[mc_n:, 4] - nfp]
        for j in range(n_bl):
            assert n_used[j] == np.unique(sp[jp == j]).size
            assert n_fixed[j] == np.unique(sp[(jp == j) & fx]).size
            assert n_unfixed[j] == np.sum((jp == j) & ~fx)
            sel = (jp == j) & fx
            assert n_fix_rows[j] == sel.sum()
            if sel.any():
                assert ms[j] == np.mean(post[mc_n:][sel] ** 2)
            else:
                assert np.isnan(ms[j])


def test_round_newcomers_rows_equal_the_numpy_branch():
    """The filter's former newcomer loop (round_newcomers per signal, reference = first fixed ambiguity of the
    signal, else the highest newcomer), on random states."""
    rng = np.random.default_rng(6)
    for _ in range(300):
        n_sig, nfp = 2, 5
        n_amb = int(rng.integers(2, 25))
        n = nfp + n_amb
        A = rng.normal(size=(n, n)) * 0.02
        P = A @ A.T
        x = np.round(rng.normal(size=n) * 20) + rng.normal(size=n) * 0.08
        amb_key = np.stack([rng.integers(0, 2, n_amb), rng.integers(0, 30, n_amb), rng.integers(0, n_sig, n_amb)], 1)
        amb_fixed = rng.random(n_amb) < 0.5
        j = 0
        mine = np.flatnonzero(amb_key[:, 0] == j)
        use = mine[rng.random(mine.size) < 0.8]
        idx_j, sig_j = nfp + use, amb_key[use, 2]
        el_j = rng.uniform(0, 1.5, use.size)
        el_j[rng.random(use.size) < 0.05] = np.nan
        fixed_j = amb_fixed[idx_j - nfp]
        ref_fixed = amb_fixed.copy()
        new_r, ref_r, v_r = [], [], []
        for f in range(n_sig):
            grp = np.flatnonzero((amb_key[:, 0] == j) & (amb_key[:, 2] == f) & ref_fixed)
            cand = idx_j[(sig_j == f) & ~fixed_j]
            if cand.size == 0:
                continue
            if grp.size:
                ref = nfp + grp[0]
            else:
                sel_f = (sig_j == f) & ~fixed_j
                ref = idx_j[sel_f][int(np.argmax(el_j[sel_f]))]
                cand = cand[cand != ref]
                if cand.size == 0:
                    continue
            D, v, okm = round_newcomers(x, P, cand, ref, 0.1, 0.2)
            if okm.any():
                new_r += cand[okm].tolist()
                ref_r += [ref] * int(okm.sum())
                v_r += v.tolist()
                ref_fixed[cand[okm] - nfp] = True
                ref_fixed[ref - nfp] = True
        af = amb_fixed.copy()
        nw, rf, vals = round_newcomers_rows(x, P, amb_key, af, nfp, idx_j, sig_j, el_j, n_sig, j, 0.1, 0.2)
        assert nw.tolist() == new_r and rf.tolist() == ref_r and vals.tolist() == v_r
        assert np.array_equal(af, ref_fixed)


def test_quest_dcm_equals_rotations_quest():
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(2, 5))
        body = rng.normal(size=(n, 3)) * rng.uniform(0.3, 3.0, (n, 1))
        q_true = rot.quat_normalize(rng.normal(size=4))
        R_true = rot.quat_to_dcm(q_true)
        ref = body @ R_true + rng.normal(size=(n, 3)) * 1e-3          # b_ref = R^T b_body (rows), noisy
        w = np.linalg.norm(body, axis=1)
        w = w / w.sum()
        q, _ = rot.quest(body[None], ref[None], w[None])
        R = quest_dcm(ref, body, w)
        assert np.allclose(R, rot.quat_to_dcm(q[0]), rtol=0, atol=1e-12)
    # parallel directions: no attitude (NaN), as rotations.quest
    body = np.array([[1.0, 0, 0], [2.0, 0, 0]])
    assert np.isnan(quest_dcm(body.copy(), body, np.array([0.5, 0.5]))).all()
    assert np.isnan(rot.quest(body[None], body[None], np.array([[0.5, 0.5]]))[0]).all()


def test_warm_up_runs():
    warm_up()


def test_fix_newcomers_constrains_like_the_batch_joseph_pseudo_update():
    """fix_newcomers = round_newcomers_rows + the DD pseudo-measurements of filter._pseudo_update (batch Joseph)."""
    from gnssatt.attitude.update_kernels import fix_newcomers

    rng = np.random.default_rng(8)
    n_checked = 0
    for _ in range(100):
        nfp, n_amb = 5, 12
        n = nfp + n_amb
        A = rng.normal(size=(n, n)) * 0.03
        P = A @ A.T + np.eye(n) * 1e-4
        x = np.round(rng.normal(size=n) * 20) + rng.normal(size=n) * 0.03
        amb_key = np.stack([np.zeros(n_amb, np.int64), np.arange(n_amb), rng.integers(0, 2, n_amb)], 1)
        amb_fixed = rng.random(n_amb) < 0.4
        idx_j, sig_j, el_j = nfp + np.arange(n_amb), amb_key[:, 2].copy(), rng.uniform(0, 1.5, n_amb)
        af1, af2 = amb_fixed.copy(), amb_fixed.copy()
        x1, P1 = x.copy(), P.copy()
        # the same rows as the filter passes them: phase rows of the update (cols[:, 4], jp, sp, fp), local elevations
        order = rng.permutation(n_amb)
        mc_n = 3
        cols = np.full((mc_n + n_amb, 5), -1, np.int64)
        cols[mc_n:, 4] = idx_j[order]
        jp = np.zeros(n_amb, np.int64)
        el_loc = el_j.copy()                       # row i: satellite sp[i] = order[i], state nfp + order[i]
        idx_j, sig_j, el_j = idx_j[order], sig_j[order], el_j[order]      # the row order fix_newcomers sees
        nw, rf, vals = round_newcomers_rows(x, P, amb_key, af1, nfp, idx_j, sig_j, el_j, 2, 0, 0.3, 0.3)
        nw2, rf2, vals2 = fix_newcomers(x1, P1, amb_key, af2, nfp, cols, mc_n, jp, order, sig_j, el_loc, 2, 0, 0.3,
                                        0.3, 1e-6)
        assert np.array_equal(nw, nw2) and np.array_equal(rf, rf2) and np.array_equal(vals, vals2)
        assert np.array_equal(af1, af2)
        if not nw.size:
            assert np.array_equal(x1, x) and np.array_equal(P1, P)
            continue
        n_checked += 1
        cols = np.stack([nw, rf], 1)
        coef = np.tile([1.0, -1.0], (nw.size, 1))
        x_ref, P_ref, _, ok = joseph_update_sparse(x, P, cols, coef, np.full(nw.size, 1e-6), vals - (x[nw] - x[rf]))
        assert ok
        assert np.allclose(x1, x_ref, rtol=0, atol=1e-9) and np.allclose(P1, P_ref, rtol=0, atol=1e-11)
        assert np.all(np.abs(x1[nw] - x1[rf] - vals) < 1e-3)
    assert n_checked > 20


def test_store_outputs():
    from gnssatt.attitude.update_kernels import store_outputs

    rng = np.random.default_rng(9)
    x, P = rng.normal(size=20), rng.normal(size=(20, 20))
    all_b_idx = np.array([3, 4, 5, 11, 12, 13], np.int64)
    out_b, out_P, out_w = np.full((4, 2, 3), np.nan), np.full((4, 6, 6), np.nan), np.full((4, 3), np.nan)
    out_ok, out_fixed, out_n = np.zeros((4, 2), bool), np.zeros((4, 2), bool), np.zeros((4, 2), np.int64)
    for pa, n_used, ever, n_fix in (([True, True], [5, 2], [True, True], [4, 3]),
                                    ([True, False], [3, 6], [True, False], [5, 6]),
                                    ([False, True], [7, 8], [False, True], [2, 4])):
        pa, n_used, ever, n_fix = np.array(pa), np.array(n_used), np.array(ever), np.array(n_fix)
        fixed_now = store_outputs(x, P, all_b_idx, 2, out_b, out_P, out_w, True, pa, n_used, ever, n_fix, 4, out_ok,
                                  out_fixed, out_n)
        assert np.array_equal(fixed_now, ever & (n_fix >= 4))
        assert np.array_equal(out_ok[2], pa & (n_used >= 3))
        assert np.array_equal(out_fixed[2], fixed_now & pa & (n_used >= 3)) and np.array_equal(out_n[2], n_used)
    assert np.array_equal(out_b[2], x[all_b_idx].reshape(2, 3)) and np.array_equal(out_P[2], P[np.ix_(all_b_idx,
                                                                                                      all_b_idx)])
    assert np.array_equal(out_w[2], x[:3]) and np.isnan(out_b[[0, 1, 3]]).all() and not out_ok[[0, 1, 3]].any()
    store_outputs(x, P, all_b_idx, 3, out_b, out_P, out_w, False, pa, n_used, ever, n_fix, 4, out_ok, out_fixed,
                  out_n)
    assert np.isnan(out_w[3]).all() and np.array_equal(out_b[3], out_b[2])
