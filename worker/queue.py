"""The task queue: Huey on SQLite by default (no server), on Redis when GNSSATT_QUEUE_URL is set.

A queue message carries only a job id. Huey delivers at most once, so the queue is only the doorbell:
the job row, with its lease, is the truth (worker/runner.py claims, renews and reaps it).
"""
from __future__ import annotations

from typing import Callable

from huey import Huey, RedisHuey, SqliteHuey

from core.settings import Settings

TASK_NAME = "gnssatt.run_job"
TASK_NAME_FANOUT = "gnssatt.run_task"


def _enqueue_only(message_id: str) -> None:
    raise RuntimeError("this process only enqueues: the worker's consumer registers the task handlers "
                       "(worker.main.build_runtime)")


def make_huey(settings: Settings, *, immediate: bool = False,
              run_job: Callable[[str], None] = _enqueue_only,
              run_task: Callable[[str], None] = _enqueue_only) -> Huey:
    """A Huey instance for the configured backend, with the tasks `gnssatt.run_job(job_id)` and
    `gnssatt.run_task(task_id)` registered. The consumer passes their bodies (worker.runner / worker.fanout);
    the API, which only enqueues, passes none: so this module imports nothing of the runtime it serves."""
    if settings.queue_url:
        huey: Huey = RedisHuey(settings.queue_name, url=settings.queue_url, results=False, immediate=immediate)
    else:
        settings.ensure_dirs()
        huey = SqliteHuey(settings.queue_name, filename=str(settings.data_dir / "queue.db"), results=False,
                          immediate=immediate, timeout=30)

    job_body, task_body = run_job, run_task

    # defined here, not registered directly: Huey names a task after the module of its function, and the API and
    # the worker must agree on the name (worker.queue.gnssatt.run_job) whatever bodies they pass
    @huey.task(name=TASK_NAME)
    def _run_job(job_id: str) -> None:
        job_body(job_id)

    @huey.task(name=TASK_NAME_FANOUT)
    def _run_task(task_id: str) -> None:
        task_body(task_id)

    huey.run_job = _run_job  # type: ignore[attr-defined]
    huey.run_task = _run_task  # type: ignore[attr-defined]
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
