"""One adapter per compiled kernel: the kernel called with the inputs of its readable reference
(gnssatt.attitude.reference_*, gnssatt.estimation.ekf_reference) and its outputs returned by name.

The kernel tests call the kernels only through these functions, so when the kernels' signatures change (record
types instead of positional arguments) only this module changes. `close` is the one comparison of floats: a
tolerance always, never bit equality across implementations.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude import (kernels as K, qc_kernels as QK, qc_records as QR, update_kernels as UK,
                              update_records as UR)
from gnssatt.attitude.reference_noise import NoiseEstimates, NoiseSettings
from gnssatt.attitude.reference_qc import (AmbiguityBook, AntennaView, ClockState, PreviousEpoch, QcLimits, SdEpoch,
                                           TripleDifferences)
from gnssatt.attitude.reference_records import EpochFlags
from gnssatt.attitude.reference_update import FixState, RoundingLimits, StateLayout, UpdateObs, UsedRows, VarianceModel
from gnssatt.estimation import ekf_kernels as EK


def close(actual, expected, *, rtol: float = 0.0, atol: float = 0.0, what: str = "") -> None:
    """assert |actual - expected| <= atol + rtol |expected| elementwise (NaN where expected is NaN); a tolerance
    must be given (rtol or atol > 0)."""
    assert rtol > 0 or atol > 0, "a tolerance is required"
    np.testing.assert_allclose(np.asarray(actual, dtype=np.float64), np.asarray(expected, dtype=np.float64),
                               rtol=rtol, atol=atol, equal_nan=True, err_msg=what)


def same(actual, expected, what: str = "") -> None:
    """Integer / boolean outputs (flags, counts, indices, reason codes): exactly equal."""
    a, e = np.asarray(actual), np.asarray(expected)
    assert a.dtype.kind in "biu" and e.dtype.kind in "biu", f"{what}: exact comparison is for integers and flags"
    np.testing.assert_array_equal(a, e, err_msg=what)


# --- gnssatt.estimation.ekf_kernels ------------------------------------------------------------------------------

def call_gather_AHt(A, cols, coef):
    return EK.gather_AHt(A, cols, coef)


def call_gather_HA(A, cols, coef):
    return EK.gather_HA(A, cols, coef)


def call_symmetric_plus_diag(S, R):
    return EK.symmetric_plus_diag(S, R)


def call_joseph_combine(AP, X, Y):
    return EK.joseph_combine(AP, X, Y)


def call_rotation_rk4_stm(b_m, omega_rad_s, dt_s, max_step_s):
    """(b1 (n_b, 3), Phi_bb (3, 3), Phi_bw (n_b, 3, 3))."""
    return EK.rotation_rk4_stm_kernel(b_m, omega_rad_s, dt_s, max_step_s)


def call_propagate_rotation_cov(P, w_idx, b_idx, Phi_bb, Phi_bw, Qw, b1, dt_s):
    """Phi P Phi^T + Q as a new array (the kernel works in place on a copy)."""
    out = np.array(P, dtype=np.float64)
    EK.propagate_rotation_cov(out, np.asarray(w_idx, np.int64), b_idx, Phi_bb, Phi_bw, Qw, b1, dt_s)
    return out


def call_sequential_update(x, P, cols, coef, R, z, joseph_ratio):
    """(good, x, P) after the sequential update of copies of x, P."""
    x1, P1 = x.copy(), P.copy()
    good = EK.sequential_update_sparse(x1, P1, cols, coef, R, z, joseph_ratio)
    return good, x1, P1


# --- gnssatt.attitude.kernels ------------------------------------------------------------------------------------

def call_np_sum(a):
    return K.np_sum(a)


def call_masked_median_axis1(a, ok):
    return K.masked_median_axis1(a, ok)


def call_count_pairs_masked(first, second, mask, n_first, n_second):
    return K.count_pairs_masked(first, second, mask, n_first, n_second)


def call_measurement_rows(rows: UsedRows, layout: StateLayout, obs: UpdateObs):
    """(cols, coef, z)."""
    return K.measurement_rows(_rows(rows), _layout(layout), _obs(obs))


def call_cn0_growth(td: TripleDifferences, ln_factor, wavelength_m, est: NoiseEstimates, settings: NoiseSettings):
    """cn0_growth_samples + cn0_growth_update, est updated in place."""
    xs, rs, off = K.cn0_growth_samples(td.code_m, td.phase_m, td.code_ok, td.phase_ok, td.median_code_m,
                                       td.median_phase_m, ln_factor, wavelength_m)
    K.cn0_growth_update(xs, np.log(rs), off, est.moments, est.n_growth, est.gamma, settings.memory_epochs,
                        settings.min_epochs, settings.min_var_ln_factor, K.POW2)


def _white_noise(est: NoiseEstimates, settings: NoiseSettings, enabled: bool = True) -> tuple:
    """The kernels' WhiteNoise record over est's arrays (updated in place through it)."""
    return tuple(QR.WhiteNoise(var_code_m2=est.var_code_m2, var_phase_m2=est.var_phase_m2, n_white=est.n_white,
                               memory_epochs=float(settings.memory_epochs), enabled=enabled))


def _triple_differences(td: TripleDifferences) -> tuple:
    return tuple(QR.TripleDifferences(code_m=td.code_m, phase_m=td.phase_m, code_ok=td.code_ok, phase_ok=td.phase_ok,
                                      median_code_m=td.median_code_m, median_phase_m=td.median_phase_m))


def call_white_noise(td: TripleDifferences, weights, est: NoiseEstimates, settings: NoiseSettings):
    """white_noise_update, est updated in place."""
    K.white_noise_update(_triple_differences(td), np.ascontiguousarray(weights), _white_noise(est, settings), K.POW2)


# --- gnssatt.attitude.qc_kernels ---------------------------------------------------------------------------------

def call_reset_white_clocks(x, P, white, var_m2):
    x1, P1 = x.copy(), P.copy()
    QK.reset_white_clocks(x1, P1, white, var_m2)
    return x1, P1


def call_propagate_dynamic(x, P, b_idx, Qw, dt_s, max_step_s, white, var_clock_m2):
    """(x, P, Phi_bb, Phi_bw) on copies."""
    x1, P1 = x.copy(), P.copy()
    Pbb, Pbw = QK.propagate_dynamic(x1, P1, np.arange(3), b_idx, Qw, dt_s, max_step_s, white, var_clock_m2)
    return x1, P1, Pbb, Pbw


def call_propagate_kinematic(x, P, b_flat, q_dt_m2, white, var_clock_m2):
    x1, P1 = x.copy(), P.copy()
    QK.propagate_kinematic(x1, P1, b_flat, q_dt_m2, white, var_clock_m2)
    return x1, P1


def call_clip_pair(a, b):
    out = np.empty((2,) + a.shape)
    QK.clip_pair(a, b, out)
    return out


def call_epoch_geometry(u, R, bs_a_T, bs_b_T, x, b_idx):
    """(los_b (n_sat, 3), ub (n_bl, n_sat), asn_in (2, n_sat, n_bl))."""
    asn = np.empty((2, u.shape[0], b_idx.shape[0]))
    los, ub = QK.epoch_geometry(u, R, bs_a_T, bs_b_T, x, b_idx, asn)
    return los, ub, asn


def _qc_limits(limits: QcLimits) -> tuple:
    return tuple(QR.QcLimits(el_mask_ant_rad=limits.el_mask_ant_rad, clock_jump_m=limits.clock_jump_m,
                             td_max_dt_s=limits.td_max_dt_s, td_code_m=limits.td_code_m,
                             td_phase_cyc=limits.td_phase_cyc, max_gap_s=limits.max_gap_s,
                             wavelength_m=limits.wavelength_m))


def _block(a) -> np.ndarray:
    """An epoch's array as the one row of an SdBlock's (the kernels read row i = 0)."""
    return np.ascontiguousarray(a)[None]


def _sd_block_qc(sd: SdEpoch) -> tuple:
    return tuple(QR.SdBlockQc(sdc_m=_block(sd.sdc_m), sdp_m=_block(sd.sdp_m), low_cn0=_block(sd.low_cn0),
                              reason0=_block(sd.reason0), clock_factor=_block(sd.clock_factor),
                              baseline_ok=_block(sd.baseline_ok)))


def _sd_block_flags(avail_c, avail_p, lli) -> tuple:
    return tuple(QR.SdBlockFlags(avail_c=_block(avail_c), avail_p=_block(avail_p), lli=_block(lli)))


def _epoch_step(prev: PreviousEpoch, t_s: float) -> tuple:
    return QR.epoch_step(i=0, t_s=float(t_s), consecutive=bool(prev.consecutive), do_td=bool(prev.do_td))


def _qc_work(sh: tuple) -> QR.QcWork:
    n_bl, n_sat, n_sig = sh
    return QR.QcWork(el_rad=np.zeros((3, n_bl, n_sat)), reason=np.zeros(sh, np.int64),
                     masks=np.zeros((9,) + sh, bool), values_m=np.zeros((4,) + sh),
                     median_td_m=np.zeros((2, n_bl, n_sig)))


def call_qc_epoch(sd: SdEpoch, view: AntennaView, ub_m, prev: PreviousEpoch, clock: ClockState, t_s: float,
                  limits: QcLimits) -> dict:
    """qc_epoch's outputs by name (the names of reference_qc.QcEpoch / TripleDifferences / EpochClock), with the
    clock state after the epoch as a ClockState; _work, _memory: the kernel records for call_td_checks."""
    n_bl = sd.sdc_m.shape[0]
    work = _qc_work(sd.sdc_m.shape)
    memory = QR.EpochMemory(prev_sdc_m=prev.sdc_m, prev_sdp_m=prev.sdp_m, prev_ub_m=prev.ub_m)
    kclock = QR.EpochClock(clock_state=clock.as_array(), clock_m=np.zeros((2, n_bl)), jump=np.zeros(n_bl, bool))
    kview = QR.antenna_view(asn_rad=np.ascontiguousarray(np.stack([view.asn_a_rad, view.asn_b_rad])),
                            az_rad=view.az_rad, mask_on=bool(view.mask_on), ever_fixed=view.ever_fixed,
                            pcv_on=bool(view.pcv_on), pcv_empty=sd.pcv_empty, ub_m=ub_m)
    flags = _sd_block_flags(sd.avail_p, sd.avail_p, sd.lli)           # (avail_c: not read by qc_epoch)
    n_jump, n_common = QK.qc_epoch(_sd_block_qc(sd), flags, kview, _epoch_step(prev, t_s), tuple(memory),
                                   tuple(kclock), _qc_limits(limits), tuple(work))
    el, wb, wf, mcp = work.el_rad, work.masks, work.values_m, work.median_td_m
    td = TripleDifferences(wf[2], wf[3], wb[3], wb[4], mcp[0], mcp[1])
    return dict(el_w_rad=el[0], el_ant_rad=el[1], az_ant_rad=el[2], reason=work.reason, use_c=wb[0], use_p=wb[1],
                slip=wb[2], sdc_c_m=wf[0], sdp_c_m=wf[1], td=td, clock_m=kclock.clock_m[0],
                predicted_m=kclock.clock_m[1], jump=kclock.jump, n_jump=n_jump, n_common_jumps=n_common,
                clock_state=ClockState(*kclock.clock_state), _work=work, _memory=memory)


def call_growth_weights(update: bool, td: TripleDifferences, ln_factor, wavelength_m, est: NoiseEstimates,
                        settings: NoiseSettings):
    """(2, n_bl, n_sat, n_sig) C/N0 weights factor^gamma after growth_weights (est updated in place if update)."""
    glw = np.zeros((2,) + ln_factor.shape)
    z = np.zeros(0)
    xs, log_rs, off = z, z, np.zeros(2 * wavelength_m.size + 1, np.int64)
    if update:
        xs, rs, off = K.cn0_growth_samples(td.code_m, td.phase_m, td.code_ok, td.phase_ok, td.median_code_m,
                                           td.median_phase_m, ln_factor, wavelength_m)
        log_rs = np.log(rs)
    QK.growth_weights(update, xs, log_rs, off, est.moments, est.n_growth, est.gamma, settings.memory_epochs,
                      settings.min_epochs, settings.min_var_ln_factor, ln_factor, glw)
    return np.exp(glw)


def call_td_checks(qc: dict, weights, est: NoiseEstimates, settings: NoiseSettings, sd: SdEpoch,
                   prev: PreviousEpoch, book: AmbiguityBook, t_s: float, limits: QcLimits, noise_on: bool) -> dict:
    """td_checks after call_qc_epoch (qc's reason / use_c / slip updated in place, est too when noise_on):
    ev_td, ev_lli, drop, need and the counts."""
    work = qc["_work"]
    kbook = QR.ambiguity_book(amb_index=book.amb_index, amb_last_t_s=book.amb_last_t_s,
                              n_fixed_part=int(book.n_fixed_part))
    n_td, n_lli, n_gap, n_drop, n_need = QK.td_checks(
        _sd_block_flags(sd.avail_p, sd.avail_p, sd.lli), _epoch_step(prev, t_s), np.ascontiguousarray(weights),
        _white_noise(est, settings, noise_on), kbook, tuple(qc["_memory"]), _qc_limits(limits), tuple(work))
    m = work.masks
    return dict(ev_td=m[5], ev_lli=m[6], drop=m[7], need=m[8], n_td=n_td, n_lli=n_lli, n_gap=n_gap,
                n_drop=n_drop, n_need=n_need)


def call_record_epoch(k: int, flags: EpochFlags, el_ant_rad, az_ant_rad, cn0_dbhz, post_m, rows: UsedRows,
                      buffers: dict, sdc_c_m, sdp_c_m, b_out_m, u) -> None:
    """record_epoch into buffers (ibuf, fbuf, pos, prev_sdc, prev_sdp, prev_ub, lookup), updated in place."""
    b = buffers
    work = _qc_work(flags.avail_c.shape)            # the QC's outputs the records read
    work.el_rad[1], work.el_rad[2], work.reason[:] = el_ant_rad, az_ant_rad, flags.reason
    work.masks[0], work.masks[1] = flags.use_c, flags.use_p
    work.values_m[0], work.values_m[1] = sdc_c_m, sdp_c_m
    kflags = _sd_block_flags(flags.avail_c, flags.avail_p, np.zeros(flags.avail_c.shape, np.int8))
    epoch = QR.output_epoch(k=int(k), i=0, cn0_dbhz=cn0_dbhz, u=u, b_out_m=b_out_m)
    fit = QR.post_fit(post_m=post_m, jc=rows.jc, sc=rows.sc, fc=rows.fc, jp=rows.jp, sp=rows.sp, fp=rows.fp)
    memory = QR.EpochMemory(prev_sdc_m=b["prev_sdc"], prev_sdp_m=b["prev_sdp"], prev_ub_m=b["prev_ub"])
    kbuf = QR.ResidualBuffers(ints=b["ibuf"], floats=b["fbuf"], lookup=b["lookup"])
    b["pos"] = QK.record_epoch(kflags, epoch, fit, tuple(work), tuple(memory), tuple(kbuf), int(b["pos"]))


def call_take_square(P, idx):
    return QK.take_square(P, idx)


def call_grow_square(P, k, var):
    return QK.grow_square(P, k, var)


# --- gnssatt.attitude.update_kernels -----------------------------------------------------------------------------

def _rows(rows: UsedRows) -> tuple:
    """The kernel record (update_records.UsedRows, as a plain tuple) of the reference's UsedRows."""
    return tuple(UR.UsedRows(jc=rows.jc, sc=rows.sc, fc=rows.fc, jp=rows.jp, sp=rows.sp, fp=rows.fp))


def _layout(layout: StateLayout) -> tuple:
    return tuple(UR.StateLayout(b_idx=layout.b_idx, clk=layout.clk, pclk=layout.pclk, bias=layout.bias,
                                amb_index=layout.amb_index, n_fixed_part=int(layout.n_fixed_part)))


def _obs(obs: UpdateObs) -> tuple:
    return tuple(UR.UpdateObs(u=obs.u, clock_factor=obs.clock_factor, wavelength_m=obs.wavelength_m,
                              sdc_c_m=obs.sdc_c_m, sdp_c_m=obs.sdp_c_m, pcv_m=obs.pcv_m,
                              cn0_dbhz=np.ascontiguousarray(obs.cn0_dbhz), el_e_rad=np.ascontiguousarray(obs.el_e_rad),
                              el_w_rad=np.ascontiguousarray(obs.el_w_rad)))


def _model(model: VarianceModel) -> tuple:
    return tuple(UR.VarianceModel(var_code_m2=model.var_code_m2, var_phase_m2=model.var_phase_m2, gamma=model.gamma,
                                  cn0_growth=bool(model.cn0_growth),
                                  elevation_weighting=bool(model.elevation_weighting), mp_model=bool(model.mp_model),
                                  mp_sigma_m=model.mp_sigma_m, mp_mult=float(model.mp_mult)))


def _fix(fix: FixState, amb_fixed=None) -> tuple:
    """update_records.FixState of fix, with amb_fixed in place of fix.amb_fixed if given (a copy to update)."""
    return tuple(UR.FixState(amb_fixed=fix.amb_fixed if amb_fixed is None else amb_fixed, amb_key=fix.amb_key))


def _limits(limits: RoundingLimits) -> tuple:
    return tuple(UR.RoundingLimits(max_sigma_cyc=float(limits.max_sigma_cyc), max_frac_cyc=float(limits.max_frac_cyc),
                                   var_cyc2=float(limits.var_cyc2)))


def call_measurement_variances(rows: UsedRows, obs: UpdateObs, model: VarianceModel):
    """(var, v_white, v_mp)."""
    return UK.measurement_variances(_rows(rows), _obs(obs), _model(model))


def call_white_variances(est_var_m2, est_n, floor_var_m2, min_epochs, estimate):
    return UK.white_variances(est_var_m2, est_n, floor_var_m2, min_epochs, estimate)


def call_measurement_update(x, P, rows: UsedRows, layout: StateLayout, obs: UpdateObs, model: VarianceModel,
                            fix: FixState, amb_last_t_s, t_s: float, joseph_ratio: float, n_bl: int,
                            n_sat: int) -> dict:
    """measurement_update on copies of x, P, amb_last_t; outputs by the names of update_records.UpdateOutputs
    (those of reference_update.UpdateResult); n_bl, n_sat: the kernel reads them off layout.amb_index."""
    assert layout.amb_index.shape[:2] == (n_bl, n_sat)
    x1, P1, last_t = x.copy(), P.copy(), amb_last_t_s.copy()
    out = UR.UpdateOutputs(*UK.measurement_update(x1, P1, _rows(rows), _layout(layout), _obs(obs), _model(model),
                                                  _fix(fix), last_t, float(t_s), float(joseph_ratio)))
    return dict(out._asdict(), x=x1, P=P1, amb_last_t_s=last_t)


def call_update_epoch(x, P, rows: UsedRows, layout: StateLayout, obs: UpdateObs, model: VarianceModel, est: dict,
                      fix: FixState, amb_last_t_s, t_s: float, joseph_ratio: float) -> dict:
    """update_epoch on copies of x, P, amb_last_t: the white variances from the estimator state `est`
    (est_var_code_m2, est_var_phase_m2, est_n, floor_code_m2, floor_phase_m2, min_epochs, estimate; model's own
    var_code_m2 / var_phase_m2 are not used), then the update; outputs as call_measurement_update's plus
    var_code_m2, var_phase_m2."""
    x1, P1, last_t = x.copy(), P.copy(), amb_last_t_s.copy()
    noise = UR.NoiseModel.plain(
        est_var_code_m2=est["est_var_code_m2"], est_var_phase_m2=est["est_var_phase_m2"], est_n=est["est_n"],
        floor_code_m2=float(est["floor_code_m2"]), floor_phase_m2=float(est["floor_phase_m2"]),
        min_epochs=int(est["min_epochs"]), estimate=bool(est["estimate"]), gamma=model.gamma,
        cn0_growth=bool(model.cn0_growth), elevation_weighting=bool(model.elevation_weighting),
        mp_model=bool(model.mp_model), mp_sigma_m=model.mp_sigma_m)
    vc, vp, res = UK.update_epoch(x1, P1, _rows(rows), _layout(layout), _obs(obs), noise, float(model.mp_mult),
                                  _fix(fix), last_t, float(t_s), float(joseph_ratio))
    return dict(UR.UpdateOutputs._make(res)._asdict(), x=x1, P=P1, amb_last_t_s=last_t, var_code_m2=vc,
                var_phase_m2=vp)


def call_phase_row_stats(rows: UsedRows, cols, fix: FixState, post_m, n_fixed_part, n_bl, n_sat) -> dict:
    out = UK.phase_row_stats(rows.jp, rows.sp, cols, rows.n_code, fix.amb_fixed, n_fixed_part, post_m, n_bl, n_sat)
    return dict(zip(("n_used", "n_fixed_used", "n_unfixed", "n_fix_rows", "ms_fix_m2"), out))


def call_round_newcomers_rows(x, P, fix: FixState, n_fixed_part, idx_j, sig_j, el_j, n_sig, j,
                              limits: RoundingLimits):
    """(new, ref, integers, amb_fixed) with amb_fixed a copy updated by the kernel."""
    amb_fixed = fix.amb_fixed.copy()
    new, ref, val = UK.round_newcomers_rows(x, P, _fix(fix, amb_fixed), n_fixed_part, idx_j, sig_j, el_j, n_sig, j,
                                            _limits(limits))
    return new, ref, val, amb_fixed


def call_fix_newcomers(x, P, fix: FixState, n_fixed_part, cols, rows: UsedRows, el_loc_rad, n_sig, j,
                       limits: RoundingLimits):
    """(x, P, new, ref, integers, amb_fixed) on copies; the phase rows of the update as the filter passes them."""
    x1, P1, amb_fixed = x.copy(), P.copy(), fix.amb_fixed.copy()
    new, ref, val, applied = UK.fix_newcomers(x1, P1, _fix(fix, amb_fixed), n_fixed_part, cols, _rows(rows),
                                              el_loc_rad, n_sig, j, _limits(limits))
    assert applied
    return x1, P1, new, ref, val, amb_fixed


def call_quest_dcm(b_ref, b_body, w):
    return UK.quest_dcm(b_ref, b_body, w)


def call_store_outputs(x, P, all_b_idx, k, out: dict, dynamic, baseline_ok, n_used, ever_fixed, n_fixed_used,
                       fixed_min_sats):
    """store_outputs into out's arrays (b_m, P_b_m2, omega_rad_s, ok, fixed, n_sats: the keys of
    reference_update.epoch_outputs) at row k; returns fixed_now."""
    status = UR.EpochStatus(baseline_ok=baseline_ok, n_used=n_used, ever_fixed=ever_fixed, n_fixed_used=n_fixed_used)
    settings = UR.OutputSettings(all_b_idx=all_b_idx, dynamic=bool(dynamic), fixed_min_sats=int(fixed_min_sats))
    buffers = UR.OutputBuffers(b_ecef_m=out["b_m"], P_b_m2=out["P_b_m2"], omega_ecef_rad_s=out["omega_rad_s"],
                               ok=out["ok"], fixed=out["fixed"], n_sats=out["n_sats"])
    return UK.store_outputs(x, P, int(k), tuple(status), tuple(settings), tuple(buffers))
