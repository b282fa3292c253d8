"""Test-only job kinds that misbehave, and a worker process that knows them.

`register()` adds to api.job_kinds.KINDS (in the calling process only):
- crash: kills its own worker process — `how` "sigkill" (os.kill(getpid(), SIGKILL), as the
  kernel's out-of-memory killer does) or "exit" (os._exit(3), as a fatal error in compiled code);
- stuck: sleeps without polling anything (work inside compiled code), past its 1 s limit;
- spin: polls the samplers' stop check (estimator.stopping) in a loop, past its 1 s limit.

`python tests/job_supervision_kinds.py --db URL ...` is `python -m api.worker` with these kinds
registered: the command a test's WorkerPool starts."""

from __future__ import annotations

import os
import signal
import sys
import time
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

TIME_LIMIT_S = 1.0
"""The wall-clock limit of the stuck and spin kinds [s]."""


class CrashParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    how: Literal["sigkill", "exit"] = "sigkill"


class SleepParams(BaseModel):
    model_config = ConfigDict(extra="forbid")
    seconds: float = Field(60.0, gt=0.0)


def run_crash(store, params: CrashParams, progress) -> list:
    progress(0.2)
    if params.how == "sigkill":
        os.kill(os.getpid(), signal.SIGKILL)
    os._exit(3)


def run_stuck(store, params: SleepParams, progress) -> list:
    time.sleep(params.seconds)          # no progress report, no stop check: as compiled code
    return []


def run_spin(store, params: SleepParams, progress) -> list:
    from estimator import stopping

    end = time.monotonic() + params.seconds
    while time.monotonic() < end:
        stopping.poll()
        time.sleep(0.01)
    return []


def register() -> None:
    from api.job_kinds import KINDS, JobKind

    for k in (JobKind("crash", CrashParams, run_crash, "kills its worker process", 60.0),
              JobKind("stuck", SleepParams, run_stuck, "sleeps, polling nothing", TIME_LIMIT_S),
              JobKind("spin", SleepParams, run_spin, "polls the stop check", TIME_LIMIT_S)):
        KINDS[k.name] = k


def worker_command() -> list[str]:
    """The command line of a worker process that knows these kinds (without --db)."""
    return [sys.executable, os.path.abspath(__file__)]


if __name__ == "__main__":
    register()
    from api.worker import main
    sys.exit(main(sys.argv[1:]))
