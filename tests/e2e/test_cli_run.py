"""`gnssatt run` (the worker's pipeline on local files, no server) writes the same products as the service (real
API and worker processes over HTTP) for the same inputs. Normalised before comparing, because they legitimately
differ between the two runs, the values of these JSON keys anywhere in a JSON product: observation_set_id / job_id
(the service's ids against the local run's "set-1" / "local") and created_at / started_at / finished_at (wall-clock
times); the ids themselves where text products (the HTML report) print them; PNG plots, which draw the set name and job id, are compared by their pixel size only, and in the HTML report the "generated ... UTC" time and the embedded
plots are blanked. Everything else must
be byte-identical."""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from client.cli import main as cli_main
from gnssatt.sim.sample_set import write_sample_set
from tests.e2e.conftest import wait_for

pytestmark = pytest.mark.e2e
VARYING_KEYS = ("observation_set_id", "job_id", "created_at", "started_at", "finished_at")


def _normalised(name: str, data: bytes) -> bytes:
    if name.endswith(".png"):  # the plots draw the set name / job id (PlotContext): compare the image's size only
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        return data[16:24]  # IHDR width and height
    if name.endswith(".html"):  # the report's generation time, and its embedded plots (which draw the ids)
        data = re.sub(rb"generated \d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC", b"generated *", data)
        return re.sub(rb"data:image/png;base64,[A-Za-z0-9+/=]+", b"data:image/png;base64,*", data)
    if name.endswith(".aem"):  # CCSDS 504.0 CREATION_DATE: the time the product was written
        return re.sub(rb"CREATION_DATE\s*=\s*\S+", b"CREATION_DATE = *", data)
    if not name.endswith(".json"):
        return data
    doc = json.loads(data)

    def clean(value):
        if isinstance(value, dict):
            return {k: "*" if k in VARYING_KEYS else clean(v) for k, v in value.items()}
        if isinstance(value, list):
            return [clean(v) for v in value]
        return value
    return json.dumps(clean(doc), sort_keys=True).encode()


def _service_products(service, paths: list[Path], job_type: str, config: dict, out: Path) -> dict[str, bytes]:
    key = service.create_key("ops")
    with service.client(key) as c:
        files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]
        resp = c.post("/v1/observation-sets", files=files)
        assert resp.status_code == 201, resp.text
        set_id = resp.json()["id"]
        resp = c.post("/v1/jobs", json={"type": job_type, "observation_set_ids": [set_id],
                                        "config": config})
        assert resp.status_code == 202, resp.text
        job_id = resp.json()["id"]
        job = wait_for(lambda: (j := c.get(f"/v1/jobs/{job_id}").json())["state"] in
                       ("succeeded", "failed", "cancelled") and j, 120.0, what="job done")
        assert job["state"] == "succeeded", (job, service.logs_text())
        products = {p["name"]: c.get(p["url"]).content for p in c.get(f"/v1/jobs/{job_id}/products").json()}
        return _with_ids(products, set_id, job_id)


def _local_products(paths: list[Path], job_type: str, config: dict, tmp_path: Path) -> dict[str, bytes]:
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps(config))
    out = tmp_path / "local-products"
    cli_main(["run", job_type, *map(str, paths), "--config", str(cfg), "--out", str(out)])
    return _with_ids({p.name: p.read_bytes() for p in out.iterdir()}, "set-1", "local")


def _with_ids(products: dict[str, bytes], set_id: str, job_id: str) -> dict[str, bytes]:
    """Text products (HTML report, CSV, ...) with the run's set id and job id written as SET-ID / JOB-ID."""
    def named(data: bytes) -> bytes:   # whole words only: the local job id "local" is also in config keys
        data = re.sub(rb"\b" + re.escape(set_id.encode()) + rb"\b", b"SET-ID", data)
        return re.sub(rb"\b" + re.escape(job_id.encode()) + rb"\b", b"JOB-ID", data)
    return {name: data if name.endswith(".png") else named(data) for name, data in products.items()}


def _assert_same(local: dict[str, bytes], remote: dict[str, bytes]) -> None:
    assert set(local) == set(remote)
    for name in sorted(remote):
        assert _normalised(name, local[name]) == _normalised(name, remote[name]), name


def test_inspect_local_run_matches_service(service, tmp_path):
    service.start_api()
    service.start_worker()
    paths = sorted(write_sample_set(tmp_path / "set", n_epochs=40))
    remote = _service_products(service, paths, "inspect", {}, tmp_path)
    _assert_same(_local_products(paths, "inspect", {}, tmp_path), remote)


def test_attitude_local_run_matches_service(service, tmp_path):
    from gnssatt.sim import simulate_scenario

    simulate_scenario("earth-pointing", tmp_path / "sim", seed=11, overrides={"duration_s": 180.0})
    sim = next(p for p in (tmp_path / "sim").rglob("platform.json")).parent
    paths = sorted((sim / "obs").glob("*.rnx")) + [sim / "nav" / "brdc.rnx", sim / "platform.json"]
    service.start_api()
    service.start_worker()
    config = {"mode": "kinematic"}
    remote = _service_products(service, paths, "attitude", config, tmp_path)
    local = _local_products(paths, "attitude", config, tmp_path)
    assert {"attitude.csv", "baselines.csv", "events.csv", "summary.json"} <= set(remote)
    _assert_same(local, remote)


def test_bad_config_names_the_field(tmp_path, capsys):
    paths = write_sample_set(tmp_path / "set", n_epochs=5)
    (tmp_path / "cfg.json").write_text('{"mode": "sideways"}')
    with pytest.raises(SystemExit) as exc:
        cli_main(["run", "attitude", *map(str, paths), "--config", str(tmp_path / "cfg.json"), "--quiet"])
    assert "config.mode" in str(exc.value)
    assert sys.modules.get("worker.local") is not None
