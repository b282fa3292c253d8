"""/health: whether the service's job queue is being served — its worker processes alive and
restarted (api.worker.WorkerPool.stats) and the queue's length. Needs the viewer role."""

from __future__ import annotations

from fastapi import APIRouter, Request

from api.answers import Health, QueueState, Workers
from api.deps import ERRORS, StoreDep, Viewer
from db import jobs as queue

router = APIRouter(tags=["service"], responses=ERRORS)


@router.get("/health", response_model=Health,
            summary="Job workers alive and restarted, and whether the queue is being served")
def health(request: Request, store: StoreDep, _: Viewer) -> Health:
    pool = getattr(request.app.state, "workers", None)
    counts = queue.queue_counts(store)
    if pool is None:
        workers = Workers(supervised=False, configured=0, alive=None, restarts=None, busy=None,
                          processes=[])
        return Health(status="ok", workers=workers, queue=QueueState(**counts, served=None))
    st = pool.stats()
    workers = Workers(supervised=True, configured=st["configured"], alive=st["alive"],
                      restarts=st["restarts"], busy=st["busy"], processes=st["workers"])
    status = "ok" if st["alive"] == st["configured"] else "degraded"
    return Health(status=status, workers=workers,
                  queue=QueueState(**counts, served=st["serving"]))
