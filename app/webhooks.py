"""Job webhooks on the API side (issue 24): POST /v1/jobs takes `webhook_url` (http or https) and optionally
`webhook_secret` (the HMAC key; without one the server makes one and returns it once, in the 202 answer);
GET /v1/jobs/{id}/webhook shows the hook's state and every delivery attempt (status, error, duration). The
worker sends the notice (worker/webhooks.py)."""
from __future__ import annotations

import secrets
from datetime import datetime
from urllib.parse import urlsplit

from fastapi import APIRouter
from pydantic import BaseModel

from app.deps import SessionDep, TeamDep
from app.problems import Problem, ProblemError
from core.models import Job
from core.webhook_models import JobWebhook, WebhookDelivery

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])


class DeliveryPublic(BaseModel):
    attempt: int
    at: datetime
    status_code: int | None
    ok: bool
    error: str | None
    duration_ms: int


class WebhookPublic(BaseModel):
    url: str
    state: str
    attempts: int
    deliveries: list[DeliveryPublic]


def check_url(url: str) -> str:
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname or len(url) > 2000:
        raise ProblemError(422, "invalid-webhook-url", "Invalid webhook URL",
                           f"webhook_url must be an absolute http(s) URL of at most 2000 characters; got {url[:200]!r}.",
                           field="webhook_url")
    return url


def check_webhook(url: str | None, secret: str | None) -> None:
    """422 for a webhook_url that is not an absolute http(s) URL, a secret without a URL, or a secret of the
    wrong length; nothing for no webhook at all."""
    if not url:
        if secret:
            raise ProblemError(422, "invalid-webhook-url", "webhook_secret without webhook_url",
                               "Give webhook_url with webhook_secret.", field="webhook_url")
        return
    check_url(url)
    if secret is not None and not 16 <= len(secret) <= 200:
        raise ProblemError(422, "invalid-webhook-secret", "Invalid webhook secret",
                           "webhook_secret must be 16 to 200 characters.", field="webhook_secret")


def register(session, job: Job, url: str | None, secret: str | None) -> str | None:
    """Attach a webhook to a new job (flushed, before its commit; check_webhook has passed); returns the secret
    when the server made it."""
    check_webhook(url, secret)
    if not url:
        return None
    made = None
    if not secret:
        secret = made = secrets.token_urlsafe(32)
    session.add(JobWebhook(job_id=job.id, url=url, secret=secret, state="pending", attempts=0))
    return made


def webhook_view(session, job_id: str) -> WebhookPublic | None:
    hook = session.get(JobWebhook, job_id)
    if hook is None:
        return None
    rows = session.query(WebhookDelivery).filter(WebhookDelivery.job_id == job_id).order_by(
        WebhookDelivery.attempt).all()
    return WebhookPublic(url=hook.url, state=hook.state, attempts=hook.attempts,
                         deliveries=[DeliveryPublic(attempt=r.attempt, at=r.at, status_code=r.status_code, ok=r.ok,
                                                    error=r.error, duration_ms=r.duration_ms) for r in rows])


ERRORS = {401: {"model": Problem}, 404: {"model": Problem}, 422: {"model": Problem}}


@router.get("/{job_id}/webhook", response_model=WebhookPublic, responses=ERRORS,
            summary="A job's webhook and its deliveries")
def get_webhook(job_id: str, team: TeamDep, session: SessionDep) -> WebhookPublic:
    job = session.get(Job, job_id)
    if job is None or job.team_id != team.id:
        raise ProblemError(404, "not-found", "Job not found", f"No job with id {job_id!r} is visible to your team.")
    view = webhook_view(session, job_id)
    if view is None:
        raise ProblemError(404, "not-found", "No webhook", "This job was submitted without a webhook_url.")
    return view
