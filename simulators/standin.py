"""The whole rig stand-in as one process (`rig emulate`): the emulator (simulators.live) paced
in real or scaled time, the PLC stand-in on Modbus TCP and the three drive stand-ins on CAN
behind a socketcand-protocol server — all on loopback by default.

    rig emulate                                   # PLC on 127.0.0.1:5020, CAN on :29536
    rig emulate --plc-port 0 --can-port 0         # free ports, printed on start
    rig emulate --effect stribeck --effect torque_offset:c0=500 --time-scale 2
    rig emulate --config rig.toml                 # [emulate] table (and [emulate.emulator])
    rig emulate --control-stdin                   # then type `silence-drive 2` (fault injection)

It prints where it listens and stops cleanly on Ctrl-C / SIGTERM. The DAQ side reaches it with
daq.settings.Settings (its defaults match these ports).

Control (`--control-stdin`, for fault benches and tests): one command a line on stdin, each
answered by a line `rig emulate: control: ...` on stdout —
    silence-drive N   drive node N dies (simulators.drives.DriveNode.silence: heartbeat, TPDOs,
                      SDO/NMT answers stop; its motor gives no torque); the rest runs on.
Off by default: a stand-in started in the background of a shell must not read the terminal.
The stand-in also prints each drive's entry into QUICK STOP ACTIVE or FAULT and each PLC trip,
so a caller sees from the plant's side when the rig was stopped.

Pacing: one thread advances the emulator by its step dt (1 ms of rig time) until rig time
catches up with wall time × time_scale, running the drives' 1 ms step (state machines, TPDOs)
after each emulator step; the PLC scan and Modbus server run in the asyncio loop.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any

DEFAULT_PLC_PORT = 5020
DEFAULT_CAN_PORT = 29536


@dataclass
class StandInOptions:
    """What `rig emulate` runs (ports 0 = pick free ports)."""

    plc_host: str = "127.0.0.1"
    plc_port: int = DEFAULT_PLC_PORT
    can_host: str = "127.0.0.1"
    can_port: int = DEFAULT_CAN_PORT
    can_channel: str = "can0"
    node_ids: tuple[int, ...] = (1, 2, 3)
    plc: bool = True
    can: bool = True
    time_scale: float = 1.0
    """Rig seconds per wall second."""
    watchdog_s: float = 0.5
    """PLC watchdog on the service heartbeat [s]."""
    word_order: str = "big"
    """Word order of the PLC's 32-bit values ('big' = S7)."""
    control_stdin: bool = False
    """Read control commands (`silence-drive N`) from stdin, one a line."""
    emulator: dict[str, Any] = field(default_factory=dict)
    """EmulatorConfig fields: effects, hysteresis, seed, dropout, temp_motor_init,
    temp_joint_init, failed_motors (motor numbers 1–3), params {JointParams field: value}."""

    def __post_init__(self) -> None:
        if not self.time_scale > 0:
            raise ValueError("time_scale must be positive")
        if not (self.plc or self.can):
            raise ValueError("nothing to run: both the PLC and the CAN side are off")
        if self.can and len(self.node_ids) != 3:
            raise ValueError("the rig has three drives: give three node ids")


def emulator_config(spec: dict[str, Any]):
    """EmulatorConfig from the options' `emulator` table (motor numbers 1–3 → indices)."""
    from core.params import JointParams
    from simulators.config import EmulatorConfig
    spec = dict(spec)
    params = JointParams().replace(**{k: float(v) for k, v in spec.pop("params", {}).items()})
    failed = spec.pop("failed_motors", [])
    if isinstance(failed, dict):
        failed = {int(m) - 1: float(t) for m, t in failed.items()}
    else:
        failed = [int(m) - 1 for m in failed]
    temps = spec.pop("temp_motor_init", None)
    return EmulatorConfig(params=params, failed_motors=failed,
                          temp_motor_init=tuple(temps) if temps else None, **spec)


class StandIn:
    """The stand-in's parts and their life cycle. `live` may be given (tests); by default a
    simulators.live.LiveJoint is built from the options' emulator table."""

    def __init__(self, options: StandInOptions, live: Any = None) -> None:
        import threading
        self.options = options
        self.config = None
        if live is None:
            from simulators.live import LiveJoint
            self.config = emulator_config(options.emulator)
            live = LiveJoint(self.config)
        self.live = live
        self.lock = threading.RLock()
        self.stop_event = threading.Event()
        self.can_server = None
        self.drives = None
        self.plc_server = None
        self.plc_port: int | None = None
        self.can_port: int | None = None
        self.error: BaseException | None = None
        """What stopped the pacing thread, if anything did."""
        self.steps = 0
        self.max_lag = 0.0
        """Largest lag of rig time behind the wall-clock schedule [s of rig time]."""
        self._pacer: threading.Thread | None = None

    def start_can(self) -> None:
        from simulators.drives import DriveStandIn
        from simulators.socketcand_server import SocketcandServer
        o = self.options
        self.can_server = SocketcandServer(o.can_host, o.can_port, o.can_channel)
        self.can_port = self.can_server.start()
        self.drives = DriveStandIn(self.can_server.local_bus(), self.live, self.lock, o.node_ids,
                                   on_event=lambda text: print(f"rig emulate: {text}", flush=True))
        self.drives.boot()

    async def start_plc(self) -> None:
        from core.plc_map import REGISTER_MAP
        from simulators.plc import PlcProgram, PlcServer
        o = self.options
        regmap = REGISTER_MAP if o.word_order == "big" else REGISTER_MAP.with_word_order(o.word_order)
        p_max = self.config.params.p_max if self.config is not None else 25e6
        program = PlcProgram(self.live, self.lock, regmap, watchdog_s=o.watchdog_s, p_max=p_max,
                             stop_drives=self.drives.stop_all if self.drives else None,
                             release_drives=self.drives.release_all if self.drives else None,
                             on_event=lambda text: print(f"rig emulate: PLC {text}", flush=True))
        self.plc_server = PlcServer(program, o.plc_host, o.plc_port)
        self.plc_port = await self.plc_server.start()

    def control(self, line: str) -> str:
        """Carry out one control command (module doc); returns the answer (one line)."""
        words = line.split()
        if not words:
            return "empty command"
        if words[0] == "silence-drive" and len(words) == 2:
            if self.drives is None:
                return "error: no drives (the CAN side is off)"
            try:
                node = self.drives.silence(int(words[1]))
            except (KeyError, ValueError) as exc:
                return f"error: {exc}"
            return (f"drive {node.node_id} (motor {node.k + 1}) silenced: off the bus, "
                    f"motor without torque")
        return f"error: unknown command {line.strip()!r} (known: silence-drive N)"

    def start_control(self) -> None:
        """Read control commands from stdin on a daemon thread (end of input: no more)."""
        import sys
        import threading

        def read() -> None:
            for line in sys.stdin:
                if self.stop_event.is_set():
                    return
                if line.strip():
                    print(f"rig emulate: control: {self.control(line)}", flush=True)
        threading.Thread(target=read, name="standin-control", daemon=True).start()

    def start_pacing(self) -> None:
        import threading
        self._pacer = threading.Thread(target=self._pace, name="emulator-pacing", daemon=True)
        self._pacer.start()

    def _pace(self) -> None:
        """Pace the emulator; an error stops the whole stand-in loudly (a stand-in whose time
        silently stood still would be worse than none)."""
        import sys
        import traceback
        try:
            self._pace_loop()
        except BaseException as exc:  # noqa: BLE001
            self.error = exc
            traceback.print_exc(file=sys.stderr)
            self.stop_event.set()

    def _pace_loop(self) -> None:
        import time
        dt = float(self.live.dt)
        scale = self.options.time_scale
        wall0 = time.monotonic()
        t0 = float(self.live.t)
        drives = self.drives
        while not self.stop_event.is_set():
            target = t0 + (time.monotonic() - wall0) * scale
            burst = 0
            while float(self.live.t) + 0.5 * dt <= target and burst < 200:
                with self.lock:
                    self.live.advance(dt)
                    if drives is not None:
                        drives.step()
                self.steps += 1
                burst += 1
            lag = target - float(self.live.t)
            if lag > self.max_lag:
                self.max_lag = lag
            if burst < 200:
                time.sleep(min(0.001, dt / scale))

    def listening(self) -> list[str]:
        o = self.options
        lines = []
        if self.plc_port is not None:
            lines.append(f"PLC (Modbus TCP, S7-1500 MB_SERVER map) listening on "
                         f"{o.plc_host}:{self.plc_port}")
        if self.can_port is not None:
            lines.append(f"CAN (socketcand, channel {o.can_channel}) listening on "
                         f"{o.can_host}:{self.can_port}; drives at node ids "
                         f"{','.join(str(n) for n in o.node_ids)}")
        lines.append(f"time scale {o.time_scale:g} rig s per wall s; Ctrl-C stops")
        return lines

    def warm_up(self) -> None:
        """Run every emulator entry point once before anything listens (the first calls load
        compiled kernels, ~0.5 s, which must not stall the first Modbus answer): one step of
        rig time, a sensor read, a motor read."""
        with self.lock:
            self.live.advance(float(self.live.dt))
            self.live.read()
            self.live.motor(0)

    async def serve(self) -> None:
        """Run until stop_event is set (signal handlers set it in `run`)."""
        import asyncio
        try:
            self.warm_up()
            if self.options.can:
                self.start_can()
            if self.options.plc:
                await self.start_plc()
            self.start_pacing()
            for line in self.listening():
                print(f"rig emulate: {line}", flush=True)
            if self.options.control_stdin:
                self.start_control()
            while not self.stop_event.is_set():
                await asyncio.sleep(0.05)
        finally:
            await self.close()

    async def close(self) -> None:
        self.stop_event.set()
        if self._pacer is not None:
            self._pacer.join(timeout=2.0)
        if self.plc_server is not None:
            await self.plc_server.stop()
        if self.drives is not None:
            self.drives.close()
        if self.can_server is not None:
            self.can_server.stop()


# --- the `rig emulate` command --------------------------------------------------------------

def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", metavar="FILE",
                        help="TOML/JSON file with an [emulate] table (same keys as the options, "
                             "plus an [emulate.emulator] table: effects, seed, params, ...); "
                             "options given on the command line win")
    parser.add_argument("--plc-host", help="PLC listen address (default 127.0.0.1)")
    parser.add_argument("--plc-port", type=int, help=f"PLC port (default {DEFAULT_PLC_PORT}; 0 = free)")
    parser.add_argument("--can-host", help="socketcand listen address (default 127.0.0.1)")
    parser.add_argument("--can-port", type=int, help=f"socketcand port (default {DEFAULT_CAN_PORT}; 0 = free)")
    parser.add_argument("--can-channel", help="CAN channel name served (default can0)")
    parser.add_argument("--node-ids", help="drive node ids, motor 1 first (default 1,2,3)")
    parser.add_argument("--no-plc", action="store_true", help="run the CAN side only")
    parser.add_argument("--no-can", action="store_true", help="run the PLC side only")
    parser.add_argument("--time-scale", type=float, help="rig seconds per wall second (default 1)")
    parser.add_argument("--watchdog", type=float, help="PLC watchdog on the service heartbeat [s] (default 0.5)")
    parser.add_argument("--control-stdin", action="store_true",
                        help="read control commands from stdin, one a line: "
                             "`silence-drive N` kills drive node N (fault injection)")
    parser.add_argument("--word-order", choices=("big", "little"), help="PLC 32-bit word order (default big, as S7)")
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[:k=v,...]",
                        help="inject an effect from the vocabulary (`rig params` lists them), "
                             "e.g. --effect stribeck:f_s=1200; repeatable")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help="override a JointParams value (SI), repeatable")
    parser.add_argument("--seed", type=int, help="emulator random seed")
    parser.add_argument("--no-hysteresis", action="store_true", help="purely elastic transmission")
    parser.add_argument("--dropout", type=float, help="sensor dropout probability per sample")
    parser.add_argument("--fail-motor", action="append", type=int, default=[], metavar="M",
                        help="motor 1–3 failed from the start; repeatable")
    parser.add_argument("--temp-motor", metavar="T1,T2,T3", help="initial motor temperatures [°C]")


def options_from_args(args: argparse.Namespace) -> StandInOptions:
    """Options: defaults ← config file [emulate] table ← command line."""
    data: dict[str, Any] = {}
    if args.config:
        from core.config_file import read_config_file
        data = read_config_file(args.config, section="emulate")
    emu = dict(data.pop("emulator", {}) or {})
    if "node_ids" in data and isinstance(data["node_ids"], str):
        data["node_ids"] = [int(x) for x in data["node_ids"].split(",")]
    for key in ("plc_host", "plc_port", "can_host", "can_port", "can_channel", "time_scale",
                "word_order"):
        v = getattr(args, key)
        if v is not None:
            data[key] = v
    if args.watchdog is not None:
        data["watchdog_s"] = args.watchdog
    if args.node_ids:
        data["node_ids"] = [int(x) for x in args.node_ids.split(",")]
    if "node_ids" in data:
        data["node_ids"] = tuple(int(x) for x in data["node_ids"])
    if args.no_plc:
        data["plc"] = False
    if args.no_can:
        data["can"] = False
    if getattr(args, "control_stdin", False):
        data["control_stdin"] = True
    effects = dict(emu.get("effects", {}) or {})
    from core.effects import parse_effect
    for spec in args.effect:
        name, kv = parse_effect(spec)
        effects[name] = kv
    if effects:
        emu["effects"] = effects
    params = dict(emu.get("params", {}) or {})
    for item in args.param:
        k, _, v = item.partition("=")
        params[k.strip()] = float(v)
    if params:
        emu["params"] = params
    if args.seed is not None:
        emu["seed"] = args.seed
    if args.no_hysteresis:
        emu["hysteresis"] = False
    if args.dropout is not None:
        emu["dropout"] = args.dropout
    if args.fail_motor:
        emu["failed_motors"] = list(args.fail_motor)
    if args.temp_motor:
        emu["temp_motor_init"] = [float(x) for x in args.temp_motor.split(",")]
    known = set(StandInOptions.__dataclass_fields__)
    unknown = set(data) - known
    if unknown:
        raise ValueError(f"unknown [emulate] keys {sorted(unknown)}; known: {sorted(known)}")
    return StandInOptions(emulator=emu, **data)


def run(args: argparse.Namespace, live: Any = None) -> int:
    """`rig emulate`: build, print where it listens, serve until Ctrl-C / SIGTERM."""
    import asyncio
    import signal
    import sys
    try:
        options = options_from_args(args)
        standin = StandIn(options, live=live)
    except (ValueError, TypeError, KeyError) as exc:
        print(f"rig emulate: {exc}", file=sys.stderr)
        return 2

    async def main() -> None:
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, standin.stop_event.set)
        await standin.serve()

    try:
        asyncio.run(main())
    except OSError as exc:  # e.g. port in use
        print(f"rig emulate: {exc}", file=sys.stderr)
        return 1
    print(f"rig emulate: stopped after {standin.live.t:.3f} s of rig time "
          f"(largest lag behind the schedule {standin.max_lag:.3f} s)", flush=True)
    if standin.error is not None:
        print(f"rig emulate: the emulator stopped on an error: {standin.error!r}", file=sys.stderr)
        return 1
    return 0


def main(argv: list[str] | None = None, live: Any = None) -> int:
    """Entry point without the `rig` wrapper (`python -m simulators.standin`); logging as
    `rig` configures it (env RIG_LOG_LEVEL, RIG_LOG_FORMAT: core/logging_setup.py)."""
    from core.logging_setup import configure_logging
    configure_logging()
    parser = argparse.ArgumentParser(prog="rig emulate")
    add_arguments(parser)
    return run(parser.parse_args(argv), live=live)


if __name__ == "__main__":
    raise SystemExit(main())
