"""The /ui pages over plain HTTP in-process (no browser): sign-in, CSRF, team scoping, rendering of a job."""
from __future__ import annotations

import re

import pytest
from fastapi.testclient import TestClient

from app.keys import create_key
from app.main import create_app
from core.models import PcvMap
from core.settings import Settings
from gnssatt.sim.sample_set import write_sample_set
from worker import runner
from worker.main import build_runtime


@pytest.fixture
def site(tmp_path):
    settings = Settings(data_dir=tmp_path / "var", lease_seconds=5, heartbeat_seconds=0.5)
    rt = build_runtime(settings, immediate=True, name="ui-test-worker")
    app = create_app(settings)
    with TestClient(app, raise_server_exceptions=False) as client:
        app.state.huey = rt.huey
        with rt.Session.begin() as s:
            key_a, _ = create_key(s, "team-a")
            key_b, _ = create_key(s, "team-b")
        client.rt = rt
        client.keys = {"a": key_a, "b": key_b}
        yield client
    runner.set_runtime(None)
    rt.engine.dispose()


def csrf_of(html: str) -> str:
    return re.search(r'<meta name="csrf-token" content="([^"]+)"', html).group(1)


def login(client: TestClient, key: str) -> str:
    page = client.get("/ui/login")
    token = csrf_of(page.text)
    resp = client.post("/ui/login", data={"api_key": key, "csrf_token": token, "next": "/ui"}, follow_redirects=False)
    assert resp.status_code == 303 and resp.headers["location"] == "/ui"
    cookie = resp.headers.get_list("set-cookie")
    key_cookie = [c for c in cookie if c.startswith("gnssatt_key=")][0].lower()
    assert "httponly" in key_cookie and "samesite=strict" in key_cookie and "path=/" in key_cookie
    assert "secure" not in key_cookie  # plain http here; https adds Secure
    return csrf_of(client.get("/ui").text)


def upload(client: TestClient, tmp_path, headers) -> dict:
    paths = write_sample_set(tmp_path / "set", n_epochs=12)
    resp = client.post("/v1/observation-sets", files=[("files", (p.name, p.read_bytes())) for p in paths],
                       data={"name": "sample-a"}, headers=headers)
    assert resp.status_code == 201, resp.text
    return resp.json()


def test_pages_need_sign_in_and_redirect_back(site):
    resp = site.get("/ui/jobs/abc?x=1", follow_redirects=False)
    assert resp.status_code == 303 and resp.headers["location"] == "/ui/login?next=%2Fui%2Fjobs%2Fabc%3Fx%3D1"
    assert site.get("/", follow_redirects=False).headers["location"] == "/ui"
    page = site.get("/ui/login")
    assert page.status_code == 200 and "Content-Security-Policy" in page.headers
    assert "default-src 'self'" in page.headers["Content-Security-Policy"]


def test_login_rejects_bad_key_and_missing_csrf(site):
    token = csrf_of(site.get("/ui/login").text)
    bad = site.post("/ui/login", data={"api_key": "gk_nope", "csrf_token": token}, follow_redirects=False)
    assert bad.status_code == 401 and "Invalid API key" in bad.text and "gnssatt_key=" not in bad.headers.get("set-cookie", "")
    forged = site.post("/ui/login", data={"api_key": site.keys["a"], "csrf_token": "x" * 40}, follow_redirects=False)
    assert forged.status_code == 403 and "gnssatt_key=" not in forged.headers.get("set-cookie", "")


def test_open_redirect_refused(site):
    token = csrf_of(site.get("/ui/login").text)
    resp = site.post("/ui/login", data={"api_key": site.keys["a"], "csrf_token": token, "next": "//evil.example/x"},
                     follow_redirects=False)
    assert resp.headers["location"] == "/ui"


def test_cookie_auth_needs_csrf_on_v1_writes_but_api_keys_do_not(site, tmp_path):
    token = login(site, site.keys["a"])
    # GET with the cookie alone works (EventSource, downloads, images)
    assert site.get("/v1/job-types").status_code == 200
    # a write with the cookie but without the token: 403 problem, nothing created
    resp = site.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}})
    assert resp.status_code == 403 and resp.headers["content-type"] == "application/problem+json"
    assert resp.json()["title"] == "CSRF token missing or invalid"
    assert site.get("/v1/jobs").json()["total"] == 0
    wrong = site.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}},
                      headers={"X-CSRF-Token": "y" * 43})
    assert wrong.status_code == 403
    ok = site.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}, headers={"X-CSRF-Token": token})
    assert ok.status_code == 202, ok.text
    # Bearer and X-API-Key clients are untouched even when a cookie is also present
    site.cookies.set("gnssatt_key", site.keys["a"])
    assert site.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}},
                     headers={"Authorization": f"Bearer {site.keys['b']}"}).status_code == 202
    assert site.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}},
                     headers={"X-API-Key": site.keys["b"]}).status_code == 202
    # multipart upload from the page carries the token too
    assert upload(site, tmp_path, {"X-CSRF-Token": token})["name"] == "sample-a"


def test_logout_needs_csrf_and_clears_cookie(site):
    token = login(site, site.keys["a"])
    assert site.post("/ui/logout", data={}, follow_redirects=False).status_code == 403
    resp = site.post("/ui/logout", data={"csrf_token": token}, follow_redirects=False)
    assert resp.status_code == 303 and resp.headers["location"] == "/ui/login"
    assert any(c.startswith('gnssatt_key=""') or "max-age=0" in c.lower() for c in resp.headers.get_list("set-cookie"))
    site.cookies.clear()
    assert site.get("/ui", follow_redirects=False).status_code == 303


def test_job_page_shows_summary_plots_and_products(site, tmp_path):
    headers = {"Authorization": f"Bearer {site.keys['a']}"}
    obs_set = upload(site, tmp_path, headers)
    job = site.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [obs_set["id"]]}, headers=headers).json()
    assert site.get(f"/v1/jobs/{job['id']}", headers=headers).json()["state"] == "succeeded"
    login(site, site.keys["a"])
    page = site.get(f"/ui/jobs/{job['id']}").text
    for name in ("summary.json", "observations.csv", "tracking.csv", "tracking.png", "cn0.png"):
        assert f'/v1/jobs/{job["id"]}/products/{name}' in page
    assert page.count('<img src="/v1/jobs/') == 2 and 'id="chart-products"' in page
    assert "n_tracking_rows" in page  # summary numbers from summary.json
    dash = site.get("/ui").text
    assert job["id"][:8] in dash and "sample-a" in dash
    set_page = site.get(f"/ui/sets/{obs_set['id']}").text
    assert "GPS-0.rnx" in set_page and "platform.json" in set_page and "C1C L1C" in set_page


def test_team_b_sees_nothing_of_team_a(site, tmp_path):
    headers = {"Authorization": f"Bearer {site.keys['a']}"}
    obs_set = upload(site, tmp_path, headers)
    job = site.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [obs_set["id"]]}, headers=headers).json()
    with site.rt.Session.begin() as s:
        team_a = s.execute(__import__("sqlalchemy").text("select id from teams where name='team-a'")).scalar_one()
        s.add(PcvMap(team_id=team_a, name="a-map", version=1, platform="P", first_antenna="GPS-2",
                     second_antenna="GPS-0", frequency="L1", sha256="0" * 64))
    login(site, site.keys["b"])
    dash = site.get("/ui").text
    assert obs_set["id"][:8] not in dash and job["id"][:8] not in dash and "sample-a" not in dash
    for url in (f"/ui/jobs/{job['id']}", f"/ui/sets/{obs_set['id']}"):
        resp = site.get(url)
        assert resp.status_code == 404 and "not found" in resp.text and "sample-a" not in resp.text
    assert site.get(f"/v1/jobs/{job['id']}/products/tracking.png").status_code == 404
    assert "a-map" not in site.get("/ui/pcv-maps").text and 'id="pcv-none"' in site.get("/ui/pcv-maps").text
    assert obs_set["id"] not in site.get("/ui/new").text
    login(site, site.keys["a"])
    assert "a-map" in site.get("/ui/pcv-maps").text


def test_pcv_map_page_shows_stats_and_is_team_scoped(site):
    """One map's page: its summary computed from the stored map; another team gets a 404 page without it."""
    import numpy as np

    from tests.gnss.test_pcv_map import make_map

    grid = make_map(seed=7)
    headers = {"Authorization": f"Bearer {site.keys['a']}"}
    meta = site.post("/v1/pcv-maps", json={"name": "gap-l1", "map": grid.to_json()}, headers=headers).json()
    login(site, site.keys["a"])
    listing = site.get("/ui/pcv-maps").text
    assert f'href="/ui/pcv-maps/{meta["id"]}"' in listing
    page = site.get(f"/ui/pcv-maps/{meta['id']}")
    assert page.status_code == 200
    filled = np.isfinite(grid.values_mm)
    assert f"{int(filled.sum())} of {grid.values_mm.size}" in page.text
    v = grid.values_mm[filled]
    assert f"{v.min():.2f} to {v.max():.2f} mm" in page.text
    assert f"{np.sqrt(np.mean(v ** 2)):.2f} mm" in page.text
    assert 'id="pcv-data"' in page.text and "</script" not in page.text.split('id="pcv-data">', 1)[1].split(
        "</script>", 1)[0]
    login(site, site.keys["b"])
    other = site.get(f"/ui/pcv-maps/{meta['id']}")
    assert other.status_code == 404 and "gap-l1" not in other.text and 'id="pcv-data"' not in other.text
