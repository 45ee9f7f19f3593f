"""Job type `calibration`: in-flight antenna baselines and differential PCV maps from a campaign of observation
sets with a reference attitude (seed 000 sec. 3). See docs/calibration.md."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from worker.jobs.registry import JobType


#: default attitude configuration of the held-out comparison: the attitude filter's lowest-noise documented
#: processing (the fixed-interval smoother, docs/attitude.md) on every tracked phase (no seed 000 Table 2 C/N0 or
#: antenna-frame masks: they drop the low antenna elevations where the differential PCV is largest). The
#: comparison measures the calibration, and white noise left in both runs dilutes the std cut; with the job's
#: plain defaults even the true calibration cuts the roll std of the bench's held-out pass by only 27.5 %
#: (docs/calibration.md "Error budget"). `{}` gives the attitude job's defaults.
#: The preset "all-phases-smoother" is exactly the former flat default {"smoother": true,
#: "elevation_mask_antenna_deg": -90, "cn0_mask_l1_dbhz": 0, "cn0_mask_l2_dbhz": 0, "cn0_mask_default_dbhz": 0}.
HELD_OUT_ATTITUDE_DEFAULT: dict = {"preset": "all-phases-smoother"}


class CalibrationConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    frequencies: list[Literal["L1", "L2"]] = Field(["L1", "L2"], min_length=1,
                                                   description="Signals used (each an independent observation); one "
                                                               "PCV map per baseline and frequency.")
    azimuth_step_deg: float = Field(2.5, gt=0.0, le=90.0, description="Azimuth bin width (divides 360).")
    elevation_step_deg: float = Field(1.0, gt=0.0, le=45.0, description="Elevation bin width.")
    elevation_min_deg: float = Field(0.0, ge=-90.0, lt=90.0, description="Lowest bin edge (antenna frame).")
    elevation_max_deg: float = Field(90.0, gt=-90.0, le=90.0, description="Highest bin edge (antenna frame).")
    min_count: int = Field(10, ge=1, le=10_000_000,
                           description="Samples a bin needs for a value; fewer leave it empty (null). 10 with the "
                                       "smoothing (each value is a fit supported by its neighbours); raise it "
                                       "(e.g. 30) with smoothing_order 0.")
    max_iterations: int = Field(10, ge=1, le=1000, description="Most PCV iterations.")
    smoothing_order: int = Field(8, ge=0, le=30, description="Radial order of the Zernike fit that smooths each "
                                 "map over the hemisphere (structure finer than ~90/N deg is smoothed away); 0 = "
                                 "plain bin means. Empty bins stay empty either way.")
    tolerance_mm: float = Field(0.1, gt=0.0, le=100.0, description="Stop when the map changes by less (RMS, mm).")
    held_out_set: str | None = Field(None, max_length=200,
                                     description="Id or name of a set kept out of the calibration and used for the "
                                                 "before/after attitude comparison.")
    held_out_attitude_config: dict = Field(
        default_factory=lambda: dict(HELD_OUT_ATTITUDE_DEFAULT),
        description="Attitude job config (docs/attitude.md) of the held-out comparison: the attitude filter "
                    "runs on the held-out set with it, once as given (a priori baselines) and once with the "
                    "calibrated baselines and maps. Default: dynamic mode with the fixed-interval smoother on "
                    "every tracked phase (no C/N0 / antenna-frame masks), the lowest-noise processing, so the "
                    "comparison shows the calibration rather than white noise; {} = the attitude job's defaults. "
                    "calibrated_baselines and pcv_map_ids are the calibration's own and may not be given.")
    map_name: str | None = Field(None, max_length=150,
                                 description="Name under which the maps are published (default: '<platform> "
                                             "calibration'); each pair and frequency gets '<name> A>B L1'.")
    sigma_phase_mm: float = Field(3.0, gt=0.0, le=100.0, description="Undifferenced phase sigma (seed 000 Table 1).")
    cn0_mask_l1_dbhz: float = Field(35.0, ge=0.0, le=60.0, description="C/N0 mask of L1 C/A (Table 2).")
    cn0_mask_l2_dbhz: float = Field(30.0, ge=0.0, le=60.0, description="C/N0 mask of L2 (Table 2).")
    elevation_mask_antenna_deg: float = Field(0.0, ge=-90.0, le=90.0,
                                              description="Satellites below this elevation in either antenna's "
                                                          "frame are not used.")
    max_reference_gap_s: float = Field(10.0, gt=0.0, le=3600.0,
                                       description="Longest reference-attitude gap interpolated across (slerp).")
    min_reference_coverage: float = Field(0.9, ge=0.0, le=1.0,
                                          description="Fraction of a set's epochs the reference must cover.")
    batch_s: float = Field(300.0, ge=10.0, le=86400.0,
                           description="Batch length of the batch-means sigma of the baselines.")
    max_deviation_mm: float = Field(50.0, gt=0.0, le=1000.0,
                                    description="An epoch-wise baseline further than this from the a priori in any "
                                                "component is left out (a wrong fix).")

    @model_validator(mode="after")
    def _grid(self):
        n_az = 360.0 / self.azimuth_step_deg
        n_el = (self.elevation_max_deg - self.elevation_min_deg) / self.elevation_step_deg
        if abs(n_az - round(n_az)) > 1e-9:
            raise ValueError("azimuth_step_deg must divide 360")
        if n_el < 1 or abs(n_el - round(n_el)) > 1e-9:
            raise ValueError("elevation_max_deg - elevation_min_deg must be a whole number of elevation_step_deg")
        if round(n_az) * round(n_el) > 200_000:
            raise ValueError("more than 200000 bins per map")
        if len(set(self.frequencies)) != len(self.frequencies):
            raise ValueError("frequencies repeat")
        own = sorted({"calibrated_baselines", "pcv_map_ids"} & set(self.held_out_attitude_config))
        if own:
            raise ValueError(f"held_out_attitude_config: {own} come from the calibration itself")
        from worker.jobs.attitude import AttitudeConfig

        try:
            AttitudeConfig(**self.held_out_attitude_config)
        except ValueError as exc:
            raise ValueError(f"held_out_attitude_config: {exc}") from exc
        return self


JOB_TYPE = JobType(
    name="calibration", title="Calibrate antenna baselines and differential PCV maps",
    description="From many observation sets of one platform, each with a reference attitude (star tracker): "
                "epoch-wise baselines rotated into the body frame and averaged (seed 000 Table 3), then "
                "differential phase-centre-variation maps per antenna pair and frequency, iterated with the "
                "previous map applied. Fans out one task per set over all workers.",
    config_model=CalibrationConfig, pipeline="worker.pipelines.calibration:run",
    min_sets=1, max_sets=None,
    produces=("baselines.json", "baselines.csv", "pcv_<first>_<second>_<frequency>.json",
              "pcv_maps.png", "pcv_counts.png", "residual_statistics.json", "held_out_attitude.json",
              "calibration_summary.json", "tasks.csv", "report.html"))
