"""/reports: a test report per run and per job, as an HTML page with SVG plots or as JSON.
Viewer role."""

from __future__ import annotations

from typing import Any, Callable

from fastapi import APIRouter, HTTPException
from fastapi.responses import HTMLResponse, Response

from api import reports
from api.answers import JobReport, RunReport
from api.deps import ERRORS, Id, StoreDep, Viewer
from db.store import RunNotFound

router = APIRouter(prefix="/reports", tags=["reports"], responses=ERRORS)


def _cached_run(store, run_id: int, what: str, compute: Callable[[], Any]) -> Any:
    """`compute()` (a run report in some form), once per service process while the run and
    what refers to it are unchanged (api/response_cache.py: keyed by the run's fingerprint;
    runs still being written are not cached). 404 for a run that does not exist."""
    from api.response_cache import cache_for, run_fingerprint
    try:
        fp = run_fingerprint(store, store.run_info(run_id))
        if fp is None:
            return compute()
        return cache_for(store).get_or_compute((what, run_id, fp), compute)
    except RunNotFound:
        raise HTTPException(404, f"no run {run_id}") from None


def _job(store, job_id: int, plots: bool) -> dict[str, Any]:
    rep = reports.job_report(store, job_id, with_plots=plots)
    if rep is None:
        raise HTTPException(404, f"no job {job_id}")
    return rep


def _cached_job(store, job_id: int, what: str, compute: Callable[[], Any]) -> Any:
    """`compute()` (a job report in some form), once per service process while the job and its
    results' documents are unchanged (api/response_cache.py: keyed by job_fingerprint; jobs
    still queued or running are not cached). 404 for a job that does not exist."""
    from api.response_cache import cache_for, job_fingerprint
    from db.jobs import get_job
    job = get_job(store, job_id)
    if job is None:
        raise HTTPException(404, f"no job {job_id}")
    fp = job_fingerprint(store, job)
    if fp is None:
        return compute()
    return cache_for(store).get_or_compute((what, job_id, fp), compute, len)


@router.get("/runs/{run_id}", summary="Run report (JSON, without the figures)",
            response_model=RunReport)
def run_report_json(run_id: Id, store: StoreDep, _: Viewer) -> Response:
    from api.response_cache import json_bytes
    body = _cached_run(store, run_id, "report-json",
                       lambda: json_bytes(reports.run_report(store, run_id, with_plots=False)))
    return Response(body, media_type="application/json")


@router.get("/runs/{run_id}/html", response_class=HTMLResponse, summary="Run report page")
def run_report_html(run_id: Id, store: StoreDep, _: Viewer) -> HTMLResponse:
    page = _cached_run(store, run_id, "page", lambda: reports.run_report_html(
        reports.run_report(store, run_id, with_plots=True)).encode("utf-8"))
    return HTMLResponse(page)


@router.get("/jobs/{job_id}", summary="Job report (JSON, without the figures)",
            response_model=JobReport)
def job_report_json(job_id: Id, store: StoreDep, _: Viewer) -> Response:
    from api.response_cache import json_bytes
    body = _cached_job(store, job_id, "job-report-json",
                       lambda: json_bytes(_job(store, job_id, plots=False)))
    return Response(body, media_type="application/json")


@router.get("/jobs/{job_id}/html", response_class=HTMLResponse, summary="Job report page")
def job_report_html(job_id: Id, store: StoreDep, _: Viewer) -> HTMLResponse:
    page = _cached_job(store, job_id, "job-page", lambda: reports.job_report_html(
        _job(store, job_id, plots=True)).encode("utf-8"))
    return HTMLResponse(page)
