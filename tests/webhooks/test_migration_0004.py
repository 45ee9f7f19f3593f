"""Revision 0004_webhook_lease upgrades a database at 0003_webhooks that holds a pending hook (the row keeps its
values, the new columns are empty and the hook is then due for a resend), downgrades and upgrades again, and
the head matches the models; SQLite and PostgreSQL."""
from __future__ import annotations

from types import SimpleNamespace

from alembic import command
from sqlalchemy import inspect, text

from core.db import make_engine, make_sessionmaker
from core.migrate import _alembic_config
from worker import webhooks


def _to(engine, revision: str, down: bool = False) -> None:
    cfg = _alembic_config()
    with engine.begin() as conn:
        cfg.attributes["connection"] = conn
        (command.downgrade if down else command.upgrade)(cfg, revision)


def _hook_columns(engine) -> set[str]:
    return {c["name"] for c in inspect(engine).get_columns("job_webhooks")}


def test_upgrade_from_0003_keeps_pending_hooks_and_makes_them_due(empty_settings, monkeypatch):
    engine = make_engine(empty_settings)
    try:
        _to(engine, "0003_webhooks")
        assert "lease_until" not in _hook_columns(engine)
        with engine.begin() as conn:
            conn.execute(text("INSERT INTO teams (id, name, created_at) VALUES ('t1', 'team', :now)"),
                         {"now": "2026-12-01 00:00:00"})
            conn.execute(text(
                "INSERT INTO jobs (id, team_id, type, config, set_ids, state, progress, created_at, attempts,"
                " max_attempts, cancel_requested) VALUES ('j1', 't1', 'selftest', '{}', '[]', 'succeeded', 1.0,"
                " :now, 1, 3, false)"), {"now": "2026-12-01 00:00:00"})
            conn.execute(text(
                "INSERT INTO job_webhooks (job_id, url, secret, state, attempts, created_at) VALUES"
                " ('j1', 'http://127.0.0.1:9/x', 'sixteen-chars-secret', 'pending', 2, :now)"),
                {"now": "2026-12-01 00:00:00"})
        _to(engine, "head")
        assert {"delivery_id", "claimed_by", "lease_until", "next_attempt_at"} <= _hook_columns(engine)
        with engine.connect() as conn:
            row = conn.execute(text("SELECT state, attempts, claimed_by, lease_until, next_attempt_at FROM"
                                    " job_webhooks WHERE job_id = 'j1'")).one()
        assert tuple(row) == ("pending", 2, None, None, None)
        Session = make_sessionmaker(engine)
        started = []
        monkeypatch.setattr(webhooks, "_start", lambda S, job_id: started.append(job_id) or object())
        assert webhooks.resend_pending(SimpleNamespace(Session=Session)) == 1 and started == ["j1"]
        _to(engine, "0003_webhooks", down=True)
        assert "lease_until" not in _hook_columns(engine)
        _to(engine, "head")
        assert "lease_until" in _hook_columns(engine)
        cfg = _alembic_config()
        with engine.begin() as conn:  # the models and the migrations agree (raises on any difference)
            cfg.attributes["connection"] = conn
            command.check(cfg)
    finally:
        engine.dispose()
