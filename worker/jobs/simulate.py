"""Job type `simulate`: the truth simulator as a service (what-if studies before launch). run() simulates into
the work dir and zips the result as one product."""
from __future__ import annotations

import zipfile
from pydantic import BaseModel, ConfigDict, Field, field_validator

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.registry import JobType
from worker.jobs.sim_overrides import SimOverrides, check_job_size

SCENARIOS = ("earth-pointing", "slew", "ttff", "calibration", "hard", "cubesat", "ground-static")


class SimulateConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    scenario: str = Field("earth-pointing", description=f"One of {', '.join(SCENARIOS)} (see docs/simulator.md).")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="Random seed; same seed and parameters, same files.")
    overrides: SimOverrides = Field(default_factory=SimOverrides,
                                    description="Any preset parameter, e.g. {\"duration_s\": 600, \"count\": 3}; "
                                                "bounded (worker/jobs/sim_overrides.py).")

    @field_validator("scenario")
    @classmethod
    def _known(cls, value: str) -> str:
        if value not in SCENARIOS:
            raise ValueError(f"unknown scenario {value!r}; known: {', '.join(SCENARIOS)}")
        return value


JOB_TYPE = JobType(
    name="simulate", title="Simulate an observation set",
    description="Writes a realistic multi-antenna observation set with exactly known attitude: RINEX 3.04 per "
                "antenna, navigation, platform SP3, platform.json, reference attitude and a truth/ folder, as "
                "one zip per run (simulated_set.zip) plus summary.json.",
    config_model=SimulateConfig, pipeline="worker.jobs.simulate:run", min_sets=0, max_sets=0,
    produces=("simulated_set.zip", "summary.json"))


# ---- the pipeline


def run(ctx: JobContext, config) -> None:
    from gnssatt.sim import simulate_scenario

    from gnssatt.sim.scenarios import make_params

    out = ctx.workdir / "sim"
    overrides = config.overrides.as_dict()
    try:
        preset = make_params(config.scenario)
        check_job_size(overrides, preset.duration_s, preset.interval_s, preset.count)
        result = simulate_scenario(config.scenario, out, seed=config.seed, overrides=overrides,
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
