"""Scratch backends for tests that build Settings themselves: `scratch_backend("sqlite")` gives nothing to
override (the embedded default in the test's data dir), `scratch_backend("pg")` a fresh PostgreSQL database made
from GNSSATT_TEST_DATABASE_URL (dropped afterwards) and, with `queue=True`, GNSSATT_TEST_QUEUE_URL (Redis) with a
queue name of its own. Without the URLs the pg variant is skipped naming them, and fails instead under CI=true or
GNSSATT_TEST_REQUIRE_PG=1 (set by .ci/run), as the end-to-end tests do."""
from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

import pytest

from client.local_service import scratch_database
from tests.conftest import missing


def _require_pg(why: str) -> None:
    if os.environ.get("GNSSATT_TEST_REQUIRE_PG") == "1":
        pytest.fail(f"PostgreSQL + Redis required (GNSSATT_TEST_REQUIRE_PG=1) but {why}")
    missing(f"PostgreSQL variant not run: {why}")


def _redis_url() -> str:
    url = os.environ.get("GNSSATT_TEST_QUEUE_URL")
    if not url:
        _require_pg("GNSSATT_TEST_QUEUE_URL is not set")
    try:
        import redis
        redis.Redis.from_url(url).ping()
    except Exception as exc:  # noqa: BLE001 - reported as the reason
        _require_pg(f"cannot reach GNSSATT_TEST_QUEUE_URL ({exc.__class__.__name__})")
    return url


@contextlib.contextmanager
def scratch_backend(kind: str, queue: bool = False, prefix: str = "gnssatt_t") -> Iterator[dict]:
    """Settings overrides (database_url, queue_url, queue_name) of a scratch backend of `kind` ("sqlite"/"pg")."""
    if kind == "sqlite":
        yield {}
        return
    base = os.environ.get("GNSSATT_TEST_DATABASE_URL")
    if not base:
        _require_pg("GNSSATT_TEST_DATABASE_URL is not set")
    try:
        scratch = scratch_database(base, prefix)
        url = scratch.__enter__()
    except Exception as exc:  # noqa: BLE001 - reported as the reason
        _require_pg(f"cannot create a scratch database from GNSSATT_TEST_DATABASE_URL ({exc.__class__.__name__})")
    overrides = {"database_url": url}
    try:
        if queue:
            overrides |= {"queue_url": _redis_url(), "queue_name": url.rsplit("/", 1)[-1]}
        yield overrides
    finally:
        scratch.__exit__(None, None, None)
