"""`rig run scheme1|scheme2|scheme3`: run one experiment scheme against the emulator or the rig
(the settings say which: RIG_CONFIG / RIG_* variables, see daq/settings.py) and store it in the
database while it runs, with a progress bar and a live line of the key channels.

    rig emulate --time-scale 10 &                       # or the real rig, by settings
    RIG_PLC_POLL_HZ=200 rig run scheme1 --speed 3000 --direction 1 --operator alice
    rig run scheme3 --sample-rate 20 --periods 2
    rig runs; rig show RUN

Exit code 0 when the run ends `success`, 1 on `abort` or `fail`, 2 on bad arguments.
"""

from __future__ import annotations

import argparse

from core.effects import parse_effect
from core.schemes import SCHEME_ARGS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scheme", choices=("scheme1", "scheme2", "scheme3"))
    for dest, (_, typ, text) in SCHEME_ARGS.items():
        parser.add_argument("--" + dest.replace("_", "-"), dest=dest, type=typ, help=text)
    parser.add_argument("--operator", help="who runs it (stored with the run)")
    parser.add_argument("--notes", default="", help="free text stored with the run")
    parser.add_argument("--config", metavar="FILE",
                        help="settings file (TOML/JSON, [daq] table; default $RIG_CONFIG); "
                             "its [emulate.emulator] effects are recorded for emulated runs")
    parser.add_argument("--db", metavar="URL", help="database URL (default $RIG_DB_URL or "
                                                    "./rig-data/rig.sqlite)")
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
    parser.add_argument("--json-progress", action="store_true",
                        help="progress as JSON lines on stdout (for a supervising service)")
    parser.add_argument("--control-stdin", action="store_true",
                        help="obey commands read from stdin: `stop` (make safe, abort), "
                             "`estop REASON`; end of input stops the run (its supervisor is gone)")


def scheme_params(args: argparse.Namespace, number: int) -> dict:
    """Scheme parameters given on the command line; refuses ones the scheme does not have."""
    from dataclasses import fields
    from core.schemes import SCHEMES
    known = {f.name for f in fields(SCHEMES[number])}
    out = {}
    for dest, (name, _, _) in SCHEME_ARGS.items():
        v = getattr(args, dest, None)
        if v is None:
            continue
        if name not in known:
            raise ValueError(f"--{dest.replace('_', '-')} does not apply to scheme {number}")
        out[name] = v
    return out


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
    """A progress bar and the key channels: one rewritten line on a terminal, one line per
    update otherwise (logs, pipes)."""

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
            self.stream.write("\r" + line[:160].ljust(160))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


class JsonProgress:
    """Progress as one JSON object per line: run id, plan time and duration [s], fraction,
    phase, sample counts and the key channels of LiveLine (SI units; NaN as null)."""

    def __init__(self, stream, run_id) -> None:
        self.stream = stream
        self.run_id = run_id
        """Callable returning the run id (None before the run is stored)."""

    def __call__(self, p) -> None:
        import json
        chans = {k: (float(p.latest[k]) if p.latest[k] == p.latest[k] else None)
                 for k, *_ in LiveLine.KEYS if k in p.latest}
        self.stream.write(json.dumps({
            "event": "progress", "run_id": self.run_id(), "t": p.t, "duration": p.duration,
            "fraction": p.fraction, "phase": p.phase or None, "n_samples": p.n_samples,
            "missed": p.missed, "channels": chans}) + "\n")
        self.stream.flush()

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
        words = (line or "stop").strip()
        if words == "stop":
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
    import sys

    from daq.engine import Engine
    from daq.plans import Plan
    from daq.rig import Rig
    from db.store import Store
    from core.config_file import read_config_file
    from daq.settings import Settings

    number = int(args.scheme[-1])
    try:
        params = scheme_params(args, number)
        plan = Plan.of(number, **params)
        settings = Settings.load(args.config)
        effects = parse_effects(args.effect) if args.effect else None
        import os
        cfg = args.config or os.environ.get("RIG_CONFIG")
        if effects is None and cfg:
            emu = read_config_file(cfg, section="emulate").get("emulator") or {}
            if isinstance(emu, dict) and emu.get("effects"):
                effects = dict(emu["effects"])
    except (ValueError, TypeError, KeyError) as exc:
        print(f"rig run: {exc}", file=sys.stderr)
        return 2
    source = args.source or ("emulator" if _is_loopback(settings.plc_host) else "rig")
    live = None if args.quiet else LiveLine(sys.stdout)
    if args.json_progress:
        live = JsonProgress(sys.stdout, lambda: engine.writer.run_id if engine.writer else None)
    store = Store(args.db)
    engine = Engine(Rig(settings), store, source=source, rig_name=args.rig_name,
                    operator=args.operator, effects=effects, notes=args.notes, progress=live,
                    reset_watchdog_fault=args.reset_watchdog)
    print(f"rig run: {plan.name} on the {source} ({settings.plc_host}:{settings.plc_port}), "
          f"{plan.duration:.1f} s of rig time, {plan.n_samples()} samples at "
          f"{plan.sample_rate_hz:g} Hz, database {store.url}", flush=True)
    try:
        outcome = asyncio.run(run_controlled(engine, plan, read_stdin=args.control_stdin))
        if outcome is None:
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        if live:
            live.close()
        rid = engine.writer.run_id if engine.writer else None
        print(f"rig run: run {rid} aborted by the operator; the rig was made safe",
              file=sys.stderr)
        return 1
    except Exception as exc:  # noqa: BLE001 - report the failure; the engine stored it
        if live:
            live.close()
        rid = engine.writer.run_id if engine.writer else None
        what = f"run {rid} failed" if rid is not None else "failed before the run started"
        print(f"rig run: {what}: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    finally:
        store.close()
    if live:
        live.close()
    print(f"rig run: run {outcome.run_id} ended {outcome.exit_status}"
          + (f" ({outcome.reason})" if outcome.reason else "")
          + f": {outcome.n_samples} samples, {outcome.missed} missed, "
            f"{outcome.interruptions} interruptions", flush=True)
    return 0 if outcome.exit_status == "success" else 1
