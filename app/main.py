"""The API application: create_app(settings) wires settings, database, blob store and queue."""
from __future__ import annotations

import logging
from contextlib import asynccontextmanager

from fastapi import FastAPI

from app.limits import JsonBodyLimit, TeamSlots
from app.problems import install_problem_handlers
from app.routes import health, job_types, jobs, observation_sets, pcv_maps
from app.routes.pages import install_pages
from app.store import summarizer
from core.blobs import BlobStore
from core.db import make_engine, make_sessionmaker
from core.migrate import migrate
from core.settings import Settings
from worker.queue import make_huey

API_VERSION = "0.1.0"
DESCRIPTION = """GNSS attitude determination as a service.

Upload an observation set (RINEX files of several antennas on one rigid platform, navigation data,
`platform.json`), submit a job, follow its progress, download its products. Every error is an
RFC 9457 `application/problem+json` document. Authenticate with `Authorization: Bearer KEY` or
`X-API-Key: KEY`.
"""


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        settings.ensure_dirs()
        engine = make_engine(settings)
        migrate(engine, settings)
        app.state.engine = engine
        app.state.Session = make_sessionmaker(engine)
        app.state.blobs = BlobStore(settings.blobs_dir)
        app.state.huey = make_huey(settings)
        yield
        summarizer.shutdown()
        engine.dispose()

    logging.basicConfig(level=settings.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    app = FastAPI(title="gnssatt", version=API_VERSION, description=DESCRIPTION, lifespan=lifespan)
    app.state.settings = settings
    app.state.upload_slots = TeamSlots("uploads", settings.max_uploads_per_team, "GNSSATT_MAX_UPLOADS_PER_TEAM")
    app.add_middleware(JsonBodyLimit, max_bytes=settings.max_json_body_bytes, max_depth=settings.max_json_depth)
    install_problem_handlers(app)
    app.include_router(health.router)
    app.include_router(observation_sets.router)
    app.include_router(jobs.router)
    app.include_router(job_types.router)
    install_pages(app)  # /ui pages, /static assets, CSRF guard for cookie-authenticated /v1 calls
    app.include_router(pcv_maps.router)
    app.openapi = lambda: _openapi_with_problems(app)  # type: ignore[method-assign]
    return app


def _openapi_with_problems(app: FastAPI) -> dict:
    """The generated spec, with every 4xx/5xx answer documented as application/problem+json (RFC 9457),
    401 on every /v1 operation and 500 everywhere, as the handlers in app/problems.py answer them."""
    if app.openapi_schema:
        return app.openapi_schema
    from fastapi.openapi.utils import get_openapi

    from app.problems import Problem

    spec = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
    schemas = spec.setdefault("components", {}).setdefault("schemas", {})
    schemas["Problem"] = Problem.model_json_schema(ref_template="#/components/schemas/{model}")
    schemas.pop("HTTPValidationError", None)
    schemas.pop("ValidationError", None)
    problem = {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}}
    for path, ops in spec.get("paths", {}).items():
        for op in ops.values():
            responses = op.setdefault("responses", {})
            if path.startswith("/v1"):
                responses.setdefault("401", {"description": "Missing or invalid API key"})
            if op.get("parameters") or op.get("requestBody"):
                responses.setdefault("422", {"description": "Validation error"})
            if op.get("requestBody"):
                responses.setdefault("400", {"description": "Malformed request body"})
            responses.setdefault("500", {"description": "Internal error"})
            for code, resp in responses.items():
                if code[0] in "45":
                    resp["content"] = problem
                    resp["description"] = resp.get("description") or "Problem"
    _add_links(spec)
    app.openapi_schema = spec
    return spec


#: OpenAPI links (3.1 sec. 4.8.20): what a created resource's id leads to, so clients and stateful testers
#: (schemathesis) can follow upload -> get/delete, submit -> get/cancel/products, map -> get/download/delete.
_LINKS = {
    ("/v1/observation-sets", "post", "201"): {
        "GetSet": ("/v1/observation-sets/{set_id}", "get", "set_id"),
        "DeleteSet": ("/v1/observation-sets/{set_id}", "delete", "set_id")},
    ("/v1/jobs", "post", "202"): {
        "GetJob": ("/v1/jobs/{job_id}", "get", "job_id"),
        "CancelJob": ("/v1/jobs/{job_id}/cancel", "post", "job_id"),
        "ListProducts": ("/v1/jobs/{job_id}/products", "get", "job_id")},
    ("/v1/pcv-maps", "post", "201"): {
        "GetMap": ("/v1/pcv-maps/{map_id}", "get", "map_id"),
        "DownloadMap": ("/v1/pcv-maps/{map_id}/download", "get", "map_id"),
        "DeleteMap": ("/v1/pcv-maps/{map_id}", "delete", "map_id")},
}


def _add_links(spec: dict) -> None:
    paths = spec.get("paths", {})
    for (path, method, status), links in _LINKS.items():
        response = paths.get(path, {}).get(method, {}).get("responses", {}).get(status)
        if response is None:
            continue
        out = response.setdefault("links", {})
        for name, (target, target_method, param) in links.items():
            operation_id = paths.get(target, {}).get(target_method, {}).get("operationId")
            if operation_id:
                out[name] = {"operationId": operation_id, "parameters": {param: "$response.body#/id"}}


def app_from_env() -> FastAPI:
    """uvicorn factory: `uvicorn --factory app.main:app_from_env`."""
    return create_app(Settings())
