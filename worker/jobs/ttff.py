"""Job type `ttff`: the time-to-first-fix study of seed 000 sec. 5 (Table 5) over many observation sets, uploaded or
simulated on the fly, with the paper's method and the body-constrained integer search side by side. See docs/ttff.md.

run(): one fan-out task per set (uploaded sets by id; simulated starts by their start parameters, each task
simulating its own set into a scratch folder), then the Table 5 tables, runs.json/csv, summary.json and plots.
A task returns its set's result, or {"input_error": ...} for an unusable uploaded set so the parent fails the job
once, naming the set, instead of retrying the task. The science is imported inside the functions."""
from __future__ import annotations

import html
import shutil
import tempfile
import time
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.registry import JobType
from worker.jobs.sim_overrides import SimOverrides


class TtffSimulation(BaseModel):
    """Random starts simulated on the fly (preset `ttff`), one set per start, each simulated by its own task."""

    model_config = ConfigDict(extra="forbid")
    count: int = Field(20, ge=1, le=5000, description="Number of random starts (sets).")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="Seed of the starts and of the simulated observations.")
    yaw_max_deg: float = Field(180.0, ge=0, le=180, description="Start yaw uniform in +-this, orbital frame (deg).")
    pitch_max_deg: float = Field(70.0, ge=0, le=90, description="Start pitch uniform in +-this (deg).")
    roll_max_deg: float = Field(40.0, ge=0, le=180, description="Start roll uniform in +-this (deg).")
    rate_deg_s: list[Annotated[float, Field(gt=0, le=10)]] = Field([0.1, 0.5], min_length=2, max_length=2,
                                    description="Peak slew-back rate uniform in [min, max] (deg/s).")
    hold_s: float = Field(0.0, ge=0, le=3600, description="Start orientation held this long before the slew back (s).")
    realistic: bool = Field(True, description="The `ttff` preset as it is (50 mm p-p differential PCV, ~1 m code "
                                              "multipath at the antenna horizon, C/N0-dependent noise, docs/ttff.md "
                                              "'Realism'); false: white noise only, no PCV or multipath "
                                              "(consistency checks).")
    overrides: SimOverrides = Field(default_factory=SimOverrides,
                                      description="Further simulator parameters of the `ttff` preset "
                                                  "(docs/simulator.md), applied last.")

    @field_validator("overrides")
    @classmethod
    def _not_the_study_s_own(cls, v: SimOverrides) -> SimOverrides:
        own = sorted({"count", "duration_s", "start_gps", "waypoints", "random_initial_attitude"} & set(v.as_dict()))
        if own:
            raise ValueError(f"{', '.join(own)}: set by the study itself (count, duration_s and the starts)")
        return v

    @field_validator("rate_deg_s")
    @classmethod
    def _rates(cls, v):
        if not (0 < v[0] <= v[1] <= 10):
            raise ValueError("rate_deg_s must be [min, max] with 0 < min <= max <= 10")
        return v


class TtffConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    simulate: TtffSimulation | None = Field(None, description="Simulate the sets instead of (or as well as) using "
                                                              "uploaded ones.")
    configurations: list[Literal["L1+L2", "L1", "L2"]] = Field(["L1+L2", "L1", "L2"], min_length=1, description=(
        "Signal configurations studied: L1+L2, L1 or L2 alone."))
    methods: list[Literal["filter", "filter-constrained", "epoch-lambda", "epoch-constrained"]] = Field(
        ["filter", "epoch-lambda", "epoch-constrained"], min_length=1,
        description="filter: the seed 000 EKF (MLAMBDA + length validation), the paper's method; "
                    "filter-constrained: the same EKF with the attitude job's ambiguity_search 'constrained' "
                    "(MC-LAMBDA first fix); epoch-lambda: "
                    "every epoch alone, same search and validation; epoch-constrained: every epoch alone, "
                    "C-/MC-LAMBDA with the body geometry, ratio + length + angle validation.")
    duration_s: float = Field(120.0, ge=5, le=86400, description="Length of each set used from its first epoch (s).")
    single_epoch_step_s: float = Field(10.0, ge=1, le=3600,
                                       description="Sampling of the single-epoch success rate (s).")
    min_ratio_constrained: float = Field(1.5, ge=1.0, le=100.0,
                                         description="Ratio of the constrained objective for an accepted fix.")
    max_length_error_m: float = Field(0.03, gt=0, le=1.0, description="Length test: largest |length - known| of a "
                                                                     "fix (m; seed 000 Table 2).")
    l2_min_ratio_first_fix: float = Field(2.0, ge=0.0, le=100.0,
                                          description="Paper's method (filter) in the L2-only configuration: a first "
                                                      "fix also needs this MLAMBDA ratio (0: the length test alone, "
                                                      "as seed 000; docs/ttff.md 'Wrong fixes of L2').")
    filter_mode: Literal["dynamic", "kinematic"] = Field("dynamic",
                                                   description="Attitude filter mode: dynamic or kinematic.")

    @model_validator(mode="after")
    def _unique(self):
        if len(set(self.configurations)) != len(self.configurations) or len(set(self.methods)) != len(self.methods):
            raise ValueError("configurations and methods must not repeat")
        return self


JOB_TYPE = JobType(
    name="ttff", title="Time to first fix study (seed 000 Table 5)",
    description="For every observation set (uploaded, or random off-pointing starts simulated on the fly): time "
                "from filter start to the first accepted ambiguity fix per baseline and frequency configuration "
                "(L1+L2, L1, L2), whether it was right (against truth when the set has it), single-epoch success "
                "rates, initial yaw/pitch/roll; the paper's method next to the body-constrained search. One "
                "fan-out task per set.",
    config_model=TtffConfig, pipeline="worker.jobs.ttff:run", min_sets=0, max_sets=None,
    produces=("table5_<method>.csv", "table5_<method>.md", "table5.html", "runs.json", "runs.csv", "summary.json",
              "ttff_table.png (up to 50 sets)", "ttff_histogram.png", "report.html"))


# ---- the pipeline (fan-out task per set, tables, plots)

#: ttff_table.png is drawn up to this many sets (matplotlib's table: ~3 s of the parent's CPU at 200 sets).
TABLE_PLOT_MAX_SETS = 50


def _options(d: dict):
    from gnssatt.ttff.single_epoch import SingleEpochOptions
    from gnssatt.ttff.study import StudyOptions

    se = SingleEpochOptions(max_length_error_m=d["max_length_error_m"],
                            min_ratio_constrained=d["min_ratio_constrained"])
    return StudyOptions(configurations=tuple(d["configurations"]), methods=tuple(d["methods"]),
                        max_duration_s=d["duration_s"], single_epoch_step_s=d["single_epoch_step_s"],
                        filter_settings={"mode": d["filter_mode"],
                                         "ambiguity": {"max_length_error_m": d["max_length_error_m"]}},
                        filter_settings_by_configuration={
                            "L2": {"ambiguity": {"min_ratio_first_fix": d.get("l2_min_ratio_first_fix", 2.0)}}},
                        single_epoch=se)


def _one_thread():
    """Single-threaded BLAS inside a task (small matrices: threads only contend; measured 4-8x faster)."""
    try:
        from threadpoolctl import threadpool_limits
        return threadpool_limits(1)
    except ImportError:  # pragma: no cover - optional
        import contextlib
        return contextlib.nullcontext()


def set_task(payload: dict, sets) -> dict:
    """One set of the study: gnssatt.ttff.study.run_set's result (+ "label"), or {"input_error": ...}."""
    from gnssatt.attitude.process import InputProblem
    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.ttff.data import load_study_set
    from gnssatt.ttff.study import run_set

    opts = _options(payload["options"])
    label = payload["label"]
    t0, c0 = time.perf_counter(), time.process_time()
    with _one_thread():
        if payload["source"] == "simulated":
            from gnssatt.sim import simulate_scenario

            tmp = Path(tempfile.mkdtemp(prefix="ttff_"))
            try:
                simulate_scenario("ttff", tmp, seed=int(payload["seed"]), overrides=payload["overrides"])
                files = ([(p.name, "rinex_obs", p) for p in sorted((tmp / "obs").glob("*.rnx"))]
                         + [("brdc.rnx", "rinex_nav", tmp / "nav" / "brdc.rnx"),
                            ("platform.sp3", "sp3", tmp / "platform.sp3"),
                            ("platform.json", "platform", tmp / "platform.json"),
                            ("reference_attitude.csv", "reference_attitude", tmp / "reference_attitude.csv")])
                t_sim = time.perf_counter() - t0
                ss = load_study_set(files, label, truth_dir=tmp / "truth", max_duration_s=opts.max_duration_s)
                out = run_set(ss, opts)
                out["simulation_seconds"] = round(t_sim, 3)
                out["start"] = payload.get("start")
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        else:
            s = next((x for x in sets if x.id == payload["set_id"]), None)
            if s is None:
                return {"input_error": {"title": "Set not found", "detail": f"set {label!r} is not an input"}}
            files = [(f.name, f.kind, f.path) for f in s.files]
            try:
                ss = load_study_set(files, label, max_duration_s=opts.max_duration_s)
            except InputProblem as exc:
                return {"input_error": {"title": exc.title, "detail": f"set {label!r}: {exc.detail}",
                                        "file": exc.file}}
            except ParseError as exc:
                return {"input_error": {"title": "An input file could not be parsed",
                                        "detail": f"set {label!r}: {exc}", "file": exc.path}}
            out = run_set(ss, opts)
    out["label"] = label
    out["task_seconds"] = round(time.perf_counter() - t0, 3)
    out["task_cpu_seconds"] = round(time.process_time() - c0, 3)    # the worker process's CPU (one task at a time)
    return out


def payloads(ctx: JobContext, config) -> list[dict]:
    """Task payloads: uploaded sets first (in the order given), then the simulated starts."""
    from gnssatt.ttff.starts import BENIGN_OVERRIDES, random_starts, start_overrides

    opts = {k: getattr(config, k) for k in ("configurations", "methods", "duration_s", "single_epoch_step_s",
                                            "min_ratio_constrained", "max_length_error_m", "filter_mode",
                                            "l2_min_ratio_first_fix")}
    out = []
    for s in ctx.sets:
        out.append({"source": "upload", "set_id": s.id, "label": s.name or s.id, "options": opts})
    sim = config.simulate
    if sim is not None:
        starts = random_starts(sim.count, sim.seed, sim.yaw_max_deg, sim.pitch_max_deg, sim.roll_max_deg,
                               tuple(sim.rate_deg_s))
        base = {} if sim.realistic else dict(BENIGN_OVERRIDES)
        for st in starts:
            ov = start_overrides(st, config.duration_s + 1.0, sim.hold_s, base)
            ov.update(sim.overrides.as_dict())
            out.append({"source": "simulated", "seed": int(sim.seed) * 100_003 + st["index"],
                        "overrides": ov, "start": dict(st), "label": f"start {st['index']:03d}", "options": opts})
    return out


def _html(runs: list[dict], methods: list[str], summary: dict) -> str:
    from gnssatt.ttff.study import table5_rows

    parts = ["<!doctype html><meta charset='utf-8'><title>Time to first fix</title>",
             "<style>table{border-collapse:collapse;font:12px sans-serif}td,th{border:1px solid #bbb;"
             "padding:2px 6px;text-align:right}</style>"]
    for m in methods:
        t = table5_rows(runs, m)
        parts.append(f"<h2>{html.escape(m)}</h2><table><tr>" + "".join(f"<th>{html.escape(c)}</th>"
                                                                        for c in t["columns"]) + "</tr>")
        for row in t["rows"] + t["footer"]:
            parts.append("<tr>" + "".join(f"<td>{html.escape(str(x))}</td>" for x in row) + "</tr>")
        parts.append("</table>")
    parts.append(f"<p>Wrong fixes in total: {summary['wrong_fixes_total']} (a wrong first fix is marked *).</p>")
    return "\n".join(parts)


def _tasks_per_worker(ctx: JobContext) -> dict:
    """{worker: [tasks, task seconds]} of this job's fan-out (how evenly the sets spread)."""
    out: dict = {}
    for r in getattr(ctx, "task_records", None) or []:
        d = out.setdefault(str(r.get("worker")), [0, 0.0])
        d[0] += 1
        d[1] = round(d[1] + (r.get("seconds") or 0.0), 2)
    return out


def run(ctx: JobContext, config) -> None:
    from gnssatt.ttff.study import runs_csv, summarize, table5_csv, table5_markdown

    tasks = payloads(ctx, config)
    if not tasks:
        raise JobInputError("Nothing to study", "give at least one observation set or a `simulate` block",
                            field="config.simulate")
    if config.simulate is not None and config.simulate.overrides.as_dict():
        from gnssatt.sim.scenarios import make_params
        try:
            make_params("ttff", tasks[-1]["overrides"])
        except ValueError as exc:
            raise JobInputError("Invalid simulation parameters", str(exc), field="config.simulate.overrides") \
                from exc
    t0 = time.perf_counter()
    results = ctx.map("worker.jobs.ttff:set_task", tasks, progress_span=(0.02, 0.9), stage="sets")
    bad = [r for r in results if "input_error" in r]
    if bad:
        e = bad[0]["input_error"]
        raise JobInputError(e["title"], e["detail"], file=e.get("file"))
    ctx.progress(0.92, "tables")
    runs = [row for r in results for row in r["runs"]]
    methods = list(dict.fromkeys(r["method"] for r in runs))
    summary = summarize(runs)
    summary.update({"configuration": config.model_dump(), "wall_seconds": round(time.perf_counter() - t0, 2),
                    "task_seconds_total": round(sum(r.get("task_seconds", 0.0) for r in results), 2),
                    "task_cpu_seconds_total": round(sum(r.get("task_cpu_seconds", 0.0) for r in results), 2),
                    "tasks_per_worker": _tasks_per_worker(ctx),
                    "sets_list": [{"label": r["label"], "initial_euler_deg": r["initial_euler_deg"],
                                   "truth": r["truth"], "n_epochs": r["n_epochs"], "start": r.get("start"),
                                   "seconds": r.get("task_seconds")} for r in results]})
    for m in methods:
        ctx.write_product(f"table5_{m}.csv", table5_csv(runs, m))
        ctx.write_product(f"table5_{m}.md", table5_markdown(runs, m), media_type="text/markdown")
    ctx.write_product("table5.html", _html(runs, methods, summary))
    ctx.write_product("runs.json", {"runs": runs, "sets": results and [
        {k: v for k, v in r.items() if k != "runs"} for r in results]})
    ctx.write_product("runs.csv", runs_csv(runs))
    ctx.write_product("summary.json", summary)
    ctx.progress(0.95, "plots")
    pngs: dict[str, bytes] = {}
    try:
        from gnssatt.plots.ttff import ttff_histogram_plot, ttff_plots

        main = "filter" if "filter" in methods else methods[0]
        main_runs = [r for r in runs if r["method"] == main]
        pctx = {"job_id": ctx.job_id, "config": {"method": main}}
        if len(results) <= TABLE_PLOT_MAX_SETS:
            pngs = ttff_plots(main_runs, pctx)
        else:   # a table image of hundreds of rows is unreadable and costs seconds: the tables carry it
            pngs = {"ttff_histogram.png": ttff_histogram_plot(main_runs, pctx)}
            ctx.log(f"ttff_table.png left out: {len(results)} sets > {TABLE_PLOT_MAX_SETS} (see table5_*.csv/md)")
        for name, png in pngs.items():
            ctx.write_product(name, png, media_type="image/png")
    except Exception as exc:  # noqa: BLE001 - plots are a convenience; the tables carry the result
        ctx.log(f"plots failed: {type(exc).__name__}: {exc}")
    from gnssatt.plots.ttff import table5
    from gnssatt.report import html_report

    tables = {f"Table 5 layout, method {m}": table5([r for r in runs if r["method"] == m]) for m in methods}
    ctx.write_product("report.html", html_report("Time to first fix", {k: v for k, v in summary.items()
                                                                       if k != "sets_list"}, pngs, tables),
                      media_type="text/html")
    ctx.progress(1.0, "done")
