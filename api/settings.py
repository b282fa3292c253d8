"""The service's one settings object, read from the environment (RIG_* variables; `ENV` names
the variable of each field). Every setting has a type, a unit and a range (pydantic validates
them): NaN, ±inf or a value out of range stops start-up with a message naming the variable. An
empty variable counts as unset.

RIG_DB_URL          database URL, shared with db/ (db.engine.database_url)
RIG_API_HOST        listen address (default 127.0.0.1: loopback only)
RIG_API_PORT        listen port (default 8000)
RIG_WORKERS         job worker processes started with the service (default 2; 0 = none; ≤ 64)
RIG_MAX_BODY_BYTES  largest accepted request body [bytes] (default 1 MiB; 1 KiB–1 GiB)
RIG_JOB_HEARTBEAT_S how often a worker stamps its running job [s] (default 2; 0.05–60)
RIG_JOB_STALE_S     a running job without a heartbeat for this long is taken as lost [s] (default 30;
                    more than the heartbeat, ≤ 1 day)
RIG_JOB_MAX_ATTEMPTS claims of one job before a lost job is failed instead of re-queued (default 2;
                    1–10); a job whose worker process died on its last attempt is failed with
                    the cause (api.worker)
RIG_JOB_TIME_LIMIT_S wall-clock limit of one attempt of a job of any kind [s] (default none: each
                    kind's own limit, api.job_kinds; 1 s–7 days); a job past it is stopped and
                    ends 'failed' with the limit in its reason
RIG_DASK_SCHEDULER  address of a Dask distributed scheduler, tcp://host:port or tls://host:port
                    (default none: jobs run in the worker processes). When set, each worker
                    process still claims jobs from SQL and stamps their heartbeats, but runs the
                    job's code as a Dask task there, its chains and Sobol evaluations spread over
                    the cluster's workers (api.dask_backend); RIG_WORKERS is then how many jobs run
                    at once. Every Dask worker needs this package (pip install '.[dask]') and the
                    database, named by RIG_DB_URL in its own environment (the URL is never sent in
                    a task). A plain tcp:// scheduler authenticates nobody and encrypts nothing:
                    keep it on a trusted network.
RIG_DASK_TLS_CA     for a tls:// scheduler (required then, refused with tcp://): the CA certificate
RIG_DASK_TLS_CERT   file, and this client's certificate and private key files (PEM), handed to
RIG_DASK_TLS_KEY    distributed.security.Security with encryption required
RIG_API_CACHE_MB    memory budget of each service process's cache of answers about finished runs
                    (aggregates, acceptance, run reports) [MiB] (default 256; 0 = no cache;
                    ≤ 65536); read by api.response_cache, which recomputes an answer when its run
                    changes
"""

from __future__ import annotations

import os
import re
from dataclasses import fields
from pathlib import Path
from typing import Any

from pydantic import ConfigDict, Field, ValidationInfo, field_validator
from pydantic.dataclasses import dataclass

from core.config_file import build_settings, setting
from db.engine import database_url

ENV: dict[str, str] = {
    "db_url": "RIG_DB_URL", "host": "RIG_API_HOST", "port": "RIG_API_PORT",
    "workers": "RIG_WORKERS", "max_body_bytes": "RIG_MAX_BODY_BYTES",
    "job_heartbeat_s": "RIG_JOB_HEARTBEAT_S", "job_stale_s": "RIG_JOB_STALE_S",
    "job_max_attempts": "RIG_JOB_MAX_ATTEMPTS", "job_time_limit_s": "RIG_JOB_TIME_LIMIT_S",
    "dask_scheduler": "RIG_DASK_SCHEDULER",
    "dask_tls_ca": "RIG_DASK_TLS_CA", "dask_tls_cert": "RIG_DASK_TLS_CERT",
    "dask_tls_key": "RIG_DASK_TLS_KEY", "api_cache_mb": "RIG_API_CACHE_MB",
}
"""The environment variable of each field."""

DASK_ADDRESS = re.compile(r"^(tcp|tls)://[^\s/:]+(:\d{1,5})?$")
"""A Dask scheduler address this service accepts: tcp:// or tls://, host, optional port."""
TLS_FIELDS = ("dask_tls_ca", "dask_tls_cert", "dask_tls_key")


@dataclass(frozen=True, config=ConfigDict(allow_inf_nan=False, extra="forbid"))
class Settings:
    """The service's settings; see the module docstring (and `ENV`) for each variable."""

    db_url: str = Field(default_factory=database_url, min_length=1, repr=False,
                        description="database URL (SQLAlchemy); may hold a password: never "
                                    "in a repr, an error message or a Dask task",
                        json_schema_extra={"unit": "-", "secret": True})
    host: str = setting("127.0.0.1", "-", "listen address", min_length=1)
    port: int = setting(8000, "-", "listen port", ge=1, le=65535)
    workers: int = setting(2, "-", "job worker processes (0 = none)", ge=0, le=64)
    max_body_bytes: int = setting(1 << 20, "bytes", "largest accepted request body",
                                  ge=1024, le=1 << 30)
    job_heartbeat_s: float = setting(2.0, "s", "how often a worker stamps its running job",
                                     ge=0.05, le=60.0)
    job_stale_s: float = setting(30.0, "s", "a running job without a heartbeat for this long "
                                 "is taken as lost (more than job_heartbeat_s)",
                                 gt=0.0, le=86400.0)
    job_max_attempts: int = setting(2, "-", "claims of one job before a lost job is failed",
                                    ge=1, le=10)
    job_time_limit_s: float | None = setting(None, "s", "wall-clock limit of a job of any kind "
                                             "(none: each kind's own, api.job_kinds)",
                                             ge=1.0, le=7 * 86400.0)
    dask_scheduler: str | None = setting(None, "-", "Dask scheduler, tcp://host:port or "
                                         "tls://host:port (none: local worker processes)")
    dask_tls_ca: str | None = setting(None, "-", "CA certificate file (PEM) of a tls:// "
                                      "scheduler", validate_default=True)
    dask_tls_cert: str | None = setting(None, "-", "this client's certificate file (PEM)",
                                        validate_default=True)
    dask_tls_key: str | None = setting(None, "-", "this client's private key file (PEM)",
                                       validate_default=True)
    api_cache_mb: float = setting(256.0, "MiB", "per-process cache of answers about finished "
                                  "runs (0 = no cache)", ge=0.0, le=65536.0)

    @field_validator("job_stale_s")
    @classmethod
    def _stale_after_heartbeat(cls, value: float, info: ValidationInfo) -> float:
        beat = info.data.get("job_heartbeat_s")
        if beat is not None and value <= beat:
            raise ValueError(f"must exceed job_heartbeat_s ({beat} s)")
        return value

    @field_validator("dask_scheduler")
    @classmethod
    def _scheduler_address(cls, value: str | None) -> str | None:
        if value is not None and not DASK_ADDRESS.match(value):
            raise ValueError("must be tcp://host:port or tls://host:port")
        return value

    @field_validator(*TLS_FIELDS)
    @classmethod
    def _tls_file(cls, value: str | None, info: ValidationInfo) -> str | None:
        scheduler = info.data.get("dask_scheduler")
        if scheduler is None and "dask_scheduler" not in info.data:
            return value                     # the scheduler itself was refused
        tls = bool(scheduler and scheduler.startswith("tls://"))
        if tls and not value:
            raise ValueError(f"a tls:// Dask scheduler needs {ENV[info.field_name]} "
                             "(a PEM file)")
        if value and not tls:
            raise ValueError(f"{ENV[info.field_name]} is set but the Dask scheduler is "
                             f"{scheduler or 'not set'}: only a tls:// scheduler uses it")
        if value and not Path(value).is_file():
            raise ValueError(f"no such file {value!r}")
        return value

    def dask_security(self) -> Any:
        """distributed.security.Security for a tls:// scheduler (CA, client certificate and
        key from the settings, encryption required); None for tcp:// or no scheduler."""
        if not (self.dask_scheduler or "").startswith("tls://"):
            return None
        from distributed.security import Security

        return Security(tls_ca_file=self.dask_tls_ca, tls_client_cert=self.dask_tls_cert,
                        tls_client_key=self.dask_tls_key, require_encryption=True)

    @classmethod
    def from_env(cls, **overrides: Any) -> "Settings":
        """Settings from RIG_* environment variables; keyword overrides win (None = not
        given). A bad value raises ValueError naming its variable."""
        values: dict[str, Any] = {}
        origin: dict[str, str] = {}
        for f in fields(cls):
            raw = os.environ.get(ENV[f.name])
            if raw:
                values[f.name], origin[f.name] = raw, ENV[f.name]
        for key, value in overrides.items():
            if value is not None:
                values[key], origin[key] = value, key
        return build_settings(cls, values, origin)
