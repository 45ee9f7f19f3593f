"""The products of a plan: plan.csv (one row per epoch) and summary.json (means, percentiles, notes)."""
from __future__ import annotations

from dataclasses import asdict

import numpy as np

from gnssatt.planning.series import PlanSeries, PlanSettings


def _fmt(x: float, digits: int) -> str:
    return "" if not np.isfinite(x) else f"{x:.{digits}f}"


def plan_csv(s: PlanSeries) -> str:
    """plan.csv: time_gps, gps_week, gps_sow, n_sats, hdop, vdop, pdop, adop, sigma_yaw_deg, sigma_pitch_deg,
    sigma_roll_deg (snapshot, all baselines), filter_sigma_yaw/pitch/roll_deg (the filter's steady state), then per baseline B: B_sigma_h_mm, B_sigma_v_mm, B_sigma_yaw_deg,
    B_sigma_tilt_deg (seed 000 eq. 3-4), B_sigma_r_eq5_deg (seed 001 eq. 5), B_crlb_deg (eq. 4)."""
    week, sow = s.time.week_sow()
    iso = s.time.iso()
    head = ["time_gps", "gps_week", "gps_sow", "n_sats", "hdop", "vdop", "pdop", "adop", "sigma_yaw_deg",
            "sigma_pitch_deg", "sigma_roll_deg", "filter_sigma_yaw_deg", "filter_sigma_pitch_deg",
            "filter_sigma_roll_deg"]
    for b in s.baselines:
        head += [f"{b}_{c}" for c in ("sigma_h_mm", "sigma_v_mm", "sigma_yaw_deg", "sigma_tilt_deg",
                                      "sigma_r_eq5_deg", "crlb_deg")]
    rows = [",".join(head)]
    for i in range(len(s.n_sats)):
        r = [iso[i], str(int(week[i])), f"{sow[i]:.3f}", str(int(s.n_sats[i]))]
        r += [_fmt(v, 3) for v in (s.hdop[i], s.vdop[i], s.pdop[i], s.adop[i])]
        r += [_fmt(v, 4) for v in s.sigma_euler_deg[i]]
        r += [_fmt(v, 4) for v in s.sigma_filter_deg[i]]
        for k in range(len(s.baselines)):
            r += [_fmt(s.sigma_h_m[i, k] * 1e3, 3), _fmt(s.sigma_v_m[i, k] * 1e3, 3), _fmt(s.sigma_yaw_deg[i, k], 4),
                  _fmt(s.sigma_tilt_deg[i, k], 4), _fmt(s.sigma_r_eq5_deg[i, k], 4), _fmt(s.crlb_deg[i, k], 5)]
        rows.append(",".join(r))
    return "\n".join(rows) + "\n"


def _stats(x: np.ndarray) -> dict:
    x = x[np.isfinite(x)]
    if not len(x):
        return {"mean": None, "p50": None, "p95": None, "max": None}
    return {"mean": float(np.mean(x)), "p50": float(np.percentile(x, 50)), "p95": float(np.percentile(x, 95)),
            "max": float(np.max(x))}


def plan_summary(s: PlanSeries, settings: PlanSettings, platform_name: str) -> dict:
    """summary.json: the settings, per-quantity mean / median / 95th percentile / max over the epochs, the
    fraction of epochs with a full attitude (>= 4 satellites and two non-collinear baselines)."""
    full = np.isfinite(s.sigma_euler_deg).all(-1)
    return {
        "platform": platform_name, "settings": asdict(settings), "n_epochs": int(len(s.n_sats)),
        "time_first": s.time[0].iso(), "time_last": s.time[-1].iso(),
        "fraction_with_attitude": float(full.mean()) if len(full) else 0.0,
        "n_sats": _stats(s.n_sats.astype(float)), "hdop": _stats(s.hdop), "vdop": _stats(s.vdop),
        "adop": _stats(s.adop),
        "sigma_deg": {k: _stats(s.sigma_euler_deg[:, i]) for i, k in enumerate(("yaw", "pitch", "roll"))},
        "filter_sigma_deg": {k: _stats(s.sigma_filter_deg[:, i]) for i, k in enumerate(("yaw", "pitch", "roll"))},
        "baselines": [{"baseline": b, "length_m": float(s.baseline_m[k]),
                       "sigma_h_mm": _stats(s.sigma_h_m[:, k] * 1e3), "sigma_v_mm": _stats(s.sigma_v_m[:, k] * 1e3),
                       "sigma_yaw_deg_eq4": _stats(s.sigma_yaw_deg[:, k]),
                       "sigma_tilt_deg_eq4": _stats(s.sigma_tilt_deg[:, k]),
                       "sigma_r_eq5_deg": _stats(s.sigma_r_eq5_deg[:, k]), "crlb_deg": _stats(s.crlb_deg[:, k])}
                      for k, b in enumerate(s.baselines)],
        "notes": list(s.notes),
    }
