"""Request dependencies: the database session and the caller's team (from the API key)."""
from __future__ import annotations

from typing import Annotated, Iterator

from fastapi import Depends, Request
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy.orm import Session

from app.keys import team_for_key
from app.problems import ProblemError
from core.models import Team
from core.settings import Settings

bearer_scheme = HTTPBearer(auto_error=False, description="API key as a bearer token")
api_key_scheme = APIKeyHeader(name="X-API-Key", auto_error=False, description="API key")


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


def get_session(request: Request) -> Iterator[Session]:
    with request.app.state.Session() as session:
        yield session


SettingsDep = Annotated[Settings, Depends(get_settings)]
SessionDep = Annotated[Session, Depends(get_session)]


def get_team(request: Request, session: SessionDep,
             bearer: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer_scheme)],
             api_key: Annotated[str | None, Depends(api_key_scheme)]) -> Team:
    key = bearer.credentials if bearer is not None else api_key
    if not key:
        key = request.cookies.get("gnssatt_key")
    if not key:
        raise ProblemError(401, "unauthorized", "API key required",
                           "Send your API key as 'Authorization: Bearer KEY' or 'X-API-Key: KEY'. "
                           "An operator mints keys with 'gnssatt admin create-key --team NAME'.")
    team = team_for_key(session, key)
    if team is None:
        raise ProblemError(401, "unauthorized", "Invalid API key",
                           "This API key is unknown or revoked. Ask your operator for a new one.")
    return team


TeamDep = Annotated[Team, Depends(get_team)]
