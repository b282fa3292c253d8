"""Scheme acquisitions started by the service, each in processes of its own.

    web process ──stdin/stdout──▶ acquisition process (`python -m api.acquisition SPEC URL`)
                                    ├─ `rig emulate` stand-in (target 'emulator': loopback,
                                    │   free ports)
                                    └─ `rig run schemeN --json-progress --control-stdin`

The web process never touches the rig: it starts one *acquisition process* per acquisition and
talks to it over pipes. The acquisition process starts the stand-in (target 'emulator') and
`rig run` — the same command an operator types, pointed at the stand-in or, for target 'rig',
at the rig of the DAQ settings (RIG_CONFIG / RIG_*) — relays `rig run`'s JSON progress lines
to its stdout, and forwards the commands it reads on stdin:

- `stop`: `rig run` cancels the run; the engine makes the rig safe and ends it `abort`;
- `estop REASON`: `rig run` e-stops the rig (daq.rig.Rig.estop: trip, make safe, latch the
  PLC's e-stop); the run ends `abort` with the e-stop as its reason. If `rig run` has not ended
  `ESTOP_GRACE_S` later (wedged), the acquisition process latches the PLC's e-stop itself
  through the DAQ driver and kills it (the PLC's heartbeat watchdog then holds the rig safe).

Nothing loses track: end of input on the acquisition process's stdin (the service is gone,
even by SIGKILL) or SIGTERM/SIGINT = stop; `rig run` likewise stops on end of its stdin; the
stand-in is stopped only after `rig run` has ended (so make-safe reaches its PLC). The service
stops its acquisitions when it shuts down (AcquisitionManager.shutdown).

Progress comes from `rig run`'s output (machine-readable JSON lines, every 0.25 s, the key
channels of the latest sample): it needs no database polling and arrives whether or not the
writer's commits are visible yet. The final state comes from SQL — the run's row written by
the engine is the record of truth — read once the processes have ended.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any

TARGETS = ("emulator", "rig")
ESTOP_GRACE_S = 5.0
"""After an e-stop command, how long `rig run` may take to end before the acquisition process
latches the PLC's e-stop itself and kills it [s]."""
STOP_GRACE_S = 30.0
"""After a stop command, how long `rig run` may take to make safe and end before SIGINT, then
SIGKILL [s]."""
EMULATOR_POLL_HZ = 200.0
"""PLC poll rate of runs on the service's stand-in [Hz of wall time]."""
EMULATOR_TPDO_HZ = 100.0
"""Drive TPDO rate of runs on the service's stand-in [Hz of rig time]."""
MAX_SAMPLE_RATE_TIMES_SCALE = 0.9 * EMULATOR_POLL_HZ
"""sample rate × time scale the stand-in's poll can deliver (the engine refuses more)."""


# --- the acquisition process ----------------------------------------------------------------

_OUT_LOCK = threading.Lock()


def _out(line: str) -> None:
    """One line to the service; if the service is gone (broken pipe) the line is dropped —
    the end of input on stdin tells the acquisition process to stop."""
    with _OUT_LOCK:
        try:
            sys.stdout.write(line + "\n")
            sys.stdout.flush()
        except (BrokenPipeError, OSError, ValueError):
            pass


def _emit(event: dict[str, Any]) -> None:
    _out(json.dumps(event))


def run_command(spec: dict[str, Any], db_url: str) -> list[str]:
    """The `rig run` command line of an acquisition spec (see AcquisitionManager.start)."""
    from core.schemes import SCHEME_ARGS
    option = {name: "--" + dest.replace("_", "-") for dest, (name, _, _) in SCHEME_ARGS.items()}
    cmd = [sys.executable, "-m", "commands.cli", "run", f"scheme{spec['scheme']}", "--json-progress",
           "--control-stdin", "--db", db_url, "--source", spec["target"]]
    # OPTION=VALUE throughout: a value starting with '-' is never taken for an option
    for name, value in spec["params"].items():
        cmd.append(f"{option[name]}={value}")
    if spec.get("operator"):
        cmd.append(f"--operator={spec['operator']}")
    if spec.get("notes"):
        cmd.append(f"--notes={spec['notes']}")
    if spec.get("reset_watchdog"):
        cmd.append("--reset-watchdog")
    for name, kv in (spec.get("effects") or {}).items():
        cmd.append(f"--effect={_effect_arg(name, kv)}")
    return cmd


def _effect_arg(name: str, kv: dict[str, float]) -> str:
    from core.effects import format_effect
    return format_effect(name, kv)


def _standin_args(spec: dict[str, Any]) -> list[str]:
    args = [f"--time-scale={float(spec['time_scale'])!r}", f"--seed={int(spec['seed'])}",
            f"--watchdog={float(spec.get('watchdog_s', 0.5))!r}"]
    for name, kv in (spec.get("effects") or {}).items():
        args.append(f"--effect={_effect_arg(name, kv)}")
    return args


def _daq_env(spec: dict[str, Any], standin) -> dict[str, str]:
    """Environment of `rig run`: the DAQ settings as they are (target 'rig'), or pointed at the
    stand-in on loopback (target 'emulator'; a settings file is then not read)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    if standin is not None:
        env.pop("RIG_CONFIG", None)
        env.update(RIG_PLC_HOST="127.0.0.1", RIG_PLC_PORT=str(standin.plc_port),
                   RIG_CAN_INTERFACE="socketcand", RIG_CAN_HOST="127.0.0.1",
                   RIG_CAN_PORT=str(standin.can_port), RIG_NODE_IDS="1,2,3",
                   RIG_PLC_POLL_HZ=repr(EMULATOR_POLL_HZ), RIG_TPDO_RATE_HZ=repr(EMULATOR_TPDO_HZ))
    return env


def latch_plc_estop(env: dict[str, str]) -> str:
    """Latch the PLC's e-stop through the DAQ driver (a fresh Modbus client on the settings of
    `env`); returns what happened."""
    import asyncio

    from daq.plc import PlcClient
    from daq.settings import Settings

    async def latch() -> None:
        client = PlcClient(Settings.load(env=env))
        await client.connect()
        try:
            await client.set_command_bits(estop=True, run=False, pump_on=False)
        finally:
            client.close()
    try:
        asyncio.run(asyncio.wait_for(latch(), 5.0))
        return "PLC e-stop latched by the acquisition process"
    except Exception as exc:  # noqa: BLE001 - report, the kill follows anyway
        return f"could not latch the PLC e-stop: {exc!r}"


def supervise(spec: dict[str, Any], db_url: str) -> int:
    """The acquisition process: stand-in (emulator), `rig run`, relay, commands (module doc)."""
    commands: queue.Queue[str | None] = queue.Queue()

    def read_stdin() -> None:
        for line in sys.stdin:
            commands.put(line.strip())
        commands.put(None)
    threading.Thread(target=read_stdin, daemon=True).start()
    signalled = [False]      # a flag, not a queue: a handler must not take a lock

    def on_signal(*_: Any) -> None:
        signalled[0] = True
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, on_signal)

    def next_command(timeout: float = 0.0) -> str | None:
        """The next stop/estop command ('stop' for end of input or a signal), else None."""
        if signalled[0]:
            signalled[0] = False
            return "stop"
        try:
            c = commands.get(timeout=timeout) if timeout else commands.get_nowait()
        except queue.Empty:
            return None
        if c is None:
            return "stop"
        return c if c == "stop" or c.startswith("estop") else None

    standin, proc = None, None
    try:
        if spec["target"] == "emulator":
            from simulators.process import StandinProcess
            _emit({"event": "state", "state": "starting", "detail": "starting the stand-in"})
            standin = StandinProcess(_standin_args(spec))
            _emit({"event": "standin", "pid": standin.proc.pid, "plc_port": standin.plc_port,
                   "can_port": standin.can_port})
        env = _daq_env(spec, standin)
        early = next_command()
        if early is not None:
            if early.startswith("estop"):    # an e-stop always reaches the rig
                _emit({"event": "log", "line": latch_plc_estop(env)})
            _emit({"event": "ended", "exit_code": None,
                   "reason": f"{early.split(' ')[0]} before the run started"})
            return 1
        proc = subprocess.Popen(run_command(spec, db_url), stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                env=env, bufsize=1)
        _emit({"event": "spawned", "pid": proc.pid})

        def relay() -> None:
            for line in proc.stdout:
                line = line.rstrip("\n")
                if line.startswith("{"):
                    _out(line)
                else:
                    _emit({"event": "log", "line": line})
        relay_thread = threading.Thread(target=relay, daemon=True)
        relay_thread.start()
        deadline, escalate = None, None
        while proc.poll() is None:
            cmd = next_command(timeout=0.1)
            if cmd is not None:
                _send(proc, cmd)
                grace = ESTOP_GRACE_S if cmd.startswith("estop") else STOP_GRACE_S
                if deadline is None or time.monotonic() + grace < deadline:
                    deadline, escalate = time.monotonic() + grace, cmd.split(" ")[0]
            if deadline is not None and time.monotonic() > deadline and proc.poll() is None:
                if escalate == "estop":
                    _emit({"event": "log", "line": latch_plc_estop(env)})
                    proc.kill()
                elif escalate == "stop":
                    proc.send_signal(signal.SIGINT)
                    deadline, escalate = time.monotonic() + 10.0, "kill"
                else:
                    proc.kill()
        rc = proc.wait()
        relay_thread.join(timeout=5.0)
        _emit({"event": "ended", "exit_code": rc})
        return 0
    except Exception as exc:  # noqa: BLE001 - tell the service, then clean up
        _emit({"event": "ended", "exit_code": None, "reason": f"{type(exc).__name__}: {exc}"})
        return 1
    finally:
        if proc is not None and proc.poll() is None:
            _send(proc, "stop")
            try:
                proc.wait(timeout=STOP_GRACE_S)
            except subprocess.TimeoutExpired:
                proc.kill()
        if standin is not None:
            rc = standin.stop()
            for line in standin.lines:     # the PLC's trips and resets, for the record
                if line.startswith("rig emulate: PLC ") and "listening" not in line:
                    _emit({"event": "log", "line": "stand-in: " + line[len("rig emulate: "):]})
            _emit({"event": "standin_stopped", "exit_code": rc})


def _send(proc: subprocess.Popen, line: str) -> None:
    try:
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
    except (BrokenPipeError, OSError, ValueError):
        pass


# --- the web process's side -----------------------------------------------------------------

class Busy(Exception):
    """The target already has an acquisition that has not ended."""


@dataclass
class Acquisition:
    """One acquisition as the service sees it (updated by the thread reading its process)."""

    id: str
    spec: dict[str, Any]
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
    proc: subprocess.Popen | None = None
    rig_run_pid: int | None = None
    exit_code: int | None = None
    runs_before: int = 0
    """Largest run id when it started (its run comes after)."""

    def snapshot(self) -> dict[str, Any]:
        """The resource as JSON."""
        return {"id": self.id, "scheme": self.spec["scheme"], "target": self.spec["target"],
                "state": self.state, "run_id": self.run_id, "run_status": self.run_status,
                "reason": self.reason, "progress": self.progress, "standin": self.standin,
                "params": self.spec["params"], "operator": self.spec.get("operator"),
                "requests": list(self.requested), "created_at": self.created_at,
                "ended_at": self.ended_at, "log_tail": list(self.log)[-20:]}


def _now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


class AcquisitionManager:
    """The service's acquisitions: start (one per target at a time), look up, stop, e-stop,
    shut down. Thread-safe; used from the request handlers."""

    def __init__(self, db_url: str, store, keep_ended: int = 100) -> None:
        self.db_url = db_url
        self.store = store
        self.keep_ended = keep_ended
        self._lock = threading.Lock()
        self._acqs: dict[str, Acquisition] = {}
        self._closed = False

    def start(self, spec: dict[str, Any]) -> Acquisition:
        """Start an acquisition of `spec` {scheme, target, params {scheme field: value},
        operator, notes, reset_watchdog, and for the emulator time_scale, seed, effects}."""
        with self._lock:
            if self._closed:
                raise Busy("the service is shutting down")
            for a in self._acqs.values():
                if a.spec["target"] == spec["target"] and a.state != "ended":
                    raise Busy(f"acquisition {a.id} ({a.state}) is using the {spec['target']}")
            acq = Acquisition(id=uuid.uuid4().hex, spec=spec, created_at=_now(),
                              runs_before=self._last_run_id())
            acq.proc = subprocess.Popen(
                [sys.executable, "-m", "api.acquisition", json.dumps(spec), self.db_url],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                text=True, bufsize=1, env=dict(os.environ, PYTHONUNBUFFERED="1"))
            self._acqs[acq.id] = acq
            self._trim()
        threading.Thread(target=self._follow, args=(acq,), name=f"acq-{acq.id[:8]}",
                         daemon=True).start()
        return acq

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
                changes: dict[str, Any] = {"progress": {k: ev.get(k) for k in (
                    "t", "duration", "fraction", "phase", "n_samples", "missed", "channels")}}
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
            elif kind == "spawned":
                self._bump(acq, rig_run_pid=int(ev["pid"]))
            elif kind == "ended":
                ended_reason = ev.get("reason")
                self._bump(acq, exit_code=ev.get("exit_code"))
            elif kind == "log":
                acq.log.append(ev.get("line", ""))
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
            tail = [ln for ln in acq.log if ln.startswith("rig run:")]
            reason = tail[-1] if tail else "the acquisition ended before a run was stored"
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
        for a in live:
            self.stop(a, "service shutdown")
        deadline = time.monotonic() + timeout
        for a in live:
            try:
                a.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                a.proc.kill()
        end = time.monotonic() + 5.0
        while any(a.state != "ended" for a in live) and time.monotonic() < end:
            time.sleep(0.05)


def main(argv: list[str] | None = None) -> int:
    """`python -m api.acquisition SPEC_JSON DB_URL`: one acquisition process."""
    argv = sys.argv[1:] if argv is None else argv
    return supervise(json.loads(argv[0]), argv[1])


if __name__ == "__main__":
    raise SystemExit(main())
