"""/jobs: submit (202 + Location; Idempotency-Key), list, show, cancel, results. Submitting
and cancelling need the operator role, reading the viewer role."""

from __future__ import annotations

import hashlib
from typing import Annotated, Any, Literal, Union

from fastapi import APIRouter, Header, HTTPException, Query, Response
from pydantic import BaseModel, ConfigDict, Field, create_model
from sqlalchemy import select

from db import jobs as queue
from api.answers import JobInfo, JobKindInfo, JobResult
from api.deps import ERRORS, Id, MAX_ID, Operator, StoreDep, Viewer
from api.job_kinds import KINDS, run_ids_of
from db.models import Run

router = APIRouter(prefix="/jobs", tags=["jobs"], responses=ERRORS)


def _submission(kind) -> type[BaseModel]:
    """The request body of one job kind: {"kind": NAME, "params": {...}}."""
    return create_model(f"{kind.name.title()}Job", __config__=ConfigDict(extra="forbid"),
                        __doc__=kind.description,
                        kind=(Literal[kind.name], ...), params=(kind.params, ...))


JobSubmission = Annotated[Union[tuple(_submission(k) for k in KINDS.values())],
                          Field(discriminator="kind")]
"""POST /jobs body: one variant per registered kind (api.job_kinds.KINDS)."""


def scoped_idempotency_key(token_id: int, key: str | None) -> str | None:
    """The key stored for a client's Idempotency-Key: the token's id and the key's SHA-256
    (fixed length whatever the client sends), so keys of different tokens never meet."""
    if key is None:
        return None
    return f"token {token_id}: {hashlib.sha256(key.encode('utf-8')).hexdigest()}"


def _not_found(job_id: int):
    raise HTTPException(404, f"no job {job_id}")


@router.post("", status_code=202, summary="Submit a job; 202 with Location to the job",
             response_model=JobInfo,
             responses={200: {"description": "the job an earlier submission with this "
                                              "Idempotency-Key made"},
                        404: {"description": "a run named in the parameters does not exist"},
                        409: {"description": "Idempotency-Key used for other parameters"}})
def submit_job(body: JobSubmission, store: StoreDep, caller: Operator, response: Response,
               idempotency_key: str | None = Header(None, max_length=200)) -> dict[str, Any]:
    """An Idempotency-Key belongs to the token that sent it: the same token retrying with it
    gets its job back, another token using the same key gets a job of its own (and can neither
    see nor block the first one's)."""
    params = body.params
    ids = run_ids_of(params)
    with store.ReadSession() as s:
        have = set(s.execute(select(Run.id).where(Run.id.in_(ids))).scalars())
    if missing := sorted(set(ids) - have):
        raise HTTPException(404, f"no run(s) {missing}")
    try:
        job, created = queue.submit(store, body.kind, params.model_dump(mode="json"),
                                    scoped_idempotency_key(caller.token_id, idempotency_key))
    except queue.IdempotencyConflict:
        raise HTTPException(409, f"Idempotency-Key {idempotency_key!r} was used by this token "
                                 "for a submission with other parameters") from None
    response.headers["Location"] = f"/jobs/{job['id']}"
    if not created:
        response.status_code = 200
    return job


@router.get("", summary="List jobs, newest first", response_model=list[JobInfo])
def list_jobs(store: StoreDep, _: Viewer,
              state: Literal["queued", "running", "succeeded", "failed", "cancelled"] | None = None,
              kind: str | None = Query(None, max_length=40),
              limit: int = Query(100, ge=1, le=1000), offset: int = Query(0, ge=0, le=MAX_ID)
              ) -> list[dict[str, Any]]:
    return queue.list_jobs(store, state, kind, limit, offset)


@router.get("/kinds", summary="The job kinds and their parameter schemas",
            response_model=dict[str, JobKindInfo])
def job_kinds(_: Viewer) -> dict[str, Any]:
    return {k.name: {"description": k.description, "params": k.params.model_json_schema()}
            for k in KINDS.values()}


@router.get("/{job_id}", summary="A job: state, progress, timings, error", response_model=JobInfo)
def get_job(job_id: Id, store: StoreDep, _: Viewer) -> dict[str, Any]:
    return queue.get_job(store, job_id) or _not_found(job_id)


@router.post("/{job_id}/cancel", summary="Cancel a queued or running job",
             response_model=JobInfo)
def cancel_job(job_id: Id, store: StoreDep, _: Operator) -> dict[str, Any]:
    return queue.cancel(store, job_id) or _not_found(job_id)


@router.get("/{job_id}/results", summary="A job's stored results (fits) and the runs they used",
            response_model=list[JobResult])
def job_results(job_id: Id, store: StoreDep, _: Viewer) -> list[dict[str, Any]]:
    from api.reports import json_clean
    if queue.get_job(store, job_id) is None:
        _not_found(job_id)
    return json_clean(queue.results_of(store, job_id))
