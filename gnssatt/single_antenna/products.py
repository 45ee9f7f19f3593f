"""attitude.csv of the single-antenna methods (CONVENTIONS.md "Output: attitude time series") and the
Euler-angle sigmas from a body-frame rotation covariance.

Implements: CONVENTIONS.md quaternions, frames (orbital frame for spacecraft, NED for terrestrial platforms),
Euler 3-2-1 angles; the Euler-rate kinematics dtheta_body = [e1, Rx(roll) e2, Rx(roll) Ry(pitch) e3]
(d_roll, d_pitch, d_yaw) for R = Rx(roll) Ry(pitch) Rz(yaw) (passive).
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.frames import R_ecef_from_gcrf, R_ned_from_ecef, R_orbital_from_ecef, ecef_to_geodetic
from gnssatt.gnss.rotations import Rx, Ry, dcm_to_euler321, dcm_to_quat


def euler_sigma_deg(R_body_from_ref: np.ndarray, cov_body_rad2: np.ndarray) -> np.ndarray:
    """(n, 3) 1-sigma of (yaw, pitch, roll) in deg from the body-frame small-rotation covariance (n, 3, 3)."""
    yaw, pitch, roll = dcm_to_euler321(R_body_from_ref)
    r, p = np.radians(roll), np.radians(pitch)
    e2, e3 = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    B = np.stack([np.broadcast_to([1.0, 0.0, 0.0], r.shape + (3,)), Rx(r) @ e2,
                  np.einsum("nij,nj->ni", Rx(r) @ Ry(p), np.broadcast_to(e3, r.shape + (3,)))], axis=-1)
    with np.errstate(all="ignore"):
        Bi = np.linalg.inv(np.where(np.isfinite(B), B, np.eye(3)))
        P = Bi @ np.where(np.isfinite(cov_body_rad2), cov_body_rad2, np.nan) @ np.swapaxes(Bi, -1, -2)
        return np.degrees(np.sqrt(np.diagonal(P, axis1=-2, axis2=-1)))[..., ::-1]


def reference_from_ecef(r_ecef_m: np.ndarray, v_ecef_m_s: np.ndarray, kind: str) -> np.ndarray:
    """R_ref_from_ecef (n, 3, 3): orbital frame (spacecraft) or NED at the position (terrestrial)."""
    if kind == "spacecraft":
        return R_orbital_from_ecef(r_ecef_m, v_ecef_m_s)
    lat, lon, _ = ecef_to_geodetic(r_ecef_m)
    return R_ned_from_ecef(lat, lon)


def attitude_csv(time, R_body_from_ecef, cov_body_rad2, r_ecef_m, v_ecef_m_s, kind: str, flags,
                 n_sats=None) -> str:
    """attitude.csv rows for the epochs with an attitude: the CONVENTIONS columns (fixed = 0: no ambiguities),
    then `flags` (the method's bit field)."""
    ok = np.isfinite(R_body_from_ecef).all((-1, -2))
    idx = np.flatnonzero(ok)
    head = ("time_gps,gps_week,gps_sow,qe_w,qe_x,qe_y,qe_z,qi_w,qi_x,qi_y,qi_z,yaw_deg,pitch_deg,roll_deg,"
            "sigma_yaw_deg,sigma_pitch_deg,sigma_roll_deg,fixed,n_sats,flags")
    if not len(idx):
        return head + "\n"
    t = time[idx]
    R = R_body_from_ecef[idx]
    qe = dcm_to_quat(R)
    qi = dcm_to_quat(R @ R_ecef_from_gcrf(t))
    R_ref = reference_from_ecef(r_ecef_m[idx], v_ecef_m_s[idx], kind)
    R_b_ref = R @ np.swapaxes(R_ref, -1, -2)
    yaw, pitch, roll = dcm_to_euler321(R_b_ref)
    sig = euler_sigma_deg(R_b_ref, cov_body_rad2[idx])
    week, sow = t.week_sow()
    iso = t.iso()
    ns = np.zeros(len(idx), int) if n_sats is None else np.asarray(n_sats)[idx]
    rows = [head]
    for k in range(len(idx)):
        vals = [iso[k], str(int(week[k])), f"{sow[k]:.3f}"] + [f"{x:.9f}" for x in (*qe[k], *qi[k])]
        vals += [f"{x:.4f}" for x in (yaw[k], pitch[k], roll[k])] + [f"{x:.4f}" for x in sig[k]]
        vals += ["0", str(int(ns[k])), str(int(flags[idx[k]]))]
        rows.append(",".join(vals))
    return "\n".join(rows) + "\n"
