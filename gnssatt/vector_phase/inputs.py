"""An observation set as the vector-phase method needs it: one antenna's GPS L1 carrier phases and the known
satellite geometry (PhaseObservations), the antenna's vector effective length, its mounting, and the initial
position (and attitude, from a reference attitude file when the set has one).

Pipeline: platform.json (parse_platform; the antenna's `antenna_pattern`, docs/formats/antenna_vector_length.md)
-> the antenna's RINEX file -> a code single point position per epoch (gnssatt.gnss.positioning.spp) for the
receiver clock and the a priori position -> satellites at emission time from the broadcast orbits
(gnssatt.gnss.geometry.emission_time_and_position, Sagnac-rotated) -> the phase in cycles corrected for the
satellite clock and the code-estimated receiver clock, Psi = L + f (dt_sv - dt_rx) (the rest of the receiver
clock stays in b) -> satellite body axes from `axes` (default nominal yaw steering).
Neglects: ionospheric and tropospheric changes along the arcs (a short session), phase centre offsets.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.geometry import R_antenna_from_body
from gnssatt.vector_phase.pattern_file import parse_antenna_pattern
from gnssatt.vector_phase.phase_model import AntennaMount
from gnssatt.vector_phase.satellite_attitude import nominal_yaw_steering
from gnssatt.vector_phase.scenario import PhaseObservations

__all__ = ["InputProblem", "VectorPhaseInputs", "load_set", "F_L1_HZ", "PHASE_CODES"]

F_L1_HZ = 1575.42e6
#: GPS L1 phase codes in order of preference (RINEX 3; "L1" is RINEX 2)
PHASE_CODES = ("L1C", "L1W", "L1P", "L1X", "L1S", "L1L", "L1")


class InputProblem(ValueError):
    """A set that cannot give a vector-phase attitude: title, detail, file and field (the job's error)."""

    def __init__(self, title: str, detail: str, file: str | None = None, field: str | None = None):
        super().__init__(f"{title}: {detail}")
        self.title, self.detail, self.file, self.field = title, detail, file, field


@dataclass
class VectorPhaseInputs:
    """platform (gnssatt.gnss.io.platform.Platform), antenna_id, mount (AntennaMount), obs (PhaseObservations),
    obs_file (name), a_priori_position_ecef_m (3,) (median of the code positions), reference (ReferenceAttitude
    or None), warnings, sigma_velocity_m_s (the velocity file's median sigma; obs.velocity_ecef_m_s holds its
    velocity)."""

    platform: object
    antenna_id: str
    mount: AntennaMount
    obs: PhaseObservations
    obs_file: str
    a_priori_position_ecef_m: np.ndarray
    reference: object = None
    warnings: list = field(default_factory=list)
    sigma_velocity_m_s: float | None = None


def _platform(files):
    from gnssatt.gnss.io.platform import parse_platform

    plat = [f for f in files if f[1] == "platform"]
    if not plat:
        raise InputProblem("No platform description", "the vector-phase method needs a platform.json (the antenna, "
                           "its boresight and its antenna_pattern)", field="platform")
    name, _, path = plat[0]
    text = Path(path).read_bytes()
    return name, parse_platform(text, name=name), json.loads(text)


def antenna_of(doc: dict, plat_name: str, antenna_id: str, model: str | None):
    """The receive antenna model: the setting's built-in model, else the platform's antenna_pattern."""
    if model is not None:
        return parse_antenna_pattern({"model": model}, name="config.vector_phase.antenna_model")
    pattern = doc.get("antennas", {}).get(antenna_id, {}).get("antenna_pattern")
    if pattern is None:
        raise InputProblem("Missing antenna pattern", f'{plat_name}: antennas["{antenna_id}"].antenna_pattern is '
                           "missing: the vector-phase method needs the antenna's vector effective length (a table "
                           "or a built-in model, docs/formats/antenna_vector_length.md), or set "
                           "vector_phase.antenna_model", file=plat_name, field=f'antennas["{antenna_id}"].antenna_pattern')
    from gnssatt.gnss.io.errors import ParseError
    try:
        return parse_antenna_pattern(pattern, name=f'{plat_name} antennas["{antenna_id}"].antenna_pattern')
    except ParseError as exc:
        raise InputProblem("Unusable antenna pattern", str(exc), file=plat_name,
                           field=f'antennas["{antenna_id}"].antenna_pattern') from exc


def _with_set_pattern(doc: dict, files, antenna_id: str) -> dict:
    """The platform document with the set's one antenna_pattern.json (its own file, identified by content) as
    the antenna's pattern where platform.json gives none (docs/formats/antenna_vector_length.md)."""
    patterns = [f for f in files if f[1] == "antenna_pattern"]
    antennas = doc.get("antennas", {})
    if len(patterns) != 1 or "antenna_pattern" in antennas.get(antenna_id, {}):
        return doc
    import json

    pattern = json.loads(Path(patterns[0][2]).read_bytes())
    return {**doc, "antennas": {**antennas, antenna_id: {**antennas.get(antenna_id, {}), "antenna_pattern": pattern}}}


def _phase_column(obs, name: str) -> int:
    for code in PHASE_CODES:
        if code in obs.codes:
            return obs.codes.index(code)
    raise InputProblem("No L1 carrier phase", f"{name}: no GPS L1 phase among the observation codes {obs.codes} "
                       f"(expected one of {list(PHASE_CODES)})", file=name)


def _geometry(obs, ephemeris, spp_sol, r0, gps_cols, elevation_mask_deg: float):
    """(r_sat (n_ep, n_sv, 3), sat clock (n_ep, n_sv) s, usable (n_ep, n_sv)) at emission for receiver r0."""
    from gnssatt.gnss.geometry import emission_time_and_position
    from gnssatt.gnss.time import GpsTime

    n_ep, n_sv = len(obs.time), len(gps_cols)
    sats = np.array([obs.sats[c] for c in gps_cols])
    t = spp_sol.time
    ts = np.repeat(np.asarray(t.s), n_sv)
    tf = np.repeat(np.asarray(t.frac), n_sv)
    res = emission_time_and_position(ephemeris.state, np.tile(sats, n_ep), r0, GpsTime(ts, tf))
    r_sat = res.r_sat_ecef_m.reshape(n_ep, n_sv, 3)
    clock = np.asarray(res.clock_s).reshape(n_ep, n_sv)
    up = r0 / np.linalg.norm(r0)
    los = r_sat - r0
    el = np.degrees(np.arcsin(np.clip(np.sum(los * up, -1) / np.linalg.norm(los, axis=-1), -1, 1)))
    return r_sat, clock, np.isfinite(clock) & (el > elevation_mask_deg)


def _troposphere_cyc(r0, r_sat) -> np.ndarray:
    """Saastamoinen slant delay (the code solution's model, gnssatt.gnss.positioning) at r0 in L1 cycles."""
    from gnssatt.vector_phase.troposphere import slant_delay_m

    return slant_delay_m(r0, r_sat) * F_L1_HZ / 299792458.0


def _observations(obs, name, nav, sigma_phase_cyc, elevation_mask_deg, axes):
    from gnssatt.gnss.ephemeris import BroadcastEphemeris
    from gnssatt.gnss.positioning import spp

    col = _phase_column(obs, name)
    gps_cols = [i for i, s in enumerate(obs.sats) if s.startswith("G")]
    if not gps_cols:
        raise InputProblem("No GPS satellites", f"{name}: the vector-phase method uses GPS L1 phases", file=name)
    ephemeris = BroadcastEphemeris(nav)
    sol = spp(obs, ephemeris)
    ok = np.all(np.isfinite(sol.position_ecef_m), axis=1)
    if not ok.any():
        raise InputProblem("No code position", f"{name}: no epoch gives a single point position (codes + "
                           "navigation file) for the receiver clock and the a priori position", file=name)
    r0 = np.median(sol.position_ecef_m[ok], axis=0)
    r_sat, clock_sv, usable = _geometry(obs, ephemeris, sol, r0, gps_cols, elevation_mask_deg)
    L = obs.values[:, gps_cols, col]
    clock_rx = np.where(np.isfinite(sol.clock_s), sol.clock_s, np.nan)
    phase = L + F_L1_HZ * (clock_sv - clock_rx[:, None]) - _troposphere_cyc(r0, r_sat)
    phase = np.where(usable & ok[:, None], phase, np.nan)
    lli = obs.lli[:, gps_cols, col]
    present = np.isfinite(phase)
    arc = present & ((lli > 0) & (lli & 1 == 1) | ~np.vstack([np.zeros((1, len(gps_cols)), bool), present[:-1]]))
    t_gps = np.asarray(sol.time.s, float) + np.asarray(sol.time.frac, float)
    x_s, y_s = axes(t_gps[:, None], r_sat, None)
    sats = [obs.sats[c] for c in gps_cols]
    return PhaseObservations(t_gps, sats, phase, r_sat, x_s, y_s, arc, sigma_phase_cyc), r0


def load_set(files, *, antenna_id: str | None = None, antenna_model: str | None = None,
             sigma_phase_cyc: float = 0.005, elevation_mask_deg: float = 10.0, axes=nominal_yaw_steering):
    """VectorPhaseInputs of a set given as (name, kind, path) triples (kinds: platform, rinex_obs, rinex_nav,
    reference_attitude). InputProblem when it cannot give an attitude."""
    from gnssatt.gnss.io.platform import match_observation_files
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    plat_name, platform, doc = _platform(files)
    ant = antenna_id or platform.master
    if ant not in platform.antennas:
        raise InputProblem("Unknown antenna", f"{plat_name}: no antenna {ant!r} (antennas: {sorted(platform.antennas)})",
                           file=plat_name, field="config.vector_phase.antenna_id")
    model = antenna_of(_with_set_pattern(doc, files, ant), plat_name, ant, antenna_model)
    obs_files = {f[0]: f[2] for f in files if f[1] == "rinex_obs"}
    navs = [f for f in files if f[1] == "rinex_nav"]
    if not obs_files:
        raise InputProblem("No observation file", "the set has no RINEX observation file", field="rinex_obs")
    if not navs:
        raise InputProblem("No navigation file", "the vector-phase method needs a RINEX navigation file (GPS)",
                           field="rinex_nav")
    parsed = {n: read_rinex_obs(p, name=n) for n, p in obs_files.items()}
    if len(parsed) == 1:
        obs_name = next(iter(parsed))
    else:
        obs_name = match_observation_files(platform, {n: o.header.marker_name for n, o in parsed.items()},
                                           name=plat_name)[ant]
    nav = read_rinex_nav(navs[0][2], name=navs[0][0])
    phase_obs, r0 = _observations(parsed[obs_name], obs_name, nav, sigma_phase_cyc, elevation_mask_deg, axes)
    mount = AntennaMount(model, R_antenna_from_body(platform.antennas[ant].boresight_body))
    phase_obs.velocity_ecef_m_s, sigma_v = _velocity(files, phase_obs.t_gps_s)
    warnings = _velocity_span_warnings(phase_obs.velocity_ecef_m_s, phase_obs.t_gps_s)
    reference = None
    for name, kind, path in files:
        if kind == "reference_attitude":
            from gnssatt.gnss.io.reference_attitude import read_reference_attitude
            reference = read_reference_attitude(Path(path).read_bytes(), name=name)
    return VectorPhaseInputs(platform, ant, mount, phase_obs, obs_name, r0, reference, warnings=warnings,
                             sigma_velocity_m_s=sigma_v)


def _velocity_span_warnings(velocity_ecef_m_s, t_gps_s) -> list[str]:
    """A warning when phase epochs lie outside velocity.csv: the EKF does not move the position there
    (gnssatt.vector_phase.ekf_filter predict needs a finite velocity), so a moving antenna is then held still."""
    if velocity_ecef_m_s is None:
        return []
    outside = ~np.all(np.isfinite(velocity_ecef_m_s), axis=1)
    if not outside.any():
        return []
    t = np.asarray(t_gps_s, float)[outside]
    return [f"velocity.csv does not cover {int(outside.sum())} of {len(outside)} phase epochs (GPS seconds "
            f"{t.min():.1f} to {t.max():.1f}): the position is not propagated there; give velocity rows over the "
            "whole observation span, or leave velocity.csv out for a static antenna"]


def _velocity(files, t_gps_s):
    """(velocity (n_ep, 3) at the phase epochs, linear between the rows of the set's velocity.csv, NaN outside
    it; its median sigma_m_s or None) or (None, None) without a velocity file (docs/formats/inertial_csv.md)."""
    from gnssatt.gnss.io.sensor_csv import read_sensor_csv

    logs = [read_sensor_csv(Path(p), "velocity", name=n) for n, k, p in files if k == "velocity"]
    if not logs:
        return None, None
    log = logs[0]
    t = log.time.seconds()
    v = np.stack([np.interp(t_gps_s, t, log.values[:, i], left=np.nan, right=np.nan) for i in range(3)], -1)
    sig = log.extra.get("sigma_m_s")
    return v, (float(np.nanmedian(sig)) if sig is not None and np.isfinite(sig).any() else None)
