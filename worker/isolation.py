"""One job attempt (or one fan-out task) in a child process under a memory and a time budget, so a runaway job
fails with a clear error, never takes the worker down, and is always cancellable.

Children come from a fork server (multiprocessing's 'forkserver' start method): a fresh interpreter the worker
starts before any of its threads, which imports the pipelines and loads the compiled kernels once (worker.zygote)
and then forks one child per attempt from its single thread. No child can inherit a lock another thread held at
fork time (an import in progress once deadlocked a child forked from the threaded worker), and every child still
starts with the modules and kernels loaded. The child builds its own database connections and queue handle from
the settings, limits its data segment (RLIMIT_DATA: what it inherited plus twice the budget, a hard stop against
an allocation burst) and runs its target; the result, log and records come back through a pipe. The parent
keeps the lease and heartbeat and watches the child every 0.2 s: memory the child owns (USS: private pages,
/proc/<pid>/smaps_rollup) above GNSSATT_JOB_MEMORY_MB, or wall time above GNSSATT_JOB_TIME_S, stops it (SIGKILL)
and fails the work with `JobBudgetExceeded` (not retried); a cancel request or a lost lease stops it the same way
within a second, whether or not the pipeline ever reports progress. A child dies with the fork server, which
exits with the worker, so a killed worker leaves no job running.
"""
from __future__ import annotations

import ctypes
import logging
import multiprocessing
import os
import resource
import signal
import sys
import threading
import time
from typing import Any, Callable

from core.blobs import BlobStore
from core.db import make_engine, make_sessionmaker
from core.settings import Settings
from worker.errors import JobBudgetExceeded, JobCancelled, LeaseLost, is_permanent, log_text_for_exception, \
    problem_for_exception
from worker.queue import make_huey
from worker.runtime import Runtime, set_runtime

log = logging.getLogger("gnssatt.worker")

POLL_S = 0.2
START_TIMEOUT_S = 30.0
#: what the fork server imports before its first fork (the pipelines and the warmed kernels)
FORK_SERVER_PRELOAD = ("worker.zygote",)
_PR_SET_PDEATHSIG = 1

_fork_server_lock = threading.Lock()
_fork_server_ready = False


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


def isolation_available() -> bool:
    return os.name == "posix" and "forkserver" in multiprocessing.get_all_start_methods()


def isolated(rt: Runtime) -> bool:
    """Whether work runs in a budgeted child (GNSSATT_JOB_ISOLATION=process; not with Huey's immediate mode, in
    which tests run jobs inline)."""
    return (rt.settings.job_isolation == "process" and isolation_available()
            and not getattr(rt.huey, "immediate", False))


def _ready() -> None:
    """A child that does nothing: it starts once the fork server has finished its imports."""


def main_module_preload() -> tuple[str, ...]:
    """The worker's main module as the fork server should preload it. multiprocessing runs the parent's main
    module again in every child of the fork server, as __mp_main__ (`python -m client.cli worker`: the module
    client.cli; the `gnssatt` console script: its file, "__main__" in the preload list); imported once in the
    fork server, that re-run finds its imports (the CLI's HTTP client, ~80 ms per job child) already loaded.
    Nothing when the main module is a package's __main__ or interactive, which multiprocessing does not re-run."""
    main = sys.modules.get("__main__")
    name = getattr(getattr(main, "__spec__", None), "name", None)
    if name:
        return () if name == "__main__" or name.endswith(".__main__") else (name,)
    return ("__main__",) if getattr(main, "__file__", None) else ()


def start_fork_server(preload: tuple[str, ...] = FORK_SERVER_PRELOAD) -> None:
    """Start the fork server (once per process) and wait until it has imported `preload` (and the worker's main
    module, main_module_preload) and can fork: the worker calls it first, before any thread; run_budgeted calls
    it too, so a child's start watchdog never counts the fork server's own start (~20 s: the science imports and
    kernels)."""
    global _fork_server_ready
    with _fork_server_lock:
        if _fork_server_ready:
            return
        mp = multiprocessing.get_context("forkserver")
        # no effect once a fork server runs in this process
        mp.set_forkserver_preload(list(preload) + [m for m in main_module_preload() if m not in preload])
        proc = mp.Process(target=_ready, name="fork-server-ready", daemon=True)
        proc.start()
        proc.join()
        _fork_server_ready = True


def _die_with_parent() -> None:
    """SIGKILL this child when its parent (the fork server, which exits with the worker) dies (Linux prctl)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def _child_runtime(settings: Settings, worker_name: str) -> Runtime:
    """The child's own database engine, blob store and queue handle (nothing is shared with the worker)."""
    engine = make_engine(settings)
    rt = Runtime(settings=settings, engine=engine, Session=make_sessionmaker(engine),
                 blobs=BlobStore(settings.blobs_dir), huey=make_huey(settings), worker_name=worker_name)
    set_runtime(rt)
    return rt


def _memory_detail(what: str, used_mb: float | None, budget_mb: int) -> str:
    used = f"used {used_mb:.0f} MB, more than" if used_mb is not None else "needed more memory than"
    return (f"The {what} {used} the {budget_mb} MB one job or fan-out task may use (GNSSATT_JOB_MEMORY_MB) and "
            "was stopped; try a shorter span or fewer sets, or ask the operator to raise GNSSATT_JOB_MEMORY_MB.")


def _child_main(settings: Settings, worker_name: str, target: Callable[[Runtime, dict], dict], conn,
                job_id: str, attempt: int, what: str) -> None:
    """In the child: a data limit, fresh connections, the target; one message back, then exit."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # the worker's Ctrl-C is the parent's to handle
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent()
    logging.basicConfig(level=settings.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    budget_bytes = settings.job_memory_mb * 2**20
    data_kb = _status_kb("self", "VmData")
    if data_kb is not None:
        limit = data_kb * 1024 + 2 * budget_bytes
        try:
            resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))
        except (ValueError, OSError):
            pass
    names: dict[str, str] = {}
    try:
        child = _child_runtime(settings, worker_name)
        conn.send(("started",))
        out = target(child, names)
        conn.send(("ok", out))
    except MemoryError as exc:
        problem = problem_for_exception(JobBudgetExceeded(
            "Memory budget exceeded", _memory_detail(what, None, settings.job_memory_mb)), job_id, attempt)
        conn.send(("error", problem, True, log_text_for_exception(exc)))
    except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent as a problem
        conn.send(("error", problem_for_exception(exc, job_id, attempt, names), is_permanent(exc),
                   log_text_for_exception(exc)))
    finally:
        conn.close()


def _reap_later(proc) -> None:
    """A child that has sent its result exits on its own (tearing down a few hundred MB takes ~40 ms): the job is
    published meanwhile; a thread waits for it and kills it if it is still there after 10 s."""
    def wait() -> None:
        proc.join(timeout=10)
        if proc.is_alive():
            proc.kill()
            proc.join(timeout=10)

    threading.Thread(target=wait, name=f"reap-{proc.name}", daemon=True).start()


def run_budgeted(rt: Runtime, ctx, target: Callable[[Runtime, dict], dict], what: str = "job") -> dict[str, Any]:
    """Run target(child_runtime, names) in a child process under the budget; its returned dict, or raise
    JobCancelled / LeaseLost / JobBudgetExceeded / ChildFailed (the target's own error) / RuntimeError.

    `target` is pickled to the child (a module-level function, or a functools.partial of one, with plain
    arguments). `ctx` is what the parent watches: job_id, attempt, the cancel_requested and lease_lost events
    and log(text) (a JobContext, or a fan-out task's watch); `what` names the work in a budget error."""
    settings = rt.settings
    start_fork_server()
    mp = multiprocessing.get_context("forkserver")
    recv, send = mp.Pipe(duplex=False)
    proc = mp.Process(target=_child_main, args=(settings, rt.worker_name, target, send, ctx.job_id, ctx.attempt,
                                                what), name=f"job-{ctx.job_id[:8]}", daemon=True)
    start = time.monotonic()
    proc.start()
    send.close()
    peak = 0
    started = finished = False
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
                if message is not None and message[0] == "ok":
                    finished = True
                    _reap_later(proc)
                    return message[1]
                proc.join(timeout=10)
                if message is None:
                    break
                _, problem, permanent, trace = message
                ctx.log(trace)
                raise ChildFailed(problem, permanent)
            if not proc.is_alive():
                break
            if not started and time.monotonic() - start > START_TIMEOUT_S:
                raise RuntimeError(f"the {what}'s process did not start within {START_TIMEOUT_S:g} s")
            if ctx.cancel_requested.is_set():
                raise JobCancelled(ctx.job_id)
            if ctx.lease_lost.is_set():
                raise LeaseLost(ctx.job_id)
            used = owned_memory_bytes(proc.pid) or 0
            peak = max(peak, used)
            if used > settings.job_memory_mb * 2**20:
                raise JobBudgetExceeded("Memory budget exceeded",
                                        _memory_detail(what, used / 2**20, settings.job_memory_mb))
            if time.monotonic() - start > settings.job_time_s:
                raise JobBudgetExceeded(
                    "Time budget exceeded", f"The {what} ran longer than the {settings.job_time_s:g} s one job or "
                    "fan-out task may take (GNSSATT_JOB_TIME_S) and was stopped; try a shorter span or fewer "
                    "sets, or ask the operator to raise GNSSATT_JOB_TIME_S.")
        code = proc.exitcode
        how = f"signal {-code}" if code is not None and code < 0 else f"exit status {code}"
        raise RuntimeError(f"the {what}'s process ended without a result ({how}); the machine may be short of "
                           "memory")
    finally:
        if not finished and proc.is_alive():
            proc.kill()
            proc.join(timeout=10)
        recv.close()
        log.info("%s of job %s attempt %d: child process peak private memory %.0f MB", what, ctx.job_id,
                 ctx.attempt, peak / 2**20)
