"""The typed form of a calibration job's baselines.json (CONVENTIONS.md "Output: calibrated baselines") as the
attitude job accepts it in `calibrated_baselines`: wrong types or values are a 422 at submit, not a failing job."""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

#: body-frame vector components of a rigid platform's baselines, metres (10 km: far beyond any platform)
Component_m = Annotated[float, Field(ge=-1e4, le=1e4)]
Vector_m = Annotated[list[Component_m], Field(min_length=3, max_length=3)]
Sigma_m = Annotated[list[Annotated[float, Field(ge=0.0, le=1e4)]], Field(min_length=3, max_length=3)]


class CalibratedBaseline(BaseModel):
    model_config = ConfigDict(extra="allow", populate_by_name=True, serialize_by_alias=True)
    from_: str = Field(alias="from", min_length=1, max_length=100, description="First antenna id.")
    to: str = Field(min_length=1, max_length=100, description="Second antenna id.")
    calibrated_m: Vector_m = Field(description="Calibrated baseline, body frame, first to second antenna (m).")
    a_priori_m: Vector_m | None = Field(None, description="A priori baseline the calibration started from, body "
                                                         "frame (m).")
    sigma_m: Sigma_m | None = Field(None, description="Sigma of each calibrated component, body frame (m).")
    n_epochs: int | None = Field(None, ge=0, le=10**9, description="Number of epochs the calibration used.")


class CalibratedBaselines(BaseModel):
    model_config = ConfigDict(extra="allow", serialize_by_alias=True)
    platform: str | None = Field(None, max_length=300, description="Platform the calibration was made for.")
    frames: Literal["body"] = Field("body", description="Frame of the vectors: body (the only one).")
    baselines: list[CalibratedBaseline] = Field(min_length=1, max_length=64)
