"""The SQL schema (SQLAlchemy 2 models). Migrations in db/migrations follow it; a test checks
that the migrated database and these models agree.

Samples are stored per *page*: a run of consecutive samples (split where the phase changes, so
a page lies in one phase) holds, per channel, one binary block (little-endian float64, NaN =
missing; text channels as a JSON list, null = missing) plus that block's statistics: count of
valid samples, Σ(x−ref), Σ(x−ref)² (ref = the channel's first valid value, so variances do not
cancel), min, max. Missing samples = the pages' sample count − the valid count. Whole runs load as a few thousand blobs; per-phase mean,
variance, min, max and counts are plain SQL aggregates over the statistics rows.
"""

from __future__ import annotations

from datetime import datetime, timezone
from typing import Any, get_args

from sqlalchemy import (JSON, DateTime, Float, ForeignKey, ForeignKeyConstraint, Index, Integer,
                        LargeBinary, MetaData, String, Text, UniqueConstraint)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from core.documents import ExitStatus

NAMING = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

RUN_STATUSES = ("running", "finished", "interrupted")
EXIT_STATUSES: tuple[str, ...] = get_args(ExitStatus)
JOB_STATUSES = ("queued", "running", "succeeded", "failed", "cancelled")


def utcnow() -> datetime:
    return datetime.now(timezone.utc)


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING)


class Rig(Base):
    """A test rig (or the emulator, or another lab's rig whose records were imported)."""
    __tablename__ = "rigs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    kind: Mapped[str | None] = mapped_column(String(40))
    description: Mapped[str | None] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Run(Base):
    """One run: metadata as given (JSON, verbatim), lifecycle status ('running', 'finished',
    'interrupted'), the writer's exit status ('success', 'abort', 'fail') and reason, and the
    live writer's identity and heartbeat (to tell a dead writer's run)."""
    __tablename__ = "runs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    rig_id: Mapped[int | None] = mapped_column(ForeignKey("rigs.id", ondelete="SET NULL"))
    scheme: Mapped[int | None] = mapped_column(Integer, index=True)
    source: Mapped[str | None] = mapped_column(String(20), index=True)
    status: Mapped[str] = mapped_column(String(20), index=True)
    exit_status: Mapped[str | None] = mapped_column(String(20))
    reason: Mapped[str | None] = mapped_column(Text)
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    started_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True), index=True)
    stopped_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    heartbeat_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    writer_host: Mapped[str | None] = mapped_column(String(255))
    writer_pid: Mapped[int | None] = mapped_column(Integer)
    writer_token: Mapped[str | None] = mapped_column(String(64))
    n_samples: Mapped[int] = mapped_column(Integer, default=0)
    n_pages: Mapped[int] = mapped_column(Integer, default=0)
    t_last: Mapped[float | None] = mapped_column(Float)
    imported_from: Mapped[str | None] = mapped_column(Text)


class Channel(Base):
    """One channel of a run: name, unit, source (device or file it came from), kind ('float',
    'text', or 'phase' — the phase lives in the pages' `phase` column) and its statistics
    reference value `ref` (first valid value)."""
    __tablename__ = "channels"
    __table_args__ = (UniqueConstraint("run_id", "name"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"), index=True)
    name: Mapped[str] = mapped_column(String(200))
    unit: Mapped[str] = mapped_column(String(40), default="")
    source: Mapped[str | None] = mapped_column(String(200))
    kind: Mapped[str] = mapped_column(String(10), default="float")
    position: Mapped[int] = mapped_column(Integer)
    ref: Mapped[float | None] = mapped_column(Float)


class SamplePage(Base):
    """Samples i0 .. i0+n−1 of a run (t0..t1 [s]), all in one phase (NULL: no phase)."""
    __tablename__ = "sample_pages"
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True)
    seq: Mapped[int] = mapped_column(Integer, primary_key=True)
    i0: Mapped[int] = mapped_column(Integer)
    n: Mapped[int] = mapped_column(Integer)
    t0: Mapped[float] = mapped_column(Float)
    t1: Mapped[float] = mapped_column(Float)
    phase: Mapped[str | None] = mapped_column(String(20))


class SampleBlock(Base):
    """One channel's samples on one page, with their statistics (see the module doc).
    A channel without a block on a page has all its samples there missing."""
    __tablename__ = "sample_blocks"
    __table_args__ = (
        ForeignKeyConstraint(["run_id", "seq"], ["sample_pages.run_id", "sample_pages.seq"],
                             ondelete="CASCADE"),
    )
    run_id: Mapped[int] = mapped_column(Integer, primary_key=True)
    seq: Mapped[int] = mapped_column(Integer, primary_key=True)
    channel_id: Mapped[int] = mapped_column(ForeignKey("channels.id", ondelete="CASCADE"),
                                            primary_key=True)
    n_valid: Mapped[int] = mapped_column(Integer)
    s1: Mapped[float | None] = mapped_column(Float)
    s2: Mapped[float | None] = mapped_column(Float)
    vmin: Mapped[float | None] = mapped_column(Float)
    vmax: Mapped[float | None] = mapped_column(Float)
    # last: SQLite reads the columns before a large blob without walking its overflow pages,
    # so the aggregates never touch the samples
    data: Mapped[bytes] = mapped_column(LargeBinary)


Index("ix_sample_blocks_channel_id", SampleBlock.channel_id)


class Interruption(Base):
    """An interruption of a run as data: interlock trip, lost drive, reconnect gap, lost writer.
    t_start/t_end in run time [s] (t_end NULL while open or unknown)."""
    __tablename__ = "interruptions"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"), index=True)
    kind: Mapped[str] = mapped_column(String(40))
    t_start: Mapped[float | None] = mapped_column(Float)
    t_end: Mapped[float | None] = mapped_column(Float)
    reason: Mapped[str | None] = mapped_column(Text)
    detail: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Job(Base):
    """A unit of heavy work (identification, diagnosis, report) run by a worker process."""
    __tablename__ = "jobs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    kind: Mapped[str] = mapped_column(String(40))
    status: Mapped[str] = mapped_column(String(20), index=True, default="queued")
    params: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    run_id: Mapped[int | None] = mapped_column(ForeignKey("runs.id", ondelete="SET NULL"))
    worker: Mapped[str | None] = mapped_column(String(255))
    progress: Mapped[float | None] = mapped_column(Float)
    error: Mapped[str | None] = mapped_column(Text)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    started_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    finished_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    heartbeat_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    idempotency_key: Mapped[str | None] = mapped_column(String(200), unique=True)
    attempts: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    worker_pid: Mapped[int | None] = mapped_column(Integer)


class Result(Base):
    """An identification result (estimator.result.Fit.as_dict() as `fit`, draws optional as a
    float64 blob of shape `draws_shape`), linked to the runs it used via result_runs."""
    __tablename__ = "results"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    job_id: Mapped[int | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"))
    model: Mapped[str] = mapped_column(String(100))
    method: Mapped[str] = mapped_column(String(40))
    fit: Mapped[dict[str, Any]] = mapped_column(JSON)
    draws: Mapped[bytes | None] = mapped_column(LargeBinary)
    draws_shape: Mapped[list[int] | None] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class ResultRun(Base):
    """Which runs a result used and how ('train', 'test')."""
    __tablename__ = "result_runs"
    result_id: Mapped[int] = mapped_column(ForeignKey("results.id", ondelete="CASCADE"),
                                           primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True)
    role: Mapped[str] = mapped_column(String(20), primary_key=True, default="train")


class RigModel(Base):
    """A stored fit marked as the rig's current model (the newest mark is the current one;
    earlier marks stay as its history). The console's live twin predicts with it."""
    __tablename__ = "rig_models"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    result_id: Mapped[int] = mapped_column(ForeignKey("results.id", ondelete="CASCADE"))
    marked_by: Mapped[str] = mapped_column(String(200))
    marked_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Report(Base):
    """A rendered report (HTML, JSON, PNG...) about a run or a result."""
    __tablename__ = "reports"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    kind: Mapped[str] = mapped_column(String(40))
    title: Mapped[str] = mapped_column(String(300))
    run_id: Mapped[int | None] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"))
    result_id: Mapped[int | None] = mapped_column(ForeignKey("results.id", ondelete="CASCADE"))
    media_type: Mapped[str] = mapped_column(String(100))
    content: Mapped[bytes] = mapped_column(LargeBinary)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class ApiToken(Base):
    """An API token, stored only as its SHA-256 hash (db/tokens.py); `prefix` identifies it in
    listings without revealing it. `expires_at` NULL: never expires."""
    __tablename__ = "api_tokens"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    token_hash: Mapped[str] = mapped_column(String(64), unique=True)
    prefix: Mapped[str] = mapped_column(String(16))
    scopes: Mapped[list[str]] = mapped_column(JSON, default=list)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    last_used_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    revoked_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    expires_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
