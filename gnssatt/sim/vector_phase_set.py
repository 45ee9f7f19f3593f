"""A simulated single-antenna observation set for the vector-phase method (seed 003), as files: RINEX 3.04 GPS
observations (C1C, L1C) of one antenna, a RINEX navigation file of the same synthetic constellation,
platform.json with the antenna's `antenna_pattern` (docs/formats/antenna_vector_length.md), the reference
attitude (ECEF->body, CONVENTIONS.md), truth.json, and velocity.csv when the antenna moves (its position at the
first epoch is truth.json's).

The phases are those of gnssatt.vector_phase.scenario (eq. 35 with delta_s of eq. 32) written in the RINEX sign
convention: L = Psi - f dt_sv (the satellite clock at emission), C1C = rho - c dt_sv + noise; the time tags are
GPS time (receiver clock 0 s; the scenario's clock random walk, in cycles, stays in the phases).
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from gnssatt.gnss.io.rinex_nav_write import write_rinex_nav_gps
from gnssatt.gnss.rotations import dcm_to_quat
from gnssatt.gnss.time import GpsTime
from gnssatt.sim._rinex_obs_out import ObsHeader, write_obs
from gnssatt.vector_phase.pattern_file import antenna_pattern_doc
from gnssatt.vector_phase.troposphere import slant_delay_m
from gnssatt.vector_phase.scenario import C_M_S, ScenarioSpec, simulate

__all__ = ["write_vector_phase_set", "F_L1_HZ"]

F_L1_HZ = 1575.42e6
#: code noise of the simulated C1C, m (a typical L1 C/A code)
SIGMA_CODE_M = 0.3
#: sigma_m_s written in velocity.csv for a moving antenna (ScenarioSpec.velocity_ecef_m_s), m/s
SIGMA_VELOCITY_M_S = 0.02


def _reference_csv(t0: GpsTime, dt_s: np.ndarray, R_body_from_ecef: np.ndarray) -> str:
    q = dcm_to_quat(R_body_from_ecef)
    iso = (t0 + dt_s).iso(3)
    rows = [f"{t},ECEF,{w:.12f},{x:.12f},{y:.12f},{z:.12f}" for t, (w, x, y, z) in zip(iso, q)]
    return "time_gps,frame,qw,qx,qy,qz\n" + "\n".join(rows) + "\n"


def _velocity_csv(path: Path, t0: GpsTime, dt_s: np.ndarray, v_ecef_m_s: np.ndarray) -> Path:
    """velocity.csv (docs/formats/inertial_csv.md) of a moving antenna, sigma_m_s SIGMA_VELOCITY_M_S (the values
    are exact: the column says what a receiver's Doppler velocity would be good to)."""
    rows = [f"{t},{vx:.6f},{vy:.6f},{vz:.6f},{SIGMA_VELOCITY_M_S}" for t, (vx, vy, vz) in zip((t0 + dt_s).iso(3),
                                                                                            v_ecef_m_s)]
    path.write_text("time_gps,vx_ecef_m_s,vy_ecef_m_s,vz_ecef_m_s,sigma_m_s\n" + "\n".join(rows) + "\n")
    return path


def write_vector_phase_set(out_dir, spec: ScenarioSpec, *, antenna_id: str = "ANT", include_pattern: bool = True,
                           troposphere: bool = True):
    """Write the set into out_dir; returns (paths, observations, truth, mount) of gnssatt.vector_phase.scenario.

    troposphere: delay code and phase by the Saastamoinen slant delay (the model the reader removes); False
    writes the scenario's vacuum ranges (the code solution is then ~9 m low, as it corrects a delay not there)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    obs, truth, mount = simulate(spec)
    const, t0, idx = truth.constellation, truth.t0, truth.sat_index
    dt = obs.t_gps_s - obs.t_gps_s[0]
    r_rx = truth.position_ecef_m + dt[:, None] * np.asarray(spec.velocity_ecef_m_s, float)   # (n_ep, 3)
    rho = np.linalg.norm(obs.r_sat_ecef_m - r_rx[:, None], axis=-1)
    _, dt_sv = const.position_clock((t0 - const.t_ref) + dt[:, None] - rho / C_M_S, idx)
    rng = np.random.default_rng(spec.seed + 1000)
    tropo_m = slant_delay_m(truth.position_ecef_m, obs.r_sat_ecef_m) if troposphere else np.zeros_like(rho)
    code = rho + tropo_m - C_M_S * dt_sv + rng.normal(0.0, SIGMA_CODE_M, rho.shape)
    phase = obs.phase_cyc + tropo_m * F_L1_HZ / C_M_S - F_L1_HZ * dt_sv
    values = np.stack([code, phase], axis=-1)
    lli = np.zeros(values.shape, int)
    ssi = np.full(values.shape, 7)
    header = ObsHeader(marker=antenna_id, obs_types=["C1C", "L1C"], interval_s=spec.interval_s,
                       approx_xyz_m=truth.position_ecef_m, antenna_delta_xyz_m=np.zeros(3),
                       boresight=np.asarray(spec.boresight_body, float), receiver="GNSSATT-SIM",
                       antenna_type=mount.antenna.name.upper()[:20], leap_s=18,
                       comments=["vector-phase simulation (seed 003 eq. 32, 35)"], date_text="20180606 120000 GPS")
    whole = np.asarray(t0.s) + np.round(dt).astype(np.int64)
    tags = GpsTime(whole, np.zeros(len(whole)))
    paths = [write_obs(out / f"{antenna_id}.rnx", header, epochs=tags, sats=obs.sats, values=values, lli=lli,
                       ssi=ssi)]
    nav_path = out / "brdc.nav"
    write_rinex_nav_gps(nav_path, [r for r in const.records(t0, t0 + float(dt[-1])) if r.sat in obs.sats])
    paths.append(nav_path)
    antenna = {"position_m": [0.0, 0.0, 0.0], "boresight": list(spec.boresight_body)}
    if include_pattern:
        antenna["antenna_pattern"] = antenna_pattern_doc(mount.antenna)
    platform = {"name": "vector-phase rover", "kind": "terrestrial", "antennas": {antenna_id: antenna},
                "observation_files": {antenna_id: f"{antenna_id}.rnx"}}
    (out / "platform.json").write_text(json.dumps(platform, indent=1))
    (out / "reference_attitude.csv").write_text(_reference_csv(t0, dt, truth.R_body_from_ecef))
    (out / "truth.json").write_text(json.dumps({"position_ecef_m": truth.position_ecef_m.tolist(),
                                                "antenna": mount.antenna.name, "sats": obs.sats}))
    paths += [out / "platform.json", out / "reference_attitude.csv"]
    if obs.velocity_ecef_m_s is not None:
        paths.append(_velocity_csv(out / "velocity.csv", t0, dt, obs.velocity_ecef_m_s))
    return paths, replace(obs), truth, mount
