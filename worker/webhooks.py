"""Webhook delivery (issue 24): when a job ends (succeeded, failed, cancelled) and carries a webhook, POST a JSON
notice to its URL, signed with HMAC-SHA256, retried with exponential backoff; every attempt is recorded
(core.webhook_models.WebhookDelivery) and the hook's state set to delivered or failed.

Signature (as GitHub and Stripe do it): header `X-Gnssatt-Signature: sha256=<hex>` where hex is
HMAC-SHA256(secret, f"{timestamp}.{body}") and `X-Gnssatt-Timestamp` is the POSIX time of the attempt; a
receiver recomputes it over the raw body and refuses stale timestamps. `X-Gnssatt-Delivery` names the notice
(the same for every retry of it, also after a restart). Delivery runs in a daemon thread of the worker, so a slow
receiver never holds a job slot.

Exactly one sender per attempt (issue 22): each attempt first takes the hook's lease with a conditional UPDATE
(state pending, lease free or expired, backoff over), sends, then records the attempt and frees the lease in one
transaction that checks the lease is still its own. Between attempts the lease is free and `next_attempt_at`
holds the backoff, so a hook whose worker died (mid-POST: after its lease, GNSSATT_WEBHOOK_LEASE_S; while
waiting: when the backoff ends) is resent by any worker's reaper (`resend_pending`) and by one of them only. A
worker killed after the receiver answered but before the record commits makes the receiver see that attempt
again, with the same X-Gnssatt-Delivery id, so it can drop the repeat.
"""
from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import socket
import threading
import time
import uuid
from dataclasses import dataclass
from datetime import datetime, timedelta

from sqlalchemy import func, or_, select, update
from sqlalchemy.exc import IntegrityError

from core.models import Job, Product, utcnow
from core.webhook_models import JobWebhook, WebhookDelivery

log = logging.getLogger("gnssatt.webhooks")
#: seconds before retry 1, 2, ...: 1, 2, 4, 8, 16 (six attempts in ~31 s); GNSSATT_WEBHOOK_BACKOFF_S="a,b,..."
DEFAULT_BACKOFF_S = (1.0, 2.0, 4.0, 8.0, 16.0)
#: per phase (connect, write, read) of one POST
TIMEOUT_S = 10.0
#: a sender's lease on one attempt: longer than the three phases of a POST; GNSSATT_WEBHOOK_LEASE_S
DEFAULT_LEASE_S = 60.0
TERMINAL = ("succeeded", "failed", "cancelled")
#: at most this many hooks resent per reaper pass
RESEND_BATCH = 100


def backoff_s() -> tuple[float, ...]:
    raw = os.environ.get("GNSSATT_WEBHOOK_BACKOFF_S")
    if not raw:
        return DEFAULT_BACKOFF_S
    return tuple(float(x) for x in raw.split(",") if x.strip())


def lease_s() -> float:
    raw = os.environ.get("GNSSATT_WEBHOOK_LEASE_S")
    return float(raw) if raw else DEFAULT_LEASE_S


def signature(secret: str, timestamp: str, body: bytes) -> str:
    """'sha256=<hex>' of HMAC-SHA256(secret, timestamp + '.' + body) (RFC 2104)."""
    mac = hmac.new(secret.encode(), timestamp.encode() + b"." + body, hashlib.sha256)
    return "sha256=" + mac.hexdigest()


def notice(session, job_id: str) -> dict | None:
    """The JSON notice of a finished job, or None when the job is gone or not finished."""
    job = session.get(Job, job_id)
    if job is None or job.state not in TERMINAL:
        return None
    products = [p.name for p in session.query(Product).filter(Product.job_id == job_id).order_by(Product.name)]
    return {"event": "job.finished", "job": {
        "id": job.id, "type": job.type, "state": job.state, "created_at": str(job.created_at),
        "finished_at": str(job.finished_at), "error": job.error, "url": f"/v1/jobs/{job.id}",
        "page": f"/ui/jobs/{job.id}", "products": products}}


@dataclass(frozen=True)
class Claim:
    """One attempt a sender holds the lease of."""
    url: str
    secret: str
    delivery_id: str
    attempt: int
    body: bytes


def _due(now: datetime) -> tuple:
    """Conditions of a hook some sender may take now: pending, lease free or expired, backoff over, job ended."""
    return (JobWebhook.state == "pending",
            or_(JobWebhook.lease_until.is_(None), JobWebhook.lease_until < now),
            or_(JobWebhook.next_attempt_at.is_(None), JobWebhook.next_attempt_at <= now),
            JobWebhook.job_id.in_(select(Job.id).where(Job.state.in_(TERMINAL))))


def claim(Session, job_id: str, owner: str, now: datetime | None = None) -> Claim | None:
    """Take the lease of the hook's next attempt (UPDATE ... WHERE due), or None when it is not due or another
    sender holds it; two senders racing for one hook cannot both get rowcount 1."""
    now = now or utcnow()
    with Session.begin() as s:
        res = s.execute(update(JobWebhook).where(JobWebhook.job_id == job_id, *_due(now)).values(
            claimed_by=owner, lease_until=now + timedelta(seconds=lease_s()),
            delivery_id=func.coalesce(JobWebhook.delivery_id, uuid.uuid4().hex))
            .execution_options(synchronize_session=False))
        if res.rowcount != 1:
            return None
        hook = s.get(JobWebhook, job_id)
        body = json.dumps(notice(s, job_id), separators=(",", ":"), default=str).encode()
        return Claim(url=hook.url, secret=hook.secret, delivery_id=hook.delivery_id, attempt=hook.attempts + 1,
                     body=body)


def _http_post(url: str, content: bytes, headers: dict):
    import httpx

    return httpx.post(url, content=content, headers=headers, timeout=TIMEOUT_S)


def send(post, c: Claim) -> tuple[int | None, str | None, int]:
    """POST the claimed attempt; (status code or None, error or None when 2xx, duration in ms)."""
    ts = str(int(time.time()))
    headers = {"Content-Type": "application/json", "User-Agent": "gnssatt-webhook/1",
               "X-Gnssatt-Event": "job.finished", "X-Gnssatt-Delivery": c.delivery_id,
               "X-Gnssatt-Timestamp": ts, "X-Gnssatt-Signature": signature(c.secret, ts, c.body)}
    t0 = time.perf_counter()
    status, error = None, None
    try:
        resp = post(c.url, c.body, headers)
        status = resp.status_code
        if not 200 <= status < 300:
            error = f"HTTP {status}: {resp.text[:200]}"
    except Exception as exc:  # noqa: BLE001 - any transport failure is a failed attempt, recorded
        error = f"{exc.__class__.__name__}: {exc}"[:500]
    return status, error, int((time.perf_counter() - t0) * 1000)


def record(Session, job_id: str, owner: str, c: Claim, status: int | None, error: str | None,
           duration_ms: int) -> dict | None:
    """Record the attempt and free the lease; the hook's new values, or None when the lease was no longer ours
    (the attempt is still recorded: it was sent) or the job is gone."""
    now = utcnow()
    delays = backoff_s()
    ok, last = error is None, c.attempt >= len(delays) + 1
    values = {"attempts": c.attempt, "claimed_by": None, "lease_until": None,
              "state": "delivered" if ok else ("failed" if last else "pending"),
              "next_attempt_at": None if ok or last else now + timedelta(seconds=delays[c.attempt - 1])}
    try:
        with Session.begin() as s:
            res = s.execute(update(JobWebhook).where(JobWebhook.job_id == job_id, JobWebhook.claimed_by == owner)
                            .values(**values).execution_options(synchronize_session=False))
            s.add(WebhookDelivery(job_id=job_id, attempt=c.attempt, at=now, status_code=status, ok=ok,
                                  error=error, duration_ms=duration_ms))
    except IntegrityError:  # the job was deleted meanwhile: nothing left to record
        return None
    if res.rowcount != 1:
        log.warning("webhook of job %s: attempt %d outlived its lease; another sender took over", job_id, c.attempt)
        return None
    return values


def deliver(Session, job_id: str, post=None, sleep=time.sleep, owner: str | None = None) -> str:
    """Send the job's notice, one leased attempt at a time, until a 2xx answer, the attempts run out or another
    sender holds the hook; returns the hook's state when this sender stops."""
    owner = owner or f"{socket.gethostname()}:{os.getpid()}/{uuid.uuid4().hex[:12]}"
    post = post or _http_post
    while (c := claim(Session, job_id, owner)) is not None:
        status, error, duration_ms = send(post, c)
        after = record(Session, job_id, owner, c, status, error, duration_ms)
        if after is None or after["state"] != "pending":
            break
        log.info("webhook of job %s attempt %d failed: %s", job_id, c.attempt, error)
        sleep(max(0.0, (after["next_attempt_at"] - utcnow()).total_seconds()) + 0.005)
    with Session() as s:
        hook = s.get(JobWebhook, job_id)
        return hook.state if hook is not None else "none"


_inflight: set[str] = set()
_inflight_lock = threading.Lock()


def _start(Session, job_id: str) -> threading.Thread | None:
    """Deliver in a daemon thread unless this process is delivering that hook already."""
    with _inflight_lock:
        if job_id in _inflight:
            return None
        _inflight.add(job_id)
    t = threading.Thread(target=_deliver_logged, args=(Session, job_id), name=f"webhook-{job_id[:8]}",
                         daemon=True)
    t.start()
    return t


def notify_finished(rt, job_id: str) -> threading.Thread | None:
    """Start the delivery of a finished job's webhook in a daemon thread (None when the job has none)."""
    with rt.Session() as s:
        if s.get(JobWebhook, job_id) is None:
            return None
    return _start(rt.Session, job_id)


def resend_pending(rt, now: datetime | None = None) -> int:
    """Start the delivery of every hook due now (its worker died mid-POST or while waiting out the backoff, or
    its thread never started); returns how many were started. Run from every worker's reaper."""
    now = now or utcnow()
    with rt.Session() as s:
        due = s.execute(select(JobWebhook.job_id).where(*_due(now)).order_by(JobWebhook.created_at)
                        .limit(RESEND_BATCH)).scalars().all()
    return sum(_start(rt.Session, job_id) is not None for job_id in due)


def _deliver_logged(Session, job_id: str) -> None:
    try:
        deliver(Session, job_id)
    except Exception:  # noqa: BLE001 - a delivery never takes the worker down
        log.exception("webhook delivery of job %s broke", job_id)
    finally:
        with _inflight_lock:
            _inflight.discard(job_id)
