"""RFC 9457 problem details for every error the API answers, and the handlers that make them.

A failed job stores the same document (worker/errors.py builds it), so a job error and an upload 422
look alike to a user: `type`, `title`, `status`, `detail`, `instance`, plus `file`, `line`, `field` or
`job_id` where they apply.
"""
from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict
from starlette.exceptions import HTTPException as StarletteHTTPException

log = logging.getLogger("gnssatt.api")

PROBLEM_MEDIA_TYPE = "application/problem+json"
TYPE_BASE = "https://gnssatt.dev/problems/"


class Problem(BaseModel):
    """RFC 9457 problem details, with gnssatt's extension members."""

    model_config = ConfigDict(extra="allow")
    type: str = "about:blank"
    title: str
    status: int
    detail: str | None = None
    instance: str | None = None
    file: str | None = None
    line: int | None = None
    field: str | None = None
    job_id: str | None = None
    errors: list[dict[str, Any]] | None = None


class ProblemError(Exception):
    """Raise anywhere in a request to answer with a problem document."""

    def __init__(self, status: int, slug: str, title: str, detail: str | None = None, **extra: Any):
        super().__init__(detail or title)
        self.status = status
        self.slug = slug
        self.title = title
        self.detail = detail
        self.extra = {k: v for k, v in extra.items() if v is not None}

    def body(self, instance: str | None = None) -> dict[str, Any]:
        doc = {"type": TYPE_BASE + self.slug, "title": self.title, "status": self.status}
        if self.detail:
            doc["detail"] = self.detail
        if instance:
            doc["instance"] = instance
        doc.update(self.extra)
        return doc


def problem_response(status: int, body: dict[str, Any], headers: dict[str, str] | None = None) -> JSONResponse:
    return JSONResponse(body, status_code=status, media_type=PROBLEM_MEDIA_TYPE, headers=headers)


def not_found(what: str, ident: str) -> ProblemError:
    return ProblemError(404, "not-found", f"{what} not found", f"No {what.lower()} with id {ident!r} is visible "
                        "to your team.")


_STATUS_TITLES = {400: "Bad request", 401: "Unauthorized", 403: "Forbidden", 404: "Not found",
                  405: "Method not allowed", 406: "Not acceptable", 409: "Conflict", 411: "Length required",
                  413: "Content too large", 415: "Unsupported media type", 422: "Unprocessable content",
                  429: "Too many requests"}


def _allowed_methods(request: Request) -> list[str]:
    """Every method the API documents for this path (Starlette's 405 names only the first route's)."""
    import re

    methods: set[str] = set()
    for template, ops in request.app.openapi().get("paths", {}).items():
        pattern = "^" + re.sub(r"\\\{[^}]+\\\}", "[^/]+", re.escape(template)) + "$"
        if re.match(pattern, request.url.path):
            methods |= {m.upper() for m in ops}
    return sorted(methods)


def install_problem_handlers(app: FastAPI) -> None:
    @app.exception_handler(ProblemError)
    async def _problem(request: Request, exc: ProblemError):
        headers = {"WWW-Authenticate": "Bearer"} if exc.status == 401 else None
        if exc.status in (429, 503) and "retry_after_s" in exc.extra:
            headers = {"Retry-After": str(int(exc.extra["retry_after_s"]))}
        return problem_response(exc.status, exc.body(str(request.url.path)), headers)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError):
        errors = []
        for err in exc.errors():
            loc = [str(p) for p in err.get("loc", ())]
            errors.append({"field": ".".join(loc), "message": err.get("msg", ""), "type": err.get("type", "")})
        first = errors[0] if errors else {"field": None, "message": "invalid request"}
        body = ProblemError(422, "validation-error", "Request validation failed",
                            f"{first['field']}: {first['message']}" if first.get("field") else first["message"],
                            field=first.get("field"), errors=errors).body(str(request.url.path))
        return problem_response(422, body)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException):
        title = _STATUS_TITLES.get(exc.status_code, "Error")
        detail = exc.detail if isinstance(exc.detail, str) and exc.detail != title else None
        body = ProblemError(exc.status_code, title.lower().replace(" ", "-"), title, detail).body(str(request.url.path))
        headers = dict(getattr(exc, "headers", None) or {})
        if exc.status_code == 405:
            headers["Allow"] = ", ".join(_allowed_methods(request))
        return problem_response(exc.status_code, body, headers or None)

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception):  # pragma: no cover - last resort
        log.exception("unhandled error on %s %s", request.method, request.url.path)
        body = ProblemError(500, "internal-error", "Internal server error",
                            "The server failed unexpectedly; nothing you sent was stored. "
                            "Please report this with the time of the request.").body(str(request.url.path))
        return problem_response(500, body)
