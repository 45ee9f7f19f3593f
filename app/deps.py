"""Request dependencies: the database session and the caller's team (from the API key)."""
from __future__ import annotations

from typing import Annotated, Callable, Iterator

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
    # End the read transaction: the connection goes back to the pool now, not when the request ends, so a
    # long request (a slow upload, an event stream) never holds one while it waits on its client.
    session.commit()
    return team


TeamDep = Annotated[Team, Depends(get_team)]


KEY_REVOKED = {"type": "https://gnssatt.dev/problems/unauthorized", "title": "Invalid API key", "status": 401,
               "detail": "This API key was revoked while the stream was open."}


def key_checker(request: Request, team_id: str) -> Callable[[Session], bool]:
    """A check that the request's API key is still valid for `team_id` (long-lived streams call it again)."""
    from app.limits import request_key

    headers = {k.lower(): v for k, v in request.headers.items()}
    key = request_key(headers, headers.get("cookie"))

    def still_allowed(session: Session) -> bool:
        team = team_for_key(session, key) if key else None
        return team is not None and team.id == team_id

    return still_allowed
