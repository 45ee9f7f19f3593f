"""/v1/job-types: the registered job types and their config JSON schemas."""
from __future__ import annotations

from fastapi import APIRouter

from app.deps import TeamDep
from app.problems import Problem
from app.schemas.jobs import JobTypePublic
from worker.jobs.registry import job_types

router = APIRouter(prefix="/v1/job-types", tags=["jobs"])


@router.get("", response_model=list[JobTypePublic], responses={401: {"model": Problem}}, summary="List job types")
def list_job_types(team: TeamDep) -> list[JobTypePublic]:
    return [JobTypePublic(name=s.name, title=s.title, description=s.description, min_sets=s.min_sets,
                          max_sets=s.max_sets, produces=list(s.produces),
                          config_schema=s.config_model.model_json_schema())
            for s in sorted(job_types().values(), key=lambda s: s.name)]
