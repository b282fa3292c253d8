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
import time
import uuid
from typing import Any, Callable, Iterable

from api.job_runtime import JobProgress, call_kind

log = logging.getLogger("rig.dask")

CONNECT_TIMEOUT_S = 10.0
"""How long a worker tries to reach the scheduler before it gives up for this loop turn [s]."""
POLL_S = 0.1
"""How often a waiting loop looks at its futures [s] (cancellation: read at most once a second)."""


def _on_worker(item: Any, fn: Callable[[Any], Any]) -> tuple[Any, str]:
    """fn(item) on a Dask worker, with that worker's address."""
    from distributed import get_worker

    return fn(item), get_worker().address


class DaskMap:
    """map(fn, items) -> [fn(item), …] in order, each item a Dask task. Reports progress as the
    tasks finish and checks for cancellation while waiting (JobProgress); `records` lists every
    task's key and the worker that returned its result. in_task=True: called from inside a Dask
    task, which leaves the worker's thread pool while it waits."""

    def __init__(self, client, progress: JobProgress, prefix: str, in_task: bool = False):
        self.client, self.progress, self.prefix, self.in_task = client, progress, prefix, in_task
        self.records: list[dict[str, str]] = []
        self.calls = 0

    def __call__(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
        from distributed import rejoin, secede

        items = list(items)
        self.calls += 1
        name = getattr(fn, "__name__", "fn").strip("<>")
        keys = [f"{self.prefix}-{name}-{self.calls}-{i}-{uuid.uuid4().hex[:8]}"
                for i in range(len(items))]
        futures = self.client.map(_on_worker, items, fn=fn, key=keys, pure=False)
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
    task error) ends the wait."""
    results: list[Any] = [None] * len(futures)
    pending = set(range(len(futures)))
    while pending:
        progress.check()
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


def run_job_task(job: dict[str, Any], worker: str, db_masked: str) -> list:
    """A job's kind run as a Dask task: opens its own Store on this Dask worker's database
    (RIG_DB_URL in its environment; RuntimeError if that is not the claiming service's
    database, `db_masked`), reports progress as the claiming `worker`, spreads chains and Sobol
    blocks over the cluster (DaskMap); returns the results (api.job_kinds.StoredResult), each
    fit annotated with fit.extra['dask']."""
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
        dmap = DaskMap(client, progress, prefix=f"rig-job{job['id']}", in_task=True)
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

    def run(self, job: dict[str, Any], progress: JobProgress) -> list:
        """Run `job` (a claimed job row) on the cluster and return its results; JobCancelled
        when it is cancelled meanwhile (its tasks are cancelled too)."""
        key = f"rig-job{job['id']}-attempt{job['attempts']}-{uuid.uuid4().hex[:8]}"
        future = self.client.submit(run_job_task, job, progress.worker, self.db_masked,
                                    key=key, pure=False)
        try:
            return _wait_in_order([future], _NoTicks(progress))[0]
        except BaseException:
            self.client.cancel([future])
            raise

    def close(self) -> None:
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
