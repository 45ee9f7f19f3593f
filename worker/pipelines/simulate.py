"""The `simulate` pipeline: run the simulator into the work dir, zip the result as one product."""
from __future__ import annotations

import zipfile

from worker.context import JobContext
from worker.errors import JobInputError


def run(ctx: JobContext, config) -> None:
    from gnssatt.sim import simulate_scenario

    out = ctx.workdir / "sim"
    try:
        result = simulate_scenario(config.scenario, out, seed=config.seed, overrides=config.overrides,
                                   progress=lambda f, stage: ctx.progress(0.9 * f, stage))
    except ValueError as exc:  # an unknown or impossible override: the user's to fix
        raise JobInputError("Invalid simulation parameters", str(exc), field="config.overrides") from exc
    ctx.progress(0.92, "packing")
    bundle = ctx.product_path("simulated_set.zip")
    with zipfile.ZipFile(bundle, "w", zipfile.ZIP_DEFLATED, compresslevel=6) as zf:
        for path in sorted(p for p in out.rglob("*") if p.is_file()):
            info = zipfile.ZipInfo(str(path.relative_to(out)), date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, path.read_bytes())
    ctx.write_product("simulated_set.zip", bundle, media_type="application/zip")
    ctx.write_product("summary.json", {"scenario": result.scenario, "seed": result.seed, "params": result.params,
                                       "sets": [{k: v for k, v in s.items() if k != "dir"} for s in result.sets]})
    ctx.progress(1.0, "done")
