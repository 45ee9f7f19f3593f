"""In-process API tests: a fresh SQLite data dir per test, Huey in immediate mode (jobs run inline)."""
from __future__ import annotations

import pytest

from app.keys import create_key
from core.db import make_engine, make_sessionmaker
from core.settings import Settings
from tests._service_client import service_client


@pytest.fixture
def settings(tmp_path):
    return Settings(data_dir=tmp_path / "var", lease_seconds=5, heartbeat_seconds=0.5,
                    max_upload_bytes=5 * 1024 * 1024)


@pytest.fixture
def api(settings, monkeypatch):
    """(client, key) with the worker runtime in immediate mode, so a submitted job runs in the request."""
    with service_client(settings, immediate=True, team="team-a", name="test-worker") as client:
        yield client


@pytest.fixture
def other_key(api):
    with api.rt.Session.begin() as s:
        key, _ = create_key(s, "team-b")
    return key


def stored_state(settings: Settings) -> dict:
    """What is kept on disk and in the database: used to prove a rejected upload stored nothing."""
    engine = make_engine(settings)
    Session = make_sessionmaker(engine)
    from sqlalchemy import func, select

    from core.models import ObservationSet, SetFile
    with Session() as s:
        n_sets = s.execute(select(func.count()).select_from(ObservationSet)).scalar_one()
        n_files = s.execute(select(func.count()).select_from(SetFile)).scalar_one()
    engine.dispose()
    blobs = [p for p in settings.blobs_dir.rglob("*") if p.is_file() and p.parent.name != "tmp"]
    staging = [p for p in settings.staging_dir.rglob("*")]
    return {"sets": n_sets, "files": n_files, "blobs": len(blobs), "staging": len(staging)}
