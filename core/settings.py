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
