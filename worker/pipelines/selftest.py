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
    ctx.write_product("selftest.json", {
        "attempt": ctx.attempt, "host": socket.gethostname(), "pid": os.getpid(),
        "elapsed_s": round(time.monotonic() - start, 3),
        "observation_sets": [{"id": s.id, "files": [f.name for f in s.files]} for s in ctx.sets]})
    ctx.progress(1.0, "done")
