"""db/tokens.py: checking a token is a read; its last use is written at most once per
LAST_USED_RESOLUTION_S, so requests do not each take the database's write lock."""

from __future__ import annotations

from datetime import timedelta, timezone

from db_fixtures import db_url  # noqa: F401  (fixture)
from sqlalchemy import event, select

from db.models import ApiToken, utcnow
from db.store import Store
from db.tokens import LAST_USED_RESOLUTION_S, create_token, revoke_token, verify_token


def _stored_last_used(store: Store, token_id: int):
    with store.engine.connect() as conn:
        v = conn.execute(select(ApiToken.last_used_at).where(ApiToken.id == token_id)).scalar()
    return v.replace(tzinfo=timezone.utc) if v is not None and v.tzinfo is None else v


def test_last_used_is_written_at_most_once_per_resolution(db_url):
    with Store(db_url) as store:
        writes: list[str] = []

        @event.listens_for(store.engine, "before_cursor_execute")
        def _count(conn, cursor, statement, params, context, executemany):
            if statement.lstrip().upper().startswith("UPDATE API_TOKENS"):
                writes.append(statement)

        token = create_token(store, "load", ["viewer"])
        t0 = utcnow()
        row = verify_token(store, token, now=t0)                 # first use: written
        assert row is not None and row.last_used_at == t0 and len(writes) == 1
        assert abs(_stored_last_used(store, row.id) - t0) < timedelta(milliseconds=1)

        for k in range(20):                                     # within the resolution: reads only
            later = t0 + timedelta(seconds=LAST_USED_RESOLUTION_S * k / 20)
            again = verify_token(store, token, now=later)
            assert again is not None and again.id == row.id and again.scopes == ["viewer"]
        assert len(writes) == 1
        assert abs(_stored_last_used(store, row.id) - t0) < timedelta(milliseconds=1)

        t1 = t0 + timedelta(seconds=LAST_USED_RESOLUTION_S + 1)  # past it: written again
        assert verify_token(store, token, now=t1).last_used_at == t1 and len(writes) == 2
        assert abs(_stored_last_used(store, row.id) - t1) < timedelta(milliseconds=1)

        # a stale 'now' (another process already wrote a later time) never moves it back
        assert verify_token(store, token, now=t0 + timedelta(seconds=LAST_USED_RESOLUTION_S * 1.5))
        assert abs(_stored_last_used(store, row.id) - t1) < timedelta(milliseconds=1)


def test_revocation_still_takes_effect_at_once(db_url):
    with Store(db_url) as store:
        token = create_token(store, "gone", ["viewer"])
        row = verify_token(store, token)
        assert row is not None
        assert revoke_token(store, row.id)
        assert verify_token(store, token) is None               # no cached answer in between
        assert verify_token(store, "not-a-token") is None


def test_a_token_is_refused_from_its_expiry_on(db_url):
    import pytest

    with Store(db_url) as store:                         # migrated: the expires_at column exists
        token = create_token(store, "week", ["viewer"], expires_in_s=7 * 86400)
        forever = create_token(store, "forever", ["viewer"])
        row = verify_token(store, token)
        assert row is not None
        expires = row.expires_at if row.expires_at.tzinfo else row.expires_at.replace(
            tzinfo=timezone.utc)
        assert abs(expires - (utcnow() + timedelta(days=7))) < timedelta(minutes=1)
        assert verify_token(store, token, now=expires - timedelta(seconds=1)) is not None
        assert verify_token(store, token, now=expires) is None
        assert verify_token(store, token, now=expires + timedelta(days=400)) is None
        assert verify_token(store, forever, now=utcnow() + timedelta(days=3650)) is not None
        for bad in (0.0, -1.0, float("nan"), float("inf"), 1e12):
            with pytest.raises(ValueError):
                create_token(store, "bad", ["viewer"], expires_in_s=bad)


def test_parse_duration():
    import pytest

    from db.tokens import parse_duration

    assert parse_duration("90s") == 90 and parse_duration("30m") == 1800
    assert parse_duration("12h") == 43200 and parse_duration("7d") == 7 * 86400
    assert parse_duration("2w") == 14 * 86400 and parse_duration("45") == 45
    assert parse_duration(" 1.5H ") == 5400
    for bad in ("", "d", "7x", "0d", "-1h", "nan", "inf", "nand", "100000d"):
        with pytest.raises(ValueError):
            parse_duration(bad)


def test_token_listing_pages(db_url):
    from db.tokens import list_tokens

    with Store(db_url) as store:
        for k in range(5):
            create_token(store, f"t{k}", ["viewer"], expires_in_s=60.0 if k == 2 else None)
        rows, total = list_tokens(store, limit=2, offset=1)
        assert total == 5 and [r["name"] for r in rows] == ["t1", "t2"]
        assert rows[1]["expires_at"] is not None and rows[0]["expires_at"] is None
        assert "token_hash" not in rows[0]
        rows, total = list_tokens(store)
        assert total == 5 and len(rows) == 5
