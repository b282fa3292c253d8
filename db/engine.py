"""Engine and sessions from one URL setting.

`RIG_DB_URL` names the database (SQLAlchemy URL); by default a SQLite file
`./rig-data/rig.sqlite`. PostgreSQL works through the same setting
(`postgresql+psycopg://user@host:port/db`).

SQLite is set up for several writer processes (architecture.md, measured here): WAL journal,
every write transaction opened with `BEGIN IMMEDIATE` (through SQLAlchemy's connect/begin hooks,
with pysqlite's own transaction handling switched off) so read-modify-write never loses an
update, a busy timeout so writers wait instead of failing, `synchronous=FULL` so a committed
page survives a power cut too, and foreign keys on. Read-only work can open its transaction
with `BEGIN DEFERRED` (`readonly=True`) so it does not queue behind writers.
"""

from __future__ import annotations

import os
from pathlib import Path

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

DEFAULT_DATA_DIR = Path("rig-data")
BUSY_TIMEOUT_S = 60.0
"""How long a SQLite writer waits for the write lock before failing [s]."""


def database_url(url: str | None = None) -> str:
    """The database URL: `url` if given, else env RIG_DB_URL, else ./rig-data/rig.sqlite."""
    if url:
        return url
    env = os.environ.get("RIG_DB_URL")
    if env:
        return env
    return f"sqlite:///{(DEFAULT_DATA_DIR / 'rig.sqlite').resolve()}"


def is_sqlite(engine_or_url: Engine | str) -> bool:
    url = engine_or_url.url if isinstance(engine_or_url, Engine) else make_url(engine_or_url)
    return url.get_backend_name() == "sqlite"


def make_engine(url: str | None = None, **kwargs) -> Engine:
    """A SQLAlchemy engine for `url` (see database_url) with the SQLite settings above; the
    SQLite file's directory is created when missing."""
    url = database_url(url)
    if not is_sqlite(url):
        return create_engine(url, pool_pre_ping=True, **kwargs)
    path = make_url(url).database
    if path and path != ":memory:" and not path.startswith("file:"):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(url, connect_args={"timeout": BUSY_TIMEOUT_S}, **kwargs)

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_conn, _record) -> None:
        dbapi_conn.isolation_level = None  # pysqlite must not BEGIN by itself: we do, below
        cur = dbapi_conn.cursor()
        cur.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
        cur.execute("PRAGMA journal_mode = WAL")
        cur.execute("PRAGMA synchronous = FULL")
        cur.execute("PRAGMA foreign_keys = ON")
        cur.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn) -> None:
        mode = conn.get_execution_options().get("sqlite_begin", "IMMEDIATE")
        conn.exec_driver_sql(f"BEGIN {mode}")

    return engine


def reader(engine: Engine) -> Engine:
    """The same engine (same pool) whose transactions start `BEGIN DEFERRED` on SQLite: for
    reads that must not wait for, nor block, writers. A no-op option elsewhere."""
    return engine.execution_options(sqlite_begin="DEFERRED")


def session_factory(engine: Engine, readonly: bool = False) -> sessionmaker[Session]:
    """ORM sessions bound to `engine` (reader(engine) when readonly)."""
    return sessionmaker(bind=reader(engine) if readonly else engine, expire_on_commit=False)
