"""Service settings, all from the environment (prefix GNSSATT_), documented in README.md.

There is no module-level settings instance: `Settings()` is built by whoever starts a process (the API
factory, the worker, the CLI) and passed down, so tests can run several configurations side by side.
"""
from __future__ import annotations

from pathlib import Path

from pydantic import Field, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="GNSSATT_", extra="ignore")

    data_dir: Path = Field(Path("./var"), description="Root of uploads, products, the SQLite database and queue.")
    database_url: str | None = Field(
        None, description="SQLAlchemy URL; default sqlite:///<data_dir>/gnssatt.db (WAL). "
        "e.g. postgresql+psycopg://user@127.0.0.1:5432/db")
    queue_url: str | None = Field(
        None, description="redis://host:port/db to share the queue between machines; default: Huey on SQLite "
        "(<data_dir>/queue.db), no server needed.")
    queue_name: str = Field("gnssatt", pattern=r"^[A-Za-z0-9_.-]{1,64}$",
                            description="Queue name (lets several deployments share one Redis).")
    max_upload_bytes: int = Field(2 * 1024**3, gt=0, description="Largest observation-set upload accepted.")
    max_bundle_members: int = Field(500, gt=0, description="Most files a .zip/.tar.gz bundle may hold.")
    max_bundle_ratio: float = Field(200.0, gt=1, description="Largest uncompressed/compressed ratio of a bundle.")
    max_uploads_per_team: int = Field(4, ge=1, description="Uploads one team may have in progress at once "
                                      "in one API process (more answer 429).")
    max_running_jobs_per_team: int = Field(4, ge=1, description="Jobs of one team running at once across all "
                                           "workers; more wait queued.")
    max_upload_files: int = Field(500, ge=1, description="Most files one upload (multipart parts, or members "
                                  "of its bundles) may hold.")
    max_expanded_bytes: int = Field(4 * 1024**3, gt=0, description="Most bytes the files of one upload may "
                                    "expand to through every compression layer (gzip, bzip2, .Z, Hatanaka, zip).")
    max_line_bytes: int = Field(64 * 1024, ge=1024, description="Longest text line accepted in an uploaded file.")
    max_header_bytes: int = Field(4 * 1024**2, ge=1024, description="Largest RINEX/SP3/ANTEX header accepted.")
    max_reference_csv_bytes: int = Field(32 * 1024**2, ge=1024, description="Largest reference attitude CSV "
                                         "accepted in an upload (about four days at 1 Hz).")
    summarizer_memory_mb: int = Field(1024, ge=0, description="Memory of the API's helper process that "
                                      "summarises navigation, SP3, clock and ANTEX files with their full readers "
                                      "(0: in the API process itself).")
    max_json_body_bytes: int = Field(4 * 1024**2, ge=1024, description="Largest JSON request body (413 beyond).")
    max_json_depth: int = Field(64, ge=4, description="Deepest nesting of a JSON request body (422 beyond).")
    job_memory_mb: int = Field(4096, ge=64, description="Memory (resident set) one job may use; a job over it "
                               "is stopped and fails with a clear error.")
    job_time_s: float = Field(6 * 3600.0, gt=0, description="Wall-clock time one job attempt may take.")
    job_isolation: str = Field("process", pattern="^(process|thread)$", description="'process': each job "
                               "attempt runs in a child process under the memory and time budget (cancel kills "
                               "it); 'thread': in the worker's own process (tests, debugging).")
    janitor_grace_s: float = Field(3600.0, ge=0, description="Age before the janitor removes staging "
                                   "directories, work directories of dead attempts and unreferenced blobs.")
    lease_seconds: float = Field(30.0, gt=0, description="A running job's lease; a worker that misses it loses the job.")
    heartbeat_seconds: float = Field(5.0, gt=0, description="How often a worker renews its leases.")
    requeue_after_seconds: float = Field(
        60.0, gt=0, description="A queued job not claimed this long is enqueued again (lost queue message).")
    max_attempts: int = Field(3, ge=1, description="Attempts before a job that keeps failing is marked failed.")
    worker_concurrency: int = Field(1, ge=1, description="Jobs one worker process runs at once.")
    log_level: str = Field("INFO", description="Python logging level of API and worker.")
    public_url: str | None = Field(None, description="Base URL used in product links; default: the request's.")

    @field_validator("data_dir")
    @classmethod
    def _absolute(cls, value: Path) -> Path:
        return value.expanduser().resolve()

    @model_validator(mode="after")
    def _check(self) -> "Settings":
        if self.heartbeat_seconds >= self.lease_seconds:
            raise ValueError("GNSSATT_HEARTBEAT_SECONDS must be shorter than GNSSATT_LEASE_SECONDS")
        if self.queue_url and not self.queue_url.startswith(("redis://", "rediss://", "unix://")):
            raise ValueError("GNSSATT_QUEUE_URL must be a redis:// URL (or unset for the embedded queue)")
        return self

    @property
    def db_url(self) -> str:
        return self.database_url or f"sqlite:///{self.data_dir / 'gnssatt.db'}"

    @property
    def is_sqlite(self) -> bool:
        return self.db_url.startswith("sqlite")

    @property
    def blobs_dir(self) -> Path:
        return self.data_dir / "blobs"

    @property
    def staging_dir(self) -> Path:
        return self.data_dir / "staging"

    def ensure_dirs(self) -> None:
        for d in (self.data_dir, self.blobs_dir, self.staging_dir):
            d.mkdir(parents=True, exist_ok=True)
