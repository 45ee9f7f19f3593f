"""The `quality` block of an attitude job's summary.json: a verdict a person reads in ten seconds.

Items (each `{"label", "value", "unit", "text", "verdict", "threshold"}`, verdict pass / check / fail / info):
fix rate [%], time to first fix per baseline [s], per-axis bias / std / max against the reference [deg] with the
product's own predicted 1-sigma beside them, wrong fixes, residual RMS per signal [mm], satellites used.

Wrong fixes and the epochs merely over 1 deg: gnssatt.attitude.wrong_fix (the one definition, also behind
summary.json's `reference.wrong_fix_epochs`).

Implements: the error of an estimate against the reference as in gnssatt.attitude.statistics (3-2-1 Euler angles
in the orbital / NED frame, CONVENTIONS.md "Euler angles"); sigma = the filter's formal 1-sigma per epoch.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssatt.attitude.wrong_fix import (DEFINITIONS, WRONG_FIX_MIN_DEG, WRONG_FIX_SIGMAS, classify_fixed_errors,
                                        over_1deg_label)

__all__ = ["ReferenceSeries", "reference_series", "quality_block", "THRESHOLDS", "WRONG_FIX_SIGMAS",
           "WRONG_FIX_MIN_DEG"]

AXES = ("yaw", "pitch", "roll")
#: listed epochs per list (the counts are always complete)
MAX_LISTED = 50
#: verdict thresholds: (pass when better than, check when better than; else fail), with the direction
THRESHOLDS = {
    "fix_rate_pct": (95.0, 80.0, "higher"),          # share of attitude epochs with every baseline fixed
    "ttff_s": (60.0, 300.0, "lower"),                 # time from first data to first fix of a baseline
    "std_over_sigma": (2.0, 3.0, "lower"),            # empirical std / predicted sigma (honest sigmas ~ 1)
    "bias_over_sigma": (2.0, 5.0, "lower"),           # |bias| / predicted sigma
    "wrong_fix_pct": (0.0, 0.1, "lower"),             # wrong-fix epochs per fixed epoch compared [%]
    "phase_rms_mm": (10.0, 20.0, "lower"),            # used phase residuals, per signal
    "median_sats": (6.0, 4.0, "higher"),              # satellites used per attitude epoch, median
}
_RANK = {"pass": 0, "info": 0, "check": 1, "fail": 2}


class ReferenceSeries(NamedTuple):
    """The reference at the attitude epochs: Euler angles [deg] (n, 3), estimate minus reference [deg] (n, 3,
    yaw and roll wrapped to +-180), valid (n,) where the reference brackets the epoch."""
    euler_ref_deg: np.ndarray
    error_deg: np.ndarray
    valid: np.ndarray


def reference_series(sol) -> ReferenceSeries | None:
    """Reference Euler angles and errors at the attitude epochs of `sol`, or None without a reference; the same
    arithmetic as statistics.summarize (interpolated reference, orbital frame of the solution)."""
    from gnssatt.attitude.statistics import interpolate_reference
    from gnssatt.gnss import rotations as rot
    from gnssatt.gnss.frames import R_gcrf_from_ecef

    ref = sol.inputs.reference
    if ref is None or sol.att_epochs is None or sol.att_epochs.size == 0:
        return None
    t_att = sol.pobs.time[sol.att_epochs]
    q_ref, valid = interpolate_reference(ref, t_att)
    R_b_f = rot.quat_to_dcm(q_ref)
    if str(ref.frame[0]) == "GCRF":
        R_b_f = R_b_f @ R_gcrf_from_ecef(t_att)
    # the orbital (or NED) frame of each epoch from the solution's own row: R_ref_from_ecef = R_b_ref^T R_b_ecef
    R_b_ref = rot.euler321_to_dcm(sol.euler_deg[:, 0], sol.euler_deg[:, 1], sol.euler_deg[:, 2])
    R_ref_ecef = np.swapaxes(R_b_ref, -1, -2) @ rot.quat_to_dcm(sol.q_body_from_ecef)
    y, p, r = rot.dcm_to_euler321(R_b_f @ np.swapaxes(R_ref_ecef, -1, -2))
    err = sol.euler_deg - np.stack([y, p, r], 1)
    err = (err + 180.0) % 360.0 - 180.0
    err[~valid] = np.nan
    euler_ref = np.stack([y, p, r], 1)
    euler_ref[~valid] = np.nan
    return ReferenceSeries(euler_ref, err, valid)


def _verdict(value: float | None, key: str) -> tuple[str, str]:
    good, ok, direction = THRESHOLDS[key]
    if value is None or not np.isfinite(value):
        return "fail", _threshold_text(key)
    if direction == "higher":
        v = "pass" if value >= good else "check" if value >= ok else "fail"
    else:
        v = "pass" if value <= good else "check" if value <= ok else "fail"
    return v, _threshold_text(key)


def _threshold_text(key: str) -> str:
    good, ok, direction = THRESHOLDS[key]
    op, op2 = ("≥", "≥") if direction == "higher" else ("≤", "≤")
    return f"pass {op} {good:g}, check {op2} {ok:g}, else fail"


def _item(label: str, value, unit: str, text: str, verdict: str, threshold: str, **extra) -> dict:
    return {"label": label, "value": value, "unit": unit, "text": text, "verdict": verdict,
            "threshold": threshold, **extra}


def _fmt_time(sol, epoch_rows: np.ndarray) -> list[str]:
    if epoch_rows.size == 0:
        return []
    iso = sol.pobs.time[sol.att_epochs[epoch_rows]].iso(3)
    return list(iso) if isinstance(iso, list) else [iso]


def _reference_items(sol, ref: ReferenceSeries) -> tuple[list[dict], dict]:
    """Per-axis accuracy items and the wrong-fix / over-1-deg lists against the reference."""
    fx = sol.att_fixed & ref.valid
    err, sig = ref.error_deg[fx], sol.sigma_euler_deg[fx]
    items: list[dict] = []
    for i, ax in enumerate(AXES):
        if err.shape[0] == 0:
            break
        e = err[:, i]
        bias, std, mx = float(np.mean(e)), float(np.std(e)), float(np.max(np.abs(e)))
        pred = float(np.sqrt(np.nanmean(sig[:, i] ** 2)))
        ratio = std / pred if pred > 0 else float("inf")
        v1, t1 = _verdict(ratio, "std_over_sigma")
        v2, t2 = _verdict(abs(bias) / pred if pred > 0 else float("inf"), "bias_over_sigma")
        verdict = max(v1, v2, key=_RANK.get)
        items.append(_item(f"{ax} vs reference", {"bias_deg": bias, "std_deg": std, "max_abs_deg": mx,
                                                  "predicted_sigma_deg": pred, "std_over_sigma": ratio},
                           "deg", f"bias {bias:+.3f}°, std {std:.3f}°, max {mx:.3f}° (predicted σ {pred:.3f}°)",
                           verdict, f"std/σ: {t1}; |bias|/σ: {t2}", key=f"{ax}_vs_reference",
                           epochs=int(fx.sum())))
    rows = np.flatnonzero(fx)
    cls = classify_fixed_errors(err, sig)
    wrong, over = cls.wrong, cls.over_1deg
    pct = 100.0 * wrong.sum() / max(fx.sum(), 1)
    v, t = _verdict(pct, "wrong_fix_pct")
    times_w = _fmt_time(sol, rows[wrong][:MAX_LISTED])
    times_o = _fmt_time(sol, rows[over][:MAX_LISTED])

    def listing(mask, times, label_of):
        out = []
        for k, r in enumerate(np.flatnonzero(mask)[:MAX_LISTED]):
            ax = int(cls.worst_axis[r])
            out.append({"time_gps": times[k], "axis": AXES[ax], "error_deg": float(err[r, ax]),
                        "sigma_deg": float(sig[r, ax]), "label": label_of(r, ax)})
        return out

    lists = {
        "wrong_fixes": listing(wrong, times_w, lambda r, ax: "wrong fix"),
        "over_1deg": listing(over, times_o, lambda r, ax: over_1deg_label(err[r, ax], sig[r, ax])),
    }
    items.append(_item("wrong fixes", int(wrong.sum()), "epochs",
                       f"{int(wrong.sum())} of {int(fx.sum())} fixed epochs ({pct:.2f} %) beyond "
                       f"{WRONG_FIX_SIGMAS:g}σ and {WRONG_FIX_MIN_DEG:g}°; {int(over.sum())} more over "
                       f"{WRONG_FIX_MIN_DEG:g}° within {WRONG_FIX_SIGMAS:g}σ (noise)", v, f"wrong fixes [%]: {t}",
                       key="wrong_fixes", over_1deg=int(over.sum()), percent=pct))
    return items, lists


def _residual_items(sol) -> list[dict]:
    res = sol.fr.residuals
    used = (res["reason"] == 0) & np.isfinite(res["residual_m"])
    items = []
    for s, sig in enumerate(sol.pobs.signals):
        for kind, name in ((1, "phase"), (0, "code")):
            m = used & (res["sig"] == s) & (res["kind"] == kind)
            if not m.any():
                continue
            rms_mm = float(np.sqrt(np.mean(res["residual_m"][m] ** 2)) * 1e3)
            if kind == 1:
                v, t = _verdict(rms_mm, "phase_rms_mm")
            else:
                v, t = "info", "shown for information"
            digits = 1 if kind == 1 else 0
            items.append(_item(f"{name} residual RMS {sig}", rms_mm, "mm",
                               f"{rms_mm:.{digits}f} mm over {int(m.sum())} used residuals", v, t,
                               key=f"{name}_rms_{sig}"))
    return items


def quality_block(sol, ref: ReferenceSeries | None = None) -> dict:
    """The `quality` block of summary.json (see module docstring): overall verdict (the worst item's), items in
    reading order, and the wrong-fix / over-1-deg epoch lists."""
    items: list[dict] = []
    lists: dict = {"wrong_fixes": [], "over_1deg": []}
    if sol.att_epochs is not None and sol.att_epochs.size:
        n, nf = int(sol.att_epochs.size), int(sol.att_fixed.sum())
        pct = 100.0 * nf / n
        v, t = _verdict(pct, "fix_rate_pct")
        items.append(_item("fix rate", pct, "%", f"{pct:.1f} % ({nf} of {n} attitude epochs, all baselines fixed)",
                           v, t, key="fix_rate"))
    for b in sol.summary.get("baselines", []):
        ttff = b.get("time_to_first_fix_s")
        v, t = _verdict(ttff, "ttff_s")
        items.append(_item(f"time to first fix {b['baseline']}", ttff, "s",
                           "never fixed" if ttff is None else f"{ttff:.0f} s", v, t, key=f"ttff_{b['baseline']}"))
    if ref is not None:
        ref_items, lists = _reference_items(sol, ref)
        items += ref_items
    elif sol.att_epochs is not None and sol.att_fixed.any():
        for i, ax in enumerate(AXES):
            pred = float(np.sqrt(np.nanmean(sol.sigma_euler_deg[sol.att_fixed, i] ** 2)))
            items.append(_item(f"{ax} predicted σ", pred, "deg", f"{pred:.3f}° (no reference in the set)", "info",
                               "no reference: accuracy not checked", key=f"{ax}_predicted_sigma"))
    items += _residual_items(sol)
    if sol.att_epochs is not None and sol.att_epochs.size:
        ns = np.asarray(sol.att_n_sats, float)
        med = float(np.median(ns))
        v, t = _verdict(med, "median_sats")
        items.append(_item("satellites used", med, "satellites",
                           f"median {med:.0f}, min {ns.min():.0f}, max {ns.max():.0f} per attitude epoch", v, t,
                           key="satellites_used", min=int(ns.min()), max=int(ns.max())))
    overall = max((it["verdict"] for it in items), key=_RANK.get, default="fail")
    return {"verdict": overall, "items": items, **lists,
            "definitions": dict(DEFINITIONS)}
