"""DELETE /v1/jobs/{id} (issue 24): a team deletes one of its finished jobs; its rows go (products, set links,
tasks, webhook and deliveries cascade). Queued or running jobs answer 409 (cancel first).

The blob store is content-addressed, so a blob is shared whenever two products (or a product and an uploaded
file) have equal bytes, and a job running now may be about to re-use one. So the request deletes no blob: it
releases the products' blobs (core.janitor.release starts their grace period) and the janitor removes those no
row points to once the grace period is over, under the store's lock that every writer takes too."""
from __future__ import annotations

from fastapi import APIRouter, Request, Response
from sqlalchemy import select

from app.deps import SessionDep, TeamDep
from app.problems import Problem, ProblemError
from core.janitor import release
from core.models import Job, Product

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])


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
    release(request.app.state.blobs, shas)
    return Response(status_code=204)
