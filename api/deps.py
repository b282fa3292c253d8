"""FastAPI dependencies and their Annotated aliases: the store, the settings, and the caller's
token checked for a role (401 without a valid token, 403 with too low a role)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from fastapi import Depends, HTTPException, Path, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api.auth import allows, role_of
from api.settings import Settings
from db.store import Store

_bearer = HTTPBearer(auto_error=False)


def get_store(request: Request) -> Store:
    return request.app.state.store


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


StoreDep = Annotated[Store, Depends(get_store)]
SettingsDep = Annotated[Settings, Depends(get_settings)]


@dataclass(frozen=True)
class Caller:
    """The authenticated caller: its token id, name and role."""
    token_id: int
    name: str
    role: str


def current_caller(store: StoreDep,
                   cred: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]) -> Caller:
    """The caller of a valid, unrevoked token with a role; 401 otherwise."""
    from db.tokens import verify_token

    row = verify_token(store, cred.credentials) if cred is not None else None
    role = role_of(row.scopes) if row is not None else None
    if row is None or role is None:
        raise HTTPException(401, "a valid API token is required (Authorization: Bearer TOKEN)",
                            headers={"WWW-Authenticate": "Bearer"})
    return Caller(token_id=row.id, name=row.name, role=role)


def check_role(caller: Caller, role: str, what: str = "this") -> None:
    """403 unless the caller holds at least `role` (for checks that depend on the request,
    e.g. the target of a scheme)."""
    if not allows(caller.role, role):
        raise HTTPException(403, f"{what} needs the {role!r} role; the token has {caller.role!r}")


def require(role: str):
    """A dependency: the caller, who must hold at least `role` (403 otherwise)."""
    def dep(caller: Annotated[Caller, Depends(current_caller)]) -> Caller:
        check_role(caller, role)
        return caller
    return dep


Viewer = Annotated[Caller, Depends(require("viewer"))]
Operator = Annotated[Caller, Depends(require("operator"))]
Admin = Annotated[Caller, Depends(require("admin"))]


ERRORS = {401: {"description": "no valid API token"},
          403: {"description": "the token's role is too low"},
          404: {"description": "no such resource"},
          413: {"description": "request body too large"},
          422: {"description": "invalid request"}}
"""Error answers every router documents (the OpenAPI schema lists them)."""

MAX_ID = 2**31 - 1
"""Largest row id accepted (SQL INTEGER on every backend)."""
Id = Annotated[int, Path(ge=1, le=MAX_ID)]
"""A row id in a URL path."""
