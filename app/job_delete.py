"""DELETE /v1/jobs/{id} (issue 24): a team deletes one of its finished jobs; its rows go (products, set links,
tasks, webhook and deliveries cascade) and each product blob that no other product or set file refers to is
removed from the content store after the commit. Queued or running jobs answer 409 (cancel first).

The blob store is content-addressed, so a blob is shared whenever two products (or a product and an uploaded
file) have equal bytes: only the last reference frees it. A writer storing the same bytes at the same moment
could lose its blob to this removal; the service's blob janitor (grace-period sweep) is the long-term owner of
collection, this removal only frees what is plainly unreferenced."""
from __future__ import annotations

from fastapi import APIRouter, Request, Response
from sqlalchemy import select

from app.deps import SessionDep, TeamDep
from app.problems import Problem, ProblemError
from core.models import Job, Product, SetFile

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])


def unreferenced(session, shas: set[str]) -> set[str]:
    """The SHA-256 values of `shas` that no product row and no set file row refers to."""
    if not shas:
        return set()
    used = set(session.execute(select(Product.sha256).where(Product.sha256.in_(list(shas)))).scalars())
    used |= set(session.execute(select(SetFile.sha256).where(SetFile.sha256.in_(list(shas)))).scalars())
    return shas - used


@router.delete("/{job_id}", status_code=204, responses={401: {"model": Problem}, 404: {"model": Problem},
                                                        409: {"model": Problem}, 422: {"model": Problem}},
               summary="Delete a finished job and its products")
def delete_job(job_id: str, request: Request, team: TeamDep, session: SessionDep) -> Response:
    job = session.get(Job, job_id)
    if job is None or job.team_id != team.id:
        raise ProblemError(404, "not-found", "Job not found", f"No job with id {job_id!r} is visible to your team.")
    if job.state in ("queued", "running"):
        raise ProblemError(409, "job-not-finished", "Job not finished",
                           f"Job {job_id} is {job.state}; cancel it (POST /v1/jobs/{job_id}/cancel) and delete it "
                           "once it has stopped.")
    shas = set(session.execute(select(Product.sha256).where(Product.job_id == job_id)).scalars())
    session.delete(job)
    session.commit()
    blobs = request.app.state.blobs
    for sha in unreferenced(session, shas):
        try:
            blobs.path(sha).unlink()
        except FileNotFoundError:
            pass
    return Response(status_code=204)
