"""The app factory: `create_app(settings)` wires the store, the routers, the request body
limit and (settings.workers > 0) the worker pool started and stopped with the service.
On start-up, jobs left 'running' by a worker that is gone are re-queued (or failed)."""

from __future__ import annotations

from contextlib import asynccontextmanager

from fastapi import FastAPI

from api.settings import Settings


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
        body, sent = b"".join(chunks), False

        async def replay():
            nonlocal sent
            if sent:
                return await receive()
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        await self.app(scope, replay, send)


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
    app.add_middleware(BodyLimit, max_bytes=st.max_body_bytes)
    return app
