"""Running a fan-out's tasks in this process (scripts, unit tests, `gnssatt run`), and the task records that
this and the service's fan-out (worker/fanout.py) both keep.

A job context without a service (`JobContext._map` unset) runs `ctx.map` here: every task, in order, with the
same task functions and the same records the workers write. Imports nothing of the runtime.
"""
from __future__ import annotations

import importlib
from datetime import datetime, timezone
from typing import Any, Callable


def utcnow() -> datetime:
    return datetime.now(timezone.utc)


def load_task_function(function: str) -> Callable[[dict, list], Any]:
    """The task function named "module:function"."""
    module_name, _, func_name = function.partition(":")
    return getattr(importlib.import_module(module_name), func_name)


def run_locally(ctx, function: str, payloads: list[dict], progress_span: tuple[float, float],
                stage: str) -> list[Any]:
    """The same contract without a service (scripts, unit tests): run every task here, in order."""
    lo, hi = progress_span
    fn = load_task_function(function)
    out, records = [], []
    for i, payload in enumerate(payloads):
        ctx.progress(lo + (hi - lo) * i / max(len(payloads), 1), f"{stage}: {i}/{len(payloads)} done")
        start = utcnow()
        out.append(fn(payload, ctx.sets))
        records.append(task_record(stage, i, payload.get("label", ""), "local", 1, start, utcnow()))
    log_task_records(ctx, records)
    return out


def task_record(stage: str, index: int, label: str, worker: str | None, attempts: int, started_at,
                finished_at) -> dict:
    """One finished task: stage, index, label, worker, attempts, started_at / finished_at (aware UTC), seconds."""
    seconds = (finished_at - started_at).total_seconds() if started_at and finished_at else None
    return {"stage": stage, "index": index, "label": str(label), "worker": worker, "attempts": attempts,
            "started_at": started_at, "finished_at": finished_at, "seconds": seconds}


def log_task_records(ctx, records: list[dict]) -> None:
    """Keep the fan-out's task records on the context (ctx.task_records) and in the job log."""
    ctx.task_records.extend(records)
    for r in records:
        secs = "?" if r["seconds"] is None else f"{r['seconds']:.2f}"
        ctx.log(f"task {r['index']:4d} {r['label']:<24} worker={r['worker']} attempts={r['attempts']} "
                f"started={r['started_at'].isoformat() if r['started_at'] else '?'} seconds={secs}")
