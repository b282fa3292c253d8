"""`rig serve`: the REST service (uvicorn) with its job worker pool; OpenAPI docs at /docs."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--host", help="listen address (default env RIG_API_HOST or 127.0.0.1)")
    p.add_argument("--port", type=int, help="listen port (default env RIG_API_PORT or 8000)")
    p.add_argument("--workers", type=int,
                   help="job worker processes (default env RIG_WORKERS or 2; 0 = none)")
    p.add_argument("--db", help="database URL (default env RIG_DB_URL)")


def run(args: argparse.Namespace) -> int:
    import uvicorn

    from api.app import create_app
    from api.settings import Settings

    from core.redact import redact_secrets

    st = Settings.from_env(host=args.host, port=args.port, workers=args.workers, db_url=args.db)
    print(f"serving on http://{st.host}:{st.port} (the operator console at /, docs at /docs), "
          f"{st.workers} job workers, "
          f"database {redact_secrets(st.db_url)}", flush=True)
    from core.logging_setup import json_requested
    # JSON logs asked for (--log-json / RIG_LOG_FORMAT=json): uvicorn's loggers get no
    # handlers of their own and propagate to the root logger's JSON handler
    # (core/logging_setup.py); otherwise uvicorn's usual access and error lines
    extra = {"log_config": None} if json_requested(getattr(args, "log_json", False)) else {}
    uvicorn.run(create_app(st), host=st.host, port=st.port, log_level="info", **extra)
    return 0
