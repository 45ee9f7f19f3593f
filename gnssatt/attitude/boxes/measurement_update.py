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

from gnssatt.attitude.filter_state import JOSEPH_RATIO, MP_SCALE_MAX, MP_SCALE_MIN, NOISE_EPOCHS, EpochData, FilterRun
from gnssatt.attitude.length_constraint import project_lengths
from gnssatt.attitude.multipath_vce import lag_epoch
from gnssatt.attitude.rigid_update import rigid_retract
from gnssatt.attitude.update_kernels import update_epoch
from gnssatt.attitude.update_records import FixState, UpdateObs, UpdateOutputs


def measurement_update(run: FilterRun, ep: EpochData) -> None:
    """x and P updated in place with the epoch's used code rows, then phase rows (compiled
    update_kernels.update_epoch); sets ep.vc_f, ep.vp_f (white variances per signal), ep.post (post-fit residuals), ep.n_used, ep.n_fixed_used,
    ep.n_unfixed, ep.has_fix (per baseline), ep.cols (the rows' state columns) and the fix monitor's statistics."""
    ep.rows = np.nonzero(ep.use_c) + np.nonzero(ep.use_p)          # update_records.UsedRows: jc, sc, fc, jp, sp, fp
    ep.jc, ep.sc, ep.fc, ep.jp, ep.sp, ep.fp = ep.rows
    ep.mc_n, ep.mp_n = ep.jc.size, ep.jp.size
    ep.m = ep.mc_n + ep.mp_n
    if ep.m:
        _update(run, ep)
    if not ep.mp_n:
        # without phase rows no satellite counts as used
        ep.n_used = np.zeros(run.n_bl, np.int64)
        ep.n_fixed_used = ep.n_unfixed = ep.n_used


def _update(run: FilterRun, ep: EpochData) -> UpdateOutputs:
    """The compiled update: sparse rows (baseline, clock, code bias / ambiguity) and observations, code rows then
    phase rows; variances: the white noise (the configured sigmas are floors: receivers smooth their code (tiny
    code TDs), and time-correlated errors (multipath) never show in a triple difference) x C/N0 factor^gamma
    [x elevation factor: the antenna-frame elevation once an attitude exists, else the local horizon], plus the
    time-correlated errors (multipath, uncalibrated PCV) growing with the off-boresight angle, scaled adaptively;
    the update as scalar updates in turn; the post-fit residuals and the sums of the multipath scale. Returns the
    kernel's outputs."""
    st, s, k, n_bl = run.st, run.s, ep.k, run.n_bl
    watch_w = run.adapter is not None and run.ever_fixed.all() and ep.prev_t is not None
    if watch_w:
        sub_prior, P_sub_prior = st.x[run.sub_w_b], st.P[run.ix_sub]          # (fancy indexing: copies)
    el_wc = np.ascontiguousarray(ep.el_w)          # one compiled signature whatever the layout
    el_e = el_wc if not run.elev_w else (ep.el_ant if run.R_mask is not None
                                         else np.repeat(ep.el_loc[None, :], n_bl, 0))
    mp_mult = run.mp_infl * run.mp_scale
    obs = UpdateObs.plain(u=ep.u, clock_factor=ep.cfac, wavelength_m=run.lam, sdc_c_m=ep.sdc_c, sdp_c_m=ep.sdp_c,
                          pcv_m=ep.pcv_m, cn0_dbhz=np.ascontiguousarray(ep.cn0), el_e_rad=el_e, el_w_rad=el_wc)
    fix = FixState.plain(amb_fixed=st.amb_fixed, amb_key=st.amb_key)       # (arrays replaced with the states)
    rigid = run.dynamic and s.baseline_update == "rigid"
    b_prior = st.x[run.b_idx] if rigid else None
    ep.vc_f, ep.vp_f, res = update_epoch(st.x, st.P, ep.rows, run.update_layout, obs, run.noise_model, mp_mult, fix,
                                         st.amb_last_t, ep.t, JOSEPH_RATIO)
    out = UpdateOutputs._make(res)
    if rigid:
        # the detector condenses the linear update into its equivalent measurement (information added: the
        # difference of the posterior's and prior's inverse covariances), valid only before the turn of P below
        if out.good and watch_w:
            _observe_manoeuvre(run, ep, sub_prior, P_sub_prior)
        rigid_retract(st.x, st.P, b_prior, run.b_idx, run.ever_fixed)    # gnssatt.attitude.rigid_update
    if run.dynamic and s.length_constraint_sigma_m > 0:     # the rigid length (gnssatt.attitude.length_constraint)
        project_lengths(st.x, st.P, run.b_idx, run.lengths, s.length_constraint_sigma_m,
                        run.ever_fixed)
    ep.cols, ep.post, ep.has_fix = out.cols, out.post_m, out.has_fix
    ep.n_used, ep.n_fixed_used, ep.n_unfixed, ep.n_fix_rows, ep.ms_fix = (out.n_used, out.n_fixed_used, out.n_unfixed,
                                                                          out.n_fix_rows, out.ms_fix_m2)
    mc_n = ep.mc_n
    if run.mp_model and run.record and ep.mp_n:
        w_p = 1.0 / out.var_m2[mc_n:]
        run.sm_corr[k] = float(np.sum(out.v_mp_m2[mc_n:] * mp_mult * w_p * w_p) / np.sum(w_p))
    if out.good and watch_w and not rigid:
        _observe_manoeuvre(run, ep, sub_prior, P_sub_prior)
    if run.mp_model and s.noise.multipath_adaptive and run.mp_vce is not None:
        _multipath_vce(run, ep, out)
    elif run.mp_model and s.noise.multipath_adaptive and out.good and out.n_mp >= 6:
        # scale of the multipath variance from the post-fit residuals of fixed phases:
        # E[r^2] = R_true (1 - h), h = (H P+ H^T)_ii / R_model (leverage); R_true = white + scale * mp
        a = 1.0 / min(run.mp_n_ep + 1.0, NOISE_EPOCHS)
        ratio = out.mp_num / out.mp_den if out.mp_den else np.float64(out.mp_num) / 0.0
        run.mp_scale = float(min(max(run.mp_scale + a * (ratio - run.mp_scale), MP_SCALE_MIN), MP_SCALE_MAX))
        run.mp_n_ep += 1
    return out


def _multipath_vce(run: FilterRun, ep: EpochData, out: UpdateOutputs) -> None:
    """run.mp_scale from the lag-1 autocovariance of the fixed phase rows' post-fit residuals
    (gnssatt.attitude.multipath_vce; multipath_adaptive_method "autocovariance"); a bad update breaks the arcs."""
    mc_n = ep.mc_n
    sel = np.zeros(out.z.size, bool)
    sel[mc_n:] = run.st.amb_fixed[out.cols[mc_n:, 4] - run.st.n_fixed_part]
    if not out.good or sel.sum() < 6:
        run.mp_vce.add(None)
        return
    key = np.full(out.z.size, -1, np.int64)
    key[mc_n:] = run.st.amb_arc[out.cols[mc_n:, 4] - run.st.n_fixed_part]     # one id per arc
    mp_mult = run.mp_infl * run.mp_scale            # the update's multiplier (before this epoch changes it)
    if run.mp_vce.add(lag_epoch(ep.t, key, out.cols, out.coef, out.var_m2, out.v_mp_m2, out.post_m, sel, mp_mult)):
        run.mp_scale = run.mp_vce.scale(run.mp_scale)
        run.mp_n_ep = run.mp_vce.n_ep


def _observe_manoeuvre(run: FilterRun, ep: EpochData, sub_prior: np.ndarray, P_sub_prior: np.ndarray) -> None:
    """The manoeuvre detector (gnssatt.attitude.adaptive) given the (omega, baselines) sub-state's prior and the
    update's posterior; on a manoeuvre the sub-state it gives replaces the posterior in place. With baseline_update
    "rigid" called before the rigid retraction: that turns P+'s baseline blocks by the update's rotation (up to ~1 deg
    in seed 000 Fig. 6's pitch-up), and J = (P+)^-1 - (P-)^-1, a small difference of two large informations, is then
    wrong by 10-50 % (measured on that pitch-up) and the detector's hypotheses and their replacements go astray."""
    st = run.st
    rep = run.adapter.observe(sub_prior, P_sub_prior, st.x[run.sub_w_b], st.P[run.ix_sub], ep.t)
    if rep is not None:        # a manoeuvre: the (omega, baselines) sub-state the detector gives
        st.x[run.sub_w_b], st.P[run.ix_sub] = rep
