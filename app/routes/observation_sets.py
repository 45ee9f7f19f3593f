"""/v1/observation-sets: upload (streamed multipart), list, get, delete."""
from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request, Response
from sqlalchemy import func, select, update
from starlette.concurrency import run_in_threadpool

from app.deps import SessionDep, SettingsDep, TeamDep
from app.problems import Problem, ProblemError, not_found
from app.schemas.common import Page
from app.schemas.observation_sets import ObservationSetPublic, SetFilePublic
from app.store.sets import store_set, validate_staged
from app.store.uploads import expand_bundles, receive_multipart
from core.janitor import release
from core.models import Job, JobSet, ObservationSet

router = APIRouter(prefix="/v1/observation-sets", tags=["observation sets"])

ERRORS = {401: {"model": Problem}, 404: {"model": Problem}, 422: {"model": Problem}}
UPLOAD_BODY = {
    "requestBody": {
        "required": True,
        "content": {"multipart/form-data": {"schema": {
            "type": "object", "required": ["files"],
            "properties": {
                "files": {"type": "array", "items": {"type": "string", "format": "binary"}, "minItems": 1,
                          "description": "RINEX observation files (one per antenna), navigation files (RINEX "
                                         "nav and/or SP3), platform.json, optionally a reference attitude CSV; "
                                         "or one .zip / .tar.gz bundle holding them."},
                "name": {"type": "string", "description": "A name for the set."},
            }}}},
    }
}


def to_public(obs_set: ObservationSet) -> ObservationSetPublic:
    return ObservationSetPublic(
        id=obs_set.id, name=obs_set.name, platform_name=obs_set.platform_name, created_at=obs_set.created_at,
        total_bytes=obs_set.total_bytes, summary=obs_set.summary or {},
        files=[SetFilePublic(name=f.name, kind=f.kind, size_bytes=f.size_bytes, sha256=f.sha256,
                             summary=f.summary or {}) for f in obs_set.files])


def get_owned_set(session, team_id: str, set_id: str) -> ObservationSet:
    obs_set = session.get(ObservationSet, set_id)
    if obs_set is None or obs_set.team_id != team_id:
        raise not_found("Observation set", set_id)
    return obs_set


@router.post("", status_code=201, response_model=ObservationSetPublic, openapi_extra=UPLOAD_BODY,
             responses={**ERRORS, 400: {"model": Problem}, 413: {"model": Problem}, 415: {"model": Problem},
                        429: {"model": Problem}},
             summary="Upload an observation set")
async def upload_set(request: Request, response: Response, team: TeamDep, session: SessionDep,
                     settings: SettingsDep) -> ObservationSetPublic:
    """Stream the files to disk, validate every one (format, version, time span, satellites; platform.json
    against the conventions, antennas matched to observation files) and keep the set. Nothing of a
    rejected upload is stored."""
    async with request.app.state.upload_slots.hold(team.id):  # no database connection is held meanwhile
        staged = await receive_multipart(request, settings)
        try:
            await run_in_threadpool(expand_bundles, staged, settings)
            files, summary = await run_in_threadpool(validate_staged, staged, settings)
            name = staged.fields.get("name") or None
            if name is not None and len(name) > 300:  # observation_sets.name
                raise ProblemError(422, "name-too-long", "Set name too long",
                                   f"The set name has {len(name)} characters; at most 300.", field="name")
            obs_set = await run_in_threadpool(store_set, session, request.app.state.blobs, team.id, name,
                                              files, summary)
        finally:
            await run_in_threadpool(staged.discard)
    response.headers["Location"] = f"/v1/observation-sets/{obs_set.id}"
    return to_public(obs_set)


@router.get("", response_model=Page[ObservationSetPublic], responses=ERRORS, summary="List observation sets")
def list_sets(team: TeamDep, session: SessionDep, limit: Annotated[int, Query(ge=1, le=500)] = 50,
              offset: Annotated[int, Query(ge=0, le=2**31)] = 0) -> Page[ObservationSetPublic]:
    q = select(ObservationSet).where(ObservationSet.team_id == team.id)
    total = session.execute(select(func.count()).select_from(q.subquery())).scalar_one()
    rows = session.execute(q.order_by(ObservationSet.created_at.desc(), ObservationSet.id)
                           .limit(limit).offset(offset)).scalars().all()
    return Page(items=[to_public(r) for r in rows], total=total, limit=limit, offset=offset,
                next_offset=offset + limit if offset + limit < total else None)


@router.get("/{set_id}", response_model=ObservationSetPublic, responses=ERRORS, summary="Get one observation set")
def get_set(set_id: str, team: TeamDep, session: SessionDep) -> ObservationSetPublic:
    return to_public(get_owned_set(session, team.id, set_id))


@router.delete("/{set_id}", status_code=204, responses={**ERRORS, 409: {"model": Problem}},
               summary="Delete an observation set")
def delete_set(set_id: str, request: Request, team: TeamDep, session: SessionDep) -> Response:
    """Refused with 409 while a queued or running job uses the set. Its blobs are left to the janitor
    (core/janitor.py), which removes those no other set or product shares once the grace period is over."""
    # Lock the set's row first (SQLite: the write lock; PostgreSQL: FOR UPDATE, which a job's foreign key
    # check waits on), so a job submitted meanwhile is either seen below (409) or fails its own commit (409).
    lock = select(ObservationSet.id).where(ObservationSet.id == set_id)
    if session.get_bind().dialect.name == "sqlite":
        session.execute(update(ObservationSet).where(ObservationSet.id == set_id)
                        .values(name=ObservationSet.name).execution_options(synchronize_session=False))
    else:
        session.execute(lock.with_for_update())
    obs_set = get_owned_set(session, team.id, set_id)
    busy = session.execute(select(Job.id).join(JobSet, JobSet.job_id == Job.id)
                           .where(JobSet.set_id == set_id, Job.state.in_(("queued", "running")))).first()
    if busy is not None:
        raise ProblemError(409, "set-in-use", "Observation set in use",
                           f"Job {busy[0]} uses this set and has not finished; cancel it or wait.", job_id=busy[0])
    shas = [f.sha256 for f in obs_set.files]
    session.delete(obs_set)
    session.commit()
    release(request.app.state.blobs, shas)
    return Response(status_code=204)
