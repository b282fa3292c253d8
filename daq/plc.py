"""The PLC driver: an async pymodbus client for the S7-1500's MB_SERVER (or its stand-in).

- Bounded behaviour, never pymodbus' defaults: timeout 0.5–1 s, retries 0–1, reconnect
  back-off capped at 1–5 s (daq.settings validates them). The client reconnects by itself;
  while the link is down calls fail fast with `PlcLinkError`. Every request is also bounded
  here (`request_bound`), so a library that never answers cannot stall a caller.
- The Modbus request limits are enforced here (the client would send over-long writes):
  reads are split into requests of ≤ 125 registers, writes into ≤ 123.
- Decoding and scaling come from core/plc_map.py; the status block is read in one request.
- `heartbeat_loop` changes the watchdog counter every `heartbeat_period`; the PLC makes the
  rig safe when it stops changing.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Mapping

from pymodbus.client import AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException

from core.plc_map import MAX_READ_REGISTERS, MAX_WRITE_REGISTERS, REGISTER_MAP, RegisterMap
from daq.settings import Settings

log = logging.getLogger(__name__)


class PlcError(Exception):
    """The PLC answered with a Modbus exception (the link is fine)."""

    def __init__(self, what: str, exception_code: int | None = None) -> None:
        super().__init__(what)
        self.exception_code = exception_code


class PlcLinkError(Exception):
    """No answer: not connected, connection lost or timed out."""


def register_map_for(settings: Settings, base: RegisterMap = REGISTER_MAP) -> RegisterMap:
    """The register map with the word order the settings name for 32-bit values."""
    return base if settings.plc_word_order == "big" else base.with_word_order(settings.plc_word_order)


class PlcClient:
    """Async Modbus TCP client of the PLC's register map."""

    def __init__(self, settings: Settings, regmap: RegisterMap | None = None) -> None:
        self.settings = settings
        self.map = regmap or register_map_for(settings)
        self.device_id = settings.plc_device_id
        self.client: AsyncModbusTcpClient | None = None
        """The pymodbus client, made in connect() (it needs the running event loop)."""
        self.command_regs: list[int] = [0] * self.map.command.count
        """Shadow of the command block (what this client last wrote or read back)."""
        self.heartbeat = 0
        self.last_beat: float | None = None
        """time.monotonic() when the PLC last acknowledged a heartbeat change."""
        self.max_beat_gap = 0.0
        """Longest time [s] between two acknowledged heartbeat changes: near the period when the
        service keeps up; near the PLC's watchdog time (0.5 s) when the service was starved (a
        loaded host, a blocked event loop) — the first thing to read after a watchdog trip."""
        self.requests = 0
        self.link_errors = 0

    # --- connection -----------------------------------------------------------------------

    async def connect(self, timeout: float = 5.0) -> None:
        """Connect (retrying until `timeout` [s]) and load the command block's shadow."""
        s = self.settings
        if self.client is None:
            self.client = AsyncModbusTcpClient(
                s.plc_host, port=s.plc_port, name="plc", timeout=s.plc_timeout,
                retries=s.plc_retries, reconnect_delay=s.plc_reconnect_delay,
                reconnect_delay_max=s.plc_reconnect_delay_max)
        deadline = time.monotonic() + timeout
        while not await self.client.connect():
            if time.monotonic() > deadline:
                raise PlcLinkError(f"PLC at {self.settings.plc_host}:{self.settings.plc_port} "
                                   f"did not accept a connection within {timeout} s")
            await asyncio.sleep(0.05)
        self.command_regs = await self.read_registers(self.map.command.start,
                                                      self.map.command.count)
        self.heartbeat = int(self.map.command.decode(self.command_regs)[self.map.heartbeat])

    def longest_beat_gap(self) -> float:
        """The longest time [s] without an acknowledged heartbeat change so far, the gap still
        open included: a service that was wedged and has not beaten since (its first poll after
        the wedge reads the PLC's trip) shows the wedge here, not only after its next beat."""
        if self.last_beat is None:
            return self.max_beat_gap
        return max(self.max_beat_gap, time.monotonic() - self.last_beat)

    @property
    def request_bound(self) -> float:
        """The longest one request may take [s], whatever the Modbus library does: every try
        (1 + retries) at `plc_timeout`, plus one more `plc_timeout` for a reconnect. A request
        that outlives it is a link failure, so no caller (the heartbeat, the poll) can wait
        forever."""
        s = self.settings
        return s.plc_timeout * (s.plc_retries + 2)

    @property
    def connected(self) -> bool:
        return self.client is not None and bool(self.client.connected)

    def close(self) -> None:
        if self.client is not None:
            self.client.close()

    # --- raw registers, with the Modbus limits enforced ------------------------------------

    async def read_registers(self, address: int, count: int) -> list[int]:
        """Holding registers [address, address+count), in requests of ≤ 125 registers."""
        if count < 1:
            raise ValueError("count must be ≥ 1")
        out: list[int] = []
        while count > 0:
            n = min(count, MAX_READ_REGISTERS)
            rr = await self._call(f"read {n} at {address}", "read_holding_registers",
                                  address, count=n, device_id=self.device_id)
            if len(rr.registers) != n:
                raise PlcError(f"read {n} at {address}: got {len(rr.registers)} registers")
            out.extend(rr.registers)
            address += n
            count -= n
        return out

    async def write_registers(self, address: int, values: list[int]) -> None:
        """Write holding registers from `address`, in requests of ≤ 123 registers."""
        values = [int(v) & 0xFFFF for v in values]
        for i in range(0, len(values), MAX_WRITE_REGISTERS):
            chunk = values[i:i + MAX_WRITE_REGISTERS]
            await self._call(f"write {len(chunk)} at {address + i}", "write_registers",
                             address + i, chunk, device_id=self.device_id)

    def _c(self) -> AsyncModbusTcpClient:
        if self.client is None:
            raise PlcLinkError("not connected: call connect() first")
        return self.client

    async def _call(self, what: str, method: str, *args, **kwargs):
        """One pymodbus request; link failures (raised at call time while disconnected, or
        while awaiting) become PlcLinkError, Modbus exception responses PlcError."""
        self.requests += 1
        try:
            rr = await asyncio.wait_for(getattr(self._c(), method)(*args, **kwargs),
                                        self.request_bound)
        except ModbusException as exc:  # ConnectionException, ModbusIOException (timeout)
            self.link_errors += 1
            raise PlcLinkError(f"{what}: {exc}") from exc
        except asyncio.TimeoutError as exc:  # the library's own timeout did not fire
            self.link_errors += 1
            raise PlcLinkError(f"{what}: no answer within {self.request_bound:.2f} s") from exc
        if rr.isError():
            code = getattr(rr, "exception_code", None)
            raise PlcError(f"{what}: Modbus exception {code}", code)
        return rr

    # --- the register map ---------------------------------------------------------------

    async def read_status(self) -> dict[str, float]:
        """The whole status block in one request, decoded and scaled to SI."""
        regs = await self.read_registers(self.map.status.start, self.map.status.count)
        return self.map.status.decode(regs)

    async def read_commands(self) -> dict[str, float]:
        """The command block as the PLC holds it (also refreshes the shadow)."""
        self.command_regs = await self.read_registers(self.map.command.start,
                                                      self.map.command.count)
        return self.map.command.decode(self.command_regs)

    async def write_commands(self, values: Mapping[str, float]) -> None:
        """Write the named command signals (SI values) in one request spanning just them;
        other registers in the span keep the shadow's values."""
        if not values:
            return
        new = self.map.command.encode(values, base=self.command_regs)
        sigs = [self.map.signals[n] for n in values]
        lo = min(s.address for s in sigs) - self.map.command.start
        hi = max(s.address + s.width for s in sigs) - self.map.command.start
        await self.write_registers(self.map.command.start + lo, new[lo:hi])
        self.command_regs = new

    async def set_command_bits(self, **bits: bool) -> None:
        """Set or clear named bits of `command_bits` (e.g. pump_on=True, estop=True)."""
        sig = self.map.signals["command_bits"]
        word = int(sig.decode(self.command_regs[sig.address - self.map.command.start:][:1]))
        for name, on in bits.items():
            word = (word | sig.bit(name)) if on else (word & ~sig.bit(name))
        await self.write_commands({"command_bits": word})

    async def beat(self) -> None:
        """Change the service heartbeat once."""
        self.heartbeat = (self.heartbeat + 1) & 0x7FFF
        await self.write_commands({self.map.heartbeat: self.heartbeat})
        now = time.monotonic()
        if self.last_beat is not None:
            self.max_beat_gap = max(self.max_beat_gap, now - self.last_beat)
        self.last_beat = now

    async def heartbeat_loop(self, period: float | None = None) -> None:
        """Change the heartbeat every `period` [s] until cancelled; link errors are survived
        (the beat resumes after the reconnect)."""
        period = self.settings.heartbeat_period if period is None else period
        while True:
            try:
                await self.beat()
            except (PlcLinkError, PlcError) as exc:
                log.debug("heartbeat write failed: %s", exc)
            await asyncio.sleep(period)
