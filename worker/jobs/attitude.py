"""Job type `attitude`: multi-antenna carrier-phase attitude (seed 000 EKF, MLAMBDA, QUEST), the product's main job."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from worker.jobs.registry import JobType


class AttitudeConfig(BaseModel):
    """Filter settings; defaults are seed 000 Table 1 (noise) and Table 2 (editing limits)."""

    model_config = ConfigDict(extra="forbid")
    mode: Literal["dynamic", "kinematic"] = Field(
        "dynamic", description="dynamic: common angular velocity, no baseline process noise; kinematic: baseline "
                               "process noise (sigma_baseline_kinematic_m per tau), no angular velocity.")
    signals: list[str] = Field(["L1", "L2"], min_length=1, max_length=16,
                               description="Signals, each one system on one frequency: 'L1' (GPS L1 C/A), 'L2' (GPS "
                                           "L2 P(Y), L2C if P(Y) is absent), or system-qualified 'G:L5', 'E:E1', "
                                           "'E:E5a', 'E:E5b', 'C:B1I', 'C:B2I', 'C:B3I', 'J:L1', 'J:L2', 'J:L5'.")
    systems: list[Literal["G", "E", "C", "J"]] | None = Field(
        None, min_length=1, max_length=4,
        description="Preset replacing `signals`: the first two frequencies of each system (GPS/QZSS L1+L2, Galileo "
                    "E1+E5b, BeiDou B1I+B2I), e.g. ['G', 'E', 'C', 'J']. GLONASS is not supported.")
    cn0_mask_dbhz: dict[str, float] = Field(
        {}, description="C/N0 masks (dB-Hz) of other signals by name (default: cn0_mask_default_dbhz).")
    cn0_mask_default_dbhz: float | None = Field(
        None, ge=0, le=70, description="C/N0 mask of signals not named; null (default): seed 000 Table 2 style, 35 on "
                                       "the first frequency of a system, 30 on the others; 0: none (the noise model "
                                       "weights weak signals; 'all phases', docs/attitude.md).")
    sigma_code_m: float = Field(0.30, gt=0, le=100, description="Single-difference code noise (m).")
    sigma_phase_m: float = Field(0.003, gt=0, le=1, description="Single-difference phase noise (m).")
    weighting: Literal["none", "cn0", "elevation"] = Field("none", description="Observation weighting.")
    noise_estimation: bool = Field(True, description="Estimate the white noise per signal from triple differences "
                                                     "(keeps the predicted sigmas honest).")
    sigma0_baseline_m: float = Field(2.0, gt=0, le=1000)
    sigma_clock_s: float = Field(1e-6, gt=0, le=1e-2)
    sigma0_omega_deg_s: float = Field(1.0, gt=0, le=100)
    sigma_omega_deg_s: float = Field(0.03, ge=0, le=100, description="Angular velocity random walk per tau.")
    tau_omega_s: float = Field(1.0, gt=0, le=3600)
    sigma0_ambiguity_cyc: float = Field(500.0, gt=0, le=1e6)
    sigma_baseline_kinematic_m: float = Field(1.0, gt=0, le=100)
    elevation_mask_local_deg: float = Field(-90.0, ge=-90, le=90)
    elevation_mask_antenna_deg: float = Field(
        0.0, ge=-90, le=90, description="Antenna-frame elevation mask once fixed (seed 000 Table 2: 0; -90 keeps "
                                         "every satellite, the noise model weighting low ones).")
    cn0_mask_l1_dbhz: float = Field(35.0, ge=0, le=70, description="C/N0 mask of GPS L1 C/A (seed 000 Table 2; 0: none).")
    cn0_mask_l2_dbhz: float = Field(30.0, ge=0, le=70, description="C/N0 mask of GPS L2 (seed 000 Table 2; 0: none).")
    td_code_m: float = Field(0.5, gt=0, le=1000)
    td_phase_cyc: float = Field(0.25, gt=0, le=100)
    max_length_error_m: float = Field(0.03, gt=0, le=10)
    min_ratio: float = Field(0.0, ge=0, le=1000, description="Also require this ratio (0: ratio only reported).")
    ambiguity_search: Literal["lambda", "constrained"] = Field(
        "lambda", description="Integer search of a baseline's first fix: lambda (MLAMBDA + length validation, "
                              "seed 000) or constrained (C-LAMBDA: the known baseline length inside the search, "
                              "accepted by the ratio of the constrained objective and the length test; fixes "
                              "single-frequency starts sooner, docs/ttff.md).")
    min_ratio_constrained: float = Field(3.0, ge=1, le=1000,
                                         description="constrained: ratio of the constrained objective to accept.")
    smoother: bool = Field(False, description="Dynamic mode: fixed-interval (RTS) smoothing of the angular velocity "
                                              "and baselines after the forward pass, so each epoch also uses the "
                                              "later data: no lag in slews, about half the noise (docs/attitude.md "
                                              "'Where the slew errors come from'). Off: the forward filter's output.")
    adaptive_omega_noise: bool = Field(
        False, description="Dynamic mode: causal manoeuvre detection (docs/attitude.md 'Adaptive angular-velocity "
                           "noise'): constant-angular-acceleration hypotheses against the angular-velocity random "
                           "walk; the estimate follows them by their weight and a detection raises the random walk "
                           "along the acceleration axis. Off: Table 1's random walk.")
    adaptive_omega_threshold: float = Field(5.0, gt=0, le=100,
                                            description="Log-likelihood ratio of a detected manoeuvre.")
    adaptive_omega_mix_at: float = Field(0.0, ge=-20, le=100, description="Log-likelihood ratio at which the "
                                                                          "estimate is half-way to the manoeuvre.")
    adaptive_omega_sigma_acc_deg_s2: float = Field(0.05, gt=0, le=100, description="Prior sigma of the "
                                                   "hypotheses' angular acceleration (deg/s^2).")
    adaptive_omega_sigma_deg_s: float = Field(0.3, ge=0, le=100, description="Angular-velocity random walk per tau "
                                                                             "along the axis after a detection.")
    adaptive_omega_hold_epochs: int = Field(30, ge=0, le=3600, description="Updates the raised random walk lasts "
                                                                           "after the last detection.")
    smoother_adaptive_noise: bool = Field(False, description="Dynamic mode, implies `smoother`: the angular "
                                          "velocity's random walk per epoch from the smoothed angular acceleration "
                                          "of a first pass (low when steady, raised around manoeuvres), then the "
                                          "whole filter run again with it and smoothed: about twice the CPU (docs/"
                                          "attitude.md 'Adaptive process noise of the smoother'). Off: Table 1's.")
    attitude_method: Literal["quest", "triad", "ml"] = Field(
        "quest", description="quest: QUEST with weights by baseline length (seed 000); triad: the first baseline "
                             "exact; ml: maximum likelihood with the baselines' full covariance (uses that a "
                             "baseline's direction is known better in some directions than others; kinematic "
                             "attitude rms 12 % lower on the simulated CASSIOPE pass, docs/attitude.md).")
    initial_q_body_from_ecef: list[float] | None = Field(
        None, min_length=4, max_length=4, description="Initial attitude; default Earth pointing (spacecraft) or "
                                                      "level heading north (terrestrial).")
    calibrated_baselines: dict | None = Field(
        None, description="A calibration job's baselines.json object (CONVENTIONS.md) replacing the a priori "
                          "antenna positions.")
    pcv_empty_bins: Literal["exclude", "keep"] = Field(
        "exclude", description="A fixed baseline's phase whose map bin is empty: exclude it (seed 000 sec. 3.2) or "
                               "keep it uncorrected.")
    pcv_map_ids: list[str] = Field(
        [], max_length=32, description="Ids of stored differential PCV maps (/v1/pcv-maps), at most one per "
                                       "baseline and signal, subtracted from the phase single differences of "
                                       "fixed baselines (directions with an empty bin then leave the solution).")

    @field_validator("signals")
    @classmethod
    def _unique(cls, v):
        from gnssatt.attitude.settings import SIGNAL_ALIASES, SIGNALS

        unknown = [x for x in v if x not in SIGNALS]
        if unknown:
            raise ValueError(f"unknown signals {unknown}; known: {', '.join(SIGNALS)}")
        if len({SIGNAL_ALIASES.get(x, x) for x in v}) != len(v):
            raise ValueError("signals must not repeat")
        return v

    @field_validator("systems")
    @classmethod
    def _unique_systems(cls, v):
        if v is not None and len(set(v)) != len(v):
            raise ValueError("systems must not repeat")
        return v

    @field_validator("cn0_mask_dbhz")
    @classmethod
    def _known_masks(cls, v):
        from gnssatt.attitude.settings import SIGNALS

        bad = [k for k, x in v.items() if k not in SIGNALS or not 0 <= x <= 70]
        if bad:
            raise ValueError(f"cn0_mask_dbhz: unknown signal or mask outside 0-70 dB-Hz: {bad}")
        return v

    def to_settings(self):
        from gnssatt.attitude.settings import AttitudeSettings

        d = self.model_dump()
        cn0 = {**d.pop("cn0_mask_dbhz"), "L1": d.pop("cn0_mask_l1_dbhz"), "L2": d.pop("cn0_mask_l2_dbhz")}
        cal = d.pop("calibrated_baselines") or {}
        d.pop("pcv_map_ids")          # resolved from the store by the pipeline (maps_for_settings)
        cal_map = {}
        for b in cal.get("baselines", []) if isinstance(cal, dict) else []:
            if {"from", "to", "calibrated_m"} <= set(b):
                cal_map[(b["from"], b["to"])] = b["calibrated_m"]
        return AttitudeSettings(cn0_mask_dbhz=cn0, calibrated_baselines=cal_map, **d)


JOB_TYPE = JobType(
    name="attitude", title="Attitude from multi-antenna GNSS",
    description="Carrier-phase attitude of a rigid platform with two or more antennas: the CASSIOPE/GAP filter "
                "(seed 000) over single differences, MLAMBDA with baseline-length validation, QUEST, honest "
                "sigmas. Products: attitude.csv, baselines.csv, residuals.csv, events.csv, summary.json, and "
                "attitude.aem (spacecraft) or heading.nmea (terrestrial).",
    config_model=AttitudeConfig, pipeline="worker.pipelines.attitude:run", min_sets=1, max_sets=1,
    produces=("attitude.csv", "baselines.csv", "residuals.csv", "events.csv", "summary.json", "attitude.aem",
              "heading.nmea", "euler.png", "fix_status.png", "dop.png", "residuals.png", "skyplot.png",
              "report.html"))


def maps_for_settings(docs: list[tuple[str, dict]], baselines: list[tuple[str, str]]) -> dict:
    """(first, second, frequency) -> map dict for AttitudeSettings.pcv_maps from (map id, CONVENTIONS JSON)
    pairs; ValueError naming the map when one is malformed, is not for a baseline of the platform, or repeats a
    (pair, frequency)."""
    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.gnss.io.pcv_map import parse_pcv_map

    out: dict = {}
    for map_id, doc in docs:
        try:
            grid = parse_pcv_map(doc, f"PCV map {map_id}")
        except ParseError as exc:
            raise ValueError(str(exc)) from exc
        key = (grid.first, grid.second, grid.frequency)
        if (grid.first, grid.second) not in set(map(tuple, baselines)):
            raise ValueError(f"PCV map {map_id} is for the pair {grid.first}>{grid.second}, not a baseline of the "
                             f"platform ({', '.join(f'{a}>{b}' for a, b in baselines)})")
        if key in out:
            raise ValueError(f"two PCV maps for {grid.first}>{grid.second} {grid.frequency} (one is {map_id})")
        out[key] = grid.to_json()
    return out
