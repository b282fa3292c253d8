"""The PLC register map: the single source of truth for the Modbus TCP interface between the
service (daq/plc.py) and the S7-1500 PLC — or its stand-in (simulators/plc.py).

Laid out as integrators lay out an S7-1500 `MB_SERVER` data block:

- one contiguous **status block** (PLC → service) read in one request (≤ 125 registers),
- a separate **command block** (service → PLC) written by the service (≤ 123 registers),
- a **watchdog/heartbeat counter** the service increments in the command block; the PLC
  program makes the rig safe when it stops changing, and echoes it in the status block.

Every signal has its address (0-based holding register), type (INT = 16-bit signed,
WORD = 16-bit bit field, DINT = 32-bit signed, REAL = IEEE-754 float32), scale (SI value =
raw value × scale), SI unit, word order of 32-bit values (S7: big-endian, high word first;
configurable per signal for other PLCs) and whether it is a status or a command.
A run-format channel name (core.channels) is given where a signal is one.

Missing sensor values: a REAL carries NaN; an INT/DINT carries its type's minimum
(-32768 / -2147483648), decoded back to NaN.

Homing, the paper's first step of scheme 1: "turn the joint angle to 0° according to
the motor code disk, and set the output encoder angle to zero". A rising edge of the `home`
command bit, while the PLC is running with no fault latched, starts it: `homing` is set and
`homed` cleared; the PLC turns the joint (through the drives) until the motor-side angle `u`
(the motor code disk referred to the output) is within HOME_TOLERANCE of 0, at most at
HOME_MOTOR_SPEED, then stops the motors, zeroes the output encoder (`q` reads 0 there from
then on), clears `homing` and sets `homed`. Homing runs only while the service holds `home`
set: clearing it, a trip or the heartbeat watchdog aborts it (`homed` stays clear).

Exceptions and unit identifier (what the stand-in in simulators/plc.py does, as MB_SERVER):

- A request for a register outside the status and command blocks is answered with Modbus
  exception 02 ILLEGAL DATA ADDRESS; a write into the status block likewise (it is read-only);
  a bad count with 03 ILLEGAL DATA VALUE; coils and discrete inputs (not in this DB) with
  01 ILLEGAL FUNCTION. Never silence, never a logged traceback.
- Unit identifier: MB_SERVER does not evaluate the MBAP unit id — it serves its data block to a
  request carrying any unit id (0–255) and echoes that id in the response. Siemens' MB_SERVER
  description lists no unit-id parameter for the server (only MB_CLIENT has `MB_UNIT_ID`), and
  integrators' notes on S7 Modbus quirks record that "MB_SERVER does not filter the unit ID,
  accepts any value". The stand-in does the same, so a client configured with another unit id
  (daq.settings `plc_device_id`) gets answers, not a timeout. Behind a gateway the unit id
  would select a serial device; on the S7-1500's own port it selects nothing.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field, replace
from typing import Iterable, Literal, Mapping

from core.channels import CHANNELS
from core.params import JointParams

MAX_READ_REGISTERS = 125
"""Modbus limit for one read holding/input registers request (FC 3/4)."""
MAX_WRITE_REGISTERS = 123
"""Modbus limit for one write multiple registers request (FC 16)."""

DType = Literal["INT", "WORD", "DINT", "REAL"]
WordOrder = Literal["big", "little"]

_WIDTH = {"INT": 1, "WORD": 1, "DINT": 2, "REAL": 2}
_INT_MISSING = -32768
_DINT_MISSING = -2147483648


@dataclass(frozen=True)
class Signal:
    """One PLC variable in the MB_SERVER DB."""

    name: str
    address: int
    """First holding register (0-based, as on the wire)."""
    dtype: DType
    scale: float
    """SI value = raw value × scale (raw is the integer or the REAL as stored)."""
    unit: str
    """SI unit of the scaled value ('' for counters, states and bit fields)."""
    access: Literal["status", "command"]
    doc: str
    channel: str | None = None
    """Run-format channel this signal feeds, if any (core.channels)."""
    word_order: WordOrder = "big"
    """Register order of 32-bit values: 'big' = high word first (S7), 'little' = low first."""
    bits: tuple[str, ...] = ()
    """Names of the bits of a WORD, bit 0 first."""

    @property
    def width(self) -> int:
        """Number of 16-bit registers."""
        return _WIDTH[self.dtype]

    def encode(self, value: float) -> list[int]:
        """SI value → registers (NaN encodes as the type's 'missing' value)."""
        if self.dtype == "REAL":
            raw = struct.pack(">f", float(value) / self.scale)
            regs = [int.from_bytes(raw[0:2], "big"), int.from_bytes(raw[2:4], "big")]
            return regs if self.word_order == "big" else regs[::-1]
        if self.dtype == "WORD":
            return [int(value) & 0xFFFF]
        if value is None or (isinstance(value, float) and math.isnan(value)):
            ival = _INT_MISSING if self.dtype == "INT" else _DINT_MISSING
        else:
            ival = int(round(float(value) / self.scale))
            lo, hi = ((-32767, 32767) if self.dtype == "INT" else (-2147483647, 2147483647))
            ival = min(max(ival, lo), hi)  # saturate like a PLC conversion, never wrap
        if self.dtype == "INT":
            return [ival & 0xFFFF]
        u = ival & 0xFFFFFFFF
        regs = [u >> 16, u & 0xFFFF]
        return regs if self.word_order == "big" else regs[::-1]

    def decode(self, regs: list[int] | tuple[int, ...]) -> float:
        """Registers (exactly `width` of them) → SI value (NaN for 'missing')."""
        if self.dtype == "WORD":
            return float(regs[0] & 0xFFFF)
        if self.dtype == "INT":
            v = regs[0] - 0x10000 if regs[0] & 0x8000 else regs[0]
            return math.nan if v == _INT_MISSING else v * self.scale
        hi, lo = (regs[0], regs[1]) if self.word_order == "big" else (regs[1], regs[0])
        if self.dtype == "REAL":
            return struct.unpack(">f", struct.pack(">HH", hi, lo))[0] * self.scale
        u = (hi << 16) | lo
        v = u - 0x100000000 if u & 0x80000000 else u
        return math.nan if v == _DINT_MISSING else v * self.scale

    def bit(self, name: str) -> int:
        """Mask of a named bit of a WORD signal."""
        return 1 << self.bits.index(name)


@dataclass(frozen=True)
class Block:
    """A contiguous run of signals, read or written in one request."""

    name: str
    start: int
    count: int
    signals: tuple[Signal, ...]

    def decode(self, regs: list[int] | tuple[int, ...]) -> dict[str, float]:
        """All signals of the block from its registers (len == count)."""
        if len(regs) != self.count:
            raise ValueError(f"block {self.name!r} has {self.count} registers, got {len(regs)}")
        out = {}
        for s in self.signals:
            o = s.address - self.start
            out[s.name] = s.decode(regs[o:o + s.width])
        return out

    def encode(self, values: Mapping[str, float], base: list[int] | None = None) -> list[int]:
        """Registers of the whole block from {signal: SI value}; signals not given keep
        `base`'s registers (zeros when no base)."""
        regs = list(base) if base is not None else [0] * self.count
        names = {s.name: s for s in self.signals}
        for name, value in values.items():
            if name not in names:
                raise KeyError(f"block {self.name!r} has no signal {name!r}; it has {sorted(names)}")
            s = names[name]
            o = s.address - self.start
            regs[o:o + s.width] = s.encode(value)
        return regs


@dataclass(frozen=True)
class RegisterMap:
    """The whole map: a status block and a command block."""

    status: Block
    command: Block
    heartbeat: str = "service_heartbeat"
    """Command-block counter the service increments; the PLC's watchdog watches it."""
    signals: dict[str, Signal] = field(init=False)

    def __post_init__(self) -> None:
        sig = {}
        for s in self.status.signals + self.command.signals:
            if s.name in sig:
                raise ValueError(f"signal name {s.name!r} used twice")
            sig[s.name] = s
        object.__setattr__(self, "signals", sig)
        _check_block(self.status, "status", MAX_READ_REGISTERS)
        _check_block(self.command, "command", MAX_WRITE_REGISTERS)
        if self.heartbeat not in {s.name for s in self.command.signals}:
            raise ValueError(f"heartbeat signal {self.heartbeat!r} is not in the command block")
        lo = max(self.status.start, self.command.start)
        hi = min(self.status.start + self.status.count, self.command.start + self.command.count)
        if lo < hi:
            raise ValueError("status and command blocks overlap")

    def with_word_order(self, order: WordOrder, names: Iterable[str] | None = None) -> "RegisterMap":
        """A copy with the word order of the named 32-bit signals (all when None) changed —
        for PLCs that store 32-bit values low word first."""
        chosen = set(self.signals) if names is None else set(names)

        def fix(b: Block) -> Block:
            return replace(b, signals=tuple(
                replace(s, word_order=order) if s.name in chosen and s.width == 2 else s
                for s in b.signals))
        return RegisterMap(fix(self.status), fix(self.command), self.heartbeat)

    def describe(self) -> list[dict]:
        """Every signal with address, type, scale, unit, word order and access (for docs)."""
        return [{"name": s.name, "address": s.address, "type": s.dtype, "registers": s.width,
                 "scale": s.scale, "unit": s.unit, "word_order": s.word_order,
                 "access": s.access, "channel": s.channel, "doc": s.doc,
                 "bits": list(s.bits)} for s in self.signals.values()]


def _check_block(block: Block, access: str, limit: int) -> None:
    addr = block.start
    for s in block.signals:
        if s.access != access:
            raise ValueError(f"signal {s.name!r} in the {access} block is a {s.access}")
        if s.address != addr:
            raise ValueError(f"{access} block not contiguous at {s.name!r}: "
                             f"address {s.address}, expected {addr}")
        if s.channel is not None and s.channel not in CHANNELS:
            raise ValueError(f"signal {s.name!r}: unknown channel {s.channel!r}")
        if (s.dtype == "WORD") != bool(s.bits):
            raise ValueError(f"signal {s.name!r}: bits are for WORD signals only")
        addr += s.width
    if addr - block.start != block.count:
        raise ValueError(f"{access} block count {block.count} != {addr - block.start}")
    if block.count > limit:
        raise ValueError(f"{access} block has {block.count} registers > Modbus limit {limit}")


def _layout(name: str, start: int, access: str, rows: list[tuple]) -> Block:
    """Assign consecutive addresses to rows (name, dtype, scale, unit, doc, channel[, bits])."""
    sigs, addr = [], start
    for row in rows:
        nm, dt, sc, un, doc, ch = row[:6]
        bits = row[6] if len(row) > 6 else ()
        s = Signal(nm, addr, dt, sc, un, access, doc, ch, "big", bits)  # type: ignore[arg-type]
        sigs.append(s)
        addr += s.width
    return Block(name, start, addr - start, tuple(sigs))


# --- the map -----------------------------------------------------------------------------

STATUS_BITS = ("estop", "watchdog_fault", "safe_state", "pump_running", "cooling_on",
               "drives_stopped", "fault_latched", "homing", "homed")
"""Bits of `status_bits`: e-stop latched (operator or service e-stop), service heartbeat
watchdog tripped, PLC in its safe state, pump motor running, cooling on, PLC has stopped the
drives (hard-wired OFF3), a fault is latched (cleared by `fault_reset` once its cause is
gone and the heartbeat is alive), homing in progress, homed (the output encoder was zeroed
at 0° since the PLC started; cleared when a new homing starts)."""

COMMAND_BITS = ("pump_on", "cooling_on", "estop", "fault_reset", "run", "home")
"""Bits of `command_bits`: pump motor on, cooling on, service e-stop (latches in the PLC),
fault reset (rising edge), run request (dynamometer and pressure set points are applied only
while `run` is set and no fault is latched), home request (homing, in the module doc)."""



FAULT_CODES = {0: "none", 1: "service heartbeat watchdog", 2: "e-stop"}
"""Values of `fault_code` (the first latched fault)."""

PLC_MODES = {0: "startup", 1: "ready", 2: "run", 3: "safe"}
"""Values of `plc_mode`."""

PUMP_STATES = {0: "off", 1: "running"}
VALVE_STATES = {0: "locked (centre, hydraulic lock)", 1: "extend", 2: "retract"}

DEG = math.pi / 180.0
ENCODER_COUNT = JointParams().enc_res
"""Output encoder count [rad] (the joint's encoder resolution, core.params: 0.01°, Table 10)."""

HOME_TOLERANCE = ENCODER_COUNT
"""Homing ends when |u| is within this [rad] (one output encoder count, 0.01°)."""
HOME_MOTOR_SPEED = 3000.0 * 2.0 * math.pi / 60.0
"""Fastest motor speed while homing [rad/s at the motor shaft] (3000 r/min, the schemes'
highest: 180° of output travel in about 110 s)."""
HOME_GAIN = 2.0
"""Homing position-loop gain [1/s]: motor speed = −N·HOME_GAIN·u, clipped to HOME_MOTOR_SPEED
(the last degree takes about 2 s)."""

STATUS_BLOCK = _layout("status", 0, "status", [
    ("plc_life", "INT", 1.0, "", "PLC life counter, +1 per PLC scan (wraps at 32767)", None),
    ("heartbeat_echo", "INT", 1.0, "", "last service heartbeat value the PLC saw", None),
    ("plc_mode", "INT", 1.0, "", f"PLC mode {PLC_MODES}", None),
    ("fault_code", "INT", 1.0, "", f"first latched fault {FAULT_CODES}", None),
    ("status_bits", "WORD", 1.0, "", "e-stop, interlock and state bits", None, STATUS_BITS),
    ("pump_state", "INT", 1.0, "", f"hydraulic pump motor {PUMP_STATES}", None),
    ("valve_state", "INT", 1.0, "", f"Y-type reversing valve {VALVE_STATES}", None),
    ("rig_time", "DINT", 1e-3, "s", "rig time of this snapshot [ms] (PLC acquisition clock)",
     "t"),
    ("q", "DINT", ENCODER_COUNT, "rad",
     "output encoder, counts of 0.01° (0 at the homed position once homed)", "q"),
    ("qd", "REAL", 1.0, "rad/s", "output joint velocity", "qd"),
    ("u", "REAL", 1.0, "rad", "motor angle referred to the output", "u"),
    ("ud", "REAL", 1.0, "rad/s", "motor velocity referred to the output", "ud"),
    ("torsion", "REAL", DEG, "rad", "displacement sensors: joint twist q − u [°]", "torsion"),
    ("torque", "REAL", 1e3, "N·m", "strain-gauge joint torque [kN·m]", "torque"),
    ("torque_load", "REAL", 1e3, "N·m", "dynamometer torque feedback [kN·m]", "torque_load"),
    ("torque_cmd", "REAL", 1e3, "N·m", "dynamometer set point applied by the PLC [kN·m]",
     "torque_cmd"),
    ("m_bend", "REAL", 1e3, "N·m", "bending moment [kN·m]", "m_bend"),
    ("f_shear", "REAL", 1e3, "N", "shear force [kN]", "f_shear"),
    ("p_hyd", "REAL", 1e5, "Pa", "pressure transmitter [bar]", "p_hyd"),
    ("pressure_sp_applied", "REAL", 1e5, "Pa",
     "proportional pressure regulator set point applied by the PLC [bar]", None),
    ("temp_joint", "REAL", 1.0, "°C", "gearbox / joint temperature", "temp_joint"),
])

COMMAND_BLOCK = _layout("command", 100, "command", [
    ("service_heartbeat", "INT", 1.0, "", "service watchdog counter, changed every write", None),
    ("command_bits", "WORD", 1.0, "", "pump, cooling, e-stop, fault reset, run, home", None,
     COMMAND_BITS),
    ("valve_cmd", "INT", 1.0, "", f"Y-type reversing valve command {VALVE_STATES}", None),
    ("dyno_torque_sp", "REAL", 1e3, "N·m", "dynamometer torque set point [kN·m]", None),
    ("pressure_sp", "REAL", 1e5, "Pa", "proportional pressure regulator set point [bar]", None),
])

REGISTER_MAP = RegisterMap(STATUS_BLOCK, COMMAND_BLOCK)
"""The rig's register map (S7-1500 MB_SERVER layout, REAL big-endian high word first)."""
