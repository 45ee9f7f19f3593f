"""Job type `satellite-baseline`: a GNSS satellite's main -> auxiliary antenna baseline (IGS body frame), the
differential code bias and the differential PCV map, from a ground network with the yaw of the attitude model
(seed 004 sec. 2.1, Table 1, Fig. 3). satellites.json (feeds satellite-yaw unchanged), baselines.csv,
residuals.csv, summary.json, pcv_<sat>.json / .png (published as PCV maps), report.html.
Science: gnssatt.satyaw.api.estimate_satellite_baseline."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from worker.context import JobContext
from worker.jobs.registry import JobType


class SatelliteBaselineConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    satellites: dict = Field(default_factory=dict, description="satellites.json content: signals and attitude "
                             "models (the a priori aux_antenna_m is not needed).")
    stations: dict = Field(default_factory=dict, description="stations.json content (CONVENTIONS.md).")
    satellite_ids: list[str] | None = Field(None, max_length=100, description="Satellites to estimate (e.g. J01); "
                                            "default every satellite with the auxiliary signal.")
    exclude: dict[str, list[tuple[float, float]]] = Field(
        default_factory=dict, description="satellite -> [[start_s, end_s]] (seconds from the first epoch) of "
        "non-nominal attitude (manoeuvres) left out.")
    elevation_mask_deg: float = Field(10.0, ge=0.0, le=60.0, description="Station elevation mask (deg).")
    phase_sigma_m: float = Field(0.002, gt=0.0, le=0.1, description="A priori sigma of one phase signal (m).")
    code_sigma_m: float = Field(0.5, gt=0.0, le=20.0, description="A priori sigma of one code signal (m).")
    pcv_map: bool = Field(True, description="Estimate the differential PCV map with the baseline.")
    nadir_step_deg: float = Field(1.0, gt=0.0, le=5.0, description="Nadir-angle bin width of the PCV map (deg).")
    azimuth_step_deg: float = Field(15.0, gt=0.0, le=90.0, description="Azimuth bin width of the PCV map (deg).")
    map_name: str | None = Field(None, max_length=150, description="Published map name (default '<sat> aux-main L1').")


JOB_TYPE = JobType(
    name="satellite-baseline", title="Antenna baseline and differential PCV of GNSS satellites",
    description="Main-to-auxiliary antenna baseline (with sigmas), differential code bias and differential PCV "
                "map of satellites with two transmitting antennas, from a ground network and the attitude model.",
    config_model=SatelliteBaselineConfig, pipeline="worker.jobs.satellite_baseline:run", min_sets=1, max_sets=1,
    produces=("satellites.json", "baselines.csv", "residuals.csv", "summary.json", "report.html"))


def pcv_map_of_doc(doc: dict):
    """gnssatt.satyaw PcvMap of a published satellite map (CONVENTIONS JSON with nadir_deg)."""
    import numpy as np

    from gnssatt.satyaw.baseline_estimator import PcvMap

    nadir = np.asarray(doc.get("nadir_deg") or [90.0 - e for e in doc["elevation_deg"]], dtype=np.float64)
    order = np.argsort(nadir)
    vals = np.array([[np.nan if v is None else v for v in row] for row in doc["values_mm"]], dtype=np.float64)
    sig = np.array([[np.nan if v is None else v for v in row] for row in doc.get("sigma_mm", doc["values_mm"])],
                   dtype=np.float64)
    return PcvMap(nadir[order], np.asarray(doc["azimuth_deg"], dtype=np.float64), vals[order],
                  np.asarray(doc.get("count", np.zeros_like(vals)), dtype=np.float64)[order], sig[order])


def run(ctx: JobContext, config) -> None:
    from gnssatt.report import html_report
    from gnssatt.satyaw import products
    from gnssatt.satyaw.api import SatYawOptions, estimate_satellite_baseline
    from gnssatt.satyaw.baseline_estimator import BaselineOptions
    from gnssatt.satyaw.inputs import SatYawInputError
    from worker.errors import JobInputError

    obs_set = ctx.require_one()
    files = [(f.name, f.path) for f in obs_set.files]
    opts = SatYawOptions(satellites=tuple(config.satellite_ids) if config.satellite_ids else None,
                         elevation_mask_deg=config.elevation_mask_deg, phase_sigma_m=config.phase_sigma_m,
                         code_sigma_m=config.code_sigma_m)
    bopts = BaselineOptions(pcv_iterations=1 if config.pcv_map else 0, nadir_step_deg=config.nadir_step_deg,
                            azimuth_step_deg=config.azimuth_step_deg)
    try:
        result = estimate_satellite_baseline(files, stations=config.stations or None,
                                             satellites=config.satellites or None, options=opts,
                                             baseline_options=bopts, exclude=config.exclude, progress=ctx.progress)
    except SatYawInputError as exc:
        raise JobInputError(exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    ctx.progress(0.92, "writing products")
    summary = {"observation_set_id": obs_set.id, **products.baseline_summary(result)}
    ctx.write_product("satellites.json", products.satellites_json(result))
    table = products.baselines_csv(result)
    ctx.write_product("baselines.csv", table)
    ctx.write_product("residuals.csv", products.baseline_residuals_csv(result))
    ctx.write_product("summary.json", summary)
    plots = {}
    for sat, s in result.satellites.items():
        if s.estimate.pcv is None:
            continue
        doc = products.pcv_map_doc(sat, s.estimate.pcv)
        ctx.write_product(f"pcv_{sat}.json", doc)
        plots[f"{sat} differential PCV"] = products.pcv_plot(sat, s.estimate.pcv)
        ctx.write_product(f"pcv_{sat}.png", plots[f"{sat} differential PCV"])
        ctx.publish_pcv_map(config.map_name or f"{sat} aux-main L1", doc)
    rows = [dict(zip(table.splitlines()[0].split(","), line.split(","))) for line in table.splitlines()[1:]]
    ctx.write_product("report.html", html_report(f"Satellite baselines of set {obs_set.name or obs_set.id}",
                                                 {k: v for k, v in summary.items() if k != "satellites"}, plots,
                                                 {"baselines (seed 004 Table 1 layout)": rows}))
