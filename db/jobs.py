"""The durable job queue in SQL (table `jobs`): submit, claim, heartbeat, finish, fail,
cancel, and recovery of jobs whose worker is gone.

Claims are atomic: a worker selects the oldest queued job (`FOR UPDATE SKIP LOCKED` on
PostgreSQL; on SQLite the whole transaction holds the write lock, opened `BEGIN IMMEDIATE`
by db.engine) and moves it to 'running' with `UPDATE … WHERE status = 'queued'`, so two
workers never run one job. A job's end is written only while it is still 'running' under the
same worker, so a cancelled or re-queued job never gets a stale result."""

from __future__ import annotations

import json
import os
import socket
import traceback
from datetime import datetime, timedelta, timezone
from typing import Any

from sqlalchemy import select, update
from sqlalchemy.exc import IntegrityError

from core.jsonsafe import json_safe
from db.fits import insert_result
from db.models import Job, Report, Result, ResultRun, utcnow
from db.store import Store, process_token

ACTIVE = ("queued", "running")
FINAL = ("succeeded", "failed", "cancelled")


class IdempotencyConflict(Exception):
    """The Idempotency-Key was used before for a different submission."""


def aware_utc(dt: datetime | None) -> datetime | None:
    """A datetime from the database as UTC-aware (SQLite hands back naive UTC datetimes)."""
    if dt is not None and dt.tzinfo is None:
        return dt.replace(tzinfo=timezone.utc)
    return dt


def worker_name(pid: int | None = None) -> str:
    """'host/pid/token' of a worker process (token guards against PID reuse)."""
    pid = os.getpid() if pid is None else pid
    return f"{socket.gethostname()}/{pid}/{process_token(pid)}"


def job_dict(j: Job, result_ids: list[int] | None = None) -> dict[str, Any]:
    """A job row as the API shows it; timings in s."""
    created, started, finished = aware_utc(j.created_at), aware_utc(j.started_at), aware_utc(j.finished_at)
    return {
        "id": j.id, "kind": j.kind, "state": j.status, "params": j.params,
        "progress": j.progress, "error": j.error, "attempts": j.attempts, "worker": j.worker,
        "created_at": created, "started_at": started, "finished_at": finished,
        "heartbeat_at": aware_utc(j.heartbeat_at),
        "timings": {
            "queued_s": ((started or finished) - created).total_seconds()
            if created and (started or finished) else None,
            "running_s": (finished - started).total_seconds() if started and finished else None,
        },
        "result_ids": result_ids or [],
    }


def submit(store: Store, kind: str, params: dict[str, Any], idempotency_key: str | None = None
           ) -> tuple[dict[str, Any], bool]:
    """Queue a job; returns (job, created). With an idempotency key already used for the same
    kind and parameters, the existing job (created False); for others IdempotencyConflict."""
    run_id = (params.get("run_ids") or [None])[0]
    if idempotency_key is not None:
        found = _by_key(store, idempotency_key, kind, params)
        if found is not None:
            return found, False
    try:
        with store.Session.begin() as s:
            job = Job(kind=kind, status="queued", params=params, run_id=run_id, attempts=0,
                      idempotency_key=idempotency_key, created_at=utcnow())
            s.add(job)
            s.flush()
            out = job_dict(job)
    except IntegrityError:          # a concurrent retry with the same key won the race
        found = _by_key(store, idempotency_key, kind, params)
        if found is None:
            raise
        return found, False
    return out, True


def _by_key(store: Store, key: str | None, kind: str, params: dict[str, Any]
            ) -> dict[str, Any] | None:
    with store.ReadSession() as s:
        j = s.execute(select(Job).where(Job.idempotency_key == key)).scalar_one_or_none()
        if j is None:
            return None
        if j.kind != kind or j.params != params:
            raise IdempotencyConflict(f"Idempotency-Key {key!r} was used for job {j.id} with "
                                      "different parameters")
        return job_dict(j, _result_ids(s, j.id))


def _result_ids(s, job_id: int) -> list[int]:
    return list(s.execute(select(Result.id).where(Result.job_id == job_id)
                          .order_by(Result.id)).scalars())


def get_job(store: Store, job_id: int) -> dict[str, Any] | None:
    with store.ReadSession() as s:
        j = s.get(Job, job_id)
        return None if j is None else job_dict(j, _result_ids(s, job_id))


def list_jobs(store: Store, state: str | None = None, kind: str | None = None,
              limit: int = 100, offset: int = 0) -> list[dict[str, Any]]:
    q = select(Job).order_by(Job.id.desc()).limit(limit).offset(offset)
    if state:
        q = q.where(Job.status == state)
    if kind:
        q = q.where(Job.kind == kind)
    with store.ReadSession() as s:
        jobs = list(s.execute(q).scalars())
        results: dict[int, list[int]] = {}
        if jobs:
            for rid, jid in s.execute(select(Result.id, Result.job_id)
                                      .where(Result.job_id.in_([j.id for j in jobs]))
                                      .order_by(Result.id)):
                results.setdefault(jid, []).append(rid)
        return [job_dict(j, results.get(j.id)) for j in jobs]


def cancel(store: Store, job_id: int) -> dict[str, Any] | None:
    """Cancel a queued or running job (a running one stops at its next progress report, and
    its results are never stored). A finished job is left as it is."""
    with store.Session.begin() as s:
        s.execute(update(Job).where(Job.id == job_id, Job.status.in_(ACTIVE))
                  .values(status="cancelled", finished_at=utcnow(),
                          error="cancelled by request"))
    return get_job(store, job_id)


def claim(store: Store, worker: str | None = None) -> dict[str, Any] | None:
    """Atomically take the oldest queued job for this worker; None when the queue is empty."""
    worker = worker or worker_name()
    now = utcnow()
    with store.Session.begin() as s:
        jid = s.execute(select(Job.id).where(Job.status == "queued").order_by(Job.id).limit(1)
                        .with_for_update(skip_locked=True)).scalar()
        if jid is None:
            return None
        res = s.execute(update(Job).where(Job.id == jid, Job.status == "queued")
                        .values(status="running", worker=worker, worker_pid=os.getpid(),
                                started_at=now, heartbeat_at=now, progress=0.0, error=None,
                                attempts=Job.attempts + 1))
        if res.rowcount != 1:
            return None
        return job_dict(s.get(Job, jid))


def _mine(job_id: int, worker: str):
    return (Job.id == job_id, Job.status == "running", Job.worker == worker)


def heartbeat(store: Store, job_id: int, worker: str, progress: float | None = None) -> str | None:
    """Stamp a running job as alive (and its progress); returns the job's state now
    ('running' while it is still ours)."""
    vals: dict[str, Any] = {"heartbeat_at": utcnow()}
    if progress is not None:
        vals["progress"] = float(progress)
    with store.Session.begin() as s:
        res = s.execute(update(Job).where(*_mine(job_id, worker)).values(**vals))
        if res.rowcount:
            return "running"
    return state_for(store, job_id, worker)


def state_for(store: Store, job_id: int, worker: str) -> str | None:
    """A job's state as `worker` sees it (a read): 'running' while it runs under `worker`,
    'taken over' when it runs under another, else its state (None: no such job)."""
    with store.ReadSession() as s:
        row = s.execute(select(Job.status, Job.worker).where(Job.id == job_id)).first()
    if row is None:
        return None
    status, owner = row
    return "taken over" if status == "running" and owner != worker else status


def queue_counts(store: Store) -> dict[str, Any]:
    """Jobs queued and running now, and how long the oldest queued job has waited [s]."""
    from sqlalchemy import func

    with store.ReadSession() as s:
        counts = dict(s.execute(select(Job.status, func.count()).where(Job.status.in_(ACTIVE))
                                .group_by(Job.status)).all())
        oldest = aware_utc(s.execute(select(func.min(Job.created_at))
                                     .where(Job.status == "queued")).scalar())
    return {"queued": int(counts.get("queued", 0)), "running": int(counts.get("running", 0)),
            "oldest_queued_s": None if oldest is None
            else max(0.0, (utcnow() - oldest).total_seconds())}


json_document = json_safe
"""A JSON-ready copy of a result's document (core.jsonsafe)."""


def finish(store: Store, job_id: int, worker: str, results: list) -> bool:
    """Store a job's results (fits, linked to their runs, with their JSON documents as `reports`
    rows) and mark it 'succeeded', in one transaction; False (nothing stored) when the job is no
    longer ours and running."""
    now = utcnow()
    with store.Session.begin() as s:
        res = s.execute(update(Job).where(*_mine(job_id, worker))
                        .values(status="succeeded", progress=1.0, finished_at=now,
                                heartbeat_at=now))
        if res.rowcount != 1:
            return False            # nothing written in this transaction
        for r in results:
            insert_result(s, r.fit, r.runs, getattr(r, "documents", {}), job_id=job_id, now=now)
    return True


def fail(store: Store, job_id: int, worker: str, error: BaseException | str) -> bool:
    """Mark a running job of ours 'failed' with its error (type, message, traceback tail)."""
    if isinstance(error, BaseException):
        tb = "".join(traceback.format_exception(error)[-6:])
        text = f"{type(error).__name__}: {error}\n{tb}"
    else:
        text = str(error)
    with store.Session.begin() as s:
        res = s.execute(update(Job).where(*_mine(job_id, worker))
                        .values(status="failed", error=text[:20000], finished_at=utcnow()))
        return res.rowcount == 1


def _worker_gone(worker: str | None, beat: datetime | None, now: datetime, stale_s: float) -> bool:
    host, pid, token = (worker or "//").split("/", 2)
    if host == socket.gethostname() and pid.isdigit():
        alive = process_token(int(pid))
        return alive is None or (alive != "alive" and token not in ("None", alive))
    return beat is None or now - beat > timedelta(seconds=stale_s)


def recover_lost(store: Store, stale_s: float = 30.0, max_attempts: int = 2,
                 local_grace_s: float = 0.0) -> list[int]:
    """Jobs left 'running' by a worker that is gone (its process ended on this host, or no
    heartbeat for stale_s from another host): re-queued while attempts < max_attempts, else
    'failed' with the reason. Returns their ids. local_grace_s: a job of a gone worker of this
    host is left alone until its last heartbeat is that old (a worker pool's supervisor, which
    knows how the process ended, records it first: worker_died)."""
    now = utcnow()
    with store.ReadSession() as s:
        rows = s.execute(select(Job.id, Job.worker, Job.heartbeat_at, Job.attempts)
                         .where(Job.status == "running")).all()
    lost = []
    for jid, worker, beat, attempts in rows:
        if not _worker_gone(worker, aware_utc(beat), now, stale_s):
            continue
        beat = aware_utc(beat)
        if local_grace_s > 0 and beat is not None and now - beat < timedelta(seconds=local_grace_s):
            continue
        reason = (f"worker {worker} was lost while running the job "
                  f"(last heartbeat {(aware_utc(beat) or now).isoformat()})")
        with store.Session.begin() as s:
            cond = (Job.id == jid, Job.status == "running", Job.worker == worker)
            if attempts < max_attempts:
                res = s.execute(update(Job).where(*cond).values(
                    status="queued", worker=None, worker_pid=None, progress=None,
                    error=reason + "; re-queued"))
            else:
                res = s.execute(update(Job).where(*cond).values(
                    status="failed", finished_at=now,
                    error=reason + f"; failed after {attempts} attempts"))
            if res.rowcount:
                lost.append(jid)
    return lost


def worker_died(store: Store, worker: str, cause: str, max_attempts: int = 2) -> list[int]:
    """The jobs left 'running' by `worker` ('host/pid/token'), whose process its supervisor saw
    end with `cause` (e.g. 'killed by signal 9 (SIGKILL)'): re-queued while attempts <
    max_attempts, else 'failed' — the job ended its worker process on every attempt it was
    given — with the cause in the reason. Returns their ids."""
    now = utcnow()
    done = []
    with store.Session.begin() as s:
        rows = s.execute(select(Job.id, Job.attempts)
                         .where(Job.status == "running", Job.worker == worker)).all()
        for jid, attempts in rows:
            what = f"its worker process {worker} died while running the job: {cause}"
            if attempts < max_attempts:
                vals = dict(status="queued", worker=None, worker_pid=None, progress=None,
                            error=f"{what}; re-queued (attempt {attempts} of {max_attempts})")
            else:
                vals = dict(status="failed", finished_at=now,
                            error=f"{what}; the job's worker process died on attempt {attempts} "
                                  f"of {max_attempts}: not re-queued")
            res = s.execute(update(Job).where(Job.id == jid, Job.status == "running",
                                              Job.worker == worker).values(**vals))
            if res.rowcount:
                done.append(jid)
    return done


def results_of(store: Store, job_id: int) -> list[dict[str, Any]]:
    """A job's stored results: id, model, method, fit (Fit.as_dict), draws shape, runs, and
    `documents`: {kind: JSON document} of its JSON reports (e.g. 'diagnosis')."""
    with store.ReadSession() as s:
        rows = s.execute(select(Result).where(Result.job_id == job_id)
                         .order_by(Result.id)).scalars().all()
        out = []
        for r in rows:
            links = s.execute(select(ResultRun.run_id, ResultRun.role)
                              .where(ResultRun.result_id == r.id)).all()
            out.append({"id": r.id, "model": r.model, "method": r.method, "fit": r.fit,
                        "draws_shape": r.draws_shape,
                        "runs": [{"run_id": a, "role": b} for a, b in links],
                        "documents": _documents(s, r.id),
                        "created_at": aware_utc(r.created_at)})
        return out


def _documents(s, result_id: int) -> dict[str, Any]:
    rows = s.execute(select(Report.kind, Report.content)
                     .where(Report.result_id == result_id,
                            Report.media_type == "application/json")
                     .order_by(Report.id)).all()
    return {kind: json.loads(content) for kind, content in rows}


def document_of(store: Store, job_id: int, kind: str) -> dict[str, Any] | None:
    """The JSON document of `kind` (e.g. 'diagnosis') stored with one of a job's results."""
    q = (select(Report.content).join(Result, Report.result_id == Result.id)
         .where(Result.job_id == job_id, Report.kind == kind,
                Report.media_type == "application/json").order_by(Report.id).limit(1))
    with store.ReadSession() as s:
        content = s.execute(q).scalar()
    return None if content is None else json.loads(content)


def results_for_run(store: Store, run_id: int, limit: int | None = None, offset: int = 0
                    ) -> list[dict[str, Any]]:
    """The stored results that used a run: result id, job id, model, method and the run's role
    (oldest first; `limit` of them from `offset`, default all)."""
    q = (select(Result.id, Result.job_id, Result.model, Result.method, ResultRun.role)
         .join(ResultRun, ResultRun.result_id == Result.id)
         .where(ResultRun.run_id == run_id).order_by(Result.id, ResultRun.role).offset(offset))
    if limit is not None:
        q = q.limit(limit)
    with store.ReadSession() as s:
        return [{"result_id": a, "job_id": b, "model": c, "method": d, "role": e}
                for a, b, c, d, e in s.execute(q).all()]
