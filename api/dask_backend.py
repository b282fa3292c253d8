"""Jobs on a Dask distributed cluster (RIG_DASK_SCHEDULER=tcp://host:port or tls://host:port).

SQL stays the source of truth for a job's state: a local worker process (api.worker) claims the
job, stamps its heartbeats and writes its end and results, exactly as without Dask. Only the
work moves to the cluster:
- DaskJobs.run submits the job kind's code as one Dask task (`run_job_task`, a plain function of
  the job row that opens its own Store on the Dask worker's RIG_DB_URL) and waits for it,
  checking every second whether the job was cancelled (then the task's futures are cancelled);
- the database URL (it may hold a password) is never a task argument: task arguments pass
  through the scheduler, its logs and dashboards. Each Dask worker names the database in its
  own environment (RIG_DB_URL); the task carries only the URL with its password masked, and
  refuses to run on a worker whose database is another;
- a tls:// scheduler is reached with distributed.security.Security built from the settings'
  certificate files (api.settings: RIG_DASK_TLS_CA/_CERT/_KEY); a tcp:// scheduler
  authenticates nobody and encrypts nothing, so it must stay on a trusted network;
- inside that task the kind gets a DaskMap as its `map_fn`: the chains of a Bayesian fit and the
  Sobol evaluation blocks become Dask tasks spread over the workers; the job task leaves its
  worker's thread pool while it waits for them (secede/rejoin). R-hat, ESS and the Sobol analysis
  are computed in the job task once every chain and block is back.
- Progress and cancellation: the job task reports progress to SQL under the claiming worker's
  name (JobProgress), after each chain or block too, and stops with JobCancelled as soon as the
  job is no longer running under that worker (cancelled, or re-queued after the claiming worker
  was lost).
- Stopping tasks that already run: cancelling a Dask future does not stop a task running in a
  worker's thread, so each job run gets a named distributed.Event (`rig-job{id}-stop-{token}`),
  its name passed to the job task and to every chain and block task. Each of them installs an
  estimator.stopping check (EventStop) that asks the scheduler whether the Event is set at most
  every EVENT_CHECK_S (one round trip; the samplers call the check every iteration, it costs a
  clock read between round trips) and raises JobCancelled once it is. The claiming worker sets
  the Event as soon as its wait ends early (its stop flag set by the watchdog: the job cancelled,
  taken over or past its wall-clock limit; or any error), so the running samplers stop within
  ~EVENT_CHECK_S + POLL_S + the watchdog's STOP_POLL_S. A set Event is cleared (which deletes it
  on the scheduler) STOP_LINGER_S later, at the claiming worker's next job or at its close, once
  every task of the job has had time to see it; an Event never set never exists on the
  scheduler.
- A Dask worker lost mid-job: the scheduler re-runs its tasks (the job task included) on the
  other workers; the claiming worker keeps waiting on the same future and the job still ends
  'succeeded' (after `distributed.scheduler.allowed-failures` losses of one task it fails with
  KilledWorker). The job's workers need the database (RIG_DB_URL in each Dask worker's
  environment: a PostgreSQL URL reachable from every Dask worker; a SQLite file only when they
  share its machine) and this package installed.

Each stored fit records where it ran in fit.extra['dask']: scheduler, the job task's key and
worker, and each chain's or block's task key and worker."""

from __future__ import annotations

import logging
import threading
import time
import uuid
from typing import Any, Callable, Iterable

from api.job_runtime import JobProgress, call_kind
from estimator import stopping

log = logging.getLogger("rig.dask")

CONNECT_TIMEOUT_S = 10.0
"""How long a worker tries to reach the scheduler before it gives up for this loop turn [s]."""
POLL_S = 0.1
"""How often a waiting loop looks at its futures [s] (cancellation: read at most once a second)."""
EVENT_CHECK_S = 0.25
"""How often a task running on the cluster asks the scheduler whether its job's stop Event is
set [s] (one scheduler round trip each time; never once per sampler iteration)."""
STOP_LINGER_S = 60.0
"""How long a job's set stop Event is kept on the scheduler before it is cleared [s]: time for
every task of the job still running (or re-run after a lost worker) to see it."""


class EventStop:
    """The stop check (estimator.stopping) of a task running on the cluster: returns while the
    job's stop Event `name` is not set and raises JobCancelled once it is. The scheduler is asked
    at most every `every_s` [s]; between asks a call costs a clock read, so the samplers may call
    it every iteration. A scheduler that does not answer leaves the work going (it is asked
    again at the next interval). Safe to call from the threads of one task."""

    def __init__(self, name: str, every_s: float = EVENT_CHECK_S):
        self.name, self.every_s = name, every_s
        self._next = 0.0
        self._stopped = False
        self._event = None
        self._lock = threading.Lock()

    def __call__(self) -> None:
        if not self._stopped:
            if time.monotonic() < self._next or not self._lock.acquire(blocking=False):
                return
            try:
                self._next = time.monotonic() + self.every_s
                self._stopped = self._is_set()
            finally:
                self._lock.release()
            if not self._stopped:
                return
        from api.job_kinds import JobCancelled
        raise JobCancelled(f"stopped by its claiming worker (Dask event {self.name}): the job "
                           "was cancelled, taken over or ran past its wall-clock limit")

    def _is_set(self) -> bool:
        from distributed import Event, get_client

        try:
            if self._event is None:
                self._event = Event(self.name, client=get_client())
            return bool(self._event.is_set())
        except (OSError, TimeoutError) as e:
            log.warning("stop event %s could not be read (%s); the task goes on", self.name, e)
            return False


def _on_worker(item: Any, fn: Callable[[Any], Any],
               stop_event: str | None = None) -> tuple[Any, str]:
    """fn(item) on a Dask worker, with that worker's address; with `stop_event`, fn's samplers
    stop (JobCancelled) once that Event is set (EventStop)."""
    from distributed import get_worker

    if stop_event is None:
        return fn(item), get_worker().address
    with stopping.stop_check(EventStop(stop_event)):
        return fn(item), get_worker().address


class DaskMap:
    """map(fn, items) -> [fn(item), …] in order, each item a Dask task. Reports progress as the
    tasks finish and checks for cancellation while waiting (JobProgress); `records` lists every
    task's key and the worker that returned its result. in_task=True: called from inside a Dask
    task, which leaves the worker's thread pool while it waits. `stop_event`: the name of the
    job's stop Event, which every task polls (EventStop)."""

    def __init__(self, client, progress: JobProgress, prefix: str, in_task: bool = False,
                 stop_event: str | None = None):
        self.client, self.progress, self.prefix, self.in_task = client, progress, prefix, in_task
        self.stop_event = stop_event
        self.records: list[dict[str, str]] = []
        self.calls = 0

    def __call__(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
        from distributed import rejoin, secede

        items = list(items)
        self.calls += 1
        name = getattr(fn, "__name__", "fn").strip("<>")
        keys = [f"{self.prefix}-{name}-{self.calls}-{i}-{uuid.uuid4().hex[:8]}"
                for i in range(len(items))]
        futures = self.client.map(_on_worker, items, fn=fn, stop_event=self.stop_event,
                                  key=keys, pure=False)
        if self.in_task:
            secede()
        try:
            out = _wait_in_order(futures, self.progress)
        except BaseException:
            self.client.cancel(futures)
            raise
        finally:
            if self.in_task:
                rejoin()
        self.records += [{"key": k, "worker": w} for k, (_, w) in zip(keys, out)]
        return [r for r, _ in out]


def _wait_in_order(futures: list, progress: JobProgress) -> list[Any]:
    """The futures' results in order; progress ticks as they finish; JobCancelled (or the first
    task error, or the stop check installed here: estimator.stopping) ends the wait."""
    results: list[Any] = [None] * len(futures)
    pending = set(range(len(futures)))
    while pending:
        progress.check()
        stopping.poll()
        finished = [i for i in pending if futures[i].status in ("finished", "error", "cancelled")]
        for i in sorted(finished):
            results[i] = futures[i].result()   # re-raises a task's error here
            pending.discard(i)
        if finished:
            progress.tick(len(futures) - len(pending), len(futures))
        elif pending:
            time.sleep(POLL_S)
    return results


def masked_url(url: str) -> str:
    """`url` with its password replaced by ***: what may be shown, logged or sent to Dask."""
    from sqlalchemy.engine import make_url

    return make_url(url).render_as_string(hide_password=True)


def run_job_task(job: dict[str, Any], worker: str, db_masked: str,
                 stop_event: str | None = None) -> list:
    """A job's kind run as a Dask task: opens its own Store on this Dask worker's database
    (RIG_DB_URL in its environment; RuntimeError if that is not the claiming service's
    database, `db_masked`), reports progress as the claiming `worker`, spreads chains and Sobol
    blocks over the cluster (DaskMap); returns the results (api.job_kinds.StoredResult), each
    fit annotated with fit.extra['dask']. `stop_event`: the name of the job's stop Event; the
    task and its chains and blocks stop (JobCancelled) once it is set (EventStop)."""
    if stop_event is None:
        return _run_job_task(job, worker, db_masked, None)
    with stopping.stop_check(EventStop(stop_event)):
        return _run_job_task(job, worker, db_masked, stop_event)


def _run_job_task(job: dict[str, Any], worker: str, db_masked: str,
                  stop_event: str | None) -> list:
    from distributed import get_client, get_worker

    from db import jobs as queue
    from api.job_kinds import KINDS
    from db.engine import database_url
    from db.store import Store

    here_db = database_url()
    if masked_url(here_db) != db_masked:
        raise RuntimeError(f"Dask worker {get_worker().address}: its database (RIG_DB_URL) is "
                           f"{masked_url(here_db)}, the job's is {db_masked}; start every Dask "
                           "worker with the service's RIG_DB_URL in its environment")
    store = Store(here_db, upgrade=False, recover=False)
    try:
        kind = KINDS[job["kind"]]
        params = kind.params.model_validate(job["params"])
        now = queue.get_job(store, job["id"]) or {}
        progress = JobProgress(store, job["id"], worker, start=now.get("progress") or 0.0)
        progress.check()          # cancelled or taken over while queued on the cluster
        client = get_client()
        here = get_worker()
        dmap = DaskMap(client, progress, prefix=f"rig-job{job['id']}", in_task=True,
                       stop_event=stop_event)
        results = call_kind(kind, store, params, progress, dmap)
        info = {"scheduler": client.scheduler.address, "job_task": here.get_current_task(),
                "job_worker": here.address, "tasks": dmap.records}
        for r in results:
            r.fit.extra["dask"] = info
        return results
    finally:
        store.close()


class DaskJobs:
    """The claiming worker's side: a Dask client on `address` that runs jobs as tasks.
    `security`: distributed.security.Security for a tls:// scheduler; by default the one the
    service's settings build (api.settings.Settings.dask_security, from RIG_DASK_TLS_*)."""

    def __init__(self, address: str, db_url: str, connect_timeout_s: float | None = None,
                 security: Any = None):
        from distributed import Client

        if security is None and address.startswith("tls://"):
            from api.settings import Settings
            security = Settings.from_env(dask_scheduler=address).dask_security()
        self.address, self.db_masked = address, masked_url(db_url)
        self.client = Client(address, timeout=connect_timeout_s or CONNECT_TIMEOUT_S,
                             set_as_default=False, security=security)
        self.stopped: list[tuple[float, str]] = []
        """The stop Events set and not yet cleared: (time.monotonic() when set, name)."""

    def run(self, job: dict[str, Any], progress: JobProgress) -> list:
        """Run `job` (a claimed job row) on the cluster and return its results; JobCancelled
        (or the stop flag's JobTimeLimit) when it is cancelled or stopped meanwhile: its
        futures are cancelled and its stop Event set, so that its tasks already running stop
        within about a second (EventStop)."""
        self.clear_stop_events(time.monotonic())
        token = uuid.uuid4().hex[:8]
        key = f"rig-job{job['id']}-attempt{job['attempts']}-{token}"
        stop_event = f"rig-job{job['id']}-stop-{token}"
        future = self.client.submit(run_job_task, job, progress.worker, self.db_masked,
                                    stop_event, key=key, pure=False)
        try:
            return _wait_in_order([future], _NoTicks(progress))[0]
        except BaseException:
            self._stop(stop_event)
            self.client.cancel([future])
            raise

    def _stop(self, name: str) -> None:
        """Set the stop Event `name` (the job's running tasks stop); kept for clear_stop_events."""
        from distributed import Event

        try:
            Event(name, client=self.client).set()
        except Exception:       # the scheduler gone: its tasks are gone with it
            log.exception("stop event %s could not be set", name)
            return
        self.stopped.append((time.monotonic(), name))

    def clear_stop_events(self, now: float) -> None:
        """Clear (delete on the scheduler) the stop Events set at least STOP_LINGER_S before
        `now` (time.monotonic() [s])."""
        from distributed import Event

        keep = []
        for t, name in self.stopped:
            if now - t < STOP_LINGER_S:
                keep.append((t, name))
                continue
            try:
                Event(name, client=self.client).clear()
            except Exception:   # the scheduler gone: so are its Events
                log.warning("stop event %s could not be cleared", name)
        self.stopped = keep

    def close(self) -> None:
        """Clear the stop Events old enough, and close the client (the younger ones are left
        set on the scheduler: tasks may still have to see them)."""
        self.clear_stop_events(time.monotonic())
        self.client.close()


class _NoTicks:
    """A JobProgress seen from the claiming worker: checks cancellation, leaves the progress to
    the job task."""

    def __init__(self, progress: JobProgress):
        self.progress = progress

    def check(self) -> None:
        self.progress.check()

    def tick(self, done: int, total: int) -> None:
        pass
