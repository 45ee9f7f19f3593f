"""Files of the gyro-fusion job: attitude.csv at the gyro rate (CONVENTIONS.md columns + `source`), gps_attitude.csv
(the snapshot solutions, source gps), bias.csv (gyro drift estimate and sigma), faults.csv (CONVENTIONS.md "Output:
fault events" + detection_delay_s), costs.csv (eq. 2 cost of every processor), gyro_tests.csv (normalised
residuals of the delayed propagators), summary.json and attitude.aem (CCSDS AEM via gnssatt.attitude.products).

Implements: ../shared/CONVENTIONS.md "Output: attitude time series", "Output: fault events (gyro fusion)".
A GPS fault event is a run of consecutive epochs isolating the same satellite (start/end its first/last epoch,
delay 0: the snapshot test has none). A gyro event starts, at the earliest, one delay of its detecting propagator
before its detection (the propagator's window is where the drift can have begun); its delay is that delay.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from gnssatt.attitude.products import aem_kvn
from gnssatt.attitude.solution import euler_and_sigma
from gnssatt.gnss import rotations as rot
from gnssatt.gnss.frames import R_ecef_from_gcrf, R_orbital_from_ecef

__all__ = ["attitude_table", "fusion_products"]

_ATT_HEAD = ("time_gps,gps_week,gps_sow,qe_w,qe_x,qe_y,qe_z,qi_w,qi_x,qi_y,qi_z,yaw_deg,pitch_deg,roll_deg,"
             "sigma_yaw_deg,sigma_pitch_deg,sigma_roll_deg,fixed,n_sats,source")


def _interp_rows(t_s, t_ep_s, x):
    return np.stack([np.interp(t_s, t_ep_s, x[:, i]) for i in range(x.shape[1])], axis=1)


def attitude_table(res) -> dict:
    """Column arrays of attitude.csv (rows at the gyro samples that have an attitude)."""
    run, gps = res.run, res.gps
    m = np.flatnonzero(run.has)
    t = run.gyro_time[m]
    t_s, t_ep = t - gps.time[0], gps.time - gps.time[0]
    q_i = run.q_body_from_gcrf[m]
    R_bi = rot.quat_to_dcm(q_i)
    R_ie = np.swapaxes(R_ecef_from_gcrf(t), -1, -2)
    R_be = R_bi @ R_ie
    r = _interp_rows(t_s, t_ep, gps.r_platform_ecef_m)
    v = _interp_rows(t_s, t_ep, gps.v_platform_ecef_m_s)
    R_ref = R_orbital_from_ecef(r, v)
    yaw, pitch, roll, sy, sp, sr = euler_and_sigma(R_be @ np.swapaxes(R_ref, -1, -2), run.P_att[m])
    k_last = np.clip(np.searchsorted(t_ep, t_s + 1e-6, side="right") - 1, 0, len(t_ep) - 1)
    return {"time": t, "qe": rot.dcm_to_quat(R_be), "qi": rot.quat_normalize(q_i), "euler": np.stack([yaw, pitch, roll], 1),
            "sigma": np.stack([sy, sp, sr], 1), "fixed": run.fused[m].astype(int), "n_sats": run.n_sats[k_last],
            "source": np.where(run.fused[m], "fused", "gyro")}


def _fmt(a, f):
    return [f % x for x in np.asarray(a).tolist()]


def _csv(head: str, cols: list) -> str:
    return head + "\n" + "".join(",".join(r) + "\n" for r in zip(*cols)) if cols and len(cols[0]) else head + "\n"


def _time_cols(t):
    iso = t.iso(3)
    week, sow = t.week_sow()
    return [iso if isinstance(iso, list) else [iso], _fmt(week, "%d"), _fmt(sow, "%.3f")]


def _attitude_csv(tab: dict) -> str:
    cols = _time_cols(tab["time"])
    for q in (tab["qe"], tab["qi"]):
        cols += [_fmt(q[:, i], "%.12f") for i in range(4)]
    cols += [_fmt(tab["euler"][:, i], "%.6f") for i in range(3)] + [_fmt(tab["sigma"][:, i], "%.6f") for i in range(3)]
    cols += [_fmt(tab["fixed"], "%d"), _fmt(tab["n_sats"], "%d"), list(tab["source"])]
    return _csv(_ATT_HEAD, cols)


def _gps_csv(res) -> str:
    run, gps = res.run, res.gps
    k = np.flatnonzero(np.isfinite(run.gps_q_body_from_ecef[:, 0]))
    t = gps.time[k]
    R_be = rot.quat_to_dcm(run.gps_q_body_from_ecef[k])
    R_bi = R_be @ R_ecef_from_gcrf(t)
    R_ref = R_orbital_from_ecef(gps.r_platform_ecef_m[k], gps.v_platform_ecef_m_s[k])
    yaw, pitch, roll, sy, sp, sr = euler_and_sigma(R_be @ np.swapaxes(R_ref, -1, -2), run.gps_P[k])
    cols = _time_cols(t)
    for q in (run.gps_q_body_from_ecef[k], rot.dcm_to_quat(R_bi)):
        cols += [_fmt(q[:, i], "%.12f") for i in range(4)]
    cols += [_fmt(a, "%.6f") for a in (yaw, pitch, roll, sy, sp, sr)]
    cols += [["1"] * len(k), _fmt(run.n_sats[k], "%d"), ["gps"] * len(k)]
    return _csv(_ATT_HEAD, cols)


def _bias_csv(res) -> str:
    run, gps = res.run, res.gps
    k = np.flatnonzero(np.isfinite(run.bias[:, 0]))
    s = np.sqrt(np.diagonal(run.bias_P[k], axis1=1, axis2=2))
    cols = _time_cols(gps.time[k]) + [_fmt(run.bias[k, i], "%.9e") for i in range(3)] + \
        [_fmt(s[:, i], "%.9e") for i in range(3)]
    return _csv("time_gps,gps_week,gps_sow,bias_x_rad_s,bias_y_rad_s,bias_z_rad_s,sigma_x_rad_s,sigma_y_rad_s,"
                "sigma_z_rad_s", cols)


def fault_rows(res) -> list[dict]:
    """The fault events (GPS runs of epochs per satellite; gyro events), time order."""
    run, gps = res.run, res.gps
    iso = gps.time.iso(3)
    rows, cur = [], None
    for k, sat, ant, J, thr, isolated in run.gps_events:
        if cur is not None and cur["satellite"] == sat and cur["_end"] == k - 1 and sat:
            cur["_end"], cur["end_gps"] = k, iso[k]
            continue
        cur = {"sensor": "gps", "antenna": ant, "satellite": sat, "axis": "", "start_gps": iso[k], "end_gps": iso[k],
               "detected_gps": iso[k], "detection_delay_s": 0.0, "test": "exclusion bank J > J*(mu, kappa)",
               "statistic": float(J), "threshold": float(thr), "_end": k, "_t": float(gps.time[k] - gps.time[0])}
        rows.append(cur)
    bank_delays = res.settings.gyro_fdi.delay_step_s
    for e in run.gyro_events:
        delay = bank_delays * e.propagator
        t_start = gps.time[e.start] + (-delay)
        rows.append({"sensor": "gyro", "antenna": "", "satellite": "", "axis": "xyz"[e.axis],
                     "start_gps": t_start.iso(3), "end_gps": iso[e.end], "detected_gps": iso[e.start],
                     "detection_delay_s": delay, "test": f"delayed propagator {e.propagator} ({delay:g} s)",
                     "statistic": e.statistic, "threshold": e.threshold, "_t": float(gps.time[e.start] - gps.time[0])})
    rows.sort(key=lambda r: r["_t"])
    return [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows]


def _faults_csv(rows: list[dict]) -> str:
    head = "sensor,antenna,satellite,axis,start_gps,end_gps,detected_gps,detection_delay_s,test,statistic,threshold"
    lines = [",".join([r["sensor"], r["antenna"], r["satellite"], r["axis"], r["start_gps"], r["end_gps"],
                       r["detected_gps"], "%.1f" % r["detection_delay_s"], r["test"], "%.3f" % r["statistic"],
                       "%.3f" % r["threshold"]]) for r in rows]
    return "\n".join([head] + lines) + "\n"


def _costs_csv(res) -> str:
    iso = res.gps.time.iso(3)
    lines = ["time_gps,reference,excluded,J,dof,threshold"]
    lines += [f"{iso[k]},{ref},{ex},{J:.4f},{dof},{thr:.4f}" for k, ref, ex, J, dof, thr in res.run.costs]
    return "\n".join(lines) + "\n"


def _gyro_tests_csv(res) -> str:
    iso = res.gps.time.iso(3)
    step = res.settings.gyro_fdi.delay_step_s
    lines = ["time_gps,propagator,delay_s,z_x,z_y,z_z"]
    lines += [f"{iso[k]},{j},{j * step:g},{a:.3f},{b:.3f},{c:.3f}" for k, j, a, b, c in res.run.gyro_tests]
    return "\n".join(lines) + "\n"


def fusion_products(res) -> dict:
    """Product name -> content (str or dict) of a FusionResult."""
    tab = attitude_table(res)
    # every row of the table is a usable attitude (fused, or gyro-propagated from one): one useable AEM segment
    n_rows = len(tab["time"])
    adapter = SimpleNamespace(att_epochs=np.arange(n_rows), pobs=SimpleNamespace(time=tab["time"]),
                              inputs=SimpleNamespace(platform=res.gps.platform), q_body_from_gcrf=tab["qi"],
                              att_fixed=np.ones(n_rows, bool))
    out = {"attitude.csv": _attitude_csv(tab), "gps_attitude.csv": _gps_csv(res), "bias.csv": _bias_csv(res),
           "faults.csv": _faults_csv(fault_rows(res)), "costs.csv": _costs_csv(res),
           "gyro_tests.csv": _gyro_tests_csv(res), "summary.json": res.summary}
    aem = aem_kvn(adapter)
    if aem is not None:
        out["attitude.aem"] = aem
    return out
