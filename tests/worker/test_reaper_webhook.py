"""A job the reaper fails (lease lost after its last attempt) has its webhook delivery started."""
from datetime import timedelta

from sqlalchemy import update

from core.models import Job, utcnow
from tests.api.conftest import api, settings  # noqa: F401 - the in-process service fixture
from worker import runner, webhooks


def test_reaper_failed_job_starts_its_webhook(api, monkeypatch):
    started = []
    monkeypatch.setattr(webhooks, "notify_finished", lambda rt, job_id: started.append(job_id))
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    with api.rt.Session.begin() as s:  # its worker died holding the last attempt
        s.execute(update(Job).where(Job.id == job_id).values(
            state="running", attempts=Job.max_attempts, lease_owner="dead/1",
            lease_expires_at=utcnow() - timedelta(seconds=5)))
    started.clear()  # the immediate-mode run at submit already started one
    counts = runner.reap(api.rt)
    assert counts["failed"] == 1
    assert started == [job_id]


def test_reaper_resends_a_hook_its_dead_worker_left_pending(api):
    """The reaper's pass starts the resend of a pending hook whose sender's lease ran out (worker.webhooks)."""
    import time

    from core.webhook_models import JobWebhook
    from tests.webhooks.receiver import Receiver

    rx = Receiver()
    try:
        job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
        with api.rt.Session.begin() as s:
            s.add(JobWebhook(job_id=job_id, url=rx.url, secret="s" * 20, state="pending", attempts=0,
                             claimed_by="gone-host:1/x", lease_until=utcnow() - timedelta(seconds=1)))
        assert runner.reap(api.rt)["webhooks_resent"] == 1
        deadline = time.monotonic() + 20
        while api.get(f"/v1/jobs/{job_id}/webhook").json()["state"] != "delivered":
            assert time.monotonic() < deadline, "the resent hook was not delivered"
            time.sleep(0.05)
    finally:
        rx.close()
    assert rx.count(job_id) == 1
