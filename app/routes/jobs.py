"""/v1/jobs: submit (202), list, get, cancel, progress as Server-Sent Events, products."""
from __future__ import annotations

import asyncio
import json
import logging
import time
from typing import Annotated

from fastapi import APIRouter, Query, Request, Response
from fastapi.responses import FileResponse, StreamingResponse
from pydantic import ValidationError
from sqlalchemy import func, select, update
from sqlalchemy.exc import IntegrityError
from starlette.concurrency import run_in_threadpool

from app.deps import KEY_REVOKED, SessionDep, TeamDep, key_checker
from app.problems import Problem, ProblemError, not_found
from app.schemas.common import Page
from app.schemas.jobs import JobCreate, JobPublic, JobState, ProductPublic
from core.models import Job, JobSet, ObservationSet, PcvMap, Product, utcnow
from worker.jobs.registry import get_job_type, job_types
from worker.queue import enqueue

log = logging.getLogger("gnssatt.api")
router = APIRouter(prefix="/v1/jobs", tags=["jobs"])
ERRORS = {401: {"model": Problem}, 404: {"model": Problem}, 422: {"model": Problem}}
TERMINAL = ("succeeded", "failed", "cancelled")


def to_public(job: Job) -> JobPublic:
    return JobPublic(id=job.id, type=job.type, state=job.state, progress=job.progress, stage=job.stage,
                     created_at=job.created_at, started_at=job.started_at, finished_at=job.finished_at,
                     attempts=job.attempts, error=job.error, config=job.config or {},
                     observation_set_ids=list(job.set_ids or []))


def get_owned_job(session, team_id: str, job_id: str) -> Job:
    job = session.get(Job, job_id)
    if job is None or job.team_id != team_id:
        raise not_found("Job", job_id)
    return job


@router.post("", status_code=202, response_model=JobPublic,
             responses={**ERRORS, 409: {"model": Problem}, 202: {"headers": {"Location": {"schema": {"type": "string"},
                                                                 "description": "URL of the new job"}}}},
             summary="Submit a job")
def submit_job(body: JobCreate, request: Request, response: Response, team: TeamDep,
               session: SessionDep) -> JobPublic:
    spec = get_job_type(body.type)
    if spec is None:
        raise ProblemError(422, "unknown-job-type", "Unknown job type",
                           f"No job type {body.type!r}; known types: {', '.join(sorted(job_types()))}.",
                           field="type")
    try:
        config = spec.config_model.model_validate(body.config)
    except ValidationError as exc:
        errors = [{"field": "config." + ".".join(str(p) for p in e["loc"]), "message": e["msg"]}
                  for e in exc.errors()]
        raise ProblemError(422, "invalid-config", f"Invalid config for job type {spec.name!r}",
                           f"{errors[0]['field']}: {errors[0]['message']}", field=errors[0]["field"],
                           errors=errors) from exc
    ids = list(dict.fromkeys(body.observation_set_ids))
    if len(ids) < spec.min_sets or (spec.max_sets is not None and len(ids) > spec.max_sets):
        want = f"{spec.min_sets}" if spec.max_sets == spec.min_sets else \
            f"{spec.min_sets} to {spec.max_sets if spec.max_sets is not None else 'any number of'}"
        raise ProblemError(422, "wrong-set-count", "Wrong number of observation sets",
                           f"Job type {spec.name!r} takes {want} observation set(s); got {len(ids)}.",
                           field="observation_set_ids")
    if ids:
        owned = set(session.execute(select(ObservationSet.id).where(ObservationSet.id.in_(ids),
                                                                    ObservationSet.team_id == team.id)).scalars())
        missing = [i for i in ids if i not in owned]
        if missing:
            raise ProblemError(422, "unknown-observation-set", "Unknown observation set",
                               f"No observation set {missing[0]!r} is visible to your team.",
                               field="observation_set_ids")
    map_ids = list(getattr(config, "pcv_map_ids", None) or [])
    if map_ids:   # maps a job applies are checked now, not when a worker runs it
        owned_maps = set(session.execute(select(PcvMap.id).where(PcvMap.id.in_(map_ids),
                                                                  PcvMap.team_id == team.id)).scalars())
        for i, map_id in enumerate(map_ids):
            if map_id not in owned_maps:
                raise ProblemError(422, "unknown-pcv-map", "Unknown PCV map",
                                   f"No PCV map {map_id!r} is visible to your team; GET /v1/pcv-maps lists them.",
                                   field=f"config.pcv_map_ids.{i}")
    # refuse now what a worker could not run: platform, orbits, antennas' files, sensor logs, common epochs
    from app.preflight import check_job

    check_job(spec.name, config, [session.get(ObservationSet, i) for i in ids])
    from app.webhooks import check_webhook, register   # optional webhook of the job's end (issue 24)

    check_webhook(body.webhook_url, body.webhook_secret)
    now = utcnow()
    settings = request.app.state.settings
    job = Job(team_id=team.id, type=spec.name, config=config.model_dump(mode="json"), set_ids=ids,
              state="queued", progress=0.0, stage="queued", created_at=now, enqueued_at=now, attempts=0,
              max_attempts=settings.max_attempts, cancel_requested=False)
    job.sets = [JobSet(set_id=sid, position=i) for i, sid in enumerate(ids)]
    session.add(job)
    try:
        session.flush()
        made_secret = register(session, job, body.webhook_url, body.webhook_secret)
        session.commit()
    except IntegrityError as exc:  # a set deleted between the check above and this commit
        session.rollback()
        raise ProblemError(409, "set-deleted", "Observation set deleted meanwhile",
                           "One of the observation sets was deleted while the job was being submitted; "
                           "upload it again or choose another.", field="observation_set_ids") from exc
    try:
        enqueue(request.app.state.huey, job.id)
    except Exception:  # noqa: BLE001 - the job row is the truth: the reaper re-rings queued jobs
        log.warning("could not enqueue job %s now; a worker's reaper will pick it up", job.id, exc_info=True)
    response.headers["Location"] = f"/v1/jobs/{job.id}"
    public = to_public(job)
    if made_secret:
        public.webhook_secret = made_secret
    return public


@router.get("", response_model=Page[JobPublic], responses=ERRORS, summary="List jobs")
def list_jobs(team: TeamDep, session: SessionDep, state: JobState | None = None,
              type: Annotated[str | None, Query(max_length=60)] = None,
              limit: Annotated[int, Query(ge=1, le=500)] = 50,
              offset: Annotated[int, Query(ge=0, le=2**31)] = 0) -> Page[JobPublic]:
    q = select(Job).where(Job.team_id == team.id)
    if state is not None:
        q = q.where(Job.state == state)
    if type is not None:
        q = q.where(Job.type == type)
    total = session.execute(select(func.count()).select_from(q.subquery())).scalar_one()
    rows = session.execute(q.order_by(Job.created_at.desc(), Job.id).limit(limit).offset(offset)).scalars().all()
    return Page(items=[to_public(j) for j in rows], total=total, limit=limit, offset=offset,
                next_offset=offset + limit if offset + limit < total else None)


@router.get("/{job_id}", response_model=JobPublic, responses=ERRORS, summary="Get one job")
def get_job(job_id: str, team: TeamDep, session: SessionDep) -> JobPublic:
    return to_public(get_owned_job(session, team.id, job_id))


@router.post("/{job_id}/cancel", response_model=JobPublic, responses={**ERRORS, 409: {"model": Problem}},
             summary="Cancel a job")
def cancel_job(job_id: str, team: TeamDep, session: SessionDep) -> JobPublic:
    """A queued job is cancelled at once; a running one stops within a few seconds."""
    job = get_owned_job(session, team.id, job_id)
    if job.state in TERMINAL:
        raise ProblemError(409, "job-finished", "Job already finished",
                           f"Job {job_id} is {job.state}; there is nothing to cancel.", job_id=job_id)
    now = utcnow()
    session.execute(update(Job).where(Job.id == job_id, Job.state == "queued")
                    .values(state="cancelled", cancel_requested=True, finished_at=now, stage="cancelled")
                    .execution_options(synchronize_session=False))
    session.execute(update(Job).where(Job.id == job_id, Job.state == "running").values(cancel_requested=True)
                    .execution_options(synchronize_session=False))
    session.commit()
    session.refresh(job)
    return to_public(job)


#: a job's event stream reads the job every SSE_POLL_S; every SSE_FINAL_POLL_S once its progress is at least
#: SSE_FINAL_FROM (its last stretch: products and plots), for at most SSE_FINAL_FOR_S, so a client sees the end
#: ~25 ms after it on average instead of ~125 ms, at 20 reads a second for a few seconds of a job only; the
#: key is re-checked every KEY_RECHECK_S
SSE_POLL_S, SSE_FINAL_POLL_S, SSE_FINAL_FROM, SSE_FINAL_FOR_S, KEY_RECHECK_S = 0.25, 0.05, 0.9, 10.0, 1.0


def sse_poll_s(doc: dict, final_for_s: float) -> float:
    """Seconds until the event stream reads a job again: `doc` its public JSON, `final_for_s` how long the stream
    has seen it running in its last stretch."""
    final = doc.get("state") == "running" and doc.get("progress", 0.0) >= SSE_FINAL_FROM
    return SSE_FINAL_POLL_S if final and final_for_s < SSE_FINAL_FOR_S else SSE_POLL_S


@router.get("/{job_id}/events", responses={**ERRORS, 200: {"content": {"text/event-stream": {}},
                                                          "description": "Server-Sent Events"}},
            response_class=StreamingResponse, summary="Follow a job's progress (Server-Sent Events)")
async def job_events(job_id: str, request: Request, team: TeamDep, session: SessionDep):
    """Streams `event: progress` with the job as JSON whenever its state, progress or stage changes, and a
    final `event: end` once it has finished. Reconnect at will: the first event is the current state."""
    get_owned_job(session, team.id, job_id)
    session.close()  # hand the connection back: the stream may last for hours
    Session = request.app.state.Session
    still_allowed = key_checker(request, team.id)

    def snapshot(check_key: bool) -> dict | None:
        with Session() as s:
            if check_key and not still_allowed(s):
                return {"revoked": True}
            job = s.get(Job, job_id)
            return to_public(job).model_dump(mode="json") if job else None

    async def stream():
        last = None
        idle = 0.0
        key_checked = -1e9
        final_since = None
        while True:
            if await request.is_disconnected():
                return
            now = time.monotonic()
            check_key = now - key_checked >= KEY_RECHECK_S
            if check_key:
                key_checked = now
            doc = await run_in_threadpool(snapshot, check_key)
            if doc is None:
                return
            if doc.get("revoked"):
                yield f"event: error\ndata: {json.dumps(KEY_REVOKED)}\n\n"
                return
            key = (doc["state"], round(doc["progress"], 4), doc["stage"], doc["attempts"])
            if key != last:
                last = key
                idle = 0.0
                yield f"event: progress\ndata: {json.dumps(doc)}\n\n"
            if doc["state"] in TERMINAL:
                yield f"event: end\ndata: {json.dumps(doc)}\n\n"
                return
            if final_since is None and doc["state"] == "running" and doc["progress"] >= SSE_FINAL_FROM:
                final_since = now
            wait_s = sse_poll_s(doc, 0.0 if final_since is None else now - final_since)
            await asyncio.sleep(wait_s)
            idle += wait_s
            if idle >= 15:
                idle = 0.0
                yield ": keep-alive\n\n"

    return StreamingResponse(stream(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


@router.get("/{job_id}/products", response_model=list[ProductPublic], responses=ERRORS,
            summary="List a job's products")
def list_products(job_id: str, request: Request, team: TeamDep, session: SessionDep) -> list[ProductPublic]:
    job = get_owned_job(session, team.id, job_id)
    rows = session.execute(select(Product).where(Product.job_id == job.id).order_by(Product.name)).scalars().all()
    base = (request.app.state.settings.public_url or str(request.base_url)).rstrip("/")
    return [ProductPublic(name=p.name, media_type=p.media_type, size_bytes=p.size_bytes, sha256=p.sha256,
                          url=f"{base}/v1/jobs/{job.id}/products/{p.name}") for p in rows]


@router.get("/{job_id}/products/{name}", response_class=FileResponse,
            responses={**ERRORS, 200: {"content": {"*/*": {"schema": {}}},
                                       "description": "The file, with its own media type (text/csv, "
                                                      "application/json, image/png, text/html, ...)"}},
            summary="Download one product")
def download_product(job_id: str, name: str, request: Request, team: TeamDep, session: SessionDep):
    job = get_owned_job(session, team.id, job_id)
    product = session.execute(select(Product).where(Product.job_id == job.id, Product.name == name)).scalar_one_or_none()
    if product is None:
        raise not_found("Product", name)
    path = request.app.state.blobs.path(product.sha256)
    return FileResponse(path, media_type=product.media_type, filename=product.name)
