"""The job page charts the main series of the job types added after attitude, in the system Chromium against the
real service: a plan job's page draws satellites in view, DOPs and the expected sigmas; the chart definitions of
gyro-fusion (gps_attitude.csv, bias.csv, faults.csv) and satellite-yaw (yaw.csv) products are checked on
product-shaped CSVs through the page's own charts.js (GnssattCharts.chartsFor)."""
from __future__ import annotations

import json

import httpx
import pytest

from tests.e2e.conftest import wait_for
from tests.ui.conftest import sign_in

pytestmark = pytest.mark.e2e
PLATFORM = {"name": "roof", "kind": "terrestrial",
            "antennas": {"A": {"position_m": [0.0, 0.0, 0.0]}, "B": {"position_m": [1.0, 0.0, 0.0]},
                         "C": {"position_m": [0.0, 1.0, 0.0]}}}
PLAN = {"start": "2018-06-06T12:20:00", "duration_s": 1800, "step_s": 60, "platform": PLATFORM,
        "orbit": {"kind": "ground", "ground": {"lat_deg": 50.0, "lon_deg": 10.0, "h_m": 200.0}}}


@pytest.fixture(scope="module")
def plan_job(site):
    key = site.create_key("later-charts")
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {key}"}, timeout=120) as c:
        resp = c.post("/v1/jobs", json={"type": "plan", "config": PLAN})
        assert resp.status_code == 202, resp.text
        job_id = resp.json()["id"]
        wait_for(lambda: c.get(f"/v1/jobs/{job_id}").json()["state"] in ("succeeded", "failed"), 600,
                 what="plan job")
        job = c.get(f"/v1/jobs/{job_id}").json()
        assert job["state"] == "succeeded", job
    return {"key": key, "job_id": job_id}


def _titles(page) -> dict[str, list[str]]:
    return {c["title"]: c["labels"] for c in page.evaluate(
        "GnssattCharts.instances.map(c => ({title: c.title, labels: c.plot.series.slice(1).map(s => s.label)}))")}


def test_plan_job_page_charts(browser, site, plan_job):
    context, page = sign_in(browser, site, plan_job["key"])
    page.goto(f"/ui/jobs/{plan_job['job_id']}")
    page.wait_for_function("() => Number(document.getElementById('charts').dataset.ready || 0) > 0")
    charts = _titles(page)
    assert charts["Satellites in common view"] == ["satellites"]
    assert charts["Dilution of precision"] == ["HDOP", "VDOP", "PDOP", "ADOP"]
    assert charts["Expected 1σ, snapshot (all baselines) [deg]"] == ["σ yaw", "σ pitch", "σ roll"]
    assert page.evaluate("GnssattCharts.instances.every(c => c.plot.width > 200)")
    assert not page.console_errors, page.console_errors
    context.close()


def _defs(page, name: str, text: str) -> dict[str, dict]:
    got = page.evaluate("([n, t]) => GnssattCharts.chartsFor(n, t).map(d => ({title: d.title, n: d.x.length, "
                        "labels: d.series.map(s => s.label), first: d.series.map(s => s.values[0])}))", [name, text])
    return {d["title"]: d for d in got}


def test_gyro_fusion_and_satellite_yaw_chart_definitions(browser, site, plan_job):
    context, page = sign_in(browser, site, plan_job["key"])
    page.goto(f"/ui/jobs/{plan_job['job_id']}")
    page.wait_for_function("() => window.GnssattCharts !== undefined")
    t = ["2018-06-06T12:20:00.000", "2018-06-06T12:20:01.000"]
    bias = ("time_gps,gps_week,gps_sow,bias_x_rad_s,bias_y_rad_s,bias_z_rad_s,sigma_x_rad_s,sigma_y_rad_s,"
            "sigma_z_rad_s\n") + "".join(f"{x},2004,303600,4.8481368e-6,0,-4.8481368e-6,1e-7,1e-7,1e-7\n" for x in t)
    d = _defs(page, "bias.csv", bias)["Gyro bias estimate [deg/h]"]
    assert d["labels"] == ["bias x", "bias y", "bias z"] and d["n"] == 2
    assert abs(d["first"][0] - 1.0) < 1e-6 and abs(d["first"][2] + 1.0) < 1e-6     # 4.848e-6 rad/s = 1 deg/h
    faults = "time_gps,reference,excluded,J,dof,threshold\n" + "".join(f"{x},G01,,3.5,6,16.8\n" for x in t)
    d = _defs(page, "faults.csv", faults)["GPS fault test: cost J and its threshold"]
    assert d["labels"] == ["J", "threshold"] and d["first"] == [3.5, 16.8]
    yaw = ("time_gps,gps_week,gps_sow,satellite,yaw_deg,sigma_yaw_deg,model_yaw_deg,model,n_stations,observability,"
           "smoothed_yaw_deg,sigma_smoothed_deg,triple_yaw_deg,sigma_triple_deg\n"
           + "".join(f"{x},2004,303600,{s},{y},0.5,{y + 1},yaw-steering,3,1,,,,\n"
                     for x in t for s, y in (("J01", 10.0), ("J02", -20.0))))
    d = _defs(page, "yaw.csv", yaw)["Satellite yaw: estimate and attitude model [deg]"]
    assert d["labels"] == ["J01 estimate", "J02 estimate", "J01 model", "J02 model"] and d["n"] == 2
    assert d["first"] == [10.0, -20.0, 11.0, -19.0]
    gps_att = "time_gps,yaw_deg,pitch_deg,roll_deg\n" + "".join(f"{x},1,2,3\n" for x in t)
    assert _defs(page, "gps_attitude.csv", gps_att)["GPS snapshot Euler angles (3-2-1) [deg]"]["first"] == [1, 2, 3]
    context.close()
