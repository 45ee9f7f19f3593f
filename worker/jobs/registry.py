"""Job types are plug-ins: one module in worker/jobs/ per type declares a `JOB_TYPE = JobType(...)`.

The same module holds the pipeline run(ctx, config), named by dotted path ("module:function"); it imports the
science inside its functions, so the API can list types and validate configs without importing any numerics. Duplicate names are refused.
"""
from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Callable

from pydantic import BaseModel


@dataclass(frozen=True)
class JobType:
    name: str
    title: str
    description: str
    config_model: type[BaseModel]
    pipeline: str  # "package.module:function", called as function(ctx, config)
    min_sets: int = 1
    max_sets: int | None = 1
    produces: tuple[str, ...] = field(default_factory=tuple)

    def load_pipeline(self) -> Callable:
        module_name, _, func_name = self.pipeline.partition(":")
        return getattr(importlib.import_module(module_name), func_name)


class DuplicateJobType(RuntimeError):
    pass


@lru_cache(maxsize=1)
def job_types() -> dict[str, JobType]:
    """Every job type found in worker/jobs/, by name."""
    import worker.jobs as pkg

    found: dict[str, JobType] = {}
    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        if info.name.startswith("_") or info.name == "registry":
            continue
        module = importlib.import_module(f"{pkg.__name__}.{info.name}")
        spec = getattr(module, "JOB_TYPE", None)
        if spec is None:
            continue
        if spec.name in found:
            raise DuplicateJobType(f"job type {spec.name!r} declared twice ({info.name})")
        found[spec.name] = spec
    return found


def get_job_type(name: str) -> JobType | None:
    return job_types().get(name)
