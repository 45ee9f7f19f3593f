"""Synthetic single-epoch attitude problems: random GPS-like geometry, a rigid antenna platform, DD phase and code.

Used by the estimation tests and by ``bench/bench_lambda.py``. Everything is drawn from a seeded numpy Generator.
The noise is simulated per antenna and satellite (undifferenced), then differenced, so the correlation between
baselines sharing the master antenna and between the DDs sharing the reference satellite is the physical one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.estimation.constrained_search import DDBlock, FloatSolution, dd_geometry, single_epoch_float
from gnssatt.gnss.signals import WAVELENGTH_GPS_L1_M, WAVELENGTH_GPS_L2_M

#: GPS L1 and L2 wavelengths, metres (c / 1575.42 MHz, c / 1227.60 MHz).
L1_WAVELENGTH_M = WAVELENGTH_GPS_L1_M
L2_WAVELENGTH_M = WAVELENGTH_GPS_L2_M
#: CASSIOPE-like body baselines (CONVENTIONS.md example platform), metres: GPS-2 -> GPS-0, GPS-2 -> GPS-1.
CASSIOPE_BODY_M = np.array([[1.04653, -0.07191, 0.0], [0.0, 1.13969, 0.0]])
#: CubeSat-like: two ~10 cm baselines at right angles.
CUBESAT_BODY_M = np.array([[0.10, 0.0, 0.0], [0.0, 0.10, 0.0]])


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix uniformly distributed on SO(3) (QR of a Gaussian matrix, sign-fixed)."""
    Qm, Rm = np.linalg.qr(rng.normal(size=(3, 3)))
    Qm = Qm * np.sign(np.diag(Rm))
    if np.linalg.det(Qm) < 0:
        Qm[:, 0] = -Qm[:, 0]
    return Qm


def random_los(rng: np.random.Generator, n_sats: int, min_elevation_deg: float = 10.0) -> np.ndarray:
    """(n_sats, 3) unit line-of-sight vectors above the horizon of a local frame with z up (uniform in solid
    angle above the mask), used directly as the 'ECEF' frame of the problem."""
    az = rng.uniform(0.0, 2 * np.pi, n_sats)
    sin_el = rng.uniform(np.sin(np.radians(min_elevation_deg)), 1.0, n_sats)
    cos_el = np.sqrt(1.0 - sin_el**2)
    return np.stack([cos_el * np.cos(az), cos_el * np.sin(az), sin_el], axis=-1)


@dataclass
class Epoch:
    sol: FloatSolution
    a_true: np.ndarray        # (n,) true DD ambiguities in the layout of sol
    b_true_m: np.ndarray      # (3q,)
    R_true: np.ndarray        # frame-from-body rotation
    body_m: np.ndarray        # (q, 3)


def simulate_epoch(rng: np.random.Generator, body_m: np.ndarray, n_sats: int = 8,
                   wavelengths_m: tuple = (L1_WAVELENGTH_M,), sigma_phase_m: float = 0.003,
                   sigma_code_m: float = 0.3, min_elevation_deg: float = 10.0) -> Epoch:
    """One epoch of DD phase and code for a rigid platform with antennas 0 (master) and 1..q at body_m."""
    body_m = np.asarray(body_m, float).reshape(-1, 3)
    q = body_m.shape[0]
    R = random_rotation(rng)
    ant_pos = np.vstack([np.zeros(3), body_m @ R.T])          # (q+1, 3) antenna positions in the frame
    e = random_los(rng, n_sats, min_elevation_deg)
    ref = int(np.argmax(e[:, 2]))                              # highest satellite as reference
    G = dd_geometry(e, ref)
    sats = tuple(i for i in range(n_sats) if i != ref)
    blocks, phases, codes, a_true = [], [], [], []
    for f, lam in enumerate(wavelengths_m):
        # undifferenced: range term -e_s . x_ant (plane wave), integer ambiguity, noise
        N_und = rng.integers(-10_000, 10_000, size=(q + 1, n_sats))
        rho = -(ant_pos @ e.T)                                # (q+1, n_sats) metres
        phi = rho / lam + N_und + rng.normal(0.0, sigma_phase_m / lam, (q + 1, n_sats))
        code = rho + rng.normal(0.0, sigma_code_m, (q + 1, n_sats))
        for i in range(q):
            sd_phi, sd_code = phi[i + 1] - phi[0], code[i + 1] - code[0]
            sd_N = N_und[i + 1] - N_und[0]
            keep = np.arange(n_sats) != ref
            blocks.append(DDBlock(i, f"L{f + 1}", lam, sats, ref, G))
            phases.append(sd_phi[keep] - sd_phi[ref])
            codes.append(sd_code[keep] - sd_code[ref])
            a_true.append(sd_N[keep] - sd_N[ref])
    order = sorted(range(len(blocks)), key=lambda j: (blocks[j].baseline, blocks[j].signal))
    blocks = [blocks[j] for j in order]
    sol = single_epoch_float(blocks, [phases[j] for j in order], [codes[j] for j in order],
                             [(0, i + 1) for i in range(q)], sigma_phase_m, sigma_code_m)
    return Epoch(sol=sol, a_true=np.concatenate([a_true[j] for j in order]),
                 b_true_m=(body_m @ R.T).reshape(-1), R_true=R, body_m=body_m)
