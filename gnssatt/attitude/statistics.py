"""Statistics of an attitude solution for summary.json: fix rate, time to first fix, residual RMS, the DOP-based
expected accuracy of seed 000 eq. 3-4 (Table 4) and the errors against a reference attitude.

Implements: seed 000 sec. 4.1, eq. 3 (sigma_H = HDOP sigma_Phi, sigma_V = VDOP sigma_Phi) and eq. 4
(sigma_yaw = asin(sigma_H / b), sigma_pitch,roll = asin(sigma_V / b)); DOP of a baseline with its differential
clock from the satellites whose phase was used, horizontal/vertical in the orbital frame (spacecraft) or the
local level frame (terrestrial). Wrong fixes against the reference: gnssatt.attitude.wrong_fix.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.wrong_fix import DEFINITIONS, classify_fixed_errors
from gnssatt.gnss import rotations as rot
from gnssatt.gnss.frames import R_gcrf_from_ecef

__all__ = ["summarize", "reference_errors", "interpolate_reference"]


def interpolate_reference(ref, t) -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_frame (n, 4), valid (n,)) of a ReferenceAttitude at GpsTime t, normalised linear
    interpolation between the bracketing samples (within 2 s), frame as in the file (one frame assumed)."""
    tr = (ref.time - ref.time[0]).astype(float) if hasattr(ref.time - ref.time[0], "astype") else ref.time - ref.time[0]
    tr = np.asarray(tr, float)
    tq = np.asarray(t - ref.time[0], float)
    i = np.clip(np.searchsorted(tr, tq, side="right") - 1, 0, max(len(tr) - 2, 0))
    if len(tr) < 2:
        return np.broadcast_to(ref.q_body_from_frame[0], (len(tq), 4)).copy(), np.abs(tq - tr[0]) < 1e-3
    q0, q1 = ref.q_body_from_frame[i], ref.q_body_from_frame[i + 1]
    q1 = np.where((np.sum(q0 * q1, -1) < 0)[:, None], -q1, q1)
    span = tr[i + 1] - tr[i]
    f = np.clip((tq - tr[i]) / span, 0.0, 1.0)
    q = rot.quat_normalize((1 - f)[:, None] * q0 + f[:, None] * q1)
    valid = (tq >= tr[0] - 1e-3) & (tq <= tr[-1] + 1e-3) & (span <= 2.0 + 1e-9)
    return q, valid


def reference_errors(sol, R_ref_from_ecef, q_ref_body_from_ecef: np.ndarray) -> np.ndarray:
    """Euler-angle errors (n_att, 3) deg (estimate minus reference, wrapped to +-180) at the attitude epochs."""
    R_be_ref = rot.quat_to_dcm(q_ref_body_from_ecef)
    Rf = R_ref_from_ecef[sol.att_epochs]
    y, p, r = rot.dcm_to_euler321(R_be_ref @ np.swapaxes(Rf, -1, -2))
    d = sol.euler_deg - np.stack([y, p, r], 1)
    return (d + 180.0) % 360.0 - 180.0


def _angle_stats(err: np.ndarray, sigma_pred: np.ndarray) -> dict:
    out = {}
    for i, name in enumerate(("yaw", "pitch", "roll")):
        e = err[:, i]
        e = e[np.isfinite(e)]
        if e.size == 0:
            continue
        out[name] = {"bias_deg": float(np.mean(e)), "sigma_deg": float(np.std(e)),
                     "rms_deg": float(np.sqrt(np.mean(e * e))), "max_abs_deg": float(np.max(np.abs(e))),
                     "predicted_sigma_deg": float(np.sqrt(np.nanmean(sigma_pred[:, i] ** 2)))}
    return out


def summarize(sol, R_ref_from_ecef: np.ndarray, orbit_source: str) -> dict:
    """The summary.json document of an AttitudeSolution."""
    fr, pobs, s = sol.fr, sol.pobs, sol.settings
    n_ep, n_bl = fr.ok.shape
    t0 = pobs.time[0]
    t_rel = np.asarray(pobs.time - t0, float)
    res = fr.residuals
    summary: dict = {
        "epochs": int(n_ep), "time_first": pobs.time[0].iso(), "time_last": pobs.time[-1].iso(),
        "mode": s.mode, "signals": list(pobs.signals), "platform": sol.inputs.platform.name,
        "kind": sol.inputs.platform.kind, "orbits": orbit_source, "platform_position": sol.geom.platform_source,
        "frames": {"ecef_to_gcrf": "IAU 2006/2000A (ERFA), EOP zero",
                   "euler_reference": "orbital frame" if sol.inputs.platform.kind != "terrestrial" else "NED"},
        "baselines": [], "warnings": list(pobs.warnings) + list(sol.inputs.warnings),
        "platform_defaults": list(getattr(sol, "platform_defaults", [])),
    }
    used = (res["reason"] == 0) & np.isfinite(res["residual_m"])
    for kind, name in ((0, "code"), (1, "phase")):
        m = used & (res["kind"] == kind)
        summary[f"residual_rms_{name}_m"] = float(np.sqrt(np.mean(res["residual_m"][m] ** 2))) if m.any() else None
    # DOPs per baseline (phase used), horizontal/vertical in the reference frame
    sel = used & (res["kind"] == 1)
    for j, (a, b) in enumerate(sol.baselines):
        L = float(np.linalg.norm(sol.body_baselines_m[j]))
        mj = sel & (res["bl"] == j)
        ep, sat = res["epoch"][mj], res["sat"][mj]
        key = np.unique(ep * 10000 + sat)            # satellites once per epoch even with two signals
        ep, sat = key // 10000, key % 10000
        u_ecef = sol.geom.los_ecef[ep, sat]
        u_ref = np.einsum("nij,nj->ni", R_ref_from_ecef[ep], u_ecef)
        g = np.concatenate([-u_ref, np.ones((ep.size, 1))], 1)
        N = np.zeros((n_ep, 4, 4))
        np.add.at(N, ep, np.einsum("ni,nj->nij", g, g))
        cnt = np.bincount(ep, minlength=n_ep)
        good = (cnt >= 4) & fr.fixed[:, j]
        hdop = vdop = float("nan")
        if good.any():
            with np.errstate(all="ignore"):
                Q = np.linalg.inv(N[good])
            hd = np.sqrt(Q[:, 0, 0] + Q[:, 1, 1])
            vd = np.sqrt(Q[:, 2, 2])
            ok = np.isfinite(hd) & np.isfinite(vd)
            hdop, vdop = float(np.mean(hd[ok])), float(np.mean(vd[ok]))
        sH, sV = hdop * s.table1.sigma_phase_m, vdop * s.table1.sigma_phase_m
        bb = sol.body_baselines_m[j]
        tilt = "pitch" if abs(bb[0]) >= abs(bb[1]) else "roll"
        ff = fr.first_fix_epoch[j]
        fd = fr.first_data_epoch[j]
        ttff = float(t_rel[ff] - t_rel[fd]) if ff >= 0 and fd >= 0 else None
        okj = fr.ok[:, j]
        bt = sol.baseline_table
        mb = (bt["bl"] == j) & bt["fixed"]
        summary["baselines"].append({
            "baseline": f"{a}>{b}", "known_length_m": L,
            "epochs_with_solution": int(okj.sum()), "epochs_fixed": int(fr.fixed[:, j].sum()),
            "fix_rate": float(fr.fixed[:, j].sum() / max(okj.sum(), 1)),
            "time_to_first_fix_s": ttff,
            "hdop": hdop, "vdop": vdop, "sigma_h_mm": sH * 1e3, "sigma_v_mm": sV * 1e3,
            "expected_sigma_yaw_deg": float(np.degrees(np.arcsin(min(sH / L, 1.0)))) if np.isfinite(sH) else None,
            f"expected_sigma_{tilt}_deg": float(np.degrees(np.arcsin(min(sV / L, 1.0)))) if np.isfinite(sV) else None,
            "tilt_angle": tilt,
            "median_length_m": float(np.median(bt["length_m"][mb])) if mb.any() else None,
            "median_azimuth_deg": float(np.median(bt["azimuth_deg"][mb])) if mb.any() else None,
            "median_elevation_deg": float(np.median(bt["elevation_deg"][mb])) if mb.any() else None,
        })
    if fr.noise is not None:
        summary["noise_model"] = fr.noise
    if getattr(fr, "smoother_data", None) is not None:
        # only with settings.smoothing.enabled (dynamic mode): the products are smoothed, not filtered, values
        summary["smoother"] = {"method": "Rauch-Tung-Striebel fixed interval (omega and baselines)",
                               "epochs_smoothed": int(fr.smoother_data.get("epochs_smoothed", 0))}
        if fr.smoother_data.get("adaptive_noise") is not None:
            summary["smoother"]["process_noise"] = fr.smoother_data["adaptive_noise"]
        if fr.smoother_data.get("covariance") is not None:
            summary["smoother"]["covariance"] = fr.smoother_data["covariance"]
    summary["fix_rate"] = float(fr.fixed.all(axis=1).sum() / max(fr.ok.all(axis=1).sum(), 1))
    summary["events"] = {}
    for e in fr.events:
        summary["events"][e["event"]] = summary["events"].get(e["event"], 0) + 1
    if sol.att_epochs is not None:
        summary["attitude_epochs"] = int(sol.att_epochs.size)
        summary["attitude_epochs_fixed"] = int(sol.att_fixed.sum())
        summary["predicted_sigma_deg"] = {n: float(np.sqrt(np.nanmean(sol.sigma_euler_deg[sol.att_fixed, i] ** 2)))
                                          if sol.att_fixed.any() else None
                                          for i, n in enumerate(("yaw", "pitch", "roll"))}
        ref = sol.inputs.reference
        if ref is not None and sol.att_epochs.size:
            t_att = pobs.time[sol.att_epochs]
            q_ref, valid = interpolate_reference(ref, t_att)
            frame = str(ref.frame[0])
            R_b_f = rot.quat_to_dcm(q_ref)
            if frame == "GCRF":
                R_b_f = R_b_f @ R_gcrf_from_ecef(t_att)
            err = reference_errors(sol, R_ref_from_ecef, rot.dcm_to_quat(R_b_f))
            err[~valid] = np.nan
            ang = rot.attitude_error_deg(sol.q_body_from_ecef, rot.dcm_to_quat(R_b_f))
            fx = sol.att_fixed & valid
            cls = classify_fixed_errors(err[fx], sol.sigma_euler_deg[fx])
            summary["reference"] = {
                "frame": frame, "epochs_compared": int(valid.sum()), "fixed_epochs_compared": int(fx.sum()),
                "fixed": _angle_stats(err[fx], sol.sigma_euler_deg[fx]),
                "float": _angle_stats(err[~sol.att_fixed & valid], sol.sigma_euler_deg[~sol.att_fixed & valid]),
                "wrong_fix_epochs": int(cls.wrong.sum()), "over_1deg_epochs": int(cls.over_1deg.sum()),
                "definitions": dict(DEFINITIONS),
                "max_error_fixed_deg": float(np.max(ang[fx])) if fx.any() else None,
            }
    return summary
