"""Job type `inspect`: parse a set fully; summary.json and observations.csv (tracking per receiver,
satellite and signal: epochs, first/last epoch, mean C/N0, gaps, loss-of-lock count)."""
from __future__ import annotations

import csv
import io

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from worker.context import JobContext
from worker.jobs.registry import JobType


class InspectConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    gap_factor: float = Field(1.5, gt=1.0, le=1000.0,
                              description="A gap is a step between observed epochs longer than this many intervals.")


JOB_TYPE = JobType(
    name="inspect", title="Inspect an observation set",
    description="Parses every file of one observation set and reports what it holds: per receiver, satellite "
                "and signal the epochs observed, first and last epoch, mean C/N0, gaps and loss-of-lock count.",
    config_model=InspectConfig, pipeline="worker.jobs.inspect:run",
    min_sets=1, max_sets=1, produces=("summary.json", "observations.csv", "tracking.csv", "tracking.png", "cn0.png"))


# ---- the pipeline: full parse of every file, tracking statistics per receiver/satellite/signal


def run(ctx: JobContext, config) -> None:
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.tracking import tracking_table
    from gnssatt.plots.inspect import tracking_arrays

    obs_set = ctx.require_one()
    obs_files = obs_set.of_kind("rinex_obs")
    other = [f for f in obs_set.files if f.kind != "rinex_obs"]
    rows: list[dict] = []
    files_summary: list[dict] = []
    tracking: list[dict] = []  # per receiver, for the plots (gnssatt/plots/inspect.py)
    for i, f in enumerate(obs_files):
        ctx.progress(i / max(len(obs_files), 1) * 0.9, f"parsing {f.name}")
        obs = read_rinex_obs(f.path, name=f.name)
        ctx.check()
        table = tracking_table(obs, gap_factor=config.gap_factor)
        receiver = obs.header.marker_name or f.name
        tracking.append(tracking_arrays(obs, receiver))
        for r in table:
            rows.append({"file": f.name, "receiver": receiver, **r})
        files_summary.append({
            "name": f.name, "kind": f.kind, "marker_name": obs.header.marker_name,
            "version": obs.header.version, "n_epochs": int(len(obs.time)),
            "time_first": obs.time[0].iso() if len(obs.time) else None,
            "time_last": obs.time[-1].iso() if len(obs.time) else None,
            "satellites": list(obs.sats), "signals": {k: list(v) for k, v in obs.header.obs_types.items()},
            "n_observations": int(np.isfinite(obs.values).sum()),
            "warnings": [w.to_dict() for w in obs.header.warnings],
        })
    ctx.progress(0.92, "writing products")
    for f in other:
        files_summary.append({"name": f.name, "kind": f.kind, **f.summary})
    summary = {"observation_set_id": obs_set.id, "name": obs_set.name, "set": obs_set.summary,
               "files": files_summary, "n_tracking_rows": len(rows)}
    ctx.write_product("summary.json", summary)
    buf = io.StringIO()
    fields = ["file", "receiver", "satellite", "signal", "epochs", "first_epoch", "last_epoch",
              "mean_cn0_dbhz", "gaps", "loss_of_lock"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in r.items()})
    ctx.write_product("observations.csv", buf.getvalue())
    _write_plots(ctx, config, obs_set, tracking, buf.getvalue())
    ctx.progress(1.0, "done")


def _write_plots(ctx: JobContext, config, obs_set, tracking: list[dict], observations_csv: str) -> None:
    """tracking.csv (per receiver and epoch: satellites, mean C/N0; feeds the job page's interactive chart),
    tracking.png (satellites x GPS time coloured by C/N0) and cn0.png (mean C/N0 per satellite and receiver)."""
    from gnssatt.plots import PlotContext
    from gnssatt.plots.inspect import cn0_overview_plot, tracking_plot, tracking_series_csv

    ctx.progress(0.95, "plotting")
    context = PlotContext(set_name=obs_set.name or obs_set.id, job_id=ctx.job_id, config=config.model_dump())
    ctx.write_product("tracking.csv", tracking_series_csv(tracking))
    ctx.write_product("tracking.png", tracking_plot(tracking, context))
    ctx.write_product("cn0.png", cn0_overview_plot(observations_csv, context))
