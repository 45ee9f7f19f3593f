"""Fixtures and helpers of the early-refusal tests: a short simulated set, an in-process service whose queue is
not drained (a queued job stays visible), and upload / refusal helpers that check nothing was stored or queued."""
from __future__ import annotations

from pathlib import Path

import pytest

from core.models import Job
from core.settings import Settings
from tests._service_client import service_client


@pytest.fixture(scope="session")
def sim(tmp_path_factory) -> Path:
    from gnssatt.sim import simulate_scenario

    out = tmp_path_factory.mktemp("sim")
    simulate_scenario("earth-pointing", out, overrides={"duration_s": 120})
    return out


@pytest.fixture
def api(tmp_path):
    settings = Settings(data_dir=tmp_path / "var")
    with service_client(settings, immediate=False, team="team-p", name="preflight-test") as client:
        yield client


def files_of(d: Path, drop=(), replace=None, add=None) -> list[tuple[str, bytes]]:
    """(name, bytes) of the set in `d` without its truth, less `drop`, with `replace`d contents, plus `add`."""
    out = []
    for p in sorted(d.rglob("*")):
        rel = str(p.relative_to(d))
        if not p.is_file() or rel.startswith("truth") or rel in drop:
            continue
        out.append((rel, (replace or {}).get(rel, p.read_bytes())))
    return out + sorted((add or {}).items())


def upload(api, files) -> str:
    resp = api.post("/v1/observation-sets", files=[("files", (n, b, "application/octet-stream")) for n, b in files])
    assert resp.status_code == 201, resp.text
    return resp.json()["id"]


def submit(api, job_type: str, set_ids: list[str], config: dict | None = None):
    return api.post("/v1/jobs", json={"type": job_type, "observation_set_ids": set_ids, "config": config or {}})


def refused(api, set_id: str | None, job_type: str = "attitude", config: dict | None = None) -> dict:
    """The 422 problem document of submitting `job_type` on the set (or on no set), after checking that no job
    was stored and nothing was queued."""
    resp = submit(api, job_type, [set_id] if set_id else [], config)
    assert resp.status_code == 422, resp.text
    assert resp.headers["content-type"].startswith("application/problem+json")
    with api.rt.Session() as s:
        assert s.query(Job).count() == 0, "a refused job must not be stored"
    assert len(api.rt.huey) == 0, "a refused job must not be queued"
    return resp.json()


def queued(api, set_id: str | None, job_type: str, config: dict | None = None) -> None:
    """The job is accepted (202) and is on the queue."""
    resp = submit(api, job_type, [set_id] if set_id else [], config)
    assert resp.status_code == 202, resp.text
    assert len(api.rt.huey) >= 1
