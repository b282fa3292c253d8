"""Database fixtures for the db tests: `db_url` runs a test on a fresh SQLite file and, when
env RIG_TEST_PG_URL names a PostgreSQL database, on a fresh schema there too (skipped with the
reason otherwise). Import the fixture into a test module: `from db_fixtures import db_url`."""

from __future__ import annotations

import os
import uuid
from contextlib import contextmanager
from pathlib import Path

import pytest

PG_ENV = "RIG_TEST_PG_URL"


def pg_base_url() -> str | None:
    return os.environ.get(PG_ENV) or None


@contextmanager
def empty_database(kind: str, directory: Path):
    """URL of an empty database of `kind`: a SQLite file in `directory`, or a new PostgreSQL
    schema (dropped afterwards; the test is skipped with the reason when no server is named)."""
    if kind == "sqlite":
        yield f"sqlite:///{directory / 'rig.sqlite'}"
        return
    base = pg_base_url()
    if not base:
        pytest.skip(f"PostgreSQL tests need a server: set {PG_ENV}=postgresql+psycopg://"
                    "user@127.0.0.1:PORT/DB (.ci/run does)")
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    schema = f"t_{uuid.uuid4().hex[:12]}"
    admin = create_engine(base)
    with admin.begin() as conn:
        conn.execute(text(f'CREATE SCHEMA "{schema}"'))
    url = make_url(base).update_query_dict({"options": f"-csearch_path={schema}"})
    try:
        yield url.render_as_string(hide_password=False)
    finally:
        with admin.begin() as conn:
            conn.execute(text(f'DROP SCHEMA "{schema}" CASCADE'))
        admin.dispose()


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path):
    """URL of an empty database: a SQLite file, or a new PostgreSQL schema (dropped after)."""
    with empty_database(request.param, tmp_path) as url:
        yield url
