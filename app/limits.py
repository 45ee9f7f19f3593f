"""Limits that keep one client from stalling or exhausting the API for everyone.

- `TeamSlots`: at most N uploads of one team at once (GNSSATT_MAX_UPLOADS_PER_TEAM); the next answers 429.
- `JsonBodyLimit` (ASGI middleware): a JSON request body is refused before it is read when the caller has no
  valid API key (401), and refused while it streams once it passes GNSSATT_MAX_JSON_BODY_BYTES (413) or nests
  deeper than GNSSATT_MAX_JSON_DEPTH (422), before any JSON parser sees it.
"""
from __future__ import annotations

import json
import re
from contextlib import asynccontextmanager
from typing import AsyncIterator

from starlette.concurrency import run_in_threadpool
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.problems import PROBLEM_MEDIA_TYPE, ProblemError


class TeamSlots:
    """Counts what each team has in flight in this API process (the event loop is one thread: no lock)."""

    def __init__(self, what: str, limit: int, setting: str):
        self.what, self.limit, self.setting = what, limit, setting
        self.active: dict[str, int] = {}

    @asynccontextmanager
    async def hold(self, team_id: str) -> AsyncIterator[None]:
        if self.active.get(team_id, 0) >= self.limit:
            raise ProblemError(429, "too-many-concurrent", f"Too many {self.what} at once",
                               f"Your team already has {self.limit} {self.what} in progress ({self.setting}); "
                               "wait for one to finish and try again.", retry_after_s=5)
        self.active[team_id] = self.active.get(team_id, 0) + 1
        try:
            yield
        finally:
            self.active[team_id] -= 1
            if not self.active[team_id]:
                del self.active[team_id]


def json_depth_exceeds(data: bytes, max_depth: int) -> bool:
    """True when the JSON text nests arrays/objects deeper than max_depth (strings are skipped; no parsing)."""
    if data.count(b"[") + data.count(b"{") <= max_depth:
        return False
    depth = 0
    for token in _JSON_TOKENS.finditer(data):
        first = token.group()[:1]
        if first in (b"[", b"{"):
            depth += 1
            if depth > max_depth:
                return True
        elif first in (b"]", b"}"):
            depth -= 1
    return False


_JSON_TOKENS = re.compile(rb'"(?:[^"\\]|\\.)*"|[\[\]{}]')


def request_key(headers: dict[str, str], cookies: str | None) -> str | None:
    """The API key of a request, as app.deps reads it: bearer token, X-API-Key, or the pages' cookie."""
    auth = headers.get("authorization", "")
    if auth[:7].lower() == "bearer " and auth[7:].strip():
        return auth[7:].strip()
    if headers.get("x-api-key"):
        return headers["x-api-key"]
    if cookies:
        for part in cookies.split(";"):
            name, _, value = part.strip().partition("=")
            if name == "gnssatt_key" and value:
                return value
    return None


def _problem_message(status: int, slug: str, title: str, detail: str, path: str) -> tuple[Message, Message]:
    body = ProblemError(status, slug, title, detail).body(path)
    raw = json.dumps(body).encode()
    headers = [(b"content-type", PROBLEM_MEDIA_TYPE.encode()), (b"content-length", str(len(raw)).encode())]
    if status == 401:
        headers.append((b"www-authenticate", b"Bearer"))
    return ({"type": "http.response.start", "status": status, "headers": headers},
            {"type": "http.response.body", "body": raw})


class JsonBodyLimit:
    """ASGI middleware for /v1 requests with a JSON body: key first, then a bounded, depth-checked body."""

    def __init__(self, app: ASGIApp, *, max_bytes: int, max_depth: int):
        self.app, self.max_bytes, self.max_depth = app, max_bytes, max_depth

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not scope["path"].startswith("/v1/") or \
                scope["method"] not in ("POST", "PUT", "PATCH"):
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        if "json" not in headers.get("content-type", "").lower():
            await self.app(scope, receive, send)
            return
        path = scope["path"]
        refusal = await self._refusal(scope, headers)
        if refusal is None:
            body, refusal = await self._read(receive, headers, path)
        if refusal is not None:
            for message in refusal:
                await send(message)
            return
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)

    async def _refusal(self, scope: Scope, headers: dict[str, str]):
        key = request_key(headers, headers.get("cookie"))
        if not key:
            return _problem_message(401, "unauthorized", "API key required",
                                    "Send your API key as 'Authorization: Bearer KEY' or 'X-API-Key: KEY'. "
                                    "An operator mints keys with 'gnssatt admin create-key --team NAME'.",
                                    scope["path"])
        app = scope.get("app")
        Session = getattr(getattr(app, "state", None), "Session", None)
        if Session is None:
            return None
        from app.keys import team_for_key

        def valid() -> bool:
            with Session() as s:
                return team_for_key(s, key) is not None

        if not await run_in_threadpool(valid):
            return _problem_message(401, "unauthorized", "Invalid API key",
                                    "This API key is unknown or revoked. Ask your operator for a new one.",
                                    scope["path"])
        return None

    async def _read(self, receive: Receive, headers: dict[str, str], path: str):
        too_large = _problem_message(413, "body-too-large", "Request body too large",
                                     f"A JSON body may hold at most {self.max_bytes} bytes "
                                     "(GNSSATT_MAX_JSON_BODY_BYTES).", path)
        declared = headers.get("content-length", "")
        if declared.isdigit() and int(declared) > self.max_bytes:
            return b"", too_large
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return b"", ()
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_bytes:
                return b"", too_large
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        if json_depth_exceeds(body, self.max_depth):
            return body, _problem_message(422, "json-too-deep", "JSON nested too deeply",
                                          f"The JSON body nests arrays/objects deeper than {self.max_depth} levels "
                                          "(GNSSATT_MAX_JSON_DEPTH).", path)
        return body, None
