"""The estimators' common result: per-epoch position, clock, attitude, covariance and observability, and the
Euler angles (CONVENTIONS.md 3-2-1 relative to NED or the orbital frame) with their sigmas, an angle left
undetermined by an unobservable rotation reported as NaN (never as determined)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.rotations import dcm_to_euler321
from gnssatt.vector_phase.observability import undetermined_angles
from gnssatt.vector_phase.rotation import perturb_body

__all__ = ["Solution", "EulerRows", "euler_rows"]


@dataclass
class Solution:
    """Per epoch (n_ep rows; rows without a solution are NaN, `valid` False):
    t_gps_s, position_ecef_m (n_ep, 3), clock_cyc (n_ep,) (receiver clock change since t0, cycles),
    R_body_from_ecef (n_ep, 3, 3), P (n_ep, 7, 7) covariance of (position m, clock cyc, body rotation rad), the
    pseudo-inverse in the observable subspace when rank < 7 (an unobservable direction gets no variance here:
    the angles it moves are reported as undetermined instead), rank, condition, null_rotation_body (n_ep, 3), observability (text),
    n_sats, residuals_cyc (n_ep, n_sv) post-fit, method ("batch" or "ekf"), sats; start_hypotheses: how the EKF's
    bank of start hypotheses ended (gnssatt.vector_phase.rate_bank), None without one."""

    t_gps_s: np.ndarray
    sats: list
    position_ecef_m: np.ndarray
    clock_cyc: np.ndarray
    R_body_from_ecef: np.ndarray
    P: np.ndarray
    rank: np.ndarray
    condition: np.ndarray
    null_rotation_body: np.ndarray
    observability: list
    n_sats: np.ndarray
    residuals_cyc: np.ndarray
    valid: np.ndarray
    method: str
    warnings: list = field(default_factory=list)
    start_hypotheses: dict | None = None

    @classmethod
    def empty(cls, t_gps_s, sats, method: str) -> "Solution":
        n, m = len(t_gps_s), len(sats)
        nan = np.nan
        return cls(np.asarray(t_gps_s, float), list(sats), np.full((n, 3), nan), np.full(n, nan),
                   np.full((n, 3, 3), nan), np.full((n, 7, 7), nan), np.zeros(n, int), np.full(n, nan),
                   np.full((n, 3), nan), [""] * n, np.zeros(n, int), np.full((n, m), nan), np.zeros(n, bool),
                   method)


@dataclass
class EulerRows:
    """euler_deg / sigma_deg (n_ep, 3) yaw, pitch, roll (NaN where undetermined), determined (n_ep, 3) bool;
    boresight_deg / sigma_boresight_deg (n_ep, 2): the antenna boresight's direction in the reference frame,
    tilt from the reference -z (up for NED, zenith for the orbital frame) and azimuth from reference x towards
    y: what a cylindrically symmetric antenna does determine."""

    euler_deg: np.ndarray
    sigma_deg: np.ndarray
    determined: np.ndarray
    boresight_deg: np.ndarray
    sigma_boresight_deg: np.ndarray


def _angles(R_body_from_ecef, R_ref_from_ecef, boresight_body) -> np.ndarray:
    """(yaw, pitch, roll, boresight tilt, boresight azimuth), rad."""
    R = R_body_from_ecef @ R_ref_from_ecef.T
    b = R.T @ boresight_body
    tilt = np.arccos(np.clip(-b[2], -1.0, 1.0))
    return np.concatenate([np.radians(np.array(dcm_to_euler321(R), dtype=float)), [tilt, np.arctan2(b[1], b[0])]])


def _angle_jacobian(R_body_from_ecef, R_ref_from_ecef, boresight_body, step_rad: float = 1e-5) -> np.ndarray:
    """d(angles of _angles) / d(body rotation) (5, 3), rad per rad, central differences."""
    G = np.empty((5, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = step_rad
        a = _angles(perturb_body(R_body_from_ecef, e), R_ref_from_ecef, boresight_body)
        b = _angles(perturb_body(R_body_from_ecef, -e), R_ref_from_ecef, boresight_body)
        G[:, k] = np.angle(np.exp(1j * (a - b))) / (2 * step_rad)
    return G


def euler_rows(sol: Solution, R_ref_from_ecef: np.ndarray, boresight_body=(0.0, 0.0, -1.0)) -> EulerRows:
    """Euler angles of the body relative to the reference frame (R_ref_from_ecef (3, 3) or (n_ep, 3, 3)) with
    sigmas from P; an angle the unobservable rotation moves is NaN (observability.undetermined_angles)."""
    n = len(sol.t_gps_s)
    R_ref = np.broadcast_to(R_ref_from_ecef, (n, 3, 3))
    bore = np.asarray(boresight_body, float)
    out = np.full((n, 5), np.nan)
    sig = np.full((n, 5), np.nan)
    det = np.zeros((n, 3), bool)
    for k in np.flatnonzero(sol.valid):
        R = sol.R_body_from_ecef[k]
        out[k] = np.degrees(_angles(R, R_ref[k], bore))
        G = _angle_jacobian(R, R_ref[k], bore)
        sig[k] = np.degrees(np.sqrt(np.maximum(np.diag(G @ sol.P[k, 4:, 4:] @ G.T), 0.0)))
        undetermined = undetermined_angles(R, R_ref[k], sol.null_rotation_body[k])
        det[k] = ~undetermined
        out[k, :3][undetermined] = np.nan
        sig[k, :3][undetermined] = np.nan
    return EulerRows(out[:, :3], sig[:, :3], det, out[:, 3:], sig[:, 3:])
