"""Running a job's pipeline in this process on local files, as the runner would hand them to it: an InputSet of a
directory (every file identified and summarised like an upload), a JobContext whose blob store only hashes, and the
products read back. Shared by bench/ (bench_calibration, bench_attitude_speed) and the pipeline tests (tests may
import it; it imports nothing of tests)."""
from __future__ import annotations

import hashlib
from pathlib import Path

from gnssatt.gnss.io.sniff import identify
from worker.context import InputFile, InputSet, JobContext

__all__ = ["input_set", "files_set", "job_context", "product_bytes"]


def input_set(directory: Path, set_id: str | None = None, skip: tuple = ()) -> InputSet:
    """The InputSet of a directory (every file but truth/, identified and summarised like an upload)."""
    directory = Path(directory)
    files = []
    for p in sorted(directory.rglob("*")):
        rel = str(p.relative_to(directory))
        if p.is_file() and not rel.startswith("truth") and rel not in skip:
            kind, summary = identify(p, rel)
            files.append(InputFile(rel, kind, p, summary))
    sid = set_id or directory.name
    return InputSet(sid, sid, files, {})


def files_set(files: list[tuple[str, str, Path]], set_id: str = "set-1", name: str | None = None) -> InputSet:
    """An InputSet of (name, kind, path) files whose kinds are already known (no identification, empty summaries)."""
    return InputSet(id=set_id, name=name, files=[InputFile(n, k, Path(p), {}) for n, k, p in files], summary={})


def _hash_only(path: Path) -> tuple[str, int]:
    data = Path(path).read_bytes()
    return hashlib.sha256(data).hexdigest(), len(data)


def job_context(workdir: Path, sets: list[InputSet], job_id: str = "test") -> JobContext:
    """A JobContext on workdir (products land in workdir/products) whose blob store hashes each product as the
    service's does and keeps nothing else; fan-out (ctx.map) runs in this process."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    return JobContext(job_id=job_id, attempt=1, sets=sets, workdir=workdir, _store_blob=_hash_only)


def product_bytes(ctx: JobContext) -> dict[str, bytes]:
    """{product name: bytes} of every product the job wrote."""
    return {name: (ctx.workdir / "products" / name).read_bytes() for name in ctx.products}
