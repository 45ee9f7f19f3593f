"""Rows of job webhooks (issue 24): a job may carry a URL that is sent an HMAC-signed POST when the job ends;
every attempt of that delivery is recorded (app/webhooks.py shows them, worker/webhooks.py sends them).

A pending hook is sent by whoever holds its lease (`claimed_by` until `lease_until`), taken with a conditional
UPDATE, so a hook left behind by a dead worker is resent by another and never by two (issue 22)."""
from __future__ import annotations

from datetime import datetime

from sqlalchemy import Boolean, ForeignKey, Integer, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from core.models import Base, UTCDateTime, new_id, utcnow


class JobWebhook(Base):
    __tablename__ = "job_webhooks"
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    url: Mapped[str] = mapped_column(String(2000))
    secret: Mapped[str] = mapped_column(String(200))
    #: pending (not sent yet or retrying), delivered (a 2xx answer), failed (every attempt failed)
    state: Mapped[str] = mapped_column(String(16), default="pending", index=True)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    #: the X-Gnssatt-Delivery id, fixed at the first attempt and kept by every retry (also after a restart)
    delivery_id: Mapped[str | None] = mapped_column(String(32))
    #: the sender holding the lease (worker name + a token per delivery), and until when
    claimed_by: Mapped[str | None] = mapped_column(String(200))
    lease_until: Mapped[datetime | None] = mapped_column(UTCDateTime())
    #: the earliest time of the next attempt (the backoff after a failed one); None: at once
    next_attempt_at: Mapped[datetime | None] = mapped_column(UTCDateTime())


class WebhookDelivery(Base):
    __tablename__ = "webhook_deliveries"
    id: Mapped[str] = mapped_column(String(32), primary_key=True, default=new_id)
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    attempt: Mapped[int] = mapped_column(Integer)
    at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    status_code: Mapped[int | None] = mapped_column(Integer)
    ok: Mapped[bool] = mapped_column(Boolean, default=False)
    error: Mapped[str | None] = mapped_column(Text)
    duration_ms: Mapped[int] = mapped_column(Integer, default=0)
