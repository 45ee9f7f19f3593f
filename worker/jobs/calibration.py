"""Job type `calibration`: in-flight antenna baselines and differential PCV maps from a campaign of observation
sets with a reference attitude (seed 000 sec. 3). See docs/calibration.md.

run(): checks the campaign from the upload summaries and the reference attitude files, fans out pass 1 (one task
per set), reduces baselines and iterates the maps, fans out pass 2, writes the products and publishes the maps.
Task functions take (payload, sets) and return picklable results; an input problem of a set comes back as
{"input_error": ...} (not raised) so the parent fails the job once, naming the set, instead of a retried task.
The science is imported inside the functions (the API imports this module for the config model)."""
from __future__ import annotations

import json
import time
from datetime import datetime, timezone
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.registry import JobType


#: default attitude configuration of the held-out comparison: the attitude filter's lowest-noise documented
#: processing (the fixed-interval smoother, docs/attitude.md) on every tracked phase (no seed 000 Table 2 C/N0 or
#: antenna-frame masks: they drop the low antenna elevations where the differential PCV is largest). The
#: comparison measures the calibration, and white noise left in both runs dilutes the std cut; with the job's
#: plain defaults even the true calibration cuts the roll std of the bench's held-out pass by only 27.5 %
#: (docs/calibration.md "Error budget"). `{}` gives the attitude job's defaults.
#: The preset "all-phases-smoother" is exactly the former flat default {"smoother": true,
#: "elevation_mask_antenna_deg": -90, "cn0_mask_l1_dbhz": 0, "cn0_mask_l2_dbhz": 0, "cn0_mask_default_dbhz": 0}.
HELD_OUT_ATTITUDE_DEFAULT: dict = {"preset": "all-phases-smoother"}


class CalibrationConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    frequencies: list[Literal["L1", "L2"]] = Field(["L1", "L2"], min_length=1,
                                                   description="Signals used (each an independent observation); one "
                                                               "PCV map per baseline and frequency.")
    azimuth_step_deg: float = Field(2.5, gt=0.0, le=90.0, description="Azimuth bin width (divides 360).")
    elevation_step_deg: float = Field(1.0, gt=0.0, le=45.0, description="Elevation bin width.")
    elevation_min_deg: float = Field(0.0, ge=-90.0, lt=90.0, description="Lowest bin edge (antenna frame).")
    elevation_max_deg: float = Field(90.0, gt=-90.0, le=90.0, description="Highest bin edge (antenna frame).")
    min_count: int = Field(10, ge=1, le=10_000_000,
                           description="Samples a bin needs for a value; fewer leave it empty (null). 10 with the "
                                       "smoothing (each value is a fit supported by its neighbours); raise it "
                                       "(e.g. 30) with smoothing_order 0.")
    max_iterations: int = Field(10, ge=1, le=1000, description="Most PCV iterations.")
    smoothing_order: int = Field(8, ge=0, le=30, description="Radial order of the Zernike fit that smooths each "
                                 "map over the hemisphere (structure finer than ~90/N deg is smoothed away); 0 = "
                                 "plain bin means. Empty bins stay empty either way.")
    tolerance_mm: float = Field(0.1, gt=0.0, le=100.0, description="Stop when the map changes by less (RMS, mm).")
    held_out_set: str | None = Field(None, max_length=200,
                                     description="Id or name of a set kept out of the calibration and used for the "
                                                 "before/after attitude comparison.")
    held_out_attitude_config: dict = Field(
        default_factory=lambda: dict(HELD_OUT_ATTITUDE_DEFAULT),
        description="Attitude job config (docs/attitude.md) of the held-out comparison: the attitude filter "
                    "runs on the held-out set with it, once as given (a priori baselines) and once with the "
                    "calibrated baselines and maps. Default: dynamic mode with the fixed-interval smoother on "
                    "every tracked phase (no C/N0 / antenna-frame masks), the lowest-noise processing, so the "
                    "comparison shows the calibration rather than white noise; {} = the attitude job's defaults. "
                    "calibrated_baselines and pcv_map_ids are the calibration's own and may not be given.")
    map_name: str | None = Field(None, max_length=150,
                                 description="Name under which the maps are published (default: '<platform> "
                                             "calibration'); each pair and frequency gets '<name> A>B L1'.")
    sigma_phase_mm: float = Field(3.0, gt=0.0, le=100.0, description="Undifferenced phase sigma (seed 000 Table 1).")
    cn0_mask_l1_dbhz: float = Field(35.0, ge=0.0, le=60.0, description="C/N0 mask of L1 C/A (Table 2).")
    cn0_mask_l2_dbhz: float = Field(30.0, ge=0.0, le=60.0, description="C/N0 mask of L2 (Table 2).")
    elevation_mask_antenna_deg: float = Field(0.0, ge=-90.0, le=90.0,
                                              description="Satellites below this elevation in either antenna's "
                                                          "frame are not used.")
    max_reference_gap_s: float = Field(10.0, gt=0.0, le=3600.0,
                                       description="Longest reference-attitude gap interpolated across (slerp).")
    min_reference_coverage: float = Field(0.9, ge=0.0, le=1.0,
                                          description="Fraction of a set's epochs the reference must cover.")
    batch_s: float = Field(300.0, ge=10.0, le=86400.0,
                           description="Batch length of the batch-means sigma of the baselines.")
    max_deviation_mm: float = Field(50.0, gt=0.0, le=1000.0,
                                    description="An epoch-wise baseline further than this from the a priori in any "
                                                "component is left out (a wrong fix).")

    @model_validator(mode="after")
    def _grid(self):
        n_az = 360.0 / self.azimuth_step_deg
        n_el = (self.elevation_max_deg - self.elevation_min_deg) / self.elevation_step_deg
        if abs(n_az - round(n_az)) > 1e-9:
            raise ValueError("azimuth_step_deg must divide 360")
        if n_el < 1 or abs(n_el - round(n_el)) > 1e-9:
            raise ValueError("elevation_max_deg - elevation_min_deg must be a whole number of elevation_step_deg")
        if round(n_az) * round(n_el) > 200_000:
            raise ValueError("more than 200000 bins per map")
        if len(set(self.frequencies)) != len(self.frequencies):
            raise ValueError("frequencies repeat")
        own = sorted({"calibrated_baselines", "pcv_map_ids"} & set(self.held_out_attitude_config))
        if own:
            raise ValueError(f"held_out_attitude_config: {own} come from the calibration itself")
        from worker.jobs.attitude import AttitudeConfig

        try:
            AttitudeConfig(**self.held_out_attitude_config)
        except ValueError as exc:
            raise ValueError(f"held_out_attitude_config: {exc}") from exc
        return self


JOB_TYPE = JobType(
    name="calibration", title="Calibrate antenna baselines and differential PCV maps",
    description="From many observation sets of one platform, each with a reference attitude (star tracker): "
                "epoch-wise baselines rotated into the body frame and averaged (seed 000 Table 3), then "
                "differential phase-centre-variation maps per antenna pair and frequency, iterated with the "
                "previous map applied. Fans out one task per set over all workers.",
    config_model=CalibrationConfig, pipeline="worker.jobs.calibration:run",
    min_sets=1, max_sets=None,
    produces=("baselines.json", "baselines.csv", "pcv_<first>_<second>_<frequency>.json",
              "pcv_maps.png", "pcv_counts.png", "residual_statistics.json", "held_out_attitude.json",
              "calibration_summary.json", "tasks.csv", "report.html"))


# ---- the pipeline (fan-out tasks, reductions, products)


STAGE_PASS1 = "pass 1 (baselines, PCV statistics)"
STAGE_PASS2 = "pass 2 (residuals, final maps, held-out set)"
HELD_OUT_COST = 12.0  # the held-out task's cost in set extractions (pass 2: three extractions + two filter runs)


def _options(cfg: dict):
    from gnssatt.calibration.binning import Grid2D
    from gnssatt.calibration.campaign import CampaignOptions
    from gnssatt.calibration.extract import ExtractOptions

    ext = ExtractOptions(signals=tuple(cfg["frequencies"]), sigma_phase_m=cfg["sigma_phase_mm"] * 1e-3,
                         cn0_mask_dbhz={"L1": cfg["cn0_mask_l1_dbhz"], "L2": cfg["cn0_mask_l2_dbhz"]},
                         elevation_mask_antenna_deg=cfg["elevation_mask_antenna_deg"],
                         max_reference_gap_s=cfg["max_reference_gap_s"])
    grid = Grid2D.regular(cfg["azimuth_step_deg"], cfg["elevation_step_deg"],
                          y_range_deg=(cfg["elevation_min_deg"], cfg["elevation_max_deg"]))
    return CampaignOptions(ext, grid, min_count=cfg["min_count"], tolerance_mm=cfg["tolerance_mm"],
                           max_iterations=cfg["max_iterations"], batch_s=cfg["batch_s"],
                           smoothing_order=cfg.get("smoothing_order", 8),
                           max_deviation_m=cfg["max_deviation_mm"] * 1e-3,
                           min_reference_coverage=cfg["min_reference_coverage"])


def _label(s) -> str:
    return s.name or s.id


def _find(sets, set_id: str):
    for s in sets:
        if s.id == set_id:
            return s
    raise KeyError(f"set {set_id} is not an input of this job")


def _load(payload: dict, sets):
    """(SetData, options) or an {"input_error"} dict."""
    from gnssatt.calibration.extract import SetInputError, load_set
    from gnssatt.gnss.io.errors import ParseError

    options = _options(payload["config"])
    s = _find(sets, payload["set_id"])
    try:
        data = load_set(s, options.extract)
    except SetInputError as exc:
        return None, options, {"input_error": {"title": "Set unusable for calibration",
                                               "detail": f"set {_label(s)!r} {exc}", "file": exc.file}}
    except ParseError as exc:
        return None, options, {"input_error": {"title": "An input file could not be parsed",
                                               "detail": f"set {_label(s)!r}: {exc}", "file": exc.path}}
    if data.reference.coverage < options.min_reference_coverage:
        from gnssatt.calibration.reference import uncovered_spans
        spans = "; ".join(f"{a} to {b}" for a, b in uncovered_spans(data.epochs, data.reference.ok))
        return None, options, {"input_error": {
            "title": "Reference attitude does not cover the observations",
            "detail": f"set {_label(s)!r}: the reference attitude covers {100 * data.reference.coverage:.1f} % of "
                      f"the observation epochs (min_reference_coverage {options.min_reference_coverage:g}); "
                      f"uncovered: {spans}"}}
    return data, options, None


def statistics_task(payload: dict, sets):
    """Pass 1 of one set: SetStats (gnssatt.calibration.campaign) or {"input_error": ...}.

    Also the set's own campaign check (reference attitude against the observation span, gnssatt.calibration.checks)
    that needs its reference file read: done here, in parallel, instead of in the parent before the fan-out."""
    from gnssatt.calibration.campaign import set_statistics
    from gnssatt.calibration.checks import CampaignError, check_campaign

    t0, c0 = time.perf_counter(), time.process_time()
    s = _find(sets, payload["set_id"])
    try:
        check_campaign(_set_infos([s], read_reference=True),
                       max_reference_gap_s=float(payload["config"]["max_reference_gap_s"]))
    except CampaignError as exc:
        return {"input_error": {"title": exc.title, "detail": exc.detail, "file": exc.file}}
    data, options, err = _load(payload, sets)
    if err:
        return err
    stats = set_statistics(data, options)
    return {"stats": stats, "seconds": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


def final_task(payload: dict, sets):
    """Pass 2 of one set: SetFinal or {"input_error": ...}."""
    from gnssatt.calibration.campaign import set_final

    t0, c0 = time.perf_counter(), time.process_time()
    data, options, err = _load(payload, sets)
    if err:
        return err
    shared = payload.get("_shared", payload)  # the maps and baselines, stored once for all tasks
    calibrated = {tuple(k.split(">")): np.asarray(v, float) for k, v in shared["calibrated"].items()}
    maps = {}
    for key, values in shared["maps"].items():
        bl, sig = key.rsplit(" ", 1)
        maps[tuple(bl.split(">")) + (sig,)] = np.array([np.nan if v is None else v for v in values], float)
    final = set_final(data, calibrated, maps, options, held_out=payload["held_out"])
    if payload["held_out"]:
        final.attitude = held_out_attitude(payload, _find(sets, payload["set_id"]), calibrated, maps, options,
                                           final.attitude)
    return {"final": final, "seconds": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


def held_out_attitude(payload: dict, s, calibrated: dict, maps: dict, options, epoch_wise: dict | None) -> dict:
    """held_out_attitude.json: the attitude filter (the attitude job's processing, `held_out_attitude_config`)
    on the held-out set without and with the calibration (gnssatt.calibration.held_out), and the epoch-wise QUEST
    comparison (gnssatt.calibration.campaign.attitude_comparison) as a secondary block."""
    from gnssatt.attitude.process import InputProblem, load_inputs
    from gnssatt.calibration.held_out import filter_comparison, map_documents
    from worker.jobs.attitude import AttitudeConfig

    att_cfg = AttitudeConfig(**payload["config"].get("held_out_attitude_config", HELD_OUT_ATTITUDE_DEFAULT))
    out = {"set": _label(s),
           "method": f"attitude filter ({att_cfg.mode} mode, the attitude job's processing) against the set's "
                     "reference attitude, over the fixed epochs: a priori baselines without maps vs calibrated "
                     "baselines + the calibration's maps (applied as with pcv_map_ids)",
           "attitude_config": att_cfg.model_dump(exclude_defaults=True)}
    try:
        inputs = load_inputs([(f.name, f.kind, f.path) for f in s.files])
        out.update(filter_comparison(inputs, att_cfg.to_settings(), calibrated, map_documents(options.grid, maps)))
    except InputProblem as exc:
        out["skipped"] = f"{exc.title}: {exc.detail}"
    if epoch_wise is not None:
        out["epoch_wise"] = epoch_wise
    return out


def _raise_input_errors(results: list, payloads: list) -> None:
    for r, p in zip(results, payloads):
        if isinstance(r, dict) and "input_error" in r:
            e = r["input_error"]
            raise JobInputError(e["title"], e["detail"], file=e.get("file"), field="observation_set_ids")


def _obs_span(s):
    """(first, last) GpsTime of a set's observations from the upload summaries (no RINEX parsing)."""
    from gnssatt.gnss.time import GpsTime

    obs = s.of_kind("rinex_obs")
    firsts = [GpsTime.from_iso(f.summary["time_first"]) for f in obs if f.summary.get("time_first")]
    lasts = [GpsTime.from_iso(f.summary["time_last"]) for f in obs if f.summary.get("time_last")]
    first = min(firsts, key=lambda t: (int(t.s), float(t.frac))) if firsts else None
    last = max(lasts, key=lambda t: (int(t.s), float(t.frac))) if lasts else None
    return first, last


def _set_infos(sets, read_reference):
    """SetInfo of each set (gnssatt.calibration.checks); the reference file is parsed only when read_reference is
    True or a collection holding the set's id (the calibration sets' references are checked in their own pass-1
    task; the parent checks what the summaries and platform.json give, and the held-out set's reference)."""
    from gnssatt.calibration.checks import SetInfo
    from gnssatt.gnss.io.reference_attitude import read_reference_attitude

    infos = []
    for s in sets:
        first, last = _obs_span(s)
        refs = s.of_kind("reference_attitude")
        ref_times = None
        if refs and (read_reference is True or (read_reference and s.id in read_reference)):
            ref_times = read_reference_attitude(refs[0].path.read_bytes(), refs[0].name).time
        infos.append(SetInfo(s.id, _label(s), s.platform(), first, last, refs[0].name if refs else None, ref_times))
    return infos


def _cost(s) -> float:
    """Expected cost of a set's task: its observation span (s); 0 when unknown."""
    first, last = _obs_span(s)
    return float(last - first) if first is not None and last is not None else 0.0


def _longest_first(payloads: list[dict], costs: list[float]) -> list[int]:
    """Task order for a fan-out: longest expected first (LPT scheduling: the last tasks to start are the short
    ones, so workers finish together); ties keep the set order. Results are put back in set order before any
    sum, so the order never changes the maps."""
    return sorted(range(len(payloads)), key=lambda i: (-costs[i], i))


def _map_in_order(ctx: JobContext, function: str, payloads: list[dict], costs: list[float], **kw) -> list:
    """ctx.map over payloads submitted longest first; results returned in payload order."""
    order = _longest_first(payloads, costs)
    results = ctx.map(function, [payloads[i] for i in order], **kw)
    out = [None] * len(payloads)
    for i, r in zip(order, results):
        out[i] = r
    return out


def _map_doc(platform: str, key, grid, values, count, sigma) -> dict:
    from gnssatt.gnss.io.pcv_map import PcvMap

    m = PcvMap(platform, key[0], key[1], key[2], grid.x_centres_deg, grid.y_centres_deg,
               np.round(values, 4), count.astype(np.int64), np.round(sigma, 4))
    return m.to_json()


def run(ctx: JobContext, config) -> None:
    from gnssatt.calibration.campaign import (combine_residual_stats, finish_maps, reduce_baselines, reduce_maps,
                                             split_baselines)
    from gnssatt.calibration.baselines import baselines_document, baselines_table_csv
    from gnssatt.calibration.checks import CampaignError, check_campaign
    from gnssatt.gnss.io.platform import parse_platform

    cfg = config.model_dump()
    options = _options(cfg)
    t_start = time.perf_counter()
    started_at = datetime.now(timezone.utc)
    ctx.progress(0.0, "checking the campaign")
    named = {s.id for s in ctx.sets if config.held_out_set in (s.id, s.name)} if config.held_out_set else set()
    # the calibration sets' reference coverage is checked in their pass-1 tasks, in parallel
    infos = _set_infos(ctx.sets, read_reference=named)
    try:
        check_campaign(infos, max_reference_gap_s=options.extract.max_reference_gap_s, held_out=config.held_out_set)
    except CampaignError as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field="observation_set_ids") from exc
    plat_file = ctx.sets[0].of_kind("platform")[0]
    platform = parse_platform(plat_file.path.read_bytes(), plat_file.name)
    held = [s for s in ctx.sets if config.held_out_set in (s.id, s.name)] if config.held_out_set else []
    held_ids = {s.id for s in held[:1]}
    cal_sets = [s for s in ctx.sets if s.id not in held_ids]
    ctx.log(f"calibration of {platform.name}: {len(cal_sets)} sets, held out: {[_label(s) for s in held[:1]]}")

    # --- pass 1 ---
    t0 = time.perf_counter()
    t_checks = t0 - t_start
    p1 = [{"set_id": s.id, "label": _label(s), "config": cfg} for s in cal_sets]
    r1 = _map_in_order(ctx, "worker.jobs.calibration:statistics_task", p1, [_cost(s) for s in cal_sets],
                       progress_span=(0.02, 0.5), stage=STAGE_PASS1)
    _raise_input_errors(r1, p1)
    t_pass1 = time.perf_counter() - t0
    stats = [r["stats"] for r in r1]
    rows = reduce_baselines(stats, platform)
    calibrated = {(r.first, r.second): r.estimate.mean_m for r in rows}
    if not all(np.all(np.isfinite(v)) for v in calibrated.values()):
        bad = [f"{a}>{b}" for (a, b), v in calibrated.items() if not np.all(np.isfinite(v))]
        raise JobInputError("No usable epochs", f"no epoch-wise solution survived for baseline(s) {bad} over "
                            f"{len(cal_sets)} set(s); check the reference attitude and the observations")
    ctx.progress(0.5, "iterating PCV maps")
    t0 = time.perf_counter()
    map_results = reduce_maps(stats, calibrated, list(config.frequencies), options,
                              boresights={a: ant.boresight_body for a, ant in platform.antennas.items()})
    calibrated = split_baselines(rows, map_results)   # baseline/map split made explicit (decomposition.py)
    t_maps = time.perf_counter() - t0
    for m in map_results:
        ctx.log(f"map {m.first}>{m.second} {m.signal}: iterations {len(m.changes_mm)}, changes (mm RMS) "
                f"{[round(c, 4) for c in m.changes_mm]}, converged {m.converged}")

    # --- pass 2 ---
    t0 = time.perf_counter()
    maps_payload = {f"{m.first}>{m.second} {m.signal}": [None if not np.isfinite(v) else round(float(v), 7)
                                                          for v in m.map_m] for m in map_results}
    cal_payload = {f"{a}>{b}": [float(x) for x in v] for (a, b), v in calibrated.items()}
    p2 = [{"set_id": s.id, "label": _label(s), "config": cfg, "held_out": s.id in held_ids}
          for s in cal_sets + held[:1]]
    # the held-out set costs ~12 set extractions (three extractions + two attitude filter runs): first in the queue
    costs2 = [_cost(s) * (HELD_OUT_COST if s.id in held_ids else 1.0) for s in cal_sets + held[:1]]
    r2 = _map_in_order(ctx, "worker.jobs.calibration:final_task", p2, costs2, progress_span=(0.52, 0.9),
                       stage=STAGE_PASS2, shared={"calibrated": cal_payload, "maps": maps_payload})
    _raise_input_errors(r2, p2)
    t_pass2 = time.perf_counter() - t0
    finals = [r["final"] for r in r2]
    maps_m = {(m.first, m.second, m.signal): np.array(maps_payload[f"{m.first}>{m.second} {m.signal}"],
                                                       dtype=float) for m in map_results}
    for m in map_results:
        m.map_m = np.where(np.isfinite(maps_m[(m.first, m.second, m.signal)]), maps_m[(m.first, m.second, m.signal)],
                           np.nan)
    final_maps = finish_maps(map_results, finals, options)

    # --- products ---
    t0 = time.perf_counter()
    ctx.progress(0.92, "writing products")
    ctx.write_product("baselines.json", baselines_document(platform.name, rows))
    ctx.write_product("baselines.csv", baselines_table_csv(rows))
    map_docs = []
    map_name = config.map_name or f"{platform.name} calibration"
    maps_summary = []
    for m in map_results:
        key = (m.first, m.second, m.signal)
        values, count, sigma, check = final_maps[key]
        doc = _map_doc(platform.name, key, options.grid, values, count, sigma)
        ctx.write_product(f"pcv_{m.first}_{m.second}_{m.signal}.json", doc)
        ctx.publish_pcv_map(f"{map_name} {m.first}>{m.second} {m.signal}", doc)
        map_docs.append(doc)
        finite = np.isfinite(values)
        maps_summary.append({
            "pair": [m.first, m.second], "frequency": m.signal, "iterations": len(m.changes_mm),
            "changes_mm": [round(c, 5) for c in m.changes_mm], "converged": m.converged,
            "bins_with_value": int(finite.sum()), "bins_total": int(values.size),
            "min_mm": round(float(np.nanmin(values)), 3) if finite.any() else None,
            "max_mm": round(float(np.nanmax(values)), 3) if finite.any() else None,
            "max_abs_final_bin_residual_mm": round(float(np.nanmax(np.abs(check))), 4) if finite.any() else None,
            "median_sigma_mm": round(float(np.nanmedian(sigma)), 4) if finite.any() else None})
    from gnssatt.plots.calibration import baselines_table, pcv_counts_plot, pcv_maps_plot

    context = {"job": ctx.job_id, "platform": platform.name, "sets": len(cal_sets)}
    pngs = {"pcv_maps.png": pcv_maps_plot(map_docs, context=context),
            "pcv_counts.png": pcv_counts_plot(map_docs, context=context)}
    for name, png in pngs.items():
        ctx.write_product(name, png, media_type="image/png")
    resid = combine_residual_stats(finals)
    if held_ids:
        resid["held_out"] = combine_residual_stats(finals, include_held_out=True)
    t_plots = time.perf_counter() - t0
    ctx.write_product("residual_statistics.json", resid)
    held_att = [f.attitude for f in finals if f.held_out]
    if held_att:
        ctx.write_product("held_out_attitude.json", held_att[0])
    per_set = [{"set": s.label, "epochs": s.n_epochs, "reference_coverage": round(s.coverage, 4),
                "epochs_used": {f"{a}>{b}": n for (a, b), n in s.n_epochs_used.items()},
                "pass1_seconds": round(r["seconds"], 3), "pass1_cpu_s": round(r.get("cpu_s", np.nan), 3),
                "pass2_seconds": round(q["seconds"], 3), "pass2_cpu_s": round(q.get("cpu_s", np.nan), 3)}
               for s, r, q in zip(stats, r1, r2)]
    summary = {
        "platform": platform.name, "sets": len(cal_sets), "held_out_set": [_label(s) for s in held[:1]],
        "extractor": "reference-aided kinematic (gnssatt.calibration.extract): epoch-wise integer fixing with the "
                     "reference attitude, epoch-wise least-squares baselines",
        "grid": {"azimuth_step_deg": config.azimuth_step_deg, "elevation_step_deg": config.elevation_step_deg,
                 "elevation_range_deg": [config.elevation_min_deg, config.elevation_max_deg],
                 "min_count": config.min_count},
        "baselines": baselines_document(platform.name, rows)["baselines"],
        "maps": maps_summary,
        "timing_s": {"checks": round(t_checks, 3), "pass1": round(t_pass1, 3), "maps": round(t_maps, 3),
                     "pass2": round(t_pass2, 3), "maps_products_and_plots": round(t_plots, 3),
                     "total": round(time.perf_counter() - t_start, 3),
                     "set_cpu_s_median": {"pass1": round(float(np.median([r.get("cpu_s", np.nan) for r in r1])), 3),
                                          "pass2": round(float(np.median([r.get("cpu_s", np.nan)
                                                                          for r in r2[:len(cal_sets)]])), 3)},
                     "held_out_cpu_s": [round(r.get("cpu_s", np.nan), 3) for r in r2[len(cal_sets):]]},
        "per_set": per_set,
        "workers": workers_summary(ctx.task_records),
    }
    ctx.write_product("tasks.csv", tasks_csv(ctx.task_records, started_at))
    ctx.write_product("calibration_summary.json", summary)
    from gnssatt.report import html_report

    report_summary = {k: v for k, v in summary.items() if k not in ("per_set", "baselines", "maps")}
    tables = {"Baselines (body frame, Table 3 layout)": baselines_table(baselines_document(platform.name, rows))}
    if held_att:
        tables["Held-out attitude (attitude filter, errors against the reference over fixed epochs)"] = \
            held_out_table(held_att[0])
    tables.update({"PCV maps": maps_summary, "Sets": per_set})
    ctx.write_product("report.html", html_report(
        f"Calibration · {platform.name} · {len(cal_sets)} sets", report_summary, pngs, tables),
        media_type="text/html")
    ctx.progress(1.0, "done")


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


def tasks_csv(records: list[dict], job_start: datetime) -> str:
    """The fan-out log: one row per task (pass, task index in queue order, set, worker, attempts, start and end in
    seconds since the pipeline started, duration), so which worker ran which set when is visible."""
    def rel(t):
        return "" if t is None else f"{(t - job_start).total_seconds():.3f}"

    lines = ["pass,task,set,worker,attempts,start_s,end_s,seconds"]
    for r in records:
        stage = 1 if r["stage"] == STAGE_PASS1 else 2 if r["stage"] == STAGE_PASS2 else r["stage"]
        label = str(r["label"]).replace('"', "'")
        lines.append(f'{stage},{r["index"]},"{label}",{r["worker"] or ""},{r["attempts"]},{rel(r["started_at"])},'
                     f'{rel(r["finished_at"])},{"" if r["seconds"] is None else format(r["seconds"], ".3f")}')
    return "\n".join(lines) + "\n"


def workers_summary(records: list[dict]) -> dict:
    """Per worker: tasks run and busy seconds (from the task records)."""
    out: dict = {}
    for r in records:
        w = out.setdefault(r["worker"] or "?", {"tasks": 0, "busy_s": 0.0})
        w["tasks"] += 1
        w["busy_s"] = round(w["busy_s"] + (r["seconds"] or 0.0), 3)
    return out


__all__ = ["run", "statistics_task", "final_task", "held_out_attitude", "held_out_table", "tasks_csv",
           "workers_summary"]
