"""single-antenna-attitude, method cn0-boresight, end to end on a simulated CubeSat set (RINEX C/N0 from the
simulator's known patch gain), boresight against the truth attitude."""
from __future__ import annotations

import csv
import hashlib
import io
import json

import numpy as np

from gnssatt.gnss.rotations import quat_to_dcm
from gnssatt.gnss.time import GpsTime
from gnssatt.sim.api import simulate_set
from worker.context import InputFile, InputSet, JobContext
from worker.jobs.single_antenna_attitude import SingleAntennaConfig, run

# the simulator's patch (gnssatt.sim.observables.gain_db, cubesat preset: 13 dB at the horizon, 0.6 dB/deg below)
THETA = list(np.arange(0.0, 181.0, 5.0))
GAIN = [-13.0 * (x / 90.0) ** 2 if x <= 90 else -13.0 - 0.6 * (x - 90.0) for x in THETA]


def test_cn0_boresight_job_on_a_simulated_cubesat(tmp_path):
    s = simulate_set("cubesat", tmp_path / "sim", seed=3, duration_s=600.0, interval_s=10.0)

    def store(path):
        data = path.read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)
    files = [InputFile(s.obs["ANT-A"].name, "rinex_obs", s.obs["ANT-A"], {}),
             InputFile(s.nav.name, "rinex_nav", s.nav, {}), InputFile("platform.json", "platform", s.platform, {})]
    ctx = JobContext(job_id="j", attempt=1, sets=[InputSet("set", "sim", files, {})], workdir=tmp_path,
                     _store_blob=store)
    ctx._flush_progress = lambda f, stage: None
    run(ctx, SingleAntennaConfig(method="cn0-boresight", cn0_boresight={"gain_pattern": {"theta_deg": THETA,
                                                                                         "gain_db": GAIN}}))
    rows = list(csv.DictReader(io.StringIO(ctx.product_path("boresight.csv").read_text())))
    summary = json.loads(ctx.product_path("summary.json").read_text())
    assert len(rows) >= 0.9 * summary["n_epochs"] and summary["n_epochs"] >= 55
    truth = {r["time_gps"][:19]: r for r in csv.DictReader(open(s.truth_dir / "attitude.csv"))}
    err = []
    for r in rows:
        tr = truth[r["time_gps"][:19]]
        R = quat_to_dcm(np.array([float(tr[k]) for k in ("qe_w", "qe_x", "qe_y", "qe_z")]))
        b_true = R.T @ np.array([0.0, 0.0, -1.0])
        b = np.array([float(r[k]) for k in ("bx_ecef", "by_ecef", "bz_ecef")])
        err.append(np.degrees(np.arccos(np.clip(b @ b_true, -1, 1))))
    err = np.array(err)
    # the simulator's C/N0 follow this very pattern, plus its noise and multipath: within the 3-15 deg of the
    # literature (seed 001) at the 95th percentile, a few degrees typically
    assert np.percentile(err, 95) < 15.0 and np.median(err) < 6.0
    assert "no magnetometer" in summary["full_attitude"]
    assert GpsTime.from_iso(rows[0]["time_gps"]).s > 0


def test_cn0_boresight_with_magnetometer_gives_full_attitude(tmp_path):
    from tests.conftest import require_module
    require_module("ppigrf", "IGRF-14 geomagnetic model")
    import datetime as dt

    from gnssatt.gnss.io.sp3 import read_sp3
    from gnssatt.gnss.rotations import attitude_error_deg
    from gnssatt.planning.trajectory import track_from_sp3
    from gnssatt.single_antenna.geomagnetic import field_ecef_nT

    s = simulate_set("cubesat", tmp_path / "sim", seed=4, duration_s=600.0, interval_s=10.0)
    truth = list(csv.DictReader(open(s.truth_dir / "attitude.csv")))
    t = GpsTime.concatenate([GpsTime.from_iso(r["time_gps"]) for r in truth])
    sp3 = read_sp3(s.platform_sp3)
    r = track_from_sp3(sp3, sp3.sats[0], t).r_ecef_m
    q = np.array([[float(x[k]) for k in ("qe_w", "qe_x", "qe_y", "qe_z")] for x in truth])
    b = np.einsum("nij,nj->ni", quat_to_dcm(q), field_ecef_nT(r, dt.datetime(2018, 6, 6)))
    b += np.random.default_rng(0).normal(0, 2.0, b.shape)
    mag = tmp_path / "magnetometer.csv"
    iso = t.iso()
    mag.write_text("time_gps,bx_nT,by_nT,bz_nT\n" + "".join(f"{iso[i]},{b[i, 0]:.1f},{b[i, 1]:.1f},{b[i, 2]:.1f}\n"
                                                              for i in range(len(t))))

    def store(path):
        data = path.read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)
    files = [InputFile(s.obs["ANT-A"].name, "rinex_obs", s.obs["ANT-A"], {}),
             InputFile(s.nav.name, "rinex_nav", s.nav, {}), InputFile("platform.json", "platform", s.platform, {}),
             InputFile("magnetometer.csv", "csv", mag, {})]
    ctx = JobContext(job_id="j", attempt=1, sets=[InputSet("set", "sim", files, {})], workdir=tmp_path,
                     _store_blob=store)
    ctx._flush_progress = lambda f, stage: None
    run(ctx, SingleAntennaConfig(method="cn0-boresight", cn0_boresight={"gain_pattern": {"theta_deg": THETA,
                                                                                         "gain_db": GAIN}}))
    rows = list(csv.DictReader(io.StringIO(ctx.product_path("attitude.csv").read_text())))
    # a sun-synchronous pass near the pole: the field is within 10 deg of the zenith boresight for the first
    # ~7 minutes (measured 1-10 deg here), so those epochs are flagged near-parallel and get no attitude
    b_ecef = field_ecef_nT(r, dt.datetime(2018, 6, 6))
    zen = np.degrees(np.arccos(np.abs(np.sum(b_ecef * r, 1)) / np.linalg.norm(b_ecef, axis=1) / np.linalg.norm(r, axis=1)))
    idx = {x: i for i, x in enumerate(iso)}
    got = np.array([idx[x["time_gps"]] for x in rows])
    assert len(rows) >= 10 and zen[got].min() > 8.0 and (zen < 8.0).sum() > 20
    by_time = {x["time_gps"][:19]: x for x in truth}
    q_est = np.array([[float(x[k]) for k in ("qe_w", "qe_x", "qe_y", "qe_z")] for x in rows])
    q_true = np.array([[float(by_time[x["time_gps"][:19]][k]) for k in ("qe_w", "qe_x", "qe_y", "qe_z")]
                       for x in rows])
    err = attitude_error_deg(q_est, q_true)
    # boresight error of a few degrees plus the field's direction (no model error simulated here): seed 001
    # cites 5-7 deg RMS for C/N0 + magnetometer; 12 deg at the 95th percentile
    assert np.percentile(err, 95) < 12.0, np.percentile(err, [50, 95])
