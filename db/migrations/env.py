"""Alembic environment for the rig database: runs the migrations in db/migrations/versions on
the URL set in the Alembic config (db/migrate.py fills it from RIG_DB_URL), through the same
engine settings as the application (SQLite: BEGIN IMMEDIATE, so concurrent upgrades serialise;
PostgreSQL: a transaction-scoped advisory lock does the same)."""

from __future__ import annotations

from alembic import context

from db.engine import is_sqlite, make_engine
from db.models import Base

MIGRATION_LOCK_KEY = 4_242_001
"""PostgreSQL advisory-lock key held while migrating."""


def run_migrations_online() -> None:
    config = context.config
    connection = config.attributes.get("connection")
    if connection is not None:
        _run(connection)
        return
    engine = make_engine(config.get_main_option("sqlalchemy.url"))
    try:
        with engine.connect() as conn:
            _run(conn)
    finally:
        engine.dispose()


def _run(connection) -> None:
    context.configure(connection=connection, target_metadata=Base.metadata,
                      render_as_batch=is_sqlite(connection.engine), compare_type=True)
    with context.begin_transaction():
        if not is_sqlite(connection.engine):
            connection.exec_driver_sql(f"SELECT pg_advisory_xact_lock({MIGRATION_LOCK_KEY})")
        context.run_migrations()


if context.is_offline_mode():
    raise SystemExit("offline (SQL script) migrations are not supported; use `rig db upgrade`")
run_migrations_online()
