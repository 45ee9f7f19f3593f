"""The attitude EKF of seed 000 sec. 2 over single-differenced carrier phase and code, with quality control and
integer ambiguity resolution.

State (fixed layout with index maps; ambiguities appended and removed as satellites come and go):
    [omega (3, dynamic mode only)] + per baseline j: [b_j ECEF (3), c*dt_j (1), code bias of signals 2.. (1 each, dual
    frequency only)] + SD ambiguities (cycles), one per (baseline, satellite, signal) in use.
Measurement model of a single difference (second antenna minus first) of satellite s, signal f, after removing
an epoch clock estimate c*dt0 from code:
    SD_code  = -u_s . b_j + (1 - rho_dot_s / c) (c dt_j) [+ B_j for signal 2] + e
    SD_phase = -u_s . b_j + (1 - rho_dot_s / c) (c dt_j) + lambda_f A_jsf + e
The factor (1 - rho_dot/c) makes the model exact for receivers whose clocks differ by up to a millisecond: the
second antenna measured at t - dt_j relative to the first, and the range moved by rho_dot dt_j meanwhile (so
free-running receiver clocks need no resampling of observations). The model is linear in the state.
Dynamics: b' = omega x b, omega random walk (dynamic); b random walk, no omega (kinematic); c*dt white noise.

Implements: seed 000 sec. 2 eq. 1-2, Table 1 (noise), Table 2 (editing: local / antenna elevation, C/N0,
triple differences of code and phase, baseline-length acceptance), fixed-step RK4 propagation, MLAMBDA on DD of
float SD ambiguities with a zero-variance pseudo-measurement for accepted fixes, sec. 3.2 compromise (all
satellites until fixed, then only those above the antenna horizon).
Neglects: differential troposphere/ionosphere (baselines of metres); correlation of the baselines through the
common master antenna's noise (each SD is treated as independent, as in the paper).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from gnssatt.attitude.adaptive import ManoeuvreDetector
from gnssatt.attitude.ambiguity import first_fix_groups, resolve_first_fix, resolve_joint_constrained
from gnssatt.attitude.pcv_correction import epoch_correction_m, pcv_tables_for
from gnssatt.attitude.qc_kernels import (add_states, drop_states, epoch_geometry, growth_weights,
                                        propagate_dynamic, propagate_kinematic, qc_epoch, record_epoch,
                                        reset_white_clocks, td_checks)
from gnssatt.attitude.fastops import clip as _clip, nz as _nz
from gnssatt.attitude.kernels import cn0_growth_samples
from gnssatt.attitude.sd_block import BLOCK_EPOCHS, sd_block
from gnssatt.attitude.settings import AttitudeSettings, cn0_mask_of
from gnssatt.attitude.update_kernels import (fix_newcomers, measurement_update, phase_row_stats, store_outputs,
                                            white_variances_cp)
from gnssatt.attitude.validation import angle_test_against_fixed, fixed_baseline_vector
from gnssatt.estimation.ekf import joseph_update_sparse
from gnssatt.gnss.constants import C_M_S

__all__ = ["FilterResult", "run_filter", "REASONS"]

DEG = np.pi / 180.0
#: reason codes of residuals.csv (0 = used)
REASONS = {0: "used", 1: "elevation_local", 2: "elevation_antenna", 3: "cn0", 4: "td_code", 5: "td_phase",
           6: "half_cycle", 7: "missing_partner", 8: "no_geometry", 9: "innovation", 10: "pcv_empty"}
TD_MAX_DT_S = 3.0   # triple differences need consecutive epochs; beyond this the arc restarts (see module doc)
FIX_CHECK_SIGMAS = 4.0   # post-fit RMS of fixed phases above this many noise sigmas ...
FIX_CHECK_MIN_M = 0.015  # ... and above 15 mm (multipath-sized) ...
FIX_CHECK_EPOCHS = 3     # ... for this many consecutive epochs: the fix is withdrawn
MP_SCALE_MIN, MP_SCALE_MAX = 0.05, 20.0   # range of the adaptive multipath-variance scale
OMEGA_RESET_TURN_DEG = 0.5   # a first fix turning its baseline by more than this resets the angular velocity
ANGLE_FAIL_RESET = 10    # first-fix candidates in a row failing the angle test against the fixed partners: the
                         # partners' fix is withdrawn
NOISE_EPOCHS = 300.0  # memory of the noise estimator (epochs)
NOISE_MIN_EPOCHS = 10  # epochs of triple differences before the estimate replaces the configured sigma
CLOCK_JUMP_M = 0.5e-3 * C_M_S * 0.5   # a change of the epoch clock estimate above 75 km (0.25 ms) is a jump
JOSEPH_RATIO = 1e3   # measurement rows with H P H^T above this many R are applied in the Joseph form (the others
                     # in the short form P - P h h P / s, gnssatt.estimation.ekf_kernels.sequential_update_sparse)
PSEUDO_VAR_CYC2 = 1e-6   # variance of the integer pseudo-measurements (keeps S positive definite in float64)
PCV_ATTITUDE_AGE_S = 10.0   # PCV maps are looked up with an attitude at most this old (else not applied)


@dataclass
class FilterResult:
    """Per epoch (n_ep) and baseline (n_bl) outputs of the filter; see run_filter."""

    ok: np.ndarray              # (n_ep, n_bl) bool: a baseline solution exists at this epoch
    b_ecef_m: np.ndarray        # (n_ep, n_bl, 3)
    P_b_m2: np.ndarray          # (n_ep, 3 n_bl, 3 n_bl) joint covariance of the baselines
    fixed: np.ndarray           # (n_ep, n_bl) bool
    n_sats: np.ndarray          # (n_ep, n_bl) int: satellites with a phase used in the update
    ratio: np.ndarray           # (n_ep, n_bl) ratio of the AR attempt at this epoch (nan if none)
    omega_ecef_rad_s: np.ndarray  # (n_ep, 3) (nan in kinematic mode)
    residuals: dict             # column arrays for residuals.csv
    events: list = field(default_factory=list)
    first_fix_epoch: np.ndarray = None    # (n_bl,) int epoch index of the first accepted fix, -1 never
    first_data_epoch: np.ndarray = None   # (n_bl,) int
    # every integer constraint the filter applied: column arrays epoch, bl, sig, sat, ref_sat (indices into
    # pobs.sats / pobs.signals), dd_cyc (the integer SD(sat) - SD(ref_sat)), last_epoch (the last epoch both arcs
    # were in the filter with this constraint); for scoring against a simulator's truth/arcs.csv
    fix_log: dict = None
    # the noise model as estimated at the end: white sigma per signal (at 45 dB-Hz), C/N0 growth exponents, the
    # adaptive multipath scale (summary.json "noise_model")
    noise: dict = None
    # dynamic mode with settings.smoothing.enabled: per epoch the (omega, baselines) sub-state after propagation (prior) and
    # at the output (posterior), the transition matrix from the previous epoch and the segment starts (resets),
    # for the fixed-interval smoother (gnssatt.attitude.smoother)
    smoother_data: dict = None


class _State:
    """x, P and the index maps."""

    def __init__(self, n_bl: int, n_sat: int, n_sig: int, dynamic: bool, phase_clock: bool):
        self.n_bl, self.n_sat, self.n_sig, self.dynamic = n_bl, n_sat, n_sig, dynamic
        self.off_w = 0
        n_pc = n_sig if phase_clock else 0
        n_bias = max(n_sig - 1, 0)               # inter-signal (frequency, system) code bias vs signal 1
        blk = 4 + n_bias + n_pc
        base0 = 3 if dynamic else 0
        # baseline j: b at b_off[j]..+2, clock +3, [code bias of signals 2.. +4..], [phase clock per signal]
        self.b_off = base0 + blk * np.arange(n_bl)
        self.clk = self.b_off + 3
        # (n_bl, n_sig) state index of the code bias of each signal (-1: signal 1, the clock's reference)
        self.bias = np.full((n_bl, n_sig), -1, dtype=np.int64)
        self.bias[:, 1:] = self.b_off[:, None] + 4 + np.arange(n_bias)[None, :]
        first_pc = 4 + n_bias
        # (n_bl, n_sig) state index of the phase clock of each signal; the code clock when not separate
        self.pclk = (self.b_off[:, None] + first_pc + np.arange(n_sig)[None, :]) if phase_clock \
            else np.repeat(self.clk[:, None], n_sig, axis=1)
        self.white = np.unique(np.concatenate([self.clk, self.pclk.ravel()]))
        self.n_fixed_part = base0 + blk * n_bl
        self.x = np.zeros(self.n_fixed_part)
        self.P = np.zeros((self.n_fixed_part, self.n_fixed_part))
        self.amb_index = np.full((n_bl, n_sat, n_sig), -1, dtype=np.int64)
        self.amb_key = np.zeros((0, 3), dtype=np.int64)        # per ambiguity state: (bl, sat, sig)
        self.amb_fixed = np.zeros(0, bool)
        self.amb_last_t = np.zeros(0)
        self.amb_arc = np.zeros(0, np.int64)                    # arc id (index into arcs) of each ambiguity state
        # arcs: one per ambiguity state ever created: [bl, sat, sig, first epoch, last epoch (-1 open)]
        self.arcs: list[list[int]] = []
        self.epoch = 0

    @property
    def n(self) -> int:
        return self.x.size

    def add_ambiguities(self, keys: np.ndarray, values: np.ndarray, sigma0: float, t: float) -> None:
        """Append float ambiguity states (keys (k, 3) = bl, sat, sig) with variance sigma0^2; new arcs open."""
        a0 = len(self.arcs)
        self.arcs.extend([int(b), int(sa), int(f), self.epoch, -1] for b, sa, f in keys.tolist())
        (self.x, self.P, self.amb_key, self.amb_fixed, self.amb_last_t, self.amb_arc) = add_states(
            self.x, self.P, np.asarray(values, np.float64), float(sigma0 ** 2), np.asarray(keys, np.int64),
            float(t), a0, self.amb_key, self.amb_fixed, self.amb_last_t, self.amb_arc, self.amb_index)

    def remove_ambiguities(self, state_idx: np.ndarray, last_epoch: int) -> None:
        """Drop ambiguity states; their arcs end at last_epoch (the last epoch their phase was used)."""
        keep = np.ones(self.n, bool)
        keep[state_idx] = False
        for a in self.amb_arc[~keep[self.n_fixed_part:]].tolist():
            self.arcs[a][4] = last_epoch
        (self.x, self.P, self.amb_key, self.amb_fixed, self.amb_last_t, self.amb_arc) = drop_states(
            self.x, self.P, keep, self.n_fixed_part, self.amb_key, self.amb_fixed, self.amb_last_t, self.amb_arc,
            self.amb_index)


def _cn0_factor(cn0_dbhz: np.ndarray) -> np.ndarray:
    """Variance factor 10^((45 - C/N0)/10), clipped to [0.25, 16] (noise doubles per -6 dB; 45 dB-Hz = Table 1)."""
    return _clip(10.0 ** ((45.0 - _nz(cn0_dbhz, 45.0)) / 10.0), 0.25, 16.0)


def _mp_var(off_boresight_rad: np.ndarray, sigma_boresight_m: float, sigma_horizon_m: float) -> np.ndarray:
    """Variance (m^2) of the time-correlated error of one SD: sigma grows from the boresight value with the square
    of the off-boresight angle, reaching sigma_horizon_m at the antenna horizon (90 deg); capped at 120 deg.
    (The filter uses the compiled update_kernels.mp_var; this is its numpy reference in the tests.)"""
    x = _clip(_nz(off_boresight_rad, np.pi / 2) / (np.pi / 2), 0.0, 4.0 / 3.0)
    return (sigma_boresight_m + (sigma_horizon_m - sigma_boresight_m) * x * x) ** 2


def run_filter(pobs, geom, baselines: list[tuple[int, int]], body_baselines_m: np.ndarray,
               boresight_body: np.ndarray, settings: AttitudeSettings, R_body_from_ecef_0: np.ndarray,
               attitude_fn=None, progress=None, q_omega: np.ndarray = None) -> FilterResult:
    """FilterResult of the EKF over all epochs of `pobs` (PlatformObs) with `geom` (EpochGeometry).

    Args:
        baselines: (first, second) antenna indices into pobs.antennas.
        body_baselines_m: (n_bl, 3) known body-frame baselines (a priori or calibrated).
        boresight_body: (n_ant, 3) antenna boresights, for the antenna-frame elevation mask.
        R_body_from_ecef_0: (3, 3) initial attitude (Earth pointing or given) for the initial baselines.
        attitude_fn: callable (b_ecef (n_bl, 3), fixed (n_bl,)) -> R_body_from_ecef (3, 3) or None; used for
            the antenna-frame mask once every baseline is fixed. None: no antenna-frame mask.
        progress: callable(fraction) called every ~200 epochs.
        q_omega: dynamic mode, (n_ep, 3, 3) omega random-walk rate (rad^2/s^3) of the propagation into each epoch,
            in place of Table 1's (and of the adapter's); None: Table 1's (smoother_adaptive_noise's second pass).
    """
    s = settings
    n_ant, n_ep, n_sat, n_sig = pobs.code_m.shape
    n_bl = len(baselines)
    dynamic = s.mode == "dynamic"
    st = _State(n_bl, n_sat, n_sig, dynamic, s.noise.separate_phase_clock)
    lam = np.ascontiguousarray(pobs.wavelength_m, dtype=np.float64)
    t_s = (pobs.time - pobs.time[0]) if n_ep else np.zeros(0)
    t_s = np.asarray(t_s, dtype=np.float64)
    lengths = np.linalg.norm(body_baselines_m, axis=1)
    sig_cn0 = np.array([cn0_mask_of(s, sig) for sig in pobs.signals])
    ia = np.array([b[0] for b in baselines])
    ib = np.array([b[1] for b in baselines])
    # --- initial state ---
    b0 = body_baselines_m @ R_body_from_ecef_0        # b_ecef = R^T b_body (rows)
    for j in range(n_bl):
        o = st.b_off[j]
        st.x[o:o + 3] = b0[j]
        sig0 = max(s.table1.sigma0_baseline_m, 1.2 * lengths[j])
        st.P[np.arange(o, o + 3), np.arange(o, o + 3)] = sig0 ** 2
        st.P[st.bias[j, 1:], st.bias[j, 1:]] = s.table1.sigma0_code_bias_m ** 2
    if dynamic:
        st.P[0:3, 0:3] = np.eye(3) * (s.table1.sigma0_omega_deg_s * DEG) ** 2
    q_w = (s.table1.sigma_omega_deg_s * DEG) ** 2 / s.table1.tau_omega_s          # rad^2/s^2 per s
    adapter = ManoeuvreDetector(q_w, (s.adaptive.sigma_omega_raised_deg_s * DEG) ** 2 / s.table1.tau_omega_s, n_bl,
                                s.adaptive.threshold, s.adaptive.mix_at,
                                s.adaptive.sigma_acc_deg_s2 * DEG, s.adaptive.hold_epochs,
                                s.rk4_step_s, not (s.smoothing.enabled or s.smoothing.adaptive_noise)) \
        if dynamic and s.adaptive.enabled else None
    q_b = s.table1.sigma_baseline_kinematic_m ** 2 / s.table1.tau_baseline_s       # m^2 per s
    var_clk = (s.table1.sigma_clock_s * C_M_S) ** 2
    cn0_growth = s.noise.weighting == "cn0" or s.noise.noise_cn0_growth
    mp_model = max(s.noise.sigma_multipath_phase_m) > 0 or max(s.noise.sigma_multipath_code_m) > 0
    mp_infl = s.noise.multipath_correlation_factor if dynamic else 1.0
    mp_sig = np.array([*s.noise.sigma_multipath_code_m, *s.noise.sigma_multipath_phase_m], dtype=np.float64)
    elev_w = s.noise.weighting == "elevation"
    var_c_floor, var_p_floor = s.table1.sigma_code_m ** 2, s.table1.sigma_phase_m ** 2
    # C/N0 growth exponent per (code, phase) and signal, estimated from the triple differences (starts at 1)
    gamma = np.ones((2, n_sig)) if cn0_growth else np.zeros((2, n_sig))
    gam_n = np.zeros((2, n_sig))
    mom = np.zeros((2, n_sig, 4))
    mp_scale, mp_n_ep = 1.0, 0          # adaptive scale of the multipath variance (1 = the configured sigmas)
    # --- outputs ---
    out_ok = np.zeros((n_ep, n_bl), bool)
    out_b = np.full((n_ep, n_bl, 3), np.nan)
    out_P = np.full((n_ep, 3 * n_bl, 3 * n_bl), np.nan)
    out_fixed = np.zeros((n_ep, n_bl), bool)
    out_n = np.zeros((n_ep, n_bl), np.int64)
    out_ratio = np.full((n_ep, n_bl), np.nan)
    out_w = np.full((n_ep, 3), np.nan)
    n_sub = 3 + 3 * n_bl
    record = dynamic and (s.smoothing.enabled or s.smoothing.adaptive_noise)
    if record:
        sm_xp, sm_xf = np.full((n_ep, n_sub), np.nan), np.full((n_ep, n_sub), np.nan)
        sm_Pp, sm_Pf = np.full((n_ep, n_sub, n_sub), np.nan), np.full((n_ep, n_sub, n_sub), np.nan)
        sm_Phi = np.full((n_ep, n_sub, n_sub), np.nan)
        sm_start = np.ones(n_ep, bool)
        sm_corr = np.zeros(n_ep)          # information-weighted share of time-correlated variance in the phases
        sm_dt = np.zeros(n_ep)            # propagation interval into the epoch (s)
    # residual records, rows appended per epoch by record_epoch: ints epoch, bl, sat, sig, kind, reason and floats
    # el_ant_deg, az_ant_deg, cn0_dbhz, residual_m (capacity grown per SdBlock)
    res_i, res_f, res_n = np.zeros((6, 0), np.int64), np.zeros((4, 0)), 0
    events: list[dict] = []
    first_fix = np.full(n_bl, -1)
    first_data = np.full(n_bl, -1)
    b_idx = st.b_off[:, None] + np.arange(3)[None, :]                 # (n_bl, 3)
    all_b_idx = b_idx.ravel()
    prev_t = None
    prev_sdc = np.full((n_bl, n_sat, n_sig), np.nan)       # clock-corrected SD of the previous epoch
    prev_sdp = np.full((n_bl, n_sat, n_sig), np.nan)
    # per baseline: last estimated epoch clock c dt0 (m), its time and drift (m/s) (qc_epoch updates them)
    clk_state = np.stack([np.full(n_bl, np.nan), np.zeros(n_bl), np.zeros(n_bl)])
    prev_b = None
    prev_ub = None
    R_mask = None                                           # attitude for the antenna-frame mask
    R_mask_t = -np.inf
    # differential PCV maps per (baseline, signal), applied to fixed baselines (gnssatt.attitude.pcv_correction)
    pcv_tables = pcv_tables_for(s.calibration.pcv_maps, list(pobs.antennas), baselines, list(pobs.signals)) \
        if s.calibration.pcv_maps else {}
    if pcv_tables:
        from gnssatt.gnss.geometry import R_antenna_from_body
        R_ant_first = R_antenna_from_body(boresight_body[ia])             # (n_bl, 3, 3)
    ever_fixed = np.zeros(n_bl, bool)
    bad_fix = np.zeros(n_bl, np.int64)
    # per-signal white-noise estimates (variance of one SD) from the triple differences: robust, exponentially
    # weighted over NOISE_EPOCHS epochs; used once NOISE_MIN_SAMPLES TDs have been seen
    est_var_c = np.full(n_sig, s.table1.sigma_code_m ** 2)
    est_var_p = np.full(n_sig, s.table1.sigma_phase_m ** 2)
    est_n = np.zeros(n_sig)

    fix_rows: list[tuple[int, int, int, float]] = []        # (epoch, arc, ref arc, integer)

    def log_fix(D, a_fix):
        for row, v in zip(D, a_fix):
            pos, neg = np.flatnonzero(row > 0.5), np.flatnonzero(row < -0.5)
            if pos.size == 1 and neg.size == 1:
                fix_rows.append((k, int(st.amb_arc[pos[0] - st.n_fixed_part]),
                                 int(st.amb_arc[neg[0] - st.n_fixed_part]), float(v)))

    angle_fail = np.zeros(n_bl, np.int64)
    pending_reset: dict = {}

    def reset_baseline(j, why):
        """Withdraw every ambiguity of baseline j (restart as float) and its baseline covariance: it learnt from
        the suspect integers too, and would otherwise re-fix the same ones."""
        drop = np.flatnonzero(st.amb_key[:, 0] == j) + st.n_fixed_part
        st.remove_ambiguities(drop, k)
        bi = b_idx[j]
        st.P[bi, :] = 0.0
        st.P[:, bi] = 0.0
        st.P[bi, bi] = max(s.table1.sigma0_baseline_m, 1.2 * lengths[j]) ** 2
        bad_fix[j] = 0
        if adapter is not None:
            adapter.reset()
        ev(k, "fix_reset", j, detail=f"{why}: ambiguities restart")
        if record:
            sm_start[k] = True

    def ev(k, kind, j=None, sat=None, sig=None, detail=""):
        events.append({"epoch": k, "event": kind, "baseline": j, "sat": sat, "signal": sig, "detail": detail})

    blk = None                                              # SdBlock of the current epochs
    # per-epoch work arrays of the compiled QC (gnssatt.attitude.qc_kernels), overwritten every epoch
    shp = (n_bl, n_sat, n_sig)
    wb = np.zeros((5,) + shp, bool)            # use_c, use_p, slip, td_c_ok, td_p_ok
    wf = np.zeros((4,) + shp)                  # sdc_c, sdp_c, td_c, td_p
    w_reason = np.zeros(shp, np.int64)
    w_el = np.zeros((3, n_bl, n_sat))          # el_w, el_ant, az_ant
    w_clk = np.zeros((2, n_bl))                # epoch clock estimate, its prediction
    w_jump = np.zeros(n_bl, bool)
    w_mcp = np.zeros((2, n_bl, n_sig))         # medians of the code / phase triple differences
    w_asn = np.zeros((2, n_sat, n_bl))
    w_glw = np.zeros((2,) + shp)
    w_ev = np.zeros((2,) + shp, bool)          # TD slips without LLI, LLI slips to report
    w_bk = np.zeros((2,) + shp, bool)          # states to drop, phases needing a state
    w_lookup = np.zeros((2,) + shp)
    # the per-epoch names are views of these arrays, made once (unpacked again every epoch: cheap, and a name
    # rebound to another array further down the loop does not leak into the next epoch)
    views = (*w_el, w_reason, *wb, *wf, *w_mcp)
    no_pcv = np.zeros(shp, bool)
    pcv_zero = np.zeros(shp)
    prev_ub = np.zeros((n_bl, n_sat))
    Qw_iso = np.eye(3) * q_w
    if q_omega is not None:
        q_omega = np.ascontiguousarray(q_omega, dtype=np.float64)       # one compiled signature
    bs_a_T = np.asfortranarray(boresight_body[ia].T)        # (3, n_bl) boresights as columns (the layout of the
    bs_b_T = np.asfortranarray(boresight_body[ib].T)        # former `@ boresight_body[ia].T`: same BLAS call)
    z_f, z_i = np.zeros(0), np.zeros(2 * n_sig + 1, np.int64)
    w_idx3 = np.arange(3)
    ix_b = np.ix_(all_b_idx, all_b_idx)
    sub_w_b = np.concatenate([w_idx3, all_b_idx])            # omega and baselines (the smoother's sub-state)
    ix_sub = np.ix_(sub_w_b, sub_w_b)
    for k in range(n_ep):
        st.epoch = k
        if progress is not None and k % 100 == 0:
            progress(k / max(n_ep, 1))
        t = t_s[k]
        # ---------------- propagation ----------------
        if prev_t is not None:
            dt = t - prev_t
            if dynamic:
                # b by RK4 rotation; P <- Phi P Phi^T + Q: the omega random walk's discrete noise and its effect on b
                # over dt; then the white-noise clocks are reset (gnssatt.attitude.qc_kernels)
                Qw = q_omega[k] if q_omega is not None else (adapter.q_rate(dt) if adapter is not None
                                                              else Qw_iso)       # (3, 3) rad^2/s^3
                Pbb, Pbw = propagate_dynamic(st.x, st.P, w_idx3, b_idx, Qw, float(dt), s.rk4_step_s, st.white,
                                             var_clk)
                if record:
                    sm_Phi[k] = np.eye(n_sub)
                    for j in range(n_bl):
                        sm_Phi[k, 3 + 3 * j:6 + 3 * j, 3 + 3 * j:6 + 3 * j] = Pbb
                        sm_Phi[k, 3 + 3 * j:6 + 3 * j, 0:3] = Pbw[j]
                    sm_xp[k], sm_Pp[k], sm_start[k], sm_dt[k] = st.x[sub_w_b], st.P[ix_sub], False, dt
            else:
                propagate_kinematic(st.x, st.P, all_b_idx, q_b * dt, st.white, var_clk)
        else:
            reset_white_clocks(st.x, st.P, st.white, var_clk)        # white-noise clocks: reset every epoch

        # ---------------- single differences and QC ----------------
        # (the editing is compiled: gnssatt.attitude.qc_kernels; Python loops only over events that happened)
        if blk is None or k - blk.k0 >= blk.pa.shape[0]:
            blk = sd_block(pobs, geom, ia, ib, k, min(k + BLOCK_EPOCHS, n_ep), s.table2.elevation_mask_local_deg * DEG,
                           sig_cn0)
            blk_lw = np.log(_cn0_factor(blk.cn0))               # ln of the full C/N0 factor
            rows = res_n + int(blk.avail_c.sum() + blk.avail_p.sum())           # residual rows of the block
            if rows > res_i.shape[1]:
                # room for this block and, at its rate, the remaining epochs (+10 %): rarely more than one copy
                cap = max(rows, int(1.1 * rows * n_ep / (k + blk.pa.shape[0])) + 64)
                res_i1, res_f1 = np.empty((6, cap), np.int64), np.empty((4, cap))
                res_i1[:, :res_n], res_f1[:, :res_n] = res_i[:, :res_n], res_f[:, :res_n]
                res_i, res_f = res_i1, res_f1
        i = k - blk.k0
        pa, u, cfac = blk.pa[i], blk.u[i], blk.cfac[i]                      # (n_bl,) (n_sat, 3) (n_sat,)
        sdc, sdp, cn0, lli = blk.sdc[i], blk.sdp[i], blk.cn0[i], blk.lli[i]  # (n_bl, n_sat, n_sig)
        avail_c, avail_p = blk.avail_c[i], blk.avail_p[i]
        el_loc = geom.elevation_local_rad[k]
        # antenna-frame elevation for the noise model: by the current attitude once known, else the initial one;
        # el_ant, az_ant (the antenna-frame mask, sec. 3.2 compromise) only once an attitude exists, else NaN
        # (n_sat, 3) body-frame lines of sight, the clipped boresight products and the predicted geometry b.u
        R_los = R_mask if R_mask is not None else R_body_from_ecef_0
        los_b, ub = epoch_geometry(u, R_los if R_los.flags.c_contiguous else np.ascontiguousarray(R_los), bs_a_T,
                                   bs_b_T, st.x, b_idx, w_asn)
        asn = np.arcsin(w_asn)                                                 # (2, n_sat, n_bl)
        az = np.arctan2(los_b[:, 1], los_b[:, 0]) if R_mask is not None else z_f
        pcv_m, empty, pcv_on = pcv_zero, no_pcv, False
        if pcv_tables and R_mask is not None and t - R_mask_t <= PCV_ATTITUDE_AGE_S:
            pcv_m, empty = _pcv_epoch(pcv_tables, los_b, R_ant_first, n_sig, ever_fixed)
            pcv_on = s.calibration.pcv_empty_bins == "exclude"
        # reasons (8 no SD, 1 local horizon, 2 antenna horizon, 10 empty PCV bin, 3 C/N0, 6 half cycle), the epoch
        # clock estimate from code (first signal): c dt0 = median(SD_code + u.b) / (1 - rdot/c) and its jump test
        # against the prediction from the last estimate and the differential drift (free-running clocks drift by up
        # to ~10 us/s relative to each other, so across an outage the change alone is no jump; no code this epoch:
        # the prediction, the phase clocks absorb the drift), and the triple differences (time differences of SDs
        # with the predicted geometry change, median-referenced)
        consecutive = prev_t is not None and (t - prev_t) <= TD_MAX_DT_S
        do_td = consecutive and prev_b is not None
        n_jump, n_common = qc_epoch(asn, az, R_mask is not None, ever_fixed, s.table2.elevation_mask_antenna_deg * DEG,
                                    blk.reason[i], empty, pcv_on, blk.low_cn0[i], avail_p, sdc, sdp, cfac, ub,
                                    prev_ub, do_td, prev_sdc, prev_sdp, pa, lli, t, clk_state, CLOCK_JUMP_M,
                                    TD_MAX_DT_S, *views[:3], w_reason, wb, wf, w_clk, w_jump, w_mcp)
        el_w, el_ant, az_ant, reason, use_c, use_p, slip, td_c_ok, td_p_ok, sdc_c, sdp_c, td_c, td_p, mc, mp = views
        if n_jump:
            clk0, clk_pred = w_clk
            for j in np.flatnonzero(w_jump):
                ev(k, "clock_jump", j, detail=f"differential clock changed by "
                                             f"{(clk0[j] - clk_pred[j]) / C_M_S * 1e3:.3f} ms more than its drift "
                                             f"predicts")
        if n_common:
            # a common phase jump without a code jump: a receiver clock jump not applied to phase -> integer shift
            common = _nz(mp - mc)
            for j, f in zip(*np.nonzero(np.abs(common) > 1000.0)):
                n_cyc = np.round(common[j, f] / lam[f])
                sel = (st.amb_key[:, 0] == j) & (st.amb_key[:, 2] == f)
                st.x[st.n_fixed_part + np.flatnonzero(sel)] += n_cyc
                mp[j, f] -= n_cyc * lam[f]
                td_p[j, :, f] -= n_cyc * lam[f]
                ev(k, "phase_clock_jump", j, sig=pobs.signals[f], detail=f"{n_cyc:.0f} cycles common to all satellites")
        noise_on = s.noise.noise_estimation and do_td
        if noise_on:
            lw = blk_lw[i]
            if cn0_growth:
                # exponent gamma of the C/N0 growth (variance ~ factor^gamma) per observable and signal: slope
                # of ln|TD| against ln(factor) / 2 (E ln|x| = ln sigma + const for Gaussian x), pooled
                # moments over NOISE_EPOCHS; a receiver whose noise does not grow as C/N0 falls gets gamma ~ 0
                # (gnssatt.attitude.kernels: the samples, then the moments and gamma, in place)
                xs, rs, g_off = cn0_growth_samples(td_c, td_p, td_c_ok, td_p_ok, mc, mp, lw, lam)
                growth_weights(True, xs, np.log(rs), g_off, mom, gam_n, gamma, NOISE_EPOCHS, NOISE_MIN_EPOCHS,
                               0.05, lw, w_glw)
            else:
                growth_weights(False, z_f, z_f, z_i, mom, gam_n, gamma, NOISE_EPOCHS, NOISE_MIN_EPOCHS, 0.05, lw,
                               w_glw)
            wfac = np.exp(w_glw)                                           # C/N0 weights of code, phase
        else:
            wfac = w_glw
        # MAD of the normalised TDs -> sigma of a TD = sqrt(2) sigma of one SD (white noise), in place; the TD
        # tests: every phase with a state is checked, used or not (a slip while rejected (C/N0, mask) must not
        # survive into the epochs where it is used again); the bookkeeping masks: restart an arc (new float from
        # code-carrier) on a slip or where no triple difference could check it, drop states of satellites no
        # longer observed or unused for max_gap_s
        n_td, n_lli, n_gap, n_drop, n_need = td_checks(
            do_td, noise_on, wfac, est_var_c, est_var_p, est_n, NOISE_EPOCHS, s.table2.td_code_m, s.table2.td_phase_cyc, lam,
            avail_p, lli, reason, wb, wf, w_mcp, consecutive, prev_sdp, st.amb_index, st.amb_last_t,
            st.n_fixed_part, t, s.ambiguity.max_gap_s, w_ev, w_bk)
        if n_td:
            for j, sat, f in zip(*np.nonzero(w_ev[0])):
                ev(k, "cycle_slip", j, pobs.sats[sat], pobs.signals[f], "triple-difference test"
                   + ("" if st.amb_index[j, sat, f] >= 0 else " (phase not in use)"))
        # every slip is reported, also on phases not in use; an LLI on the first epoch of an arc is an acquisition
        if n_lli:
            for j, sat, f in zip(*np.nonzero(w_ev[1])):
                ev(k, "cycle_slip", j, pobs.sats[sat], pobs.signals[f], "loss-of-lock indicator"
                   + ("" if st.amb_index[j, sat, f] >= 0 else " (phase not in use)"))
        # ---------------- ambiguity bookkeeping ----------------
        if n_gap:
            ev(k, "arc_restart", detail=f"{n_gap} ambiguities without a triple-difference check (data gap)")
        need = w_bk[1]
        if n_drop:
            drop_mask = w_bk[0]
            st.remove_ambiguities(st.amb_index[drop_mask], k - 1)
            need = use_p & (st.amb_index < 0)
            n_need = int(need.sum())
        if n_need:
            jj, ss, ff = np.nonzero(need)
            vals = (sdp_c[jj, ss, ff] - sdc_c[jj, ss, ff]) / lam[ff]
            st.add_ambiguities(np.stack([jj, ss, ff], 1), vals, s.table1.sigma0_ambiguity_cyc, t)
        # ---------------- measurement update ----------------
        jc, sc, fc = np.nonzero(use_c)
        jp, sp, fp = np.nonzero(use_p)
        mc_n, mp_n = jc.size, jp.size
        m = mc_n + mp_n
        if m:
            # gnssatt.attitude.update_kernels.measurement_update, x and P in place: sparse rows (baseline, clock,
            # code bias / ambiguity) and observations, code rows then phase rows; variances: the white noise
            # (the configured sigmas are floors: receivers smooth their code (tiny code TDs), and time-correlated
            # errors (multipath) never show in a triple difference) x C/N0 factor^gamma [x elevation factor: the
            # antenna-frame elevation once an attitude exists, else the local horizon], plus the time-correlated
            # errors (multipath, uncalibrated PCV) growing with the off-boresight angle, scaled adaptively; the
            # update as scalar updates in turn; the post-fit residuals and the sums of the multipath scale
            vc_f, vp_f = white_variances_cp(est_var_c, est_var_p, est_n, var_c_floor, var_p_floor, NOISE_MIN_EPOCHS,
                                            s.noise.noise_estimation)
            watch_w = adapter is not None and ever_fixed.all() and prev_t is not None
            if watch_w:
                sub_prior, P_sub_prior = st.x[sub_w_b], st.P[ix_sub]          # (fancy indexing: copies)
            el_wc = np.ascontiguousarray(el_w)          # one compiled signature whatever the layout
            el_e = el_wc if not elev_w else (el_ant if R_mask is not None else np.repeat(el_loc[None, :], n_bl, 0))
            mp_mult = mp_infl * mp_scale
            (cols, coef, z, var, v_mp, post, good, mp_num, mp_den, n_mp, n_used, n_fixed_used, n_unfixed, n_fix_rows,
             ms_fix, has_fix) = measurement_update(
                st.x, st.P, jc, sc, fc, jp, sp, fp, b_idx, u, cfac, st.clk, st.pclk, st.bias, st.amb_index, lam,
                sdc_c, sdp_c, pcv_m, vc_f, vp_f, np.ascontiguousarray(cn0), gamma, cn0_growth, el_e, elev_w, el_wc,
                mp_model, mp_sig, mp_mult, st.amb_fixed, st.n_fixed_part, st.amb_last_t, t, JOSEPH_RATIO, st.amb_key,
                n_bl, n_sat)
            if mp_model and record and mp_n:
                w_p = 1.0 / var[mc_n:]
                sm_corr[k] = float(np.sum(v_mp[mc_n:] * mp_mult * w_p * w_p) / np.sum(w_p))
            if good and watch_w:
                rep = adapter.observe(sub_prior, P_sub_prior, st.x[sub_w_b], st.P[ix_sub], t)
                if rep is not None:        # a manoeuvre: the (omega, baselines) sub-state the detector gives
                    st.x[sub_w_b], st.P[ix_sub] = rep
            if mp_model and s.noise.multipath_adaptive and good and n_mp >= 6:
                # scale of the multipath variance from the post-fit residuals of fixed phases:
                # E[r^2] = R_true (1 - h), h = (H P+ H^T)_ii / R_model (leverage); R_true = white + scale * mp
                a = 1.0 / min(mp_n_ep + 1.0, NOISE_EPOCHS)
                ratio = mp_num / mp_den if mp_den else np.float64(mp_num) / 0.0
                mp_scale = float(min(max(mp_scale + a * (ratio - mp_scale), MP_SCALE_MIN), MP_SCALE_MAX))
                mp_n_ep += 1
        else:
            post = np.zeros(0)
        # ---------------- ambiguity resolution ----------------
        # with phase rows, measurement_update gave the satellites used / with a fixed ambiguity per baseline, the
        # unfixed rows and the fix monitor's post-fit mean squares (phase_row_stats)
        if not mp_n:
            n_used = np.zeros(n_bl, np.int64)
            n_fixed_used = n_unfixed = n_used
        ar_changed = False     # the AR below changed st.amb_fixed (the stats above are then recomputed)
        joint_ar = {}          # ambiguity_search "constrained": one MC-LAMBDA first fix of all baselines together
        if s.ambiguity.ambiguity_search == "constrained" and n_bl >= 2 and mp_n and not st.amb_fixed.any():
            gb = {j: first_fix_groups(cols[mc_n:, 4][jp == j], fp[jp == j], el_loc[sp[jp == j]], n_sig)
                  for j in range(n_bl) if pa[j] and n_used[j] >= s.ambiguity.min_sats}
            gb = {j: g for j, g in gb.items() if g and sum(x.size - 1 for x, _ in g) >= s.ambiguity.min_dd}
            if len(gb) >= 2:
                joint_ar = {j: o for j, o in resolve_joint_constrained(st.x, st.P, gb, b_idx, body_baselines_m,
                                                                      s).items() if o.accepted}
        for j in range(n_bl):
            if n_used[j] and first_data[j] < 0:
                first_data[j] = k
            if not pa[j] or n_used[j] < s.ambiguity.min_sats or not n_unfixed[j]:
                continue
            if not has_fix[j]:                                  # no signal of baseline j fixed yet
                sel_j = jp == j
                idx_j = cols[mc_n:, 4][sel_j]
                el_j = el_loc[sp[sel_j]]
                sig_j = fp[sel_j]
                groups = first_fix_groups(idx_j, sig_j, el_j, n_sig)
                if not groups or sum(g.size - 1 for g, _ in groups) < s.ambiguity.min_dd:
                    continue
                outcome = joint_ar.get(j) or resolve_first_fix(st.x, st.P, groups, b_idx[j], lengths[j], s)
                out_ratio[k, j] = outcome.ratio
                if outcome.accepted and not (outcome.ratio >= s.ambiguity.min_ratio_first_fix):
                    outcome.accepted = False
                    outcome.reason = f"ratio {outcome.ratio:.2f} < {s.ambiguity.min_ratio_first_fix:.2f} (first fix)"
                if outcome.accepted and n_bl > 1 and s.ambiguity.max_angle_error_m > 0:
                    partners = [j2 for j2 in range(n_bl) if j2 != j and st.amb_fixed[st.amb_key[:, 0] == j2].any()]
                    if partners:
                        b_cand = fixed_baseline_vector(st.x, st.P, outcome.D, outcome.a_fix, b_idx[j])
                        ok_ang, worst = angle_test_against_fixed(
                            b_cand, body_baselines_m[j], st.x[b_idx[partners]], body_baselines_m[partners],
                            s.ambiguity.max_angle_error_m)
                        if not ok_ang:
                            outcome.accepted = False
                            outcome.reason = (f"angle to fixed baseline(s) {partners} off by {worst:.2f} deg "
                                              f"(length {outcome.length_m:.4f} m)")
                            angle_fail[j] += 1
                            if angle_fail[j] >= ANGLE_FAIL_RESET:
                                # a candidate that passes length and ratio but never fits the partners' directions:
                                # the partners' fix is the suspect one; back to float on all of them
                                for j2 in partners:
                                    pending_reset[j2] = (f"{ANGLE_FAIL_RESET} candidates of baseline {j} in a row "
                                                         f"failed the angle test against it")
                                angle_fail[j] = 0
                        else:
                            angle_fail[j] = 0
                if outcome.accepted:
                    angle_fail[j] = 0
                    log_fix(outcome.D, outcome.a_fix)
                    b_before = st.x[b_idx[j]].copy()
                    _pseudo_update(st, outcome.D, outcome.a_fix)
                    b_after = st.x[b_idx[j]]
                    turn_deg = np.degrees(np.arccos(_clip(b_before @ b_after / max(
                        np.linalg.norm(b_before) * np.linalg.norm(b_after), 1e-12), -1.0, 1.0)))
                    if dynamic and turn_deg > OMEGA_RESET_TURN_DEG:
                        # the angular velocity was learnt with a baseline that the fix has just turned: its
                        # estimate and covariance (linearised about the wrong baseline) are not to be trusted
                        st.P[0:3, :] = 0.0
                        st.P[:, 0:3] = 0.0
                        st.P[0:3, 0:3] = np.eye(3) * (s.table1.sigma0_omega_deg_s * DEG) ** 2
                        ev(k, "omega_reset", j, detail=f"the fix turned the baseline by {turn_deg:.2f} deg")
                        if record:
                            sm_start[k] = True
                        if adapter is not None:
                            adapter.reset()
                    for g, _ in outcome.groups or groups:
                        st.amb_fixed[g - st.n_fixed_part] = True
                    ar_changed = True
                    ev(k, "fix", j, detail=f"{outcome.n_dd} DD ambiguities, ratio {outcome.ratio:.2f}, "
                                         f"length {outcome.length_m:.4f} m")
                    if first_fix[j] < 0:
                        first_fix[j] = k
                else:
                    ev(k, "fix_rejected", j, detail=f"ratio {outcome.ratio:.2f}, {outcome.reason}")
            else:
                # newcomers on a fixed baseline: DD to the fixed reference of their signal rounded (compiled)
                # and constrained in place (DD pseudo-measurements as in _pseudo_update, as scalar Joseph updates)
                nw, rf, vals = fix_newcomers(st.x, st.P, st.amb_key, st.amb_fixed, st.n_fixed_part, cols, mc_n, jp,
                                             sp, fp, el_loc, n_sig, j, s.ambiguity.new_amb_round_sigma_cyc,
                                             s.ambiguity.new_amb_round_frac_cyc, PSEUDO_VAR_CYC2)
                if nw.size:
                    ar_changed = True
                    fix_rows.extend(zip([k] * nw.size, st.amb_arc[nw - st.n_fixed_part].tolist(),
                                        st.amb_arc[rf - st.n_fixed_part].tolist(), vals.tolist()))
                    ev(k, "fix_added", j, detail=f"{nw.size} newcomers fixed by rounding")
        # fix monitor: post-fit phase residuals of fixed ambiguities far above the noise for FIX_CHECK_EPOCHS in a
        # row mean a wrong fix (or an undetected slip): restart every ambiguity of that baseline as float
        if mp_n:
            if ar_changed:
                _, n_fixed_post, _, n_fix_rows, ms_fix = phase_row_stats(jp, sp, cols, mc_n, st.amb_fixed,
                                                                         st.n_fixed_part, post, n_bl, n_sat)
            lim = max(FIX_CHECK_SIGMAS * math.sqrt(max(vp_f.tolist())), FIX_CHECK_MIN_M)
            for j in range(n_bl):
                if n_fix_rows[j] >= 4:
                    rms = np.sqrt(ms_fix[j])
                    bad_fix[j] = bad_fix[j] + 1 if rms > lim else 0
                    if bad_fix[j] >= FIX_CHECK_EPOCHS:
                        reset_baseline(j, f"post-fit phase RMS {rms * 1e3:.1f} mm > {lim * 1e3:.1f} mm "
                                          f"for {FIX_CHECK_EPOCHS} epochs")
                        mp_n = 0          # the state no longer matches this epoch's rows
        # partners withdrawn by the angle test (after the monitor: the state layout changes)
        for j2, why in pending_reset.items():
            if st.amb_fixed[st.amb_key[:, 0] == j2].any():
                reset_baseline(j2, why)
                mp_n = 0
        pending_reset.clear()
        # recount fixed after AR
        had_fix = ever_fixed
        if mp_n and not ar_changed:
            ever_fixed = has_fix                    # st.amb_fixed as measurement_update saw it
        else:
            ever_fixed = np.zeros(n_bl, bool)
            ever_fixed[st.amb_key[st.amb_fixed, 0]] = True
        lost = had_fix & ~ever_fixed
        if lost.any():
            for j in np.flatnonzero(lost):
                ev(k, "fix_lost", j, detail="no fixed ambiguity left (slips, gaps or setting satellites)")
        if mp_n and ar_changed:
            n_fixed_used = n_fixed_post             # after AR (a reset above leaves the count before AR)
        # ---------------- outputs ----------------
        # out_b[k], out_P[k], out_w[k]; out_ok[k] = pa & (n_used >= 3), out_fixed[k] = fixed_now & out_ok[k],
        # out_n[k] = n_used; fixed_now = ever_fixed & (n_fixed_used >= fixed_min_sats)
        fixed_now = store_outputs(st.x, st.P, all_b_idx, k, out_b, out_P, out_w, dynamic, pa, n_used, ever_fixed,
                                  n_fixed_used, s.ambiguity.fixed_min_sats, out_ok, out_fixed, out_n)
        if record:
            sm_xf[k], sm_Pf[k] = st.x[sub_w_b], st.P[ix_sub]
        if attitude_fn is not None and k % (1 if pcv_tables else 10) == 0 and fixed_now.all():
            R_mask = attitude_fn(out_b[k], fixed_now)
            R_mask_t = t
        # residual records (used and rejected): the epoch's code rows, then its phase rows; and the memory for the
        # triple differences (clock-corrected SDs where available)
        res_n = record_epoch(k, avail_c, avail_p, use_c, use_p, reason, el_ant, az_ant, cn0, post, m, jc, sc, fc, jp,
                             sp, fp, w_lookup, res_i, res_f, res_n, sdc_c, sdp_c, prev_sdc, prev_sdp, out_b[k], u,
                             prev_ub)                                   # prev_ub = out_b[k] @ u.T
        prev_t = t
        prev_b = out_b[k]
    if progress is not None:
        progress(1.0)
    # column arrays for residuals.csv (contiguous views of the record rows)
    residuals = {"epoch": res_i[0, :res_n], "bl": res_i[1, :res_n], "sat": res_i[2, :res_n], "sig": res_i[3, :res_n],
                 "el_ant_deg": res_f[0, :res_n], "az_ant_deg": res_f[1, :res_n], "cn0_dbhz": res_f[2, :res_n],
                 "kind": res_i[4, :res_n], "residual_m": res_f[3, :res_n], "reason": res_i[5, :res_n]}
    arcs = np.array(st.arcs, dtype=np.int64).reshape(-1, 5)
    arcs[arcs[:, 4] < 0, 4] = n_ep - 1
    fl = np.array(fix_rows, dtype=np.float64).reshape(-1, 4)
    a_arc, r_arc = fl[:, 1].astype(np.int64), fl[:, 2].astype(np.int64)
    fix_log = {"epoch": fl[:, 0].astype(np.int64), "bl": arcs[a_arc, 0], "sig": arcs[a_arc, 2],
               "sat": arcs[a_arc, 1], "ref_sat": arcs[r_arc, 1], "dd_cyc": fl[:, 3],
               "last_epoch": np.minimum(arcs[a_arc, 4], arcs[r_arc, 4])}
    noise = {"sigma_phase_white_m": {sg: float(np.sqrt(max(est_var_p[f], s.table1.sigma_phase_m ** 2)))
                                     for f, sg in enumerate(pobs.signals)},
             "sigma_code_white_m": {sg: float(np.sqrt(max(est_var_c[f], s.table1.sigma_code_m ** 2)))
                                    for f, sg in enumerate(pobs.signals)},
             "cn0_gamma_code": {sg: float(gamma[0, f]) for f, sg in enumerate(pobs.signals)},
             "cn0_gamma_phase": {sg: float(gamma[1, f]) for f, sg in enumerate(pobs.signals)},
             "multipath_scale": float(mp_scale) if mp_model else None,
             "multipath_correlation_factor": float(mp_infl)}
    smoother_data = {"x_prior": sm_xp, "P_prior": sm_Pp, "x_post": sm_xf, "P_post": sm_Pf, "Phi": sm_Phi,
                     "start": sm_start, "corr_share": sm_corr, "dt_s": sm_dt, "q_omega": q_w} if record else None
    return FilterResult(out_ok, out_b, out_P, out_fixed, out_n, out_ratio, out_w, residuals, events,
                        first_fix, first_data, fix_log, noise, smoother_data)


def _pcv_epoch(tables, los_b, R_ant_first, n_sig, fixed):
    """(correction m (n_bl, n_sat, n_sig), no-correction mask) of an epoch: maps apply to fixed baselines only;
    a fixed baseline's phase without a correction (empty bin) leaves the solution (seed 000 sec. 3.2)."""
    corr, has = epoch_correction_m(tables, los_b, R_ant_first, n_sig)
    on = fixed[:, None, None] & has[:, None, :]
    return np.where(on, np.nan_to_num(corr), 0.0), on & ~np.isfinite(corr)


def _pseudo_update(st: _State, D: np.ndarray, a_fix: np.ndarray) -> None:
    """Constrain DD ambiguities D x = a_fix with a (numerically) zero-variance pseudo-measurement (Joseph form)."""
    r, c = np.nonzero(D)                         # row-major: each row's columns ascending
    cnt = np.bincount(r, minlength=D.shape[0])
    kmax = int(cnt.max())
    pos = np.arange(r.size) - np.repeat(np.cumsum(cnt) - cnt, cnt)   # position of each non-zero in its row
    cols = np.full((D.shape[0], kmax), -1, dtype=np.int64)
    coef = np.zeros((D.shape[0], kmax))
    cols[r, pos] = c
    coef[r, pos] = D[r, c]
    innov = a_fix - D @ st.x
    # 1e-6 cycles^2 keeps S positive definite in float64 without loosening the constraint noticeably
    x1, P1, _, good = joseph_update_sparse(st.x, st.P, cols, coef, np.full(D.shape[0], 1e-6), innov)
    if good:
        st.x, st.P = x1, P1

