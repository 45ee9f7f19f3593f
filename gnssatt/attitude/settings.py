"""Settings of the attitude filter: seed 000 Table 1 (process and measurement noise) and Table 2 (editing limits)
as defaults, every value with its unit in the name.
"""
from __future__ import annotations

from dataclasses import dataclass, field

# The signals the filter knows (system, RINEX 3 codes in order of preference, frequency, wavelength, default C/N0
# mask), the historical aliases "L1"/"L2" and the `systems` presets live in the one signal table,
# gnssatt.gnss.signals; they stay importable from here under the names this module always had.
from gnssatt.gnss.signals import SIGNAL_ALIASES, SIGNALS, SYSTEM_SIGNALS  # noqa: F401  (public re-export)


def signal_system(name: str) -> str:
    """System letter (G, E, C, J) of a signal name of SIGNALS."""
    return SIGNALS[name]["system"]


def effective_signals(settings: "AttitudeSettings") -> list[str]:
    """The filter's signals: `settings.signals`, or with `settings.systems` the preset pair of every system in
    that order (SYSTEM_SIGNALS). Raises ValueError for an unknown signal or system, or a repeated signal."""
    if settings.systems:
        unknown = [x for x in settings.systems if x not in SYSTEM_SIGNALS]
        if unknown:
            raise ValueError(f"systems {unknown} not supported (G, E, C, J)")
        sig = [name for x in dict.fromkeys(settings.systems) for name in SYSTEM_SIGNALS[x]]
    else:
        sig = list(settings.signals)
    unknown = [x for x in sig if x not in SIGNALS]
    if unknown:
        raise ValueError(f"signals {unknown} unknown (known: {', '.join(SIGNALS)})")
    canon = [SIGNAL_ALIASES.get(x, x) for x in sig]
    if len(set(canon)) != len(canon):
        raise ValueError(f"signals {sig} repeat a signal")
    return sig


def cn0_mask_of(settings: "AttitudeSettings", name: str) -> float:
    """C/N0 mask (dB-Hz) of signal `name`: settings.cn0_mask_dbhz by that name or by its alias ("L1" also masks
    "G:L1" and the reverse), else settings.cn0_mask_default_dbhz (0: none), or when that is None the signal's
    default in SIGNALS; -inf for a name SIGNALS does not know."""
    masks = settings.cn0_mask_dbhz
    if name in masks:
        return float(masks[name])
    canon = SIGNAL_ALIASES.get(name, name)
    for key, val in masks.items():
        if SIGNAL_ALIASES.get(key, key) == canon:
            return float(val)
    if getattr(settings, "cn0_mask_default_dbhz", None) is not None:
        return float(settings.cn0_mask_default_dbhz)
    return float(SIGNALS[name]["cn0_mask_dbhz"]) if name in SIGNALS else -float("inf")


#: Seed 000 Table 2's editing masks (antenna-frame elevation once fixed, C/N0 per signal): the defaults.
TABLE2_MASKS: dict = {"elevation_mask_antenna_deg": 0.0, "cn0_mask_dbhz": {}, "cn0_mask_default_dbhz": None}
#: "All phases": no antenna-frame or C/N0 mask; the noise model (C/N0 growth, off-boresight multipath term)
#: weights weak and low signals instead. Measured better on simulated passes (docs/attitude.md "Data selection").
ALL_PHASES: dict = {"elevation_mask_antenna_deg": -90.0, "cn0_mask_dbhz": {}, "cn0_mask_default_dbhz": 0.0}


@dataclass
class AttitudeSettings:
    """Every tuning constant of the filter. Defaults: seed 000 Tables 1-2 unless noted."""

    mode: str = "dynamic"                       # dynamic (common angular velocity) | kinematic (baseline noise)
    signals: list = field(default_factory=lambda: ["L1", "L2"])   # names of SIGNALS (GPS L1 + L2 by default)
    systems: list | None = None                 # preset replacing `signals`: e.g. ["G", "E", "C", "J"] = the first
                                                # two frequencies of each system (SYSTEM_SIGNALS, RTKLIB "L1+L2")
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
    adaptive_omega_noise: bool = False          # dynamic mode: causal manoeuvre detection (gnssatt/attitude/adaptive.py):
                                                # constant-acceleration hypotheses against the random walk; the
                                                # estimate follows them by their weight, a detection raises the
                                                # random walk along the acceleration axis; off = Table 1
    adaptive_omega_threshold: float = 5.0       # log-likelihood ratio of a detected manoeuvre
    adaptive_omega_mix_at: float = 0.0          # log-likelihood ratio at which the estimate is half-way to it
    adaptive_omega_sigma_acc_deg_s2: float = 0.05   # prior sigma of the hypotheses' angular acceleration
    adaptive_omega_sigma_deg_s: float = 0.3     # random walk (per tau) along the axis after a detection
    adaptive_omega_hold_epochs: int = 30        # updates it stays raised after the last detection
    tau_omega_s: float = 1.0
    smoother: bool = False                      # dynamic mode: fixed-interval (Rauch-Tung-Striebel) smoothing of the
                                                # angular velocity and baselines after the forward pass
                                                # (gnssatt/attitude/smoother.py); off = the forward filter's output
                                                # post-processing only: each epoch uses the later data
    smoother_adaptive_noise: bool = False       # dynamic mode, implies smoother: the omega random walk per epoch
                                                # from the smoothed angular acceleration of a first pass, then the
                                                # whole filter run again with it and smoothed (smoother.py
                                                # adaptive_noise_profile); off = Table 1's random walk
    smoother_noise_floor: float = 0.03          # its quiet level, a fraction of Table 1's rate (sigma x 0.17)
    smoother_noise_gain: float = 0.5            # + gain x alpha alpha^T dt (alpha the smoothed angular acceleration)
    smoother_noise_window_s: float = 20.0       # the largest alpha within +- this sets an epoch's noise
    smoother_accel_window_s: float = 5.0        # alpha from the smoothed omega over +- this
    smoother_accel_noise_k: float = 3.0         # |alpha| first shrunk by this x its median over the pass (noise)
    sigma0_ambiguity_cyc: float = 500.0
    sigma_baseline_kinematic_m: float = 1.0     # kinematic mode: per baseline component per tau (seed 000 sec. 4.1)
    tau_baseline_s: float = 1.0
    sigma0_code_bias_m: float = 10.0            # inter-signal code bias of a baseline (each signal after the first
                                                # vs the first: inter-frequency and inter-system), constant
    rk4_step_s: float = 1.0
    # --- Table 2: editing limits ---
    elevation_mask_local_deg: float = -90.0
    # Table 2 has an antenna-frame mask of 0 deg (applied only once the baseline is fixed) and C/N0 masks of L1 35 /
    # L2 30 dB-Hz (SIGNALS "cn0_mask_dbhz" for every signal): the defaults, as issue 6 asks. ALL_PHASES keeps every
    # tracked phase instead (the noise model weights weak and low signals): on the simulated passes the masks throw
    # away the satellites that fix the baseline direction best (clean pass: kinematic angle error std 0.16 -> 0.135
    # deg, the true-integer least-squares floor; the realistic and hard presets improve too).
    elevation_mask_antenna_deg: float = 0.0
    cn0_mask_dbhz: dict = field(default_factory=dict)   # per signal name (aliases "L1"/"G:L1" match)
    cn0_mask_default_dbhz: float | None = None  # signals not in cn0_mask_dbhz; None = their SIGNALS (Table 2) mask
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
    attitude_method: str = "quest"              # quest (weights by baseline length) | triad | ml (full covariance)
    pcv_maps: dict = field(default_factory=dict)   # (first, second, freq) -> map dict (CONVENTIONS layout)
    pcv_empty_bins: str = "exclude"             # a fixed baseline's phase in an empty map bin: "exclude" (seed 000
                                                # sec. 3.2: observations without PCV correction leave once fixed)
                                                # | "keep" (used uncorrected, as without maps)
    calibrated_baselines: dict = field(default_factory=dict)  # (first, second) -> body vector (3,)
