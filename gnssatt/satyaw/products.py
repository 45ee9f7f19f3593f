"""Files of the satellite-yaw and satellite-baseline jobs (CONVENTIONS.md "yaw of GNSS satellites",
docs/formats/orbex.md): yaw.csv, yaw.obx (ORBEX), events.csv, residuals.csv, summary.json and plots; for the
baseline job satellites.json, baselines.csv (seed 004 Table 1 layout), PCV maps and their plots."""
from __future__ import annotations

import io
import json

import numpy as np

from gnssatt.gnss.rotations import dcm_to_quat
from gnssatt.satyaw.attitude_models import R_ecef_from_body, wrap_deg
from gnssatt.satyaw.orbex import OrbexAttitude, orbex_text

__all__ = ["yaw_csv", "yaw_orbex", "events_csv", "yaw_residuals_csv", "yaw_summary", "yaw_plot",
           "satellites_json", "baselines_csv", "pcv_map_doc", "pcv_plot", "baseline_summary",
           "baseline_residuals_csv"]


#: a yaw whose sigma exceeds this is reported as not observable (no agreement verdict): +-90 deg is no information
OBSERVABLE_SIGMA_DEG = 90.0


def _f(v, nd=4):
    return "" if v is None or not np.isfinite(v) else f"{v:.{nd}f}"


def yaw_csv(run) -> str:
    """yaw.csv: time_gps, gps_week, gps_sow, satellite, yaw_deg, sigma_yaw_deg, model_yaw_deg, model,
    n_stations, observability (+ smoothed_yaw_deg, sigma_smoothed_deg, triple_yaw_deg, sigma_triple_deg)."""
    net = run.network
    iso = net.time.iso(3)
    week, sow = net.time.week_sow()
    lines = ["time_gps,gps_week,gps_sow,satellite,yaw_deg,sigma_yaw_deg,model_yaw_deg,model,n_stations,"
             "observability,smoothed_yaw_deg,sigma_smoothed_deg,triple_yaw_deg,sigma_triple_deg"]
    for sat, s in run.satellites.items():
        e = s.estimate
        for t in range(len(net.time)):
            row = [iso[t], str(int(week[t])), f"{sow[t]:.3f}", sat,
                   _f(e.yaw_deg[t]) if e else "", _f(e.sigma_yaw_deg[t]) if e else "", _f(s.model_yaw_deg[t]),
                   s.description.attitude_model, str(int(e.n_stations[t])) if e else "0",
                   _f(e.observability[t]) if e else "",
                   _f(s.smoothed[0][t]) if s.smoothed else "", _f(s.smoothed[1][t]) if s.smoothed else "",
                   _f(s.triple.yaw_deg[t]) if s.triple else "", _f(s.triple.sigma_yaw_deg[t]) if s.triple else ""]
            lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def yaw_orbex(run) -> str:
    """ORBEX ATT records of the estimated yaw (the model's where there is no estimate), ECEF -> body."""
    times, sats, quats = [], [], []
    for sat, s in run.satellites.items():
        yaw = s.estimate.yaw_deg if s.estimate is not None else s.model_yaw_deg
        ok = np.isfinite(yaw)
        R_eb = R_ecef_from_body(s.geometry.R_orbital_from_ecef[ok], yaw[ok])
        quats.append(dcm_to_quat(np.swapaxes(R_eb, -1, -2)))
        times.append(run.network.time[np.flatnonzero(ok)])
        sats += [sat] * int(ok.sum())
    from gnssatt.gnss.time import GpsTime

    att = OrbexAttitude(GpsTime.concatenate(times), np.array(sats), np.concatenate(quats))
    comments = [f"{sat}: {'estimated' if s.estimate is not None else 'model'} yaw, model {s.description.attitude_model}"
                f", baseline {s.description.source}" for sat, s in run.satellites.items()]
    return orbex_text(att, description="Satellite yaw from ground-network two-antenna differences",
                      comments=tuple(comments) + (f"orbit: {run.orbit_source}",))


def events_csv(run) -> str:
    lines = ["satellite,kind,time_gps,time_s"]
    for sat, s in run.satellites.items():
        for e in s.events:
            lines.append(f"{sat},{e.kind},{run.network.time[e.index].iso(3)},{e.time_s:.1f}")
    return "\n".join(lines) + "\n"


def yaw_residuals_csv(run) -> str:
    lines = ["satellite,time_gps,station,type,residual_m"]
    for sat, s in run.satellites.items():
        if s.estimate is None:
            continue
        o = s.obs
        iso = run.network.time.iso(3)
        for k in range(len(o.epoch)):
            lines.append(f"{sat},{iso[o.epoch[k]]},{o.stations[o.station[k]]},{'code' if o.is_code[k] else 'phase'},"
                         f"{s.estimate.residual_m[k]:.5f}")
    return "\n".join(lines) + "\n"


def yaw_summary(run) -> dict:
    """Per satellite: the mean estimated yaw, its sigma, the model's and whether they agree within 2 sigma
    (None when the sigma exceeds OBSERVABLE_SIGMA_DEG: the data do not constrain the yaw)."""
    sats = {}
    for sat, s in run.satellites.items():
        e = s.estimate
        d = {"model": s.description.attitude_model, "baseline_source": s.description.source, "mode": s.mode,
             "mean_model_yaw_deg": float(np.degrees(np.angle(np.mean(np.exp(1j * np.radians(s.model_yaw_deg)))))),
             "beta_deg": float(np.mean(s.geometry.beta_deg)), "warnings": s.warnings}
        if e is not None:
            ok = np.isfinite(e.yaw_deg)
            dev = wrap_deg(e.yaw_deg[ok] - s.model_yaw_deg[ok])
            sig = float(np.sqrt(np.mean(e.sigma_yaw_deg[ok] ** 2)))
            d.update(n_epochs=int(ok.sum()), n_stations=int(len(np.unique(s.obs.station))),
                     mean_yaw_deg=float(np.degrees(np.angle(np.mean(np.exp(1j * np.radians(e.yaw_deg[ok])))))),
                     rms_sigma_yaw_deg=sig, mean_minus_model_deg=float(np.mean(dev)),
                     rms_minus_model_deg=float(np.sqrt(np.mean(dev ** 2))),
                     observable=bool(sig < OBSERVABLE_SIGMA_DEG),
                     agrees_with_model=bool(abs(np.mean(dev)) <= 2.0 * sig) if sig < OBSERVABLE_SIGMA_DEG else None,
                     sigma0=e.sigma0, ar1_factor=e.ar1_factor, events=[ev.to_dict() for ev in s.events])
            if s.triple is not None:
                okt = np.isfinite(s.triple.yaw_deg)
                dt = wrap_deg(s.triple.yaw_deg[okt] - s.model_yaw_deg[okt])
                st = float(np.sqrt(np.mean(s.triple.sigma_yaw_deg[okt] ** 2)))
                d.update(triple_rms_minus_model_deg=float(np.sqrt(np.mean(dt ** 2))) if st < OBSERVABLE_SIGMA_DEG
                         else None, triple_rms_sigma_deg=st if st < OBSERVABLE_SIGMA_DEG else None,
                         triple_observable=bool(st < OBSERVABLE_SIGMA_DEG))
        sats[sat] = d
    return {"satellites": sats, "orbit": run.orbit_source, "stations": [st.name for st in run.network.stations],
            "n_epochs": int(len(run.network.time)), "time_first": run.network.time[0].iso(3),
            "time_last": run.network.time[-1].iso(3), "warnings": run.warnings}


def yaw_plot(run, title: str = "Satellite yaw") -> bytes:
    """Per satellite: modelled (black) and estimated (red, +-sigma) yaw, and the difference below it."""
    from gnssatt.plots.common import figure_png, new_figure

    sats = list(run.satellites)
    fig = new_figure(10.0, 3.2 * max(len(sats), 1))
    gs = fig.add_gridspec(2 * max(len(sats), 1), 1, height_ratios=[2, 1] * max(len(sats), 1))
    t_h = run.network.t_s / 3600.0
    for i, sat in enumerate(sats):
        s = run.satellites[sat]
        ax = fig.add_subplot(gs[2 * i])
        ax.plot(t_h, s.model_yaw_deg, "k.", ms=2, label=f"model ({s.description.attitude_model})")
        if s.estimate is not None:
            e = s.estimate
            ax.fill_between(t_h, e.yaw_deg - e.sigma_yaw_deg, e.yaw_deg + e.sigma_yaw_deg, color="r", alpha=0.2,
                            lw=0, label="+-1 sigma")
            ax.plot(t_h, e.yaw_deg, "r.", ms=2, label="estimated")
        ax.set_ylabel(f"{sat} yaw (deg)")
        ax.legend(fontsize=7, loc="best")
        ax2 = fig.add_subplot(gs[2 * i + 1], sharex=ax)
        if s.estimate is not None:
            d = wrap_deg(s.estimate.yaw_deg - s.model_yaw_deg)
            ax2.fill_between(t_h, d - s.estimate.sigma_yaw_deg, d + s.estimate.sigma_yaw_deg, color="r", alpha=0.2,
                             lw=0)
            ax2.plot(t_h, d, "r.", ms=2)
        ax2.axhline(0.0, color="k", lw=0.5)
        ax2.set_ylabel("est - model (deg)")
    fig.axes[-1].set_xlabel(f"hours from {run.network.time[0].iso(0)} GPS")
    fig.suptitle(title, fontsize=9)
    return figure_png(fig)


def satellites_json(brun) -> dict:
    """satellites.json of the baseline job (feeds a satellite-yaw job unchanged)."""
    out = {}
    for sat, s in brun.satellites.items():
        e = s.estimate
        out[sat] = {"aux_antenna_m": [round(float(v), 5) for v in e.baseline_body_m],
                    "sigma_m": [round(float(v), 5) for v in e.sigma_m],
                    "aux_signals": list(s.description.aux_signals), "main_signals": list(s.description.main_signals),
                    "attitude_model": s.description.attitude_model,
                    "yaw_rate_limit_deg_s": s.description.yaw_rate_limit_deg_s,
                    "n_stations": e.n_stations, "n_epochs": e.n_epochs,
                    "dcb_m": None if not np.isfinite(e.dcb_m) else round(e.dcb_m, 4),
                    "source": "satellite-baseline job"}
    return {"satellites": out}


def baselines_csv(brun) -> str:
    """Table 1 layout: satellite, x_m, y_m, z_m, sigma_x_m, sigma_y_m, sigma_z_m, n_stations, n_epochs,
    sigma0, ar1_factor, dcb_m."""
    lines = ["satellite,x_m,y_m,z_m,sigma_x_m,sigma_y_m,sigma_z_m,n_stations,n_epochs,sigma0,ar1_factor,dcb_m"]
    for sat, s in brun.satellites.items():
        e = s.estimate
        b, sg = e.baseline_body_m, e.sigma_m
        lines.append(f"{sat},{b[0]:.5f},{b[1]:.5f},{b[2]:.5f},{sg[0]:.5f},{sg[1]:.5f},{sg[2]:.5f},"
                     f"{e.n_stations},{e.n_epochs},{e.sigma0:.3f},{e.ar1_factor:.3f},{_f(e.dcb_m)}")
    return "\n".join(lines) + "\n"


def baseline_residuals_csv(brun) -> str:
    lines = ["satellite,time_gps,station,type,residual_m"]
    for sat, s in brun.satellites.items():
        o = s.obs
        iso = brun.network.time.iso(3)
        for k in range(len(o.epoch)):
            lines.append(f"{sat},{iso[o.epoch[k]]},{o.stations[o.station[k]]},{'code' if o.is_code[k] else 'phase'},"
                         f"{s.estimate.residual_m[k]:.5f}")
    return "\n".join(lines) + "\n"


def pcv_map_doc(sat: str, pm) -> dict:
    """The PCV map as CONVENTIONS JSON: pair [sat-main, sat-aux], L1; the grid is the body frame's nadir angle
    (elevation_deg = 90 - nadir, increasing) and azimuth from body +x towards +y."""
    order = np.argsort(90.0 - pm.nadir_deg)
    d = pm.to_dict()
    return {"platform": sat, "pair": [f"{sat}-main", f"{sat}-aux"], "frequency": "L1",
            "azimuth_deg": d["azimuth_deg"], "elevation_deg": [float(90.0 - pm.nadir_deg[i]) for i in order],
            "nadir_deg": [float(pm.nadir_deg[i]) for i in order],
            "values_mm": [d["values_mm"][i] for i in order],
            "count": [[int(round(c)) for c in d["count"][i]] for i in order],
            "sigma_mm": [d["sigma_mm"][i] for i in order],
            "grid": "satellite body frame: elevation_deg = 90 - nadir angle; bilinear between nodes"}


def pcv_plot(sat: str, pm) -> bytes:
    from gnssatt.plots.common import figure_png, new_figure

    fig = new_figure(6.0, 5.5)
    ax = fig.add_subplot(projection="polar")
    az = np.radians(np.r_[pm.azimuth_deg, 360.0])
    vals = np.c_[pm.values_mm, pm.values_mm[:, :1]]
    mesh = ax.pcolormesh(az, pm.nadir_deg, vals, shading="gouraud", cmap="RdBu_r")
    fig.colorbar(mesh, ax=ax, label="differential PCV (mm)")
    ax.set_title(f"{sat} aux - main L1 PCV (radius: nadir deg)", fontsize=9)
    return figure_png(fig)


def baseline_summary(brun) -> dict:
    return {"satellites": {sat: {"baseline_m": s.estimate.baseline_body_m.tolist(),
                                 "sigma_m": s.estimate.sigma_m.tolist(), "sigma0": s.estimate.sigma0,
                                 "n_rows": s.estimate.n_rows, "warnings": s.warnings}
                           for sat, s in brun.satellites.items()},
            "orbit": brun.orbit_source, "stations": [st.name for st in brun.network.stations],
            "warnings": brun.warnings}


def dumps(doc) -> str:
    buf = io.StringIO()
    json.dump(doc, buf, indent=1, default=float)
    return buf.getvalue()
