"""gnssatt.plots.elevation: residual RMS and C/N0 median per elevation bin recomputed from the rows built here;
the fix-status sky plot colours each epoch-satellite point by its baseline's fixed flag."""
from __future__ import annotations

import numpy as np

from gnssatt.plots.elevation import binned, elevation_figure, fix_skyplot_figure


def _tables(n_ep=200, sats=6, seed=1):
    rng = np.random.default_rng(seed)
    t0 = np.datetime64("2020-01-01T00:00:00", "ms")
    rows = {k: [] for k in ("time_gps", "baseline", "sat", "signal", "observable", "residual_m", "az_ant_deg",
                            "el_ant_deg", "cn0_dbhz", "used")}
    for e in range(n_ep):
        for s in range(sats):
            el = 5.0 + 80.0 * s / sats + 0.05 * e
            for sig in ("L1", "L2"):
                for obs in ("code", "phase"):
                    rows["time_gps"].append(t0 + np.timedelta64(e * 1000, "ms"))
                    rows["baseline"].append("A>B")
                    rows["sat"].append(f"G{s + 1:02d}")
                    rows["signal"].append(sig)
                    rows["observable"].append(obs)
                    scale = 0.004 * (1 + (90 - el) / 30) if obs == "phase" else 0.5
                    rows["residual_m"].append(rng.normal(0, scale))
                    rows["az_ant_deg"].append(37.0 * s)
                    rows["el_ant_deg"].append(el if e >= 10 else np.nan)       # no direction before the fix
                    rows["cn0_dbhz"].append(30 + el / 4 + (0 if sig == "L1" else -5))
                    rows["used"].append(1.0)
    res = {k: np.array(v) for k, v in rows.items()}
    res["time_gps"] = np.array(rows["time_gps"], dtype="datetime64[ms]")
    bl = {"time_gps": t0 + np.arange(n_ep) * np.timedelta64(1000, "ms"), "baseline": np.array(["A>B"] * n_ep),
          "fixed": (np.arange(n_ep) >= 30).astype(float)}
    return res, bl


def test_binned_statistics():
    el = np.array([1.0, 2.0, 7.0, 8.0, 9.0])
    v = np.array([3.0, 4.0, 1.0, 2.0, 10.0])
    c, rms, n = binned(el, v)
    i0, i1 = np.searchsorted(c, 2.5), np.searchsorted(c, 7.5)
    assert n[i0] == 2 and abs(rms[i0] - np.sqrt((9 + 16) / 2)) < 1e-12
    c, med, n = binned(el, v, "median")
    assert med[i1] == 2.0 and n[i1] == 3


def test_elevation_figure_draws_the_bins_of_the_rows():
    res, _ = _tables()
    fig = elevation_figure(res)
    ax_r, ax_c = fig.axes[:2]
    lines = {l.get_label(): l for l in ax_r.get_lines()}
    line = lines["L1: RMS per 5° bin"]
    m = (res["signal"] == "L1") & (res["observable"] == "phase") & np.isfinite(res["el_ant_deg"])
    c, rms, n = binned(res["el_ant_deg"][m], 1e3 * res["residual_m"][m])
    ok = n >= 10
    assert np.allclose(line.get_xdata(), c[ok]) and np.allclose(line.get_ydata(), rms[ok])
    med = {l.get_label(): l for l in ax_c.get_lines()}["L2: median"]
    assert np.all(np.diff(med.get_ydata()) > 0)              # C/N0 grows with elevation, as built
    assert "mm" in ax_r.get_ylabel() and "dB-Hz" in ax_c.get_ylabel()


def test_fix_skyplot_colours_by_fix_status():
    res, bl = _tables()
    fig = fix_skyplot_figure(res, bl)
    ax = fig.axes[0]
    labels = ax.get_legend_handles_labels()[1]
    # one point per epoch and satellite with a direction: epochs 10..29 float, 30.. fixed, 6 satellites
    assert labels == [f"float ({20 * 6})", f"fixed ({170 * 6})"]
    assert "60 epoch-satellite rows without an antenna-frame direction" in ax.get_title()
