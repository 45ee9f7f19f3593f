from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator


class PcvMapCreate(BaseModel):
    """Upload of a map made elsewhere: the CONVENTIONS.md JSON object, or ANTEX-style text as gnssatt writes it."""

    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=200, pattern=r"^[A-Za-z0-9 _.:+-]+$",
                      description="Map name; uploading the same name again makes a new version.")
    map: dict[str, Any] | None = Field(None, description="One map as CONVENTIONS.md JSON.")
    antex: str | None = Field(None, max_length=4_000_000,
                              description="ANTEX-style text holding exactly one map (the whole JSON body is "
                                          "limited to GNSSATT_MAX_JSON_BODY_BYTES).")

    @model_validator(mode="after")
    def _one_source(self) -> "PcvMapCreate":
        if (self.map is None) == (self.antex is None):
            raise ValueError("give exactly one of `map` (JSON) or `antex` (text)")
        return self


class PcvMapPublic(BaseModel):
    id: str
    name: str
    version: int
    platform: str
    pair: list[str]
    frequency: str
    source_job_id: str | None
    created_at: datetime
    n_bins: int
    n_filled: int
    url_json: str
    url_antex: str
