"""Snapshot (single-epoch) attitude from double-differenced L1 carrier phases: seed 002 eq. 1-2.

Model (eq. 1, in cycles; the plane-wave single difference of baseline b is -e.b, gnssatt.estimation.
constrained_search.dd_geometry):

    phi_i^{p,0} = -(1/lambda) (e_p - e_0)' A' b_i + N_i^{p,0} + d + eps,     A = R_body_from_ecef,

for antenna i against the master and satellite p against the reference satellite 0. With Y the (m-1, n-1)
matrix of double differences after the integers are removed, Delta_m the between-satellite operator, S' the (m, 3)
lines of sight (ECEF) and B the (n-1, 3) body baselines, the snapshot attitude minimises (eq. 2)

    J(A) = tr{ (Y - M(A))' Lambda_m (Y - M(A)) Lambda_n },    M(A) = -(1/lambda) Delta_m S' A' B',

with the decoupling matrices Lambda_m = lambda^2 (Delta_m D Delta_m')^-1 and Lambda_n = (Delta_n Delta_n')^-1,
D = diag(sigma_p^2) the undifferenced phase variance per satellite (same on every antenna): vec(Y) then has
covariance (Delta_n Delta_n') (x) (Delta_m D Delta_m') / lambda^2, so at the true A, J ~ chi^2 with
mu = (m-1)(n-1) - 3 degrees of freedom (sec. 2.1). J is minimised by Gauss-Newton over small body-frame rotations
A = (I - [dtheta x]) A0, with dM_pi/dtheta = (1/lambda) g_p' A0' [b_i x] (g_p row p of Delta_m S').

The integers come from the library's MLAMBDA (gnssatt.estimation.lambda_search.mlambda) on the float double
differences Y_raw - M(A_prior) with covariance H P_prior H' + cov(vec Y): a predicted attitude is the float
solution, as the paper resolves the integers every sample (sec. 4.3). The ratio test (3) validates the fix while
the prior is weak (the first epoch: Earth pointing within a few degrees); once the prior alone determines every
integer (PRIOR_FIXES_CYC) the best candidate is taken.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.estimation.constrained_search import dd_operator
from gnssatt.estimation.lambda_search import AmbiguitySearchError, mlambda
from gnssatt.gnss.rotations import skew

__all__ = ["EpochPhases", "SnapshotFit", "integer_corrected", "fit_attitude", "dof"]

GN_ITERATIONS = 10         # at most this many Gauss-Newton steps ...
GN_TOLERANCE_RAD = 1e-10   # ... stopping once a step is this small (2-3 steps from a prior within a few degrees)


@dataclass
class EpochPhases:
    """One epoch's L1 phases of the satellites in view of every antenna.

    phase_cyc (n_ant, m): master first; los_ecef (m, 3); sigma_white_m, sigma_mp_m (m,) undifferenced phase
    error per satellite (thermal, multipath); sats (m,) ids; wavelength_m.
    """

    phase_cyc: np.ndarray
    los_ecef: np.ndarray
    sigma_white_m: np.ndarray
    sigma_mp_m: np.ndarray
    sats: list
    wavelength_m: float

    @property
    def sigma_m(self) -> np.ndarray:
        return np.hypot(self.sigma_white_m, self.sigma_mp_m)


@dataclass
class SnapshotFit:
    """Result of eq. 2 on one subset of satellites: attitude, cost, its dof and threshold inputs, covariances."""

    R_body_from_ecef: np.ndarray
    J: float
    dof: int
    P_rad2: np.ndarray            # (3, 3) covariance of the body-frame small rotation (all noise)
    P_mp_rad2: np.ndarray         # the multipath part of it (the Gauss-Markov part of the GPS attitude noise)
    residual_cyc: np.ndarray      # (len(subset)-1, n-1) residual double differences
    subset: np.ndarray            # satellite indices used; ref first
    ref: int


def dof(m: int, n: int) -> int:
    """Degrees of freedom of J: (m - 1)(n - 1) - 3 (seed 002 sec. 2.1)."""
    return (m - 1) * (n - 1) - 3


def _sd(phase_cyc: np.ndarray) -> np.ndarray:
    """(m, n-1) single differences antenna i minus the master, cycles."""
    return (phase_cyc[1:] - phase_cyc[:1]).T


def _model(G: np.ndarray, R: np.ndarray, B: np.ndarray, lam: float) -> np.ndarray:
    """M = -(1/lambda) G A' B' for geometry rows G (k, 3) (ECEF), A = R_body_from_ecef, B (n-1, 3) body."""
    return -(G @ R.T @ B.T) / lam


def _jacobian(G: np.ndarray, R: np.ndarray, B: np.ndarray, lam: float) -> np.ndarray:
    """(k * (n-1), 3) d vec(M) / d dtheta, vec stacking columns (baseline-major)."""
    GA = G @ R.T                                         # (k, 3): g_p' A0'
    rows = [GA @ skew(b) / lam for b in B]               # (k, 3) each: (1/lambda) g_p' A0' [b_i x]
    return np.vstack(rows)


def _weights(D_m2: np.ndarray, Dm: np.ndarray, n_bl: int, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """(W, C): the weight matrix (Lambda_n (x) Lambda_m) and covariance of vec(Y) in cycles^2."""
    Dn = np.hstack([-np.ones((n_bl, 1)), np.eye(n_bl)])
    Cn = Dn @ Dn.T
    Cm = Dm @ np.diag(D_m2) @ Dm.T / lam ** 2
    C = np.kron(Cn, Cm)
    return np.kron(np.linalg.inv(Cn), np.linalg.inv(Cm)), C


#: below this prior sigma of every double difference (cycles) the prior alone fixes the integers (a 6-sigma
#: margin to the rounding boundary of 0.5 cycle), so MLAMBDA's ratio test is not applied: a phase fault of 0.35
#: cycle (seed 002 Table 1) would otherwise fail it and hide the fault from the exclusion bank
PRIOR_FIXES_CYC = 0.08


def integer_corrected(ep: EpochPhases, B: np.ndarray, R_prior: np.ndarray, P_prior_rad2: np.ndarray,
                      ref: int, ratio_min: float = 3.0):
    """(Z (m, n-1) single differences minus the integers, relative to the reference satellite's, ratio, N) or
    (None, ratio, None) when MLAMBDA's ratio test fails. Z[ref] = 0; any double difference is then Z[p] - Z[q];
    N (m-1, n-1) the double-difference integers of the satellites but ref (in order) against ref."""
    m = len(ep.sats)
    Dm = dd_operator(m, ref)
    lam = ep.wavelength_m
    Y_raw = Dm @ _sd(ep.phase_cyc)                                      # (m-1, n-1)
    G = Dm @ ep.los_ecef
    a_float = (Y_raw - _model(G, R_prior, B, lam)).T.ravel()             # vec, baseline-major
    H = _jacobian(G, R_prior, B, lam)
    _, C = _weights(ep.sigma_m ** 2, Dm, len(B), lam)
    Q = H @ P_prior_rad2 @ H.T + C
    try:
        res = mlambda(a_float, 0.5 * (Q + Q.T), m=2)
    except (AmbiguitySearchError, ValueError):
        return None, float("nan"), None
    prior_sigma_cyc = np.sqrt(np.max(np.diag(H @ P_prior_rad2 @ H.T)))
    if not res.ratio >= ratio_min and prior_sigma_cyc > PRIOR_FIXES_CYC:
        return None, float(res.ratio), None
    N = res.fixed[0].reshape(len(B), m - 1).T                            # (m-1, n-1)
    Z = np.zeros((m, len(B)))
    Z[np.arange(m) != ref] = Y_raw - N
    return Z, float(res.ratio), N


def fit_attitude(Z: np.ndarray, ep: EpochPhases, B: np.ndarray, R0: np.ndarray, subset: np.ndarray,
                 ref: int) -> SnapshotFit:
    """Minimise eq. 2 over the satellites `subset` (indices into ep, containing ref) with reference `ref`."""
    subset = np.asarray([ref] + [int(s) for s in subset if s != ref])
    k = len(subset)
    Dm = dd_operator(k, 0)
    lam = ep.wavelength_m
    Y = Dm @ Z[subset]
    G = Dm @ ep.los_ecef[subset]
    W, _ = _weights(ep.sigma_m[subset] ** 2, Dm, len(B), lam)
    R = R0.copy()
    for _ in range(GN_ITERATIONS):
        r = (Y - _model(G, R, B, lam)).T.ravel()
        H = _jacobian(G, R, B, lam)
        N = H.T @ W @ H
        dth = np.linalg.solve(N, H.T @ W @ r)
        R = _small_rotation(dth) @ R
        if np.linalg.norm(dth) < GN_TOLERANCE_RAD:
            break
    res = Y - _model(G, R, B, lam)
    r = res.T.ravel()
    J = float(r @ W @ r)
    H = _jacobian(G, R, B, lam)
    P = np.linalg.inv(H.T @ W @ H)
    _, C_mp = _weights(ep.sigma_mp_m[subset] ** 2, Dm, len(B), lam)
    K = P @ H.T @ W
    P_mp = K @ C_mp @ K.T
    return SnapshotFit(R, J, dof(k, len(B) + 1), P, 0.5 * (P_mp + P_mp.T), res, subset, ref)


def _small_rotation(theta: np.ndarray) -> np.ndarray:
    """exp(-[theta x]) (the passive rotation of the error state): R_new = exp(-[theta x]) R_old."""
    a = float(np.linalg.norm(theta))
    K = skew(theta)
    if a < 1e-12:
        return np.eye(3) - K
    return np.eye(3) - np.sin(a) / a * K + (1 - np.cos(a)) / a ** 2 * K @ K
