"""/runs: list and filter, detail, channel data (time range, decimation), per-phase aggregates
(SQL) and acceptance indicators (Table 11). Viewer role."""

from __future__ import annotations

import json
from datetime import datetime
from enum import IntEnum
from typing import Any, Iterator, Literal

from fastapi import APIRouter, HTTPException, Query, Response
from fastapi.responses import StreamingResponse
from sqlalchemy import select

from api.answers import Acceptance, PhaseAggregate, RunDetail, RunSamples, RunSummary
from api.deps import ERRORS, Id, MAX_ID, StoreDep, Viewer
from db.jobs import aware_utc, results_for_run
from db.models import Rig, Run
from db.store import RunNotFound
from core.jsonsafe import finite_list

router = APIRouter(prefix="/runs", tags=["runs"], responses=ERRORS)

class Direction(IntEnum):
    """Sense of motion of a run (meta 'direction')."""
    forward = 1
    reverse = -1


MAX_POINTS = 100_000
"""Most samples per channel one data request returns (ask for decimation beyond)."""

MAX_LIST = 5000
"""Most items of each list one run detail request returns (page with offset beyond)."""


def _summary(r: Run, rig: str | None) -> dict[str, Any]:
    meta = r.meta or {}
    return {"id": r.id, "rig": rig, "scheme": r.scheme, "source": r.source, "status": r.status,
            "exit_status": r.exit_status, "motor_speed_rpm": meta.get("motor_speed_rpm"),
            "direction": meta.get("direction"),
            "operator": None if meta.get("operator") is None else str(meta["operator"]),
            "started_at": aware_utc(r.started_at),
            "stopped_at": aware_utc(r.stopped_at), "n_samples": r.n_samples, "t_last": r.t_last}


@router.get("", summary="List runs, newest first, with filters",
            response_model=list[RunSummary])
def list_runs(store: StoreDep, _: Viewer,
              scheme: int | None = Query(None, ge=1, le=3),
              speed: float | None = Query(None, ge=0, le=1e5, description="motor speed [r/min]"),
              direction: Direction | None = Query(None, description="+1 or -1"),
              rig: str | None = Query(None, max_length=200),
              status: Literal["running", "finished", "interrupted"] | None = None,
              source: str | None = Query(None, max_length=20),
              operator: str | None = Query(None, max_length=200, description="who ran it"),
              started_after: datetime | None = None, started_before: datetime | None = None,
              limit: int = Query(100, ge=1, le=1000), offset: int = Query(0, ge=0, le=MAX_ID)
              ) -> list[dict[str, Any]]:
    q = select(Run, Rig.name).outerjoin(Rig, Rig.id == Run.rig_id).order_by(Run.id.desc())
    if scheme is not None:
        q = q.where(Run.scheme == scheme)
    if speed is not None:
        q = q.where(Run.meta["motor_speed_rpm"].as_float() == speed)
    if direction is not None:
        q = q.where(Run.meta["direction"].as_integer() == int(direction))
    if rig:
        q = q.where(Rig.name == rig)
    if status:
        q = q.where(Run.status == status)
    if source:
        q = q.where(Run.source == source)
    if operator:
        q = q.where(Run.meta["operator"].as_string() == operator)
    if started_after is not None:
        q = q.where(Run.started_at >= started_after)
    if started_before is not None:
        q = q.where(Run.started_at < started_before)
    with store.ReadSession() as s:
        return [_summary(r, name) for r, name in s.execute(q.limit(limit).offset(offset)).all()]


def _info(store, run_id: int) -> dict[str, Any]:
    try:
        return store.run_info(run_id)
    except RunNotFound:
        raise HTTPException(404, f"no run {run_id}") from None


@router.get("/{run_id}", summary="A run: status, metadata, channels, interruptions, results using it",
            response_model=RunDetail)
def get_run(run_id: Id, store: StoreDep, _: Viewer,
            limit: int = Query(500, ge=1, le=MAX_LIST,
                               description="most items of each list (channels, interruptions, results)"),
            offset: int = Query(0, ge=0, le=MAX_ID, description="items of each list skipped")
            ) -> dict[str, Any]:
    """The lists are paged alike (`limit` items of each from `offset`, in stored order); how
    many each holds in all is under "totals"."""
    info = _info(store, run_id)
    info["channels"] = store.channels(run_id, limit, offset)
    info["interruptions"] = store.interruptions(run_id, limit, offset)
    info["results"] = results_for_run(store, run_id, limit, offset)
    info["totals"] = store.list_totals(run_id)
    return info


_jsonable = finite_list


@router.get("/{run_id}/data", summary="Channel samples in a time range, decimated",
            response_model=RunSamples)
def run_data(run_id: Id, store: StoreDep, _: Viewer,
             channels: str | None = Query(None, max_length=2000,
                                          description="comma-separated channel names (default all)"),
             t_start: float | None = Query(None, ge=-1e12, le=1e12, description="from this run time [s]"),
             t_end: float | None = Query(None, ge=-1e12, le=1e12, description="up to this run time [s]"),
             every: int = Query(1, ge=1, le=MAX_ID, description="keep every n-th sample"),
             max_points: int = Query(10_000, ge=1, le=MAX_POINTS,
                                     description="decimate further to at most this many")
             ) -> Response:
    """Streamed as JSON: {"run_id", "n" (samples per channel), "every" (stride over the samples
    in range), "n_in_range", "max_points", "capped" (true when max_points decimated beyond
    `every`), "channels": {name: [values]}} with "t" first. Reads only the pages holding
    samples of the range and only the channels asked, a few pages at a time
    (Store.select_range / range_values), so memory does not grow with the run."""
    names = None
    if channels:
        names = [c.strip() for c in channels.split(",") if c.strip()]
        names = ["t"] + [c for c in names if c != "t"]
    try:
        sel = store.select_range(run_id, names, t_start, t_end, every, max_points)
    except RunNotFound:
        raise HTTPException(404, f"no run {run_id}") from None
    except KeyError as e:           # a channel the run does not have
        raise HTTPException(404, str(e.args[0] if e.args else e)) from None
    head = {"run_id": run_id, "n": sel.n, "every": sel.every, "n_in_range": sel.n_in_range,
            "max_points": max_points, "capped": sel.every > every}

    def body() -> Iterator[bytes]:
        yield json.dumps(head)[:-1].encode() + b', "channels": {'
        for k, ch in enumerate(sel.channels):
            yield (", " if k else "").encode() + json.dumps(ch.name).encode() + b": ["
            first = True
            for chunk in store.range_values(sel, ch):
                if chunk.size:
                    text = json.dumps(_jsonable(chunk), allow_nan=False)[1:-1]
                    yield (text if first else ", " + text).encode()
                    first = False
            yield b"]"
        yield b"}}"
    return StreamingResponse(body(), media_type="application/json")


def _finished_key(store, run_id: int) -> tuple | None:
    """(created_at, status, pages, samples) of a run no longer being written, None for a run
    still running: what its stored samples depend on. One light query; 404 for no such run."""
    with store.ReadSession() as s:
        row = s.execute(select(Run.created_at, Run.status, Run.n_pages, Run.n_samples)
                        .where(Run.id == run_id)).one_or_none()
    if row is None:
        raise HTTPException(404, f"no run {run_id}")
    return None if row.status == "running" else tuple(row)


@router.get("/{run_id}/aggregates", summary="Per-phase mean, variance, min, max, count (SQL)",
            response_model=list[PhaseAggregate])
def run_aggregates(run_id: Id, store: StoreDep, _: Viewer, by_phase: bool = True) -> Response:
    """Computed in SQL over the page statistics; for a run no longer being written, once per
    service process and kept encoded (api/response_cache.py), keyed by the run's page and
    sample counts."""
    from api.reports import json_clean
    from api.response_cache import cache_for, json_bytes

    key = _finished_key(store, run_id)

    def compute() -> bytes:
        try:
            df = store.phase_aggregates(run_id, by_phase=by_phase)
        except RunNotFound:
            raise HTTPException(404, f"no run {run_id}") from None
        return json_bytes(json_clean(df.to_dict(orient="records")))
    body = compute() if key is None else cache_for(store).get_or_compute(
        ("aggregates", run_id, by_phase, key), compute, len)
    return Response(body, media_type="application/json")


@router.get("/{run_id}/acceptance", summary="Acceptance indicators (Table 11) with pass/fail",
            response_model=Acceptance)
def run_acceptance(run_id: Id, store: StoreDep, _: Viewer) -> dict[str, Any]:
    """Judged on the whole run; for a run no longer being written, once per service process
    (api/response_cache.py), keyed by the run's row (samples, pages, metadata)."""
    from api.reports import json_clean
    from api.response_cache import cache_for, run_row_key
    from core.acceptance import acceptance

    info = _info(store, run_id)

    def compute() -> dict[str, Any]:
        ind = [i.as_dict() for i in acceptance(store.load_run(run_id))]
        judged = [i["passed"] for i in ind if i["passed"] is not None]
        return json_clean({"run_id": run_id, "passed": all(judged) if judged else None,
                           "indicators": ind})
    row = run_row_key(info)
    if row is None:
        return compute()
    return cache_for(store).get_or_compute(("acceptance", run_id, row), compute)


@router.get("/{run_id}/file", summary="The run in the interchange format (run-format.md), as a "
                                      "zip of run-<id>.csv|.parquet and run-<id>.json",
            response_class=Response,
            responses={200: {"content": {"application/zip": {}}}})
def run_file(run_id: Id, store: StoreDep, _: Viewer,
             format: Literal["csv", "parquet"] = Query("csv", description="sample file format")
             ) -> Response:
    from db.run_export import run_archive

    _info(store, run_id)
    try:
        body = run_archive(store, run_id, format)
    except RunNotFound:
        raise HTTPException(404, f"no run {run_id}") from None
    return Response(body, media_type="application/zip", headers={
        "Content-Disposition": f'attachment; filename="run-{run_id}.zip"'})
