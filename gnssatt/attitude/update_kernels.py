"""Compiled (numba) kernels of the attitude filter's measurement update, fix bookkeeping and mask attitude (the
boxes "measurement update", "ambiguity resolution" and "output" of seed 000 Fig. 2, gnssatt.attitude.boxes).

`measurement_update` does in one call what the filter did with a few dozen numpy calls per epoch: the sparse
rows (gnssatt.attitude.kernels.measurement_rows), the measurement variances (white noise x C/N0 factor^gamma
[x elevation factor] + the multipath model), the update itself (gnssatt.estimation.ekf_kernels
.sequential_update_sparse, m scalar updates instead of the batch Joseph form: the same estimator, results equal to
the last bits of the arithmetic), the post-fit residuals and the sums of the adaptive multipath scale.
`phase_row_stats` gives the per-baseline satellite counts, the unfixed rows (the ambiguity resolution skips a
baseline whose used ambiguities are all fixed) and the fix monitor's post-fit sums; `fix_newcomers` rounds and
constrains the newcomers of a fixed baseline; `store_outputs` writes an epoch's outputs; `quest_dcm` gives the
attitude of the antenna-frame mask (the q-method of gnssatt.gnss.rotations.quest for one epoch).

The kernels take their inputs as a few records (plain tuples in the field order of the NamedTuples of
gnssatt.attitude.update_records), unpacked in one line at the top.

Specification: gnssatt.attitude.reference_update, the readable numpy form of the same steps (seed 000 eq. 1,
Table 1, Fig. 2; each kernel names its function there); tests/attitude/test_update_kernels.py compares every
kernel with it, with tolerances in physical units.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from gnssatt.attitude.kernels import measurement_rows, np_sum
from gnssatt.attitude.update_records import (EpochStatus, FixState, NoiseModel, OutputBuffers, OutputSettings,
                                             RoundingLimits, StateLayout, UpdateObs, UpdateOutputs, UsedRows,
                                             VarianceModel)
from gnssatt.estimation.ekf_kernels import sequential_update_sparse

__all__ = ["cn0_factor", "mp_var", "measurement_variances", "white_variances", "measurement_update", "update_epoch",
           "white_variances_cp", "phase_row_stats", "round_newcomers_rows", "fix_newcomers", "store_outputs",
           "quest_dcm", "warm_up"]

_HALF_PI = np.pi / 2


@njit(cache=True, nogil=True)
def cn0_factor(cn0_dbhz):
    """Variance factor 10^((45 - C/N0)/10) clipped to [0.25, 16] (NaN C/N0 -> 45 dB-Hz) of one observation.
    Specification: gnssatt.attitude.reference_noise.cn0_variance_factor."""
    c = 45.0 if np.isnan(cn0_dbhz) else cn0_dbhz
    v = 10.0 ** ((45.0 - c) / 10.0)
    return min(max(v, 0.25), 16.0)


@njit(cache=True, nogil=True)
def mp_var(off_boresight_rad, sigma_boresight_m, sigma_horizon_m):
    """Variance (m^2) of the time-correlated error of one SD (sigma grows with the square of the off-boresight
    angle from the boresight value to sigma_horizon_m at 90 deg; capped at 120 deg; NaN -> 90 deg).
    Specification: gnssatt.attitude.reference_noise.multipath_variance_m2."""
    th = _HALF_PI if np.isnan(off_boresight_rad) else off_boresight_rad
    x = min(max(th / _HALF_PI, 0.0), 4.0 / 3.0)
    v = sigma_boresight_m + (sigma_horizon_m - sigma_boresight_m) * x * x
    return v * v


@njit(cache=True, nogil=True)
def white_variances(est_var, est_n, floor_var, min_epochs, estimate):
    """(n_sig,) white-noise variance of one SD per signal: the estimate (not below the configured floor) once
    min_epochs of triple differences were seen, else the floor; the floor alone without noise estimation.
    Specification: gnssatt.attitude.reference_update.white_variances."""
    out = np.empty(est_var.size)
    for f in range(est_var.size):
        out[f] = max(est_var[f], floor_var) if (estimate and est_n[f] >= min_epochs) else floor_var
    return out


@njit(cache=True, nogil=True)
def measurement_variances(rows: UsedRows, obs: UpdateObs, model: VarianceModel):
    """(var (m,), v_white (m,), v_mp (m,)) in m^2 of the code rows, then the phase rows of `rows`: the white
    variance of the signal x C/N0 factor^gamma[kind, f] (if cn0_growth) x clip(1/sin^2 e, 1, 16) of el_e_rad (NaN ->
    0.5 rad, e >= 0.05 rad; if elevation_weighting) = v_white, plus mp_mult x v_mp, v_mp the multipath variance at
    the off-boresight angle 90 deg - el_w_rad (if mp_model). Records: gnssatt.attitude.update_records.

    Specification: gnssatt.attitude.reference_update.measurement_variances (seed 000 Table 1 and the noise model of
    docs/attitude.md).
    """
    jc, sc, fc, jp, sp, fp = rows
    u, clock_factor, wavelength_m, sdc_c_m, sdp_c_m, pcv_m, cn0_dbhz, el_e_rad, el_w_rad = obs
    var_code_m2, var_phase_m2, gamma, cn0_growth, elevation_weighting, mp_model, mp_sigma_m, mp_mult = model
    mc_n = jc.size
    m = mc_n + jp.size
    var = np.empty(m)
    v_white = np.empty(m)
    v_mp = np.zeros(m)
    for r in range(m):
        if r < mc_n:
            j, s, f, kind = jc[r], sc[r], fc[r], 0
            v = var_code_m2[f]
        else:
            j, s, f, kind = jp[r - mc_n], sp[r - mc_n], fp[r - mc_n], 1
            v = var_phase_m2[f]
        if cn0_growth:
            v *= cn0_factor(cn0_dbhz[j, s, f]) ** gamma[kind, f]
        if elevation_weighting:
            e = el_e_rad[j, s]
            if np.isnan(e):
                e = 0.5
            e = max(e, 0.05)
            se = np.sin(e)
            v *= min(max(1.0 / (se * se), 1.0), 16.0)
        v_white[r] = v
        if mp_model:
            vm = mp_var(_HALF_PI - el_w_rad[j, s], mp_sigma_m[2 * kind], mp_sigma_m[2 * kind + 1])
            v_mp[r] = vm
            v += vm * mp_mult
        var[r] = v
    return var, v_white, v_mp


@njit(cache=True, nogil=True)
def measurement_update(x, P, rows: UsedRows, layout: StateLayout, obs: UpdateObs, model: VarianceModel,
                       fix: FixState, amb_last_t_s, t_s, joseph_ratio) -> UpdateOutputs:
    """One epoch's measurement update, x (n,) and P (n, n) in place (unchanged if an innovation variance is not
    positive; good = False); amb_last_t_s (n_amb,) of the ambiguities in the update set to t_s (s).

    Returns the fields of update_records.UpdateOutputs as a plain tuple: the sparse rows and observations
    (measurement_rows), the variances (measurement_variances; v_mp without the multipath multiplier mp_mult),
    the post-fit residuals z - H x+, and over the phase rows of fixed ambiguities the sums of the adaptive
    multipath scale: mp_num = sum(post^2 / (1 - h) - v_white), mp_den = sum(v_mp), n_mp rows, with the leverage
    h = clip(H P+ H^T / var, 0, 0.95) (E[r^2] = R_true (1 - h)); then phase_row_stats of the phase rows (n_used,
    n_fixed_used, n_unfixed, n_fix_rows, ms_fix) and (n_bl,) has_fix: the baselines with a fixed ambiguity state.
    The rows are applied as m scalar updates in turn (gnssatt.estimation.ekf_kernels.sequential_update_sparse,
    short form, Joseph form for rows with H P H^T > joseph_ratio R): the same estimator as the batch Joseph update
    of the specification, equal to rounding errors.

    Specification: gnssatt.attitude.reference_update.measurement_update (seed 000 Fig. 2 "measurement update", eq. 1,
    Table 1; Joseph form, Gelb 1974 eq. 4.2-21) and multipath_scale_sums (docs/attitude.md).
    """
    jc, sc, fc, jp, sp, fp = rows
    b_idx, clk, pclk, bias, amb_index, n_fixed_part = layout
    amb_fixed, amb_key = fix
    n_bl, n_sat = amb_index.shape[0], amb_index.shape[1]
    cols, coef, z = measurement_rows(rows, layout, obs)
    var_m2, v_white, v_mp_m2 = measurement_variances(rows, obs, model)
    good = sequential_update_sparse(x, P, cols, coef, var_m2, z, joseph_ratio)
    mc_n = jc.size
    m = cols.shape[0]
    kk = cols.shape[1]
    for r in range(mc_n, m):
        amb_last_t_s[cols[r, 4] - n_fixed_part] = t_s
    post_m = np.empty(m)
    for r in range(m):
        hx = 0.0
        for a in range(kk):
            c = cols[r, a]
            if c >= 0:
                hx += coef[r, a] * x[c]
        post_m[r] = z[r] - hx
    bn = np.empty(m)
    bd = np.empty(m)
    n_mp = 0
    for r in range(mc_n, m):
        if not amb_fixed[cols[r, 4] - n_fixed_part]:
            continue
        hph = 0.0
        for a in range(kk):
            ca = cols[r, a]
            if ca < 0:
                continue
            acc = 0.0
            for b in range(kk):
                cb = cols[r, b]
                if cb >= 0:
                    acc += P[ca, cb] * coef[r, b]
            hph += coef[r, a] * acc
        one_h = min(max(1.0 - hph / var_m2[r], 0.05), 1.0)
        bn[n_mp] = post_m[r] * post_m[r] / one_h - v_white[r]
        bd[n_mp] = v_mp_m2[r]
        n_mp += 1
    mp_num = np_sum(bn[:n_mp])
    mp_den = np_sum(bd[:n_mp])
    n_used, n_fixed_used, n_unfixed, n_fix_rows, ms_fix_m2 = phase_row_stats(jp, sp, cols, mc_n, amb_fixed,
                                                                             n_fixed_part, post_m, n_bl, n_sat)
    has_fix = np.zeros(n_bl, np.bool_)
    for a in range(amb_key.shape[0]):
        if amb_fixed[a]:
            has_fix[amb_key[a, 0]] = True
    return (cols, coef, z, var_m2, v_mp_m2, post_m, good, mp_num, mp_den, n_mp, n_used, n_fixed_used, n_unfixed,
            n_fix_rows, ms_fix_m2, has_fix)


@njit(cache=True, nogil=True)
def phase_row_stats(jp, sp, cols, mc_n, amb_fixed, n_fixed_part, post, n_bl, n_sat):
    """Per baseline over the phase rows (jp, sp) of an update (rows mc_n.. of cols / post; ambiguity in column 4):
    (n_used satellites, n_fixed_used satellites with a fixed ambiguity, n_unfixed rows, n_fix_rows rows with a
    fixed ambiguity, mean square of their post-fit residuals (NaN if none)): the satellite counts of the fix test,
    the skip of the ambiguity resolution for a baseline without unfixed rows, and the fix monitor's RMS.
    Specification: gnssatt.attitude.reference_update.phase_row_stats."""
    occ = np.zeros((n_bl, n_sat), np.bool_)
    occ_f = np.zeros((n_bl, n_sat), np.bool_)
    n_used = np.zeros(n_bl, np.int64)
    n_fixed = np.zeros(n_bl, np.int64)
    n_unfixed = np.zeros(n_bl, np.int64)
    n_fix_rows = np.zeros(n_bl, np.int64)
    ms = np.full(n_bl, np.nan)
    mp_n = jp.size
    buf = np.empty(mp_n)
    for j in range(n_bl):
        nb = 0
        for i in range(mp_n):
            if jp[i] != j:
                continue
            s = sp[i]
            if not occ[j, s]:
                occ[j, s] = True
                n_used[j] += 1
            if amb_fixed[cols[mc_n + i, 4] - n_fixed_part]:
                if not occ_f[j, s]:
                    occ_f[j, s] = True
                    n_fixed[j] += 1
                p = post[mc_n + i]
                buf[nb] = p * p
                nb += 1
            else:
                n_unfixed[j] += 1
        n_fix_rows[j] = nb
        if nb:
            ms[j] = np_sum(buf[:nb]) / nb
    return n_used, n_fixed, n_unfixed, n_fix_rows, ms


@njit(cache=True, nogil=True)
def round_newcomers_rows(x, P, fix: FixState, n_fixed_part, idx_j, sig_j, el_j, n_sig, j, limits: RoundingLimits):
    """(new (r,), ref (r,), integers (r,)) of the DD ambiguities new - ref of baseline j fixed by rounding, and
    fix.amb_fixed set in place for them and their references, per signal f in turn.

    idx_j, sig_j, el_j: state index, signal and local elevation of baseline j's phase rows. Per signal: the
    reference is the first fixed ambiguity state of (j, f), else the unfixed newcomer at the highest elevation
    (first of equals; NaN counts as highest, as np.argmax); a DD is rounded when its sigma < max_sigma_cyc and its
    float lies within max_frac_cyc of the integer (bootstrapping, Teunissen 1998). Records:
    gnssatt.attitude.update_records.

    Specification: gnssatt.attitude.reference_update.round_newcomers_rows (gnssatt.attitude.ambiguity
    .round_newcomers per signal).
    """
    amb_fixed, amb_key = fix
    max_sigma_cyc, max_frac_cyc, var_cyc2 = limits
    nr = idx_j.size
    fixed_j = np.empty(nr, np.bool_)
    for i in range(nr):
        fixed_j[i] = amb_fixed[idx_j[i] - n_fixed_part]
    out_new = np.empty(nr, np.int64)
    out_ref = np.empty(nr, np.int64)
    out_v = np.empty(nr)
    n_out = 0
    for f in range(n_sig):
        n_cand = 0
        for i in range(nr):
            if sig_j[i] == f and not fixed_j[i]:
                n_cand += 1
        if n_cand == 0:
            continue
        ref = -1
        for a in range(amb_key.shape[0]):
            if amb_key[a, 0] == j and amb_key[a, 2] == f and amb_fixed[a]:
                ref = n_fixed_part + a
                break
        if ref < 0:
            best = -1
            for i in range(nr):
                if sig_j[i] == f and not fixed_j[i]:
                    if best < 0:
                        best = i
                    elif not np.isnan(el_j[best]) and (np.isnan(el_j[i]) or el_j[i] > el_j[best]):
                        best = i
            ref = idx_j[best]
            if n_cand == 1:
                continue
        any_ok = False
        for i in range(nr):
            if sig_j[i] != f or fixed_j[i]:
                continue
            c = idx_j[i]
            if c == ref:
                continue
            d = x[c] - x[ref]
            var = (P[c, c] - P[ref, c]) - (P[c, ref] - P[ref, ref])
            r = np.round(d)
            if np.sqrt(max(var, 0.0)) < max_sigma_cyc and np.abs(d - r) < max_frac_cyc:
                out_new[n_out] = c
                out_ref[n_out] = ref
                out_v[n_out] = r
                n_out += 1
                any_ok = True
        if any_ok:
            for q in range(n_out):
                if out_ref[q] == ref:
                    amb_fixed[out_new[q] - n_fixed_part] = True
            amb_fixed[ref - n_fixed_part] = True
    return out_new[:n_out], out_ref[:n_out], out_v[:n_out]


@njit(cache=True, nogil=True)
def fix_newcomers(x, P, fix: FixState, n_fixed_part, cols, rows: UsedRows, el_loc_rad, n_sig, j,
                  limits: RoundingLimits):
    """(new, ref, integers, applied) as round_newcomers_rows over baseline j's phase rows of the update (row
    m_code + i of cols with jp[i] == j: ambiguity state cols[., 4], signal fp[i], local elevation el_loc_rad[sp[i]]
    (n_sat,)),
    then x, P constrained in place to its DDs x[new] - x[ref] = integer by scalar pseudo-measurements of variance
    limits.var_cyc2, each in the Joseph form (scalar updates in turn). applied False: an innovation variance was
    not positive, x, P and fix.amb_fixed are left as they were (the newcomers stay float). Records:
    gnssatt.attitude.update_records.

    Specification: gnssatt.attitude.reference_update.fix_newcomers (the batch Joseph DD constraint of
    boxes.ambiguity_resolution.pseudo_update; Gelb 1974 eq. 4.2-21).
    """
    jc, sc, fc, jp, sp, fp = rows
    max_sigma_cyc, max_frac_cyc, var_cyc2 = limits
    amb_fixed, amb_key = fix
    amb_fixed_before = amb_fixed.copy()
    mc_n = jc.size
    nr = 0
    for i in range(jp.size):
        if jp[i] == j:
            nr += 1
    idx_j = np.empty(nr, np.int64)
    sig_j = np.empty(nr, np.int64)
    el_j = np.empty(nr)
    q = 0
    for i in range(jp.size):
        if jp[i] == j:
            idx_j[q] = cols[mc_n + i, 4]
            sig_j[q] = fp[i]
            el_j[q] = el_loc_rad[sp[i]]
            q += 1
    nw, rf, vals = round_newcomers_rows(x, P, fix, n_fixed_part, idx_j, sig_j, el_j, n_sig, j, limits)
    r = nw.size
    if r:
        c2 = np.empty((r, 2), np.int64)
        coef = np.empty((r, 2))
        for i in range(r):
            c2[i, 0], c2[i, 1] = nw[i], rf[i]
            coef[i, 0], coef[i, 1] = 1.0, -1.0
        if not sequential_update_sparse(x, P, c2, coef, np.full(r, var_cyc2), vals, 0.0):
            amb_fixed[:] = amb_fixed_before       # x, P are as they were: the newcomers stay float
            return nw, rf, vals, False
    return nw, rf, vals, True


@njit(cache=True, nogil=True)
def white_variances_cp(est_var_c, est_var_p, est_n, floor_c, floor_p, min_epochs, estimate):
    """(var_code_m2, var_phase_m2) (n_sig,): white_variances of code and phase (VarianceModel's first fields)."""
    return (white_variances(est_var_c, est_n, floor_c, min_epochs, estimate),
            white_variances(est_var_p, est_n, floor_p, min_epochs, estimate))


@njit(cache=True, nogil=True)
def update_epoch(x, P, rows: UsedRows, layout: StateLayout, obs: UpdateObs, noise: NoiseModel, mp_mult,
                 fix: FixState, amb_last_t_s, t_s, joseph_ratio):
    """(var_code_m2 (n_sig,), var_phase_m2 (n_sig,), measurement_update's UpdateOutputs as a plain tuple): the
    epoch's white variances of one SD per signal from the noise estimates (white_variances_cp), then
    measurement_update with them and mp_mult (x, P, amb_last_t_s in place). The box "measurement update" in one
    compiled call (each call from Python costs ~1.5 us of dispatch, ~1 % of the filter's time).

    Specification: gnssatt.attitude.reference_update.white_variances, then reference_update.measurement_update.
    """
    (est_var_code_m2, est_var_phase_m2, est_n, floor_code_m2, floor_phase_m2, min_epochs, estimate, gamma,
     cn0_growth, elevation_weighting, mp_model, mp_sigma_m) = noise
    var_code_m2, var_phase_m2 = white_variances_cp(est_var_code_m2, est_var_phase_m2, est_n, floor_code_m2,
                                                   floor_phase_m2, min_epochs, estimate)
    model: VarianceModel = (var_code_m2, var_phase_m2, gamma, cn0_growth, elevation_weighting, mp_model, mp_sigma_m,
                            mp_mult)
    return var_code_m2, var_phase_m2, measurement_update(x, P, rows, layout, obs, model, fix, amb_last_t_s, t_s,
                                                         joseph_ratio)


@njit(cache=True, nogil=True)
def store_outputs(x, P, k, status: EpochStatus, settings: OutputSettings, out: OutputBuffers):
    """(n_bl,) fixed_now = ever_fixed & (n_fixed_used >= fixed_min_sats), and row k of the output buffers written:
    b_ecef_m = the baselines (n_bl, 3) of x, P_b_m2 = their joint covariance, omega_ecef_rad_s = omega (dynamic
    mode; else left NaN), ok = baseline_ok & (n_used >= 3), fixed = fixed_now & ok, n_sats = n_used. Records:
    gnssatt.attitude.update_records.

    Specification: gnssatt.attitude.reference_update.epoch_outputs (seed 000 Fig. 2 "output").
    """
    baseline_ok, n_used, ever_fixed, n_fixed_used = status
    all_b_idx, dynamic, fixed_min_sats = settings
    b_ecef_m, P_b_m2, omega_ecef_rad_s, ok, fixed, n_sats = out
    nb = all_b_idx.size
    for a in range(nb):
        b_ecef_m[k, a // 3, a % 3] = x[all_b_idx[a]]
        for c in range(nb):
            P_b_m2[k, a, c] = P[all_b_idx[a], all_b_idx[c]]
    if dynamic:
        for a in range(3):
            omega_ecef_rad_s[k, a] = x[a]
    n_bl = baseline_ok.size
    fixed_now = np.empty(n_bl, np.bool_)
    for j in range(n_bl):
        ok_j = baseline_ok[j] and n_used[j] >= 3
        fixed_now[j] = ever_fixed[j] and n_fixed_used[j] >= fixed_min_sats
        ok[k, j] = ok_j
        fixed[k, j] = fixed_now[j] and ok_j
        n_sats[k, j] = n_used[j]
    return fixed_now


@njit(cache=True, nogil=True)
def quest_dcm(b_ref, b_body, w):
    """R_body_from_ref (3, 3) minimising sum_i w_i |b_body_i - R b_ref_i|^2 over directions (n, 3) of one epoch;
    NaN if fewer than two usable non-parallel directions (information matrix condition >= 1e12). Vectors with a
    NaN or weight <= 0 are ignored.

    Implements: gnssatt.gnss.rotations.quest for one epoch without its covariance (Davenport's q-method: the
    eigenvector of the largest eigenvalue of K, Keat 1977; Shuster & Oh 1981 eqs. 36-44), then quat_to_dcm.
    """
    n = b_ref.shape[0]
    B = np.zeros((3, 3))
    bu = np.zeros((n, 3))
    ru = np.zeros((n, 3))
    wo = np.zeros(n)
    for i in range(n):
        nb = np.sqrt(b_body[i, 0] ** 2 + b_body[i, 1] ** 2 + b_body[i, 2] ** 2)
        nr = np.sqrt(b_ref[i, 0] ** 2 + b_ref[i, 1] ** 2 + b_ref[i, 2] ** 2)
        ok = np.isfinite(w[i]) and w[i] > 0
        for a in range(3):
            bu[i, a] = b_body[i, a] / nb
            ru[i, a] = b_ref[i, a] / nr
            ok = ok and np.isfinite(bu[i, a]) and np.isfinite(ru[i, a])
        if not ok:
            continue
        wo[i] = w[i]
        for a in range(3):
            for c in range(3):
                B[a, c] += w[i] * bu[i, a] * ru[i, c]
    sigma = B[0, 0] + B[1, 1] + B[2, 2]
    K = np.empty((4, 4))
    K[0, 0] = sigma
    K[0, 1] = K[1, 0] = B[1, 2] - B[2, 1]
    K[0, 2] = K[2, 0] = B[2, 0] - B[0, 2]
    K[0, 3] = K[3, 0] = B[0, 1] - B[1, 0]
    for a in range(3):
        for c in range(3):
            K[1 + a, 1 + c] = B[a, c] + B[c, a] - (sigma if a == c else 0.0)
    _, vecs = np.linalg.eigh(K)
    q = vecs[:, 3].copy()
    q /= np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    if q[0] < 0.0:
        q = -q
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    R = np.empty((3, 3))
    R[0, 0] = qw * qw + qx * qx - qy * qy - qz * qz
    R[0, 1] = 2 * (qx * qy + qw * qz)
    R[0, 2] = 2 * (qx * qz - qw * qy)
    R[1, 0] = 2 * (qx * qy - qw * qz)
    R[1, 1] = qw * qw - qx * qx + qy * qy - qz * qz
    R[1, 2] = 2 * (qy * qz + qw * qx)
    R[2, 0] = 2 * (qx * qz + qw * qy)
    R[2, 1] = 2 * (qy * qz - qw * qx)
    R[2, 2] = qw * qw - qx * qx - qy * qy + qz * qz
    # information of the body-frame rotation error: sum w (I - bh bh^T), bh = R r; singular -> no attitude
    info = np.zeros((3, 3))
    for i in range(n):
        if wo[i] == 0.0:
            continue
        bh = np.dot(R, ru[i])
        for a in range(3):
            for c in range(3):
                info[a, c] += wo[i] * ((1.0 if a == c else 0.0) - bh[a] * bh[c])
    ev = np.abs(np.linalg.eigvalsh(info))
    if not (ev.max() < 1e12 * ev.min()):
        R[:, :] = np.nan
    return R


def warm_up() -> None:
    """Compile (or load from the cache) every kernel once on tiny inputs with the record and array layouts of
    run_filter: np.nonzero's index arrays are strided views (numba layout A), but contiguous (C) when they hold at
    most one row, so the code and the phase rows of UsedRows come in four layout combinations; the SD block's
    baseline_ok may be a strided view too."""
    use, use1 = np.zeros((1, 3, 2), np.bool_), np.zeros((1, 3, 2), np.bool_)
    use[0, :2, 0] = True
    use1[0, 1, 0] = True
    for use_c, use_p in ((use1, use1), (use1, use), (use, use1), (use, use)):
        _warm_up_update(UsedRows(*np.nonzero(use_c), *np.nonzero(use_p)))
    quest_dcm(np.eye(3)[:2].copy(), np.eye(3)[:2].copy(), np.ones(2))
    two, n2 = np.ones(2, np.bool_), np.zeros(2, np.int64)
    x, P = np.zeros(10), np.eye(10)
    settings = tuple(OutputSettings(all_b_idx=np.arange(6, dtype=np.int64), dynamic=True, fixed_min_sats=4))
    buffers = tuple(OutputBuffers(b_ecef_m=np.zeros((1, 2, 3)), P_b_m2=np.zeros((1, 6, 6)),
                                  omega_ecef_rad_s=np.zeros((1, 3)), ok=np.zeros((1, 2), np.bool_),
                                  fixed=np.zeros((1, 2), np.bool_), n_sats=np.zeros((1, 2), np.int64)))
    for baseline_ok in (two, np.ones((2, 2), np.bool_)[:, 0]):
        status = EpochStatus(baseline_ok=baseline_ok, n_used=n2, ever_fixed=two, n_fixed_used=n2)
        store_outputs(x, P, 0, tuple(status), settings, buffers)


def _warm_up_update(rows: UsedRows) -> None:
    """update_epoch (so measurement_update), phase_row_stats, round_newcomers_rows and fix_newcomers with the
    layouts of `rows`."""
    td = np.ones((1, 3, 2))
    el = np.ones((1, 3))
    x, P = np.zeros(10), np.eye(10)
    amb = np.full((1, 3, 2), -1, np.int64)
    amb[0, 0, 0], amb[0, 1, 0] = 8, 9
    layout = StateLayout(b_idx=np.arange(3, dtype=np.int64).reshape(1, 3), clk=np.array([3], np.int64),
                         pclk=np.array([[4, 5]], np.int64), bias=np.array([[-1, 6]], np.int64), amb_index=amb,
                         n_fixed_part=8)
    obs = UpdateObs(u=np.eye(3), clock_factor=np.ones(3), wavelength_m=np.ones((3, 2)), sdc_c_m=td, sdp_c_m=td, pcv_m=td,
                    cn0_dbhz=np.full((1, 3, 2), 45.0), el_e_rad=el, el_w_rad=el)
    noise = NoiseModel(est_var_code_m2=np.ones(2), est_var_phase_m2=np.ones(2), est_n=np.zeros(2), floor_code_m2=1.0,
                       floor_phase_m2=1.0, min_epochs=10, estimate=True, gamma=np.ones((2, 2)), cn0_growth=True,
                       elevation_weighting=False, mp_model=True, mp_sigma_m=np.ones(4))
    fix = FixState(amb_fixed=np.array([True, False]), amb_key=np.array([[0, 0, 0], [0, 1, 0]], np.int64))
    _, _, res = update_epoch(x, P, tuple(rows), tuple(layout), tuple(obs), tuple(noise), 1.0, tuple(fix), np.zeros(2),
                             0.0, 1e3)
    out = UpdateOutputs._make(res)
    phase_row_stats(rows.jp, rows.sp, out.cols, rows.jc.size, fix.amb_fixed, 8, out.post_m, 1, 3)
    limits = tuple(RoundingLimits(max_sigma_cyc=0.1, max_frac_cyc=0.2, var_cyc2=1e-6))
    fix_copy = (fix.amb_fixed.copy(), fix.amb_key)
    round_newcomers_rows(x, P, fix_copy, 8, np.array([8, 9], np.int64), np.zeros(2, np.int64), np.ones(2), 2, 0,
                         limits)
    fix_newcomers(x, P, fix_copy, 8, out.cols, tuple(rows), np.ones(3), 2, 0, limits)
