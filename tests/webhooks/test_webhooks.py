"""Issue 24: a job's webhook is sent an HMAC-signed POST when the job ends, retried with backoff while the
receiver fails, every attempt recorded and visible at GET /v1/jobs/{id}/webhook. The receiver is a real HTTP
server on 127.0.0.1 in this process; the job runs in the real worker code (immediate queue)."""
from __future__ import annotations

import hashlib
import hmac
import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from core.settings import Settings
from tests._service_client import service_client

SECRET = "s3cret-of-sixteen-chars"


class Receiver:
    """Answers 500 to the first `fail_first` POSTs, then 204; keeps (time, headers, body) of each."""

    def __init__(self, fail_first: int):
        self.fail_first, self.calls = fail_first, []
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self):
                body = self.rfile.read(int(self.headers["Content-Length"]))
                outer.calls.append((time.monotonic(), dict(self.headers), body))
                self.send_response(500 if len(outer.calls) <= outer.fail_first else 204)
                self.end_headers()

            def log_message(self, *a):
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/hook"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self):
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture
def api(tmp_path, monkeypatch):
    monkeypatch.setenv("GNSSATT_WEBHOOK_BACKOFF_S", "0.2,0.4,0.8")
    settings = Settings(data_dir=tmp_path / "var")
    with service_client(settings, immediate=True, team="team-w", name="webhook-test-worker") as client:
        yield client


def wait_state(api, job_id, states, timeout_s=20.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        r = api.get(f"/v1/jobs/{job_id}/webhook")
        if r.status_code == 200 and r.json()["state"] in states:
            return r.json()
        time.sleep(0.05)
    raise AssertionError(f"webhook of {job_id} not in {states}: {api.get(f'/v1/jobs/{job_id}/webhook').text}")


def submit(api, url, secret=SECRET):
    body = {"type": "selftest", "config": {"duration_s": 0}, "webhook_url": url}
    if secret:
        body["webhook_secret"] = secret
    resp = api.post("/v1/jobs", json=body)
    assert resp.status_code == 202, resp.text
    return resp.json()


def check_signature(headers: dict, body: bytes, secret: str) -> None:
    ts = headers["X-Gnssatt-Timestamp"]
    want = "sha256=" + hmac.new(secret.encode(), ts.encode() + b"." + body, hashlib.sha256).hexdigest()
    assert hmac.compare_digest(headers["X-Gnssatt-Signature"], want)
    assert abs(time.time() - int(ts)) < 60


def test_receiver_failing_twice_gets_the_third_attempt(api):
    rx = Receiver(fail_first=2)
    try:
        job = submit(api, rx.url)
        assert job["webhook_secret"] is None            # the client gave it: never echoed
        hook = wait_state(api, job["id"], ("delivered", "failed"))
    finally:
        rx.close()
    assert hook["state"] == "delivered" and hook["attempts"] == 3
    assert [d["status_code"] for d in hook["deliveries"]] == [500, 500, 204]
    assert [d["ok"] for d in hook["deliveries"]] == [False, False, True]
    assert hook["deliveries"][0]["error"].startswith("HTTP 500")
    assert len(rx.calls) == 3
    gaps = [b[0] - a[0] for a, b in zip(rx.calls, rx.calls[1:])]
    assert gaps[0] >= 0.18 and gaps[1] >= 0.38, gaps      # backoff 0.2 s then 0.4 s (clock slack 20 ms)
    ids = {c[1]["X-Gnssatt-Delivery"] for c in rx.calls}
    assert len(ids) == 1                                   # one notice, retried
    for _, headers, body in rx.calls:
        check_signature(headers, body, SECRET)
    doc = json.loads(rx.calls[-1][2])
    assert doc["event"] == "job.finished" and doc["job"]["id"] == job["id"] and doc["job"]["state"] == "succeeded"
    assert "selftest.json" in doc["job"]["products"]


def test_receiver_that_never_answers_well_is_recorded_failed(api):
    rx = Receiver(fail_first=99)
    try:
        job = submit(api, rx.url, secret=None)
        secret = job["webhook_secret"]
        assert secret and len(secret) >= 32                # made by the server, shown once
        hook = wait_state(api, job["id"], ("failed",))
    finally:
        rx.close()
    assert hook["attempts"] == 4 and len(rx.calls) == 4   # 1 + the 3 backoff steps
    check_signature(rx.calls[0][1], rx.calls[0][2], secret)
    assert api.get(f"/v1/jobs/{job['id']}").json().get("webhook_secret") is None


def test_unreachable_receiver_and_bad_urls(api):
    job = submit(api, "http://127.0.0.1:9/nothing-listens")
    hook = wait_state(api, job["id"], ("failed",))
    assert all(d["status_code"] is None and "Connect" in d["error"] for d in hook["deliveries"])
    for bad in ("ftp://example.org/x", "not a url", "http:///nohost"):
        resp = api.post("/v1/jobs", json={"type": "selftest", "webhook_url": bad})
        assert resp.status_code == 422 and resp.json()["field"] == "webhook_url", bad
    resp = api.post("/v1/jobs", json={"type": "selftest", "webhook_url": "http://127.0.0.1:9/", "webhook_secret": "short"})
    assert resp.status_code == 422 and resp.json()["field"] == "webhook_secret"
    with api.rt.Session() as s:
        from core.models import Job
        n_jobs = s.query(Job).count()
    assert n_jobs == 1, "a refused webhook must not leave a job behind"
    plain = api.post("/v1/jobs", json={"type": "selftest"}).json()
    assert api.get(f"/v1/jobs/{plain['id']}/webhook").status_code == 404


def test_deliveries_visible_on_the_job_page(api):
    import re

    rx = Receiver(fail_first=1)
    try:
        job = submit(api, rx.url)
        wait_state(api, job["id"], ("delivered",))
    finally:
        rx.close()
    key = api.headers.pop("Authorization")[7:]
    page = api.get("/ui/login")
    token = re.search(r'name="csrf-token" content="([^"]+)"', page.text).group(1)
    api.post("/ui/login", data={"api_key": key, "csrf_token": token, "next": "/ui"}, follow_redirects=False)
    html = api.get(f"/ui/jobs/{job['id']}").text
    cell = html.split('id="webhook"', 1)[1].split("</td>", 1)[0]
    assert rx.url in cell and "delivered" in cell and "2 attempts" in cell
    assert "HTTP 500" in cell and "204 ok" in cell


def test_delete_job_leaves_its_blobs_to_the_janitor(api):
    """DELETE /v1/jobs/{id}: 204, the job and its product rows gone, every blob still there (the request deletes
    none); the janitor removes the blobs no one else refers to once the grace period after the deletion is over,
    and keeps those shared with another job's product; unfinished jobs 409, other teams' 404."""
    from core import janitor
    from core.models import Job, Product

    first = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    second = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "fan_out": 2}}).json()["id"]
    blobs, settings = api.app.state.blobs, api.rt.settings
    prods = {p["name"]: p["sha256"] for p in api.get(f"/v1/jobs/{first}/products").json()}
    other = {p["sha256"] for p in api.get(f"/v1/jobs/{second}/products").json()}
    shared, own = set(prods.values()) & other, set(prods.values()) - other
    assert own, "the two jobs must differ in some product for this test"
    assert api.delete(f"/v1/jobs/{first}").status_code == 204
    assert api.get(f"/v1/jobs/{first}").status_code == 404
    assert all(blobs.path(s).exists() for s in prods.values())  # not deleted by the request
    grace_s = settings.janitor_grace_s + settings.job_time_s
    janitor.sweep(settings, api.rt.Session, blobs, now=time.time() + grace_s - 60)
    assert all(blobs.path(s).exists() for s in prods.values())  # the grace counts from the deletion
    janitor.sweep(settings, api.rt.Session, blobs, now=time.time() + grace_s + 60)
    assert all(not blobs.path(s).exists() for s in own)
    assert all(blobs.path(s).exists() for s in shared)
    assert all(blobs.path(s).exists() for s in other)
    assert api.get(f"/v1/jobs/{second}/products/selftest.json").status_code == 200
    assert api.delete(f"/v1/jobs/{first}").status_code == 404
    with api.rt.Session.begin() as s:
        s.add(Job(id="f" * 32, team_id=s.get(Job, second).team_id, type="selftest", state="running", config={},
                  set_ids=[]))
        assert s.query(Product).filter(Product.job_id == first).count() == 0
    resp = api.delete("/v1/jobs/" + "f" * 32)
    assert resp.status_code == 409 and "cancel" in resp.json()["detail"]
