"""/tokens: create (the secret is shown once), list, revoke API tokens. Admin role."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, HTTPException, Query, Response
from pydantic import BaseModel, ConfigDict, Field
from sqlalchemy import select

from api.answers import TokenCreated, TokenInfo
from api.auth import ROLES
from api.deps import Admin, ERRORS, Id, MAX_ID, StoreDep
from db.jobs import aware_utc
from db.models import ApiToken
from db.tokens import MAX_LIFETIME_S

router = APIRouter(prefix="/tokens", tags=["tokens"], responses=ERRORS)


class TokenRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=200)
    role: Literal[ROLES]
    expires_in_s: float | None = Field(
        None, gt=0, le=MAX_LIFETIME_S,
        description="lifetime [s] from now; the token is refused (401) after it (default: never)")


@router.post("", status_code=201, summary="Create a token; its secret is returned only here",
             response_model=TokenCreated)
def create(body: TokenRequest, store: StoreDep, _: Admin) -> dict[str, Any]:
    from db.tokens import PREFIX_LEN, create_token
    secret = create_token(store, body.name, [body.role], expires_in_s=body.expires_in_s)
    with store.ReadSession() as s:
        tid, expires = s.execute(select(ApiToken.id, ApiToken.expires_at).where(
            ApiToken.prefix == secret[:PREFIX_LEN]).order_by(ApiToken.id.desc())).first()
    return {"id": tid, "name": body.name, "role": body.role, "token": secret,
            "expires_at": aware_utc(expires)}


@router.get("", summary="List tokens (prefix only, never the secret)",
            response_model=list[TokenInfo])
def list_tokens(store: StoreDep, _: Admin, response: Response,
                limit: int = Query(100, ge=1, le=1000), offset: int = Query(0, ge=0, le=MAX_ID)
                ) -> list[dict[str, Any]]:
    """Oldest first, `limit` from `offset`; the number of tokens in all is in the
    `X-Total-Count` header."""
    from db.tokens import list_tokens as page_of_tokens
    rows, total = page_of_tokens(store, limit, offset)
    response.headers["X-Total-Count"] = str(total)
    return rows


@router.delete("/{token_id}", status_code=204, summary="Revoke a token")
def revoke(token_id: Id, store: StoreDep, _: Admin) -> None:
    from db.tokens import revoke_token
    if not revoke_token(store, token_id):
        raise HTTPException(404, f"no live token {token_id}")
