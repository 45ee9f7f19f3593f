"""Scoring a fusion run against the simulator's truth (gnssatt.sim.gyro_scenario): attitude errors of the fused,
GPS-only and gyro-only solutions per body axis, error / own sigma, GPS FDI rates, integer failures and the gyro
fault detection delays. Used by tests/gyro and bench/bench_gyro_fusion.py, never by the job.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from gnssatt.gnss import rotations as rot
from gnssatt.gnss.frames import R_ecef_from_gcrf
from gnssatt.gnss.time import GpsTime
from gnssatt.gyro.ekf import propagate_attitude

__all__ = ["attitude_scores", "fdi_scores", "integer_failures", "gyro_delays", "ratio_sampling_sd"]


def _truth_q(set_dir: Path):
    from gnssatt.gnss.io.reference_attitude import read_reference_attitude

    ref = read_reference_attitude((Path(set_dir) / "truth" / "attitude_gyro_rate.csv").read_bytes())
    return ref.time, ref.q_body_from_frame


def _err(q_est, q_true):
    """Body-axis error angles (n, 3) rad of q_est against q_true (rotation vector of q_est (x) q_true^-1)."""
    return rot.quat_to_rotvec(rot.quat_multiply(q_est, rot.quat_conjugate(q_true)))


def _stats(e_rad, sig_rad=None):
    out = {"rms_deg": np.degrees(np.sqrt(np.mean(e_rad ** 2, axis=0))).round(4).tolist(),
           "p95_abs_deg": np.degrees(np.percentile(np.abs(e_rad), 95, axis=0)).round(4).tolist(),
           "n": int(len(e_rad))}
    if sig_rad is not None:
        out["error_over_sigma_rms"] = np.sqrt(np.mean((e_rad / sig_rad) ** 2, axis=0)).round(3).tolist()
    return out


def attitude_scores(set_dir: Path, run, gps, until_s: float = float("inf")) -> dict:
    """Per body axis (x ~ roll, y ~ pitch, z ~ yaw for Earth pointing): rms and 95 % errors of fused (gyro rate),
    GPS-only (snapshot epochs) and gyro-only (raw gyro integrated from the first fused attitude) solutions, over
    the samples up to until_s seconds after the first truth sample."""
    t_true, q_true = _truth_q(set_dir)
    keep_t = (t_true - t_true[0]) <= until_s
    q_true = np.where(keep_t[:, None], q_true, np.nan)
    key = np.round((t_true - t_true[0]) * 1000).astype(np.int64)
    pos = {int(v): i for i, v in enumerate(key)}
    kg = np.round((run.gyro_time - t_true[0]) * 1000).astype(np.int64)
    ig = np.array([pos.get(int(v), -1) for v in kg])
    ig = np.where(ig >= 0, ig, -1)
    m = run.has & (ig >= 0)
    m[m] &= np.isfinite(q_true[ig[m], 0])
    e_f = _err(run.q_body_from_gcrf[m], q_true[ig[m]])
    s_f = np.sqrt(np.diagonal(run.P_att[m], axis1=1, axis2=2))
    out = {"fused": _stats(e_f, s_f)}
    ke = np.round((gps.time - t_true[0]) * 1000).astype(np.int64)
    ie = np.array([pos.get(int(v), -1) for v in ke])
    g = np.isfinite(run.gps_q_body_from_ecef[:, 0]) & (ie >= 0)
    g[g] &= np.isfinite(q_true[ie[g], 0])
    q_gi = rot.dcm_to_quat(rot.quat_to_dcm(run.gps_q_body_from_ecef[g]) @ R_ecef_from_gcrf(gps.time[g]))
    e_g = _err(q_gi, q_true[ie[g]])
    out["gps"] = _stats(e_g, np.sqrt(np.diagonal(run.gps_P[g], axis1=1, axis2=2)))
    i0 = int(np.flatnonzero(m)[0])
    rates = np.ascontiguousarray(np.asarray(run.gyro_rates), dtype=np.float64)
    dts = np.asarray(run.gyro_dts)
    q = run.q_body_from_gcrf[i0].copy()
    q_go = np.empty((len(rates) - i0 - 1, 4))
    for n, i in enumerate(range(i0 + 1, len(rates))):        # raw gyro alone, no drift estimate
        q = propagate_attitude(q, np.zeros(3), rates[i:i + 1], dts[i:i + 1])
        q_go[n] = q
    jj = ig[i0 + 1:]
    ok = jj >= 0
    ok[ok] &= np.isfinite(q_true[jj[ok], 0])
    out["gyro"] = _stats(_err(q_go[ok], q_true[jj[ok]]))
    out["fused_errors_rad"] = e_f
    out["fused_sigma_rad"] = s_f
    out["fused_time_s"] = (run.gyro_time - t_true[0])[m]
    return out


def ratio_sampling_sd(z: np.ndarray, t_s: np.ndarray, step_s: float = 1.0) -> tuple[float, float]:
    """(rms of z, its 1-sigma sampling uncertainty) for a normalised error z(t) correlated in time.

    For a stationary Gaussian z of unit variance and autocorrelation rho, var(z^2) = 2 and cov(z^2(t), z^2(t +
    u)) = 2 rho(u)^2, so the rms over a span T has sd ~ sqrt(integral_0^inf rho(u)^2 du / T). rho is estimated
    from the series resampled to step_s and integrated up to its first zero (at most T / 5)."""
    t = np.arange(t_s[0], t_s[-1], step_s)
    x = np.interp(t, t_s, z)
    rms = float(np.sqrt(np.mean(z ** 2)))
    y = x - x.mean()
    n = len(y)
    f = np.fft.rfft(y, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n] / (y @ y)
    acf = acf / (1.0 - np.arange(n) / n)                 # unbiased lag weights
    stop = min(int(np.argmax(acf <= 0)) if (acf <= 0).any() else n, n // 5)
    integral = float(np.sum(acf[:stop] ** 2) * step_s - 0.5 * step_s)   # trapezoid start at rho(0) = 1
    return rms, rms * float(np.sqrt(max(integral, step_s) / (n * step_s)))


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fdi_scores(set_dir: Path, run, gps) -> dict:
    """GPS FDI against truth/gps_faults.csv, counting faults on satellites the run used at that epoch:
    missed = fault epochs not detected; isolated right = detections naming the faulty satellite; false alarms =
    detections at fault-free epochs (per fault-free epoch, and as a share of all detections)."""
    t_ep = gps.time.s.astype(float) + gps.time.frac
    by_t = {round(float(v), 3): k for k, v in enumerate(t_ep)}
    faults = {}
    for row in _read_csv(Path(set_dir) / "truth" / "gps_faults.csv"):
        k = by_t.get(round(float(row["start_gps_s"]), 3))
        if k is not None:
            faults[k] = row["satellite"]
    used = {k: {v[0], *v[1]} for k, v in run.integers.items()}
    det = {e[0]: e for e in run.gps_events}
    fault_eps = [k for k, s in faults.items() if s in used.get(k, set())]
    n_missed = sum(1 for k in fault_eps if k not in det)
    hits = [k for k in fault_eps if k in det]
    right = sum(1 for k in hits if det[k][1] == faults[k])
    clean = [k for k in used if k not in faults]
    false = [k for k in clean if k in det]
    return {"faults_injected": len(faults), "faults_on_used_satellites": len(fault_eps), "missed": n_missed,
            "missed_rate": n_missed / max(len(fault_eps), 1), "detected": len(hits),
            "isolated_right": right, "isolated_right_rate": right / max(len(hits), 1),
            "clean_epochs": len(clean), "false_alarms": len(false),
            "false_alarm_rate_per_clean_epoch": len(false) / max(len(clean), 1),
            "false_share_of_detections": len(false) / max(len(false) + len(hits), 1),
            "epochs_without_gps": int(np.sum(~np.isfinite(run.gps_q_body_from_ecef[:, 0])))}


def integer_failures(set_dir: Path, run, gps) -> dict:
    """Resolved DD integers against truth/arcs.csv: counts of epochs with any wrong integer."""
    rows = _read_csv(Path(set_dir) / "truth" / "arcs.csv")
    arcs: dict = {}
    for r in rows:
        arcs.setdefault((r["antenna"], r["sat"]), []).append(
            (float(GpsTime.from_iso(r["start_time_gps"]).seconds()), float(GpsTime.from_iso(r["end_time_gps"]).seconds()),
             int(r["ambiguity_cyc"])))
    t_ep = gps.time.seconds()

    def amb(ant, sat, t):
        for a, b, n in arcs.get((ant, sat), []):
            if a - 1e-3 <= t <= b + 1e-3:
                return n
        return None

    wrong, checked = 0, 0
    for k, (ref, others, N) in run.integers.items():
        t = float(t_ep[k])
        bad = False
        for p, sat in enumerate(others):
            for i, ant in enumerate(gps.antennas[1:]):
                vals = [amb(ant, sat, t), amb(gps.antennas[0], sat, t), amb(ant, ref, t), amb(gps.antennas[0], ref, t)]
                if None in vals:
                    continue
                true_dd = vals[0] - vals[1] - vals[2] + vals[3]
                bad |= int(N[p, i]) != true_dd
        checked += 1
        wrong += bad
    return {"epochs_checked": checked, "epochs_with_wrong_integer": wrong, "rate": wrong / max(checked, 1)}


def gyro_delays(set_dir: Path, run, gps) -> dict:
    """Detection delay per propagator (s after the injected fault's start) and the false gyro events."""
    rows = _read_csv(Path(set_dir) / "truth" / "gyro_faults.csv")
    t_ep = gps.time - gps.time[0]
    t0_gyro = float(run.gyro_time[0] - gps.time[0]) - float(np.asarray(run.gyro_dts)[0])
    out = {"faults": [], "false_events": 0}
    for r in rows:
        start = float(r["start_s"]) + t0_gyro
        true_events = [e for e in run.gyro_events if t_ep[e.end] >= start]
        delays = {}
        for e in true_events:
            for j, k in e.first_by_propagator.items():
                delays.setdefault(j, float(t_ep[k] - start))
        out["faults"].append({"axis": r["axis"], "start_s": start, "delay_s_by_propagator": delays,
                              "axis_isolated": ["xyz"[e.axis] for e in true_events][:1]})
    starts = [float(r["start_s"]) + t0_gyro for r in rows]
    out["false_events"] = sum(1 for e in run.gyro_events if not starts or t_ep[e.end] < min(starts))
    return out
