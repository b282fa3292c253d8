"""The job worker: a separate process that claims queued jobs from SQL and runs them (never in
the web process, never in a web request's background task, which would die with it). `python -m api.worker` runs one; the
service starts a pool of them (WorkerPool) and stops them with it.

Each loop turn (`run_once`) first re-queues jobs whose worker is gone (db.jobs.recover_lost),
then claims one job and runs it: a heartbeat thread stamps the job every
RIG_JOB_HEARTBEAT_S; progress reports check for cancellation; the results are written with the
job's end in one transaction; an exception ends the job 'failed' with its error.

The job kind runs here, its chains and Sobol blocks one after another (api.job_runtime.ProgressMap),
or, with RIG_DASK_SCHEDULER set, as a task on that Dask cluster with its chains and blocks spread
over the cluster's workers (api.dask_backend); the claim, heartbeats and the job's end stay here.
Without a reachable scheduler the worker claims nothing (the jobs wait, queued)."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Any

log = logging.getLogger("rig.worker")


class Worker:
    """One worker process's loop over the queue of the database at `db_url`."""

    def __init__(self, db_url: str | None = None, heartbeat_s: float = 2.0,
                 stale_s: float = 30.0, max_attempts: int = 2,
                 dask_scheduler: str | None = None):
        from db.jobs import worker_name
        from db.store import Store

        self.store = Store(db_url)
        self.name = worker_name()
        self.heartbeat_s = heartbeat_s
        self.stale_s = stale_s
        self.max_attempts = max_attempts
        self.dask_scheduler = dask_scheduler
        self.dask = None            # api.dask_backend.DaskJobs, connected on first use
        self.stopping = threading.Event()

    def _dask_ready(self) -> bool:
        """Connect to the Dask scheduler when one is configured; False while it is unreachable."""
        if self.dask_scheduler is None or self.dask is not None:
            return True
        from api.dask_backend import DaskJobs
        try:
            self.dask = DaskJobs(self.dask_scheduler, self.store.url)
        except OSError as e:            # includes timeouts: the jobs stay queued
            log.warning("Dask scheduler %s unreachable (%s); not claiming jobs",
                        self.dask_scheduler, e)
            return False
        return True

    def run_once(self) -> int | None:
        """Recover lost jobs, then claim and run one job; returns its id (None: queue empty, or
        the Dask scheduler is configured but unreachable)."""
        from db import jobs as queue

        queue.recover_lost(self.store, self.stale_s, self.max_attempts)
        if not self._dask_ready():
            return None
        job = queue.claim(self.store, self.name)
        if job is None:
            return None
        self.run_job(job)
        return job["id"]

    def run_job(self, job: dict[str, Any]) -> None:
        from db import jobs as queue
        from api.job_kinds import KINDS, JobCancelled
        from api.job_runtime import JobProgress, ProgressMap, call_kind

        jid = job["id"]
        done = threading.Event()

        def beat() -> None:
            while not done.wait(self.heartbeat_s):
                try:
                    queue.heartbeat(self.store, jid, self.name)
                except Exception:  # a missed beat is retried; the job goes on
                    log.exception("heartbeat of job %s failed", jid)

        progress = JobProgress(self.store, jid, self.name)
        t = threading.Thread(target=beat, name=f"job-{jid}-heartbeat", daemon=True)
        t.start()
        try:
            kind = KINDS.get(job["kind"])
            if kind is None:
                raise ValueError(f"unknown job kind {job['kind']!r}")
            params = kind.params.model_validate(job["params"])
            progress(0.05)
            if self.dask is not None:
                results = self.dask.run(job, progress)
            else:
                results = call_kind(kind, self.store, params, progress, ProgressMap(progress))
            progress(0.95)
            if not queue.finish(self.store, jid, self.name, results):
                log.info("job %s was cancelled or taken over; its results are discarded", jid)
        except JobCancelled as e:
            log.info("%s", e)
        except Exception as e:  # the job's own failure: recorded, the worker goes on
            log.exception("job %s failed", jid)
            queue.fail(self.store, jid, self.name, e)
        finally:
            done.set()
            t.join()

    def close(self) -> None:
        """Close the Dask client (if any) and the store."""
        if self.dask is not None:
            self.dask.close()
            self.dask = None
        self.store.close()

    def serve(self, poll_s: float = 0.5, max_jobs: int | None = None) -> None:
        """Loop until stopped (SIGTERM/SIGINT) or `max_jobs` jobs ran."""
        ran = 0
        while not self.stopping.is_set():
            jid = self.run_once()
            if jid is None:
                self.stopping.wait(poll_s)
                continue
            ran += 1
            if max_jobs is not None and ran >= max_jobs:
                break


def worker_command(db_url: str) -> list[str]:
    """The command line of one worker process on the database at `db_url`."""
    return [sys.executable, "-m", "api.worker", "--db", db_url]


class WorkerPool:
    """`n` worker processes on the database at `db_url`, started and stopped together."""

    def __init__(self, db_url: str, n: int, env: dict[str, str] | None = None):
        self.db_url, self.n = db_url, n
        self.env = env
        self.procs: list[subprocess.Popen] = []

    def start(self) -> "WorkerPool":
        env = {**os.environ, **(self.env or {})}
        self.procs = [subprocess.Popen(worker_command(self.db_url), env=env)
                      for _ in range(self.n)]
        return self

    def stop(self, timeout_s: float = 10.0) -> None:
        """SIGTERM each worker (it ends after its current job's next step), SIGKILL after
        timeout_s; a job killed with its worker is re-queued by the next recovery."""
        for p in self.procs:
            if p.poll() is None:
                p.terminate()
        deadline = time.monotonic() + timeout_s
        for p in self.procs:
            try:
                p.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.procs = []


def main(argv: list[str] | None = None) -> int:
    from api.settings import Settings

    ap = argparse.ArgumentParser(prog="python -m api.worker", description=__doc__.split("\n")[0])
    ap.add_argument("--db", help="database URL (default env RIG_DB_URL)")
    ap.add_argument("--poll", type=float, default=0.5, help="queue poll interval when idle [s]")
    ap.add_argument("--max-jobs", type=int, help="exit after this many jobs")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s worker %(process)d %(message)s")
    logging.getLogger("alembic").setLevel(logging.WARNING)
    st = Settings.from_env(db_url=args.db)
    w = Worker(st.db_url, st.job_heartbeat_s, st.job_stale_s, st.job_max_attempts,
               st.dask_scheduler)

    def stop(*_):
        w.stopping.set()
    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    w.serve(args.poll, args.max_jobs)
    w.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
