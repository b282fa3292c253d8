"""Test harness for the driver/stand-in tests: the stand-in process (simulators.process), free
ports, and waiting for a condition."""

from __future__ import annotations

import time
from pathlib import Path

from simulators.process import StandinProcess  # noqa: F401  (re-exported for the tests)

REPO = Path(__file__).resolve().parents[1]


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
