"""Product texts of the vector-phase method: attitude.csv (CONVENTIONS.md columns plus extras), observability.csv
(per epoch), residuals.csv and summary.json. An angle left undetermined by an unobservable rotation is an empty
cell (never a number), and so are the quaternions of an epoch whose attitude is not fully determined."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.rotations import dcm_to_quat
from gnssatt.gnss.time import GpsTime

__all__ = ["attitude_csv", "observability_csv", "residuals_csv", "ATTITUDE_COLUMNS"]

ATTITUDE_COLUMNS = ("time_gps,gps_week,gps_sow,qe_w,qe_x,qe_y,qe_z,qi_w,qi_x,qi_y,qi_z,yaw_deg,pitch_deg,roll_deg,"
                    "sigma_yaw_deg,sigma_pitch_deg,sigma_roll_deg,fixed,n_sats,rank,condition,yaw_determined,"
                    "pitch_determined,roll_determined,boresight_tilt_deg,boresight_azimuth_deg,"
                    "sigma_boresight_tilt_deg,sigma_boresight_azimuth_deg,x_ecef_m,y_ecef_m,z_ecef_m,clock_cyc,"
                    "estimator")


def _f(x, fmt: str) -> str:
    return "" if not np.isfinite(x) else format(float(x), fmt)


def _times(t_gps_s: np.ndarray):
    whole = np.floor(t_gps_s).astype(np.int64)
    t = GpsTime(whole, t_gps_s - whole)
    week, sow = t.week_sow()
    return t.iso(3), np.atleast_1d(week), np.atleast_1d(sow)


def attitude_csv(sol, euler, R_ecef_from_gcrf: np.ndarray) -> str:
    """attitude.csv text: one row per epoch with a solution (sol: Solution, euler: EulerRows,
    R_ecef_from_gcrf (n_ep, 3, 3)). `fixed` is 0: the method has no integer ambiguities to fix (the phase changes
    of eq. 44 need none), kept for the CONVENTIONS layout."""
    iso, week, sow = _times(sol.t_gps_s)
    lines = [ATTITUDE_COLUMNS]
    for k in np.flatnonzero(sol.valid):
        full = bool(euler.determined[k].all())
        qe = dcm_to_quat(sol.R_body_from_ecef[k]) if full else np.full(4, np.nan)
        qi = dcm_to_quat(sol.R_body_from_ecef[k] @ R_ecef_from_gcrf[k]) if full else np.full(4, np.nan)
        cells = [iso[k], str(int(week[k])), f"{sow[k]:.3f}"]
        cells += [_f(v, ".10f") for v in (*qe, *qi)]
        cells += [_f(v, ".5f") for v in euler.euler_deg[k]] + [_f(v, ".5f") for v in euler.sigma_deg[k]]
        cells += ["0", str(int(sol.n_sats[k])), str(int(sol.rank[k])), _f(sol.condition[k], ".4g")]
        cells += [str(int(d)) for d in euler.determined[k]]
        cells += [_f(v, ".5f") for v in (*euler.boresight_deg[k], *euler.sigma_boresight_deg[k])]
        cells += [_f(v, ".4f") for v in sol.position_ecef_m[k]] + [_f(sol.clock_cyc[k], ".4f"), sol.method]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def observability_csv(sol) -> str:
    """observability.csv: time_gps, rank (of 7), condition (scaled information matrix), the unobservable rotation
    axis in body axes (empty when rank 7), n_sats and the text."""
    iso, _, _ = _times(sol.t_gps_s)
    lines = ["time_gps,rank,condition,unobservable_axis_x_body,unobservable_axis_y_body,unobservable_axis_z_body,"
             "n_sats,observability"]
    for k in range(len(sol.t_gps_s)):
        axis = [_f(v, ".5f") for v in sol.null_rotation_body[k]]
        text = sol.observability[k].replace('"', "'")
        lines.append(f'{iso[k]},{int(sol.rank[k])},{_f(sol.condition[k], ".4g")},{",".join(axis)},'
                     f'{int(sol.n_sats[k])},"{text}"')
    return "\n".join(lines) + "\n"


def residuals_csv(sol) -> str:
    """residuals.csv: time_gps, sat, residual_cyc (post-fit phase residual, cycles)."""
    iso, _, _ = _times(sol.t_gps_s)
    lines = ["time_gps,sat,residual_cyc"]
    for k, j in zip(*np.nonzero(np.isfinite(sol.residuals_cyc))):
        lines.append(f"{iso[k]},{sol.sats[j]},{sol.residuals_cyc[k, j]:.6f}")
    return "\n".join(lines) + "\n"
