"""A webhook left `pending` by a dead worker is resent, once overall, with its backoff and delivery id kept
(issue 22): every attempt is taken with a lease on the job_webhooks row (worker/webhooks.py). Real HTTP receiver
on 127.0.0.1, real sender processes where a kill is needed; SQLite and PostgreSQL. About 15 s per backend."""
from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
import uuid
from datetime import timedelta
from types import SimpleNamespace

from sqlalchemy import select

from core.db import make_engine, make_sessionmaker
from core.models import Job, Team, utcnow
from core.webhook_models import JobWebhook, WebhookDelivery
from tests.conftest import REPO_ROOT
from tests.webhooks.receiver import Receiver
from worker import webhooks

SECRET = "s3cret-of-sixteen-chars"


def finished_job(Session, url: str, **hook) -> str:
    """A succeeded job with a pending webhook row (its columns overridden by `hook`)."""
    with Session.begin() as s:
        team = Team(name=f"team-{uuid.uuid4().hex[:8]}")
        s.add(team)
        s.flush()
        job = Job(team_id=team.id, type="selftest", config={}, set_ids=[], state="succeeded", progress=1.0,
                  created_at=utcnow(), finished_at=utcnow(), attempts=1, max_attempts=3, cancel_requested=False)
        s.add(job)
        s.flush()
        s.add(JobWebhook(job_id=job.id, url=url, secret=SECRET, **{"state": "pending", "attempts": 0, **hook}))
        return job.id


def hook_row(Session, job_id: str) -> JobWebhook:
    with Session() as s:
        return s.get(JobWebhook, job_id)


def deliveries(Session, job_id: str) -> list[WebhookDelivery]:
    with Session() as s:
        return s.execute(select(WebhookDelivery).where(WebhookDelivery.job_id == job_id)
                         .order_by(WebhookDelivery.attempt)).scalars().all()


def wait_until(predicate, what: str, timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def test_receiver_failing_twice_then_accepting_gets_one_success_recorded(Session, monkeypatch):
    monkeypatch.setenv("GNSSATT_WEBHOOK_BACKOFF_S", "0.1,0.2,0.4")
    rx = Receiver(fail_first=2)
    try:
        job_id = finished_job(Session, rx.url)
        assert webhooks.deliver(Session, job_id) == "delivered"
    finally:
        rx.close()
    rows = deliveries(Session, job_id)
    assert [r.ok for r in rows] == [False, False, True] and [r.status_code for r in rows] == [500, 500, 204]
    calls = rx.calls[job_id]
    assert len(calls) == 3
    gaps = [b[0] - a[0] for a, b in zip(calls, calls[1:])]
    assert gaps[0] >= 0.09 and gaps[1] >= 0.19, gaps  # the backoff (10 ms clock slack)
    assert len({h["X-Gnssatt-Delivery"] for _, h in calls}) == 1
    hook = hook_row(Session, job_id)
    assert (hook.state, hook.attempts, hook.claimed_by, hook.lease_until, hook.next_attempt_at) == (
        "delivered", 3, None, None, None)
    assert hook.delivery_id == calls[0][1]["X-Gnssatt-Delivery"]


def test_pending_hook_of_a_dead_owner_is_resent_once_live_and_waiting_ones_are_not(Session, monkeypatch):
    monkeypatch.setenv("GNSSATT_WEBHOOK_BACKOFF_S", "0.1,0.2")
    now = utcnow()
    rx = Receiver()
    try:
        dead = finished_job(Session, rx.url, attempts=1, delivery_id="d" * 32, claimed_by="gone-host:1/x",
                            lease_until=now - timedelta(seconds=1))
        with Session.begin() as s:  # its first attempt failed and was recorded before the worker died
            s.add(WebhookDelivery(job_id=dead, attempt=1, at=now, status_code=500, ok=False, error="HTTP 500",
                                  duration_ms=3))
        alive = finished_job(Session, rx.url, claimed_by="live-host:2/y", lease_until=now + timedelta(seconds=60))
        waiting = finished_job(Session, rx.url, attempts=1, next_attempt_at=now + timedelta(seconds=60))
        rt = SimpleNamespace(Session=Session)
        assert webhooks.resend_pending(rt) == 1
        wait_until(lambda: hook_row(Session, dead).state == "delivered", "the dead owner's hook delivered")
        wait_until(lambda: not webhooks._inflight, "the delivery thread to end")
        assert webhooks.resend_pending(rt) == 0  # nothing else is due
        time.sleep(0.3)
    finally:
        rx.close()
    assert rx.count(dead) == 1 and rx.count(alive) == 0 and rx.count(waiting) == 0
    assert rx.calls[dead][0][1]["X-Gnssatt-Delivery"] == "d" * 32  # the notice's id survives the restart
    rows = deliveries(Session, dead)
    assert [(r.attempt, r.ok) for r in rows] == [(1, False), (2, True)]
    assert hook_row(Session, dead).attempts == 2
    assert hook_row(Session, alive).state == "pending" and hook_row(Session, waiting).state == "pending"


SENDER = """
import sys
from core.db import make_engine, make_sessionmaker
from core.settings import Settings
from worker.webhooks import deliver
settings = Settings(data_dir=sys.argv[1], database_url=sys.argv[2] or None)
deliver(make_sessionmaker(make_engine(settings)), sys.argv[3])
"""


def test_sender_killed_mid_post_is_resent_once_after_its_lease(Session, db_settings, monkeypatch):
    """A sender process is SIGKILLed while its POST is in flight: the hook stays leased (not resent while the
    lease runs), then exactly one resend delivers it, with the same delivery id."""
    monkeypatch.setenv("GNSSATT_WEBHOOK_LEASE_S", "8")
    rx = Receiver(hold=True)
    try:
        job_id = finished_job(Session, rx.url)
        env = {**os.environ, "PYTHONPATH": str(REPO_ROOT), "GNSSATT_WEBHOOK_LEASE_S": "8"}
        proc = subprocess.Popen([sys.executable, "-c", SENDER, str(db_settings.data_dir),
                                 db_settings.database_url or "", job_id], env=env, cwd=REPO_ROOT)
        try:
            assert rx.first_arrived.wait(30), "the sender never posted"
        finally:
            proc.kill()
            proc.wait(10)
        rx.release.set()
        hook = hook_row(Session, job_id)
        assert hook.state == "pending" and hook.claimed_by and hook.lease_until > utcnow()
        rt = SimpleNamespace(Session=Session)
        assert webhooks.resend_pending(rt) == 0  # the dead sender's lease still runs
        time.sleep(max(0.0, (hook.lease_until - utcnow()).total_seconds()) + 0.05)
        assert webhooks.resend_pending(rt) == 1
        wait_until(lambda: hook_row(Session, job_id).state == "delivered", "the resend delivered")
        wait_until(lambda: not webhooks._inflight, "the delivery thread to end")
        assert webhooks.resend_pending(rt) == 0
    finally:
        rx.close()
    assert rx.count(job_id) == 2  # the killed attempt (never answered) and the resend
    assert len({h["X-Gnssatt-Delivery"] for _, h in rx.calls[job_id]}) == 1
    assert [(r.attempt, r.ok) for r in deliveries(Session, job_id)] == [(1, True)]


def test_concurrent_resenders_send_each_attempt_once(Session, db_settings, monkeypatch):
    """Four resenders, each with its own engine (as four workers have), start on the same eight due hooks at
    one instant and keep trying until each hook is done; the receiver fails each hook's first POST. Every hook
    is POSTed exactly twice (one failure, one success) and has exactly two recorded attempts."""
    monkeypatch.setenv("GNSSATT_WEBHOOK_BACKOFF_S", "0.05")
    rx = Receiver(fail_first=1)
    engines = [make_engine(db_settings) for _ in range(4)]
    try:
        jobs = [finished_job(Session, rx.url) for _ in range(8)]
        barrier = threading.Barrier(len(engines) * len(jobs))
        errors: list[BaseException] = []

        def resender(S, job_id):
            try:
                barrier.wait(30)
                while webhooks.deliver(S, job_id) == "pending":
                    time.sleep(0.002)
            except BaseException as exc:  # noqa: BLE001 - reported below
                errors.append(exc)

        threads = [threading.Thread(target=resender, args=(make_sessionmaker(e), j), daemon=True)
                   for e in engines for j in jobs]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
    finally:
        rx.close()
        for e in engines:
            e.dispose()
    assert not errors, errors
    assert {j: rx.count(j) for j in jobs} == {j: 2 for j in jobs}
    for j in jobs:
        assert [(r.attempt, r.ok) for r in deliveries(Session, j)] == [(1, False), (2, True)]
        assert hook_row(Session, j).state == "delivered"
