"""Plots against the antenna frame's elevation, as RTKPLOT and the online PPP services show them: residuals and
C/N0 versus elevation per baseline (with the RMS / median in 5-degree bins), and a sky plot coloured by the
baseline's fix status.

Inputs are the attitude job's residuals.csv (long layout: time_gps, baseline, sat, signal, observable,
residual_m, az_ant_deg, el_ant_deg, cn0_dbhz, used) and baselines.csv (time_gps, baseline, fixed), as text or
column tables (gnssatt.plots.common.Table).
Implements: elevation and azimuth in the antenna frame of the baseline's first antenna (CONVENTIONS.md); bin
statistic RMS = sqrt(mean r^2) of the used residuals in each 5-degree elevation bin.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np
from matplotlib.figure import Figure

from gnssatt.plots.common import (Margins, PlotContext, axes_pixels, categories, column, figure_png,
                                  first_per_epoch_and_key, gps_time, new_figure, no_data, numeric, polar_screen_points,
                                  read_csv_table, screen_points, set_title, truthy)

__all__ = ["elevation_figure", "elevation_plot", "fix_skyplot_figure", "fix_skyplot_plot", "binned"]

BIN_DEG = 5.0

def _drawn(ax, rows: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The rows of a scatter the panel shows apart (gnssatt.plots.common.screen_points; the bin statistics use
    every row)."""
    return rows[screen_points(x[rows], y[rows], *axes_pixels(ax))]


def binned(el_deg: np.ndarray, values: np.ndarray, stat: str = "rms", bin_deg: float = BIN_DEG):
    """(bin centres deg, statistic, count) of values in elevation bins of bin_deg from -90 to 90; stat "rms" or
    "median"; empty bins are NaN."""
    edges = np.arange(-90.0, 90.0 + bin_deg, bin_deg)
    k = np.clip(np.digitize(el_deg, edges) - 1, 0, len(edges) - 2)
    n = np.bincount(k, minlength=len(edges) - 1)
    if stat == "rms":
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.sqrt(np.bincount(k, weights=values ** 2, minlength=len(edges) - 1) / n)
    else:
        out = np.full(len(edges) - 1, np.nan)
        order = np.argsort(k, kind="stable")
        bounds = np.searchsorted(k[order], np.arange(len(edges)))
        for b in np.flatnonzero(n):
            out[b] = float(np.median(values[order[bounds[b]:bounds[b + 1]]]))
    return 0.5 * (edges[:-1] + edges[1:]), out, n


def _columns(res):
    """(phase mask, used, phase residual [mm], elevation [deg], C/N0) per row of residuals.csv in the long layout
    (observable + residual_m) or the wide one (phase_residual_mm / phase_residual_m per row)."""
    n = len(column(res, "time_gps"))
    used = column(res, "used")
    used = np.ones(n, bool) if used is None else truthy(used)
    kind, r = column(res, "observable"), numeric(res, "residual_m")
    if kind is not None and r is not None:
        kinds, kind_code = categories(kind)
        phase = np.isin(kind_code, [i for i, k in enumerate(kinds) if k.lower() == "phase"])
        phase_mm = 1e3 * r
    else:
        mm, m = numeric(res, "phase_residual_mm"), numeric(res, "phase_residual_m")
        phase_mm = mm if mm is not None else (1e3 * m if m is not None else np.full(n, np.nan))
        phase = np.ones(n, bool)
    el = numeric(res, "el_ant_deg", "elevation_deg", "elevation_antenna_deg", "el_deg")
    cn0 = numeric(res, "cn0_dbhz", "cn0", "snr_dbhz")
    return (phase, used, phase_mm, np.full(n, np.nan) if el is None else el,
            np.full(n, np.nan) if cn0 is None else cn0)


def _signals(res, n: int) -> tuple[list[str], np.ndarray]:
    sig = column(res, "signal", "code", "frequency")
    return categories(sig) if sig is not None else (["all"], np.zeros(n, dtype=np.int64))


def elevation_figure(residuals_csv: Any, context: PlotContext | Mapping | None = None) -> Figure:
    """Per baseline (rows): used phase residuals [mm] vs antenna elevation with the RMS per 5-deg bin (left),
    C/N0 [dB-Hz] vs antenna elevation with the median per bin (right), one colour per signal."""
    res = read_csv_table(residuals_csv)
    t = column(res, "time_gps")
    base = column(res, "baseline")
    names, code = categories(base) if base is not None and t is not None and len(t) else ([], None)
    fig = new_figure(11.0, 1.4 + 2.7 * max(len(names), 1),
                     Margins(left=0.75, top=0.95, hgap=0.85, wgap=0.85, rows=max(len(names), 1), cols=2))
    axes = fig.subplots(max(len(names), 1), 2, squeeze=False)
    title = "Residuals and C/N0 versus elevation in the antenna frame"
    if not names:
        for a in axes[0]:
            no_data(a, "no residuals")
        set_title(fig, title, context)
        return fig
    phase, used, r_mm, el, cn0 = _columns(res)
    sig_names, sig_code = _signals(res, len(t))
    for row, name in enumerate(names):
        ax_r, ax_c = axes[row]
        for s, sig in enumerate(sig_names):
            m = np.flatnonzero((code == row) & (sig_code == s) & used & phase & np.isfinite(r_mm) & np.isfinite(el))
            if m.size:
                k = _drawn(ax_r, m, el, r_mm)
                colour = f"C{s % 10}"
                ax_r.plot(el[k], r_mm[k], ".", ms=1.2, color=colour, alpha=0.35)
                c, rms, n = binned(el[m], r_mm[m])
                ok = n >= 10
                ax_r.plot(c[ok], rms[ok], "-o", ms=3, lw=1.2, color=colour, label=f"{sig}: RMS per {BIN_DEG:g}° bin")
            mc = np.flatnonzero((code == row) & (sig_code == s) & phase & np.isfinite(cn0) & np.isfinite(el))
            if mc.size:
                mc = first_per_epoch_and_key(gps_time(res), sig_code, mc)
                k = _drawn(ax_c, mc, el, cn0)
                ax_c.plot(el[k], cn0[k], ".", ms=1.2, color=f"C{s % 10}", alpha=0.35)
                c, med, n = binned(el[mc], cn0[mc], "median")
                ok = n >= 10
                ax_c.plot(c[ok], med[ok], "-o", ms=3, lw=1.2, color=f"C{s % 10}", label=f"{sig}: median")
        ax_r.set_ylabel("phase residual [mm]")
        ax_c.set_ylabel("C/N0 [dB-Hz]")
        for ax, what in ((ax_r, "phase residuals (used)"), (ax_c, "C/N0")):
            ax.set_title(f"{name} · {what}", fontsize=8)
            ax.set_xlabel("elevation in the antenna frame [deg]")
            ax.grid(color="0.88", lw=0.5)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7, loc="best")
    set_title(fig, title, context)
    return fig


def elevation_plot(residuals_csv: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `elevation_figure`."""
    return figure_png(elevation_figure(residuals_csv, context))


def fix_skyplot_figure(residuals_csv: Any, baselines_csv: Any, context: PlotContext | Mapping | None = None) -> Figure:
    """Sky plot per baseline in the antenna frame (as gnssatt.plots.attitude.skyplot_figure), each
    epoch-satellite point coloured by the baseline's fix status at that epoch (green fixed, orange float). Rows
    without an antenna-frame direction (epochs before the attitude is known) are counted in the panel title."""
    res, bl = read_csv_table(residuals_csv), read_csv_table(baselines_csv)
    t = column(res, "time_gps")
    base = column(res, "baseline")
    names, code = categories(base) if base is not None and t is not None and len(t) else ([], None)
    n = max(len(names), 1)
    fig = new_figure(4.4 * n + 0.6, 5.0, Margins(left=0.55, right=0.55, top=1.25, bottom=0.3, wgap=1.1, cols=n))
    axes = [fig.add_subplot(1, n, i + 1, projection="polar") for i in range(n)]
    title = "Sky plot in the antenna frame by fix status (green fixed, orange float)"
    if not names:
        no_data(axes[0], "no residuals")
        set_title(fig, title, context)
        return fig
    tr = gps_time(res).astype(np.int64)
    tb = gps_time(bl).astype(np.int64) if column(bl, "time_gps") is not None else np.zeros(0, np.int64)
    bl_names = np.asarray(column(bl, "baseline") if column(bl, "baseline") is not None else [], dtype=str)
    fixed_b = truthy(column(bl, "fixed")) if column(bl, "fixed") is not None else np.zeros(len(tb), bool)
    nan = np.full(len(tr), np.nan)
    az = numeric(res, "az_ant_deg", "azimuth_deg", "azimuth_antenna_deg", "az_deg")
    el = numeric(res, "el_ant_deg", "elevation_deg", "elevation_antenna_deg", "el_deg")
    az, el = (nan if az is None else az), (nan if el is None else el)
    sat = column(res, "sat", "satellite", "prn")
    _, sat_code = categories(sat) if sat is not None else ([], np.zeros(len(tr), dtype=np.int64))
    for j, (ax, name) in enumerate(zip(axes, names)):
        mb = bl_names == name
        order = np.argsort(tb[mb], kind="stable")
        tbj, fbj = tb[mb][order], fixed_b[mb][order]
        rows = first_per_epoch_and_key(gps_time(res), sat_code,
                                       np.flatnonzero((code == j) & np.isfinite(az) & np.isfinite(el)))
        pos = np.clip(np.searchsorted(tbj, tr[rows]), 0, max(len(tbj) - 1, 0))
        fx = (tbj[pos] == tr[rows]) & fbj[pos] if len(tbj) else np.zeros(len(rows), bool)
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        for mask, colour, label in ((~fx, "#ff7f0e", "float"), (fx, "#2ca02c", "fixed")):
            k = rows[mask][polar_screen_points(ax, az[rows[mask]], 90.0 - el[rows[mask]])]
            ax.scatter(np.radians(az[k]), 90.0 - el[k], s=3, color=colour, linewidths=0,
                       label=f"{label} ({int(mask.sum())})")
        r_max = max(90.0, 90.0 - float(np.min(el[rows])) + 2.0) if len(rows) else 90.0
        ax.set_rlim(0, r_max)
        ticks = [r for r in (0, 30, 60, 90, 120) if r <= r_max]
        ax.set_rticks(ticks)
        ax.set_yticklabels([f"{90 - r:.0f}°" for r in ticks], fontsize=7)
        ax.set_xticks(np.radians([0, 90, 180, 270]))
        ax.set_xticklabels(["x 0°", "y 90°", "180°", "270°"], fontsize=8)
        no_dir = first_per_epoch_and_key(gps_time(res), sat_code, np.flatnonzero((code == j) & ~np.isfinite(el)))
        note = (f"\n{len(no_dir)} epoch-satellite rows without an antenna-frame direction (no attitude yet)"
                if len(no_dir) else "")
        ax.set_title(f"{name} (antenna frame of {name.split('>')[0]}){note}", fontsize=8)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(-0.12, 1.0), markerscale=3)
    set_title(fig, title, context)
    return fig


def fix_skyplot_plot(residuals_csv: Any, baselines_csv: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `fix_skyplot_figure`."""
    return figure_png(fix_skyplot_figure(residuals_csv, baselines_csv, context))
