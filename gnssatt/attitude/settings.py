"""Settings of the attitude filter: seed 000 Table 1 (process and measurement noise) and Table 2 (editing limits)
as defaults, every value with its unit in the name.
"""
from __future__ import annotations


from dataclasses import dataclass, field, fields, replace
from typing import Literal

# The signals the filter knows (system, RINEX 3 codes in order of preference, frequency, wavelength, default C/N0
# mask), the historical aliases "L1"/"L2" and the `systems` presets live in the one signal table,
# gnssatt.gnss.signals; they stay importable from here under the names this module always had.
from gnssatt.gnss.signals import SIGNAL_ALIASES, SIGNALS, SYSTEM_SIGNALS  # noqa: F401  (public re-export)


def signal_system(name: str) -> str:
    """System letter (G, E, C, J, R) of a signal name of SIGNALS."""
    return SIGNALS[name]["system"]


def effective_signals(settings: "AttitudeSettings") -> list[str]:
    """The filter's signals: `settings.signals`, or with `settings.systems` the preset pair of every system in
    that order (SYSTEM_SIGNALS). Raises ValueError for an unknown signal or system, or a repeated signal."""
    if settings.systems:
        unknown = [x for x in settings.systems if x not in SYSTEM_SIGNALS]
        if unknown:
            raise ValueError(f"systems {unknown} not supported (G, E, C, J, R)")
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
    """C/N0 mask (dB-Hz) of signal `name`: settings.table2.cn0_mask_dbhz by that name or by its alias ("L1" also masks
    "G:L1" and the reverse), else settings.table2.cn0_mask_default_dbhz (0: none), or when that is None the signal's
    default in SIGNALS; -inf for a name SIGNALS does not know."""
    masks = settings.table2.cn0_mask_dbhz
    if name in masks:
        return float(masks[name])
    canon = SIGNAL_ALIASES.get(name, name)
    for key, val in masks.items():
        if SIGNAL_ALIASES.get(key, key) == canon:
            return float(val)
    if settings.table2.cn0_mask_default_dbhz is not None:
        return float(settings.table2.cn0_mask_default_dbhz)
    return float(SIGNALS[name]["cn0_mask_dbhz"]) if name in SIGNALS else -float("inf")


def _f(default, description: str, factory=None, **bounds):
    """A settings field: default (or default factory), bounds (gt/ge/lt/le for the job's validation) and a
    description, kept as dataclass metadata: the single source of truth of the job's config model."""
    meta = {"description": description, **bounds}
    if factory is not None:
        return field(default_factory=factory, metadata=meta)
    return field(default=default, metadata=meta)


@dataclass
class Table1Noise:
    """Process and measurement noise of single differences. Implements: seed 000 Table 1 (sec. 2); the kinematic
    baseline noise is seed 000 sec. 4.1; sigma0_code_bias_m (inter-signal bias state) is ours."""

    sigma_code_m: float = _f(0.30, "Single-difference code noise (m), Table 1.", gt=0, le=100)
    sigma_phase_m: float = _f(0.003, "Single-difference phase noise (m), Table 1.", gt=0, le=1)
    sigma0_baseline_m: float = _f(2.0, "Initial sigma of each baseline component (m), Table 1.", gt=0, le=1000)
    sigma_clock_s: float = _f(1.0e-6, "Differential clock: white noise, reset each epoch (s), Table 1.",
                              gt=0, le=1e-2)
    sigma0_omega_deg_s: float = _f(1.0, "Initial sigma of the angular velocity (deg/s), Table 1.", gt=0, le=100)
    sigma_omega_deg_s: float = _f(0.03, "Angular-velocity random walk per tau (deg/s), Table 1.", ge=0, le=100)
    tau_omega_s: float = _f(1.0, "Time interval tau of the angular-velocity random walk (s), Table 1.",
                            gt=0, le=3600)
    sigma0_ambiguity_cyc: float = _f(500.0, "Initial sigma of an ambiguity (cycles), Table 1.", gt=0, le=1e6)
    sigma_baseline_kinematic_m: float = _f(1.0, "Kinematic mode: baseline random walk per component per tau (m), "
                                                "seed 000 sec. 4.1.", gt=0, le=100)
    tau_baseline_s: float = _f(1.0, "Kinematic mode: tau of the baseline random walk (s).", gt=0, le=3600)
    sigma0_code_bias_m: float = _f(10.0, "Initial sigma of the inter-signal code bias of a baseline (each signal "
                                         "after the first vs the first), constant (m).", gt=0, le=1000)


@dataclass
class Table2Editing:
    """Editing limits of quality control: elevation masks, C/N0 masks, triple-difference limits. Implements: seed
    000 Table 2 (sec. 2, data quality control); the innovation gate is ours (docs/attitude.md)."""

    elevation_mask_local_deg: float = _f(-90.0, "Elevation mask on the local horizon (deg), Table 2.",
                                         ge=-90, le=90)
    elevation_mask_antenna_deg: float = _f(0.0, "Antenna-frame elevation mask once fixed (deg); Table 2: 0; -90 "
                                                "keeps every satellite, the noise model weighting low ones.",
                                           ge=-90, le=90)
    cn0_mask_dbhz: dict[str, float] = _f(None, "C/N0 masks (dB-Hz) per signal name (aliases 'L1'/'G:L1' match).",
                                         factory=dict)
    cn0_mask_default_dbhz: float | None = _f(None, "C/N0 mask of signals not in cn0_mask_dbhz; null: their Table 2 "
                                                   "mask (SIGNALS: 35 dB-Hz on a system's first frequency, 30 on the "
                                                   "others); 0: none ('all phases', docs/attitude.md).",
                                             ge=0, le=70)
    td_code_m: float = _f(0.50, "Triple-difference limit of code (m), Table 2.", gt=0, le=1000)
    td_phase_cyc: float = _f(0.25, "Triple-difference limit of phase (cycles), Table 2.", gt=0, le=100)
    innovation_gate_sigma: float = _f(8.0, "Phase innovations beyond this (normalised) are re-checked / rejected.",
                                      gt=0, le=1000)


@dataclass
class AmbiguityResolution:
    """Integer ambiguity resolution and fix validation. Implements: seed 000 sec. 2 (MLAMBDA, validation by the
    known length, Table 2 'ambiguity acceptance'); the ratio, constrained search, angle test and rounding of
    newcomers are ours, with reasons in docs/attitude.md and docs/ttff.md."""

    max_length_error_m: float = _f(0.03, "Ambiguity acceptance: |length - known| (m), Table 2.", gt=0, le=10)
    length_validation: Literal["filter", "single-epoch", "both"] = _f(
        "both", "Which first-fix baseline the length test takes: filter = the filter's baseline conditioned on "
                "the candidate integers; single-epoch = the epoch's own phases with them (seed 000 sec. 2, "
                "gnssatt.attitude.single_epoch_length); both = both must pass (default: over simulator seeds 0-7 "
                "filter alone let 6 wrong integers through on one hard pass after an outage, both none; "
                "bench/bench_fix_validation.py). Both lengths are in the events.")
    min_ratio: float = _f(0.0, "Also require this ratio (0: ratio only reported; the paper validates by length).",
                          ge=0, le=1000)
    ambiguity_search: Literal["lambda", "constrained"] = _f(
        "lambda", "Integer search of a baseline's first fix: lambda (MLAMBDA + length validation, seed 000) or "
                  "constrained (C-LAMBDA with the known length inside the search, docs/ttff.md).")
    min_ratio_constrained: float = _f(3.0, "constrained: ratio of the constrained objective to accept.",
                                      ge=1, le=1000)
    min_ratio_constrained_joint: float = _f(1.5, "constrained, >= 2 baselines, none fixed: ratio of the joint "
                                                 "MC-LAMBDA objective (+ length and angle tests).", ge=1, le=1000)
    min_ratio_first_fix: float = _f(0.0, "A first fix of a baseline also needs this ratio.", ge=0, le=1000)
    max_angle_error_m: float = _f(0.03, "A first fix must agree with every baseline already fixed: angle within "
                                        "atan(this / l_min); 0 switches the test off (m).", ge=0, le=10)
    min_dd: int = _f(6, "DD ambiguities (all signals) before a first MLAMBDA attempt.", ge=1, le=1000)
    min_sats: int = _f(4, "Satellites with phase on a baseline before an AR attempt.", ge=2, le=100)
    fixed_min_sats: int = _f(4, "Fixed satellites in the update for an epoch to count as fixed.", ge=1, le=100)
    new_amb_round_sigma_cyc: float = _f(0.08, "A fixed baseline fixes a newcomer by rounding below this sigma "
                                              "(cycles).", gt=0, le=10)
    new_amb_round_frac_cyc: float = _f(0.2, "Rounding also needs the float within this of an integer (cycles).",
                                       gt=0, le=0.5)
    max_gap_s: float = _f(10.0, "An ambiguity unobserved longer than this restarts as float (s).", gt=0, le=86400)


@dataclass
class NoiseModel:
    """The measurement noise model beyond Table 1's constant white noise: weighting, per-signal noise estimation,
    the separate phase clock and time-correlated multipath. Ours (seed 000 sec. 2 uses no weighting); reasons and
    measurements in docs/attitude.md 'Noise model'."""

    weighting: Literal["none", "cn0", "elevation"] = _f("none", "Observation weighting: elevation (antenna frame), "
                                                                "cn0 (C/N0) or none (Table 1).")
    separate_phase_clock: bool = _f(True, "Phase gets its own white-noise clock per signal (enters as double "
                                          "differences; code multipath cannot leak through the ambiguity).")
    noise_estimation: bool = _f(True, "Estimate the white noise per signal from triple differences (keeps the "
                                      "predicted sigmas honest).")
    noise_cn0_growth: bool = _f(True, "White-noise variance x 10^((45 - C/N0)/10) (tracking jitter).")
    sigma_multipath_phase_m: tuple[float, float] = _f(
        (0.0015, 0.006), "Time-correlated phase error of one SD (boresight, antenna horizon) (m), growing with the "
                         "square of the off-boresight angle; (0, 0): off.")
    sigma_multipath_code_m: tuple[float, float] = _f((0.15, 0.9), "Time-correlated code error of one SD "
                                                                  "(boresight, antenna horizon) (m); (0, 0): off.")
    multipath_correlation_factor: float = _f(3.0, "Dynamic mode: the correlated variance x this (epochs averaged "
                                                  "within one correlation time).", gt=0, le=1000)
    multipath_adaptive: bool = _f(True, "Scale the multipath variance by what the post-fit residuals of fixed "
                                        "phases show (300-epoch memory).")
    multipath_adaptive_method: Literal["leverage", "autocovariance"] = _f(
        "leverage", "How the adaptive scale is estimated: leverage (post-fit residuals' square over 1 - leverage, "
                    "minus the white variance) or autocovariance (the lag-1 product of one SD's post-fit "
                    "residuals: no white noise in it, whatever R the filter assumes).")


@dataclass
class SmootherSettings:
    """Fixed-interval (Rauch-Tung-Striebel) smoothing after the forward pass, and its adaptive omega noise.
    Ours (gnssatt/attitude/smoother.py; docs/attitude.md 'Where the slew errors come from', 'Adaptive process
    noise of the smoother'); off = seed 000's forward filter."""

    enabled: bool = _f(False, "Dynamic mode: RTS smoothing of the angular velocity and baselines after the "
                              "forward pass (each epoch also uses the later data).")
    adaptive_noise: bool = _f(False, "Dynamic mode, implies enabled: the omega random walk per epoch from the "
                                     "smoothed angular acceleration of a first pass, then the filter run again "
                                     "(about twice the CPU). Off: Table 1's random walk.")
    noise_floor: float = _f(0.03, "Adaptive noise: the quiet level, a fraction of Table 1's rate.", ge=0, le=100)
    noise_gain: float = _f(0.5, "Adaptive noise: the quiet level + this x alpha alpha^T dt (alpha the smoothed "
                                "angular acceleration).",
                           ge=0, le=1000)
    noise_window_s: float = _f(20.0, "The largest alpha within +- this sets an epoch's noise (s).", gt=0, le=3600)
    accel_window_s: float = _f(5.0, "Adaptive noise: alpha from the smoothed omega over +- this (s).", gt=0, le=3600)
    accel_noise_k: float = _f(3.0, "Adaptive noise: |alpha| first shrunk by this x its pass median.", ge=0, le=100)
    noise_em_iterations: int = _f(0, "Adaptive noise: up to this many more iterations (filter runs), each "
                                     "with the floor x the ratio of the smoothed omega increments to their "
                                     "predicted covariance (maximum likelihood, gnssatt.attitude.process_noise_em); "
                                     "0: the configured floor.", ge=0, le=10)
    noise_em_bound: float = _f(10.0, "Adaptive noise with noise_em_iterations: the estimated floor stays within "
                                     "[1 / this, this] x noise_floor.", ge=1, le=1000)
    quiet_jerk_share: float = _f(1.0, "Adaptive noise with angular_acceleration_state: the second pass's angular-jerk "
                                      "rate x this x sqrt(the epoch's omega rate / its quiet level), at most the "
                                      "configured rate; 1: the configured rate everywhere.", gt=0, le=1)


@dataclass
class AdaptiveSettings:
    """Causal manoeuvre detection raising the angular-velocity random walk (gnssatt/attitude/adaptive.py,
    docs/attitude.md 'Adaptive angular-velocity noise'). Ours; off = Table 1's random walk."""

    enabled: bool = _f(False, "Dynamic mode: constant-acceleration hypotheses against the random walk; a "
                              "detection raises the random walk along the acceleration axis.")
    threshold: float = _f(5.0, "Log-likelihood ratio of a detected manoeuvre.", gt=0, le=100)
    mix_at: float = _f(0.0, "Log-likelihood ratio at which the estimate is half-way to the manoeuvre.",
                       ge=-20, le=100)
    sigma_acc_deg_s2: float = _f(0.05, "Prior sigma of the hypotheses' angular acceleration (deg/s^2).",
                                 gt=0, le=100)
    sigma_omega_raised_deg_s: float = _f(0.3, "Random walk per tau along the axis after a detection (deg/s).",
                                         ge=0, le=100)
    hold_epochs: int = _f(30, "Updates it stays raised after the last detection.", ge=0, le=3600)


@dataclass
class AntennaCalibration:
    """A calibration applied by the filter: differential PCV maps and calibrated body baselines (seed 000 sec. 3,
    Table 3). Library-side records (tuple keys): the job declares its own JSON forms (pcv_map_ids,
    calibrated_baselines)."""

    pcv_maps: dict = _f(None, "(first, second, freq) -> map dict (CONVENTIONS layout).", factory=dict, job=False)
    pcv_empty_bins: Literal["exclude", "keep"] = _f(
        "exclude", "A fixed baseline's phase in an empty map bin: exclude it (seed 000 sec. 3.2) or keep it "
                   "uncorrected.")
    calibrated_baselines: dict = _f(None, "(first, second) -> body vector (3,) (m).", factory=dict, job=False)


#: the groups of AttitudeSettings: attribute name -> record type
GROUPS: dict[str, type] = {"table1": Table1Noise, "table2": Table2Editing, "ambiguity": AmbiguityResolution,
                           "noise": NoiseModel, "smoothing": SmootherSettings, "adaptive": AdaptiveSettings,
                           "calibration": AntennaCalibration}

#: renamed fields (old flat name -> name in its group); every other field kept its flat name
_RENAMED = {"smoother": "enabled", "smoother_adaptive_noise": "adaptive_noise", "smoother_noise_floor": "noise_floor",
            "smoother_noise_gain": "noise_gain", "smoother_noise_window_s": "noise_window_s",
            "smoother_accel_window_s": "accel_window_s", "smoother_accel_noise_k": "accel_noise_k",
            "smoother_quiet_jerk_share": "quiet_jerk_share", "smoother_noise_em_iterations": "noise_em_iterations",
            "smoother_noise_em_bound": "noise_em_bound",
            "adaptive_omega_noise": "enabled", "adaptive_omega_threshold": "threshold",
            "adaptive_omega_mix_at": "mix_at", "adaptive_omega_sigma_acc_deg_s2": "sigma_acc_deg_s2",
            "adaptive_omega_sigma_deg_s": "sigma_omega_raised_deg_s", "adaptive_omega_hold_epochs": "hold_epochs",
            "ar_min_ratio_first_fix": "min_ratio_first_fix", "ar_min_dd": "min_dd", "ar_min_sats": "min_sats"}


def _flat_to_nested() -> dict[str, str]:
    back = {}
    for old, new in _RENAMED.items():
        group = "smoothing" if old.startswith("smoother") else "adaptive" if old.startswith("adaptive") else "ambiguity"
        back[f"{group}.{new}"] = old
    out = {}
    for gname, gtype in GROUPS.items():
        for f in fields(gtype):
            path = f"{gname}.{f.name}"
            out[back.get(path, f.name)] = path
    return out


@dataclass
class AttitudeSettings:
    """Every tuning constant of the filter, by concern (GROUPS). Defaults: seed 000 Tables 1-2 unless noted.
    Build with AttitudeSettings.preset(name, **overrides) (PRESETS) or AttitudeSettings(table1=Table1Noise(...))."""

    mode: Literal["dynamic", "kinematic"] = _f("dynamic", "dynamic: common angular velocity, no baseline process "
                                                          "noise; kinematic: baseline process noise, no angular "
                                                          "velocity (seed 000 sec. 2, 4.1).")
    signals: list[str] = _f(None, "Signal names of SIGNALS, each one system on one frequency (GPS L1 + L2 by "
                                  "default).", factory=lambda: ["L1", "L2"], min_length=1, max_length=16)
    systems: list[Literal["G", "E", "C", "J", "R"]] | None = _f(
        None, "Preset replacing `signals`: the first two frequencies of each system (SYSTEM_SIGNALS, RTKLIB "
              "'L1+L2'), e.g. ['G', 'E', 'C', 'J', 'R'] (R: GLONASS FDMA G1 + G2).", min_length=1, max_length=5)
    platform_defaults: bool = _f(
        True, "Defaults by platform kind for what is left as it is (gnssatt.attitude.platform_defaults): terrestrial "
              "platforms use every system of G/E/C/J/R in the files and elevation weights; spacecraft keep seed 000 "
              "Tables 1-2. False: the settings exactly as given.")
    length_constraint_sigma_m: float = _f(
        0.0, "Dynamic mode: once a baseline has been fixed, its state is held to the known body length by a soft "
             "constraint of this sigma after each update (gnssatt.attitude.length_constraint; without it the "
             "lengths drift by mm over an hour; 5e-4 keeps them within 0.07 mm on the clean 106-min pass); 0: off "
             "(m).", ge=0, le=1)
    baseline_update: Literal["additive", "rigid"] = _f(
        "rigid", "Dynamic mode: how the measurement update moves a fixed baseline. 'rigid' (default): the "
                 "baselines turned as one body by the update's common rotation, each length changed by the part of "
                 "db along b only, and the covariance turned with them (gnssatt.attitude.rigid_update; lengths "
                 "without drift); 'additive': b + db (its length grows by |db across b|^2 / 2|b| per epoch, mm over "
                 "an hour).")
    angular_acceleration_state: bool = _f(
        False, "Dynamic mode: an angular acceleration (3 states, rad/s^2) after the angular velocity, a random walk "
               "of rate sigma_angular_jerk_deg_s3 (constant-acceleration model, gnssatt.attitude.angular_acceleration;"
               " the smoother then passes constant angular accelerations unbiased up to the edge of a run). Not "
               "combined with adaptive_omega_noise (the manoeuvre detector is off with it). true / false.")
    sigma_angular_jerk_deg_s3: float = _f(
        0.0005, "With angular_acceleration_state: random walk of the angular acceleration, sigma per tau_omega_s "
               "(deg/s^2 per sqrt(s), i.e. deg/s^3 as a rate); 0 < value <= 10.", gt=0, le=10)
    sigma_omega_with_acceleration_deg_s: float = _f(
        0.01, "With angular_acceleration_state: the angular-velocity random walk per tau_omega_s in place of Table "
              "1's sigma_omega_deg_s (deg/s; the acceleration state carries the slow changes); 0 <= value <= 100.",
        ge=0, le=100)
    sigma0_angular_acceleration_deg_s2: float = _f(
        0.05, "With angular_acceleration_state: initial sigma of the angular acceleration, also after an omega reset "
              "(deg/s^2); 0 < value <= 100.", gt=0, le=100)
    rk4_step_s: float = _f(1.0, "Step of the Runge-Kutta propagation of the attitude between epochs (s).",
                           gt=0, le=60)
    initial_attitude: Literal["earth-pointing", "level", "given"] = _f(
        "earth-pointing", "earth-pointing (spacecraft) / level (terrestrial) | given (initial_q_body_from_ecef).",
        job=False)
    initial_q_body_from_ecef: list[float] | None = _f(
        None, "Initial attitude; default Earth pointing (spacecraft) or level heading north (terrestrial).",
        min_length=4, max_length=4)
    attitude_method: Literal["quest", "triad", "ml"] = _f(
        "quest", "quest: QUEST with weights by baseline length (seed 000); triad: the first baseline exact; ml: "
                 "maximum likelihood with the baselines' full covariance (docs/attitude.md).")
    table1: Table1Noise = field(default_factory=Table1Noise, metadata={"description": Table1Noise.__doc__})
    table2: Table2Editing = field(default_factory=Table2Editing, metadata={"description": Table2Editing.__doc__})
    ambiguity: AmbiguityResolution = field(default_factory=AmbiguityResolution,
                                           metadata={"description": AmbiguityResolution.__doc__})
    noise: NoiseModel = field(default_factory=NoiseModel, metadata={"description": NoiseModel.__doc__})
    smoothing: SmootherSettings = field(default_factory=SmootherSettings,
                                        metadata={"description": SmootherSettings.__doc__})
    adaptive: AdaptiveSettings = field(default_factory=AdaptiveSettings,
                                       metadata={"description": AdaptiveSettings.__doc__})
    calibration: AntennaCalibration = field(default_factory=AntennaCalibration,
                                            metadata={"description": AntennaCalibration.__doc__})

    @classmethod
    def preset(cls, name: str = "seed000", **overrides) -> "AttitudeSettings":
        """The named preset (PRESETS) with `overrides` applied (see `override`)."""
        if name not in PRESETS:
            raise ValueError(f"unknown preset {name!r} (known: {', '.join(PRESETS)})")
        return cls().override(**PRESETS[name]).override(**overrides)

    def override(self, **overrides) -> "AttitudeSettings":
        """A copy with `overrides`: top-level fields by name, a group by its name (a record replaces it, a dict
        updates some of its fields), or an old flat field name (FLAT_TO_NESTED). ValueError names an unknown key."""
        top, groups = {}, {g: {} for g in GROUPS}
        for key, val in overrides.items():
            if key in GROUPS:
                if isinstance(val, GROUPS[key]):
                    top[key] = val
                else:
                    groups[key].update(val)
            elif key in FLAT_TO_NESTED:
                g, name = FLAT_TO_NESTED[key].split(".")
                groups[g][name] = val
            elif key in _TOP:
                top[key] = val
            else:
                raise ValueError(f"unknown attitude setting {key!r}")
        out = replace(self, **top)
        for g, kw in groups.items():
            if kw:
                known = {f.name for f in fields(GROUPS[g])}
                bad = sorted(set(kw) - known)
                if bad:
                    raise ValueError(f"unknown attitude setting {g}.{bad[0]}")
                setattr(out, g, replace(getattr(out, g), **kw))
        return out


#: defaults by platform kind (gnssatt.attitude.platform_defaults applies them): kind -> setting -> {value, reason};
#: the attitude job's config schema exposes it as it is ("x-platform-defaults")
PLATFORM_DEFAULTS: dict = {
    "spacecraft": {
        "signals": {"value": "GPS L1 C/A + L2 (signals ['L1', 'L2'])",
                    "reason": "seed 000 Tables 1-2: the paper's configuration, its published figures"},
        "noise.weighting": {"value": "none",
                            "reason": "seed 000 Table 1 (no weighting); no ground multipath at a spacecraft"},
    },
    "terrestrial": {
        "systems": {"value": "every system of G, E, C, J, R with satellites in every antenna's file",
                    "reason": "real Nagoya 0.99 m baseline: GPS alone gives -3.4 mm length and -0.23 deg elevation, "
                              "G/E/C/J within 0.3 mm / 0.03 deg of the known baseline (more satellites, better "
                              "vertical geometry)"},
        "noise.weighting": {"value": "elevation",
                            "reason": "ground multipath grows at low elevation; with elevation weights the "
                                      "Nagoya baseline meets 3 mm / 0.05 deg azimuth / 0.1 deg elevation"},
    },
}

#: old flat field name -> "group.field" (every field that moved into a group)
FLAT_TO_NESTED: dict[str, str] = _flat_to_nested()
_TOP = {f.name for f in fields(AttitudeSettings) if f.name not in GROUPS}

#: Seed 000 Table 2's editing masks (antenna-frame elevation once fixed, C/N0 per signal): the defaults.
TABLE2_MASKS: dict = {"table2": {"elevation_mask_antenna_deg": 0.0, "cn0_mask_dbhz": {},
                                 "cn0_mask_default_dbhz": None}}
#: "All phases": no antenna-frame or C/N0 mask; the noise model (C/N0 growth, off-boresight multipath term)
#: weights weak and low signals instead. Measured better on simulated passes (docs/attitude.md "Data selection").
ALL_PHASES: dict = {"table2": {"elevation_mask_antenna_deg": -90.0, "cn0_mask_dbhz": {}, "cn0_mask_default_dbhz": 0.0}}

#: Named configurations (overrides of the defaults, `AttitudeSettings.override` form): "seed000" = Tables 1-2 as
#: the paper; "all-phases" = ALL_PHASES (the benches' selection); "all-phases-smoother" = + the fixed-interval
#: smoother (the calibration job's held-out comparison); "all-phases-adaptive-smoother" = + its adaptive omega
#: noise (docs/attitude.md, the slews' best).
PRESETS: dict[str, dict] = {
    "seed000": TABLE2_MASKS,
    "all-phases": ALL_PHASES,
    "all-phases-smoother": {**ALL_PHASES, "smoothing": {"enabled": True}},
    "all-phases-adaptive-smoother": {**ALL_PHASES, "smoothing": {"enabled": True, "adaptive_noise": True}},
}
