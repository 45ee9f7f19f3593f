"""/v1/pcv-maps: upload (JSON or ANTEX-style), versions, download both ways, team scope, maps made by jobs."""
from __future__ import annotations

from tests.gnss.test_pcv_map import make_map
from gnssatt.gnss.io.pcv_map import parse_pcv_map, read_pcv_antex


def test_upload_list_download_round_trip(api):
    grid = make_map(seed=5)
    resp = api.post("/v1/pcv-maps", json={"name": "cassiope-2018", "map": grid.to_json()})
    assert resp.status_code == 201, resp.text
    meta = resp.json()
    assert meta["version"] == 1 and meta["pair"] == ["GPS-2", "GPS-0"] and meta["frequency"] == "L1"
    assert meta["n_bins"] == grid.values_mm.size and 0 < meta["n_filled"] < meta["n_bins"]
    as_json = api.get(meta["url_json"])
    assert as_json.status_code == 200 and 'pcv_GPS-2_GPS-0_L1.json' in as_json.headers["content-disposition"]
    assert parse_pcv_map(as_json.json()).equals(grid)
    as_text = api.get(meta["url_antex"])
    assert as_text.headers["content-type"].startswith("text/plain")
    assert read_pcv_antex(as_text.text)[0].equals(grid)
    # the ANTEX-style text uploads back as version 2, unchanged
    again = api.post("/v1/pcv-maps", json={"name": "cassiope-2018", "antex": as_text.text}).json()
    assert again["version"] == 2
    assert parse_pcv_map(api.get(again["url_json"]).json()).equals(grid)
    listing = api.get("/v1/pcv-maps", params={"name": "cassiope-2018"}).json()
    assert listing["total"] == 2 and [m["version"] for m in listing["items"]] == [2, 1]
    assert api.delete(f"/v1/pcv-maps/{meta['id']}").status_code == 204
    assert api.get(f"/v1/pcv-maps/{meta['id']}").status_code == 404


def test_bad_maps_are_422(api):
    doc = make_map().to_json()
    doc["values_mm"] = doc["values_mm"][:-1]
    resp = api.post("/v1/pcv-maps", json={"name": "bad", "map": doc})
    assert resp.status_code == 422 and "values_mm" in resp.json()["detail"]
    resp = api.post("/v1/pcv-maps", json={"name": "bad", "antex": "not antex"})
    assert resp.status_code == 422 and resp.json()["line"] == 1
    resp = api.post("/v1/pcv-maps", json={"name": "bad"})
    assert resp.status_code == 422
    assert api.get("/v1/pcv-maps").json()["total"] == 0


def test_maps_are_team_scoped(api, other_key):
    meta = api.post("/v1/pcv-maps", json={"name": "m", "map": make_map().to_json()}).json()
    other = {"Authorization": f"Bearer {other_key}"}
    assert api.get(f"/v1/pcv-maps/{meta['id']}", headers=other).status_code == 404
    assert api.get(meta["url_json"], headers=other).status_code == 404
    assert api.delete(f"/v1/pcv-maps/{meta['id']}", headers=other).status_code == 404
    assert api.get("/v1/pcv-maps", headers=other).json()["total"] == 0


def test_a_job_publishes_maps_only_when_it_succeeds(api):
    ok = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0, "publish_pcv_map": "made"}})
    job = api.get(f"/v1/jobs/{ok.json()['id']}").json()
    assert job["state"] == "succeeded"
    maps = api.get("/v1/pcv-maps", params={"name": "made"}).json()["items"]
    assert len(maps) == 1 and maps[0]["source_job_id"] == job["id"]
    failed = api.post("/v1/jobs", json={"type": "selftest", "config": {
        "duration_s": 0, "publish_pcv_map": "never", "fail_attempts": 9, "fail_as_input_error": True}}).json()
    assert api.get(f"/v1/jobs/{failed['id']}").json()["state"] == "failed"
    assert api.get("/v1/pcv-maps", params={"name": "never"}).json()["total"] == 0
