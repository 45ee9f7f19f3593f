"""Plots of the `attitude` job, from its CSV products (columns: ../shared/CONVENTIONS.md and docs/pages.md).

Public API (each `*_plot` returns PNG bytes of the matching `*_figure`):
    euler_plot(attitude_csv, reference=None, context=None)   Euler angles + reference, errors (seed 000 Figs. 5-7)
    fix_status_plot(attitude_csv=None, baselines_csv=None, events_csv=None, context=None)
    dop_plot(residuals_csv=None, attitude_csv=None, context=None)
    residuals_plot(residuals_csv, context=None)               phase [mm] and code [m] per baseline and signal
    skyplot_plot(residuals_csv, context=None)                 antenna-frame sky plot coloured by C/N0
Data helpers: reference_euler(attitude, reference), euler_errors(attitude, reference), status_spans(...),
dop_from_directions(az_deg, el_deg), dop_series(residuals).
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np
from matplotlib.figure import Figure

from gnssatt.gnss.rotations import dcm_to_euler321, euler321_to_dcm, quat_to_dcm
from gnssatt.plots.common import (EULER_COLOURS, Margins, PlotContext, Table, axes_pixels, categories, category_memo,
                                 column, figure_png, first_per_epoch_and_key, gps_time, new_figure, no_data, numeric,
                                 polar_screen_points, read_csv_table, screen_points, set_title, time_axis, truthy,
                                 wrap_deg)

AXES = ("yaw", "pitch", "roll")
#: Offsets of the error curves, as seed 000 Figs. 5-7 draw them (roll +1.5 deg, pitch -1.5 deg) "for better
#: readability"; yaw stays in the middle.
ERROR_OFFSETS_DEG = {"yaw": 0.0, "pitch": -1.5, "roll": 1.5}
#: A reference sample farther than this from both neighbours of an epoch is not interpolated across [s]
#: (star trackers drop out; bridging a gap would invent a reference).
MAX_REFERENCE_GAP_S = 60.0
#: Sky plots and residual scatters draw the points a screen shows apart (gnssatt.plots.common.screen_points: each
#: pixel column's extremes and one point per occupied 2 x 2 px cell, as the panel titles say); all statistics use
#: all rows, and residuals.csv holds them all.
DRAWN_NOTE = "screen-decimated, spikes kept"

RESIDUAL_COLUMNS = {
    "baseline": ("baseline",),
    "satellite": ("satellite", "sat", "prn"),
    "signal": ("signal", "code", "frequency"),
    "code_m": ("code_residual_m", "code_res_m", "residual_code_m"),
    "phase_mm": ("phase_residual_mm", "phase_res_mm", "residual_phase_mm"),
    "phase_m": ("phase_residual_m", "phase_res_m", "residual_phase_m"),
    "azimuth_deg": ("azimuth_deg", "az_ant_deg", "azimuth_antenna_deg", "az_deg", "az_antenna_deg"),
    "elevation_deg": ("elevation_deg", "el_ant_deg", "elevation_antenna_deg", "el_deg", "el_antenna_deg"),
    "cn0_dbhz": ("cn0_dbhz", "cn0", "snr_dbhz"),
    "used": ("used",),
}


def _seconds(t: np.ndarray) -> np.ndarray:
    return t.astype("datetime64[ms]").astype(np.int64) / 1000.0


def _residual(table: Table, key: str) -> np.ndarray | None:
    return column(table, *RESIDUAL_COLUMNS[key])


def _residual_num(table: Table, key: str) -> np.ndarray | None:
    return numeric(table, *RESIDUAL_COLUMNS[key])


def residual_values(table: Table) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(phase_mm, code_m) per row of residuals.csv, NaN where a row holds the other observable.

    Two layouts are read: wide (`phase_residual_mm` or `phase_residual_m`, and `code_residual_m` columns) and
    long (`observable` = code | phase with `residual_m`, one row per observable, as gnssatt/attitude writes)."""
    kind, value = column(table, "observable"), numeric(table, "residual_m")
    if kind is not None and value is not None:
        kinds, code = categories(kind)
        kinds = [k.lower() for k in kinds]
        is_phase = np.isin(code, [i for i, k in enumerate(kinds) if k == "phase"])
        is_code = np.isin(code, [i for i, k in enumerate(kinds) if k == "code"])
        return np.where(is_phase, value * 1000.0, np.nan), np.where(is_code, value, np.nan)
    phase = _residual_num(table, "phase_mm")
    if phase is None and _residual_num(table, "phase_m") is not None:
        phase = _residual_num(table, "phase_m") * 1000.0
    return phase, _residual_num(table, "code_m")


# --- Euler angles and errors -------------------------------------------------------------------------------

def _interp_quaternions(t_ref_s: np.ndarray, q_ref: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Reference quaternions (n, 4) at times t_s by normalised linear interpolation (nlerp) between the two
    neighbouring samples (sign-aligned); NaN outside the reference span or across gaps > MAX_REFERENCE_GAP_S.
    Neglects: nlerp's non-uniform angular rate, < 1e-5 rad for 1 s samples at 1 deg/s."""
    out = np.full((len(t_s), 4), np.nan)
    if len(t_ref_s) == 0:
        return out
    order = np.argsort(t_ref_s, kind="stable")
    t_ref_s, q_ref = t_ref_s[order], q_ref[order]
    j = np.searchsorted(t_ref_s, t_s)
    tol = 1e-3
    exact_lo = (j > 0) & (np.abs(t_ref_s[np.clip(j - 1, 0, None)] - t_s) <= tol)
    exact_hi = (j < len(t_ref_s)) & (np.abs(t_ref_s[np.clip(j, None, len(t_ref_s) - 1)] - t_s) <= tol)
    lo = np.clip(j - 1, 0, len(t_ref_s) - 1)
    hi = np.clip(j, 0, len(t_ref_s) - 1)
    inside = (j > 0) & (j < len(t_ref_s)) & (t_ref_s[hi] - t_ref_s[lo] <= MAX_REFERENCE_GAP_S)
    span = np.where(t_ref_s[hi] > t_ref_s[lo], t_ref_s[hi] - t_ref_s[lo], 1.0)
    f = np.clip((t_s - t_ref_s[lo]) / span, 0.0, 1.0)[:, None]
    q_lo, q_hi = q_ref[lo], q_ref[hi]
    q_hi = np.where(np.sum(q_lo * q_hi, axis=1, keepdims=True) < 0, -q_hi, q_hi)
    q = (1 - f) * q_lo + f * q_hi
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    out[inside] = q[inside]
    out[exact_hi] = q_ref[np.clip(j, None, len(t_ref_s) - 1)][exact_hi]
    out[exact_lo] = q_ref[lo][exact_lo]
    return out


def reference_euler(attitude: Any, reference: Any) -> dict[str, np.ndarray]:
    """Reference yaw/pitch/roll [deg] at the epochs of `attitude` (NaN where the reference has none).

    attitude: attitude.csv (CONVENTIONS.md columns) as CSV text or Table.
    reference: either a table of Euler angles (time_gps, yaw_deg, pitch_deg, roll_deg), interpolated
        linearly (unwrapped), or the set's reference attitude CSV (time_gps, frame, qw, qx, qy, qz;
        frame GCRF or ECEF). For quaternions the orbital frame of each epoch is taken from the estimate's
        own row: R_frame_from_orb = R(q_body_from_frame_est)^T Rx(roll) Ry(pitch) Rz(yaw), so
        R_body_from_orb_ref = R(q_ref) R_frame_from_orb; exact because the orbital frame depends only on
        the platform's orbit, not on its attitude.
    Implements: CONVENTIONS.md "Euler angles" (3-2-1, passive) and "Quaternions" (Shuster, w >= 0).
    """
    att, ref = read_csv_table(attitude), read_csv_table(reference)
    t = gps_time(att)
    t_s = _seconds(t)
    t_ref_s = _seconds(gps_time(ref))
    out = {"time": t}
    if column(ref, "yaw_deg") is not None:
        for ax in AXES:
            values = numeric(ref, f"{ax}_deg")
            order = np.argsort(t_ref_s, kind="stable")
            tr, v = t_ref_s[order], values[order]
            unwrapped = np.degrees(np.unwrap(np.radians(v))) if ax != "pitch" else v
            y = np.interp(t_s, tr, unwrapped, left=np.nan, right=np.nan)
            j = np.clip(np.searchsorted(tr, t_s), 1, max(len(tr) - 1, 1))
            gap = (tr[j] - tr[j - 1] > MAX_REFERENCE_GAP_S) if len(tr) > 1 else np.zeros(len(t_s), bool)
            y[gap & ~np.isin(t_s, tr)] = np.nan
            out[f"{ax}_deg"] = wrap_deg(y) if ax != "pitch" else y
        return out
    q_cols = [numeric(ref, c) for c in ("qw", "qx", "qy", "qz")]
    if any(c is None for c in q_cols):
        raise ValueError("reference needs yaw_deg/pitch_deg/roll_deg or qw,qx,qy,qz columns")
    frame_col = column(ref, "frame")
    frame = str(frame_col[0]).upper() if frame_col is not None and len(frame_col) else "GCRF"
    prefix = {"GCRF": "qi", "ECEF": "qe"}.get(frame)
    if prefix is None:
        raise ValueError(f"reference frame {frame!r} is neither GCRF nor ECEF")
    q_est = np.stack([numeric(att, f"{prefix}_{c}") for c in "wxyz"], axis=-1)
    q_ref = _interp_quaternions(t_ref_s, np.stack(q_cols, axis=-1), t_s)
    ok = np.isfinite(q_ref).all(axis=1) & np.isfinite(q_est).all(axis=1)
    ypr_est = [numeric(att, f"{ax}_deg") for ax in AXES]
    for ax in AXES:
        out[f"{ax}_deg"] = np.full(len(t), np.nan)
    if ok.any():
        R_body_from_orb_est = euler321_to_dcm(*(v[ok] for v in ypr_est))
        R_body_from_frame_est = quat_to_dcm(q_est[ok])
        R_frame_from_orb = np.swapaxes(R_body_from_frame_est, -1, -2) @ R_body_from_orb_est
        R_body_from_orb_ref = quat_to_dcm(q_ref[ok]) @ R_frame_from_orb
        for ax, values in zip(AXES, dcm_to_euler321(R_body_from_orb_ref)):
            out[f"{ax}_deg"][ok] = values
    return out


def euler_errors(attitude: Any, reference: Any) -> dict[str, np.ndarray]:
    """Estimate minus reference Euler angles [deg] at the attitude epochs (yaw and roll wrapped to
    (-180, 180]); keys time, yaw_deg, pitch_deg, roll_deg; NaN where the reference has no value."""
    att = read_csv_table(attitude)
    ref = reference_euler(att, reference)
    out = {"time": ref["time"]}
    for ax in AXES:
        diff = numeric(att, f"{ax}_deg") - ref[f"{ax}_deg"]
        out[f"{ax}_deg"] = wrap_deg(diff) if ax != "pitch" else diff
    return out


def euler_figure(attitude_csv: Any, reference: Any = None, context: PlotContext | Mapping | None = None,
                 error_offsets_deg: Mapping[str, float] = ERROR_OFFSETS_DEG) -> Figure:
    """Top: estimated yaw, pitch, roll (dots; float epochs hollow) with the reference (solid lines).
    Bottom: errors against the reference, offset as in seed 000 Figs. 5-7 (roll +1.5 deg, pitch -1.5 deg),
    with the product's own 1-sigma as a band and bias/std in the legend; without a reference, the formal
    1-sigma of each angle. Errors may also come as attitude.csv extra columns `<axis>_error_deg`."""
    att = read_csv_table(attitude_csv)
    fig = new_figure(10.0, 7.0, Margins(left=0.75, top=0.7, hgap=0.35, rows=2))
    top, bottom = fig.subplots(2, 1, sharex=True)
    if not len(column(att, "time_gps") if column(att, "time_gps") is not None else []):
        no_data(top, "no attitude epochs")
        no_data(bottom)
        set_title(fig, "Euler angles (3-2-1) and errors", context)
        return fig
    t = gps_time(att)
    fixed = truthy(column(att, "fixed")) if column(att, "fixed") is not None else np.ones(len(t), bool)
    ref = reference_euler(att, reference) if reference is not None else None
    errors = None
    if ref is not None:
        errors = euler_errors(att, reference)
    elif all(column(att, f"{ax}_error_deg") is not None for ax in AXES):
        errors = {f"{ax}_deg": numeric(att, f"{ax}_error_deg") for ax in AXES}
    for ax in AXES:
        colour = EULER_COLOURS[ax]
        y = numeric(att, f"{ax}_deg")
        top.plot(t[fixed], y[fixed], ".", ms=2.5, color=colour, label=f"{ax} (fixed)")
        if (~fixed).any():
            top.plot(t[~fixed], y[~fixed], ".", ms=2.5, mfc="none", color=colour, alpha=0.6, label=f"{ax} (float)")
        if ref is not None:
            top.plot(t, ref[f"{ax}_deg"], "-", lw=1.0, color=colour, alpha=0.8, label=f"{ax} reference")
    top.set_ylabel("Euler angle [deg]")
    top.legend(fontsize=7, ncols=3, loc="upper right")
    top.grid(color="0.88", lw=0.5)
    for ax in AXES:
        colour = EULER_COLOURS[ax]
        sigma = numeric(att, f"sigma_{ax}_deg")
        off = float(error_offsets_deg.get(ax, 0.0))
        off_txt = f" {off:+.1f}°" if off else ""
        if errors is not None:
            e = errors[f"{ax}_deg"]
            good = np.isfinite(e) & fixed
            stats = (f": bias {np.mean(e[good]):+.3f}°, std {np.std(e[good]):.3f}°" if good.sum() > 1 else "")
            bottom.plot(t, e + off, ".", ms=2.5, color=colour, label=f"{ax} error{off_txt}{stats}")
            if sigma is not None and np.isfinite(sigma).any():
                bottom.fill_between(t, off - sigma, off + sigma, where=fixed, color=colour, alpha=0.12, lw=0)
        elif sigma is not None:
            bottom.plot(t, sigma, "-", lw=1.0, color=colour, label=f"formal 1σ {ax}")
    _focus_on_fixed(top, [numeric(att, f"{ax}_deg")[fixed] for ax in AXES]
                    + ([ref[f"{ax}_deg"] for ax in AXES] if ref is not None else []), margin_frac=0.08)
    if errors is not None and fixed.any():
        _focus_on_fixed(bottom, [errors[f"{ax}_deg"][fixed] + float(error_offsets_deg.get(ax, 0.0)) for ax in AXES],
                        margin_abs=0.5)
    if errors is not None:
        bottom.set_ylabel("error (estimate − reference) [deg]")
    elif any(numeric(att, f"sigma_{ax}_deg") is not None for ax in AXES):
        bottom.set_ylabel("formal 1σ [deg]")
        bottom.set_title("no reference attitude: formal 1σ of the product", fontsize=8)
    else:
        no_data(bottom, "no reference and no sigma columns")
    if bottom.get_legend_handles_labels()[0]:
        bottom.legend(fontsize=7, loc="upper right")
    bottom.grid(color="0.88", lw=0.5)
    time_axis(bottom, t)
    set_title(fig, "Euler angles (3-2-1, body vs orbital/NED frame) and errors", context)
    return fig


def _focus_on_fixed(ax, arrays, margin_frac: float = 0.0, margin_abs: float = 0.0) -> None:
    """Set the y range to the finite values given (the fixed epochs: float epochs before the first fix can
    be off by tens of degrees and would flatten everything else); says how many drawn points fall outside."""
    values = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in arrays]) if arrays else np.zeros(0)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return
    lo, hi = float(values.min()), float(values.max())
    pad = max((hi - lo) * margin_frac, margin_abs, 1e-3)
    lo, hi = lo - pad, hi + pad
    outside = 0
    for line in ax.get_lines():
        y = np.asarray(line.get_ydata(), dtype=np.float64)
        outside += int(np.sum(np.isfinite(y) & ((y < lo) | (y > hi))))
    ax.set_ylim(lo, hi)
    if outside:
        ax.text(0.01, 0.02, f"{outside} float-epoch points outside this range", transform=ax.transAxes,
                fontsize=7, color="0.35")


def euler_plot(attitude_csv: Any, reference: Any = None, context: PlotContext | Mapping | None = None,
               **kwargs) -> bytes:
    """PNG of `euler_figure`."""
    return figure_png(euler_figure(attitude_csv, reference, context, **kwargs))


# --- fix status, satellites, events ---------------------------------------------------------------------------

def status_spans(time: np.ndarray, fixed: np.ndarray, max_gap_s: float | None = None) -> list[tuple]:
    """Runs of equal fix status: [(start datetime64, end datetime64, fixed bool), ...]; a step longer than
    `max_gap_s` (default 1.5 x the median epoch interval) ends a run, so data gaps stay blank."""
    time = np.asarray(time, dtype="datetime64[ms]")
    fixed = np.asarray(fixed, dtype=bool)
    if len(time) == 0:
        return []
    t_s = _seconds(time)
    steps = np.diff(t_s)
    interval = float(np.median(steps)) if len(steps) else 1.0
    if max_gap_s is None:
        max_gap_s = 1.5 * interval
    spans = []
    start = 0
    for k in range(1, len(time) + 1):
        if k == len(time) or fixed[k] != fixed[start] or t_s[k] - t_s[k - 1] > max_gap_s:
            end = time[k - 1] + np.timedelta64(int(round(interval * 1000)), "ms")
            spans.append((time[start], end, bool(fixed[start])))
            start = k
    return spans


def fix_status_figure(attitude_csv: Any = None, baselines_csv: Any = None, events_csv: Any = None,
                      context: PlotContext | Mapping | None = None) -> Figure:
    """Top: one lane per series (the attitude, then each baseline of baselines.csv): fixed spans green,
    float spans orange, gaps blank. Middle: events of events.csv, one row of ticks per kind labelled with its
    count (their own axis: a realistic pass has thousands of slips, which drawn across the lanes hid them).
    Bottom: satellites used per series. Axes in that order (fig.axes[:3])."""
    import matplotlib.dates as mdates

    series: list[tuple[str, np.ndarray, np.ndarray, np.ndarray | None]] = []
    att = read_csv_table(attitude_csv)
    if column(att, "time_gps") is not None and len(column(att, "time_gps")):
        series.append(("attitude", gps_time(att), truthy(column(att, "fixed")), numeric(att, "n_sats")))
    bl = read_csv_table(baselines_csv)
    if column(bl, "time_gps") is not None and len(column(bl, "time_gps")):
        names = column(bl, "baseline").astype(str)
        t_all = gps_time(bl)
        for name in dict.fromkeys(names):
            m = names == name
            n_sats = numeric(bl, "n_sats")
            series.append((f"baseline {name}", t_all[m], truthy(column(bl, "fixed")[m]),
                           n_sats[m] if n_sats is not None else None))
    ev = read_csv_table(events_csv)
    kinds, t_ev = np.array([], dtype=str), np.array([], dtype="datetime64[ms]")
    if column(ev, "time_gps") is not None and len(column(ev, "time_gps")):
        t_ev = gps_time(ev)
        k = column(ev, "event", "kind", "type")
        kinds = k.astype(str) if k is not None else np.array(["event"] * len(t_ev))
    kind_names = list(dict.fromkeys(kinds))
    n_rows = max(len(series), 1)
    fig = new_figure(10.0, 3.4 + 0.5 * n_rows + 0.22 * max(len(kind_names), 1),
                     Margins(left=1.7, top=0.7, hgap=0.12, rows=3))
    lanes, events, counts = fig.subplots(3, 1, sharex=True,
                                         height_ratios=[n_rows, 0.45 * max(len(kind_names), 1), 2])
    if not series:
        no_data(lanes, "no attitude or baseline epochs")
        no_data(events)
        no_data(counts)
        set_title(fig, "Fix status, events and satellites used", context)
        return fig
    t_min = min(s[1].min() for s in series)
    labelled: set[str] = set()
    for i, (name, t, fixed, n_sats) in enumerate(series):
        spans = status_spans(t, fixed)
        for want, colour, label in ((True, "#2ca02c", "fixed"), (False, "#ff7f0e", "float")):
            bars = [(mdates.date2num(a), mdates.date2num(b) - mdates.date2num(a)) for a, b, f in spans if f == want]
            if bars:
                lanes.broken_barh(bars, (i - 0.35, 0.7), color=colour,
                                  label=None if label in labelled else label)
                labelled.add(label)
        if n_sats is not None:
            counts.step(t, n_sats, where="post", lw=1.0, label=name)
    lanes.set_yticks(range(len(series)))
    lanes.set_yticklabels([s[0] for s in series], fontsize=8)
    lanes.set_ylim(len(series) - 0.5, -0.5)
    lanes.legend(fontsize=7, loc="upper right", ncols=2)
    palette = ["#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#17becf", "#bcbd22", "#1f77b4"]
    for k, kind in enumerate(kind_names):
        m = kinds == kind
        # one path per kind (x = t, t, NaN per distinct event time), not thousands of artists
        t_k = mdates.date2num(np.unique(t_ev[m]))
        x = np.repeat(t_k, 3)
        x[2::3] = np.nan
        y = np.tile([k - 0.35, k + 0.35, np.nan], len(t_k))
        events.plot(x, y, "-", color=palette[k % len(palette)], lw=0.8, label=f"{kind} ({int(m.sum())})")
    if kind_names:
        events.set_yticks(range(len(kind_names)))
        events.set_yticklabels([f"{kind} ({int((kinds == kind).sum())})" for kind in kind_names], fontsize=7)
        events.set_ylim(len(kind_names) - 0.5, -0.5)
    else:
        events.set_yticks([])
        no_data(events, "no events")
    counts.set_ylabel("satellites used")
    if counts.get_legend_handles_labels()[0]:
        counts.legend(fontsize=7, loc="lower right", ncols=3)
    else:
        no_data(counts, "no n_sats column")
    counts.grid(color="0.88", lw=0.5)
    time_axis(counts, np.array([t_min]))
    set_title(fig, "Fix status, events and satellites used", context)
    return fig


def fix_status_plot(attitude_csv: Any = None, baselines_csv: Any = None, events_csv: Any = None,
                    context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `fix_status_figure`."""
    return figure_png(fix_status_figure(attitude_csv, baselines_csv, events_csv, context))


# --- DOP ------------------------------------------------------------------------------------------------------

def dop_from_directions(az_deg: np.ndarray, el_deg: np.ndarray, epoch_index: np.ndarray | None = None,
                        n_epochs: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(HDOP, VDOP) per epoch of the line-of-sight directions (azimuth from x towards y, elevation above the
    x-y plane, degrees) of the satellites used at that epoch; NaN with fewer than 4 satellites.

    Geometry rows g = (cos el cos az, cos el sin az, sin el, 1) (the 1 is the differential receiver clock of
    a single-difference baseline); Q = (G^T G)^-1, HDOP = sqrt(Q11 + Q22), VDOP = sqrt(Q33), in the frame
    of the directions (the antenna frame: H is in the antenna plane, V along boresight).
    Implements: seed 000 eq. 3 (sigma_H = HDOP sigma_Phi, sigma_V = VDOP sigma_Phi); DOP as in Misra & Enge,
    Global Positioning System (2006) sec. 6.1.3.
    """
    az, el = np.radians(np.asarray(az_deg, float)), np.radians(np.asarray(el_deg, float))
    if epoch_index is None:
        epoch_index, n_epochs = np.zeros(len(az), dtype=np.int64), 1
    g = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el), np.ones_like(az)], axis=-1)
    normal = np.zeros((n_epochs, 4, 4))
    np.add.at(normal, epoch_index, g[:, :, None] * g[:, None, :])
    n_sats = np.bincount(epoch_index, minlength=n_epochs)
    hdop, vdop = np.full(n_epochs, np.nan), np.full(n_epochs, np.nan)
    ok = n_sats >= 4
    if ok.any():
        cond = np.linalg.cond(normal[ok])
        good = np.flatnonzero(ok)[cond < 1e12]
        if len(good):
            q = np.linalg.inv(normal[good])
            hdop[good] = np.sqrt(q[:, 0, 0] + q[:, 1, 1])
            vdop[good] = np.sqrt(q[:, 2, 2])
    return hdop, vdop


def dop_series(residuals_csv: Any) -> dict[str, dict[str, np.ndarray]]:
    """Per baseline: {"time", "hdop", "vdop", "n_sats"} from the used rows of residuals.csv (one direction
    per epoch and satellite, whatever the number of signals)."""
    res = read_csv_table(residuals_csv)
    out: dict[str, dict[str, np.ndarray]] = {}
    if column(res, "time_gps") is None or not len(column(res, "time_gps")):
        return out
    t = gps_time(res)
    base = _residual(res, "baseline")
    names, base_code = categories(base) if base is not None else (["all"], np.zeros(len(t), dtype=np.int64))
    _, sat_code = categories(_residual(res, "satellite"))
    az, el = _residual_num(res, "azimuth_deg"), _residual_num(res, "elevation_deg")
    used = truthy(_residual(res, "used")) if _residual(res, "used") is not None else np.ones(len(t), bool)
    for j, name in enumerate(names):
        m = (base_code == j) & used & np.isfinite(az) & np.isfinite(el)
        if not m.any():
            continue
        rows = first_per_epoch_and_key(t, sat_code, np.flatnonzero(m))
        epochs, idx = np.unique(t[rows], return_inverse=True)
        hdop, vdop = dop_from_directions(az[rows], el[rows], idx, len(epochs))
        out[name] = {"time": epochs, "hdop": hdop, "vdop": vdop, "n_sats": np.bincount(idx, minlength=len(epochs))}
    return out


def dop_figure(residuals_csv: Any = None, attitude_csv: Any = None,
               context: PlotContext | Mapping | None = None) -> Figure:
    """HDOP and VDOP over time: from attitude.csv columns `hdop`/`vdop` (any `*dop` column) when present,
    else per baseline from the antenna-frame directions of residuals.csv (`dop_series`)."""
    fig = new_figure(10.0, 4.0, Margins(left=0.7, top=0.95))
    ax = fig.subplots()
    att = read_csv_table(attitude_csv)
    dop_cols = [k for k in att if k.lower().endswith("dop")]
    t_any = None
    if dop_cols and column(att, "time_gps") is not None:
        t_any = gps_time(att)
        for k in dop_cols:
            ax.plot(t_any, numeric(att, k), "-", lw=1.0, label=k.upper())
        source = "attitude.csv"
    else:
        series = dop_series(residuals_csv) if residuals_csv is not None else {}
        for name, s in series.items():
            ax.plot(s["time"], s["hdop"], "-", lw=1.0, label=f"HDOP {name}")
            ax.plot(s["time"], s["vdop"], "--", lw=1.0, label=f"VDOP {name}")
            t_any = s["time"] if t_any is None else np.concatenate([t_any, s["time"]])
        source = "antenna frame of each baseline's first antenna, from residuals.csv"
    if t_any is None:
        no_data(ax, "no DOP columns and no residuals with azimuth/elevation")
    else:
        time_axis(ax, t_any)
        ax.legend(fontsize=7, ncols=4, loc="upper right")
        ax.set_title(f"source: {source}", fontsize=8)
    ax.set_ylabel("DOP [-]")
    ax.grid(color="0.88", lw=0.5)
    set_title(fig, "Dilution of precision (HDOP, VDOP)", context)
    return fig


def dop_plot(residuals_csv: Any = None, attitude_csv: Any = None, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `dop_figure`."""
    return figure_png(dop_figure(residuals_csv, attitude_csv, context))


# --- residuals and sky plot -------------------------------------------------------------------------------------

def residuals_figure(residuals_csv: Any, context: PlotContext | Mapping | None = None) -> Figure:
    """Single-difference residuals over time, one row per baseline: carrier phase [mm] (left) and code [m]
    (right), one colour per signal, used observations only; the legend gives each signal's RMS."""
    res = read_csv_table(residuals_csv)
    has_rows = column(res, "time_gps") is not None and len(column(res, "time_gps")) > 0
    base = _residual(res, "baseline") if has_rows else None
    if base is not None:
        names, base_code = categories(base)
    else:
        names, base_code = (["all"] if has_rows else []), None
    fig = new_figure(11.0, 1.5 + 2.6 * max(len(names), 1),
                     Margins(left=0.75, top=0.95, hgap=0.4, wgap=0.85, rows=max(len(names), 1), cols=2))
    axes = fig.subplots(max(len(names), 1), 2, sharex=True, squeeze=False)
    if not has_rows:
        for a in axes[0]:
            no_data(a, "no residuals")
        set_title(fig, "Single-difference residuals per baseline and signal", context)
        return fig
    t = gps_time(res)
    if base_code is None:
        base_code = np.zeros(len(t), dtype=np.int64)
    sig = _residual(res, "signal")
    sig_names, sig_code = categories(sig) if sig is not None else (["?"], np.zeros(len(t), dtype=np.int64))
    used = truthy(_residual(res, "used")) if _residual(res, "used") is not None else np.ones(len(t), bool)
    phase, code = residual_values(res)
    t_s = _seconds(t)
    for row, name in enumerate(names):
        for col, (values, unit, what) in enumerate(((phase, "mm", "phase"), (code, "m", "code"))):
            ax = axes[row, col]
            if values is None:
                no_data(ax, f"no {what} residual column")
                continue
            sel = base_code == row
            n_rejected = int((sel & ~used & np.isfinite(values)).sum())
            n_used = n_drawn = 0
            for s in sorted(sig_names[j] for j in np.unique(sig_code[sel])):
                m = np.flatnonzero(sel & used & (sig_code == sig_names.index(s)) & np.isfinite(values))
                if not len(m):
                    continue
                rms = float(np.sqrt(np.mean(values[m] ** 2)))
                k = m[screen_points(t_s[m], values[m], *axes_pixels(ax))]
                n_used, n_drawn = n_used + len(m), n_drawn + len(k)
                ax.plot(t[k], values[k], ".", ms=1.5, label=f"{s}: RMS {rms:.3g} {unit} (n={len(m)})")
            ax.set_ylabel(f"{what} residual [{unit}]")
            ax.set_title(f"{name} · {what}" + (f" · {n_rejected} rejected not shown" if n_rejected else "")
                         + (f" · {n_drawn} of {n_used} drawn ({DRAWN_NOTE})"
                            if n_drawn < n_used else ""), fontsize=8)
            ax.grid(color="0.88", lw=0.5)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7, markerscale=4, loc="upper right")
    for a in axes[-1]:
        time_axis(a, t, maxticks=5)       # two panels side by side: ~5 HH:MM:SS labels fit each
    set_title(fig, "Single-difference residuals per baseline and signal", context)
    return fig


def residuals_plot(residuals_csv: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `residuals_figure`."""
    return figure_png(residuals_figure(residuals_csv, context))


def skyplot_figure(residuals_csv: Any, context: PlotContext | Mapping | None = None) -> Figure:
    """Tracks of the satellites in the antenna frame of each baseline's first antenna, coloured by C/N0.

    Polar axes: azimuth from antenna x (top) towards antenna y (right), clockwise; radius = 90 - elevation
    (boresight at the centre; the dashed circle is the antenna plane, tracks below it lie outside). One point
    per epoch and satellite (the first signal listed for it), all rows whether used or not.
    Implements: CONVENTIONS.md antenna frame (z boresight, azimuth from x towards y).
    """
    res = read_csv_table(residuals_csv)
    has_rows = column(res, "time_gps") is not None and len(column(res, "time_gps")) > 0
    base = _residual(res, "baseline") if has_rows else None
    if base is not None:
        names, base_code = categories(base)
    else:
        names, base_code = (["all"] if has_rows else []), None
    n = max(len(names), 1)
    fig = new_figure(4.6 * n + 1.0, 5.2, Margins(left=0.45, right=0.35, top=1.35, bottom=0.3, wgap=0.9, cols=n))
    axes = [fig.add_subplot(1, n, i + 1, projection="polar") for i in range(n)]
    if not has_rows:
        no_data(axes[0], "no residuals")
        set_title(fig, "Sky plot in the antenna frame, coloured by C/N0", context)
        return fig
    t = gps_time(res)
    if base_code is None:
        base_code = np.zeros(len(t), dtype=np.int64)
    _, sat_code = categories(_residual(res, "satellite"))
    sats = _residual(res, "satellite").astype(str)
    az, el = _residual_num(res, "azimuth_deg"), _residual_num(res, "elevation_deg")
    cn0 = _residual_num(res, "cn0_dbhz")
    if cn0 is None:
        cn0 = np.full(len(t), np.nan)
    finite_cn0 = cn0[np.isfinite(cn0)]
    vmin, vmax = ((float(np.floor(finite_cn0.min())), float(np.ceil(finite_cn0.max()))) if finite_cn0.size
                  else (20.0, 55.0))
    scatter = None
    for j, (ax, name) in enumerate(zip(axes, names)):
        m = (base_code == j) & np.isfinite(az) & np.isfinite(el)
        rows_all = first_per_epoch_and_key(t, sat_code, np.flatnonzero(m))
        rows = rows_all[polar_screen_points(ax, az[rows_all], 90.0 - el[rows_all])]
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        r_max = max(90.0, 90.0 - float(np.min(el[rows])) + 2.0) if len(rows) else 90.0
        scatter = ax.scatter(np.radians(az[rows]), 90.0 - el[rows], c=cn0[rows], s=4, cmap="viridis",
                             vmin=vmin, vmax=vmax, linewidths=0)
        theta = np.linspace(0, 2 * np.pi, 361)
        ax.plot(theta, np.full_like(theta, 90.0), "--", color="0.4", lw=0.8)
        ax.set_rlim(0, r_max)
        ticks = [r for r in (0, 30, 60, 90, 120) if r <= r_max]
        ax.set_rticks(ticks)
        ax.set_yticklabels([f"{90 - r:.0f}°" for r in ticks], fontsize=7)
        ax.set_xticks(np.radians([0, 90, 180, 270]))
        ax.set_xticklabels(["x 0°", "y 90°", "180°", "270°"], fontsize=8)
        for s in sorted(set(sats[rows])):
            last = rows[sats[rows] == s][-1]
            ax.annotate(s, (np.radians(az[last]), 90.0 - el[last]), fontsize=6, color="0.25")
        first_ant = name.split(">")[0] if ">" in name else name
        thinned = (f"\n{len(rows)} of {len(rows_all)} epoch-satellite points drawn ({DRAWN_NOTE})"
                   if len(rows) < len(rows_all) else "")
        ax.set_title(f"{name}\nantenna frame of {first_ant} (elevation on radius){thinned}", fontsize=8)
    if scatter is not None:
        fig.colorbar(scatter, ax=axes, label="C/N0 [dB-Hz]", shrink=0.8)
    set_title(fig, "Sky plot in the antenna frame, coloured by C/N0", context)
    return fig


def skyplot_plot(residuals_csv: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `skyplot_figure`."""
    return figure_png(skyplot_figure(residuals_csv, context))


#: the attitude job's PNGs in report order (attitude_plots)
PLOT_NAMES = ("euler.png", "fix_status.png", "dop.png", "residuals.png", "skyplot.png", "elevation.png",
              "skyplot_fix.png")


def attitude_plots(products: Mapping[str, Any], reference: Any = None,
                   context: PlotContext | Mapping | None = None, names: Any = PLOT_NAMES) -> dict[str, bytes]:
    """Every attitude PNG that the given products allow, by product name, in report order.

    products: {"attitude.csv": text, "baselines.csv": text, "residuals.csv": text, "events.csv": text}
        (any may be missing; a one-baseline platform has no attitude.csv).
    reference: the set's reference attitude CSV text (CONVENTIONS.md) or None.
    names: the plots to draw (of PLOT_NAMES; two processes each draw a part of them).
    Returns e.g. {"euler.png", "fix_status.png", "dop.png", "residuals.png", "skyplot.png", "elevation.png",
    "skyplot_fix.png"} (the last two: gnssatt.plots.elevation).
    """
    from gnssatt.plots.elevation import elevation_plot, fix_skyplot_plot

    # each CSV is parsed once here, not once per plot (residuals.csv feeds three plots)
    tab = {k: (None if v is None else read_csv_table(v)) for k, v in products.items()}
    att, bl = tab.get("attitude.csv"), tab.get("baselines.csv")
    res, ev = tab.get("residuals.csv"), tab.get("events.csv")
    reference = None if reference is None else read_csv_table(reference)
    makers = {"euler.png": (att is not None and len(att.get("time_gps", [])),
                            lambda: euler_plot(att, reference, context)),
              "fix_status.png": (att is not None or bl is not None, lambda: fix_status_plot(att, bl, ev, context)),
              "dop.png": (res is not None, lambda: dop_plot(res, att, context)),
              "residuals.png": (res is not None, lambda: residuals_plot(res, context)),
              "skyplot.png": (res is not None, lambda: skyplot_plot(res, context)),
              "elevation.png": (res is not None, lambda: elevation_plot(res, context)),
              "skyplot_fix.png": (res is not None and bl is not None, lambda: fix_skyplot_plot(res, bl, context))}
    out: dict[str, bytes] = {}
    with category_memo():
        for name in PLOT_NAMES:
            if name in names and makers[name][0]:
                out[name] = makers[name][1]()
    return out
