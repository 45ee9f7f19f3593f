"""Method `vector-phase` of job type single-antenna-attitude: position, clock and three-axis attitude from the
carrier phase of one antenna, through its vector effective length (seed 003 eq. 32-36, 44-45; docs/vector_phase.md).

Settings (pydantic only) and run(ctx, config), which hands the set to gnssatt.vector_phase.api.solve_set and
writes its products: attitude.csv (CONVENTIONS.md columns; an undetermined angle is an empty cell),
observability.csv, residuals.csv, summary.json, attitude.png, observability.png, residuals.png, report.html.
The antenna's pattern comes from platform.json (antennas[id].antenna_pattern, docs/formats/
antenna_vector_length.md) or the antenna_model setting."""
from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from gnssatt.vector_phase.defaults import POSITION_WALK_DEFAULTS
from worker.errors import JobInputError

L1_WAVELENGTH_MM = 299792458.0 / 1575.42e6 * 1e3


class Settings(BaseModel):
    model_config = ConfigDict(extra="forbid", json_schema_extra={
        "x-platform-defaults": {"position_random_walk_m_per_sqrt_s": POSITION_WALK_DEFAULTS}})
    estimator: Literal["ekf", "batch"] = Field(
        "ekf", description="ekf: Kalman filter with an angular-rate state (the epochs tied by the dynamics); "
                           "batch: each epoch's seven unknowns from its own phase changes (eq. 44-45 as a closed "
                           "system per epoch).")
    initial_attitude: Literal["reference", "given", "coarse-search"] = Field(
        "reference", description="The attitude at the first epoch, which the phase changes of eq. 44 are counted "
                                 "from: reference (the set's reference attitude file), given "
                                 "(q_body_from_ecef) or coarse-search "
                                 "(a yaw grid, the EKF scoring each start; needs the platform to rotate).")
    q_body_from_ecef: list[Annotated[float, Field(ge=-1.0, le=1.0)]] | None = Field(
        None, min_length=4, max_length=4, description="ECEF->body quaternion (w, x, y, z) at the first epoch, for "
                                                      "initial_attitude 'given'.")
    initial_position_ecef_m: list[Annotated[float, Field(ge=-1.0e8, le=1.0e8)]] | None = Field(
        None, min_length=3, max_length=3, description="Antenna position at the first epoch, ECEF m; default the "
                                                      "median code solution (metres off: better give it).")
    antenna_id: str | None = Field(None, max_length=100, description="The antenna of platform.json to use "
                                                                      "(default its master).")
    antenna_model: Literal["short-dipole", "rhcp-patch", "asymmetric-patch"] | None = Field(
        None, description="A built-in receive antenna (short-dipole, rhcp-patch or asymmetric-patch) instead of "
                          "platform.json's antenna_pattern (the defaults of "
                          "docs/formats/antenna_vector_length.md). Cylindrically symmetric ones leave a rotation "
                          "unobservable; the products say which.")
    sigma_phase_mm: float = Field(1.0, gt=0.0, le=50.0, description="Undifferenced L1 phase noise, mm (1 sigma).")
    elevation_mask_deg: float = Field(10.0, ge=-10.0, le=80.0, description="Local-level elevation mask (deg).")
    min_sats: int = Field(7, ge=6, le=40, description="Fewer satellites leave an epoch without a solution (7: "
                                                      "position, clock and three angles; 6 suffices for a dipole).")
    sigma_initial_attitude_deg: float = Field(0.01, gt=0.0, le=180.0, description="EKF: sigma of the initial "
                                                                                  "attitude (deg).")
    sigma_initial_rate_deg_s: float = Field(
        1.0, gt=0.0, le=100.0, description="EKF: sigma of the initial angular rate per axis (deg/s; the filter "
                                           "starts from zero rate). With exactly 7 satellites a value near the "
                                           "platform's true rate avoids an early wrong solution "
                                           "(docs/vector_phase.md).")
    start_rate_hypotheses_deg_s: float = Field(
        1.0, ge=0.0, le=50.0, description="EKF: spacing of the bank of start hypotheses, initial angular rates "
                                          "{-s, 0, s}^3 deg/s per body axis beside the single filter (28 "
                                          "filters until the phases single one out; summary.json "
                                          "start_hypotheses). With exactly 7 satellites one "
                                          "filter from zero rate can settle on a wrong attitude in the first "
                                          "seconds (docs/vector_phase.md); 0: one filter from zero rate.")
    rate_random_walk_deg_s_per_sqrt_s: float = Field(
        0.18, gt=0.0, le=100.0, description="EKF: angular-rate random walk (white angular acceleration), "
                                            "deg/s per sqrt(s).")
    position_random_walk_m_per_sqrt_s: float | None = Field(
        None, ge=0.0, le=100.0, description="EKF: position random walk, m per sqrt(s). Unset: by the set (the "
                                            "schema's x-platform-defaults, with reasons): 0 for a static antenna; "
                                            "with a velocity.csv the position follows that velocity and walks by "
                                            "its sigma.")
    coarse_step_deg: float = Field(30.0, ge=5.0, le=90.0, description="Coarse search: yaw grid step (deg).")
    coarse_tilt_max_deg: float = Field(0.0, ge=0.0, le=90.0, description="Coarse search: pitch and roll range "
                                                                         "(deg; 0: level only).")
    coarse_epochs: int = Field(60, ge=5, le=3600, description="Coarse search: epochs scored per candidate.")

    @model_validator(mode="after")
    def _given_needs_q(self):
        if self.initial_attitude == "given" and self.q_body_from_ecef is None:
            raise ValueError("initial_attitude 'given' needs q_body_from_ecef")
        if self.q_body_from_ecef is not None and not math.isclose(sum(v * v for v in self.q_body_from_ecef), 1.0,
                                                                  abs_tol=1e-6):
            raise ValueError("q_body_from_ecef must have unit norm")
        return self

    def to_options(self):
        """gnssatt.vector_phase.api.VectorPhaseOptions of these settings."""
        from gnssatt.vector_phase.api import VectorPhaseOptions
        from gnssatt.vector_phase.batch import BatchOptions
        from gnssatt.vector_phase.ekf import EkfOptions

        sigma_cyc = self.sigma_phase_mm / L1_WAVELENGTH_MM
        ekf = EkfOptions(sigma_attitude0_deg=self.sigma_initial_attitude_deg, min_sats=self.min_sats,
                         sigma_rate0_deg_s=self.sigma_initial_rate_deg_s,
                         rate_hypotheses_step_deg_s=self.start_rate_hypotheses_deg_s,
                         q_rate_rad2_s3=math.radians(self.rate_random_walk_deg_s_per_sqrt_s) ** 2,
                         sigma_position0_m=1e-3 if self.initial_position_ecef_m is not None else 10.0)
        return VectorPhaseOptions(
            estimator=self.estimator, initial_attitude=self.initial_attitude,
            q_body_from_ecef=tuple(self.q_body_from_ecef) if self.q_body_from_ecef else None,
            initial_position_ecef_m=tuple(self.initial_position_ecef_m) if self.initial_position_ecef_m else None,
            antenna_id=self.antenna_id, antenna_model=self.antenna_model, sigma_phase_cyc=sigma_cyc,
            elevation_mask_deg=self.elevation_mask_deg, ekf=ekf, batch=BatchOptions(min_sats=self.min_sats),
            coarse_step_deg=self.coarse_step_deg, coarse_tilt_max_deg=self.coarse_tilt_max_deg,
            coarse_epochs=self.coarse_epochs, position_random_walk_m_per_sqrt_s=self.position_random_walk_m_per_sqrt_s)


def run(ctx, config) -> None:
    """The vector-phase method on the job's one set: solve_set, then its products."""
    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.vector_phase.api import solve_set
    from gnssatt.vector_phase.inputs import InputProblem

    settings: Settings = config.vector_phase
    obs_set = ctx.require_one()
    ctx.progress(0.02, "reading files")
    files = [(f.name, f.kind, f.path) for f in obs_set.files]
    try:
        result = solve_set(files, settings.to_options(),
                           progress=lambda fraction: ctx.progress(0.1 + 0.8 * fraction, "estimating"))
    except InputProblem as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    except ParseError as exc:
        raise JobInputError("An input file could not be parsed", str(exc), file=exc.path, line=exc.line_no) from exc
    ctx.progress(0.92, "writing products")
    summary_extra = {"observation_set_id": obs_set.id, "settings": settings.model_dump()}
    result.summary.update(summary_extra)
    for name, content in result.products(ctx.job_id).items():
        ctx.write_product(name, content)
    ctx.progress(1.0, "done")
