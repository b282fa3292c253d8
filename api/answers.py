"""What the service answers: the pydantic models of the JSON bodies the runs, jobs, tokens and
reports routers return, attached to the routes as `response_model` so the OpenAPI schema shows a
client what it gets.

The models are written from what the routes return (db.store, db.jobs, api.reports), in the
order the keys are produced, so an answer is the same bytes with or without its model. Every
model keeps keys it does not declare (`extra="allow"`): a key added where an answer is built
reaches the client, never silently dropped; the schema then says which keys a client can rely
on. Numbers that come from JSON documents (run metadata) are `int | float`, so a whole number
stays one (a `float` field would turn 3000 into 3000.0).
"""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from core.acceptance import Indicator
from db.models import JOB_STATUSES, RUN_STATUSES

Number = int | float
"""A JSON number as it was stored: integer or not."""


class Answer(BaseModel):
    """Base of every answer: keys beyond the declared fields are kept (see the module doc)."""
    model_config = ConfigDict(extra="allow")


# --- runs ---------------------------------------------------------------------------------------

class RunSummary(Answer):
    """One run in a list: what identifies and filters it."""
    id: int
    rig: str | None = Field(description="the rig's name")
    scheme: int | None = Field(description="1, 2 or 3; null for a record of another rig")
    source: str | None = Field(description="'rig', 'emulator' or 'import'")
    status: Literal[RUN_STATUSES]
    exit_status: str | None = Field(description="'success', 'abort' or 'fail' once finished")
    motor_speed_rpm: Number | None = Field(description="motor speed [r/min] (metadata)")
    direction: Number | None = Field(description="+1 or −1 (metadata)")
    operator: str | None = Field(None, description="who ran it (metadata)")
    started_at: datetime | None
    stopped_at: datetime | None
    n_samples: int
    t_last: float | None = Field(description="run time of the last stored sample [s]")


class RunInfo(Answer):
    """A run's row (db.store.Store.run_info): status, exit status and reason, counts, times and
    its whole metadata (the run format's keys; for an acquired run the start document,
    core.documents.RunStart, with the end document under `end`)."""
    id: int
    rig: str | None
    scheme: int | None
    source: str | None
    status: Literal[RUN_STATUSES]
    exit_status: str | None
    reason: str | None
    started_at: datetime | None
    stopped_at: datetime | None
    created_at: datetime | None
    heartbeat_at: datetime | None
    n_samples: int
    n_pages: int
    t_last: float | None
    imported_from: str | None = Field(description="the file an imported run came from")
    meta: dict[str, Any]


class RunChannel(Answer):
    """One channel of a run, in stored order."""
    name: str
    unit: str | None
    source: str | None = Field(description="the device or stream it comes from")
    kind: str = Field(description="'float', 'text' or 'phase'")


class RunInterruption(Answer):
    """One interruption of a run (interlock trip, lost drive, PLC link gap, acquisition error,
    core.documents.InterruptionKind; an imported run may name others), in run time [s]."""
    kind: str
    t_start: float | None
    t_end: float | None
    reason: str | None
    detail: dict[str, Any] | None
    created_at: datetime | None


class RunResultLink(Answer):
    """A stored result (fit) that used the run, and the run's role in it ('train', 'test')."""
    result_id: int
    job_id: int | None
    model: str
    method: str
    role: str


class RunListTotals(Answer):
    """How many items each of a run's lists holds in all (the detail pages through them)."""
    channels: int
    interruptions: int
    results: int


class RunDetail(RunInfo):
    """A run with a page of each of its lists: channels, interruptions and the results that
    used it, and how many each holds in all."""
    channels: list[RunChannel]
    interruptions: list[RunInterruption]
    results: list[RunResultLink]
    totals: RunListTotals


class RunSamples(Answer):
    """Channel samples of a run in a time range, decimated; "t" first. A missing sample is
    null."""
    run_id: int
    n: int = Field(description="samples per channel in this answer")
    every: int = Field(description="stride over the samples in range")
    n_in_range: int = Field(description="samples in the time range before decimation")
    max_points: int
    capped: bool = Field(description="true when max_points decimated beyond `every`")
    channels: dict[str, list[float | str | None]]


class PhaseAggregate(Answer):
    """Statistics of one numeric channel over one phase (phase null: samples without a phase,
    or the whole run with by_phase=false)."""
    channel: str
    phase: str | None
    count: int = Field(description="valid samples")
    missing: int
    mean: float | None
    var: float | None = Field(description="sample variance (n − 1)")
    min: float | None
    max: float | None


class Acceptance(Answer):
    """A run's acceptance indicators (Table 11); `passed` is null when none could be judged."""
    run_id: int
    passed: bool | None
    indicators: list[Indicator]


# --- jobs ---------------------------------------------------------------------------------------

class JobTimings(Answer):
    """How long the job waited and ran [s] (null until known)."""
    queued_s: float | None
    running_s: float | None


class JobInfo(Answer):
    """A job (db.jobs.job_dict): its kind and parameters, state, progress in [0, 1], error,
    attempts, the worker running it, times, and the ids of its stored results."""
    id: int
    kind: str
    state: Literal[JOB_STATUSES]
    params: dict[str, Any]
    progress: float | None
    error: str | None
    attempts: int
    worker: str | None = Field(description="'host/pid/token' of the worker")
    created_at: datetime | None
    started_at: datetime | None
    finished_at: datetime | None
    heartbeat_at: datetime | None
    timings: JobTimings
    result_ids: list[int]


class JobKindInfo(Answer):
    """A job kind: what it does and the JSON schema of its parameters."""
    description: str
    params: dict[str, Any] = Field(description="JSON schema of the kind's `params`")


class ResultRunLink(Answer):
    """A run a result used, and its role ('train', 'test')."""
    run_id: int
    role: str


class JobResult(Answer):
    """One stored result of a job: the fit (estimator.result.Fit.as_dict), the shape of its
    stored draws, the runs it used and its JSON documents by kind (e.g. 'diagnosis', the gap
    diagnosis report, core.documents.DiagnosisReport)."""
    id: int
    model: str
    method: str
    fit: dict[str, Any] | None
    draws_shape: list[int] | None
    runs: list[ResultRunLink]
    documents: dict[str, Any]
    created_at: datetime | None


# --- tokens -------------------------------------------------------------------------------------

class TokenCreated(Answer):
    """A new token; `token` is its secret, shown only in this answer."""
    id: int | None
    name: str
    role: str
    token: str
    expires_at: datetime | None = Field(description="null: the token never expires")


class TokenInfo(Answer):
    """A token as listed: its prefix, never the secret."""
    id: int
    name: str
    prefix: str
    scopes: list[str]
    created_at: datetime | None
    last_used_at: datetime | None
    revoked_at: datetime | None
    expires_at: datetime | None


# --- reports ------------------------------------------------------------------------------------

class RunReport(Answer):
    """A run's report (api.reports.run_report) without its figures."""
    run: RunInfo
    channels: list[RunChannel]
    interruptions: list[RunInterruption]
    acceptance: list[Indicator]
    acceptance_passed: bool | None
    aggregates: list[PhaseAggregate]
    results: list[RunResultLink]


class JobReportResult(Answer):
    """One result in a job's report: as JobResult, with `documents` the kinds of its JSON
    documents only (the diagnosis is the report's own `diagnosis`)."""
    id: int
    model: str
    method: str
    fit: dict[str, Any] | None
    draws_shape: list[int] | None
    runs: list[ResultRunLink]
    created_at: datetime | None
    documents: list[str]


class JobReport(Answer):
    """A job's report (api.reports.job_report) without its figures: the job, its results, the
    paper-layout tables as text (null without fits) and, for a diagnosis job, the gap
    diagnosis report (core.documents.DiagnosisReport)."""
    job: JobInfo
    results: list[JobReportResult]
    tables: str | None
    diagnosis: dict[str, Any] | None = None


# --- the service's health -----------------------------------------------------------------------

class WorkerExit(Answer):
    """How a job worker process last ended, as its supervisor saw it (api.worker.WorkerPool)."""
    pid: int
    cause: str = Field(description="e.g. 'killed by signal 9 (SIGKILL — out of memory, or "
                                   "killed)', 'exited with status 3'")
    jobs: list[int] = Field(description="the jobs it was running: re-queued, or failed")
    at: str = Field(description="when the supervisor saw it (ISO 8601, UTC)")


class WorkerState(Answer):
    """One place of the worker pool."""
    pid: int | None = Field(description="null while the process waits to be restarted")
    alive: bool
    job: int | None = Field(description="the job it runs now")
    restarts: int
    last_exit: WorkerExit | None


class Workers(Answer):
    """The service's job worker processes."""
    supervised: bool = Field(description="false: this service starts no worker processes "
                                         "(RIG_WORKERS=0); workers run elsewhere, if at all")
    configured: int
    alive: int | None
    restarts: int | None = Field(description="worker processes restarted since start-up")
    busy: int | None
    processes: list[WorkerState]


class QueueState(Answer):
    """The job queue now."""
    queued: int
    running: int
    oldest_queued_s: float | None = Field(description="how long the oldest queued job has "
                                                      "waited [s]")
    served: bool | None = Field(description="a worker process of this service is alive to "
                                            "claim jobs (null when unsupervised)")


class Health(Answer):
    """GET /health: whether the job queue is being served."""
    status: Literal["ok", "degraded"] = Field(
        description="'degraded' while fewer worker processes are alive than configured (a dead "
                    "one waits for its restart; the queue is unserved when none is alive)")
    workers: Workers
    queue: QueueState
