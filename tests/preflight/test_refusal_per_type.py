"""Early refusal for the job types beyond attitude and calibration: each required input missing answers 422
naming it, with nothing stored or queued (tests/preflight/conftest.py refused); the complete set is queued.
gyro-fusion: the gyro log (and its overlap with the observations), three antennas; single-antenna-attitude per
method: the sensor logs, a velocity, navigation, platform.json, a configured antenna; satellite-yaw /
satellite-baseline: orbits; plan: a platform with a baseline, the orbit kind's file; ttff: something to study."""
from __future__ import annotations

import json

import pytest

from tests.preflight.conftest import files_of, queued, refused, upload

NAV = "nav/brdc.rnx"


def sensor_csv(columns: tuple[str, str, str], value: tuple[float, float, float], day: str = "2018-06-06") -> bytes:
    """A 1 Hz sensor log of constant `value` over 12:19:50-12:22:30 GPS of `day` (the simulated set starts at
    2018-06-06 12:20:05 and lasts 120 s)."""
    rows = [f"time_gps,{','.join(columns)}"]
    for k in range(161):
        m, s = divmod(19 * 60 + 50 + k, 60)
        rows.append(f"{day}T12:{m:02d}:{s:02d}.000,{value[0]},{value[1]},{value[2]}")
    return ("\n".join(rows) + "\n").encode()


GYRO = sensor_csv(("wx_rad_s", "wy_rad_s", "wz_rad_s"), (1e-4, -1.1e-3, 2e-5))
ACC = sensor_csv(("ax_m_s2", "ay_m_s2", "az_m_s2"), (0.01, 0.02, 0.03))
MAG = sensor_csv(("bx_nT", "by_nT", "bz_nT"), (20000.0, -3000.0, 35000.0))


def test_gyro_fusion_needs_a_gyro_log(api, sim):
    doc = refused(api, upload(api, files_of(sim)), "gyro-fusion")
    assert doc["type"].endswith("missing-gyro-log") and "gyro log" in doc["detail"]
    assert "wx_rad_s" in doc["detail"] and "gyro_csv.md" in doc["detail"]
    queued(api, upload(api, files_of(sim, add={"gyro.csv": GYRO})), "gyro-fusion")


def test_gyro_fusion_needs_the_gyro_log_over_the_observations(api, sim):
    late = sensor_csv(("wx_rad_s", "wy_rad_s", "wz_rad_s"), (1e-4, -1.1e-3, 2e-5), day="2018-06-07")
    doc = refused(api, upload(api, files_of(sim, add={"gyro.csv": late})), "gyro-fusion")
    assert doc["type"].endswith("no-common-epochs") and doc["file"] == "gyro.csv"
    assert "2018-06-07" in doc["detail"] and "2018-06-06" in doc["detail"]


def test_gyro_fusion_needs_three_antennas(api, sim):
    plat = json.loads((sim / "platform.json").read_text())
    plat["antennas"].pop("GPS-1")
    plat["baselines"] = [["GPS-2", "GPS-0"]]
    plat["observation_files"].pop("GPS-1")
    files = files_of(sim, replace={"platform.json": json.dumps(plat).encode()}, add={"gyro.csv": GYRO})
    set_id = upload(api, files)
    doc = refused(api, set_id, "gyro-fusion")
    assert doc["type"].endswith("too-few-antennas") and "at least 3 antennas (2 baselines)" in doc["detail"]
    queued(api, set_id, "attitude")          # the same set is fine for one baseline


@pytest.mark.parametrize("missing", ["accelerometer", "magnetometer"])
def test_acceleration_magnetometer_needs_both_logs(api, sim, missing):
    logs = {"accelerometer.csv": ACC, "magnetometer.csv": MAG}
    logs.pop(f"{missing}.csv")
    cfg = {"method": "acceleration-magnetometer"}
    doc = refused(api, upload(api, files_of(sim, add=logs)), "single-antenna-attitude", cfg)
    assert doc["type"].endswith(f"missing-{missing}-log") and f"{missing}.csv" in doc["detail"]
    assert "method acceleration-magnetometer" in doc["detail"]


def test_acceleration_magnetometer_needs_a_velocity(api, sim):
    cfg = {"method": "acceleration-magnetometer"}
    logs = {"accelerometer.csv": ACC, "magnetometer.csv": MAG}
    doc = refused(api, upload(api, files_of(sim, drop={NAV}, add=logs)), "single-antenna-attitude", cfg)
    assert doc["type"].endswith("missing-velocity") and "velocity.csv" in doc["detail"]
    queued(api, upload(api, files_of(sim, add=logs)), "single-antenna-attitude", cfg)


@pytest.mark.parametrize("method", ["cn0-boresight", "vector-phase"])
def test_single_antenna_phase_and_cn0_methods_need_a_navigation_file(api, sim, method):
    doc = refused(api, upload(api, files_of(sim, drop={NAV})), "single-antenna-attitude", {"method": method})
    assert doc["type"].endswith("missing-navigation") and "RINEX navigation" in doc["detail"]
    assert f"method {method}" in doc["detail"]


def test_vector_phase_needs_a_platform_and_a_known_antenna(api, sim):
    doc = refused(api, upload(api, files_of(sim, drop={"platform.json"})), "single-antenna-attitude",
                  {"method": "vector-phase"})
    assert doc["type"].endswith("missing-platform") and "platform.json" in doc["detail"]
    set_id = upload(api, files_of(sim))
    doc = refused(api, set_id, "single-antenna-attitude",
                  {"method": "vector-phase", "vector_phase": {"antenna_id": "GPS-9"}})
    assert doc["type"].endswith("unknown-antenna") and doc["field"] == "config.vector_phase.antenna_id"
    assert "GPS-9" in doc["detail"] and "GPS-2" in doc["detail"]


def test_cn0_boresight_runs_without_platform(api, sim):
    queued(api, upload(api, files_of(sim, drop={"platform.json"})), "single-antenna-attitude",
           {"method": "cn0-boresight"})


@pytest.mark.parametrize("job_type", ["satellite-yaw", "satellite-baseline"])
def test_satellite_jobs_need_orbits(api, sim, job_type):
    doc = refused(api, upload(api, files_of(sim, drop={NAV, "platform.json"})), job_type)
    assert doc["type"].endswith("missing-navigation") and "SP3" in doc["detail"]


PLAN = {"start": "2018-06-06T12:20:05", "duration_s": 60, "step_s": 10}


def test_plan_needs_a_platform(api, sim):
    cfg = {**PLAN, "orbit": {"kind": "ground", "ground": {"lat_deg": 50.0, "lon_deg": 10.0}}}
    doc = refused(api, None, "plan", cfg)
    assert doc["type"].endswith("missing-platform") and doc["field"] == "config.platform"
    one = {"name": "one", "kind": "terrestrial", "antennas": {"A": {"position_m": [0, 0, 0]}}}
    doc = refused(api, None, "plan", {**cfg, "platform": one})
    assert doc["type"].endswith("too-few-antennas") and "names 1" in doc["detail"]
    queued(api, None, "plan", {**cfg, "platform": json.loads((sim / "platform.json").read_text())})


@pytest.mark.parametrize("kind, named, extra", [("sp3", "an SP3 file", {"sp3_satellite": "L01"}),
                                                ("trajectory", "velocity.csv", {})])
def test_plan_needs_the_file_of_its_orbit_kind(api, sim, kind, named, extra):
    doc = refused(api, upload(api, files_of(sim, drop={"platform.sp3"})), "plan",
                  {**PLAN, "orbit": {"kind": kind, **extra}})
    assert doc["field"] == "config.orbit.kind" and named in doc["detail"] and f"orbit.kind {kind}" in doc["title"]


def test_ttff_needs_something_to_study(api, sim):
    doc = refused(api, None, "ttff")
    assert doc["type"].endswith("nothing-to-study") and "config.simulate" in doc["detail"]
    doc = refused(api, upload(api, files_of(sim, drop={NAV})), "ttff")
    assert doc["type"].endswith("missing-navigation")
