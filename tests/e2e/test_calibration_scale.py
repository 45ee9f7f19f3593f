"""A small calibration campaign through the real service (issue 8 "same campaign gives identical maps on 1 worker and
on 3 workers"): the same job on one worker and on three workers, on both backends (SQLite + Huey-on-SQLite and
PostgreSQL + Redis), gives byte-identical maps and baselines, equal to the in-process run; with three workers the
fan-out is shared and visible in the job's tasks.csv."""
from __future__ import annotations

import csv
import hashlib
import io
from pathlib import Path

import httpx
import pytest

from bench.local_jobs import input_set, job_context, product_bytes
from gnssatt.calibration.simulated import simulate_campaign
from tests.e2e.conftest import wait_for

pytestmark = pytest.mark.e2e

N_SETS = 5  # 4 calibration sets + 1 held out (10 min each)
CFG = {"azimuth_step_deg": 10.0, "elevation_step_deg": 5.0, "min_count": 10, "held_out_set": f"set_{N_SETS - 1:03d}"}
COMPARED = ("baselines.json", "baselines.csv")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> list[Path]:
    """Five 10-minute passes of the `calibration` preset (noise, multipath, PCV, 2 arcsec reference)."""
    root = tmp_path_factory.mktemp("cal_scale")
    return simulate_campaign(root, N_SETS, 600.0, seed=23, overrides={"reference_sigma_arcsec": 2.0})


@pytest.fixture(scope="module")
def in_process(campaign, tmp_path_factory) -> dict[str, str]:
    """sha256 of the compared products of the same campaign run in-process (fan-out run locally)."""
    from worker.jobs.calibration import CalibrationConfig
    from worker.jobs.calibration import run

    ctx = job_context(tmp_path_factory.mktemp("cal_scale_job"), [input_set(d) for d in campaign])
    run(ctx, CalibrationConfig(**CFG))
    return _hashes(product_bytes(ctx))


def _hashes(products: dict[str, bytes]) -> dict[str, str]:
    return {k: hashlib.sha256(v).hexdigest() for k, v in products.items()
            if k in COMPARED or (k.startswith("pcv_") and k.endswith(".json"))}


def _run_job(c: httpx.Client, set_ids: list[str]) -> tuple[dict[str, bytes], list[dict]]:
    job = c.post("/v1/jobs", json={"type": "calibration", "observation_set_ids": set_ids, "config": CFG})
    assert job.status_code == 202, job.text
    jid = job.json()["id"]
    done = wait_for(lambda: (j := c.get(f"/v1/jobs/{jid}").json())["state"] in ("succeeded", "failed", "cancelled")
                    and j, 180, interval_s=0.3, what="calibration job")
    assert done["state"] == "succeeded", done
    listing = c.get(f"/v1/jobs/{jid}/products").json()
    names = [p["name"] for p in (listing["items"] if isinstance(listing, dict) else listing)]
    products = {n: c.get(f"/v1/jobs/{jid}/products/{n}").content for n in names
                if n in COMPARED or n == "tasks.csv" or (n.startswith("pcv_") and n.endswith(".json"))}
    tasks = list(csv.DictReader(io.StringIO(products.pop("tasks.csv").decode())))
    return products, tasks


def test_same_campaign_same_maps_on_one_and_three_workers(service, campaign, in_process, tmp_path):
    service.start_api()
    first = service.start_worker()
    key = service.create_key("calibration")
    with service.client(key) as c:
        c.timeout = httpx.Timeout(120)
        ids = []
        for d in campaign:
            files = [("files", (p.name, p.read_bytes(), "application/octet-stream"))
                     for p in sorted(d.rglob("*")) if p.is_file() and "truth" not in p.relative_to(d).parts]
            r = c.post("/v1/observation-sets", files=files, data={"name": d.name})
            assert r.status_code == 201, r.text
            ids.append(r.json()["id"])

        one, tasks_one = _run_job(c, ids)
        extra = [service.start_worker(), service.start_worker()]
        for proc in extra:  # both consuming before the job (once, all its tasks ran on the first worker)
            service.wait_worker_ready(proc)
        three, tasks_three = _run_job(c, ids)

    assert len([k for k in one if k.startswith("pcv_")]) == 4  # 2 baselines x L1, L2
    # byte-identical maps and baselines: 1 worker, 3 workers and the in-process run
    assert _hashes(one) == _hashes(three), service.logs_text()
    assert _hashes(one) == in_process

    # the fan-out log: every set once per pass (held-out set only in pass 2, first in the queue)
    labels = [d.name for d in campaign]
    for tasks in (tasks_one, tasks_three):
        assert sorted(t["set"] for t in tasks if t["pass"] == "1") == labels[:-1]
        assert sorted(t["set"] for t in tasks if t["pass"] == "2") == labels
        assert next(t for t in tasks if t["pass"] == "2" and t["task"] == "0")["set"] == labels[-1]
        assert all(float(t["end_s"]) >= float(t["start_s"]) >= 0.0 for t in tasks)
    assert len({t["worker"] for t in tasks_one}) == 1
    assert len({t["worker"] for t in tasks_three}) >= 2, tasks_three  # the work was shared
    assert first.poll() is None
