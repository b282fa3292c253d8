"""RunWriter: stores a run while it goes on, so a crash loses at most the last second.

    w = RunWriter(store)
    run_id = w.start(meta, [ChannelSpec("t"), ChannelSpec("q", source="encoder"), ...])
    w.append({"t": t, "q": q, "phase": ["load"] * len(t)})     # any number of times
    w.interruption("interlock", t_start=12.3, reason="oil temperature high")
    w.stop("abort", reason="interlock trip")                    # 'success' | 'abort' | 'fail'

Appended samples are buffered and committed by a background thread every `commit_interval_s`
(0.5 s by default, so a sample is durable well within one second of its append), together with
the run's heartbeat; appends never wait for the database. The run row carries the writer's host,
pid and process token: if the process dies, the next Store opened on the database marks the run
'interrupted'. Used as a context manager the writer always stops the run: 'fail' with the
exception text when the block raised, 'success' otherwise (unless stopped inside the block).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import numpy as np
import pandas as pd
from sqlalchemy import insert, update

from db.models import EXIT_STATUSES, Interruption, Run, utcnow
from db.pages import PAGE_SAMPLES, ChannelRef, write_pages
from db.store import Store, _parse_started, writer_identity
from core.channels import PHASES, unit_of
from core.documents import ExitStatus, RunMeta
from core.runfile import validate_meta

HEARTBEAT_S = 5.0
"""How often an idle writer still commits its heartbeat [s] (< store.STALE_AFTER_S)."""


@dataclass(frozen=True)
class ChannelSpec:
    """A channel the writer will receive: name, unit (None: meta['units'] or core.channels),
    source (the device or stream it comes from; None: meta['source']) and kind ('float',
    'text'; the channel named 'phase' is always the phase)."""
    name: str
    unit: str | None = None
    source: str | None = None
    kind: str = "float"


class RunWriter:
    """Writes one run into `store` while it is acquired (see the module doc)."""

    def __init__(self, store: Store, commit_interval_s: float = 0.5, max_page: int = PAGE_SAMPLES):
        self.store = store
        self.commit_interval_s = commit_interval_s
        self.max_page = max_page
        self.run_id: int | None = None
        self._meta: RunMeta = {}
        self._channels: list[ChannelRef] = []
        self._buf: list[dict[str, Any]] = []
        self._pending_interruptions: list[dict[str, Any]] = []
        self._buf_lock = threading.Lock()
        self._flush_lock = threading.Lock()
        self._stop_evt = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self._seq = 0
        self._n = 0
        self._t_last: float | None = None      # last appended t (validation)
        self._t_stored: float | None = None    # last committed t
        self._last_commit = 0.0
        self._stopped = False

    # --- lifecycle ------------------------------------------------------------------------

    def start(self, meta: RunMeta, channels: Iterable[ChannelSpec | str],
              rig: str | None = None) -> int:
        """Create the run (status 'running') with its channels; `t` is added first when not
        listed. `meta`: the run-format metadata (the acquisition engine's start document,
        core.documents.RunStart, is one). Returns the run id and starts the commit thread."""
        if self.run_id is not None:
            raise RuntimeError("this writer already started a run")
        self._meta = validate_meta(dict(meta), "<run metadata>")
        specs = self._specs(channels)
        if "t" not in [s.name for s in specs]:
            specs.insert(0, ChannelSpec("t"))
        rig_name = rig or self._meta.get("rig")
        now = utcnow()
        with self.store.engine.begin() as conn:
            rid = conn.execute(insert(Run).values(
                rig_id=self.store.rig_id(conn, rig_name, self._meta.get("source")),
                scheme=self._meta.get("scheme") if isinstance(self._meta.get("scheme"), int) else None,
                source=self._meta.get("source") if isinstance(self._meta.get("source"), str) else None,
                status="running", meta=self._meta,
                started_at=_parse_started(self._meta) or now, created_at=now, heartbeat_at=now,
                n_samples=0, n_pages=0, **writer_identity()).returning(Run.id)).scalar_one()
            self._channels = self.store.create_channels(conn, rid, [self._row(s) for s in specs])
        self.run_id = rid
        self._last_commit = time.monotonic()
        self._thread = threading.Thread(target=self._commit_loop, name=f"run-{rid}-writer",
                                        daemon=True)
        self._thread.start()
        return rid

    def add_channels(self, channels: Iterable[ChannelSpec | str]) -> None:
        """Declare more channels mid-run (e.g. a stream that comes up late); their earlier
        samples are missing."""
        self._check_running()
        specs = [s for s in self._specs(channels) if s.name not in self.channel_names]
        with self._flush_lock, self.store.engine.begin() as conn:
            self._channels += self.store.create_channels(
                conn, self.run_id, [self._row(s) for s in specs], first_position=len(self._channels))

    @property
    def channel_names(self) -> list[str]:
        return [c.name for c in self._channels]

    def append(self, samples: Mapping[str, Any] | pd.DataFrame) -> None:
        """Buffer samples: `t` [s] required, strictly increasing (also across appends); every
        other key must be a declared channel; declared channels not given are missing (NaN /
        None). Raises the commit thread's error if it failed."""
        self._check_running()
        cols = {k: samples[k] for k in samples.keys()} if not isinstance(samples, pd.DataFrame) \
            else {k: samples[k].to_numpy() for k in samples.columns}
        if "t" not in cols:
            raise ValueError("append needs 't'")
        unknown = [k for k in cols if k not in self.channel_names]
        if unknown:
            raise KeyError(f"undeclared channel(s) {unknown}: declare them with add_channels")
        t = np.atleast_1d(np.asarray(cols["t"], dtype=float))
        n = len(t)
        kinds = {c.name: c.kind for c in self._channels}
        chunk: dict[str, Any] = {}
        for name, v in cols.items():
            if kinds[name] == "float":
                a = np.atleast_1d(np.array(v, dtype=float))
            else:
                a = np.array([x if isinstance(x, str) else None for x in np.atleast_1d(
                    np.asarray(v, dtype=object))], dtype=object)
                if kinds[name] == "phase":
                    bad = [x for x in a if x is not None and x not in PHASES]
                    if bad:
                        raise ValueError(f"unknown phase {bad[0]!r} (expected one of {PHASES})")
            if len(a) != n:
                raise ValueError(f"channel {name!r} has {len(a)} samples where 't' has {n}")
            chunk[name] = a
        if n == 0:
            return
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0) or (
                self._t_last is not None and t[0] <= self._t_last):
            raise ValueError("'t' must be finite and strictly increasing across appends")
        with self._buf_lock:
            self._buf.append(chunk)
            self._t_last = float(t[-1])

    def interruption(self, kind: str, t_start: float | None, t_end: float | None = None,
                     reason: str | None = None, detail: dict[str, Any] | None = None) -> None:
        """Record an interruption (interlock trip, lost drive, reconnect gap...) in run time [s];
        committed with the next commit."""
        self._check_running()
        with self._buf_lock:
            self._pending_interruptions.append({
                "run_id": self.run_id, "kind": kind, "t_start": t_start, "t_end": t_end,
                "reason": reason, "detail": detail, "created_at": utcnow()})

    def flush(self) -> None:
        """Commit everything buffered now (pages, interruptions, heartbeat)."""
        if self.run_id is None:
            return
        with self._flush_lock:
            with self._buf_lock:
                chunks, self._buf = self._buf, []
                intr, self._pending_interruptions = self._pending_interruptions, []
            try:
                self._commit(chunks, intr)
            except BaseException:
                with self._buf_lock:  # keep the data for the next attempt
                    self._buf = chunks + self._buf
                    self._pending_interruptions = intr + self._pending_interruptions
                raise

    def stop(self, exit_status: ExitStatus = "success", reason: str | None = None) -> None:
        """Commit what is left and close the run: status 'finished' with exit_status
        ('success', 'abort', 'fail') and the reason."""
        if exit_status not in EXIT_STATUSES:
            raise ValueError(f"exit_status must be one of {EXIT_STATUSES}, got {exit_status!r}")
        if self.run_id is None:
            raise RuntimeError("start the run first")
        if self._stopped:
            raise RuntimeError(f"run {self.run_id} is already stopped")
        self._stop_evt.set()
        if self._thread is not None:
            self._thread.join()
        self.flush()  # raises if the database is still failing; stop() may then be retried
        with self.store.engine.begin() as conn:
            conn.execute(update(Run).where(Run.id == self.run_id).values(
                status="finished", exit_status=exit_status, reason=reason, stopped_at=utcnow(),
                heartbeat_at=utcnow()))
        self._stopped = True

    def __enter__(self) -> "RunWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.run_id is None or self._stopped:
            return
        if exc is None:
            self.stop("success")
        else:
            self.stop("fail", reason=f"{exc_type.__name__}: {exc}")

    # --- internals ------------------------------------------------------------------------

    def _specs(self, channels: Iterable[ChannelSpec | str]) -> list[ChannelSpec]:
        return [c if isinstance(c, ChannelSpec) else ChannelSpec(str(c)) for c in channels]

    def _row(self, s: ChannelSpec) -> tuple[str, str, str | None, str]:
        units = self._meta.get("units") if isinstance(self._meta.get("units"), dict) else {}
        unit = s.unit if s.unit is not None else (units.get(s.name) or unit_of(s.name))
        kind = "phase" if s.name == "phase" else s.kind
        if kind not in ("float", "text", "phase"):
            raise ValueError(f"channel kind must be 'float' or 'text', got {kind!r}")
        return (s.name, unit, s.source if s.source is not None else self._meta.get("source"), kind)

    def _check_running(self) -> None:
        if self.run_id is None:
            raise RuntimeError("start the run first")
        if self._stopped:
            raise RuntimeError(f"run {self.run_id} is already stopped")
        if self._error is not None:
            raise RuntimeError(f"the writer of run {self.run_id} failed to commit: "
                               f"{self._error!r}") from self._error

    def _commit_loop(self) -> None:
        while not self._stop_evt.wait(self.commit_interval_s / 4):
            due = time.monotonic() - self._last_commit
            with self._buf_lock:
                has_data = bool(self._buf or self._pending_interruptions)
            if (has_data and due >= self.commit_interval_s) or due >= HEARTBEAT_S:
                try:
                    self.flush()
                    self._error = None
                except Exception as exc:  # kept and retried; append() reports it
                    self._error = exc

    def _commit(self, chunks: list[dict[str, Any]], intr: list[dict[str, Any]]) -> None:
        cols: dict[str, Any] = {}
        n = 0
        if chunks:
            names = {k for c in chunks for k in c}
            for name in names:
                parts = []
                for c in chunks:
                    m = len(c["t"])
                    if name in c:
                        parts.append(c[name])
                    else:
                        kind = next(ch.kind for ch in self._channels if ch.name == name)
                        parts.append(np.full(m, np.nan) if kind == "float" else np.full(m, None, dtype=object))
                cols[name] = np.concatenate(parts)
            n = len(cols["t"])
        refs_before = [ch.ref for ch in self._channels]
        try:
            with self.store.engine.begin() as conn:
                pages = write_pages(conn, self.run_id, self._channels, cols, seq0=self._seq,
                                    i0=self._n, max_len=self.max_page) if n else 0
                if intr:
                    conn.execute(insert(Interruption), intr)
                t_last = float(cols["t"][-1]) if n else self._t_stored
                conn.execute(update(Run).where(Run.id == self.run_id).values(
                    n_samples=self._n + n, n_pages=self._seq + pages, t_last=t_last,
                    heartbeat_at=utcnow()))
        except BaseException:
            for ch, ref in zip(self._channels, refs_before):  # refs were not committed
                ch.ref = ref
            raise
        self._seq += pages
        self._n += n
        self._t_stored = t_last
        self._last_commit = time.monotonic()
