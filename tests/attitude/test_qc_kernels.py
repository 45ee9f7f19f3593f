"""gnssatt.attitude.qc_kernels (numba) give the bits of the numpy code of run_filter they replaced: each test runs
that numpy code (kept here as the reference) and the kernels on random epochs with events (clock jumps, slips,
half cycles, gaps, missing data) and compares every output."""
from __future__ import annotations

import numpy as np

from tests.attitude.test_attitude_kernels import _numpy_noise
from gnssatt.attitude.fastops import clip as _clip, nanmedian1, nz as _nz
from gnssatt.attitude.kernels import cn0_growth_samples
from gnssatt.attitude.qc_kernels import (clip_pair, epoch_geometry, growth_weights, propagate_dynamic,
                                        propagate_kinematic, qc_epoch, record_epoch, reset_white_clocks, td_checks)
from gnssatt.estimation.ekf_kernels import propagate_rotation_cov, rotation_rk4_stm_kernel

DEG = np.pi / 180.0
CLOCK_JUMP_M, TD_MAX_DT_S, NOISE_EPOCHS, MIN_EPOCHS = 0.5e-3 * 299792458.0 * 0.5, 3.0, 300.0, 10
TD_CODE_M, TD_PHASE_CYC, MAX_GAP_S, EL_MASK = 5.0, 0.5, 10.0, 5.0 * DEG
LAM = np.array([0.19029, 0.24421])


def _spd(rng, n):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


def test_propagation_equals_the_former_calls():
    rng = np.random.default_rng(3)
    for _ in range(50):
        n_bl = int(rng.integers(1, 4))
        blk = 5
        n = 3 + blk * n_bl + int(rng.integers(0, 20))
        b_idx = 3 + blk * np.arange(n_bl)[:, None] + np.arange(3)[None, :]
        white = np.unique(np.concatenate([b_idx[:, 2] + 1, b_idx[:, 2] + 2]))
        x, P = rng.normal(size=n), _spd(rng, n)
        Qw, dt, var = _spd(rng, 3) * 1e-6, float(rng.uniform(0.1, 3.0)), float(rng.uniform(1, 1e6))
        # the former filter code
        x0, P0 = x.copy(), P.copy()
        all_b = b_idx.ravel()
        b1, Pbb, Pbw = rotation_rk4_stm_kernel(x0[all_b].reshape(n_bl, 3), x0[0:3], dt, 1.0)
        x0[all_b] = b1.ravel()
        propagate_rotation_cov(P0, np.arange(3), b_idx, Pbb, Pbw, Qw, b1, dt)
        x0[white], P0[white, :], P0[:, white] = 0.0, 0.0, 0.0
        P0[white, white] = var
        x1, P1 = x.copy(), P.copy()
        Pbb1, Pbw1 = propagate_dynamic(x1, P1, np.arange(3), b_idx, Qw, dt, 1.0, white, var)
        assert np.array_equal(x0, x1) and np.array_equal(P0, P1)
        assert np.array_equal(Pbb, Pbb1) and np.array_equal(Pbw, Pbw1)
        # kinematic
        x0, P0, x1, P1 = x.copy(), P.copy(), x.copy(), P.copy()
        P0[all_b, all_b] += 1e-4 * dt
        x0[white], P0[white, :], P0[:, white] = 0.0, 0.0, 0.0
        P0[white, white] = var
        propagate_kinematic(x1, P1, all_b, 1e-4 * dt, white, var)
        assert np.array_equal(x0, x1) and np.array_equal(P0, P1)
        assert not np.array_equal(P0, P)                     # something happened
        x2, P2 = x.copy(), P.copy()
        reset_white_clocks(x2, P2, white, var)
        assert np.all(x2[white] == 0) and np.all(P2[white][:, white] == var * np.eye(white.size))


def test_clip_pair_is_np_clip():
    rng = np.random.default_rng(4)
    a, b = rng.normal(size=(7, 3)) * 2, rng.normal(size=(7, 3)) * 2
    a[0, 0] = np.nan
    out = np.empty((2, 7, 3))
    clip_pair(a, b, out)
    assert np.array_equal(out[0], np.clip(a, -1, 1), equal_nan=True) and np.array_equal(out[1], np.clip(b, -1, 1))


def test_epoch_geometry_equals_the_numpy_products():
    """np.dot in the kernel gives the bits of numpy's @ (both OpenBLAS) for the filter's shapes and layouts."""
    rng = np.random.default_rng(11)
    for _ in range(3000):
        n_sat, n_bl = int(rng.integers(0, 100)), int(rng.integers(1, 4))
        u = rng.normal(size=(n_sat, 3))
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        bs = rng.normal(size=(n_bl + 1, 3))
        ia, ib = np.zeros(n_bl, int), np.arange(1, n_bl + 1)
        bs_a_T, bs_b_T = bs[ia].T, bs[ib].T            # Fortran order, as run_filter passes (and used) them
        x = rng.normal(size=5 + 6 * n_bl)
        b_idx = 3 + 6 * np.arange(n_bl)[:, None] + np.arange(3)[None, :]
        asn = np.empty((2, n_sat, n_bl))
        los, ub = epoch_geometry(u, R, bs_a_T, bs_b_T, x, b_idx, asn)
        los_ref = u @ R.T
        assert np.array_equal(los, los_ref)
        assert np.array_equal(ub, x[b_idx.ravel()].reshape(n_bl, 3) @ u.T)
        assert np.array_equal(asn[0], _clip(los_ref @ boresight_T(bs, ia), -1, 1))
        assert np.array_equal(asn[1], _clip(los_ref @ boresight_T(bs, ib), -1, 1))


def boresight_T(bs, idx):
    return bs[idx].T


def _epoch(rng, n_bl, n_sat, n_sig, t, clk_true, amb_m, ub):
    """Random observations of one epoch (the SdBlock slice and the state inputs of the QC)."""
    sh = (n_bl, n_sat, n_sig)
    pa = rng.random(n_bl) < 0.95
    gv = rng.random(n_sat) < 0.9
    u = rng.normal(size=(n_sat, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u[~gv] = 0.0
    cfac = 1.0 - rng.uniform(-800, 800, n_sat) / 299792458.0
    geo = -ub                                   # SD = -u.b + clock + noise (+ ambiguity)
    sdc = geo[:, :, None] + cfac[None, :, None] * clk_true[:, None, None] + rng.normal(size=sh) * 0.3
    sdp = geo[:, :, None] + cfac[None, :, None] * clk_true[:, None, None] + rng.normal(size=sh) * 0.003 \
        + amb_m
    sdc[rng.random(sh) < 0.08] = np.nan
    sdp[rng.random(sh) < 0.08] = np.nan
    avail_c = np.isfinite(sdc) & pa[:, None, None] & gv[None, :, None]
    avail_p = np.isfinite(sdp) & avail_c
    reason0 = np.where(avail_c, 0, 8)
    reason0 = np.where((reason0 == 0) & (rng.random((1, n_sat, 1)) < 0.1), 1, reason0)
    low = rng.random(sh) < 0.1
    lli = np.where(rng.random(sh) < 0.04, rng.integers(1, 4, sh), 0).astype(np.int8)
    cn0 = rng.uniform(28, 52, sh)
    return pa, u, cfac, sdc, sdp, avail_c, avail_p, reason0, low, lli, cn0


def _numpy_qc(asn_a, asn_b, az, mask_on, ever_fixed, reason, empty, pcv_on, low, avail_p, sdc, sdp, cfac, ub,
              prev_ub, do_td, consecutive, prev_sdc, prev_sdp, pa, lli, t, clk, noise, lw, amb_index, amb_last_t,
              n_fixed_part):
    """run_filter's QC as it was written in numpy (before qc_kernels), up to the bookkeeping masks."""
    n_bl, n_sat, n_sig = sdc.shape
    prev_clk0, prev_clk0_t, clk_rate = clk
    el_ant = np.full((n_bl, n_sat), np.nan)
    az_ant = np.full((n_bl, n_sat), np.nan)
    el_w = np.fmin(asn_a, asn_b).T
    reason = reason.copy()
    if mask_on:
        el_ant[:] = el_w
        az_ant[:] = az[None, :]
        below = ever_fixed[:, None] & ~(el_ant >= EL_MASK)
        reason = np.where((reason == 0) & below[:, :, None], 2, reason)
    if pcv_on:
        reason = np.where((reason == 0) & empty, 10, reason)
    reason = np.where((reason == 0) & low, 3, reason)
    use_c = reason == 0
    use_p = use_c & avail_p
    c0 = (sdc[:, :, 0] + ub) / cfac[None, :]
    clk0_raw = nanmedian1(np.where(use_c[:, :, 0], c0, np.nan))
    have0 = np.isfinite(clk0_raw)
    clk_pred = prev_clk0 + clk_rate * (t - prev_clk0_t)
    clk0 = np.where(have0, clk0_raw, _nz(clk_pred))
    corr = cfac[None, :, None] * clk0[:, None, None]
    sdc_c = sdc - corr
    sdp_c = sdp - corr
    jump = have0 & np.isfinite(clk_pred) & (np.abs(clk0 - clk_pred) > CLOCK_JUMP_M) & pa
    upd = have0 & pa
    dtc = t - prev_clk0_t
    rate_ok = upd & ~jump & np.isfinite(prev_clk0) & (dtc > 0) & (dtc <= TD_MAX_DT_S)
    clk_rate = np.where(rate_ok, clk_rate + 0.1 * ((clk0 - prev_clk0) / np.where(dtc > 0, dtc, 1.0) - clk_rate),
                        clk_rate)
    prev_clk0 = np.where(upd, clk0, prev_clk0)
    prev_clk0_t = np.where(upd, t, prev_clk0_t)
    slip = (lli & 1).astype(bool) & avail_p
    half = (lli & 2).astype(bool) & avail_p
    reason = np.where((reason == 0) & half, 6, reason)
    use_p &= ~half
    td_p = np.full(sdp.shape, np.nan)
    out = {}
    ev_td = np.zeros(sdc.shape, bool)
    if do_td:
        dgeo = -(ub - prev_ub)
        td_c = sdc_c - prev_sdc - dgeo[:, :, None]
        td_p = sdp_c - prev_sdp - dgeo[:, :, None]
        td_c_ok = np.isfinite(td_c) & use_c
        td_p_ok = np.isfinite(td_p) & use_p
        mc = nanmedian1(np.where(td_c_ok, td_c, np.nan))
        mp = nanmedian1(np.where(td_p_ok, td_p, np.nan))
        out["n_common"] = int(np.sum(np.abs(_nz(mp - mc)) > 1000.0))
        out.update(td_c=td_c, td_c_ok=td_c_ok, td_p_ok=td_p_ok, mc=mc, mp=mp)
        if noise is not None:
            out["wfac"] = _numpy_noise(td_c, td_p, td_c_ok, td_p_ok, mc, mp, lw, LAM, *noise)
        bad_tc = td_c_ok & (np.abs(td_c - _nz(mc)[:, None, :]) > TD_CODE_M)
        td_p_chk = np.isfinite(td_p) & avail_p
        bad_tp = td_p_chk & (np.abs(td_p - _nz(mp)[:, None, :]) > TD_PHASE_CYC * LAM[None, None, :])
        reason = np.where((reason == 0) & bad_tc, 4, reason)
        use_c &= ~bad_tc
        slip |= bad_tp
        ev_td = bad_tp & ~((lli & 1).astype(bool))
    cont = np.isfinite(prev_sdp) if consecutive else np.zeros(avail_p.shape, bool)
    ev_lli = (lli & 1).astype(bool) & avail_p & ((amb_index >= 0) | cont)
    have = amb_index >= 0
    td_possible = np.isfinite(td_p) if do_td else np.zeros(have.shape, bool)
    restart = have & avail_p & (slip | ~td_possible)
    n_gap = int((have & avail_p & ~slip & ~td_possible).sum())
    last_t = np.full(have.shape, np.inf)
    last_t[have] = amb_last_t[amb_index[have] - n_fixed_part]
    drop_mask = restart | (have & ~avail_p) | (have & ~use_p & (last_t < t - MAX_GAP_S))
    need = use_p & (amb_index < 0)
    out.update(el_w=el_w, el_ant=el_ant, az_ant=az_ant, reason=reason, use_c=use_c, use_p=use_p, sdc_c=sdc_c,
               sdp_c=sdp_c, clk0=clk0, clk_pred=clk_pred, jump=jump, slip=slip, td_p=td_p, ev_td=ev_td,
               ev_lli=ev_lli, n_gap=n_gap, drop=drop_mask, need=need,
               clk=np.stack([prev_clk0, prev_clk0_t, clk_rate]))
    return out


def test_qc_epoch_and_td_checks_equal_the_numpy_qc_over_many_epochs():
    rng = np.random.default_rng(5)
    n_bl, n_sig = 2, 2
    noise_ref = [np.zeros((2, 2, 4)), np.zeros((2, 2)), np.ones((2, 2)), np.full(2, 0.09), np.full(2, 1e-5),
                 np.zeros(2)]
    noise_k = [a.copy() for a in noise_ref]
    clk_ref = np.stack([np.full(n_bl, np.nan), np.zeros(n_bl), np.zeros(n_bl)])
    clk_k = clk_ref.copy()
    seen = dict(common=0, jump=0, ev_td=0, ev_lli=0, gap=0, drop=0, need=0, half=0, reason2=0, reason4=0, reason10=0)
    n_sat = 12
    prev_sdc = np.full((n_bl, n_sat, n_sig), np.nan)
    prev_sdp = prev_sdc.copy()
    prev_ub = rng.normal(size=(n_bl, n_sat))
    clk_true = rng.normal(size=n_bl) * 1e3
    amb_m = rng.integers(-50, 50, (n_bl, n_sat, n_sig)) * LAM
    t = 0.0
    for k in range(400):
        dt = 1.0 if rng.random() < 0.95 else float(rng.choice([0.5, 5.0]))
        t += dt
        clk_true = clk_true + rng.normal(size=n_bl) * 3.0
        if rng.random() < 0.03:
            clk_true[int(rng.integers(n_bl))] += 1e5                    # a clock jump
        ub = prev_ub + rng.normal(size=(n_bl, n_sat)) * 0.01
        pa, u, cfac, sdc, sdp, avail_c, avail_p, reason0, low, lli, cn0 = _epoch(rng, n_bl, n_sat, n_sig, t,
                                                                                  clk_true, amb_m, ub)
        if rng.random() < 0.1:
            sdp[rng.integers(n_bl), rng.integers(n_sat), rng.integers(n_sig)] += 0.37      # a slip without LLI
        if rng.random() < 0.02:
            amb_m[int(rng.integers(n_bl)), :, 0] += 10000 * LAM[0]     # a clock jump applied to code only
        if rng.random() < 0.1:
            sdc[rng.integers(n_bl), rng.integers(n_sat), rng.integers(n_sig)] += 20.0      # a code outlier
        asn = np.arcsin(np.clip(rng.normal(size=(2, n_sat, n_bl)), -1, 1))
        asn[0, 0, 0] = np.nan
        az = rng.uniform(-np.pi, np.pi, n_sat)
        mask_on = bool(rng.random() < 0.7)
        ever_fixed = rng.random(n_bl) < 0.6
        pcv_on = bool(rng.random() < 0.3)
        empty = rng.random((n_bl, n_sat, n_sig)) < 0.1
        consecutive = k > 0 and dt <= TD_MAX_DT_S
        do_td = consecutive
        amb_index = np.where(rng.random((n_bl, n_sat, n_sig)) < 0.6, 20 + np.arange(n_bl * n_sat * n_sig).reshape(
            n_bl, n_sat, n_sig), -1)
        amb_last_t = t - rng.uniform(0, 15, n_bl * n_sat * n_sig)
        lw = np.log(np.minimum(np.maximum(10.0 ** ((45.0 - cn0) / 10.0), 0.25), 16.0))
        ref = _numpy_qc(asn[0], asn[1], az, mask_on, ever_fixed, reason0, empty, pcv_on, low, avail_p, sdc, sdp,
                        cfac, ub, prev_ub, do_td, consecutive, prev_sdc, prev_sdp, pa, lli, t, clk_ref,
                        noise_ref, lw, amb_index, amb_last_t, 20)
        clk_ref = ref["clk"]
        # the kernels, as run_filter calls them
        sh = (n_bl, n_sat, n_sig)
        w_el, w_reason = np.zeros((3, n_bl, n_sat)), np.zeros(sh, np.int64)
        wb, wf = np.zeros((5,) + sh, bool), np.zeros((4,) + sh)
        w_clk, w_jump, w_mcp = np.zeros((2, n_bl)), np.zeros(n_bl, bool), np.zeros((2, n_bl, n_sig))
        n_jump, n_common = qc_epoch(np.ascontiguousarray(asn), az, mask_on, ever_fixed, EL_MASK, reason0, empty,
                                    pcv_on, low, avail_p, sdc, sdp, cfac, ub, prev_ub, do_td, prev_sdc, prev_sdp,
                                    pa, lli, t, clk_k, CLOCK_JUMP_M, TD_MAX_DT_S, w_el[0], w_el[1], w_el[2],
                                    w_reason, wb, wf, w_clk, w_jump, w_mcp)
        w_glw = np.zeros((2,) + sh)
        mom, gam_n, gamma, est_var_c, est_var_p, est_n = noise_k
        if do_td:
            xs, rs, off = cn0_growth_samples(wf[2], wf[3], wb[3], wb[4], w_mcp[0], w_mcp[1], lw, LAM)
            growth_weights(True, xs, np.log(rs), off, mom, gam_n, gamma, NOISE_EPOCHS, MIN_EPOCHS, 0.05, lw, w_glw)
        wfac = np.exp(w_glw)
        ev, bk = np.zeros((2,) + sh, bool), np.zeros((2,) + sh, bool)
        n_td, n_lli, n_gap, n_drop, n_need = td_checks(
            do_td, True, wfac, est_var_c, est_var_p, est_n, NOISE_EPOCHS, TD_CODE_M, TD_PHASE_CYC, LAM, avail_p,
            lli, w_reason, wb, wf, w_mcp, consecutive, prev_sdp, amb_index, amb_last_t, 20, t, MAX_GAP_S, ev, bk)
        eq = lambda a, b: np.array_equal(a, b, equal_nan=True)  # noqa: E731
        assert eq(w_el[0], ref["el_w"]) and eq(w_el[1], ref["el_ant"]) and eq(w_el[2], ref["az_ant"])
        assert eq(w_reason, ref["reason"]) and eq(wb[0], ref["use_c"]) and eq(wb[1], ref["use_p"])
        assert eq(wb[2], ref["slip"]) and eq(wf[0], ref["sdc_c"]) and eq(wf[1], ref["sdp_c"]) and eq(wf[3], ref["td_p"])
        assert eq(w_clk[0], ref["clk0"]) and eq(w_clk[1], ref["clk_pred"]) and eq(w_jump, ref["jump"])
        assert n_jump == ref["jump"].sum() and eq(clk_k, clk_ref)
        if do_td:
            assert eq(wf[2], ref["td_c"]) and eq(wb[3], ref["td_c_ok"]) and eq(wb[4], ref["td_p_ok"])
            assert eq(w_mcp[0], ref["mc"]) and eq(w_mcp[1], ref["mp"]) and n_common == ref["n_common"]
            assert eq(wfac[0], ref["wfac"][0]) and eq(wfac[1], ref["wfac"][1])
        for a, b in zip(noise_ref, noise_k):
            assert np.array_equal(a, b)
        assert eq(ev[0], ref["ev_td"]) and eq(ev[1], ref["ev_lli"]) and n_gap == ref["n_gap"]
        assert eq(bk[0], ref["drop"]) and eq(bk[1], ref["need"])
        assert (n_td, n_lli, n_drop, n_need) == (ref["ev_td"].sum(), ref["ev_lli"].sum(), ref["drop"].sum(),
                                                  ref["need"].sum())
        seen["jump"] += n_jump
        seen["common"] += n_common
        seen["ev_td"] += n_td
        seen["ev_lli"] += n_lli
        seen["gap"] += n_gap
        seen["drop"] += n_drop
        seen["need"] += n_need
        for code, key in ((6, "half"), (2, "reason2"), (4, "reason4"), (10, "reason10")):
            seen[key] += int(np.sum(w_reason == code))
        prev_sdc = np.where(avail_c, wf[0], np.nan)
        prev_sdp = np.where(avail_p, wf[1], np.nan)
        prev_ub = ub
    assert all(v > 0 for v in seen.values()), str(seen)                     # every branch was exercised
    assert np.all(noise_k[1] > MIN_EPOCHS)                                # the noise estimators ran


def _residual_records(blocks: list[tuple]) -> dict:
    """run_filter's former assembly of residuals.csv from per-epoch records (epochs in order; per epoch its code
    rows (kind 0), then its phase rows (kind 1, where a phase exists))."""
    cat = lambda i: np.concatenate([b[i] for b in blocks])  # noqa: E731
    n_rows = np.array([b[1].size for b in blocks])
    ep = np.repeat(np.array([b[0] for b in blocks], dtype=np.int64), n_rows)
    keep = cat(11)
    cols = {"epoch": ep, "bl": cat(1).astype(np.int64), "sat": cat(2).astype(np.int64),
            "sig": cat(3).astype(np.int64), "el_ant_deg": cat(4), "az_ant_deg": cat(5),
            "cn0_dbhz": cat(6).astype(np.float64)}
    code = {**cols, "kind": np.zeros(ep.size, np.int64), "residual_m": cat(7), "reason": cat(8).astype(np.int64)}
    phase = {**{k: v[keep] for k, v in cols.items()}, "kind": np.ones(int(keep.sum()), np.int64),
             "residual_m": cat(9)[keep], "reason": cat(10).astype(np.int64)[keep]}
    order = np.argsort(2 * np.concatenate([code["epoch"], phase["epoch"]])
                       + np.concatenate([code["kind"], phase["kind"]]), kind="stable")
    return {k: np.concatenate([code[k], phase[k]])[order] for k in code}


def test_record_epoch_equals_the_former_records():
    rng = np.random.default_rng(6)
    n_bl, n_sat, n_sig = 2, 9, 2
    sh = (n_bl, n_sat, n_sig)
    blocks = []
    ibuf, fbuf, pos = np.zeros((6, 4000), np.int64), np.zeros((4, 4000)), 0
    lookup = np.zeros((2,) + sh)
    prev_sdc, prev_sdp, prev_ub = np.zeros(sh), np.zeros(sh), np.zeros((n_bl, n_sat))
    for k in range(60):
        avail_c = rng.random(sh) < 0.8
        avail_p = avail_c & (rng.random(sh) < 0.9)
        reason = np.where(rng.random(sh) < 0.7, 0, rng.integers(1, 11, sh))
        use_c = (reason == 0) & (rng.random(sh) < 0.9) & avail_c
        use_p = use_c & avail_p & (rng.random(sh) < 0.9)
        el_ant = rng.uniform(-1, 1.5, (n_bl, n_sat))
        az_ant = rng.uniform(-np.pi, np.pi, (n_bl, n_sat))
        if k % 5 == 0:
            el_ant[:], az_ant[:] = np.nan, np.nan
        cn0 = rng.uniform(25, 50, sh)
        sdc_c, sdp_c = rng.normal(size=sh), rng.normal(size=sh)
        b_out, u = rng.normal(size=(n_bl, 3)), rng.normal(size=(n_sat, 3))
        jc, sc, fc = np.nonzero(use_c)
        jp, sp, fp = np.nonzero(use_p)
        mc_n = jc.size
        m = mc_n + jp.size
        post = rng.normal(size=m) if m and k % 7 else np.zeros(0)
        if post.size == 0:
            m = 0
        # former code
        jr, sr, fr_ = np.nonzero(avail_c)
        if jr.size:
            lk = np.full((2, n_bl, n_sat, n_sig), np.nan)
            if m:
                lk[0, jc, sc, fc] = post[:mc_n]
                lk[1, jp, sp, fp] = post[mc_n:]
            rsn_c = np.where(use_c[jr, sr, fr_], 0, reason[jr, sr, fr_])
            rsn_p = np.where(use_p[jr, sr, fr_], 0, np.where(reason[jr, sr, fr_] == 0, 5, reason[jr, sr, fr_]))
            blocks.append((k, jr, sr, fr_, np.degrees(el_ant[jr, sr]), np.degrees(np.mod(az_ant[jr, sr], 2 * np.pi)),
                           cn0[jr, sr, fr_], lk[0, jr, sr, fr_], rsn_c, lk[1, jr, sr, fr_], rsn_p,
                           avail_p[jr, sr, fr_]))
        pos = record_epoch(k, avail_c, avail_p, use_c, use_p, reason, el_ant, az_ant, cn0, post, m, jc, sc, fc, jp,
                           sp, fp, lookup, ibuf, fbuf, pos, sdc_c, sdp_c, prev_sdc, prev_sdp, b_out, u, prev_ub)
        assert np.array_equal(prev_ub, b_out @ u.T)
        assert np.array_equal(prev_sdc, np.where(avail_c, sdc_c, np.nan), equal_nan=True)
        assert np.array_equal(prev_sdp, np.where(avail_p, sdp_c, np.nan), equal_nan=True)
    ref = _residual_records(blocks)
    got = {"epoch": ibuf[0, :pos], "bl": ibuf[1, :pos], "sat": ibuf[2, :pos], "sig": ibuf[3, :pos],
           "el_ant_deg": fbuf[0, :pos], "az_ant_deg": fbuf[1, :pos], "cn0_dbhz": fbuf[2, :pos],
           "kind": ibuf[4, :pos], "residual_m": fbuf[3, :pos], "reason": ibuf[5, :pos]}
    assert pos == ref["epoch"].size > 1000
    for key in ref:
        assert np.array_equal(ref[key], got[key], equal_nan=True), key
    assert np.isfinite(got["residual_m"]).sum() > 100


def test_take_and_grow_square_are_the_numpy_indexing():
    from gnssatt.attitude.qc_kernels import grow_square, take_square

    rng = np.random.default_rng(10)
    for n in (1, 5, 40):
        P = rng.normal(size=(n, n))
        keep = rng.random(n) < 0.6
        assert np.array_equal(take_square(P, np.flatnonzero(keep)), P[np.ix_(keep, keep)])
        ref = np.zeros((n + 3, n + 3))
        ref[:n, :n] = P
        ref[np.arange(n, n + 3), np.arange(n, n + 3)] = 0.25
        assert np.array_equal(grow_square(P, 3, 0.25), ref)


class _NumpyStates:
    """_State's ambiguity add / remove as written in numpy before drop_states / add_states (the reference)."""

    def __init__(self, x, P, n_fixed, shape):
        self.x, self.P, self.n_fixed_part = x, P, n_fixed
        self.amb_index = np.full(shape, -1, dtype=np.int64)
        self.amb_key = np.zeros((0, 3), dtype=np.int64)
        self.amb_fixed = np.zeros(0, bool)
        self.amb_last_t = np.zeros(0)
        self.amb_arc = np.zeros(0, np.int64)
        self.arcs = []

    def add(self, keys, values, sigma0, t):
        n0, k = self.x.size, keys.shape[0]
        self.x = np.concatenate([self.x, values])
        P = np.zeros((n0 + k, n0 + k))
        P[:n0, :n0] = self.P
        P[np.arange(n0, n0 + k), np.arange(n0, n0 + k)] = sigma0 ** 2
        self.P = P
        self.amb_key = np.concatenate([self.amb_key, keys])
        self.amb_fixed = np.concatenate([self.amb_fixed, np.zeros(k, bool)])
        self.amb_last_t = np.concatenate([self.amb_last_t, np.full(k, t)])
        a0 = len(self.arcs)
        self.arcs.extend([int(b), int(sa), int(f), 0, -1] for b, sa, f in keys)
        self.amb_arc = np.concatenate([self.amb_arc, a0 + np.arange(k)])
        self.amb_index[keys[:, 0], keys[:, 1], keys[:, 2]] = n0 + np.arange(k)

    def remove(self, state_idx):
        keep = np.ones(self.x.size, bool)
        keep[state_idx] = False
        self.x = self.x[keep]
        self.P = self.P[np.ix_(keep, keep)]
        ka = keep[self.n_fixed_part:]
        gone = self.amb_key[~ka]
        self.amb_index[gone[:, 0], gone[:, 1], gone[:, 2]] = -1
        self.amb_key, self.amb_fixed = self.amb_key[ka], self.amb_fixed[ka]
        self.amb_last_t, self.amb_arc = self.amb_last_t[ka], self.amb_arc[ka]
        self.amb_index[self.amb_key[:, 0], self.amb_key[:, 1], self.amb_key[:, 2]] = \
            self.n_fixed_part + np.arange(self.amb_key.shape[0])


def test_state_add_and_remove_equal_the_numpy_bookkeeping():
    from gnssatt.attitude.filter import _State

    rng = np.random.default_rng(12)
    st = _State(2, 9, 2, True, False)
    n0 = st.n
    A = rng.normal(size=(n0, n0))
    st.x, st.P = rng.normal(size=n0), A @ A.T
    ref = _NumpyStates(st.x.copy(), st.P.copy(), st.n_fixed_part, (2, 9, 2))
    names = ("x", "P", "amb_index", "amb_key", "amb_fixed", "amb_last_t", "amb_arc")
    n_add = n_rm = 0
    for epoch in range(200):
        free = np.argwhere(st.amb_index < 0)
        if free.size and rng.random() < 0.6:
            keys = free[rng.random(len(free)) < 0.3].astype(np.int64)
            if keys.size:
                vals = rng.normal(size=len(keys)) * 100
                st.add_ambiguities(keys, vals, 30.0, float(epoch))
                ref.add(keys, vals, 30.0, float(epoch))
                n_add += 1
        if st.amb_key.shape[0] and rng.random() < 0.5:
            drop = st.n_fixed_part + np.flatnonzero(rng.random(st.amb_key.shape[0]) < 0.3)
            st.remove_ambiguities(drop, epoch)
            ref.remove(drop)
            n_rm += 1
        st.amb_fixed |= rng.random(st.amb_fixed.size) < 0.1
        ref.amb_fixed = st.amb_fixed.copy()
        for nm in names:
            a, b = getattr(st, nm), getattr(ref, nm)
            assert a.dtype == b.dtype and np.array_equal(a, b), nm
        assert [a[:3] for a in st.arcs] == [a[:3] for a in ref.arcs]
    assert n_add > 20 and n_rm > 20
