"""Apply the Alembic migrations at start-up, idempotently and safely when several processes start at once.

SQLite: an exclusive `fcntl` lock on a file beside the database serialises the processes of one machine.
PostgreSQL: a session-level advisory lock serialises every process on every machine.
"""
from __future__ import annotations

import fcntl
from contextlib import contextmanager
from pathlib import Path

from alembic import command
from alembic.config import Config
from sqlalchemy import text
from sqlalchemy.engine import Engine

from core.settings import Settings

MIGRATIONS_DIR = Path(__file__).resolve().parents[1] / "migrations"
_PG_LOCK_KEY = 0x676E737361747400  # "gnssatt\0": an arbitrary constant shared by every process


def _alembic_config() -> Config:
    cfg = Config(str(MIGRATIONS_DIR / "alembic.ini"))
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    return cfg


@contextmanager
def _file_lock(path: Path):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def migrate(engine: Engine, settings: Settings) -> None:
    """Upgrade the database to the newest revision; a no-op when it is already there."""
    cfg = _alembic_config()
    if engine.dialect.name == "sqlite":
        with _file_lock(settings.data_dir / ".migrate.lock"), engine.begin() as conn:
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")
        return
    with engine.connect() as lock_conn:
        lock_conn.execute(text("SELECT pg_advisory_lock(:k)"), {"k": _PG_LOCK_KEY})
        try:
            with engine.begin() as conn:
                cfg.attributes["connection"] = conn
                command.upgrade(cfg, "head")
        finally:
            lock_conn.execute(text("SELECT pg_advisory_unlock(:k)"), {"k": _PG_LOCK_KEY})
            lock_conn.commit()
