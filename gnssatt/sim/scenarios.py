"""Scenario presets: one parameters dataclass per preset, every field overridable by name.

`list_scenarios()` gives name -> all default parameters (JSON-serialisable); `make_params(name,
overrides)` returns the preset's dataclass with overrides applied, refusing unknown keys.
See docs/simulator.md for the table of presets and which realism each switches on.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

CASSIOPE_ANTENNAS = {
    "GPS-2": {"position_m": [0.0, 0.0, 0.0], "boresight": [0, 0, -1]},
    "GPS-0": {"position_m": [1.04653, -0.07191, 0.0], "boresight": [0, 0, -1]},
    "GPS-1": {"position_m": [0.0, 1.13969, 0.0], "boresight": [0, 0, -1]},
}
# Calibration truth: hidden mean phase-centre shifts of GPS-0 and GPS-1 relative to GPS-2 (mm, body),
# calibrated minus a priori baselines of seed 000 Table 3.
CASSIOPE_TABLE3_OFFSETS_MM = {"GPS-2": [0.0, 0.0, 0.0], "GPS-0": [2.10, -7.86, -5.68], "GPS-1": [4.63, -7.33, -6.12]}


@dataclass
class SimParams:
    """All parameters of one simulated observation set (or `count` sets). Units in names."""

    # --- time ---
    start_gps: str = "2018-06-06T12:20:00"      # ISO GPS time of the first epoch (receiver time tag)
    duration_s: float = 6360.0
    interval_s: float = 1.0
    count: int = 1                               # number of sets (passes); >1 writes pass_000/, pass_001/...
    pass_spacing_s: float = 6 * 3600.0           # start-time spacing between passes
    # --- platform ---
    platform_name: str = "CASSIOPE-like"
    kind: str = "spacecraft"                     # spacecraft | terrestrial
    antennas: dict = field(default_factory=lambda: {k: dict(v) for k, v in CASSIOPE_ANTENNAS.items()})
    master: str = "GPS-2"
    antenna_offsets_mm: dict = field(default_factory=dict)   # hidden true phase-centre shift (body, mm)
    # orbit (spacecraft)
    orbit_source: str = "kepler-j2"              # kepler-j2 | tle | sp3
    perigee_alt_km: float = 328.0
    apogee_alt_km: float = 1294.0
    inclination_deg: float = 80.97
    raan_deg: float = 40.0
    argp_deg: float = 60.0
    mean_anomaly_deg: float = 20.0
    tle_line1: str = ""
    tle_line2: str = ""
    orbit_sp3_path: str = ""
    # terrestrial
    lat_deg: float = 35.15
    lon_deg: float = 136.97
    height_m: float = 60.0
    trajectory_csv: str = ""
    # --- attitude ---
    attitude_profile: str = "earth-pointing"    # earth-pointing | waypoints | quaternion-csv | fixed
    euler_deg: list = field(default_factory=lambda: [0.0, 0.0, 0.0])   # fixed yaw, pitch, roll (deg)
    wobble_amp_deg: list = field(default_factory=lambda: [0.3, 0.3, 0.3])
    wobble_period_s: list = field(default_factory=lambda: [1100.0, 700.0, 900.0])
    waypoints: list = field(default_factory=list)   # [[t_s, yaw, pitch, roll], ...] min-jerk slerp
    attitude_csv: str = ""
    random_initial_attitude: bool = False        # TTFF: random start orientation, slew back to Earth pointing
    slew_back_rate_deg_s: float = 0.15           # peak rate of the slew back (min-jerk: 1.875 angle / T)
    slew_back_hold_s: float = 60.0
    # --- constellation ---
    constellation_seed: int = 2018
    nav_file: str = ""                           # a real RINEX nav file: its GPS (GLONASS) records drive the orbits
    systems: str = "G"                           # G | R | G+R: GPS, GLONASS FDMA (24 slots or the nav file), both
    # --- receivers / tracking ---
    signals: list = field(default_factory=lambda: ["L1", "L2"])
    clock_mode: str = "steered"                  # steered | free
    clock_steer_amp_s: float = 3e-7
    clock_free_drift_ppm: float = 1.0
    clock_jump_in_phase: bool = True
    code_bias_sigma_m: float = 0.5
    receiver_types: dict = field(default_factory=dict)   # antenna -> receiver model (REC # / TYPE); unset: SIM RX
    # receiver model -> GLONASS inter-channel biases {"code_m_per_k", "phase_m_per_k", "code_m_by_k",
    # "phase_m_by_k": {"k": m}}, optionally per signal {"L1": {...}, "L2": {...}}; models not named have none
    glonass_icb_by_model: dict = field(default_factory=dict)
    n_channels: int = 12
    acquisition_delays: bool = True
    acq_delay_l1_s: list = field(default_factory=lambda: [2.0, 20.0])
    acq_delay_l2_s: list = field(default_factory=lambda: [1.0, 8.0])
    acq_l1_dbhz: float = 32.0
    trk_l1_dbhz: float = 27.0
    acq_l2_dbhz: float = 27.0
    trk_l2_dbhz: float = 22.0
    # --- signal / antenna ---
    cn0_zenith_l1_dbhz: float = 49.0
    l2_cn0_offset_db: float = -6.0              # semi-codeless P(Y) loss relative to L1
    gain_horizon_loss_db: float = 13.0
    gain_backlobe_db_per_deg: float = 0.6
    cn0_jitter_db: float = 0.5
    earth_block_height_km: float = 80.0
    elevation_mask_deg: float = 10.0             # terrestrial: local horizon mask
    pcv: bool = True
    pcv_peak_to_peak_mm: float = 10.0
    l2_pcv_factor: float = 1.3
    pco: bool = True
    pco_nominal_mm: list = field(default_factory=lambda: [[0.0, 0.0, 55.0], [0.0, 0.0, 50.0]])   # L1, L2 (antenna)
    pco_scatter_mm: float = 1.5
    ionosphere: bool = True
    vtec_tecu: float = 20.0
    troposphere: bool = True                     # terrestrial only
    windup: bool = True
    # None: the ideal crossed-dipole wind-up (Wu et al. 1993); an antenna_pattern.json object (docs/formats/
    # antenna_vector_length.md): that antenna's vector-phase wind-up, seed 003 eq. 32 (gnssatt/sim/vector_windup.py)
    windup_antenna: dict | None = None
    multipath: bool = True
    mp_tau_s: float = 60.0
    mp_code_m: list = field(default_factory=lambda: [0.1, 0.6, 1.5])     # zenith, horizon, cap
    mp_phase_m: list = field(default_factory=lambda: [0.0005, 0.004, 0.010])
    noise: bool = True
    noise_phase_m: float = 0.003
    noise_code_m: float = 0.3
    noise_doppler_hz: float = 0.03
    noise_grows_with_cn0: bool = True
    noise_ref_cn0_dbhz: float = 45.0
    noise_scale_max: float = 4.0                 # cap of the C/N0 growth factor (4 = 12 dB below the reference)
    l2_noise_factor: float = 1.5
    # --- events ---
    slip_rate_per_hour: float = 0.0              # per tracked signal at 40 dB-Hz, x10 per -10 dB
    slip_lli_fraction: float = 1.0
    gap_rate_per_hour: float = 0.0
    gap_length_s: list = field(default_factory=lambda: [2.0, 20.0])
    outage_rate_per_hour: float = 0.0
    outage_length_s: list = field(default_factory=lambda: [20.0, 90.0])
    outage_windows: list = field(default_factory=list)   # [[antenna or "*", start_s, duration_s], ...]
    # --- outputs ---
    reference_sigma_arcsec: float = 3.0
    reference_interval_s: float = 1.0
    sp3_interval_s: float = 10.0
    truth_components: bool = True                # truth/observations_<ant>.csv: per-observation terms


@dataclass
class EarthPointingParams(SimParams):
    """CASSIOPE-like Earth pointing, 6 June 2018 12:20-14:06 (seed 000 sec. 4.1, Table 4)."""


@dataclass
class SlewParams(SimParams):
    """Yaw/roll manoeuvre of seed 000 Fig. 6 (top), 12 Aug 2017 07:10-07:27."""

    start_gps: str = "2017-08-12T07:10:00"
    duration_s: float = 1020.0
    attitude_profile: str = "waypoints"
    waypoints: list = field(default_factory=lambda: [[0.0, -27.0, 0.0, 11.0], [300.0, -178.0, -27.0, 86.0]])
    wobble_amp_deg: list = field(default_factory=lambda: [0.0, 0.0, 0.0])


@dataclass
class TtffParams(SimParams):
    """Random off-nadir starts slewing back to Earth pointing (seed 000 sec. 5, Table 5): 20 short sets."""

    start_gps: str = "2017-08-10T14:01:00"
    duration_s: float = 600.0
    count: int = 20
    pass_spacing_s: float = 5 * 86400.0 + 3 * 3600.0 + 17 * 60.0
    random_initial_attitude: bool = True
    wobble_amp_deg: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    acquisition_delays: bool = False             # receivers start already tracking (activation mid-orbit)
    # what real spacecraft data have (issue 7 item 2, docs/ttff.md "Realism"): uncalibrated PCV 35 mm p-p per
    # antenna (~50 mm p-p differential, L2 x1.3; seed 000 Figs. 3-4), code multipath ~1 m at the antenna horizon
    # (cap 2 m below it), thermal noise growing with falling C/N0 up to x2 (6 mm phase / 0.6 m code at <= 39 dB-Hz)
    # and L2 P(Y) semi-codeless x1.2 on top of its 6 dB lower C/N0
    pcv_peak_to_peak_mm: float = 35.0
    mp_code_m: list = field(default_factory=lambda: [0.1, 1.0, 2.0])
    noise_scale_max: float = 2.0
    l2_noise_factor: float = 1.2


@dataclass
class CalibrationParams(SimParams):
    """Calibration campaign: many Earth-pointing passes, hidden offsets (Table 3), 50 mm p-p diff. PCV."""

    start_gps: str = "2018-01-10T03:00:00"
    duration_s: float = 2700.0
    count: int = 10
    pass_spacing_s: float = 2 * 86400.0 + 5 * 3600.0 + 11 * 60.0
    antenna_offsets_mm: dict = field(default_factory=lambda: {k: list(v) for k, v in
                                                              CASSIOPE_TABLE3_OFFSETS_MM.items()})
    pcv_peak_to_peak_mm: float = 35.0


@dataclass
class HardParams(SimParams):
    """A hard pass: free-running clocks with 1 ms jumps, slips (some without LLI), gaps, outages."""

    duration_s: float = 1800.0
    clock_mode: str = "free"
    wobble_amp_deg: list = field(default_factory=lambda: [1.0, 1.0, 1.0])
    slip_rate_per_hour: float = 6.0
    slip_lli_fraction: float = 0.7
    gap_rate_per_hour: float = 4.0
    outage_rate_per_hour: float = 1.0
    outage_windows: list = field(default_factory=lambda: [["GPS-0", 600.0, 60.0], ["*", 1200.0, 15.0]])
    mp_code_m: list = field(default_factory=lambda: [0.2, 1.2, 3.0])
    mp_phase_m: list = field(default_factory=lambda: [0.001, 0.008, 0.02])
    trk_l2_dbhz: float = 25.0
    pcv_peak_to_peak_mm: float = 25.0


@dataclass
class CubesatParams(SimParams):
    """3U-like CubeSat: 10 cm baselines, low-gain patches, 500 km sun-synchronous orbit, L1 only."""

    platform_name: str = "CubeSat-10cm"
    antennas: dict = field(default_factory=lambda: {
        "ANT-A": {"position_m": [0.0, 0.0, 0.0], "boresight": [0, 0, -1]},
        "ANT-B": {"position_m": [0.10, 0.0, 0.0], "boresight": [0, 0, -1]},
        "ANT-C": {"position_m": [0.0, 0.10, 0.0], "boresight": [0, 0, -1]}})
    master: str = "ANT-A"
    duration_s: float = 3000.0
    perigee_alt_km: float = 495.0
    apogee_alt_km: float = 505.0
    inclination_deg: float = 97.4
    signals: list = field(default_factory=lambda: ["L1"])
    cn0_zenith_l1_dbhz: float = 45.0
    wobble_amp_deg: list = field(default_factory=lambda: [2.0, 2.0, 2.0])
    wobble_period_s: list = field(default_factory=lambda: [300.0, 250.0, 350.0])
    pcv_peak_to_peak_mm: float = 6.0
    pco_nominal_mm: list = field(default_factory=lambda: [[0.0, 0.0, 20.0], [0.0, 0.0, 18.0]])


@dataclass
class GroundStaticParams(SimParams):
    """A static dual-antenna ground set (1 m baseline along the vehicle x axis), heading 30 deg."""

    platform_name: str = "ground-dual"
    kind: str = "terrestrial"
    antennas: dict = field(default_factory=lambda: {
        "ANT1": {"position_m": [0.0, 0.0, 0.0], "boresight": [0, 0, -1]},
        "ANT2": {"position_m": [1.0, 0.0, 0.0], "boresight": [0, 0, -1]}})
    master: str = "ANT1"
    start_gps: str = "2024-06-24T03:00:00"
    duration_s: float = 3600.0
    attitude_profile: str = "fixed"
    euler_deg: list = field(default_factory=lambda: [30.0, 0.0, 0.0])
    wobble_amp_deg: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    cn0_zenith_l1_dbhz: float = 50.0
    gain_horizon_loss_db: float = 15.0
    mp_tau_s: float = 300.0
    vtec_tecu: float = 25.0
    acquisition_delays: bool = False


PRESETS: dict[str, type[SimParams]] = {
    "earth-pointing": EarthPointingParams,
    "slew": SlewParams,
    "ttff": TtffParams,
    "calibration": CalibrationParams,
    "hard": HardParams,
    "cubesat": CubesatParams,
    "ground-static": GroundStaticParams,
}


def list_scenarios() -> dict[str, dict]:
    """Scenario name -> all default parameters (JSON-serialisable), with the preset's description under '_doc'."""
    out = {}
    for name, cls in PRESETS.items():
        d = dataclasses.asdict(cls())
        d["_doc"] = (cls.__doc__ or "").strip()
        out[name] = d
    return out


def make_params(scenario: str, overrides: dict | None = None) -> SimParams:
    """The preset's parameters with `overrides` applied; ValueError naming an unknown scenario or key."""
    if scenario not in PRESETS:
        raise ValueError(f"unknown scenario {scenario!r}; known: {', '.join(PRESETS)}")
    cls = PRESETS[scenario]
    params = cls()
    if not overrides:
        return params
    names = {f.name: f for f in dataclasses.fields(cls)}
    for key in overrides:
        if key not in names:
            raise ValueError(f"unknown parameter {key!r} for scenario {scenario!r}")
    fixed = {}
    for key, value in overrides.items():
        default = getattr(params, key)
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise ValueError(f"parameter {key!r} must be true or false, got {value!r}")
        elif isinstance(default, (int, float)) and not isinstance(default, bool):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"parameter {key!r} must be a number, got {value!r}")
            value = type(default)(value) if isinstance(default, float) or float(value).is_integer() else value
        elif isinstance(default, str) and not isinstance(value, str):
            raise ValueError(f"parameter {key!r} must be a string, got {value!r}")
        elif isinstance(default, (list, dict)) and not isinstance(value, type(default)):
            raise ValueError(f"parameter {key!r} must be a {type(default).__name__}, got {value!r}")
        fixed[key] = value
    return dataclasses.replace(params, **fixed)
