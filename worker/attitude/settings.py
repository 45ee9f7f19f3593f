"""Settings of the attitude filter: seed 000 Table 1 (process and measurement noise) and Table 2 (editing limits)
as defaults, every value with its unit in the name.
"""
from __future__ import annotations

from dataclasses import dataclass, field

#: Signals the filter knows, per name: (code, phase, C/N0 RINEX 3 codes in order of preference, carrier Hz).
SIGNALS: dict[str, dict] = {
    "L1": {"code": ["C1C"], "phase": ["L1C"], "snr": ["S1C"], "freq_hz": 1575.42e6},
    "L2": {"code": ["C2W", "C2L", "C2X", "C2S"], "phase": ["L2W", "L2L", "L2X", "L2S"],
           "snr": ["S2W", "S2L", "S2X", "S2S"], "freq_hz": 1227.60e6},
}


@dataclass
class AttitudeSettings:
    """Every tuning constant of the filter. Defaults: seed 000 Tables 1-2 unless noted."""

    mode: str = "dynamic"                       # dynamic (common angular velocity) | kinematic (baseline noise)
    signals: list = field(default_factory=lambda: ["L1", "L2"])
    # --- Table 1: measurement noise of single differences ---
    sigma_code_m: float = 0.30
    sigma_phase_m: float = 0.003
    weighting: str = "none"                     # none | cn0 | elevation (antenna frame)
    separate_phase_clock: bool = True           # phase gets its own white-noise clock per signal, so the phase
                                                # enters as double differences and code multipath cannot leak
                                                # into the baseline through the common-mode ambiguity
    noise_estimation: bool = True               # per-signal white-noise sigma from the triple differences (honest
                                                # sigmas when the receiver is noisier than Table 1 says)
    noise_cn0_growth: bool = True               # white-noise variance x 10^((45 - C/N0)/10) (tracking-loop
                                                # jitter ~ 1/sqrt(C/N0)); same as weighting "cn0"
    # time-correlated errors of one SD (multipath, uncalibrated PCV/PCO): sigma (boresight, antenna horizon) m,
    # growing with the square of the off-boresight angle; (0, 0) switches the term off (Table 1: white only)
    sigma_multipath_phase_m: tuple = (0.0015, 0.006)
    sigma_multipath_code_m: tuple = (0.15, 0.9)
    multipath_correlation_factor: float = 3.0   # dynamic mode: the correlated variance is multiplied by this,
                                                # ~ the epochs the filter averages over within one correlation
                                                # time, so its averaged contribution is not counted as white
    multipath_adaptive: bool = True             # scale the multipath variance by what the post-fit residuals of
                                                # fixed phases show (300-epoch memory; 1 = the sigmas above)
    # --- Table 1: initial and process noise ---
    sigma0_baseline_m: float = 2.0
    sigma_clock_s: float = 1.0e-6              # white noise, reset each epoch
    sigma0_omega_deg_s: float = 1.0
    sigma_omega_deg_s: float = 0.03             # random walk, per tau
    tau_omega_s: float = 1.0
    sigma0_ambiguity_cyc: float = 500.0
    sigma_baseline_kinematic_m: float = 1.0     # kinematic mode: per baseline component per tau (seed 000 sec. 4.1)
    tau_baseline_s: float = 1.0
    sigma0_code_bias_m: float = 10.0            # inter-signal code bias of a baseline (2nd signal vs 1st), constant
    rk4_step_s: float = 1.0
    # --- Table 2: editing limits ---
    elevation_mask_local_deg: float = -90.0
    elevation_mask_antenna_deg: float = 0.0     # applied only once the baseline is fixed
    cn0_mask_dbhz: dict = field(default_factory=lambda: {"L1": 35.0, "L2": 30.0})
    td_code_m: float = 0.50
    td_phase_cyc: float = 0.25
    max_length_error_m: float = 0.03            # ambiguity acceptance: |length - known| (Table 2)
    # --- ambiguity resolution (not in the paper: our choices, with reasons in docs/attitude.md) ---
    min_ratio: float = 0.0                      # 0 = ratio only reported (the paper validates by length)
    ambiguity_search: str = "lambda"            # lambda (MLAMBDA + length, the paper) | constrained (C-LAMBDA with
                                                # the known length, docs/ttff.md; first fixes of a baseline)
    min_ratio_constrained: float = 3.0          # constrained: ratio of the constrained objective to accept
    min_ratio_constrained_joint: float = 1.5    # constrained, >= 2 baselines, none fixed: ratio of the joint
                                                # MC-LAMBDA objective (+ length and angle tests; docs/ttff.md)
    ar_min_ratio_first_fix: float = 0.0         # a first fix of a baseline also needs this ratio
    max_angle_error_m: float = 0.03             # a first fix must agree with every baseline already fixed: angle
                                                # between them vs the body angle within atan(this / l_min) (1.6 deg
                                                # at 1.05 m); 0 switches the test off
    ar_min_dd: int = 6                          # DD ambiguities (all signals) before a first MLAMBDA attempt: with
                                                # fewer, several integer vectors pass the 3 cm length test
    ar_min_sats: int = 4                        # satellites with phase on a baseline before an AR attempt
    fixed_min_sats: int = 4                     # fixed satellites in the update for an epoch to count as fixed
    new_amb_round_sigma_cyc: float = 0.08       # a fixed baseline fixes a newcomer by rounding below this sigma
    new_amb_round_frac_cyc: float = 0.2         # ... and when the float is within this of an integer
    max_gap_s: float = 10.0                     # an ambiguity unobserved longer than this restarts as float
    innovation_gate_sigma: float = 8.0          # phase innovations beyond this (normalised) -> re-check / reject
    # --- initial attitude ---
    initial_attitude: str = "earth-pointing"    # earth-pointing (spacecraft) / level (terrestrial) | given
    initial_q_body_from_ecef: list | None = None
    # --- attitude ---
    attitude_method: str = "quest"              # quest (weights by baseline length) | triad
    pcv_maps: dict = field(default_factory=dict)   # (first, second, freq) -> map dict (CONVENTIONS layout)
    calibrated_baselines: dict = field(default_factory=dict)  # (first, second) -> body vector (3,)
