"""The engine's database calls run off the event loop (which also writes the PLC heartbeat),
and a cancellation never leaves one half done."""

from __future__ import annotations

import asyncio
import threading
import time

import pytest

from daq.engine import _off_loop


def test_the_event_loop_keeps_beating_while_the_database_blocks():
    beats: list[float] = []

    def slow_commit(x: int) -> int:
        time.sleep(0.3)
        return 2 * x

    async def main() -> int:
        async def heartbeat():
            while True:
                beats.append(time.monotonic())
                await asyncio.sleep(0.01)
        hb = asyncio.create_task(heartbeat())
        await asyncio.sleep(0)
        out = await _off_loop(slow_commit, 21)
        hb.cancel()
        return out

    assert asyncio.run(main()) == 42
    # the heartbeat task ran all along the 0.3 s call (a blocking call would leave one beat)
    assert len(beats) >= 5


def test_a_cancelled_call_finishes_before_the_cancellation_propagates():
    done = threading.Event()
    raised = []

    def commit() -> None:
        time.sleep(0.2)
        done.set()

    def failing() -> None:
        raise RuntimeError("database down")

    async def main() -> None:
        task = asyncio.create_task(_off_loop(commit))
        await asyncio.sleep(0.05)
        task.cancel()
        await asyncio.sleep(0.01)
        task.cancel()             # cancelled twice (an impatient Ctrl-C)
        try:
            await task
        except asyncio.CancelledError:
            raised.append(done.is_set())
        with pytest.raises(RuntimeError, match="database down"):
            await _off_loop(failing)

    asyncio.run(main())
    assert raised == [True]


def test_rig_stop_ends_a_loop_that_swallowed_a_cancellation():
    """Python 3.11's wait_for can lose a cancellation that races a reply; the rig's background
    loops must still end when the rig stops."""
    from daq.rig import _cancel_all

    quit_now = False

    async def stubborn(swallow: int) -> None:
        while not quit_now:
            try:
                await asyncio.sleep(0.01)
            except asyncio.CancelledError:
                if swallow <= 0:
                    raise
                swallow -= 1          # as if the reply won the race

    async def main():
        nonlocal quit_now
        tasks = [asyncio.create_task(stubborn(n)) for n in (0, 1, 3)]
        await asyncio.sleep(0.02)
        left = await _cancel_all(tasks, timeout=5.0)
        assert not left and all(t.cancelled() for t in tasks)
        forever = asyncio.create_task(stubborn(10**9))
        await asyncio.sleep(0.02)
        assert await _cancel_all([forever], timeout=0.3) == {forever}   # bounded, reported
        quit_now = True
        await forever

    asyncio.run(main())
