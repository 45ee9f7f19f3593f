"""End-to-end fixtures: the real API (uvicorn in a subprocess) and real worker processes, over HTTP.

Two backends: `sqlite` (the embedded default: SQLite file + Huey on SQLite) and `pg` (PostgreSQL +
Redis, as a team that outgrew one machine runs it). The pg variant needs GNSSATT_TEST_DATABASE_URL (a
server database we may create scratch databases from) and GNSSATT_TEST_QUEUE_URL; without them it is
skipped with that reason, and with GNSSATT_TEST_REQUIRE_PG=1 (set by .ci/run) it fails instead.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import httpx
import pytest

REPO = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Service:
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

    def wait_ready(self, timeout_s: float = 30.0) -> None:
        """Ready = OUR process says it is serving on the port (another test's server may have raced us to a
        free port) and /readyz answers 200."""
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
        self.workers.append(proc)
        return proc

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


def _pg_urls() -> tuple[str, str] | None:
    db = os.environ.get("GNSSATT_TEST_DATABASE_URL")
    queue = os.environ.get("GNSSATT_TEST_QUEUE_URL")
    return (db, queue) if db and queue else None


def _missing_pg(reason: str):
    if os.environ.get("GNSSATT_TEST_REQUIRE_PG") == "1":
        pytest.fail(f"PostgreSQL + Redis required (GNSSATT_TEST_REQUIRE_PG=1) but {reason}")
    pytest.skip(f"PostgreSQL + Redis variant not run: {reason}")


@pytest.fixture(params=["sqlite", "pg"])
def backend(request):
    return request.param


@pytest.fixture
def service(tmp_path, backend, request):
    db_url = queue_url = None
    scratch_db = None
    admin_engine = None
    if backend == "pg":
        urls = _pg_urls()
        if urls is None:
            _missing_pg("GNSSATT_TEST_DATABASE_URL / GNSSATT_TEST_QUEUE_URL are not set")
        base_db, queue_url = urls
        from sqlalchemy import create_engine, text
        from sqlalchemy.engine import make_url
        try:
            admin_engine = create_engine(base_db, isolation_level="AUTOCOMMIT")
            scratch_db = f"gnssatt_e2e_{uuid.uuid4().hex[:12]}"
            with admin_engine.connect() as conn:
                conn.execute(text(f'CREATE DATABASE "{scratch_db}"'))
            import redis
            redis.Redis.from_url(queue_url).ping()
        except Exception as exc:  # noqa: BLE001
            _missing_pg(f"cannot reach them ({exc})")
        db_url = make_url(base_db).set(database=scratch_db).render_as_string(hide_password=False)
    svc = Service(tmp_path, backend, db_url, queue_url)
    try:
        yield svc
    finally:
        svc.shutdown()
        if request.node.rep_call.failed if hasattr(request.node, "rep_call") else False:
            print(svc.logs_text())
        if scratch_db and admin_engine is not None:
            from sqlalchemy import text
            with admin_engine.connect() as conn:
                conn.execute(text(f'DROP DATABASE IF EXISTS "{scratch_db}" WITH (FORCE)'))
            admin_engine.dispose()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    setattr(item, "rep_" + rep.when, rep)


def wait_for(predicate, timeout_s: float = 30.0, interval_s: float = 0.1, what: str = "condition"):
    deadline = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(interval_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what} (last: {last!r})")
