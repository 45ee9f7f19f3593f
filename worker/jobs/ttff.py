"""Job type `ttff`: the time-to-first-fix study of seed 000 sec. 5 (Table 5) over many observation sets, uploaded or
simulated on the fly, with the paper's method and the body-constrained integer search side by side. See docs/ttff.md."""
from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from worker.jobs.registry import JobType


class TtffSimulation(BaseModel):
    """Random starts simulated on the fly (preset `ttff`), one set per start, each simulated by its own task."""

    model_config = ConfigDict(extra="forbid")
    count: int = Field(20, ge=1, le=5000, description="Number of random starts (sets).")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="Seed of the starts and of the simulated observations.")
    yaw_max_deg: float = Field(180.0, ge=0, le=180, description="Start yaw uniform in +-this (orbital frame).")
    pitch_max_deg: float = Field(70.0, ge=0, le=90, description="Start pitch uniform in +-this.")
    roll_max_deg: float = Field(40.0, ge=0, le=180, description="Start roll uniform in +-this.")
    rate_deg_s: list[float] = Field([0.1, 0.5], min_length=2, max_length=2,
                                    description="Peak slew-back rate uniform in [min, max] (deg/s).")
    hold_s: float = Field(0.0, ge=0, le=3600, description="Start orientation held this long before the slew back.")
    realistic: bool = Field(True, description="The `ttff` preset as it is (50 mm p-p differential PCV, ~1 m code "
                                              "multipath at the antenna horizon, C/N0-dependent noise, docs/ttff.md "
                                              "'Realism'); false: white noise only, no PCV or multipath "
                                              "(consistency checks).")
    overrides: dict[str, Any] = Field(default_factory=dict,
                                      description="Further simulator parameters of the `ttff` preset "
                                                  "(docs/simulator.md), applied last.")

    @field_validator("rate_deg_s")
    @classmethod
    def _rates(cls, v):
        if not (0 < v[0] <= v[1] <= 10):
            raise ValueError("rate_deg_s must be [min, max] with 0 < min <= max <= 10")
        return v


class TtffConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    simulate: TtffSimulation | None = Field(None, description="Simulate the sets instead of (or as well as) using "
                                                              "uploaded ones.")
    configurations: list[Literal["L1+L2", "L1", "L2"]] = Field(["L1+L2", "L1", "L2"], min_length=1)
    methods: list[Literal["filter", "filter-constrained", "epoch-lambda", "epoch-constrained"]] = Field(
        ["filter", "epoch-lambda", "epoch-constrained"], min_length=1,
        description="filter: the seed 000 EKF (MLAMBDA + length validation), the paper's method; "
                    "filter-constrained: the same EKF with the attitude job's ambiguity_search 'constrained' "
                    "(MC-LAMBDA first fix); epoch-lambda: "
                    "every epoch alone, same search and validation; epoch-constrained: every epoch alone, "
                    "C-/MC-LAMBDA with the body geometry, ratio + length + angle validation.")
    duration_s: float = Field(120.0, ge=5, le=86400, description="Seconds of each set used from its first epoch.")
    single_epoch_step_s: float = Field(10.0, ge=1, le=3600,
                                       description="Sampling of the single-epoch success rate (s).")
    min_ratio_constrained: float = Field(1.5, ge=1.0, le=100.0,
                                         description="Ratio of the constrained objective for an accepted fix.")
    max_length_error_m: float = Field(0.03, gt=0, le=1.0, description="Length test (seed 000 Table 2).")
    l2_min_ratio_first_fix: float = Field(2.0, ge=0.0, le=100.0,
                                          description="Paper's method (filter) in the L2-only configuration: a first "
                                                      "fix also needs this MLAMBDA ratio (0: the length test alone, "
                                                      "as seed 000; docs/ttff.md 'Wrong fixes of L2').")
    filter_mode: Literal["dynamic", "kinematic"] = Field("dynamic", description="Attitude filter mode.")

    @model_validator(mode="after")
    def _unique(self):
        if len(set(self.configurations)) != len(self.configurations) or len(set(self.methods)) != len(self.methods):
            raise ValueError("configurations and methods must not repeat")
        return self


JOB_TYPE = JobType(
    name="ttff", title="Time to first fix study (seed 000 Table 5)",
    description="For every observation set (uploaded, or random off-pointing starts simulated on the fly): time "
                "from filter start to the first accepted ambiguity fix per baseline and frequency configuration "
                "(L1+L2, L1, L2), whether it was right (against truth when the set has it), single-epoch success "
                "rates, initial yaw/pitch/roll; the paper's method next to the body-constrained search. One "
                "fan-out task per set.",
    config_model=TtffConfig, pipeline="worker.pipelines.ttff:run", min_sets=0, max_sets=None,
    produces=("table5_<method>.csv", "table5_<method>.md", "table5.html", "runs.json", "runs.csv", "summary.json",
              "ttff_table.png (up to 50 sets)", "ttff_histogram.png", "report.html"))
