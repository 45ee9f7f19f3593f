"""Issue 24: POST /v1/jobs answers 422 naming what is missing before anything is queued: platform.json, navigation
data, a file named in platform.json, too few antennas, no common epochs (sets uploaded through the API, the
service in-process; the queue and the jobs table are checked to be empty afterwards)."""
from __future__ import annotations

import json

import pytest

from core.models import SetFile
from tests.preflight.conftest import files_of, refused, upload


def test_complete_set_is_queued(api, sim):
    set_id = upload(api, files_of(sim))
    resp = api.post("/v1/jobs", json={"type": "attitude", "observation_set_ids": [set_id]})
    assert resp.status_code == 202, resp.text
    assert len(api.rt.huey) == 1


def test_no_platform_json(api, sim):
    doc = refused(api, upload(api, files_of(sim, drop={"platform.json"})))
    assert doc["type"].endswith("missing-platform") and "platform.json" in doc["detail"]
    assert "template" in doc["detail"]


def test_no_navigation_data(api, sim):
    doc = refused(api, upload(api, files_of(sim, drop={"nav/brdc.rnx"})))
    assert doc["type"].endswith("missing-navigation") and "RINEX navigation" in doc["detail"]
    # the same set is fine for a job type that needs no orbits
    assert api.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [
        upload(api, files_of(sim, drop={"nav/brdc.rnx"}))]}).status_code == 202


def test_file_named_in_platform_json_missing(api, sim):
    set_id = upload(api, files_of(sim))
    with api.rt.Session.begin() as s:      # a stored set whose file of GPS-1 is gone (e.g. removed since)
        f = s.query(SetFile).filter(SetFile.set_id == set_id, SetFile.name.like("%GPS-1.rnx")).one()
        gone = f.name
        s.delete(f)
    doc = refused(api, set_id)
    assert doc["type"].endswith("missing-observation-file")
    assert "GPS-1" in doc["title"] and gone in doc["detail"] and doc["file"] == "platform.json"


def test_too_few_antennas(api, sim):
    plat = json.loads((sim / "platform.json").read_text())
    keep = next(iter(plat["antennas"]))
    plat["antennas"] = {keep: plat["antennas"][keep]}
    for k in ("baselines", "master", "observation_files"):
        plat.pop(k, None)
    files = files_of(sim, replace={"platform.json": json.dumps(plat).encode()})
    resp = api.post("/v1/observation-sets", files=[("files", (n, b, "application/octet-stream")) for n, b in files])
    if resp.status_code != 201:      # refused at upload already: that also names the antennas
        assert resp.status_code in (400, 422) and "antenna" in resp.text.lower(), resp.text
        pytest.fail(f"a one-antenna platform.json is refused at upload, the job check is unreachable: {resp.text}")
    doc = refused(api, resp.json()["id"])
    assert doc["type"].endswith("too-few-antennas") and "at least 2 antennas" in doc["detail"]


def _epochs(text: str) -> tuple[str, list[str]]:
    head, body = text.split("END OF HEADER", 1)
    head += "END OF HEADER" + body.split("\n", 1)[0] + "\n"
    body = body.split("\n", 1)[1]
    records = ["> " + r for r in body.split("\n> ")]
    records[0] = records[0][2:]
    return head, records


def test_no_common_epochs(api, sim):
    """GPS-0's file keeps the first 40 epochs, the others the last 40: no time in common."""
    replace = {}
    for ant, part in (("GPS-0", slice(0, 40)), ("GPS-1", slice(-40, None)), ("GPS-2", slice(-40, None))):
        head, recs = _epochs((sim / "obs" / f"{ant}.rnx").read_text())
        replace[f"obs/{ant}.rnx"] = (head + "\n".join(r.rstrip("\n") for r in recs[part]) + "\n").encode()
    doc = refused(api, upload(api, files_of(sim, replace=replace)))
    assert doc["type"].endswith("no-common-epochs") and "GPS-0" in doc["detail"] and "GPS-1" in doc["detail"]
