"""Job type `single-antenna-attitude`: attitude from one GNSS antenna, by one of several methods.

Methods: `acceleration-magnetometer` and `cn0-boresight` (seed 001 sec. IV-VI), `vector-phase` (seed 003).
Each method is one module in worker/jobs/single_antenna/ holding its `Settings` model (pydantic only) and its
pipeline `run(ctx, config)`; this module holds the config (the method and one settings group per method), the
JobType and the dispatch. The numerics are imported inside the methods' run()."""
from __future__ import annotations

import importlib
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from worker.context import JobContext
from worker.jobs.registry import JobType
# aliased: with postponed annotations a field named like its module (vector_phase: vector_phase.Settings) would
# resolve the annotation to the field's own default (pydantic: 'FieldInfo' object has no attribute 'Settings')
from worker.jobs.single_antenna import acceleration_magnetometer as _acceleration_magnetometer
from worker.jobs.single_antenna import cn0_boresight as _cn0_boresight
from worker.jobs.single_antenna import vector_phase as _vector_phase

#: method name -> the module that runs it
METHODS = {
    "acceleration-magnetometer": "worker.jobs.single_antenna.acceleration_magnetometer",
    "cn0-boresight": "worker.jobs.single_antenna.cn0_boresight",
    "vector-phase": "worker.jobs.single_antenna.vector_phase",
}


class SingleAntennaConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    method: Literal["acceleration-magnetometer", "cn0-boresight", "vector-phase"] = Field(
        ..., description="acceleration-magnetometer: GNSS-derived acceleration + accelerometer + magnetometer, "
                         "Wahba by SVD (seed 001 sec. V-VI); cn0-boresight: antenna boresight from C/N0 (seed 001 "
                         "sec. IV); vector-phase: carrier phase of one antenna's vector effective length (seed 003).")
    acceleration_magnetometer: _acceleration_magnetometer.Settings = Field(
        default_factory=_acceleration_magnetometer.Settings,
        description="Settings of method acceleration-magnetometer.")
    cn0_boresight: _cn0_boresight.Settings = Field(
        default_factory=_cn0_boresight.Settings, description="Settings of method cn0-boresight.")
    vector_phase: _vector_phase.Settings = Field(
        default_factory=_vector_phase.Settings, description="Settings of method vector-phase.")


JOB_TYPE = JobType(
    name="single-antenna-attitude", title="Attitude from one antenna",
    description="Attitude of a platform with one GNSS antenna: from GNSS-derived acceleration, an accelerometer and "
                "a magnetometer (seed 001), from C/N0 (boresight), or from the carrier phase of the antenna's "
                "vector effective length (seed 003).",
    config_model=SingleAntennaConfig, pipeline="worker.jobs.single_antenna_attitude:run", min_sets=1, max_sets=1,
    produces=("attitude.csv", "summary.json", "report.html"))


def run(ctx: JobContext, config: SingleAntennaConfig) -> None:
    importlib.import_module(METHODS[config.method]).run(ctx, config)
