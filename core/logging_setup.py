"""Logging configured once per process: the `rig` command line, the rig stand-in
(`python -m simulators.standin`) and the service's workers all call `configure_logging`.

Why one place: pymodbus logs every Modbus frame at DEBUG (`>>>>> recv: 0x0 0x1 ...`) and a
failed datastore lookup at ERROR with a traceback; python-can, asyncio and alembic are chatty
too. Left to their defaults (or to a root logger at DEBUG) these reach the emulator's output
and the acquisition's log tail, which the API shows to viewers. Here the root logger gets the
level asked for (`--log-level`, `RIG_LOG_LEVEL`, default WARNING) and the noisy libraries are
held at WARNING unless DEBUG is asked for explicitly, so protocol frames appear only behind
`--log-level DEBUG`.

Format: one plain line per record, or one JSON object per line (`--log-json` or
`RIG_LOG_FORMAT=json`) for a service whose logs are collected by a log shipper. Records go to
stderr: stdout stays for a command's output (tables, `--json`).
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from typing import IO

LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")

LIBRARY_LEVELS: dict[str, int] = {
    "pymodbus": logging.WARNING,
    "can": logging.WARNING,
    "canopen": logging.WARNING,
    "asyncio": logging.WARNING,
    "alembic": logging.WARNING,
    "matplotlib": logging.WARNING,
    "numba": logging.WARNING,
    "urllib3": logging.WARNING,
    "httpx": logging.WARNING,
    "distributed": logging.WARNING,
}
"""Libraries held at WARNING (their DEBUG/INFO is protocol or build detail) unless the
process asks for DEBUG, when they log at DEBUG too."""

_HANDLER_NAME = "rig"


class JsonFormatter(logging.Formatter):
    """One JSON object per record: time (ISO 8601 UTC), level, logger, message, and the
    exception text when there is one."""

    def format(self, record: logging.LogRecord) -> str:
        out = {
            "time": time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(record.created))
                    + f".{int(record.msecs):03d}Z",
            "level": record.levelname,
            "logger": record.name,
            "message": record.getMessage(),
        }
        if record.exc_info:
            out["exc"] = self.formatException(record.exc_info)
        return json.dumps(out, ensure_ascii=False)


class FrameDumpFilter(logging.Filter):
    """pymodbus appends its last 20 frames (`>>>>> recv: 0x0 0x1 ...`) to every ERROR record it
    logs when DEBUG is off. This strips those lines, so frames appear only at DEBUG (where
    pymodbus logs each frame as its own record)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.name.startswith("pymodbus") and isinstance(record.msg, str) \
                and "\n>>>>> " in record.msg:
            record.msg = record.msg.split("\n>>>>> ", 1)[0]
        return True


def resolve_level(level: str | int | None) -> int:
    """`level` (a name such as 'info', a number, or None for `RIG_LOG_LEVEL` / WARNING) as a
    logging level number; an unknown name raises ValueError naming the choices."""
    if level is None:
        level = os.environ.get("RIG_LOG_LEVEL") or "WARNING"
    if isinstance(level, int):
        return level
    name = str(level).strip().upper()
    if name not in LEVELS:
        raise ValueError(f"unknown log level {level!r}; use one of {', '.join(LEVELS)}")
    return getattr(logging, name)


def json_requested(flag: bool | None = None) -> bool:
    """True for JSON logs: the flag if given, else `RIG_LOG_FORMAT=json`."""
    if flag:
        return True
    return os.environ.get("RIG_LOG_FORMAT", "").strip().lower() == "json"


def configure_logging(level: str | int | None = None, *, json_logs: bool | None = None,
                      stream: IO[str] | None = None) -> int:
    """Configure the root logger once (calling again replaces the handler this module
    installed, never a handler someone else added) and the per-library levels. Returns the
    level number in force."""
    lvl = resolve_level(level)
    root = logging.getLogger()
    for h in list(root.handlers):
        if h.get_name() == _HANDLER_NAME:
            root.removeHandler(h)
    out = stream if stream is not None else sys.stderr
    handler = logging.StreamHandler(out)
    handler.set_name(_HANDLER_NAME)
    if json_requested(json_logs):
        handler.setFormatter(JsonFormatter())
    else:
        # on a terminal, clear a progress line being redrawn there ("\r", erase to end of
        # line) so a record never runs on from it; the next redraw starts on a new line
        clear = "\r\x1b[K" if getattr(out, "isatty", lambda: False)() else ""
        handler.setFormatter(logging.Formatter(
            clear + "%(asctime)s %(levelname)s %(name)s: %(message)s"))
    if lvl > logging.DEBUG:
        handler.addFilter(FrameDumpFilter())
    root.addHandler(handler)
    root.setLevel(lvl)
    lib_level = logging.DEBUG if lvl <= logging.DEBUG else None
    for name, default in LIBRARY_LEVELS.items():
        logging.getLogger(name).setLevel(lib_level if lib_level is not None else max(default, lvl))
    quiet_pymodbus()
    return lvl


def quiet_pymodbus() -> None:
    """pymodbus 3.x sets its own logger's level when its server or client starts only if asked
    (`pymodbus_apply_logging_config`); it never adds handlers by itself. Its records then
    propagate to the root logger, where `configure_logging` decides. Make sure a stray
    handler pymodbus may have attached (older releases did) does not bypass that."""
    log = logging.getLogger("pymodbus")
    for h in list(log.handlers):
        log.removeHandler(h)
    log.propagate = True
