"""Job type `selftest`: an operator's check of the whole job path (queue, worker, leases, progress,
cancellation, products) without any science. It reports progress for `duration_s`, writes a product
naming the attempt that made it, and can be told to fail its first attempts to show retries."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from worker.jobs.registry import JobType


class SelftestConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    duration_s: float = Field(2.0, ge=0.0, le=3600.0, description="How long the job runs, reporting progress.")
    fail_attempts: int = Field(0, ge=0, le=100, description="Fail (as an internal error) the first N attempts.")
    fail_as_input_error: bool = Field(False, description="Fail as a user-input error instead (never retried).")
    fan_out: int = Field(0, ge=0, le=1000, description="Split into this many tasks that any worker may run.")
    fan_out_passes: int = Field(1, ge=1, le=5, description="Fan out this many times in a row (pass k squares, "
                                "cubes, ... each task's number) to check that passes never mix.")
    task_seconds: float = Field(0.2, ge=0.0, le=600.0, description="How long each fanned-out task works.")
    publish_pcv_map: str | None = Field(None, max_length=200,
                                        description="Publish a small flat test PCV map under this name.")


JOB_TYPE = JobType(
    name="selftest", title="Service self-test",
    description="Checks the job path end to end: runs for duration_s with progress, writes selftest.json "
                "with the attempt number; can fail its first attempts to show retries.",
    config_model=SelftestConfig, pipeline="worker.pipelines.selftest:run", min_sets=0, max_sets=None,
    produces=("selftest.json", "early.json"))
