"""Plots of the `inspect` job: satellite tracking coloured by C/N0, and a C/N0 overview per satellite.

Public API:
    tracking_arrays(obs, name=None) -> dict          arrays of one receiver (from a RinexObs)
    tracking_series_csv(receivers) -> str            tracking.csv: per receiver and epoch, satellites and mean C/N0
    tracking_figure(receivers, context=None) -> Figure;  tracking_plot(...) -> PNG bytes
    cn0_overview_figure(observations_csv, context=None) -> Figure;  cn0_overview_plot(...) -> PNG bytes
"""
from __future__ import annotations

import csv
import io
from typing import Any, Mapping, Sequence

import numpy as np
from matplotlib import dates as mdates
from matplotlib.figure import Figure

from gnssatt.plots.common import (PlotContext, column, figure_png, new_figure, no_data, numeric, read_csv_table,
                                 set_title, time_axis)

SECONDS_PER_WEEK = 604800
#: Most time columns drawn in a tracking panel; longer files are shown in blocks (tracked if any epoch of
#: the block is, C/N0 the block mean). 1500 columns is more than a 10-inch figure at 100 dpi resolves.
MAX_COLUMNS = 1500


def tracking_arrays(obs, name: str | None = None) -> dict[str, Any]:
    """Tracking of one receiver as arrays, from a RinexObs (gnssatt.gnss.io.rinex_obs).

    Returns {"name", "time" datetime64[ms] (n_epochs,) GPS time, "gps_week" int (n_epochs,), "gps_sow" s,
    "sats" list (n_sats), "tracked" bool (n_epochs, n_sats) where any code or phase is observed,
    "cn0_dbhz" float (n_epochs, n_sats): the first C/N0 code (S..) of each satellite's system in header
    order (the L1 signal in practice), NaN where absent or not positive}.
    Implements: RINEX 3.05 sec. 5.1 observation codes (C code, L phase, S signal strength).
    """
    n_epochs, n_sats = len(obs.time), len(obs.sats)
    codes = list(obs.codes)
    cp = [i for i, c in enumerate(codes) if c[:1] in ("C", "L", "P")]
    tracked = np.isfinite(obs.values[:, :, cp]).any(axis=2) if cp else np.zeros((n_epochs, n_sats), bool)
    cn0 = np.full((n_epochs, n_sats), np.nan)
    for j, sat in enumerate(obs.sats):
        types = obs.header.obs_types.get(sat[0]) or codes
        s_codes = [c for c in types if c.startswith("S") and c in codes]
        if s_codes:
            vals = obs.values[:, j, codes.index(s_codes[0])]
            cn0[:, j] = np.where(vals > 0, vals, np.nan)
    whole_s = np.asarray(obs.time.s, dtype=np.int64)
    frac_s = np.asarray(obs.time.frac, dtype=np.float64)
    iso = obs.time.iso() if n_epochs else []
    return {"name": name or obs.header.marker_name or obs.name or "receiver",
            "time": np.array([str(t) for t in iso], dtype="datetime64[ms]"),
            "gps_week": whole_s // SECONDS_PER_WEEK, "gps_sow": (whole_s % SECONDS_PER_WEEK) + frac_s,
            "sats": list(obs.sats), "tracked": tracked, "cn0_dbhz": cn0}


def tracking_series_csv(receivers: Sequence[Mapping[str, Any]]) -> str:
    """`tracking.csv`: one row per receiver and epoch: time_gps, gps_week, gps_sow, receiver, n_sats
    (satellites with any code or phase), mean_cn0_dbhz (mean over tracked satellites of the first C/N0 code,
    empty when none). Feeds the job page's interactive chart."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["time_gps", "gps_week", "gps_sow", "receiver", "n_sats", "mean_cn0_dbhz"])
    for rx in receivers:
        tracked = np.asarray(rx["tracked"], dtype=bool)
        cn0 = np.where(tracked, np.asarray(rx["cn0_dbhz"], dtype=np.float64), np.nan)
        n = tracked.sum(axis=1)
        with np.errstate(invalid="ignore"):
            counts = np.isfinite(cn0).sum(axis=1)
            mean = np.where(counts > 0, np.nansum(cn0, axis=1) / np.maximum(counts, 1), np.nan)
        times = np.datetime_as_string(np.asarray(rx["time"], dtype="datetime64[ms]"), unit="ms")
        for k in range(len(times)):
            w.writerow([times[k], int(rx["gps_week"][k]), f"{float(rx['gps_sow'][k]):.3f}", rx["name"], int(n[k]),
                        "" if not np.isfinite(mean[k]) else f"{mean[k]:.2f}"])
    return buf.getvalue()


def _blocks(time: np.ndarray, tracked: np.ndarray, cn0: np.ndarray):
    """Time edges (matplotlib date numbers, n+1) and per-column tracked/C/N0 after block-averaging."""
    t = mdates.date2num(time.astype("datetime64[ms]")) if len(time) else np.zeros(0)
    n = len(t)
    step = int(np.ceil(n / MAX_COLUMNS)) if n > MAX_COLUMNS else 1
    if step > 1:
        starts = np.arange(0, n, step)
        tracked_b = np.add.reduceat(tracked.astype(np.int64), starts, axis=0) > 0
        finite = np.isfinite(cn0)
        sums = np.add.reduceat(np.where(finite, cn0, 0.0), starts, axis=0)
        counts = np.add.reduceat(finite.astype(np.int64), starts, axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            cn0_b = np.where(counts > 0, sums / counts, np.nan)
        t_b = t[starts]
    else:
        tracked_b, cn0_b, t_b = tracked, cn0, t
    if len(t_b) > 1:
        dt = np.median(np.diff(t_b))
    else:
        dt = 1.0 / 86400.0
    edges = np.concatenate([t_b - dt / 2, [t_b[-1] + dt / 2]]) if len(t_b) else np.zeros(1)
    return edges, tracked_b, cn0_b


def tracking_figure(receivers: Sequence[Mapping[str, Any]], context: PlotContext | Mapping | None = None) -> Figure:
    """One panel per receiver: satellites (rows) against GPS time, each tracked epoch coloured by its C/N0
    (grey where tracked without C/N0, blank where not tracked); one C/N0 colour scale for all panels.

    receivers: dicts as `tracking_arrays` returns (name, time, sats, tracked, cn0_dbhz).
    """
    n_rx = max(len(receivers), 1)
    height = min(2.0 + 0.13 * sum(len(r["sats"]) for r in receivers) + 0.6 * n_rx, 30.0)
    fig = new_figure(10.0, max(height, 3.5))
    axes = fig.subplots(n_rx, 1, sharex=True, squeeze=False)[:, 0]
    all_cn0 = np.concatenate([np.asarray(r["cn0_dbhz"], float).ravel() for r in receivers]) if receivers else []
    finite = np.asarray(all_cn0)[np.isfinite(all_cn0)] if len(all_cn0) else np.zeros(0)
    vmin, vmax = (float(np.floor(finite.min())), float(np.ceil(finite.max()))) if finite.size else (20.0, 55.0)
    if vmax <= vmin:
        vmax = vmin + 1.0
    mesh = None
    for ax, rx in zip(axes, receivers):
        tracked = np.asarray(rx["tracked"], dtype=bool)
        cn0 = np.where(tracked, np.asarray(rx["cn0_dbhz"], dtype=np.float64), np.nan)
        time = np.asarray(rx["time"], dtype="datetime64[ms]")
        sats = list(rx["sats"])
        if not len(time) or not sats:
            no_data(ax, f"{rx['name']}: no observations")
            continue
        edges, tracked_b, cn0_b = _blocks(time, tracked, cn0)
        y_edges = np.arange(len(sats) + 1) - 0.5
        grey = np.where(tracked_b & ~np.isfinite(cn0_b), 1.0, np.nan)
        ax.pcolormesh(edges, y_edges, grey.T, cmap="Greys", vmin=0.0, vmax=2.0, shading="flat")
        mesh = ax.pcolormesh(edges, y_edges, cn0_b.T, cmap="viridis", vmin=vmin, vmax=vmax, shading="flat")
        ax.set_yticks(np.arange(len(sats)))
        ax.set_yticklabels(sats, fontsize=7)
        ax.set_ylim(len(sats) - 0.5, -0.5)
        ax.set_ylabel(f"{rx['name']}\nsatellite")
        ax.xaxis_date()
        time_axis(ax, time, label=ax is axes[-1])
        ax.grid(axis="x", color="0.85", lw=0.5)
    if mesh is not None:
        fig.colorbar(mesh, ax=list(axes), label="C/N0 [dB-Hz]", shrink=0.9)
    if not receivers:
        no_data(axes[0], "no observation files")
    set_title(fig, "Tracking per receiver and satellite, coloured by C/N0", context)
    return fig


def tracking_plot(receivers: Sequence[Mapping[str, Any]], context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `tracking_figure`."""
    return figure_png(tracking_figure(receivers, context))


def cn0_overview_figure(observations_csv: str | bytes | Any,
                        context: PlotContext | Mapping | None = None) -> Figure:
    """Mean C/N0 per satellite, one panel per signal, one bar per receiver (so a weak antenna stands out).

    observations_csv: the inspect job's observations.csv (columns receiver, satellite, signal,
        mean_cn0_dbhz; rows without C/N0 are left out).
    """
    table = read_csv_table(observations_csv)
    rx_col, sat_col, sig_col = column(table, "receiver"), column(table, "satellite"), column(table, "signal")
    cn0 = numeric(table, "mean_cn0_dbhz")
    signals: list[str] = []
    if rx_col is not None and cn0 is not None:
        ok = np.isfinite(cn0)
        signals = sorted({str(s) for s in sig_col[ok]})
    fig = new_figure(10.0, 1.2 + 2.4 * max(len(signals), 1))
    axes = fig.subplots(max(len(signals), 1), 1, squeeze=False)[:, 0]
    if not signals:
        no_data(axes[0], "no C/N0 observations (no S codes in the files)")
    receivers = sorted({str(r) for r in rx_col}) if rx_col is not None else []
    for ax, sig in zip(axes, signals):
        sel = (sig_col.astype(str) == sig) & np.isfinite(cn0)
        sats = sorted({str(s) for s in sat_col[sel]})
        x = np.arange(len(sats))
        width = 0.8 / max(len(receivers), 1)
        for k, rx in enumerate(receivers):
            heights = np.full(len(sats), np.nan)
            for i, s in enumerate(sats):
                m = sel & (rx_col.astype(str) == rx) & (sat_col.astype(str) == s)
                if m.any():
                    heights[i] = float(cn0[m][0])
            ax.bar(x - 0.4 + width * (k + 0.5), np.nan_to_num(heights, nan=0.0), width, label=rx)
        ax.set_xticks(x)
        ax.set_xticklabels(sats, fontsize=7, rotation=90 if len(sats) > 20 else 0)
        ax.set_ylabel(f"{sig}: mean C/N0 [dB-Hz]")
        finite = cn0[sel]
        ax.set_ylim(max(0.0, float(np.nanmin(finite)) - 5.0), float(np.nanmax(finite)) + 3.0)
        ax.grid(axis="y", color="0.85", lw=0.5)
        ax.legend(fontsize=7, ncols=min(len(receivers), 6), loc="lower right")
    axes[-1].set_xlabel("satellite")
    set_title(fig, "Mean C/N0 per satellite, signal and receiver", context)
    return fig


def cn0_overview_plot(observations_csv: str | bytes | Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `cn0_overview_figure`."""
    return figure_png(cn0_overview_figure(observations_csv, context))
