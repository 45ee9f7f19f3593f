"""A local gnssatt service for end-to-end tests and benchmarks: the real API and worker processes started with the
`gnssatt` command (`python -m client.cli serve` / `worker`), reached over HTTP. Used by tests/e2e, tests/ui and
bench/ (service load, attitude speed, TTFF and calibration jobs); `make demo` (client/demo.py) starts its own
long-lived pair instead."""
from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[1]

__all__ = ["LocalService", "scratch_database"]

PG_DEFAULT = "postgresql+psycopg://postgres@127.0.0.1:5432/test"
REDIS_DEFAULT = "redis://127.0.0.1:6379/0"


@contextlib.contextmanager
def scratch_database(base_url: str, prefix: str = "gnssatt_scratch"):
    """A fresh PostgreSQL database made on the server of `base_url` (a database we may create others from);
    yields its URL and drops it (WITH FORCE) afterwards."""
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url
    name = f"{prefix}_{uuid.uuid4().hex[:12]}"
    admin = create_engine(base_url, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as conn:
            conn.execute(text(f'CREATE DATABASE "{name}"'))
        yield make_url(base_url).set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as conn:
            conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LocalService:
    """The API (`gnssatt serve`) and worker processes (`gnssatt worker`) as subprocesses of this one, on a fresh
    data directory `tmp/var`, for the end-to-end tests and the service benchmarks. backend "sqlite": the embedded
    default (SQLite file + Huey on SQLite); "pg": db_url / queue_url (PostgreSQL + Redis). Short leases
    (GNSSATT_LEASE_SECONDS 3, heartbeat 0.5 s, requeue after 20 s) so that kill tests finish quickly; pop them from
    `env` before start_api() for the service's defaults. Logs go to tmp/<api|worker>-<n>.log."""

    def __init__(self, tmp: Path, backend: str, db_url: str | None, queue_url: str | None):
        self.tmp = tmp
        self.backend = backend
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.env = {k: v for k, v in os.environ.items() if not k.startswith("GNSSATT_")}
        self.env.update(GNSSATT_DATA_DIR=str(tmp / "var"), GNSSATT_LEASE_SECONDS="3",
                        GNSSATT_HEARTBEAT_SECONDS="0.5", GNSSATT_REQUEUE_AFTER_SECONDS="20",
                        GNSSATT_QUEUE_NAME=f"e2e{uuid.uuid4().hex[:10]}", GNSSATT_LOG_LEVEL="INFO",
                        PYTHONUNBUFFERED="1")
        if db_url:
            self.env["GNSSATT_DATABASE_URL"] = db_url
        if queue_url:
            self.env["GNSSATT_QUEUE_URL"] = queue_url
        self.api: subprocess.Popen | None = None
        self.workers: list[subprocess.Popen] = []
        self.logs: list[Path] = []

    def _spawn(self, args: list[str], log_name: str) -> subprocess.Popen:
        log = self.tmp / f"{log_name}-{len(self.logs)}.log"
        self.logs.append(log)
        return subprocess.Popen([sys.executable, "-m", "client.cli", *args], cwd=REPO, env=self.env,
                                stdout=open(log, "wb"), stderr=subprocess.STDOUT)

    def start_api(self, wait: bool = True) -> None:
        self.api = self._spawn(["serve", "--port", str(self.port)], "api")
        self.api_log = self.logs[-1]
        if wait:
            self.wait_ready()

    def wait_ready(self, timeout_s: float = 120.0) -> None:
        """Ready = OUR process says it is serving on the port (another test's server may have raced us to a
        free port) and /readyz answers 200. The limit only ends a wait for a server that will never come up: an
        API starts in ~2-5 s on an idle 2-core machine, but took > 30 s at a load of 6-13 (helper runs)."""
        deadline = time.monotonic() + timeout_s
        marker = f"running on http://127.0.0.1:{self.port}"
        while time.monotonic() < deadline:
            if self.api is not None and self.api.poll() is not None:
                raise RuntimeError(f"API exited early:\n{self.logs_text()}")
            bound = marker in self.api_log.read_text(errors="replace") if self.api_log.exists() else False
            try:
                if bound and httpx.get(self.url + "/readyz", timeout=2).status_code == 200:
                    return
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        raise RuntimeError(f"API not ready in {timeout_s} s:\n{self.logs_text()}")

    def stop_api(self, sig=signal.SIGTERM) -> None:
        if self.api is not None:
            self.api.send_signal(sig)
            self.api.wait(timeout=20)
            self.api = None

    def start_worker(self, concurrency: int = 1) -> subprocess.Popen:
        proc = self._spawn(["worker", "--concurrency", str(concurrency)], "worker")
        proc.log_path = self.logs[-1]
        self.workers.append(proc)
        return proc

    def wait_worker_ready(self, proc: subprocess.Popen, timeout_s: float = 180.0) -> None:
        """Until the worker's queue consumer runs (Huey logs "consumer started" once the fork server has loaded
        the pipelines and kernels, ~20-40 s idle): a test that needs the work shared must not submit before."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                raise RuntimeError(f"worker exited early:\n{self.logs_text()}")
            if "consumer started" in (proc.log_path.read_text(errors="replace") if proc.log_path.exists() else ""):
                return
            time.sleep(0.2)
        raise RuntimeError(f"worker not ready in {timeout_s} s:\n{self.logs_text()}")

    def kill_worker(self, proc: subprocess.Popen, sig=signal.SIGKILL) -> None:
        proc.send_signal(sig)
        proc.wait(timeout=20)
        self.workers.remove(proc)

    def create_key(self, team: str) -> str:
        out = subprocess.run([sys.executable, "-m", "client.cli", "admin", "create-key", "--team", team],
                             cwd=REPO, env=self.env, capture_output=True, text=True, timeout=60, check=True)
        return out.stdout.strip().splitlines()[-1]

    def client(self, key: str) -> httpx.Client:
        return httpx.Client(base_url=self.url, headers={"Authorization": f"Bearer {key}"}, timeout=60)

    def logs_text(self) -> str:
        return "\n".join(f"--- {p.name}\n{p.read_text(errors='replace')[-3000:]}" for p in self.logs if p.exists())

    def shutdown(self) -> None:
        for proc in list(self.workers):
            proc.send_signal(signal.SIGINT)
        for proc in list(self.workers):
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
        self.workers.clear()
        if self.api is not None:
            self.api.terminate()
            try:
                self.api.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.api.kill()
