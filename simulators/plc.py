"""The PLC stand-in: an S7-1500 `MB_SERVER` look-alike on Modbus TCP, backed by the emulator.

- The register layout comes from core/plc_map.py (the same map the driver reads).
- A pymodbus 3.16 server holds one SimDevice (the current simulator API, not the deprecated
  datastore classes); its action hook refreshes the status block from the emulator on every
  read and applies the command block to the emulator on every write.
- `PlcProgram` is what the real PLC program does on its own, scanned every few ms: the
  service-heartbeat watchdog (no change for `watchdog_s`, default 0.5 s → ramp the
  dynamometer to zero, stop the drives, latch a fault bit), the e-stop latch and fault reset,
  and homing (core/plc_map.py's module doc): it turns the joint to u = 0 by setting the
  motors' speeds itself, as the real PLC commands the S120 drives, then zeroes the output
  encoder — the status block's `q` is the emulator's angle minus that zero.
- Malformed or over-long requests get Modbus exception responses (FC 3/4/23 counts are
  checked here: pymodbus would otherwise answer them with function code 0x80); the server
  never crashes on them.

Thread model: the emulator (LiveJoint) is shared with the drive stand-in and the pacing
thread; every call into it holds `lock`.
"""

from __future__ import annotations

import asyncio
import math
import struct
import threading
import time
from typing import Any, Callable

from pymodbus.constants import ExcCodes
from pymodbus.pdu import ExceptionResponse
from pymodbus.pdu.register_message import (ReadHoldingRegistersRequest,
                                           ReadWriteMultipleRegistersRequest)
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from core.params import N_MOTORS, REDUCTION
from core.plc_map import (HOME_GAIN, HOME_MOTOR_SPEED, HOME_TOLERANCE, MAX_READ_REGISTERS,
                          REGISTER_MAP, RegisterMap)

MODE_STARTUP, MODE_RUN, MODE_SAFE = 0, 1, 2
FAULT_NONE, FAULT_WATCHDOG, FAULT_ESTOP = 0, 1, 2

DYNO_SP_LIMIT = 200e3
"""Largest |dynamometer set point| the PLC accepts [N·m] (loading range 0–180 kN·m, Table 11);
beyond it a write is refused with ILLEGAL DATA VALUE."""


class PlcProgram:
    """The PLC program's logic between the command block, the emulator and the status block.

    `live` is a LiveJoint (simulators/live.py contract); `lock` guards every call into it.
    `stop_drives()` is the PLC's hard-wired OFF3 to the drives (called once per trip),
    `release_drives()` removes it after a fault reset.
    Times: the watchdog runs on the wall clock (it watches a communication link), the
    dynamometer ramp on rig time (it is physics)."""

    def __init__(self, live: Any, lock: threading.RLock, regmap: RegisterMap = REGISTER_MAP,
                 *, watchdog_s: float = 0.5, ramp_rate: float = 600e3,
                 p_max: float = 25e6, stop_drives: Callable[[], None] | None = None,
                 release_drives: Callable[[], None] | None = None,
                 on_event: Callable[[str], None] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.live = live
        self.lock = lock
        self.map = regmap
        self.watchdog_s = float(watchdog_s)
        if not 0.0 < self.watchdog_s <= 60.0:
            raise ValueError(f"PLC watchdog must be in (0, 60] s, got {watchdog_s!r}")
        self.ramp_rate = float(ramp_rate)
        """Dynamometer ramp-down rate in the safe state [N·m per second of rig time]."""
        self.p_max = float(p_max)
        self.stop_drives = stop_drives
        self.release_drives = release_drives
        self.on_event = on_event
        self.clock = clock
        self.commands: dict[str, float] = {s.name: 0.0 for s in regmap.command.signals}
        self.command_regs: list[int] = [0] * regmap.command.count
        self.mode = MODE_STARTUP
        self.fault_code = FAULT_NONE
        self.estop = False
        self.watchdog_fault = False
        self.drives_stopped = False
        self.life = 0
        self.heartbeat_seen: float | None = None
        self.last_heartbeat_change: float | None = None
        self.dyno_applied = 0.0
        self.pressure_applied = 0.0
        self.pump_on = False
        self.cooling_on = False
        self.valve_state = 0
        self._last_scan_t: float | None = None
        self._prev_reset = False
        self.homing = False
        self.homed = False
        self.encoder_zero = 0.0
        """Output encoder zero [rad of the emulator's angle], set by homing."""
        self._prev_home = False
        self._home_requested = False
        self.events: list[tuple[float, str]] = []
        """(wall time, text) of every trip and reset (also passed to `on_event`)."""

    # --- command block ------------------------------------------------------------------

    def validate_command(self, regs: list[int]) -> ExcCodes | None:
        """Refuse a command block that would carry nonsense: NaN/inf or out-of-range set
        points, an unknown valve command."""
        vals = self.map.command.decode(regs)
        dyno, p = vals["dyno_torque_sp"], vals["pressure_sp"]
        if not (math.isfinite(dyno) and math.isfinite(p)):
            return ExcCodes.ILLEGAL_VALUE
        if abs(dyno) > DYNO_SP_LIMIT or not 0.0 <= p <= self.p_max:
            return ExcCodes.ILLEGAL_VALUE
        if int(vals["valve_cmd"]) not in (0, 1, 2):
            return ExcCodes.ILLEGAL_VALUE
        return None

    def write_commands(self, regs: list[int]) -> None:
        """Accept a (validated) command block: note the heartbeat, latch the e-stop, handle
        the fault reset edge, apply set points."""
        now = self.clock()
        vals = self.map.command.decode(regs)
        hb = int(vals[self.map.heartbeat])
        if self.heartbeat_seen is None or hb != self.heartbeat_seen:
            self.heartbeat_seen = hb
            self.last_heartbeat_change = now
        self.command_regs = list(regs)
        self.commands = vals
        bits = int(vals["command_bits"])
        cb = self.map.signals["command_bits"]
        if bits & cb.bit("estop") and not self.estop:
            self._trip(FAULT_ESTOP, "service e-stop")
        reset = bool(bits & cb.bit("fault_reset"))
        if reset and not self._prev_reset:
            self._fault_reset(now)
        self._prev_reset = reset
        home = bool(bits & cb.bit("home"))
        if home and not self._prev_home:
            self._home_requested = True   # started by the next scan that finds the PLC running
            self._start_homing()
        elif not home:
            self._home_requested = False
            if self.homing:
                self._stop_homing("homing aborted: home request cleared")
        self._prev_home = home
        self.cooling_on = bool(bits & cb.bit("cooling_on"))
        self.valve_state = int(vals["valve_cmd"])
        self._apply_outputs()

    # --- the scan -----------------------------------------------------------------------

    def scan(self) -> None:
        """One PLC cycle: watchdog, mode, ramps, outputs to the emulator."""
        now = self.clock()
        self.life = (self.life + 1) & 0x7FFF
        if self.mode == MODE_STARTUP and self.last_heartbeat_change is not None \
                and self.fault_code == FAULT_NONE:
            self.mode = MODE_RUN
        if self.mode == MODE_RUN and self.last_heartbeat_change is not None \
                and not now - self.last_heartbeat_change <= self.watchdog_s:  # NaN trips
            self._trip(FAULT_WATCHDOG, f"service heartbeat unchanged for "
                                       f"{now - self.last_heartbeat_change:.3f} s")
        if self._home_requested and not self.homing:
            self._start_homing()
        if self.homing:
            self._home_step()
        self._apply_outputs()

    # --- homing -------------------------------------------------------------------------

    def _start_homing(self) -> None:
        """Start a requested homing once the PLC runs (a request made during start-up waits
        for it); refused in the safe state or with a fault latched."""
        if self.mode == MODE_STARTUP and self.fault_code == FAULT_NONE:
            return
        self._home_requested = False
        if self.mode != MODE_RUN or self.fault_code != FAULT_NONE:
            self._note("homing refused: the PLC is in its safe state or a fault is latched")
            return
        self.homing, self.homed = True, False
        self._note("homing started")

    def _stop_homing(self, why: str) -> None:
        """End homing without zeroing the encoder: the motors are told to stand still (a trip
        has already stopped the drives; their own ramps then take over)."""
        self.homing = False
        if self.mode == MODE_RUN:
            self._set_motor_speeds(0.0)
        self._note(why)

    def _set_motor_speeds(self, w: float) -> None:
        with self.lock:
            for k in range(N_MOTORS):
                self.live.set_motor_speed(k, w)

    def _home_step(self) -> None:
        """One scan of homing: a proportional position loop on the motor code disk's angle u
        (referred to the output); at |u| ≤ HOME_TOLERANCE stop and zero the output encoder."""
        if self.mode != MODE_RUN:
            self._stop_homing("homing aborted: the PLC made the rig safe")
            return
        with self.lock:
            r = self.live.read()
        u, q = r.get("u", math.nan), r.get("q", math.nan)
        if not (math.isfinite(u) and math.isfinite(q)):
            return  # a missing reading: wait for the next scan
        if abs(u) <= HOME_TOLERANCE:
            self._set_motor_speeds(0.0)
            self.encoder_zero = q
            self.homing, self.homed = False, True
            self._note(f"homed: u {u:.6f} rad, output encoder zeroed at {q:.6f} rad")
            return
        w = -REDUCTION * HOME_GAIN * u
        self._set_motor_speeds(max(-HOME_MOTOR_SPEED, min(HOME_MOTOR_SPEED, w)))

    def _trip(self, code: int, why: str) -> None:
        if code == FAULT_ESTOP:
            self.estop = True
        if code == FAULT_WATCHDOG:
            self.watchdog_fault = True
        if self.fault_code == FAULT_NONE:
            self.fault_code = code
        self.mode = MODE_SAFE
        if self.homing:
            self._stop_homing("homing aborted: the PLC made the rig safe")
        self._note(f"trip: {why}")
        if not self.drives_stopped:
            self.drives_stopped = True
            if self.stop_drives is not None:
                self.stop_drives()

    def _fault_reset(self, now: float) -> None:
        if self.mode != MODE_SAFE:
            return
        bits = int(self.commands["command_bits"])
        if bits & self.map.signals["command_bits"].bit("estop"):
            self._note("fault reset refused: e-stop still set")
            return
        if self.last_heartbeat_change is None or now - self.last_heartbeat_change > self.watchdog_s:
            self._note("fault reset refused: no live service heartbeat")
            return
        self.estop = self.watchdog_fault = self.drives_stopped = False
        self.fault_code = FAULT_NONE
        self.mode = MODE_RUN
        if self.release_drives is not None:
            self.release_drives()
        self._note("fault reset")

    def _note(self, text: str) -> None:
        self.events.append((time.time(), text))
        if self.on_event is not None:
            self.on_event(text)

    def _apply_outputs(self) -> None:
        """Set points to the emulator: applied in RUN; in SAFE/STARTUP the dynamometer ramps to
        zero (rig-time rate), the regulator goes to 0 Pa, and an e-stop stops the pump."""
        with self.lock:
            t = float(self.live.t)
            dt = 0.0 if self._last_scan_t is None else max(0.0, t - self._last_scan_t)
            self._last_scan_t = t
            bits = int(self.commands["command_bits"])
            cb = self.map.signals["command_bits"]
            if self.mode == MODE_RUN:
                self.dyno_applied = float(self.commands["dyno_torque_sp"])
                self.pressure_applied = float(self.commands["pressure_sp"])
                self.pump_on = bool(bits & cb.bit("pump_on"))
            else:
                step = self.ramp_rate * dt
                d = self.dyno_applied
                self.dyno_applied = 0.0 if abs(d) <= step else d - math.copysign(step, d)
                self.pressure_applied = 0.0
                self.pump_on = self.pump_on and not self.estop and bool(bits & cb.bit("pump_on"))
            self.live.set_dyno_torque(self.dyno_applied)
            self.live.set_pump(self.pump_on)
            self.live.set_pressure(self.pressure_applied)

    # --- status block -------------------------------------------------------------------

    def status_values(self) -> dict[str, float]:
        """Every status signal now: the emulator's sensors plus the program's state."""
        with self.lock:
            r = self.live.read()
            t = float(self.live.t)
        sb = self.map.signals["status_bits"]
        bits = 0
        for name, on in (("estop", self.estop), ("watchdog_fault", self.watchdog_fault),
                         ("safe_state", self.mode == MODE_SAFE), ("pump_running", self.pump_on),
                         ("cooling_on", self.cooling_on), ("drives_stopped", self.drives_stopped),
                         ("fault_latched", self.fault_code != FAULT_NONE),
                         ("homing", self.homing), ("homed", self.homed)):
            if on:
                bits |= sb.bit(name)
        out: dict[str, float] = {
            "plc_life": self.life,
            "heartbeat_echo": float(self.heartbeat_seen or 0),
            "plc_mode": self.mode,
            "fault_code": self.fault_code,
            "status_bits": bits,
            "pump_state": 1 if self.pump_on else 0,
            "valve_state": self.valve_state,
            "pressure_sp_applied": self.pressure_applied,
        }
        for s in self.map.status.signals:
            if s.channel is not None and s.name not in out:
                out[s.name] = t if s.channel == "t" else float(r.get(s.channel, math.nan))
        out["q"] -= self.encoder_zero
        return out

    def status_registers(self) -> list[int]:
        return self.map.status.encode(self.status_values())


# --- Modbus server ---------------------------------------------------------------------

class _StrictRead(ReadHoldingRegistersRequest):
    """FC 3 that answers a bad count or a truncated request with exception 03 (ILLEGAL DATA
    VALUE) under its own function code, as the Modbus spec asks."""

    _bad = False

    def decode(self, data: bytes) -> None:
        if len(data) < 4:
            self._bad, self.address, self.count = True, 0, 0
            return
        self.address, self.count = struct.unpack(">HH", data[:4])

    async def datastore_update(self, context, device_id):
        if self._bad or not 1 <= self.count <= MAX_READ_REGISTERS:
            return ExceptionResponse(self.function_code, ExcCodes.ILLEGAL_VALUE)
        return await super().datastore_update(context, device_id)


class _StrictReadInput(_StrictRead):
    function_code = 4


class _StrictReadWrite(ReadWriteMultipleRegistersRequest):
    """FC 23 with the same treatment (its datastore_update already checks the counts)."""

    _bad = False

    def decode(self, data: bytes) -> None:
        if len(data) < 9:
            self._bad = True
            self.read_count = self.write_count = self.write_byte_count = 0
            self.write_registers = []
            return
        (self.read_address, self.read_count, self.write_address, self.write_count,
         self.write_byte_count) = struct.unpack(">HHHHB", data[:9])
        self._payload_byte_count = len(data) - 9
        self.write_registers = [struct.unpack(">H", data[i:i + 2])[0]
                                for i in range(9, min(len(data), self.write_byte_count + 9) - 1, 2)]

    async def datastore_update(self, context, device_id):
        if self._bad:
            return ExceptionResponse(self.function_code, ExcCodes.ILLEGAL_VALUE)
        return await super().datastore_update(context, device_id)


STRICT_PDUS = [_StrictRead, _StrictReadInput, _StrictReadWrite]

_READ_FCS = (3, 4, 23)
_WRITE_FCS = (6, 16, 23)


ANY_UNIT_ID = 0
"""pymodbus' SimCore serves a request whose unit id has no device of its own from device 0:
the stand-in's one device has id 0, so it answers every unit id as MB_SERVER does
(core/plc_map.py, "Unit identifier")."""


def build_device(program: PlcProgram, device_id: int = ANY_UNIT_ID) -> SimDevice:
    """The SimDevice of the MB_SERVER DB: status block read-only, command block writable,
    everything else invalid (ILLEGAL DATA ADDRESS). Its action hook ties it to `program`.
    `device_id` ANY_UNIT_ID (the default) answers requests of every unit id."""
    m = program.map

    async def action(function_code: int, start_address: int, address: int, count: int,
                     registers: list[int], set_values: list[int] | list[bool] | None):
        if function_code not in _READ_FCS + _WRITE_FCS:
            return ExcCodes.ILLEGAL_FUNCTION  # coils / discrete inputs are not in this DB
        lo, hi = address, address + count
        if set_values is not None and function_code in _WRITE_FCS:
            c0 = m.command.start
            if lo < c0 or hi > c0 + m.command.count:
                return ExcCodes.ILLEGAL_ADDRESS
            regs = list(program.command_regs)
            regs[lo - c0:hi - c0] = [int(v) for v in set_values]
            if (exc := program.validate_command(regs)) is not None:
                return exc
            program.write_commands(regs)
            return None
        s0 = m.status.start
        if lo < s0 + m.status.count and hi > s0:
            o = s0 - start_address
            registers[o:o + m.status.count] = program.status_registers()
        return None

    return SimDevice(
        id=device_id,
        simdata=[
            SimData(m.status.start, count=m.status.count, values=0,
                    datatype=DataType.REGISTERS, readonly=True),
            SimData(m.command.start, count=m.command.count, values=0,
                    datatype=DataType.REGISTERS),
        ],
        action=action,
    )


class PlcServer:
    """The Modbus TCP server plus the PLC scan task, in the caller's asyncio loop."""

    def __init__(self, program: PlcProgram, host: str = "127.0.0.1", port: int = 5020,
                 *, scan_period: float = 0.005, device_id: int = ANY_UNIT_ID) -> None:
        self.program = program
        self.host = host
        self.port = port
        self.scan_period = scan_period
        self.device = build_device(program, device_id)
        self.server: ModbusTcpServer | None = None
        self._scan_task: asyncio.Task | None = None

    async def start(self) -> int:
        """Listen and start scanning; returns the bound port (useful with port 0)."""
        self.server = ModbusTcpServer(self.device, address=(self.host, self.port),
                                      custom_pdu=STRICT_PDUS)
        try:
            await self.server.serve_forever(background=True)
        except RuntimeError as exc:  # pymodbus' way of saying the bind failed
            raise OSError(f"PLC cannot listen on {self.host}:{self.port} "
                          f"(address in use or not local): {exc}") from None
        self.port = self.server.transport.sockets[0].getsockname()[1]
        self._scan_task = asyncio.create_task(self._scan_loop())
        return self.port

    async def _scan_loop(self) -> None:
        while True:
            try:
                self.program.scan()
            except Exception as exc:  # a PLC keeps scanning; the fault is logged
                self.program._note(f"scan error: {exc!r}")
            await asyncio.sleep(self.scan_period)

    async def stop(self) -> None:
        if self._scan_task is not None:
            self._scan_task.cancel()
            try:
                await self._scan_task
            except asyncio.CancelledError:
                pass
        if self.server is not None:
            await self.server.shutdown()
