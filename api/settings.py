"""The service's one settings object, read from the environment (RIG_* variables).

RIG_DB_URL          database URL, shared with db/ (db.engine.database_url)
RIG_API_HOST        listen address (default 127.0.0.1: loopback only)
RIG_API_PORT        listen port (default 8000)
RIG_WORKERS         job worker processes started with the service (default 2; 0 = none)
RIG_MAX_BODY_BYTES  largest accepted request body [bytes] (default 1 MiB)
RIG_JOB_HEARTBEAT_S how often a worker stamps its running job [s] (default 2)
RIG_JOB_STALE_S     a running job without a heartbeat for this long is taken as lost [s] (default 30)
RIG_JOB_MAX_ATTEMPTS claims of one job before a lost job is failed instead of re-queued (default 2)
RIG_DASK_SCHEDULER  address of a Dask distributed scheduler, e.g. tcp://10.0.0.5:8786 (default
                    none: jobs run in the worker processes). When set, each worker process still
                    claims jobs from SQL and stamps their heartbeats, but runs the job's code as
                    a Dask task there, its chains and Sobol evaluations spread over the cluster's
                    workers (api.dask_backend); RIG_WORKERS is then how many jobs run at once.
                    Every Dask worker needs this package (pip install '.[dask]') and the database.
RIG_API_CACHE_MB    memory budget of each service process's cache of answers about finished runs
                    (aggregates, acceptance, run reports) [MiB] (default 256; 0 = no cache); read
                    by api.response_cache, which recomputes an answer when its run changes
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

from db.engine import database_url


def _env(name: str, default: str) -> str:
    return os.environ.get(name) or default


@dataclass(frozen=True)
class Settings:
    db_url: str = field(default_factory=database_url)
    host: str = "127.0.0.1"
    port: int = 8000
    workers: int = 2
    max_body_bytes: int = 1 << 20
    job_heartbeat_s: float = 2.0
    job_stale_s: float = 30.0
    job_max_attempts: int = 2
    dask_scheduler: str | None = None

    @classmethod
    def from_env(cls, **overrides) -> "Settings":
        """Settings from RIG_* environment variables; keyword overrides win."""
        values = dict(
            db_url=database_url(),
            host=_env("RIG_API_HOST", "127.0.0.1"),
            port=int(_env("RIG_API_PORT", "8000")),
            workers=int(_env("RIG_WORKERS", "2")),
            max_body_bytes=int(_env("RIG_MAX_BODY_BYTES", str(1 << 20))),
            job_heartbeat_s=float(_env("RIG_JOB_HEARTBEAT_S", "2")),
            job_stale_s=float(_env("RIG_JOB_STALE_S", "30")),
            job_max_attempts=int(_env("RIG_JOB_MAX_ATTEMPTS", "2")),
            dask_scheduler=os.environ.get("RIG_DASK_SCHEDULER") or None,
        )
        values.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**values)
