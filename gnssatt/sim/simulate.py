"""Simulate one scenario: synthetic constellation, platform motion, per-antenna observations, all files.

Public entry points: `simulate_scenario`, `list_scenarios`, `SimResult`. Files written per set (see
docs/simulator.md): obs/<antenna>.rnx, nav/brdc.rnx, platform.sp3, platform.json,
reference_attitude.csv, truth/{attitude.csv, receivers.csv, arcs.csv, model.json, pcv/*.json,
observations_<antenna>.csv}. Same seed + parameters -> byte-identical files (no wall-clock anywhere,
random streams from numpy SeedSequence([seed, pass, antenna, stream])).
"""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from gnssatt.gnss.io.rinex_nav_write import write_rinex_nav_gps
from gnssatt.gnss.io.sp3_write import write_sp3
from gnssatt.gnss.time import GpsTime
from gnssatt.sim import _rot
from gnssatt.sim import observables as ob
from gnssatt.sim._constants import (C_M_S, F_L1_HZ, F_L2_HZ, GAMMA_L2, LEAP_TABLE_EXPIRES,
                                   leap_expiry_warning)
from gnssatt.sim._frames import EarthRotation
from gnssatt.sim._rinex_obs_out import ObsHeader, write_obs
from gnssatt.sim.constellation import RECORD_INTERVAL_S as GPS_RECORD_S, gps_from_nav, synthetic_gps
from gnssatt.sim.glonass_constellation import MixedConstellation, glonass_from_nav, synthetic_glonass
from gnssatt.sim.scenarios import SimParams, list_scenarios, make_params
from gnssatt.sim.trajectory import (AttitudeProfile, Platform, orbit_from_sp3_file, orbit_kepler_j2, orbit_tle,
                                   read_quaternion_csv, terrestrial_from_csv, terrestrial_static)

Progress = Callable[[float, str], None] | None
_DOPPLER_H_S = 0.01      # half-step of the central difference giving Doppler (truncation < 1e-6 Hz)
_STREAMS = {"clock": 1, "bias": 2, "track": 3, "slip": 4, "gap": 5, "outage": 6, "mp": 7, "noise": 8,
            "amb": 9, "pcv": 10, "cn0": 11, "ref": 12, "att": 13, "pco": 14}


@dataclass
class SimResult:
    """What simulate_scenario wrote: one entry per set (pass) with its directory and files."""

    scenario: str
    seed: int
    out_dir: Path
    params: dict
    sets: list[dict] = field(default_factory=list)   # {"dir", "files": {...}, "summary": {...}}


def _rng(seed: int, pass_idx: int, ant_idx: int, stream: str) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), pass_idx, ant_idx, _STREAMS[stream]]))


def simulate_scenario(scenario: str, out_dir: Path, *, seed: int = 0, overrides: dict | None = None,
                      progress: Progress = None) -> SimResult:
    """Simulate preset `scenario` (with `overrides`) into `out_dir`; returns a SimResult.

    Args:
        scenario: one of list_scenarios() (earth-pointing, slew, ttff, calibration, hard, cubesat,
            ground-static).
        out_dir: directory to write into (created). With count > 1 each set goes to out_dir/pass_NNN/.
        seed: random seed of every stochastic element (noise, multipath, clocks, events, ambiguities).
        overrides: {parameter: value}; unknown keys -> ValueError naming the key.
        progress: optional callable(fraction in [0, 1], stage text).
    """
    params = make_params(scenario, overrides)
    _validate(params)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    res = SimResult(scenario, int(seed), out_dir, dataclasses.asdict(params))
    n = max(1, int(params.count))
    for p in range(n):
        set_dir = out_dir if n == 1 else out_dir / f"pass_{p:03d}"

        def sub(frac, stage, _p=p):
            if progress is not None:
                progress((_p + frac) / n, stage if n == 1 else f"pass {_p + 1}/{n}: {stage}")
        res.sets.append(_simulate_one(params, scenario, set_dir, int(seed), p, sub))
    if progress is not None:
        progress(1.0, "done")
    return res


def _validate(p: SimParams):
    if p.kind not in ("spacecraft", "terrestrial"):
        raise ValueError(f"kind must be spacecraft or terrestrial, not {p.kind!r}")
    if p.master not in p.antennas:
        raise ValueError(f"master {p.master!r} is not one of the antennas {list(p.antennas)}")
    if not set(p.signals) <= {"L1", "L2"} or "L1" not in p.signals:
        raise ValueError(f"signals must be ['L1'] or ['L1', 'L2'], not {p.signals!r}")
    if p.duration_s <= 0 or p.interval_s <= 0:
        raise ValueError("duration_s and interval_s must be positive")
    if p.clock_mode not in ("steered", "free"):
        raise ValueError(f"clock_mode must be steered or free, not {p.clock_mode!r}")
    for a in p.antenna_offsets_mm:
        if a not in p.antennas:
            raise ValueError(f"antenna_offsets_mm names unknown antenna {a!r}")
    if p.systems not in ("G", "R", "G+R"):
        raise ValueError(f"systems must be G, R or G+R, not {p.systems!r}")
    for a in p.receiver_types:
        if a not in p.antennas:
            raise ValueError(f"receiver_types names unknown antenna {a!r}")


# ----------------------------------------------------------------------------------------------- one set
_LAMBDA_M = {"L1": C_M_S / F_L1_HZ, "L2": C_M_S / F_L2_HZ}
_TGD_FACTOR = {"L1": 1.0, "L2": GAMMA_L2}       # IS-GPS-200 20.3.3.3.3.2: T_GD on L1, gamma T_GD on L2


@dataclass
class _SetContext:
    """What every stage of one simulated set shares: parameters, identity, epochs, platform and constellation.

    Epochs are receiver time tags t0 + dt_tag (s); the constellation's own time is off + dt_tag.
    """

    p: SimParams
    scenario: str
    seed: int
    pidx: int
    set_dir: Path
    t0: GpsTime
    dt_tag: np.ndarray
    tags: GpsTime
    earth: EarthRotation
    platform: Platform
    const: object
    off: float
    sigs: list[str]

    @property
    def n_ep(self) -> int:
        return int(self.dt_tag.size)

    @property
    def n_sv(self) -> int:
        return int(self.const.n)

    def rng(self, ant_idx: int, stream: str) -> np.random.Generator:
        return _rng(self.seed, self.pidx, ant_idx, stream)


@dataclass
class _Atmosphere:
    """Common atmosphere of a set, once per epoch at the CoM along the master's lines of sight (m)."""

    iono: dict                   # signal -> (n_ep, n_sv) ionospheric group delay on that signal
    trop: np.ndarray             # (n_ep, n_sv) troposphere (terrestrial only, else zero)
    rate: dict                   # signal -> (n_ep, n_sv) d(trop - iono)/dt, m/s (enters the Doppler)
    sin_el_local: np.ndarray     # (n_ep, n_sv) sine of the local elevation


def _simulate_one(p: SimParams, scenario: str, set_dir: Path, seed: int, pidx: int, progress) -> dict:
    """Simulate and write one set (pass): platform, antennas, geometry, atmosphere, observables, files."""
    set_dir.mkdir(parents=True, exist_ok=True)
    for sub in ("obs", "nav", "truth", "truth/pcv"):
        (set_dir / sub).mkdir(parents=True, exist_ok=True)
    start = GpsTime.from_iso(p.start_gps) + pidx * p.pass_spacing_s
    t0 = GpsTime(int(start.s))                     # whole second; epochs are t0 + dt_tag
    first = float(start - t0)
    n_ep = int(np.floor(p.duration_s / p.interval_s + 1e-9)) + 1
    dt_tag = first + np.arange(n_ep) * p.interval_s
    span = (dt_tag[0] - 5.0, dt_tag[-1] + 5.0)
    earth = EarthRotation(int(t0.s), span)
    progress(0.02, "orbit and attitude")
    attitude = _attitude_profile(p, _rng(seed, pidx, 0, "att"), int(t0.s))
    platform = Platform(p.kind, _centre_of_mass(p, earth, span, t0, pidx), attitude, earth)
    const = _constellation(p, t0, span, earth.leap_s)
    ctx = _SetContext(p, scenario, seed, pidx, set_dir, t0, dt_tag, t0 + dt_tag, earth, platform, const,
                      float(t0 - const.t_ref), [s for s in ("L1", "L2") if s in p.signals])
    n_sv = ctx.n_sv
    ant_ids = list(p.antennas)

    # --- nominal-epoch quantities: CoM, attitude, satellite axes ---
    r_com_nom, R_e_b_nom, R_e_i_nom = platform.state(dt_tag)
    r_sv_nom, _ = const.position_clock(ctx.off + dt_tag[:, None] + np.zeros((1, n_sv)))
    r_sv_nom1, _ = const.position_clock(ctx.off + dt_tag[:, None] + 1.0 + np.zeros((1, n_sv)))
    sat_axes = ob.satellite_axes(r_sv_nom, r_sv_nom1, 1.0)

    sat_phase_bias = {f: _rng(seed, pidx, 99, "bias").uniform(0, 1, n_sv) if f == "L1"
                      else _rng(seed, pidx, 98, "bias").uniform(0, 1, n_sv) for f in ctx.sigs}
    antennas = {aid: _antenna_truth(p, seed, pidx, ai, aid) for ai, aid in enumerate(ant_ids)}
    geo = {}
    for ai, aid in enumerate(ant_ids):
        progress(0.05 + 0.4 * ai / len(ant_ids), f"geometry {aid}")
        geo[aid] = _antenna_geometry(ctx, antennas[aid], sat_axes)
    atm = _atmosphere(ctx, r_com_nom, geo[p.master]["e"])

    # --- per antenna signals, tracking, observables ---
    truth_rows, arc_rows, obs_files = [], [], {}
    summary = {"n_epochs": n_ep, "antennas": {}}
    comp_files = {}
    for ai, aid in enumerate(ant_ids):
        progress(0.45 + 0.45 * ai / len(ant_ids), f"observables {aid}")
        A, G = antennas[aid], geo[aid]
        approx = r_com_nom[0] + R_e_b_nom[0] @ A["pos"]
        ant_sum, gap, outage, comp, tracked = _antenna_observables(ctx, ai, aid, A, G, atm, sat_phase_bias,
                                                                   approx, arc_rows)
        obs_files[aid] = f"obs/{aid}.rnx"
        summary["antennas"][aid] = {"signals": ant_sum, "gap_epochs": int(gap.sum()),
                                    "outage_epochs": int(outage.sum()),
                                    "clock_jumps": int(np.count_nonzero(np.diff(G["k_jump"])))}
        truth_rows.append((aid, G, gap))
        if p.truth_components:
            comp_files[aid] = _write_components(set_dir / "truth" / f"observations_{aid}.csv", ctx.tags,
                                                const.sats, G, comp, tracked, ctx.sigs, gap)
    progress(0.92, "files (nav, SP3, attitude, truth)")
    _write_platform_files(ctx, antennas, obs_files)
    _write_attitude(set_dir / "truth" / "attitude.csv", ctx.tags, R_e_b_nom, R_e_i_nom,
                    platform.reference_dcm(dt_tag), geo[p.master], p)
    _write_reference(set_dir / "reference_attitude.csv", p, platform, t0, dt_tag, _rng(seed, pidx, 0, "ref"))
    _write_receivers(set_dir / "truth" / "receivers.csv", ctx.tags, truth_rows, antennas)
    _write_arcs(set_dir / "truth" / "arcs.csv", ctx.tags, arc_rows)
    pcv_files = _write_pcv_maps(set_dir / "truth" / "pcv", p, antennas, ctx.sigs)
    model = _model_json(p, scenario, seed, pidx, t0, antennas, const, sat_phase_bias, ctx.sigs, earth, pcv_files)
    (set_dir / "truth" / "model.json").write_text(json.dumps(model, indent=1, sort_keys=True) + "\n")
    files = {"obs": {a: str(set_dir / f) for a, f in obs_files.items()}, "nav": str(set_dir / "nav" / "brdc.rnx"),
             "platform_json": str(set_dir / "platform.json"), "reference_attitude": str(set_dir /
                                                                                         "reference_attitude.csv"),
             "truth_dir": str(set_dir / "truth")}
    if p.sp3_interval_s > 0:
        files["sp3"] = str(set_dir / "platform.sp3")
    return {"dir": str(set_dir), "files": files, "summary": summary}


def _constellation(p: SimParams, t0: GpsTime, span: tuple, leap_s: int):
    """GPS (Constellation, as before GLONASS existed), or a MixedConstellation when `systems` includes R."""
    gps = None
    if "G" in p.systems:
        gps = gps_from_nav(p.nav_file, t0) if p.nav_file else synthetic_gps(t0, seed=p.constellation_seed)
        if p.systems == "G":
            return gps
    t_ref = gps.t_ref if gps is not None else GpsTime(int(t0.s) - int(t0.s) % GPS_RECORD_S)
    off = float(t0 - t_ref)
    span_ref = (off + span[0] - 1.0, off + span[1] + 2.0)
    glo = (glonass_from_nav(p.nav_file, t0, t_ref, span_ref, leap_s) if p.nav_file
           else synthetic_glonass(t_ref, span_ref, leap_s, seed=p.constellation_seed))
    return MixedConstellation(gps, glo)


def _lambda_m(const, f: str):
    """Wavelength of signal f: one number (GPS-only sets), else (n_sv,) per satellite (GLONASS channels)."""
    return const.wavelength_m(f) if isinstance(const, MixedConstellation) else _LAMBDA_M[f]


def _receiver_type(p: SimParams, aid: str) -> str:
    return p.receiver_types.get(aid) or ("SPACEBORNE SIM OEM4" if p.kind == "spacecraft" else "SIM RX")


def _glonass_icb_m(p: SimParams, aid: str, const, f: str) -> tuple[np.ndarray, np.ndarray]:
    """(code, phase) inter-channel biases (n_sv,) in m of antenna aid's receiver model on signal f: a per-k slope
    plus an optional per-channel table (non-linear part); zero for GPS and for models without an entry."""
    spec = p.glonass_icb_by_model.get(_receiver_type(p, aid), {})
    spec = spec.get(f, spec)
    k = const.channels
    out = []
    for kind in ("code", "phase"):
        table = spec.get(f"{kind}_m_by_k", {})
        extra = np.array([float(table.get(str(int(x)), table.get(int(x), 0.0))) for x in k])
        out.append(np.where(const.is_glonass, float(spec.get(f"{kind}_m_per_k", 0.0)) * k + extra, 0.0))
    return out[0], out[1]


def _centre_of_mass(p: SimParams, earth: EarthRotation, span: tuple, t0: GpsTime, pidx: int):
    """The platform's centre-of-mass trajectory: Kepler + J2, TLE (SGP4) or SP3 orbit, or a terrestrial track."""
    if p.kind != "spacecraft":
        return (terrestrial_from_csv(earth, int(t0.s), p.trajectory_csv) if p.trajectory_csv
                else terrestrial_static(earth, p.lat_deg, p.lon_deg, p.height_m))
    if p.orbit_source == "kepler-j2":
        return orbit_kepler_j2(earth, span, perigee_alt_km=p.perigee_alt_km, apogee_alt_km=p.apogee_alt_km,
                               inclination_deg=p.inclination_deg, raan_deg=p.raan_deg, argp_deg=p.argp_deg,
                               mean_anomaly_deg=p.mean_anomaly_deg + 360.0 * 0.37 * pidx)
    if p.orbit_source == "tle":
        return orbit_tle(earth, span, int(t0.s), earth.leap_s, p.tle_line1, p.tle_line2)
    if p.orbit_source == "sp3":
        return orbit_from_sp3_file(earth, span, int(t0.s), p.orbit_sp3_path)
    raise ValueError(f"orbit_source must be kepler-j2, tle or sp3, not {p.orbit_source!r}")


def _antenna_truth(p: SimParams, seed: int, pidx: int, ai: int, aid: str) -> dict:
    """Static truth of antenna ``aid``: position, offset, frame, PCV grids, PCOs, receiver clock and biases."""
    spec = p.antennas[aid]
    pos = np.asarray(spec["position_m"], dtype=np.float64)
    bore = np.asarray(spec.get("boresight", [0, 0, -1]), dtype=np.float64)
    offset = np.asarray(p.antenna_offsets_mm.get(aid, [0, 0, 0]), dtype=np.float64) / 1e3
    R_a_b = ob.antenna_frame(bore)
    # PCV and PCO belong to the antennas, not to a pass: every pass of a multi-pass run (a calibration
    # campaign) sees the same hardware, so their random streams do not depend on the pass index.
    prng = _rng(seed, 0, ai, "pcv")
    pcv = {f: ob.pcv_grid_mm(prng, p.pcv_peak_to_peak_mm * (p.l2_pcv_factor if f == "L2" else 1.0)
                             * prng.uniform(0.8, 1.0)) if p.pcv else np.zeros((len(ob.PCV_EL_DEG),
                                                                               len(ob.PCV_AZ_DEG)))
           for f in ("L1", "L2")}
    crng = _rng(seed, 0, ai, "pco")
    pco = {f: ((np.asarray(p.pco_nominal_mm[k]) + crng.normal(0, p.pco_scatter_mm, 3)) / 1e3 if p.pco
               else np.zeros(3)) for k, f in enumerate(("L1", "L2"))}
    brng = _rng(seed, pidx, ai, "bias")
    clk_rng = _rng(seed, pidx, ai, "clock")
    if p.clock_mode == "steered":
        clock = ob.ClockModel("steered", bias_s=clk_rng.uniform(-1, 1) * 0.3 * p.clock_steer_amp_s,
                              amp_s=p.clock_steer_amp_s * clk_rng.uniform(0.5, 1.0),
                              period_s=clk_rng.uniform(900, 3000), phase_rad=clk_rng.uniform(0, 2 * np.pi))
    else:
        clock = ob.ClockModel("free", bias_s=clk_rng.uniform(-4e-4, 4e-4),
                              drift_s_s=p.clock_free_drift_ppm * 1e-6 * clk_rng.choice([-1, 1])
                              * clk_rng.uniform(0.6, 1.0), jump_in_phase=p.clock_jump_in_phase)
    return dict(id=aid, index=ai, pos=pos, offset=offset, arp=pos + offset, bore=bore, R_a_b=R_a_b,
                pcv=pcv, pco=pco, clock=clock,
                code_bias={f: float(brng.normal(0, p.code_bias_sigma_m)) for f in ("L1", "L2")},
                phase_bias={f: float(brng.uniform(0, 1)) for f in ("L1", "L2")})


def _antenna_geometry(ctx: _SetContext, A: dict, sat_axes: tuple) -> dict:
    """Per-epoch geometry of one antenna in true time: light-time ranges, lines of sight, range rate (central
    difference of rho + c(dt_rx - dt_sv) in receiver time), antenna-frame az/el, wind-up and Earth blockage."""
    p, platform, const, off, dt_tag = ctx.p, ctx.platform, ctx.const, ctx.off, ctx.dt_tag
    n_ep, n_sv = ctx.n_ep, ctx.n_sv
    x_s, y_s = sat_axes
    k_jump = A["clock"].jumps(np.round(dt_tag))
    dtr = A["clock"].offset(dt_tag, k_jump)
    t_true = dt_tag - dtr
    r_com, R_e_b, _ = platform.state(t_true)
    r_ant = r_com + np.einsum("nij,j->ni", R_e_b, A["arp"])
    rho, e, dt_sv, tau, r_s = ob.light_time_geometry(const, off + t_true, r_ant)
    # Doppler: central difference of rho + c(dt_rx - dt_sv) in receiver time
    gpm = []
    for sgn in (1.0, -1.0):
        T = dt_tag + sgn * _DOPPLER_H_S
        dtr_h = A["clock"].offset(T, k_jump)
        th = T - dtr_h
        rc, Rb, _ = platform.state(th)
        ra = rc + np.einsum("nij,j->ni", Rb, A["arp"])
        rho_h, _, dsv_h, _, _ = ob.light_time_geometry(const, off + th, ra, tau0=tau, iters=2)
        gpm.append(rho_h + C_M_S * (dtr_h[:, None] - dsv_h))
    range_rate = (gpm[0] - gpm[1]) / (2 * _DOPPLER_H_S)
    e_body = np.einsum("nji,nsj->nsi", R_e_b, e)
    e_ant = e_body @ A["R_a_b"].T
    el = np.degrees(np.arcsin(np.clip(e_ant[..., 2], -1, 1)))
    az = np.mod(np.degrees(np.arctan2(e_ant[..., 1], e_ant[..., 0])), 360.0)
    x_r = np.einsum("nij,j->ni", R_e_b, A["R_a_b"][0])
    y_r = np.einsum("nij,j->ni", R_e_b, A["R_a_b"][1])
    if p.windup and p.windup_antenna is not None:      # a real antenna's wind-up (seed 003 eq. 32)
        from gnssatt.sim.vector_windup import vector_windup_cycles
        w = vector_windup_cycles(p.windup_antenna, e, R_e_b, A["R_a_b"], x_s, y_s)
    else:
        w = ob.windup_cycles(e, x_r, y_r, x_s, y_s) if p.windup else np.zeros((n_ep, n_sv))
    blocked = (ob.earth_blocked(r_ant, e, rho, p.earth_block_height_km * 1e3) if p.kind == "spacecraft"
               else np.zeros((n_ep, n_sv), bool))   # terrestrial: the local elevation mask decides
    return dict(k_jump=k_jump, dtr=dtr, t_true=t_true, r_ant=r_ant, rho=rho, e=e, dt_sv=dt_sv, tau=tau,
                range_rate=range_rate, el=el, az=az, windup=w, blocked=blocked, e_ant=e_ant)


def _atmosphere(ctx: _SetContext, r_com_nom: np.ndarray, e_master: np.ndarray) -> _Atmosphere:
    """Ionosphere (L1 delay, gamma times on L2) and troposphere once per epoch at the CoM, master line of sight."""
    p, dt_tag = ctx.p, ctx.dt_tag
    tod = np.mod((ctx.t0.s % 86400) + dt_tag, 86400.0)
    iono_l1, sin_el_local = ob.ionosphere_l1_m(r_com_nom, e_master, tod, p.kind, p.vtec_tecu)
    if not p.ionosphere:
        iono_l1 = np.zeros_like(iono_l1)
    trop = (ob.troposphere_m(sin_el_local, 2.4) if (p.kind == "terrestrial" and p.troposphere)
            else np.zeros_like(iono_l1))
    if isinstance(ctx.const, MixedConstellation):     # 1/f^2 of each satellite's carrier
        iono = {f: iono_l1 * ctx.const.iono_factor(f)[None, :] for f in ("L1", "L2")}
    else:
        iono = {"L1": iono_l1, "L2": iono_l1 * GAMMA_L2}
    atm_rate = {f: np.gradient(trop - iono[f], p.interval_s, axis=0) if ctx.n_ep > 1 else np.zeros_like(trop)
                for f in ctx.sigs}
    return _Atmosphere(iono, trop, atm_rate, sin_el_local)


def _tracking(ctx: _SetContext, ai: int, aid: str, G: dict, atm: _Atmosphere) -> tuple:
    """C/N0 per signal (gain pattern, range loss, Gauss-Markov jitter), outages, data gaps and the receiver's
    tracking state machine of one antenna: returns (cn0, outage, gap, tracked), per signal (n_ep, n_sv)."""
    p, dt_tag, n_ep, n_sv = ctx.p, ctx.dt_tag, ctx.n_ep, ctx.n_sv
    visible = ~G["blocked"]
    if p.kind == "terrestrial":
        visible &= atm.sin_el_local >= np.sin(np.radians(p.elevation_mask_deg))
    cn0_rng = ctx.rng(ai, "cn0")
    jitter = ob.gauss_markov(cn0_rng, n_ep, n_sv, p.interval_s, 20.0) * p.cn0_jitter_db
    cn0 = {}
    base = (p.cn0_zenith_l1_dbhz + ob.gain_db(G["el"], p.gain_horizon_loss_db, p.gain_backlobe_db_per_deg)
            - 20 * np.log10(G["rho"] / 2.2e7) + jitter)
    cn0["L1"] = np.where(visible, base, np.nan)
    cn0["L2"] = np.where(visible, base + p.l2_cn0_offset_db
                         + ob.gauss_markov(cn0_rng, n_ep, n_sv, p.interval_s, 20.0) * p.cn0_jitter_db, np.nan)
    # outages and gaps
    out_rng = ctx.rng(ai, "outage")
    outage = ob.poisson_windows(out_rng, n_ep, p.interval_s, p.outage_rate_per_hour, tuple(p.outage_length_s))
    for who, s0, dur in p.outage_windows:
        if who in ("*", aid):
            outage |= (dt_tag - dt_tag[0] >= s0) & (dt_tag - dt_tag[0] < s0 + dur)
    gap = ob.poisson_windows(ctx.rng(ai, "gap"), n_ep, p.interval_s, p.gap_rate_per_hour,
                             tuple(p.gap_length_s))
    n_sys = len(p.systems.split("+"))             # n_channels per system (separate GPS and GLONASS channels)
    cfg = ob.TrackingConfig(n_channels=p.n_channels * n_sys, acq_l1_dbhz=p.acq_l1_dbhz, trk_l1_dbhz=p.trk_l1_dbhz,
                            acq_l2_dbhz=p.acq_l2_dbhz, trk_l2_dbhz=p.trk_l2_dbhz,
                            acq_delay_l1_s=tuple(p.acq_delay_l1_s) if p.acquisition_delays else (0.0, 0.0),
                            acq_delay_l2_s=tuple(p.acq_delay_l2_s) if p.acquisition_delays else (0.0, 0.0))
    trk1, trk2 = ob.track(cn0["L1"], cn0["L2"] if "L2" in ctx.sigs else None, outage, p.interval_s, cfg,
                          ctx.rng(ai, "track"))
    return cn0, outage, gap, {"L1": trk1, "L2": trk2}


@dataclass
class _AntennaStreams:
    """The random streams of one antenna's observables, shared by its signals in order (L1 then L2)."""

    slip: np.random.Generator
    mp: np.random.Generator
    noise: np.random.Generator
    amb: np.random.Generator


def _antenna_observables(ctx: _SetContext, ai: int, aid: str, A: dict, G: dict, atm: _Atmosphere,
                         sat_phase_bias: dict, approx_xyz_m: np.ndarray, arc_rows: list) -> tuple:
    """Observables of one antenna (code, phase, Doppler, C/N0 per signal) written to obs/<aid>.rnx; appends the
    arcs to ``arc_rows``; returns (per-signal summary, gap, outage, truth components, tracked)."""
    p = ctx.p
    cn0, outage, gap, tracked = _tracking(ctx, ai, aid, G, atm)
    streams = _AntennaStreams(ctx.rng(ai, "slip"), ctx.rng(ai, "mp"), ctx.rng(ai, "noise"), ctx.rng(ai, "amb"))
    values, llis, ssis, types, types_r = [], [], [], [], []
    comp = {}
    ant_sum = {}
    for f in ctx.sigs:
        obs, comp[f], arcs, n_arc = _signal_observables(ctx, f, A, G, atm, cn0[f], tracked[f], gap,
                                                        sat_phase_bias[f], streams)
        trk = tracked[f]
        sig = "1C" if f == "L1" else "2W"
        for typ, (val, l_, s_) in zip("CLDS", obs):
            values.append(np.where(trk, val, np.nan))
            llis.append(np.where(trk, l_, 0))
            ssis.append(np.where(trk, s_, 0))
            types.append(typ + sig)
            types_r.append(typ + ("1C" if f == "L1" else "2P"))
        for j in range(len(arcs.sat)):
            sat = ctx.const.sats[arcs.sat[j]]
            arc_rows.append((aid, sat, _truth_signal(sat, f), arcs.start[j], arcs.end[j], arcs.cause[j],
                             int(arcs.lli[j]), int(n_arc[j])))
        ant_sum[f] = {"n_obs": int(trk[~gap].sum()), "n_arcs": len(arcs.sat),
                      "n_slips": int(sum(c == "slip" for c in arcs.cause))}
    vals = np.stack(values, axis=-1)
    vals[gap] = np.nan
    header = ObsHeader(marker=aid, obs_types=types, interval_s=p.interval_s, approx_xyz_m=approx_xyz_m,
                       antenna_delta_xyz_m=A["pos"], boresight=A["bore"],
                       receiver=_receiver_type(p, aid),
                       marker_type="SPACEBORNE" if p.kind == "spacecraft" else "GEODETIC",
                       antenna_type="SIM PATCH", leap_s=ctx.earth.leap_s,
                       comments=[f"gnssatt simulator scenario {ctx.scenario} seed {ctx.seed} pass {ctx.pidx}",
                                 "time tags in receiver time; see truth/receivers.csv"],
                       date_text=_date_text(ctx.t0), **_glonass_header(ctx.const, p.systems, types_r))
    write_obs(ctx.set_dir / "obs" / f"{aid}.rnx", header, epochs=ctx.tags, sats=ctx.const.sats, values=vals,
              lli=np.stack(llis, axis=-1), ssi=np.stack(ssis, axis=-1))
    return ant_sum, gap, outage, comp, tracked


def _truth_signal(sat: str, f: str) -> str:
    """Signal name in truth/arcs.csv: "L1"/"L2" for GPS (as always), "R:G1"/"R:G2" for GLONASS."""
    return f if sat[0] == "G" else {"L1": "R:G1", "L2": "R:G2"}[f]


def _glonass_header(const, systems: str, types_r: list) -> dict:
    """ObsHeader fields of the GLONASS part: systems, R observation types, GLONASS SLOT / FRQ # pairs."""
    if not isinstance(const, MixedConstellation):
        return {}
    slots = tuple((int(s[1:]), int(k)) for s, k, r in zip(const.sats, const.channels, const.is_glonass) if r)
    return {"systems": systems.replace("+", ""), "glonass_obs_types": tuple(types_r), "glonass_slots": slots}


def _signal_observables(ctx: _SetContext, f: str, A: dict, G: dict, atm: _Atmosphere, cn0_f: np.ndarray,
                        trk: np.ndarray, gap: np.ndarray, sat_phase_bias_f: np.ndarray,
                        streams: _AntennaStreams) -> tuple:
    """Code (m), phase (cycles), Doppler (Hz) and C/N0 (dB-Hz) of one antenna on signal ``f``, before masking by
    tracking: returns ((value, lli, ssi) for C, L, D, S; truth components; arcs; integer per arc).

    Implements: the observation equations of docs/simulator.md "Models" (stated in truth/model.json),
    code = rho + pco + c(dt_rx + k_f T_GD - dt_sv) + T + I_f + bias + mp + noise,
    phase = rho + pco + pcv + c(dt_rx - dt_sv) + T - I_f + lambda_f (windup + biases + N) + mp + noise.
    """
    p, const, n_ep, n_sv = ctx.p, ctx.const, ctx.n_ep, ctx.n_sv
    trop, iono = atm.trop, atm.iono
    mrng, nrng, srng, arng = streams.mp, streams.noise, streams.slip, streams.amb
    lam_f = _lambda_m(const, f)
    pco_term = -G["e_ant"] @ A["pco"][f]                            # -e . pco  (m)
    pcv_term = ob.bilinear_pcv_mm(A["pcv"][f], G["az"], G["el"]) / 1e3
    clock_code = G["dtr"]
    clock_phase = G["dtr"] if A["clock"].jump_in_phase else G["dtr"] + 1e-3 * G["k_jump"]
    common = G["rho"] + pco_term - C_M_S * G["dt_sv"] + trop
    code = common + C_M_S * (clock_code[:, None] + _TGD_FACTOR[f] * const.tgd[None, :]) + iono[f] \
        + A["code_bias"][f]
    phase_m = common + pcv_term + C_M_S * clock_phase[:, None] - iono[f] + lam_f * G["windup"]
    if isinstance(const, MixedConstellation) and p.glonass_icb_by_model:
        icb_code, icb_phase = _glonass_icb_m(p, A["id"], const, f)
        code = code + icb_code[None, :]
        phase_m = phase_m + icb_phase[None, :]
    # stochastic parts
    if p.multipath:
        sc = ob.horizon_growth(G["el"], *p.mp_code_m)
        sp = ob.horizon_growth(G["el"], *p.mp_phase_m)
        mp_code = sc * ob.gauss_markov(mrng, n_ep, n_sv, p.interval_s, p.mp_tau_s)
        mp_phase = sp * ob.gauss_markov(mrng, n_ep, n_sv, p.interval_s, p.mp_tau_s)
    else:
        mp_code = np.zeros((n_ep, n_sv))
        mp_phase = np.zeros((n_ep, n_sv))
    fac = ob.noise_scale(cn0_f, p.noise_ref_cn0_dbhz, p.noise_grows_with_cn0, p.noise_scale_max) \
        * (p.l2_noise_factor if f == "L2" else 1.0)
    if p.noise:
        n_code = nrng.standard_normal((n_ep, n_sv)) * p.noise_code_m * fac
        n_phase = nrng.standard_normal((n_ep, n_sv)) * p.noise_phase_m * fac
        n_dop = nrng.standard_normal((n_ep, n_sv)) * p.noise_doppler_hz * fac
    else:
        n_code = n_phase = n_dop = np.zeros((n_ep, n_sv))
    code_obs = code + mp_code + n_code
    phase_wo_n = phase_m + mp_phase + n_phase + lam_f * (A["phase_bias"][f] + sat_phase_bias_f[None, :])
    arcs, n_arc, lli = _arcs_and_integers(p, trk, cn0_f, gap, code_obs, phase_wo_n, lam_f, srng, arng)
    amb = np.where(arcs.arc_id >= 0, n_arc[np.maximum(arcs.arc_id, 0)] if len(n_arc) else 0, 0)
    phase_cyc = phase_wo_n / lam_f + amb
    dop = -(G["range_rate"] + np.gradient(pco_term + pcv_term + lam_f * G["windup"], p.interval_s, axis=0)
            + atm.rate[f]) / lam_f + n_dop
    cn0_w = np.round(cn0_f, 1)
    ssi = np.clip(np.floor(np.nan_to_num(cn0_w, nan=0) / 6.0), 1, 9).astype(np.int64)
    obs = ((code_obs, 0 * lli, ssi), (phase_cyc, lli, ssi), (dop, 0 * lli, ssi), (cn0_w, 0 * lli, 0 * ssi))
    comp = dict(pco=pco_term, pcv=pcv_term, mp_code=mp_code, mp_phase=mp_phase, n_code=n_code,
                n_phase=n_phase, iono=iono[f])
    return obs, comp, arcs, n_arc


def _arcs_and_integers(p: SimParams, trk: np.ndarray, cn0_f: np.ndarray, gap: np.ndarray, code_obs: np.ndarray,
                       phase_wo_n: np.ndarray, lam_f: float, srng, arng) -> tuple:
    """Cycle slips (rate growing as C/N0 falls), continuous arcs, one integer ambiguity per arc (near the code at
    the arc's start; a slip jumps it by 1-39 cycles) and the LLI flags: returns (arcs, n_arc, lli)."""
    n_ep, n_sv = trk.shape
    lam_sat = np.broadcast_to(lam_f, (n_sv,))
    if p.slip_rate_per_hour > 0:
        pr = np.clip(p.slip_rate_per_hour / 3600.0 * p.interval_s
                     * 10.0 ** ((40.0 - np.nan_to_num(cn0_f, nan=40.0)) / 10.0), 0, 0.5)
        slip = trk & (srng.random((n_ep, n_sv)) < pr)
        slip_lli = srng.random((n_ep, n_sv)) < p.slip_lli_fraction
    else:
        slip = np.zeros_like(trk)
        slip_lli = np.ones_like(trk)
    arcs = ob.build_arcs(trk, slip, slip_lli)
    n_arc = np.zeros(len(arcs.sat), np.int64)
    last_n = {}
    for j, (s, a, cause) in enumerate(zip(arcs.sat, arcs.start, arcs.cause)):
        if cause == "slip" and s in last_n:
            jump = int(arng.integers(1, 40)) * int(arng.choice([-1, 1]))
            n_arc[j] = last_n[s] + jump
        else:
            n_arc[j] = int(np.round((code_obs[a, s] - phase_wo_n[a, s]) / lam_sat[s])) + int(arng.integers(-5, 6))
        last_n[s] = n_arc[j]
    arcs.n_cyc = n_arc.tolist()
    lli = np.zeros((n_ep, n_sv), np.int64)
    for s, a, b, fl in zip(arcs.sat, arcs.start, arcs.end, arcs.lli):
        if fl:   # an arc starting inside a data gap flags its first epoch in the file
            k = a
            while k <= b and gap[k]:
                k += 1
            if k <= b:
                lli[k, s] = 1
    return arcs, n_arc, lli


def _declared_phase_centre(p, sigs, antenna: str) -> dict:
    """platform.json's declared phase-centre uncertainty of one antenna
    (docs/formats/platform_antenna_uncertainty.md): the spec the simulator draws from, not the drawn values -
    pco_sigma_mm = the PCO scatter per axis combined with the antenna's hidden fixed offset
    (`antenna_offsets_mm`, the calibration preset's Table 3 shifts) as its per-axis RMS, pcv_rms_mm per signal =
    the expected RMS over the upper hemisphere of pcv_grid_mm's pattern (observables.PCV_RMS_PER_PEAK_TO_PEAK x
    the peak-to-peak x the RMS of its uniform(0.8, 1) scale, x l2_pcv_factor on L2)."""
    scale_rms = float(np.sqrt((1.0 - 0.8 ** 3) / (3 * 0.2)))
    pcv = {f: round(ob.PCV_RMS_PER_PEAK_TO_PEAK * p.pcv_peak_to_peak_mm * scale_rms
                    * (p.l2_pcv_factor if f == "L2" else 1.0), 3) if p.pcv else 0.0 for f in sigs}
    scatter_mm = float(p.pco_scatter_mm) if p.pco else 0.0
    hidden_ms_mm2 = float(np.mean(np.square(p.antenna_offsets_mm.get(antenna, [0.0, 0.0, 0.0]))))
    return {"pco_sigma_mm": round(float(np.sqrt(scatter_mm ** 2 + hidden_ms_mm2)), 3), "pcv_rms_mm": pcv}


def _write_platform_files(ctx: _SetContext, antennas: dict, obs_files: dict) -> None:
    """nav/brdc.rnx (the constellation as broadcast), platform.json and platform.sp3 (CoM truth orbit)."""
    p, set_dir, t0, tags, dt_tag = ctx.p, ctx.set_dir, ctx.t0, ctx.tags, ctx.dt_tag
    const = ctx.const
    mixed = isinstance(const, MixedConstellation)
    gps = const.gps if mixed else const
    recs = gps.records(tags[0], tags[-1]) if gps is not None else []
    glo_recs = const.glonass.records(tags[0], tags[-1], ctx.earth.leap_s) if mixed else []
    write_rinex_nav_gps(set_dir / "nav" / "brdc.rnx", recs, date_text=_date_text(t0), glonass_records=glo_recs,
                        iono_alpha=[1.1176e-08, 7.4506e-09, -5.9605e-08, -5.9605e-08],
                        iono_beta=[9.0112e+04, 1.6384e+04, -1.9661e+05, -6.5536e+04], leap_seconds=ctx.earth.leap_s,
                        comments=[_nav_comment(p)])
    ant_ids = list(p.antennas)
    pj = {"name": p.platform_name, "kind": p.kind,
          "antennas": {a: {"position_m": [float(v) for v in antennas[a]["pos"]],
                           "boresight": [float(v) for v in antennas[a]["bore"]], **_declared_phase_centre(p, ctx.sigs, a)}
                       for a in ant_ids},
          "master": p.master, "baselines": [[p.master, a] for a in ant_ids if a != p.master],
          "observation_files": obs_files}
    (set_dir / "platform.json").write_text(json.dumps(pj, indent=2) + "\n")
    if p.sp3_interval_s > 0:
        sp3_dt = np.arange(dt_tag[0], dt_tag[-1] + 1e-9, p.sp3_interval_s)
        r_sp3 = ctx.platform.com.r_ecef(sp3_dt)
        v_sp3 = (ctx.platform.com.r_ecef(sp3_dt + 0.5) - ctx.platform.com.r_ecef(sp3_dt - 0.5))
        write_sp3(set_dir / "platform.sp3", t0 + sp3_dt, ["L01"], r_sp3[:, None, :], v_sp3[:, None, :],
                  comments=[f"{p.platform_name} centre of mass, gnssatt simulator",
                            f"scenario {ctx.scenario} seed {ctx.seed} pass {ctx.pidx}", "ECEF, EOP zero",
                            "truth orbit"])


def _nav_comment(p: SimParams) -> str:
    what = {"G": "GPS", "R": "GLONASS", "G+R": "GPS+GLONASS"}[p.systems]
    return (f"{what} constellation from {Path(p.nav_file).name}, gnssatt simulator" if p.nav_file
            else f"synthetic {what} constellation, gnssatt simulator")


def _date_text(t0: GpsTime) -> str:
    y, mo, d, hh, mi, ss = (int(v) for v in t0.calendar())
    return f"{y:04d}{mo:02d}{d:02d} {hh:02d}{mi:02d}{ss:02d} GPS"


def _attitude_profile(p: SimParams, rng, t0_s: int) -> AttitudeProfile:
    wob_phase = tuple(rng.uniform(0, 2 * np.pi, 3))
    wob = dict(wobble_amp_deg=tuple(p.wobble_amp_deg), wobble_period_s=tuple(p.wobble_period_s),
               wobble_phase_rad=wob_phase)
    if p.attitude_profile == "quaternion-csv":
        tt, q, frame = read_quaternion_csv(p.attitude_csv, t0_s)
        return AttitudeProfile(kind="quaternion-csv", csv_times_s=tt, csv_q=q, csv_frame=frame)
    if p.random_initial_attitude:
        yaw = rng.uniform(-135, 135)
        pitch = rng.choice([-1, 1]) * rng.uniform(10, 68)
        roll = rng.uniform(-30, 60) if rng.random() > 0.1 else rng.uniform(60, 130)
        ang = float(_rot.rotation_angle_deg(_rot.dcm_from_euler321_deg(yaw, pitch, roll)))
        T = max(1.875 * ang / p.slew_back_rate_deg_s, 1.0)
        wp = [[0.0, yaw, pitch, roll], [p.slew_back_hold_s, yaw, pitch, roll],
              [p.slew_back_hold_s + T, 0.0, 0.0, 0.0]]
        return AttitudeProfile(kind="waypoints", waypoints=tuple(map(tuple, wp)), **wob)
    if p.attitude_profile == "waypoints":
        if not p.waypoints:
            raise ValueError("attitude_profile 'waypoints' needs waypoints [[t_s, yaw, pitch, roll], ...]")
        return AttitudeProfile(kind="waypoints", waypoints=tuple(map(tuple, p.waypoints)), **wob)
    if p.attitude_profile == "earth-pointing":
        return AttitudeProfile(kind="fixed", euler_deg=(0.0, 0.0, 0.0), **wob)
    if p.attitude_profile == "fixed":
        return AttitudeProfile(kind="fixed", euler_deg=tuple(p.euler_deg), **wob)
    raise ValueError(f"attitude_profile must be earth-pointing, fixed, waypoints or quaternion-csv, "
                     f"not {p.attitude_profile!r}")


def _fmt_rows(fmt: str, cols: list) -> str:
    return "".join(fmt % row for row in zip(*cols))


def _write_attitude(path, tags, R_e_b, R_e_i, R_ref_e, Gm, p):
    R_b_e = np.swapaxes(R_e_b, -1, -2)
    qe = _rot.quat_from_dcm(R_b_e)
    qi = _rot.quat_from_dcm(R_b_e @ R_e_i)
    yaw, pitch, roll = _rot.euler321_deg_from_dcm(R_b_e @ np.swapaxes(R_ref_e, -1, -2))
    week, sow = tags.week_sow()
    n = len(sow)
    zero = np.zeros(n)
    head = ("time_gps,gps_week,gps_sow,qe_w,qe_x,qe_y,qe_z,qi_w,qi_x,qi_y,qi_z,yaw_deg,pitch_deg,roll_deg,"
            "sigma_yaw_deg,sigma_pitch_deg,sigma_roll_deg,fixed,n_sats\n")
    iso = tags.iso(3)
    nsat = np.zeros(n, np.int64)
    cols = [iso, week.tolist(), sow.tolist()] + [qe[:, k].tolist() for k in range(4)] + \
        [qi[:, k].tolist() for k in range(4)] + [yaw.tolist(), pitch.tolist(), roll.tolist()] + \
        [zero.tolist()] * 3 + [[1] * n, nsat.tolist()]
    fmt = "%s,%d,%.3f," + ",".join(["%.12f"] * 8) + ",%.9f,%.9f,%.9f,%.1f,%.1f,%.1f,%d,%d\n"
    path.write_text(head + _fmt_rows(fmt, cols))


def _write_reference(path, p: SimParams, platform: Platform, t0: GpsTime, dt_tag, rng):
    dt = np.arange(dt_tag[0], dt_tag[-1] + 1e-9, p.reference_interval_s)
    _, R_e_b, R_e_i = platform.state(dt)
    R_b_i = np.swapaxes(R_e_b, -1, -2) @ R_e_i
    sig = np.radians(p.reference_sigma_arcsec / 3600.0)
    err = rng.standard_normal((len(dt), 3)) * sig
    # small rotation error in the body frame: R_noisy = (I - [err x]) R
    E = np.zeros((len(dt), 3, 3))
    E[:, 0, 1], E[:, 0, 2], E[:, 1, 2] = err[:, 2], -err[:, 1], err[:, 0]
    E = E - np.swapaxes(E, -1, -2)
    R_noisy = (np.eye(3) + E + 0.5 * E @ E) @ R_b_i
    q = _rot.quat_from_dcm(R_noisy)
    iso = (t0 + dt).iso(3)
    fmt = "%s,GCRF,%.12f,%.12f,%.12f,%.12f,%.3f\n"
    path.write_text("time_gps,frame,qw,qx,qy,qz,sigma_arcsec\n" +
                    _fmt_rows(fmt, [iso] + [q[:, k].tolist() for k in range(4)]
                              + [[p.reference_sigma_arcsec] * len(dt)]))


def _write_receivers(path, tags, truth_rows, antennas):
    week, sow = tags.week_sow()
    iso = tags.iso(3)
    parts = ["time_gps,gps_week,gps_sow,antenna,clock_s,clock_jumps_ms,t_true_minus_tag_s,x_ecef_m,y_ecef_m,"
             "z_ecef_m,in_file\n"]
    for aid, G, gap in truth_rows:
        n = len(iso)
        cols = [iso, week.tolist(), sow.tolist(), [aid] * n, G["dtr"].tolist(), G["k_jump"].tolist(),
                (-G["dtr"]).tolist(), G["r_ant"][:, 0].tolist(), G["r_ant"][:, 1].tolist(),
                G["r_ant"][:, 2].tolist(), (~gap).astype(int).tolist()]
        parts.append(_fmt_rows("%s,%d,%.3f,%s,%.15e,%d,%.15e,%.5f,%.5f,%.5f,%d\n", cols))
    path.write_text("".join(parts))


def _write_arcs(path, tags, rows):
    iso = tags.iso(3)
    out = ["antenna,sat,signal,start_time_gps,end_time_gps,cause,lli,ambiguity_cyc\n"]
    for aid, sat, f, a, b, cause, lli, n in rows:
        out.append(f"{aid},{sat},{f},{iso[a]},{iso[b]},{cause},{lli},{n}\n")
    path.write_text("".join(out))


def _write_components(path, tags, sats, G, comp, tracked, sigs, gap):
    """Per-observation truth terms where L1 is tracked (also epochs in gaps, flagged in_file=0)."""
    k, s = np.nonzero(tracked["L1"])
    iso = np.asarray(tags.iso(3))
    cols = [iso[k].tolist(), np.asarray(sats)[s].tolist(), G["rho"][k, s].tolist(), G["dt_sv"][k, s].tolist(),
            G["tau"][k, s].tolist(), G["az"][k, s].tolist(), G["el"][k, s].tolist(),
            comp["L1"]["iono"][k, s].tolist(), G["windup"][k, s].tolist()]
    head = "time_gps,sat,rho_m,dt_sv_s,tau_s,az_ant_deg,el_ant_deg,iono_l1_m,windup_cyc"
    fmt = "%s,%s,%.5f,%.15e,%.12e,%.5f,%.5f,%.5f,%.6f"
    for f in sigs:
        for key in ("pco", "pcv", "mp_code", "mp_phase", "n_code", "n_phase"):
            cols.append(comp[f][key][k, s].tolist())
            head += f",{key}_{f}_m"
            fmt += ",%.5f"
        cols.append(tracked[f][k, s].astype(int).tolist())
        head += f",tracked_{f}"
        fmt += ",%d"
    cols.append((~gap[k]).astype(int).tolist())
    head += ",in_file\n"
    fmt += ",%d\n"
    path.write_text(head + _fmt_rows(fmt, cols))
    return str(path)


def _write_pcv_maps(folder: Path, p, antennas, sigs):
    """Differential PCV maps (second minus first, grid of the first antenna's frame) per baseline/frequency.

    Exact when both antennas share the antenna frame (parallel boresights); otherwise the map is the
    difference of the two grids at equal (az, el) and documented as approximate.
    """
    out = []
    for a in [x for x in p.antennas if x != p.master]:
        pair = [p.master, a]
        for f in sigs:
            diff = antennas[a]["pcv"][f] - antennas[p.master]["pcv"][f]
            doc = {"platform": p.platform_name, "pair": pair, "frequency": f,
                   "azimuth_deg": ob.PCV_AZ_DEG.tolist(), "elevation_deg": ob.PCV_EL_DEG.tolist(),
                   "values_mm": np.round(diff, 4).tolist(),
                   "count": None, "sigma_mm": None, "nodes": "grid nodes (bilinear), not bin centres",
                   "parallel_frames": bool(np.allclose(antennas[a]["R_a_b"], antennas[p.master]["R_a_b"]))}
            name = f"{pair[0]}_{pair[1]}_{f}.json"
            (folder / name).write_text(json.dumps(doc) + "\n")
            out.append(f"truth/pcv/{name}")
    return out


def _model_json(p, scenario, seed, pidx, t0, antennas, const, sat_phase_bias, sigs, earth, pcv_files):
    ants = {}
    for aid, A in antennas.items():
        c = A["clock"]
        ants[aid] = {"position_apriori_body_m": A["pos"].tolist(), "offset_body_m": A["offset"].tolist(),
                     "arp_true_body_m": A["arp"].tolist(), "boresight_body": A["bore"].tolist(),
                     "R_ant_from_body": A["R_a_b"].tolist(),
                     "pco_ant_m": {f: A["pco"][f].tolist() for f in sigs},
                     "pcv_grid_mm": {f: np.round(A["pcv"][f], 6).tolist() for f in sigs},
                     "receiver_code_bias_m": {f: A["code_bias"][f] for f in sigs},
                     "receiver_phase_bias_cyc": {f: A["phase_bias"][f] for f in sigs},
                     "clock": dataclasses.asdict(c)}
    leap_warning = leap_expiry_warning(float(t0.s))  # UTC/UT1 of the files may be stale after the expiry
    return {
        "scenario": scenario, "seed": seed, "pass": pidx, "t0_gps": t0.iso(3), "interval_s": p.interval_s,
        "signals": sigs, "frames": "ECEF from GCRF by IAU 2006/2000A (ERFA), EOP zero (xp=yp=0, UT1=UTC)",
        "leap_seconds": earth.leap_s, "leap_table_expires": LEAP_TABLE_EXPIRES,
        **({"leap_table_warning": leap_warning} if leap_warning else {}),
        "pcv_grid": {"azimuth_deg": ob.PCV_AZ_DEG.tolist(), "elevation_deg": ob.PCV_EL_DEG.tolist(),
                     "interpolation": "bilinear on grid nodes; antenna frame of each antenna; mm"},
        "pcv_differential_maps": pcv_files,
        "antennas": ants,
        "satellite_phase_bias_cyc": {f: dict(zip(const.sats, sat_phase_bias[f].round(12).tolist())) for f in sigs},
        "satellite_tgd_s": dict(zip(const.sats, const.tgd.tolist())),
        "model": {
            "phase_m": "rho - e.pco + PCV + c(dt_rx - dt_sv) - I_f + T + lambda w + MP + eps + lambda(N + b_rx + b_sv)",
            "code_m": "rho - e.pco + c(dt_rx - dt_sv + k_f TGD) + I_f + T + B_rx + MP + eps (k_L1=1, k_L2=gamma)",
            "doppler_hz": "-(d/dT phase without MP and noise)/lambda + eps_D",
            "rho": "|R3(wE tau) r_sat(t_rx - tau) - r_arp(t_rx)|, r_sat from the broadcast model (nav file)",
            "t_rx": "time tag - clock_s (truth/receivers.csv)",
            "windup": "Wu et al. 1993 (RTKLIB windupcorr form); satellite z to Earth centre, y = -(r x v_inertial)"
                      " at the nominal epoch; receiver x/y = antenna frame axes; unwrapped over all epochs",
            "ionosphere": "common to all antennas, once per epoch at the CoM; L2 = gamma x L1",
            "clock_jump_in_phase": p.clock_jump_in_phase},
        "parameters": _parameters_json(p),
        **_glonass_model(p, antennas, const, sigs),
    }


_GLONASS_PARAMS = {"systems": "G", "receiver_types": {}, "glonass_icb_by_model": {}}


def _parameters_json(p: SimParams) -> dict:
    """The parameters as model.json lists them; the GLONASS ones only when set (GPS-only files unchanged)."""
    d = dataclasses.asdict(p)
    for k, default in _GLONASS_PARAMS.items():
        if d[k] == default:
            del d[k]
    return d


def _glonass_model(p: SimParams, antennas: dict, const, sigs: list) -> dict:
    """model.json "glonass": channel k per satellite, receiver model and inter-channel biases per antenna (m)."""
    if not isinstance(const, MixedConstellation):
        return {}
    glo = [j for j in range(const.n) if const.is_glonass[j]]
    icb = {}
    for aid in antennas:
        per = {}
        for f in sigs:
            c, ph = _glonass_icb_m(p, aid, const, f)
            per[f] = {"code_m": {const.sats[j]: float(c[j]) for j in glo},
                      "phase_m": {const.sats[j]: float(ph[j]) for j in glo}}
        icb[aid] = {"receiver": _receiver_type(p, aid), "icb": per}
    return {"glonass": {"channels": {const.sats[j]: int(const.channels[j]) for j in glo},
                        "wavelength_m": {f: {const.sats[j]: float(const.wavelength_m(f)[j]) for j in glo}
                                         for f in sigs},
                        "time_offset_to_gps_s": 0.0, "receivers": icb,
                        "model": {"signals": "L1 = G1, L2 = G2 of channel k: f = 1602 + 0.5625 k, 1246 + 0.4375 k MHz",
                                  "ionosphere": "I_f = (f_GPS_L1 / f_k)^2 I_L1 per satellite", "tgd": "none",
                                  "icb": "receiver model's code / phase bias (m) added to its GLONASS observations",
                                  "orbit": "GLONASS ICD 5.1 A.3.1.2 (J2, constant lunisolar acceleration), RK4 5 s; "
                                           "records every 30 min are truth states"}}}


__all__ = ["simulate_scenario", "list_scenarios", "SimResult"]
