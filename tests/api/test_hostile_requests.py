"""Requests that used to crash or leak (issue 22, defects 8, 9, 12): user data in Content-Disposition, a set
deleted while a job is submitted on it, an event stream whose key is revoked, names longer than columns."""
from __future__ import annotations

import threading
import time
from urllib.parse import unquote

from sqlalchemy import delete, event
from sqlalchemy.orm import Session as OrmSession

from app.keys import revoke_key
from core.models import Job, ObservationSet
from tests.api.test_observation_sets import _files, sample_items
from tests.gnss.test_pcv_map import make_map


def _map_with_pair(api, first: str, second: str):
    doc = make_map(seed=5).to_json()
    doc["pair"] = [first, second]
    return api.post("/v1/pcv-maps", json={"name": "hostile", "map": doc})


def test_content_disposition_is_rfc6266_encoded_for_any_antenna_id(api):
    for first in ("GPS-2\r\nX-Injected: yes", "GPS\x002", "Антенна-€", 'a"b\\c;d'):
        resp = _map_with_pair(api, first, "GPS-0")
        assert resp.status_code == 201, (first, resp.text)
        got = api.get(resp.json()["url_json"])
        assert got.status_code == 200, (first, got.status_code)
        disposition = got.headers["content-disposition"]
        assert "x-injected" not in {k.lower() for k in got.headers}
        fallback = disposition.split('filename="', 1)[1].split('"', 1)[0]
        assert all(32 < ord(c) < 127 and c not in '"\\' for c in fallback), disposition
        encoded = disposition.split("filename*=UTF-8''", 1)[1]
        assert unquote(encoded) == f"pcv_{first}_GPS-0_L1.json"


def test_antenna_ids_longer_than_their_column_are_422(api):
    resp = _map_with_pair(api, "A" * 101, "GPS-0")
    assert resp.status_code == 422 and resp.json()["field"] == "map.pair.0", resp.text
    assert api.get("/v1/pcv-maps").json()["total"] == 0


def test_set_deleted_while_a_job_is_submitted_is_409(api):
    """The race of the probe (2 of 30 gave 500 IntegrityError), made deterministic: the set disappears between
    the submit's ownership check and its commit."""
    set_id = api.post("/v1/observation-sets", files=_files(*sample_items(5))).json()["id"]
    engine = api.app.state.engine
    fired: list[bool] = []

    def delete_set_meanwhile(session, *_):   # at the flush that would write the new job and its set links
        if fired or not any(isinstance(o, Job) for o in session.new):
            return
        fired.append(True)
        with engine.begin() as conn:
            conn.execute(delete(ObservationSet).where(ObservationSet.id == set_id))

    event.listen(OrmSession, "before_flush", delete_set_meanwhile)
    try:
        resp = api.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [set_id]})
    finally:
        event.remove(OrmSession, "before_flush", delete_set_meanwhile)
    assert fired and resp.status_code == 409, resp.text
    assert resp.json()["type"].endswith("/set-deleted")
    assert api.get("/v1/jobs").json()["total"] == 0


def test_event_stream_stops_when_its_key_is_revoked(api, monkeypatch):
    import app.routes.jobs as jobs_routes

    monkeypatch.setattr(jobs_routes, "enqueue", lambda huey, job_id, delay_s=None: None)  # stays queued
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    key = api.headers["Authorization"].split(" ", 1)[1]
    lines: list[str] = []
    done = threading.Event()

    def follow() -> None:
        with api.stream("GET", f"/v1/jobs/{job_id}/events") as resp:
            for line in resp.iter_lines():
                lines.append(line)
                if line == "event: progress" and len(lines) == 1:
                    with api.rt.Session.begin() as s:
                        assert revoke_key(s, key) == 1
                    lines.append(f"revoked at {time.monotonic()}")
        done.set()

    reader = threading.Thread(target=follow, daemon=True)
    reader.start()
    assert done.wait(10), f"the stream kept going after the key was revoked: {lines}"
    assert "event: error" in lines and any('"status": 401' in line for line in lines)
