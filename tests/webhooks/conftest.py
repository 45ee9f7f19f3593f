"""Database fixtures of the webhook tests: a migrated SQLite file, and a scratch PostgreSQL database made from
GNSSATT_TEST_DATABASE_URL (as the end-to-end tests do); without that URL the pg variant is skipped naming it, and
it fails instead under CI=true or GNSSATT_TEST_REQUIRE_PG=1."""
from __future__ import annotations

import pytest

from core.db import make_engine, make_sessionmaker
from core.migrate import migrate
from core.settings import Settings
from tests._backends import scratch_backend


@pytest.fixture(params=["sqlite", "pg"])
def empty_settings(request, tmp_path):
    """Settings of an empty database (no tables) on the backend of the parameter."""
    with scratch_backend(request.param, prefix="gnssatt_hooks") as overrides:
        yield Settings(data_dir=tmp_path / "var", **overrides)


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
