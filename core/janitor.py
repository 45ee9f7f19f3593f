"""The janitor: what a killed process or a deleted row leaves on disk is removed, and never what a row needs.

- `staging/<upload>/`: an upload whose API process died (kill -9 mid-upload); removed once nothing in it was
  written for GNSSATT_JANITOR_GRACE_S (a live upload writes at least every megabyte).
- `work/<job>-<attempt>/`: the scratch directory of an attempt that is no longer running (its worker was
  killed); removed once the job row says that attempt is over and the directory is a minute old.
- `blobs/ab/cd/<sha256>`: a blob no row points to (set files, products, PCV maps, fan-out results and shared
  objects), untouched for the grace period plus the longest a job may run (GNSSATT_JOB_TIME_S: a running
  job's products are referenced only once it succeeds). The janitor reads the references and deletes under the
  blob store's exclusive lock, while an upload holds the shared lock from its first blob until its rows commit
  (`BlobStore.adding`, core/blobs.py): an upload that re-uses an old blob either re-creates it after the
  janitor removed it, or the janitor sees its committed rows and leaves the blob alone, however slow the upload.
  A job's products are touched again under the shared lock as its success commits (worker/runner.py); one
  whose blob went meanwhile (the job outran GNSSATT_JOB_TIME_S) fails the attempt instead of publishing it.

The janitor alone deletes blobs. Deleting a job or a set (by its team) only drops the rows and `release`s their
blobs: they are touched, so the grace period counts from the deletion (a download that read its row just before
still finds the file), and the next sweep after it takes those no other row points to.

Every worker runs `sweep` from its reaper thread every few minutes; concurrent sweeps are harmless.
"""
from __future__ import annotations

import logging
import os
import shutil
import time
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from core.blobs import BlobStore
from core.models import Job, JobTask, PcvMap, Product, SetFile
from core.settings import Settings

log = logging.getLogger("gnssatt.janitor")

WORKDIR_GRACE_S = 60.0


def _newest_mtime(root: Path) -> float:
    newest = root.stat().st_mtime
    for dirpath, _dirs, files in os.walk(root):
        for name in files:
            try:
                newest = max(newest, os.stat(os.path.join(dirpath, name)).st_mtime)
            except FileNotFoundError:
                continue
    return newest


def sweep_staging(settings: Settings, now: float) -> int:
    removed = 0
    if not settings.staging_dir.is_dir():
        return 0
    for entry in settings.staging_dir.iterdir():
        try:
            if entry.is_dir() and _newest_mtime(entry) < now - settings.janitor_grace_s:
                shutil.rmtree(entry, ignore_errors=True)
                removed += 1
        except FileNotFoundError:  # finished (and removed) meanwhile
            continue
    return removed


def sweep_workdirs(settings: Settings, Session: sessionmaker[Session], now: float) -> int:
    root = settings.data_dir / "work"
    if not root.is_dir():
        return 0
    candidates: dict[str, list[tuple[Path, int]]] = {}
    for entry in root.iterdir():
        job_id, _, attempt = entry.name.rpartition("-")
        try:
            if entry.is_dir() and attempt.isdigit() and entry.stat().st_mtime < now - WORKDIR_GRACE_S:
                candidates.setdefault(job_id, []).append((entry, int(attempt)))
        except FileNotFoundError:
            continue
    if not candidates:
        return 0
    with Session() as s:
        live = {job_id: attempts for job_id, attempts in s.execute(
            select(Job.id, Job.attempts).where(Job.id.in_(list(candidates)), Job.state == "running")).all()}
    removed = 0
    for job_id, dirs in candidates.items():
        for path, attempt in dirs:
            if live.get(job_id) != attempt:
                shutil.rmtree(path, ignore_errors=True)
                removed += 1
    return removed


def referenced_blobs(Session: sessionmaker[Session]) -> set[str]:
    """Every sha256 a row points to."""
    with Session() as s:
        refs = set(s.execute(select(SetFile.sha256)).scalars())
        refs |= set(s.execute(select(Product.sha256)).scalars())
        refs |= set(s.execute(select(PcvMap.sha256)).scalars())
        refs |= {r for r in s.execute(select(JobTask.result_sha256)).scalars() if r}
        for payload in s.execute(select(JobTask.payload)).scalars():
            if isinstance(payload, dict) and isinstance(payload.get("_shared_sha256"), str):
                refs.add(payload["_shared_sha256"])
    return refs


def release(blobs: BlobStore, shas) -> int:
    """Start the grace period of blobs whose rows were just deleted: touch each one still there, under the
    store's shared lock (as a new blob is); returns how many. Nothing is deleted here: `sweep_blobs` does that."""
    touched = 0
    with blobs.lock(exclusive=False):
        for sha in set(shas):
            try:
                os.utime(blobs.path(sha))
                touched += 1
            except FileNotFoundError:
                continue
    return touched


def sweep_blobs(settings: Settings, Session: sessionmaker[Session], blobs: BlobStore, now: float) -> int:
    grace_s = settings.janitor_grace_s + settings.job_time_s
    old: list[Path] = []
    for path in blobs.root.glob("??/??/*"):
        try:
            if path.stat().st_mtime < now - grace_s:
                old.append(path)
        except FileNotFoundError:
            continue
    tmp_dir = blobs.root / "tmp"
    if tmp_dir.is_dir():  # half-written blobs of a process that died mid-write
        for path in tmp_dir.iterdir():
            try:
                if path.stat().st_mtime < now - grace_s:
                    path.unlink(missing_ok=True)
            except FileNotFoundError:
                continue
    if not old:
        return 0
    removed = 0
    with blobs.lock(exclusive=True):  # the references are read under it: see `BlobStore.adding`
        refs = referenced_blobs(Session)
        for path in old:
            if path.name in refs:
                continue
            try:
                if path.stat().st_mtime < now - grace_s:  # not touched by an upload since we looked
                    path.unlink()
                    removed += 1
            except FileNotFoundError:
                continue
    return removed


def sweep(settings: Settings, Session: sessionmaker[Session], blobs: BlobStore,
          now: float | None = None) -> dict[str, int]:
    """One pass over staging, work directories and blobs; returns what was removed."""
    now = time.time() if now is None else now
    counts = {"staging": sweep_staging(settings, now), "workdirs": sweep_workdirs(settings, Session, now),
              "blobs": sweep_blobs(settings, Session, blobs, now)}
    if any(counts.values()):
        log.info("janitor removed %s", counts)
    return counts
