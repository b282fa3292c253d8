"""The job worker: a separate process that claims queued jobs from SQL and runs them (never in
the web process, never in a web request's background task, which would die with it). `python -m api.worker` runs one; the
service starts a pool of them (WorkerPool), supervises them and stops them with it.

Each loop turn (`run_once`) first re-queues jobs whose worker is gone (db.jobs.recover_lost),
then claims one job and runs it: a watchdog thread stamps the job every RIG_JOB_HEARTBEAT_S and
reads its state every STOP_POLL_S; when the job was cancelled (or taken over), or has run past
its kind's wall-clock limit (api.job_kinds), it sets the job's stop flag, which the samplers
poll every iteration (estimator.stopping) — the job then ends 'cancelled', or 'failed' with the
limit in its reason, within a fraction of a second of work. The results are written with the
job's end in one transaction; an exception ends the job 'failed' with its error.

The job kind runs here, its chains and Sobol blocks one after another (api.job_runtime.ProgressMap),
or, with RIG_DASK_SCHEDULER set, as a task on that Dask cluster with its chains and blocks spread
over the cluster's workers (api.dask_backend); the claim, heartbeats and the job's end stay here.
Without a reachable scheduler the worker claims nothing (the jobs wait, queued).

Supervision (WorkerPool): each worker process tells its pool, on a pipe, its name and which job
it starts and ends. The pool's supervisor thread restarts a worker process that died (after
RESTART_BACKOFF_S, doubling while it keeps dying within STABLE_S of its start), records the
cause on the job it was running (db.jobs.worker_died: re-queued, or 'failed' once the job has
ended its worker on each of its RIG_JOB_MAX_ATTEMPTS attempts), and ends a worker process whose
job does not stop within STOP_GRACE_S of being cancelled or of passing its wall-clock limit (a
job stuck in compiled code, which polls nothing). So a job that crashes its worker or hangs
never stops the queue; `GET /health` shows the workers alive and restarted (WorkerPool.stats)."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

log = logging.getLogger("rig.worker")

STOP_POLL_S = 0.2
"""How often a running job's state is read for a cancellation, and its time checked [s]."""
STOP_GRACE_S = 5.0
"""How long a job told to stop may take before its worker process is ended [s]."""
RESTART_BACKOFF_S = (0.5, 30.0)
"""Delay before restarting a dead worker process: the first, and the cap of its doubling [s]."""
STABLE_S = 60.0
"""A worker process that lived this long before dying is restarted after the first delay [s]."""
SUPERVISE_POLL_S = 0.25
"""How often the supervisor looks at its worker processes [s]."""
SUPERVISED_RECOVERY_GRACE_S = 5.0
"""A supervised worker leaves the job of a dead worker of this host to the supervisor this long
(after the job's last heartbeat) before recovering it itself [s]."""


class Worker:
    """One worker process's loop over the queue of the database at `db_url`. `time_limit_s`:
    the wall-clock limit of every job, overriding the kinds' own [s] (RIG_JOB_TIME_LIMIT_S);
    `status_fd`: the pipe to the supervising WorkerPool (None: not supervised)."""

    def __init__(self, db_url: str | None = None, heartbeat_s: float = 2.0,
                 stale_s: float = 30.0, max_attempts: int = 2,
                 dask_scheduler: str | None = None,
                 time_limit_s: float | None = None, status_fd: int | None = None):
        from db.jobs import worker_name
        from db.store import Store

        self.store = Store(db_url)
        self.name = worker_name()
        self.heartbeat_s = heartbeat_s
        self.stale_s = stale_s
        self.max_attempts = max_attempts
        self.dask_scheduler = dask_scheduler
        self.time_limit_s = time_limit_s
        self.status_fd = status_fd
        self.dask = None            # api.dask_backend.DaskJobs, connected on first use
        self.stopping = threading.Event()

    def announce(self, *words: Any) -> None:
        """One line to the supervising pool ('ready NAME', 'start JOB LIMIT_S', 'end JOB')."""
        if self.status_fd is None:
            return
        try:
            os.write(self.status_fd, (" ".join(map(str, words)) + "\n").encode())
        except OSError:             # the pool is gone: nothing to tell
            pass

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

        grace = SUPERVISED_RECOVERY_GRACE_S if self.status_fd is not None else 0.0
        queue.recover_lost(self.store, self.stale_s, self.max_attempts, local_grace_s=grace)
        if not self._dask_ready():
            return None
        job = queue.claim(self.store, self.name)
        if job is None:
            return None
        self.run_job(job)
        return job["id"]

    def _watch(self, jid: int, limit_s: float | None, flag, done: threading.Event) -> None:
        """The running job's watchdog thread: heartbeats, and the stop flag set when the job
        is no longer running under this worker or has run past `limit_s`."""
        from db import jobs as queue
        from api.job_kinds import JobCancelled, JobTimeLimit

        t0 = time.monotonic()
        next_beat = t0 + self.heartbeat_s
        while not done.wait(STOP_POLL_S):
            now = time.monotonic()
            try:
                if now >= next_beat:
                    state = queue.heartbeat(self.store, jid, self.name)
                    next_beat = now + self.heartbeat_s
                else:
                    state = queue.state_for(self.store, jid, self.name)
            except Exception:  # a missed beat or read is retried; the job goes on
                log.exception("watchdog of job %s: the job's state could not be read", jid)
                continue
            if state != "running":
                flag.set(JobCancelled(f"job {jid} is no longer running under {self.name} "
                                      f"({state or 'gone'})"))
            elif limit_s is not None and now - t0 > limit_s:
                flag.set(JobTimeLimit(f"the job ran past its wall-clock limit of {limit_s:g} s "
                                      "and was stopped"))

    def run_job(self, job: dict[str, Any]) -> None:
        from db import jobs as queue
        from api.job_kinds import KINDS, JobCancelled, JobTimeLimit, time_limit_s
        from api.job_runtime import JobProgress, ProgressMap, StopFlag, call_kind
        from estimator.stopping import stop_check

        jid = job["id"]
        limit_s = time_limit_s(job["kind"], self.time_limit_s)
        flag = StopFlag()
        done = threading.Event()
        progress = JobProgress(self.store, jid, self.name, stop=flag)
        t = threading.Thread(target=self._watch, args=(jid, limit_s, flag, done),
                             name=f"job-{jid}-watchdog", daemon=True)
        self.announce("start", jid, "-" if limit_s is None else f"{limit_s:g}")
        t.start()
        try:
            kind = KINDS.get(job["kind"])
            if kind is None:
                raise ValueError(f"unknown job kind {job['kind']!r}")
            params = kind.params.model_validate(job["params"])
            progress(0.05)
            with stop_check(flag.check):
                if self.dask is not None:
                    results = self.dask.run(job, progress)
                else:
                    results = call_kind(kind, self.store, params, progress, ProgressMap(progress))
            progress(0.95)
            if not queue.finish(self.store, jid, self.name, results):
                log.info("job %s was cancelled or taken over; its results are discarded", jid)
        except JobCancelled as e:
            log.info("%s", e)
        except JobTimeLimit as e:
            log.warning("job %s: %s", jid, e)
            queue.fail(self.store, jid, self.name, str(e))
        except Exception as e:  # the job's own failure: recorded, the worker goes on
            log.exception("job %s failed", jid)
            queue.fail(self.store, jid, self.name, e)
        finally:
            done.set()
            t.join()
            self.announce("end", jid)

    def close(self) -> None:
        """Close the Dask client (if any) and the store."""
        if self.dask is not None:
            self.dask.close()
            self.dask = None
        self.store.close()

    def serve(self, poll_s: float = 0.5, max_jobs: int | None = None) -> None:
        """Loop until stopped (SIGTERM/SIGINT) or `max_jobs` jobs ran."""
        self.announce("ready", self.name)
        ran = 0
        while not self.stopping.is_set():
            jid = self.run_once()
            if jid is None:
                self.stopping.wait(poll_s)
                continue
            ran += 1
            if max_jobs is not None and ran >= max_jobs:
                break


def exit_cause(returncode: int) -> str:
    """How a process ended, from its Popen return code, in words."""
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = "unknown signal"
        crash = " — a crash in compiled code"
        hint = {"SIGKILL": " — out of memory, or killed", "SIGSEGV": crash, "SIGBUS": crash,
                "SIGILL": crash, "SIGABRT": " — aborted, e.g. a crash in compiled code"
                }.get(name, "")
        return f"killed by signal {-returncode} ({name}{hint})"
    return f"exited with status {returncode}"


@dataclass
class _Slot:
    """One place of the pool: its current worker process and what the pool knows of it."""
    proc: subprocess.Popen | None = None
    name: str | None = None                 # 'host/pid/token', from its 'ready' line
    job: tuple[int, float | None, float] | None = None   # (job id, limit [s], monotonic start)
    stop_seen: float | None = None          # when its job was first seen cancelled/taken
    kill_reason: str | None = None          # why the supervisor ended it
    started: float = 0.0
    quick_deaths: int = 0
    restart_at: float = 0.0
    restarts: int = 0
    last_exit: dict[str, Any] | None = None
    reader: threading.Thread | None = None


class WorkerPool:
    """`n` supervised worker processes on the database at `db_url`, started and stopped
    together (see the module docstring). `command`: the command line of one worker without its
    --status-fd (default `python -m api.worker`; the database URL reaches it as RIG_DB_URL in
    its environment, never on its command line); `max_attempts`: the claims of one job
    before a job whose worker died is failed (RIG_JOB_MAX_ATTEMPTS)."""

    def __init__(self, db_url: str, n: int, env: dict[str, str] | None = None,
                 command: list[str] | None = None, max_attempts: int = 2,
                 grace_s: float = STOP_GRACE_S,
                 backoff_s: tuple[float, float] = RESTART_BACKOFF_S):
        self.db_url, self.n = db_url, n
        self.env = env
        self.command = list(command) if command else [sys.executable, "-m", "api.worker"]
        self.max_attempts = max_attempts
        self.grace_s = grace_s
        self.backoff_s = backoff_s
        self.slots: list[_Slot] = []
        self.store = None
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def procs(self) -> list[subprocess.Popen]:
        """The worker processes now started (dead ones not yet restarted included)."""
        return [s.proc for s in self.slots if s.proc is not None]

    def start(self) -> "WorkerPool":
        from db.store import Store

        self.store = Store(self.db_url, upgrade=False, recover=False)
        self.slots = [_Slot() for _ in range(self.n)]
        for slot in self.slots:
            self._spawn(slot)
        self._thread = threading.Thread(target=self._supervise, name="worker-supervisor",
                                        daemon=True)
        self._thread.start()
        return self

    def _spawn(self, slot: _Slot) -> None:
        r, w = os.pipe()
        # the database URL (with its password) by environment, never on the command line
        env = {**os.environ, **(self.env or {}), "RIG_DB_URL": self.db_url}
        try:
            proc = subprocess.Popen([*self.command, "--status-fd", str(w)],
                                    env=env, pass_fds=(w,))
        except BaseException:
            os.close(r)
            raise
        finally:
            os.close(w)
        with self._lock:
            slot.proc, slot.name, slot.job, slot.stop_seen = proc, None, None, None
            slot.kill_reason = None
            slot.started = time.monotonic()
        slot.reader = threading.Thread(target=self._read, args=(slot, proc, r),
                                       name=f"worker-{proc.pid}-status", daemon=True)
        slot.reader.start()

    def _read(self, slot: _Slot, proc: subprocess.Popen, fd: int) -> None:
        """Follow one worker process's status lines until it exits."""
        with os.fdopen(fd, "r", encoding="utf-8", errors="replace") as f:
            for line in f:
                words = line.split()
                with self._lock:
                    if slot.proc is not proc or not words:
                        continue
                    if words[0] == "ready" and len(words) == 2:
                        slot.name = words[1]
                    elif words[0] == "start" and len(words) == 3:
                        limit = None if words[2] == "-" else float(words[2])
                        slot.job, slot.stop_seen = (int(words[1]), limit, time.monotonic()), None
                    elif words[0] == "end":
                        slot.job, slot.stop_seen = None, None

    def _supervise(self) -> None:
        while not self._stopping.wait(SUPERVISE_POLL_S):
            for slot in self.slots:
                if self._stopping.is_set():
                    return
                try:
                    self._look_after(slot)
                except Exception:  # e.g. the database unreachable: try again next turn
                    log.exception("worker supervisor")

    def _look_after(self, slot: _Slot) -> None:
        from db import jobs as queue

        now = time.monotonic()
        proc = slot.proc
        if proc is None:
            if now >= slot.restart_at:
                try:
                    self._spawn(slot)
                except OSError:         # e.g. out of memory: try again after the longest delay
                    slot.restart_at = now + self.backoff_s[1]
                    raise
                slot.restarts += 1
                log.warning("worker process restarted (pid %s, restart %d of this slot)",
                            slot.proc.pid, slot.restarts)
            return
        rc = proc.poll()
        if rc is not None:
            self._reap(slot, proc, rc, now)
            return
        if slot.job is None or slot.name is None:
            return
        jid, limit_s, t0 = slot.job
        if limit_s is not None and now - t0 > limit_s + self.grace_s:
            reason = (f"the job ran past its wall-clock limit of {limit_s:g} s and did not stop "
                      f"within {self.grace_s:g} s: its worker process was ended")
            queue.fail(self.store, jid, slot.name, reason)
            self._kill(slot, proc, f"ended by its supervisor: job {jid} ran past its wall-clock "
                                   f"limit of {limit_s:g} s and did not stop")
            return
        state = queue.state_for(self.store, jid, slot.name)
        if state == "running":
            return
        if slot.stop_seen is None:
            slot.stop_seen = now
        elif now - slot.stop_seen > self.grace_s:
            self._kill(slot, proc, f"ended by its supervisor: job {jid} was {state} but did not "
                                   f"stop within {self.grace_s:g} s")

    def _kill(self, slot: _Slot, proc: subprocess.Popen, reason: str) -> None:
        log.warning("worker process %s %s", proc.pid, reason)
        slot.kill_reason = reason
        proc.kill()

    def _reap(self, slot: _Slot, proc: subprocess.Popen, rc: int, now: float) -> None:
        """A dead worker process: record the cause on its job, schedule its restart."""
        from db import jobs as queue

        if slot.reader is not None:
            slot.reader.join(2.0)           # its last status lines (name, job) are read
        cause = slot.kill_reason or exit_cause(rc)
        jobs = queue.worker_died(self.store, slot.name, cause, self.max_attempts) \
            if slot.name else []
        lived = now - slot.started
        slot.quick_deaths = slot.quick_deaths + 1 if lived < STABLE_S else 1
        first, cap = self.backoff_s
        delay = min(cap, first * 2.0 ** (slot.quick_deaths - 1))
        log.error("worker process %s %s after %.1f s%s; restarting in %.1f s", proc.pid, cause,
                  lived, f" while running job(s) {jobs}" if jobs else "", delay)
        with self._lock:
            slot.last_exit = {"pid": proc.pid, "cause": cause, "jobs": jobs,
                              "at": datetime.now(timezone.utc).isoformat()}
            slot.proc, slot.job, slot.stop_seen = None, None, None
            slot.restart_at = now + delay

    def stats(self) -> dict[str, Any]:
        """The pool now: worker processes configured, alive, restarted (in all), busy, and
        whether the queue is being served (at least one worker process alive)."""
        with self._lock:
            alive = [s for s in self.slots if s.proc is not None and s.proc.poll() is None]
            workers = [{"pid": s.proc.pid if s.proc is not None else None,
                        "alive": s in alive, "job": s.job[0] if s.job else None,
                        "restarts": s.restarts, "last_exit": s.last_exit}
                       for s in self.slots]
        return {"configured": self.n, "alive": len(alive),
                "restarts": sum(s.restarts for s in self.slots),
                "busy": sum(1 for w in workers if w["job"] is not None),
                "serving": len(alive) > 0, "workers": workers}

    def stop_supervising(self) -> None:
        """End the supervisor thread: dead workers are no longer restarted nor recorded."""
        self._stopping.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stop supervising, SIGTERM each worker (it ends after its current job's next step),
        SIGKILL after timeout_s; a job killed with its worker is re-queued by the next
        recovery."""
        self.stop_supervising()
        procs = self.procs
        for p in procs:
            if p.poll() is None:
                p.terminate()
        deadline = time.monotonic() + timeout_s
        for p in procs:
            try:
                p.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for slot in self.slots:
            if slot.reader is not None:
                slot.reader.join(2.0)
            slot.proc = None
        if self.store is not None:
            self.store.close()
            self.store = None


PARENT_POLL_S = 0.5
"""How often a pool's worker checks that the service that started it is alive [s]."""


def follow_parent(parent: int, poll_s: float = PARENT_POLL_S) -> threading.Thread:
    """End this worker process when `parent` (the service whose pool started it) is gone, e.g.
    killed by SIGKILL: an orphan would go on taking jobs from the queue that no service
    supervises, with no wall-clock limit enforced from outside. The process ends at once
    (os._exit): its job is left 'running' with a heartbeat that stops, and is re-queued as after
    any worker crash (db.jobs: stale heartbeat, start-up re-queue)."""
    def watch() -> None:
        while True:
            time.sleep(poll_s)
            if os.getppid() != parent:
                log.error("the service (pid %d) that started this worker is gone: exiting", parent)
                logging.shutdown()
                os._exit(3)
    t = threading.Thread(target=watch, name="parent-watch", daemon=True)
    t.start()
    return t


def main(argv: list[str] | None = None) -> int:
    from api.settings import Settings

    ap = argparse.ArgumentParser(prog="python -m api.worker", description=__doc__.split("\n")[0])
    ap.add_argument("--db", help="database URL (default env RIG_DB_URL)")
    ap.add_argument("--poll", type=float, default=0.5, help="queue poll interval when idle [s]")
    ap.add_argument("--max-jobs", type=int, help="exit after this many jobs")
    ap.add_argument("--status-fd", type=int,
                    help="pipe to the supervising pool (WorkerPool passes it)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s worker %(process)d %(message)s")
    logging.getLogger("alembic").setLevel(logging.WARNING)
    st = Settings.from_env(db_url=args.db)
    w = Worker(st.db_url, st.job_heartbeat_s, st.job_stale_s, st.job_max_attempts,
               st.dask_scheduler, time_limit_s=st.job_time_limit_s, status_fd=args.status_fd)

    def stop(*_):
        w.stopping.set()
    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    if args.status_fd is not None:
        follow_parent(os.getppid())
    w.serve(args.poll, args.max_jobs)
    w.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
