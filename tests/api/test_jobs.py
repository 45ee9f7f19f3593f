"""Jobs in process (Huey immediate mode): submit, validate, run, products, retries, cancel, isolation."""
from __future__ import annotations

from tests.api.test_observation_sets import _files, sample_items


def _set(api) -> str:
    return api.post("/v1/observation-sets", files=_files(*sample_items())).json()["id"]


def test_job_types_list_config_schemas(api):
    types = {t["name"]: t for t in api.get("/v1/job-types").json()}
    assert {"inspect", "selftest"} <= set(types)
    assert types["inspect"]["config_schema"]["properties"]["gap_factor"]["exclusiveMinimum"] == 1.0


def test_selftest_job_runs_and_publishes_products(api):
    set_id = _set(api)
    resp = api.post("/v1/jobs", json={"type": "selftest", "observation_set_ids": [set_id],
                                      "config": {"duration_s": 0.2}})
    assert resp.status_code == 202, resp.text
    job_id = resp.json()["id"]
    assert resp.headers["location"] == f"/v1/jobs/{job_id}"
    job = api.get(f"/v1/jobs/{job_id}").json()
    assert job["state"] == "succeeded" and job["progress"] == 1.0 and job["attempts"] == 1
    assert job["started_at"] and job["finished_at"] and job["observation_set_ids"] == [set_id]
    products = {p["name"]: p for p in api.get(f"/v1/jobs/{job_id}/products").json()}
    assert set(products) == {"early.json", "selftest.json"}
    dl = api.get(f"/v1/jobs/{job_id}/products/selftest.json")
    assert dl.status_code == 200 and dl.headers["content-type"] == "application/json"
    assert 'filename="selftest.json"' in dl.headers["content-disposition"]
    assert dl.json()["attempt"] == 1 and dl.json()["observation_sets"][0]["id"] == set_id
    assert api.get(f"/v1/jobs/{job_id}/products/nope.csv").status_code == 404


def test_unknown_type_and_bad_config_are_422_naming_the_field(api):
    resp = api.post("/v1/jobs", json={"type": "no-such-type", "observation_set_ids": []})
    assert resp.status_code == 422 and resp.json()["field"] == "type"
    assert "inspect" in resp.json()["detail"]
    resp = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": -1}})
    assert resp.status_code == 422 and resp.json()["field"] == "config.duration_s"
    resp = api.post("/v1/jobs", json={"type": "selftest", "config": {"bogus": 1}})
    assert resp.status_code == 422 and resp.json()["field"] == "config.bogus"
    resp = api.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": []})
    assert resp.status_code == 422 and resp.json()["field"] == "observation_set_ids"
    resp = api.post("/v1/jobs", json={"type": "inspect"}, headers={"content-type": "application/json"})
    assert resp.status_code == 422
    resp = api.post("/v1/jobs", content=b"{not json", headers={"content-type": "application/json"})
    assert resp.status_code == 422 and resp.headers["content-type"].startswith("application/problem+json")


def test_retries_then_success_keeps_only_the_last_attempts_products(api):
    resp = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "fail_attempts": 2}})
    job_id = resp.json()["id"]
    # Immediate mode runs the retries as they are scheduled; drive the queue until the job settles.
    import time
    from worker.runner import execute_job
    for _ in range(3):
        if api.get(f"/v1/jobs/{job_id}").json()["state"] == "queued":
            execute_job(api.rt, job_id)
        time.sleep(0.01)
    job = api.get(f"/v1/jobs/{job_id}").json()
    assert job["state"] == "succeeded" and job["attempts"] == 3, job
    early = api.get(f"/v1/jobs/{job_id}/products/early.json").json()
    assert early["attempt"] == 3


def test_fails_after_max_attempts_with_problem_document(api):
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "fail_attempts": 99}}).json()["id"]
    from worker.runner import execute_job
    for _ in range(5):
        execute_job(api.rt, job_id)
    job = api.get(f"/v1/jobs/{job_id}").json()
    assert job["state"] == "failed" and job["attempts"] == 3
    assert job["error"]["status"] == 500 and "fails on purpose" in job["error"]["detail"]
    assert api.get(f"/v1/jobs/{job_id}/products").json() == []


def test_input_error_is_not_retried(api):
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"fail_attempts": 5,
                                                                       "fail_as_input_error": True}}).json()["id"]
    job = api.get(f"/v1/jobs/{job_id}").json()
    assert job["state"] == "failed" and job["attempts"] == 1
    assert job["error"]["field"] == "config.fail_attempts" and job["error"]["status"] == 422


def test_cancel_queued_job_and_refuse_finished(api):
    from core.models import Job
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    assert api.post(f"/v1/jobs/{job_id}/cancel").status_code == 409  # already succeeded
    with api.rt.Session.begin() as s:  # a job no worker has reached yet
        job = Job(team_id=s.get(Job, job_id).team_id, type="selftest", config={}, set_ids=[], state="queued")
        s.add(job)
        s.flush()
        queued_id = job.id
    resp = api.post(f"/v1/jobs/{queued_id}/cancel")
    assert resp.status_code == 200 and resp.json()["state"] == "cancelled"
    from worker.runner import execute_job
    assert execute_job(api.rt, queued_id) is None  # a late queue message does nothing


def test_set_in_use_cannot_be_deleted(api):
    from core.models import Job, JobSet
    set_id = _set(api)
    with api.rt.Session.begin() as s:
        team_id = s.execute(__import__("sqlalchemy").text("select team_id from observation_sets")).scalar()
        job = Job(team_id=team_id, type="selftest", config={}, set_ids=[set_id], state="running")
        job.sets = [JobSet(set_id=set_id, position=0)]
        s.add(job)
    resp = api.delete(f"/v1/observation-sets/{set_id}")
    assert resp.status_code == 409 and resp.json()["job_id"]


def test_job_list_filters_and_isolation(api, other_key):
    for d in (0, 0, 0):
        api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": d}})
    api.post("/v1/jobs", json={"type": "selftest", "config": {"fail_attempts": 1, "fail_as_input_error": True}})
    assert api.get("/v1/jobs", params={"state": "succeeded"}).json()["total"] == 3
    assert api.get("/v1/jobs", params={"state": "failed"}).json()["total"] == 1
    assert api.get("/v1/jobs", params={"type": "inspect"}).json()["total"] == 0
    page = api.get("/v1/jobs", params={"limit": 3}).json()
    assert page["total"] == 4 and page["next_offset"] == 3
    assert api.get("/v1/jobs", params={"state": "bogus"}).status_code == 422
    other = {"Authorization": f"Bearer {other_key}"}
    assert api.get("/v1/jobs", headers=other).json()["total"] == 0
    job_id = page["items"][0]["id"]
    for path in (f"/v1/jobs/{job_id}", f"/v1/jobs/{job_id}/products", f"/v1/jobs/{job_id}/events"):
        assert api.get(path, headers=other).status_code == 404
    assert api.post(f"/v1/jobs/{job_id}/cancel", headers=other).status_code == 404


def test_health(api):
    assert api.get("/healthz").json() == {"status": "ok", "database": None, "queue": None}
    assert api.get("/readyz").json()["status"] == "ok"


def test_simulate_job_writes_a_set_that_uploads_back(api):
    import io
    import zipfile
    resp = api.post("/v1/jobs", json={"type": "simulate", "config": {"scenario": "earth-pointing", "seed": 3,
                                                                      "overrides": {"duration_s": 60}}})
    assert resp.status_code == 202, resp.text
    job = api.get(f"/v1/jobs/{resp.json()['id']}").json()
    assert job["state"] == "succeeded", job
    bundle = api.get(f"/v1/jobs/{job['id']}/products/simulated_set.zip")
    assert bundle.headers["content-type"] == "application/zip"
    names = zipfile.ZipFile(io.BytesIO(bundle.content)).namelist()
    assert {"obs/GPS-2.rnx", "obs/GPS-0.rnx", "obs/GPS-1.rnx", "nav/brdc.rnx", "platform.json",
            "truth/attitude.csv"} <= set(names)
    # the simulated set is a valid observation set (without its truth folder)
    buf = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(bundle.content)) as src, zipfile.ZipFile(buf, "w") as dst:
        for n in src.namelist():
            if not n.startswith("truth/"):
                dst.writestr(n, src.read(n))
    up = api.post("/v1/observation-sets", files=[("files", ("sim.zip", buf.getvalue(), "application/zip"))])
    assert up.status_code == 201, up.text
    assert up.json()["summary"]["antennas"] == {"GPS-2": "obs/GPS-2.rnx", "GPS-0": "obs/GPS-0.rnx",
                                               "GPS-1": "obs/GPS-1.rnx"}


def test_simulate_job_refuses_unknown_scenario_and_override(api):
    resp = api.post("/v1/jobs", json={"type": "simulate", "config": {"scenario": "moon-landing"}})
    assert resp.status_code == 422 and resp.json()["field"] == "config.scenario"
    job_id = api.post("/v1/jobs", json={"type": "simulate", "config": {"overrides": {"no_such_knob": 1}}}).json()["id"]
    job = api.get(f"/v1/jobs/{job_id}").json()
    assert job["state"] == "failed" and job["attempts"] == 1 and "no_such_knob" in job["error"]["detail"]


def test_fan_out_runs_every_task_once_on_a_single_worker(api):
    """Immediate mode, one process: the parent job runs its own tasks while it waits (no deadlock)."""
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "fan_out": 5,
                                                                       "task_seconds": 0}}).json()["id"]
    job = api.get(f"/v1/jobs/{job_id}").json()
    assert job["state"] == "succeeded", job
    tasks = api.get(f"/v1/jobs/{job_id}/products/selftest.json").json()["tasks"]
    assert [t["square"] for t in tasks] == [0, 1, 4, 9, 16]


def test_lost_queue_message_is_rerung_by_the_reaper(api, monkeypatch):
    """The queue is only a doorbell: a job whose message never arrived still runs."""
    import app.routes.jobs as jobs_routes
    from worker import runner

    def down(*a, **k):
        raise ConnectionError("queue unreachable")

    monkeypatch.setattr(jobs_routes, "enqueue", down)
    resp = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}})
    assert resp.status_code == 202
    job_id = resp.json()["id"]
    assert api.get(f"/v1/jobs/{job_id}").json()["state"] == "queued"
    monkeypatch.undo()
    api.rt.settings.requeue_after_seconds = 0.01
    import time
    time.sleep(0.05)
    counts = runner.reap(api.rt)  # immediate mode: re-ringing runs the job
    assert counts["rerung"] == 1
    assert api.get(f"/v1/jobs/{job_id}").json()["state"] == "succeeded"


def test_reaper_leaves_a_reclaimed_job_alone(api):
    """A job whose dead worker's lease was taken over by a live claim is not requeued again."""
    from datetime import timedelta

    from sqlalchemy import update

    from core.models import Job, utcnow
    from worker import runner

    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    with api.rt.Session.begin() as s:  # pretend a worker died holding it
        s.execute(update(Job).where(Job.id == job_id).values(
            state="running", lease_owner="dead/1", lease_expires_at=utcnow() - timedelta(seconds=5)))
    # another worker's reaper requeued it and a worker claimed it again, with a fresh lease
    with api.rt.Session.begin() as s:
        s.execute(update(Job).where(Job.id == job_id).values(
            state="running", lease_owner="alive/2", lease_expires_at=utcnow() + timedelta(seconds=60)))
    counts = runner.reap(api.rt)
    assert counts["requeued"] == 0
    with api.rt.Session() as s:
        job = s.get(Job, job_id)
        assert job.state == "running" and job.lease_owner == "alive/2"


def test_successive_fan_outs_of_one_job_never_mix(api):
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {
        "duration_s": 0, "fan_out": 4, "fan_out_passes": 3, "task_seconds": 0}}).json()["id"]
    assert api.get(f"/v1/jobs/{job_id}").json()["state"] == "succeeded"
    passes = api.get(f"/v1/jobs/{job_id}/products/selftest.json").json()["passes"]
    assert [[t["power"] for t in p] for p in passes] == [[n ** k for n in range(4)] for k in (2, 3, 4)]


def test_attitude_job_with_unknown_pcv_map_is_422_at_submit(api):
    """A map id that is not the team's is refused when the job is submitted (field names the list entry), a known
    one is accepted; nothing is queued for the refused job."""
    from tests.gnss.test_pcv_map import make_map

    set_id = _set(api)
    known = api.post("/v1/pcv-maps", json={"name": "m", "map": make_map(seed=2).to_json()}).json()["id"]
    before = api.get("/v1/jobs").json()["total"]
    resp = api.post("/v1/jobs", json={"type": "attitude", "observation_set_ids": [set_id],
                                      "config": {"pcv_map_ids": [known, "f" * 32]}})
    assert resp.status_code == 422, resp.text
    doc = resp.json()
    assert doc["field"] == "config.pcv_map_ids.1" and "f" * 32 in doc["detail"]
    assert api.get("/v1/jobs").json()["total"] == before
    resp = api.post("/v1/jobs", json={"type": "attitude", "observation_set_ids": [set_id],
                                      "config": {"pcv_map_ids": [known]}})
    # the known map passes; the sample set has no navigation file, which is refused next (app/preflight.py)
    assert resp.status_code == 422 and resp.json()["type"].endswith("missing-navigation"), resp.text
    assert api.get("/v1/jobs").json()["total"] == before
