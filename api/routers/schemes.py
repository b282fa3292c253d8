"""/schemes and /acquisitions: start scheme 1, 2 or 3 on the emulator (operator role) or the rig
(rig-operator role), follow it (state, server-sent events with progress and the live key
channels), stop it (operator: make-safe, the run ends `abort`) or e-stop it (any signed-in
role: whoever sees a danger must be able to stop the machine). The acquisition runs in
processes of its own (api/acquisition_process.py); the web process only starts, follows and
commands them (api/acquisition.py)."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterable
from contextlib import asynccontextmanager
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Body, Depends, FastAPI, HTTPException, Path, Request, Response
from fastapi.sse import EventSourceResponse, ServerSentEvent
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, create_model

from api.acquisition import Acquisition, AcquisitionManager, Busy
from api.acquisition_process import MAX_SAMPLE_RATE_TIMES_SCALE, AcquisitionSpec
from api.auth import RIG_ROLE
from api.deps import ERRORS, Caller, Operator, Viewer, check_role
from core.effects import EFFECT_NAMES


@asynccontextmanager
async def lifespan(app: FastAPI):
    """The service's acquisitions live and die with it: stopped (made safe) at shutdown."""
    mgr = AcquisitionManager(app.state.settings.db_url, app.state.store)
    app.state.acquisitions = mgr
    try:
        yield
    finally:
        await asyncio.to_thread(mgr.shutdown)


router = APIRouter(tags=["schemes"], responses=ERRORS, lifespan=lifespan)

def _utf8(v: str) -> str:
    v.encode("utf-8")          # UnicodeEncodeError (a ValueError → 422) for lone surrogates
    return v


Text = Annotated[str, Field(max_length=200, pattern=r"^[^\x00-\x1f\x7f]*$"),
                 AfterValidator(_utf8)]
"""One line of printable text (it ends up in the run's metadata and in logs)."""


def _params_model(number: int) -> type[BaseModel]:
    """The request model of scheme `number`'s parameters, derived from core.schemes (fields,
    defaults, units, bounds): nothing typed here."""
    from core.schemes import SCHEMES, scheme_params

    spec: dict[str, Any] = {}
    for p in scheme_params(number):
        b = p.bounds
        typ = Literal[b.choices] if b.choices is not None else p.type
        unit = f" [{b.unit}]" if b.unit else ""
        spec[p.name] = (typ, Field(p.default, ge=b.ge, gt=b.gt, le=b.le,
                                   description=f"{b.doc}{unit}"))
    doc = (SCHEMES[number].__doc__ or "").strip().split("\n\n")[0]
    return create_model(f"Scheme{number}Params", __config__=ConfigDict(extra="forbid"),
                        __doc__=doc, **spec)


PARAMS: dict[int, type[BaseModel]] = {n: _params_model(n) for n in (1, 2, 3)}
"""The parameters each scheme accepts (core.schemes' settable fields, bounded), paper
defaults."""


class EmulatorOptions(BaseModel):
    """How the service's stand-in runs (target 'emulator' only)."""
    model_config = ConfigDict(extra="forbid")
    time_scale: float = Field(1.0, ge=0.1, le=20.0, description="rig seconds per wall second")
    seed: int = Field(0, ge=0, le=2**31 - 1)
    watchdog_s: float = Field(0.5, ge=0.1, le=5.0, description="the stand-in PLC's watchdog on "
                                                               "the service heartbeat [s]")
    effects: dict[Literal[EFFECT_NAMES], dict[Annotated[str, Field(max_length=40)], float]] = \
        Field(default_factory=dict, max_length=len(EFFECT_NAMES),
              description="effects injected in the emulator {name: {param: value}} "
                          "(core.effects vocabulary), recorded with the run")


def _request_model(number: int) -> type[BaseModel]:
    return create_model(
        f"Scheme{number}RunRequest", __config__=ConfigDict(extra="forbid"),
        target=(Literal["emulator", "rig"], Field(description="the emulator (a stand-in started "
                                                              "for this run) or the rig of the "
                                                              "DAQ settings")),
        operator=(Text, Field(min_length=1, description="who runs it (stored with the run)")),
        notes=(Text, ""),
        params=(PARAMS[number], Field(default_factory=PARAMS[number])),
        emulator=(EmulatorOptions, Field(default_factory=EmulatorOptions)),
        reset_watchdog=(bool, Field(False, description="reset a PLC heartbeat-watchdog fault "
                                                       "latched by the previous session (never "
                                                       "an e-stop or a limit trip)")))


AcqId = Annotated[str, Path(pattern=r"^[0-9a-f]{32}$")]


def _manager(request: Request) -> AcquisitionManager:
    return request.app.state.acquisitions


def _acq(request: Request, acq_id: AcqId) -> Acquisition:
    acq = _manager(request).get(acq_id)
    if acq is None:
        raise HTTPException(404, f"no acquisition {acq_id}")
    return acq


Acq = Annotated[Acquisition, Depends(_acq)]
"""The acquisition of the path's id (404 if this service has none)."""


def _start(number: int, caller: Caller, body: BaseModel, request: Request, response: Response
           ) -> dict[str, Any]:
    from core.schemes import RunSpec

    if body.target == "rig":
        check_role(caller, RIG_ROLE, "starting a scheme on the rig")

    params = body.params.model_dump()
    emu = body.emulator if body.target == "emulator" else None
    if emu is not None:
        from core.effects import check_effects
        try:                               # known, finite, in range (core/effects.py)
            check_effects(emu.effects)
        except ValueError as exc:
            raise HTTPException(422, f"emulator effects: {exc}") from None
    run = RunSpec(scheme=number, params=params, operator=body.operator, notes=body.notes,
                  effects=(emu.effects or None) if emu else None, source=body.target,
                  reset_watchdog=body.reset_watchdog)
    try:
        run.make_scheme()                  # the scheme's own checks (e.g. the ±180° travel)
    except (ValueError, TypeError) as exc:
        raise HTTPException(422, f"scheme {number}: {exc}") from None
    if emu is not None:
        if params["sample_rate_hz"] * emu.time_scale > MAX_SAMPLE_RATE_TIMES_SCALE:
            raise HTTPException(422, f"sample rate × time scale must be ≤ "
                                     f"{MAX_SAMPLE_RATE_TIMES_SCALE:g} Hz on the emulator "
                                     "(its PLC poll rate): lower one of them")
        spec = AcquisitionSpec(run=run, target="emulator", time_scale=emu.time_scale,
                               seed=emu.seed, watchdog_s=emu.watchdog_s)
    else:
        spec = AcquisitionSpec(run=run, target=body.target)
    try:
        acq = _manager(request).start(spec)
    except Busy as exc:
        raise HTTPException(409, str(exc)) from None
    response.headers["Location"] = f"/acquisitions/{acq.id}"
    return acq.snapshot()


def _add_start_route(number: int) -> None:
    model = _request_model(number)

    def start(caller: Operator, body, request: Request, response: Response) -> dict[str, Any]:
        return _start(number, caller, body, request, response)
    start.__annotations__["body"] = Annotated[model, Body()]   # the model of this scheme
    start.__name__ = f"start_scheme{number}"
    router.add_api_route(
        f"/schemes/{number}/runs", start, methods=["POST"], status_code=202,
        summary=f"Start scheme {number} on the emulator (operator) or the rig (rig-operator); "
                "202 with Location to the acquisition",
        responses={409: {"description": "the target already has an acquisition running"}})


for _n in (1, 2, 3):
    _add_start_route(_n)


@router.get("/acquisitions", summary="Acquisitions of this service run, newest first")
def list_acquisitions(request: Request, _: Viewer) -> list[dict[str, Any]]:
    return [a.snapshot() for a in reversed(_manager(request).acquisitions())]


@router.get("/acquisitions/{acq_id}",
            summary="An acquisition: state (starting, running, stopping, ended), run id, "
                    "progress, final run status")
def get_acquisition(_: Viewer, acq: Acq) -> dict[str, Any]:
    return acq.snapshot()


def _progress_since(acq: Acquisition, seen: int) -> list[tuple[int, str]]:
    """The progress events after sequence number `seen`, oldest first, as (sequence number,
    JSON text) (a client that connects gets the latest one only: the last known state)."""
    recent = list(acq.recent_progress)
    if seen < 0:
        return recent[-1:]
    return [(n, p) for n, p in recent if n > seen]


@router.get("/acquisitions/{acq_id}/events", response_class=EventSourceResponse,
            summary="Server-sent events: `state` on each change, `progress` (phase, fraction, "
                    "live channels, the rig's state — PLC, drives, interlocks, e-stop latch — "
                    "the live twin) every 0.2 s and once more after make-safe, `end` with the "
                    "run's final status")
async def acquisition_events(_: Viewer, acq: Acq,
                             request: Request) -> AsyncIterable[ServerSentEvent]:
    seen_version, seen_state, seen_seq = -1, None, -1
    idle = 0.0
    while True:
        if acq.version != seen_version:
            seen_version, idle = acq.version, 0.0
            if acq.state != seen_state:
                seen_state = acq.state
                yield ServerSentEvent(event="state", data={"state": acq.state,
                                                           "run_id": acq.run_id})
            for seq, text in _progress_since(acq, seen_seq):   # every one, none merged
                seen_seq = seq
                yield ServerSentEvent(event="progress", raw_data=text)
            if acq.state == "ended":
                yield ServerSentEvent(event="end", data=acq.snapshot())
                return
        if await request.is_disconnected():
            return
        await asyncio.sleep(0.05)
        idle += 0.05
        if idle >= 15.0:
            idle = 0.0
            yield ServerSentEvent(comment="keep-alive")


@router.post("/acquisitions/{acq_id}/stop",
             summary="Stop: the rig is made safe and the run ends `abort`")
def stop_acquisition(caller: Operator, acq: Acq, request: Request) -> dict[str, Any]:
    _manager(request).stop(acq, caller.name)
    return acq.snapshot()


class EStop(BaseModel):
    """Why the operator e-stops (stored as the run's reason and interruption)."""
    model_config = ConfigDict(extra="forbid")
    reason: Text = "operator e-stop from the API"


@router.post("/acquisitions/{acq_id}/estop",
             summary="E-stop now (any signed-in role): trip, make safe, latch the PLC's "
                     "e-stop; the run ends `abort` with the e-stop as its reason")
def estop_acquisition(caller: Viewer, acq: Acq, request: Request,
                      body: EStop | None = None) -> dict[str, Any]:
    _manager(request).estop(acq, (body or EStop()).reason, caller.name)
    return acq.snapshot()
