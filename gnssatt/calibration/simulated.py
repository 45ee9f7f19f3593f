"""Simulated calibration campaigns and their truth, for the calibration tests and bench/bench_calibration.py:
sets made by the project simulator (gnssatt.sim), and the injected offsets, PCO and PCV expressed in the
calibration's baseline/map split (gnssatt.calibration.decomposition), to score a campaign's products against.

Each set is simulated as pass 0 of its own run (`count: 1`) with its own start time and orbit phase, so all sets
share the antennas' hidden offsets, PCO and PCV: the simulator draws PCO/PCV per pass index (see
gnssatt/sim/simulate.py `_rng(seed, pidx, ai, "pcv")`), so its own multi-pass `count` would give every pass
different antennas.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["SPACING_S", "simulate_campaign", "truth_of", "truth_map_mm", "compare_maps_mm", "truth_split"]

SPACING_S = 2 * 86400.0 + 5 * 3600.0 + 11 * 60.0  # the calibration preset's pass spacing


def simulate_campaign(out: Path, n_sets: int, duration_s: float, *, seed: int = 7, overrides: dict | None = None,
                      spacing_s: float = SPACING_S, start_gps: str = "2018-01-10T03:00:00") -> list[Path]:
    """Directories of n_sets simulated calibration passes (reused when already there)."""
    from gnssatt.sim import simulate_scenario

    dirs = []
    t0 = GpsTime.from_iso(start_gps)
    for i in range(n_sets):
        d = Path(out) / f"set_{i:03d}"
        if not (d / "truth" / "model.json").exists():
            ov = {"count": 1, "duration_s": float(duration_s), "start_gps": (t0 + i * spacing_s).iso(0),
                  "mean_anomaly_deg": (133.2 * i) % 360.0}
            ov.update(overrides or {})
            simulate_scenario("calibration", d, seed=seed, overrides=ov)
        dirs.append(d)
    return dirs


def truth_of(directory: Path) -> dict:
    """Truth of a simulated set: per baseline the physical body baseline per frequency (ARP + PCO) and their
    mean, and the differential PCV grids (second minus first) with their nodes."""
    model = json.loads((Path(directory) / "truth" / "model.json").read_text())
    A = model["antennas"]
    out = {"baselines": {}, "pcv": {}}
    plat = json.loads((Path(directory) / "platform.json").read_text())
    for first, second in plat["baselines"]:
        R1 = np.asarray(A[first]["R_ant_from_body"])
        R2 = np.asarray(A[second]["R_ant_from_body"])
        arp = np.asarray(A[second]["arp_true_body_m"]) - np.asarray(A[first]["arp_true_body_m"])
        per_f = {f: arp + R2.T @ np.asarray(A[second]["pco_ant_m"][f]) - R1.T @ np.asarray(A[first]["pco_ant_m"][f])
                 for f in model["signals"]}
        out["baselines"][(first, second)] = {"arp_m": arp, "per_frequency_m": per_f,
                                             "mean_m": np.mean(list(per_f.values()), axis=0)}
        for f in model["signals"]:
            doc = json.loads((Path(directory) / "truth" / "pcv" / f"{first}_{second}_{f}.json").read_text())
            out["pcv"][(first, second, f)] = doc
    return out


def truth_map_mm(truth: dict, key: tuple, b_calibrated_m: np.ndarray, az_deg: np.ndarray, el_deg: np.ndarray,
                 boresight_first=(0.0, 0.0, -1.0)) -> np.ndarray:
    """The injected differential PCV of (first, second, signal) at (az, el) in the antenna frame of the first
    antenna, expressed in the decomposition the calibration uses: with baseline b_cal instead of the physical
    (ARP + PCO of that frequency) baseline b_f the map must also hold -g.(b_f - b_cal) (g the unit line of sight,
    body frame), and it is defined up to a constant (the per-epoch clock). mm."""
    from gnssatt.gnss.geometry import R_antenna_from_body
    from gnssatt.sim.observables import bilinear_pcv_mm

    doc = truth["pcv"][key]
    grid = np.array([[np.nan if v is None else v for v in row] for row in doc["values_mm"]], float)
    pcv = bilinear_pcv_mm(grid, np.asarray(az_deg), np.asarray(el_deg))
    a, e = np.radians(az_deg), np.radians(el_deg)
    d_ant = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)
    g_body = d_ant @ R_antenna_from_body(np.asarray(boresight_first, float))  # R^T d
    b_f = truth["baselines"][key[:2]]["per_frequency_m"][key[2]]
    return pcv - (g_body @ (b_f - np.asarray(b_calibrated_m))) * 1e3


def compare_maps_mm(values_mm: np.ndarray, truth_mm: np.ndarray, weight: np.ndarray) -> float:
    """RMS (mm) of estimated minus truth over bins with a value, after removing the weighted mean difference."""
    ok = np.isfinite(values_mm) & np.isfinite(truth_mm) & (weight > 0)
    if not np.any(ok):
        return float("nan")
    d = values_mm[ok] - truth_mm[ok]
    d = d - np.average(d, weights=weight[ok])
    return float(np.sqrt(np.mean(d ** 2)))


def truth_split(truth: dict, pair: tuple, az_deg: np.ndarray, el_deg: np.ndarray, weights: dict,
                boresight_first=(0.0, 0.0, -1.0)) -> tuple[np.ndarray, dict]:
    """The injected truth of a baseline in the calibration's decomposition (gnssatt.calibration.decomposition):
    (baseline (3,) m, {signal: map (n_el, n_az) mm}) such that, solid-angle weighted over the bins with
    weight > 0 (the bins where the estimated maps have a value: the same observed sky), the maps have no
    least-squares part a_f - g.db, exactly as the calibration splits its own estimate (CONVENTIONS.md). The physical model per frequency (ARP + PCO baseline b_f, injected differential PCV) is the
    single-difference term T_f(az, el) = -g.b_f + PCV_f; this function only re-expresses it.

    Args: az_deg (n_az,), el_deg (n_el,) bin centres (a regular grid); weights: signal -> (n_el, n_az), > 0 where
        the estimated map has a value (e.g. its bin counts there), 0 = empty.
    """
    from gnssatt.calibration.decomposition import bin_solid_angle_sr, offset_split
    from gnssatt.gnss.geometry import R_antenna_from_body
    from gnssatt.sim.observables import bilinear_pcv_mm

    A, E = np.meshgrid(np.asarray(az_deg, float), np.asarray(el_deg, float))
    a, e = np.radians(A), np.radians(E)
    d_ant = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1).reshape(-1, 3)
    g = d_ant @ R_antenna_from_body(np.asarray(boresight_first, float))
    sigs = sorted(weights)
    solid = bin_solid_angle_sr(az_deg, el_deg).ravel()
    T, W = [], []
    for sig in sigs:
        doc = truth["pcv"][tuple(pair) + (sig,)]
        grid = np.array([[np.nan if v is None else v for v in row] for row in doc["values_mm"]], float)
        pcv = bilinear_pcv_mm(grid, A, E).ravel()
        b_f = truth["baselines"][tuple(pair)]["per_frequency_m"][sig]
        w = np.where(np.asarray(weights[sig], float).ravel() > 0, solid, 0.0)
        T.append(np.where(w > 0, -(g @ b_f) * 1e3 + pcv, np.nan))
        W.append(w)
    db_mm, a_f = offset_split(T, W, g)
    maps = {sig: (t + g @ db_mm - af).reshape(A.shape) for sig, t, af in zip(sigs, T, a_f)}
    return db_mm * 1e-3, maps
