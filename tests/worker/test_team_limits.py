"""At most GNSSATT_MAX_RUNNING_JOBS_PER_TEAM jobs of one team run at once; the others wait queued and are rung
when one finishes, while other teams' jobs are claimed at once."""
from __future__ import annotations

import pytest

from core.models import Job, Team, utcnow
from core.settings import Settings
from worker import runner
from worker.main import build_runtime


@pytest.fixture
def rt(tmp_path):
    settings = Settings(data_dir=tmp_path / "var", lease_seconds=5, heartbeat_seconds=0.5,
                        max_running_jobs_per_team=2)
    rt = build_runtime(settings, name="limit-test")
    yield rt
    runner.set_runtime(None)
    rt.engine.dispose()


def _jobs(rt, team: str, n: int) -> list[str]:
    with rt.Session.begin() as s:
        t = Team(name=team)
        s.add(t)
        s.flush()
        jobs = [Job(team_id=t.id, type="selftest", config={}, set_ids=[], state="queued", progress=0.0,
                    created_at=utcnow(), enqueued_at=utcnow(), attempts=0, max_attempts=3, cancel_requested=False)
                for _ in range(n)]
        s.add_all(jobs)
        s.flush()
        return [j.id for j in jobs]


def test_team_limit_holds_back_the_third_job_only_for_that_team(rt, monkeypatch):
    a1, a2, a3 = _jobs(rt, "team-a", 3)
    (b1,) = _jobs(rt, "team-b", 1)
    token1, _ = runner.claim(rt, a1)
    assert runner.claim(rt, a2) is not None
    assert runner.claim(rt, a3) is None  # team-a runs 2 = its limit
    assert runner.claim(rt, b1) is not None  # another team is not held back
    with rt.Session() as s:
        assert s.get(Job, a3).state == "queued"
    rung: list[str] = []
    monkeypatch.setattr(runner, "enqueue", lambda huey, job_id, delay_s=None: rung.append(job_id))
    assert runner._finish(rt, a1, token1, state="succeeded", finished_at=utcnow())
    assert runner.ring_waiting(rt, a1) == a3 and rung == [a3]
    assert runner.claim(rt, a3) is not None
