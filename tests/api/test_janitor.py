"""The janitor (core/janitor.py) removes dead uploads' staging, dead attempts' work directories and blobs no row
points to after their grace period, and never a blob a row points to, also while uploads re-use blobs
concurrently (issue 22, defect 11); each test on SQLite and on PostgreSQL (a scratch database). About 6 s a backend."""
from __future__ import annotations

import os
import threading
import time

import pytest
from sqlalchemy import select

from core import janitor
from core.models import SetFile
from core.settings import Settings
from tests._backends import scratch_backend
from tests.api.test_observation_sets import _files, sample_items

HOUR = 3600.0


@pytest.fixture(params=["sqlite", "pg"])
def settings(request, tmp_path):
    """The API tests' settings (tests/api/conftest.py) on the backend of the parameter."""
    with scratch_backend(request.param, prefix="gnssatt_janitor") as overrides:
        yield Settings(data_dir=tmp_path / "var", lease_seconds=5, heartbeat_seconds=0.5,
                       max_upload_bytes=5 * 1024 * 1024, **overrides)


def _age(path, seconds: float) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t))


def test_dead_staging_and_work_dirs_are_removed_live_ones_kept(api, settings):
    rt = api.rt
    dead = settings.staging_dir / "dead"
    (dead / "0000.part").parent.mkdir(parents=True)
    (dead / "0000.part").write_bytes(b"x" * 1000)
    _age(dead / "0000.part", 2 * HOUR)
    _age(dead, 2 * HOUR)
    live = settings.staging_dir / "live"
    live.mkdir()
    (live / "0000.part").write_bytes(b"y")
    _age(live, 2 * HOUR)  # an old directory with a fresh write: a slow upload still going
    job_id = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    work = settings.data_dir / "work"
    gone, kept = work / f"{job_id}-1", work / "0123456789abcdef-1"
    for d in (gone, kept):
        d.mkdir(parents=True)
        _age(d, 120)
    counts = janitor.sweep(settings, rt.Session, rt.blobs)
    assert counts["staging"] == 1 and not dead.exists() and live.exists()
    assert not gone.exists()  # the job finished: its attempt 1 is over
    assert not kept.exists()  # no such job at all
    assert counts["workdirs"] == 2


def test_unreferenced_blobs_go_after_the_grace_period_referenced_ones_never(api, settings):
    rt = api.rt
    set_id = api.post("/v1/observation-sets", files=_files(*sample_items(5))).json()["id"]
    with rt.Session() as s:
        shas = set(s.execute(select(SetFile.sha256).where(SetFile.set_id == set_id)).scalars())
    orphan_old, _ = rt.blobs.put_bytes(b"orphan, old")
    orphan_new, _ = rt.blobs.put_bytes(b"orphan, new")
    old = time.time() + 10 * HOUR  # "now" far beyond the grace period: only references protect
    for sha in shas | {orphan_old}:
        _age(rt.blobs.path(sha), 0)
    counts = janitor.sweep(settings, rt.Session, rt.blobs, now=old)
    assert not rt.blobs.exists(orphan_old) and not rt.blobs.exists(orphan_new)
    assert all(rt.blobs.exists(sha) for sha in shas) and counts["blobs"] == 2
    assert api.delete(f"/v1/observation-sets/{set_id}").status_code == 204
    janitor.sweep(settings, rt.Session, rt.blobs, now=old)
    assert not any(rt.blobs.exists(sha) for sha in shas)  # deleted set: its files go too


def test_concurrent_uploads_reusing_blobs_never_lose_one(api, settings):
    """Upload, delete, age the blobs past the grace period and at once upload the same bytes again, while a
    janitor with a 0.5 s grace sweeps in a loop: every stored set always has all its blobs (the upload holds the
    store's shared lock from its first blob to its commit and the janitor reads references under the exclusive
    one, so the janitor either removed a blob first and the upload wrote it anew, or sees the row; this failed
    once on a slow host when the references were read before the lock and the upload took > 0.5 s)."""
    rt = api.rt
    settings.janitor_grace_s = 0.0
    settings.job_time_s = 0.5
    stop = threading.Event()
    removed = [0, 0]  # sweeps, blobs removed
    errors: list[BaseException] = []

    def sweeper():
        try:
            while not stop.is_set():
                removed[1] += janitor.sweep_blobs(settings, rt.Session, rt.blobs, time.time())
                removed[0] += 1
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    thread = threading.Thread(target=sweeper, daemon=True)
    thread.start()
    items = sample_items(3)
    try:
        for _ in range(25):
            resp = api.post("/v1/observation-sets", files=_files(*items))
            assert resp.status_code == 201, resp.text
            body = resp.json()
            before = removed[0]
            while removed[0] < before + 2 and thread.is_alive():
                time.sleep(0.002)
            lost = [f["name"] for f in body["files"] if not rt.blobs.exists(f["sha256"])]
            assert not lost, f"blobs of a stored set were removed: {lost}"
            assert api.delete(f"/v1/observation-sets/{body['id']}").status_code == 204
            for f in body["files"]:  # unreferenced now, and long untouched: the janitor's to take
                if rt.blobs.exists(f["sha256"]):
                    _age(rt.blobs.path(f["sha256"]), 10.0)
    finally:
        stop.set()
        thread.join(timeout=10)
    assert not errors and removed[0] >= 50
    assert removed[1] > 0  # the janitor did remove the deleted sets' blobs meanwhile


def _job_row(rt, team_id: str, sha: str, size: int) -> str:
    """Commit a succeeded job with one product pointing to blob `sha`; returns the job id."""
    from core.models import Job, Product, utcnow

    with rt.Session.begin() as s:
        job = Job(team_id=team_id, type="selftest", config={}, set_ids=[], state="succeeded", progress=1.0,
                  created_at=utcnow(), finished_at=utcnow(), attempts=1, max_attempts=3, cancel_requested=False)
        s.add(job)
        s.flush()
        s.add(Product(job_id=job.id, attempt=1, name="out.txt", media_type="text/plain", sha256=sha,
                      size_bytes=size))
        return job.id


def _published_job(rt, team_id: str, payload: bytes) -> tuple[str, str]:
    """A succeeded job with one product of `payload`, stored as a worker publishes it (blob first, then the
    row, under the store's shared lock as worker/runner.py does); returns (job id, sha256)."""
    with rt.blobs.adding():
        sha, size = rt.blobs.put_bytes(payload)
        return _job_row(rt, team_id, sha, size), sha


def test_deleting_jobs_while_other_jobs_reuse_their_product_blobs_never_loses_one(api, settings):
    """A team deletes a job while another job publishes a product of the same bytes, at a random moment within
    twice the grace period after the delete, and a janitor with a 0.3 s grace sweeps in a loop: the new job's
    product is always there and downloadable (the delete only releases the blob; the janitor deletes under the
    store's exclusive lock and only what was not touched since it looked), and the janitor did take the
    released blobs meanwhile."""
    import random

    from core.models import Job

    rt = api.rt
    settings.janitor_grace_s = 0.0
    settings.job_time_s = 0.3
    first = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    with rt.Session() as s:
        team_id = s.get(Job, first).team_id
    stop, sweeps, errors = threading.Event(), [0], []

    def sweeper():
        try:
            while not stop.is_set():
                janitor.sweep_blobs(settings, rt.Session, rt.blobs, time.time())
                sweeps[0] += 1
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    thread = threading.Thread(target=sweeper, daemon=True)
    thread.start()
    rng, gone_before_reuse = random.Random(22), 0
    try:
        for i in range(16):
            payload = f"product {i} ".encode() * 1000
            old_job, sha = _published_job(rt, team_id, payload)
            assert api.delete(f"/v1/jobs/{old_job}").status_code == 204
            time.sleep(rng.uniform(0.0, 0.6))
            gone_before_reuse += not rt.blobs.exists(sha)
            new_job, sha_again = _published_job(rt, team_id, payload)
            assert sha_again == sha
            before = sweeps[0]
            while sweeps[0] < before + 2 and thread.is_alive():
                time.sleep(0.002)
            assert rt.blobs.exists(sha), f"round {i}: a product's blob was removed"
            resp = api.get(f"/v1/jobs/{new_job}/products/out.txt")
            assert resp.status_code == 200 and resp.content == payload
    finally:
        stop.set()
        thread.join(timeout=10)
    assert not errors
    assert gone_before_reuse > 0  # the janitor did take released blobs, so the reuse raced real deletions


def test_a_commit_slower_than_the_grace_period_keeps_its_blobs(api, settings):
    """The worst moment, forced: a deleted job's blob is far past its grace; another job has just written the
    same bytes again and holds the store's shared lock, but its row is not committed yet (a slow upload or a
    slow database); the janitor sweeps with "now" so far ahead that the fresh touch looks old too. It must wait
    for the commit and then see the row (it reads the references under its exclusive lock), so the blob stays,
    however long the writer took between its blob and its row."""
    from core.models import Job

    rt = api.rt
    first = api.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).json()["id"]
    with rt.Session() as s:
        team_id = s.get(Job, first).team_id
    payload = b"the same product bytes " * 500
    old_job, sha = _published_job(rt, team_id, payload)
    assert api.delete(f"/v1/jobs/{old_job}").status_code == 204
    _age(rt.blobs.path(sha), 100 * HOUR)
    touched, go_on, new_job, swept = threading.Event(), threading.Event(), [], []

    def slow_writer():
        with rt.blobs.adding():
            sha_again, size = rt.blobs.put_bytes(payload)
            touched.set()
            go_on.wait(10)
            new_job.append(_job_row(rt, team_id, sha_again, size))

    def janitor_run():
        swept.append(janitor.sweep_blobs(settings, rt.Session, rt.blobs, time.time() + 100 * HOUR))

    writer = threading.Thread(target=slow_writer, daemon=True)
    writer.start()
    assert touched.wait(10)
    sweeper = threading.Thread(target=janitor_run, daemon=True)
    sweeper.start()
    sweeper.join(timeout=0.5)
    assert sweeper.is_alive() and not swept  # it waits for the writer's commit
    go_on.set()
    writer.join(timeout=10)
    sweeper.join(timeout=10)
    assert swept == [0] and rt.blobs.exists(sha) and new_job
    janitor.sweep(settings, rt.Session, rt.blobs, now=time.time() + 100 * HOUR)
    assert rt.blobs.exists(sha)  # referenced now: never removed
    assert api.get(f"/v1/jobs/{new_job[0]}/products/out.txt").content == payload


def test_a_product_whose_blob_went_while_the_job_ran_fails_the_attempt(api, settings):
    """A job that outran GNSSATT_JOB_TIME_S may find the janitor took a product's blob: it must not publish a
    row pointing to nothing; the attempt fails with a message naming the product and the setting."""
    from worker.runner import _publish_success

    class _Ctx:
        products = {"out.txt": type("Rec", (), {"name": "out.txt", "sha256": "0" * 64})()}

    with pytest.raises(RuntimeError, match=r"out\.txt.*GNSSATT_JOB_TIME_S"):
        _publish_success(api.rt, "0123456789abcdef", "token", _Ctx())
