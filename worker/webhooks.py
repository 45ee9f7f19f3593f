"""Webhook delivery (issue 24): when a job ends (succeeded, failed, cancelled) and carries a webhook, POST a JSON
notice to its URL, signed with HMAC-SHA256, retried with exponential backoff; every attempt is recorded
(core.webhook_models.WebhookDelivery) and the hook's state set to delivered or failed.

Signature (as GitHub and Stripe do it): header `X-Gnssatt-Signature: sha256=<hex>` where hex is
HMAC-SHA256(secret, f"{timestamp}.{body}") and `X-Gnssatt-Timestamp` is the POSIX time of the attempt; a
receiver recomputes it over the raw body and refuses stale timestamps. `X-Gnssatt-Delivery` names the notice
(the same for every retry of it). Delivery runs in a daemon thread of the worker, so a slow receiver never holds
a job slot; a worker that dies mid-retry leaves the hook `pending` (not resent: at most once per attempt).
"""
from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import threading
import time
import uuid

from core.models import Job, Product, utcnow
from core.webhook_models import JobWebhook, WebhookDelivery

log = logging.getLogger("gnssatt.webhooks")
#: seconds before retry 1, 2, ...: 1, 2, 4, 8, 16 (six attempts in ~31 s); GNSSATT_WEBHOOK_BACKOFF_S="a,b,..."
DEFAULT_BACKOFF_S = (1.0, 2.0, 4.0, 8.0, 16.0)
TIMEOUT_S = 10.0
TERMINAL = ("succeeded", "failed", "cancelled")


def backoff_s() -> tuple[float, ...]:
    raw = os.environ.get("GNSSATT_WEBHOOK_BACKOFF_S")
    if not raw:
        return DEFAULT_BACKOFF_S
    return tuple(float(x) for x in raw.split(",") if x.strip())


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


def deliver(Session, job_id: str, post=None, sleep=time.sleep) -> str:
    """Send the job's notice until a 2xx answer or the attempts run out; returns the hook's final state."""
    import httpx

    with Session() as s:
        hook = s.get(JobWebhook, job_id)
        if hook is None or hook.state != "pending":
            return hook.state if hook is not None else "none"
        url, secret = hook.url, hook.secret
        body = json.dumps(notice(s, job_id), separators=(",", ":"), default=str).encode()
    delivery_id = uuid.uuid4().hex
    post = post or (lambda u, content, headers: httpx.post(u, content=content, headers=headers, timeout=TIMEOUT_S))
    delays = backoff_s()
    state = "failed"
    for attempt in range(1, len(delays) + 2):
        ts = str(int(time.time()))
        headers = {"Content-Type": "application/json", "User-Agent": "gnssatt-webhook/1",
                   "X-Gnssatt-Event": "job.finished", "X-Gnssatt-Delivery": delivery_id,
                   "X-Gnssatt-Timestamp": ts, "X-Gnssatt-Signature": signature(secret, ts, body)}
        t0 = time.perf_counter()
        status, error = None, None
        try:
            resp = post(url, body, headers)
            status = resp.status_code
            if not 200 <= status < 300:
                error = f"HTTP {status}: {resp.text[:200]}"
        except Exception as exc:  # noqa: BLE001 - any transport failure is a failed attempt, recorded
            error = f"{exc.__class__.__name__}: {exc}"[:500]
        ok = error is None
        with Session.begin() as s:
            s.add(WebhookDelivery(job_id=job_id, attempt=attempt, at=utcnow(), status_code=status, ok=ok,
                                  error=error, duration_ms=int((time.perf_counter() - t0) * 1000)))
            hook = s.get(JobWebhook, job_id)
            if hook is not None:
                hook.attempts = attempt
                if ok or attempt == len(delays) + 1:
                    hook.state = "delivered" if ok else "failed"
        if ok:
            state = "delivered"
            break
        log.info("webhook of job %s attempt %d failed: %s", job_id, attempt, error)
        if attempt <= len(delays):
            sleep(delays[attempt - 1])
    return state


def notify_finished(rt, job_id: str) -> threading.Thread | None:
    """Start the delivery of a finished job's webhook in a daemon thread (None when the job has none)."""
    with rt.Session() as s:
        if s.get(JobWebhook, job_id) is None:
            return None
    t = threading.Thread(target=_deliver_logged, args=(rt.Session, job_id), name=f"webhook-{job_id[:8]}",
                         daemon=True)
    t.start()
    return t


def _deliver_logged(Session, job_id: str) -> None:
    try:
        deliver(Session, job_id)
    except Exception:  # noqa: BLE001 - a delivery never takes the worker down
        log.exception("webhook delivery of job %s broke", job_id)
