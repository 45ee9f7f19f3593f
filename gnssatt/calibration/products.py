"""Files of the calibration job from a campaign's result (gnssatt.calibration.api.CampaignResult): baselines.json
and baselines.csv (seed 000 Table 3), one pcv_<first>_<second>_<frequency>.json per map (CONVENTIONS.md PCV map
layout), pcv_maps.png, pcv_counts.png, residual_statistics.json, held_out_attitude.json (with a held-out set),
calibration_summary.json and report.html. tasks.csv, the fan-out's log, is the runtime's (worker/jobs/calibration.py).

Implements: ../shared/CONVENTIONS.md "PCV maps"; seed 000 Table 3 (baselines layout).
"""
from __future__ import annotations

import time

import numpy as np

from gnssatt.calibration.baselines import baselines_document, baselines_table_csv

__all__ = ["EXTRACTOR", "map_document", "maps_summary", "grid_summary", "per_set_rows", "held_out_table",
           "campaign_summary", "campaign_products"]

EXTRACTOR = {"filter-kinematic": "the attitude filter's kinematic mode (seed 000 sec. 3.1; "
                                   "gnssatt.calibration.filter_baselines): epoch-wise baselines of the filter's fixed "
                                   "epochs, single-difference integers of its fixed baselines",
             "reference-aided-ablation": "ABLATION, reference-aided (gnssatt.calibration.kinematic): integers rounded "
                                         "from the reference attitude, epoch-wise least-squares baselines"}


def map_document(platform: str, key: tuple, grid, values_mm, count, sigma_mm) -> dict:
    """The CONVENTIONS JSON of one map (gnssatt.gnss.io.pcv_map.PcvMap) of (first, second, signal) on `grid`:
    values and sigmas (n_el, n_az) in mm rounded to 0.1 um, counts as integers."""
    from gnssatt.gnss.io.pcv_map import PcvMap

    m = PcvMap(platform, key[0], key[1], key[2], grid.x_centres_deg, grid.y_centres_deg,
               np.round(values_mm, 4), count.astype(np.int64), np.round(sigma_mm, 4))
    return m.to_json()


def maps_summary(result) -> list[dict]:
    """Per map: pair, frequency, the iteration's changes and convergence, bins with a value, range, the largest
    final-pass bin residual and the median bin sigma (mm)."""
    out = []
    for m in result.maps:
        values, _, sigma, check = result.final_maps[(m.first, m.second, m.signal)]
        finite = np.isfinite(values)
        out.append({
            "pair": [m.first, m.second], "frequency": m.signal, "iterations": len(m.changes_mm),
            "changes_mm": [round(c, 5) for c in m.changes_mm], "converged": m.converged,
            "bins_with_value": int(finite.sum()), "bins_total": int(values.size),
            "min_mm": round(float(np.nanmin(values)), 3) if finite.any() else None,
            "max_mm": round(float(np.nanmax(values)), 3) if finite.any() else None,
            "max_abs_final_bin_residual_mm": round(float(np.nanmax(np.abs(check))), 4) if finite.any() else None,
            "median_sigma_mm": round(float(np.nanmedian(sigma)), 4) if finite.any() else None})
    return out


def grid_summary(options) -> dict:
    """The grid as asked for (Grid2D.regular's steps and elevation range) and the bins' min_count."""
    grid = options.grid
    if grid.regular_deg is not None:
        x_step, y_step, _, y_range = grid.regular_deg
    else:
        x_step, y_step = grid.x_edges_deg[1] - grid.x_edges_deg[0], grid.y_edges_deg[1] - grid.y_edges_deg[0]
        y_range = (grid.y_edges_deg[0], grid.y_edges_deg[-1])
    return {"azimuth_step_deg": x_step, "elevation_step_deg": y_step, "elevation_range_deg": list(y_range),
            "min_count": options.min_count}


def per_set_rows(result) -> list[dict]:
    """Per calibration set: epochs, reference coverage, epochs used per baseline, where the platform position came
    from, each pass's wall and CPU s."""
    return [{"set": s.label, "epochs": s.n_epochs, "reference_coverage": round(s.coverage, 4),
             "epochs_used": {f"{a}>{b}": n for (a, b), n in s.n_epochs_used.items()},
             "platform_position": getattr(s, "position_source", ""),
             "pass1_seconds": round(r["seconds"], 3), "pass1_cpu_s": round(r.get("cpu_s", np.nan), 3),
             "pass2_seconds": round(q["seconds"], 3), "pass2_cpu_s": round(q.get("cpu_s", np.nan), 3)}
            for s, r, q in zip(result.stats, result.pass1_runs, result.pass2_runs)]


def held_out_table(doc: dict) -> list[dict]:
    """Rows of the report's held-out table: per Euler angle the filter's bias and std without and with the
    calibration and their cuts; the epoch-wise (QUEST) std cut alongside when computed."""
    rows = []
    w0, w1, cut = doc.get("without_calibration", {}), doc.get("with_calibration", {}), doc.get("cut", {})
    ew = (doc.get("epoch_wise") or {}).get("cut", {})
    for name, ew_name in (("yaw", "z_yaw"), ("pitch", "y_pitch"), ("roll", "x_roll")):
        a, b, c = w0.get(name), w1.get(name), cut.get(name)
        if not (a and b and c):
            continue
        rows.append({"angle": name, "bias a priori deg": a["bias_deg"], "bias calibrated deg": b["bias_deg"],
                     "bias cut %": c["bias_cut_percent"], "std a priori deg": a["std_deg"],
                     "std calibrated deg": b["std_deg"], "std cut %": c["std_cut_percent"],
                     "epoch-wise std cut %": (ew.get(ew_name) or {}).get("std_cut_percent")})
    return rows


def _timing(result, products_s: float) -> dict:
    t = result.timing_s
    n_cal = len(result.sets)
    return {"checks": round(t["checks"], 3), "pass1": round(t["pass1"], 3), "maps": round(t["maps"], 3),
            "pass2": round(t["pass2"], 3), "maps_products_and_plots": round(t["finish"] + products_s, 3),
            "total": round(time.perf_counter() - result.started_perf_s, 3),
            "set_cpu_s_median": {"pass1": round(float(np.median([r.get("cpu_s", np.nan)
                                                                  for r in result.pass1_runs])), 3),
                                 "pass2": round(float(np.median([r.get("cpu_s", np.nan)
                                                                 for r in result.pass2_runs[:n_cal]])), 3)},
            "held_out_cpu_s": [round(r.get("cpu_s", np.nan), 3) for r in result.pass2_runs[n_cal:]]}


def campaign_summary(result, products_s: float = 0.0, workers: dict | None = None) -> dict:
    """calibration_summary.json: platform, sets, held-out set, extractor, grid, baselines (Table 3), maps
    (maps_summary), wall and CPU times (`products_s`: seconds spent on the products so far), per set, and the
    runtime's per-worker record when given (`workers`)."""
    summary = {
        "platform": result.platform.name, "sets": len(result.sets), "held_out_set": list(result.held_out_set),
        "extractor": EXTRACTOR[result.options.extract.producer], "grid": grid_summary(result.options),
        "baselines": baselines_document(result.platform.name, result.baselines)["baselines"],
        "maps": maps_summary(result), "timing_s": _timing(result, products_s), "per_set": per_set_rows(result),
        "reader_warnings": list(getattr(result, "reader_warnings", []))}
    if workers is not None:
        summary["workers"] = workers
    return summary


def _report(result, summary: dict, pngs: dict) -> str:
    from gnssatt.plots.calibration import baselines_table
    from gnssatt.report import html_report

    report_summary = {k: v for k, v in summary.items() if k not in ("per_set", "baselines", "maps")}
    tables = {"Baselines (body frame, Table 3 layout)":
              baselines_table(baselines_document(result.platform.name, result.baselines))}
    if result.held_out_attitude is not None:
        tables["Held-out attitude (attitude filter, errors against the reference over fixed epochs)"] = \
            held_out_table(result.held_out_attitude)
    tables.update({"PCV maps": summary["maps"], "Sets": summary["per_set"]})
    return html_report(f"Calibration · {result.platform.name} · {len(result.sets)} sets", report_summary, pngs,
                       tables)


def campaign_products(result, job_id: str | None = None, workers: dict | None = None) -> dict:
    """Product name -> content (a dict for JSON, text, or PNG bytes) of the calibration job, in the order the job
    writes them. `job_id` is named in the plots' titles; `workers` (per worker: tasks, busy s) goes into
    calibration_summary.json when given."""
    from gnssatt.plots.calibration import pcv_counts_plot, pcv_maps_plot

    t0 = time.perf_counter()
    name = result.platform.name
    out: dict = {"baselines.json": baselines_document(name, result.baselines),
                 "baselines.csv": baselines_table_csv(result.baselines)}
    for (first, second, signal), doc in result.pcv_maps.items():
        out[f"pcv_{first}_{second}_{signal}.json"] = doc
    docs = list(result.pcv_maps.values())
    context = {"job": job_id, "platform": name, "sets": len(result.sets)}
    pngs = {"pcv_maps.png": pcv_maps_plot(docs, context=context),
            "pcv_counts.png": pcv_counts_plot(docs, context=context)}
    out.update(pngs)
    out["residual_statistics.json"] = result.residual_statistics
    if result.held_out_attitude is not None:
        out["held_out_attitude.json"] = result.held_out_attitude
    summary = campaign_summary(result, time.perf_counter() - t0, workers)
    out["calibration_summary.json"] = summary
    out["report.html"] = _report(result, summary, pngs)
    return out
