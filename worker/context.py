"""What a pipeline sees of the service: its inputs, a progress reporter and a product writer.

A pipeline never touches HTTP or the database session. Products are written into the blob store as
they are made and listed here; the runner publishes the list atomically only when the attempt
succeeds and still holds its lease, so products of a failed or repeated attempt never show.
"""
from __future__ import annotations

import hashlib
import json
import mimetypes
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from gnssatt.product_files import product_json
from worker.errors import JobCancelled, JobInputError, LeaseLost
from worker.inprocess import run_locally

MEDIA_TYPES = {".csv": "text/csv", ".json": "application/json", ".png": "image/png", ".html": "text/html",
               ".txt": "text/plain", ".aem": "text/plain", ".nmea": "text/plain", ".atx": "text/plain",
               ".rnx": "text/plain", ".sp3": "text/plain", ".zip": "application/zip"}


def media_type_for(name: str) -> str:
    suffix = Path(name).suffix.lower()
    return MEDIA_TYPES.get(suffix) or mimetypes.guess_type(name)[0] or "application/octet-stream"


@dataclass(frozen=True)
class InputFile:
    name: str  # the name inside the observation set (what the user calls it)
    kind: str  # rinex_obs, rinex_nav, sp3, rinex_clock, antex, platform, reference_attitude
    path: Path  # read-only blob on disk
    summary: dict


@dataclass(frozen=True)
class InputSet:
    id: str
    name: str | None
    files: list[InputFile]
    summary: dict

    def of_kind(self, kind: str) -> list[InputFile]:
        return [f for f in self.files if f.kind == kind]

    def platform(self) -> dict | None:
        files = self.of_kind("platform")
        return json.loads(files[0].path.read_text()) if files else None


@dataclass
class ProductRecord:
    name: str
    media_type: str
    sha256: str
    size_bytes: int


@dataclass
class JobContext:
    job_id: str
    attempt: int
    sets: list[InputSet]
    workdir: Path
    _store_blob: Callable[[Path], tuple[str, int]]
    _flush_progress: Callable[[float, str | None], None] | None = None
    _map: Callable[..., list] | None = None
    progress_interval_s: float = 0.3
    products: dict[str, ProductRecord] = field(default_factory=dict)
    fraction: float = 0.0
    stage: str | None = None
    cancel_requested: threading.Event = field(default_factory=threading.Event)
    lease_lost: threading.Event = field(default_factory=threading.Event)
    _last_flush: float = 0.0
    log_lines: list[str] = field(default_factory=list)
    pcv_maps: list[tuple[str, dict]] = field(default_factory=list)
    _map_offset: int = 0
    #: one record per finished fan-out task, in task order: stage, index, label, worker, attempts,
    #: started_at / finished_at (aware UTC datetimes), seconds (written by worker.fanout)
    task_records: list[dict] = field(default_factory=list)
    # map id -> the team's stored PCV map (CONVENTIONS JSON) or None; set by the runner (tests: any callable)
    _load_pcv_map: Callable[[str], dict | None] | None = None
    # store a file whose sha256 is already known (the runner moves it into the blob store instead of reading and
    # copying it); None: products go through _store_blob
    _store_hashed_blob: Callable[[Path, str], tuple[str, int]] | None = None

    # --- progress and cancellation ---------------------------------------------------------------
    def check(self) -> None:
        """Raise JobCancelled / LeaseLost when the job must stop (call it in long loops)."""
        if self.lease_lost.is_set():
            raise LeaseLost(self.job_id)
        if self.cancel_requested.is_set():
            raise JobCancelled(self.job_id)

    def progress(self, fraction: float, stage: str | None = None) -> None:
        """Report progress in [0, 1] and the stage's name; also the place where cancellation happens."""
        self.check()
        self.fraction = min(max(float(fraction), 0.0), 1.0)
        if stage is not None:
            self.stage = stage[:200]
        now = time.monotonic()
        if self._flush_progress and (now - self._last_flush >= self.progress_interval_s or stage is not None):
            self._last_flush = now
            self._flush_progress(self.fraction, self.stage)

    def log(self, message: str) -> None:
        self.log_lines.append(f"{time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())} {message}")

    # --- fan-out ---------------------------------------------------------------------------------
    def map(self, function: str, payloads: list[dict], *, progress_span: tuple[float, float] = (0.0, 0.9),
            stage: str = "tasks", shared: Any = None) -> list:
        """Run `function(payload, sets) -> result` ("module:function") for every payload on any worker
        (this one included) and return the results in payload order. Progress counts finished tasks.
        A pipeline may fan out several times; each call gets its own task rows (call them in the same order
        on every attempt, so a retried job reuses the results it already has).
        `shared`: one picklable object every task needs (e.g. maps): stored once in the blob store instead of in
        every task row, and handed to each task as payload["_shared"]."""
        if self._map is None:
            if shared is not None:
                payloads = [{**p, "_shared": shared} for p in payloads]
            return run_locally(self, function, payloads, progress_span, stage)
        if shared is not None:
            import pickle

            path = self.workdir / "shared" / f"map{self._map_offset}.pickle"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(pickle.dumps(shared, protocol=5))
            sha, _ = self._store_blob(path)
            payloads = [{**p, "_shared_sha256": sha} for p in payloads]
        offset = self._map_offset
        self._map_offset += len(payloads)
        return self._map(function, payloads, progress_span, stage, offset)

    # --- products --------------------------------------------------------------------------------
    def write_product(self, name: str, data: bytes | str | dict | list | Path,
                      media_type: str | None = None) -> ProductRecord:
        """Store one product; `data` is bytes, text, a JSON-able dict/list or a file path."""
        if "/" in name or "\\" in name or name.startswith(".") or not name:
            raise ValueError(f"bad product name {name!r}")
        self.check()
        path = self.workdir / "products" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(data, Path):
            sha, size = self._store_blob(data)
        else:
            if isinstance(data, (dict, list)):
                data = product_json(data)
            raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
            path.write_bytes(raw)
            if self._store_hashed_blob is not None:
                # hashed from memory and moved into the store: the file is written once, not written, read back
                # and copied (residuals.csv of a 106-min pass is ~54 MB)
                sha, size = self._store_hashed_blob(path, hashlib.sha256(raw).hexdigest())
            else:
                sha, size = self._store_blob(path)
        record = ProductRecord(name, media_type or media_type_for(name), sha, size)
        self.products[name] = record
        return record

    def publish_pcv_map(self, name: str, doc: dict) -> None:
        """Keep a PCV map (CONVENTIONS JSON) as the next version of `name` in the team's maps, published
        with the products when the job succeeds (and never by a failed or repeated attempt)."""
        from gnssatt.gnss.io.pcv_map import parse_pcv_map

        parse_pcv_map(doc, name)  # refuse a malformed map now, not at publication
        self.pcv_maps.append((name, doc))

    def input_pcv_map(self, map_id: str) -> dict:
        """A stored PCV map of the job's team by id (CONVENTIONS JSON); JobInputError when there is none."""
        doc = self._load_pcv_map(map_id) if self._load_pcv_map is not None else None
        if doc is None:
            raise JobInputError("Unknown PCV map", f"there is no PCV map with id {map_id!r} in this team",
                                field="config.pcv_map_ids")
        return doc

    def product_path(self, name: str) -> Path:
        """A scratch path to write a product into; then call write_product(name, path)."""
        path = self.workdir / "products" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def require_one(self) -> InputSet:
        if len(self.sets) != 1:
            raise JobInputError("Wrong number of observation sets", f"this job type takes exactly one "
                                f"observation set, got {len(self.sets)}", field="observation_set_ids")
        return self.sets[0]

    def input_error(self, title: str, detail: str, **where: Any) -> JobInputError:
        return JobInputError(title, detail, **where)


