"""Job type `plan` end to end on a TLE, Keplerian elements and a ground position, and its input errors."""
from __future__ import annotations

import csv
import hashlib
import io
import json

import pytest

from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.plan import PlanConfig, run
from worker.jobs.registry import get_job_type

PLATFORM = {"name": "CASSIOPE-like", "kind": "spacecraft",
            "antennas": {"GPS-2": {"position_m": [0, 0, 0], "boresight": [0, 0, -1]},
                         "GPS-0": {"position_m": [1.04653, -0.07191, 0], "boresight": [0, 0, -1]},
                         "GPS-1": {"position_m": [0, 1.13969, 0], "boresight": [0, 0, -1]}},
            "master": "GPS-2"}
TLE = ["1 25544U 98067A   18157.51782528  .00001264  00000-0  26430-4 0  9991",
       "2 25544  51.6415 119.9622 0003872 213.0498 266.0397 15.54055584117052"]


def _ctx(tmp_path):
    def store(path):
        data = path.read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)
    ctx = JobContext(job_id="job-1", attempt=1, sets=[], workdir=tmp_path, _store_blob=store)
    ctx._flush_progress = lambda f, stage: None
    return ctx


def _run(tmp_path, **cfg):
    ctx = _ctx(tmp_path)
    run(ctx, PlanConfig(start="2018-06-06T12:20:00", duration_s=1800, step_s=60, platform=PLATFORM, **cfg))
    rows = list(csv.DictReader(io.StringIO(ctx.product_path("plan.csv").read_text())))
    return rows, json.loads(ctx.product_path("summary.json").read_text())


@pytest.mark.parametrize("orbit", [
    {"kind": "tle", "tle": TLE},
    {"kind": "keplerian", "keplerian": {"epoch": "2018-06-06T12:00:00", "a_m": 7014.3e3, "i_deg": 98.0}},
])
def test_plan_over_an_orbit(tmp_path, orbit):
    rows, summary = _run(tmp_path, orbit=orbit)
    assert len(rows) == 31 and summary["n_epochs"] == 31
    # zenith antennas in LEO with a 31-satellite GPS: 8-14 in common view; ~1 m baselines and 3 mm: ~0.1-0.3 deg
    assert 6 <= summary["n_sats"]["mean"] <= 16
    assert 0.02 < summary["sigma_deg"]["pitch"]["mean"] < 0.5
    assert summary["fraction_with_attitude"] == 1.0
    # the filter averages epochs: its steady-state sigma is below the snapshot's
    assert summary["filter_sigma_deg"]["pitch"]["mean"] < summary["sigma_deg"]["pitch"]["mean"]
    assert set(rows[0]) >= {"time_gps", "n_sats", "hdop", "vdop", "adop", "sigma_yaw_deg",
                            "GPS-2>GPS-0_sigma_h_mm", "GPS-2>GPS-1_crlb_deg"}
    assert get_job_type("plan").pipeline == "worker.jobs.plan:run"


def test_plan_on_the_ground_and_bad_inputs(tmp_path):
    rows, summary = _run(tmp_path, orbit={"kind": "ground", "ground": {"lat_deg": 47.0, "lon_deg": 7.0}})
    assert summary["settings"]["reference"] == "ned" and summary["settings"]["horizon_mask_deg"] == 10.0
    with pytest.raises(JobInputError, match="config.start"):
        run(_ctx(tmp_path), PlanConfig(start="June", orbit={"kind": "tle", "tle": TLE}, platform=PLATFORM))
    with pytest.raises(JobInputError, match="platform"):
        run(_ctx(tmp_path), PlanConfig(start="2018-06-06T12:20:00", orbit={"kind": "tle", "tle": TLE}))
    with pytest.raises(ValueError, match="needs orbit.keplerian"):
        PlanConfig(start="2018-06-06T12:20:00", orbit={"kind": "keplerian"})


def test_plan_from_a_sets_sp3_nav_and_platform(tmp_path):
    from gnssatt.gnss.io.sp3 import read_sp3
    from gnssatt.sim.api import simulate_set
    from worker.context import InputFile, InputSet

    s = simulate_set("cubesat", tmp_path / "sim", seed=1, duration_s=300.0, interval_s=10.0)
    ctx = _ctx(tmp_path)
    ctx.sets.append(InputSet("set", "sim", [InputFile("platform.sp3", "sp3", s.platform_sp3, {}),
                                            InputFile("brdc.rnx", "rinex_nav", s.nav, {}),
                                            InputFile("platform.json", "platform", s.platform, {})], {}))
    sat = read_sp3(s.platform_sp3).sats[0]
    run(ctx, PlanConfig(start="2018-06-06T12:20:00", duration_s=290, step_s=10,
                        orbit={"kind": "sp3", "sp3_satellite": sat}, max_sats=12))
    summary = json.loads(ctx.product_path("summary.json").read_text())
    assert any("broadcast ephemerides of brdc.rnx" in n for n in summary["notes"])
    assert summary["platform"] == "CubeSat-10cm" and summary["n_epochs"] == 30
    # 10 cm baselines, 3 mm: seed 001's eq. 5-6 regime, the snapshot sigma of the order of 2-3 deg (eq. 6: 1.7 deg
    # for ADOP 1 and 3 mm over 10 cm); with 12 channels all epochs have an attitude
    assert 0.5 < summary["sigma_deg"]["pitch"]["mean"] < 5.0 and summary["fraction_with_attitude"] == 1.0
    assert summary["n_sats"]["max"] <= 12


def test_plan_along_a_ground_trajectory(tmp_path):
    import numpy as np

    from gnssatt.gnss.time import GpsTime
    from gnssatt.sim.inertial import SensorLogs, airborne_truth, write_sensor_csvs
    from worker.context import InputFile, InputSet

    truth = airborne_truth(GpsTime.from_iso("2018-06-06T12:20:00"), truth_rate_hz=10.0)
    i = np.arange(0, len(truth.r_ecef_m), 10)
    logs = SensorLogs(truth.time[i], np.zeros((len(i), 3)) + 9.8, truth.time[i], np.zeros((len(i), 3)) + 4e4,
                      truth.time[i], truth.r_ecef_m[i], truth.v_ecef_m_s[i], i)
    paths = write_sensor_csvs(logs, tmp_path / "traj")
    ctx = _ctx(tmp_path)
    ctx.sets.append(InputSet("set", "t", [InputFile("velocity.csv", "csv", paths["velocity"], {})], {}))
    run(ctx, PlanConfig(start="2018-06-06T12:21:00", duration_s=600, step_s=60, platform=PLATFORM,
                        orbit={"kind": "trajectory"}, attitude={"reference": "ned"}))
    summary = json.loads(ctx.product_path("summary.json").read_text())
    assert summary["n_epochs"] == 11 and summary["settings"]["horizon_mask_deg"] == 10.0
    late = _ctx(tmp_path)
    late.sets.extend(ctx.sets)
    with pytest.raises(JobInputError, match="inside"):      # the trajectory ends at 12:39
        run(late, PlanConfig(start="2018-06-06T13:00:00", duration_s=600, step_s=60, platform=PLATFORM,
                             orbit={"kind": "trajectory"}))
