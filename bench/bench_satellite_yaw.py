"""Satellite-yaw benchmark (issue 17 "Done when"): a simulated month of a QZS-2-like satellite with two transmitting
antennas over a network of ground stations, through an eclipse season (pseudo-yaw steering at 0.055 deg/s),
one orbit-normal manoeuvre (Fig. 8) and one 360 deg turn (Fig. 5).

    .venv/bin/python -m bench.bench_satellite_yaw [--days 30] [--stations 20] [--interval 30] [--repeats 1]
                                                  [--figures DIR]

Steps and what is measured against the simulator's truth (gnssatt/sim/satellite_pair.py):
1. baseline + differential PCV map (estimate_baseline) with the model yaw, the manoeuvre and the turn left out
   (as seed 004 leaves out non-nominal periods): error, sigma and error/sigma per component; the map's RMS
   against the truth pattern (both without the four functions the baseline and arc constants absorb);
2. per-epoch yaw (estimate_yaw) with the estimated baseline and map: RMS error overall, through the rate-limited
   midnight/noon turns and through the orbit-normal manoeuvre, RMS(error/sigma);
3. mode switches (detect_mode_switches) against the events the simulator flew;
4. the triple-frequency combination (eq. 3-9, no PCV map): its yaw error next to the single-frequency one, and
   the formal sigma ratio against eq. 8's noise factor / k1.
Prints a JSON record (with the machine and wall times: median of --repeats for the estimators) and, with
--figures, writes the plots used in docs/satellite_yaw.md.
"""
from __future__ import annotations

import argparse
import json
import os
import platform as _platform
import time
from pathlib import Path

import numpy as np

from gnssatt.satyaw.attitude_models import model_yaw_deg, wrap_deg
from gnssatt.satyaw.baseline_estimator import BaselineOptions, estimate_baseline, unobservable_basis
from gnssatt.satyaw.differential import body_los, nadir_azimuth_deg
from gnssatt.satyaw.mode_switch import detect_mode_switches
from gnssatt.satyaw.triple_frequency import noise_factor, table2_coefficients
from gnssatt.satyaw.yaw_estimator import estimate_yaw
from gnssatt.sim.satellite_pair import SatPairScenario, pcv_truth_mm, simulate_satellite_pair

DAY = 86400.0


def scenario(days: float, stations: int, interval_s: float) -> SatPairScenario:
    """beta -4 deg at the start rising through 0 about mid-month (eclipse season: pseudo-yaw steering turns
    whenever |beta| < 4.3 deg, where the nominal rate at noon/midnight exceeds 0.055 deg/s),
    an orbit-normal manoeuvre 07:00-19:00 on day 25 and a 360 deg turn of ~2 h on day 3."""
    on = ((24 * DAY + 7 * 3600.0, 24 * DAY + 19 * 3600.0) if days > 25
          else (0.6 * days * DAY, 0.6 * days * DAY + 6 * 3600.0))
    turn = (2 * DAY + 10 * 3600.0, 6545.0, 1) if days > 3 else (0.2 * days * DAY, 6545.0, 1)
    return SatPairScenario(start="2017-12-01T00:00:00", duration_s=days * DAY, interval_s=interval_s,
                           n_stations=stations, beta_deg=-4.0, midnight_s=6 * 3600.0,
                           profile="qzss-pseudo-yaw-steering", orbit_normal_windows=(on,), turns_360=(turn,),
                           seed=2017)


def _timed(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, float(np.median(times))


def _pcv_rms(pm, amplitude_mm):
    NN, AA = np.meshgrid(pm.nadir_deg, pm.azimuth_deg, indexing="ij")
    ok = np.isfinite(pm.values_mm)
    truth = pcv_truth_mm(NN[ok], AA[ok], amplitude_mm)
    B = unobservable_basis(NN[ok], AA[ok])
    truth = truth - B @ np.linalg.lstsq(B, truth, rcond=None)[0]
    return float(np.sqrt(np.mean((pm.values_mm[ok] - truth) ** 2))), float(np.sqrt(np.mean(truth ** 2))), int(ok.sum())


def _exclusion(sc, tr, obs):
    keep = np.ones(len(obs.epoch), dtype=bool)
    t = tr.geometry.t_s[obs.epoch]
    for a, b in sc.orbit_normal_windows:
        keep &= ~((t >= a - 600) & (t < b + 3600))
    for a, d, _ in sc.turns_360:
        keep &= ~((t >= a - 600) & (t < a + d + 600))
    return keep


def run(days: float, stations: int, interval_s: float, repeats: int, figures: Path | None) -> dict:
    sc = scenario(days, stations, interval_s)
    tr, t_sim = _timed(lambda: simulate_satellite_pair(sc), 1)
    g = tr.geometry
    model = model_yaw_deg(sc.profile, g.t_s, g.nominal_yaw_deg, g.nominal_rate_deg_s)
    sf = tr.sf
    base_obs = sf.select(_exclusion(sc, tr, sf))
    be, t_base = _timed(lambda: estimate_baseline(base_obs, g, model, BaselineOptions()), repeats)
    err_b = be.baseline_body_m - np.array(sc.baseline_body_m)
    pcv_rms, pcv_truth_rms, pcv_nodes = _pcv_rms(be.pcv, sc.pcv_amplitude_mm)
    e_b = body_los(g.R_orbital_from_ecef[sf.epoch], model[sf.epoch], sf.los_ecef)
    pcv_rows = be.pcv.lookup_m(*nadir_azimuth_deg(e_b))
    ye, t_yaw = _timed(lambda: estimate_yaw(sf, g, be.baseline_body_m, model, pcv_m=pcv_rows), repeats)
    err = wrap_deg(ye.yaw_deg - tr.yaw_deg)
    turning = (np.abs(wrap_deg(model - g.nominal_yaw_deg)) > 1.0)
    on_a, on_b = sc.orbit_normal_windows[0]
    manoeuvre = (g.t_s >= on_a) & (g.t_s < on_b + 1800)
    ev, t_ev = _timed(lambda: detect_mode_switches(g.t_s, ye.yaw_deg, ye.sigma_yaw_deg, model), 1)
    matches = []
    for truth_ev in tr.events:
        cands = [e for e in ev if e.kind == truth_ev["kind"]]
        dt = min((abs(e.time_s - truth_ev["time_s"]) for e in cands), default=float("inf"))
        matches.append({"kind": truth_ev["kind"], "truth_s": truth_ev["time_s"], "abs_dt_s": dt})
    y3, t_tf = _timed(lambda: estimate_yaw(tr.tf, g, sc.baseline_body_m, model), repeats)
    err3 = wrap_deg(y3.yaw_deg - tr.yaw_deg)
    c = table2_coefficients()
    rms = lambda a: float(np.sqrt(np.nanmean(a ** 2)))  # noqa: E731
    rec = {
        "command": f"python -m bench.bench_satellite_yaw --days {days:g} --stations {stations} "
                   f"--interval {interval_s:g} --repeats {repeats}",
        "machine": f"{_platform.machine()} {os.cpu_count()} cpu, {_platform.python_implementation()} "
                   f"{_platform.python_version()}",
        "rows_single_frequency": int(len(sf.value_m)), "groups": int(sf.n_groups), "epochs": int(len(g.t_s)),
        "beta_deg_range": [float(g.beta_deg.min()), float(g.beta_deg.max())],
        "baseline": {"error_mm": (err_b * 1e3).round(2).tolist(), "sigma_mm": (be.sigma_m * 1e3).round(2).tolist(),
                     "error_over_sigma": (err_b / be.sigma_m).round(2).tolist(), "sigma0": round(be.sigma0, 3),
                     "ar1_factor": round(be.ar1_factor, 3), "dcb_error_m": round(be.dcb_m - sc.dcb_m, 3)},
        "pcv": {"rms_error_mm": round(pcv_rms, 3), "truth_rms_mm": round(pcv_truth_rms, 3), "nodes": pcv_nodes},
        "yaw": {"rms_error_deg": round(rms(err), 3), "rms_sigma_deg": round(rms(ye.sigma_yaw_deg), 3),
                "rms_error_over_sigma": round(rms(err / ye.sigma_yaw_deg), 3),
                "turn_epochs": int(turning.sum()), "rms_error_turns_deg": round(rms(err[turning]), 3),
                "rms_error_over_sigma_turns": round(rms(err[turning] / ye.sigma_yaw_deg[turning]), 3),
                "rms_error_manoeuvre_deg": round(rms(err[manoeuvre]), 3),
                "max_abs_error_deg": round(float(np.nanmax(np.abs(err))), 2),
                "epochs_estimated": int(np.isfinite(ye.yaw_deg).sum())},
        "mode_switches": {"found": len(ev), "matches": matches,
                          "max_abs_dt_s": max(m["abs_dt_s"] for m in matches) if matches else None},
        "triple_frequency": {"rms_error_deg": round(rms(err3), 3), "rms_sigma_deg": round(rms(y3.sigma_yaw_deg), 3),
                             "rms_error_over_sigma": round(rms(err3 / y3.sigma_yaw_deg), 3),
                             "formal_sigma_ratio_tf_over_sf": round(float(np.nanmedian(
                                 (y3.sigma_yaw_deg / y3.sigma0) / (ye.sigma_yaw_deg / ye.sigma0))), 3),
                             "eq8_expected_ratio": round(noise_factor(c) / c.k1 / np.sqrt(2), 3),
                             "noise_factor": round(noise_factor(c), 4)},
        "seconds": {"simulate": round(t_sim, 2), "baseline_and_pcv": round(t_base, 2), "yaw": round(t_yaw, 2),
                    "mode_switches": round(t_ev, 3), "yaw_triple": round(t_tf, 2)},
    }
    if figures is not None:
        _figures(figures, tr, model, ye, y3, be)
    return rec


def baseline_seeds(n: int, days: float, stations: int, interval_s: float) -> dict:
    """RMS over n independent simulations (seeds 1..n, nominal yaw steering at beta 20 deg) of the baseline's
    error / sigma per component: the honesty of the baseline sigmas, which one month gives one sample of."""
    from dataclasses import replace

    ratios, errors = [], []
    for seed in range(1, n + 1):
        sc = replace(scenario(days, stations, interval_s), profile="yaw-steering", beta_deg=20.0,
                     orbit_normal_windows=(), turns_360=(), seed=seed)
        tr = simulate_satellite_pair(sc)
        be = estimate_baseline(tr.sf, tr.geometry, tr.yaw_deg, BaselineOptions())
        err = be.baseline_body_m - np.array(sc.baseline_body_m)
        ratios.append(err / be.sigma_m)
        errors.append(err)
    r, e = np.array(ratios), np.array(errors)
    return {"runs": n, "days": days, "rms_error_over_sigma": np.sqrt(np.mean(r ** 2, axis=0)).round(3).tolist(),
            "rms_error_mm": (np.sqrt(np.mean(e ** 2, axis=0)) * 1e3).round(3).tolist()}


def _figures(out: Path, tr, model, ye, y3, be) -> None:
    from gnssatt.plots.common import figure_png, new_figure
    from gnssatt.satyaw.products import pcv_plot

    out.mkdir(parents=True, exist_ok=True)
    g = tr.geometry
    sc = tr.scenario
    windows = {"midnight_turn": None, "manoeuvre": (sc.orbit_normal_windows[0][0] - 3 * 3600,
                                                     sc.orbit_normal_windows[0][1] + 3 * 3600),
               "turn_360": (sc.turns_360[0][0] - 3600, sc.turns_360[0][0] + sc.turns_360[0][1] + 3600)}
    dev = np.abs(wrap_deg(model - g.nominal_yaw_deg))
    k = int(np.nanargmax(dev))
    windows["midnight_turn"] = (g.t_s[k] - 2 * 3600, g.t_s[k] + 2 * 3600)
    for name, (a, b) in windows.items():
        m = (g.t_s >= a) & (g.t_s < b)
        t_h = (g.t_s[m] - a) / 3600.0
        fig = new_figure(9.0, 5.5)
        ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
        ax.plot(t_h, g.nominal_yaw_deg[m], color="0.6", lw=1, label="nominal yaw steering")
        ax.plot(t_h, model[m], "k-", lw=1, label=f"model ({sc.profile})")
        ax.plot(t_h, ye.yaw_deg[m], "r.", ms=2, label="estimated (L1 SLAS - C/A)")
        ax.set_ylabel("yaw (deg)")
        ax.legend(fontsize=7)
        ax2.plot(t_h, wrap_deg(ye.yaw_deg[m] - tr.yaw_deg[m]), "r.", ms=2, label="single frequency")
        ax2.plot(t_h, wrap_deg(y3.yaw_deg[m] - tr.yaw_deg[m]), "b.", ms=1, alpha=0.4, label="triple frequency")
        ax2.set_ylim(-15, 15)
        ax2.set_ylabel("estimate - truth (deg)")
        ax2.set_xlabel(f"hours from day {a / 86400:.2f} of the simulated month")
        ax2.legend(fontsize=7)
        (out / f"satyaw_sim_{name}.png").write_bytes(figure_png(fig))
    (out / "satyaw_sim_pcv.png").write_bytes(pcv_plot(sc.sat, be.pcv))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=float, default=30.0)
    ap.add_argument("--stations", type=int, default=20)
    ap.add_argument("--interval", type=float, default=30.0)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--figures", type=Path, default=None)
    ap.add_argument("--baseline-seeds", type=int, default=0,
                    help="also N independent shorter runs (--seed-days) of the baseline for its error/sigma")
    ap.add_argument("--seed-days", type=float, default=5.0)
    a = ap.parse_args()
    if a.baseline_seeds:
        print(json.dumps(baseline_seeds(a.baseline_seeds, a.seed_days, a.stations, 60.0), indent=1))
        return
    print(json.dumps(run(a.days, a.stations, a.interval, a.repeats, a.figures), indent=1))


if __name__ == "__main__":
    main()
