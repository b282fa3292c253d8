"""`rig run scheme1|scheme2|scheme3`: run one experiment scheme against the emulator or the rig
(the settings say which: RIG_CONFIG / RIG_* variables, see daq/settings.py) and store it in the
database while it runs, with a progress bar and a live line of the key channels.

    rig emulate --time-scale 10 &                       # or the real rig, by settings
    RIG_PLC_POLL_HZ=200 rig run scheme1 --speed 3000 --direction 1 --operator alice
    rig run scheme3 --sample-rate 20 --periods 2
    rig run scheme1 --limit-set range --speed 300 --load 180000   # Table 11's torque range
    rig run --spec run.json                             # the same run as one JSON document
    rig runs; rig show RUN

The scheme options are derived from the schemes' own parameters (core.schemes: unit, default,
range); `--spec FILE` (or `-` for stdin) gives the whole run as one JSON document
(core.schemes.RunSpec), which is how the service's acquisition process starts it. With
`--json-events` stdout carries only JSON lines, one event each (`started`, `run_created`,
`progress`, `run_ended`, `run_failed`); the human lines then go to stderr.

The database is named by RIG_DB_URL (or `--db`; a password on a command line is visible to
every user of the machine, so prefer the variable); printed URLs have their password masked.

Exit code 0 when the run ends `success`, 1 on `abort` or `fail`, 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import json
import numbers
import os
import sys
from typing import Any

from core.effects import parse_effect
from core.schemes import RunSpec, SchemeParam, scheme_options

RUN_OPTIONS = ("operator", "notes", "effect", "reset_watchdog", "source", "rig_name")
"""Options that describe the run (they are in a --spec document instead)."""


def _option_help(per: dict[int, SchemeParam]) -> str:
    """Help of one scheme option: what, unit, range, the schemes it applies to, defaults."""
    p = next(iter(per.values()))
    b = p.bounds
    unit = f" [{b.unit}]" if b.unit else ""
    docs = list(dict.fromkeys(q.bounds.doc for q in per.values()))
    what = " / ".join(docs)
    defaults = {q.default for q in per.values()}
    fmt = "{!r}" if p.type is str else "{:g}"
    if len(defaults) == 1:
        default = "default " + fmt.format(p.default)
    else:
        default = "default " + ", ".join(fmt.format(q.default) + f" (scheme {n})"
                                         for n, q in per.items())
    which = ("scheme " if len(per) == 1 else "schemes ") + ", ".join(map(str, per))
    rng = b.interval() if b.choices is not None else "in " + b.interval()
    return f"{what}{unit}, {rng}; {which}; {default}"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scheme", nargs="?", choices=("scheme1", "scheme2", "scheme3"),
                        help="the scheme to run (or give the whole run with --spec)")
    parser.add_argument("--spec", metavar="FILE",
                        help="the run as one JSON document {scheme, params {field: value} "
                             "(the scheme options' fields, limit_set among them), "
                             "operator, notes, effects, source, rig_name, reset_watchdog}; "
                             "'-' reads stdin (with --control-stdin: its first line, the "
                             "commands follow); replaces the scheme and the run's options")
    for option, (_, typ, per) in scheme_options().items():
        choices = next(iter(per.values())).bounds.choices
        metavar = "{" + ",".join(choices) + "}" if typ is str else None
        parser.add_argument("--" + option.replace("_", "-"), dest=option, type=typ,
                            metavar=metavar, help=_option_help(per))
    parser.add_argument("--operator", help="who runs it (stored with the run)")
    parser.add_argument("--notes", help="free text stored with the run")
    parser.add_argument("--config", metavar="FILE",
                        help="settings file (TOML/JSON, [daq] table; default $RIG_CONFIG); "
                             "its [emulate.emulator] effects are recorded for emulated runs")
    parser.add_argument("--db", metavar="URL", help="database URL (default $RIG_DB_URL or "
                                                    "./rig-data/rig.sqlite; prefer the "
                                                    "variable for a URL with a password)")
    parser.add_argument("--source", choices=("emulator", "rig"),
                        help="what the settings point at (default: emulator when the PLC is "
                             "on a loopback address, else rig)")
    parser.add_argument("--rig-name", help="rig name stored with the run")
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[:k=v,...]",
                        help="an effect injected in the emulator (as given to `rig emulate`), "
                             "recorded with the run; repeatable")
    parser.add_argument("--reset-watchdog", action="store_true",
                        help="reset a PLC heartbeat-watchdog fault latched when the previous "
                             "session ended (never an e-stop or a limit trip)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    parser.add_argument("--json", action="store_true",
                        help="print the run's end record as one JSON object on stdout "
                             "(README, \"JSON output\"); progress and messages go to stderr")
    parser.add_argument("--json-events", action="store_true",
                        help="stdout carries only JSON lines, one event each (started, "
                             "run_created, progress, run_ended, run_failed), for a supervising "
                             "service; the human lines go to stderr")
    parser.add_argument("--control-stdin", action="store_true",
                        help="obey commands read from stdin: `stop` (make safe, abort), "
                             "`estop REASON`; end of input stops the run (its supervisor is gone)")


def scheme_params(args: argparse.Namespace, number: int) -> dict[str, Any]:
    """Scheme parameters given on the command line {dataclass field: value}; refuses options
    the scheme does not have."""
    out = {}
    for option, (name, _, per) in scheme_options().items():
        v = getattr(args, option, None)
        if v is None:
            continue
        if number not in per:
            raise ValueError(f"--{option.replace('_', '-')} does not apply to scheme {number}")
        out[name] = v
    return out


def run_spec(args: argparse.Namespace) -> RunSpec:
    """The run the arguments ask for: the --spec document, or the scheme and options (one or
    the other; ValueError when mixed or missing)."""
    if args.spec is None:
        if args.scheme is None:
            raise ValueError("give the scheme (scheme1, scheme2, scheme3) or --spec FILE")
        number = int(args.scheme[-1])
        return RunSpec(scheme=number, params=scheme_params(args, number),
                       operator=args.operator, notes=args.notes or "",
                       effects=parse_effects(args.effect) if args.effect else None,
                       source=args.source, rig_name=args.rig_name,
                       reset_watchdog=args.reset_watchdog)
    given = [o for o in scheme_options() if getattr(args, o, None) is not None]
    given += [o for o in RUN_OPTIONS if getattr(args, o, None) not in (None, False, [])]
    if args.scheme is not None or given:
        what = ", ".join(["the scheme"] * (args.scheme is not None)
                         + ["--" + o.replace("_", "-") for o in given])
        raise ValueError(f"--spec holds the whole run: give {what} in it, not as arguments")
    if args.spec == "-":
        text = sys.stdin.readline() if args.control_stdin else sys.stdin.read()
    else:
        with open(args.spec, encoding="utf-8") as f:
            text = f.read()
    return RunSpec.from_json(text)


def parse_effects(specs: list[str]) -> dict[str, dict[str, float]]:
    """`NAME[:k=v,...]` items as {name: {k: v}} (the syntax of `rig emulate --effect`)."""
    return dict(parse_effect(spec) for spec in specs)


def _is_loopback(host: str) -> bool:
    import ipaddress
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class LiveLine:
    """A progress bar and the key channels on stderr: one line rewritten in place on a
    terminal, cut to the terminal's width (read at every update, so a resized window is
    followed) and never wrapping; one plain line per update otherwise (logs, pipes)."""

    KEYS = (("q", "q", "rad", 1.0), ("torque", "T", "kN·m", 1e-3),
            ("torque_load", "τL", "kN·m", 1e-3), ("i_m1", "i1", "A", 1.0),
            ("w_m1", "w1", "rad/s", 1.0), ("p_hyd", "p", "bar", 1e-5))

    def __init__(self, stream) -> None:
        self.stream = stream
        self.tty = stream.isatty()

    def __call__(self, p) -> None:
        width = 24
        fill = int(round(p.fraction * width))
        bar = "#" * fill + "-" * (width - fill)
        vals = " ".join(f"{lab}={p.latest[k] * sc:.4g}{unit}" for k, lab, unit, sc in self.KEYS
                        if k in p.latest and p.latest[k] == p.latest[k])
        line = (f"[{bar}] {100 * p.fraction:5.1f}% t={p.t:.1f}/{p.duration:.1f} s "
                f"phase={p.phase} n={p.n_samples} missed={p.missed} {vals}")
        if self.tty:
            import shutil
            cols = shutil.get_terminal_size((80, 24)).columns
            try:
                cols = os.get_terminal_size(self.stream.fileno()).columns
            except (OSError, ValueError, AttributeError):
                pass
            # one column short of the width: a full-width line wraps on some terminals;
            # "\x1b[K" clears what a longer previous line left instead of padding with blanks
            self.stream.write("\r" + line[:max(cols - 1, 1)] + "\x1b[K")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


class JsonEvents:
    """The run reported as JSON lines, one event each, with an explicit `event` type (SI units;
    NaN as null): `started` (plan, source, duration, samples), `run_created` (run_id, once the
    run is stored), `progress` (run id, plan time and duration [s], fraction, phase, sample
    counts, every numeric channel of the latest sample, the rig's state: core.documents.RigState),
    `run_ended` (the outcome) or `run_failed` (reason).
    Also the engine's progress callback."""

    def __init__(self, stream, run_id) -> None:
        self.stream = stream
        self.run_id = run_id
        """Callable returning the run id (None before the run is stored)."""
        self.announced: int | None = None

    def emit(self, event: str, **fields: Any) -> None:
        from core.redact import redact_secrets
        for k, v in fields.items():
            if isinstance(v, str):
                fields[k] = redact_secrets(v)
        self.stream.write(json.dumps({"event": event, **fields}) + "\n")
        self.stream.flush()

    def announce(self) -> int | None:
        """`run_created` the first time the run id is known; returns the id."""
        rid = self.run_id()
        if rid is not None and self.announced is None:
            self.announced = rid
            self.emit("run_created", run_id=rid)
        return rid

    def __call__(self, p) -> None:
        rid = self.announce()
        chans = {k: (float(v) if v == v else None) for k, v in p.latest.items()
                 if isinstance(v, numbers.Real) and k != "t"}   # every numeric channel
        self.emit("progress", run_id=rid, t=p.t, duration=p.duration, fraction=p.fraction,
                  phase=p.phase or None, n_samples=p.n_samples, missed=p.missed,
                  channels=chans, rig=p.rig)

    def close(self) -> None:
        pass


async def run_controlled(engine, plan, read_stdin: bool = False):
    """Run `plan`; Ctrl-C (SIGINT) and SIGTERM stop it: the run is cancelled, the engine makes
    the rig safe and ends it `abort`. With read_stdin, also obey stdin: `stop`, `estop REASON`
    (e-stops the rig; the run ends `abort` with the e-stop as its reason), end of input = stop.
    Returns the outcome, None if the run was cancelled."""
    import asyncio
    import signal
    import sys
    import threading

    loop = asyncio.get_running_loop()
    task = asyncio.ensure_future(engine.run(plan))
    pending: set = set()

    def stop() -> None:
        # Python 3.11's asyncio.wait_for (inside every pymodbus request) can swallow a
        # cancellation that races a reply: cancel again until the engine is making the rig
        # safe (rig.safe is set before make-safe's first await; never cancel make-safe)
        if not task.done() and not engine.rig.safe:
            task.cancel()
            loop.call_later(0.5, stop)

    def command(line: str | None) -> None:
        if task.done():
            return
        # end of input: whatever controlled this run (the acquisition process) is gone
        words = (line if line is not None else
                 "stop the controlling process is gone (end of the run's input)").strip()
        if words == "stop" or words.startswith("stop "):
            if words[5:].strip():          # 'stop <reason>': recorded as the end reason
                engine.stop_reason = words[5:].strip()
            stop()
        elif words.split(" ")[0] == "estop":
            t = loop.create_task(engine.rig.estop(words[5:].strip() or "operator"))
            pending.add(t)
            t.add_done_callback(pending.discard)

    def read() -> None:
        for line in sys.stdin:
            loop.call_soon_threadsafe(command, line)
        loop.call_soon_threadsafe(command, None)
    if read_stdin:
        threading.Thread(target=read, name="stdin-commands", daemon=True).start()
    loop.add_signal_handler(signal.SIGTERM, command, "stop")
    loop.add_signal_handler(signal.SIGINT, command, "stop")
    try:
        return await task
    except asyncio.CancelledError:
        if task.cancelled() and not asyncio.current_task().cancelling():
            return None
        raise


def run(args: argparse.Namespace) -> int:
    import asyncio
    import os

    from core.config_file import read_config_file
    from core.redact import redact_secrets
    from daq.engine import Engine
    from daq.plans import Plan
    from daq.rig import Rig
    from daq.settings import Settings
    from db.store import Store

    events = JsonEvents(sys.stdout, lambda: engine.writer.run_id if engine.writer else None) \
        if args.json_events else None
    human = sys.stderr if events or args.json else sys.stdout

    def say(text: str, stream=None) -> None:
        print(redact_secrets(text), file=stream or human, flush=True)

    try:
        spec = run_spec(args)
        plan = Plan.of(spec.scheme, **spec.params)
        settings = Settings.load(args.config)
        effects = spec.effects
        cfg = args.config or os.environ.get("RIG_CONFIG")
        if effects is None and cfg:
            emu = read_config_file(cfg, section="emulate").get("emulator") or {}
            if isinstance(emu, dict) and emu.get("effects"):
                effects = dict(emu["effects"])
    except (ValueError, TypeError, KeyError, OSError) as exc:
        say(f"rig run: {exc}", sys.stderr)
        if events:
            events.emit("run_failed", run_id=None, reason=f"bad arguments: {exc}")
        return 2
    source = spec.source or ("emulator" if _is_loopback(settings.plc_host) else "rig")
    live = events or (None if args.quiet else LiveLine(sys.stderr))
    try:
        store = Store(args.db)
    except Exception as exc:  # noqa: BLE001 - one line, not a traceback: the store is unreachable
        first = (str(exc).splitlines() or [""])[0]
        why = f"cannot open the database: {type(exc).__name__}: {first}"
        say(f"rig run: {why}", sys.stderr)
        if events:
            events.emit("run_failed", run_id=None, reason=why)
        return 1
    engine = Engine(Rig(settings), store, source=source, rig_name=spec.rig_name,
                    operator=spec.operator, effects=effects, notes=spec.notes, progress=live,
                    reset_watchdog_fault=spec.reset_watchdog)
    say(f"rig run: {plan.name} on the {source} ({settings.plc_host}:{settings.plc_port}), "
        f"{plan.duration:.1f} s of rig time, {plan.n_samples()} samples at "
        f"{plan.sample_rate_hz:g} Hz, database {store.url}")
    if events:
        events.emit("started", plan=plan.name, scheme=spec.scheme, source=source,
                    plc=f"{settings.plc_host}:{settings.plc_port}", duration=plan.duration,
                    n_samples=plan.n_samples(), sample_rate_hz=plan.sample_rate_hz)
    try:
        outcome = asyncio.run(run_controlled(engine, plan, read_stdin=args.control_stdin))
        if outcome is None:
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        if live:
            live.close()
        rid = engine.writer.run_id if engine.writer else None
        say(f"rig run: run {rid} aborted by the operator; the rig was made safe", sys.stderr)
        if events:
            events.announce()
            events.emit("run_failed", run_id=rid, reason="aborted by the operator")
        return 1
    except Exception as exc:  # noqa: BLE001 - report the failure; the engine stored it
        if live:
            live.close()
        rid = engine.writer.run_id if engine.writer else None
        what = f"run {rid} failed" if rid is not None else "failed before the run started"
        say(f"rig run: {what}: {type(exc).__name__}: {exc}", sys.stderr)
        if events:
            events.announce()
            events.emit("run_failed", run_id=rid, reason=f"{what}: {type(exc).__name__}: {exc}")
        return 1
    finally:
        store.close()
    if live:
        live.close()
    say(f"rig run: run {outcome.run_id} ended {outcome.exit_status}"
        + (f" ({outcome.reason})" if outcome.reason else "")
        + f": {outcome.n_samples} samples, {outcome.missed} missed, "
          f"{outcome.interruptions} interruptions")
    if events:
        events.announce()
        events.emit("run_ended", run_id=outcome.run_id, exit_status=outcome.exit_status,
                    reason=outcome.reason, n_samples=outcome.n_samples, missed=outcome.missed,
                    interruptions=outcome.interruptions)
    elif args.json:
        print(json.dumps({"run_id": outcome.run_id, "plan": plan.name, "scheme": spec.scheme,
                          "source": source, "exit_status": outcome.exit_status,
                          "reason": outcome.reason, "n_samples": outcome.n_samples,
                          "missed": outcome.missed, "interruptions": outcome.interruptions}))
    return 0 if outcome.exit_status == "success" else 1
