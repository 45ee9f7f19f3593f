"""Record layouts of the compiled quality-control kernels: gnssatt.attitude.qc_kernels.qc_epoch, td_checks and
record_epoch, and gnssatt.attitude.kernels.white_noise_update. Each layout is a `typing.NamedTuple` defined here
once, one comment per field (unit, shape, frame); the names and the grouping follow the readable records of the
specification (gnssatt.attitude.reference_qc, reference_noise, reference_records) where they fit.

Shapes: n_bl baselines, n_sat satellites, n_sig signals, n_blk epochs of an SdBlock; "(bl, sat, sig)" is
(n_bl, n_sat, n_sig), "(blk, bl, sat, sig)" (n_blk, n_bl, n_sat, n_sig).

How they travel (bench/design/qc_record_calls.py measured the choices): a record goes to a kernel as a plain tuple
in field order (numba types a plain tuple by a C fingerprint, a namedtuple through Python at ~1 us more per call)
and the kernel unpacks it in one line in field order (tests/attitude/test_qc_records.py checks every such line
against `_fields`). Records of arrays that live for the whole run (limits, work arrays, the previous-epoch memory,
the epoch clock, the noise estimator's state, all mutated in place) are built once per run, by keyword, by
gnssatt.attitude.filter_state.FilterRun (`tuple(QcLimits(...))`), the single differences once per SdBlock
(SdBlockQc, SdBlockFlags: the kernels take the epoch's row EpochStep.i themselves, ~0.14 us per view saved). The
per-epoch ones (AntennaView, EpochStep, AmbiguityBook, OutputEpoch, PostFit) are built by keyword too, through the
keyword-only builders below (`epoch_step(i=..., ...)` returns the plain tuple in ~0.1-0.2 us;
`tuple(EpochStep(...))` takes ~0.5-0.7).
Each kernel takes only records whose fields it mostly uses: every field is one more argument to type and unbox
(~70 ns). Each field always has one numba type (float, bool, int; arrays C-contiguous, np.nonzero's index arrays
as numpy gives them), so each kernel compiles the few signatures its warm_up covers.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssatt.attitude.record_tuples import plain_tuple_builder

__all__ = ["QcLimits", "SdBlockQc", "SdBlockFlags", "AntennaView", "EpochStep", "EpochMemory", "EpochClock",
           "QcWork", "AmbiguityBook", "TripleDifferences", "WhiteNoise", "OutputEpoch", "PostFit", "ResidualBuffers",
           "antenna_view", "epoch_step", "ambiguity_book", "output_epoch", "post_fit"]


class QcLimits(NamedTuple):
    """Editing thresholds of seed 000 Table 2 (gnssatt.attitude.settings; reference_qc.QcLimits); run constant."""
    el_mask_ant_rad: float          # elevation mask in the antenna frame (baselines ever fixed), rad
    clock_jump_m: float             # epoch clock off its prediction by more: a clock jump, m
    td_max_dt_s: float              # longest epoch gap of triple differences and of the clock drift, s
    td_code_m: float                # code TD off its median by more: outlier, m
    td_phase_cyc: float             # phase TD off its median by more: slip, cycles
    max_gap_s: float                # an ambiguity unused for longer is dropped, s
    wavelength_m: np.ndarray        # (n_sig,) carrier wavelengths, m


class SdBlockQc(NamedTuple):
    """The single differences (second antenna minus first) and their editing before the QC, over the epochs of the
    current SdBlock (gnssatt.attitude.sd_block; an epoch is row EpochStep.i = k - k0): reference_qc.SdEpoch of
    each epoch but avail_p, lli (SdBlockFlags) and pcv_empty (AntennaView); read by qc_epoch; once per block."""
    sdc_m: np.ndarray               # (blk, bl, sat, sig) SD code, m
    sdp_m: np.ndarray               # (blk, bl, sat, sig) SD phase, m
    low_cn0: np.ndarray             # (blk, bl, sat, sig) bool: C/N0 below the signal's mask
    reason0: np.ndarray             # (blk, bl, sat, sig) int64 reasons set before (0 usable, 1 local horizon, 8 no
                                    # SD)
    clock_factor: np.ndarray        # (n_blk, n_sat) 1 - rho_dot / c: the clock partial of each satellite's SD
    baseline_ok: np.ndarray         # (n_blk, n_bl) bool: both antennas of the baseline have data


class SdBlockFlags(NamedTuple):
    """Which single differences exist and their loss-of-lock bits, over the epochs of the current SdBlock
    (reference_qc.SdEpoch.avail_p / lli, reference_records.EpochFlags.avail_c / avail_p): read by the three QC
    kernels; once per block."""
    avail_c: np.ndarray             # (blk, bl, sat, sig) bool: SD code exists (both antennas, geometry)
    avail_p: np.ndarray             # (blk, bl, sat, sig) bool: SD phase exists too
    lli: np.ndarray                 # (blk, bl, sat, sig) loss-of-lock bits of either antenna (1 slip, 2 half cycle)


class AntennaView(NamedTuple):
    """Where each satellite lies for the antennas, and the predicted geometry (reference_qc.AntennaView and the
    ub_m argument of reference_qc.qc_epoch); per epoch."""
    asn_rad: np.ndarray             # (2, n_sat, n_bl) elevation above the antenna plane of the baseline's first /
                                    # second antenna (arcsin of the boresight products; NaN where unknown), rad
    az_rad: np.ndarray              # (n_sat,) azimuth in the body frame, rad (empty while mask_on is False)
    mask_on: bool                   # an attitude is known: the antenna-frame mask applies
    ever_fixed: np.ndarray          # (n_bl,) bool: baselines fixed before (the antenna-frame mask is theirs)
    pcv_on: bool                    # phases in empty PCV bins are rejected
    pcv_empty: np.ndarray           # (bl, sat, sig) bool: phase in an empty bin of the PCV map
    ub_m: np.ndarray                # (n_bl, n_sat) predicted geometry b . u of this epoch (ECEF), m


class EpochStep(NamedTuple):
    """The epoch's row in the SdBlock records, its time and its link to the previous epoch (reference_qc.PreviousEpoch's
    flags); per epoch."""
    i: int                          # row of the epoch in SdBlockQc / SdBlockFlags (k - k0)
    t_s: float                      # epoch time, s since the first epoch
    consecutive: bool               # the previous epoch is at most td_max_dt_s before
    do_td: bool                     # triple differences are formed (consecutive, and a previous output exists)


class EpochMemory(NamedTuple):
    """The previous epoch as the triple differences need it (reference_qc.PreviousEpoch's arrays): written by
    record_epoch in place; run constant."""
    prev_sdc_m: np.ndarray          # (bl, sat, sig) previous clock-corrected SD code (NaN where none), m
    prev_sdp_m: np.ndarray          # (bl, sat, sig) previous clock-corrected SD phase (NaN where none), m
    prev_ub_m: np.ndarray           # (n_bl, n_sat) previous b . u of the output baselines, m


class EpochClock(NamedTuple):
    """The epoch clock of each baseline (reference_qc.ClockState carried from epoch to epoch, EpochClock of this
    epoch): written by qc_epoch in place; run constant."""
    clock_state: np.ndarray         # (3, n_bl) last estimated epoch clock (m; NaN before the first), its time (s)
                                    # and drift (m/s): reference_qc.ClockState.as_array()
    clock_m: np.ndarray             # (2, n_bl) this epoch's clock used, its prediction, m
    jump: np.ndarray                # (n_bl,) bool: clock jump


class QcWork(NamedTuple):
    """The QC's per-epoch outputs (reference_qc.QcEpoch), in work arrays overwritten every epoch (the filter's
    per-epoch names are views of their rows); run constant."""
    el_rad: np.ndarray              # (3, n_bl, n_sat) el_w (lower antenna-frame elevation), el_ant, az_ant (NaN
                                    # without an attitude), rad
    reason: np.ndarray              # (bl, sat, sig) int64 reason code (gnssatt.attitude.filter_state.REASONS)
    masks: np.ndarray               # (9, bl, sat, sig) bool: use_c, use_p, slip, td_c_ok, td_p_ok (qc_epoch), TD
                                    # slips without LLI, LLI slips to report, states to drop, used phases needing
                                    # a state (td_checks)
    values_m: np.ndarray            # (4, bl, sat, sig) sdc_c, sdp_c (SDs minus clock_factor x the epoch clock),
                                    # td_c, td_p (triple differences; NaN where not formed), m
    median_td_m: np.ndarray         # (2, n_bl, n_sig) median over the satellites of td_c, td_p (NaN if none), m


class AmbiguityBook(NamedTuple):
    """The ambiguity states' index map and ages (reference_qc.AmbiguityBook); per epoch (states come and go)."""
    amb_index: np.ndarray           # (bl, sat, sig) int64 state index of each phase's ambiguity, -1 none
    amb_last_t_s: np.ndarray        # (n_amb,) last time each ambiguity was in an update (row a: state
                                    # n_fixed_part + a), s
    n_fixed_part: int               # the first ambiguity's state index


class TripleDifferences(NamedTuple):
    """Epoch-to-epoch differences of the clock-corrected SDs minus the predicted geometry change, which of them
    enter the medians, and the medians (reference_qc.TripleDifferences; in the filter rows of QcWork)."""
    code_m: np.ndarray              # (bl, sat, sig) code TD, m
    phase_m: np.ndarray             # (bl, sat, sig) phase TD, m
    code_ok: np.ndarray             # (bl, sat, sig) bool: used code with a TD
    phase_ok: np.ndarray            # (bl, sat, sig) bool: used phase with a TD
    median_code_m: np.ndarray       # (n_bl, n_sig) median code TD over the satellites (NaN if none), m
    median_phase_m: np.ndarray      # (n_bl, n_sig) median phase TD, m


class WhiteNoise(NamedTuple):
    """The white-noise estimator (reference_noise.NoiseEstimates' white part, NoiseSettings.memory_epochs): state
    updated in place; run constant."""
    var_code_m2: np.ndarray         # (n_sig,) white variance of one SD code at 45 dB-Hz, m^2
    var_phase_m2: np.ndarray        # (n_sig,) white variance of one SD phase, m^2
    n_white: np.ndarray             # (n_sig,) float: epochs in those means
    memory_epochs: float            # exponential memory of the means, epochs
    enabled: bool                   # the estimator runs (settings noise.noise_estimation)


class OutputEpoch(NamedTuple):
    """The epoch as the residual records and the triple-difference memory need it, besides its SdBlockFlags row;
    per epoch."""
    k: int                          # epoch index
    i: int                          # row of the epoch in SdBlockFlags (k - k0)
    cn0_dbhz: np.ndarray            # (bl, sat, sig) the lower C/N0 of the two antennas, dB-Hz
    u: np.ndarray                   # (n_sat, 3) lines of sight (ECEF, unit)
    b_out_m: np.ndarray             # (n_bl, 3) the epoch's output baselines (ECEF), m


class PostFit(NamedTuple):
    """The update's post-fit residuals and the observations of its rows; per epoch (empty without an update)."""
    post_m: np.ndarray              # (m,) post-fit residual of each row (code rows, then phase rows), m
    jc: np.ndarray                  # (m_code,) int64 baseline of each code row
    sc: np.ndarray                  # (m_code,) satellite
    fc: np.ndarray                  # (m_code,) signal
    jp: np.ndarray                  # (m_phase,) int64 baseline of each phase row
    sp: np.ndarray                  # (m_phase,) satellite
    fp: np.ndarray                  # (m_phase,) signal


class ResidualBuffers(NamedTuple):
    """Rows of residuals.csv appended epoch by epoch (gnssatt.attitude.boxes.output); rebuilt when they grow."""
    ints: np.ndarray                # (6, cap) int64 epoch, bl, sat, sig, kind (0 code, 1 phase), reason
    floats: np.ndarray              # (4, cap) el_ant_deg, az_ant_deg, cn0_dbhz, residual_m
    lookup: np.ndarray              # (2, bl, sat, sig) work: the residual of each code / phase observation, m


antenna_view = plain_tuple_builder(AntennaView)
epoch_step = plain_tuple_builder(EpochStep)
ambiguity_book = plain_tuple_builder(AmbiguityBook)
output_epoch = plain_tuple_builder(OutputEpoch)
post_fit = plain_tuple_builder(PostFit)
