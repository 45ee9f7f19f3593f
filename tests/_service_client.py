"""An in-process API client on a fresh runtime, shared by the API fixtures of tests/api, tests/preflight and
tests/webhooks: the app on `settings`, Huey immediate or not, one team's key in the Authorization header."""
from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from fastapi.testclient import TestClient

from app.keys import create_key
from app.main import create_app
from worker import runner
from worker.main import build_runtime


@contextmanager
def service_client(settings, *, immediate: bool, team: str, name: str) -> Iterator[TestClient]:
    """TestClient with `.rt` (the worker runtime) and a key of `team`; the runtime is torn down after."""
    rt = build_runtime(settings, immediate=immediate, name=name)
    app = create_app(settings)
    with TestClient(app, raise_server_exceptions=False) as client:
        app.state.huey = rt.huey
        with rt.Session.begin() as s:
            key, _ = create_key(s, team)
        client.headers["Authorization"] = f"Bearer {key}"
        client.rt = rt
        yield client
    runner.set_runtime(None)
    rt.engine.dispose()
