"""Job type `simulate`: the truth simulator as a service (what-if studies before launch)."""
from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from worker.jobs.registry import JobType

SCENARIOS = ("earth-pointing", "slew", "ttff", "calibration", "hard", "cubesat", "ground-static")


class SimulateConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    scenario: str = Field("earth-pointing", description=f"One of {', '.join(SCENARIOS)} (see docs/simulator.md).")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="Random seed; same seed and parameters, same files.")
    overrides: dict[str, Any] = Field(default_factory=dict,
                                      description="Any preset parameter, e.g. {\"duration_s\": 600, \"count\": 3}.")

    @field_validator("scenario")
    @classmethod
    def _known(cls, value: str) -> str:
        if value not in SCENARIOS:
            raise ValueError(f"unknown scenario {value!r}; known: {', '.join(SCENARIOS)}")
        return value


JOB_TYPE = JobType(
    name="simulate", title="Simulate an observation set",
    description="Writes a realistic multi-antenna observation set with exactly known attitude: RINEX 3.04 per "
                "antenna, navigation, platform SP3, platform.json, reference attitude and a truth/ folder, as "
                "one zip per run (simulated_set.zip) plus summary.json.",
    config_model=SimulateConfig, pipeline="worker.pipelines.simulate:run", min_sets=0, max_sets=0,
    produces=("simulated_set.zip", "summary.json"))
