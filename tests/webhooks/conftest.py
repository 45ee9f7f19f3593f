"""Database fixtures of the webhook tests: a migrated SQLite file, and a scratch PostgreSQL database made from
GNSSATT_TEST_DATABASE_URL (as the end-to-end tests do); without that URL the pg variant is skipped naming it, and
it fails instead under CI=true or GNSSATT_TEST_REQUIRE_PG=1."""
from __future__ import annotations

import os
import uuid

import pytest

from core.db import make_engine, make_sessionmaker
from core.migrate import migrate
from core.settings import Settings
from tests.conftest import missing


def _scratch_pg() -> tuple[str, object, str]:
    base = os.environ.get("GNSSATT_TEST_DATABASE_URL")
    why = "GNSSATT_TEST_DATABASE_URL is not set"
    if base:
        from sqlalchemy import create_engine, text
        from sqlalchemy.engine import make_url
        name = f"gnssatt_hooks_{uuid.uuid4().hex[:12]}"
        try:
            admin = create_engine(base, isolation_level="AUTOCOMMIT")
            with admin.connect() as conn:
                conn.execute(text(f'CREATE DATABASE "{name}"'))
            return make_url(base).set(database=name).render_as_string(hide_password=False), admin, name
        except Exception as exc:  # noqa: BLE001 - reported as the reason
            why = f"cannot create a scratch database from GNSSATT_TEST_DATABASE_URL ({exc.__class__.__name__})"
    if os.environ.get("GNSSATT_TEST_REQUIRE_PG") == "1":
        pytest.fail(f"PostgreSQL required (GNSSATT_TEST_REQUIRE_PG=1) but {why}")
    missing(f"PostgreSQL variant not run: {why}")


@pytest.fixture(params=["sqlite", "pg"])
def empty_settings(request, tmp_path):
    """Settings of an empty database (no tables) on the backend of the parameter."""
    admin = name = url = None
    if request.param == "pg":
        url, admin, name = _scratch_pg()
    yield Settings(data_dir=tmp_path / "var", database_url=url)
    if admin is not None:
        from sqlalchemy import text
        with admin.connect() as conn:
            conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@pytest.fixture
def db_settings(empty_settings):
    """Settings of a database migrated to the newest revision."""
    engine = make_engine(empty_settings)
    migrate(engine, empty_settings)
    engine.dispose()
    return empty_settings


@pytest.fixture
def Session(db_settings):
    engine = make_engine(db_settings)
    yield make_sessionmaker(engine)
    engine.dispose()
