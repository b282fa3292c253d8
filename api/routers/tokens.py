"""/tokens: create (the secret is shown once), list, revoke API tokens. Admin role."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, ConfigDict, Field
from sqlalchemy import select

from api.deps import Admin, ERRORS, Id, StoreDep
from db.jobs import aware_utc
from db.models import ApiToken

router = APIRouter(prefix="/tokens", tags=["tokens"], responses=ERRORS)


class TokenRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=200)
    role: Literal["viewer", "operator", "admin"]


@router.post("", status_code=201, summary="Create a token; its secret is returned only here")
def create(body: TokenRequest, store: StoreDep, _: Admin) -> dict[str, Any]:
    from db.tokens import PREFIX_LEN, create_token
    secret = create_token(store, body.name, [body.role])
    with store.ReadSession() as s:
        tid = s.execute(select(ApiToken.id).where(
            ApiToken.prefix == secret[:PREFIX_LEN]).order_by(ApiToken.id.desc())).scalar()
    return {"id": tid, "name": body.name, "role": body.role, "token": secret}


@router.get("", summary="List tokens (prefix only, never the secret)")
def list_tokens(store: StoreDep, _: Admin) -> list[dict[str, Any]]:
    with store.ReadSession() as s:
        rows = s.execute(select(ApiToken).order_by(ApiToken.id)).scalars().all()
        return [{"id": t.id, "name": t.name, "prefix": t.prefix, "scopes": t.scopes,
                 "created_at": aware_utc(t.created_at), "last_used_at": aware_utc(t.last_used_at),
                 "revoked_at": aware_utc(t.revoked_at)} for t in rows]


@router.delete("/{token_id}", status_code=204, summary="Revoke a token")
def revoke(token_id: Id, store: StoreDep, _: Admin) -> None:
    from db.tokens import revoke_token
    if not revoke_token(store, token_id):
        raise HTTPException(404, f"no live token {token_id}")
