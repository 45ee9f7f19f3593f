"""charts.json of an attitude job: the job page's interactive series, computed once by the worker so the browser
draws a full pass without parsing the CSVs (residuals.csv of a 106-minute pass is ~6e5 rows).

Layout (docs/pages.md "charts.json"): {"version": 1, "time_system": "GPS", "gps_minus_utc_s": int,
"charts": [{"id", "title", "y" (unit), "x" (GPS seconds since 1970-01-01 as written, no leap shift),
"fixed" (1/0 per x or absent), "series": [{"label", "values", "role"?, "scale"?, "step"?, "points"?}]}]}.
Every series is at full per-epoch resolution (one value per epoch is what the CSV charts drew); numbers are
rounded to the CSVs' digits, NaN -> null.

Implements: per-epoch RMS of the used single-difference residuals, sqrt(sum r^2 / n), per baseline and signal
(as app/static/charts.js did from residuals.csv).
"""
from __future__ import annotations

import numpy as np

__all__ = ["chart_series", "gps_minus_utc_s"]

AXES = ("yaw", "pitch", "roll")
#: GPS - UTC [s] from these UTC dates on (IERS Bulletin C); enough for the time axis' UTC option
_LEAPS = (("1999-01-01", 13), ("2006-01-01", 14), ("2009-01-01", 15), ("2012-07-01", 16), ("2015-07-01", 17),
          ("2017-01-01", 18))


def gps_minus_utc_s(t_ms: np.ndarray) -> int:
    """GPS - UTC [s] at the first time of t_ms (datetime64[ms], GPS time): the leap seconds in force."""
    if t_ms.size == 0:
        return 18
    first = t_ms[0]
    n = 13
    for day, leap in _LEAPS:
        if first >= np.datetime64(day):
            n = leap
    return n


def _values(a, digits: int) -> list:
    a = np.round(np.asarray(a, dtype=np.float64), digits)
    out = a.astype(object)
    out[~np.isfinite(a)] = None
    return out.tolist()


def _seconds(t_ms: np.ndarray) -> list:
    return (t_ms.astype("datetime64[ms]").astype(np.int64) / 1000.0).tolist()


def _attitude_charts(sol, ref, x, fixed) -> list[dict]:
    charts = []
    series = [{"label": a, "values": _values(sol.euler_deg[:, i], 5), "axis": a} for i, a in enumerate(AXES)]
    if ref is not None:
        series += [{"label": f"{a} reference", "values": _values(ref.euler_ref_deg[:, i], 5), "axis": a,
                    "role": "reference"} for i, a in enumerate(AXES)]
    charts.append({"id": "euler", "title": "Euler angles (3-2-1) [deg]" + (" with the reference" if ref is not None
                                                                          else ""),
                   "y": "deg", "x": x, "fixed": fixed, "series": series})
    if ref is not None:
        charts.append({"id": "errors", "title": "Euler angle errors (estimate − reference) [deg]", "y": "deg", "x": x,
                       "fixed": fixed, "series": [{"label": f"{a} error", "values": _values(ref.error_deg[:, i], 5),
                                                   "axis": a, "points": True} for i, a in enumerate(AXES)]})
    charts.append({"id": "sigma", "title": "Formal 1σ of the Euler angles [deg]", "y": "deg", "x": x,
                   "fixed": fixed, "series": [{"label": f"σ {a}", "values": _values(sol.sigma_euler_deg[:, i], 5),
                                               "axis": a} for i, a in enumerate(AXES)]})
    charts.append({"id": "fix", "title": "Fix status and satellites used", "y": "satellites", "y2": "fixed", "x": x,
                   "series": [{"label": "satellites used", "values": np.asarray(sol.att_n_sats, int).tolist()},
                              {"label": "fixed (1) / float (0)", "values": fixed, "scale": "fix", "step": True}]})
    return charts


def _baseline_charts(sol, t_ep, n_ep) -> list[dict]:
    bt = sol.baseline_table
    names = [f"{a}>{b}" for a, b in sol.baselines]
    ep_all = np.unique(bt["epoch"])
    if ep_all.size == 0:
        return []
    pos = np.searchsorted(ep_all, bt["epoch"])
    x = _seconds(t_ep[ep_all])
    charts = []
    for col, title, digits in (("azimuth_deg", "Baseline azimuth (heading) [deg]", 4),
                               ("elevation_deg", "Baseline elevation [deg]", 4), ("length_m", "Baseline length [m]", 5)):
        grid = np.full((len(names), ep_all.size), np.nan)
        grid[bt["bl"], pos] = bt[col]
        fx = np.zeros((len(names), ep_all.size), bool)
        fx[bt["bl"], pos] = bt["fixed"]
        charts.append({"id": f"baseline_{col}", "title": title, "y": "m" if col.endswith("_m") else "deg", "x": x,
                       "fixed": fx.all(axis=0).astype(int).tolist(),
                       "series": [{"label": n, "values": _values(grid[j], digits)} for j, n in enumerate(names)]})
    return charts


def _residual_charts(sol, t_ep, n_ep, fixed_ep) -> list[dict]:
    r = sol.fr.residuals
    if r["epoch"].size == 0:
        return []
    used = (r["reason"] == 0) & np.isfinite(r["residual_m"])
    n_sig = len(sol.pobs.signals)
    names = [f"{a}>{b}" for a, b in sol.baselines]
    charts = []
    for kind, title, scale, unit, digits in ((1, "Phase residual RMS per epoch [mm]", 1e3, "mm", 2),
                                             (0, "Code residual RMS per epoch [m]", 1.0, "m", 4)):
        m = used & (r["kind"] == kind)
        key = (r["bl"][m] * n_sig + r["sig"][m]) * n_ep + r["epoch"][m]
        size = len(names) * n_sig * n_ep
        ss = np.bincount(key, weights=(r["residual_m"][m] * scale) ** 2, minlength=size).reshape(-1, n_ep)
        cnt = np.bincount(key, minlength=size).reshape(-1, n_ep)
        any_ep = np.flatnonzero(cnt.sum(axis=0) > 0)
        if any_ep.size == 0:
            continue
        with np.errstate(invalid="ignore", divide="ignore"):
            rms = np.sqrt(ss / cnt)
        series = []
        for j, bl in enumerate(names):
            for s, sig in enumerate(sol.pobs.signals):
                row = rms[j * n_sig + s, any_ep]
                if np.isfinite(row).any():
                    series.append({"label": f"{bl} {sig}", "values": _values(row, digits)})
        charts.append({"id": f"residual_{unit}", "title": title, "y": unit, "x": _seconds(t_ep[any_ep]),
                       "fixed": fixed_ep[any_ep].astype(int).tolist(), "series": series})
    return charts


def chart_series(sol, ref=None) -> dict:
    """The charts.json document of an AttitudeSolution (see module docstring); ref is
    gnssatt.attitude.quality.reference_series(sol) or None."""
    iso = sol.pobs.time.iso(3)
    t_ep = np.array(iso if isinstance(iso, list) else [iso], dtype="datetime64[ms]")
    n_ep = t_ep.size
    fixed_ep = np.asarray(sol.fr.fixed, bool).all(axis=1) if sol.fr.fixed.ndim == 2 else np.asarray(sol.fr.fixed)
    charts: list[dict] = []
    if sol.att_epochs is not None and sol.att_epochs.size:
        x = _seconds(t_ep[sol.att_epochs])
        charts += _attitude_charts(sol, ref, x, np.asarray(sol.att_fixed, int).tolist())
    charts += _baseline_charts(sol, t_ep, n_ep)
    charts += _residual_charts(sol, t_ep, n_ep, fixed_ep)
    return {"version": 1, "time_system": "GPS", "gps_minus_utc_s": gps_minus_utc_s(t_ep), "charts": charts}
