"""Running one job exactly once: claim by lease, heartbeat, publish products atomically, reap the dead.

The job row is the source of truth. A worker claims a queued job with one conditional UPDATE (atomic on
SQLite, whose writers are serialised, and on PostgreSQL, where a concurrent claimer re-checks the WHERE
after the first commits), renews the lease while it runs, and finishes with another UPDATE guarded by
its lease token. A job whose worker died is put back in the queue by the reaper once its lease runs out
(on PostgreSQL the reaper reads with FOR UPDATE SKIP LOCKED so reapers on many machines share the work).
"""
from __future__ import annotations

import logging
import os
import shutil
import socket
import threading
import time
import traceback
import uuid
from datetime import datetime, timedelta
from functools import partial

from sqlalchemy import func, select, update
from sqlalchemy.orm import aliased

from core.models import Job, Product, utcnow
from core.pcv_store import add_pcv_map
from core.settings import Settings
from worker.context import JobContext
from worker.errors import JobCancelled, LeaseLost, is_permanent, log_text_for_exception, problem_for_exception
from worker.fanout import gather, reap_tasks
from worker.isolation import ChildFailed, isolated, run_budgeted
from worker.jobs.registry import get_job_type
from worker.queue import enqueue
from worker.runtime import Runtime, get_runtime, load_inputs, load_pcv_map, set_runtime

__all__ = ["Runtime", "set_runtime", "get_runtime", "load_inputs", "execute_job", "reap", "claim"]

log = logging.getLogger("gnssatt.worker")

TERMINAL_STATES = ("succeeded", "failed", "cancelled")


def run_claimed_job_message(job_id: str) -> None:
    """Huey task body: run the job if it can be claimed; a duplicate or stale message does nothing."""
    execute_job(get_runtime(), job_id)


# --- claim / heartbeat / finish -------------------------------------------------------------------

def _lease_until(rt: Runtime) -> datetime:
    return utcnow() + timedelta(seconds=rt.settings.lease_seconds)


def claim(rt: Runtime, job_id: str) -> tuple[str, int] | None:
    """Claim a queued job: returns (lease token, attempt number) or None if someone else has it, or when its
    team already runs GNSSATT_MAX_RUNNING_JOBS_PER_TEAM jobs (it stays queued; `ring_waiting` wakes it)."""
    token = f"{rt.worker_name}/{uuid.uuid4().hex[:8]}"
    now = utcnow()
    running = aliased(Job)
    team_running = (select(func.count()).select_from(running)
                    .where(running.team_id == Job.team_id, running.state == "running").scalar_subquery())
    with rt.Session.begin() as s:
        res = s.execute(update(Job).where(Job.id == job_id, Job.state == "queued",
                                          Job.cancel_requested.is_(False),
                                          team_running < rt.settings.max_running_jobs_per_team)
                        .values(state="running", attempts=Job.attempts + 1, lease_owner=token,
                                lease_expires_at=_lease_until(rt), heartbeat_at=now, started_at=now,
                                finished_at=None, progress=0.0, stage="starting", error=None)
                        .execution_options(synchronize_session=False))
        if res.rowcount != 1:
            return None
        attempt = s.execute(select(Job.attempts).where(Job.id == job_id)).scalar_one()
    return token, attempt


class Heartbeat(threading.Thread):
    """Renews the lease every heartbeat_seconds and polls for a cancel request every second."""

    def __init__(self, rt: Runtime, job_id: str, token: str, ctx: JobContext, write_progress: bool = True):
        super().__init__(name=f"heartbeat-{job_id[:8]}", daemon=True)
        self.rt, self.job_id, self.token, self.ctx = rt, job_id, token, ctx
        self.write_progress = write_progress  # False: a job child writes its own progress
        self.stop_event = threading.Event()

    def run(self) -> None:
        last_renew = time.monotonic()
        poll_s = min(1.0, self.rt.settings.heartbeat_seconds)
        while not self.stop_event.wait(poll_s):
            try:
                renew = time.monotonic() - last_renew >= self.rt.settings.heartbeat_seconds
                if not self.beat(renew):
                    self.ctx.lease_lost.set()
                    return
                if renew:
                    last_renew = time.monotonic()
            except Exception:  # a database hiccup: try again next beat; the lease has slack
                log.warning("heartbeat of job %s failed:\n%s", self.job_id, traceback.format_exc(limit=2))

    def beat(self, renew: bool) -> bool:
        with self.rt.Session.begin() as s:
            values = {"progress": self.ctx.fraction, "stage": self.ctx.stage} if self.write_progress else {}
            if renew:
                values.update(lease_expires_at=_lease_until(self.rt), heartbeat_at=utcnow())
            if values:
                res = s.execute(update(Job).where(Job.id == self.job_id, Job.lease_owner == self.token,
                                                  Job.state == "running").values(**values)
                                .execution_options(synchronize_session=False))
                held = res.rowcount == 1
            else:
                held = s.execute(select(Job.id).where(Job.id == self.job_id, Job.lease_owner == self.token,
                                                      Job.state == "running")).first() is not None
            if not held:
                return False
            if s.execute(select(Job.cancel_requested).where(Job.id == self.job_id)).scalar_one():
                self.ctx.cancel_requested.set()
        return True


def ring_waiting(rt: Runtime, job_id: str) -> str | None:
    """After a job of a team stops running, enqueue that team's oldest queued job again (it may have been
    refused a claim at the team's limit); a duplicate message is harmless, the claim is conditional."""
    with rt.Session() as s:
        team_id = s.execute(select(Job.team_id).where(Job.id == job_id)).scalar_one_or_none()
        waiting = s.execute(select(Job.id).where(Job.team_id == team_id, Job.state == "queued",
                                                 Job.cancel_requested.is_(False))
                            .order_by(Job.created_at, Job.id).limit(1)).scalar_one_or_none()
    if waiting is not None:
        enqueue(rt.huey, waiting)
    return waiting


def _finish(rt: Runtime, job_id: str, token: str, **values) -> bool:
    """Move a running job we hold to its next state; False when the lease was lost meanwhile."""
    with rt.Session.begin() as s:
        res = s.execute(update(Job).where(Job.id == job_id, Job.lease_owner == token, Job.state == "running")
                        .values(lease_owner=None, lease_expires_at=None, **values)
                        .execution_options(synchronize_session=False))
        return res.rowcount == 1


def _publish_success(rt: Runtime, job_id: str, token: str, ctx: JobContext) -> bool:
    """Mark the job succeeded and insert its products, in one transaction guarded by the lease, under the blob
    store's shared lock with every product blob touched first (core/janitor.py: the janitor reads references and
    deletes under the exclusive lock, so it sees either fresh blobs or the committed rows)."""
    with rt.blobs.adding():
        missing = [rec.name for rec in ctx.products.values() if not rt.blobs.touch(rec.sha256)]
        if missing:
            raise RuntimeError(f"the stored blobs of products {missing} were removed before the job finished: it "
                               f"ran longer than GNSSATT_JOB_TIME_S plus the janitor's grace; raise "
                               f"GNSSATT_JOB_TIME_S to the longest a job of this size runs")
        return _insert_success(rt, job_id, token, ctx)


def _insert_success(rt: Runtime, job_id: str, token: str, ctx: JobContext) -> bool:
    with rt.Session.begin() as s:
        res = s.execute(update(Job).where(Job.id == job_id, Job.lease_owner == token, Job.state == "running")
                        .values(state="succeeded", progress=1.0, stage="done", finished_at=utcnow(),
                                lease_owner=None, lease_expires_at=None, log=_log_text(ctx))
                        .execution_options(synchronize_session=False))
        if res.rowcount != 1:
            s.rollback()
            return False
        for rec in ctx.products.values():
            s.add(Product(job_id=job_id, attempt=ctx.attempt, name=rec.name, media_type=rec.media_type,
                          sha256=rec.sha256, size_bytes=rec.size_bytes))
        if ctx.pcv_maps:
            team_id = s.execute(select(Job.team_id).where(Job.id == job_id)).scalar_one()
            from gnssatt.gnss.io.pcv_map import parse_pcv_map

            for name, doc in ctx.pcv_maps:
                add_pcv_map(s, rt.blobs, team_id, name, parse_pcv_map(doc, name), source_job_id=job_id)
    return True


def _log_text(ctx: JobContext) -> str | None:
    return "\n".join(ctx.log_lines[-2000:]) or None


# --- the whole life of one attempt ----------------------------------------------------------------

def _make_context(rt: Runtime, job_id: str, attempt: int, token: str, workdir) -> JobContext:
    """The pipeline's context, its callbacks bound to `rt` (the worker's, or a job child's own)."""
    def flush(fraction: float, stage: str | None) -> None:
        with rt.Session.begin() as s2:
            s2.execute(update(Job).where(Job.id == job_id, Job.lease_owner == token)
                       .values(progress=fraction, stage=stage).execution_options(synchronize_session=False))

    ctx = JobContext(job_id=job_id, attempt=attempt, sets=[], workdir=workdir,
                     _store_blob=lambda p: rt.blobs.put_file(p), _flush_progress=flush,
                     _store_hashed_blob=lambda p, sha: rt.blobs.put_file(p, sha))
    ctx._map = lambda function, payloads, span, stage, offset: gather(rt, ctx, function, payloads, span, stage,
                                                                      offset)
    ctx._load_pcv_map = lambda map_id: load_pcv_map(rt, job_id, map_id)
    return ctx


def _input_names(ctx: JobContext) -> dict[str, str]:
    """Blob path -> the file's name in its set (job errors name files as the user knows them)."""
    return {str(f.path): f.name for s in ctx.sets for f in s.files}


def _run_pipeline(rt: Runtime, ctx: JobContext, spec, config, token: str) -> None:
    """The pipeline, in a child process under the job budget (GNSSATT_JOB_ISOLATION=process) or in this thread."""
    if not isolated(rt):
        ctx.sets.extend(load_inputs(rt, ctx.job_id))
        ctx.progress(0.0, "running")
        spec.load_pipeline()(ctx, config)
        return
    # the config goes as JSON: the fork server pickles what it hands the child, and some job types' config
    # models are classes made at import (not picklable by name); the child validates it again
    out = run_budgeted(rt, ctx, partial(_pipeline_in_child, ctx.job_id, ctx.attempt, token, ctx.workdir,
                                        spec.name, config.model_dump(mode="json")))
    ctx.products.update(out["products"])
    ctx.pcv_maps.extend(out["pcv_maps"])
    ctx.log_lines.extend(out["log_lines"])
    ctx.task_records.extend(out["task_records"])


def _pipeline_in_child(job_id: str, attempt: int, token: str, workdir, job_type: str, config_json: dict,
                       child_rt: Runtime, names: dict) -> dict:
    """In the job's child (worker.isolation): the pipeline on the child's own runtime; what the parent publishes."""
    spec = get_job_type(job_type)
    config = spec.config_model.model_validate(config_json)
    cctx = _make_context(child_rt, job_id, attempt, token, workdir)
    cctx.sets.extend(load_inputs(child_rt, job_id))
    names.update(_input_names(cctx))
    cctx.progress(0.0, "running")
    spec.load_pipeline()(cctx, config)
    return {"products": cctx.products, "pcv_maps": cctx.pcv_maps, "log_lines": cctx.log_lines,
            "task_records": cctx.task_records}


def execute_job(rt: Runtime, job_id: str) -> str | None:
    """Claim and run one job; returns the state it was left in, or None when it could not be claimed. A job that
    ended (succeeded, failed, cancelled) has its webhook, if any, sent (worker.webhooks)."""
    state = _execute_job(rt, job_id)
    if state in TERMINAL_STATES:
        from worker.webhooks import notify_finished

        notify_finished(rt, job_id)
    return state


def _execute_job(rt: Runtime, job_id: str) -> str | None:
    claimed = claim(rt, job_id)
    if claimed is None:
        return None
    token, attempt = claimed
    with rt.Session() as s:
        job = s.get(Job, job_id)
        job_type, raw_config, max_attempts = job.type, dict(job.config or {}), job.max_attempts
    workdir = rt.settings.data_dir / "work" / f"{job_id}-{attempt}"
    shutil.rmtree(workdir, ignore_errors=True)
    workdir.mkdir(parents=True)
    ctx = _make_context(rt, job_id, attempt, token, workdir)
    beat = Heartbeat(rt, job_id, token, ctx, write_progress=not isolated(rt))
    beat.start()
    log.info("job %s (%s) attempt %d claimed by %s", job_id, job_type, attempt, token)
    try:
        spec = get_job_type(job_type)
        if spec is None:
            raise RuntimeError(f"unknown job type {job_type!r} in this worker")
        config = spec.config_model.model_validate(raw_config)
        _run_pipeline(rt, ctx, spec, config, token)
        ctx.check()
        if _publish_success(rt, job_id, token, ctx):
            log.info("job %s succeeded with %d products", job_id, len(ctx.products))
            return "succeeded"
        log.warning("job %s finished but its lease was lost; its products are dropped", job_id)
        return None
    except LeaseLost:
        log.warning("job %s attempt %d lost its lease; stopping without writing", job_id, attempt)
        return None
    except JobCancelled:
        _finish(rt, job_id, token, state="cancelled", finished_at=utcnow(), stage="cancelled", log=_log_text(ctx))
        log.info("job %s cancelled", job_id)
        return "cancelled"
    except Exception as exc:  # noqa: BLE001 - every failure becomes a stored problem document
        if isinstance(exc, ChildFailed):
            problem, permanent = exc.problem, exc.permanent
        else:
            problem, permanent = problem_for_exception(exc, job_id, attempt, _input_names(ctx)), is_permanent(exc)
            if not permanent:
                ctx.log(log_text_for_exception(exc))
        if not permanent:
            log.warning("job %s attempt %d: internal error\n%s", job_id, attempt, ctx.log_lines[-1:])
        if permanent or attempt >= max_attempts:
            _finish(rt, job_id, token, state="failed", finished_at=utcnow(), error=problem, log=_log_text(ctx))
            log.info("job %s failed: %s", job_id, problem.get("detail"))
            return "failed"
        log.warning("job %s attempt %d failed, will retry: %s", job_id, attempt, problem.get("detail"))
        if _finish(rt, job_id, token, state="queued", error=problem, enqueued_at=utcnow(), stage="retrying",
                   log=_log_text(ctx)):
            enqueue(rt.huey, job_id, delay_s=min(2.0 * attempt, 30.0))
        return "queued"
    finally:
        beat.stop_event.set()
        beat.join(timeout=5)
        shutil.rmtree(workdir, ignore_errors=True)
        try:
            ring_waiting(rt, job_id)
        except Exception:  # noqa: BLE001 - the reaper re-rings queued jobs anyway
            log.warning("could not ring the next queued job of job %s's team", job_id, exc_info=True)


# --- the reaper -----------------------------------------------------------------------------------

def reap(rt: Runtime) -> dict[str, int]:
    """Requeue jobs whose lease ran out (their worker died), re-ring jobs whose message was lost and resend
    webhooks left pending by a dead worker (worker.webhooks.resend_pending).

    Every change is a conditional UPDATE that re-checks what was read (state, expired lease, same owner),
    so reapers on many machines, and a worker claiming the job meanwhile, can never be overwritten by a
    stale read; on PostgreSQL the candidates are also read with FOR UPDATE SKIP LOCKED.
    """
    now = utcnow()
    to_enqueue: list[str] = []
    ended: list[str] = []  # failed or cancelled here: their webhooks are sent once the UPDATE is committed
    counts = {"requeued": 0, "failed": 0, "cancelled": 0, "rerung": 0}
    pg = rt.engine.dialect.name == "postgresql"
    with rt.Session.begin() as s:
        q = select(Job.id, Job.lease_owner, Job.cancel_requested, Job.attempts, Job.max_attempts).where(
            Job.state == "running", Job.lease_expires_at < now)
        if pg:
            q = q.with_for_update(skip_locked=True)
        for job_id, owner, cancel, attempts, max_attempts in s.execute(q).all():
            still = (Job.id == job_id, Job.state == "running", Job.lease_owner == owner, Job.lease_expires_at < now)
            if cancel:
                kind, values = "cancelled", {"state": "cancelled", "finished_at": now, "stage": "cancelled"}
            elif attempts >= max_attempts:
                kind, values = "failed", {"state": "failed", "finished_at": now, "error": {
                    "type": "https://gnssatt.dev/problems/worker-lost", "status": 500,
                    "title": "The worker running this job was lost",
                    "detail": f"the worker running this job stopped responding {attempts} times "
                              f"(max_attempts {max_attempts})", "job_id": job_id}}
            else:
                kind, values = "requeued", {"state": "queued", "stage": "requeued after lost worker",
                                            "enqueued_at": now}
            res = s.execute(update(Job).where(*still).values(lease_owner=None, lease_expires_at=None, **values)
                            .execution_options(synchronize_session=False))
            if res.rowcount == 1:
                counts[kind] += 1
                if kind == "requeued":
                    to_enqueue.append(job_id)
                else:
                    ended.append(job_id)
        stale = now - timedelta(seconds=rt.settings.requeue_after_seconds)
        q = select(Job.id).where(Job.state == "queued", Job.enqueued_at < stale)
        if pg:
            q = q.with_for_update(skip_locked=True)
        for job_id in s.execute(q).scalars().all():
            res = s.execute(update(Job).where(Job.id == job_id, Job.state == "queued", Job.enqueued_at < stale)
                            .values(enqueued_at=now).execution_options(synchronize_session=False))
            if res.rowcount == 1:
                to_enqueue.append(job_id)
                counts["rerung"] += 1
    for job_id in to_enqueue:
        enqueue(rt.huey, job_id)
    if ended:
        from worker.webhooks import notify_finished

        for job_id in ended:
            notify_finished(rt, job_id)
    counts["tasks_requeued"] = reap_tasks(rt)
    from worker.webhooks import resend_pending

    counts["webhooks_resent"] = resend_pending(rt)
    if any(counts.values()):
        log.info("reaper: %s", counts)
    return counts


def default_worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def cleanup_stale_workdirs(settings: Settings, older_than_s: float = 3600.0) -> None:
    root = settings.data_dir / "work"
    if not root.is_dir():
        return
    cutoff = time.time() - older_than_s
    for d in root.iterdir():
        if d.is_dir() and d.stat().st_mtime < cutoff:
            shutil.rmtree(d, ignore_errors=True)


