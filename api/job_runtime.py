"""What a running job gets, wherever it runs (a local worker process or a Dask task):
- StopFlag: why the job must stop now (cancelled, taken over, past its wall-clock limit), set by
  the worker's watchdog thread (api.worker) and polled by the samplers through the stop check of
  estimator.stopping (a read of one attribute, so they poll it every iteration);
- JobProgress: reports progress to SQL and raises JobCancelled once the job is no longer running
  under its claiming worker (cancelled, or re-queued after that worker was lost), or the stop
  flag's exception as soon as the flag is set;
- ProgressMap: the local `map`-like callable handed to a job kind (chains, Sobol blocks run here
  one after another, with a progress report and cancellation check after each);
- call_kind: runs a job kind, handing it the map when the kind takes one (`map_fn`)."""

from __future__ import annotations

import inspect
import time
from typing import Any, Callable, Iterable

MAP_SHARE = 0.5
"""A map moves the job's progress this share of the way from its last reported value to 0.9."""


class StopFlag:
    """Set once with the exception that stops a running job (JobCancelled, JobTimeLimit);
    `check()` raises a fresh copy of it once set and returns at once otherwise — the stop check
    installed for the samplers (estimator.stopping). Safe to set from another thread."""

    def __init__(self) -> None:
        self.reason: BaseException | None = None

    def set(self, exc: BaseException) -> bool:
        """Set the reason (the first one wins); True when this call set it."""
        if self.reason is not None:
            return False
        self.reason = exc
        return True

    def check(self) -> None:
        exc = self.reason
        if exc is not None:
            raise type(exc)(*exc.args)


class JobProgress:
    """progress(x): store x ∈ [0, 1] (never lower than before) as the progress of job `job_id`
    run by `worker` ('host/pid/token' of the claiming worker process); raises JobCancelled when
    the job is no longer running under that worker, and the exception of `stop` (a StopFlag)
    once that is set."""

    def __init__(self, store, job_id: int, worker: str, start: float = 0.0,
                 check_every_s: float = 1.0, stop: StopFlag | None = None):
        self.store, self.job_id, self.worker = store, job_id, worker
        self.base = self.last = float(start or 0.0)
        self.check_every_s = check_every_s
        self.stop = stop
        self._checked = 0.0

    def __call__(self, x: float) -> None:
        """A job kind's report: x is the start of its next phase."""
        self.base = max(self.base, float(x))
        self._write(self.base)

    def tick(self, done: int, total: int) -> None:
        """A map's report: `done` of `total` items finished in the current phase."""
        span = max(0.0, 0.9 - self.base) * MAP_SHARE
        self._write(self.base + span * done / max(total, 1))

    def _write(self, x: float) -> None:
        from db import jobs as queue
        from api.job_kinds import JobCancelled

        if self.stop is not None:
            self.stop.check()
        self.last = max(self.last, min(x, 1.0))
        self._checked = time.monotonic()
        if queue.heartbeat(self.store, self.job_id, self.worker, progress=self.last) != "running":
            raise JobCancelled(f"job {self.job_id} is no longer running under {self.worker}")

    def check(self) -> None:
        """Raise JobCancelled when the job was cancelled or taken over (a read, at most every
        check_every_s)."""
        from db import jobs as queue
        from api.job_kinds import JobCancelled

        if self.stop is not None:
            self.stop.check()
        if time.monotonic() - self._checked < self.check_every_s:
            return
        self._checked = time.monotonic()
        job = queue.get_job(self.store, self.job_id)
        if job is None or job["state"] != "running" or job["worker"] != self.worker:
            raise JobCancelled(f"job {self.job_id} is no longer running under {self.worker}")


class ProgressMap:
    """map(fn, items) -> [fn(item), …] here, in order, reporting progress after each item and
    checking the stop flag before each (the samplers inside an item poll it themselves)."""

    def __init__(self, progress: JobProgress):
        self.progress = progress

    def __call__(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
        items = list(items)
        out = []
        for i, item in enumerate(items):
            if self.progress.stop is not None:
                self.progress.stop.check()
            out.append(fn(item))
            self.progress.tick(i + 1, len(items))
        return out


def takes_map(run: Callable) -> bool:
    """Whether a job kind's run function accepts `map_fn`."""
    return "map_fn" in inspect.signature(run).parameters


def call_kind(kind, store, params, progress: JobProgress, map_fn: Callable) -> list:
    """kind.run(store, params, progress[, map_fn]) → the results to store."""
    if takes_map(kind.run):
        return kind.run(store, params, progress, map_fn=map_fn)
    return kind.run(store, params, progress)
