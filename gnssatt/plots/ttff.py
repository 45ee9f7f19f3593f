"""Plots of the `ttff` job: the seed 000 Table 5 layout and a time-to-first-fix histogram.

Input `runs`: CSV text, a Table or a list of row dicts, one row per (set, configuration, baseline):
    set            name of the start (test case)
    yaw_deg, pitch_deg, roll_deg   initial offset from the assumed Earth-pointing attitude [deg]
    configuration  "L1L2" / "L1+L2" / "L1/L2", "L1", "L2" (aliases: config, frequencies)
    baseline       e.g. "GPS-0/GPS-2" or "GPS-2>GPS-0"
    ttff_s         time from filter start to the first accepted fix [s]; empty = never fixed
Public API: table5(runs) -> dict; ttff_table_figure / ttff_table_plot; ttff_histogram_figure / ttff_histogram_plot.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np
from matplotlib.figure import Figure

from gnssatt.plots.calibration import table_figure
from gnssatt.plots.common import PlotContext, column, figure_png, new_figure, no_data, numeric, read_csv_table, set_title

CONFIG_ORDER = ("L1/L2", "L1", "L2", "L5")


def config_label(name: str) -> str:
    """'L1L2', 'L1+L2', 'l1/l2' -> 'L1/L2' (seed 000 Table 5 header); others upper-cased."""
    bands = "".join(ch for ch in str(name).upper() if ch.isalnum())
    if bands in ("L1L2", "DUAL"):
        return "L1/L2"
    return bands or "?"


def _runs(runs: Any) -> dict[str, np.ndarray]:
    table = read_csv_table(runs)
    sets = column(table, "set", "case", "set_name")
    n = len(sets) if sets is not None else 0
    cfg = column(table, "configuration", "config", "frequencies")
    base = column(table, "baseline", "pair")
    return {"set": sets.astype(str) if sets is not None else np.array([], str),
            "configuration": np.array([config_label(c) for c in cfg]) if cfg is not None else np.array(["?"] * n),
            "baseline": base.astype(str) if base is not None else np.array(["all"] * n),
            "ttff_s": numeric(table, "ttff_s") if numeric(table, "ttff_s") is not None else np.full(n, np.nan),
            **{f"{a}_deg": (numeric(table, f"{a}_deg") if numeric(table, f"{a}_deg") is not None
                            else np.full(n, np.nan)) for a in ("yaw", "pitch", "roll")}}


def table5(runs: Any) -> dict[str, list]:
    """Seed 000 Table 5 layout: {"columns": [Yaw, Pitch, Roll, "<config> <baseline>" ...],
    "rows": [[yaw, pitch, roll, ttff ...] per set, in order of first appearance; "–" = never fixed],
    "footer": [["Instant fix [%]", "", "", share of TTFF == 0 over all sets per column ...],
               ["Mean TTFF (> 0) [s]", "", "", mean of the non-zero finite TTFFs ...],
               ["No fix", "", "", count of sets never fixed ...]]}.
    Implements: seed 000 sec. 5, Table 5 (percentage of instant fixes, average of non-zero TTFFs)."""
    r = _runs(runs)
    sets = list(dict.fromkeys(r["set"]))
    cfgs = sorted(set(r["configuration"]), key=lambda c: (CONFIG_ORDER.index(c) if c in CONFIG_ORDER else 99, c))
    bases = list(dict.fromkeys(r["baseline"]))
    cols = [(c, b) for c in cfgs for b in bases if ((r["configuration"] == c) & (r["baseline"] == b)).any()]
    grid = np.full((len(sets), len(cols)), np.nan)
    present = np.zeros((len(sets), len(cols)), bool)
    angles = np.full((len(sets), 3), np.nan)
    index = {s: i for i, s in enumerate(sets)}
    col_index = {c: j for j, c in enumerate(cols)}
    for k in range(len(r["set"])):
        i = index[r["set"][k]]
        j = col_index[(r["configuration"][k], r["baseline"][k])]
        grid[i, j] = r["ttff_s"][k]
        present[i, j] = True
        for a, name in enumerate(("yaw_deg", "pitch_deg", "roll_deg")):
            if np.isfinite(r[name][k]):
                angles[i, a] = r[name][k]

    def fmt(v: float, ok: bool) -> str:
        return "" if not ok else ("–" if not np.isfinite(v) else f"{v:.1f}")

    rows = [[f"{angles[i, 0]:.1f}", f"{angles[i, 1]:.1f}", f"{angles[i, 2]:.1f}",
             *[fmt(grid[i, j], present[i, j]) for j in range(len(cols))]] for i in range(len(sets))]
    instant, mean_nonzero, no_fix = [], [], []
    for j in range(len(cols)):
        v = grid[present[:, j], j]
        instant.append(f"{100.0 * np.mean(v == 0):.0f}" if len(v) else "")
        nz = v[np.isfinite(v) & (v > 0)]
        mean_nonzero.append(f"{np.mean(nz):.1f}" if len(nz) else "–")
        no_fix.append(str(int(np.sum(~np.isfinite(v)))))
    return {"columns": ["Yaw [°]", "Pitch [°]", "Roll [°]", *[f"{c} [s] {b}" for c, b in cols]],
            "rows": rows, "sets": sets,
            "footer": [["Instant fix [%]", "", "", *instant], ["Mean TTFF (> 0) [s]", "", "", *mean_nonzero],
                       ["No fix", "", "", *no_fix]]}


def ttff_table_figure(runs: Any, context: PlotContext | Mapping | None = None) -> Figure:
    """`table5` drawn as a table figure."""
    t = table5(runs)
    return table_figure(t["columns"], t["rows"], "Time to first fix per start, baseline and frequency "
                        "configuration (seed 000 Table 5 layout)", context, footer=t["footer"])


def ttff_table_plot(runs: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `ttff_table_figure`."""
    return figure_png(ttff_table_figure(runs, context))


def ttff_histogram_figure(runs: Any, context: PlotContext | Mapping | None = None, bin_s: float = 1.0) -> Figure:
    """Histogram of TTFF [s] in `bin_s` bins (the first bin [0, bin_s) holds the instant fixes), one panel
    per frequency configuration, one bar series per baseline; never-fixed runs are counted in the title."""
    r = _runs(runs)
    cfgs = sorted(set(r["configuration"]), key=lambda c: (CONFIG_ORDER.index(c) if c in CONFIG_ORDER else 99, c))
    fig = new_figure(10.0, 1.2 + 2.3 * max(len(cfgs), 1))
    axes = fig.subplots(max(len(cfgs), 1), 1, squeeze=False, sharex=True)[:, 0]
    if not cfgs:
        no_data(axes[0], "no runs")
    finite = r["ttff_s"][np.isfinite(r["ttff_s"])]
    top = max(float(finite.max()) if finite.size else 1.0, bin_s)
    edges = np.arange(0.0, top + bin_s + 1e-9, bin_s)
    bases = list(dict.fromkeys(r["baseline"]))
    for ax, c in zip(axes, cfgs):
        data, labels = [], []
        never = 0
        for b in bases:
            m = (r["configuration"] == c) & (r["baseline"] == b)
            if not m.any():
                continue
            v = r["ttff_s"][m]
            never += int(np.sum(~np.isfinite(v)))
            data.append(v[np.isfinite(v)])
            labels.append(f"{b}: {100.0 * np.mean(v == 0):.0f}% instant")
        width = bin_s / max(len(data), 1)
        for k, (values, label) in enumerate(zip(data, labels)):
            counts, _ = np.histogram(values, bins=edges)
            ax.bar(edges[:-1] + k * width, counts, width, align="edge", label=label)
        ax.set_ylabel("starts")
        ax.set_title(f"{c}" + (f" · {never} never fixed" if never else ""), fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(axis="y", color="0.88", lw=0.5)
    axes[-1].set_xlabel(f"time to first fix [s] (bins of {bin_s:g} s)")
    set_title(fig, "Time-to-first-fix distribution", context)
    return fig


def ttff_histogram_plot(runs: Any, context: PlotContext | Mapping | None = None) -> bytes:
    """PNG of `ttff_histogram_figure`."""
    return figure_png(ttff_histogram_figure(runs, context))


def ttff_plots(runs: Any, context: PlotContext | Mapping | None = None) -> dict[str, bytes]:
    """{"ttff_table.png", "ttff_histogram.png"}."""
    return {"ttff_table.png": ttff_table_plot(runs, context), "ttff_histogram.png": ttff_histogram_plot(runs, context)}
