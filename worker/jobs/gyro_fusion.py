"""Job type `gyro-fusion`: GPS + MEMS gyro attitude with autonomous fault detection and isolation (seed 002).

The config model, JOB_TYPE and run(ctx, config), which hands the set's files (the observation set plus the gyro
log: a CSV whose header names time_gps, wx_rad_s, wy_rad_s, wz_rad_s, docs/formats/gyro_csv.md) to
gnssatt.gyro.fuse and writes its products, plots and report.html. See docs/gyro_fusion.md.
The science is imported inside run() (the API imports this module for the config model)."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.registry import JobType


class GyroFusionConfig(BaseModel):
    """Seed 002 Table 1 defaults; every field maps onto gnssatt.gyro.settings.FusionSettings."""

    model_config = ConfigDict(extra="forbid")
    kappa: float = Field(3.0, ge=0.0, le=10.0, description="GPS fault threshold control parameter (seed 002 "
                         "sec. 3.1: 0-5, 3 from simulation).")
    gps_threshold_model: Literal["chi2", "gaussian"] = Field(
        "chi2", description="chi2: J* is the chi-square quantile with the tail of a normal kappa-sigma test; "
                            "gaussian: the paper's J* = mu + kappa sqrt(2 mu).")
    gps_fdi: bool = Field(True, description="Run the exclusion bank (false: every snapshot is used as it is).")
    n_propagators: int = Field(5, ge=1, le=20, description="Delayed attitude propagators of the gyro test.")
    delay_step_s: float = Field(60.0, gt=0.0, le=3600.0, description="Delay of propagator j is j times this (s).")
    gyro_threshold_sigma: float = Field(5.0, gt=0.0, le=100.0,
                                        description="A propagator flags when |residual| exceeds this many "
                                                    "theoretical sigmas on some axis, gyro_persistence times in a row.")
    gyro_persistence: int = Field(3, ge=1, le=100, description="Consecutive GPS epochs over "
                                                               "gyro_threshold_sigma before a propagator flags.")
    gyro_test_reference: Literal["filter", "independent", "gps"] = Field(
        "filter", description="What each delayed propagator is tested against (seed 002 sec. 3.2): 'filter' the "
                              "fused filter's posterior (detects sooner: a 10x drift step in 116-236 s); "
                              "'independent' its own delayed EKF tested against the GPS snapshot with "
                              "sqrt(H P_j H' + R) (241-471 s; docs/gyro_fusion.md); 'gps' the snapshot attitude.")
    elevation_mask_deg: float = Field(15.0, ge=-10.0, le=80.0, description="Antenna-frame elevation mask (deg).")
    phase_sigma_m: float = Field(0.0019, gt=0.0, le=0.1, description="Undifferenced L1 phase white noise "
                                 "(m; Table 1: 1 % of the wavelength).")
    multipath_zenith_m: float = Field(0.0005, ge=0.0, le=0.1, description="Phase multipath sigma at boresight (m).")
    multipath_horizon_m: float = Field(0.004, ge=0.0, le=0.1,
                                       description="Phase multipath sigma at the antenna horizon (m).")
    multipath_tau_s: float = Field(60.0, gt=0.0, le=86400.0, description="Correlation time of the GPS attitude "
                                   "noise's Gauss-Markov part (s).")
    arw_rad_sqrt_s: float = Field(1.92e-5, gt=0.0, le=0.1, description="Gyro angle random walk, rad/sqrt(s) (Table 1: "
                                  "0.066 deg/sqrt(h)).")
    drift_sigma_rad_s: float = Field(4.85e-5, gt=0.0, le=0.1, description="Gyro drift stability, the "
                                     "Gauss-Markov sigma, rad/s (Table 1: 10 deg/h).")
    drift_tau_s: float = Field(1800.0, gt=0.0, le=1e7, description="Gyro drift correlation time (s).")

    def to_settings(self):
        from gnssatt.gyro.settings import FusionSettings, GpsFdi, GpsNoise, GyroFdi, GyroNoise

        return FusionSettings(
            gyro=GyroNoise(arw_rad_sqrt_s=self.arw_rad_sqrt_s, drift_sigma_rad_s=self.drift_sigma_rad_s,
                           drift_tau_s=self.drift_tau_s, initial_drift_sigma_rad_s=self.drift_sigma_rad_s),
            gps=GpsNoise(phase_sigma_m=self.phase_sigma_m, multipath_zenith_m=self.multipath_zenith_m,
                         multipath_horizon_m=self.multipath_horizon_m, multipath_tau_s=self.multipath_tau_s,
                         elevation_mask_deg=self.elevation_mask_deg),
            gps_fdi=GpsFdi(kappa=self.kappa, enabled=self.gps_fdi, threshold_model=self.gps_threshold_model),
            gyro_fdi=GyroFdi(n_propagators=self.n_propagators, delay_step_s=self.delay_step_s,
                             threshold_sigma=self.gyro_threshold_sigma, persistence=self.gyro_persistence,
                             reference=self.gyro_test_reference))


JOB_TYPE = JobType(
    name="gyro-fusion", title="GPS + gyro attitude with fault detection",
    description="Snapshot attitude from double-differenced L1 phases (seed 002 eq. 1-2) with a bank of processors "
                "excluding one satellite each (threshold mu + kappa sigma), fused with a MEMS gyro log in a "
                "quaternion EKF; a bank of delayed propagators detects gyro drift faults. Attitude at the gyro "
                "rate, gyro bias, fault events, per-processor costs, plots, report and CCSDS AEM.",
    config_model=GyroFusionConfig, pipeline="worker.jobs.gyro_fusion:run",
    produces=("attitude.csv", "gps_attitude.csv", "bias.csv", "faults.csv", "costs.csv", "gyro_tests.csv",
              "summary.json", "attitude.aem", "attitude.png", "faults.png", "bias.png", "errors.png", "report.html"))


def run(ctx: JobContext, config: GyroFusionConfig) -> None:
    from gnssatt.gyro.api import FusionInputError, fuse
    from gnssatt.gyro.plots import fusion_plots
    from gnssatt.gyro.products import attitude_table, fault_rows
    from gnssatt.report import html_report

    obs_set = ctx.require_one()
    ctx.progress(0.0, "reading files")
    files = [(f.name, f.kind, f.path) for f in obs_set.files]
    try:
        res = fuse(files, config.to_settings(), progress=lambda f: ctx.progress(0.05 + 0.8 * f, "fusing"))
    except FusionInputError as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    ctx.progress(0.87, "writing products")
    res.summary["observation_set_id"] = obs_set.id
    for name, content in res.products().items():
        ctx.write_product(name, content)
    ctx.progress(0.93, "plotting")
    refs = obs_set.of_kind("reference_attitude")
    reference = None
    if refs:                                  # a reference attitude in the set: errors.png (seed 002 Fig. 7)
        from gnssatt.gnss.io.reference_attitude import read_reference_attitude

        reference = read_reference_attitude(refs[0].path.read_bytes(), refs[0].name)
    pngs = fusion_plots(res, attitude_table(res), reference)
    for name, png in pngs.items():
        ctx.write_product(name, png, media_type="image/png")
    faults = fault_rows(res)
    ctx.write_product("report.html", html_report(f"GPS + gyro fusion · {obs_set.name or obs_set.id}", res.summary,
                                                 pngs, {"fault events": faults[:500]}), media_type="text/html")
    ctx.progress(1.0, "done")
