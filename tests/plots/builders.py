"""Synthetic products in the CONVENTIONS.md / docs/pages.md layouts, with known answers, for the plot tests."""
from __future__ import annotations

import csv
import io

import numpy as np

from gnssatt.gnss.rotations import dcm_to_quat, euler321_to_dcm, quat_to_dcm

T0 = np.datetime64("2018-06-06T12:20:00.000")
GPS_WEEK = 2004
SOW0 = 3 * 86400 + 12 * 3600 + 20 * 60  # Wednesday 2018-06-06 12:20:00 GPST


def _csv(header: list[str], rows: list[list]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


def times(n: int, step_s: float = 1.0) -> np.ndarray:
    return T0 + (np.arange(n) * step_s * 1000).astype("timedelta64[ms]")


def iso(t: np.ndarray) -> list[str]:
    return list(np.datetime_as_string(t, unit="ms"))


def random_rotations(n: int, rng) -> np.ndarray:
    """n random R_gcrf_from_orb (orthonormal, det +1)."""
    q = rng.normal(size=(n, 4))
    q[:, 0] = np.abs(q[:, 0])
    return np.swapaxes(quat_to_dcm(q / np.linalg.norm(q, axis=1, keepdims=True)), -1, -2)


def attitude_case(n: int = 120, seed: int = 0, error_deg=(0.10, -0.20, 0.05), float_epochs=(), skip=()):
    """(attitude_csv, reference_quat_csv, reference_euler_csv, truth dict).

    True Euler angles slew smoothly; the estimate is truth + `error_deg` (yaw, pitch, roll) exactly; the
    orbital frame is an arbitrary rotation per epoch (the plots must not assume one)."""
    rng = np.random.default_rng(seed)
    t = times(n)
    k = np.arange(n)
    yaw_true = -170.0 + 0.5 * k            # crosses +-180 within the span
    yaw_true = (yaw_true + 180.0) % 360.0 - 180.0
    pitch_true = 20.0 * np.sin(k / 30.0)
    roll_true = 10.0 + 0.1 * k
    est = [yaw_true + error_deg[0], pitch_true + error_deg[1], roll_true + error_deg[2]]
    est[0] = (est[0] + 180.0) % 360.0 - 180.0
    R_gcrf_from_orb = random_rotations(n, rng)
    R_ecef_from_gcrf = random_rotations(n, rng)
    R_body_from_orb_est = euler321_to_dcm(*est)
    R_body_from_gcrf_est = R_body_from_orb_est @ np.swapaxes(R_gcrf_from_orb, -1, -2)
    R_body_from_ecef_est = R_body_from_gcrf_est @ np.swapaxes(R_ecef_from_gcrf, -1, -2)
    qi, qe = dcm_to_quat(R_body_from_gcrf_est), dcm_to_quat(R_body_from_ecef_est)
    R_body_from_gcrf_true = euler321_to_dcm(yaw_true, pitch_true, roll_true) @ np.swapaxes(R_gcrf_from_orb, -1, -2)
    q_ref = dcm_to_quat(R_body_from_gcrf_true)
    fixed = np.ones(n, int)
    fixed[list(float_epochs)] = 0
    n_sats = 8 + (k // 40)
    header = ["time_gps", "gps_week", "gps_sow", "qe_w", "qe_x", "qe_y", "qe_z", "qi_w", "qi_x", "qi_y", "qi_z",
              "yaw_deg", "pitch_deg", "roll_deg", "sigma_yaw_deg", "sigma_pitch_deg", "sigma_roll_deg", "fixed",
              "n_sats"]
    keep = [i for i in range(n) if i not in set(skip)]
    rows = [[iso(t)[i], GPS_WEEK, f"{SOW0 + i:.3f}", *[f"{v:.12f}" for v in qe[i]], *[f"{v:.12f}" for v in qi[i]],
             f"{est[0][i]:.9f}", f"{est[1][i]:.9f}", f"{est[2][i]:.9f}", "0.08", "0.3", "0.25", fixed[i], n_sats[i]]
            for i in keep]
    attitude = _csv(header, rows)
    ref_q = _csv(["time_gps", "frame", "qw", "qx", "qy", "qz", "sigma_arcsec"],
                 [[iso(t)[i], "GCRF", *[f"{v:.12f}" for v in q_ref[i]], 3.0] for i in range(n)])
    ref_e = _csv(["time_gps", "yaw_deg", "pitch_deg", "roll_deg"],
                 [[iso(t)[i], f"{yaw_true[i]:.9f}", f"{pitch_true[i]:.9f}", f"{roll_true[i]:.9f}"] for i in range(n)])
    return attitude, ref_q, ref_e, {"time": t[keep], "yaw": yaw_true[keep], "pitch": pitch_true[keep],
                                    "roll": roll_true[keep], "fixed": fixed[keep], "n_sats": n_sats[keep]}


SATS = ("G01", "G05", "G12", "G17", "G21", "G30")


def sat_directions(n: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Antenna-frame azimuth/elevation tracks [deg] of SATS over n epochs (two go below the antenna plane)."""
    k = np.arange(n)
    out = {}
    for j, s in enumerate(SATS):
        az = (60.0 * j + 0.2 * k) % 360.0
        el = (75.0 - 16.0 * j) - 0.05 * k
        out[s] = (az, el)
    return out


def residuals_case(n: int = 60, baselines=("GPS-2>GPS-0", "GPS-2>GPS-1"), signals=("L1C", "L2W"), seed: int = 1):
    """(residuals_csv, truth): rows per epoch, baseline, satellite, signal; satellites with el < 0 rejected."""
    rng = np.random.default_rng(seed)
    t = times(n)
    dirs = sat_directions(n)
    header = ["time_gps", "gps_week", "gps_sow", "baseline", "satellite", "signal", "code_residual_m",
              "phase_residual_mm", "azimuth_deg", "elevation_deg", "cn0_dbhz", "used", "reason"]
    rows, truth = [], {"phase": {}, "code": {}, "cn0": {}}
    for b in baselines:
        for s in signals:
            truth["phase"][(b, s)] = []
            truth["code"][(b, s)] = []
    for i in range(n):
        for b in baselines:
            for s in SATS:
                az, el = dirs[s][0][i], dirs[s][1][i]
                cn0 = 30.0 + 0.25 * max(el, 0.0)
                for sig in signals:
                    ph = rng.normal(0, 3.0 if sig.startswith("L1") else 4.0)
                    co = rng.normal(0, 0.3)
                    used = el > 0
                    rows.append([iso(t)[i], GPS_WEEK, f"{SOW0 + i:.3f}", b, s, sig, f"{co:.4f}", f"{ph:.3f}",
                                 f"{az:.3f}", f"{el:.3f}", f"{cn0 - (4 if sig.startswith('L2') else 0):.1f}",
                                 int(used), "" if used else "below antenna horizon"])
                    if used:
                        truth["phase"][(b, sig)].append(float(f"{ph:.3f}"))
                        truth["code"][(b, sig)].append(float(f"{co:.4f}"))
    return _csv(header, rows), truth


def baselines_case(n: int = 50, names=("GPS-2>GPS-0", "GPS-2>GPS-1")):
    t = times(n)
    header = ["time_gps", "gps_week", "gps_sow", "baseline", "x_ecef_m", "y_ecef_m", "z_ecef_m", "length_m",
              "azimuth_deg", "elevation_deg", "sigma_azimuth_deg", "sigma_elevation_deg", "sigma_length_m",
              "fixed", "n_sats"]
    rows = []
    for i in range(n):
        for j, b in enumerate(names):
            fixed = int(i >= 5 * (j + 1))
            rows.append([iso(t)[i], GPS_WEEK, f"{SOW0 + i:.3f}", b, "0.5", "0.5", "0.7", "1.05", "45.0", "1.0",
                         "0.1", "0.2", "0.003", fixed, 7 + j])
    return _csv(header, rows)


def events_case():
    t = times(60)
    return _csv(["time_gps", "gps_week", "gps_sow", "event", "baseline", "satellite", "signal", "detail"],
                [[iso(t)[5], GPS_WEEK, SOW0 + 5, "fix", "GPS-2>GPS-0", "", "", "ratio 5.1"],
                 [iso(t)[20], GPS_WEEK, SOW0 + 20, "cycle_slip", "GPS-2>GPS-0", "G05", "L1C", ""],
                 [iso(t)[30], GPS_WEEK, SOW0 + 30, "cycle_slip", "GPS-2>GPS-1", "G12", "L2W", ""],
                 [iso(t)[40], GPS_WEEK, SOW0 + 40, "clock_jump", "", "", "", "1 ms"]])


def pcv_map(pair=("GPS-2", "GPS-0"), frequency="L1", amplitude_mm=20.0, empty_below_deg=10.0):
    az = np.arange(0.0, 360.0, 10.0) + 5.0
    el = np.arange(0.0, 90.0, 5.0) + 2.5
    values = amplitude_mm * np.cos(np.radians(el))[:, None] * np.sin(np.radians(az))[None, :]
    count = np.tile((10 + np.arange(len(el)) * 3)[:, None], (1, len(az)))
    vals = [[None if el[i] < empty_below_deg else round(float(values[i, j]), 3) for j in range(len(az))]
            for i in range(len(el))]
    cnt = [[int(count[i, j]) if el[i] >= empty_below_deg else 1 for j in range(len(az))] for i in range(len(el))]
    return {"platform": "CASSIOPE-like", "pair": list(pair), "frequency": frequency, "azimuth_deg": az.tolist(),
            "elevation_deg": el.tolist(), "values_mm": vals, "count": cnt,
            "sigma_mm": [[None if v is None else 1.0 for v in row] for row in vals]}


TABLE5_FIRST_ROWS = [  # seed 000 Table 5, first three test cases: yaw pitch roll, L1/L2 0-2 1-2, L1 0-2 1-2, L2 0-2 1-2
    (27.1, 42.1, 7.5, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0),
    (-59.3, -37.7, -26.3, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
    (74.4, -50.3, 35.8, 0.0, 0.0, 46.0, 0.0, 16.0, 0.0),
]


def ttff_runs(cases=TABLE5_FIRST_ROWS, never=()):
    """Long-format runs of the seed 000 Table 5 cases; (case index, config, baseline) in `never` get no fix."""
    rows = []
    for i, c in enumerate(cases):
        for k, (cfg, b) in enumerate([(cfg, b) for cfg in ("L1L2", "L1", "L2") for b in ("GPS-0/GPS-2", "GPS-1/GPS-2")]):
            ttff = "" if (i, cfg, b) in never else c[3 + k]
            rows.append([f"case{i + 1:02d}", c[0], c[1], c[2], cfg, b, ttff])
    return _csv(["set", "yaw_deg", "pitch_deg", "roll_deg", "configuration", "baseline", "ttff_s"], rows)
