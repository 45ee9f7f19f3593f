"""The hostile cases of issue 22 on both backends (SQLite + Huey, PostgreSQL + Redis), real processes: NaN in
JSON columns and names longer than the column types are 422 (PostgreSQL refuses them where SQLite would keep
them), 30 delete-while-submit races never give 500, a decompression bomb stores nothing, and a worker stops a
runaway job at its memory budget and a job that never yields at cancel. About 25 s per backend."""
from __future__ import annotations

import gzip
import threading
import time

import pytest

from gnssatt.sim.sample_set import write_sample_set
from tests.e2e.conftest import wait_for
from tests.gnss.test_pcv_map import make_map

pytestmark = pytest.mark.e2e


def _set_files(tmp_path):
    paths = write_sample_set(tmp_path / "set", n_epochs=5)
    return [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]


def test_hostile_requests_on_both_backends(service, tmp_path):
    service.env["GNSSATT_JOB_MEMORY_MB"] = "256"
    service.start_api()
    service.start_worker()
    key = service.create_key("hostile")
    files = _set_files(tmp_path)
    with service.client(key) as c:
        # NaN / Infinity would reach a JSON column (PostgreSQL: invalid input syntax for type json)
        for literal in ("NaN", "Infinity"):
            resp = c.post("/v1/jobs", content=('{"type": "selftest", "config": {"x": [%s]}}' % literal).encode(),
                          headers={"Content-Type": "application/json"})
            assert resp.status_code == 422, resp.text
        # names longer than their columns (PostgreSQL: value too long for type character varying)
        assert c.post("/v1/observation-sets", files=files, data={"name": "n" * 301}).status_code == 422
        doc = make_map(seed=5).to_json()
        doc["pair"] = ["A" * 101, "GPS-0"]
        assert c.post("/v1/pcv-maps", json={"name": "long", "map": doc}).status_code == 422
        # a bomb stores nothing
        bomb = gzip.compress(b" " * 79 + b"\n" * (64 * 2**20 // 80))
        resp = c.post("/v1/observation-sets", files=files[1:] + [("files", ("GPS-2.rnx.gz", bomb, "x"))])
        assert resp.status_code in (413, 422), resp.text
        assert c.get("/v1/observation-sets").json()["total"] == 0
        # delete-while-submit races: 409 or success, never 500
        statuses: list[int] = []
        for _ in range(30):
            set_id = c.post("/v1/observation-sets", files=files).json()["id"]
            results: dict[str, int] = {}
            submit = threading.Thread(target=lambda: results.__setitem__("submit", c.post(
                "/v1/jobs", json={"type": "inspect", "observation_set_ids": [set_id]}).status_code))
            submit.start()
            results["delete"] = c.delete(f"/v1/observation-sets/{set_id}").status_code
            submit.join()
            statuses += [results["submit"], results["delete"]]
            assert results["submit"] in (202, 409, 422) and results["delete"] in (204, 409), results
        assert 500 not in statuses
        # a runaway job fails at the worker's budget; a job that never reports progress is cancelled
        hog = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "allocate_mb": 4096}})
        job = wait_for(lambda: (j := c.get(hog.headers["location"]).json())["state"] in ("failed", "succeeded")
                       and j, timeout_s=90, what="the memory hog to end")
        assert job["state"] == "failed" and job["error"]["title"] == "Memory budget exceeded", job
        spin = c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "spin_s": 600}})
        wait_for(lambda: c.get(spin.headers["location"]).json()["state"] == "running", timeout_s=60,
                 what="the spinning job to start")
        time.sleep(0.5)
        t0 = time.monotonic()
        assert c.post(spin.headers["location"] + "/cancel").status_code == 200
        wait_for(lambda: c.get(spin.headers["location"]).json()["state"] == "cancelled", timeout_s=15,
                 what="the spinning job to be cancelled")
        assert time.monotonic() - t0 < 10
