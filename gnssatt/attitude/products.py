"""Files of the attitude job: attitude.csv, baselines.csv (CONVENTIONS.md columns), residuals.csv, events.csv,
summary.json, and exports in the field's formats: CCSDS AEM (KVN) for spacecraft, NMEA HDT for terrestrial.

Implements: ../shared/CONVENTIONS.md "Output: attitude time series" and "Output: baseline time series";
CCSDS 504.0-B-1 Attitude Data Messages sec. 4 (AEM version 1.0, KVN, ATTITUDE_TYPE = QUATERNION,
QUATERNION_TYPE = FIRST, ATTITUDE_DIR = A2B from GCRF to the body frame); NMEA 0183 v4.10 HDT sentence
("$GPHDT,x.x,T*hh", checksum = XOR of the characters between '$' and '*').
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from gnssatt.attitude.filter import REASONS
from gnssatt.csv_text import csv_text, csv_text_blocks, fixed_cells, int_cells, label_cells

__all__ = ["attitude_csv", "baselines_csv", "residuals_csv", "events_csv", "errors_csv", "aem_kvn", "nmea_hdt",
           "sign_continuous", "all_products",
           "product_tables", "write_products"]


def _epoch_time_texts(sol) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ISO text as a str array, gps_week, gps_sow) of every epoch of the pass, computed once per solution (the
    CSVs, the AEM and the plot tables index it instead of formatting the same epochs again)."""
    cached = getattr(sol, "_epoch_time_texts", None)
    if cached is None:
        week, sow = sol.pobs.time.week_sow()
        iso = sol.pobs.time.iso(3)
        cached = (np.asarray(iso if isinstance(iso, list) else [iso], dtype=str), np.atleast_1d(week),
                  np.atleast_1d(sow))
        setattr(sol, "_epoch_time_texts", cached)
    return cached


def _time_cols(sol, epochs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(time_gps text, gps_week, gps_sow) of the epochs (indices into sol.pobs.time)."""
    iso, week, sow = _epoch_time_texts(sol)
    return iso[epochs], week[epochs], sow[epochs]


def _fmt(arr: np.ndarray, fmt: str) -> np.ndarray:
    """fmt % value for each value, as a str array (Python's %-formatting, as np.char.mod, ~10x faster)."""
    return np.array(list(map(fmt.__mod__, np.asarray(arr).tolist())), dtype=object)


def attitude_csv(sol) -> str | None:
    """attitude.csv text (CONVENTIONS.md columns + gps_time flags); None with fewer than two baselines."""
    if sol.att_epochs is None:
        return None
    iso_all, week_all, sow_all = _epoch_time_texts(sol)
    ep = sol.att_epochs
    cols = [label_cells(iso_all, ep), int_cells(week_all[ep]), fixed_cells(sow_all[ep], 3)]
    for q in (sol.q_body_from_ecef, sol.q_body_from_gcrf):
        cols += [fixed_cells(q[:, i], 12) for i in range(4)]
    cols += [fixed_cells(sol.euler_deg[:, i], 6) for i in range(3)]
    cols += [fixed_cells(sol.sigma_euler_deg[:, i], 6) for i in range(3)]
    cols += [int_cells(sol.att_fixed.astype(int)), int_cells(sol.att_n_sats)]
    header = ("time_gps,gps_week,gps_sow,qe_w,qe_x,qe_y,qe_z,qi_w,qi_x,qi_y,qi_z,yaw_deg,pitch_deg,roll_deg,"
              "sigma_yaw_deg,sigma_pitch_deg,sigma_roll_deg,fixed,n_sats")
    return csv_text(header, cols)


def baselines_csv(sol) -> str:
    """baselines.csv text, one row per epoch and baseline with a solution (CONVENTIONS.md)."""
    bt = sol.baseline_table
    iso_all, week_all, sow_all = _epoch_time_texts(sol)
    ep = bt["epoch"]
    names = np.array([f"{a}>{b}" for a, b in sol.baselines] or ["-"])
    cols = [label_cells(iso_all, ep), int_cells(week_all[ep]), fixed_cells(sow_all[ep], 3),
            label_cells(names, bt["bl"])]
    cols += [fixed_cells(bt["b"][:, i], 5) for i in range(3)]
    cols += [fixed_cells(bt[c], 5) for c in ("length_m", "azimuth_deg", "elevation_deg", "sigma_azimuth_deg",
                                             "sigma_elevation_deg", "sigma_length_m")]
    cols += [int_cells(bt["fixed"].astype(int)), int_cells(bt["n_sats"])]
    header = ("time_gps,gps_week,gps_sow,baseline,x_ecef_m,y_ecef_m,z_ecef_m,length_m,azimuth_deg,elevation_deg,"
              "sigma_azimuth_deg,sigma_elevation_deg,sigma_length_m,fixed,n_sats")
    return csv_text(header, cols)


def residuals_csv(sol) -> str:
    """residuals.csv: per epoch, baseline, satellite, signal and observable, the post-fit SD residual (m),
    antenna-frame azimuth/elevation, C/N0, used flag and rejection reason (empty numeric cells where not finite)."""
    r = sol.fr.residuals
    header = ("time_gps,gps_sow,baseline,sat,signal,observable,residual_m,az_ant_deg,el_ant_deg,cn0_dbhz,used,"
              "reason")
    if r["epoch"].size == 0:
        return header + "\n"
    iso_all, _, sow_all = _epoch_time_texts(sol)
    names = [f"{a}>{b}" for a, b in sol.baselines]
    sats, sigs = [str(s) for s in sol.pobs.sats], [str(s) for s in sol.pobs.signals]

    def pairs(a, b):
        """'a,b' for every pair of two small label lists, flat index i * len(b) + j."""
        return [f"{x},{y}" for x in a for y in b]

    # columns that come from a few labels (epoch times, baseline + satellite, signal + observable,
    # used + reason) are one label column each, indexed per row
    used_reason = [f"{int(i == 0)},{REASONS[i]}" for i in range(len(REASONS))]
    time_cells = label_cells((iso_all.astype(object) + "," + _fmt(sow_all, "%.3f")).tolist(), r["epoch"])
    sat_cells = label_cells(pairs(names, sats), r["bl"] * len(sats) + r["sat"])
    sig_cells = label_cells(pairs(sigs, ["code", "phase"]), r["sig"] * 2 + r["kind"])
    reason_cells = label_cells(used_reason, r["reason"])

    def columns_of(lo: int, hi: int) -> list:
        return [time_cells.rows(lo, hi), sat_cells.rows(lo, hi), sig_cells.rows(lo, hi),
                fixed_cells(r["residual_m"][lo:hi], 5, True), fixed_cells(r["az_ant_deg"][lo:hi], 2, True),
                fixed_cells(r["el_ant_deg"][lo:hi], 2, True), fixed_cells(r["cn0_dbhz"][lo:hi], 1, True),
                reason_cells.rows(lo, hi)]

    # ~1e6 rows on a 106-min pass: a block at a time (csv_text_blocks), the same text as csv_text of all rows
    return csv_text_blocks(header, len(time_cells), columns_of)


def events_csv(sol) -> str:
    """events.csv: fixes, failed validations, slips, clock jumps, restarts, in time order."""
    buf = io.StringIO()
    buf.write("time_gps,gps_sow,event,baseline,sat,signal,detail\n")
    iso, _, sow = _epoch_time_texts(sol)
    iso, sow = iso.tolist(), sow.tolist()
    for e in sol.fr.events:
        k = e["epoch"]
        bl = "" if e["baseline"] is None else f"{sol.baselines[e['baseline']][0]}>{sol.baselines[e['baseline']][1]}"
        detail = str(e.get("detail", "")).replace('"', "'")
        buf.write(f"{iso[k]},{sow[k]:.3f},{e['event']},{bl},{e['sat'] or ''},{e['signal'] or ''},\"{detail}\"\n")
    return buf.getvalue()


def sign_continuous(q: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4) with signs chosen so that consecutive rows have a non-negative dot product (q and -q
    are the same rotation; interpolators of AEM data need the short way between samples)."""
    q = np.array(q, dtype=np.float64, copy=True)
    if len(q) < 2:
        return q
    flip = np.cumsum(np.sum(q[1:] * q[:-1], axis=1) < 0) % 2 == 1
    q[1:][flip] *= -1.0
    return q


def _utc_now() -> str:
    import datetime as _dt

    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")


def _aem_segment(name: str, iso: np.ndarray, q: np.ndarray, comments: list[str], useable: bool) -> list[str]:
    meta = ["META_START", *(f"COMMENT {c}" for c in comments), f"OBJECT_NAME = {name}", f"OBJECT_ID = {name}",
            "CENTER_NAME = EARTH", "REF_FRAME_A = GCRF", "REF_FRAME_B = SC_BODY_1", "ATTITUDE_DIR = A2B",
            "TIME_SYSTEM = GPS", f"START_TIME = {iso[0]}"]
    if useable:
        meta += [f"USEABLE_START_TIME = {iso[0]}", f"USEABLE_STOP_TIME = {iso[-1]}"]
    meta += [f"STOP_TIME = {iso[-1]}", "ATTITUDE_TYPE = QUATERNION", "QUATERNION_TYPE = FIRST", "META_STOP", "",
             "DATA_START"]
    body = iso.astype(object)
    for i in range(4):
        body = body + " " + _fmt(q[:, i], "%.12f").astype(object)
    return meta + body.tolist() + ["DATA_STOP", ""]


def aem_kvn(sol, creation_date: str | None = None, originator: str = "GNSSATT",
            float_epochs: str = "omit") -> str | None:
    """CCSDS AEM 1.0 KVN of the GCRF->body quaternions (scalar first), or None without a fixed attitude.

    The first segment holds the fixed epochs only, USEABLE_START/STOP_TIME = first / last fixed epoch; signs
    are continuous (sign_continuous) across the segment. float_epochs: "omit" (default) leaves the float
    epochs out, "segment" adds them as a second segment without a useable span. creation_date: UTC, default
    now. Implements: CCSDS 504.0-B-1 sec. 4.2-4.3 (segments, USEABLE_START/STOP_TIME within START/STOP_TIME).
    """
    if float_epochs not in ("omit", "segment"):
        raise ValueError(f"float_epochs must be 'omit' or 'segment', not {float_epochs!r}")
    if sol.att_epochs is None or sol.att_epochs.size == 0 or not sol.att_fixed.any():
        return None
    iso_all = _time_cols(sol, sol.att_epochs)[0]
    name = sol.inputs.platform.name
    fixed = np.asarray(sol.att_fixed, bool)
    lines = ["CCSDS_AEM_VERS = 1.0", f"CREATION_DATE = {creation_date or _utc_now()}", f"ORIGINATOR = {originator}",
             ""]
    common = "GNSS attitude (gnssatt): passive quaternion GCRF -> body, v_body = R(q) v_gcrf, scalar first"
    lines += _aem_segment(name, iso_all[fixed], sign_continuous(sol.q_body_from_gcrf[fixed]),
                          [common, "GCRF from ECEF by IAU 2006/2000A with zero EOP",
                           f"fixed epochs only ({int(fixed.sum())} of {fixed.size}; float epochs "
                           f"{'in the next segment' if float_epochs == 'segment' else 'left out'})"], True)
    if float_epochs == "segment" and (~fixed).any():
        lines += ["", *_aem_segment(name, iso_all[~fixed], sign_continuous(sol.q_body_from_gcrf[~fixed]),
                                    [common, "FLOAT epochs: ambiguities not fixed, sigma in attitude.csv; "
                                     "not for use where the fixed segment has data"], False)]
    return "\n".join(lines)


def nmea_hdt(sol, baseline_index: int = 0) -> str | None:
    """NMEA HDT sentences (true heading of the body x axis) for a terrestrial platform, one per FIXED epoch
    (attitude fixed, or the baseline fixed when there is one baseline); heading = baseline azimuth minus the
    baseline's azimuth in the body frame. None without a fixed epoch."""
    bt = sol.baseline_table
    if sol.inputs.platform.kind != "terrestrial" or bt["epoch"].size == 0:
        return None
    if sol.att_epochs is not None:
        keep = np.asarray(sol.att_fixed, bool)
        heading = np.mod(sol.euler_deg[keep, 0], 360.0)
    else:
        m = (bt["bl"] == baseline_index) & np.asarray(bt["fixed"], bool)
        bb = sol.body_baselines_m[baseline_index]
        heading = np.mod(bt["azimuth_deg"][m] - np.degrees(np.arctan2(bb[1], bb[0])), 360.0)
    if heading.size == 0:
        return None
    out = []
    for hd in heading.tolist():
        body = f"GPHDT,{hd:.3f},T"
        ck = 0
        for ch in body:
            ck ^= ord(ch)
        out.append(f"${body}*{ck:02X}")
    return "\r\n".join(out) + "\r\n"


def errors_csv(sol, ref) -> str | None:
    """errors.csv: per attitude epoch, the reference Euler angles and the estimate's errors against them [deg]
    (gnssatt.attitude.quality.reference_series; empty cells where the reference has no value), fixed flag and
    the formal 1-sigma; None without a reference."""
    if ref is None:
        return None
    iso_all, _, sow_all = _epoch_time_texts(sol)
    ep = sol.att_epochs
    cols = [label_cells(iso_all, ep), fixed_cells(sow_all[ep], 3)]
    cols += [fixed_cells(ref.euler_ref_deg[:, i], 6, True) for i in range(3)]
    cols += [fixed_cells(ref.error_deg[:, i], 6, True) for i in range(3)]
    cols += [fixed_cells(sol.sigma_euler_deg[:, i], 6) for i in range(3)] + [int_cells(sol.att_fixed.astype(int))]
    header = ("time_gps,gps_sow,yaw_ref_deg,pitch_ref_deg,roll_ref_deg,yaw_error_deg,pitch_error_deg,"
              "roll_error_deg,sigma_yaw_deg,sigma_pitch_deg,sigma_roll_deg,fixed")
    return csv_text(header, cols)


def all_products(sol, creation_date: str | None = None, aem_float_epochs: str = "omit") -> dict[str, str | dict]:
    """Product name -> content (text or JSON-able dict) of a solved attitude job. Adds the `quality` block
    (gnssatt.attitude.quality) to sol.summary; errors.csv when the set has a reference; charts.json (the job
    page's series, gnssatt.attitude.chart_series)."""
    from gnssatt.attitude.chart_series import chart_series
    from gnssatt.attitude.quality import quality_block, reference_series

    out: dict[str, str | dict] = {}
    ref = reference_series(sol)
    sol.summary["quality"] = quality_block(sol, ref)
    att = attitude_csv(sol)
    if att is not None:
        out["attitude.csv"] = att
    out["baselines.csv"] = baselines_csv(sol)
    out["residuals.csv"] = residuals_csv(sol)
    out["events.csv"] = events_csv(sol)
    err = errors_csv(sol, ref) if att is not None else None
    if err is not None:
        out["errors.csv"] = err
    out["charts.json"] = chart_series(sol, ref)
    out["summary.json"] = sol.summary
    if sol.inputs.platform.kind == "terrestrial":
        hdt = nmea_hdt(sol)
        if hdt is not None:
            out["heading.nmea"] = hdt
    else:
        # one creation time per solution: products written twice from one solution are the same bytes
        if creation_date is None:
            creation_date = getattr(sol, "_aem_creation_date", None) or _utc_now()
            setattr(sol, "_aem_creation_date", creation_date)
        aem = aem_kvn(sol, creation_date=creation_date, float_epochs=aem_float_epochs)
        if aem is not None:
            out["attitude.aem"] = aem
    return out


def _epoch_times(sol) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(time_gps as datetime64[ms], gps_week, gps_sow) of every epoch of the pass (the CSVs' time columns)."""
    iso, week, sow = _epoch_time_texts(sol)
    return iso.astype("datetime64[ms]"), np.asarray(week, float), np.asarray(sow, float)


def product_tables(sol) -> dict[str, dict[str, np.ndarray]]:
    """attitude.csv, baselines.csv and residuals.csv as column arrays (gnssatt.plots.common.Table) straight from
    the solution, for the plots: same column names and rows as the CSV texts, numbers as float64 (unrounded; NaN
    where the CSV cell is empty), names as str arrays, time_gps as datetime64[ms] (GPS time, as written).
    What read_csv_table would give back from the texts, without formatting and re-parsing ~6e5 residual rows."""
    from gnssatt.plots.common import coded_strings

    t_ep, week_ep, sow_ep = _epoch_times(sol)
    out: dict[str, dict[str, np.ndarray]] = {}
    if sol.att_epochs is not None:
        ep = sol.att_epochs
        tab = {"time_gps": t_ep[ep], "gps_week": week_ep[ep], "gps_sow": sow_ep[ep]}
        for prefix, q in (("qe", sol.q_body_from_ecef), ("qi", sol.q_body_from_gcrf)):
            tab.update({f"{prefix}_{c}": np.asarray(q[:, i], float) for i, c in enumerate("wxyz")})
        for i, a in enumerate(("yaw", "pitch", "roll")):
            tab[f"{a}_deg"] = np.asarray(sol.euler_deg[:, i], float)
        for i, a in enumerate(("yaw", "pitch", "roll")):
            tab[f"sigma_{a}_deg"] = np.asarray(sol.sigma_euler_deg[:, i], float)
        tab["fixed"] = sol.att_fixed.astype(float)
        tab["n_sats"] = np.asarray(sol.att_n_sats, float)
        out["attitude.csv"] = tab
    bt = sol.baseline_table
    ep = bt["epoch"]
    names = np.array([f"{a}>{b}" for a, b in sol.baselines] or ["-"])
    tab = {"time_gps": t_ep[ep], "gps_week": week_ep[ep], "gps_sow": sow_ep[ep], "baseline": names[bt["bl"]]}
    tab.update({c: np.asarray(bt["b"][:, i], float) for i, c in enumerate(("x_ecef_m", "y_ecef_m", "z_ecef_m"))})
    for c in ("length_m", "azimuth_deg", "elevation_deg", "sigma_azimuth_deg", "sigma_elevation_deg",
              "sigma_length_m", "fixed", "n_sats"):
        tab[c] = np.asarray(bt[c], float)
    out["baselines.csv"] = tab
    r = sol.fr.residuals
    ep = r["epoch"]
    reasons = np.array([REASONS[i] for i in range(len(REASONS))])
    # label columns carry their categories (gnssatt.plots.common.coded_strings): the plots need not sort them
    out["residuals.csv"] = {
        "time_gps": t_ep[ep], "gps_sow": sow_ep[ep],
        "baseline": coded_strings([f"{a}>{b}" for a, b in sol.baselines] or ["-"], r["bl"]),
        "sat": coded_strings(sol.pobs.sats, r["sat"]), "signal": coded_strings(sol.pobs.signals, r["sig"]),
        "observable": coded_strings(["code", "phase"], r["kind"]),
        **{c: np.asarray(r[c], float) for c in ("residual_m", "az_ant_deg", "el_ant_deg", "cn0_dbhz")},
        "used": (r["reason"] == 0).astype(float), "reason": coded_strings(reasons, r["reason"])}
    return out


def write_products(sol, out_dir: str | Path) -> dict[str, Path]:
    """Write the attitude job's text products of `sol` (all_products) into out_dir
    (created), JSON as the service writes it (gnssatt.product_files); returns product name -> path. Plots and
    report.html are not made."""
    from gnssatt.product_files import write_product_files

    return write_product_files(all_products(sol), out_dir)
