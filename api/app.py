"""The app factory: `create_app(settings)` wires the store, the routers, the request body
limit, the refusal of non-finite numbers in JSON bodies and (settings.workers > 0) the worker
pool started and stopped with the service. On start-up, jobs left 'running' by a worker that is
gone are re-queued (or failed)."""

from __future__ import annotations

import json
import math
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from api.settings import Settings


def _replaying(body: bytes, receive):
    """An ASGI `receive` that gives the app `body`, already read by a middleware, as one
    message, then hands over to the real `receive` (a disconnect)."""
    sent = False

    async def replay():
        nonlocal sent
        if sent:
            return await receive()
        sent = True
        return {"type": "http.request", "body": body, "more_body": False}
    return replay


class BodyLimit:
    """ASGI middleware: 413 for a request body over `max_bytes`, judged by Content-Length, and
    for a body without one (chunked) by reading it up to the limit before the app sees it."""

    def __init__(self, app, max_bytes: int):
        self.app, self.max_bytes = app, max_bytes

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = dict(scope.get("headers") or []).get(b"content-length")
        if length is not None and (not length.isdigit() or int(length) > self.max_bytes):
            return await _too_large(send, self.max_bytes)
        if length is not None:
            return await self.app(scope, receive, send)
        # no Content-Length (chunked): read the body up to the limit first, then replay it
        chunks, seen, more = [], 0, True
        while more:
            msg = await receive()
            if msg["type"] != "http.request":
                return
            chunks.append(msg.get("body", b""))
            seen += len(chunks[-1])
            if seen > self.max_bytes:
                return await _too_large(send, self.max_bytes)
            more = msg.get("more_body", False)
        body = b"".join(chunks)

        await self.app(scope, _replaying(body, receive), send)


class _NonFinite:
    """Stands for a NaN, Infinity or -Infinity literal while a JSON body is checked."""

    def __init__(self, text: str):
        self.text = text


def _non_finite_paths(doc: Any, path: tuple = ()) -> list[tuple[tuple, str]]:
    """(path, literal) of every non-finite number in a parsed JSON document."""
    if isinstance(doc, _NonFinite):
        return [(path, doc.text)]
    if isinstance(doc, dict):
        return [hit for k, v in doc.items() for hit in _non_finite_paths(v, path + (k,))]
    if isinstance(doc, list):
        return [hit for i, v in enumerate(doc) for hit in _non_finite_paths(v, path + (i,))]
    return []


def non_finite_errors(body: bytes) -> list[dict[str, Any]]:
    """422 error items (FastAPI's shape: loc, msg, type, input) for every NaN, Infinity or
    -Infinity literal in a JSON body; [] when there is none or the body is no JSON (the route's
    own validation answers that). Python's json reads these literals, JSON does not have them:
    a NaN passes no bound check and poisons physics and metadata, an Infinity passes a one-sided
    bound, and a validation error holding either cannot be rendered as JSON."""
    if b"NaN" not in body and b"Infinity" not in body:
        return []
    try:
        doc = json.loads(body, parse_constant=_NonFinite)
    except (ValueError, RecursionError):
        return []
    out = []
    for path, text in _non_finite_paths(doc):
        name = ".".join(map(str, path)) or "the body"
        out.append({"type": "finite_number", "loc": ["body", *path], "input": text,
                    "msg": f"{name} must be a finite number, got {text}"})
    return out


class FiniteJson:
    """ASGI middleware: 422 naming the field for a JSON request body holding NaN, Infinity or
    -Infinity, before any route sees it (so nothing is created). Runs inside BodyLimit: the body
    it reads is bounded."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or scope["method"] not in ("POST", "PUT", "PATCH"):
            return await self.app(scope, receive, send)
        ctype = dict(scope.get("headers") or []).get(b"content-type", b"").lower()
        if b"json" not in ctype:
            return await self.app(scope, receive, send)
        chunks, more = [], True
        while more:
            msg = await receive()
            if msg["type"] != "http.request":
                return
            chunks.append(msg.get("body", b""))
            more = msg.get("more_body", False)
        body = b"".join(chunks)
        errors = non_finite_errors(body)
        if errors:
            return await JSONResponse({"detail": errors}, status_code=422)(scope, receive, send)

        await self.app(scope, _replaying(body, receive), send)


def _finite_inputs(x: Any) -> Any:
    """A copy of validation errors with non-finite floats as their text (JSON has none)."""
    if isinstance(x, dict):
        return {k: _finite_inputs(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite_inputs(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return x


async def _validation_error(request: Request, exc: RequestValidationError) -> JSONResponse:
    """FastAPI's 422 answer, renderable whatever the input (a NaN from a query string, say)."""
    return JSONResponse({"detail": _finite_inputs(jsonable_encoder(exc.errors()))},
                        status_code=422)


async def _too_large(send, max_bytes: int) -> None:
    body = f'{{"detail":"request body larger than {max_bytes} bytes"}}'.encode()
    await send({"type": "http.response.start", "status": 413,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


def create_app(settings: Settings | None = None) -> FastAPI:
    """The FastAPI application on `settings` (default Settings.from_env())."""
    from api.routers import console, health, jobs, reports, rig_model, runs, schemes, tokens

    st = settings or Settings.from_env()

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        from db.jobs import recover_lost
        from api.worker import WorkerPool
        from db.store import Store

        app.state.store = Store(st.db_url)
        recover_lost(app.state.store, st.job_stale_s, st.job_max_attempts)
        env = {"RIG_DASK_SCHEDULER": st.dask_scheduler} if st.dask_scheduler else None
        pool = WorkerPool(st.db_url, st.workers, env=env, max_attempts=st.job_max_attempts
                          ).start() if st.workers > 0 else None
        app.state.workers = pool
        try:
            yield
        finally:
            if pool is not None:
                pool.stop()
            app.state.store.close()

    app = FastAPI(title="J4 joint test platform", version="0.1.0", lifespan=lifespan,
                  docs_url=None, redoc_url=None,   # served offline by api/routers/console.py
                  description="Stored runs, identification and sensitivity jobs, test reports. "
                              "Every endpoint needs `Authorization: Bearer TOKEN` "
                              "(`rig token create --role viewer|operator|rig-operator|admin`).")
    app.state.settings = st
    for r in (runs.router, jobs.router, reports.router, tokens.router, schemes.router,
              health.router, rig_model.router, console.router, console.page_router):
        app.include_router(r)
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.add_middleware(FiniteJson)
    app.add_middleware(BodyLimit, max_bytes=st.max_body_bytes)    # outermost: runs first
    return app
