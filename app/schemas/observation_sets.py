from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, Field


class SetFilePublic(BaseModel):
    name: str = Field(description="Path of the file inside the set.")
    kind: str = Field(description="rinex_obs, rinex_nav, sp3, rinex_clock, antex, platform, stations, satellites, "
                      "antenna_pattern, reference_attitude, accelerometer, magnetometer, gyro or velocity")
    size_bytes: int
    sha256: str
    summary: dict[str, Any] = Field(description="What the file holds: format, version, time span, satellites...")


class ObservationSetPublic(BaseModel):
    id: str
    name: str | None
    platform_name: str | None
    created_at: datetime
    total_bytes: int
    files: list[SetFilePublic]
    summary: dict[str, Any] = Field(description="Set-level summary: antennas matched to files, time span, warnings.")
