"""Test harness for the driver/stand-in tests: the stand-in process (simulators.process), free
ports, and waiting for a condition."""

from __future__ import annotations

import time
from pathlib import Path

from simulators.process import StandinProcess  # noqa: F401  (re-exported for the tests)

REPO = Path(__file__).resolve().parents[1]

SLACK_S = 2.0
"""The DAQ's link timeouts and the stand-in's watchdog [s] in tests whose point is not those
timeouts (2 s instead of 0.5 s): on a loaded 2-core test host a starved process must not trip the
rig. Measured: with six CPU hogs on this machine the scheme runs into SQL aborted on the 0.5 s
PLC link timeout or the PLC watchdog in 3 of 6 runs. The timeouts are tested where they are the
point (test_standin_plc, test_standin_interlocks, test_drivers_plc)."""
SLACK_ENV = {"RIG_PLC_LINK_TIMEOUT": str(SLACK_S), "RIG_DRIVE_HEARTBEAT_TIMEOUT": str(SLACK_S)}
"""SLACK_S for a `rig run` process, through its settings' environment."""
SLACK_STANDIN = ["--watchdog", str(SLACK_S)]
"""SLACK_S for the stand-in's PLC watchdog."""


def free_port() -> int:
    """A TCP port free on loopback right now (for a server that must come back on it)."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(cond, timeout: float = 3.0, step: float = 0.01) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(step)
    return bool(cond())


async def await_for(cond, timeout: float = 3.0, step: float = 0.01) -> bool:
    """Like wait_for inside an event loop; `cond` may be a coroutine function."""
    import asyncio
    import inspect
    end = time.monotonic() + timeout
    while True:
        v = cond()
        if inspect.isawaitable(v):
            v = await v
        if v or time.monotonic() > end:
            return bool(v)
        await asyncio.sleep(step)
