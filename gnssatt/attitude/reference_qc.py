"""The attitude filter's quality control of one epoch in readable numpy (the "quality control" box of seed 000
Fig. 2): antenna-frame elevation mask, C/N0 and PCV editing, the epoch clock from code and its jump test, half
cycles, triple differences with their median tests, and the masks of the ambiguity bookkeeping.

This is the specification of the compiled kernels gnssatt.attitude.qc_kernels.qc_epoch and td_checks (the filter
runs the kernels; tests/attitude/test_qc_kernels.py checks them against this module). Plain numpy, no numba.
Reason codes as gnssatt.attitude.filter.REASONS: 0 used, 1 no geometry, 2 below the antenna mask, 3 low C/N0,
4 code TD outlier, 5 phase TD (slip), 6 half cycle, 8 not available, 10 empty PCV bin.

Implements: seed 000 Table 2 (elevation mask in the antenna frame, C/N0 mask, cycle-slip detection by triple
differences and LLI, receiver clock handling) and sec. 2 (one ambiguity state per continuous phase arc).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["QcLimits", "SdEpoch", "AntennaView", "PreviousEpoch", "ClockState", "AmbiguityBook",
           "TripleDifferences", "EpochClock", "QcEpoch", "antenna_frame_elevations", "edit_observations",
           "epoch_clock", "triple_differences", "triple_difference_tests", "ambiguity_bookkeeping", "qc_epoch",
           "COMMON_PHASE_JUMP_M"]

R_ANTENNA, R_CN0, R_TD_CODE, R_HALF, R_PCV_EMPTY = 2, 3, 4, 6, 10
#: a baseline's median phase TD this far from its median code TD is a common (phase clock) jump (m)
COMMON_PHASE_JUMP_M = 1000.0


@dataclass(frozen=True)
class QcLimits:
    """Editing thresholds (gnssatt.attitude.settings; seed 000 Table 2)."""
    el_mask_ant_rad: float          # elevation mask in the antenna frame, for baselines that were ever fixed
    clock_jump_m: float             # epoch clock off its prediction by more: a clock jump
    td_max_dt_s: float              # longest epoch gap over which triple differences and the drift are formed
    td_code_m: float                # code TD off its median by more: outlier
    td_phase_cyc: float             # phase TD off its median by more (cycles): slip
    max_gap_s: float                # an ambiguity unused for longer is dropped
    wavelength_m: np.ndarray        # (n_sig,)


@dataclass
class SdEpoch:
    """One epoch's single differences (n_bl, n_sat, n_sig) and their flags before the QC."""
    sdc_m: np.ndarray               # code SD
    sdp_m: np.ndarray               # phase SD (m)
    avail_p: np.ndarray             # phase available (and its code)
    lli: np.ndarray                 # int8 loss-of-lock bits (1 slip, 2 half cycle)
    low_cn0: np.ndarray             # below the C/N0 mask
    pcv_empty: np.ndarray           # in an empty bin of the PCV map
    reason0: np.ndarray             # reasons set before (0 usable, 1 no geometry, 8 not available)
    clock_factor: np.ndarray        # (n_sat,) 1 - rho_dot / c: the clock partial of each satellite's SD
    baseline_ok: np.ndarray         # (n_bl,) both antennas of the baseline have data


@dataclass
class AntennaView:
    """Where each satellite lies for the antennas: asn_a_rad, asn_b_rad (n_sat, n_bl) elevation above the antenna
    plane of the baseline's first / second antenna, az_rad (n_sat,) azimuth; mask_on when an attitude is known,
    ever_fixed (n_bl,) baselines fixed before (the mask applies to them), pcv_on: PCV map in use."""
    asn_a_rad: np.ndarray
    asn_b_rad: np.ndarray
    az_rad: np.ndarray
    mask_on: bool
    ever_fixed: np.ndarray
    pcv_on: bool


@dataclass
class PreviousEpoch:
    """The memory of the triple differences: the previous epoch's clock-corrected SDs (NaN where unavailable),
    its predicted geometry ub_m (n_bl, n_sat) = b . u, and whether it is the epoch just before (gap <=
    td_max_dt_s); triple differences are formed when do_td."""
    sdc_m: np.ndarray
    sdp_m: np.ndarray
    ub_m: np.ndarray
    consecutive: bool
    do_td: bool


@dataclass
class ClockState:
    """(n_bl,) last estimated epoch clock (m; NaN before the first), its time (s) and drift (m/s)."""
    clock_m: np.ndarray
    time_s: np.ndarray
    rate_m_s: np.ndarray

    def as_array(self) -> np.ndarray:
        """(3, n_bl) rows clock, time, rate (the layout of qc_kernels.qc_epoch's clk_state)."""
        return np.stack([self.clock_m, self.time_s, self.rate_m_s])


@dataclass
class AmbiguityBook:
    """amb_index (n_bl, n_sat, n_sig) state index of each phase's ambiguity (-1 none), amb_last_t_s (n_amb,) last
    time each was in an update (row a = state n_fixed_part + a)."""
    amb_index: np.ndarray
    amb_last_t_s: np.ndarray
    n_fixed_part: int


@dataclass
class TripleDifferences:
    """Epoch-to-epoch differences of the clock-corrected SDs minus the predicted geometry change (n_bl, n_sat,
    n_sig; NaN where not formed), which of them enter the medians (used observations), and the medians (n_bl,
    n_sig) over the satellites (NaN if none)."""
    code_m: np.ndarray
    phase_m: np.ndarray
    code_ok: np.ndarray
    phase_ok: np.ndarray
    median_code_m: np.ndarray
    median_phase_m: np.ndarray


@dataclass
class EpochClock:
    """(n_bl,) epoch clock used (estimate, else the prediction, else 0), its prediction, jump flags."""
    clock_m: np.ndarray
    predicted_m: np.ndarray
    jump: np.ndarray


@dataclass
class QcEpoch:
    """Everything the QC of one epoch decides (shapes (n_bl, n_sat, n_sig) unless noted)."""
    el_w_rad: np.ndarray            # (n_bl, n_sat) antenna-frame elevation (lower of the two antennas)
    el_ant_rad: np.ndarray          # (n_bl, n_sat) el_w where an attitude exists, else NaN (residual records)
    az_ant_rad: np.ndarray          # (n_bl, n_sat)
    reason: np.ndarray
    use_c: np.ndarray
    use_p: np.ndarray
    slip: np.ndarray
    sdc_c_m: np.ndarray             # SDs minus clock_factor x epoch clock
    sdp_c_m: np.ndarray
    clock: EpochClock
    clock_state: ClockState         # after this epoch
    td: TripleDifferences
    n_common_jumps: int             # (baseline, signal) with a common phase jump > COMMON_PHASE_JUMP_M
    ev_td: np.ndarray               # slips found by the TD test without an LLI
    ev_lli: np.ndarray              # LLI slips of phases with a state or a previous epoch
    n_gap: int                      # states restarted because no TD could check them
    drop: np.ndarray                # ambiguity states to drop
    need: np.ndarray                # used phases without a state


def antenna_frame_elevations(view: AntennaView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(el_w, el_ant, az_ant) (n_bl, n_sat): the lower of the two antennas' elevations (NaN-ignoring), and el_w /
    the azimuth where view.mask_on, else NaN. Implements: seed 000 Table 2 elevation mask (antenna frame)."""
    el_w = np.fmin(view.asn_a_rad, view.asn_b_rad).T
    n_bl, n_sat = el_w.shape
    if view.mask_on:
        return el_w, el_w.copy(), np.broadcast_to(view.az_rad[None, :], (n_bl, n_sat)).copy()
    return el_w, np.full((n_bl, n_sat), np.nan), np.full((n_bl, n_sat), np.nan)


def edit_observations(sd: SdEpoch, view: AntennaView, el_w_rad: np.ndarray,
                      limits: QcLimits) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(reason, use_c, use_p, slip): the first reason of each observation in the order antenna mask (2, baselines
    ever fixed, when an attitude exists), empty PCV bin (10), low C/N0 (3); use_c where none; use_p = use_c and a
    phase, except half cycles (LLI bit 2: reason 6, phase unused, code kept); slip = LLI bit 1 on a phase.
    Implements: seed 000 Table 2 (masks and LLI)."""
    reason = sd.reason0.copy()
    if view.mask_on:
        below = view.ever_fixed[:, None] & ~(el_w_rad >= limits.el_mask_ant_rad)
        reason = np.where((reason == 0) & below[:, :, None], R_ANTENNA, reason)
    if view.pcv_on:
        reason = np.where((reason == 0) & sd.pcv_empty, R_PCV_EMPTY, reason)
    reason = np.where((reason == 0) & sd.low_cn0, R_CN0, reason)
    use_c = reason == 0
    half = ((sd.lli & 2) != 0) & sd.avail_p
    reason = np.where((reason == 0) & half, R_HALF, reason)
    use_p = use_c & sd.avail_p & ~half
    slip = ((sd.lli & 1) != 0) & sd.avail_p
    return reason, use_c, use_p, slip


def epoch_clock(sd: SdEpoch, ub_m: np.ndarray, use_c: np.ndarray, state: ClockState, t_s: float,
                limits: QcLimits) -> tuple[EpochClock, ClockState]:
    """The epoch clock of each baseline: the median over used satellites of (SD code of signal 1 + b.u) /
    clock_factor, else the prediction clock + drift x (t - t_clock) (0 without one); a jump where it is off the
    prediction by more than limits.clock_jump_m; the drift follows (gain 0.1) over gaps <= td_max_dt_s without a
    jump. Implements: seed 000 Table 2 receiver clock handling (SD clocks estimated per epoch)."""
    raw = (sd.sdc_m[:, :, 0] + ub_m) / sd.clock_factor[None, :]
    with np.errstate(all="ignore"), _no_warnings():
        est = np.nanmedian(np.where(use_c[:, :, 0], raw, np.nan), axis=1)
    have = np.isfinite(est)
    pred = state.clock_m + state.rate_m_s * (t_s - state.time_s)
    clk = np.where(have, est, np.where(np.isnan(pred), 0.0, pred))
    jump = have & np.isfinite(pred) & (np.abs(clk - pred) > limits.clock_jump_m) & sd.baseline_ok
    upd = have & sd.baseline_ok
    dt = t_s - state.time_s
    rate_ok = upd & ~jump & np.isfinite(state.clock_m) & (dt > 0) & (dt <= limits.td_max_dt_s)
    rate = np.where(rate_ok, state.rate_m_s + 0.1 * ((clk - state.clock_m) / np.where(dt > 0, dt, 1.0)
                                                     - state.rate_m_s), state.rate_m_s)
    new = ClockState(np.where(upd, clk, state.clock_m), np.where(upd, t_s, state.time_s), rate)
    return EpochClock(clk, pred, jump), new


def triple_differences(sdc_c_m: np.ndarray, sdp_c_m: np.ndarray, prev: PreviousEpoch, ub_m: np.ndarray,
                       use_c: np.ndarray, use_p: np.ndarray) -> tuple[TripleDifferences, int]:
    """(TripleDifferences, n common phase jumps): TD = SD_c(t) - SD_c(t-1) + (b.u)(t) - (b.u)(t-1) (the SD
    model is -b.u + clock + ambiguity), medians over the used satellites; a common jump where a baseline's median
    phase TD is more than COMMON_PHASE_JUMP_M off its median code TD. Without do_td: NaN, nothing ok.
    Implements: seed 000 Table 2 cycle-slip detection by triple differences."""
    shape = sdc_c_m.shape
    if not prev.do_td:
        nan3, nan2, no = np.full(shape, np.nan), np.full((shape[0], shape[2]), np.nan), np.zeros(shape, bool)
        return TripleDifferences(nan3, nan3.copy(), no, no.copy(), nan2, nan2.copy()), 0
    dgeo = -(ub_m - prev.ub_m)[:, :, None]
    td_c = sdc_c_m - prev.sdc_m - dgeo
    td_p = sdp_c_m - prev.sdp_m - dgeo
    ok_c, ok_p = np.isfinite(td_c) & use_c, np.isfinite(td_p) & use_p
    with np.errstate(all="ignore"), _no_warnings():
        mc = np.nanmedian(np.where(ok_c, td_c, np.nan), axis=1)
        mp = np.nanmedian(np.where(ok_p, td_p, np.nan), axis=1)
    d = mp - mc
    n_common = int(np.sum(np.abs(np.where(np.isnan(d), 0.0, d)) > COMMON_PHASE_JUMP_M))
    return TripleDifferences(td_c, td_p, ok_c, ok_p, mc, mp), n_common


def triple_difference_tests(td: TripleDifferences, sd: SdEpoch, reason: np.ndarray, use_c: np.ndarray,
                            slip: np.ndarray, limits: QcLimits) -> tuple[np.ndarray, ...]:
    """(reason, use_c, slip, ev_td) after the TD tests: a used code TD off its median by more than td_code_m is an
    outlier (reason 4, code unused); any available phase TD off its median by more than td_phase_cyc wavelengths
    is a slip; ev_td = such slips without an LLI. Implements: seed 000 Table 2 (TD slip / outlier tests)."""
    mc = np.where(np.isnan(td.median_code_m), 0.0, td.median_code_m)[:, None, :]
    mp = np.where(np.isnan(td.median_phase_m), 0.0, td.median_phase_m)[:, None, :]
    bad_code = td.code_ok & (np.abs(td.code_m - mc) > limits.td_code_m)
    checked = np.isfinite(td.phase_m) & sd.avail_p
    bad_phase = checked & (np.abs(td.phase_m - mp) > limits.td_phase_cyc * limits.wavelength_m[None, None, :])
    reason = np.where((reason == 0) & bad_code, R_TD_CODE, reason)
    ev_td = bad_phase & ((sd.lli & 1) == 0)
    return reason, use_c & ~bad_code, slip | bad_phase, ev_td


def ambiguity_bookkeeping(sd: SdEpoch, slip: np.ndarray, use_p: np.ndarray, td: TripleDifferences,
                          prev: PreviousEpoch, book: AmbiguityBook, t_s: float,
                          limits: QcLimits) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
    """(ev_lli, n_gap, drop, need): LLI slips of phases with a state or a previous epoch; a state restarts on a
    slip or where no TD could check its phase (n_gap of those without a slip), is dropped when its phase is gone
    or unused for longer than max_gap_s; need = used phases without a state.
    Implements: seed 000 sec. 2 (one ambiguity per continuous arc) and Table 2 (slip handling)."""
    have = book.amb_index >= 0
    lli_slip = ((sd.lli & 1) != 0) & sd.avail_p
    cont = np.isfinite(prev.sdp_m) if prev.consecutive else np.zeros(have.shape, bool)
    ev_lli = lli_slip & (have | cont)
    checked = np.isfinite(td.phase_m)
    restart = have & sd.avail_p & (slip | ~checked)
    n_gap = int((have & sd.avail_p & ~slip & ~checked).sum())
    last_t = np.full(have.shape, np.inf)
    last_t[have] = book.amb_last_t_s[book.amb_index[have] - book.n_fixed_part]
    stale = have & ~use_p & (last_t < t_s - limits.max_gap_s)
    drop = restart | (have & ~sd.avail_p) | stale
    return ev_lli, n_gap, drop, use_p & ~have


def qc_epoch(sd: SdEpoch, view: AntennaView, ub_m: np.ndarray, prev: PreviousEpoch, clock: ClockState,
             book: AmbiguityBook, t_s: float, limits: QcLimits) -> QcEpoch:
    """The quality control of one epoch, in the filter's order: elevations, editing, epoch clock, clock-corrected
    SDs, triple differences and their tests, ambiguity bookkeeping (the noise estimators of
    gnssatt.attitude.reference_noise run on the TDs between the TDs and their tests; they change neither).
    ub_m (n_bl, n_sat): this epoch's predicted geometry b . u. Implements: seed 000 Fig. 2 "quality control",
    Table 2."""
    el_w, el_ant, az_ant = antenna_frame_elevations(view)
    reason, use_c, use_p, slip = edit_observations(sd, view, el_w, limits)
    clk, clock_after = epoch_clock(sd, ub_m, use_c, clock, t_s, limits)
    corr = sd.clock_factor[None, :, None] * clk.clock_m[:, None, None]
    sdc_c, sdp_c = sd.sdc_m - corr, sd.sdp_m - corr
    td, n_common = triple_differences(sdc_c, sdp_c, prev, ub_m, use_c, use_p)
    ev_td = np.zeros(reason.shape, bool)
    if prev.do_td:
        reason, use_c, slip, ev_td = triple_difference_tests(td, sd, reason, use_c, slip, limits)
    ev_lli, n_gap, drop, need = ambiguity_bookkeeping(sd, slip, use_p, td, prev, book, t_s, limits)
    return QcEpoch(el_w, el_ant, az_ant, reason, use_c, use_p, slip, sdc_c, sdp_c, clk, clock_after, td, n_common,
                   ev_td, ev_lli, n_gap, drop, need)


class _no_warnings:
    """np.nanmedian warns on all-NaN slices (the NaN result is what is wanted)."""

    def __enter__(self):
        import warnings
        self._cm = warnings.catch_warnings()
        self._cm.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        return self._cm.__exit__(*exc)
