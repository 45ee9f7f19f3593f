"""Compiled (numba) kernels of the first half of the attitude filter's epoch (seed 000 Fig. 2 "propagate" and
"quality control", gnssatt.attitude.boxes): propagation with the white-noise clock reset, the single-difference
quality control (antenna-frame mask, C/N0, epoch clock estimate and its jump test, half cycles, triple differences
and their tests), the ambiguity bookkeeping masks and states, and the residual records.

Each kernel does in one call what ~100 numpy calls on arrays of a few dozen elements would, medians as
gnssatt.attitude.kernels.masked_median_axis1 (of an insertion sort of the few values, no allocation).
Transcendental functions (arcsin, arctan2, log, exp, power) stay in numpy, whose SIMD loops differ from the C
library's in the last bit. Rare events (clock jumps, phase clock jumps, slips, gaps, states to add or drop) come
back as masks and counts, so the filter only loops in Python when one happened. qc_epoch, td_checks and
record_epoch take a few records (gnssatt.attitude.qc_records) as plain tuples.

Specification: the readable numpy of gnssatt.attitude.reference_qc (qc_epoch and td_checks follow its qc_epoch:
seed 000 Table 2 editing and slip detection, sec. 2 one ambiguity per arc), reference_propagate (propagation,
sec. 2 eq. 2), reference_states (states added and dropped), reference_records (record_epoch) and reference_noise
(the white-noise estimator of docs/attitude.md); each kernel names its part. tests/attitude/test_qc_kernels.py
checks every kernel against it with tolerances in physical units.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from gnssatt.attitude.kernels import POW2, cn0_growth_update, white_noise_update
from gnssatt.attitude.qc_records import (AmbiguityBook, AntennaView, EpochClock, EpochMemory, EpochStep, OutputEpoch,
                                         PostFit, QcLimits, QcWork, ResidualBuffers, SdBlockFlags, SdBlockQc,
                                         WhiteNoise, ambiguity_book, antenna_view, epoch_step, output_epoch, post_fit)
from gnssatt.estimation.ekf_kernels import propagate_rotation_cov, rotation_rk4_stm_kernel

__all__ = ["reset_white_clocks", "propagate_dynamic", "propagate_kinematic", "clip_pair", "epoch_geometry", "qc_epoch",
           "growth_weights", "td_checks", "record_epoch", "take_square", "grow_square", "drop_states",
           "add_states", "warm_up"]

#: reason codes set here (gnssatt.attitude.filter.REASONS)
R_ANTENNA, R_CN0, R_TD_CODE, R_TD_PHASE, R_HALF, R_PCV_EMPTY = 2, 3, 4, 5, 6, 10
RAD2DEG = 180.0 / np.pi          # np.degrees multiplies by this constant


@njit(cache=True, nogil=True)
def _median_of(buf, n):
    """Median of the n values buf[:n] (no NaN) as np.median / masked_median_axis1 give it: 0.5 (lo + hi) of the
    middle ones after an insertion sort in place (a few dozen values; no allocation)."""
    for a in range(1, n):
        v = buf[a]
        b = a - 1
        while b >= 0 and buf[b] > v:
            buf[b + 1] = buf[b]
            b -= 1
        buf[b + 1] = v
    return 0.5 * (buf[(n - 1) // 2] + buf[n // 2])


@njit(cache=True, nogil=True)
def reset_white_clocks(x, P, white, var):
    """In place: x[white] = 0, rows and columns of P at white zeroed, P[white, white] = var (white-noise clocks)."""
    n = P.shape[0]
    for a in white:
        x[a] = 0.0
        for c in range(n):
            P[a, c] = 0.0
            P[c, a] = 0.0
    for a in white:
        P[a, a] = var


@njit(cache=True, nogil=True)
def propagate_dynamic(x, P, w_idx, b_idx, Qw, dt, max_step_s, white, var_clk):
    """In place, dynamic mode: the baselines x[b_idx] by RK4 rotation with omega x[0:3] over dt, P <- Phi P Phi^T +
    Q (gnssatt.estimation.ekf_kernels), then the white-noise clock reset; returns (Phi_bb, Phi_bw) for the smoother."""
    nb = b_idx.shape[0]
    bb = np.empty((nb, 3))
    for j in range(nb):
        for a in range(3):
            bb[j, a] = x[b_idx[j, a]]
    b1, Pbb, Pbw = rotation_rk4_stm_kernel(bb, x[0:3], dt, max_step_s)
    for j in range(nb):
        for a in range(3):
            x[b_idx[j, a]] = b1[j, a]
    propagate_rotation_cov(P, w_idx, b_idx, Pbb, Pbw, Qw, b1, dt)
    reset_white_clocks(x, P, white, var_clk)
    return Pbb, Pbw


@njit(cache=True, nogil=True)
def propagate_kinematic(x, P, b_flat, q_dt, white, var_clk):
    """In place, kinematic mode: P[b, b] += q_dt on the baseline diagonal (random walk), then the clock reset."""
    for a in b_flat:
        P[a, a] += q_dt
    reset_white_clocks(x, P, white, var_clk)


@njit(cache=True, nogil=True)
def clip_pair(da, db, out):
    """out[0], out[1] = np.clip(da, -1, 1), np.clip(db, -1, 1) (NaN propagates), for one np.arcsin call."""
    n0, n1 = da.shape
    for i in range(n0):
        for j in range(n1):
            for q in range(2):
                v = da[i, j] if q == 0 else db[i, j]
                if v < -1.0:
                    v = -1.0
                if v > 1.0:
                    v = 1.0
                out[q, i, j] = v


@njit(cache=True, nogil=True)
def epoch_geometry(u, R, bs_a_T, bs_b_T, x, b_idx, asn_in):
    """(los_b (n_sat, 3) = u R^T: lines of sight in the body frame, ub (n_bl, n_sat) = b u^T with b = x[b_idx]:
    the predicted SD geometry); asn_in (2, n_sat, n_bl) = clip(los_b bs_a_T), clip(los_b bs_b_T) (boresights of
    the first / second antennas as columns), for np.arcsin. np.dot (BLAS) where run_filter used @: the same bits
    (tests/attitude/test_qc_kernels.py)."""
    los = np.dot(u, R.T)
    clip_pair(np.dot(los, bs_a_T), np.dot(los, bs_b_T), asn_in)
    nb = b_idx.shape[0]
    b = np.empty((nb, 3))
    for j in range(nb):
        for a in range(3):
            b[j, a] = x[b_idx[j, a]]
    return los, np.dot(b, u.T)


@njit(cache=True, nogil=True)
def qc_epoch(sd: SdBlockQc, flags: SdBlockFlags, view: AntennaView, step: EpochStep, memory: EpochMemory,
             clock: EpochClock, limits: QcLimits, work: QcWork):
    """One epoch (row step.i of the SdBlock records sd, flags) of the filter's editing before the noise estimation,
    into work (QcWork) and clock (EpochClock) in place; returns (n clock jumps, n common phase jumps above 1000 m).

    work.el_rad = el_w (n_bl, n_sat) antenna-frame elevation = fmin of view.asn_rad[0], [1], el_ant / az_ant =
    el_w / az when view.mask_on (an attitude exists) else NaN; work.reason from sd.reason0: 2 below the antenna
    mask on ever-fixed baselines (mask_on), 10 an empty PCV bin (pcv_on, pcv_empty), 3 low C/N0, then 6 half cycle
    (after use_c); work.masks[0:5] = use_c, use_p, slip (LLI bit 1), td_c_ok, td_p_ok; work.values_m = sdc_c,
    sdp_c (minus clock_factor x the epoch clock), td_c, td_p (triple differences with the predicted geometry change
    ub - memory.prev_ub_m when step.do_td, else NaN); work.median_td_m = medians of td_c, td_p; clock.clock_m =
    clock estimate (median of (SD code 1 + u.b) / clock_factor over used satellites, else the prediction),
    prediction; clock.jump; clock.clock_state = last estimated clock, its time, its drift, updated.

    Specification: gnssatt.attitude.reference_qc.qc_epoch up to the TD tests (antenna_frame_elevations,
    edit_observations, epoch_clock, triple_differences; seed 000 Table 2).
    """
    sdc_m, sdp_m, low_cn0, reason0, clock_factor, baseline_ok = sd
    avail_c, avail_p, lli = flags
    asn_rad, az_rad, mask_on, ever_fixed, pcv_on, pcv_empty, ub_m = view
    i, t_s, consecutive, do_td = step
    prev_sdc_m, prev_sdp_m, prev_ub_m = memory
    clock_state, clock_m, jump = clock
    el_mask_ant_rad, clock_jump_m, td_max_dt_s, td_code_m, td_phase_cyc, max_gap_s, wavelength_m = limits
    el_rad, reason, masks, values_m, median_td_m = work
    sdc_m, sdp_m, low_cn0, reason0, avail_p, lli = sdc_m[i], sdp_m[i], low_cn0[i], reason0[i], avail_p[i], lli[i]
    clock_factor, baseline_ok = clock_factor[i], baseline_ok[i]                      # the epoch's rows
    el_w, el_ant, az_ant = el_rad[0], el_rad[1], el_rad[2]
    n_bl, n_sat, n_sig = sdc_m.shape
    use_c, use_p, slip, td_c_ok, td_p_ok = masks[0], masks[1], masks[2], masks[3], masks[4]
    sdc_c, sdp_c, td_c, td_p = values_m[0], values_m[1], values_m[2], values_m[3]
    for j in range(n_bl):
        for s in range(n_sat):
            a = asn_rad[0, s, j]
            b = asn_rad[1, s, j]
            if np.isnan(a):
                e = b
            elif np.isnan(b):
                e = a
            else:
                e = a if a <= b else b
            el_w[j, s] = e
            if mask_on:
                el_ant[j, s] = e
                az_ant[j, s] = az_rad[s]
            else:
                el_ant[j, s] = np.nan
                az_ant[j, s] = np.nan
            below = mask_on and ever_fixed[j] and not (e >= el_mask_ant_rad)
            for f in range(n_sig):
                r = reason0[j, s, f]
                if r == 0 and below:
                    r = R_ANTENNA
                if r == 0 and pcv_on and pcv_empty[j, s, f]:
                    r = R_PCV_EMPTY
                if r == 0 and low_cn0[j, s, f]:
                    r = R_CN0
                uc = r == 0
                ap = avail_p[j, s, f]
                up = uc and ap
                lv = lli[j, s, f]
                slip[j, s, f] = (lv & 1) != 0 and ap
                if (lv & 2) != 0 and ap:
                    if r == 0:
                        r = R_HALF
                    up = False
                reason[j, s, f] = r
                use_c[j, s, f] = uc
                use_p[j, s, f] = up
    # epoch clock from code (first signal), its prediction and jump test, the drift
    buf = np.empty(n_sat)
    n_jump = 0
    for j in range(n_bl):
        n = 0
        for s in range(n_sat):
            if use_c[j, s, 0]:
                v = (sdc_m[j, s, 0] + ub_m[j, s]) / clock_factor[s]
                if not np.isnan(v):
                    buf[n] = v
                    n += 1
        raw = _median_of(buf, n) if n else np.nan
        have0 = np.isfinite(raw)
        pc, pt, rate = clock_state[0, j], clock_state[1, j], clock_state[2, j]
        pred = pc + rate * (t_s - pt)
        if have0:
            c0 = raw
        elif np.isnan(pred):
            c0 = 0.0
        else:
            c0 = pred
        jmp = have0 and np.isfinite(pred) and np.abs(c0 - pred) > clock_jump_m and baseline_ok[j]
        upd = have0 and baseline_ok[j]
        dtc = t_s - pt
        if upd and not jmp and np.isfinite(pc) and dtc > 0 and dtc <= td_max_dt_s:
            clock_state[2, j] = rate + 0.1 * ((c0 - pc) / dtc - rate)
        if upd:
            clock_state[0, j] = c0
            clock_state[1, j] = t_s
        clock_m[0, j] = c0
        clock_m[1, j] = pred
        jump[j] = jmp
        if jmp:
            n_jump += 1
        for s in range(n_sat):
            corr = clock_factor[s] * c0
            dgeo = -(ub_m[j, s] - prev_ub_m[j, s]) if do_td else 0.0
            for f in range(n_sig):
                vc = sdc_m[j, s, f] - corr
                vp = sdp_m[j, s, f] - corr
                sdc_c[j, s, f] = vc
                sdp_c[j, s, f] = vp
                if do_td:
                    tc = vc - prev_sdc_m[j, s, f] - dgeo
                    tp = vp - prev_sdp_m[j, s, f] - dgeo
                    td_c[j, s, f] = tc
                    td_p[j, s, f] = tp
                    td_c_ok[j, s, f] = np.isfinite(tc) and use_c[j, s, f]
                    td_p_ok[j, s, f] = np.isfinite(tp) and use_p[j, s, f]
                else:
                    td_c[j, s, f] = np.nan
                    td_p[j, s, f] = np.nan
                    td_c_ok[j, s, f] = False
                    td_p_ok[j, s, f] = False
    n_common = 0
    if do_td:
        # medians over the satellites (gnssatt.attitude.kernels.masked_median_axis1 of td, td_ok)
        for j in range(n_bl):
            for f in range(n_sig):
                for q in range(2):
                    td = td_c if q == 0 else td_p
                    ok = td_c_ok if q == 0 else td_p_ok
                    n = 0
                    for s in range(n_sat):
                        if ok[j, s, f]:
                            buf[n] = td[j, s, f]
                            n += 1
                    median_td_m[q, j, f] = _median_of(buf, n) if n else np.nan
                d = median_td_m[1, j, f] - median_td_m[0, j, f]
                if not np.isnan(d) and np.abs(d) > 1000.0:
                    n_common += 1
    else:
        median_td_m[:] = np.nan
    return n_jump, n_common


@njit(cache=True, nogil=True)
def growth_weights(update, xs, log_rs, off, mom, gam_n, gamma, noise_epochs, min_epochs, min_var, lw, glw):
    """If update: gnssatt.attitude.kernels.cn0_growth_update (moments and gamma, in place); then glw[kk] =
    gamma[kk, f] x lw (n_bl, n_sat, n_sig), whose exp is the C/N0 weight of code (kk = 0) / phase (1)."""
    if update:
        cn0_growth_update(xs, log_rs, off, mom, gam_n, gamma, noise_epochs, min_epochs, min_var, POW2)
    n_bl, n_sat, n_sig = lw.shape
    for kk in range(2):
        for j in range(n_bl):
            for s in range(n_sat):
                for f in range(n_sig):
                    glw[kk, j, s, f] = gamma[kk, f] * lw[j, s, f]


@njit(cache=True, nogil=True)
def td_checks(flags: SdBlockFlags, step: EpochStep, wfac, noise: WhiteNoise, book: AmbiguityBook,
              memory: EpochMemory, limits: QcLimits, work: QcWork):
    """The filter's white-noise update (gnssatt.attitude.kernels.white_noise_update with the C/N0 weights wfac
    (2, bl, sat, sig) of code and phase, when step.do_td), triple-difference tests and ambiguity-bookkeeping masks
    of one epoch (row step.i of flags), after qc_epoch (and any phase clock jump correction); returns (n TD slips,
    n LLI slips, n gaps, n to drop, n to add).

    In place in work: reason 4 and use_c off where the code TD is off its median by more than td_code_m; slip where
    a phase TD (every available phase) is off by more than td_phase_cyc cycles; masks[5] = such slips without LLI,
    masks[6] = LLI slips of phases with a state or a previous epoch (memory.prev_sdp_m finite, consecutive);
    masks[7] = states to drop (restart on a slip or where no TD could check, satellite gone, unused for
    max_gap_s), masks[8] = phases needing a state (valid only when nothing is dropped).

    Specification: gnssatt.attitude.reference_qc.triple_difference_tests and ambiguity_bookkeeping (seed 000
    Table 2, sec. 2), gnssatt.attitude.reference_noise.update_white_noise.
    """
    avail_c, avail_p, lli = flags
    i, t_s, consecutive, do_td = step
    amb_index, amb_last_t_s, n_fixed_part = book
    prev_sdc_m, prev_sdp_m, prev_ub_m = memory
    el_mask_ant_rad, clock_jump_m, td_max_dt_s, td_code_m, td_phase_cyc, max_gap_s, wavelength_m = limits
    el_rad, reason, masks, values_m, median_td_m = work
    ev_td, ev_lli, to_drop, to_add = masks[5], masks[6], masks[7], masks[8]
    avail_p, lli = avail_p[i], lli[i]                                                # the epoch's rows
    n_bl, n_sat, n_sig = reason.shape
    use_c, use_p, slip, td_c_ok, td_p_ok = masks[0], masks[1], masks[2], masks[3], masks[4]
    td_c, td_p = values_m[2], values_m[3]
    mc, mp = median_td_m[0], median_td_m[1]
    if do_td:
        white_noise_update((td_c, td_p, td_c_ok, td_p_ok, mc, mp), wfac, noise, POW2)      # TripleDifferences
    n_td = 0
    n_lli = 0
    n_gap = 0
    n_drop = 0
    n_need = 0
    t_gap = t_s - max_gap_s
    for j in range(n_bl):
        for f in range(n_sig):
            m_c = mc[j, f]
            if np.isnan(m_c):
                m_c = 0.0
            m_p = mp[j, f]
            if np.isnan(m_p):
                m_p = 0.0
            lim_p = td_phase_cyc * wavelength_m[f]
            for s in range(n_sat):
                ap = avail_p[j, s, f]
                l1 = (lli[j, s, f] & 1) != 0
                e_td = False
                if do_td:
                    if td_c_ok[j, s, f] and np.abs(td_c[j, s, f] - m_c) > td_code_m:
                        if reason[j, s, f] == 0:
                            reason[j, s, f] = R_TD_CODE
                        use_c[j, s, f] = False
                    tp = td_p[j, s, f]
                    if np.isfinite(tp) and ap and np.abs(tp - m_p) > lim_p:
                        slip[j, s, f] = True
                        e_td = not l1
                ev_td[j, s, f] = e_td
                n_td += e_td
                ai = amb_index[j, s, f]
                have = ai >= 0
                cont = consecutive and np.isfinite(prev_sdp_m[j, s, f])
                e_l = l1 and ap and (have or cont)
                ev_lli[j, s, f] = e_l
                n_lli += e_l
                td_possible = do_td and np.isfinite(td_p[j, s, f])
                sl = slip[j, s, f]
                drop = False
                if have:
                    if ap and not sl and not td_possible:
                        n_gap += 1
                    last_t = amb_last_t_s[ai - n_fixed_part]
                    drop = (ap and (sl or not td_possible)) or not ap or (not use_p[j, s, f] and last_t < t_gap)
                to_drop[j, s, f] = drop
                n_drop += drop
                need = use_p[j, s, f] and not have
                to_add[j, s, f] = need
                n_need += need
    return n_td, n_lli, n_gap, n_drop, n_need


@njit(cache=True, nogil=True)
def record_epoch(flags: SdBlockFlags, epoch: OutputEpoch, fit: PostFit, work: QcWork, memory: EpochMemory,
                 buffers: ResidualBuffers, pos):
    """The residual rows of epoch.k (row epoch.i of flags) written from row pos of buffers.ints (6, cap) = epoch,
    bl, sat, sig, kind, reason and buffers.floats (4, cap) = el_ant_deg, az_ant_deg (of az mod 2 pi), cn0_dbhz,
    residual_m: its code rows (kind 0, every available code in (bl, sat, sig) order, residual post_m[r] of code row
    r (jc, sc, fc), post_m[jc.size + r] of phase row r (jp, sp, fp) when the update had rows, else NaN, reason 0 if
    used), then its phase rows (kind 1, where a phase exists; reason 0 if used, else the code's or 5 (td_phase));
    and the memory of the triple differences memory.prev_sdc_m / prev_sdp_m = sdc_c / sdp_c where available, else
    NaN, memory.prev_ub_m = b_out_m u^T (the epoch's output baselines, np.dot as the former @). Returns the next
    free row.

    Specification: gnssatt.attitude.reference_records.epoch_residual_rows, residual_table (row order) and
    triple_difference_memory (seed 000 Fig. 2 "output").
    """
    avail_c, avail_p, lli = flags
    k, i, cn0_dbhz, u, b_out_m = epoch
    avail_c, avail_p = avail_c[i], avail_p[i]                                        # the epoch's rows
    post_m, jc, sc, fc, jp, sp, fp = fit
    el_rad, reason, masks, values_m, median_td_m = work
    prev_sdc_m, prev_sdp_m, prev_ub_m = memory
    ints, floats, lookup = buffers
    el_ant, az_ant = el_rad[1], el_rad[2]
    use_c, use_p = masks[0], masks[1]
    sdc_c, sdp_c = values_m[0], values_m[1]
    n_bl, n_sat, n_sig = avail_c.shape
    lookup[:] = np.nan
    if post_m.size:
        mc_n = jc.size
        for r in range(mc_n):
            lookup[0, jc[r], sc[r], fc[r]] = post_m[r]
        for r in range(jp.size):
            lookup[1, jp[r], sp[r], fp[r]] = post_m[mc_n + r]
    for kind in range(2):
        for j in range(n_bl):
            for s in range(n_sat):
                el_deg = el_ant[j, s] * RAD2DEG
                az_deg = (az_ant[j, s] % (2 * np.pi)) * RAD2DEG
                for f in range(n_sig):
                    if not avail_c[j, s, f] or (kind == 1 and not avail_p[j, s, f]):
                        continue
                    ints[0, pos] = k
                    ints[1, pos] = j
                    ints[2, pos] = s
                    ints[3, pos] = f
                    ints[4, pos] = kind
                    r = reason[j, s, f]
                    if kind == 0:
                        ints[5, pos] = 0 if use_c[j, s, f] else r
                    else:
                        ints[5, pos] = 0 if use_p[j, s, f] else (R_TD_PHASE if r == 0 else r)
                    floats[0, pos] = el_deg
                    floats[1, pos] = az_deg
                    floats[2, pos] = cn0_dbhz[j, s, f]
                    floats[3, pos] = lookup[kind, j, s, f]
                    pos += 1
    for j in range(n_bl):
        for s in range(n_sat):
            for f in range(n_sig):
                prev_sdc_m[j, s, f] = sdc_c[j, s, f] if avail_c[j, s, f] else np.nan
                prev_sdp_m[j, s, f] = sdp_c[j, s, f] if avail_p[j, s, f] else np.nan
    prev_ub_m[:] = np.dot(b_out_m, u.T)
    return pos


@njit(cache=True, nogil=True)
def take_square(P, idx):
    """P[np.ix_(idx, idx)] (a new C-contiguous array): the covariance of the states kept when ambiguities go."""
    n = idx.size
    out = np.empty((n, n))
    for a in range(n):
        ra = idx[a]
        for b in range(n):
            out[a, b] = P[ra, idx[b]]
    return out


@njit(cache=True, nogil=True)
def grow_square(P, k, var):
    """(n + k, n + k) covariance: P, then k new uncorrelated states of variance var (new ambiguities)."""
    n0 = P.shape[0]
    out = np.zeros((n0 + k, n0 + k))
    for a in range(n0):
        for b in range(n0):
            out[a, b] = P[a, b]
    for a in range(n0, n0 + k):
        out[a, a] = var
    return out


@njit(cache=True, nogil=True)
def drop_states(x, P, keep, n_fixed, amb_key, amb_fixed, amb_last_t, amb_arc, amb_index):
    """(x, P, amb_key, amb_fixed, amb_last_t, amb_arc) of the states where keep (the ambiguity arrays row a at
    state n_fixed + a), with amb_index rewritten in place (-1 for dropped keys, the new state index of kept ones):
    run_filter's _State.remove_ambiguities without its arc log."""
    n1 = 0
    for a in range(keep.size):
        n1 += keep[a]
    idx = np.empty(n1, np.int64)
    q = 0
    for a in range(keep.size):
        if keep[a]:
            idx[q] = a
            q += 1
    x1 = np.empty(n1)
    for a in range(n1):
        x1[a] = x[idx[a]]
    P1 = take_square(P, idx)
    m0 = amb_key.shape[0]
    m1 = n1 - n_fixed
    key1 = np.empty((m1, 3), np.int64)
    fixed1 = np.empty(m1, np.bool_)
    last1 = np.empty(m1)
    arc1 = np.empty(m1, np.int64)
    for a in range(m0):
        if not keep[n_fixed + a]:
            amb_index[amb_key[a, 0], amb_key[a, 1], amb_key[a, 2]] = -1
    q = 0
    for a in range(m0):
        if keep[n_fixed + a]:
            for c in range(3):
                key1[q, c] = amb_key[a, c]
            fixed1[q] = amb_fixed[a]
            last1[q] = amb_last_t[a]
            arc1[q] = amb_arc[a]
            amb_index[amb_key[a, 0], amb_key[a, 1], amb_key[a, 2]] = n_fixed + q
            q += 1
    return x1, P1, key1, fixed1, last1, arc1


@njit(cache=True, nogil=True)
def add_states(x, P, values, var, keys, t, arc0, amb_key, amb_fixed, amb_last_t, amb_arc, amb_index):
    """(x, P, amb_key, amb_fixed, amb_last_t, amb_arc) with k new ambiguity states appended: values, variance var
    (uncorrelated), keys (k, 3), not fixed, last used at t, arcs arc0 + 0..k-1; amb_index of the keys set in place:
    run_filter's _State.add_ambiguities without its arc log."""
    n0 = x.size
    k = keys.shape[0]
    m0 = amb_key.shape[0]
    x1 = np.empty(n0 + k)
    x1[:n0] = x
    x1[n0:] = values
    key1 = np.empty((m0 + k, 3), np.int64)
    key1[:m0] = amb_key
    key1[m0:] = keys
    fixed1 = np.zeros(m0 + k, np.bool_)
    fixed1[:m0] = amb_fixed
    last1 = np.empty(m0 + k)
    last1[:m0] = amb_last_t
    last1[m0:] = t
    arc1 = np.empty(m0 + k, np.int64)
    arc1[:m0] = amb_arc
    for a in range(k):
        arc1[m0 + a] = arc0 + a
        amb_index[keys[a, 0], keys[a, 1], keys[a, 2]] = n0 + a
    return x1, grow_square(P, k, var), key1, fixed1, last1, arc1


def warm_up() -> None:
    """Compile (or load from the cache) every kernel once on tiny inputs of the types run_filter passes (contiguous
    epoch slices of the SdBlock; np.nonzero's index arrays both contiguous and strided)."""
    n_bl, n_sat, n_sig = 2, 3, 2
    sh = (n_bl, n_sat, n_sig)
    x, P = np.zeros(14), np.eye(14)
    white, b_idx = np.array([6, 12], np.int64), np.array([[3, 4, 5], [7, 8, 9]], np.int64)
    propagate_dynamic(x, P, np.arange(3, dtype=np.int64), b_idx, np.eye(3), 1.0, 1.0, white, 1.0)
    propagate_kinematic(x, P, b_idx.ravel(), 1.0, white, 1.0)
    reset_white_clocks(x, P, white, 1.0)
    asn = np.zeros((2, n_sat, n_bl))
    clip_pair(np.zeros((n_sat, n_bl)), np.zeros((n_sat, n_bl)), asn)
    u = np.ones((n_sat, 3))
    for nb in (1, n_bl):           # boresight columns (3, n_bl) in Fortran order; C too for one baseline
        bs_T = np.ones((nb, 3)).T
        epoch_geometry(u, np.eye(3), bs_T, bs_T, x, b_idx[:nb], np.zeros((2, n_sat, nb)))
    f2, f3, b3 = np.zeros((n_bl, n_sat)), np.zeros(sh), np.zeros(sh, np.bool_)
    i3, lli = np.zeros(sh, np.int64), np.zeros(sh, np.int8)
    limits = tuple(QcLimits(el_mask_ant_rad=0.0, clock_jump_m=1.0, td_max_dt_s=3.0, td_code_m=1.0, td_phase_cyc=0.5,
                            max_gap_s=10.0, wavelength_m=np.ones(n_sig)))
    work = tuple(QcWork(el_rad=np.zeros((3, n_bl, n_sat)), reason=i3.copy(), masks=np.zeros((9,) + sh, np.bool_),
                        values_m=np.zeros((4,) + sh), median_td_m=np.zeros((2, n_bl, n_sig))))
    memory = tuple(EpochMemory(prev_sdc_m=f3.copy(), prev_sdp_m=f3.copy(), prev_ub_m=f2.copy()))
    clock = tuple(EpochClock(clock_state=np.zeros((3, n_bl)), clock_m=np.zeros((2, n_bl)),
                             jump=np.zeros(n_bl, np.bool_)))
    f4, b4 = np.zeros((2,) + sh), np.zeros((2,) + sh, np.bool_)                 # SdBlock arrays of 2 epochs
    sd = tuple(SdBlockQc(sdc_m=f4, sdp_m=f4, low_cn0=b4, reason0=np.zeros((2,) + sh, np.int64),
                         clock_factor=np.ones((2, n_sat)), baseline_ok=np.ones((2, n_bl), np.bool_)))
    flags = tuple(SdBlockFlags(avail_c=b4, avail_p=b4, lli=np.zeros((2,) + sh, np.int8)))
    noise = tuple(WhiteNoise(var_code_m2=np.ones(n_sig), var_phase_m2=np.ones(n_sig), n_white=np.zeros(n_sig),
                             memory_epochs=300.0, enabled=True))
    book = ambiguity_book(amb_index=i3 - 1, amb_last_t_s=np.zeros(0), n_fixed_part=8)
    for do in (False, True):
        view = antenna_view(asn_rad=asn, az_rad=np.zeros(n_sat), mask_on=do, ever_fixed=np.zeros(n_bl, np.bool_),
                            pcv_on=do, pcv_empty=b3, ub_m=f2)
        step = epoch_step(i=1, t_s=1.0, consecutive=do, do_td=do)
        qc_epoch(sd, flags, view, step, memory, clock, limits, work)
        td_checks(flags, step, np.ones((2,) + sh), noise, book, memory, limits, work)
    z = np.zeros(0)
    for do in (False, True):
        growth_weights(do, z, z, np.zeros(2 * n_sig + 1, np.int64), np.zeros((2, n_sig, 4)), np.zeros((2, n_sig)),
                       np.ones((2, n_sig)), 300.0, 10, 0.05, f3, np.zeros((2,) + sh))
    take_square(P, np.arange(3, dtype=np.int64))
    grow_square(P, 2, 1.0)
    amb_index = np.full(sh, -1, np.int64)
    keys = np.array([[0, 1, 0], [1, 2, 1]], np.int64)
    st = add_states(x, P, np.ones(2), 1.0, keys, 1.0, 0, np.zeros((0, 3), np.int64), np.zeros(0, np.bool_),
                    np.zeros(0), np.zeros(0, np.int64), amb_index)
    keep = np.ones(16, np.bool_)
    keep[14] = False
    drop_states(st[0], st[1], keep, 14, st[2], st[3], st[4], st[5], amb_index)
    buffers = tuple(ResidualBuffers(ints=np.zeros((6, 8), np.int64), floats=np.zeros((4, 8)),
                                    lookup=np.zeros((2,) + sh)))
    epoch = output_epoch(k=0, i=1, cn0_dbhz=f3, u=u, b_out_m=np.zeros((n_bl, 3)))
    for idx in (np.zeros(1, np.int64), np.nonzero(np.ones((2, 2)))[0]):      # contiguous, strided
        fit = post_fit(post_m=z, jc=idx, sc=idx, fc=idx, jp=idx, sp=idx, fp=idx)
        record_epoch(flags, epoch, fit, work, memory, buffers, 0)
