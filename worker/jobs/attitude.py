"""Job type `attitude`: multi-antenna carrier-phase attitude (seed 000 EKF, MLAMBDA, QUEST), the product's main job.

One module per job type: the config model (generated from gnssatt.attitude.settings), the JobType, PRELOAD and the
pipeline run(ctx, config) that parses the set, calls gnssatt.attitude.process and writes the products. The numerics
are imported inside run() and its helpers, so the API can list job types without them."""
from __future__ import annotations

import dataclasses
import logging
import time
import typing
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, create_model, field_validator, model_validator

from gnssatt.attitude.settings import (FLAT_TO_NESTED, GROUPS, PLATFORM_DEFAULTS, PRESETS, SIGNAL_ALIASES, SIGNALS,
                                       AttitudeSettings, cn0_mask_of)

from worker.context import JobContext
from worker.errors import JobInputError
from worker.forked import cpu_s
from worker.jobs.calibrated_baselines import CalibratedBaselines
from worker.jobs.registry import JobType


_BOUNDS = ("gt", "ge", "lt", "le", "min_length", "max_length")


#: bounds of list/dict items, which the settings' metadata cannot express (every number of a job config is bounded)
_ITEM_HINTS = {"initial_q_body_from_ecef": list[Annotated[float, Field(ge=-1.0, le=1.0)]] | None,
               "cn0_mask_dbhz": dict[str, Annotated[float, Field(ge=0.0, le=70.0)]]}


def _field_of(f: dataclasses.Field, hint):
    """(type, pydantic Field) of one settings field from its dataclass metadata (default, bounds, description)."""
    hint = _ITEM_HINTS.get(f.name, hint)
    default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
    kw = {k: v for k, v in f.metadata.items() if k in _BOUNDS}
    return hint, Field(default, description=f.metadata.get("description"), **kw)


def _model_of(record: type, name: str, extra: dict | None = None) -> type[BaseModel]:
    """Pydantic model generated from a settings dataclass (fields without metadata job=False), extra="forbid"."""
    hints = typing.get_type_hints(record)
    spec = {f.name: _field_of(f, hints[f.name]) for f in dataclasses.fields(record)
            if f.name not in GROUPS and f.metadata.get("job", True)}
    return create_model(name, __config__=ConfigDict(extra="forbid"), __doc__=record.__doc__, **spec, **(extra or {}))


#: job-only fields of the Table 2 group: the GPS L1/L2 C/N0 masks, pinned into cn0_mask_dbhz (null: the preset's)
_TABLE2_JOB = {
    "cn0_mask_l1_dbhz": (float | None, Field(None, ge=0, le=70, description="C/N0 mask of GPS L1 C/A, dB-Hz (seed 000 "
                                              "Table 2: 35; 0: none); null: the preset's.")),
    "cn0_mask_l2_dbhz": (float | None, Field(None, ge=0, le=70, description="C/N0 mask of GPS L2, dB-Hz (seed 000 "
                                              "Table 2: 30; 0: none); null: the preset's.")),
}
_GROUP_MODELS = {g: _model_of(t, f"Attitude{t.__name__}", _TABLE2_JOB if g == "table2" else None)
                 for g, t in GROUPS.items()}
#: legacy flat keys of the job config -> "group.field" (the settings' FLAT_TO_NESTED + the job's L1/L2 masks)
JOB_FLAT_TO_NESTED = {**{k: v for k, v in FLAT_TO_NESTED.items()
                         if v.split(".")[1] in _GROUP_MODELS[v.split(".")[0]].model_fields},
                      "cn0_mask_l1_dbhz": "table2.cn0_mask_l1_dbhz",
                      "cn0_mask_l2_dbhz": "table2.cn0_mask_l2_dbhz"}


class _AttitudeConfigBase(BaseModel):
    """Attitude job config. Canonical JSON: nested groups ({"table1": {...}, "table2": {...}, "ambiguity",
    "noise", "smoothing", "adaptive", "calibration"}) over a named `preset`; the old flat keys (e.g.
    "sigma_code_m", "smoother") are accepted too and translated by JOB_FLAT_TO_NESTED. Defaults shown are the
    seed000 preset's; with another preset, unset fields take the preset's values. Terrestrial platforms change
    two of them unless they are set (`platform_defaults`; the schema's "x-platform-defaults" lists each with its
    reason)."""

    # the defaults by platform kind with their reasons, as data in the job type's schema (/v1/job-types)
    model_config = ConfigDict(extra="forbid", json_schema_extra={"x-platform-defaults": PLATFORM_DEFAULTS})

    @model_validator(mode="before")
    @classmethod
    def _nest_flat_keys(cls, data):
        if not isinstance(data, dict):
            return data
        out: dict = {}
        for key, val in data.items():
            if key in JOB_FLAT_TO_NESTED:
                g, name = JOB_FLAT_TO_NESTED[key].split(".")
                grp = out.setdefault(g, {})
                if not isinstance(grp, dict) or name in grp:
                    raise ValueError(f"{key} given both flat and in {g}")
                grp[name] = val
            elif key in GROUPS and isinstance(val, dict) and isinstance(out.get(key), dict):
                dup = sorted(set(out[key]) & set(val))
                if dup:
                    raise ValueError(f"{dup[0]} given both flat and in {key}")
                out[key] = {**out[key], **val}
            else:
                out[key] = val
        return out

    @field_validator("signals", check_fields=False)
    @classmethod
    def _unique(cls, v):
        unknown = [x for x in v if x not in SIGNALS]
        if unknown:
            raise ValueError(f"unknown signals {unknown}; known: {', '.join(SIGNALS)}")
        if len({SIGNAL_ALIASES.get(x, x) for x in v}) != len(v):
            raise ValueError("signals must not repeat")
        return v

    @field_validator("systems", check_fields=False)
    @classmethod
    def _unique_systems(cls, v):
        if v is not None and len(set(v)) != len(v):
            raise ValueError("systems must not repeat")
        return v

    @model_validator(mode="after")
    def _known_masks(self):
        bad = [k for k, x in self.table2.cn0_mask_dbhz.items() if k not in SIGNALS or not 0 <= x <= 70]
        if bad:
            raise ValueError(f"cn0_mask_dbhz: unknown signal or mask outside 0-70 dB-Hz: {bad}")
        return self

    def to_settings(self) -> AttitudeSettings:
        """The filter settings: the preset, then every field given (nested or flat), the L1/L2 masks pinned."""
        d = self.model_dump(exclude_unset=True)
        preset = d.pop("preset", "seed000")
        cal = d.pop("calibrated_baselines", None) or {}
        d.pop("pcv_map_ids", None)          # resolved from the store by the pipeline (maps_for_settings)
        t2 = d.setdefault("table2", {})
        base = AttitudeSettings.preset(preset)
        cn0 = {**t2.get("cn0_mask_dbhz", base.table2.cn0_mask_dbhz)}
        for key, sig in (("cn0_mask_l1_dbhz", "L1"), ("cn0_mask_l2_dbhz", "L2")):
            val = t2.pop(key, None)
            cn0[sig] = cn0_mask_of(base, sig) if val is None else val
        t2["cn0_mask_dbhz"] = cn0
        cal_map = {}
        for b in cal.get("baselines", []) if isinstance(cal, dict) else []:
            if {"from", "to", "calibrated_m"} <= set(b):
                cal_map[(b["from"], b["to"])] = b["calibrated_m"]
        d.setdefault("calibration", {})["calibrated_baselines"] = cal_map
        return base.override(**d)


_JOB_EXTRA = {
    "preset": (Literal[tuple(PRESETS)], Field("seed000", description="Named settings the fields given here "
                                               "override (gnssatt.attitude.settings.PRESETS): seed000 = Tables "
                                               "1-2; all-phases = no C/N0 or antenna-frame masks; "
                                               "all-phases-smoother = all-phases + RTS smoothing; "
                                               "all-phases-adaptive-smoother = that + the adaptive omega noise.")),
    "calibrated_baselines": (CalibratedBaselines | None, Field(
        None, description="A calibration job's baselines.json object (CONVENTIONS.md) replacing the a priori "
                          "antenna positions.")),
    "pcv_map_ids": (list[str], Field(
        [], max_length=32, description="Ids of stored differential PCV maps (/v1/pcv-maps), at most one per "
                                       "baseline and signal, subtracted from the phase single differences of "
                                       "fixed baselines (directions with an empty bin then leave the solution).")),
}
_TOP_HINTS = typing.get_type_hints(AttitudeSettings)
AttitudeConfig = create_model(
    "AttitudeConfig", __base__=_AttitudeConfigBase, __doc__=_AttitudeConfigBase.__doc__,
    **{f.name: _field_of(f, _TOP_HINTS[f.name]) for f in dataclasses.fields(AttitudeSettings)
       if f.name not in GROUPS and f.metadata.get("job", True)},
    **{g: (m, Field(default_factory=m, description=GROUPS[g].__doc__)) for g, m in _GROUP_MODELS.items()},
    **_JOB_EXTRA)


JOB_TYPE = JobType(
    name="attitude", title="Attitude from multi-antenna GNSS",
    description="Carrier-phase attitude of a rigid platform with two or more antennas: the CASSIOPE/GAP filter "
                "(seed 000) over single differences, MLAMBDA with baseline-length validation, QUEST, honest "
                "sigmas. Products: attitude.csv, baselines.csv, residuals.csv, events.csv, summary.json, and "
                "attitude.aem (spacecraft) or heading.nmea (terrestrial).",
    config_model=AttitudeConfig, pipeline="worker.jobs.attitude:run", min_sets=1, max_sets=1,
    produces=("attitude.csv", "baselines.csv", "residuals.csv", "events.csv", "errors.csv", "charts.json",
              "summary.json", "attitude.aem", "heading.nmea", "euler.png", "fix_status.png", "dop.png",
              "residuals.png", "skyplot.png", "elevation.png", "skyplot_fix.png", "report.html"))


def maps_for_settings(docs: list[tuple[str, dict]], baselines: list[tuple[str, str]]) -> dict:
    """(first, second, frequency) -> map dict for AttitudeSettings.calibration.pcv_maps from (map id, CONVENTIONS JSON)
    pairs; ValueError naming the map when one is malformed, is not for a baseline of the platform, or repeats a
    (pair, frequency)."""
    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.gnss.io.pcv_map import parse_pcv_map

    out: dict = {}
    for map_id, doc in docs:
        try:
            grid = parse_pcv_map(doc, f"PCV map {map_id}")
        except ParseError as exc:
            raise ValueError(str(exc)) from exc
        key = (grid.first, grid.second, grid.frequency)
        if (grid.first, grid.second) not in set(map(tuple, baselines)):
            raise ValueError(f"PCV map {map_id} is for the pair {grid.first}>{grid.second}, not a baseline of the "
                             f"platform ({', '.join(f'{a}>{b}' for a, b in baselines)})")
        if key in out:
            raise ValueError(f"two PCV maps for {grid.first}>{grid.second} {grid.frequency} (one is {map_id})")
        out[key] = grid.to_json()
    return out


# ---- the pipeline: parse the set, run gnssatt.attitude.process, write the products

log = logging.getLogger("gnssatt.attitude")
#: imported by the worker at start (worker.main.preload_pipelines), not by the first job: the pipeline's modules
#: and those it imports inside functions (the readers, orbits, chart series, the smoother), so that a job child of
#: the fork server imports nothing (~0.2-0.4 s per job without .pyc files, PYTHONDONTWRITEBYTECODE;
#: tests/worker/test_preload.py)
PRELOAD = ("gnssatt.attitude.process", "gnssatt.attitude.products", "gnssatt.attitude.statistics",
           "gnssatt.attitude.chart_series", "gnssatt.attitude.quality", "gnssatt.attitude.smoother",
           "gnssatt.attitude.process_noise_em",
           "gnssatt.gnss.io.rinex_obs", "gnssatt.gnss.io.rinex_nav", "gnssatt.gnss.io.sp3",
           "gnssatt.gnss.io.platform", "gnssatt.gnss.io.reference_attitude", "gnssatt.gnss.io.reader_warnings",
           "gnssatt.gnss.io.compression", "gnssatt.gnss.orbits.broadcast", "gnssatt.gnss.orbits.sp3_interp",
           "gnssatt.gnss.ephemeris", "gnssatt.gnss.geometry", "gnssatt.gnss.positioning",
           "gnssatt.plots.attitude", "gnssatt.plots.elevation", "gnssatt.report", "matplotlib.backends.backend_agg")


class StageClock:
    """Wall and CPU (worker.forked.cpu_s: the whole worker process and the plot process it forked, counted in
    the stage that waited for it) seconds per stage of one job, for the job's log: `mark(name)` closes the
    running stage and opens the next; `line()` is the log line."""

    def __init__(self) -> None:
        self.rows: list[tuple[str, float, float]] = []
        self._stage: str | None = None
        self._t = (time.perf_counter(), cpu_s())

    def mark(self, stage: str | None) -> None:
        now = (time.perf_counter(), cpu_s())
        if self._stage is not None:
            self.rows.append((self._stage, now[0] - self._t[0], now[1] - self._t[1]))
        self._stage, self._t = stage, now

    def line(self) -> str:
        total_wall, total_cpu = sum(r[1] for r in self.rows), sum(r[2] for r in self.rows)
        return ("stages (wall s / CPU s): " + "; ".join(f"{n} {w:.2f}/{c:.2f}" for n, w, c in self.rows)
                + f"; total {total_wall:.2f}/{total_cpu:.2f}")


def run(ctx: JobContext, config) -> None:
    from gnssatt.attitude.process import InputProblem, load_inputs, process
    from gnssatt.gnss.io.reader_warnings import reader_warnings
    from gnssatt.attitude.products import all_products, product_tables

    obs_set = ctx.require_one()
    clock = StageClock()
    clock.mark("reading files")
    ctx.progress(0.0, "reading files")
    from worker.forked import Forked

    files = [(f.name, f.kind, f.path) for f in obs_set.files]
    settings = config.to_settings()
    try:
        # the first ~2 s of a job are serial otherwise, and the worker has two cores: all RINEX observation files
        # but one are parsed in a forked child (load_inputs), and most of the satellite geometry is computed in
        # another while the filter runs (process)
        inputs = load_inputs(files, background=Forked)
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    if config.pcv_map_ids:
        docs = [(map_id, ctx.input_pcv_map(map_id)) for map_id in config.pcv_map_ids]
        try:
            settings.calibration.pcv_maps = maps_for_settings(docs, list(inputs.platform.baselines))
        except ValueError as exc:
            raise JobInputError("Unusable PCV map", str(exc), field="config.pcv_map_ids") from exc
    last = [0.0]

    def progress(fraction, stage=None):
        now = time.monotonic()
        if stage is not None:
            clock.mark(stage)
        if stage is not None or now - last[0] > 0.2:
            last[0] = now
            ctx.progress(0.05 + 0.85 * fraction, stage)

    try:
        sol = process(inputs, settings, progress, background=Forked)
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    clock.mark("product texts")
    ctx.progress(0.92, "writing products")
    sol.summary["observation_set_id"] = obs_set.id
    sol.summary["pcv_map_ids"] = list(config.pcv_map_ids)
    sol.summary["reader_warnings"] = reader_warnings([obs_set])
    tables = product_tables(sol)
    plots = _PlotJob(ctx, config, obs_set, sol, tables)
    try:
        products = all_products(sol)
        clock.mark("storing products")
        for name, content in products.items():
            ctx.write_product(name, content)
        clock.mark("plots")
        pngs = plots.draw()
    finally:
        plots.cancel()
    clock.mark("report and storing plots")
    _write_plots_and_report(ctx, config, obs_set, pngs, sol.summary)
    clock.mark(None)
    ctx.log(clock.line())
    log.info("attitude job %s %s", ctx.job_id, clock.line())
    ctx.progress(1.0, "done")


#: the plots by the forked process that draws them while the job writes the CSV products: two children, so that both
#: cores draw while this process formats and stores the texts (on the 106-minute pass ~1.0 s CPU for each group
#: against ~0.9 s of CSV texts + storing here: one child that drew the first three plots and the fix sky plot
#: while this process drew the rest after its texts left it ~0.5 s behind the child; docs/BENCHMARKS.md
#: "Attitude job speed"). The second group reads events.csv, made by its child from the solution.
PLOT_GROUPS = (("residuals.png", "skyplot.png", "elevation.png"),
               ("euler.png", "fix_status.png", "dop.png", "skyplot_fix.png"))


class _PlotJob:
    """The job's PNG plots (seed 000 Figs. 5-7 style Euler errors, fix status, DOP, residuals, sky plots), each
    group of PLOT_GROUPS drawn by a child forked at once (it inherits the solution and `tables` without a copy).
    The plots take the CSV products' column arrays (`tables`, gnssatt.attitude.products.product_tables), not the
    texts parsed back; events.csv is the only text they read."""

    def __init__(self, ctx: JobContext, config, obs_set, sol, tables: dict):
        from gnssatt.plots import PlotContext
        from worker.forked import Forked

        ctx.progress(0.93, "plotting")
        refs = obs_set.of_kind("reference_attitude")
        reference_path = refs[0].path if refs else None
        # the plot titles name the few settings that change what a plot shows; the report shows the config once
        context = PlotContext(set_name=obs_set.name or obs_set.id, job_id=ctx.job_id,
                              config={"preset": config.preset, "mode": config.mode})
        self.children = [Forked(lambda names=names: _draw_group(sol, tables, reference_path, context, names))
                         for names in PLOT_GROUPS]

    def draw(self) -> dict[str, bytes]:
        """Every PNG by name in report order."""
        from gnssatt.plots.attitude import PLOT_NAMES

        pngs: dict[str, bytes] = {}
        for child in self.children:
            pngs.update(child.result())
        return {name: pngs[name] for name in PLOT_NAMES if name in pngs}

    def cancel(self) -> None:
        for child in self.children:
            child.cancel()


def _draw_group(sol, tables: dict, reference_path, context, names) -> dict[str, bytes]:
    """The PNGs `names` of the solution (in a plot child): tables for the CSVs they hold, events.csv's text, and
    the reference attitude CSV only when euler.png is drawn."""
    from gnssatt.attitude.products import events_csv
    from gnssatt.plots.attitude import attitude_plots

    products = dict(tables)
    if "fix_status.png" in names:
        products["events.csv"] = events_csv(sol)
    reference = reference_path.read_text() if reference_path is not None and "euler.png" in names else None
    return attitude_plots(products, reference, context, names=names)


def _write_plots_and_report(ctx: JobContext, config, obs_set, pngs: dict, summary: dict) -> None:
    """The PNG plots and one self-contained report.html; see docs/pages.md."""
    from gnssatt.report import html_report

    for name, png in pngs.items():
        ctx.write_product(name, png, media_type="image/png")
    ctx.write_product("report.html", html_report(f"Attitude · {obs_set.name or obs_set.id}", summary, pngs,
                                                 config=config.model_dump(mode="json")), media_type="text/html")
