"""Method `cn0-boresight` of job type single-antenna-attitude (seed 001 sec. IV): the antenna boresight from C/N0,
as the C/N0-weighted mean of the lines of sight or as the fit of a gain pattern, with sigma; with a magnetometer
log, full attitude by Wahba's problem (boresight + magnetic field). Settings and run(ctx, config) over
gnssatt.single_antenna.boresight.

Inputs of the set: one RINEX observation file with C/N0 (S1C/S1X/S1W) and a navigation file; optional
platform.json (the antenna's boresight in the body frame, kind); optional magnetometer.csv."""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from worker.errors import JobInputError


class GainPatternModel(BaseModel):
    model_config = ConfigDict(extra="forbid")
    theta_deg: list[Annotated[float, Field(ge=0.0, le=180.0)]] = Field(..., min_length=2, max_length=361, description="Off-boresight angles (deg), "
                                   "increasing from 0 to at most 180.")
    gain_db: list[Annotated[float, Field(ge=-100.0, le=50.0)]] = Field(..., min_length=2, max_length=361, description="Gain (dB) at theta_deg.")

    @model_validator(mode="after")
    def _shape(self):
        import numpy as np

        t = np.asarray(self.theta_deg)
        if len(t) != len(self.gain_db) or t[0] != 0 or t[-1] > 180 or np.any(np.diff(t) <= 0):
            raise ValueError("gain_pattern: theta_deg from 0, increasing, <= 180, one gain_db per angle")
        return self


class Settings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    estimator: Literal["gain-pattern-fit", "weighted-mean"] = Field(
        "gain-pattern-fit", description="gain-pattern-fit: C/N0 = c0 + G(off-boresight angle) fitted (Axelrad); "
                                        "weighted-mean: C/N0-weighted mean of the lines of sight (JPL).")
    gain_pattern: GainPatternModel | None = Field(None, description="The antenna's gain against the off-boresight "
                                                  "angle; null: a generic GNSS patch (gnssatt.single_antenna."
                                                  "boresight.PATCH).")
    antenna: str | None = Field(None, max_length=64, description="Antenna id of platform.json; null: the master.")
    min_sats: int = Field(5, ge=3, le=40, description="Fewest tracked satellites for a boresight.")
    min_angle_deg: float = Field(10.0, ge=0.1, le=80.0, description="Smallest angle between boresight and "
                                 "magnetic field for a full attitude (deg).")
    magnetic_model_sigma_nT: float = Field(160.0, ge=0.0, le=1e4, description="Geomagnetic model error per axis "
                                           "(nT).")
    magnetometer_noise_nT: float = Field(2.0, ge=0.0, le=1e4, description="Magnetometer noise per sample (nT).")


def _pattern(st: Settings):
    import numpy as np

    from gnssatt.single_antenna.boresight import PATCH, GainPattern

    if st.gain_pattern is None:
        return PATCH
    return GainPattern(np.asarray(st.gain_pattern.theta_deg, float), np.asarray(st.gain_pattern.gain_db, float))


def _geometry(obs_set, ctx):
    """(time (n,), r_rx_ecef_m (n, 3), v (n, 3), los_ecef (n, m, 3), cn0 (n, m), n_sats (n,)) over valid SPP epochs."""
    import numpy as np

    from gnssatt.gnss.ephemeris import BroadcastEphemeris
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.positioning import select_code, spp

    obs_f, nav_f = obs_set.of_kind("rinex_obs"), obs_set.of_kind("rinex_nav")
    if not obs_f or not nav_f:
        raise JobInputError("No GNSS observations", "method cn0-boresight needs a RINEX observation file with C/N0 "
                            "and a navigation file", field="observation_set_ids")
    obs = read_rinex_obs(obs_f[0].path, name=obs_f[0].name)
    eph = BroadcastEphemeris(read_rinex_nav(nav_f[0].path, name=nav_f[0].name))
    cn0, _ = select_code(obs, "G", ("S1C", "S1X", "S1W"))
    if not np.isfinite(cn0).any():
        raise JobInputError("No C/N0", f"{obs_f[0].name}: no GPS S1C/S1X/S1W observations", file=obs_f[0].name)
    ctx.progress(0.1, "positioning")
    sol = spp(obs, eph)
    ok = sol.valid
    sats = [s for s in obs.sats if s.startswith("G")]
    cols = [obs.sats.index(s) for s in sats]
    t = sol.time[ok]
    n = int(ok.sum())
    los = np.full((n, len(sats), 3), np.nan)
    for j, s in enumerate(sats):
        st = eph.state([s] * n, t + (-0.075))       # ~75 ms travel time: 0.3 km of satellite motion
        d = st.r_ecef_m - sol.position_ecef_m[ok]
        los[:, j] = np.where(st.valid[:, None], d / np.linalg.norm(d, axis=-1, keepdims=True), np.nan)
    c = cn0[ok][:, cols]
    return t, sol.position_ecef_m[ok], sol.velocity_ecef_m_s[ok], los, c, obs_f[0].name


def run(ctx, config) -> None:
    import json

    import numpy as np

    from gnssatt.single_antenna.boresight import pattern_fit, weighted_mean

    st = config.cn0_boresight
    obs_set = ctx.require_one()
    t, r, v, los, cn0, obs_name = _geometry(obs_set, ctx)
    plat = obs_set.of_kind("platform")
    doc = json.loads(plat[0].path.read_text()) if plat else {}
    ants = doc.get("antennas", {})
    ant = st.antenna or doc.get("master") or (next(iter(ants)) if ants else None)
    if st.antenna and st.antenna not in ants:
        raise JobInputError("Unknown antenna", f"antenna {st.antenna!r} is not in platform.json", field="config.antenna")
    bore_body = np.asarray(ants.get(ant, {}).get("boresight", [0, 0, -1]), float)
    bore_body /= np.linalg.norm(bore_body)
    pattern = _pattern(st)
    ctx.progress(0.4, "boresight")
    out = []
    for k in range(len(t)):
        n_tr = int(np.isfinite(cn0[k]).sum())
        if n_tr < st.min_sats:
            out.append(None)
            continue
        b = pattern_fit(los[k], cn0[k], pattern) if st.estimator == "gain-pattern-fit" else weighted_mean(los[k], cn0[k])
        out.append(b if b.ok else None)
    ctx.write_product("boresight.csv", _boresight_csv(t, r, out, st.estimator))
    att = _full_attitude(ctx, obs_set, t, r, v, out, bore_body, st, doc.get("kind", "spacecraft"))
    good = [b for b in out if b is not None]
    ctx.write_product("summary.json", {
        "method": "cn0-boresight", "estimator": st.estimator, "observations": obs_name, "antenna": ant,
        "boresight_body": bore_body.tolist(), "n_epochs": len(t), "n_with_boresight": len(good),
        "median_sigma_deg": float(np.median([b.sigma_deg for b in good])) if good else None,
        "full_attitude": att, "pattern": "generic patch" if st.gain_pattern is None else "given",
        "notes": ["seed 001 sec. IV: 3-15 deg in the literature; the boresight alone leaves the rotation about it "
                  "free (full attitude needs the magnetometer)"]})
    ctx.progress(1.0, "done")


def _boresight_csv(t, r, out, estimator: str) -> str:
    import numpy as np

    from gnssatt.gnss.frames import R_ned_from_ecef, ecef_to_geodetic

    week, sow = t.week_sow()
    iso = t.iso()
    lat, lon, _ = ecef_to_geodetic(r)
    R = R_ned_from_ecef(lat, lon)
    rows = ["time_gps,gps_week,gps_sow,bx_ecef,by_ecef,bz_ecef,azimuth_deg,elevation_deg,sigma_deg,n_sats,c0_dbhz,"
            "estimator"]
    for k, b in enumerate(out):
        if b is None:
            continue
        ned = R[k] @ b.boresight
        az = np.degrees(np.arctan2(ned[1], ned[0])) % 360.0
        el = np.degrees(np.arcsin(np.clip(-ned[2], -1, 1)))
        c0 = "" if not np.isfinite(b.c0_dbhz) else f"{b.c0_dbhz:.2f}"
        rows.append(",".join([iso[k], str(int(week[k])), f"{sow[k]:.3f}", *(f"{x:.6f}" for x in b.boresight),
                              f"{az:.3f}", f"{el:.3f}", f"{b.sigma_deg:.3f}", str(b.n_sats), c0, estimator]))
    return "\n".join(rows) + "\n"


def _full_attitude(ctx, obs_set, t, r, v, out, bore_body, st: Settings, kind: str) -> str:
    """Writes attitude.csv from the boresight and a magnetometer log when the set has one; returns a note."""
    import numpy as np

    from gnssatt.single_antenna.acc_mag import sample_at
    from gnssatt.single_antenna.geomagnetic import field_ecef_nT, model_date
    from gnssatt.single_antenna.products import attitude_csv
    from gnssatt.gnss.io.sensor_csv import read_sensor_csv
    from gnssatt.single_antenna.wahba import wahba_svd

    f = next((x for x in obs_set.files if x.kind == "magnetometer" or x.name.lower().endswith("magnetometer.csv")), None)
    if f is None:
        return "no magnetometer.csv: boresight only (two of three attitude angles)"
    mag_log = read_sensor_csv(f.path, "magnetometer", f.name)
    mag, _ = sample_at(mag_log, t, 0.5)
    try:
        b_model = field_ecef_nT(r, model_date(t[len(t) // 2]))
    except ValueError as exc:
        raise JobInputError("No geomagnetic model", str(exc), field="observation_set_ids") from exc
    b_ecef = np.array([b.boresight if b is not None else np.full(3, np.nan) for b in out])
    sig_b = np.radians([b.sigma_deg if b is not None else np.nan for b in out])
    sig_m = np.hypot(st.magnetic_model_sigma_nT, st.magnetometer_noise_nT) / np.linalg.norm(b_model, axis=-1)
    w = np.stack([1.0 / sig_b ** 2, 1.0 / sig_m ** 2], -1)
    sol = wahba_svd(np.stack([np.broadcast_to(bore_body, mag.shape), mag], 1), np.stack([b_ecef, b_model], 1),
                    np.where(np.isfinite(w), w, 0.0), min_angle_deg=st.min_angle_deg)
    ctx.write_product("attitude.csv", attitude_csv(t, sol.R_body_from_ref, sol.cov_body_rad2, r, v, kind, sol.flags))
    return f"attitude.csv from the boresight and {f.name} (Wahba by SVD, IGRF-14)"
