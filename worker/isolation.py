"""One job attempt in a child process under a memory and a time budget, so a runaway job fails with a clear
error, never takes the worker down, and is always cancellable.

The worker forks a child per attempt (Linux `fork`: the child starts with the worker's imported modules and
compiled kernels, no re-import). The child gets its own database connections and queue handle, limits its
data segment (RLIMIT_DATA: what it inherited plus twice the budget, a hard stop against an allocation burst)
and runs the pipeline; its products, log and records come back through a pipe. The parent keeps the lease and
heartbeat and watches the child every 0.2 s: memory the child owns (USS: private pages, /proc/<pid>/smaps_rollup)
above GNSSATT_JOB_MEMORY_MB, or wall time above GNSSATT_JOB_TIME_S, stops it (SIGKILL) and fails the job with
`JobBudgetExceeded` (not retried); a cancel request or a lost lease stops it the same way within a second,
whether or not the pipeline ever reports progress.
"""
from __future__ import annotations

import dataclasses
import logging
import multiprocessing
import os
import resource
import signal
import time
from typing import Any, Callable

from worker.context import JobContext
from worker.errors import (JobBudgetExceeded, JobCancelled, LeaseLost, is_permanent, log_text_for_exception,
                           problem_for_exception)
from worker.queue import make_huey
from worker.runtime import Runtime, set_runtime

log = logging.getLogger("gnssatt.worker")

POLL_S = 0.2
START_TIMEOUT_S = 30.0


class ChildFailed(Exception):
    """The pipeline raised in the child: its problem document, and whether another attempt could help."""

    def __init__(self, problem: dict, permanent: bool):
        super().__init__(problem.get("detail") or problem.get("title"))
        self.problem = problem
        self.permanent = permanent


def _status_kb(pid: int | str, field: str) -> int | None:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except (OSError, ValueError):
        return None
    return None


def owned_memory_bytes(pid: int) -> int | None:
    """Private (unshared) resident bytes of a process: what it allocated itself (USS), None off Linux."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            total = 0
            for line in fh:
                if line.startswith(("Private_Clean:", "Private_Dirty:")):
                    total += int(line.split()[1]) * 1024
            return total
    except (OSError, ValueError):
        rss_kb = _status_kb(pid, "VmRSS")
        return rss_kb * 1024 if rss_kb is not None else None


def _child_main(rt: Runtime, target: Callable[[Runtime], dict], conn, budget_bytes: int, job_id: str,
                attempt: int) -> None:
    """In the child: fresh connections, a data limit, the pipeline; one message back, then exit."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # the worker's Ctrl-C is the parent's to handle
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    data_kb = _status_kb("self", "VmData")
    if data_kb is not None:
        limit = data_kb * 1024 + 2 * budget_bytes
        try:
            resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))
        except (ValueError, OSError):
            pass
    rt.engine.dispose(close=False)  # the parent's pooled connections stay the parent's
    child = dataclasses.replace(rt, huey=make_huey(rt.settings))
    set_runtime(child)
    conn.send(("started",))
    names: dict[str, str] = {}
    try:
        out = target(child, names)
        conn.send(("ok", out))
    except MemoryError as exc:
        mb = budget_bytes // 2**20
        problem = problem_for_exception(JobBudgetExceeded(
            "Memory budget exceeded", f"The job needed more memory than the {mb} MB one job may use "
            "(GNSSATT_JOB_MEMORY_MB) and was stopped; try a shorter span or fewer sets."), job_id, attempt)
        conn.send(("error", problem, True, log_text_for_exception(exc)))
    except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent as a problem
        conn.send(("error", problem_for_exception(exc, job_id, attempt, names), is_permanent(exc),
                   log_text_for_exception(exc)))
    finally:
        conn.close()


def run_budgeted(rt: Runtime, ctx: JobContext, target: Callable[[Runtime, dict], dict]) -> dict[str, Any]:
    """Run target(child_runtime, names) in a child process under the budget; its returned dict, or raise
    JobCancelled / LeaseLost / JobBudgetExceeded / ChildFailed (the pipeline's own error) / RuntimeError."""
    settings = rt.settings
    budget_bytes = settings.job_memory_mb * 2**20
    mp = multiprocessing.get_context("fork")
    recv, send = mp.Pipe(duplex=False)
    proc = mp.Process(target=_child_main, args=(rt, target, send, budget_bytes, ctx.job_id, ctx.attempt),
                      name=f"job-{ctx.job_id[:8]}", daemon=True)
    start = time.monotonic()
    proc.start()
    send.close()
    peak = 0
    started = False
    try:
        while True:
            if recv.poll(POLL_S):
                try:
                    message = recv.recv()
                except EOFError:
                    message = None
                if message is not None and message[0] == "started":
                    started = True
                    continue
                proc.join(timeout=10)
                if message is None:
                    break
                if message[0] == "ok":
                    return message[1]
                _, problem, permanent, trace = message
                ctx.log(trace)
                raise ChildFailed(problem, permanent)
            if not proc.is_alive():
                break
            if not started and time.monotonic() - start > START_TIMEOUT_S:
                # a lock another thread held at fork time (an import in progress): another attempt will do
                raise RuntimeError(f"the job's process did not start within {START_TIMEOUT_S:g} s")
            if ctx.cancel_requested.is_set():
                raise JobCancelled(ctx.job_id)
            if ctx.lease_lost.is_set():
                raise LeaseLost(ctx.job_id)
            used = owned_memory_bytes(proc.pid) or 0
            peak = max(peak, used)
            if used > budget_bytes:
                raise JobBudgetExceeded(
                    "Memory budget exceeded", f"The job used {used / 2**20:.0f} MB, more than the "
                    f"{settings.job_memory_mb} MB one job may use (GNSSATT_JOB_MEMORY_MB), and was stopped; "
                    "try a shorter span or fewer sets, or ask the operator for a larger budget.")
            if time.monotonic() - start > settings.job_time_s:
                raise JobBudgetExceeded(
                    "Time budget exceeded", f"The job ran longer than the {settings.job_time_s:g} s one job may "
                    "take (GNSSATT_JOB_TIME_S) and was stopped; try a shorter span or fewer sets.")
        code = proc.exitcode
        how = f"signal {-code}" if code is not None and code < 0 else f"exit status {code}"
        raise RuntimeError(f"the job's process ended without a result ({how}); the machine may be short of memory")
    finally:
        if proc.is_alive():
            proc.kill()
            proc.join(timeout=10)
        recv.close()
        log.info("job %s attempt %d: child process peak private memory %.0f MB", ctx.job_id, ctx.attempt,
                 peak / 2**20)


def isolation_available() -> bool:
    return os.name == "posix" and "fork" in multiprocessing.get_all_start_methods()
