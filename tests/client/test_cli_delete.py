"""`gnssatt delete job|set ID`: by full id or unique prefix, the job (with its products) or the set is gone
afterwards; an ambiguous prefix, an unfinished job and a set in use are refused in one line, deleting nothing."""
from __future__ import annotations

from core.models import ApiKey, Job
from gnssatt.sim.sample_set import write_sample_set
from tests.client.conftest import run_cli


def _upload(service, tmp_path, name: str) -> str:
    paths = write_sample_set(tmp_path / name, n_epochs=12)
    resp = service.post("/v1/observation-sets", files=[("files", (p.name, p.read_bytes(), "application/octet-stream"))
                                                       for p in paths], data={"name": name})
    assert resp.status_code == 201, resp.text
    return resp.json()["id"]


def test_delete_job_and_set_by_prefix(service, capsys, tmp_path):
    set_id = _upload(service, tmp_path, "a")
    job = service.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [set_id]}).json()
    assert service.get(f"/v1/jobs/{job['id']}").json()["state"] == "succeeded"
    assert service.get(f"/v1/jobs/{job['id']}/products").json()
    code, out, err = run_cli(capsys, "delete", "job", "--key", service.key, job["id"][:8])
    assert code == 0, err
    assert out.strip() == f"deleted job {job['id']}"
    assert service.get(f"/v1/jobs/{job['id']}").status_code == 404
    code, out, err = run_cli(capsys, "delete", "set", "--key", service.key, set_id[:8])
    assert code == 0 and out.strip() == f"deleted observation set {set_id}", err
    assert service.get(f"/v1/observation-sets/{set_id}").status_code == 404


def test_delete_refusals_are_one_line_and_delete_nothing(service, capsys, tmp_path):
    set_id = _upload(service, tmp_path, "b")
    with service.rt.Session.begin() as s:
        team_id = s.query(ApiKey).first().team_id
        for i in (1, 2):
            s.add(Job(id=f"beef{i}" + "0" * 27, team_id=team_id, type="inspect", state="running", config={},
                      set_ids=[]))
    code, _, err = run_cli(capsys, "delete", "job", "--key", service.key, "beef")
    assert code != 0 and "ambiguous" in err and "beef1" in err
    code, _, err = run_cli(capsys, "delete", "job", "--key", service.key, "beef1")
    assert code != 0 and len(err.strip().splitlines()) == 1 and "Job not finished" in err and "cancel" in err, err
    code, _, err = run_cli(capsys, "delete", "set", "--key", service.key, "0000")
    assert code != 0 and "no set of your team" in err
    with service.rt.Session() as s:
        assert s.query(Job).count() == 2
    assert service.get(f"/v1/observation-sets/{set_id}").status_code == 200
