"""An in-process cache of computed answers (per-phase aggregates, run reports) of runs that no
longer change, for the routers.

Why (bench/bench_api_load.py, 1 004 001-sample run, 2 shared cores): a run report loads the
whole run (22 numeric channels × 8 bytes × 1 M samples = 176 MB) for its acceptance indicators and
plots, 0.5-1 s for the JSON and 1-2 s with plots per request, and under 50 concurrent clients
not one report request finished within 5 s; the aggregates query costs 10-30 ms per request,
mostly Python, which capped the endpoint near 65 requests/s with p99 2 s. A finished run's
samples never change, so its answers are computed once per process and served from memory.

Correctness: an entry's key carries what the answer is built from, which the router reads with
cheap queries on every request, so when anything changes the key changes and the answer is
recomputed: for aggregates the run's status, page and sample counts (its samples); for a report
the whole run row (metadata included) and the ids of the results, stored documents and
interruptions that refer to the run (run_fingerprint); for a job report (whose page redraws
every posterior, corner and diagnosis figure) the job's row and its results' documents
(job_fingerprint). Runs still being written and jobs still queued or running are never cached. The cache lives in the process (not in SQL), so a
new version of the report code never serves a report rendered by the old one.

Concurrent requests for the same missing key compute it once (the others wait for it), so a
burst of report requests does not load the same run 50 times at once.

RIG_API_CACHE_MB   memory budget per service process [MiB] (default 256; 0 turns caching off)
"""

from __future__ import annotations

import os
import sys
import threading
import weakref
from collections import OrderedDict
from typing import Any, Callable, Hashable, TypeVar

T = TypeVar("T")

DEFAULT_CACHE_MB = 256


def cache_budget_bytes() -> int:
    """The memory budget from env RIG_API_CACHE_MB [bytes] (0: no caching)."""
    mb = float(os.environ.get("RIG_API_CACHE_MB") or DEFAULT_CACHE_MB)
    if not mb >= 0:
        raise ValueError(f"RIG_API_CACHE_MB must be >= 0, got {mb!r}")
    return int(mb * 1024 * 1024)


def approx_size(x: Any) -> int:
    """Rough size of a JSON-like value in memory [bytes] (for the cache's budget)."""
    if isinstance(x, (bytes, str)):
        return sys.getsizeof(x)
    if isinstance(x, dict):
        return sys.getsizeof(x) + sum(approx_size(k) + approx_size(v) for k, v in x.items())
    if isinstance(x, (list, tuple)):
        return sys.getsizeof(x) + sum(approx_size(v) for v in x)
    return sys.getsizeof(x)


class ResponseCache:
    """Least-recently-used map of key → value within `max_bytes`, thread safe, computing a
    missing key once however many threads ask for it at the same time."""

    def __init__(self, max_bytes: int):
        self.max_bytes = max_bytes
        self._data: OrderedDict[Hashable, tuple[Any, int]] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()
        self._inflight: dict[Hashable, threading.Lock] = {}
        self.hits = self.misses = 0

    def __len__(self) -> int:
        return len(self._data)

    @property
    def nbytes(self) -> int:
        """Bytes held (by the sizes given when storing)."""
        return self._bytes

    def _lookup(self, key: Hashable) -> tuple[bool, Any]:
        with self._lock:
            if key in self._data:
                self._data.move_to_end(key)
                self.hits += 1
                return True, self._data[key][0]
            return False, None

    def get_or_compute(self, key: Hashable, compute: Callable[[], T],
                       size_of: Callable[[T], int] = approx_size) -> T:
        """The value stored under `key`, else `compute()` stored under it (when it fits) and
        returned. An exception from compute() propagates and nothing is stored."""
        if self.max_bytes <= 0:
            return compute()
        found, value = self._lookup(key)
        if found:
            return value
        with self._lock:
            flight = self._inflight.setdefault(key, threading.Lock())
        with flight:
            found, value = self._lookup(key)   # computed by the thread we waited for
            if found:
                return value
            try:
                value = compute()
                self._store(key, value, size_of(value))
            finally:
                with self._lock:
                    if self._inflight.get(key) is flight:
                        del self._inflight[key]
            return value

    def _store(self, key: Hashable, value: Any, size: int) -> None:
        with self._lock:
            self.misses += 1
            if size > self.max_bytes:
                return
            if key in self._data:
                self._bytes -= self._data.pop(key)[1]
            self._data[key] = (value, size)
            self._bytes += size
            while self._bytes > self.max_bytes:
                _, (_, old) = self._data.popitem(last=False)
                self._bytes -= old


_caches: "weakref.WeakKeyDictionary[Any, ResponseCache]" = weakref.WeakKeyDictionary()
_caches_lock = threading.Lock()


def cache_for(store: Any) -> ResponseCache:
    """The cache of one Store (one per service process: entries of different databases never
    mix), created with the budget of RIG_API_CACHE_MB on first use."""
    with _caches_lock:
        c = _caches.get(store)
        if c is None:
            c = _caches[store] = ResponseCache(cache_budget_bytes())
        return c


def run_row_key(info: dict[str, Any]) -> str | None:
    """The run's row `info` (Store.run_info: samples, pages, status, metadata) as a cache key;
    None for a run still being written (not cacheable)."""
    if info.get("status") == "running":
        return None
    return repr(sorted(info.items(), key=lambda kv: kv[0]))


def run_fingerprint(store: Any, info: dict[str, Any]) -> tuple | None:
    """What a run's answers are built from, as a hashable tuple, from the run's row `info`
    (Store.run_info) and the ids of the results, stored documents (reports rows) and
    interruptions referring to the run. None for a run still being written (not cacheable)."""
    row = run_row_key(info)
    if row is None:
        return None
    from sqlalchemy import func, or_, select

    from db.models import Interruption, Report, ResultRun

    results = select(ResultRun.result_id).where(ResultRun.run_id == info["id"])
    with store.ReadSession() as s:
        res = s.execute(select(func.count(), func.max(ResultRun.result_id))
                        .where(ResultRun.run_id == info["id"])).one()
        docs = s.execute(select(func.count(), func.max(Report.id)).where(
            or_(Report.run_id == info["id"], Report.result_id.in_(results)))).one()
        intr = s.execute(select(func.count(), func.max(Interruption.id))
                         .where(Interruption.run_id == info["id"])).one()
    return (row, tuple(res), tuple(docs), tuple(intr))


def job_fingerprint(store: Any, job: dict[str, Any]) -> tuple | None:
    """What a job's report is built from, as a hashable tuple, from the job as the API shows it
    (db.jobs.get_job: state, timings, error, result ids) and the count and newest id of the
    stored documents of its results. None for a job still queued or running (not cacheable:
    its progress and heartbeat change)."""
    if job.get("state") in ("queued", "running"):
        return None
    from sqlalchemy import func, select

    from db.models import Report, Result

    results = select(Result.id).where(Result.job_id == job["id"])
    with store.ReadSession() as s:
        docs = s.execute(select(func.count(), func.max(Report.id))
                         .where(Report.result_id.in_(results))).one()
    return (repr(sorted(job.items(), key=lambda kv: kv[0])), tuple(docs))


def json_bytes(value: Any) -> bytes:
    """`value` encoded as JSON the way FastAPI encodes a returned value (pydantic; datetimes as
    ISO 8601): a cached answer is encoded once and sent as is."""
    global _ANY
    if _ANY is None:
        from pydantic import TypeAdapter
        _ANY = TypeAdapter(Any)
    return _ANY.dump_json(value)


_ANY = None
