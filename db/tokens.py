"""API tokens: random secrets shown once, stored only as their SHA-256 hash (a token has 256
bits of entropy, so a fast hash is enough; no salt is needed against guessing)."""

from __future__ import annotations

import hashlib
import secrets

from sqlalchemy import select

from db.models import ApiToken, utcnow
from db.store import Store

PREFIX_LEN = 8


def hash_token(token: str) -> str:
    """Hex SHA-256 of a token (what the database stores)."""
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def create_token(store: Store, name: str, scopes: list[str] | None = None) -> str:
    """Create a token named `name`; returns the secret (never stored, shown once)."""
    token = secrets.token_urlsafe(32)
    with store.Session.begin() as s:
        s.add(ApiToken(name=name, token_hash=hash_token(token), prefix=token[:PREFIX_LEN],
                       scopes=list(scopes or []), created_at=utcnow()))
    return token


def verify_token(store: Store, token: str) -> ApiToken | None:
    """The live (not revoked) token row matching `token`, its last use updated; else None."""
    with store.Session.begin() as s:
        row = s.execute(select(ApiToken).where(ApiToken.token_hash == hash_token(token),
                                               ApiToken.revoked_at.is_(None))).scalar_one_or_none()
        if row is not None:
            row.last_used_at = utcnow()
        return row


def revoke_token(store: Store, token_id: int) -> bool:
    """Revoke a token by id; False when there is no such live token."""
    with store.Session.begin() as s:
        row = s.get(ApiToken, token_id)
        if row is None or row.revoked_at is not None:
            return False
        row.revoked_at = utcnow()
        return True
