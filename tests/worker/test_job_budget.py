"""Each job attempt runs in a child process under a memory and a time budget (worker/isolation.py): a runaway
job fails with a clear, non-retried error, a job that never reports progress is still cancelled within a few
seconds, and a normal job (fan-out included) publishes as before. About 10 s."""
from __future__ import annotations

import threading
import time

import pytest
from sqlalchemy import update

from core.models import Job, Product, Team, utcnow
from core.settings import Settings
from worker import runner
from worker.isolation import owned_memory_bytes
from worker.main import build_runtime


@pytest.fixture
def rt(tmp_path, fork_server):
    settings = Settings(data_dir=tmp_path / "var", lease_seconds=5, heartbeat_seconds=0.5,
                        job_memory_mb=200, job_time_s=3.0, job_isolation="process")
    rt = build_runtime(settings, name="budget-test")
    yield rt
    runner.set_runtime(None)
    rt.engine.dispose()


def _job(rt, config: dict) -> str:
    with rt.Session.begin() as s:
        team = Team(name=f"team-{time.monotonic_ns()}")
        s.add(team)
        s.flush()
        job = Job(team_id=team.id, type="selftest", config=config, set_ids=[], state="queued", progress=0.0,
                  created_at=utcnow(), enqueued_at=utcnow(), attempts=0, max_attempts=3, cancel_requested=False)
        s.add(job)
        s.flush()
        return job.id


def _row(rt, job_id: str) -> Job:
    with rt.Session() as s:
        return s.get(Job, job_id)


def test_runaway_memory_fails_the_job_and_the_worker_stays_small(rt):
    job_id = _job(rt, {"duration_s": 0, "allocate_mb": 2048})
    t0 = time.monotonic()
    assert runner.execute_job(rt, job_id) == "failed"
    job = _row(rt, job_id)
    assert job.error["type"].endswith("/job-budget-exceeded") and job.attempts == 1  # not retried
    assert "Memory budget exceeded" == job.error["title"] and "200 MB" in job.error["detail"]
    assert time.monotonic() - t0 < 15
    # the worker (this process) never held the job's memory: 2 GB were asked for in the child only
    assert owned_memory_bytes(__import__("os").getpid()) < 1500 * 2**20


def test_time_budget_stops_a_job_that_never_reports_progress(rt):
    job_id = _job(rt, {"duration_s": 0, "spin_s": 60})
    t0 = time.monotonic()
    assert runner.execute_job(rt, job_id) == "failed"
    assert time.monotonic() - t0 < 8
    job = _row(rt, job_id)
    assert job.error["title"] == "Time budget exceeded" and "GNSSATT_JOB_TIME_S" in job.error["detail"]


def test_cancel_stops_a_job_that_never_reports_progress(rt):
    rt.settings.job_time_s = 120.0
    job_id = _job(rt, {"duration_s": 0, "spin_s": 60})
    result: list = []
    worker = threading.Thread(target=lambda: result.append(runner.execute_job(rt, job_id)), daemon=True)
    worker.start()
    deadline = time.monotonic() + 10
    while _row(rt, job_id).state != "running" and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    t0 = time.monotonic()
    with rt.Session.begin() as s:
        s.execute(update(Job).where(Job.id == job_id).values(cancel_requested=True))
    worker.join(timeout=10)
    assert result == ["cancelled"] and time.monotonic() - t0 < 4
    assert _row(rt, job_id).state == "cancelled"


def test_a_normal_job_with_fan_out_publishes_from_the_child(rt):
    job_id = _job(rt, {"duration_s": 0.3, "fan_out": 3, "task_seconds": 0.0})
    assert runner.execute_job(rt, job_id) == "succeeded"
    job = _row(rt, job_id)
    assert job.progress == 1.0
    with rt.Session() as s:
        names = sorted(p.name for p in s.query(Product).filter(Product.job_id == job_id))
    assert names == ["early.json", "selftest.json"]
    selftest = rt.blobs.path(next(p.sha256 for p in s.query(Product).filter(Product.job_id == job_id,
                                                                                  Product.name == "selftest.json")))
    doc = __import__("json").loads(selftest.read_text())
    assert [t["square"] for t in doc["tasks"]] == [0, 1, 4]


def test_internal_error_in_the_child_is_retried_without_traceback_or_paths(rt):
    job_id = _job(rt, {"duration_s": 0, "fail_attempts": 1})
    assert runner.execute_job(rt, job_id) == "queued"
    job = _row(rt, job_id)
    assert job.error["status"] == 500 and "fails on purpose" in job.error["detail"]
    assert "traceback" not in job.error and "Traceback" in (job.log or "")
