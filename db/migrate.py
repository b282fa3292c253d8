"""Schema migrations (Alembic, scripts in db/migrations): `upgrade(url)` brings a database to
the newest revision; `current(url)` tells where it is. `rig db upgrade` calls upgrade."""

from __future__ import annotations

from pathlib import Path

from db.engine import database_url

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"


def alembic_config(url: str | None = None):
    """Alembic Config pointing at db/migrations and the database URL (no alembic.ini needed)."""
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("sqlalchemy.url", database_url(url).replace("%", "%%"))
    return cfg


def head_revision() -> str:
    """The newest revision in db/migrations/versions."""
    from alembic.script import ScriptDirectory

    return ScriptDirectory.from_config(alembic_config("sqlite://")).get_current_head()


def current(url: str | None = None) -> str | None:
    """Revision the database is at (None: never migrated)."""
    from sqlalchemy import inspect, text

    from db.engine import make_engine, reader

    engine = make_engine(url)
    try:
        with reader(engine).connect() as conn:
            if not inspect(conn).has_table("alembic_version"):
                return None
            return conn.execute(text("SELECT version_num FROM alembic_version")).scalar()
    finally:
        engine.dispose()


def upgrade(url: str | None = None, revision: str = "head") -> str:
    """Migrate the database to `revision` (default the newest); returns the revision reached."""
    from alembic import command

    command.upgrade(alembic_config(url), revision)
    return current(url) or ""
