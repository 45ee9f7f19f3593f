"""Job type `plan`: how good will the attitude be, before flight. Over a platform's orbit (TLE, Keplerian elements
or SP3) or ground position and an attitude profile: satellites in common view, DOPs, ADOP (seed 001 eq. 5), the CRLB
of eq. 4, and the multi-antenna filter's expected yaw / pitch / roll sigma (seed 000 eq. 3-4, Table 4), with plots.

The config model and a thin run(ctx, config) over gnssatt.planning; the numerics are imported inside run()."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.registry import JobType


class KeplerianElements(BaseModel):
    model_config = ConfigDict(extra="forbid")
    epoch: str = Field(..., description="Epoch of the elements, ISO 8601 GPS time.")
    a_m: float = Field(..., ge=6.4e6, le=5e7, description="Semi-major axis (m).")
    e: float = Field(0.0, ge=0, lt=0.9, description="Orbit eccentricity (0: circular).")
    i_deg: float = Field(..., ge=0, le=180, description="Inclination (deg, GCRF).")
    raan_deg: float = Field(0.0, ge=-360, le=360, description="Right ascension of the ascending node (deg).")
    argp_deg: float = Field(0.0, ge=-360, le=360, description="Argument of perigee (deg).")
    m0_deg: float = Field(0.0, ge=-360, le=360, description="Mean anomaly at epoch (deg).")


class GroundPosition(BaseModel):
    model_config = ConfigDict(extra="forbid")
    lat_deg: float = Field(..., ge=-90, le=90, description="WGS 84 geodetic latitude (deg).")
    lon_deg: float = Field(..., ge=-180, le=360, description="Longitude (deg, east).")
    h_m: float = Field(0.0, ge=-500, le=1e5, description="Height above the ellipsoid (m).")


class PlanOrbit(BaseModel):
    model_config = ConfigDict(extra="forbid")
    kind: Literal["tle", "keplerian", "sp3", "ground", "trajectory"] = Field(
        ..., description="Where the platform is: tle, keplerian, sp3 or ground (see the fields below); "
                         "trajectory: the set's velocity.csv with its x/y/z_ecef_m columns "
                         "(docs/formats/inertial_csv.md), e.g. a ground vehicle's track.")
    tle: list[str] | None = Field(None, min_length=2, max_length=3, description="Two-line elements (an optional "
                                                                                "name line first), for kind tle.")
    keplerian: KeplerianElements | None = Field(None, description="For kind keplerian.")
    sp3_satellite: str | None = Field(None, max_length=8, description="The platform's id in the set's SP3 "
                                                                      "file (e.g. L09), for kind sp3.")
    ground: GroundPosition | None = Field(None, description="For kind ground (a static terrestrial platform).")

    @model_validator(mode="after")
    def _given(self):
        need = {"tle": self.tle, "keplerian": self.keplerian, "sp3": self.sp3_satellite, "ground": self.ground,
                "trajectory": True}
        if need[self.kind] is None:
            raise ValueError(f"orbit.kind {self.kind} needs orbit.{'sp3_satellite' if self.kind == 'sp3' else self.kind}")
        return self


class AttitudeProfile(BaseModel):
    model_config = ConfigDict(extra="forbid")
    reference: Literal["orbital", "ned"] | None = Field(None, description="Reference of the Euler angles: orbital "
                                                        "(spacecraft) or ned (terrestrial); null: by the orbit kind.")
    yaw_deg: float = Field(0.0, ge=-180, le=180, description="Fixed yaw of the body in the reference (deg).")
    pitch_deg: float = Field(0.0, ge=-90, le=90, description="Fixed pitch (deg).")
    roll_deg: float = Field(0.0, ge=-180, le=180, description="Fixed roll (deg).")


class PlanConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    start: str = Field(..., description="First epoch, ISO 8601 GPS time (e.g. 2018-06-06T12:20:00).")
    duration_s: float = Field(5400.0, gt=0, le=7 * 86400, description="Length of the plan (s).")
    step_s: float = Field(30.0, ge=1.0, le=3600, description="Epoch spacing (s).")
    orbit: PlanOrbit
    platform: dict | None = Field(None, description="A platform.json object (CONVENTIONS.md); null: the set's.")
    attitude: AttitudeProfile = Field(default_factory=AttitudeProfile)
    systems: list[Literal["G", "E", "C", "J"]] = Field(["G"], min_length=1, max_length=4,
                                                      description="Constellations used: G (GPS), E (Galileo), "
                                                                  "C (BeiDou), J (QZSS).")
    horizon_mask_deg: float | None = Field(None, ge=-90, le=90, description="Local-horizon elevation mask "
                                           "(deg); null: -90 for spacecraft (seed 000 Table 2), 10 on the ground.")
    antenna_mask_deg: float = Field(0.0, ge=-90, le=90, description="Antenna-frame elevation mask (deg, seed "
                                                                    "000 Table 2: 0), for every antenna.")
    sigma_phase_m: float = Field(0.003, gt=0, le=0.1, description="Single-difference carrier-phase sigma "
                                                                 "(m; seed 000 Table 1: 3 mm).")
    cn0_dbhz: float = Field(45.0, ge=20, le=60, description="C/N0 for the SNR of the eq. 4 CRLB (dB-Hz).")
    integration_s: float = Field(1.0, gt=0, le=100, description="Integration time of one measurement for eq. 4 "
                                                                "(s): SNR = C/N0 x integration time.")
    max_sats: int | None = Field(None, ge=2, le=100, description="Receiver channels: the satellites highest in the "
                                                                 "antenna frame are kept; null: all in view.")
    filter_interval_s: float = Field(1.0, gt=0, le=600, description="The attitude filter's epoch interval (s).")
    sigma_omega_deg_s: float = Field(0.03, ge=0, le=100, description="The filter's angular-velocity random walk "
                                     "per tau (deg/s; seed 000 Table 1: 0.03), for its steady-state sigma.")
    tau_omega_s: float = Field(1.0, gt=0, le=3600, description="Tau of that random walk (s; Table 1: 1).")


JOB_TYPE = JobType(
    name="plan", title="Plan the attitude accuracy",
    description="Before flight: over an orbit (TLE, Keplerian elements or SP3) or a ground position and an attitude "
                "profile, the satellites in common view, DOPs, ADOP and CRLB (seed 001 eq. 4-5), and the expected "
                "yaw/pitch/roll sigma of the multi-antenna filter (seed 000 eq. 3-4, Table 4).",
    config_model=PlanConfig, pipeline="worker.jobs.plan:run", min_sets=0, max_sets=1,
    produces=("plan.csv", "summary.json", "plan.png"))


def _platform(ctx: JobContext, config: PlanConfig):
    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.gnss.io.platform import parse_platform
    from gnssatt.planning.series import PlanPlatform

    import json
    if config.platform is not None:
        text, name = json.dumps(config.platform), "config.platform"
    else:
        files = [f for s in ctx.sets for f in s.of_kind("platform")]
        if not files:
            raise JobInputError("No platform", "give config.platform or a set with platform.json",
                                field="config.platform")
        text, name = files[0].path.read_text(), files[0].name
    try:
        p = parse_platform(text, name)
    except ParseError as exc:
        raise JobInputError("Invalid platform", str(exc), file=name) from exc
    return p, PlanPlatform({k: a.position_body_m for k, a in p.antennas.items()},
                           {k: a.boresight_body for k, a in p.antennas.items()}, list(p.baselines))


def _track(ctx: JobContext, config: PlanConfig, t):
    from gnssatt.gnss.time import GpsTime
    from gnssatt.planning import trajectory as tr

    o = config.orbit
    try:
        if o.kind == "tle":
            lines = [x for x in o.tle if x.startswith(("1 ", "2 "))]
            if len(lines) != 2:
                raise ValueError("orbit.tle needs a line starting '1 ' and one starting '2 '")
            return tr.track_from_tle(lines[0], lines[1], t)
        if o.kind == "keplerian":
            k = o.keplerian
            el = tr.Keplerian(GpsTime.from_iso(k.epoch), k.a_m, k.e, k.i_deg, k.raan_deg, k.argp_deg, k.m0_deg)
            return tr.track_from_keplerian(el, t)
        if o.kind == "ground":
            return tr.track_ground(o.ground.lat_deg, o.ground.lon_deg, o.ground.h_m, t)
        if o.kind == "trajectory":
            return _trajectory(ctx, t)
        return tr.track_from_sp3(_sp3(ctx), o.sp3_satellite, t)
    except ValueError as exc:
        raise JobInputError("Invalid orbit", str(exc), field="config.orbit") from exc


def _trajectory(ctx: JobContext, t):
    """The track of the set's velocity.csv (positions and velocities), interpolated to the plan's epochs."""
    import numpy as np

    from gnssatt.planning.trajectory import track_from_samples
    from gnssatt.gnss.io.sensor_csv import read_sensor_csv

    files = [f for s in ctx.sets for f in s.files if f.kind == "velocity" or f.name.lower().endswith("velocity.csv")]
    if not files:
        raise JobInputError("No trajectory", "orbit.kind trajectory needs velocity.csv in the set",
                            field="config.orbit")
    log = read_sensor_csv(files[0].path, "velocity", files[0].name)
    cols = ("x_ecef_m", "y_ecef_m", "z_ecef_m")
    if not all(c in log.extra for c in cols) or len(log.t_s) < 2:
        raise JobInputError("No trajectory", f"{files[0].name}: x_ecef_m, y_ecef_m, z_ecef_m columns and two rows "
                            "at least are needed", file=files[0].name, line=1)
    track = track_from_samples(log.time, np.stack([log.extra[c] for c in cols], 1), log.values, t)
    if not np.isfinite(track.r_ecef_m).all():
        raise JobInputError("Plan outside the trajectory", f"{files[0].name} spans {log.time[0].iso()} to "
                            f"{log.time[-1].iso()}: start and duration must lie inside", field="config.start")
    return track


def _sp3(ctx: JobContext):
    from gnssatt.gnss.io.sp3 import read_sp3

    files = [f for s in ctx.sets for f in s.of_kind("sp3")]
    if not files:
        raise JobInputError("No SP3 file", "orbit.kind sp3 needs a set with an SP3 file", field="config.orbit")
    return read_sp3(files[0].path, name=files[0].name)


def _gnss_positions(ctx: JobContext, t0):
    """(callable t -> (sats, r_ecef_m), description): the set's navigation file, else a synthetic GPS."""
    import numpy as np

    navs = [f for s in ctx.sets for f in s.of_kind("rinex_nav")]
    if navs:
        from gnssatt.gnss.io.rinex_nav import read_rinex_nav
        from gnssatt.planning.satellites import positions_from_nav

        from_nav = positions_from_nav(read_rinex_nav(navs[0].path, name=navs[0].name))
        return from_nav, f"broadcast ephemerides of {navs[0].name}"
    from gnssatt.sim.constellation import synthetic_gps

    const = synthetic_gps(t0)

    def synthetic(t):
        r, _ = const.position_clock(np.asarray(t - const.t_ref, float)[:, None] + np.zeros(const.n))
        return const.sats, r
    return synthetic, "synthetic nominal 31-satellite GPS constellation (no navigation file in the set)"


def run(ctx: JobContext, config: PlanConfig) -> None:
    import numpy as np

    from gnssatt.gnss.time import GpsTime
    from gnssatt.planning.products import plan_csv, plan_summary
    from gnssatt.planning.series import PlanSettings, plan_series

    try:
        t0 = GpsTime.from_iso(config.start)
    except (ValueError, IndexError) as exc:
        raise JobInputError("Invalid start", f"config.start: expected ISO 8601 GPS time, got {config.start!r}",
                            field="config.start") from exc
    t = t0 + np.arange(0.0, config.duration_s + 1e-9, config.step_s)
    platform, plan_platform = _platform(ctx, config)
    if len(plan_platform.baselines) < 1:
        raise JobInputError("No baseline", "the platform needs at least two antennas", field="config.platform")
    ctx.progress(0.05, "orbit")
    track = _track(ctx, config, t)
    positions, source = _gnss_positions(ctx, t0)
    ground = track.kind == "terrestrial"
    settings = PlanSettings(
        reference=config.attitude.reference or ("ned" if ground else "orbital"), yaw_deg=config.attitude.yaw_deg,
        pitch_deg=config.attitude.pitch_deg, roll_deg=config.attitude.roll_deg,
        horizon_mask_deg=config.horizon_mask_deg if config.horizon_mask_deg is not None else (10.0 if ground else -90.0),
        antenna_mask_deg=config.antenna_mask_deg, systems=tuple(config.systems),
        sigma_phase_m=config.sigma_phase_m, cn0_dbhz=config.cn0_dbhz, integration_s=config.integration_s,
        max_sats=config.max_sats, interval_s=config.filter_interval_s, sigma_omega_deg_s=config.sigma_omega_deg_s,
        tau_omega_s=config.tau_omega_s)
    ctx.progress(0.2, "geometry")
    series = plan_series(track, positions, plan_platform, settings)
    series.notes.append(f"GNSS orbits: {source}")
    ctx.progress(0.8, "products")
    ctx.write_product("plan.csv", plan_csv(series))
    ctx.write_product("summary.json", plan_summary(series, settings, platform.name))
    from gnssatt.planning.plots import plan_png

    ctx.write_product("plan.png", plan_png(series))
    ctx.progress(1.0, "done")
