"""The worker's handles on the service (settings, database, blob store, queue) and the inputs of a job.

Shared by the job runner (worker/runner.py) and the fan-out (worker/fanout.py), which both read a job's
observation sets; it imports neither, so the two never import each other through it.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.engine import Engine
from sqlalchemy.orm import Session, sessionmaker

from core.blobs import BlobStore
from core.models import Job, JobSet, ObservationSet, PcvMap
from core.settings import Settings
from worker.context import InputFile, InputSet


@dataclass
class Runtime:
    settings: Settings
    engine: Engine
    Session: sessionmaker[Session]
    blobs: BlobStore
    huey: object
    worker_name: str


_RUNTIME: Runtime | None = None


def set_runtime(runtime: Runtime | None) -> None:
    global _RUNTIME
    _RUNTIME = runtime


def get_runtime() -> Runtime:
    if _RUNTIME is None:
        raise RuntimeError("worker runtime not configured (worker.main.build_runtime)")
    return _RUNTIME


def load_inputs(rt: Runtime, job_id: str) -> list[InputSet]:
    with rt.Session() as s:
        rows = s.execute(select(ObservationSet).join(JobSet, JobSet.set_id == ObservationSet.id)
                         .where(JobSet.job_id == job_id).order_by(JobSet.position)).scalars().all()
        return [InputSet(id=o.id, name=o.name, summary=o.summary or {},
                         files=[InputFile(name=f.name, kind=f.kind, path=rt.blobs.path(f.sha256),
                                          summary=f.summary or {}) for f in o.files])
                for o in rows]


def load_pcv_map(rt: Runtime, job_id: str, map_id: str) -> dict | None:
    """The JSON of PCV map `map_id` when it belongs to the job's team, else None."""
    with rt.Session() as s:
        row = s.get(PcvMap, map_id)
        team_id = s.execute(select(Job.team_id).where(Job.id == job_id)).scalar_one()
        if row is None or row.team_id != team_id:
            return None
        return json.loads(rt.blobs.path(row.sha256).read_bytes())
