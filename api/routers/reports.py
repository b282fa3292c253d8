"""/reports: a test report per run and per job, as an HTML page with SVG plots or as JSON.
Viewer role."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException
from fastapi.responses import HTMLResponse

from api import reports
from api.deps import ERRORS, Id, StoreDep, Viewer
from db.store import RunNotFound

router = APIRouter(prefix="/reports", tags=["reports"], responses=ERRORS)


def _run(store, run_id: int, plots: bool) -> dict[str, Any]:
    try:
        return reports.run_report(store, run_id, with_plots=plots)
    except RunNotFound:
        raise HTTPException(404, f"no run {run_id}") from None


def _job(store, job_id: int, plots: bool) -> dict[str, Any]:
    rep = reports.job_report(store, job_id, with_plots=plots)
    if rep is None:
        raise HTTPException(404, f"no job {job_id}")
    return rep


@router.get("/runs/{run_id}", summary="Run report (JSON, without the figures)")
def run_report_json(run_id: Id, store: StoreDep, _: Viewer) -> dict[str, Any]:
    return _run(store, run_id, plots=False)


@router.get("/runs/{run_id}/html", response_class=HTMLResponse, summary="Run report page")
def run_report_html(run_id: Id, store: StoreDep, _: Viewer) -> HTMLResponse:
    return HTMLResponse(reports.run_report_html(_run(store, run_id, plots=True)))


@router.get("/jobs/{job_id}", summary="Job report (JSON, without the figures)")
def job_report_json(job_id: Id, store: StoreDep, _: Viewer) -> dict[str, Any]:
    return _job(store, job_id, plots=False)


@router.get("/jobs/{job_id}/html", response_class=HTMLResponse, summary="Job report page")
def job_report_html(job_id: Id, store: StoreDep, _: Viewer) -> HTMLResponse:
    return HTMLResponse(reports.job_report_html(_job(store, job_id, plots=True)))
