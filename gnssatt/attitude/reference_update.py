"""The attitude filter's measurement update in readable numpy (the "measurement update" box of seed 000 Fig. 2
and the bookkeeping right after it): the SD code and phase rows of seed 000 eq. 1, their variances (Table 1 white
noise x C/N0 factor^gamma [x elevation factor] + multipath), the batch Joseph update, post-fit residuals, the sums
of the adaptive multipath scale, per-baseline counts, rounding of newcomer ambiguities on fixed baselines, the
epoch's outputs and the attitude of the antenna-frame mask (QUEST).

This is the specification of the compiled kernels of gnssatt.attitude.update_kernels and
gnssatt.attitude.kernels.measurement_rows (the filter runs the kernels, which update sequentially row by row;
tests/attitude/test_update_kernels.py checks them against this module with tolerances). Plain numpy, no numba.

Implements: seed 000 eq. 1 (SD observation model), Table 1 (noise), the Joseph-form Kalman update (Gelb 1974
eq. 4.2-21; gnssatt.estimation.ekf_reference.joseph_update), bootstrapped rounding of DD ambiguities (Teunissen
1998), QUEST / Davenport's q-method (Shuster & Oh 1981; gnssatt.gnss.rotations.quest).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.attitude.ambiguity import round_newcomers
from gnssatt.attitude.reference_noise import cn0_variance_factor, multipath_variance_m2
from gnssatt.estimation.ekf_reference import joseph_update, sparse_rows_to_dense
from gnssatt.gnss import rotations

__all__ = ["UsedRows", "StateLayout", "UpdateObs", "VarianceModel", "FixState", "RoundingLimits", "PhaseRowStats",
           "UpdateResult", "measurement_rows", "measurement_variances", "white_variances", "phase_row_stats",
           "multipath_scale_sums", "measurement_update", "round_newcomers_rows", "fix_newcomers", "epoch_outputs",
           "mask_attitude_dcm"]


@dataclass
class UsedRows:
    """The observations in the update: code rows (jc, sc, fc) then phase rows (jp, sp, fp) as (baseline,
    satellite, signal) index arrays (np.nonzero of use_c, use_p)."""
    jc: np.ndarray
    sc: np.ndarray
    fc: np.ndarray
    jp: np.ndarray
    sp: np.ndarray
    fp: np.ndarray

    @classmethod
    def from_masks(cls, use_c: np.ndarray, use_p: np.ndarray) -> "UsedRows":
        return cls(*np.nonzero(use_c), *np.nonzero(use_p))

    @property
    def n_code(self) -> int:
        return int(self.jc.size)


@dataclass
class StateLayout:
    """State indices: b_idx (n_bl, 3) baselines, clk (n_bl,) code clocks, pclk (n_bl, n_sig) phase clocks, bias
    (n_bl, n_sig) code biases of signals 2.. (-1 for signal 1), amb_index (n_bl, n_sat, n_sig) ambiguities
    (-1 none); the ambiguities start at n_fixed_part."""
    b_idx: np.ndarray
    clk: np.ndarray
    pclk: np.ndarray
    bias: np.ndarray
    amb_index: np.ndarray
    n_fixed_part: int


@dataclass
class UpdateObs:
    """One epoch's inputs of the update: u (n_sat, 3) lines of sight, clock_factor (n_sat,), wavelength_m
    (n_sat, n_sig) per satellite (GLONASS FDMA: per channel), clock-corrected SDs sdc_c_m / sdp_c_m and the PCV correction pcv_m (n_bl, n_sat, n_sig), cn0_dbhz,
    el_e_rad (n_bl, n_sat) elevation for the elevation weighting, el_w_rad (n_bl, n_sat) antenna-frame
    elevation (multipath model)."""
    u: np.ndarray
    clock_factor: np.ndarray
    wavelength_m: np.ndarray
    sdc_c_m: np.ndarray
    sdp_c_m: np.ndarray
    pcv_m: np.ndarray
    cn0_dbhz: np.ndarray
    el_e_rad: np.ndarray
    el_w_rad: np.ndarray


@dataclass
class VarianceModel:
    """White variances of one SD per signal (var_code_m2, var_phase_m2 (n_sig,)), the C/N0 exponents gamma (2,
    n_sig), switches, the multipath sigmas mp_sigma_m = (code boresight, code horizon, phase boresight, phase
    horizon) and the adaptive multipath multiplier."""
    var_code_m2: np.ndarray
    var_phase_m2: np.ndarray
    gamma: np.ndarray
    cn0_growth: bool
    elevation_weighting: bool
    mp_model: bool
    mp_sigma_m: np.ndarray
    mp_mult: float


@dataclass
class FixState:
    """amb_fixed (n_amb,) which ambiguity states are fixed; amb_key (n_amb, 3) their (baseline, satellite,
    signal)."""
    amb_fixed: np.ndarray
    amb_key: np.ndarray


@dataclass(frozen=True)
class RoundingLimits:
    """Newcomer rounding: DD sigma below max_sigma_cyc and float within max_frac_cyc of the integer; the
    constraint's variance var_cyc2."""
    max_sigma_cyc: float
    max_frac_cyc: float
    var_cyc2: float = 1e-6


@dataclass
class PhaseRowStats:
    """Per baseline (n_bl,): satellites with a phase row, satellites with a fixed one, unfixed rows, fixed rows,
    mean square of the fixed rows' post-fit residuals (m^2, NaN if none)."""
    n_used: np.ndarray
    n_fixed_used: np.ndarray
    n_unfixed: np.ndarray
    n_fix_rows: np.ndarray
    ms_fix_m2: np.ndarray


@dataclass
class UpdateResult:
    """x, P after the update; the rows (cols, coef, z), variances var (m^2) and v_mp (multipath part before
    mp_mult), post-fit residuals post_m; the adaptive multipath sums over fixed phase rows (mp_num, mp_den,
    n_mp); PhaseRowStats; has_fix (n_bl,); the ambiguity rows (a, into amb_last_t) that were in the update."""
    x: np.ndarray
    P: np.ndarray
    cols: np.ndarray
    coef: np.ndarray
    z: np.ndarray
    var_m2: np.ndarray
    v_mp_m2: np.ndarray
    post_m: np.ndarray
    mp_num: float
    mp_den: float
    n_mp: int
    stats: PhaseRowStats
    has_fix: np.ndarray
    updated_ambiguities: np.ndarray


def measurement_rows(rows: UsedRows, layout: StateLayout,
                     obs: UpdateObs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cols (m, 5) int64, coef (m, 5), z (m,)): the sparse rows of the code then phase SDs. Each row: baseline
    -u (3 columns), the code / phase clock with the partial clock_factor, then for code the bias of signals 2..
    (coefficient 1; none for signal 1), for phase the ambiguity (coefficient = wavelength); z = the
    clock-corrected SD code, SD phase - PCV. Implements: seed 000 eq. 1."""
    jc, sc, fc, jp, sp, fp = rows.jc, rows.sc, rows.fc, rows.jp, rows.sp, rows.fp
    mc_n, m = jc.size, jc.size + jp.size
    n_sig = obs.sdc_c_m.shape[2]
    cols = np.full((m, 5), -1, dtype=np.int64)
    coef = np.zeros((m, 5))
    jb, sb = np.concatenate([jc, jp]), np.concatenate([sc, sp])
    cols[:, 0:3], coef[:, 0:3] = layout.b_idx[jb], -obs.u[sb]
    cols[:mc_n, 3], cols[mc_n:, 3], coef[:, 3] = layout.clk[jc], layout.pclk[jp, fp], obs.clock_factor[sb]
    if n_sig > 1:
        cols[:mc_n, 4], coef[:mc_n, 4] = layout.bias[jc, fc], 1.0
    cols[mc_n:, 4], coef[mc_n:, 4] = layout.amb_index[jp, sp, fp], obs.wavelength_m[sp, fp]
    z = np.concatenate([obs.sdc_c_m[jc, sc, fc], obs.sdp_c_m[jp, sp, fp] - obs.pcv_m[jp, sp, fp]])
    return cols, coef, z


def measurement_variances(rows: UsedRows, obs: UpdateObs,
                          model: VarianceModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(var, v_white, v_mp) (m,) in m^2 of the code then phase rows: v_white = white variance of the signal x
    C/N0 factor^gamma (cn0_growth) x clip(1 / sin^2 e, 1, 16) (elevation_weighting; e = el_e, NaN -> 0.5 rad,
    >= 0.05 rad); v_mp = multipath variance at the off-boresight angle 90 deg - el_w (mp_model, else 0);
    var = v_white + mp_mult v_mp. Implements: seed 000 Table 1 and the noise model of docs/attitude.md."""
    jc, sc, fc, jp, sp, fp = rows.jc, rows.sc, rows.fc, rows.jp, rows.sp, rows.fp
    v_white = np.concatenate([model.var_code_m2[fc], model.var_phase_m2[fp]])
    if model.cn0_growth:
        v_white = v_white * np.concatenate([cn0_variance_factor(obs.cn0_dbhz[jc, sc, fc]) ** model.gamma[0, fc],
                                            cn0_variance_factor(obs.cn0_dbhz[jp, sp, fp]) ** model.gamma[1, fp]])
    if model.elevation_weighting:
        e = np.concatenate([obs.el_e_rad[jc, sc], obs.el_e_rad[jp, sp]])
        e = np.maximum(np.where(np.isnan(e), 0.5, e), 0.05)
        v_white = v_white * np.clip(1.0 / np.sin(e) ** 2, 1.0, 16.0)
    v_mp = np.zeros(v_white.size)
    if model.mp_model:
        sig = model.mp_sigma_m
        v_mp = np.concatenate([multipath_variance_m2(np.pi / 2 - obs.el_w_rad[jc, sc], sig[0], sig[1]),
                               multipath_variance_m2(np.pi / 2 - obs.el_w_rad[jp, sp], sig[2], sig[3])])
    return v_white + v_mp * model.mp_mult, v_white, v_mp


def white_variances(est_var_m2: np.ndarray, est_n: np.ndarray, floor_var_m2: float, min_epochs: int,
                    estimate: bool) -> np.ndarray:
    """(n_sig,) white variance of one SD: the estimate (not below the configured floor) once min_epochs were
    seen, else the floor; the floor alone without estimation. Implements: seed 000 Table 1 as the floor."""
    if not estimate:
        return np.full(est_var_m2.size, floor_var_m2)
    return np.where(est_n >= min_epochs, np.maximum(est_var_m2, floor_var_m2), floor_var_m2)


def phase_row_stats(rows: UsedRows, cols: np.ndarray, fix: FixState, post_m: np.ndarray, n_fixed_part: int,
                    n_bl: int, n_sat: int) -> PhaseRowStats:
    """Per-baseline counts over the phase rows (rows n_code.. of cols / post; ambiguity in column 4): the
    satellite counts of the fix test, the unfixed rows (the ambiguity resolution skips a baseline without any),
    and the fix monitor's mean square post-fit residual of the fixed rows."""
    mc_n = rows.n_code
    fixed = fix.amb_fixed[cols[mc_n:, 4] - n_fixed_part]
    post_p = post_m[mc_n:]
    out = PhaseRowStats(*(np.zeros(n_bl, np.int64) for _ in range(4)), np.full(n_bl, np.nan))
    for j in range(n_bl):
        mine = rows.jp == j
        out.n_used[j] = np.unique(rows.sp[mine]).size
        out.n_fixed_used[j] = np.unique(rows.sp[mine & fixed]).size
        out.n_unfixed[j] = np.sum(mine & ~fixed)
        out.n_fix_rows[j] = np.sum(mine & fixed)
        if out.n_fix_rows[j]:
            out.ms_fix_m2[j] = np.mean(post_p[mine & fixed] ** 2)
    return out


def multipath_scale_sums(H: np.ndarray, P_post: np.ndarray, var_m2: np.ndarray, v_white_m2: np.ndarray,
                         v_mp_m2: np.ndarray, post_m: np.ndarray, sel: np.ndarray) -> tuple[float, float, int]:
    """(sum(post^2 / (1 - h) - v_white), sum(v_mp), n) over the rows sel, h = H P+ H^T / var clipped to
    [0, 0.95] (the leverage: E[post^2] = var (1 - h)); the adaptive multipath multiplier is num / den.
    Implements: the adaptive multipath scale of docs/attitude.md (residual-based covariance matching)."""
    rows = np.flatnonzero(sel)
    hph = np.einsum("ij,jk,ik->i", H[rows], P_post, H[rows])
    one_h = np.clip(1.0 - hph / var_m2[rows], 0.05, 1.0)
    return float(np.sum(post_m[rows] ** 2 / one_h - v_white_m2[rows])), float(np.sum(v_mp_m2[rows])), rows.size


def measurement_update(x: np.ndarray, P: np.ndarray, rows: UsedRows, layout: StateLayout, obs: UpdateObs,
                       model: VarianceModel, fix: FixState, n_bl: int, n_sat: int) -> UpdateResult:
    """One epoch's measurement update: rows and variances, the batch Joseph update (x, P not changed in place),
    post-fit residuals z - H x+, the adaptive multipath sums over the phase rows of fixed ambiguities, the
    per-baseline counts and has_fix (baselines with a fixed ambiguity state).
    Implements: seed 000 Fig. 2 "measurement update" (eq. 1, Table 1; Joseph form, Gelb 1974 eq. 4.2-21)."""
    cols, coef, z = measurement_rows(rows, layout, obs)
    var, v_white, v_mp = measurement_variances(rows, obs, model)
    H = sparse_rows_to_dense(cols, coef, x.size)
    x1, P1, _ = joseph_update(x, P, H, var, z - H @ x)
    post = z - H @ x1
    amb_rows = cols[rows.n_code:, 4] - layout.n_fixed_part
    sel = np.zeros(z.size, bool)
    sel[rows.n_code:] = fix.amb_fixed[amb_rows]
    mp_num, mp_den, n_mp = multipath_scale_sums(H, P1, var, v_white, v_mp, post, sel)
    stats = phase_row_stats(rows, cols, fix, post, layout.n_fixed_part, n_bl, n_sat)
    has_fix = np.zeros(n_bl, bool)
    has_fix[fix.amb_key[fix.amb_fixed, 0]] = True
    return UpdateResult(x1, P1, cols, coef, z, var, v_mp, post, mp_num, mp_den, n_mp, stats, has_fix, amb_rows)


def _signal_reference(fixed_now, fix, n_fixed_part, cand, el_cand, j, f):
    """(reference state, candidates) of signal f on baseline j: the first fixed ambiguity state of (j, f), else
    the candidate at the highest elevation (NaN counts highest, as np.argmax), removed from the candidates."""
    grp = np.flatnonzero((fix.amb_key[:, 0] == j) & (fix.amb_key[:, 2] == f) & fixed_now)
    if grp.size:
        return n_fixed_part + grp[0], cand
    ref = cand[int(np.argmax(el_cand))]
    return ref, cand[cand != ref]


def round_newcomers_rows(x: np.ndarray, P: np.ndarray, fix: FixState, n_fixed_part: int, idx_j: np.ndarray,
                         sig_j: np.ndarray, el_j: np.ndarray, n_sig: int, j: int, limits: RoundingLimits):
    """(new, ref, integers, amb_fixed): the DD ambiguities new - ref of baseline j fixed by rounding, per signal
    in turn, and a copy of fix.amb_fixed with them and their references set. idx_j, sig_j, el_j: state index,
    signal, local elevation of baseline j's phase rows; candidates are its unfixed ones.
    Implements: bootstrapped rounding of DDs on a fixed baseline (Teunissen 1998; ambiguity.round_newcomers)."""
    amb_fixed = fix.amb_fixed.copy()
    fixed_j = fix.amb_fixed[idx_j - n_fixed_part]
    new, ref_out, val = [], [], []
    for f in range(n_sig):
        sel = (sig_j == f) & ~fixed_j
        if not sel.any():
            continue
        ref, cand = _signal_reference(amb_fixed, fix, n_fixed_part, idx_j[sel], el_j[sel], j, f)
        if cand.size == 0:
            continue
        _, v, ok = round_newcomers(x, P, cand, ref, limits.max_sigma_cyc, limits.max_frac_cyc)
        if ok.any():
            new += cand[ok].tolist()
            ref_out += [ref] * int(ok.sum())
            val += v.tolist()
            amb_fixed[cand[ok] - n_fixed_part] = True
            amb_fixed[ref - n_fixed_part] = True
    return np.array(new, np.int64), np.array(ref_out, np.int64), np.array(val, np.float64), amb_fixed


def fix_newcomers(x: np.ndarray, P: np.ndarray, fix: FixState, n_fixed_part: int, idx_j: np.ndarray,
                  sig_j: np.ndarray, el_j: np.ndarray, n_sig: int, j: int, limits: RoundingLimits):
    """(x, P, new, ref, integers, amb_fixed): round_newcomers_rows, then x, P constrained to x[new] - x[ref] =
    integer by a batch Joseph update with pseudo-measurements of variance limits.var_cyc2 (x, P unchanged if
    nothing was rounded). Implements: filter._pseudo_update's DD constraint (Joseph form, Gelb 1974 eq. 4.2-21)."""
    new, ref, val, amb_fixed = round_newcomers_rows(x, P, fix, n_fixed_part, idx_j, sig_j, el_j, n_sig, j, limits)
    if not new.size:
        return x.copy(), P.copy(), new, ref, val, amb_fixed
    D = np.zeros((new.size, x.size))
    D[np.arange(new.size), new] = 1.0
    D[np.arange(new.size), ref] -= 1.0
    x1, P1, _ = joseph_update(x, P, D, np.full(new.size, limits.var_cyc2), val - D @ x)
    return x1, P1, new, ref, val, amb_fixed


def epoch_outputs(x: np.ndarray, P: np.ndarray, all_b_idx: np.ndarray, dynamic: bool, baseline_ok: np.ndarray,
                  n_used: np.ndarray, ever_fixed: np.ndarray, n_fixed_used: np.ndarray,
                  fixed_min_sats: int) -> dict:
    """One output row: baselines (n_bl, 3), their joint covariance, omega (dynamic mode, else NaN), ok = data on
    the baseline and >= 3 satellites, fixed = ok and fixed now (ever fixed and >= fixed_min_sats fixed
    satellites), n_sats. Implements: seed 000 Fig. 2 "output"."""
    fixed_now = ever_fixed & (n_fixed_used >= fixed_min_sats)
    ok = baseline_ok & (n_used >= 3)
    return {"b_m": x[all_b_idx].reshape(-1, 3), "P_b_m2": P[np.ix_(all_b_idx, all_b_idx)],
            "omega_rad_s": x[:3] if dynamic else np.full(3, np.nan), "ok": ok, "fixed": fixed_now & ok,
            "n_sats": n_used, "fixed_now": fixed_now}


def mask_attitude_dcm(b_ref: np.ndarray, b_body: np.ndarray, w: np.ndarray) -> np.ndarray:
    """R_body_from_ref (3, 3) minimising sum w |b_body - R b_ref|^2 over directions (n, 3) of one epoch (NaN if
    the directions do not determine it). Implements: QUEST / Davenport's q-method (Shuster & Oh 1981 eqs.
    36-44) as gnssatt.gnss.rotations.quest, then quat_to_dcm."""
    q, _ = rotations.quest(b_body[None], b_ref[None], w[None])
    return rotations.quat_to_dcm(q[0])
