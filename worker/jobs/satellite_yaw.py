"""Job type `satellite-yaw`: the yaw of GNSS satellites from ground stations tracking a signal of the satellite's
auxiliary antenna together with the same frequency from its main antenna (seed 004 eq. 9), against the
satellite's attitude model; yaw.csv, yaw.obx (IGS ORBEX), events.csv, residuals.csv, summary.json, yaw.png,
report.html. Science: gnssatt.satyaw.api.estimate_satellite_yaw."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from worker.context import JobContext
from worker.jobs.registry import JobType


class SatelliteYawConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    satellites: dict = Field(default_factory=dict, description="satellites.json content (CONVENTIONS.md): "
                             "baselines and attitude models; seed 004 Table 1 (J01-J03) is built in, and a "
                             "satellite-baseline job's satellites.json can be given unchanged.")
    stations: dict = Field(default_factory=dict, description="stations.json content (CONVENTIONS.md); stations "
                           "not in it take the header APPROX POSITION XYZ, with a warning.")
    satellite_ids: list[str] | None = Field(None, max_length=100, description="Satellites to estimate (each "
                                            "needs a baseline); default every satellite with the auxiliary signal.")
    yaw_mode: Literal["auto", "per-epoch", "offset"] = Field(
        "auto", description="per-epoch yaw, or one yaw offset from the model over the span (short spans, one "
        "or two stations); auto picks offset below 3 stations per epoch or 1 h.")
    elevation_mask_deg: float = Field(10.0, ge=0.0, le=60.0, description="Station elevation mask (deg).")
    phase_sigma_m: float = Field(0.002, gt=0.0, le=0.1, description="A priori sigma of one phase signal (m).")
    code_sigma_m: float = Field(0.5, gt=0.0, le=20.0, description="A priori sigma of one code signal (m).")
    systematic_mm: float = Field(0.3, ge=0.0, le=20.0, description="RMS of slowly varying differential errors (mm) "
                                 "added to the sigma of offset-mode yaw (gnssatt.satyaw.yaw_estimator.YawOptions).")
    smooth: bool = Field(False, description="Also a yaw-rate-limited (satellite's limit) smoothed series.")
    triple_frequency: bool = Field(False, description="Also the triple-frequency (aux L1, main L2, L5) "
                                   "combination's yaw (seed 004 sec. 3).")
    pcv_map_ids: dict[str, str] = Field(default_factory=dict, description="satellite -> stored PCV map id "
                                        "(published by a satellite-baseline job).")


JOB_TYPE = JobType(
    name="satellite-yaw", title="Yaw of GNSS satellites from two transmitting antennas",
    description="Per epoch yaw (with sigma and observability) of satellites whose auxiliary antenna transmits a "
                "signal on a main-antenna frequency (QZSS L1 SLAS: C1Z/L1Z), from a ground network, with the "
                "attitude model it departs from, mode switches and an IGS ORBEX attitude file.",
    config_model=SatelliteYawConfig, pipeline="worker.jobs.satellite_yaw:run", min_sets=1, max_sets=1,
    produces=("yaw.csv", "yaw.obx", "events.csv", "residuals.csv", "summary.json", "yaw.png", "report.html"))


def run(ctx: JobContext, config) -> None:
    from gnssatt.report import html_report
    from gnssatt.satyaw import products
    from gnssatt.satyaw.api import SatYawOptions, estimate_satellite_yaw
    from gnssatt.satyaw.inputs import SatYawInputError
    from worker.errors import JobInputError
    from worker.jobs.satellite_baseline import pcv_map_of_doc

    obs_set = ctx.require_one()
    files = [(f.name, f.path) for f in obs_set.files]
    maps = {sat: pcv_map_of_doc(ctx.input_pcv_map(mid)) for sat, mid in config.pcv_map_ids.items()}
    opts = SatYawOptions(satellites=tuple(config.satellite_ids) if config.satellite_ids else None,
                         yaw_mode=config.yaw_mode, elevation_mask_deg=config.elevation_mask_deg,
                         phase_sigma_m=config.phase_sigma_m, code_sigma_m=config.code_sigma_m,
                         smooth=config.smooth, triple=config.triple_frequency, pcv_maps=maps,
                         systematic_m=config.systematic_mm * 1e-3)
    try:
        result = estimate_satellite_yaw(files, stations=config.stations or None,
                                        satellites=config.satellites or None, options=opts, progress=ctx.progress)
    except SatYawInputError as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    ctx.progress(0.92, "writing products")
    summary = {"observation_set_id": obs_set.id, **products.yaw_summary(result)}
    ctx.write_product("yaw.csv", products.yaw_csv(result))
    ctx.write_product("yaw.obx", products.yaw_orbex(result), media_type="text/plain")
    ctx.write_product("events.csv", products.events_csv(result))
    ctx.write_product("residuals.csv", products.yaw_residuals_csv(result))
    ctx.write_product("summary.json", summary)
    png = products.yaw_plot(result, f"Satellite yaw, set {obs_set.name or obs_set.id}")
    ctx.write_product("yaw.png", png)
    table = [{"satellite": sat, **{k: v for k, v in d.items() if not isinstance(v, (list, dict))}}
             for sat, d in summary["satellites"].items()]
    ctx.write_product("report.html", html_report(f"Satellite yaw of set {obs_set.name or obs_set.id}",
                                                 {k: v for k, v in summary.items() if k != "satellites"},
                                                 {"modelled and estimated yaw": png}, {"satellites": table}))
