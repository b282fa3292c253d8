"""The run store: save, load, list and summarise runs in the SQL database (db/models.py).

`Store(url)` opens the database named by the URL setting (db/engine.py), brings its schema to
the newest migration and marks runs left 'running' by a dead writer as 'interrupted'. Whole
runs load as numpy arrays or a RunData; per-phase statistics come from SQL aggregates over the
pages' statistics rows, so reports never load samples.
"""

from __future__ import annotations

import os
import socket
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any, Iterable, Iterator

import numpy as np
import pandas as pd
from sqlalchemy import and_, func, insert, null, select, update

from db.engine import make_engine, reader, session_factory
from db.models import (EXIT_STATUSES, Channel, Interruption, ResultRun, Rig, Run, SampleBlock,
                       SamplePage, utcnow)
from db.pages import (PAGE_SAMPLES, ChannelRef, PageShare, assemble, block_values, channel_kind,
                      decimation_stride, decode_float, in_range_positions, page_coverage,
                      write_pages)
from core.channels import PHASES, unit_of
from core.run import RunData
from core.runfile import validate_meta, validate_samples

STALE_AFTER_S = 30.0
"""A running run whose writer is on another host and has not committed for this long is
taken as interrupted [s] (a live writer commits at least every few seconds)."""


PAGES_PER_READ = 32
"""Pages fetched per query by a range read (32 float blocks of 128 KiB: 4 MiB at most held)."""


class RunNotFound(KeyError):
    pass


@dataclass
class RangeRead:
    """The samples of a run a range read returns (Store.select_range): the channels in the
    order asked, how many samples lie in the time range, the stride over them (`every`), the
    number returned per channel (`n`) and, per page holding any, which of its samples."""
    run_id: int
    channels: list[ChannelRef]
    n_in_range: int
    every: int
    n: int
    pages: list[PageShare]


def _aware(dt: datetime | None) -> datetime | None:
    """SQLite hands back naive datetimes: they were stored in UTC."""
    if dt is not None and dt.tzinfo is None:
        return dt.replace(tzinfo=timezone.utc)
    return dt


def _parse_started(meta: dict[str, Any]) -> datetime | None:
    v = meta.get("started_at")
    if not isinstance(v, str):
        return None
    try:
        dt = datetime.fromisoformat(v.replace("Z", "+00:00"))
    except ValueError:
        return None
    return _aware(dt)


def process_token(pid: int) -> str | None:
    """A token identifying a live process (its start time in clock ticks since boot, from
    /proc), None when no such live process (gone, or a zombie). Guards against PID reuse."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        if not Path("/proc/self/stat").exists():  # no procfs: fall back to a signal probe
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                return None
            except PermissionError:
                return "alive"
            return "alive"
        return None
    fields = stat[stat.rindex(")") + 2:].split()
    if fields[0] in ("Z", "X"):
        return None
    return fields[19]


def writer_identity() -> dict[str, Any]:
    """Host, pid and process token of this process, stored on the runs it writes."""
    pid = os.getpid()
    return {"writer_host": socket.gethostname(), "writer_pid": pid,
            "writer_token": process_token(pid)}


class Store:
    """The SQL run store. `url`: SQLAlchemy URL (default: env RIG_DB_URL or
    ./rig-data/rig.sqlite). `upgrade`: migrate the schema to the newest revision on open.
    `recover`: mark runs of dead writers 'interrupted' on open."""

    def __init__(self, url: str | None = None, *, upgrade: bool = True, recover: bool = True):
        from db.engine import database_url
        self.url = database_url(url)
        if upgrade:
            from db.migrate import current, head_revision, upgrade as do_upgrade
            if current(self.url) != head_revision():
                do_upgrade(self.url)
        self.engine = make_engine(self.url)
        self.Session = session_factory(self.engine)
        self.ReadSession = session_factory(self.engine, readonly=True)
        if recover:
            self.recover_interrupted()

    def close(self) -> None:
        self.engine.dispose()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --- writing -----------------------------------------------------------------------------

    def rig_id(self, conn, name: str | None, kind: str | None = None) -> int | None:
        """Id of the rig named `name`, created when new (safe under concurrent writers)."""
        if not name:
            return None
        dialect = conn.engine.dialect.name
        if dialect == "postgresql":
            from sqlalchemy.dialects.postgresql import insert as dinsert
        elif dialect == "sqlite":
            from sqlalchemy.dialects.sqlite import insert as dinsert
        else:  # pragma: no cover - only SQLite and PostgreSQL are supported
            raise RuntimeError(f"unsupported database {dialect}")
        conn.execute(dinsert(Rig).values(name=name, kind=kind, created_at=utcnow())
                     .on_conflict_do_nothing(index_elements=["name"]))
        return conn.execute(select(Rig.id).where(Rig.name == name)).scalar_one()

    def create_channels(self, conn, run_id: int, specs: Iterable[tuple[str, str, str | None, str]],
                        first_position: int = 0) -> list[ChannelRef]:
        """Insert channel rows (name, unit, source, kind) for a run; returns their refs."""
        refs = []
        for k, (name, unit, source, kind) in enumerate(specs):
            cid = conn.execute(insert(Channel).values(
                run_id=run_id, name=name, unit=unit, source=source, kind=kind,
                position=first_position + k).returning(Channel.id)).scalar_one()
            refs.append(ChannelRef(name=name, id=cid, kind=kind))
        return refs

    def save_run(self, run: RunData, *, exit_status: str | None = None, reason: str | None = None,
                 imported_from: str | None = None, units: dict[str, str] | None = None,
                 sources: dict[str, str] | None = None, max_page: int = PAGE_SAMPLES) -> int:
        """Store a whole run in one transaction (all or nothing); returns its id. The run is
        validated first as run-format.md says (core.runfile; RunFileError when it breaks a rule).
        Units: `units` > meta['units'] > core.channels. Channel source: `sources` > the imported
        file's name > meta['source']."""
        if exit_status is not None and exit_status not in EXIT_STATUSES:
            raise ValueError(f"exit_status must be one of {EXIT_STATUSES}, got {exit_status!r}")
        label = imported_from or "<run>"
        df = validate_samples(run.samples, label)     # the interchange format's rules
        meta = dict(validate_meta(run.meta, label))
        meta_units = meta.get("units") if isinstance(meta.get("units"), dict) else {}
        default_source = Path(imported_from).name if imported_from else meta.get("source")
        cols: dict[str, Any] = {}
        specs = []
        for name in df.columns:
            kind = channel_kind(name, df[name])
            if kind == "float":
                cols[name] = df[name].to_numpy(dtype=float)
            else:
                cols[name] = df[name].to_numpy(dtype=object)  # non-text cells are missing
            unit = (units or {}).get(name) or meta_units.get(name) or unit_of(name)
            specs.append((name, unit, (sources or {}).get(name, default_source), kind))
        n = len(df)
        t = cols["t"]
        with self.engine.begin() as conn:
            rid = conn.execute(insert(Run).values(
                rig_id=self.rig_id(conn, meta.get("rig"), meta.get("source")),
                scheme=meta.get("scheme") if isinstance(meta.get("scheme"), int) else None,
                source=meta.get("source") if isinstance(meta.get("source"), str) else None,
                status="finished", exit_status=exit_status, reason=reason, meta=meta,
                started_at=_parse_started(meta), stopped_at=utcnow(), created_at=utcnow(),
                n_samples=n, n_pages=0, t_last=float(t[-1]) if n else None,
                imported_from=imported_from).returning(Run.id)).scalar_one()
            chans = self.create_channels(conn, rid, specs)
            n_pages = write_pages(conn, rid, chans, cols, seq0=0, i0=0, max_len=max_page)
            conn.execute(update(Run).where(Run.id == rid).values(n_pages=n_pages))
        return rid

    def update_run_meta(self, run_id: int, updates: dict[str, Any]) -> dict[str, Any]:
        """Merge `updates` into a run's metadata (read-modify-write under a row lock / SQLite's
        write lock, so concurrent updaters never lose each other's keys); returns the new meta."""
        with self.Session.begin() as s:
            run = s.execute(select(Run).where(Run.id == run_id).with_for_update()).scalar_one_or_none()
            if run is None:
                raise RunNotFound(run_id)
            run.meta = {**run.meta, **updates}
            return dict(run.meta)

    def recover_interrupted(self, stale_after_s: float = STALE_AFTER_S) -> list[int]:
        """Mark runs left 'running' by a writer that is gone as 'interrupted' (with a
        'writer_lost' interruption at the last stored sample). A writer on this host is gone
        when its process is; on another host when it has not committed for stale_after_s."""
        host = socket.gethostname()
        now = utcnow()
        with reader(self.engine).connect() as conn:
            rows = conn.execute(select(Run.id, Run.writer_host, Run.writer_pid, Run.writer_token,
                                       Run.heartbeat_at).where(Run.status == "running")).all()
        dead = []
        for rid, whost, pid, token, beat in rows:
            beat = _aware(beat)
            if whost == host and pid is not None:
                alive = process_token(pid)
                gone = alive is None or (token is not None and alive != "alive" and alive != token)
            else:
                gone = beat is None or now - beat > timedelta(seconds=stale_after_s)
            if gone:
                dead.append((rid, whost, pid, beat))
        marked = []
        for rid, whost, pid, beat in dead:
            with self.engine.begin() as conn:
                t_last = conn.execute(select(Run.t_last).where(Run.id == rid)).scalar()
                reason = (f"writer process {pid} on {whost} ended without stopping the run; "
                          f"last commit {beat.isoformat() if beat else 'never'}")
                res = conn.execute(update(Run).where(Run.id == rid, Run.status == "running")
                                   .values(status="interrupted", reason=reason,
                                           stopped_at=beat or now))
                if res.rowcount:
                    conn.execute(insert(Interruption).values(
                        run_id=rid, kind="writer_lost", t_start=t_last, t_end=None,
                        reason=reason, created_at=now))
                    marked.append(rid)
        return marked

    # --- reading -----------------------------------------------------------------------------

    def _run_row(self, s, run_id: int) -> Run:
        run = s.get(Run, run_id)
        if run is None:
            raise RunNotFound(f"no run {run_id}")
        return run

    def channel_refs(self, conn, run_id: int) -> list[ChannelRef]:
        rows = conn.execute(select(Channel.name, Channel.id, Channel.kind, Channel.ref)
                            .where(Channel.run_id == run_id).order_by(Channel.position)).all()
        return [ChannelRef(name=r[0], id=r[1], kind=r[2], ref=r[3]) for r in rows]

    def load_arrays(self, run_id: int, channels: Iterable[str] | None = None) -> dict[str, np.ndarray]:
        """Whole channels of a run: float64 arrays (NaN = missing) for numeric channels, object
        arrays (None = missing) for text and phase. `channels`: a subset (default all)."""
        with self.ReadSession() as s:
            conn = s.connection()
            n = self._run_row(s, run_id).n_samples
            chans = self.channel_refs(conn, run_id)
            if channels is not None:
                want = list(channels)
                missing = [c for c in want if c not in {ch.name for ch in chans}]
                if missing:
                    raise KeyError(f"run {run_id} has no channel(s) {missing}")
                chans = [ch for ch in chans if ch.name in want]
            pages = conn.execute(select(SamplePage.seq, SamplePage.i0, SamplePage.n, SamplePage.phase)
                                 .where(SamplePage.run_id == run_id)).all()
            blocks = _fetch_blocks(conn, run_id, None if channels is None else [c.id for c in chans])
        return assemble(n, pages, blocks, chans)

    def select_range(self, run_id: int, channels: Iterable[str] | None = None,
                     t_start: float | None = None, t_end: float | None = None,
                     every: int = 1, max_points: int | None = None) -> RangeRead:
        """Which samples a read of [t_start, t_end] (run time [s], None: open) of `channels`
        (default all) returns: every `every`-th sample in range, decimated further evenly to at
        most `max_points`. Reads no samples but the time blocks of the pages the range cuts
        through: a page's time statistics say whether it lies wholly inside or outside.
        RunNotFound for no run, KeyError for a channel the run lacks."""
        if every < 1 or (max_points is not None and max_points < 1):
            raise ValueError("every and max_points must be >= 1")
        with self.ReadSession() as s:
            conn = s.connection()
            self._run_row(s, run_id)
            refs = self.channel_refs(conn, run_id)
            by_name = {ch.name: ch for ch in refs}
            if channels is None:
                chans = refs
            else:
                want = list(dict.fromkeys(channels))
                missing = [c for c in want if c not in by_name]
                if missing:
                    raise KeyError(f"run {run_id} has no channel(s) {missing}")
                chans = [by_name[c] for c in want]
            tref = by_name.get("t")
            b = SampleBlock.__table__
            p = SamplePage.__table__
            on = and_(b.c.run_id == p.c.run_id, b.c.seq == p.c.seq,
                      b.c.channel_id == (tref.id if tref is not None else -1))
            rows = conn.execute(select(p.c.seq, p.c.n, p.c.phase, b.c.vmin, b.c.vmax, b.c.n_valid)
                                .select_from(p.outerjoin(b, on))
                                .where(p.c.run_id == run_id).order_by(p.c.seq)).all()
            cover = {r.seq: page_coverage(r.vmin, r.vmax, r.n_valid, r.n, t_start, t_end)
                     for r in rows}
            cut = [r.seq for r in rows if cover[r.seq] == "some"]
            positions: dict[int, np.ndarray] = {}
            for k in range(0, len(cut), PAGES_PER_READ):
                for _, seq, data in fetch_page_blocks(conn, run_id, [tref.id],
                                                      cut[k:k + PAGES_PER_READ]):
                    positions[seq] = in_range_positions(decode_float(data), t_start, t_end)
        counts = {r.seq: (r.n if cover[r.seq] == "all" else
                          positions[r.seq].size if r.seq in positions else 0) for r in rows}
        n_in_range = sum(counts.values())
        stride = decimation_stride(n_in_range, every, max_points or max(n_in_range, 1))
        pages, k0 = [], 0
        for r in rows:
            m = counts[r.seq]
            if m:
                first = (-k0) % stride
                keep = (np.arange(first, m, stride, dtype=np.int64) if cover[r.seq] == "all"
                        else positions[r.seq][first::stride].astype(np.int64))
                if keep.size:
                    pages.append(PageShare(seq=r.seq, n=r.n, phase=r.phase, keep=keep))
                k0 += m
        return RangeRead(run_id=run_id, channels=chans, n_in_range=n_in_range, every=stride,
                         n=sum(pg.keep.size for pg in pages), pages=pages)

    def range_values(self, sel: RangeRead, channel: ChannelRef,
                     pages_per_read: int = PAGES_PER_READ) -> Iterator[np.ndarray]:
        """The samples `sel` returns of one of its channels, as consecutive chunks (one per
        `pages_per_read` pages), reading only the blocks of the pages holding any: memory is
        bounded by one chunk whatever the run's length."""
        for k in range(0, len(sel.pages), pages_per_read):
            batch = sel.pages[k:k + pages_per_read]
            data: dict[int, bytes] = {}
            if channel.kind != "phase":
                with self.ReadSession() as s:
                    for _, seq, blob in fetch_page_blocks(s.connection(), sel.run_id, [channel.id],
                                                          [pg.seq for pg in batch]):
                        data[seq] = blob
            yield np.concatenate([block_values(channel, pg, data.get(pg.seq)) for pg in batch])

    def load_run(self, run_id: int) -> RunData:
        """A stored run as RunData: samples in the stored channel order, meta as stored."""
        arrays = self.load_arrays(run_id)
        with self.ReadSession() as s:
            meta = dict(self._run_row(s, run_id).meta)
        samples = pd.DataFrame({k: pd.Series(v, dtype=v.dtype, copy=False)
                                for k, v in arrays.items()}, copy=False)
        return RunData(samples=samples, meta=meta)

    def run_info(self, run_id: int) -> dict[str, Any]:
        """A run's row as a dict (status, exit status, reason, counts, times, meta)."""
        with self.ReadSession() as s:
            r = self._run_row(s, run_id)
            rig = s.execute(select(Rig.name).where(Rig.id == r.rig_id)).scalar() if r.rig_id else None
            return _run_dict(r, rig)

    def list_runs(self, *, status: str | None = None, scheme: int | None = None,
                  source: str | None = None, rig: str | None = None,
                  limit: int | None = None) -> list[dict[str, Any]]:
        """Runs, newest first, filtered by status, scheme, source and rig name."""
        q = select(Run, Rig.name).outerjoin(Rig, Rig.id == Run.rig_id).order_by(Run.id.desc())
        if status:
            q = q.where(Run.status == status)
        if scheme is not None:
            q = q.where(Run.scheme == scheme)
        if source:
            q = q.where(Run.source == source)
        if rig:
            q = q.where(Rig.name == rig)
        if limit:
            q = q.limit(limit)
        with self.ReadSession() as s:
            return [_run_dict(r, name) for r, name in s.execute(q).all()]

    def channels(self, run_id: int, limit: int | None = None, offset: int = 0
                 ) -> list[dict[str, Any]]:
        """A run's channels: name, unit, source, kind, in stored order (`limit` of them from
        `offset`, default all)."""
        q = (select(Channel).where(Channel.run_id == run_id).order_by(Channel.position)
             .offset(offset))
        with self.ReadSession() as s:
            self._run_row(s, run_id)
            rows = s.execute(q if limit is None else q.limit(limit)).scalars().all()
            return [{"name": c.name, "unit": c.unit, "source": c.source, "kind": c.kind}
                    for c in rows]

    def interruptions(self, run_id: int, limit: int | None = None, offset: int = 0
                      ) -> list[dict[str, Any]]:
        """A run's interruptions, oldest first (`limit` of them from `offset`, default all)."""
        q = (select(Interruption).where(Interruption.run_id == run_id).order_by(Interruption.id)
             .offset(offset))
        with self.ReadSession() as s:
            rows = s.execute(q if limit is None else q.limit(limit)).scalars().all()
            return [{"kind": i.kind, "t_start": i.t_start, "t_end": i.t_end, "reason": i.reason,
                     "detail": i.detail, "created_at": _aware(i.created_at)} for i in rows]

    def list_totals(self, run_id: int) -> dict[str, int]:
        """How many channels, interruptions and results (result–run links) a run has: the
        totals of the lists a run's detail pages through."""
        with self.ReadSession() as s:
            count = lambda q: s.execute(q).scalar_one()  # noqa: E731
            return {"channels": count(select(func.count()).where(Channel.run_id == run_id)),
                    "interruptions": count(select(func.count())
                                           .where(Interruption.run_id == run_id)),
                    "results": count(select(func.count()).where(ResultRun.run_id == run_id))}

    def phase_aggregates(self, run_id: int, by_phase: bool = True) -> pd.DataFrame:
        """Per channel and phase (or per channel over the whole run with by_phase=False), from
        SQL aggregates over the page statistics: count (valid samples), missing, mean,
        var (sample variance, n−1), min, max. Numeric channels only; phase None = samples
        without a phase. Rows in channel order, phases in core.channels.PHASES order."""
        b, p, c = SampleBlock.__table__, SamplePage.__table__, Channel.__table__
        n = func.sum(b.c.n_valid)
        s1, s2 = func.sum(b.c.s1), func.sum(b.c.s2)
        group = [c.c.id, c.c.name, c.c.position, c.c.ref] + ([p.c.phase] if by_phase else [])
        stmt = (select(c.c.name, c.c.position, (p.c.phase if by_phase else null().label("phase")),
                       n.label("count"),
                       (c.c.ref + s1 / func.nullif(n, 0)).label("mean"),
                       ((s2 - s1 * s1 / func.nullif(n, 0)) / func.nullif(n - 1, 0)).label("var"),
                       func.min(b.c.vmin).label("min"), func.max(b.c.vmax).label("max"))
                .select_from(b.join(p, and_(p.c.run_id == b.c.run_id, p.c.seq == b.c.seq))
                             .join(c, c.c.id == b.c.channel_id))
                .where(b.c.run_id == run_id, c.c.kind == "float")
                .group_by(*group))
        pstmt = select(*([p.c.phase] if by_phase else []), func.sum(p.c.n)).where(p.c.run_id == run_id)
        if by_phase:
            pstmt = pstmt.group_by(p.c.phase)
        with self.ReadSession() as s:
            self._run_row(s, run_id)
            conn = s.connection()
            rows = conn.execute(stmt).all()
            totals = conn.execute(pstmt).all()
            names = conn.execute(select(c.c.name, c.c.position).where(
                c.c.run_id == run_id, c.c.kind == "float")).all()
        total = {(r[0] if by_phase else None): int(r[-1] or 0) for r in totals}
        got = {(r[0], r[2]): r for r in rows}
        order = {ph: k for k, ph in enumerate(PHASES)}
        out = []
        for name, pos in sorted(names, key=lambda x: x[1]):
            for ph in sorted(total, key=lambda x: order.get(x, len(order))):
                r = got.get((name, ph))
                cnt = int(r.count) if r is not None and r.count is not None else 0
                var = None if r is None or r.var is None else max(float(r.var), 0.0)
                out.append({"channel": name, "phase": ph, "count": cnt,
                            "missing": total[ph] - cnt,
                            "mean": None if r is None or r.mean is None else float(r.mean),
                            "var": var,
                            "min": None if r is None or r.min is None else float(r.min),
                            "max": None if r is None or r.max is None else float(r.max)})
        df = pd.DataFrame(out, columns=["channel", "phase", "count", "missing", "mean", "var",
                                        "min", "max"])
        df = df.astype({"mean": float, "var": float, "min": float, "max": float})
        df["phase"] = pd.Series([r["phase"] for r in out], dtype=object)
        return df

    def phase_durations(self, run_id: int) -> pd.DataFrame:
        """Per phase: samples, and time spanned by its pages [s] (first to last sample of each
        page, summed)."""
        p = SamplePage.__table__
        stmt = (select(p.c.phase, func.sum(p.c.n).label("samples"), func.count().label("pages"),
                       func.sum(p.c.t1 - p.c.t0).label("span_s"))
                .where(p.c.run_id == run_id).group_by(p.c.phase))
        with reader(self.engine).connect() as conn:
            rows = conn.execute(stmt).all()
        order = {ph: k for k, ph in enumerate(PHASES)}
        rows = sorted(rows, key=lambda r: order.get(r[0], len(order)))
        return pd.DataFrame([tuple(r) for r in rows], columns=["phase", "samples", "pages", "span_s"])


def _fetch_blocks(conn, run_id: int, channel_ids: list[int] | None) -> list[tuple[int, int, bytes]]:
    """(channel_id, seq, data) of a run's blocks. On PostgreSQL through a binary-format cursor:
    psycopg's default text format sends bytea as hex, measured 3x slower for whole runs."""
    if conn.engine.dialect.name == "postgresql":
        sql = "SELECT channel_id, seq, data FROM sample_blocks WHERE run_id = %s"
        params: list[Any] = [run_id]
        if channel_ids is not None:
            sql += " AND channel_id = ANY(%s)"
            params.append(list(channel_ids))
        with conn.connection.dbapi_connection.cursor(binary=True) as cur:
            cur.execute(sql, params)
            return cur.fetchall()
    q = select(SampleBlock.channel_id, SampleBlock.seq, SampleBlock.data).where(
        SampleBlock.run_id == run_id)
    if channel_ids is not None:
        q = q.where(SampleBlock.channel_id.in_(channel_ids))
    return [tuple(r) for r in conn.execute(q).all()]


def fetch_page_blocks(conn, run_id: int, channel_ids: list[int], seqs: list[int]
                      ) -> list[tuple[int, int, bytes]]:
    """(channel_id, seq, data) of the blocks of `channel_ids` on the pages `seqs` of a run
    (a primary-key lookup per block); binary transfer on PostgreSQL as in _fetch_blocks."""
    if not channel_ids or not seqs:
        return []
    if conn.engine.dialect.name == "postgresql":
        with conn.connection.dbapi_connection.cursor(binary=True) as cur:
            cur.execute("SELECT channel_id, seq, data FROM sample_blocks WHERE run_id = %s"
                        " AND channel_id = ANY(%s) AND seq = ANY(%s)",
                        [run_id, list(channel_ids), list(seqs)])
            return cur.fetchall()
    q = select(SampleBlock.channel_id, SampleBlock.seq, SampleBlock.data).where(
        SampleBlock.run_id == run_id, SampleBlock.channel_id.in_(channel_ids),
        SampleBlock.seq.in_(seqs))
    return [tuple(r) for r in conn.execute(q).all()]


def _run_dict(r: Run, rig: str | None) -> dict[str, Any]:
    return {"id": r.id, "rig": rig, "scheme": r.scheme, "source": r.source, "status": r.status,
            "exit_status": r.exit_status, "reason": r.reason, "started_at": _aware(r.started_at),
            "stopped_at": _aware(r.stopped_at), "created_at": _aware(r.created_at),
            "heartbeat_at": _aware(r.heartbeat_at), "n_samples": r.n_samples,
            "n_pages": r.n_pages, "t_last": r.t_last, "imported_from": r.imported_from,
            "meta": dict(r.meta)}
