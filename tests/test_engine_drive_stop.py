"""The end of a run waits for the drives to confirm the quick stop before it reads the end
baseline (daq.engine.drives_left_operation): a drive reports its new state only with its next
status TPDO, and under load the end record showed a drive that had been stopped as still
OPERATION ENABLED (tests/test_engine_runs.py's interlock test, in a loaded full-suite run)."""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass

from daq.engine import drives_left_operation


@dataclass
class _Drive:
    node_id: int
    confirm_at: float | None   # monotonic time its TPDO reports the stop; None: never

    @property
    def state(self) -> str:
        if self.confirm_at is not None and time.monotonic() >= self.confirm_at:
            return "QUICK STOP ACTIVE"
        return "OPERATION ENABLED"


def test_the_end_waits_for_a_late_confirmation():
    now = time.monotonic()
    drives = [_Drive(1, now), _Drive(2, now + 0.2), _Drive(3, now + 0.3)]
    msg = asyncio.run(drives_left_operation(drives, 1.0))
    assert msg.startswith("every drive left OPERATION ENABLED within")
    assert all(d.state != "OPERATION ENABLED" for d in drives)   # what the baseline then reads
    assert 0.25 <= float(msg.split("within ")[1].split(" s")[0]) < 1.0


def test_a_drive_that_never_confirms_is_named_and_the_wait_is_bounded():
    now = time.monotonic()
    drives = [_Drive(1, now), _Drive(7, None)]
    t0 = time.monotonic()
    msg = asyncio.run(drives_left_operation(drives, 0.3))
    assert 0.3 <= time.monotonic() - t0 < 2.0
    assert "still reporting OPERATION ENABLED after 0.3 s: drive(s) 7" == msg
