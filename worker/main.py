"""The worker process: start the fork server of job children, migrate, start the reaper, consume the queue until
told to stop."""
from __future__ import annotations

import logging
import threading
import time

from core import janitor
from core.blobs import BlobStore
from core.db import make_engine, make_sessionmaker
from core.migrate import migrate
from core.settings import Settings
from worker import fanout, isolation, runner
from worker.isolation import isolation_available
from worker.queue import make_huey

log = logging.getLogger("gnssatt.worker")

#: (first, longest) wait [s] of an idle consumer thread between two looks at the embedded SQLite queue (Huey backs
#: off by 1.3x per empty look): a job waits at most the longest for its pick-up (0.5 s before; ~20 cheap SELECTs
#: a second per idle job slot now). Redis queues block on the read instead (BRPOP) and do not poll.
POLL_S = (0.02, 0.05)


def build_runtime(settings: Settings, *, immediate: bool = False, name: str | None = None) -> runner.Runtime:
    settings.ensure_dirs()
    engine = make_engine(settings)
    migrate(engine, settings)
    rt = runner.Runtime(settings=settings, engine=engine, Session=make_sessionmaker(engine),
                        blobs=BlobStore(settings.blobs_dir),
                        huey=make_huey(settings, immediate=immediate, run_job=runner.run_claimed_job_message,
                                       run_task=fanout.run_task_message),
                        worker_name=name or runner.default_worker_name())
    runner.set_runtime(rt)
    return rt


class Reaper(threading.Thread):
    def __init__(self, rt: runner.Runtime):
        super().__init__(name="reaper", daemon=True)
        self.rt = rt
        self.stop_event = threading.Event()
        self.interval_s = max(0.5, min(rt.settings.lease_seconds / 3, 10.0))

    def run(self) -> None:
        next_sweep = time.monotonic()
        janitor_every_s = min(300.0, max(30.0, self.rt.settings.janitor_grace_s / 4))
        while True:
            try:
                runner.reap(self.rt)
            except Exception:
                log.exception("reaper pass failed; trying again")
            if time.monotonic() >= next_sweep:
                next_sweep = time.monotonic() + janitor_every_s
                try:
                    janitor.sweep(self.rt.settings, self.rt.Session, self.rt.blobs)
                except Exception:
                    log.exception("janitor pass failed; trying again later")
            if self.stop_event.wait(self.interval_s):
                return


def preload_pipelines() -> None:
    """Import every job type's pipeline and the modules it names in its PRELOAD tuple (science, plots), so the
    first job a worker runs does not pay ~1 s of imports (numpy/scipy/matplotlib and the science modules) on top
    of its own work. Run by the fork server of job children (worker.zygote), or, when jobs run in threads, in a
    background thread at start: a job arriving meanwhile waits on the import lock."""
    import importlib

    from worker.jobs.registry import job_types

    for name, spec in job_types().items():
        try:
            module = importlib.import_module(spec.pipeline.partition(":")[0])
            for extra in getattr(module, "PRELOAD", ()):
                importlib.import_module(extra)
        except Exception:  # noqa: BLE001 - a broken pipeline fails its jobs, not the worker's start
            log.warning("preloading the %s pipeline failed", name, exc_info=True)


def _warm_up_kernels() -> None:
    """Load (or compile, the first time on this machine) the attitude filter's, the CSV writer's and the plots'
    numba kernels before taking jobs, so the first job does not pay it (docs/attitude.md "Speed")."""
    try:
        from gnssatt.attitude.kernels import warm_up as warm_up_attitude
        from gnssatt.attitude.qc_kernels import warm_up as warm_up_qc
        from gnssatt.attitude.rigid_kernels import warm_up as warm_up_rigid
        from gnssatt.attitude.update_kernels import warm_up as warm_up_update
        from gnssatt.csv_text import warm_up as warm_up_csv
        from gnssatt.estimation.ekf_kernels import warm_up as warm_up_ekf
        from gnssatt.plots.common import warm_up as warm_up_plots

        print("loading the filter kernels (a cold cache compiles them once, ~60-100 s; docs/DEPENDENCIES.md)",
              flush=True)
        t0 = time.perf_counter()
        warm_up_ekf()
        warm_up_attitude()
        warm_up_qc()
        warm_up_update()
        warm_up_rigid()
        warm_up_csv()
        warm_up_plots()
        print(f"filter kernels ready in {time.perf_counter() - t0:.1f} s", flush=True)
    except Exception:                       # a job would report the same error; the worker still serves others
        log.exception("numba kernels failed to compile at start")


def run_worker(settings: Settings, concurrency: int | None = None) -> None:
    """Run a worker until SIGINT/SIGTERM (the Huey consumer handles both)."""
    logging.basicConfig(level=settings.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    process_mode = settings.job_isolation == "process" and isolation_available()
    if process_mode:
        # first, before any thread: job children fork from this server, which loads the pipelines and kernels
        isolation.start_fork_server()
    rt = build_runtime(settings)
    runner.cleanup_stale_workdirs(settings)
    if not process_mode:
        _warm_up_kernels()
        threading.Thread(target=preload_pipelines, name="preload", daemon=True).start()
    reaper = Reaper(rt)
    reaper.start()
    workers = concurrency or settings.worker_concurrency
    log.info("worker %s: %d job slot(s), database %s, queue %s", rt.worker_name, workers,
             rt.engine.url.render_as_string(hide_password=True), settings.queue_url or "huey-sqlite")
    consumer = rt.huey.create_consumer(workers=workers, worker_type="thread", periodic=False,
                                       initial_delay=POLL_S[0], backoff=1.3, max_delay=POLL_S[1],
                                       check_worker_health=True)
    try:
        consumer.run()
    finally:
        reaper.stop_event.set()
