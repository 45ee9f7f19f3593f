"""Fan-out: split one job into tasks that any worker may run, and gather their results.

`ctx.map(function, payloads)` inserts one `job_tasks` row per payload and rings the queue for each. Every
worker's consumer claims task rows with the same lease discipline as jobs (conditional UPDATE, heartbeat,
reaper). The parent's own worker does not sit idle while it waits: it claims and runs pending tasks of its
job itself, so one worker alone finishes the job, and N workers share it. Task functions are pure
(`function(payload, sets) -> dict`); results are pickled into the content-addressed blob store, so a
repeated task (its worker died) just overwrites an identical result, and a retried parent job reuses the
results its earlier attempt already has. A task a worker's consumer picks up runs in a child process under the
same memory and time budget as a job (worker.isolation, GNSSATT_JOB_MEMORY_MB / GNSSATT_JOB_TIME_S); a task over
it fails for good and fails its job with the same clear error. The tasks a job runs itself run in the job's own
child, inside the job's budget.
"""
from __future__ import annotations

import logging
import pickle
import threading
import time
import traceback
import uuid
from dataclasses import dataclass, field
from datetime import timedelta
from functools import partial
from typing import Any

from sqlalchemy import func, select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert

from core.models import Job, JobTask, utcnow
from worker.context import InputSet
from worker.errors import JobBudgetExceeded, JobCancelled, LeaseLost
from worker.inprocess import load_task_function, log_task_records, task_record
from worker.isolation import ChildFailed, isolated, run_budgeted
from worker.queue import enqueue_task
from worker.runtime import get_runtime, load_inputs

log = logging.getLogger("gnssatt.fanout")


class TaskFailed(RuntimeError):
    pass


#: how a task's stored error starts when it exceeded the budget: "<mark><title>: <detail>" (gather re-raises it)
BUDGET_MARK = "JobBudgetExceeded: "


def create_tasks(rt, job_id: str, function: str, payloads: list[dict], offset: int = 0) -> None:
    """Insert the task rows of one fan-out of a job at indices offset.. (idempotent: rows of an earlier attempt
    are kept with their results; a pipeline calls its fan-outs in the same order, so offsets repeat)."""
    rows = [{"id": uuid.uuid4().hex, "job_id": job_id, "idx": offset + i, "function": function, "payload": p,
             "state": "pending", "attempts": 0} for i, p in enumerate(payloads)]
    insert = pg_insert if rt.engine.dialect.name == "postgresql" else sqlite_insert
    with rt.Session.begin() as s:
        if rows:
            s.execute(insert(JobTask).values(rows).on_conflict_do_nothing(index_elements=["job_id", "idx"]))
        # tasks that failed in an earlier attempt of the parent get a fresh start
        s.execute(update(JobTask).where(JobTask.job_id == job_id, JobTask.state == "failed")
                  .values(state="pending", attempts=0, error=None).execution_options(synchronize_session=False))


def ring(rt, job_id: str) -> None:
    with rt.Session() as s:
        ids = s.execute(select(JobTask.id).where(JobTask.job_id == job_id, JobTask.state == "pending")
                        .order_by(JobTask.idx)).scalars().all()  # queue order = task order (longest first)
    for task_id in ids:
        enqueue_task(rt.huey, task_id)


def claim_task(rt, task_id: str | None = None, job_id: str | None = None) -> tuple[str, str] | None:
    """Claim one pending task (a given one, or any of a job's); returns (task id, lease token) or None."""
    token = f"{rt.worker_name}/{uuid.uuid4().hex[:8]}"
    for _ in range(5):
        with rt.Session() as s:
            if task_id is None:
                task_id_try = s.execute(select(JobTask.id).where(JobTask.job_id == job_id, JobTask.state == "pending")
                                        .order_by(JobTask.idx).limit(1)).scalar_one_or_none()
                if task_id_try is None:
                    return None
            else:
                task_id_try = task_id
        with rt.Session.begin() as s:
            res = s.execute(update(JobTask).where(JobTask.id == task_id_try, JobTask.state == "pending")
                            .values(state="running", attempts=JobTask.attempts + 1, lease_owner=token,
                                    worker=rt.worker_name, started_at=utcnow(),
                                    lease_expires_at=utcnow() + timedelta(seconds=rt.settings.lease_seconds))
                            .execution_options(synchronize_session=False))
        if res.rowcount == 1:
            return task_id_try, token
        if task_id is not None:
            return None
    return None


def _read_task(rt, task_id: str) -> tuple[str, dict, str, int, int, bool]:
    """function, payload, job id, attempts, the parent's max_attempts, and whether the parent still wants it."""
    with rt.Session() as s:
        task = s.get(JobTask, task_id)
        parent = s.get(Job, task.job_id)
        wanted = parent is not None and not parent.cancel_requested and parent.state not in ("failed", "cancelled")
        return (task.function, dict(task.payload), task.job_id, task.attempts,
                parent.max_attempts if parent else 3, wanted)


class _TaskHeartbeat(threading.Thread):
    """Renews a claimed task's lease; with a watch, also flags a lost lease and a cancelled or ended parent."""

    def __init__(self, rt, task_id: str, token: str, job_id: str, watch: "_TaskWatch | None" = None):
        super().__init__(daemon=True, name=f"task-{task_id[:8]}")
        self.rt, self.task_id, self.token, self.job_id, self.watch = rt, task_id, token, job_id, watch
        self.stop_event = threading.Event()

    def run(self) -> None:
        poll_s = min(1.0, self.rt.settings.heartbeat_seconds) if self.watch else self.rt.settings.heartbeat_seconds
        last_renew = time.monotonic()
        while not self.stop_event.wait(poll_s):
            try:
                renew = time.monotonic() - last_renew >= self.rt.settings.heartbeat_seconds - poll_s / 2
                if renew:
                    last_renew = time.monotonic()
                self.beat(renew)
            except Exception:  # noqa: BLE001 - next beat; the lease has slack
                log.warning("task heartbeat failed", exc_info=True)

    def beat(self, renew: bool) -> None:
        with self.rt.Session.begin() as s:
            if renew:
                res = s.execute(update(JobTask).where(JobTask.id == self.task_id, JobTask.lease_owner == self.token)
                                .values(lease_expires_at=utcnow() + timedelta(seconds=self.rt.settings.lease_seconds))
                                .execution_options(synchronize_session=False))
                if res.rowcount != 1 and self.watch:
                    self.watch.lease_lost.set()
            if self.watch:
                parent = s.execute(select(Job.cancel_requested, Job.state).where(Job.id == self.job_id)).first()
                if parent is None or parent.cancel_requested or parent.state in ("failed", "cancelled"):
                    self.watch.cancel_requested.set()


def run_task(rt, task_id: str, token: str, sets: list[InputSet] | None = None) -> bool:
    """Run a claimed task in this process; True when its result was stored."""
    function, payload, job_id, attempts, max_attempts, wanted = _read_task(rt, task_id)
    if not wanted:
        _settle(rt, task_id, token, state="cancelled")
        return False
    beat = _TaskHeartbeat(rt, task_id, token, job_id)
    beat.start()
    t0 = time.monotonic()
    try:
        sha = _compute(rt, function, payload, job_id, sets)
        ok = _settle(rt, task_id, token, state="done", result_sha256=sha)
        log.info("task %s of job %s (#%s) done by %s in %.2f s", task_id[:8], job_id[:8], payload.get("label", ""),
                 rt.worker_name, time.monotonic() - t0)
        return ok
    except Exception as exc:  # noqa: BLE001 - the task's failure is recorded, the parent decides
        _settle(rt, task_id, token, state="failed" if attempts >= max_attempts else "pending",
                error=_error_text(exc))
        log.warning("task %s of job %s failed (attempt %d): %s", task_id[:8], job_id[:8], attempts, exc)
        return False
    finally:
        beat.stop_event.set()
        beat.join(timeout=5)


def _compute(rt, function: str, payload: dict, job_id: str, sets: list[InputSet] | None) -> str:
    """The task function on its payload; the sha256 of its pickled result in the blob store."""
    if sets is None:
        sets = load_inputs(rt, job_id)
    if "_shared_sha256" in payload:
        payload["_shared"] = _shared_object(rt, payload["_shared_sha256"])
    result = load_task_function(function)(payload, sets)
    sha, _ = rt.blobs.put_bytes(pickle.dumps(result, protocol=5))
    return sha


def _error_text(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}\n" + "".join(traceback.format_exception(exc))[-3000:]


@dataclass
class _TaskWatch:
    """What worker.isolation watches while a task's child runs (the fields of a JobContext it reads)."""
    job_id: str
    attempt: int
    cancel_requested: threading.Event = field(default_factory=threading.Event)
    lease_lost: threading.Event = field(default_factory=threading.Event)
    log_lines: list[str] = field(default_factory=list)

    def log(self, text: str) -> None:
        self.log_lines.append(text)


def _task_in_child(function: str, payload: dict, job_id: str, child_rt, names: dict) -> dict:
    """In the task's child: the result's sha256, or the task function's error as text (MemoryError goes up: the
    child reports it as the budget's)."""
    try:
        return {"result_sha256": _compute(child_rt, function, payload, job_id, None)}
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - recorded on the task row, as in run_task
        return {"error": _error_text(exc)}


def run_task_budgeted(rt, task_id: str, token: str) -> bool:
    """Run a claimed task in a child process under the job budget (worker.isolation); True when its result was
    stored. Over the budget the task fails for good with the budget's error; a cancelled or ended parent job, or a
    lost lease, stops the child within a second."""
    function, payload, job_id, attempts, max_attempts, wanted = _read_task(rt, task_id)
    if not wanted:
        _settle(rt, task_id, token, state="cancelled")
        return False
    watch = _TaskWatch(job_id, attempts)
    beat = _TaskHeartbeat(rt, task_id, token, job_id, watch)
    beat.start()
    label = payload.get("label", "")
    what = f"fan-out task {label or task_id[:8]}"
    t0 = time.monotonic()
    retry_or_fail = "failed" if attempts >= max_attempts else "pending"
    try:
        out = run_budgeted(rt, watch, partial(_task_in_child, function, payload, job_id), what=what)
        if "error" in out:
            _settle(rt, task_id, token, state=retry_or_fail, error=out["error"])
            log.warning("task %s of job %s failed (attempt %d): %s", task_id[:8], job_id[:8], attempts,
                        out["error"].splitlines()[0])
            return False
        ok = _settle(rt, task_id, token, state="done", result_sha256=out["result_sha256"])
        log.info("task %s of job %s (#%s) done by %s in a child in %.2f s", task_id[:8], job_id[:8], label,
                 rt.worker_name, time.monotonic() - t0)
        return ok
    except JobBudgetExceeded as exc:
        _settle(rt, task_id, token, state="failed", error=f"{BUDGET_MARK}{exc.title}: {exc.detail}")
        log.warning("task %s of job %s: %s", task_id[:8], job_id[:8], exc.detail)
        return False
    except JobCancelled:
        _settle(rt, task_id, token, state="cancelled")
        return False
    except LeaseLost:
        log.warning("task %s of job %s lost its lease; stopping without writing", task_id[:8], job_id[:8])
        return False
    except (ChildFailed, RuntimeError) as exc:  # the child died or could not start: another attempt may do
        if isinstance(exc, ChildFailed) and exc.problem.get("type", "").endswith("/job-budget-exceeded"):
            # the child hit its data limit (MemoryError) before the parent's poll saw it over the budget: the
            # same budget error, so the parent job fails with it (not as an internal error)
            title, detail = exc.problem["title"], exc.problem["detail"]
            _settle(rt, task_id, token, state="failed", error=f"{BUDGET_MARK}{title}: {detail}")
            log.warning("task %s of job %s: %s", task_id[:8], job_id[:8], detail)
            return False
        permanent = isinstance(exc, ChildFailed) and exc.permanent
        trace = "\n".join(watch.log_lines)[-3000:]
        _settle(rt, task_id, token, state="failed" if permanent else retry_or_fail,
                error=f"{type(exc).__name__}: {exc}\n{trace}")
        log.warning("task %s of job %s failed (attempt %d): %s", task_id[:8], job_id[:8], attempts, exc)
        return False
    finally:
        beat.stop_event.set()
        beat.join(timeout=5)


_SHARED: dict[str, Any] = {}  # sha256 -> unpickled shared object of a fan-out (the last few, per process)


def _shared_object(rt, sha: str) -> Any:
    """The `shared` object of a ctx.map (stored once in the blob store), cached per process."""
    if sha not in _SHARED:
        if len(_SHARED) >= 2:
            _SHARED.pop(next(iter(_SHARED)))
        _SHARED[sha] = pickle.loads(rt.blobs.path(sha).read_bytes())
    return _SHARED[sha]


def _settle(rt, task_id: str, token: str, **values) -> bool:
    with rt.Session.begin() as s:
        res = s.execute(update(JobTask).where(JobTask.id == task_id, JobTask.lease_owner == token)
                        .values(lease_owner=None, lease_expires_at=None, finished_at=utcnow(), **values)
                        .execution_options(synchronize_session=False))
        return res.rowcount == 1


def run_task_message(task_id: str) -> None:
    """Queue entry point: claim and run one task if it is still pending."""
    rt = get_runtime()
    claimed = claim_task(rt, task_id=task_id)
    if claimed is not None:
        (run_task_budgeted if isolated(rt) else run_task)(rt, *claimed)


def gather(rt, ctx, function: str, payloads: list[dict], progress_span: tuple[float, float],
           stage: str, offset: int = 0) -> list[Any]:
    """Create, share, help run and wait for the tasks of one fan-out of this job (task indices offset..offset+n-1,
    so several fan-outs of one job never share rows); returns their results in payload order."""
    job_id = ctx.job_id
    n = len(payloads)
    in_this = (JobTask.job_id == job_id, JobTask.idx >= offset, JobTask.idx < offset + n)
    create_tasks(rt, job_id, function, payloads, offset)
    ring(rt, job_id)
    lo, hi = progress_span
    while True:
        ctx.check()
        with rt.Session() as s:
            counts = dict(s.execute(select(JobTask.state, func.count()).where(*in_this)
                                    .group_by(JobTask.state)).all())
        done = counts.get("done", 0)
        ctx.progress(lo + (hi - lo) * done / max(n, 1), f"{stage}: {done}/{n} done")
        if counts.get("failed"):
            with rt.Session() as s:
                bad = s.execute(select(JobTask).where(*in_this, JobTask.state == "failed")
                                .order_by(JobTask.idx).limit(1)).scalar_one()
                if (bad.error or "").startswith(BUDGET_MARK):
                    title, _, detail = bad.error[len(BUDGET_MARK):].partition(": ")
                    raise JobBudgetExceeded(title, detail)
                raise TaskFailed(f"task {bad.idx} ({bad.payload.get('label', '')}) failed {bad.attempts} times: "
                                 f"{(bad.error or '').splitlines()[0]}")
        if done == n:
            break
        claimed = claim_task(rt, job_id=job_id)
        if claimed is not None:
            run_task(rt, *claimed, sets=ctx.sets)
        else:
            time.sleep(0.2)
    with rt.Session() as s:
        rows = s.execute(select(JobTask).where(*in_this).order_by(JobTask.idx)).scalars().all()
        records = [task_record(stage, r.idx - offset, r.payload.get("label", ""), r.worker, r.attempts,
                               r.started_at, r.finished_at) for r in rows]
        shas = [r.result_sha256 for r in rows]
    log_task_records(ctx, records)
    return [pickle.loads(rt.blobs.path(sha).read_bytes()) for sha in shas]


def reap_tasks(rt) -> int:
    """Put tasks whose worker died back to pending (and ring the queue); returns how many.
    Conditional on the state and lease that were read, like the job reaper."""
    now = utcnow()
    ids = []
    with rt.Session.begin() as s:
        q = select(JobTask.id, JobTask.lease_owner).where(JobTask.state == "running", JobTask.lease_expires_at < now)
        if rt.engine.dialect.name == "postgresql":
            q = q.with_for_update(skip_locked=True)
        for task_id, owner in s.execute(q).all():
            res = s.execute(update(JobTask).where(JobTask.id == task_id, JobTask.state == "running",
                                                  JobTask.lease_owner == owner, JobTask.lease_expires_at < now)
                            .values(state="pending", lease_owner=None, lease_expires_at=None)
                            .execution_options(synchronize_session=False))
            if res.rowcount == 1:
                ids.append(task_id)
    for task_id in ids:
        enqueue_task(rt.huey, task_id)
    return len(ids)
