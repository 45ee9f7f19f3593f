"""Simulator overrides as a job config accepts them (`simulate.overrides`, `ttff.simulate.overrides`): bounded.

The simulator (gnssatt.sim.scenarios) takes any preset parameter by name; a service must not let one request
ask for a billion seconds or a million passes (the probe of issue 22: a worker grew to 16 GB in four minutes).
So the sizes that drive time and memory have explicit bounds (in the schema), every other number must be finite
and within +-1e9, lists and objects are capped, and the parameters naming files on the worker's disk
(`nav_file`, `orbit_sp3_path`, `trajectory_csv`, `attitude_csv`) are refused: a job reads only its inputs.
"""
from __future__ import annotations

import json
import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

#: Most epochs one simulated set may have (duration_s / interval_s): two days at 1 Hz.
MAX_EPOCHS_PER_SET = 172_800
#: Most epochs of all the sets of one simulate job (count x epochs per set).
MAX_EPOCHS_PER_JOB = 1_000_000
MAX_NUMBER = 1e9
MAX_COMPOUND_BYTES = 64 * 1024
SERVER_PATHS = ("nav_file", "orbit_sp3_path", "trajectory_csv", "attitude_csv")


class SimOverrides(BaseModel):
    """Further preset parameters (docs/simulator.md); the ones below are bounded here, any other is checked for
    finite numbers within +-1e9 and compact lists/objects by the simulator's own names and types."""

    model_config = ConfigDict(extra="allow")
    duration_s: float | None = Field(None, gt=0, le=2 * 86400.0, description="Length of each set (s).")
    interval_s: float | None = Field(None, ge=0.01, le=3600.0, description="Epoch interval (s).")
    count: int | None = Field(None, ge=1, le=100, description="Number of sets (passes) simulated.")
    pass_spacing_s: float | None = Field(None, ge=0, le=366 * 86400.0, description="Start spacing of passes (s).")
    n_channels: int | None = Field(None, ge=1, le=64, description="Receiver channels: most satellites tracked at once.")
    reference_interval_s: float | None = Field(None, ge=0.01, le=3600.0,
                                                description="Step of the reference attitude file (s).")

    @model_validator(mode="after")
    def _bounded(self) -> "SimOverrides":
        for key in SERVER_PATHS:
            if (self.model_extra or {}).get(key):
                raise ValueError(f"{key} names a file on the worker; the service simulates only from its presets")
        for key, value in (self.model_extra or {}).items():
            _check_value(key, value)
        # the presets' own values where not overridden (the longest preset set: 6360 s at 1 Hz); the worker
        # checks again with the scenario's exact values (check_job_size)
        check_job_size(self.as_dict(), 6360.0, 1.0, 1)
        return self

    def as_dict(self) -> dict[str, Any]:
        return self.model_dump(exclude_none=True)


def _check_value(key: str, value: Any) -> None:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        if isinstance(value, str) and len(value) > 1000:
            raise ValueError(f"{key}: a string of at most 1000 characters")
        return
    if isinstance(value, (int, float)):
        if not math.isfinite(value) or abs(value) > MAX_NUMBER:
            raise ValueError(f"{key}: {value!r} is not a finite number within +-{MAX_NUMBER:g}")
        return
    if isinstance(value, (list, dict)):
        if len(json.dumps(value)) > MAX_COMPOUND_BYTES:
            raise ValueError(f"{key}: at most {MAX_COMPOUND_BYTES} bytes as JSON")
        items = value.values() if isinstance(value, dict) else value
        for item in items:
            _check_value(key, item)
        return
    raise ValueError(f"{key}: unsupported value {value!r}")


def check_job_size(overrides: dict[str, Any], preset_duration_s: float, preset_interval_s: float,
                   preset_count: int) -> None:
    """ValueError when the sets these overrides ask for exceed MAX_EPOCHS_PER_SET / MAX_EPOCHS_PER_JOB."""
    duration = float(overrides.get("duration_s", preset_duration_s))
    interval = float(overrides.get("interval_s", preset_interval_s))
    count = int(overrides.get("count", preset_count))
    per_set = duration / interval
    if per_set > MAX_EPOCHS_PER_SET:
        raise ValueError(f"{per_set:.0f} epochs per set (duration_s / interval_s); at most {MAX_EPOCHS_PER_SET}")
    if per_set * count > MAX_EPOCHS_PER_JOB:
        raise ValueError(f"{per_set * count:.0f} epochs in all (count x duration_s / interval_s); at most "
                         f"{MAX_EPOCHS_PER_JOB}")
