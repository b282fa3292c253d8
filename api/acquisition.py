"""Scheme acquisitions started by the service, each in processes of its own: the web side.

    web process (AcquisitionManager) ──stdin/stdout──▶ acquisition process
                                                         (api/acquisition_process.py)
                                                         ├─ `rig emulate` stand-in (emulator)
                                                         └─ `rig run --spec -`

The web process never touches the rig: it starts one acquisition process per acquisition
(`python -m api.acquisition_process`), writes it the acquisition's spec (one JSON line) and
then the commands `stop` / `estop REASON` on its stdin, and reads its events (JSON lines with an
explicit `event` type) from its stdout. The database URL goes to it by environment
(RIG_DB_URL), never on a command line; every line kept for `log_tail` and every reason shown
has any URL password masked (core.redact).

Progress and the run id come from the events (`progress`, `run_created`, relayed from `rig
run`, every 0.2 s with every numeric channel of the latest sample and the rig's state — PLC,
drives, interlocks, e-stop latch, core.documents.RigState — plus one after make-safe with the
final state; the last one stays in the acquisition's `progress` as the last known state): no
database polling, and
they arrive whether or not the writer's commits are visible yet. The final state comes from SQL —
the run's row written by the engine is the record of truth — read once the processes have
ended. The service stops its acquisitions when it shuts down (AcquisitionManager.shutdown).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any

from api.acquisition_process import STOP_GRACE_S, AcquisitionSpec
from core.jsonsafe import json_safe
from core.redact import redact_secrets


class Busy(Exception):
    """The target already has an acquisition that has not ended."""


@dataclass
class Acquisition:
    """One acquisition as the service sees it (updated by the thread reading its process)."""

    id: str
    spec: AcquisitionSpec
    state: str = "starting"
    """starting → running → stopping → ended"""
    run_id: int | None = None
    run_status: str | None = None
    """When ended: the run's exit status (success, abort, fail), 'interrupted' if its writer
    died, None if no run was stored."""
    reason: str | None = None
    progress: dict[str, Any] | None = None
    standin: dict[str, Any] | None = None
    requested: list[dict[str, Any]] = field(default_factory=list)
    """Stop / e-stop requests: who, what, when."""
    created_at: str = ""
    ended_at: str | None = None
    log: deque = field(default_factory=lambda: deque(maxlen=50))
    version: int = 0
    """Bumped on every change (the event stream waits on it)."""
    progress_seq: int = 0
    """Number of progress events received (the sequence number of the latest)."""
    recent_progress: deque = field(default_factory=lambda: deque(maxlen=32))
    """The latest progress events as (sequence number, the event as JSON text with the run id):
    the event stream sends each one, not only the latest it sees when it wakes (two events that
    came close together, e.g. after a stall of a process on a loaded machine, are both
    delivered); serialized once here, not once per client."""
    proc: subprocess.Popen | None = None
    rig_run_pid: int | None = None
    exit_code: int | None = None
    runs_before: int = 0
    """Largest run id when it started (its run comes after)."""
    failure: str | None = None
    """`rig run`'s reason when it reported `run_failed` (e.g. refused before a run was
    stored)."""
    twin: Any = None
    """The live twin (estimator.twin.Twin) of the rig's model when the acquisition started,
    None when no fit is marked as the rig's model."""
    twin_fit_id: int | None = None

    def snapshot(self) -> dict[str, Any]:
        """The resource as JSON."""
        reason = redact_secrets(self.reason) if self.reason is not None else None
        return {"id": self.id, "scheme": self.spec.run.scheme, "target": self.spec.target,
                "state": self.state, "run_id": self.run_id, "run_status": self.run_status,
                "reason": reason, "progress": self.progress, "standin": self.standin,
                "params": self.spec.run.params, "operator": self.spec.run.operator,
                "requests": list(self.requested), "created_at": self.created_at,
                "ended_at": self.ended_at,
                "log_tail": [redact_secrets(ln) for ln in list(self.log)[-20:]]}


def _now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


class AcquisitionManager:
    """The service's acquisitions: start (one per target at a time), look up, stop, e-stop,
    shut down. Thread-safe; used from the request handlers."""

    def __init__(self, db_url: str, store, keep_ended: int = 100) -> None:
        self._db_url = db_url
        """Given to the acquisition processes by environment only (never argv, never shown)."""
        self.store = store
        self.keep_ended = keep_ended
        self._lock = threading.Lock()
        self._acqs: dict[str, Acquisition] = {}
        self._closed = False

    def start(self, spec: AcquisitionSpec) -> Acquisition:
        """Start an acquisition of `spec`: its process, given the spec on stdin and the
        database by environment."""
        with self._lock:
            if self._closed:
                raise Busy("the service is shutting down")
            for a in self._acqs.values():
                if a.spec.target == spec.target and a.state != "ended":
                    raise Busy(f"acquisition {a.id} ({a.state}) is using the {spec.target}")
            acq = Acquisition(id=uuid.uuid4().hex, spec=spec, created_at=_now(),
                              runs_before=self._last_run_id())
            acq.twin, acq.twin_fit_id = self._twin()
            acq.proc = subprocess.Popen(
                process_command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT, text=True, bufsize=1,
                env=dict(os.environ, PYTHONUNBUFFERED="1", RIG_DB_URL=self._db_url))
            try:
                acq.proc.stdin.write(spec.to_json() + "\n")
                acq.proc.stdin.flush()
            except (BrokenPipeError, OSError):
                pass  # it died at once: _follow records how
            self._acqs[acq.id] = acq
            self._trim()
        threading.Thread(target=self._follow, args=(acq,), name=f"acq-{acq.id[:8]}",
                         daemon=True).start()
        return acq

    def _twin(self) -> tuple[Any, int | None]:
        """The live twin of the rig's current model (db.rig_model), or (None, None)."""
        from db.rig_model import current_rig_model
        from estimator.twin import Twin, TwinUnavailable
        try:
            cur = current_rig_model(self.store)
            if cur is None:
                return None, None
            return Twin(cur["model"], cur["params"]), cur["fit_id"]
        except (TwinUnavailable, OSError, ValueError):
            return None, None

    def _trim(self) -> None:
        ended = [a for a in self._acqs.values() if a.state == "ended"]
        for a in ended[:max(0, len(ended) - self.keep_ended)]:
            del self._acqs[a.id]

    def get(self, acq_id: str) -> Acquisition | None:
        return self._acqs.get(acq_id)

    def acquisitions(self) -> list[Acquisition]:
        """Every acquisition this service has run (the last `keep_ended` ended ones), oldest
        first."""
        return list(self._acqs.values())

    def _bump(self, acq: Acquisition, **changes: Any) -> None:
        with self._lock:
            for k, v in changes.items():
                setattr(acq, k, v)
            if "progress" in changes:
                acq.progress_seq += 1
                text = json.dumps(json_safe({"run_id": acq.run_id, **changes["progress"]}))
                acq.recent_progress.append((acq.progress_seq, text))
            acq.version += 1

    def _follow(self, acq: Acquisition) -> None:
        """Read the acquisition process's events until it ends, then take the final state
        from SQL."""
        ended_reason = None
        for line in acq.proc.stdout:
            line = line.rstrip("\n")
            try:
                ev = json.loads(line) if line.startswith("{") else {"event": "log", "line": line}
            except json.JSONDecodeError:
                ev = {"event": "log", "line": line}
            kind = ev.get("event")
            if kind == "progress":
                progress = {k: ev.get(k) for k in (
                    "t", "duration", "fraction", "phase", "n_samples", "missed", "channels",
                    "rig")}
                progress["sent_at"] = time.time()
                if acq.twin is not None and progress["t"] is not None:
                    twin = acq.twin.update(float(progress["t"]), progress["channels"] or {})
                    if twin is not None:
                        progress["twin"] = {"fit_id": acq.twin_fit_id, **twin}
                changes: dict[str, Any] = {"progress": progress}
                if ev.get("run_id") is not None:
                    changes["run_id"] = int(ev["run_id"])
                if acq.state == "starting":
                    changes["state"] = "running"
                self._bump(acq, **changes)
            elif kind == "standin":
                self._bump(acq, standin={"pid": ev["pid"], "plc_port": ev["plc_port"],
                                         "can_port": ev["can_port"], "running": True})
            elif kind == "standin_stopped":
                if acq.standin is not None:
                    self._bump(acq, standin={**acq.standin, "running": False,
                                             "exit_code": ev.get("exit_code")})
            elif kind == "run_created":
                self._bump(acq, run_id=int(ev["run_id"]))
            elif kind == "run_ended":
                if ev.get("run_id") is not None:
                    self._bump(acq, run_id=int(ev["run_id"]))
            elif kind == "run_failed":
                failed: dict[str, Any] = {"failure": str(ev.get("reason") or "rig run failed")}
                if ev.get("run_id") is not None:
                    failed["run_id"] = int(ev["run_id"])
                self._bump(acq, **failed)
            elif kind == "spawned":
                self._bump(acq, rig_run_pid=int(ev["pid"]))
            elif kind == "ended":
                ended_reason = ev.get("reason")
                self._bump(acq, exit_code=ev.get("exit_code"))
            elif kind == "log":
                acq.log.append(redact_secrets(str(ev.get("line", ""))))
        acq.proc.wait()
        with self._lock:
            acq.proc.stdin.close()
        acq.proc.stdout.close()
        self._finish(acq, ended_reason)

    def _finish(self, acq: Acquisition, reason: str | None) -> None:
        """The run's final status and reason from its row in SQL (after marking runs whose
        writer died as interrupted)."""
        run_id, status = acq.run_id, None
        try:
            self.store.recover_interrupted()
            if run_id is None and acq.rig_run_pid is not None:
                run_id = self._run_of_pid(acq.rig_run_pid, acq.runs_before)
            if run_id is not None:
                info = self.store.run_info(run_id)
                status = info["exit_status"] or info["status"]
                reason = info["reason"]
        except Exception as exc:  # noqa: BLE001 - the acquisition must still end
            reason = f"{reason + '; ' if reason else ''}could not read the run: {exc!r}"
        if run_id is None and reason is None:
            reason = acq.failure or "the acquisition ended before a run was stored"
        self._bump(acq, state="ended", run_id=run_id, run_status=status, reason=reason,
                   ended_at=_now())

    def _run_of_pid(self, pid: int, after_id: int) -> int | None:
        """The run a `rig run` process wrote (when it died before reporting its id)."""
        import socket

        from sqlalchemy import select

        from db.models import Run
        with self.store.ReadSession() as s:
            return s.execute(select(Run.id).where(
                Run.writer_pid == pid, Run.writer_host == socket.gethostname(),
                Run.id > after_id).order_by(Run.id.desc()).limit(1)).scalar()

    def _last_run_id(self) -> int:
        from sqlalchemy import func, select

        from db.models import Run
        with self.store.ReadSession() as s:
            return int(s.execute(select(func.max(Run.id))).scalar() or 0)

    def _command(self, acq: Acquisition, line: str, who: str) -> None:
        with self._lock:
            acq.requested.append({"command": line.split(" ")[0], "by": who, "at": _now()})
            if acq.state in ("starting", "running"):
                acq.state = "stopping"
            acq.version += 1
            try:
                acq.proc.stdin.write(line + "\n")
                acq.proc.stdin.flush()
            except (BrokenPipeError, OSError, ValueError):
                pass  # the process has ended; _follow records how

    def stop(self, acq: Acquisition, who: str) -> None:
        """Stop: the run is made safe and ends `abort` (no-op once ended)."""
        if acq.state != "ended":
            self._command(acq, "stop", who)

    def estop(self, acq: Acquisition, reason: str, who: str) -> None:
        """E-stop the rig at once; the run ends `abort` with the e-stop as its reason."""
        if acq.state != "ended":
            self._command(acq, f"estop {reason} (by {who})", who)

    def shutdown(self, timeout: float = STOP_GRACE_S + 15.0) -> None:
        """Stop every acquisition and wait for them to end (service shutdown)."""
        with self._lock:
            self._closed = True
            live = [a for a in self._acqs.values() if a.state != "ended"]
        for a in live:      # recorded as the run's end reason
            if a.state != "ended":
                self._command(a, "stop the service shut down", "service shutdown")
        deadline = time.monotonic() + timeout
        for a in live:
            try:
                a.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                a.proc.kill()
        end = time.monotonic() + 5.0
        while any(a.state != "ended" for a in live) and time.monotonic() < end:
            time.sleep(0.05)


def process_command() -> list[str]:
    """The acquisition process's command line: nothing of the acquisition or the database on
    it (the spec comes on its stdin, the database URL by environment)."""
    return [sys.executable, "-m", "api.acquisition_process"]
