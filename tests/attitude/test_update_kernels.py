"""gnssatt.attitude.update_kernels and gnssatt.estimation.ekf_kernels.sequential_update_sparse (numba) against the
library's readable reference (gnssatt.attitude.reference_update, gnssatt.estimation.ekf_reference: rows, variances,
the batch Joseph update, QUEST), through one adapter per kernel (tests/attitude/_kernel_calls.py).

Tolerances: the sequential scalar updates and the batch Joseph update are the same estimator computed in a
different order, so they agree to rounding errors that grow with the conditioning of the problem. State errors
are stated in units of the posterior sigmas and covariance errors in units of sigma_i sigma_j, bounded by
C x eps x kappa, kappa the condition number of the prior's correlation matrix (what the rounding of an update is
amplified by); residuals in metres, counts and flags exactly.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gnssatt.attitude import reference_update as RU
from gnssatt.attitude.reference_noise import cn0_variance_factor, multipath_variance_m2
from gnssatt.estimation.ekf import joseph_update_sparse
from gnssatt.estimation.ekf_reference import joseph_update, sparse_rows_to_dense
from gnssatt.gnss import rotations as rot
from tests.attitude._kernel_calls import (call_fix_newcomers, call_measurement_update, call_measurement_variances,
                                          call_phase_row_stats, call_quest_dcm, call_round_newcomers_rows,
                                          call_sequential_update, call_store_outputs, call_update_epoch,
                                          call_white_variances, close, same)

EPS = np.finfo(float).eps


def _spd(rng, n, scales):
    A = rng.normal(size=(n, n)) * scales[:, None]
    return A @ A.T + np.diag(scales ** 2) * 1e-3


def _rows(rng, n, m, k=5):
    cols = np.stack([rng.choice(n, size=k, replace=False) for _ in range(m)]).astype(np.int64)
    cols[rng.random((m, k)) < 0.15] = -1
    return cols, rng.normal(size=(m, k))


def _kappa(P):
    """Condition number of the correlation matrix of P (the scale-free conditioning of the update)."""
    d = np.sqrt(np.diag(P))
    return float(np.linalg.cond(P / np.outer(d, d)))


def _sigma_errors(x1, P1, x_ref, P_ref):
    """(max |x1 - x_ref| / sigma, max |P1 - P_ref| / (sigma_i sigma_j)) with the reference's posterior sigmas."""
    sd = np.sqrt(np.diag(P_ref))
    return np.max(np.abs(x1 - x_ref) / sd), np.max(np.abs(P1 - P_ref) / np.outer(sd, sd))


def test_sequential_update_equals_batch_update():
    """m scalar updates in turn = the batch Kalman update (textbook form and the sparse Joseph form), for either
    choice of the per-row form (joseph_ratio 0: all Joseph, inf: all short form, 1e3: mixed); state and
    covariance within 100 eps kappa in sigma units."""
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
        tol = 100 * EPS * _kappa(P)
        for jr in (0.0, 1e3, np.inf):
            good, x1, P1 = call_sequential_update(x, P, cols, coef, R, z, jr)
            assert good
            close(P1, P1.T, rtol=0, atol=EPS * np.abs(P1).max(), what="symmetric")
            err_x, err_P = _sigma_errors(x1, P1, x_ref, P_ref)
            assert err_x < tol and err_P < tol, (err_x, err_P, tol)
            assert _sigma_errors(x1, P1, x_sp, P_sp)[1] < tol


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
    good, x1, P1 = call_sequential_update(x, P, cols, coef, R, z, 1e3)
    assert good
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
    good, x3, P3 = call_sequential_update(x, P, cols, coef, R, z, np.inf)
    assert good
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
    good, x1, P1 = call_sequential_update(x, P, cols, coef, np.array([1.0, 0.0]), np.ones(2), 1e3)
    assert not good
    # the prior restored from the kernel's own copy: same implementation, so its exact bits (P[0, 1] != P[1, 0])
    assert x1.tobytes() == x.tobytes() and P1.tobytes() == P.tobytes()


def _variance_inputs(rng, n_bl, n_sat, n_sig):
    use_c = rng.random((n_bl, n_sat, n_sig)) < 0.7
    use_p = use_c & (rng.random(use_c.shape) < 0.8)
    cn0 = rng.uniform(20, 55, (n_bl, n_sat, n_sig))
    cn0[rng.random(cn0.shape) < 0.1] = np.nan
    el_e = rng.uniform(-0.3, 1.6, (n_bl, n_sat))
    el_w = rng.uniform(-0.8, 1.6, (n_bl, n_sat))
    el_e[rng.random(el_e.shape) < 0.1] = np.nan
    el_w[rng.random(el_w.shape) < 0.1] = np.nan
    z3 = np.zeros((n_bl, n_sat, n_sig))
    obs = RU.UpdateObs(np.zeros((n_sat, 3)), np.ones(n_sat), np.ones((n_sat, n_sig)), z3, z3, z3, cn0, el_e, el_w)
    return RU.UsedRows.from_masks(use_c, use_p), obs


def test_measurement_variances_equal_the_numpy_formulas():
    """Variances (m^2) relative 1e-13: products of a few factors and one power / sine (a few ulps each)."""
    rng = np.random.default_rng(3)
    n_bl, n_sat, n_sig = 2, 12, 2
    for _ in range(50):
        rows, obs = _variance_inputs(rng, n_bl, n_sat, n_sig)
        gamma = rng.uniform(0, 1.5, (2, n_sig))
        vc_f, vp_f = rng.uniform(0.01, 0.2, n_sig), rng.uniform(1e-6, 1e-5, n_sig)
        mp_sig = np.array([0.15, 0.9, 0.0015, 0.006])
        mult = rng.uniform(0.1, 3.0)
        for growth, elev, mp in ((True, False, True), (False, True, False), (True, True, True)):
            model = RU.VarianceModel(vc_f, vp_f, gamma, growth, elev, mp, mp_sig, mult)
            var, v_white, v_mp = RU.measurement_variances(rows, obs, model)
            out = call_measurement_variances(rows, obs, model)
            close(out[1], v_white, rtol=1e-13, what="v_white")
            close(out[2], v_mp, rtol=1e-13, atol=1e-300, what="v_mp")
            close(out[0], var, rtol=1e-13, what="var")
    # the reference's factors themselves, at their definition points
    close(cn0_variance_factor(np.array([45.0, 35.0, 60.0, 20.0, np.nan])), [1.0, 10.0, 0.25, 16.0, 1.0], rtol=1e-15)
    close(multipath_variance_m2(np.array([0.0, np.pi / 2, np.pi, np.nan]), 0.1, 0.5),
          [0.01, 0.25, (0.1 + 0.4 * 16 / 9) ** 2, 0.25], rtol=1e-14)


def test_white_variances():
    est, n = np.array([0.5, 0.01, 0.2]), np.array([20.0, 20.0, 3.0])
    for estimate, expected in ((True, [0.5, 0.09, 0.09]), (False, [0.09, 0.09, 0.09])):
        ref = RU.white_variances(est, n, 0.09, 10, estimate)
        close(ref, expected, rtol=1e-15, what="reference")                 # selections of given values
        close(call_white_variances(est, n, 0.09, 10, estimate), ref, rtol=1e-15, what="kernel")


_REALISTIC_SCALES = {"omega": 1e-3, "baseline": 1e-2, "clock": 300.0, "bias": 1.0, "phase_clock": 300.0,
                     "ambiguity": 5.0}


def _filter_epoch(rng, realistic=False, n_sig=2, n_bl=2, n_sat=10):
    """A random epoch in the filter's state layout: (x, P, rows, layout, obs, model, fix, amb_last_t).

    realistic: the filter's magnitudes (sigmas: omega 1e-3 rad/s, baselines 1 cm, white clocks 300 m, code
    biases 1 m, ambiguities 5 cycles; Table 1 noise; GPS L1/L2 wavelengths; lines of sight of a real sky);
    else state sigmas spread over 1e-2..1."""
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
    if realistic:
        s = np.full(n, _REALISTIC_SCALES["ambiguity"])
        s[:3] = _REALISTIC_SCALES["omega"]
        s[b_idx.ravel()] = _REALISTIC_SCALES["baseline"]
        s[clk], s[pclk.ravel()] = _REALISTIC_SCALES["clock"], _REALISTIC_SCALES["phase_clock"]
        s[bias[:, 1:].ravel()] = _REALISTIC_SCALES["bias"]
        P = _spd(rng, n, s * rng.uniform(0.5, 2.0, n)) / n
        x = rng.normal(size=n) * s
    else:
        P = _spd(rng, n, 10.0 ** rng.uniform(-2, 0, n))
        x = rng.normal(size=n)
    u = rng.normal(size=(n_sat, 3))
    if realistic:
        u[:, 2] = np.abs(u[:, 2]) + 0.1                       # above the horizon
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    lam = np.array([0.19029, 0.24421, 0.2548])[:n_sig]
    sdc_c, sdp_c = rng.normal(size=(2, n_bl, n_sat, n_sig)) * (np.array([0.3, 0.003])[:, None, None, None]
                                                                if realistic else 1.0)
    obs = RU.UpdateObs(u, 1.0 + rng.normal(size=n_sat) * 1e-6, np.repeat(np.atleast_1d(lam)[None, :], n_sat, axis=0), sdc_c, sdp_c,
                       rng.normal(size=(n_bl, n_sat, n_sig)) * 1e-3, rng.uniform(30, 50, (n_bl, n_sat, n_sig)),
                       rng.uniform(0.1, 1.5, (n_bl, n_sat)), rng.uniform(0.1, 1.5, (n_bl, n_sat)))
    model = RU.VarianceModel(np.full(n_sig, 0.09), np.full(n_sig, 1e-5), np.ones((2, n_sig)), True, False, True,
                             np.array([0.15, 0.9, 0.0015, 0.006]), 1.3)
    amb_key = np.zeros((n_amb, 3), np.int64)
    amb_key[amb_index[use_p] - nfp] = np.stack(np.nonzero(use_p), 1)
    fix = RU.FixState(rng.random(n_amb) < 0.7, amb_key)
    layout = RU.StateLayout(b_idx, clk, pclk, bias, amb_index, nfp)
    return x, P, RU.UsedRows.from_masks(use_c, use_p), layout, obs, model, fix, np.zeros(n_amb)


def _fixed_rows(ref: RU.UpdateResult, rows: RU.UsedRows, fix: RU.FixState) -> np.ndarray:
    """Rows of the update whose ambiguity is fixed (the rows of the multipath sums and the fix monitor)."""
    return rows.n_code + np.flatnonzero(fix.amb_fixed[ref.updated_ambiguities])


def _update_tolerances(x, P, ref: RU.UpdateResult) -> tuple[float, float]:
    """(tol_x, tol_P) in posterior sigma units for the kernel's sequential update against the batch reference.

    P: both forms round at ~eps relative to P's correlation structure, amplified by its conditioning: 100 eps
    kappa(P) (observed <= 0.8 eps kappa). x: the update moves x by K nu, and both solve with S =
    H P H^T + R, so the error is ~ eps kappa(S) x the move (in sigmas; observed <= 0.17 of it over 600 random and
    realistic epochs): 4 eps kappa(S) x max |x+ - x-| / sigma+. (The former fixed 1e-9 failed on some CPUs at
    1.02e-9.)"""
    H = sparse_rows_to_dense(ref.cols, ref.coef, x.size)
    S = H @ P @ H.T + np.diag(ref.var_m2)
    move = np.max(np.abs(ref.x - x) / np.sqrt(np.diag(ref.P)))
    return 4 * EPS * _kappa(S) * max(move, 1.0), 100 * EPS * _kappa(P)


def _compare_update(out: dict, ref: RU.UpdateResult, rows: RU.UsedRows, fix: RU.FixState, tol: tuple):
    """Kernel update against the reference: rows (copies) and variances relative 1e-13, x and P within tol =
    (tol_x, tol_P) posterior sigmas, post-fit residuals and the multipath sums within the bounds those imply."""
    tol_sigma, tol_P = tol
    same(out["cols"], ref.cols, "cols")
    close(out["coef"], ref.coef, rtol=1e-15, what="coef")
    close(out["z"], ref.z, rtol=1e-15, atol=1e-15, what="z (m)")
    close(out["var_m2"], ref.var_m2, rtol=1e-13, what="var (m^2)")
    close(out["v_mp_m2"], ref.v_mp_m2, rtol=1e-13, what="v_mp (m^2)")
    err_x, err_P = _sigma_errors(out["x"], out["P"], ref.x, ref.P)
    assert err_x < tol_sigma and err_P < tol_P, (err_x, err_P, tol)
    # post = z - H x+: its error is H (x_k - x_ref), at most |H| (err_x sigma) per row (m)
    H = sparse_rows_to_dense(ref.cols, ref.coef, ref.x.size)
    sd = np.sqrt(np.diag(ref.P))
    d_post = tol_sigma * (np.abs(H) @ sd) + 1e-12
    assert np.all(np.abs(out["post_m"] - ref.post_m) <= d_post), "post-fit residuals (m)"
    assert out["n_mp"] == ref.n_mp
    # the multipath sums, bounded by propagating those errors: post^2 / (1 - h) moves by (2 |post| d + d^2) / 0.05
    # (1 - h >= 0.05) and by post^2 / 0.05^2 x dh, dh = |H| dP |H|^T / var <= tol_sigma (|H| sd)^2 / var
    rows_fx = _fixed_rows(ref, rows, fix)
    p, d = np.abs(ref.post_m[rows_fx]), d_post[rows_fx]
    dh = tol_P * (np.abs(H[rows_fx]) @ sd) ** 2 / ref.var_m2[rows_fx]
    bound_num = np.sum((2 * p * d + d * d) / 0.05 + p * p / 0.05 ** 2 * dh) + 1e-13 * np.sum(ref.var_m2[rows_fx])
    assert abs(out["mp_num"] - ref.mp_num) <= bound_num, ("mp_num (m^2)", out["mp_num"], ref.mp_num, bound_num)
    close(out["mp_den"], ref.mp_den, rtol=1e-13, atol=1e-300, what="mp_den (m^2)")
    bound_ms = np.max(2 * p * d + d * d, initial=0.0) + 1e-15
    close(out["ms_fix_m2"], ref.stats.ms_fix_m2, rtol=1e-13, atol=bound_ms, what="ms_fix (m^2)")
    for name in ("n_used", "n_fixed_used", "n_unfixed", "n_fix_rows"):
        same(out[name], getattr(ref.stats, name), name)
    close(out["ms_fix_m2"], ref.stats.ms_fix_m2, rtol=1e-6, atol=1e-9 * np.max(ref.var_m2), what="ms_fix (m^2)")
    same(out["has_fix"], ref.has_fix, "has_fix")


@pytest.mark.parametrize("realistic", [False, True], ids=["random", "realistic"])
def test_measurement_update_equals_rows_variances_batch_update_and_postfit(realistic):
    """The kernel's one-call update (sequential scalar rows) against reference_update.measurement_update (batch
    Joseph): x and P within tolerances of the posterior sigmas set by the conditioning (_update_tolerances), on
    random states and on states of the filter's magnitudes."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        x, P, rows, layout, obs, model, fix, last_t = _filter_epoch(rng, realistic)
        n_bl, n_sat = obs.el_w_rad.shape
        ref = RU.measurement_update(x, P, rows, layout, obs, model, fix, n_bl, n_sat)
        out = call_measurement_update(x, P, rows, layout, obs, model, fix, last_t, 7.0, 1e3, n_bl, n_sat)
        assert out["good"]
        _compare_update(out, ref, rows, fix, _update_tolerances(x, P, ref))
        close(out["amb_last_t_s"][ref.updated_ambiguities], 7.0, rtol=1e-15, what="last used (s)")
        stats = call_phase_row_stats(rows, ref.cols, fix, out["post_m"], layout.n_fixed_part, n_bl, n_sat)
        for name in ("n_used", "n_fixed_used", "n_unfixed", "n_fix_rows"):
            same(stats[name], out[name], name)
        close(stats["ms_fix_m2"], out["ms_fix_m2"], rtol=1e-15, what="ms_fix: the same kernel code")


def test_update_epoch_is_white_variances_then_measurement_update():
    """The filter's one call (update_epoch) = reference_update.white_variances of code and phase from the estimator
    state, then measurement_update with them: the white variances relative 1e-15 (selections of given values);
    everything else within 4 eps relative (the same compiled arithmetic, reached through a second kernel), with
    and without noise estimation, estimates below and above the floors."""
    rng = np.random.default_rng(9)
    for trial in range(20):
        x, P, rows, layout, obs, model, fix, last_t = _filter_epoch(rng, realistic=bool(trial % 2))
        n_sig = model.gamma.shape[1]
        est = dict(est_var_code_m2=rng.uniform(0.01, 0.2, n_sig), est_var_phase_m2=rng.uniform(1e-6, 3e-5, n_sig),
                   est_n=rng.choice([3.0, 10.0, 50.0], n_sig), floor_code_m2=0.09, floor_phase_m2=1e-5,
                   min_epochs=10, estimate=bool(trial % 4 < 2))
        vc = RU.white_variances(est["est_var_code_m2"], est["est_n"], est["floor_code_m2"], 10, est["estimate"])
        vp = RU.white_variances(est["est_var_phase_m2"], est["est_n"], est["floor_phase_m2"], 10, est["estimate"])
        n_bl, n_sat = obs.el_w_rad.shape
        ref = call_measurement_update(x, P, rows, layout, obs, dataclasses.replace(model, var_code_m2=vc,
                                                                                  var_phase_m2=vp),
                                      fix, last_t, 7.0, 1e3, n_bl, n_sat)
        out = call_update_epoch(x, P, rows, layout, obs, model, est, fix, last_t, 7.0, 1e3)
        close(out["var_code_m2"], vc, rtol=1e-15, what="white code variance (m^2)")
        close(out["var_phase_m2"], vp, rtol=1e-15, what="white phase variance (m^2)")
        for name, value in ref.items():
            if np.asarray(value).dtype.kind in "biu":
                same(out[name], value, name)
            else:
                close(out[name], value, rtol=4 * EPS, atol=1e-300, what=name)


def test_phase_row_stats_equal_numpy_counts():
    """Counts exactly; the mean square post-fit residual (m^2) relative 1e-14 (a mean of <= 30 squares)."""
    rng = np.random.default_rng(5)
    for _ in range(100):
        n_bl, n_sat = 3, 9
        mp_n = int(rng.integers(0, 30))
        jp, sp = rng.integers(0, n_bl, mp_n), rng.integers(0, n_sat, mp_n)
        mc_n = int(rng.integers(0, 5))
        nfp = 10
        z0 = np.zeros(mc_n, np.int64)
        rows = RU.UsedRows(z0, z0, z0, jp, sp, np.zeros(mp_n, np.int64))
        cols = np.full((mc_n + mp_n, 5), -1, np.int64)
        cols[mc_n:, 4] = nfp + rng.permutation(mp_n)
        fix = RU.FixState(rng.random(mp_n) < 0.6, np.zeros((mp_n, 3), np.int64))
        post = rng.normal(size=mc_n + mp_n)
        ref = RU.phase_row_stats(rows, cols, fix, post, nfp, n_bl, n_sat)
        out = call_phase_row_stats(rows, cols, fix, post, nfp, n_bl, n_sat)
        for name in ("n_used", "n_fixed_used", "n_unfixed", "n_fix_rows"):
            same(out[name], getattr(ref, name), name)
        close(out["ms_fix_m2"], ref.ms_fix_m2, rtol=1e-14, what="ms_fix (m^2)")
        assert np.array_equal(np.isnan(out["ms_fix_m2"]), ref.n_fix_rows == 0)        # NaN exactly where no row


def _newcomer_case(rng):
    n_sig, nfp = 2, 5
    n_amb = int(rng.integers(2, 25))
    n = nfp + n_amb
    A = rng.normal(size=(n, n)) * 0.02
    P = A @ A.T
    x = np.round(rng.normal(size=n) * 20) + rng.normal(size=n) * 0.08
    amb_key = np.stack([rng.integers(0, 2, n_amb), rng.integers(0, 30, n_amb), rng.integers(0, n_sig, n_amb)], 1)
    fix = RU.FixState(rng.random(n_amb) < 0.5, amb_key)
    mine = np.flatnonzero(amb_key[:, 0] == 0)
    use = mine[rng.random(mine.size) < 0.8]
    el_j = rng.uniform(0, 1.5, use.size)
    el_j[rng.random(use.size) < 0.05] = np.nan
    return x, P, fix, nfp, nfp + use, amb_key[use, 2], el_j, n_sig


def test_round_newcomers_rows_equal_the_numpy_branch():
    """The newcomer rounding per signal (reference = first fixed ambiguity of the signal, else the highest
    newcomer) on random states: the accepted DDs, their integers (whole cycles: within 1e-12 cycle) and the
    fixed flags."""
    rng = np.random.default_rng(6)
    limits = RU.RoundingLimits(0.1, 0.2)
    n_rounded = 0
    for _ in range(300):
        x, P, fix, nfp, idx_j, sig_j, el_j, n_sig = _newcomer_case(rng)
        new_r, ref_r, v_r, fixed_r = RU.round_newcomers_rows(x, P, fix, nfp, idx_j, sig_j, el_j, n_sig, 0, limits)
        nw, rf, vals, fixed_k = call_round_newcomers_rows(x, P, fix, nfp, idx_j, sig_j, el_j, n_sig, 0, limits)
        same(nw, new_r, "new")
        same(rf, ref_r, "ref")
        close(vals, v_r, atol=1e-12, what="integers (cycles)")
        same(fixed_k, fixed_r, "amb_fixed")
        n_rounded += nw.size
    assert n_rounded > 50                                   # the rounding branch was exercised


def test_quest_dcm_equals_rotations_quest():
    """The mask attitude against reference_update.mask_attitude_dcm (rotations.quest): DCM elements within 1e-12
    (= 2e-10 deg of rotation; both are eigenvectors of the same 4x4 K)."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(2, 5))
        body = rng.normal(size=(n, 3)) * rng.uniform(0.3, 3.0, (n, 1))
        q_true = rot.quat_normalize(rng.normal(size=4))
        R_true = rot.quat_to_dcm(q_true)
        ref = body @ R_true + rng.normal(size=(n, 3)) * 1e-3          # b_ref = R^T b_body (rows), noisy
        w = np.linalg.norm(body, axis=1)
        w = w / w.sum()
        R_ref = RU.mask_attitude_dcm(ref, body, w)
        R = call_quest_dcm(ref, body, w)
        close(R, R_ref, atol=1e-12, what="R_body_from_ref")
        angle_deg = np.degrees(np.arccos(np.clip((np.trace(R @ R_true.T) - 1) / 2, -1, 1)))
        assert angle_deg < 1.0                                          # and it is the attitude (noise 1e-3)
    # parallel directions: no attitude (NaN), as rotations.quest
    body = np.array([[1.0, 0, 0], [2.0, 0, 0]])
    assert np.isnan(call_quest_dcm(body.copy(), body, np.array([0.5, 0.5]))).all()
    assert np.isnan(RU.mask_attitude_dcm(body.copy(), body, np.array([0.5, 0.5]))).all()


def test_warm_up_runs():
    from gnssatt.attitude.update_kernels import warm_up

    warm_up()


def test_fix_newcomers_constrains_like_the_batch_joseph_pseudo_update():
    """fix_newcomers (rounding + sequential Joseph DD constraints) against reference_update.fix_newcomers (batch
    Joseph): the same DDs; x within 1e-9 cycles and P within 1e-11 cycles^2 (the constraints of variance 1e-6
    cycles^2 make S's condition ~ 1e4; both forms within ~1e3 eps of it); the constraint holds to 1e-3 cycle."""
    rng = np.random.default_rng(8)
    limits = RU.RoundingLimits(0.3, 0.3, 1e-6)
    n_checked = 0
    for _ in range(100):
        nfp, n_amb = 5, 12
        n = nfp + n_amb
        A = rng.normal(size=(n, n)) * 0.03
        P = A @ A.T + np.eye(n) * 1e-4
        x = np.round(rng.normal(size=n) * 20) + rng.normal(size=n) * 0.03
        amb_key = np.stack([np.zeros(n_amb, np.int64), np.arange(n_amb), rng.integers(0, 2, n_amb)], 1)
        fix = RU.FixState(rng.random(n_amb) < 0.4, amb_key)
        # the phase rows of the update as the filter passes them (cols[:, 4], jp, sp, fp), local elevations
        order = rng.permutation(n_amb)
        mc_n = 3
        cols = np.full((mc_n + n_amb, 5), -1, np.int64)
        cols[mc_n:, 4] = nfp + order
        z0 = np.zeros(mc_n, np.int64)
        rows = RU.UsedRows(z0, z0, z0, np.zeros(n_amb, np.int64), order, amb_key[order, 2])
        el_loc = rng.uniform(0, 1.5, n_amb)                  # row i: satellite sp[i] = order[i]
        x_ref, P_ref, new_r, ref_r, v_r, fixed_r = RU.fix_newcomers(x, P, fix, nfp, nfp + order, amb_key[order, 2],
                                                                    el_loc[order], 2, 0, limits)
        x1, P1, nw, rf, vals, fixed_k = call_fix_newcomers(x, P, fix, nfp, cols, rows, el_loc, 2, 0, limits)
        same(nw, new_r, "new")
        same(rf, ref_r, "ref")
        close(vals, v_r, atol=1e-12, what="integers (cycles)")
        same(fixed_k, fixed_r, "amb_fixed")
        close(x1, x_ref, atol=1e-9, what="x (cycles)")
        close(P1, P_ref, atol=1e-11, what="P (cycles^2)")
        if nw.size:
            n_checked += 1
            assert np.all(np.abs(x1[nw] - x1[rf] - vals) < 1e-3)
    assert n_checked > 20


def test_store_outputs():
    """The output row against reference_update.epoch_outputs: copies of states (within 1e-15 relative), flags and
    counts exactly; rows not written stay NaN / False."""
    rng = np.random.default_rng(9)
    x, P = rng.normal(size=20), rng.normal(size=(20, 20))
    all_b_idx = np.array([3, 4, 5, 11, 12, 13], np.int64)
    out = {"b_m": np.full((4, 2, 3), np.nan), "P_b_m2": np.full((4, 6, 6), np.nan),
           "omega_rad_s": np.full((4, 3), np.nan), "ok": np.zeros((4, 2), bool), "fixed": np.zeros((4, 2), bool),
           "n_sats": np.zeros((4, 2), np.int64)}
    for pa, n_used, ever, n_fix in (([True, True], [5, 2], [True, True], [4, 3]),
                                    ([True, False], [3, 6], [True, False], [5, 6]),
                                    ([False, True], [7, 8], [False, True], [2, 4])):
        pa, n_used, ever, n_fix = np.array(pa), np.array(n_used), np.array(ever), np.array(n_fix)
        ref = RU.epoch_outputs(x, P, all_b_idx, True, pa, n_used, ever, n_fix, 4)
        fixed_now = call_store_outputs(x, P, all_b_idx, 2, out, True, pa, n_used, ever, n_fix, 4)
        same(fixed_now, ref["fixed_now"], "fixed_now")
        for name in ("ok", "fixed", "n_sats"):
            same(out[name][2], ref[name], name)
    for name in ("b_m", "P_b_m2", "omega_rad_s"):
        close(out[name][2], ref[name], rtol=1e-15, what=name)
    assert np.isnan(out["b_m"][[0, 1, 3]]).all() and not out["ok"][[0, 1, 3]].any()
    call_store_outputs(x, P, all_b_idx, 3, out, False, pa, n_used, ever, n_fix, 4)
    assert np.isnan(out["omega_rad_s"][3]).all()
    close(out["b_m"][3], out["b_m"][2], rtol=1e-15, what="same state, same row")
