"""Liveness (/healthz) and readiness (/readyz: database and queue reachable)."""
from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse
from pydantic import BaseModel
from sqlalchemy import text
from starlette.concurrency import run_in_threadpool

from worker.queue import queue_reachable

router = APIRouter(tags=["health"])


class Health(BaseModel):
    status: str
    database: str | None = None
    queue: str | None = None


@router.get("/healthz", response_model=Health, summary="Process is up")
def healthz() -> Health:
    return Health(status="ok")


@router.get("/readyz", response_model=Health, responses={503: {"model": Health}},
            summary="Database and queue reachable")
async def readyz(request: Request):
    def check() -> tuple[bool, bool]:
        db_ok = True
        try:
            with request.app.state.engine.connect() as conn:
                conn.execute(text("SELECT 1"))
        except Exception:
            db_ok = False
        return db_ok, queue_reachable(request.app.state.huey)

    db_ok, q_ok = await run_in_threadpool(check)
    body = Health(status="ok" if db_ok and q_ok else "unavailable", database="ok" if db_ok else "unreachable",
                  queue="ok" if q_ok else "unreachable")
    return JSONResponse(body.model_dump(), status_code=200 if db_ok and q_ok else 503)
