"""Job type `calibration`: in-flight antenna baselines and differential PCV maps from a campaign of observation
sets with a reference attitude (seed 000 sec. 3). See docs/calibration.md.

The config model and JOB_TYPE; the fan-out task entry points (statistics_task, final_task: one set's pass 1 or
2, gnssatt.calibration.tasks); and run(), which hands the campaign to gnssatt.calibration.run_campaign with a map
function over the job's workers (queued longest first), writes its products and tasks.csv and publishes the maps.
Task functions take (payload, sets) and return picklable results; an input problem of a set comes back as
{"input_error": ...} (not raised) so the parent fails the job once, naming the set, instead of a retried task.
The science is imported inside the functions (the API imports this module for the config model)."""
from __future__ import annotations

from datetime import datetime, timezone
from typing import Literal

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
                                                   description="Signals used, L1 and/or L2 (each an independent "
                                                               "observation); one PCV map per baseline and frequency.")
    azimuth_step_deg: float = Field(2.5, gt=0.0, le=90.0, description="Azimuth bin width (deg; divides 360).")
    elevation_step_deg: float = Field(1.0, gt=0.0, le=45.0, description="Elevation bin width (deg).")
    elevation_min_deg: float = Field(0.0, ge=-90.0, lt=90.0, description="Lowest bin edge, antenna frame (deg).")
    elevation_max_deg: float = Field(90.0, gt=-90.0, le=90.0, description="Highest bin edge, antenna frame (deg).")
    min_count: int = Field(10, ge=1, le=10_000_000,
                           description="Samples a bin needs for a value; fewer leave it empty (null). 10 with the "
                                       "smoothing (each value is a fit supported by its neighbours); raise it "
                                       "(e.g. 30) with smoothing_order 0.")
    max_iterations: int = Field(10, ge=1, le=1000, description="Most PCV iterations (fewer once the map "
                                                               "changes by less than tolerance_mm).")
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
    sigma_phase_mm: float = Field(3.0, gt=0.0, le=100.0,
                                  description="Undifferenced phase sigma (mm; seed 000 Table 1).")
    cn0_mask_l1_dbhz: float = Field(35.0, ge=0.0, le=60.0, description="C/N0 mask of L1 C/A (dB-Hz; Table 2).")
    cn0_mask_l2_dbhz: float = Field(30.0, ge=0.0, le=60.0, description="C/N0 mask of L2 (dB-Hz; Table 2).")
    elevation_mask_antenna_deg: float = Field(0.0, ge=-90.0, le=90.0,
                                              description="Satellites below this elevation in either antenna's "
                                                          "frame are not used (deg).")
    max_reference_gap_s: float = Field(10.0, gt=0.0, le=3600.0,
                                       description="Longest reference-attitude gap interpolated across by slerp (s).")
    min_reference_coverage: float = Field(0.9, ge=0.0, le=1.0,
                                          description="Fraction of a set's epochs the reference must cover.")
    batch_s: float = Field(300.0, ge=10.0, le=86400.0,
                           description="Batch length of the batch-means sigma of the baselines (s).")
    epoch_baselines: Literal["filter-kinematic", "reference-aided-ablation"] = Field(
        "filter-kinematic",
        description="Where the epoch-wise baselines come from: 'filter-kinematic', the attitude filter in kinematic "
                    "mode (seed 000 sec. 3.1: baseline process noise, the filter's own integers); "
                    "'reference-aided-ablation', ONLY an ablation: the former processor that rounds the integers "
                    "from the reference attitude and solves each epoch by least squares.")
    max_deviation_mm: float = Field(50.0, gt=0.0, le=1000.0,
                                    description="An epoch-wise baseline further than this from the a priori in any "
                                                "component is left out as a wrong fix (mm).")

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
                "epoch-wise baselines of the attitude filter's kinematic mode rotated into the body frame and "
                "averaged (seed 000 sec. 3.1, Table 3), then "
                "differential phase-centre-variation maps per antenna pair and frequency, iterated with the "
                "previous map applied. Fans out one task per set over all workers.",
    config_model=CalibrationConfig, pipeline="worker.jobs.calibration:run",
    min_sets=1, max_sets=None,
    produces=("baselines.json", "baselines.csv", "pcv_<first>_<second>_<frequency>.json",
              "pcv_maps.png", "pcv_counts.png", "residual_statistics.json", "held_out_attitude.json",
              "calibration_summary.json", "tasks.csv", "report.html"))


# ---- the pipeline: the fan-out tasks and a thin run() over gnssatt.calibration.run_campaign


def _options(cfg: dict):
    """CampaignOptions (gnssatt.calibration.campaign) of the job config (a model_dump)."""
    from gnssatt.calibration.binning import Grid2D
    from gnssatt.calibration.campaign import CampaignOptions
    from gnssatt.calibration.extract import ExtractOptions

    ext = ExtractOptions(signals=tuple(cfg["frequencies"]), sigma_phase_m=cfg["sigma_phase_mm"] * 1e-3,
                         cn0_mask_dbhz={"L1": cfg["cn0_mask_l1_dbhz"], "L2": cfg["cn0_mask_l2_dbhz"]},
                         elevation_mask_antenna_deg=cfg["elevation_mask_antenna_deg"],
                         max_reference_gap_s=cfg["max_reference_gap_s"],
                         producer=cfg.get("epoch_baselines", "filter-kinematic"))
    grid = Grid2D.regular(cfg["azimuth_step_deg"], cfg["elevation_step_deg"],
                          y_range_deg=(cfg["elevation_min_deg"], cfg["elevation_max_deg"]))
    return CampaignOptions(ext, grid, min_count=cfg["min_count"], tolerance_mm=cfg["tolerance_mm"],
                           max_iterations=cfg["max_iterations"], batch_s=cfg["batch_s"],
                           smoothing_order=cfg.get("smoothing_order", 8),
                           max_deviation_m=cfg["max_deviation_mm"] * 1e-3,
                           min_reference_coverage=cfg["min_reference_coverage"])


def _held_out(cfg: dict):
    """HeldOutAttitude (gnssatt.calibration.held_out) of the job config: the attitude job's settings of
    held_out_attitude_config, recorded as given (without defaults)."""
    from gnssatt.calibration.held_out import HeldOutAttitude
    from worker.jobs.attitude import AttitudeConfig

    att_cfg = AttitudeConfig(**cfg.get("held_out_attitude_config", HELD_OUT_ATTITUDE_DEFAULT))
    return HeldOutAttitude(att_cfg.to_settings(), att_cfg.model_dump(exclude_defaults=True))


def statistics_task(payload: dict, sets):
    """Pass 1 of one set (gnssatt.calibration.tasks.statistics_of_set): SetStats or {"input_error": ...}."""
    from gnssatt.calibration.tasks import find_set, statistics_of_set

    return statistics_of_set(find_set(sets, payload["set_id"]), _options(payload["config"]))


def final_task(payload: dict, sets):
    """Pass 2 of one set (gnssatt.calibration.tasks.final_of_set): SetFinal or {"input_error": ...}; the held-out
    set's attitude filter runs with the job's held_out_attitude_config."""
    from gnssatt.calibration.tasks import final_of_set, find_set

    cfg = payload["config"]
    shared = payload.get("_shared", payload)  # the maps and baselines, stored once for all tasks
    return final_of_set(find_set(sets, payload["set_id"]), _options(cfg), shared,
                        _held_out(cfg) if payload["held_out"] else None)


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


TASK_FUNCTIONS = {1: "worker.jobs.calibration:statistics_task", 2: "worker.jobs.calibration:final_task"}


def _fan_out(ctx: JobContext, cfg: dict):
    """The map function run_campaign hands its passes to: ctx.map over the job's workers, one task per set, queued
    longest first. A payload names the set and carries the job config, from which each task builds its options and
    the held-out attitude settings (as run() built them for run_campaign: fan.held_out is not sent)."""
    def map_fn(fan) -> list:
        payloads = [{"set_id": t.set_id, "label": t.label, "config": cfg} for t in fan.tasks]
        if fan.pass_number == 2:
            payloads = [{**p, "held_out": t.held_out} for p, t in zip(payloads, fan.tasks)]
        return _map_in_order(ctx, TASK_FUNCTIONS[fan.pass_number], payloads, [t.cost_s for t in fan.tasks],
                             progress_span=fan.progress_span, stage=fan.stage, shared=fan.shared)
    return map_fn


def run(ctx: JobContext, config) -> None:
    """The calibration job: gnssatt.calibration.run_campaign over the job's sets with the fan-out over workers,
    then its products, tasks.csv (the fan-out log) and the maps published under map_name."""
    from gnssatt.calibration.api import run_campaign
    from gnssatt.calibration.checks import CampaignError

    cfg = config.model_dump()
    started_at = datetime.now(timezone.utc)
    try:
        result = run_campaign(ctx.sets, options=_options(cfg), held_out=config.held_out_set,
                              held_out_attitude=_held_out(cfg) if config.held_out_set else None,
                              map_fn=_fan_out(ctx, cfg), progress=ctx.progress, log=ctx.log)
    except CampaignError as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file,
                            field="observation_set_ids" if exc.about_sets else None) from exc
    ctx.progress(0.92, "writing products")
    for name, content in result.products(ctx.job_id, workers_summary(ctx.task_records)).items():
        ctx.write_product(name, content)
    ctx.write_product("tasks.csv", tasks_csv(ctx.task_records, started_at))
    map_name = config.map_name or f"{result.platform.name} calibration"
    for (first, second, signal), doc in result.pcv_maps.items():
        ctx.publish_pcv_map(f"{map_name} {first}>{second} {signal}", doc)
    ctx.progress(1.0, "done")


def tasks_csv(records: list[dict], job_start: datetime) -> str:
    """The fan-out log: one row per task (pass, task index in queue order, set, worker, attempts, start and end in
    seconds since the pipeline started, duration), so which worker ran which set when is visible."""
    from gnssatt.calibration.tasks import STAGE_PASS1, STAGE_PASS2

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


__all__ = ["run", "statistics_task", "final_task", "tasks_csv", "workers_summary"]
