"""The `attitude` pipeline: parse the set, run gnssatt.attitude.process, write the products."""
from __future__ import annotations

import logging
import time

from worker.context import JobContext
from worker.errors import JobInputError

log = logging.getLogger("gnssatt.attitude")
#: imported by the worker at start (worker.main.preload_pipelines), not by the first job
PRELOAD = ("gnssatt.attitude.process", "gnssatt.attitude.products", "gnssatt.attitude.statistics",
           "gnssatt.plots.attitude", "gnssatt.report", "matplotlib.backends.backend_agg")


class StageClock:
    """Wall and CPU (time.process_time: the whole worker process) seconds per stage of one job, for the job's
    log: `mark(name)` closes the running stage and opens the next; `line()` is the log line."""

    def __init__(self) -> None:
        self.rows: list[tuple[str, float, float]] = []
        self._stage: str | None = None
        self._t = (time.perf_counter(), time.process_time())

    def mark(self, stage: str | None) -> None:
        now = (time.perf_counter(), time.process_time())
        if self._stage is not None:
            self.rows.append((self._stage, now[0] - self._t[0], now[1] - self._t[1]))
        self._stage, self._t = stage, now

    def line(self) -> str:
        total_wall, total_cpu = sum(r[1] for r in self.rows), sum(r[2] for r in self.rows)
        return ("stages (wall s / CPU s): " + "; ".join(f"{n} {w:.2f}/{c:.2f}" for n, w, c in self.rows)
                + f"; total {total_wall:.2f}/{total_cpu:.2f}")


def run(ctx: JobContext, config) -> None:
    from gnssatt.attitude.process import InputProblem, load_inputs, process
    from gnssatt.attitude.products import all_products, product_tables

    obs_set = ctx.require_one()
    clock = StageClock()
    clock.mark("reading files")
    ctx.progress(0.0, "reading files")
    files = [(f.name, f.kind, f.path) for f in obs_set.files]
    settings = config.to_settings()
    try:
        inputs = load_inputs(files)
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    if config.pcv_map_ids:
        from worker.jobs.attitude import maps_for_settings

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
        sol = process(inputs, settings, progress)
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    clock.mark("product texts")
    ctx.progress(0.92, "writing products")
    sol.summary["observation_set_id"] = obs_set.id
    sol.summary["pcv_map_ids"] = list(config.pcv_map_ids)
    products = all_products(sol)
    clock.mark("storing products")
    for name, content in products.items():
        ctx.write_product(name, content)
    clock.mark("plots")
    _write_plots_and_report(ctx, config, obs_set, products, product_tables(sol), sol.summary, clock)
    clock.mark(None)
    ctx.log(clock.line())
    log.info("attitude job %s %s", ctx.job_id, clock.line())
    ctx.progress(1.0, "done")


def _write_plots_and_report(ctx: JobContext, config, obs_set, products: dict, tables: dict, summary: dict,
                            clock: StageClock | None = None) -> None:
    """PNG plots (seed 000 Figs. 5-7 style Euler errors, fix status, DOP, residuals, sky plot) and one
    self-contained report.html; see docs/pages.md. The plots take the CSV products' column arrays (`tables`,
    gnssatt.attitude.products.product_tables) where there are some, not the texts parsed back."""
    from gnssatt.plots import PlotContext
    from gnssatt.plots.attitude import attitude_plots
    from gnssatt.report import html_report

    ctx.progress(0.95, "plotting")
    texts = {name: (content.decode() if isinstance(content, bytes) else content)
             for name, content in products.items() if name.endswith(".csv")}
    texts.update({name: table for name, table in tables.items() if name in texts})
    refs = obs_set.of_kind("reference_attitude")
    reference = refs[0].path.read_text() if refs else None
    context = PlotContext(set_name=obs_set.name or obs_set.id, job_id=ctx.job_id, config=config.model_dump())
    pngs = attitude_plots(texts, reference, context)
    if clock is not None:
        clock.mark("report and storing plots")
    for name, png in pngs.items():
        ctx.write_product(name, png, media_type="image/png")
    ctx.write_product("report.html", html_report(f"Attitude · {obs_set.name or obs_set.id}", summary, pngs),
                      media_type="text/html")
