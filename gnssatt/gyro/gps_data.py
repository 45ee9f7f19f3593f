"""The GPS side of a fusion run: an observation set read into per-epoch L1 phases and lines of sight.

Reuses the attitude job's readers and geometry (gnssatt.attitude.process.load_inputs, the platform and satellite
states, gnssatt.attitude.geometry.compute_geometry) and builds, per epoch, the EpochPhases of the satellites
tracked on every antenna above the antenna-frame elevation mask, with the phase error model of
gnssatt.gyro.settings.GpsNoise (white + multipath growing quadratically with the off-boresight angle, as the
simulator's docs/simulator.md "Multipath").
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime
from gnssatt.gyro.settings import GpsNoise
from gnssatt.gyro.snapshot import EpochPhases

__all__ = ["GpsData", "load_gps", "epoch_phases"]


@dataclass
class GpsData:
    """time (n_ep,); phase_cyc (n_ant, n_ep, n_sat), master first; los_ecef (n_ep, n_sat, 3); valid (n_ep, n_sat);
    r/v_platform_ecef (n_ep, 3); baselines_body_m (n_ant-1, 3) master -> antenna; boresight_body (n_ant, 3)."""

    time: GpsTime
    antennas: list
    sats: list
    phase_cyc: np.ndarray
    los_ecef: np.ndarray
    valid: np.ndarray
    r_platform_ecef_m: np.ndarray
    v_platform_ecef_m_s: np.ndarray
    baselines_body_m: np.ndarray
    boresight_body: np.ndarray
    wavelength_m: float
    platform: object
    kind: str
    warnings: list


def load_gps(files: list[tuple[str, str, Path]]) -> GpsData:
    """GpsData of an observation set given as (name, kind, path) triples (gnssatt.attitude.process.load_inputs)."""
    from gnssatt.attitude.geometry import compute_geometry
    from gnssatt.attitude.observations import build_platform_obs
    from gnssatt.attitude.process import InputProblem, _platform_state, _sat_state, load_inputs

    inputs = load_inputs(files)
    plat = inputs.platform
    master = plat.master if plat.master in inputs.obs else list(inputs.obs)[0]
    antennas = [master] + [a for a in inputs.obs if a != master]
    if len(antennas) < 3:
        raise InputProblem("Too few antennas", "gyro fusion needs three antennas (two baselines) for a snapshot "
                           "attitude (seed 002 sec. 2.1)", field="platform")
    pobs = build_platform_obs({a: inputs.obs[a] for a in antennas}, ["L1"])
    if len(pobs.time) == 0:
        raise InputProblem("No observations", "the observation files hold no GPS L1 epochs")
    r_p, v_p, psrc = _platform_state(inputs, pobs, master)
    sat_state, _ = _sat_state(inputs, ("G",))
    observed = np.isfinite(pobs.phase_m[..., 0]).all(axis=0)
    geom = compute_geometry(pobs.time, pobs.sats, observed, sat_state, r_p, v_p, psrc)
    lam = float(pobs.wavelength_m[0])
    B = np.array([plat.baseline_body_m(master, a) for a in antennas[1:]])
    bs = np.array([plat.antennas[a].boresight_body for a in antennas])
    return GpsData(pobs.time, antennas, list(pobs.sats), pobs.phase_m[..., 0] / lam, geom.los_ecef,
                   geom.valid & observed, r_p, v_p, B, bs, lam, plat, plat.kind, list(inputs.warnings))


def epoch_phases(gps: GpsData, k: int, R_body_from_ecef: np.ndarray, noise: GpsNoise):
    """(EpochPhases of epoch k above the mask, satellite indices into gps.sats, reference order by elevation)."""
    ok = np.flatnonzero(gps.valid[k])
    e = gps.los_ecef[k, ok]                                   # (m, 3)
    e_body = e @ R_body_from_ecef.T
    el_deg = np.degrees(np.arcsin(np.clip(e_body @ gps.boresight_body.T, -1, 1)))    # (m, n_ant)
    el_min = el_deg.min(axis=1)
    keep = el_min >= noise.elevation_mask_deg
    ok, e, el_min = ok[keep], e[keep], el_min[keep]
    x = (90.0 - el_min) / 90.0
    mp = np.minimum(noise.multipath_zenith_m + (noise.multipath_horizon_m - noise.multipath_zenith_m) * x ** 2,
                    noise.multipath_cap_m)
    ep = EpochPhases(gps.phase_cyc[:, k, ok], e, np.full(len(ok), noise.phase_sigma_m), mp,
                     [gps.sats[j] for j in ok], gps.wavelength_m)
    refs = list(np.argsort(-el_min))
    return ep, ok, refs
