"""Run one job on local files without a server, database or queue (`gnssatt run`): the same job type registry,
config model and pipeline as the worker, a JobContext whose products land in an output directory, fan-out tasks run
in this process (worker/inprocess.py), PCV maps read from local files instead of the team's store."""
from __future__ import annotations

import hashlib
import json
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable

from gnssatt.gnss.io.observation_set import ANSWER_KEY_FOLDER, ObservationSet, SetProblem, set_summary
from worker.context import InputFile, InputSet, JobContext
from worker.errors import JobInputError
from worker.jobs.registry import get_job_type, job_types

__all__ = ["local_set", "run_job_locally", "stderr_progress", "ANSWER_KEY_FOLDER"]


def local_set(paths: list[Path], set_id: str) -> InputSet:
    """An InputSet of local files (a directory stands for every file under it but its top-level ANSWER_KEY_FOLDER),
    each identified by its content and the set checked and summarised as an upload is
    (gnssatt.gnss.io.observation_set.ObservationSet.of_paths, set_summary)."""
    obs_set = ObservationSet.of_paths(paths, set_id)
    try:
        summary = set_summary(obs_set.files)
    except SetProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    files = [InputFile(f.name, f.kind, Path(f.path), f.summary) for f in obs_set.files]
    return InputSet(id=set_id, name=None, files=files, summary=summary)


def stderr_progress(fraction: float, stage: str | None) -> None:
    """A one-line progress bar on stderr: bar, percent, stage."""
    filled = int(round(30 * fraction))
    sys.stderr.write(f"\r[{'#' * filled}{' ' * (30 - filled)}] {100 * fraction:5.1f}% {(stage or '')[:60]:<60}")
    sys.stderr.flush()


def run_job_locally(job_type: str, sets: list[InputSet], config: dict, out_dir: Path, *,
                    pcv_maps: dict[str, Path] | None = None,
                    progress: Callable[[float, str | None], None] | None = stderr_progress) -> dict[str, Path]:
    """Validate `config` with the job type's model, run its pipeline on `sets`, copy every product into
    `out_dir`; returns {product name: path}. JobInputError names the field of a bad config."""
    spec = get_job_type(job_type)
    if spec is None:
        raise JobInputError("Unknown job type", f"{job_type!r} is not one of {sorted(job_types())}", field="type")
    from pydantic import ValidationError

    try:
        model = spec.config_model.model_validate(config)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise JobInputError("Invalid config", f"config.{where}: {first['msg']}", field=f"config.{where}") from exc
    n_max = spec.max_sets if spec.max_sets is not None else len(sets)
    if not spec.min_sets <= len(sets) <= n_max:
        raise JobInputError("Wrong number of observation sets", f"{job_type} takes {spec.min_sets}..{spec.max_sets}"
                            f" sets, got {len(sets)}", field="observation_set_ids")
    stored: dict[str, Path] = {}

    def store(path: Path) -> tuple[str, int]:
        data = Path(path).read_bytes()
        sha = hashlib.sha256(data).hexdigest()
        stored[sha] = Path(path)
        return sha, len(data)

    maps = {k: json.loads(Path(v).read_text()) for k, v in (pcv_maps or {}).items()}
    with tempfile.TemporaryDirectory(prefix="gnssatt-run-") as tmp:
        ctx = JobContext(job_id="local", attempt=1, sets=sets, workdir=Path(tmp), _store_blob=store,
                         _flush_progress=progress, _load_pcv_map=maps.get)
        ctx.progress(0.0, "running")
        spec.load_pipeline()(ctx, model)
        ctx.progress(1.0, "done")
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        written = {}
        for name, rec in ctx.products.items():
            source = Path(tmp) / "products" / name
            shutil.copyfile(source if source.is_file() else stored[rec.sha256], out_dir / name)
            written[name] = out_dir / name
        for name, doc in ctx.pcv_maps:
            (out_dir / f"pcv_map_{name}.json").write_text(json.dumps(doc, indent=2) + "\n")
            written[f"pcv_map_{name}.json"] = out_dir / f"pcv_map_{name}.json"
    if progress is not None:
        sys.stderr.write("\n")
    return written
