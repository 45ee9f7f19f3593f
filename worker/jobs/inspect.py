"""Job type `inspect`: parse a set fully; summary.json and observations.csv (tracking per receiver,
satellite and signal: epochs, first/last epoch, mean C/N0, gaps, loss-of-lock count)."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from worker.jobs.registry import JobType


class InspectConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    gap_factor: float = Field(1.5, gt=1.0, le=1000.0,
                              description="A gap is a step between observed epochs longer than this many intervals.")


JOB_TYPE = JobType(
    name="inspect", title="Inspect an observation set",
    description="Parses every file of one observation set and reports what it holds: per receiver, satellite "
                "and signal the epochs observed, first and last epoch, mean C/N0, gaps and loss-of-lock count.",
    config_model=InspectConfig, pipeline="worker.pipelines.inspect:run",
    min_sets=1, max_sets=1, produces=("summary.json", "observations.csv", "tracking.csv", "tracking.png", "cn0.png"))
