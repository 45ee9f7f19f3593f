"""The `attitude` pipeline: parse the set, run worker.attitude.process, write the products."""
from __future__ import annotations

import time

from worker.context import JobContext
from worker.errors import JobInputError


def run(ctx: JobContext, config) -> None:
    from worker.attitude.process import InputProblem, load_inputs, process
    from worker.attitude.products import all_products

    obs_set = ctx.require_one()
    ctx.progress(0.0, "reading files")
    files = [(f.name, f.kind, f.path) for f in obs_set.files]
    settings = config.to_settings()
    try:
        inputs = load_inputs(files)
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    last = [0.0]

    def progress(fraction, stage=None):
        now = time.monotonic()
        if stage is not None or now - last[0] > 0.2:
            last[0] = now
            ctx.progress(0.05 + 0.85 * fraction, stage)

    try:
        sol = process(inputs, settings, progress)
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    ctx.progress(0.92, "writing products")
    sol.summary["observation_set_id"] = obs_set.id
    for name, content in all_products(sol).items():
        ctx.write_product(name, content)
    ctx.progress(1.0, "done")
