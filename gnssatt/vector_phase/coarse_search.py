"""Initial attitude by a coarse search, when it is not known (seed 003 sec. V.B needs it at t0): every candidate
of a grid of yaw, pitch and roll (relative to the reference frame) starts the EKF (gnssatt.vector_phase.ekf, its
initial attitude sigma = the grid step) over the first epochs, and the candidate whose phases fit best (smallest
mean squared normalised post-fit residual) wins. The epoch-wise estimator cannot do this (each epoch's free
attitude absorbs a wrong start); the filter's dynamics tie the epochs together. The phases carry the attitude only
through its changes, so the platform must rotate during those epochs, and an antenna pattern with an m-fold
azimuthal symmetry (AsymmetricPatch harmonic m) leaves m starts 360/m deg apart equally good: the result keeps the
best and the second-best score more than two steps away (ratio near 1: ambiguous).
The scoring filter keeps a position random walk (SCORE_Q_POSITION_M2_S), although the estimation EKF's default is
0 since the static-antenna fix: a candidate is up to half a grid step off, and without that slack the filter's
convergence from such a start is erratic. Measured on the m = 2 test set (45 deg grid, truth 100 deg): walk 0 scored
the twins 90 / 270 deg at 0.69 / 10.6 (4 iterations) and 10.0 / 10.5 (10 iterations), against 0.53 at the exact
start; with 1e-6 m^2/s, 0.44 / 0.43 (the walk the search was designed with).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.rotations import euler321_to_dcm
from gnssatt.vector_phase.ekf import EkfOptions, ekf_solve
from gnssatt.vector_phase.phase_model import ReceiverState

__all__ = ["CoarseResult", "coarse_search", "AMBIGUITY_RATIO"]

#: a search is ambiguous when a candidate more than two steps from the best scores within this factor of it: the
#: m = 2 patch's 180 deg twin scores within 1 % (tests/vector_phase/test_coarse_search.py), a wrong start of the
#: m = 1 patch 1.5x worse
AMBIGUITY_RATIO = 1.2
#: position random walk of the scoring filter, m^2/s (1 mm/sqrt(s)): slack for a start half a grid step off
SCORE_Q_POSITION_M2_S = 1e-6


@dataclass(frozen=True)
class CoarseResult:
    """R_body_from_ecef (3, 3) of the best candidate, its euler_deg (yaw, pitch, roll), score (mean squared
    normalised residual), second_score (the best candidate more than 2 steps away), n_candidates."""

    R_body_from_ecef: np.ndarray
    euler_deg: tuple
    score: float
    second_score: float
    n_candidates: int

    @property
    def ambiguous(self) -> bool:
        """Another start, far from the best, fits about as well (AMBIGUITY_RATIO)."""
        return bool(self.second_score < AMBIGUITY_RATIO * self.score)


def _score(obs, mount, position, R0, n_epochs: int, min_sats: int, step_deg: float) -> float:
    sol = ekf_solve(_head(obs, n_epochs), mount, ReceiverState(position, 0.0, R0),
                    EkfOptions(sigma_attitude0_deg=step_deg, min_sats=min_sats, rate_hypotheses_step_deg_s=0.0,
                               q_position_m2_s=SCORE_Q_POSITION_M2_S))
    r = sol.residuals_cyc[1:] / obs.sigma_phase_cyc
    if not np.isfinite(r).any():
        return np.inf
    return float(np.nanmean(r ** 2))


def _head(obs, n_epochs: int):
    from dataclasses import replace
    s = slice(0, n_epochs)
    return replace(obs, t_gps_s=obs.t_gps_s[s], phase_cyc=obs.phase_cyc[s], r_sat_ecef_m=obs.r_sat_ecef_m[s],
                   x_sat_ecef=obs.x_sat_ecef[s], y_sat_ecef=obs.y_sat_ecef[s], arc_start=obs.arc_start[s],
                   velocity_ecef_m_s=None if obs.velocity_ecef_m_s is None else obs.velocity_ecef_m_s[s])


def coarse_search(obs, mount, position_ecef_m, R_ref_from_ecef, *, step_deg: float = 30.0,
                  tilt_max_deg: float = 0.0, n_epochs: int = 60, min_sats: int = 7) -> CoarseResult:
    """CoarseResult over yaw in [0, 360) and pitch, roll in [-tilt_max, tilt_max] (0: level only) on a step_deg
    grid, each scored over the first n_epochs."""
    tilts = np.arange(-tilt_max_deg, tilt_max_deg + 1e-9, step_deg) if tilt_max_deg > 0 else np.array([0.0])
    cands = [(y, p, r) for y in np.arange(0.0, 360.0, step_deg) for p in tilts for r in tilts]
    scores = np.array([_score(obs, mount, position_ecef_m, euler321_to_dcm(*c) @ R_ref_from_ecef, n_epochs,
                              min_sats, step_deg) for c in cands])
    best = int(np.argmin(scores))
    far = [i for i, c in enumerate(cands)
           if max(abs((c[0] - cands[best][0] + 180) % 360 - 180), abs(c[1] - cands[best][1]),
                  abs(c[2] - cands[best][2])) > 2 * step_deg]
    second = float(np.min(scores[far])) if far else float("inf")
    return CoarseResult(euler321_to_dcm(*cands[best]) @ R_ref_from_ecef, tuple(float(v) for v in cands[best]),
                        float(scores[best]), second, len(cands))
