"""Job type `selftest`: an operator's check of the whole job path (queue, worker, leases, progress,
cancellation, products) without any science. It reports progress for `duration_s`, writes a product
naming the attempt that made it, and can be told to fail its first attempts to show retries."""
from __future__ import annotations

import os
import socket
import time

from pydantic import BaseModel, ConfigDict, Field

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.registry import JobType


class SelftestConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    duration_s: float = Field(2.0, ge=0.0, le=3600.0, description="How long the job runs, reporting progress (s).")
    fail_attempts: int = Field(0, ge=0, le=100, description="Fail (as an internal error) the first N attempts.")
    fail_as_input_error: bool = Field(False, description="Fail as a user-input error instead (never retried).")
    fan_out: int = Field(0, ge=0, le=1000, description="Split into this many tasks that any worker may run.")
    fan_out_passes: int = Field(1, ge=1, le=5, description="Fan out this many times in a row (pass k squares, "
                                "cubes, ... each task's number) to check that passes never mix.")
    task_seconds: float = Field(0.2, ge=0.0, le=600.0, description="How long each fanned-out task works (s).")
    publish_pcv_map: str | None = Field(None, max_length=200,
                                        description="Publish a small flat test PCV map under this name.")
    allocate_mb: int = Field(0, ge=0, le=65536, description="Allocate (and touch) this much memory, 16 MB at a "
                             "time, to check the worker's memory budget (GNSSATT_JOB_MEMORY_MB).")
    spin_s: float = Field(0.0, ge=0.0, le=3600.0, description="Compute this long without reporting progress, to "
                          "check that the time budget and cancel stop a job that never yields (s).")


JOB_TYPE = JobType(
    name="selftest", title="Service self-test",
    description="Checks the job path end to end: runs for duration_s with progress, writes selftest.json "
                "with the attempt number; can fail its first attempts to show retries.",
    config_model=SelftestConfig, pipeline="worker.jobs.selftest:run", min_sets=0, max_sets=None,
    produces=("selftest.json", "early.json"))


# ---- the pipeline


def run(ctx: JobContext, config) -> None:
    ctx.write_product("early.json", {"attempt": ctx.attempt, "pid": os.getpid()})
    if ctx.attempt <= config.fail_attempts:
        if config.fail_as_input_error:
            raise JobInputError("Selftest asked to fail", f"attempt {ctx.attempt} fails on purpose",
                                field="config.fail_attempts")
        raise RuntimeError(f"selftest: attempt {ctx.attempt} fails on purpose (fail_attempts={config.fail_attempts})")
    hog = []
    for _ in range(config.allocate_mb // 16):
        hog.append(bytearray(16 * 2**20))  # zero-filled: every page touched
    spin_until = time.monotonic() + config.spin_s
    while time.monotonic() < spin_until:
        sum(range(10_000))
    del hog
    start = time.monotonic()
    steps = max(int(config.duration_s / 0.1), 1)
    for k in range(steps):
        ctx.progress(k / steps, f"step {k + 1} of {steps}")
        time.sleep(config.duration_s / steps)
    tasks = []
    passes = []
    for k in range(config.fan_out_passes if config.fan_out else 0):
        lo = 0.5 + 0.45 * k / config.fan_out_passes
        passes.append(ctx.map("worker.jobs.selftest:square_task",
                              [{"n": i, "power": k + 2, "seconds": config.task_seconds, "label": f"n={i}"}
                               for i in range(config.fan_out)],
                              progress_span=(lo, lo + 0.45 / config.fan_out_passes), stage=f"fan-out {k + 1}"))
    if passes:
        tasks = passes[0]
    if config.publish_pcv_map:
        ctx.publish_pcv_map(config.publish_pcv_map, {
            "platform": "selftest", "pair": ["A", "B"], "frequency": "L1", "azimuth_deg": [45.0, 135.0, 225.0, 315.0],
            "elevation_deg": [15.0, 45.0, 75.0], "values_mm": [[0.0, 0.5, None, 1.0]] * 3,
            "count": [[10, 10, 0, 10]] * 3, "sigma_mm": [[0.1, 0.1, None, 0.1]] * 3})
    ctx.write_product("selftest.json", {
        "tasks": tasks, "passes": passes,
        "attempt": ctx.attempt, "host": socket.gethostname(), "pid": os.getpid(),
        "elapsed_s": round(time.monotonic() - start, 3),
        "observation_sets": [{"id": s.id, "files": [f.name for f in s.files]} for s in ctx.sets]})
    ctx.progress(1.0, "done")


def square_task(payload: dict, sets) -> dict:
    """A fan-out task: works for payload['seconds'] and reports which worker process ran it."""
    time.sleep(float(payload.get("seconds", 0.0)))
    power = int(payload.get("power", 2))
    return {"n": payload["n"], "square": payload["n"] ** 2, "power": payload["n"] ** power,
            "worker": f"{socket.gethostname()}:{os.getpid()}"}
