"""Fig. 2 box "measurement update": code and phase single differences of every used signal, as independent
observations, in one sequential EKF update; then the adaptive parts of the noise model that need the post-fit
residuals (manoeuvre detector, multipath scale).

Implements: seed 000 sec. 2 (the measurement model of the module doc of gnssatt.attitude.filter: SD code and phase,
linear in the state; Table 1 sigmas 30 cm / 3 mm as floors) with the noise model of docs/attitude.md (white noise
x C/N0 factor^gamma [x elevation factor] + time-correlated variance growing off boresight); sequential scalar
updates (short form, Joseph form for rows with H P H^T > JOSEPH_RATIO R; Bierman/Joseph, standard EKF).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.filter_state import (JOSEPH_RATIO, MP_SCALE_MAX, MP_SCALE_MIN, NOISE_EPOCHS, NOISE_MIN_EPOCHS,
                                           EpochData, FilterRun)
from gnssatt.attitude.update_kernels import measurement_update as update_kernel, white_variances_cp


def measurement_update(run: FilterRun, ep: EpochData) -> None:
    """x and P updated in place with the epoch's used code rows, then phase rows (compiled
    update_kernels.measurement_update); sets ep.post (post-fit residuals), ep.n_used, ep.n_fixed_used,
    ep.n_unfixed, ep.has_fix (per baseline), ep.cols (the rows' state columns) and the fix monitor's statistics."""
    ep.jc, ep.sc, ep.fc = np.nonzero(ep.use_c)
    ep.jp, ep.sp, ep.fp = np.nonzero(ep.use_p)
    ep.mc_n, ep.mp_n = ep.jc.size, ep.jp.size
    ep.m = ep.mc_n + ep.mp_n
    if ep.m:
        _update(run, ep)
    if not ep.mp_n:
        # without phase rows no satellite counts as used
        ep.n_used = np.zeros(run.n_bl, np.int64)
        ep.n_fixed_used = ep.n_unfixed = ep.n_used


def _update(run: FilterRun, ep: EpochData) -> None:
    """The compiled update: sparse rows (baseline, clock, code bias / ambiguity) and observations, code rows then
    phase rows; variances: the white noise (the configured sigmas are floors: receivers smooth their code (tiny
    code TDs), and time-correlated errors (multipath) never show in a triple difference) x C/N0 factor^gamma
    [x elevation factor: the antenna-frame elevation once an attitude exists, else the local horizon], plus the
    time-correlated errors (multipath, uncalibrated PCV) growing with the off-boresight angle, scaled adaptively;
    the update as scalar updates in turn; the post-fit residuals and the sums of the multipath scale."""
    st, s, k, n_bl = run.st, run.s, ep.k, run.n_bl
    ep.vc_f, ep.vp_f = white_variances_cp(run.est_var_c, run.est_var_p, run.est_n, run.var_c_floor, run.var_p_floor,
                                          NOISE_MIN_EPOCHS, s.noise.noise_estimation)
    watch_w = run.adapter is not None and run.ever_fixed.all() and ep.prev_t is not None
    if watch_w:
        sub_prior, P_sub_prior = st.x[run.sub_w_b], st.P[run.ix_sub]          # (fancy indexing: copies)
    el_wc = np.ascontiguousarray(ep.el_w)          # one compiled signature whatever the layout
    el_e = el_wc if not run.elev_w else (ep.el_ant if run.R_mask is not None
                                         else np.repeat(ep.el_loc[None, :], n_bl, 0))
    mp_mult = run.mp_infl * run.mp_scale
    (ep.cols, coef, z, var, v_mp, ep.post, good, mp_num, mp_den, n_mp, ep.n_used, ep.n_fixed_used, ep.n_unfixed,
     ep.n_fix_rows, ep.ms_fix, ep.has_fix) = update_kernel(
        st.x, st.P, ep.jc, ep.sc, ep.fc, ep.jp, ep.sp, ep.fp, run.b_idx, ep.u, ep.cfac, st.clk, st.pclk, st.bias,
        st.amb_index, run.lam, ep.sdc_c, ep.sdp_c, ep.pcv_m, ep.vc_f, ep.vp_f, np.ascontiguousarray(ep.cn0),
        run.gamma, run.cn0_growth, el_e, run.elev_w, el_wc, run.mp_model, run.mp_sig, mp_mult, st.amb_fixed,
        st.n_fixed_part, st.amb_last_t, ep.t, JOSEPH_RATIO, st.amb_key, n_bl, run.n_sat)
    mc_n = ep.mc_n
    if run.mp_model and run.record and ep.mp_n:
        w_p = 1.0 / var[mc_n:]
        run.sm_corr[k] = float(np.sum(v_mp[mc_n:] * mp_mult * w_p * w_p) / np.sum(w_p))
    if good and watch_w:
        rep = run.adapter.observe(sub_prior, P_sub_prior, st.x[run.sub_w_b], st.P[run.ix_sub], ep.t)
        if rep is not None:        # a manoeuvre: the (omega, baselines) sub-state the detector gives
            st.x[run.sub_w_b], st.P[run.ix_sub] = rep
    if run.mp_model and s.noise.multipath_adaptive and good and n_mp >= 6:
        # scale of the multipath variance from the post-fit residuals of fixed phases:
        # E[r^2] = R_true (1 - h), h = (H P+ H^T)_ii / R_model (leverage); R_true = white + scale * mp
        a = 1.0 / min(run.mp_n_ep + 1.0, NOISE_EPOCHS)
        ratio = mp_num / mp_den if mp_den else np.float64(mp_num) / 0.0
        run.mp_scale = float(min(max(run.mp_scale + a * (ratio - run.mp_scale), MP_SCALE_MIN), MP_SCALE_MAX))
        run.mp_n_ep += 1
