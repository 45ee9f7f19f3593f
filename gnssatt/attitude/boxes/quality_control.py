"""Fig. 2 box "quality control": single differences of the epoch, editing, cycle-slip detection and the ambiguity
bookkeeping (new floats from code-carrier differences after a slip).

Implements: seed 000 sec. 2 and Table 2 (elevation masks on the local horizon and, once fixed, in the antenna frame
(sec. 3.2 compromise); C/N0 masks per signal; triple differences of code (0.5 m) and phase (0.25 cycles) against
their median; re-initialisation of slipped ambiguities from code-carrier); beyond the paper: the epoch clock
estimate and its jump test, phase clock jumps, half cycles, differential PCV bins, and the white-noise and C/N0-
growth estimators of the noise model (docs/attitude.md), all from the same triple differences.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.fastops import nz as _nz
from gnssatt.attitude.filter_state import (DEG, NOISE_EPOCHS, NOISE_MIN_EPOCHS, PCV_ATTITUDE_AGE_S, TD_MAX_DT_S,
                                           EpochData, FilterRun, cn0_factor)
from gnssatt.attitude.kernels import cn0_growth_samples
from gnssatt.attitude.pcv_correction import epoch_correction_m
from gnssatt.attitude.qc_kernels import epoch_geometry, growth_weights, qc_epoch, td_checks
from gnssatt.attitude.qc_records import SdBlockFlags, SdBlockQc, ambiguity_book, antenna_view, epoch_step
from gnssatt.attitude.sd_block import BLOCK_EPOCHS, sd_block
from gnssatt.gnss.constants import C_M_S


def quality_control(run: FilterRun, ep: EpochData) -> None:
    """The epoch's SDs (from the SdBlock, run.blk), their editing (ep.use_c, ep.use_p, ep.reason ...), slips and
    the ambiguity states added or dropped; Table 2 in the order of seed 000 sec. 2."""
    load_epoch(run, ep)
    epoch_geometry_and_pcv(run, ep)
    edit_epoch(run, ep)
    triple_differences(run, ep)
    ambiguity_bookkeeping(run, ep)


def load_epoch(run: FilterRun, ep: EpochData) -> None:
    """The epoch's single differences from the current SdBlock (a new block every BLOCK_EPOCHS epochs, with room
    in the residual records for its rows and the QC kernels' records of it, run.sd_qc and run.sd_flags: the kernels
    read the epoch's row ep.i themselves); views of the epoch's row for the other boxes."""
    k = ep.k
    blk = run.blk
    if blk is None or k - blk.k0 >= blk.pa.shape[0]:
        run.geom.ready(min(k + BLOCK_EPOCHS, run.n_ep))        # the geometry's background part, if any
        blk = run.blk = sd_block(run.pobs, run.geom, run.ia, run.ib, k, min(k + BLOCK_EPOCHS, run.n_ep),
                                 run.s.table2.elevation_mask_local_deg * DEG, run.sig_cn0)
        run.blk_lw = np.log(cn0_factor(blk.cn0))               # ln of the full C/N0 factor
        rows = run.res_n + int(blk.avail_c.sum() + blk.avail_p.sum())           # residual rows of the block
        if rows > run.res_i.shape[1]:
            # room for this block and, at its rate, the remaining epochs (+10 %): rarely more than one copy
            cap = max(rows, int(1.1 * rows * run.n_ep / (k + blk.pa.shape[0])) + 64)
            res_i1, res_f1 = np.empty((6, cap), np.int64), np.empty((4, cap))
            res_i1[:, :run.res_n], res_f1[:, :run.res_n] = run.res_i[:, :run.res_n], run.res_f[:, :run.res_n]
            run.set_residual_buffers(res_i1, res_f1)
        if run.fdma_sig.any():                                  # FDMA phase clock jumps so far (edit_epoch)
            blk.sdp -= run.phase_jump_m[None, :, None, :]
        run.sd_qc = tuple(SdBlockQc(sdc_m=blk.sdc, sdp_m=blk.sdp, low_cn0=blk.low_cn0, reason0=blk.reason,
                                    clock_factor=blk.cfac, baseline_ok=blk.pa))
        run.sd_flags = tuple(SdBlockFlags(avail_c=blk.avail_c, avail_p=blk.avail_p, lli=blk.lli))
    i = ep.i = k - blk.k0
    # (n_bl,) (n_sat, 3) (n_sat,) (n_bl, n_sat, n_sig): what the other boxes read of the epoch
    ep.pa, ep.u, ep.cfac, ep.cn0 = blk.pa[i], blk.u[i], blk.cfac[i], blk.cn0[i]
    ep.el_loc = run.geom.elevation_local_rad[k]


def epoch_geometry_and_pcv(run: FilterRun, ep: EpochData) -> None:
    """Antenna-frame geometry of the epoch and the differential PCV corrections of fixed baselines.

    Antenna-frame elevation for the noise model: by the current attitude once known, else the initial one; el_ant,
    az_ant (the antenna-frame mask, sec. 3.2 compromise) only once an attitude exists, else NaN; (n_sat, 3)
    body-frame lines of sight, the clipped boresight products and the predicted geometry b.u."""
    R_los = run.R_mask if run.R_mask is not None else run.R_body_from_ecef_0
    los_b, ep.ub = epoch_geometry(ep.u, R_los if R_los.flags.c_contiguous else np.ascontiguousarray(R_los),
                                  run.bs_a_T, run.bs_b_T, run.st.x, run.b_idx, run.w_asn)
    ep.asn = np.arcsin(run.w_asn)                                                 # (2, n_sat, n_bl)
    ep.az = np.arctan2(los_b[:, 1], los_b[:, 0]) if run.R_mask is not None else run.z_f
    ep.pcv_m, ep.empty, ep.pcv_on = run.pcv_zero, run.no_pcv, False
    if run.pcv_tables and run.R_mask is not None and ep.t - run.R_mask_t <= PCV_ATTITUDE_AGE_S:
        ep.pcv_m, ep.empty = pcv_epoch(run.pcv_tables, los_b, run.R_ant_first, run.n_sig, run.ever_fixed)
        ep.pcv_on = run.s.calibration.pcv_empty_bins == "exclude"


def pcv_epoch(tables, los_b, R_ant_first, n_sig, fixed):
    """(correction m (n_bl, n_sat, n_sig), no-correction mask) of an epoch: maps apply to fixed baselines only;
    a fixed baseline's phase without a correction (empty bin) leaves the solution (seed 000 sec. 3.2)."""
    corr, has = epoch_correction_m(tables, los_b, R_ant_first, n_sig)
    on = fixed[:, None, None] & has[:, None, :]
    return np.where(on, np.nan_to_num(corr), 0.0), on & ~np.isfinite(corr)


def edit_epoch(run: FilterRun, ep: EpochData) -> None:
    """Table 2 editing before the triple-difference tests (compiled qc_epoch), its rare events in Python.

    Reasons (8 no SD, 1 local horizon, 2 antenna horizon, 10 empty PCV bin, 3 C/N0, 6 half cycle), the epoch clock
    estimate from code (first signal): c dt0 = median(SD_code + u.b) / (1 - rdot/c) and its jump test against the
    prediction from the last estimate and the differential drift (free-running clocks drift by up to ~10 us/s
    relative to each other, so across an outage the change alone is no jump; no code this epoch: the prediction,
    the phase clocks absorb the drift), and the triple differences (time differences of SDs with the predicted
    geometry change, median-referenced). ep.step: the epoch's EpochStep (gnssatt.attitude.qc_records), td_checks
    takes it too."""
    k, t, st, lam = ep.k, ep.t, run.st, run.lam
    ep.consecutive = ep.prev_t is not None and (t - ep.prev_t) <= TD_MAX_DT_S       # bool or np.bool_: one type
    ep.do_td = ep.consecutive and run.prev_b is not None
    ep.step = epoch_step(i=ep.i, t_s=t, consecutive=ep.consecutive, do_td=ep.do_td)
    view = antenna_view(asn_rad=ep.asn, az_rad=ep.az, mask_on=run.R_mask is not None, ever_fixed=run.ever_fixed,
                        pcv_on=ep.pcv_on, pcv_empty=ep.empty, ub_m=ep.ub)
    n_jump, n_common = qc_epoch(run.sd_qc, run.sd_flags, view, ep.step, run.qc_memory, run.qc_clock, run.qc_limits,
                                run.qc_work)
    (ep.el_w, ep.el_ant, ep.az_ant, ep.reason, ep.use_c, ep.use_p, ep.slip, ep.td_c_ok, ep.td_p_ok, ep.sdc_c,
     ep.sdp_c, ep.td_c, ep.td_p, ep.mc, ep.mp) = run.views
    if n_jump:
        clk0, clk_pred = run.w_clk
        for j in np.flatnonzero(run.w_jump):
            run.events.add(k, "clock_jump", j, detail=f"differential clock changed by "
                                                      f"{(clk0[j] - clk_pred[j]) / C_M_S * 1e3:.3f} ms more than its "
                                                      f"drift predicts")
    if n_common:
        # a common phase jump without a code jump: a receiver clock jump not applied to phase -> integer shift
        common = _nz(ep.mp - ep.mc)
        for j, f in zip(*np.nonzero(np.abs(common) > 1000.0)):
            if run.fdma_sig[f]:
                _fdma_phase_clock_jump(run, ep, j, f, common[j, f])
                continue
            n_cyc_sat = np.round(common[j, f] / lam[:, f])         # per satellite (FDMA: per-channel wavelength)
            n_cyc = np.round(common[j, f] / run.lam_sig[f])
            sel = np.flatnonzero((st.amb_key[:, 0] == j) & (st.amb_key[:, 2] == f))
            st.x[st.n_fixed_part + sel] += n_cyc_sat[st.amb_key[sel, 1]]
            ep.mp[j, f] -= n_cyc * run.lam_sig[f]
            ep.td_p[j, :, f] -= n_cyc_sat * lam[:, f]
            run.events.add(k, "phase_clock_jump", j, sig=run.pobs.signals[f],
                           detail=f"{n_cyc:.0f} cycles common to all satellites")


#: a receiver clock jump is a whole number of milliseconds (receiver clock steering)
CLOCK_JUMP_UNIT_M = C_M_S * 1e-3
#: a common phase-minus-code jump this close to whole milliseconds is taken as exactly that (the median's code
#: noise is decimetres); farther off, the measured jump is used as it is
CLOCK_JUMP_TOL_M = 5.0


def _fdma_phase_clock_jump(run: FilterRun, ep: EpochData, j: int, f: int, common_m: float) -> None:
    """A receiver clock jump applied to the code but not the phase on an FDMA signal (GLONASS): repaired in the
    observations, not the integers. The jump is d metres of phase, the same for every satellite, which is f_k d / c
    cycles per satellite: for d = 1 ms half-integer on odd GLONASS channels k (f_k = 1602 + 0.5625 k MHz, GLONASS
    ICD 5.1 sec. 3.3.1.4), so no integer shift of the ambiguities absorbs it (the GPS repair above). d (whole ms
    when within CLOCK_JUMP_TOL_M of it, else as measured) is subtracted from this and every later SD phase of the
    baseline and signal (run.phase_jump_m) and the ambiguities are kept; an error e in d moves a double difference
    by e (1/lambda_s - 1/lambda_r), 0.0019 cycles per m and channel of difference on G1."""
    n_ms = np.round(common_m / CLOCK_JUMP_UNIT_M)
    whole = abs(common_m - n_ms * CLOCK_JUMP_UNIT_M) <= CLOCK_JUMP_TOL_M
    d = n_ms * CLOCK_JUMP_UNIT_M if whole else float(common_m)
    run.phase_jump_m[j, f] += d
    run.blk.sdp[ep.i + 1:, j, :, f] -= d
    ep.sdp_c[j, :, f] -= d
    ep.td_p[j, :, f] -= d
    ep.mp[j, f] -= d
    what = f"{n_ms:.0f} ms" if whole else f"{common_m:.3f} m (not whole ms, as measured)"
    run.events.add(ep.k, "phase_clock_jump", j, sig=run.pobs.signals[f],
                   detail=f"{what} common to all satellites (FDMA: repaired in the phase, integers kept)")


def noise_weights(run: FilterRun, ep: EpochData):
    """The C/N0 weights (code, phase) of the white-noise estimator, updating the C/N0-growth exponent gamma.

    Exponent gamma of the C/N0 growth (variance ~ factor^gamma) per observable and signal: slope of ln|TD| against
    ln(factor) / 2 (E ln|x| = ln sigma + const for Gaussian x), pooled moments over NOISE_EPOCHS; a receiver whose
    noise does not grow as C/N0 falls gets gamma ~ 0 (gnssatt.attitude.kernels: the samples, then the moments and
    gamma, in place). Implements: docs/attitude.md noise model (beyond seed 000 Table 1's fixed sigmas)."""
    if not ep.noise_on:
        return run.w_glw
    lw = run.blk_lw[ep.i]
    if run.cn0_growth:
        xs, rs, g_off = cn0_growth_samples(ep.td_c, ep.td_p, ep.td_c_ok, ep.td_p_ok, ep.mc, ep.mp, lw, run.lam_sig)
        growth_weights(True, xs, np.log(rs), g_off, run.mom, run.gam_n, run.gamma, NOISE_EPOCHS, NOISE_MIN_EPOCHS,
                       0.05, lw, run.w_glw)
    else:
        growth_weights(False, run.z_f, run.z_f, run.z_i, run.mom, run.gam_n, run.gamma, NOISE_EPOCHS,
                       NOISE_MIN_EPOCHS, 0.05, lw, run.w_glw)
    return np.exp(run.w_glw)                                           # C/N0 weights of code, phase


def triple_differences(run: FilterRun, ep: EpochData) -> None:
    """Table 2 triple-difference tests (code 0.5 m, phase 0.25 cycles) and the white-noise estimate (compiled
    td_checks); slips reported as events.

    MAD of the normalised TDs -> sigma of a TD = sqrt(2) sigma of one SD (white noise), in place; the TD tests:
    every phase with a state is checked, used or not (a slip while rejected (C/N0, mask) must not survive into the
    epochs where it is used again); the bookkeeping masks: restart an arc (new float from code-carrier) on a slip
    or where no triple difference could check it, drop states of satellites no longer observed or unused for
    max_gap_s."""
    k, st, s = ep.k, run.st, run.s
    ep.noise_on = s.noise.noise_estimation and ep.do_td
    wfac = noise_weights(run, ep)
    book = ambiguity_book(amb_index=st.amb_index, amb_last_t_s=st.amb_last_t, n_fixed_part=st.n_fixed_part)
    n_td, n_lli, ep.n_gap, ep.n_drop, ep.n_need = td_checks(run.sd_flags, ep.step, wfac, run.white_noise, book,
                                                            run.qc_memory, run.qc_limits, run.qc_work)
    # every slip is reported, also on phases not in use; an LLI on the first epoch of an arc is an acquisition
    for n, evm, how in ((n_td, run.w_ev[0], "triple-difference test"), (n_lli, run.w_ev[1], "loss-of-lock indicator")):
        if n:
            for j, sat, f in zip(*np.nonzero(evm)):
                run.events.add(k, "cycle_slip", j, run.pobs.sats[sat], run.pobs.signals[f],
                               how + ("" if st.amb_index[j, sat, f] >= 0 else " (phase not in use)"))


def ambiguity_bookkeeping(run: FilterRun, ep: EpochData) -> None:
    """Drop the ambiguity states marked by td_checks and add float states, from the code-carrier difference
    (SD phase - SD code) / lambda with Table 1's sigma0 (500 cycles), for used phases without one (seed 000 sec. 2:
    "newly initialized as float values based on code-carrier differences")."""
    st, k, lam = run.st, ep.k, run.lam
    if ep.n_gap:
        run.events.add(k, "arc_restart", detail=f"{ep.n_gap} ambiguities without a triple-difference check (data gap)")
    need, n_need = run.w_bk[1], ep.n_need
    if ep.n_drop:
        st.remove_ambiguities(st.amb_index[run.w_bk[0]], k - 1)
        need = ep.use_p & (st.amb_index < 0)
        n_need = int(need.sum())
    if n_need:
        jj, ss, ff = np.nonzero(need)
        vals = (ep.sdp_c[jj, ss, ff] - ep.sdc_c[jj, ss, ff]) / lam[ss, ff]
        st.add_ambiguities(np.stack([jj, ss, ff], 1), vals, run.s.table1.sigma0_ambiguity_cyc, ep.t)
