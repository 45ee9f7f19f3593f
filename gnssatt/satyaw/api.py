"""Entry points of the satellite-yaw capability on local files (the satellite-yaw and satellite-baseline jobs
call exactly these): `estimate_satellite_yaw(files, ...)` and `estimate_satellite_baseline(files, ...)`.

files: paths (or (name, path) pairs) of ground-station RINEX observation files and at least one orbit
product (RINEX navigation or SP3); stations / satellites: the stations.json / satellites.json documents
(CONVENTIONS.md) or None. Results carry per satellite the epochs, geometry, estimates, model and warnings;
`gnssatt.satyaw.products` writes the job's files from them.
"""
from __future__ import annotations

import json

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.satyaw.attitude_models import model_yaw_deg, wrap_deg
from gnssatt.satyaw.baseline_estimator import BaselineEstimate, BaselineOptions, PcvMap, estimate_baseline
from gnssatt.satyaw.differential import DiffObs, SatGeometry, body_los, nadir_azimuth_deg
from gnssatt.satyaw.inputs import (Network, RowOptions, SatelliteDescription, SatYawInputError, build_network,
                                   differential_rows, load_station, parse_stations, satellite_descriptions,
                                   satellite_geometry_from_ephemeris)
from gnssatt.satyaw.mode_switch import ModeEvent, detect_mode_switches
from gnssatt.satyaw.yaw_estimator import YawEstimate, YawOptions, estimate_yaw
from gnssatt.satyaw.yaw_smoother import smooth_yaw

__all__ = ["SatYawOptions", "SatelliteYaw", "YawRun", "SatelliteBaseline", "BaselineRun",
           "estimate_satellite_yaw", "estimate_satellite_baseline", "load_inputs", "nominal_model"]


@dataclass(frozen=True)
class SatYawOptions:
    """satellites: ids to process (None: every satellite with the auxiliary signal; those without a baseline
    get the model only); yaw_mode: "auto" (one yaw offset from the model over the span when fewer than 3
    stations see an epoch on median or the span is under 1 h, else per epoch), "per-epoch" or "offset";
    smooth: also a yaw-rate-limited smoothed series; triple: also the triple-frequency combination;
    systematic_m: see gnssatt.satyaw.yaw_estimator.YawOptions (offset mode only)."""

    satellites: tuple[str, ...] | None = None
    yaw_mode: str = "auto"
    elevation_mask_deg: float = 10.0
    phase_sigma_m: float = 0.002
    code_sigma_m: float = 0.5
    smooth: bool = False
    triple: bool = False
    pcv_maps: dict[str, PcvMap] = field(default_factory=dict)
    systematic_m: float = 0.0003


@dataclass
class SatelliteYaw:
    """One satellite's yaw: description, geometry, rows, estimate (None: model only), smoothed (yaw, sigma) or
    None, triple-frequency estimate or None, events, mode used, warnings."""

    sat: str
    description: SatelliteDescription
    geometry: SatGeometry
    model_yaw_deg: np.ndarray
    obs: DiffObs | None
    estimate: YawEstimate | None
    smoothed: tuple[np.ndarray, np.ndarray] | None
    triple: YawEstimate | None
    events: list[ModeEvent]
    mode: str
    warnings: list[str]


@dataclass
class YawRun:
    network: Network
    satellites: dict[str, SatelliteYaw]
    warnings: list[str]
    orbit_source: str


def _pairs(files) -> list[tuple[str, Path]]:
    out = []
    for f in files:
        if isinstance(f, (tuple, list)):
            out.append((str(f[0]), Path(f[1])))
        else:
            out.append((Path(f).name, Path(f)))
    return out


def _ephemeris(orbit_files: list[tuple[str, Path, str]]):
    from gnssatt.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris

    sp3 = [f for f in orbit_files if f[2] == "sp3"]
    if sp3:
        from gnssatt.gnss.io.sp3 import read_sp3

        return PreciseEphemeris(read_sp3(sp3[0][1], name=sp3[0][0]), antenna_offsets=None), f"SP3 {sp3[0][0]}"
    nav = [f for f in orbit_files if f[2] == "rinex_nav"]
    if nav:
        from gnssatt.gnss.io.rinex_nav import read_rinex_nav

        return BroadcastEphemeris(read_rinex_nav(nav[0][1], name=nav[0][0])), f"broadcast {nav[0][0]}"
    raise SatYawInputError("No orbit", "the set needs a RINEX navigation file or an SP3 orbit of the satellites",
                           field="files")


def load_inputs(files, stations: dict | None = None):
    """(Network, ephemeris, orbit source text, warnings, satellites.json document or None) of local files
    identified by content; the set's stations.json / satellites.json are used where the caller gives none."""
    from gnssatt.gnss.io.sniff import identify

    pairs = _pairs(files)
    kinds = [(n, p, identify(p, n)[0]) for n, p in pairs]
    docs = {k: json.loads(Path(p).read_bytes()) for n, p, k in kinds if k in ("stations", "satellites")}
    positions = parse_stations(stations or docs.get("stations"))
    obs_files = [(n, p) for n, p, k in kinds if k == "rinex_obs"]
    if not obs_files:
        raise SatYawInputError("No observations", "the set has no RINEX observation file", field="files")
    st = [load_station(p, n, positions) for n, p in obs_files]
    eph, source = _ephemeris([(n, p, k) for n, p, k in kinds if k in ("sp3", "rinex_nav")])
    warnings = [w for s in st for w in s.warnings]
    return build_network(st), eph, source, warnings, docs.get("satellites")


def nominal_model(desc: SatelliteDescription, geom: SatGeometry) -> np.ndarray:
    """The satellite's attitude-model yaw (T,) at the geometry's epochs."""
    return model_yaw_deg(desc.attitude_model, geom.t_s, geom.nominal_yaw_deg, geom.nominal_rate_deg_s,
                         rate_limit_deg_s=desc.yaw_rate_limit_deg_s, beta_deg=geom.beta_deg)


def _sats_with_aux(net: Network, descs: dict[str, SatelliteDescription]) -> list[str]:
    found = set()
    for st in net.stations:
        for sat in st.obs.sats:
            d = descs.get(sat, SatelliteDescription(sat, None))
            k = st.obs.code_index(d.aux_signals[1], sat[0])
            if k is not None and np.isfinite(st.obs.values[:, st.obs.sats.index(sat), k]).any():
                found.add(sat)
    return sorted(found)


def _pick_satellites(net, descs, wanted) -> list[str]:
    if wanted:
        for sat in wanted:
            d = descs.get(sat)
            if d is None or d.aux_antenna_m is None:
                raise SatYawInputError("Satellite without a baseline", f"{sat}: no auxiliary-antenna baseline (not "
                                       "in seed 004 Table 1 and not given in satellites.json); run a "
                                       "satellite-baseline job or give aux_antenna_m", field="satellites")
        return list(wanted)
    sats = _sats_with_aux(net, descs)
    if not sats:
        raise SatYawInputError("No auxiliary signal", "no observation file (" + ", ".join(
            s.file for s in net.stations) + ") tracks an auxiliary-antenna signal (e.g. C1Z/L1Z)",
            file=", ".join(s.file for s in net.stations))
    return sats


def _mode(opts: SatYawOptions, obs: DiffObs, geom: SatGeometry) -> str:
    if opts.yaw_mode != "auto":
        return opts.yaw_mode
    per_epoch = np.bincount(np.unique(obs.epoch * 1000 + obs.station) // 1000)
    span = geom.t_s[-1] - geom.t_s[0]
    return "offset" if np.median(per_epoch[per_epoch > 0]) < 3 or span < 3600.0 else "per-epoch"


def _pcv_rows(opts, sat, geom, obs, yaw):
    pm = opts.pcv_maps.get(sat)
    if pm is None:
        return None
    e_b = body_los(geom.R_orbital_from_ecef[obs.epoch], wrap_deg(yaw)[obs.epoch], obs.los_ecef)
    return pm.lookup_m(*nadir_azimuth_deg(e_b))


def _one_yaw(net, eph, sat, desc, opts: SatYawOptions) -> SatelliteYaw:
    geom = satellite_geometry_from_ephemeris(net, sat, eph)
    model = nominal_model(desc, geom)
    warnings: list[str] = []
    if desc.aux_antenna_m is None:
        warnings.append(f"{sat}: {desc.source or 'no baseline'}; only the {desc.attitude_model} model yaw is given")
        return SatelliteYaw(sat, desc, geom, model, None, None, None, None, [], "model-only", warnings)
    ro = RowOptions(opts.elevation_mask_deg, opts.phase_sigma_m, opts.code_sigma_m)
    obs = differential_rows(net, sat, desc, geom, ro)
    warnings += obs.warnings
    mode = _mode(opts, obs, geom)
    yo = YawOptions(block_s=None if mode == "per-epoch" else 0.0, systematic_m=opts.systematic_m)
    est = estimate_yaw(obs, geom, desc.aux_antenna_m, model, yo, pcv_m=_pcv_rows(opts, sat, geom, obs, model))
    smoothed = (smooth_yaw(geom.t_s, est.yaw_deg, est.sigma_yaw_deg, desc.yaw_rate_limit_deg_s)
                if opts.smooth and mode == "per-epoch" else None)
    triple = None
    if opts.triple:
        try:
            tf = differential_rows(net, sat, desc, geom, RowOptions(opts.elevation_mask_deg, opts.phase_sigma_m,
                                                                    opts.code_sigma_m, triple=True))
            triple = estimate_yaw(tf, geom, desc.aux_antenna_m, model, yo)
        except SatYawInputError as exc:
            warnings.append(f"{sat}: triple-frequency path skipped: {exc.detail}")
    events = detect_mode_switches(geom.t_s, est.yaw_deg, est.sigma_yaw_deg, model) if mode == "per-epoch" else []
    return SatelliteYaw(sat, desc, geom, model, obs, est, smoothed, triple, events, mode, warnings)


def estimate_satellite_yaw(files, *, stations: dict | None = None, satellites: dict | None = None,
                           options: SatYawOptions | None = None, progress=None) -> YawRun:
    """YawRun: every selected satellite's yaw from the set's files (seed 004 eq. 9, sec. 2.2-2.5)."""
    opts = options or SatYawOptions()
    net, eph, source, warnings, set_satellites = load_inputs(files, stations)
    descs = satellite_descriptions(satellites or set_satellites)
    sats = _pick_satellites(net, descs, opts.satellites)
    out = {}
    for i, sat in enumerate(sats):
        if progress:
            progress(0.1 + 0.8 * i / len(sats), f"yaw of {sat}")
        out[sat] = _one_yaw(net, eph, sat, descs.get(sat, SatelliteDescription(sat, None)), opts)
    return YawRun(net, out, warnings, source)


@dataclass
class SatelliteBaseline:
    sat: str
    description: SatelliteDescription
    geometry: SatGeometry
    model_yaw_deg: np.ndarray
    obs: DiffObs
    estimate: BaselineEstimate
    warnings: list[str]


@dataclass
class BaselineRun:
    network: Network
    satellites: dict[str, SatelliteBaseline]
    warnings: list[str]
    orbit_source: str


def estimate_satellite_baseline(files, *, stations: dict | None = None, satellites: dict | None = None,
                                options: SatYawOptions | None = None, baseline_options: BaselineOptions | None = None,
                                exclude: dict[str, list[tuple[float, float]]] | None = None,
                                progress=None) -> BaselineRun:
    """BaselineRun: each satellite's main -> aux baseline, code bias and PCV map with the model yaw
    (seed 004 sec. 2.1). exclude: sat -> [(start_s, end_s)] of non-nominal periods (manoeuvres) to leave out."""
    opts = options or SatYawOptions()
    net, eph, source, warnings, set_satellites = load_inputs(files, stations)
    descs = satellite_descriptions(satellites or set_satellites)
    sats = list(opts.satellites) if opts.satellites else _sats_with_aux(net, descs)
    if not sats:
        raise SatYawInputError("No auxiliary signal", "no observation file tracks an auxiliary-antenna signal",
                               file=", ".join(s.file for s in net.stations))
    out = {}
    for i, sat in enumerate(sats):
        if progress:
            progress(0.1 + 0.8 * i / len(sats), f"baseline of {sat}")
        desc = descs.get(sat, SatelliteDescription(sat, None))
        geom = satellite_geometry_from_ephemeris(net, sat, eph)
        model = nominal_model(desc, geom)
        obs = differential_rows(net, sat, desc, geom, RowOptions(opts.elevation_mask_deg, opts.phase_sigma_m,
                                                                 opts.code_sigma_m))
        keep = np.ones(len(obs.epoch), dtype=bool)
        for a, b in (exclude or {}).get(sat, []):
            keep &= ~((geom.t_s[obs.epoch] >= a) & (geom.t_s[obs.epoch] < b))
        obs = obs.select(keep)
        est = estimate_baseline(obs, geom, model, baseline_options)
        out[sat] = SatelliteBaseline(sat, desc, geom, model, obs, est, obs.warnings + est.warnings)
    return BaselineRun(net, out, warnings, source)
