"""Record layouts of the compiled measurement-update kernels (gnssatt.attitude.update_kernels and
gnssatt.attitude.kernels.measurement_rows): each kernel takes a few of these records instead of dozens of arrays.

Each layout is a `typing.NamedTuple`, defined once here, with its fields in the order the kernels unpack them
(tests/attitude/test_update_records.py checks every unpacking and every returned tuple against `_fields`). The
names and the grouping follow the readable specification, gnssatt.attitude.reference_update (UsedRows,
StateLayout, UpdateObs, VarianceModel, FixState, RoundingLimits, epoch_outputs); NoiseModel holds what the
filter derives VarianceModel from (reference_update.white_variances).

Python callers pass a record as a plain tuple, not as the NamedTuple: numba types a plain tuple of arrays by its C
fingerprint, a namedtuple through Python (about twice the dispatch cost). `Record.plain(field=..., ...)` builds
that tuple from the fields by keyword (all required, keyword only): the same tuple as `tuple(Record(...))` at a
fifth of the cost (0.14 vs 0.7 us for nine fields; built per epoch, the difference is ~1 % of the filter's time).
Records that stay the same for a whole run (state layout, noise model, rounding limits, output buffers and
settings) are built once and kept on the FilterRun (gnssatt.attitude.filter_state); the others are built per epoch
(or per call, where the state vector may have been replaced in between). Keep a field's type the same on every call
(float vs int, Python bool, C- vs A-contiguous arrays): each variant compiles a new signature (see the kernels'
warm_up).

Shapes: n_bl baselines, n_sat satellites, n_sig signals, m = m_code + m_phase rows of the update, n_amb ambiguity
states; state indices are int64 into the EKF state x (gnssatt.attitude.filter_state.FilterState).
Implements: the record grouping of gnssatt.attitude.reference_update (seed 000 eq. 1, Table 1, Fig. 2 "measurement
update", "ambiguity resolution", "output").
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssatt.attitude.record_tuples import plain_tuple_builder

__all__ = ["UsedRows", "StateLayout", "UpdateObs", "VarianceModel", "NoiseModel", "FixState", "RoundingLimits",
           "UpdateOutputs", "OutputSettings", "OutputBuffers", "EpochStatus", "RECORDS"]


class UsedRows(NamedTuple):
    """The observations in the update (np.nonzero of use_c, then of use_p); per epoch."""
    jc: np.ndarray      # (m_code,) int64 baseline of each code row
    sc: np.ndarray      # (m_code,) int64 satellite of each code row
    fc: np.ndarray      # (m_code,) int64 signal of each code row
    jp: np.ndarray      # (m_phase,) int64 baseline of each phase row
    sp: np.ndarray      # (m_phase,) int64 satellite of each phase row
    fp: np.ndarray      # (m_phase,) int64 signal of each phase row


class StateLayout(NamedTuple):
    """Where each quantity sits in the state vector; run-constant (amb_index is updated in place when ambiguity
    states are added or dropped)."""
    b_idx: np.ndarray       # (n_bl, 3) int64 baseline components (ECEF, m)
    clk: np.ndarray         # (n_bl,) int64 code clock c dt (m)
    pclk: np.ndarray        # (n_bl, n_sig) int64 phase clock of each signal (the code clock if not separate)
    bias: np.ndarray        # (n_bl, n_sig) int64 code bias of signals 2.. (m); -1 for signal 1
    amb_index: np.ndarray   # (n_bl, n_sat, n_sig) int64 SD ambiguity (cycles); -1 none
    n_fixed_part: int       # index of the first ambiguity state (the states before it never move)


class UpdateObs(NamedTuple):
    """One epoch's observations and geometry for the update rows and variances; per epoch."""
    u: np.ndarray               # (n_sat, 3) unit lines of sight, ECEF
    clock_factor: np.ndarray    # (n_sat,) clock partial 1 - rho_dot / c
    wavelength_m: np.ndarray    # (n_sat, n_sig) carrier wavelength per satellite (m; GLONASS FDMA: per channel)
    sdc_c_m: np.ndarray         # (n_bl, n_sat, n_sig) SD code minus the epoch clock estimate (m)
    sdp_c_m: np.ndarray         # (n_bl, n_sat, n_sig) SD phase minus the epoch clock estimate (m)
    pcv_m: np.ndarray           # (n_bl, n_sat, n_sig) differential PCV correction of the phase (m)
    cn0_dbhz: np.ndarray        # (n_bl, n_sat, n_sig) C/N0 (dB-Hz; NaN unknown), C-contiguous
    el_e_rad: np.ndarray        # (n_bl, n_sat) elevation of the elevation weighting (rad), C-contiguous
    el_w_rad: np.ndarray        # (n_bl, n_sat) antenna-frame elevation of the multipath model (rad), C-contiguous


class VarianceModel(NamedTuple):
    """The measurement noise model of the epoch (seed 000 Table 1 floors, docs/attitude.md); per epoch."""
    var_code_m2: np.ndarray     # (n_sig,) white variance of one code SD at 45 dB-Hz (m^2)
    var_phase_m2: np.ndarray    # (n_sig,) white variance of one phase SD at 45 dB-Hz (m^2)
    gamma: np.ndarray           # (2, n_sig) C/N0 growth exponents (code, phase), updated in place by the QC
    cn0_growth: bool            # white variance x C/N0 factor^gamma
    elevation_weighting: bool   # white variance x clip(1 / sin^2 el_e, 1, 16)
    mp_model: bool              # add the time-correlated (multipath) variance
    mp_sigma_m: np.ndarray      # (4,) multipath sigmas: code boresight, code horizon, phase boresight, horizon (m)
    mp_mult: float              # multiplier of the multipath variance (correlation factor x adaptive scale)


class NoiseModel(NamedTuple):
    """The run's noise model as update_kernels.update_epoch reads it: the white-noise estimator's state (updated in
    place by the quality control), its Table 1 floors, and the constant parts of VarianceModel; run-constant."""
    est_var_code_m2: np.ndarray     # (n_sig,) estimated white variance of one code SD at 45 dB-Hz (m^2)
    est_var_phase_m2: np.ndarray    # (n_sig,) estimated white variance of one phase SD at 45 dB-Hz (m^2)
    est_n: np.ndarray               # (n_sig,) float epochs of triple differences in the estimates
    floor_code_m2: float            # Table 1 code sigma^2 (m^2), the floor of the code estimate
    floor_phase_m2: float           # Table 1 phase sigma^2 (m^2), the floor of the phase estimate
    min_epochs: int                 # epochs of estimates before they replace the floors
    estimate: bool                  # noise estimation on (else the floors)
    gamma: np.ndarray               # (2, n_sig) C/N0 growth exponents (code, phase), updated in place by the QC
    cn0_growth: bool                # white variance x C/N0 factor^gamma
    elevation_weighting: bool       # white variance x clip(1 / sin^2 el_e, 1, 16)
    mp_model: bool                  # add the time-correlated (multipath) variance
    mp_sigma_m: np.ndarray          # (4,) multipath sigmas: code boresight, code horizon, phase boresight, horizon (m)


class FixState(NamedTuple):
    """Which ambiguity states are fixed; per call (the arrays are replaced when states are added or dropped)."""
    amb_fixed: np.ndarray   # (n_amb,) bool fixed to an integer (set in place by the rounding)
    amb_key: np.ndarray     # (n_amb, 3) int64 (baseline, satellite, signal) of each ambiguity state


class RoundingLimits(NamedTuple):
    """Newcomer rounding on a fixed baseline (bootstrapping, Teunissen 1998); run-constant."""
    max_sigma_cyc: float    # DD sigma below this (cycles) ...
    max_frac_cyc: float     # ... and the float DD within this of its integer (cycles)
    var_cyc2: float         # variance of the integer pseudo-measurement (cycles^2)


class UpdateOutputs(NamedTuple):
    """What update_kernels.measurement_update returns (as a plain tuple, in this order); per epoch."""
    cols: np.ndarray            # (m, 5) int64 state columns of each row (-1 none)
    coef: np.ndarray            # (m, 5) their coefficients
    z: np.ndarray               # (m,) observations (m)
    var_m2: np.ndarray          # (m,) measurement variances (m^2)
    v_mp_m2: np.ndarray         # (m,) multipath part of var before mp_mult (m^2)
    post_m: np.ndarray          # (m,) post-fit residuals z - H x+ (m)
    good: bool                  # False: an innovation variance was not positive, x and P unchanged
    mp_num: float               # sum over fixed phase rows of post^2 / (1 - h) - v_white (m^2)
    mp_den: float               # sum over the same rows of v_mp (m^2)
    n_mp: int                   # number of those rows
    n_used: np.ndarray          # (n_bl,) int64 satellites with a phase row
    n_fixed_used: np.ndarray    # (n_bl,) int64 satellites with a fixed phase row
    n_unfixed: np.ndarray       # (n_bl,) int64 phase rows of unfixed ambiguities
    n_fix_rows: np.ndarray      # (n_bl,) int64 phase rows of fixed ambiguities
    ms_fix_m2: np.ndarray       # (n_bl,) mean square post-fit residual of those rows (m^2; NaN none)
    has_fix: np.ndarray         # (n_bl,) bool baseline with a fixed ambiguity state


class OutputSettings(NamedTuple):
    """What store_outputs needs of the run's layout and settings; run-constant."""
    all_b_idx: np.ndarray   # (3 n_bl,) int64 state indices of the baselines, baseline-major
    dynamic: bool           # dynamic mode: omega (the first three states) is output
    fixed_min_sats: int     # fixed satellites a baseline needs to count as fixed now


class OutputBuffers(NamedTuple):
    """The per-epoch output arrays of the run (FilterResult's), written row by row; run-constant."""
    b_ecef_m: np.ndarray            # (n_ep, n_bl, 3) baselines (ECEF, m)
    P_b_m2: np.ndarray              # (n_ep, 3 n_bl, 3 n_bl) their joint covariance (m^2)
    omega_ecef_rad_s: np.ndarray    # (n_ep, 3) angular velocity (ECEF, rad/s; NaN in kinematic mode)
    ok: np.ndarray                  # (n_ep, n_bl) bool a baseline solution exists
    fixed: np.ndarray               # (n_ep, n_bl) bool fixed now and ok
    n_sats: np.ndarray              # (n_ep, n_bl) int64 satellites with a phase used


class EpochStatus(NamedTuple):
    """The epoch's per-baseline status after the ambiguity resolution and the fix monitor; per epoch."""
    baseline_ok: np.ndarray     # (n_bl,) bool both antennas have data (may be a strided view of the SD block)
    n_used: np.ndarray          # (n_bl,) int64 satellites with a phase used
    ever_fixed: np.ndarray      # (n_bl,) bool baseline holds a fixed ambiguity
    n_fixed_used: np.ndarray    # (n_bl,) int64 satellites with a fixed phase used


#: every record of this module (the layout test walks them)
RECORDS = (UsedRows, StateLayout, UpdateObs, VarianceModel, NoiseModel, FixState, RoundingLimits, UpdateOutputs,
           OutputSettings, OutputBuffers, EpochStatus)


for _record in RECORDS:
    _record.plain = staticmethod(plain_tuple_builder(_record, "plain"))
