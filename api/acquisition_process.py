"""The acquisition process: the child the service starts for each acquisition
(`python -m api.acquisition_process`), which supervises the stand-in and `rig run`.

    web process ──stdin/stdout──▶ acquisition process (this module)
      (api/acquisition.py)          ├─ `rig emulate` stand-in (target 'emulator': loopback,
                                    │   free ports)
                                    └─ `rig run --spec - --json-events --control-stdin`

Input, on stdin: the first line is the acquisition's spec (AcquisitionSpec as one line of
JSON); the lines after it are commands. The database is named by the environment (RIG_DB_URL),
never on a command line: a URL with its password would be visible to every user of the machine.

The acquisition process starts the stand-in (target 'emulator') and `rig run` — the same
command an operator types, pointed at the stand-in or, for target 'rig', at the rig of the DAQ
settings (RIG_CONFIG / RIG_*) — and hands `rig run` its run (core.schemes.RunSpec) as the first
line of its stdin. It forwards the commands it reads:

- `stop [REASON]`: `rig run` cancels the run; the engine makes the rig safe and ends it `abort`
  with REASON (default "cancelled by the operator");
- `estop REASON`: `rig run` e-stops the rig (daq.rig.Rig.estop: trip, make safe, latch the
  PLC's e-stop); the run ends `abort` with the e-stop as its reason. If `rig run` has not ended
  `ESTOP_GRACE_S` later (wedged), the acquisition process latches the PLC's e-stop itself
  through the DAQ driver and kills it (the PLC's heartbeat watchdog then holds the rig safe).

Output, on stdout: JSON lines, one event each, with an explicit `event` type — its own
(`state`, `standin`, `spawned`, `log`, `ended`, `standin_stopped`) and `rig run`'s, relayed as
they are (`started`, `run_created`, `progress`, `run_ended`, `run_failed`). `rig run`'s human
lines (its stderr) become `log` events, with any URL password masked.

Nothing loses track: end of input on stdin (the service is gone, even by SIGKILL) or
SIGTERM/SIGINT = stop, each with its reason in the run's record; `rig run` likewise stops on end
of its stdin; the stand-in is stopped
only after `rig run` has ended (so make-safe reaches its PLC).
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
from dataclasses import asdict, dataclass
from typing import Any

from core.redact import redact_secrets
from core.schemes import RunSpec

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


@dataclass(frozen=True)
class AcquisitionSpec:
    """What the service asks of one acquisition process: the run, the target, and for the
    emulator how the stand-in runs. No secret: the database comes by environment."""
    run: RunSpec
    target: str
    """'emulator' (a stand-in started for this run) or 'rig' (the DAQ settings' rig)."""
    time_scale: float = 1.0
    """Stand-in: rig seconds per wall second."""
    seed: int = 0
    """Stand-in: the emulator's seed."""
    watchdog_s: float = 0.5
    """Stand-in: the PLC's watchdog on the service heartbeat [s]."""

    def __post_init__(self) -> None:
        if self.target not in TARGETS:
            raise ValueError(f"target must be one of {TARGETS}, got {self.target!r}")

    def to_json(self) -> str:
        """One line of JSON (the first line the acquisition process reads)."""
        return json.dumps({**asdict(self), "run": self.run.to_dict()}, allow_nan=False)

    @classmethod
    def from_json(cls, text: str) -> "AcquisitionSpec":
        doc = json.loads(text)
        return cls(**{**doc, "run": RunSpec.from_dict(doc["run"])})


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


def _emit(event: str, **fields: Any) -> None:
    _out(json.dumps({"event": event, **fields}))


def _log(line: str) -> None:
    _emit("log", line=redact_secrets(line))


def run_command() -> list[str]:
    """The `rig run` command line: the run itself comes on its stdin, the database by
    environment; nothing on it is the run's or a secret."""
    return [sys.executable, "-m", "commands.cli", "run", "--spec", "-", "--json-events",
            "--control-stdin"]


def _effect_arg(name: str, kv: dict[str, float]) -> str:
    from core.effects import format_effect
    return format_effect(name, kv)


def standin_args(spec: AcquisitionSpec) -> list[str]:
    """`rig emulate`'s options for the stand-in of an emulator acquisition."""
    args = [f"--time-scale={float(spec.time_scale)!r}", f"--seed={int(spec.seed)}",
            f"--watchdog={float(spec.watchdog_s)!r}"]
    for name, kv in (spec.run.effects or {}).items():
        args.append(f"--effect={_effect_arg(name, kv)}")
    return args


def daq_env(standin) -> dict[str, str]:
    """Environment of `rig run`: the DAQ settings as they are (target 'rig'), or pointed at the
    stand-in on loopback (target 'emulator'; a settings file is then not read). RIG_DB_URL is
    passed on as it came."""
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


def _relay_events(stream) -> None:
    """`rig run`'s stdout: its JSON events, forwarded as they are; anything else as a log."""
    for line in stream:
        line = line.rstrip("\n")
        try:
            ev = json.loads(line)
        except json.JSONDecodeError:
            ev = None
        if isinstance(ev, dict) and isinstance(ev.get("event"), str):
            _out(json.dumps(ev))
        elif line:
            _log(line)


def _relay_log(stream) -> None:
    """`rig run`'s stderr (its human lines): log events."""
    for line in stream:
        _log(line.rstrip("\n"))


def supervise(spec: AcquisitionSpec, commands: "queue.Queue[str | None]") -> int:
    """The acquisition process's work: stand-in (emulator), `rig run`, relay, commands (module
    doc). `commands` yields the lines read after the spec (None: end of input)."""
    signalled = [False]      # a flag, not a queue: a handler must not take a lock

    def on_signal(*_: Any) -> None:
        signalled[0] = True
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, on_signal)

    def next_command(timeout: float = 0.0) -> str | None:
        """The next stop/estop command ('stop' for end of input or a signal), else None."""
        if signalled[0]:
            signalled[0] = False
            return "stop the acquisition process was signalled to stop"
        try:
            c = commands.get(timeout=timeout) if timeout else commands.get_nowait()
        except queue.Empty:
            return None
        if c is None:   # the service's end of the pipe closed: it is gone (even by SIGKILL)
            return "stop the service is gone (end of the acquisition's input)"
        return c if c == "stop" or c.startswith(("stop ", "estop")) else None

    standin, proc = None, None
    try:
        if spec.target == "emulator":
            from simulators.process import StandinProcess
            _emit("state", state="starting", detail="starting the stand-in")
            standin = StandinProcess(standin_args(spec))
            _emit("standin", pid=standin.proc.pid, plc_port=standin.plc_port,
                  can_port=standin.can_port)
        env = daq_env(standin)
        early = next_command()
        if early is not None:
            if early.startswith("estop"):    # an e-stop always reaches the rig
                _log(latch_plc_estop(env))
            _emit("ended", exit_code=None, reason=f"{early.split(' ')[0]} before the run started")
            return 1
        proc = subprocess.Popen(run_command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=env, bufsize=1)
        _emit("spawned", pid=proc.pid)
        _send(proc, spec.run.to_json())              # the run: the first line of its stdin
        relays = [threading.Thread(target=_relay_events, args=(proc.stdout,), daemon=True),
                  threading.Thread(target=_relay_log, args=(proc.stderr,), daemon=True)]
        for t in relays:
            t.start()
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
                    _log(latch_plc_estop(env))
                    proc.kill()
                elif escalate == "stop":
                    proc.send_signal(signal.SIGINT)
                    deadline, escalate = time.monotonic() + 10.0, "kill"
                else:
                    proc.kill()
        rc = proc.wait()
        for t in relays:
            t.join(timeout=5.0)
        _emit("ended", exit_code=rc)
        return 0
    except Exception as exc:  # noqa: BLE001 - tell the service, then clean up
        _emit("ended", exit_code=None, reason=redact_secrets(f"{type(exc).__name__}: {exc}"))
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
                    _log("stand-in: " + line[len("rig emulate: "):])
            _emit("standin_stopped", exit_code=rc)


def _send(proc: subprocess.Popen, line: str) -> None:
    try:
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
    except (BrokenPipeError, OSError, ValueError):
        pass


def main() -> int:
    """`python -m api.acquisition_process`: read the spec (first line of stdin), then
    supervise, obeying the commands on the following lines."""
    first = sys.stdin.readline()
    try:
        spec = AcquisitionSpec.from_json(first)
    except (ValueError, TypeError, KeyError) as exc:
        _emit("ended", exit_code=None, reason=f"bad acquisition spec: {exc}")
        return 2
    commands: queue.Queue[str | None] = queue.Queue()

    def read_stdin() -> None:
        for line in sys.stdin:
            commands.put(line.strip())
        commands.put(None)
    threading.Thread(target=read_stdin, daemon=True).start()
    return supervise(spec, commands)


if __name__ == "__main__":
    raise SystemExit(main())
