"""Keeping PCV maps: the map JSON as a blob, a row naming it as the next version of `name` for a team."""
from __future__ import annotations

import json
from typing import TYPE_CHECKING

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from core.blobs import BlobStore
from core.models import PcvMap

if TYPE_CHECKING:  # the grid arrives parsed; core imports no numerics
    from gnssatt.gnss.io.pcv_map import PcvMap as PcvGrid


class PcvFieldTooLong(ValueError):
    """A map's platform, antenna id or frequency is longer than its column holds."""

    def __init__(self, field: str, limit: int, value: str):
        super().__init__(f"{field} is {len(value)} characters long; at most {limit} are kept")
        self.field = field


def check_fits(grid: PcvGrid) -> None:
    """Refuse (PcvFieldTooLong) what the pcv_maps columns cannot hold, on every database alike."""
    for field, value, column in (("platform", grid.platform, PcvMap.platform),
                                 ("pair.0", grid.first, PcvMap.first_antenna),
                                 ("pair.1", grid.second, PcvMap.second_antenna),
                                 ("frequency", grid.frequency, PcvMap.frequency)):
        limit = column.property.columns[0].type.length
        if len(value) > limit:
            raise PcvFieldTooLong(field, limit, value)


def add_pcv_map(session: Session, blobs: BlobStore, team_id: str, name: str, grid: PcvGrid,
                source_job_id: str | None = None) -> PcvMap:
    """Write the blob, add the row (not committed: the caller's transaction decides)."""
    check_fits(grid)
    sha, _ = blobs.put_bytes(json.dumps(grid.to_json(), separators=(",", ":")).encode())
    version = (session.execute(select(func.max(PcvMap.version)).where(PcvMap.team_id == team_id,
                                                                      PcvMap.name == name)).scalar() or 0) + 1
    row = PcvMap(team_id=team_id, name=name, version=version, platform=grid.platform, first_antenna=grid.first,
                 second_antenna=grid.second, frequency=grid.frequency, source_job_id=source_job_id, sha256=sha)
    session.add(row)
    session.flush()
    return row
