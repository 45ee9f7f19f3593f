"""Inputs of the satellite-yaw capability: satellite descriptions (seed 004 Table 1 built in), station
coordinates (stations.json or the RINEX headers) and the differential observations extracted from ground-station
RINEX files (CONVENTIONS.md "yaw of GNSS satellites").

Everything that cannot be processed raises `SatYawInputError` naming the file (or the field) and what was
expected; the worker turns it into a job error, never a crash.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.time import GpsTime
from gnssatt.satyaw.attitude_models import MODELS
from gnssatt.satyaw.differential import DiffObs, SatGeometry, satellite_geometry, split_arcs
from gnssatt.satyaw.triple_frequency import table2_coefficients

__all__ = ["SatYawInputError", "SatelliteDescription", "TABLE1", "satellite_descriptions", "parse_stations",
           "StationData", "load_station", "Network", "build_network", "differential_rows", "L1_HZ", "RowOptions",
           "satellite_geometry_from_ephemeris"]

L1_HZ = 1575.42e6
_BAND_HZ = {"1": 1575.42e6, "2": 1227.60e6, "5": 1176.45e6, "6": 1278.75e6}


class SatYawInputError(ValueError):
    """Input that cannot be processed: `file` (or None), `field` (or None) and the message."""

    def __init__(self, title: str, detail: str, *, file: str | None = None, field: str | None = None):
        super().__init__(detail)
        self.title, self.detail, self.file, self.field = title, detail, file, field


@dataclass(frozen=True)
class SatelliteDescription:
    """aux_antenna_m (3,): main -> auxiliary antenna in the IGS body frame; sigma_m (3,) or None; signals;
    attitude_model (one of attitude_models.MODELS); yaw_rate_limit_deg_s; source (where the values come from)."""

    sat: str
    aux_antenna_m: tuple[float, float, float] | None
    sigma_m: tuple[float, float, float] | None = None
    aux_signals: tuple[str, str] = ("C1Z", "L1Z")
    main_signals: tuple[str, str] = ("C1C", "L1C")
    attitude_model: str = "yaw-steering"
    yaw_rate_limit_deg_s: float = 0.055
    source: str = ""
    dcb_m: float | None = None


_SLAS = ("C1Z", "L1Z")
#: seed 004 Table 1 (L1 SLAS, main L-band -> SLAS antenna, IGS body frame) and the satellites' attitude laws
#: (QZS-1: yaw steering switching to orbit normal near |beta| = 20 deg, sec. 1; QZS-2/-4: pseudo-yaw steering,
#: sec. 2.4; QZS-3 (GEO): orbit normal, no published baseline).
TABLE1 = {
    "J01": SatelliteDescription("J01", (-1.1482, -0.6922, 0.1522), (0.0012, 0.0020, 0.0184), _SLAS,
                                attitude_model="qzs1-yaw-steering", source="seed 004 Table 1 (QZS-1)"),
    "J02": SatelliteDescription("J02", (-1.2587, 0.4196, 1.3301), (0.0027, 0.0046, 0.0266), _SLAS,
                                attitude_model="qzss-pseudo-yaw-steering", source="seed 004 Table 1 (QZS-2/-4)"),
    "J03": SatelliteDescription("J03", (-1.2587, 0.4196, 1.3301), (0.0027, 0.0046, 0.0266), _SLAS,
                                attitude_model="qzss-pseudo-yaw-steering", source="seed 004 Table 1 (QZS-2/-4)"),
    "J07": SatelliteDescription("J07", None, None, _SLAS, attitude_model="orbit-normal",
                                source="QZS-3 (GEO): no baseline in seed 004 Table 1"),
}


def satellite_descriptions(doc: dict | None, name: str = "satellites.json") -> dict[str, SatelliteDescription]:
    """Built-in TABLE1 updated by a satellites.json document (CONVENTIONS.md; also the satellite-baseline output)."""
    out = dict(TABLE1)
    if not doc:
        return out
    sats = doc.get("satellites") if isinstance(doc, dict) else None
    if not isinstance(sats, dict):
        raise SatYawInputError("Bad satellites.json", f"{name}: expected {{\"satellites\": {{\"J02\": {{...}}}}}}",
                               file=name, field="satellites")
    for sat, d in sats.items():
        if not isinstance(d, dict):
            raise SatYawInputError("Bad satellites.json", f"{name}: satellites.{sat} must be an object", file=name)
        base = out.get(sat, SatelliteDescription(sat, None))
        b = d.get("aux_antenna_m", base.aux_antenna_m)
        if b is not None and (not isinstance(b, (list, tuple)) or len(b) != 3):
            raise SatYawInputError("Bad satellites.json", f"{name}: satellites.{sat}.aux_antenna_m must be "
                                   f"[x, y, z] in metres, found {b!r}", file=name)
        model = d.get("attitude_model", base.attitude_model)
        if model not in MODELS:
            raise SatYawInputError("Bad satellites.json", f"{name}: satellites.{sat}.attitude_model must be one "
                                   f"of {', '.join(MODELS)}, found {model!r}", file=name)
        out[sat] = SatelliteDescription(
            sat, None if b is None else tuple(float(v) for v in b),
            tuple(float(v) for v in d["sigma_m"]) if d.get("sigma_m") else None,
            tuple(d.get("aux_signals", base.aux_signals)), tuple(d.get("main_signals", base.main_signals)),
            model, float(d.get("yaw_rate_limit_deg_s", base.yaw_rate_limit_deg_s)), d.get("source", name),
            d.get("dcb_m"))
    return out


def parse_stations(doc: dict | None, name: str = "stations.json") -> dict[str, np.ndarray]:
    """Station name -> ECEF position (m) from a stations.json document (CONVENTIONS.md); also keyed by the
    observation file name given there."""
    if not doc:
        return {}
    st = doc.get("stations") if isinstance(doc, dict) else None
    if not isinstance(st, dict):
        raise SatYawInputError("Bad stations.json", f"{name}: expected {{\"stations\": {{NAME: "
                               f"{{\"position_ecef_m\": [x, y, z]}}}}}}", file=name, field="stations")
    out = {}
    for k, v in st.items():
        p = v.get("position_ecef_m") if isinstance(v, dict) else None
        if not isinstance(p, (list, tuple)) or len(p) != 3 or np.linalg.norm(np.asarray(p, float)) < 6.0e6:
            raise SatYawInputError("Bad stations.json", f"{name}: stations.{k}.position_ecef_m must be the ECEF "
                                   f"position [x, y, z] in metres (|r| > 6000 km), found {p!r}", file=name)
        out[k] = np.asarray(p, dtype=np.float64)
        if isinstance(v, dict) and v.get("observation_file"):
            out[str(v["observation_file"])] = out[k]
    return out


@dataclass
class StationData:
    """One station's file: name (marker or file), file name, position (3,), time (n,) and the RinexObs."""

    name: str
    file: str
    position_ecef_m: np.ndarray
    obs: object
    warnings: list[str] = field(default_factory=list)


def load_station(path, file_name: str, positions: dict[str, np.ndarray]) -> StationData:
    """Read one station's RINEX file; its position from `positions` (marker name or file name) or the header
    (with a warning: headers can be off by metres). One-epoch files are refused."""
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    obs = read_rinex_obs(path, name=file_name)
    if len(obs.time) < 2:
        raise SatYawInputError("Too few epochs", f"{file_name}: {len(obs.time)} observation epoch(s); the "
                               "differential arcs need at least 2 epochs (an ambiguity per arc)", file=file_name)
    name = obs.header.marker_name or file_name
    warnings = []
    pos = positions.get(name, positions.get(file_name))
    if pos is None:
        pos = obs.header.approx_position_ecef_m
        if pos is None:
            raise SatYawInputError("No station position", f"{file_name}: no APPROX POSITION XYZ in the header and "
                                   f"no entry for {name!r} in stations.json", file=file_name)
        warnings.append(f"{file_name}: station position from the header APPROX POSITION XYZ (can be off by "
                        "metres; give stations.json)")
    return StationData(name, file_name, np.asarray(pos, dtype=np.float64), obs, warnings)


@dataclass
class Network:
    """Common epochs of the stations: time (T,) GpsTime, t_s (T,) from the first; stations."""

    time: GpsTime
    t_s: np.ndarray
    stations: list[StationData]


def build_network(stations: list[StationData]) -> Network:
    """The union of the stations' epochs (rounded to 1 ms) as the estimation epochs."""
    ms = np.unique(np.concatenate([st.obs.time.s * 1000 + np.round(st.obs.time.frac * 1000).astype(np.int64)
                                   for st in stations]))
    t0 = ms[0]
    time = GpsTime(ms // 1000, (ms % 1000) / 1000.0)
    return Network(time, (ms - t0) / 1000.0, stations)


def _signal(obs, code: str, sat: str):
    k = obs.code_index(code, sat[0])
    if k is None:
        return None
    j = obs.sats.index(sat)
    return obs.values[:, j, k], obs.lli[:, j, k]


def _epoch_index(net: Network, obs) -> np.ndarray:
    ms = obs.time.s * 1000 + np.round(obs.time.frac * 1000).astype(np.int64)
    t0 = net.time.s[0] * 1000 + int(round(net.time.frac[0] * 1000))
    return np.searchsorted(np.round(net.t_s * 1000).astype(np.int64) + t0, ms)


@dataclass(frozen=True)
class RowOptions:
    """elevation_mask_deg; phase_sigma_m / code_sigma_m: a priori sigma of one signal (the difference has
    sqrt(2) of it); triple: the triple-frequency combination instead of the same-frequency difference."""

    elevation_mask_deg: float = 10.0
    phase_sigma_m: float = 0.002
    code_sigma_m: float = 0.5
    triple: bool = False
    l2_codes: tuple[str, ...] = ("L2X", "L2L", "L2S")
    l5_codes: tuple[str, ...] = ("L5X", "L5Q", "L5I")


def _station_rows(st: StationData, sat: str, desc: SatelliteDescription, ep: np.ndarray, r_sat, opts: RowOptions):
    """(epoch, phase_m, code_m, lli, los) of one station for one satellite, or None without the signals."""
    if sat not in st.obs.sats:
        return None
    lam = 299792458.0 / _BAND_HZ[desc.aux_signals[1][1]]
    aux_l = _signal(st.obs, desc.aux_signals[1], sat)
    main_l = _signal(st.obs, desc.main_signals[1], sat)
    aux_c = _signal(st.obs, desc.aux_signals[0], sat)
    main_c = _signal(st.obs, desc.main_signals[0], sat)
    if aux_l is None or main_l is None:
        return None
    code = (aux_c[0] - main_c[0]) if aux_c is not None and main_c is not None else np.full(len(ep), np.nan)
    if opts.triple:
        l2 = next((s for s in (_signal(st.obs, c, sat) for c in opts.l2_codes) if s is not None), None)
        l5 = next((s for s in (_signal(st.obs, c, sat) for c in opts.l5_codes) if s is not None), None)
        if l2 is None or l5 is None:
            return None
        c = table2_coefficients()
        lam2, lam5 = 299792458.0 / _BAND_HZ["2"], 299792458.0 / _BAND_HZ["5"]
        phase = c.k1 * aux_l[0] * lam + c.k2 * l2[0] * lam2 + c.k5 * l5[0] * lam5      # eq. 5, metres
        lli = np.maximum(np.maximum(aux_l[1], l2[1]), l5[1])
        code = np.full(len(ep), np.nan)
    else:
        phase = (aux_l[0] - main_l[0]) * lam
        lli = np.maximum(aux_l[1], main_l[1])
    d = r_sat[ep] - st.position_ecef_m
    los = d / np.linalg.norm(d, axis=-1, keepdims=True)
    up = st.position_ecef_m / np.linalg.norm(st.position_ecef_m)
    elev = np.degrees(np.arcsin(los @ up))
    ok = np.isfinite(phase) & (elev > opts.elevation_mask_deg) & np.all(np.isfinite(los), axis=1)
    return ep[ok], phase[ok], code[ok], lli[ok], los[ok]


def differential_rows(net: Network, sat: str, desc: SatelliteDescription, geom: SatGeometry,
                      opts: RowOptions | None = None) -> DiffObs:
    """DiffObs of one satellite over the network: per station arc one phase group and one code group.

    Stations without the satellite's auxiliary (or, triple, L2/L5) signals are left out with a warning; when no
    station has them SatYawInputError names the files.
    """
    o = opts or RowOptions()
    parts, warnings, missing = [], [], []
    for si, st in enumerate(net.stations):
        rows = _station_rows(st, sat, desc, _epoch_index(net, st.obs), geom.r_sat_ecef_m, o)
        if rows is None:
            missing.append(st.file)
            continue
        parts.append((si,) + rows)
    if missing:
        sig = "/".join(desc.aux_signals) + (" + L2/L5" if o.triple else "")
        warnings.append(f"{sat}: no {sig} with {'/'.join(desc.main_signals)} in {', '.join(missing)}: left out")
    if not parts or sum(len(p[1]) for p in parts) < 2:
        raise SatYawInputError("No auxiliary signal", f"{sat}: none of the observation files ("
                               f"{', '.join(st.file for st in net.stations)}) has {'/'.join(desc.aux_signals)} "
                               f"together with {'/'.join(desc.main_signals)} above the elevation mask",
                               file=", ".join(missing) or None)
    ep = np.concatenate([p[1] for p in parts])
    sta = np.concatenate([np.full(len(p[1]), p[0]) for p in parts])
    phase = np.concatenate([p[2] for p in parts])
    code = np.concatenate([p[3] for p in parts])
    lli = np.concatenate([p[4] for p in parts])
    los = np.concatenate([p[5] for p in parts])
    arc = split_arcs(ep, sta, phase, np.where(lli < 0, 0, lli), slip_m=0.05 if not o.triple else 0.1)
    n_arc = int(arc.max()) + 1
    arc_sta = np.zeros(n_arc, dtype=np.int64)
    arc_sta[arc] = sta
    k = table2_coefficients().k1 if o.triple else 1.0
    fac = table2_coefficients() if o.triple else None
    sp = o.phase_sigma_m * (np.sqrt(np.sum(fac.k ** 2)) if o.triple else np.sqrt(2.0))
    has_code = np.isfinite(code)
    n = len(ep)
    names = [st.name for st in net.stations]
    obs = DiffObs(np.r_[ep, ep[has_code]], np.r_[sta, sta[has_code]], np.r_[arc, arc[has_code] + n_arc],
                  np.r_[phase, code[has_code]],
                  np.r_[np.full(n, sp), np.full(has_code.sum(), np.sqrt(2) * o.code_sigma_m)],
                  np.r_[np.zeros(n, bool), np.ones(has_code.sum(), bool)], np.r_[los, los[has_code]], names,
                  np.r_[arc_sta, arc_sta], np.r_[np.zeros(n_arc, bool), np.ones(n_arc, bool)], k, warnings)
    return obs.select(np.ones(len(obs.epoch), dtype=bool))


def satellite_geometry_from_ephemeris(net: Network, sat: str, ephemeris) -> SatGeometry:
    """SatGeometry of `sat` at the network epochs; SatYawInputError when the orbit product does not cover it."""
    from gnssatt.satyaw.states import satellite_states, sun_ecef_m

    r, v, ok = satellite_states(ephemeris, sat, net.time)
    if not ok.any():
        raise SatYawInputError("No orbit", f"{sat}: the navigation/SP3 files give no position at the observation "
                               "epochs", field="files")
    bad = ~ok
    if bad.any():   # fill short holes by the nearest valid state (the geometry changes by 1e-4 rad/min)
        idx = np.flatnonzero(ok)
        near = idx[np.clip(np.searchsorted(idx, np.flatnonzero(bad)), 0, len(idx) - 1)]
        r[bad], v[bad] = r[near], v[near]
    return satellite_geometry(net.t_s, r, v, sun_ecef_m(net.time))
