"""The `selftest` pipeline (see worker/jobs/selftest.py)."""
from __future__ import annotations

import os
import socket
import time

from worker.context import JobContext
from worker.errors import JobInputError


def run(ctx: JobContext, config) -> None:
    ctx.write_product("early.json", {"attempt": ctx.attempt, "pid": os.getpid()})
    if ctx.attempt <= config.fail_attempts:
        if config.fail_as_input_error:
            raise JobInputError("Selftest asked to fail", f"attempt {ctx.attempt} fails on purpose",
                                field="config.fail_attempts")
        raise RuntimeError(f"selftest: attempt {ctx.attempt} fails on purpose (fail_attempts={config.fail_attempts})")
    start = time.monotonic()
    steps = max(int(config.duration_s / 0.1), 1)
    for k in range(steps):
        ctx.progress(k / steps, f"step {k + 1} of {steps}")
        time.sleep(config.duration_s / steps)
    tasks = []
    passes = []
    for k in range(config.fan_out_passes if config.fan_out else 0):
        lo = 0.5 + 0.45 * k / config.fan_out_passes
        passes.append(ctx.map("worker.pipelines.selftest:square_task",
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
