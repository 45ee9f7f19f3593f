"""Plots of the `calibration` job: polar differential PCV maps on one colour scale (seed 000 Figs. 3-4),
their sample counts, and the calibrated baseline table (seed 000 Table 3 layout).

Public API:
    pcv_maps_figure(maps, kind="values", limit_mm=None, context=None) -> Figure
    pcv_maps_plot(maps, limit_mm=None, context=None) -> PNG;  pcv_counts_plot(maps, context=None) -> PNG
    baselines_table(baselines_json) -> (columns, rows);  baselines_table_plot(baselines_json, context=None) -> PNG
Maps are the CONVENTIONS.md map objects (dicts, or JSON text): platform, pair, frequency, azimuth_deg,
elevation_deg (bin centres), values_mm[i][j] for elevation i and azimuth j (null = too few samples), count,
sigma_mm.
"""
from __future__ import annotations

import json
from typing import Any, Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from gnssatt.plots.common import PlotContext, figure_png, new_figure, no_data, set_title

FREQUENCY_ORDER = ("L1", "L2", "L5", "E1", "E5a", "E5b", "B1", "B2", "B3")


def _as_map(m: Any) -> dict:
    if isinstance(m, (str, bytes)):
        m = json.loads(m)
    return dict(m)


def _edges(centres: np.ndarray, period: float | None = None) -> np.ndarray:
    """Bin edges around bin centres (uniform width = median spacing; one bin: width `period` or 1)."""
    centres = np.asarray(centres, dtype=np.float64)
    if len(centres) > 1:
        width = float(np.median(np.diff(centres)))
    else:
        width = period if period else 1.0
    return np.concatenate([centres - width / 2, [centres[-1] + width / 2]])


def map_grid(m: Mapping[str, Any], kind: str = "values") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta_edges_rad (n_az+1), radius_edges_deg = 90 - elevation edges (n_el+1), grid (n_el, n_az) float
    with NaN for null bins) of one CONVENTIONS.md map; kind "values" (mm), "count" or "sigma" (mm)."""
    key = {"values": "values_mm", "count": "count", "sigma": "sigma_mm"}[kind]
    az = np.asarray(m["azimuth_deg"], dtype=np.float64)
    el = np.asarray(m["elevation_deg"], dtype=np.float64)
    raw = m.get(key)
    if raw is None:
        grid = np.full((len(el), len(az)), np.nan)
    else:
        grid = np.array([[np.nan if v is None else float(v) for v in row] for row in raw], dtype=np.float64)
    if grid.shape != (len(el), len(az)):
        raise ValueError(f"map {m.get('pair')} {m.get('frequency')}: {key} is {grid.shape}, expected "
                         f"(n_elevation, n_azimuth) = {(len(el), len(az))}")
    return np.radians(_edges(az, 360.0)), 90.0 - _edges(el), grid


def _layout(maps: Sequence[dict]) -> tuple[list[str], list[str]]:
    pairs = list(dict.fromkeys("/".join(m["pair"]) for m in maps))
    freqs = sorted({str(m["frequency"]) for m in maps},
                   key=lambda f: (FREQUENCY_ORDER.index(f) if f in FREQUENCY_ORDER else 99, f))
    return pairs, freqs


def pcv_maps_figure(maps: Sequence[Any], kind: str = "values", limit_mm: float | None = None,
                    context: PlotContext | Mapping | None = None) -> Figure:
    """Polar maps, one row per frequency and one column per antenna pair, all on one colour scale.

    Polar axes: azimuth in the antenna frame of the pair's first antenna from x (top) towards y (right),
    radius = 90 - elevation (boresight at the centre). kind "values": differential PCV [mm] on a symmetric
    diverging scale +-limit_mm (default: the largest |value| of all maps, rounded up to 5 mm), as seed 000
    Figs. 3-4 use one scale for all plots; kind "count": samples per bin on one scale from 0. Empty bins stay
    blank, never filled in.
    Implements: CONVENTIONS.md phase-centre-variation map layout and antenna frame.
    """
    maps = [_as_map(m) for m in maps]
    pairs, freqs = _layout(maps)
    fig = new_figure(1.2 + 4.2 * max(len(pairs), 1), 0.9 + 4.0 * max(len(freqs), 1))
    if not maps:
        no_data(fig.add_subplot(), "no PCV maps")
        set_title(fig, "Differential phase-centre variation maps", context)
        return fig
    grids = {("/".join(m["pair"]), str(m["frequency"])): (m, *map_grid(m, kind)) for m in maps}
    values = np.concatenate([g[3].ravel() for g in grids.values()])
    finite = values[np.isfinite(values)]
    if kind == "values":
        if limit_mm is None:
            peak = float(np.max(np.abs(finite))) if finite.size else 1.0
            limit_mm = max(5.0 * np.ceil(peak / 5.0), 5.0)
        vmin, vmax, cmap, label = -limit_mm, limit_mm, "RdBu_r", "differential PCV [mm] (second − first antenna)"
    else:
        vmin, vmax, cmap = 0.0, float(finite.max()) if finite.size else 1.0, "viridis"
        label = "samples per bin" if kind == "count" else "1σ per bin [mm]"
    mesh = None
    axes = []
    for i, f in enumerate(freqs):
        for j, p in enumerate(pairs):
            ax = fig.add_subplot(len(freqs), len(pairs), i * len(pairs) + j + 1, projection="polar")
            axes.append(ax)
            ax.set_theta_zero_location("N")
            ax.set_theta_direction(-1)
            if (p, f) not in grids:
                ax.set_axis_off()
                ax.set_title(f"{p} · {f}: no map", fontsize=9)
                continue
            m, theta, radius, grid = grids[(p, f)]
            mesh = ax.pcolormesh(theta, radius, np.ma.masked_invalid(grid), cmap=cmap, vmin=vmin, vmax=vmax,
                                 shading="flat")
            ax.set_rlim(0, max(90.0, float(radius.max())))
            ticks = [r for r in (0, 30, 60, 90) if r <= radius.max() + 1e-9]
            ax.set_rticks(ticks)
            ax.set_yticklabels([f"{90 - r:.0f}°" for r in ticks], fontsize=7)
            ax.set_xticks(np.radians([0, 90, 180, 270]))
            ax.set_xticklabels(["x 0°", "y 90°", "180°", "270°"], fontsize=8)
            n_bins = int(np.isfinite(grid).sum())
            counts = map_grid(m, "count")[2]
            n_samples = int(np.nansum(counts)) if np.isfinite(counts).any() else 0
            ax.set_title(f"{p} · {f}\n{n_bins} bins filled, {n_samples} samples", fontsize=9)
    if mesh is not None:
        fig.colorbar(mesh, ax=axes, label=label, shrink=0.8)
    what = ("Differential phase-centre variation maps" if kind == "values"
            else "Samples per bin of the PCV maps" if kind == "count" else "1σ of the PCV maps")
    platform = maps[0].get("platform")
    set_title(fig, what + (f", {platform}" if platform else ""), context)
    return fig


def pcv_maps_plot(maps: Sequence[Any], limit_mm: float | None = None,
                  context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of the PCV value maps (`pcv_maps_figure(kind="values")`)."""
    return figure_png(pcv_maps_figure(maps, "values", limit_mm, context))


def pcv_counts_plot(maps: Sequence[Any], context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of the sample-count maps (`pcv_maps_figure(kind="count")`)."""
    return figure_png(pcv_maps_figure(maps, "count", None, context))


def baselines_table(baselines_json: Any) -> tuple[list[str], list[list[str]]]:
    """(columns, rows) of the calibrated baselines (CONVENTIONS.md baselines.json), seed 000 Table 3 style:
    per baseline and body axis the a priori and calibrated component [m], their difference [mm] and 1-sigma
    [mm], and the epochs used."""
    doc = _as_map(baselines_json)
    columns = ["baseline", "axis", "a priori [m]", "calibrated [m]", "difference [mm]", "1σ [mm]", "epochs"]
    rows = []
    for b in doc.get("baselines", []):
        apriori = np.asarray(b.get("a_priori_m", [np.nan] * 3), dtype=float)
        cal = np.asarray(b.get("calibrated_m", [np.nan] * 3), dtype=float)
        sigma = np.asarray(b.get("sigma_m", [np.nan] * 3), dtype=float)
        for k, axis in enumerate("xyz"):
            rows.append([f"{b.get('from')}>{b.get('to')}", axis, f"{apriori[k]:.4f}", f"{cal[k]:.4f}",
                         f"{(cal[k] - apriori[k]) * 1000.0:+.1f}", f"{sigma[k] * 1000.0:.2f}",
                         str(b.get("n_epochs", ""))])
        rows.append([f"{b.get('from')}>{b.get('to')}", "length", f"{np.linalg.norm(apriori):.4f}",
                     f"{np.linalg.norm(cal):.4f}", f"{(np.linalg.norm(cal) - np.linalg.norm(apriori)) * 1000:+.1f}",
                     "", str(b.get("n_epochs", ""))])
    return columns, rows


def table_figure(columns: Sequence[str], rows: Sequence[Sequence[str]], what: str,
                 context: PlotContext | Mapping | None = None, footer: Sequence[Sequence[str]] = ()) -> Figure:
    """A table as a figure (for reports and downloads); footer rows are drawn bold on grey."""
    all_rows = [list(r) for r in rows] + [list(r) for r in footer]
    labels = [_wrap(str(c)) for c in columns]
    fig = new_figure(min(1.3 * len(columns) + 0.6, 18.0), 0.9 + 0.27 * (len(all_rows) + 2))
    ax = fig.add_subplot()
    ax.axis("off")
    if not all_rows:
        no_data(ax, "no rows")
    else:
        n = len(all_rows) + 2  # the header takes two rows' height
        table = ax.table(cellText=all_rows, colLabels=labels, cellLoc="center", bbox=[0.0, 0.0, 1.0, 1.0])
        table.auto_set_font_size(False)
        table.set_fontsize(8)
        for (r, _c), cell in table.get_celld().items():
            cell.set_height((2.0 if r == 0 else 1.0) / n)
            if r == 0:
                cell.set_text_props(weight="bold")
                cell.set_facecolor("#e8eef5")
            elif r > len(rows):
                cell.set_text_props(weight="bold")
                cell.set_facecolor("#f0f0f0")
    set_title(fig, what, context)
    return fig


def _wrap(label: str, width: int = 14) -> str:
    """A long column label broken at the blank nearest its middle (table figures only)."""
    if len(label) <= width or " " not in label:
        return label
    mid = len(label) // 2
    cut = min((i for i, ch in enumerate(label) if ch == " "), key=lambda i: abs(i - mid))
    return label[:cut] + "\n" + label[cut + 1:]


def baselines_table_figure(baselines_json: Any, context: PlotContext | Mapping | None = None) -> Figure:
    """`baselines_table` drawn as a table figure."""
    columns, rows = baselines_table(baselines_json)
    return table_figure(columns, rows, "Calibrated baselines in the body frame (a priori vs calibrated)", context)


def baselines_table_plot(baselines_json: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `baselines_table_figure`."""
    return figure_png(baselines_table_figure(baselines_json, context))


def calibration_plots(maps: Sequence[Any], baselines_json: Any = None,
                      context: PlotContext | Mapping | None = None) -> dict[str, bytes]:
    """{"pcv_maps.png", "pcv_counts.png", "baselines_table.png"} (those the inputs allow)."""
    out: dict[str, bytes] = {}
    if maps:
        out["pcv_maps.png"] = pcv_maps_plot(maps, context=context)
        out["pcv_counts.png"] = pcv_counts_plot(maps, context=context)
    if baselines_json is not None:
        out["baselines_table.png"] = baselines_table_plot(baselines_json, context)
    return out
