"""A fan-out task a worker's consumer picks up (fanout.run_task_message) runs in a child process under the job
budget (worker.isolation), as the job's own attempt does: a task that allocates beyond the budget fails for good
with the budget's error and fails its job with it, the worker itself never holds the memory and goes on serving;
a cancelled parent stops a task that never returns; and a calibration whose every task went through that path
gives the products of the same calibration run in one process; each on SQLite + Huey and on PostgreSQL + Redis (2 two-minute sets; 74 s measured with load
average 20 on 2 cores, most of it simulating the sets and drawing the plots twice)."""
from __future__ import annotations

import hashlib
import os
import threading
import time

import pytest
from sqlalchemy import select, update

from core.models import Job, JobSet, JobTask, ObservationSet, SetFile, Team, utcnow
from core.settings import Settings
from tests._backends import scratch_backend
from worker import fanout, runner
from worker.errors import JobBudgetExceeded, problem_for_exception
from worker.isolation import owned_memory_bytes
from worker.main import build_runtime

HOG_MB = 1024
BUDGET_MB = 200


def hog_task(payload: dict, sets) -> dict:
    """A task function that allocates (and touches) payload['mb'] MB, 16 MB at a time."""
    hog = [bytearray(16 * 2**20) for _ in range(int(payload["mb"]) // 16)]
    return {"held_mb": 16 * len(hog)}


def spin_task(payload: dict, sets) -> dict:
    """A task function that computes for payload['seconds'] s and never yields."""
    until = time.monotonic() + float(payload["seconds"])
    while time.monotonic() < until:
        sum(range(10_000))
    return {}


@pytest.fixture(params=["sqlite", "pg"])
def rt(request, tmp_path, fork_server):
    """A worker runtime on the embedded default, or on PostgreSQL + Redis (scratch database, own queue name)."""
    with scratch_backend(request.param, queue=True, prefix="gnssatt_fanout") as overrides:
        settings = Settings(data_dir=tmp_path / "var", lease_seconds=5, heartbeat_seconds=0.5,
                            job_memory_mb=BUDGET_MB, job_time_s=120.0, job_isolation="process", **overrides)
        rt = build_runtime(settings, name="fanout-budget-test")
        yield rt
        runner.set_runtime(None)
        rt.engine.dispose()


def _running_job(rt, job_type: str = "selftest", config: dict | None = None, set_ids: tuple = ()) -> str:
    with rt.Session.begin() as s:
        team = Team(name=f"team-{time.monotonic_ns()}")
        s.add(team)
        s.flush()
        job = Job(team_id=team.id, type=job_type, config=config or {}, set_ids=list(set_ids), state="running",
                  progress=0.0, created_at=utcnow(), enqueued_at=utcnow(), attempts=1, max_attempts=3,
                  cancel_requested=False)
        s.add(job)
        s.flush()
        for i, set_id in enumerate(set_ids):
            s.add(JobSet(job_id=job.id, set_id=set_id, position=i))
        return job.id


def _task(rt, job_id: str, function: str, payloads: list[dict]) -> list[str]:
    fanout.create_tasks(rt, job_id, function, payloads)
    with rt.Session() as s:
        return list(s.execute(select(JobTask.id).where(JobTask.job_id == job_id).order_by(JobTask.idx)).scalars())


def _task_row(rt, task_id: str) -> JobTask:
    with rt.Session() as s:
        return s.get(JobTask, task_id)


def test_a_consumed_task_over_the_memory_budget_fails_clearly_and_the_worker_goes_on(rt, monkeypatch):
    job_id = _running_job(rt)
    (hog,) = _task(rt, job_id, f"{__name__}:hog_task", [{"mb": HOG_MB, "label": "hog"}])
    t0 = time.monotonic()
    fanout.run_task_message(hog)
    row = _task_row(rt, hog)
    assert row.state == "failed" and row.result_sha256 is None  # for good: another attempt cannot fit either
    assert row.error.startswith(fanout.BUDGET_MARK + "Memory budget exceeded: The fan-out task hog ")
    assert f"{BUDGET_MB} MB" in row.error and "GNSSATT_JOB_MEMORY_MB" in row.error
    assert time.monotonic() - t0 < 20
    # the worker (this process) never held the task's memory: 1 GB was asked for in the child only
    assert owned_memory_bytes(os.getpid()) < 900 * 2**20

    # the job waiting on the task fails with the budget's error (not retried), not an internal error
    monkeypatch.setattr(fanout, "create_tasks", lambda *a, **k: None)  # keep the failed row as it is
    monkeypatch.setattr(fanout, "ring", lambda *a, **k: None)
    ctx = runner._make_context(rt, job_id, 1, "no-lease", rt.settings.data_dir / "work" / job_id)
    with pytest.raises(JobBudgetExceeded) as caught:
        fanout.gather(rt, ctx, f"{__name__}:hog_task", [{"mb": HOG_MB, "label": "hog"}], (0.0, 1.0), "hog")
    problem = problem_for_exception(caught.value, job_id, 1)
    assert problem["type"].endswith("/job-budget-exceeded") and problem["title"] == "Memory budget exceeded"
    assert "fan-out task hog" in problem["detail"] and "GNSSATT_JOB_MEMORY_MB" in problem["detail"]

    monkeypatch.undo()

    # and the same worker runs the next task normally
    (square,) = _task(rt, _running_job(rt), "worker.jobs.selftest:square_task", [{"n": 7, "seconds": 0.0}])
    fanout.run_task_message(square)
    row = _task_row(rt, square)
    assert row.state == "done"
    result = __import__("pickle").loads(rt.blobs.path(row.result_sha256).read_bytes())
    assert result["square"] == 49 and not result["worker"].endswith(f":{os.getpid()}")  # run in a child


def test_cancelling_the_parent_stops_a_consumed_task_that_never_returns(rt):
    job_id = _running_job(rt)
    (task_id,) = _task(rt, job_id, f"{__name__}:spin_task", [{"seconds": 60.0, "label": "spin"}])
    worker = threading.Thread(target=fanout.run_task_message, args=(task_id,), daemon=True)
    worker.start()
    deadline = time.monotonic() + 10
    while _task_row(rt, task_id).state != "running" and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    t0 = time.monotonic()
    with rt.Session.begin() as s:
        s.execute(update(Job).where(Job.id == job_id).values(cancel_requested=True))
    worker.join(timeout=10)
    assert not worker.is_alive() and time.monotonic() - t0 < 4
    assert _task_row(rt, task_id).state == "cancelled"


# --- a calibration whose tasks all go through the consumer's budgeted path ------------------------------------

CAL_CFG = {"azimuth_step_deg": 30.0, "elevation_step_deg": 15.0, "min_count": 5}
COMPARED = ("baselines.json", "baselines.csv")


def _store_sets(rt, dirs) -> list[str]:
    """The simulated set folders as observation sets of the service (ids = folder names, as input_set gives)."""
    from bench.local_jobs import input_set

    ids = []
    with rt.Session.begin() as s:
        team = Team(name=f"cal-{time.monotonic_ns()}")
        s.add(team)
        s.flush()
        for d in dirs:
            local = input_set(d)
            s.add(ObservationSet(id=local.id, team_id=team.id, name=local.name, summary=local.summary))
            s.flush()
            for f in local.files:
                sha, size = rt.blobs.put_file(f.path)
                s.add(SetFile(set_id=local.id, name=f.name, kind=f.kind, sha256=sha, size_bytes=size,
                              summary=f.summary))
            ids.append(local.id)
    return ids


def _compared(products: dict[str, bytes]) -> dict[str, str]:
    return {k: hashlib.sha256(v).hexdigest() for k, v in products.items()
            if k in COMPARED or (k.startswith("pcv_") and k.endswith(".json"))}


def test_a_calibration_with_every_task_consumed_in_a_child_gives_the_in_process_products(rt, tmp_path):
    from bench.local_jobs import input_set, job_context, product_bytes
    from gnssatt.calibration.simulated import simulate_campaign
    from worker.jobs.calibration import CalibrationConfig, run

    dirs = simulate_campaign(tmp_path / "campaign", 2, 120.0, seed=11,
                             overrides={"noise": False, "multipath": False, "cn0_jitter_db": 0.0})
    local = job_context(tmp_path / "local", [input_set(d) for d in dirs])
    run(local, CalibrationConfig(**CAL_CFG))
    expected = _compared(product_bytes(local))
    assert any(k.startswith("pcv_") for k in expected) and "baselines.json" in expected

    job_id = _running_job(rt, "calibration", CAL_CFG, tuple(_store_sets(rt, dirs)))
    ctx = runner._make_context(rt, job_id, 1, "no-lease", tmp_path / "work")
    ctx.sets.extend(fanout.load_inputs(rt, job_id))
    consumed: list[str] = []

    def map_by_consumers(function, payloads, span, stage, offset):
        """Every task of the fan-out run by the queue's entry point (as another worker's consumer runs it), then
        the ordinary gather, which finds them done."""
        fanout.create_tasks(rt, job_id, function, payloads, offset)
        with rt.Session() as s:
            ids = s.execute(select(JobTask.id).where(JobTask.job_id == job_id, JobTask.idx >= offset,
                                                     JobTask.idx < offset + len(payloads))
                            .order_by(JobTask.idx)).scalars().all()
        for task_id in ids:
            fanout.run_task_message(task_id)
            consumed.append(task_id)
        return fanout.gather(rt, ctx, function, payloads, span, stage, offset)

    ctx._map = map_by_consumers
    run(ctx, CalibrationConfig(**CAL_CFG))
    with rt.Session() as s:
        rows = s.execute(select(JobTask).where(JobTask.job_id == job_id)).scalars().all()
    assert len(consumed) == len(rows) >= 4 and {r.state for r in rows} == {"done"}
    assert all(r.attempts == 1 for r in rows)  # each ran once, in its budgeted child
    got = {name: hashlib.sha256(rt.blobs.path(rec.sha256).read_bytes()).hexdigest()
           for name, rec in ctx.products.items()}
    assert {k: got[k] for k in expected} == expected
