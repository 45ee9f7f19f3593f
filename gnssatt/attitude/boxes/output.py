"""Fig. 2 box "output": the epoch's baselines, their covariance and fix status into the output buffers, the
attitude for the antenna-frame mask, the residual records and the memory the next epoch's triple differences need;
at the end, the FilterResult.

Implements: seed 000 sec. 2 (after each update and fixing attempt the attitude from the baselines by TRIAD/QUEST,
here through run_filter's attitude_fn for the antenna-frame mask; the products' attitude is computed in
gnssatt.attitude.process); the residuals.csv records (REASONS).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.filter_state import EpochData, FilterResult, FilterRun
from gnssatt.attitude.qc_kernels import record_epoch
from gnssatt.attitude.qc_records import output_epoch, post_fit
from gnssatt.attitude.update_kernels import store_outputs
from gnssatt.attitude.update_records import EpochStatus


def output(run: FilterRun, ep: EpochData) -> None:
    """Row ep.k of the outputs: out_b, out_P, out_w; out_ok = pa & (n_used >= 3), out_fixed = fixed_now & out_ok,
    out_n = n_used, fixed_now = ever_fixed & (n_fixed_used >= fixed_min_sats); the mask attitude once every baseline
    is fixed; the residual rows; the previous-epoch memory."""
    st, k = run.st, ep.k
    status = EpochStatus.plain(baseline_ok=ep.pa, n_used=ep.n_used, ever_fixed=run.ever_fixed,
                               n_fixed_used=ep.n_fixed_used)
    fixed_now = store_outputs(st.x, st.P, k, status, run.output_settings, run.output_buffers)
    if run.record:
        run.sm_xf[k], run.sm_Pf[k] = st.x[run.sub_w_b], st.P[run.ix_sub]
    if run.attitude_fn is not None and k % (1 if run.pcv_tables else 10) == 0 and fixed_now.all():
        R = run.attitude_fn(run.out_b[k], fixed_now, k)
        if R is not None:
            run.R_mask, run.R_mask_t = R, ep.t
    # residual records (used and rejected): the epoch's code rows, then its phase rows; and the memory for the
    # triple differences (clock-corrected SDs where available)
    epoch = output_epoch(k=k, i=ep.i, cn0_dbhz=ep.cn0, u=ep.u, b_out_m=run.out_b[k])
    fit = post_fit(post_m=ep.post, jc=ep.jc, sc=ep.sc, fc=ep.fc, jp=ep.jp, sp=ep.sp, fp=ep.fp)
    run.res_n = record_epoch(run.sd_flags, epoch, fit, run.qc_work, run.qc_memory, run.res_buffers, run.res_n)
    run.prev_t = ep.t
    run.prev_b = run.out_b[k]


def filter_result(run: FilterRun) -> FilterResult:
    """The FilterResult of a finished run: the output buffers, residuals.csv columns, the fix log (arcs resolved),
    the final noise model and the smoother's records."""
    s, n_res = run.s, run.res_n
    res_i, res_f = run.res_i, run.res_f
    # column arrays for residuals.csv (contiguous views of the record rows)
    residuals = {"epoch": res_i[0, :n_res], "bl": res_i[1, :n_res], "sat": res_i[2, :n_res], "sig": res_i[3, :n_res],
                 "el_ant_deg": res_f[0, :n_res], "az_ant_deg": res_f[1, :n_res], "cn0_dbhz": res_f[2, :n_res],
                 "kind": res_i[4, :n_res], "residual_m": res_f[3, :n_res], "reason": res_i[5, :n_res]}
    arcs = np.array(run.st.arcs, dtype=np.int64).reshape(-1, 5)
    arcs[arcs[:, 4] < 0, 4] = run.n_ep - 1
    fl = np.array(run.fix_rows, dtype=np.float64).reshape(-1, 4)
    a_arc, r_arc = fl[:, 1].astype(np.int64), fl[:, 2].astype(np.int64)
    fix_log = {"epoch": fl[:, 0].astype(np.int64), "bl": arcs[a_arc, 0], "sig": arcs[a_arc, 2],
               "sat": arcs[a_arc, 1], "ref_sat": arcs[r_arc, 1], "dd_cyc": fl[:, 3],
               "last_epoch": np.minimum(arcs[a_arc, 4], arcs[r_arc, 4])}
    signals = run.pobs.signals
    noise = {"sigma_phase_white_m": {sg: float(np.sqrt(max(run.est_var_p[f], s.table1.sigma_phase_m ** 2)))
                                     for f, sg in enumerate(signals)},
             "sigma_code_white_m": {sg: float(np.sqrt(max(run.est_var_c[f], s.table1.sigma_code_m ** 2)))
                                    for f, sg in enumerate(signals)},
             "cn0_gamma_code": {sg: float(run.gamma[0, f]) for f, sg in enumerate(signals)},
             "cn0_gamma_phase": {sg: float(run.gamma[1, f]) for f, sg in enumerate(signals)},
             "multipath_scale": float(run.mp_scale) if run.mp_model else None,
             "multipath_correlation_factor": float(run.mp_infl),
             # multipath_adaptive_method "autocovariance": the residuals' white phase variance over the filter's
             "white_phase_scale_residuals": run.mp_vce.white_scale() if run.mp_vce is not None else None}
    smoother_data = {"x_prior": run.sm_xp, "P_prior": run.sm_Pp, "x_post": run.sm_xf, "P_post": run.sm_Pf,
                     "Phi": run.sm_Phi, "start": run.sm_start, "corr_share": run.sm_corr, "dt_s": run.sm_dt,
                     "q_omega": run.q_w, "noise_state": run.noise_state()} if run.record else None
    return FilterResult(run.out_ok, run.out_b, run.out_P, run.out_fixed, run.out_n, run.out_ratio, run.out_w,
                        residuals, run.events.rows, run.first_fix, run.first_data, fix_log, noise, smoother_data)
