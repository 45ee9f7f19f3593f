"""The task queue: Huey on SQLite by default (no server), on Redis when GNSSATT_QUEUE_URL is set.

A queue message carries only a job id. Huey delivers at most once, so the queue is only the doorbell:
the job row, with its lease, is the truth (worker/runner.py claims, renews and reaps it).
"""
from __future__ import annotations

from huey import Huey, RedisHuey, SqliteHuey

from app.settings import Settings

TASK_NAME = "gnssatt.run_job"
TASK_NAME_FANOUT = "gnssatt.run_task"


def make_huey(settings: Settings, *, immediate: bool = False) -> Huey:
    """A Huey instance for the configured backend, with the one task `gnssatt.run_job(job_id)` registered."""
    if settings.queue_url:
        huey: Huey = RedisHuey(settings.queue_name, url=settings.queue_url, results=False, immediate=immediate)
    else:
        settings.ensure_dirs()
        huey = SqliteHuey(settings.queue_name, filename=str(settings.data_dir / "queue.db"), results=False,
                          immediate=immediate, timeout=30)

    @huey.task(name=TASK_NAME)
    def run_job(job_id: str) -> None:
        from worker.runner import run_claimed_job_message
        run_claimed_job_message(job_id)

    @huey.task(name=TASK_NAME_FANOUT)
    def run_task(task_id: str) -> None:
        from worker.fanout import run_task_message
        run_task_message(task_id)

    huey.run_job = run_job  # type: ignore[attr-defined]
    huey.run_task = run_task  # type: ignore[attr-defined]
    return huey


def enqueue(huey: Huey, job_id: str, delay_s: float | None = None) -> None:
    """Ring the doorbell for one job; duplicates are harmless (claiming is conditional on the row)."""
    if delay_s:
        huey.run_job.schedule((job_id,), delay=delay_s)  # type: ignore[attr-defined]
    else:
        huey.run_job(job_id)  # type: ignore[attr-defined]


def enqueue_task(huey: Huey, task_id: str) -> None:
    """Ring the doorbell for one fan-out task (see worker/fanout.py)."""
    huey.run_task(task_id)  # type: ignore[attr-defined]


def queue_reachable(huey: Huey) -> bool:
    """True when the queue backend answers (used by /readyz)."""
    try:
        huey.storage.queue_size()
        return True
    except Exception:
        return False
