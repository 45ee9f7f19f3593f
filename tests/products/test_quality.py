"""Issue 24 done-when: the quality block's figures equal those computed here, independently, from attitude.csv and
the set's reference_attitude.csv (scipy's rotations, not the library's; not read from summary.json)."""
from __future__ import annotations

import csv
import io

import numpy as np
from scipy.spatial.transform import Rotation

AXES = ("yaw", "pitch", "roll")


def _rows(text: str) -> list[dict]:
    return list(csv.DictReader(io.StringIO(text)))


def _passive(q_wxyz: np.ndarray) -> np.ndarray:
    """R_body_from_frame of a passive scalar-first quaternion (CONVENTIONS.md): the transpose of scipy's active
    matrix of the same quaternion."""
    return Rotation.from_quat(q_wxyz[:, [1, 2, 3, 0]]).as_matrix().transpose(0, 2, 1)


def _euler321(R_body_from_ref: np.ndarray) -> np.ndarray:
    """(yaw, pitch, roll) deg of R = Rx(roll) Ry(pitch) Rz(yaw) (frame rotations): R^T is the active intrinsic
    Z-Y-X rotation by (yaw, pitch, roll)."""
    return Rotation.from_matrix(R_body_from_ref.transpose(0, 2, 1)).as_euler("ZYX", degrees=True)


def independent_errors(attitude_csv: str, reference_csv: str):
    """(errors deg (n, 3), sigma deg (n, 3), fixed (n,), n_sats (n,)) at the attitude rows that the reference has
    (same time stamps: both at 1 Hz here). The orbital frame comes from the estimate's own row
    (R_orb_from_gcrf = R_b_orb^T R_b_gcrf), which holds because the orbital frame depends on the orbit only."""
    att, ref = _rows(attitude_csv), {r["time_gps"]: r for r in _rows(reference_csv)}
    keep = [r for r in att if r["time_gps"] in ref]
    assert len(keep) > 0.9 * len(att)
    assert {ref[r["time_gps"]]["frame"] for r in keep} == {"GCRF"}
    qi = np.array([[float(r[f"qi_{c}"]) for c in "wxyz"] for r in keep])
    ypr = np.array([[float(r[f"{a}_deg"]) for a in AXES] for r in keep])
    qr = np.array([[float(ref[r["time_gps"]][f"q{c}"]) for c in "wxyz"] for r in keep])
    R_b_orb = Rotation.from_euler("ZYX", ypr, degrees=True).as_matrix().transpose(0, 2, 1)
    R_orb_gcrf = R_b_orb.transpose(0, 2, 1) @ _passive(qi)
    ref_ypr = _euler321(_passive(qr) @ R_orb_gcrf.transpose(0, 2, 1))
    err = ypr - ref_ypr
    err[:, [0, 2]] = (err[:, [0, 2]] + 180.0) % 360.0 - 180.0
    sig = np.array([[float(r[f"sigma_{a}_deg"]) for a in AXES] for r in keep])
    fixed = np.array([r["fixed"] == "1" for r in keep])
    return err, sig, fixed, np.array([int(r["n_sats"]) for r in keep]), [r["time_gps"] for r in keep]


def test_quality_figures_equal_an_independent_computation(short_pass):
    prods = short_pass["products"]
    q = prods["summary.json"]["quality"]
    items = {it["key"]: it for it in q["items"]}
    err, sig, fixed, n_sats, times = independent_errors(prods["attitude.csv"],
                                                         (short_pass["dir"] / "reference_attitude.csv").read_text())
    # the conventions are right: the steady state agrees with the reference to well under a degree
    assert np.median(np.abs(err[fixed]), axis=0).max() < 0.5
    # fix rate in %: every attitude row of attitude.csv
    att = _rows(prods["attitude.csv"])
    fix_pct = 100.0 * sum(r["fixed"] == "1" for r in att) / len(att)
    assert abs(items["fix_rate"]["value"] - fix_pct) < 1e-9 and items["fix_rate"]["unit"] == "%"
    # per axis, fixed epochs: the CSV's 6-decimal rounding of angles and quaternions (12 decimals) bounds the
    # difference to ~1e-5 deg
    for i, ax in enumerate(AXES):
        v = items[f"{ax}_vs_reference"]["value"]
        e = err[fixed, i]
        assert abs(v["bias_deg"] - e.mean()) < 2e-5, ax
        assert abs(v["std_deg"] - e.std()) < 2e-5, ax
        assert abs(v["max_abs_deg"] - np.abs(e).max()) < 2e-5, ax
        assert abs(v["predicted_sigma_deg"] - np.sqrt(np.mean(sig[fixed, i] ** 2))) < 2e-6, ax
        assert items[f"{ax}_vs_reference"]["verdict"] in ("pass", "check", "fail")
    # wrong fixes (beyond 6 sigma and 1 deg on an axis) and the epochs merely over 1 deg
    big = np.abs(err) > 1.0
    wrong = fixed & (big & (np.abs(err) > 6 * sig)).any(axis=1)
    over = fixed & big.any(axis=1) & ~wrong
    assert items["wrong_fixes"]["value"] == int(wrong.sum())
    assert items["wrong_fixes"]["over_1deg"] == int(over.sum())
    assert [e["time_gps"] for e in q["over_1deg"]] == [t for t, o in zip(times, over) if o][:50]
    for e in q["over_1deg"]:
        assert e["label"] == ("noise" if abs(e["error_deg"]) <= 6 * e["sigma_deg"] else "large")
    # satellites used
    assert items["satellites_used"]["value"] == float(np.median([int(r["n_sats"]) for r in att]))
    # the overall verdict is the worst item's
    rank = {"pass": 0, "info": 0, "check": 1, "fail": 2}
    assert rank[q["verdict"]] == max(rank[it["verdict"]] for it in q["items"])


def test_residual_rms_per_signal_from_residuals_csv(short_pass):
    prods = short_pass["products"]
    items = {it["key"]: it for it in prods["summary.json"]["quality"]["items"]}
    rows = [r for r in _rows(prods["residuals.csv"]) if r["used"] == "1" and r["residual_m"]]
    signals = sorted({r["signal"] for r in rows})
    assert signals
    for sig in signals:
        for kind in ("phase", "code"):
            v = np.array([float(r["residual_m"]) for r in rows if r["signal"] == sig and r["observable"] == kind])
            if v.size == 0:
                continue
            item = items[f"{kind}_rms_{sig}"]
            assert item["unit"] == "mm"
            # residual_m is written with 5 decimals (10 um): the RMS agrees to 0.01 mm
            assert abs(item["value"] - 1e3 * np.sqrt(np.mean(v ** 2))) < 0.01, (sig, kind)


def test_ttff_per_baseline_and_thresholds_are_stated(short_pass):
    from gnssatt.attitude.quality import THRESHOLDS

    prods = short_pass["products"]
    q = prods["summary.json"]["quality"]
    ttff = [it for it in q["items"] if it["key"].startswith("ttff_")]
    assert {it["key"] for it in ttff} == {f"ttff_{b}" for b in ("GPS-2>GPS-0", "GPS-2>GPS-1")}
    # first fix of each baseline from events.csv (its first 'fix' event) minus its first data (its first row of
    # residuals.csv: single differences formed)
    from datetime import datetime
    ev = [r for r in _rows(prods["events.csv"]) if r["event"] == "fix"]
    res = _rows(prods["residuals.csv"])
    for it in ttff:
        bl = it["key"][5:]
        t_fix = min(r["time_gps"] for r in ev if r["baseline"] == bl)
        t_data = min(r["time_gps"] for r in res if r["baseline"] == bl)
        dt = (datetime.fromisoformat(t_fix) - datetime.fromisoformat(t_data)).total_seconds()
        assert abs(it["value"] - dt) < 1e-6, bl
        assert it["unit"] == "s" and "pass ≤ 60" in it["threshold"]
    assert THRESHOLDS["ttff_s"][0] == 60.0
    for it in q["items"]:
        assert it["threshold"] and it["unit"] and it["text"]
