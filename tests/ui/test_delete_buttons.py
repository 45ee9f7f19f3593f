"""Delete buttons on the job page and the set page, in the system Chromium against the real service: declining
the confirmation deletes nothing; accepting it deletes the job (or set) and returns to the overview; a set still
used by an unfinished job shows the service's refusal on the page."""
from __future__ import annotations

import httpx
import pytest

from gnssatt.sim.sample_set import write_sample_set
from tests.e2e.conftest import wait_for
from tests.ui.conftest import sign_in

pytestmark = pytest.mark.e2e


@pytest.fixture
def job_and_set(site, tmp_path):
    key = site.create_key("delete-ui")
    paths = write_sample_set(tmp_path / "set", n_epochs=12)
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {key}"}, timeout=120) as c:
        up = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]
        set_id = c.post("/v1/observation-sets", files=up, data={"name": "to delete"}).json()["id"]
        job_id = c.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [set_id]}).json()["id"]
        wait_for(lambda: c.get(f"/v1/jobs/{job_id}").json()["state"] in ("succeeded", "failed"), 600,
                 what="inspect job")
    return {"key": key, "set_id": set_id, "job_id": job_id}


def _status(site, key: str, path: str) -> int:
    return httpx.get(site.url + path, headers={"Authorization": f"Bearer {key}"}, timeout=30).status_code


def test_job_and_set_delete_buttons(browser, site, job_and_set):
    key, job_id, set_id = job_and_set["key"], job_and_set["job_id"], job_and_set["set_id"]
    context, page = sign_in(browser, site, key)
    page.goto(f"/ui/jobs/{job_id}")
    page.once("dialog", lambda d: d.dismiss())
    page.click("#delete-job")
    page.wait_for_timeout(300)
    assert _status(site, key, f"/v1/jobs/{job_id}") == 200, "declined: nothing deleted"
    messages = []
    page.once("dialog", lambda d: (messages.append(d.message), d.accept()))
    with page.expect_navigation():
        page.click("#delete-job")
    assert "Delete this job" in messages[0] and page.url.rstrip("/").endswith("/ui")
    assert _status(site, key, f"/v1/jobs/{job_id}") == 404
    page.goto(f"/ui/sets/{set_id}")
    page.once("dialog", lambda d: d.accept())
    with page.expect_navigation():
        page.click("#delete-set")
    assert _status(site, key, f"/v1/observation-sets/{set_id}") == 404
    context.close()


def test_set_in_use_shows_the_refusal(browser, site, job_and_set):
    key, set_id = job_and_set["key"], job_and_set["set_id"]
    with httpx.Client(base_url=site.url, headers={"Authorization": f"Bearer {key}"}, timeout=60) as c:
        resp = c.post("/v1/jobs", json={"type": "selftest", "observation_set_ids": [set_id],
                                        "config": {"duration_s": 60}})
        assert resp.status_code == 202, resp.text
        busy = resp.json()["id"]
    context, page = sign_in(browser, site, key)
    page.goto(f"/ui/sets/{set_id}")
    page.once("dialog", lambda d: d.accept())
    page.click("#delete-set")
    page.wait_for_selector("#delete-problem:not([hidden])")
    assert "in use" in page.inner_text("#delete-problem") and busy in page.inner_text("#delete-problem")
    assert _status(site, key, f"/v1/observation-sets/{set_id}") == 200
    httpx.post(f"{site.url}/v1/jobs/{busy}/cancel", headers={"Authorization": f"Bearer {key}"}, timeout=30)
    context.close()
