"""Method `acceleration-magnetometer` of job type single-antenna-attitude (seed 001 sec. V-VI): Settings and
run(ctx, config) over gnssatt.single_antenna.acc_mag.

Inputs of the set: accelerometer.csv and magnetometer.csv (docs/formats/inertial_csv.md), optional gyro.csv;
the antenna's velocity from velocity.csv (with the x/y/z_ecef_m position columns) or, without it, from the
set's RINEX observation + navigation files by the library's single point positioning (Doppler); optional
platform.json (kind, the antenna position, "sensors": {"accelerometer": {"position_m": [...]}})."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from worker.errors import JobInputError


class Settings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    bandwidth_hz: float = Field(0.1, gt=0.001, le=50.0, description="Bandwidth of the differentiating filter of "
                                "the GNSS velocity and of the low-pass of the accelerometer and magnetometer (Hz); "
                                "lower: less noise, more lag in manoeuvres.")
    min_specific_force_m_s2: float = Field(0.5, ge=0.0, le=50.0, description="Below this specific force (GNSS or "
                                           "accelerometer, m/s^2) an epoch has no attitude: free fall (LEO) is "
                                           "unobservable.")
    min_angle_deg: float = Field(10.0, ge=0.1, le=80.0, description="Smallest angle between specific force and "
                                 "magnetic field for an attitude, deg (nearly parallel pairs leave a rotation free).")
    estimate_bias: bool = Field(True, description="Estimate a constant accelerometer bias where the specific force "
                                "turns enough in the body frame (else flagged unobservable).")
    min_bias_spread_deg: float = Field(10.0, ge=1.0, le=90.0, description="Turn of the body-frame specific force "
                                       "needed to estimate the bias (deg).")
    accelerometer_noise_m_s2: float = Field(0.1, ge=0.0, le=10.0, description="White noise of one accelerometer "
                                            "sample (m/s^2), for the weights.")
    accelerometer_bias_sigma_m_s2: float = Field(0.04, ge=0.0, le=10.0, description="A priori accelerometer bias "
                                                 "sigma (m/s^2; seed 001: 3.5-4 mg = 0.035-0.04) when not estimated.")
    magnetometer_noise_nT: float = Field(2.0, ge=0.0, le=1e4, description="White noise of one magnetometer sample "
                                         "(nT).")
    magnetic_model_sigma_nT: float = Field(160.0, ge=0.0, le=1e4, description="Geomagnetic model error per axis "
                                           "(nT; seed 001: 140 N/E, 200 down).")
    velocity_sigma_m_s: float | None = Field(None, gt=0.0, le=10.0, description="GNSS velocity sigma per axis "
                                             "(m/s); null: velocity.csv's sigma_m_s, else 0.005.")
    gravity_only_attitude: bool = Field(True, description="Where the GNSS sees no kinematic acceleration (static or "
                                        "unaccelerated), give the accelerometer-tilt + magnetometer-heading attitude "
                                        "(flagged gravity-only); false: no attitude there.")
    iterations: int = Field(3, ge=1, le=10, description="Passes (rates, ECEF filtering and bias from the previous "
                                                        "pass).")


def _file(obs_set, kind: str):
    for f in obs_set.files:
        if f.kind == kind or f.name.rsplit("/", 1)[-1].lower() == f"{kind}.csv":
            return f
    return None


def _velocity(obs_set, ctx):
    """(time, r_ecef_m, v_ecef_m_s, sigma_m_s or None, n_sats or None, source)."""
    import numpy as np

    from gnssatt.gnss.io.sensor_csv import read_sensor_csv

    f = _file(obs_set, "velocity")
    if f is not None:
        vel = read_sensor_csv(f.path, "velocity", f.name)
        cols = ("x_ecef_m", "y_ecef_m", "z_ecef_m")
        if not all(c in vel.extra for c in cols):
            raise JobInputError("Velocity without position", f"{f.name}: the x_ecef_m, y_ecef_m, z_ecef_m columns are "
                                "needed (gravity and the geomagnetic field depend on the position)", file=f.name, line=1)
        sig = float(np.median(vel.extra["sigma_m_s"])) if "sigma_m_s" in vel.extra else None
        return vel.time, np.stack([vel.extra[c] for c in cols], 1), vel.values, sig, None, f.name
    obs, navs = obs_set.of_kind("rinex_obs"), obs_set.of_kind("rinex_nav")
    if not obs or not navs:
        raise JobInputError("No GNSS velocity", "give velocity.csv, or a RINEX observation file with Doppler and a "
                            "navigation file", field="observation_set_ids")
    from gnssatt.gnss.ephemeris import BroadcastEphemeris
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.positioning import spp

    ctx.progress(0.1, "positioning")
    sol = spp(read_rinex_obs(obs[0].path, name=obs[0].name),
              BroadcastEphemeris(read_rinex_nav(navs[0].path, name=navs[0].name)))
    ok = sol.valid & np.isfinite(sol.velocity_ecef_m_s).all(-1)
    if ok.sum() < 16:
        raise JobInputError("Too few velocities", f"{obs[0].name}: {int(ok.sum())} epochs with a Doppler velocity "
                            "(at least 16 needed)", file=obs[0].name)
    return sol.time[ok], sol.position_ecef_m[ok], sol.velocity_ecef_m_s[ok], None, sol.n_sats[ok], \
        f"single point positioning (Doppler) of {obs[0].name}"


def _platform(obs_set):
    """(kind, lever arm accelerometer - antenna (3,), note) from platform.json's sensors / antennas."""
    import json

    import numpy as np

    files = obs_set.of_kind("platform")
    if not files:
        return "terrestrial", np.zeros(3), "no platform.json: terrestrial, sensors at the antenna"
    doc = json.loads(files[0].path.read_text())
    ants = doc.get("antennas", {})
    master = doc.get("master") or (next(iter(ants)) if ants else None)
    ant = np.array(ants.get(master, {}).get("position_m", [0, 0, 0]), float)
    acc = np.array(doc.get("sensors", {}).get("accelerometer", {}).get("position_m", ant), float)
    return doc.get("kind", "spacecraft"), acc - ant, f"platform {doc.get('name', '')}"


def run(ctx, config) -> None:

    import numpy as np

    from gnssatt.single_antenna import acc_mag
    from gnssatt.single_antenna.geomagnetic import MODEL_NAME, field_ecef_nT, model_date
    from gnssatt.single_antenna.products import attitude_csv
    from gnssatt.gnss.io.sensor_csv import read_sensor_csv

    st = config.acceleration_magnetometer
    obs_set = ctx.require_one()
    logs = {}
    for kind in ("accelerometer", "magnetometer", "gyro"):
        f = _file(obs_set, kind)
        if f is None and kind != "gyro":
            raise JobInputError(f"No {kind} log", f"method acceleration-magnetometer needs {kind}.csv in the set "
                                "(docs/formats/inertial_csv.md)", field="observation_set_ids")
        logs[kind] = read_sensor_csv(f.path, kind, f.name) if f is not None else None
    t, r, v, sig_csv, n_sats, source = _velocity(obs_set, ctx)
    kind, lever, pnote = _platform(obs_set)
    date = model_date(t[len(t) // 2])
    try:
        b_model = field_ecef_nT(r, date)
    except ValueError as exc:
        raise JobInputError("No geomagnetic model", str(exc), field="observation_set_ids") from exc
    settings = acc_mag.AccMagSettings(
        bandwidth_hz=st.bandwidth_hz, min_specific_force_m_s2=st.min_specific_force_m_s2,
        min_angle_deg=st.min_angle_deg, estimate_bias=st.estimate_bias, min_bias_spread_deg=st.min_bias_spread_deg,
        accelerometer_noise_m_s2=st.accelerometer_noise_m_s2,
        accelerometer_bias_sigma_m_s2=st.accelerometer_bias_sigma_m_s2, magnetometer_noise_nT=st.magnetometer_noise_nT,
        magnetic_model_sigma_nT=st.magnetic_model_sigma_nT,
        velocity_sigma_m_s=st.velocity_sigma_m_s or sig_csv or 0.005, iterations=st.iterations,
        gravity_only_attitude=st.gravity_only_attitude)
    inp = acc_mag.AccMagInputs(t, r, v, logs["accelerometer"], logs["magnetometer"], b_model, lever, logs["gyro"])
    ctx.progress(0.4, "attitude")
    acc_mag.check_units(inp, settings)
    sol = acc_mag.solve_acc_mag(inp, settings)
    ctx.write_product("attitude.csv", attitude_csv(t, sol.R_body_from_ecef, sol.cov_body_rad2, r, v, kind, sol.flags,
                                                   n_sats))
    ctx.write_product("summary.json", _summary(sol, settings, source, pnote, MODEL_NAME, date, kind))
    ctx.progress(1.0, "done")


def _summary(sol, settings, source: str, pnote: str, model: str, date, kind: str) -> dict:
    import dataclasses

    import numpy as np

    from gnssatt.single_antenna import acc_mag

    have = np.isfinite(sol.q_body_from_ecef).all(-1)
    names = {"no_specific_force": acc_mag.FLAG_NO_SPECIFIC_FORCE, "gravity_only": acc_mag.FLAG_GRAVITY_ONLY,
             "near_parallel": acc_mag.FLAG_NEAR_PARALLEL, "filter_edge": acc_mag.FLAG_FILTER_EDGE,
             "no_sensor": acc_mag.FLAG_NO_SENSOR, "bias_unobservable": acc_mag.FLAG_BIAS_UNOBSERVABLE}
    counts = {k: int(((sol.flags & b) != 0).sum()) for k, b in names.items()}
    n = len(sol.flags)
    if counts["no_specific_force"] == n:
        obs = ("unobservable: no specific force at any epoch (free fall): the accelerometer senses nothing the "
               "GNSS-derived acceleration could be matched with; no attitude is given")
    elif counts["gravity_only"] >= 0.9 * n:
        obs = ("gravity only: no kinematic acceleration above the GNSS noise, so the GNSS adds nothing beyond the "
               "gravity direction; the attitude is an accelerometer-tilt + magnetometer-heading one")
    else:
        obs = "observable"
    sig = np.degrees(np.sqrt(np.nanmedian(np.diagonal(sol.cov_body_rad2, axis1=-2, axis2=-1), axis=0))) \
        if have.any() else [None] * 3
    return {"method": "acceleration-magnetometer", "observability": obs, "n_epochs": n,
            "n_with_attitude": int(have.sum()), "flag_counts": counts, "velocity_source": source,
            "platform": pnote, "kind": kind, "geomagnetic_model": model, "model_date": date.isoformat(),
            "accelerometer_bias_m_s2": [float(x) for x in sol.bias_m_s2],
            "median_sigma_body_deg": [None if x is None else float(x) for x in sig],
            "sigma_specific_force_m_s2": float(sol.sigma_f_m_s2), "notes": sol.notes,
            "settings": dataclasses.asdict(settings)}
