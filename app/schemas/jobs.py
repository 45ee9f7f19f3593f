from __future__ import annotations

import math
from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

JobState = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class JobCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    type: str = Field(description="A job type from GET /v1/job-types.", min_length=1, max_length=60)
    observation_set_ids: list[str] = Field(default_factory=list, max_length=10000)
    config: dict[str, Any] = Field(default_factory=dict, description="Validated against the type's config schema.")
    webhook_url: str | None = Field(None, max_length=2000, description="http(s) URL sent an HMAC-signed POST "
                                    "when the job ends (app/webhooks.py, worker/webhooks.py).")
    webhook_secret: str | None = Field(None, max_length=200, description="HMAC-SHA256 key of the webhook's "
                                       "X-Gnssatt-Signature (16-200 characters); made by the server when omitted.")

    @field_validator("config")
    @classmethod
    def _finite(cls, value: dict[str, Any]) -> dict[str, Any]:
        """NaN and Infinity (which Python's JSON reader accepts) are no JSON numbers: refused everywhere."""
        stack = [value]
        while stack:
            item = stack.pop()
            if isinstance(item, dict):
                stack.extend(item.values())
            elif isinstance(item, list):
                stack.extend(item)
            elif isinstance(item, float) and not math.isfinite(item):
                raise ValueError(f"{item} is not a JSON number; give a finite value")
        return value


class JobPublic(BaseModel):
    id: str
    type: str
    state: JobState
    progress: float = Field(ge=0, le=1)
    stage: str | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    attempts: int
    error: dict[str, Any] | None = Field(description="RFC 9457 problem document of a failed job.")
    config: dict[str, Any]
    observation_set_ids: list[str]
    webhook_secret: str | None = Field(None, description="The webhook's HMAC key, only in the answer to the submit "
                                       "that made it (no webhook_secret given).")


class ProductPublic(BaseModel):
    name: str
    media_type: str
    size_bytes: int
    sha256: str
    url: str


class JobTypePublic(BaseModel):
    name: str
    title: str
    description: str
    min_sets: int
    max_sets: int | None
    produces: list[str]
    config_schema: dict[str, Any]
