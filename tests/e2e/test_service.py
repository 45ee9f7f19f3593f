"""The whole service as users run it: real API and worker processes, real HTTP, both backends."""
from __future__ import annotations

import csv
import io
import json
import threading

import httpx
import pytest

from gnssatt.sim.sample_set import write_sample_set
from tests.e2e.conftest import wait_for

pytestmark = pytest.mark.e2e
TERMINAL = ("succeeded", "failed", "cancelled")


def _upload(client: httpx.Client, paths) -> dict:
    files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]
    resp = client.post("/v1/observation-sets", files=files)
    assert resp.status_code == 201, resp.text
    return resp.json()


def _wait_job(client, job_id, timeout_s=180.0, states=TERMINAL) -> dict:
    """The job row once in `states`; the limit only ends a wait for a job that will never get there (these
    jobs take seconds idle, but the worker start and first job took > 60 s at a load of 6-13)."""
    return wait_for(lambda: (j := client.get(f"/v1/jobs/{job_id}").json())["state"] in states and j,
                    timeout_s, what=f"job {job_id} in {states}")


def test_upload_inspect_products(service, tmp_path):
    service.start_api()
    service.start_worker()
    key = service.create_key("ops")
    with service.client(key) as c:
        obs_set = _upload(c, write_sample_set(tmp_path / "set", n_epochs=40))
        resp = c.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [obs_set["id"]]})
        assert resp.status_code == 202
        job = _wait_job(c, resp.json()["id"])
        assert job["state"] == "succeeded", (job, service.logs_text())
        products = {p["name"]: p for p in c.get(f"/v1/jobs/{job['id']}/products").json()}
        assert set(products) == {"summary.json", "observations.csv", "tracking.csv", "tracking.png", "cn0.png"}
        assert products["tracking.png"]["media_type"] == "image/png" and products["tracking.png"]["size_bytes"] > 1000
        rows = list(csv.DictReader(io.StringIO(c.get(products["observations.csv"]["url"]).text)))
        # 3 receivers x 4 satellites x 2 signals (1C, 2W), every epoch observed
        assert len(rows) == 24 and {r["epochs"] for r in rows} == {"40"}
        lol = {(r["receiver"], r["satellite"], r["signal"]): int(r["loss_of_lock"]) for r in rows}
        assert lol[("GPS-0", "G01", "1C")] == 3  # builder sets LLI on L1C every 10th epoch (10, 20, 30)
        summary = c.get(f"/v1/jobs/{job['id']}/products/summary.json").json()
        assert [f["n_epochs"] for f in summary["files"] if f["kind"] == "rinex_obs"] == [40, 40, 40]


def test_restart_keeps_everything(service, tmp_path):
    service.start_api()
    service.start_worker()
    key = service.create_key("ops")
    with service.client(key) as c:
        obs_set = _upload(c, write_sample_set(tmp_path / "set"))
        job = c.post("/v1/jobs", json={"type": "selftest", "observation_set_ids": [obs_set["id"]],
                                       "config": {"duration_s": 0.3}}).json()
        job = _wait_job(c, job["id"])
        assert job["state"] == "succeeded"
        before = c.get(f"/v1/jobs/{job['id']}/products/selftest.json").content
    service.stop_api()
    for w in list(service.workers):
        service.kill_worker(w)
    service.start_api()
    service.start_worker()
    with service.client(key) as c:
        assert c.get(f"/v1/observation-sets/{obs_set['id']}").json()["files"] == obs_set["files"]
        assert c.get(f"/v1/jobs/{job['id']}").json()["state"] == "succeeded"
        assert c.get(f"/v1/jobs/{job['id']}/products/selftest.json").content == before
        # and the restarted worker takes new work
        job2 = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()
        assert _wait_job(c, job2["id"])["state"] == "succeeded"


def test_job_queued_while_no_worker_runs_later(service):
    service.start_api()
    key = service.create_key("ops")
    with service.client(key) as c:
        job = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()
        assert c.get(f"/v1/jobs/{job['id']}").json()["state"] == "queued"
        service.stop_api()
        service.start_api()
        service.start_worker()
        assert _wait_job(c, job["id"])["state"] == "succeeded"


def test_kill9_worker_mid_job_reruns_exactly_once(service):
    service.start_api()
    worker = service.start_worker()
    key = service.create_key("ops")
    with service.client(key) as c:
        job = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 4}}).json()
        wait_for(lambda: (j := c.get(f"/v1/jobs/{job['id']}").json())["state"] == "running"
                 and j["progress"] > 0.2, 30, what="job running")
        service.kill_worker(worker)  # SIGKILL: no clean-up, lease left behind
        assert c.get(f"/v1/jobs/{job['id']}").json()["state"] == "running"
        service.start_worker()
        done = _wait_job(c, job["id"], timeout_s=60)
        assert done["state"] == "succeeded" and done["attempts"] == 2, (done, service.logs_text())
        products = c.get(f"/v1/jobs/{job['id']}/products").json()
        assert sorted(p["name"] for p in products) == ["early.json", "selftest.json"]
        assert c.get(f"/v1/jobs/{job['id']}/products/early.json").json()["attempt"] == 2
        assert c.get(f"/v1/jobs/{job['id']}/products/selftest.json").json()["attempt"] == 2


def test_cancel_running_job_stops_within_seconds(service):
    service.start_api()
    service.start_worker()
    key = service.create_key("ops")
    with service.client(key) as c:
        job = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 60}}).json()
        wait_for(lambda: c.get(f"/v1/jobs/{job['id']}").json()["state"] == "running", 30, what="running")
        import time
        t0 = time.monotonic()
        assert c.post(f"/v1/jobs/{job['id']}/cancel").status_code == 200
        done = _wait_job(c, job["id"], timeout_s=10)
        assert done["state"] == "cancelled" and time.monotonic() - t0 < 5.0
        assert c.get(f"/v1/jobs/{job['id']}/products").json() == []
        # the worker is free again
        job2 = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()
        assert _wait_job(c, job2["id"])["state"] == "succeeded"


def test_sse_delivers_progress(service):
    service.start_api()
    service.start_worker()
    key = service.create_key("ops")
    with service.client(key) as c:
        job = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 2.5}}).json()
        events = []
        with c.stream("GET", f"/v1/jobs/{job['id']}/events", timeout=60) as resp:
            assert resp.status_code == 200 and resp.headers["content-type"].startswith("text/event-stream")
            name = None
            for line in resp.iter_lines():
                if line.startswith("event:"):
                    name = line[6:].strip()
                elif line.startswith("data:"):
                    events.append((name, json.loads(line[5:])))
                    if name == "end":
                        break
        progress = [d["progress"] for n, d in events if n == "progress"]
        assert events[-1][0] == "end" and events[-1][1]["state"] == "succeeded"
        assert len({p for p in progress if 0 < p < 1}) >= 3, progress
        assert progress == sorted(progress)


def test_teams_and_pagination_over_http(service, tmp_path):
    service.start_api()
    service.start_worker()
    key_a, key_b = service.create_key("team-a"), service.create_key("team-b")
    paths = write_sample_set(tmp_path / "set", n_epochs=5)
    with service.client(key_a) as a, service.client(key_b) as b:
        ids = [_upload(a, paths)["id"] for _ in range(3)]
        page = a.get("/v1/observation-sets", params={"limit": 2}).json()
        assert page["total"] == 3 and page["next_offset"] == 2
        assert len(a.get("/v1/observation-sets", params={"limit": 2, "offset": 2}).json()["items"]) == 1
        assert b.get("/v1/observation-sets").json()["total"] == 0
        assert b.get(f"/v1/observation-sets/{ids[0]}").status_code == 404
        job = a.post("/v1/jobs", json={"type": "selftest", "observation_set_ids": ids[:1],
                                       "config": {"duration_s": 0}}).json()
        assert b.get(f"/v1/jobs/{job['id']}").status_code == 404
        assert b.get(f"/v1/jobs/{job['id']}/products").status_code == 404


def test_processes_starting_at_once_share_one_migrated_database(service):
    """API and three workers start together on an empty database: migrations must not collide."""
    service.start_api(wait=False)
    for _ in range(3):
        service.start_worker()
    service.wait_ready()
    key = service.create_key("ops")
    with service.client(key) as c:
        jobs = [c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0.5}}).json()
                for _ in range(6)]
        for job in jobs:
            done = _wait_job(c, job["id"])
            assert done["state"] == "succeeded" and done["attempts"] == 1
    assert all(w.poll() is None for w in service.workers), service.logs_text()


def test_fan_out_spreads_over_workers_and_survives_a_killed_one(service):
    service.start_api()
    first, second = service.start_worker(), service.start_worker()
    key = service.create_key("ops")
    for proc in (first, second):  # both consuming before the job, or one may take every task
        service.wait_worker_ready(proc)
    with service.client(key) as c:
        job = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "fan_out": 12,
                                                                      "task_seconds": 0.6}}).json()
        wait_for(lambda: c.get(f"/v1/jobs/{job['id']}").json()["progress"] > 0.6, 60, what="fan-out under way")
        service.kill_worker(first)  # whatever it held (the parent or a task) comes back after its lease
        service.start_worker()
        done = _wait_job(c, job["id"], timeout_s=90)
        assert done["state"] == "succeeded", (done, service.logs_text())
        tasks = c.get(f"/v1/jobs/{job['id']}/products/selftest.json").json()["tasks"]
        assert [t["square"] for t in tasks] == [n * n for n in range(12)]
        assert len({t["worker"] for t in tasks}) >= 2, tasks  # the work was shared


def test_cli_submit_status_fetch_and_revoke(service, tmp_path):
    import subprocess
    import sys
    service.start_api()
    service.start_worker()
    key = service.create_key("cli")
    env = dict(service.env, GNSSATT_URL=service.url, GNSSATT_API_KEY=key)
    paths = [str(p) for p in write_sample_set(tmp_path / "set", n_epochs=10)]

    def cli(*args):
        return subprocess.run([sys.executable, "-m", "client.cli", *args], env=env, capture_output=True, text=True,
                              timeout=120, cwd=str(tmp_path))

    out = cli("submit", "--type", "inspect", "--out", str(tmp_path / "products"), *paths)
    assert out.returncode == 0, out.stderr
    assert sorted(p.name for p in (tmp_path / "products").iterdir()) == [
        "cn0.png", "observations.csv", "summary.json", "tracking.csv", "tracking.png"]
    assert "100.0%" in out.stderr  # the progress bar reached the end
    job_id = out.stderr.split("job ")[1].split()[0]
    status = cli("status")
    assert status.returncode == 0 and job_id in status.stdout and "succeeded" in status.stdout
    fetched = cli("fetch", job_id, "--out", str(tmp_path / "again"))
    assert fetched.returncode == 0 and (tmp_path / "again" / "summary.json").is_file()
    bad = cli("submit", "--type", "inspect", str(tmp_path / "set" / "platform.json"))
    assert bad.returncode == 1 and "422" in bad.stderr and "observation file" in bad.stderr
    revoked = cli("admin", "revoke-key", key)
    assert revoked.returncode == 0 and "revoked 1" in revoked.stdout
    assert cli("status").returncode == 1
