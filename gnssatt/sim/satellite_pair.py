"""A GNSS satellite with two transmitting antennas (main L-band: L1 C/A, L2C, L5; auxiliary: L1 SLAS) seen by
a network of ground stations (seed 004): the truth and the observations for the satellite-yaw capability.

The satellite flies a circular inclined geosynchronous orbit (QZS-2/-4 like) whose node is placed so that the
Sun's beta angle and the time of orbit midnight are as asked, with a yaw profile: nominal yaw steering, QZS-2/-4
pseudo-yaw steering (rate limit 0.055 deg/s), orbit-normal manoeuvre windows (slews at slew_rate_deg_s) and
360 deg yaw turns. Per station and epoch: the differential geometry k e . (O R(yaw) b), a differential PCV
pattern, phase ambiguities per arc, differential code bias, multipath (small in the same-frequency difference,
larger and independent per frequency) and white noise. `write_satellite_pair_set` writes RINEX 3.04
observations (C1C L1C C1Z L1Z C2L L2L C5Q L5Q), an SP3 orbit, stations.json, satellites.json and truth.

Frames: the orbit is built in GCRF and taken to ECEF by gnssatt.gnss.frames (zero EOP); the Sun is
gnssatt.satyaw.states.sun_ecef_m, the same function the estimators use.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.constants import OMEGA_EARTH_RAD_S
from gnssatt.gnss.time import GpsTime

__all__ = ["SatPairScenario", "SatPairTruth", "simulate_satellite_pair", "write_satellite_pair_set",
           "pcv_truth_mm"]

GM_M3_S2 = 3.986004418e14
A_GEOSYNC_M = 42164.17e3


@dataclass(frozen=True)
class SatPairScenario:
    """What to simulate. Times in seconds from `start` (GPS, ISO 8601). Sigmas per signal (m).

    profile: "yaw-steering" or "qzss-pseudo-yaw-steering"; orbit_normal_windows: ((start_s, end_s), ...)
    where the satellite slews to yaw 180 at start_s and back from end_s; turns_360: ((start_s, duration_s,
    +-1), ...). beta_deg / midnight_s: beta at the start and one orbit-midnight time (node and phase chosen
    for them). Stations: n_stations random sites (seeded) in the lat/lon box, longitudes relative to the mean
sub-satellite longitude (the node follows from beta and midnight); elevation mask in degrees."""

    sat: str = "J02"
    start: str = "2017-12-13T00:00:00"
    duration_s: float = 6 * 3600.0
    interval_s: float = 30.0
    n_stations: int = 20
    baseline_body_m: tuple[float, float, float] = (-1.2587, 0.4196, 1.3301)
    inclination_deg: float = 41.0
    beta_deg: float = 0.1
    midnight_s: float = 3 * 3600.0
    profile: str = "qzss-pseudo-yaw-steering"
    rate_limit_deg_s: float = 0.055
    orbit_normal_windows: tuple[tuple[float, float], ...] = ()
    turns_360: tuple[tuple[float, float, int], ...] = ()
    slew_rate_deg_s: float = 0.5
    phase_sigma_m: float = 0.001
    code_sigma_m: float = 0.3
    diff_multipath_m: float = 0.0003
    freq_multipath_m: float = 0.003
    pcv_amplitude_mm: float = 2.0
    dcb_m: float = 1.7
    lat_range_deg: tuple[float, float] = (-35.0, 45.0)
    lon_range_deg: tuple[float, float] = (-35.0, 35.0)
    elevation_mask_deg: float = 10.0
    arc_break_s: float = 86400.0
    seed: int = 0


@dataclass
class SatPairTruth:
    """Truth and observations: time (T,), geometry (gnssatt.satyaw.differential.SatGeometry), yaw_deg (T,),
    r_sat/v_sat ECEF (T, 3), stations (name -> ECEF), events (mode switches, s from start), sf / tf
    (DiffObs of the single-frequency aux-main L1 rows, phase and code, and of the triple-frequency
    combination), components (per-row raw parts used by the RINEX writer)."""

    scenario: SatPairScenario
    time: GpsTime
    geometry: object
    yaw_deg: np.ndarray
    r_sat_ecef_m: np.ndarray
    v_sat_ecef_m_s: np.ndarray
    stations: dict[str, np.ndarray]
    events: list[dict]
    sf: object
    tf: object
    components: dict[str, np.ndarray] = field(default_factory=dict)
    orbit: tuple[float, float, float] = (0.0, 0.0, 0.0)   # raan, inclination, u0 (rad)


def pcv_truth_mm(nadir_deg, azimuth_deg, amplitude_mm: float = 2.0) -> np.ndarray:
    """Simulated differential PCV (mm): a (n/9)^2 cos(2 az + 0.5) + 0.6 a (n/9)^3 sin(3 az), a few mm peak to
    peak like seed 004 Fig. 3, and free of the parts the baseline and arc constants absorb."""
    n = np.asarray(nadir_deg) / 9.0
    a = np.radians(azimuth_deg)
    return amplitude_mm * (n ** 2 * np.cos(2 * a + 0.5) + 0.6 * n ** 3 * np.sin(3 * a))


def _orbit_gcrf(t_s, raan, inc, u0):
    n = np.sqrt(GM_M3_S2 / A_GEOSYNC_M ** 3)
    u = u0 + n * t_s
    cu, su = np.cos(u), np.sin(u)
    p = np.stack([cu, su * np.cos(inc), su * np.sin(inc)], -1)
    q = np.stack([-su, cu * np.cos(inc), cu * np.sin(inc)], -1)
    rot = np.array([[np.cos(raan), -np.sin(raan), 0.0], [np.sin(raan), np.cos(raan), 0.0], [0.0, 0.0, 1.0]])
    return A_GEOSYNC_M * p @ rot.T, A_GEOSYNC_M * n * q @ rot.T


def _to_ecef(time: GpsTime, r_g, v_g):
    from gnssatt.gnss.frames import R_ecef_from_gcrf

    R = R_ecef_from_gcrf(time)
    r = np.einsum("nij,nj->ni", R, r_g)
    v = np.einsum("nij,nj->ni", R, v_g) - np.cross([0.0, 0.0, OMEGA_EARTH_RAD_S], r)
    return r, v


def _beta_of_raan(raans, t0: GpsTime, inc):
    from gnssatt.satyaw.attitude_models import orbit_angles
    from gnssatt.satyaw.states import sun_ecef_m

    tt = GpsTime(np.full(len(raans), t0.s), np.zeros(len(raans)))
    rv = [_orbit_gcrf(np.zeros(1), x, inc, 0.0) for x in raans]
    r, v = _to_ecef(tt, np.concatenate([a for a, _ in rv]), np.concatenate([b for _, b in rv]))
    return orbit_angles(r, v, sun_ecef_m(tt)).beta_deg


def _place_orbit(sc: SatPairScenario, t0: GpsTime):
    """(raan, u0) giving beta_deg at the start and orbit midnight at midnight_s (rad)."""
    from gnssatt.satyaw.attitude_models import orbit_angles
    from gnssatt.satyaw.states import sun_ecef_m

    inc = np.radians(sc.inclination_deg)
    coarse = np.radians(np.arange(0.0, 360.0, 1.0))
    raan = coarse[int(np.argmin(np.abs(_beta_of_raan(coarse, t0, inc) - sc.beta_deg)))]
    fine = raan + np.radians(np.arange(-1.0, 1.0, 0.0005))
    raan = fine[int(np.argmin(np.abs(_beta_of_raan(fine, t0, inc) - sc.beta_deg)))]
    u0 = 0.0
    tm_s = float(int(sc.midnight_s))
    tm = GpsTime(np.atleast_1d(t0.s + int(tm_s)), np.zeros(1))
    for _ in range(3):                      # mu grows with the argument of latitude one to one
        r, v = _to_ecef(tm, *_orbit_gcrf(np.array([tm_s]), raan, inc, u0))
        u0 -= np.radians(orbit_angles(r, v, sun_ecef_m(tm)).mu_deg[0])
    return raan, u0


def _slew_between(t, start_s, yaw_from, target_deg, rate):
    """Yaw leaving yaw_from (series) at start_s towards target at `rate` (shortest way), then target."""
    from gnssatt.satyaw.attitude_models import wrap_deg

    i0 = int(np.searchsorted(t, start_s))
    i0 = min(i0, len(t) - 1)
    delta = float(wrap_deg(target_deg - yaw_from[i0]))
    dur = abs(delta) / rate
    frac = np.clip((t - t[i0]) / dur, 0.0, 1.0) if dur > 0 else np.ones_like(t)
    return wrap_deg(yaw_from[i0] + delta * frac), t[i0] + dur


def _yaw_profile(sc: SatPairScenario, t, geom):
    """Truth yaw (T,) and the mode-switch events."""
    from gnssatt.satyaw.attitude_models import model_yaw_deg, wrap_deg

    yaw = model_yaw_deg(sc.profile, t, geom.nominal_yaw_deg, geom.nominal_rate_deg_s,
                        rate_limit_deg_s=sc.rate_limit_deg_s)
    base = yaw.copy()
    events = []
    for start_s, end_s in sc.orbit_normal_windows:
        to_on, t_on = _slew_between(t, start_s, base, 180.0, sc.slew_rate_deg_s)
        inside = (t >= start_s) & (t < end_s)
        yaw = np.where(inside, to_on, yaw)
        dev = wrap_deg(base - 180.0)
        back = wrap_deg(180.0 + np.sign(dev) * sc.slew_rate_deg_s * (t - end_s))
        reached = (t >= end_s) & (np.abs(wrap_deg(back - 180.0)) >= np.abs(dev))
        i_back = int(np.argmax(reached)) if reached.any() else len(t)
        ret = (t >= end_s) & (np.arange(len(t)) < i_back)
        yaw = np.where(ret, back, yaw)
        events += [{"kind": "leave-model", "time_s": float(start_s)},
                   {"kind": "orbit-normal", "time_s": float(t_on)},
                   {"kind": "leave-orbit-normal", "time_s": float(end_s)},
                   {"kind": "back-to-model", "time_s": float(t[min(i_back, len(t) - 1)])}]
    for start_s, dur_s, direction in sc.turns_360:
        inside = (t >= start_s) & (t < start_s + dur_s)
        yaw = np.where(inside, wrap_deg(base + direction * 360.0 * (t - start_s) / dur_s), yaw)
        events += [{"kind": "turn-360-start", "time_s": float(start_s)},
                   {"kind": "turn-360-end", "time_s": float(start_s + dur_s)}]
    return wrap_deg(yaw), events


def _stations(sc: SatPairScenario, rng, r_sat_ecef_m):
    from gnssatt.gnss.frames import geodetic_to_ecef

    lon0 = np.degrees(np.angle(np.mean(np.exp(1j * np.arctan2(r_sat_ecef_m[:, 1], r_sat_ecef_m[:, 0])))))
    lat = rng.uniform(*sc.lat_range_deg, sc.n_stations)
    lon = lon0 + rng.uniform(*sc.lon_range_deg, sc.n_stations)
    r = geodetic_to_ecef(np.radians(lat), np.radians(lon), np.zeros(sc.n_stations))
    return {f"S{i:03d}": np.asarray(r[i]) for i in range(sc.n_stations)}


def _multipath(rng, n_sta, t, amplitude_m, n_terms: int = 3):
    """(n_sta, T) sum of sinusoids with periods 5-30 min (site multipath as the geometry slowly changes)."""
    out = np.zeros((n_sta, len(t)))
    for _ in range(n_terms):
        per = rng.uniform(300.0, 1800.0, n_sta)[:, None]
        ph = rng.uniform(0, 2 * np.pi, n_sta)[:, None]
        out += amplitude_m / np.sqrt(n_terms) * np.sqrt(2) * np.sin(2 * np.pi * t[None, :] / per + ph)
    return out


def _rows(sc: SatPairScenario, rng, geom, yaw, stations, t):
    """Per (station, epoch) visible rows and their raw components (m)."""
    from gnssatt.satyaw.attitude_models import R_ecef_from_body
    from gnssatt.satyaw.differential import nadir_azimuth_deg

    names = list(stations)
    r_sta = np.stack([stations[s] for s in names])
    d = geom.r_sat_ecef_m[None, :, :] - r_sta[:, None, :]
    rng_m = np.linalg.norm(d, axis=-1)
    e = d / rng_m[..., None]
    up = r_sta / np.linalg.norm(r_sta, axis=-1, keepdims=True)
    elev = np.degrees(np.arcsin(np.einsum("stj,sj->st", e, up)))
    vis = elev > sc.elevation_mask_deg
    s_idx, t_idx = np.nonzero(vis)
    R_eb = R_ecef_from_body(geom.R_orbital_from_ecef, yaw)[t_idx]
    los = e[s_idx, t_idx]
    e_body = np.einsum("nji,nj->ni", R_eb, los)
    proj = e_body @ np.asarray(sc.baseline_body_m)
    nadir, az = nadir_azimuth_deg(e_body)
    n_sta = len(names)
    comp = {"station": s_idx, "epoch": t_idx, "los": los, "proj": proj, "range": rng_m[s_idx, t_idx],
            "elev": elev[s_idx, t_idx],
            "pcv": pcv_truth_mm(nadir, az, sc.pcv_amplitude_mm) * 1e-3,
            "mp_diff": _multipath(rng, n_sta, t, sc.diff_multipath_m)[s_idx, t_idx],
            "code_mp": _multipath(rng, n_sta, t, 0.3 * sc.code_sigma_m)[s_idx, t_idx]}
    for key in ("mp1", "mp2", "mp5"):
        comp[key] = _multipath(rng, n_sta, t, sc.freq_multipath_m)[s_idx, t_idx]
    for key in ("n1c", "n1z", "n2", "n5"):
        comp[key] = rng.normal(0.0, sc.phase_sigma_m, len(s_idx))
    for key in ("c1c", "c1z"):
        comp[key] = rng.normal(0.0, sc.code_sigma_m, len(s_idx))
    day = np.floor(t[t_idx] / sc.arc_break_s).astype(np.int64)
    new = np.ones(len(s_idx), dtype=bool)
    new[1:] = (s_idx[1:] != s_idx[:-1]) | (t_idx[1:] - t_idx[:-1] > 1) | (day[1:] != day[:-1])
    arc = np.cumsum(new) - 1
    n_arc = int(arc.max()) + 1 if len(arc) else 0
    lam1 = 299792458.0 / 1575.42e6
    comp["arc"] = arc
    comp["dcb_rx"] = rng.normal(0.0, 0.5, n_sta)[s_idx]
    for key in ("amb1c", "amb1z", "amb2", "amb5"):
        comp[key] = (rng.integers(-10000, 10000, n_arc) * lam1 + rng.uniform(0, lam1, n_arc))[arc]
    return names, comp


def _diff_obs(sc: SatPairScenario, names, comp, tf_coeffs):
    from gnssatt.satyaw.differential import DiffObs

    n = len(comp["arc"])
    arc = comp["arc"]
    n_arc = int(arc.max()) + 1 if n else 0
    arc_station = np.zeros(n_arc, dtype=np.int64)
    arc_station[arc] = comp["station"]
    sf_phase = (comp["proj"] + comp["pcv"] + comp["amb1z"] - comp["amb1c"] + comp["mp_diff"]
                + comp["n1z"] - comp["n1c"])
    sf_code = comp["proj"] + sc.dcb_m + comp["dcb_rx"] + comp["code_mp"] + comp["c1z"] - comp["c1c"]
    k1, k2, k5 = tf_coeffs
    l1z = comp["proj"] + comp["pcv"] + comp["mp1"] + comp["mp_diff"] + comp["n1z"] + comp["amb1z"]
    tf_phase = (k1 * l1z + k2 * (comp["mp2"] + comp["n2"] + comp["amb2"])
                + k5 * (comp["mp5"] + comp["n5"] + comp["amb5"]))
    ep, st, los = comp["epoch"], comp["station"], comp["los"]
    sig_p = np.full(n, np.sqrt(2) * sc.phase_sigma_m)
    sig_c = np.full(n, np.sqrt(2) * sc.code_sigma_m)
    sf = DiffObs(np.r_[ep, ep], np.r_[st, st], np.r_[arc, arc + n_arc], np.r_[sf_phase, sf_code],
                 np.r_[sig_p, sig_c], np.r_[np.zeros(n, bool), np.ones(n, bool)], np.r_[los, los], names,
                 np.r_[arc_station, arc_station], np.r_[np.zeros(n_arc, bool), np.ones(n_arc, bool)])
    tf_sigma = sc.phase_sigma_m * np.sqrt(k1 * k1 + k2 * k2 + k5 * k5)
    tf = DiffObs(ep, st, arc, tf_phase, np.full(n, tf_sigma), np.zeros(n, bool), los, names, arc_station,
                 np.zeros(n_arc, bool), k=k1)
    return sf, tf


def simulate_satellite_pair(scenario: SatPairScenario | None = None) -> SatPairTruth:
    """SatPairTruth of a scenario (deterministic for its seed)."""
    from gnssatt.satyaw.differential import satellite_geometry
    from gnssatt.satyaw.states import sun_ecef_m
    from gnssatt.satyaw.triple_frequency import table2_coefficients

    sc = scenario or SatPairScenario()
    rng = np.random.default_rng(sc.seed)
    t0 = GpsTime.from_iso(sc.start)
    t = np.arange(0.0, sc.duration_s, sc.interval_s)
    time = GpsTime(t0.s + t.astype(np.int64), np.zeros(len(t)))
    raan, u0 = _place_orbit(sc, t0)
    r, v = _to_ecef(time, *_orbit_gcrf(t, raan, np.radians(sc.inclination_deg), u0))
    geom = satellite_geometry(t, r, v, sun_ecef_m(time))
    yaw, events = _yaw_profile(sc, t, geom)
    stations = _stations(sc, rng, r)
    names, comp = _rows(sc, rng, geom, yaw, stations, t)
    c = table2_coefficients()
    sf, tf = _diff_obs(sc, names, comp, (c.k1, c.k2, c.k5))
    return SatPairTruth(sc, time, geom, yaw, r, v, stations, events, sf, tf, comp,
                        (raan, np.radians(sc.inclination_deg), u0))


def write_satellite_pair_set(truth: SatPairTruth, out_dir) -> dict[str, Path]:
    """Write the set: <station>.rnx (RINEX 3.04), orbit.sp3, stations.json, satellites.json, truth/yaw.csv and
    truth/truth.json; returns name -> path. Phases in cycles (F14.3: 0.2 mm steps on L1)."""
    from gnssatt.gnss.io.rinex_obs import ObsHeader, RinexObs
    from gnssatt.gnss.io.rinex_obs_write import ObsWriteHeader, write_rinex_obs
    from gnssatt.gnss.io.sp3_write import write_sp3

    sc = truth.scenario
    out = Path(out_dir)
    (out / "truth").mkdir(parents=True, exist_ok=True)
    c = truth.components
    f = {"1": 1575.42e6, "2": 1227.60e6, "5": 1176.45e6}
    lam = {k: 299792458.0 / v for k, v in f.items()}
    iono1 = 3.0 + 2.0 * np.sin(c["epoch"] * 1e-3 + c["station"])
    common = c["range"] + 1e3 * np.sin(c["epoch"] * 1e-4)          # geometry + clocks, cancel in differences
    cols = {"C1C": common + iono1 + c["c1c"], "L1C": (common - iono1 + c["amb1c"] + c["mp1"] + c["n1c"]) / lam["1"],
            "C1Z": common + iono1 + c["proj"] + sc.dcb_m + c["dcb_rx"] + c["code_mp"] + c["c1z"],
            "L1Z": (common - iono1 + c["proj"] + c["pcv"] + c["mp1"] + c["mp_diff"] + c["n1z"] + c["amb1z"]) / lam["1"],
            "C2L": common + iono1 * (f["1"] / f["2"]) ** 2,
            "L2L": (common - iono1 * (f["1"] / f["2"]) ** 2 + c["mp2"] + c["n2"] + c["amb2"]) / lam["2"],
            "C5Q": common + iono1 * (f["1"] / f["5"]) ** 2,
            "L5Q": (common - iono1 * (f["1"] / f["5"]) ** 2 + c["mp5"] + c["n5"] + c["amb5"]) / lam["5"]}
    codes = list(cols)
    paths: dict[str, Path] = {}
    for si, name in enumerate(truth.stations):
        m = c["station"] == si
        vals = np.full((len(truth.time), 1, len(codes)), np.nan)
        for k, code in enumerate(codes):
            vals[c["epoch"][m], 0, k] = cols[code][m]
        hdr = ObsHeader(version=3.04, file_type="O", satellite_system="J", marker_name=name,
                        obs_types={"J": codes})
        obs = RinexObs(hdr, truth.time, np.zeros(len(truth.time), np.int8), np.full(len(truth.time), np.nan),
                       [sc.sat], codes, vals, np.full(vals.shape, -1, np.int8), np.full(vals.shape, -1, np.int8))
        p = out / f"{name}.rnx"
        keep = ~np.all(np.isnan(vals[:, 0, :]), axis=1)
        obs.time, obs.values = truth.time[keep], vals[keep]
        obs.lli, obs.ssi = obs.lli[keep], obs.ssi[keep]
        obs.epoch_flag, obs.clock_offset_s = obs.epoch_flag[keep], obs.clock_offset_s[keep]
        write_rinex_obs(p, obs, 3.04, ObsWriteHeader(marker_name=name, receiver_type="SIM",
                                                     antenna_type="SIM", approx_position_ecef_m=truth.stations[name],
                                                     interval_s=sc.interval_s))
        paths[name] = p
    t_nodes = np.arange(-3600.0, sc.duration_s + 3600.0, 300.0)   # 5-min SP3 with an hour either side
    t0 = truth.time[0]
    time_nodes = GpsTime(t0.s + t_nodes.astype(np.int64), np.zeros(len(t_nodes)))
    raan, inc, u0 = truth.orbit
    r_nodes, _ = _to_ecef(time_nodes, *_orbit_gcrf(t_nodes, raan, inc, u0))
    paths["orbit.sp3"] = write_sp3(out / "orbit.sp3", time_nodes, [sc.sat], r_nodes[:, None, :],
                                   clock_us=np.zeros((len(t_nodes), 1)), file_type="J")
    stations = {"stations": {k: {"position_ecef_m": [float(x) for x in v], "observation_file": f"{k}.rnx"}
                             for k, v in truth.stations.items()}}
    (out / "stations.json").write_text(json.dumps(stations, indent=1))
    sats = {"satellites": {sc.sat: {"aux_antenna_m": list(sc.baseline_body_m), "aux_signals": ["C1Z", "L1Z"],
                                    "main_signals": ["C1C", "L1C"], "attitude_model": sc.profile,
                                    "yaw_rate_limit_deg_s": sc.rate_limit_deg_s}}}
    (out / "satellites.json").write_text(json.dumps(sats, indent=1))
    paths["stations.json"], paths["satellites.json"] = out / "stations.json", out / "satellites.json"
    lines = ["time_gps,yaw_deg,nominal_yaw_deg"] + [
        f"{truth.time[i].iso(3)},{truth.yaw_deg[i]:.6f},{truth.geometry.nominal_yaw_deg[i]:.6f}"
        for i in range(len(truth.time))]
    (out / "truth" / "yaw.csv").write_text("\n".join(lines) + "\n")
    (out / "truth" / "truth.json").write_text(json.dumps(
        {"scenario": asdict(sc), "events": truth.events}, indent=1, default=list))
    return paths
