"""The estimate against a reference attitude (a star tracker, or the simulator's truth): the reference rotated to
ECEF at the solution epochs, and per angle the RMS error and the RMS of error / sigma (the consistency the issue
asks for: 0.8-1.25), over the epochs where the angle is determined."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from gnssatt.vector_phase.solution import euler_rows

__all__ = ["reference_R_body_from_ecef", "compare_with_reference"]


def reference_R_body_from_ecef(reference, t_gps_s: np.ndarray, max_gap_s: float = 10.0) -> np.ndarray:
    """(n, 3, 3) R_body_from_ecef of a ReferenceAttitude (gnssatt.gnss.io.reference_attitude) at t_gps_s, nearest
    sample within max_gap_s (NaN elsewhere); GCRF rows rotated with zero EOP."""
    from gnssatt.gnss.frames import R_ecef_from_gcrf
    from gnssatt.gnss.rotations import quat_to_dcm

    t_ref = np.asarray(reference.time.s, float) + np.asarray(reference.time.frac, float)
    idx = np.clip(np.searchsorted(t_ref, t_gps_s), 0, len(t_ref) - 1)
    prev = np.clip(idx - 1, 0, len(t_ref) - 1)
    idx = np.where(np.abs(t_ref[prev] - t_gps_s) < np.abs(t_ref[idx] - t_gps_s), prev, idx)
    R = quat_to_dcm(reference.q_body_from_frame[idx])
    gcrf = np.asarray(reference.frame)[idx] == "GCRF"
    if gcrf.any():
        R[gcrf] = R[gcrf] @ np.swapaxes(R_ecef_from_gcrf(reference.time[idx[gcrf]]), -1, -2)
    R[np.abs(t_ref[idx] - t_gps_s) > max_gap_s] = np.nan
    return R


def compare_with_reference(sol, euler, R_ref_from_ecef, mount, R_true_body_from_ecef):
    """(reference Euler angles (n, 3) deg, comparison dict): RMS error (deg) and RMS error/sigma per angle."""
    ok = np.all(np.isfinite(R_true_body_from_ecef), axis=(1, 2))
    R_true = np.where(ok[:, None, None], R_true_body_from_ecef, np.eye(3))
    true_rows = euler_rows(replace(sol, R_body_from_ecef=R_true, valid=sol.valid & ok,
                                   null_rotation_body=np.full_like(sol.null_rotation_body, np.nan)),
                           R_ref_from_ecef, mount.R_ant_from_body[2])
    err = (euler.euler_deg - true_rows.euler_deg + 180.0) % 360.0 - 180.0
    out = {}
    for i, a in enumerate(("yaw", "pitch", "roll")):
        m = np.isfinite(err[:, i]) & (euler.sigma_deg[:, i] > 0)
        m[0] = False                                               # the start is the reference itself
        out[a] = {"epochs": int(m.sum()),
                  "rms_error_deg": float(np.sqrt(np.mean(err[m, i] ** 2))) if m.any() else None,
                  "rms_error_over_sigma": float(np.sqrt(np.mean((err[m, i] / euler.sigma_deg[m, i]) ** 2)))
                  if m.any() else None}
    return true_rows.euler_deg, out
