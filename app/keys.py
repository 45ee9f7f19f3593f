"""API keys: minted once, shown once, stored only as SHA-256 (keys are 256-bit random, so no salt needed)."""
from __future__ import annotations

import hashlib
import secrets

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import ApiKey, Team, utcnow

KEY_PREFIX = "gk_"


def hash_key(key: str) -> str:
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


def create_key(session: Session, team_name: str, label: str | None = None) -> tuple[str, ApiKey]:
    """Mint a key for a team (created when new); returns (the key in clear, its row)."""
    team = session.execute(select(Team).where(Team.name == team_name)).scalar_one_or_none()
    if team is None:
        team = Team(name=team_name)
        session.add(team)
        session.flush()
    key = KEY_PREFIX + secrets.token_urlsafe(32)
    row = ApiKey(team_id=team.id, prefix=key[:10], key_sha256=hash_key(key), label=label)
    session.add(row)
    session.flush()
    return key, row


def revoke_key(session: Session, key_or_prefix: str) -> int:
    """Revoke the key given in clear, or every key whose 10-character prefix matches; returns the count."""
    rows = session.execute(select(ApiKey).where(
        (ApiKey.key_sha256 == hash_key(key_or_prefix)) | (ApiKey.prefix == key_or_prefix[:10]),
        ApiKey.revoked_at.is_(None))).scalars().all()
    if len(key_or_prefix) < 10:
        rows = []
    for row in rows:
        row.revoked_at = utcnow()
    return len(rows)


def team_for_key(session: Session, key: str) -> Team | None:
    row = session.execute(select(ApiKey).where(ApiKey.key_sha256 == hash_key(key),
                                               ApiKey.revoked_at.is_(None))).scalar_one_or_none()
    return row.team if row is not None else None
