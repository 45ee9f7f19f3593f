"""Method `cn0-boresight` of job type single-antenna-attitude: Settings and run(ctx, config). (Placeholder: its
issue's work replaces this module.)"""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict

from worker.errors import JobInputError


class Settings(BaseModel):
    model_config = ConfigDict(extra="forbid")


def run(ctx, config) -> None:
    raise JobInputError("Method not available", "method cn0-boresight is not implemented in this build",
                        field="config.method")
