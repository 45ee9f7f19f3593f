"""End-to-end fixtures: the real API (uvicorn in a subprocess) and real worker processes, over HTTP
(client.local_service.LocalService).

Two backends: `sqlite` (the embedded default: SQLite file + Huey on SQLite) and `pg` (PostgreSQL +
Redis, as a team that outgrew one machine runs it). The pg variant needs GNSSATT_TEST_DATABASE_URL (a
server database we may create scratch databases from) and GNSSATT_TEST_QUEUE_URL; without them it is
skipped with that reason, and with GNSSATT_TEST_REQUIRE_PG=1 (set by .ci/run) it fails instead.
"""
from __future__ import annotations

import os
import time
import uuid

import pytest

from client.local_service import LocalService


def _pg_urls() -> tuple[str, str] | None:
    db = os.environ.get("GNSSATT_TEST_DATABASE_URL")
    queue = os.environ.get("GNSSATT_TEST_QUEUE_URL")
    return (db, queue) if db and queue else None


def _missing_pg(reason: str):
    if os.environ.get("GNSSATT_TEST_REQUIRE_PG") == "1":
        pytest.fail(f"PostgreSQL + Redis required (GNSSATT_TEST_REQUIRE_PG=1) but {reason}")
    pytest.skip(f"PostgreSQL + Redis variant not run: {reason}")


@pytest.fixture(params=["sqlite", "pg"])
def backend(request):
    return request.param


@pytest.fixture
def service(tmp_path, backend, request):
    db_url = queue_url = None
    scratch_db = None
    admin_engine = None
    if backend == "pg":
        urls = _pg_urls()
        if urls is None:
            _missing_pg("GNSSATT_TEST_DATABASE_URL / GNSSATT_TEST_QUEUE_URL are not set")
        base_db, queue_url = urls
        from sqlalchemy import create_engine, text
        from sqlalchemy.engine import make_url
        try:
            admin_engine = create_engine(base_db, isolation_level="AUTOCOMMIT")
            scratch_db = f"gnssatt_e2e_{uuid.uuid4().hex[:12]}"
            with admin_engine.connect() as conn:
                conn.execute(text(f'CREATE DATABASE "{scratch_db}"'))
            import redis
            redis.Redis.from_url(queue_url).ping()
        except Exception as exc:  # noqa: BLE001
            _missing_pg(f"cannot reach them ({exc})")
        db_url = make_url(base_db).set(database=scratch_db).render_as_string(hide_password=False)
    svc = LocalService(tmp_path, backend, db_url, queue_url)
    try:
        yield svc
    finally:
        svc.shutdown()
        if request.node.rep_call.failed if hasattr(request.node, "rep_call") else False:
            print(svc.logs_text())
        if scratch_db and admin_engine is not None:
            from sqlalchemy import text
            with admin_engine.connect() as conn:
                conn.execute(text(f'DROP DATABASE IF EXISTS "{scratch_db}" WITH (FORCE)'))
            admin_engine.dispose()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    setattr(item, "rep_" + rep.when, rep)


def wait_for(predicate, timeout_s: float = 30.0, interval_s: float = 0.1, what: str = "condition"):
    deadline = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(interval_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what} (last: {last!r})")
