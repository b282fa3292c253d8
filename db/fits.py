"""Stored identification results (tables `results`, `result_runs`, `reports`): the one place
their rows are written and read.

A result is an estimator Fit (`Fit.as_dict()` in `results.fit`, its posterior draws as a
little-endian float64 blob of shape `draws_shape`), linked to the runs it used with their role
('train', 'test'), and optionally JSON documents that belong to it (`reports` rows of media type
application/json, e.g. the diagnosis report). The API's jobs write them through db.jobs.finish
(with their job id); `rig identify` on stored runs writes the same rows with no job
(`job_id` NULL)."""

from __future__ import annotations

import json
from datetime import datetime, timezone
from typing import Any, Mapping

import numpy as np
from sqlalchemy import insert, select

from core.jsonsafe import json_safe
from db.models import Report, Result, ResultRun, Run, utcnow
from db.store import RunNotFound, Store


def insert_result(s, fit: Any, runs: Mapping[int, str], documents: Mapping[str, Any] | None = None,
                  *, job_id: int | None = None, now: datetime | None = None) -> int:
    """Insert one fit (an estimator.result.Fit) with its run links and JSON documents in the
    open session `s` (the caller owns the transaction); returns the result id."""
    now = now or utcnow()
    draws = None if fit.draws is None else np.ascontiguousarray(fit.draws, dtype="<f8")
    rid = s.execute(insert(Result).values(
        job_id=job_id, model=fit.model, method=fit.method, fit=fit.as_dict(),
        draws=None if draws is None else draws.tobytes(),
        draws_shape=None if draws is None else list(draws.shape),
        created_at=now).returning(Result.id)).scalar_one()
    for run_id, role in runs.items():
        s.execute(insert(ResultRun).values(result_id=rid, run_id=int(run_id), role=role))
    title = f"of job {job_id}" if job_id is not None else f"of fit {rid}"
    for kind, doc in (documents or {}).items():
        s.execute(insert(Report).values(
            kind=kind, title=f"{kind} {title}", result_id=rid,
            media_type="application/json", created_at=now,
            content=json.dumps(json_safe(doc), allow_nan=False).encode("utf-8")))
    return rid


def save_fit(store: Store, fit: Any, runs: Mapping[int, str],
             documents: Mapping[str, Any] | None = None) -> int:
    """Store one fit made outside a job (e.g. by `rig identify`) linked to its stored runs, in
    one transaction; returns its result id. RunNotFound (nothing stored) when a run is not in
    the store."""
    with store.Session.begin() as s:
        known = set(s.execute(select(Run.id).where(Run.id.in_([int(r) for r in runs]))).scalars())
        missing = sorted(int(r) for r in runs if int(r) not in known)
        if missing:
            raise RunNotFound(missing[0])
        return insert_result(s, fit, runs, documents)


def _utc(dt: datetime | None) -> datetime | None:
    """SQLite hands back naive datetimes: they were stored in UTC."""
    return dt.replace(tzinfo=timezone.utc) if dt is not None and dt.tzinfo is None else dt


def _summary(r: Result, links: list[tuple[int, str]]) -> dict[str, Any]:
    d = r.fit or {}
    return {"id": r.id, "job_id": r.job_id, "model": r.model, "method": r.method,
            "created_at": _utc(r.created_at),
            "sigma": d.get("sigma"), "rmse_train": d.get("rmse_train"),
            "rmse_test": d.get("rmse_test"), "draws_shape": r.draws_shape,
            "runs": [{"run_id": a, "role": b} for a, b in sorted(links)]}


def _links(s, ids: list[int]) -> dict[int, list[tuple[int, str]]]:
    out: dict[int, list[tuple[int, str]]] = {i: [] for i in ids}
    if ids:
        for rid, run_id, role in s.execute(
                select(ResultRun.result_id, ResultRun.run_id, ResultRun.role)
                .where(ResultRun.result_id.in_(ids))).all():
            out[rid].append((run_id, role))
    return out


def list_fits(store: Store, *, run_id: int | None = None, model: str | None = None,
              method: str | None = None, limit: int = 100, offset: int = 0
              ) -> list[dict[str, Any]]:
    """Stored fits, newest first: id, job_id (None for a fit made by `rig identify`), model,
    method, created_at, sigma, rmse_train, rmse_test [output unit], draws_shape and runs
    [{run_id, role}]. run_id keeps the fits that used that run; model matches the model's base
    name or its full spec ('eq4' matches 'eq4+stribeck')."""
    q = select(Result).order_by(Result.id.desc())
    if run_id is not None:
        q = q.where(Result.id.in_(select(ResultRun.result_id).where(ResultRun.run_id == run_id)))
    if model:
        q = q.where((Result.model == model) | Result.model.like(f"{model}+%"))
    if method:
        q = q.where(Result.method == method)
    with store.ReadSession() as s:
        rows = s.execute(q.limit(limit).offset(offset)).scalars().all()
        links = _links(s, [r.id for r in rows])
        return [_summary(r, links[r.id]) for r in rows]


def get_fit(store: Store, result_id: int, *, draws: bool = False) -> dict[str, Any] | None:
    """One stored fit: its summary (list_fits' keys), `fit` (Fit.as_dict), `documents`
    ({kind: JSON document}) and, with draws=True, `draws` as a (chains, draws, p) array.
    None when there is no such fit."""
    with store.ReadSession() as s:
        r = s.get(Result, result_id)
        if r is None:
            return None
        out = _summary(r, _links(s, [r.id])[r.id])
        out["fit"] = r.fit
        rows = s.execute(select(Report.kind, Report.content)
                         .where(Report.result_id == r.id,
                                Report.media_type == "application/json")
                         .order_by(Report.id)).all()
        out["documents"] = {kind: json.loads(content) for kind, content in rows}
        if draws:
            out["draws"] = (None if r.draws is None or not r.draws_shape else
                            np.frombuffer(r.draws, dtype="<f8").reshape(r.draws_shape).copy())
        return out
