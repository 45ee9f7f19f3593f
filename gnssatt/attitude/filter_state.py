"""The state of one run of the attitude filter (seed 000 Fig. 2 "initialisation"): the EKF state vector and
covariance with their index maps and the ambiguity bookkeeping (`FilterState`, eq. 1), and everything else the
boxes of Fig. 2 read and write from epoch to epoch (`FilterRun`: the fixed inputs, the noise model, the fix status,
the event log, the per-epoch output buffers, the memory of the previous epoch); `EpochData` holds one epoch's
intermediate arrays as they pass from box to box.

Implements: seed 000 sec. 2 eq. 1 (state vector, here per baseline with its code biases and phase clocks) and
Table 1 (initial sigmas: baselines 2 m or 1.2 x the length, angular velocity, code biases).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.attitude.adaptive import ManoeuvreDetector
from gnssatt.attitude.angular_acceleration import jerk_rate_profile
from gnssatt.attitude.fastops import clip as _clip, nz as _nz
from gnssatt.attitude.multipath_vce import MultipathVce
from gnssatt.attitude.pcv_correction import pcv_tables_for
from gnssatt.attitude.qc_kernels import add_states, drop_states
from gnssatt.attitude.qc_records import EpochClock, EpochMemory, QcLimits, QcWork, ResidualBuffers, WhiteNoise
from gnssatt.attitude.settings import AttitudeSettings, cn0_mask_of
from gnssatt.attitude.update_records import NoiseModel, OutputBuffers, OutputSettings, RoundingLimits, StateLayout
from gnssatt.gnss.constants import C_M_S

__all__ = ["FilterResult", "FilterState", "FilterRun", "EpochData", "EventLog", "REASONS", "DEG"]

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
    # dynamic mode with settings.smoother: per epoch the (omega, baselines) sub-state after propagation (prior) and
    # at the output (posterior), the transition matrix from the previous epoch and the segment starts (resets),
    # for the fixed-interval smoother (gnssatt.attitude.smoother)
    smoother_data: dict = None


class FilterState:
    """x, P and the index maps (seed 000 eq. 1); the ambiguity states and the arcs they belong to."""

    def __init__(self, n_bl: int, n_sat: int, n_sig: int, dynamic: bool, phase_clock: bool,
                 acceleration: bool = False):
        self.n_bl, self.n_sat, self.n_sig, self.dynamic = n_bl, n_sat, n_sig, dynamic
        # states of the rotation ahead of the baselines: omega (3) [+ alpha (3), gnssatt.attitude.angular_acceleration]
        self.n_rate = (6 if acceleration else 3) if dynamic else 0
        self.off_w = 0
        n_pc = n_sig if phase_clock else 0
        n_bias = max(n_sig - 1, 0)               # inter-signal (frequency, system) code bias vs signal 1
        blk = 4 + n_bias + n_pc
        base0 = self.n_rate
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

    def baseline_has_fix(self, j: int) -> bool:
        """Whether any ambiguity of baseline j is fixed."""
        return bool(self.amb_fixed[self.amb_key[:, 0] == j].any())


class EventLog:
    """events.csv rows: epoch, event, baseline, sat, signal, detail."""

    def __init__(self):
        self.rows: list[dict] = []

    def add(self, k, kind, j=None, sat=None, sig=None, detail=""):
        self.rows.append({"epoch": k, "event": kind, "baseline": j, "sat": sat, "signal": sig, "detail": detail})


def cn0_factor(cn0_dbhz: np.ndarray) -> np.ndarray:
    """Variance factor 10^((45 - C/N0)/10), clipped to [0.25, 16] (noise doubles per -6 dB; 45 dB-Hz = Table 1)."""
    return _clip(10.0 ** ((45.0 - _nz(cn0_dbhz, 45.0)) / 10.0), 0.25, 16.0)


class EpochData:
    """One epoch's intermediate arrays, filled box by box (names as in the boxes' docstrings)."""

    def __init__(self, k: int, t: float, prev_t):
        self.k, self.t, self.prev_t = k, t, prev_t
        self.post = np.zeros(0)          # post-fit residuals of the update (none without rows)
        self.m = self.mc_n = self.mp_n = 0
        self.ar_changed = False          # ambiguity resolution changed amb_fixed (the counts are then recomputed)


class FilterRun:
    """Everything the boxes of Fig. 2 share across epochs, built from run_filter's arguments (initialisation).

    Groups: inputs (pobs, geom, settings and what follows from them), `st` (FilterState), the noise model (white
    variances, C/N0 growth, multipath scale), the fix status, `events`, the output buffers (`out_*`, residual
    records, smoother records) and the memory of the previous epoch (`prev_*`, the mask attitude)."""

    def __init__(self, pobs, geom, baselines, body_baselines_m, boresight_body, settings: AttitudeSettings,
                 R_body_from_ecef_0, attitude_fn, q_omega, noise0: dict | None = None):
        s = self.s = settings
        # the settings of the first-fix search: with length_validation "single-epoch" the filter-baseline length
        # test is left to boxes.validation (the search's own test made blind: 10 m, the field's limit)
        self.s_search = s if s.ambiguity.length_validation != "single-epoch" else s.override(
            ambiguity={"max_length_error_m": 10.0})
        self.pobs, self.geom, self.baselines = pobs, geom, baselines
        self.body_baselines_m, self.boresight_body = body_baselines_m, boresight_body
        self.R_body_from_ecef_0, self.attitude_fn = R_body_from_ecef_0, attitude_fn
        n_ant, self.n_ep, self.n_sat, self.n_sig = pobs.code_m.shape
        n_bl = self.n_bl = len(baselines)
        self.dynamic = s.mode == "dynamic"
        self.accel = self.dynamic and bool(s.angular_acceleration_state)
        self.st = FilterState(n_bl, self.n_sat, self.n_sig, self.dynamic, s.noise.separate_phase_clock,
                              self.accel)
        # (n_sat, n_sig) wavelength per satellite (GLONASS FDMA: one per channel) and (n_sig,) the signal's nominal
        self.lam_sig = np.ascontiguousarray(pobs.wavelength_m, dtype=np.float64)
        lam_sat = np.asarray(getattr(pobs, "wavelength_sat_m", None) if getattr(pobs, "wavelength_sat_m", None)
                             is not None else np.repeat(self.lam_sig[None, :], self.n_sat, axis=0), np.float64)
        self.lam = np.ascontiguousarray(np.where(np.isfinite(lam_sat), lam_sat, self.lam_sig[None, :]))
        # FDMA signals (one wavelength per satellite) and the phase clock jumps applied to their SD phase (m)
        self.fdma_sig = np.ptp(self.lam, axis=0) > 0 if self.n_sat else np.zeros(self.n_sig, bool)
        self.phase_jump_m = np.zeros((n_bl, self.n_sig))
        t_s = (pobs.time - pobs.time[0]) if self.n_ep else np.zeros(0)
        self.t_s = np.asarray(t_s, dtype=np.float64)
        self.lengths = np.linalg.norm(body_baselines_m, axis=1)
        self.sig_cn0 = np.array([cn0_mask_of(s, sig) for sig in pobs.signals])
        self.ia = np.array([b[0] for b in baselines])
        self.ib = np.array([b[1] for b in baselines])
        self.b_idx = self.st.b_off[:, None] + np.arange(3)[None, :]                 # (n_bl, 3)
        self.all_b_idx = self.b_idx.ravel()
        self.events = EventLog()
        self._init_state()
        self._init_noise_model(q_omega)
        if noise0 is not None:
            self.start_noise_from(noise0)
        self._init_outputs()
        self._init_memory()
        self._init_work()
        self._init_update_records()

    def _init_state(self):
        """Initial x, P: seed 000 Table 1 (baselines from the initial attitude, sigma0 2 m or 1.2 x the length)."""
        s, st = self.s, self.st
        b0 = self.body_baselines_m @ self.R_body_from_ecef_0        # b_ecef = R^T b_body (rows)
        for j in range(self.n_bl):
            o = st.b_off[j]
            st.x[o:o + 3] = b0[j]
            sig0 = max(s.table1.sigma0_baseline_m, 1.2 * self.lengths[j])
            st.P[np.arange(o, o + 3), np.arange(o, o + 3)] = sig0 ** 2
            st.P[st.bias[j, 1:], st.bias[j, 1:]] = s.table1.sigma0_code_bias_m ** 2
        if self.dynamic:
            st.P[0:3, 0:3] = np.eye(3) * (s.table1.sigma0_omega_deg_s * DEG) ** 2
        if self.accel:
            st.P[3:6, 3:6] = np.eye(3) * (s.sigma0_angular_acceleration_deg_s2 * DEG) ** 2

    def _init_noise_model(self, q_omega):
        """Process noise (Table 1, the manoeuvre detector) and the measurement noise model's estimator state."""
        s, n_bl, n_sig = self.s, self.n_bl, self.n_sig
        sig_w = s.sigma_omega_with_acceleration_deg_s if self.accel else s.table1.sigma_omega_deg_s
        self.q_w = q_w = (sig_w * DEG) ** 2 / s.table1.tau_omega_s          # rad^2/s^2 per s
        self.adapter = ManoeuvreDetector(
            q_w, (s.adaptive.sigma_omega_raised_deg_s * DEG) ** 2 / s.table1.tau_omega_s, n_bl, s.adaptive.threshold,
            s.adaptive.mix_at, s.adaptive.sigma_acc_deg_s2 * DEG, s.adaptive.hold_epochs,
            s.rk4_step_s, not (s.smoothing.enabled or s.smoothing.adaptive_noise)) \
            if self.dynamic and s.adaptive.enabled and not self.accel else None
        # angular-acceleration random walk (rad^2/s^4 per s) with angular_acceleration_state
        self.q_alpha = (s.sigma_angular_jerk_deg_s3 * DEG) ** 2 / s.table1.tau_omega_s
        self.q_b = s.table1.sigma_baseline_kinematic_m ** 2 / s.table1.tau_baseline_s       # m^2 per s
        self.var_clk = (s.table1.sigma_clock_s * C_M_S) ** 2
        self.Qw_iso = np.eye(3) * q_w
        self.q_omega = np.ascontiguousarray(q_omega, dtype=np.float64) if q_omega is not None else None
        # the angular-jerk rate per epoch of a second pass (smoothing.quiet_jerk_share < 1); None: q_alpha throughout
        self.q_alpha_k = jerk_rate_profile(self.q_alpha, self.q_omega, s.smoothing.noise_floor * q_w,
                                           s.smoothing.quiet_jerk_share) \
            if self.accel and self.q_omega is not None and s.smoothing.quiet_jerk_share < 1 else None
        self.cn0_growth = s.noise.weighting == "cn0" or s.noise.noise_cn0_growth
        self.mp_model = max(s.noise.sigma_multipath_phase_m) > 0 or max(s.noise.sigma_multipath_code_m) > 0
        self.mp_infl = s.noise.multipath_correlation_factor if self.dynamic else 1.0
        self.mp_sig = np.array([*s.noise.sigma_multipath_code_m, *s.noise.sigma_multipath_phase_m], dtype=np.float64)
        self.elev_w = s.noise.weighting == "elevation"
        self.var_c_floor, self.var_p_floor = s.table1.sigma_code_m ** 2, s.table1.sigma_phase_m ** 2
        # C/N0 growth exponent per (code, phase) and signal, estimated from the triple differences (starts at 1)
        self.gamma = np.ones((2, n_sig)) if self.cn0_growth else np.zeros((2, n_sig))
        self.gam_n = np.zeros((2, n_sig))
        self.mom = np.zeros((2, n_sig, 4))
        self.mp_scale, self.mp_n_ep = 1.0, 0   # adaptive scale of the multipath variance (1 = the configured sigmas)
        # its variance-component estimate from the residuals' lag-1 autocovariance (multipath_adaptive_method)
        self.mp_vce = MultipathVce(NOISE_EPOCHS, MP_SCALE_MIN, MP_SCALE_MAX, TD_MAX_DT_S) \
            if s.noise.multipath_adaptive_method == "autocovariance" else None
        # per-signal white-noise estimates (variance of one SD) from the triple differences: robust, exponentially
        # weighted over NOISE_EPOCHS epochs; used once NOISE_MIN_SAMPLES TDs have been seen
        self.est_var_c = np.full(n_sig, s.table1.sigma_code_m ** 2)
        self.est_var_p = np.full(n_sig, s.table1.sigma_phase_m ** 2)
        self.est_n = np.zeros(n_sig)
        self.white_noise = tuple(WhiteNoise(var_code_m2=self.est_var_c, var_phase_m2=self.est_var_p,
                                            n_white=self.est_n, memory_epochs=NOISE_EPOCHS,
                                            enabled=bool(s.noise.noise_estimation)))     # td_checks updates it

    def noise_state(self) -> dict:
        """Copies of the measurement noise estimator's state (white variances and their counts, C/N0 exponents,
        multipath scale): what a second pass over the same data starts from (start_noise_from)."""
        return {"est_var_c": self.est_var_c.copy(), "est_var_p": self.est_var_p.copy(), "est_n": self.est_n.copy(),
                "gamma": self.gamma.copy(), "gam_n": self.gam_n.copy(), "mom": self.mom.copy(),
                "mp_scale": float(self.mp_scale), "mp_n_ep": int(self.mp_n_ep),
                "mp_vce": self.mp_vce.state() if self.mp_vce is not None else None}

    def start_noise_from(self, noise0: dict) -> None:
        """Start the noise estimator where a first pass over the same data ended (noise_state), in place (the
        WhiteNoise records hold the arrays): the second pass of smoother_adaptive_noise weights its first epochs
        with the noise the data showed, not with Table 1's floor (measured: 3.0 mm at the first fix against
        4.0 / 5.8 mm estimated on L1 / L2 of seed 000 Fig. 6's clean slews; docs/attitude.md)."""
        for name in ("est_var_c", "est_var_p", "est_n", "gamma", "gam_n", "mom"):
            getattr(self, name)[...] = noise0[name]
        self.mp_scale, self.mp_n_ep = float(noise0["mp_scale"]), int(noise0["mp_n_ep"])
        if self.mp_vce is not None and noise0.get("mp_vce") is not None:
            self.mp_vce.start_from(noise0["mp_vce"])

    def _init_outputs(self):
        """Per-epoch output buffers, the residual records and (dynamic, smoother) the smoother's records."""
        n_ep, n_bl = self.n_ep, self.n_bl
        self.out_ok = np.zeros((n_ep, n_bl), bool)
        self.out_b = np.full((n_ep, n_bl, 3), np.nan)
        self.out_P = np.full((n_ep, 3 * n_bl, 3 * n_bl), np.nan)
        self.out_fixed = np.zeros((n_ep, n_bl), bool)
        self.out_n = np.zeros((n_ep, n_bl), np.int64)
        self.out_ratio = np.full((n_ep, n_bl), np.nan)
        self.out_w = np.full((n_ep, 3), np.nan)
        n_sub = self.n_sub = max(self.st.n_rate, 3) + 3 * n_bl
        self.record = self.dynamic and (self.s.smoothing.enabled or self.s.smoothing.adaptive_noise)
        if self.record:
            self.sm_xp, self.sm_xf = np.full((n_ep, n_sub), np.nan), np.full((n_ep, n_sub), np.nan)
            self.sm_Pp, self.sm_Pf = np.full((n_ep, n_sub, n_sub), np.nan), np.full((n_ep, n_sub, n_sub), np.nan)
            self.sm_Phi = np.full((n_ep, n_sub, n_sub), np.nan)
            self.sm_start = np.ones(n_ep, bool)
            self.sm_corr = np.zeros(n_ep)     # information-weighted share of time-correlated variance in the phases
            self.sm_dt = np.zeros(n_ep)       # propagation interval into the epoch (s)
        # residual records, rows appended per epoch by record_epoch: ints epoch, bl, sat, sig, kind, reason and
        # floats el_ant_deg, az_ant_deg, cn0_dbhz, residual_m (capacity grown per SdBlock)
        self.w_lookup = np.zeros((2, n_bl, self.n_sat, self.n_sig))
        self.set_residual_buffers(np.zeros((6, 0), np.int64), np.zeros((4, 0)))
        self.res_n = 0
        # fix status
        self.first_fix = np.full(n_bl, -1)
        self.first_data = np.full(n_bl, -1)
        self.ever_fixed = np.zeros(n_bl, bool)
        self.bad_fix = np.zeros(n_bl, np.int64)
        self.angle_fail = np.zeros(n_bl, np.int64)
        self.pending_reset: dict = {}
        self.fix_rows: list[tuple[int, int, int, float]] = []        # (epoch, arc, ref arc, integer)

    def _init_memory(self):
        """The previous epoch as the next one needs it (triple differences, clock prediction, mask attitude)."""
        n_bl, n_sat, n_sig = self.n_bl, self.n_sat, self.n_sig
        self.prev_t = None
        self.prev_sdc = np.full((n_bl, n_sat, n_sig), np.nan)       # clock-corrected SD of the previous epoch
        self.prev_sdp = np.full((n_bl, n_sat, n_sig), np.nan)
        # per baseline: last estimated epoch clock c dt0 (m), its time and drift (m/s) (qc_epoch updates them)
        self.clk_state = np.stack([np.full(n_bl, np.nan), np.zeros(n_bl), np.zeros(n_bl)])
        self.prev_b = None
        self.prev_ub = np.zeros((n_bl, n_sat))
        self.qc_memory = tuple(EpochMemory(prev_sdc_m=self.prev_sdc, prev_sdp_m=self.prev_sdp,
                                           prev_ub_m=self.prev_ub))                  # record_epoch writes them
        self.R_mask = None                                           # attitude for the antenna-frame mask
        self.R_mask_t = -np.inf
        self.blk = None                                              # SdBlock of the current epochs
        self.sd_qc = self.sd_flags = None                            # the QC kernels' records of it (qc_records)
        self.blk_lw = None
        # differential PCV maps per (baseline, signal), applied to fixed baselines (gnssatt.attitude.pcv_correction)
        s = self.s
        self.pcv_tables = pcv_tables_for(s.calibration.pcv_maps, list(self.pobs.antennas), self.baselines,
                                         list(self.pobs.signals)) if s.calibration.pcv_maps else {}
        if self.pcv_tables:
            from gnssatt.gnss.geometry import R_antenna_from_body
            self.R_ant_first = R_antenna_from_body(self.boresight_body[self.ia])             # (n_bl, 3, 3)

    def _init_work(self):
        """Per-epoch work arrays of the compiled QC (gnssatt.attitude.qc_kernels), overwritten every epoch, and the
        QC kernels' run-constant records of them (gnssatt.attitude.qc_records: limits, work, epoch clock)."""
        n_bl, n_sat, n_sig = self.n_bl, self.n_sat, self.n_sig
        shp = (n_bl, n_sat, n_sig)
        s = self.s
        self.qc_limits = tuple(QcLimits(
            el_mask_ant_rad=float(s.table2.elevation_mask_antenna_deg * DEG), clock_jump_m=CLOCK_JUMP_M,
            td_max_dt_s=TD_MAX_DT_S, td_code_m=float(s.table2.td_code_m), td_phase_cyc=float(s.table2.td_phase_cyc),
            max_gap_s=float(s.ambiguity.max_gap_s), wavelength_m=self.lam_sig))
        work = QcWork(el_rad=np.zeros((3, n_bl, n_sat)), reason=np.zeros(shp, np.int64),
                      masks=np.zeros((9,) + shp, bool), values_m=np.zeros((4,) + shp),
                      median_td_m=np.zeros((2, n_bl, n_sig)))
        self.qc_work = tuple(work)
        self.w_ev, self.w_bk = work.masks[5:7], work.masks[7:9]     # slips to report; states to drop / to add
        clock = EpochClock(clock_state=self.clk_state, clock_m=np.zeros((2, n_bl)), jump=np.zeros(n_bl, bool))
        self.qc_clock = tuple(clock)                                   # qc_epoch writes it
        self.w_clk, self.w_jump = clock.clock_m, clock.jump
        # the per-epoch names (EpochData el_w .. mp) are views of these arrays, made once
        self.views = (*work.el_rad, work.reason, *work.masks[:5], *work.values_m, *work.median_td_m)
        self.w_asn = np.zeros((2, n_sat, n_bl))
        self.w_glw = np.zeros((2,) + shp)
        self.no_pcv = np.zeros(shp, bool)
        self.pcv_zero = np.zeros(shp)
        bs = self.boresight_body
        self.bs_a_T = np.asfortranarray(bs[self.ia].T)   # (3, n_bl) boresights as columns (the layout of the
        self.bs_b_T = np.asfortranarray(bs[self.ib].T)   # former `@ boresight_body[ia].T`: same BLAS call)
        self.z_f, self.z_i = np.zeros(0), np.zeros(2 * n_sig + 1, np.int64)
        self.w_idx3 = np.arange(3)
        # omega [, alpha] and baselines (the smoother's sub-state)
        self.sub_w_b = np.concatenate([np.arange(max(self.st.n_rate, 3)), self.all_b_idx])
        self.ix_sub = np.ix_(self.sub_w_b, self.sub_w_b)

    def set_residual_buffers(self, ints: np.ndarray, floats: np.ndarray) -> None:
        """The residual records' buffers (res_i (6, cap), res_f (4, cap)) and record_epoch's record of them."""
        self.res_i, self.res_f = ints, floats
        self.res_buffers = tuple(ResidualBuffers(ints=ints, floats=floats, lookup=self.w_lookup))

    def _init_update_records(self):
        """The run-constant records of the compiled update kernels (gnssatt.attitude.update_records), as plain
        tuples: the state layout, the noise model (its arrays updated in place), the newcomer rounding limits, the
        output settings and buffers."""
        s, st = self.s, self.st
        self.update_layout = StateLayout.plain(b_idx=self.b_idx, clk=st.clk, pclk=st.pclk, bias=st.bias,
                                               amb_index=st.amb_index, n_fixed_part=st.n_fixed_part)
        self.noise_model = NoiseModel.plain(
            est_var_code_m2=self.est_var_c, est_var_phase_m2=self.est_var_p, est_n=self.est_n,
            floor_code_m2=float(self.var_c_floor), floor_phase_m2=float(self.var_p_floor), min_epochs=NOISE_MIN_EPOCHS,
            estimate=bool(s.noise.noise_estimation), gamma=self.gamma, cn0_growth=bool(self.cn0_growth),
            elevation_weighting=bool(self.elev_w), mp_model=bool(self.mp_model), mp_sigma_m=self.mp_sig)
        self.rounding_limits = RoundingLimits.plain(max_sigma_cyc=float(s.ambiguity.new_amb_round_sigma_cyc),
                                                    max_frac_cyc=float(s.ambiguity.new_amb_round_frac_cyc),
                                                    var_cyc2=PSEUDO_VAR_CYC2)
        self.output_settings = OutputSettings.plain(all_b_idx=self.all_b_idx, dynamic=self.dynamic,
                                                    fixed_min_sats=int(s.ambiguity.fixed_min_sats))
        self.output_buffers = OutputBuffers.plain(b_ecef_m=self.out_b, P_b_m2=self.out_P, omega_ecef_rad_s=self.out_w,
                                                  ok=self.out_ok, fixed=self.out_fixed, n_sats=self.out_n)

    def mark_segment_start(self, k: int) -> None:
        """The smoother's segment restarts at epoch k (a reset of omega or of a baseline's covariance)."""
        if self.record:
            self.sm_start[k] = True
