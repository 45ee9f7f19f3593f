"""Simulated C/N0 of the GNSS satellites seen by one antenna with a known gain pattern, for the cn0-boresight
method: C/N0 = c0 + G(off-boresight angle) - path-loss difference + per-satellite transmit offset + noise,
quantised, with a tracking threshold.

Implements: the free-space path loss 20 log10(range) relative to 20 200 km; a constant transmit-power offset
per satellite (the "inaccurate link budget" seed 001 sec. IV names as the main error), white noise.
Neglects: the transmit antenna's off-nadir pattern (folded into the offsets), multipath, ionospheric
scintillation; satellites behind the Earth are not tracked (100 km grazing height).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Cn0Params:
    """c0 (dB-Hz at boresight gain 0 dB and 20 200 km), per-satellite offset sigma (dB), noise sigma (dB),
    quantisation step (dB; 0 none), tracking threshold (dB-Hz)."""

    c0_dbhz: float = 42.0
    sat_offset_sigma_db: float = 1.5
    noise_sigma_db: float = 1.0
    resolution_db: float = 1.0
    threshold_dbhz: float = 30.0


def simulate_cn0(r_rx_ecef_m: np.ndarray, r_sat_ecef_m: np.ndarray, boresight_ecef: np.ndarray, pattern,
                 p: Cn0Params, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(cn0_dbhz (n, m) NaN where not tracked, los_ecef (n, m, 3)) for receiver positions (n, 3), satellite
    positions (n, m, 3) and the boresight in ECEF (n, 3)."""
    d = r_sat_ecef_m - r_rx_ecef_m[:, None, :]
    rng_m = np.linalg.norm(d, axis=-1)
    e = d / rng_m[..., None]
    tca = -np.einsum("nmi,ni->nm", e, r_rx_ecef_m)
    closest = np.linalg.norm(r_rx_ecef_m[:, None, :] + np.clip(tca, 0, None)[..., None] * e, axis=-1)
    visible = (tca <= 0) | (closest > 6378137.0 + 100e3)
    theta = np.degrees(np.arccos(np.clip(np.einsum("nmi,ni->nm", e, boresight_ecef), -1, 1)))
    offsets = rng.normal(0, p.sat_offset_sigma_db, r_sat_ecef_m.shape[1])
    cn0 = (p.c0_dbhz + pattern.gain(theta) - 20 * np.log10(rng_m / 20.2e6) + offsets[None]
           + rng.normal(0, p.noise_sigma_db, theta.shape))
    if p.resolution_db > 0:
        cn0 = np.round(cn0 / p.resolution_db) * p.resolution_db
    return np.where(visible & (cn0 >= p.threshold_dbhz) & np.isfinite(cn0), cn0, np.nan), e
