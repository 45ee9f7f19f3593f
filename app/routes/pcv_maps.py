"""/v1/pcv-maps: differential phase-centre-variation maps as first-class, versioned, team-scoped data."""
from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Request, Response
from sqlalchemy import func, select
from starlette.concurrency import run_in_threadpool

from app.deps import SessionDep, TeamDep
from app.http_headers import content_disposition
from app.problems import Problem, ProblemError, not_found
from app.schemas.common import Page
from app.schemas.pcv_maps import PcvMapCreate, PcvMapPublic
from core.models import PcvMap
from core.pcv_store import PcvFieldTooLong, add_pcv_map
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.pcv_map import PcvMap as PcvGrid
from gnssatt.gnss.io.pcv_map import parse_pcv_map, read_pcv_antex, write_pcv_antex

router = APIRouter(prefix="/v1/pcv-maps", tags=["PCV maps"])
ERRORS = {401: {"model": Problem}, 404: {"model": Problem}, 422: {"model": Problem}}


def _load_grid(request: Request, row: PcvMap) -> PcvGrid:
    return parse_pcv_map(request.app.state.blobs.path(row.sha256).read_bytes(), row.name)


def to_public(request: Request, row: PcvMap, grid: PcvGrid | None = None) -> PcvMapPublic:
    summary = row_summary(request, row) if grid is None else _summary(grid)
    return PcvMapPublic(id=row.id, name=row.name, version=row.version, platform=row.platform,
                        pair=[row.first_antenna, row.second_antenna], frequency=row.frequency,
                        source_job_id=row.source_job_id, created_at=row.created_at,
                        url_json=f"/v1/pcv-maps/{row.id}/download?format=json",
                        url_antex=f"/v1/pcv-maps/{row.id}/download?format=antex", **summary)


def _summary(grid: PcvGrid) -> dict:
    import numpy as np
    return {"n_bins": int(grid.values_mm.size), "n_filled": int(np.isfinite(grid.values_mm).sum())}


def row_summary(request: Request, row: PcvMap) -> dict:
    return _summary(_load_grid(request, row))


def _owned(session, team_id: str, map_id: str) -> PcvMap:
    row = session.get(PcvMap, map_id)
    if row is None or row.team_id != team_id:
        raise not_found("PCV map", map_id)
    return row


@router.post("", status_code=201, response_model=PcvMapPublic, responses=ERRORS, summary="Upload a PCV map")
def create_map(body: PcvMapCreate, request: Request, response: Response, team: TeamDep,
               session: SessionDep) -> PcvMapPublic:
    try:
        if body.map is not None:
            grid = parse_pcv_map(body.map, "map")
        else:
            grids = read_pcv_antex(body.antex, "antex")
            if len(grids) != 1:
                raise ProblemError(422, "one-map", "One map per upload",
                                   f"The ANTEX-style text holds {len(grids)} maps; upload them one at a time.",
                                   field="antex")
            grid = grids[0]
    except ParseError as exc:
        raise ProblemError(422, "invalid-pcv-map", "Invalid PCV map", str(exc), field="map" if body.map else "antex",
                           line=exc.line_no) from exc
    try:
        row = add_pcv_map(session, request.app.state.blobs, team.id, body.name, grid)
    except PcvFieldTooLong as exc:
        raise ProblemError(422, "invalid-pcv-map", "Invalid PCV map", str(exc), field=f"map.{exc.field}") from exc
    session.commit()
    response.headers["Location"] = f"/v1/pcv-maps/{row.id}"
    return to_public(request, row, grid)


@router.get("", response_model=Page[PcvMapPublic], responses=ERRORS, summary="List PCV maps")
def list_maps(request: Request, team: TeamDep, session: SessionDep,
              platform: Annotated[str | None, Query(max_length=300)] = None,
              name: Annotated[str | None, Query(max_length=200)] = None,
              frequency: Annotated[str | None, Query(max_length=10)] = None,
              limit: Annotated[int, Query(ge=1, le=500)] = 50,
              offset: Annotated[int, Query(ge=0, le=2**31)] = 0) -> Page[PcvMapPublic]:
    q = select(PcvMap).where(PcvMap.team_id == team.id)
    for col, value in ((PcvMap.platform, platform), (PcvMap.name, name), (PcvMap.frequency, frequency)):
        if value is not None:
            q = q.where(col == value)
    total = session.execute(select(func.count()).select_from(q.subquery())).scalar_one()
    rows = session.execute(q.order_by(PcvMap.name, PcvMap.version.desc(), PcvMap.id).limit(limit).offset(offset)
                           ).scalars().all()
    return Page(items=[to_public(request, r) for r in rows], total=total, limit=limit, offset=offset,
                next_offset=offset + limit if offset + limit < total else None)


@router.get("/{map_id}", response_model=PcvMapPublic, responses=ERRORS, summary="Get one PCV map's metadata")
def get_map(map_id: str, request: Request, team: TeamDep, session: SessionDep) -> PcvMapPublic:
    return to_public(request, _owned(session, team.id, map_id))


@router.get("/{map_id}/download", responses={**ERRORS, 200: {"content": {"application/json": {}, "text/plain": {}},
                                                           "description": "The map"}},
            summary="Download a PCV map as JSON or ANTEX-style text")
async def download_map(map_id: str, request: Request, team: TeamDep, session: SessionDep,
                       format: Literal["json", "antex"] = "json") -> Response:
    row = _owned(session, team.id, map_id)
    stem = f"pcv_{row.first_antenna}_{row.second_antenna}_{row.frequency}"
    if format == "json":
        data = await run_in_threadpool(request.app.state.blobs.path(row.sha256).read_bytes)
        return Response(data, media_type="application/json",
                        headers={"Content-Disposition": content_disposition(f"{stem}.json")})
    grid = await run_in_threadpool(_load_grid, request, row)
    return Response(write_pcv_antex([grid]), media_type="text/plain",
                    headers={"Content-Disposition": content_disposition(f"{stem}.atx")})


@router.delete("/{map_id}", status_code=204, responses=ERRORS, summary="Delete a PCV map version")
def delete_map(map_id: str, team: TeamDep, session: SessionDep) -> Response:
    session.delete(_owned(session, team.id, map_id))
    session.commit()
    return Response(status_code=204)
