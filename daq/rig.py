"""The DAQ-side facade of the rig: the PLC driver, the drives driver and the interlocks joined
from one settings object, plus the record other code (the scheme engine) reads.

    async with Rig(Settings.load()).session() as rig:     # make-safe always runs at the end
        await rig.set_pump(True)
        await rig.set_motor_speed(100.0)
        ...

What it does while running:
- polls the PLC status block at `plc_poll_hz` into `plc` (a column store; one row per new
  PLC snapshot, repeats counted, not stored) and checks the interlocks on every sample;
- writes the service heartbeat every `heartbeat_period`;
- receives the drives' TPDOs (daq/drives.py) into per-drive streams;
- records everything that interrupts acquisition in `events` (data, not log lines): PLC link
  gaps with their start and end, drive drops, trips, make-safe steps and their outcome.

Homing (`home`): the PLC turns the joint to 0° by the motor code disk and zeroes the output
encoder (core/plc_map.py); the absolute-angle interlock then watches ±180° on that encoder.
The interlock limits follow a limit set (`use_limits`, core/schemes.py LIMIT_SETS), "default"
until a plan names another.

Policy: a lost or faulted drive is dropped and the joint continues on the others (the rig's
designed redundancy); a second lost drive, a lost PLC link, any interlock trip or an e-stop
makes the rig safe — dynamometer to zero, drives quick-stop, hydraulics to `safe_pressure` —
and latches `safe` until `reset()`. Make-safe never raises: every step is attempted and its
outcome recorded.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from array import array
from dataclasses import dataclass, field
from typing import Any, AsyncIterator

from core.plc_map import HOME_GAIN, HOME_MOTOR_SPEED
from core.params import REDUCTION
from core.schemes import LimitSet
from daq.drives import DriveError, DriveEvent, DriveMaster
from daq.interlocks import Interlocks, Trip
from daq.plc import PlcClient, PlcError, PlcLinkError
from daq.settings import Settings


async def _cancel_all(tasks: list[asyncio.Task], timeout: float = 5.0) -> set[asyncio.Task]:
    """Cancel `tasks` and wait until they end; returns those still running after `timeout` [s].
    Cancelled once is not enough: Python 3.11's asyncio.wait_for (inside every pymodbus
    request) can swallow a cancellation that races a reply, and the heartbeat and poll loops
    would then run on forever (seen: `rig run` that never exited after its run had ended)."""
    deadline = time.monotonic() + timeout
    pending = set(tasks)
    while pending and time.monotonic() < deadline:
        for t in pending:
            t.cancel()
        done, pending = await asyncio.wait(pending, timeout=0.1)
        for t in done:  # their errors were recorded by _guarded; do not re-raise them here
            if not t.cancelled():
                t.exception()
    return pending


class RigSafeError(Exception):
    """A set point was refused because the rig is in its safe state (see `Rig.trips`)."""


@dataclass
class RigEvent:
    """One entry of the record: wall time [s], source ('plc', 'drive', 'interlock', 'rig',
    'operator'), kind, text, details."""

    t: float
    source: str
    kind: str
    message: str
    data: dict[str, Any] = field(default_factory=dict)


class PlcStream:
    """PLC status samples as columns (array('d') each): every status signal by name, plus
    `t_rx` (wall time the answer arrived [s]) and `latency` (poll round trip [s])."""

    def __init__(self, names: list[str]) -> None:
        self.names = names
        self.columns: dict[str, array] = {n: array("d") for n in ["t_rx", "latency"] + names}

    def append(self, t_rx: float, latency: float, status: dict[str, float]) -> None:
        c = self.columns
        c["t_rx"].append(t_rx)
        c["latency"].append(latency)
        for n in self.names:
            c[n].append(status[n])

    def __len__(self) -> int:
        return len(self.columns["t_rx"])

    def __getitem__(self, name: str) -> array:
        return self.columns[name]


class Rig:
    """PLC + drives + interlocks from one settings object (async; the CANopen master's
    blocking calls run in worker threads)."""

    def __init__(self, settings: Settings | None = None) -> None:
        self.settings = settings or Settings()
        self.plc_client = PlcClient(self.settings)
        self.drives: DriveMaster | None = (DriveMaster(self.settings, self._drive_event_threadsafe)
                                           if self.settings.node_ids else None)
        self.interlocks = Interlocks(self.settings)
        self.events: list[RigEvent] = []
        self.trips: list[Trip] = []
        self.plc = PlcStream([s.name for s in self.plc_client.map.status.signals])
        self.gaps: list[list[float | None]] = []
        """PLC link gaps: [wall time of the last good answer, wall time of the next] (None
        while open)."""
        self.safe = False
        self.polls = 0
        self.poll_errors = 0
        self.repeats = 0
        """Polls that returned a PLC snapshot already recorded (same rig_time)."""
        self.overruns = 0
        """Polls started late by more than one period."""
        self.last_status: dict[str, float] | None = None
        self._tasks: list[asyncio.Task] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._last_ok = time.monotonic()
        self._tripped: set[str] = set()
        self._make_safe_lock = asyncio.Lock()

    # --- record ---------------------------------------------------------------------------

    def record(self, source: str, kind: str, message: str, **data: Any) -> RigEvent:
        ev = RigEvent(time.time(), source, kind, message, data)
        self.events.append(ev)
        return ev

    def events_of(self, kind: str) -> list[RigEvent]:
        return [e for e in self.events if e.kind == kind]

    # --- life cycle -----------------------------------------------------------------------

    async def start(self, connect_timeout: float = 5.0) -> None:
        """Connect to the PLC, start the heartbeat and the poll loop; bring the drives up
        (NMT, configuration, OPERATION ENABLED)."""
        self._loop = asyncio.get_running_loop()
        await self.plc_client.connect(connect_timeout)
        await self.plc_client.beat()
        self._last_ok = time.monotonic()
        self.record("rig", "plc_connected",
                    f"PLC at {self.settings.plc_host}:{self.settings.plc_port}")
        self._tasks.append(asyncio.create_task(self._guarded(self.plc_client.heartbeat_loop()),
                                               name="heartbeat"))
        self._tasks.append(asyncio.create_task(self._guarded(self._poll_loop()), name="plc-poll"))
        if self.drives is not None:
            d = self.drives
            await asyncio.to_thread(d.open)
            await asyncio.to_thread(d.configure)
            try:
                await asyncio.to_thread(d.start)
            except DriveError as exc:
                if not self.safe:
                    raise
                # a trip during the bring-up: the drives stay stopped, the session goes on
                self.record("rig", "drives_not_enabled", f"drives not enabled: {exc}")
                d.quick_stop()
            else:
                self.record("rig", "drives_enabled",
                            f"{len(d.active)} drives in OPERATION ENABLED")

    async def stop(self) -> None:
        """Stop polling and the heartbeat, close the links (no commands: see make_safe)."""
        tasks, self._tasks = self._tasks, []
        left = await _cancel_all(tasks)
        if left:
            self.record("rig", "stop_incomplete",
                        f"background loops still running after repeated cancels: "
                        f"{sorted(t.get_name() for t in left)}")
        if self.drives is not None:
            await asyncio.to_thread(self.drives.close)
        self.plc_client.close()
        self.record("rig", "stopped", "acquisition stopped")

    @contextlib.asynccontextmanager
    async def session(self) -> AsyncIterator["Rig"]:
        """start … yield … make_safe (always, even when the body raises) … stop."""
        try:
            await self.start()
            yield self
        except BaseException as exc:
            await self.make_safe(f"session ended by {type(exc).__name__}: {exc}")
            raise
        else:
            await self.make_safe("session ended")
        finally:
            await self.stop()

    # --- set points (refused while safe) -----------------------------------------------------

    def _check_not_safe(self) -> None:
        if self.safe:
            why = self.trips[-1].message if self.trips else "made safe"
            raise RigSafeError(f"rig is in its safe state ({why}); reset() first")

    async def set_dyno_torque(self, tau: float) -> None:
        """Dynamometer torque set point [N·m]."""
        self._check_not_safe()
        await self.plc_client.write_commands({"dyno_torque_sp": tau})

    async def set_pressure(self, p: float) -> None:
        """Proportional pressure regulator set point [Pa]."""
        self._check_not_safe()
        await self.plc_client.write_commands({"pressure_sp": p})

    async def set_pump(self, on: bool) -> None:
        self._check_not_safe()
        await self.plc_client.set_command_bits(pump_on=on)

    async def set_cooling(self, on: bool) -> None:
        await self.plc_client.set_command_bits(cooling_on=on)

    async def set_valve(self, cmd: int) -> None:
        """Y-type reversing valve: 0 locked, 1 extend, 2 retract."""
        self._check_not_safe()
        await self.plc_client.write_commands({"valve_cmd": cmd})

    async def set_motor_speed(self, w: float) -> None:
        """Speed set point of every active drive [rad/s at the motor shaft]."""
        self._check_not_safe()
        if self.drives is None:
            raise RuntimeError("no drives configured (settings.node_ids is empty)")
        self.drives.set_speed(w)

    # --- limits and homing -------------------------------------------------------------------

    def use_limits(self, limit_set: LimitSet) -> None:
        """Hold the rig to `limit_set` from now on (recorded as an event)."""
        self.interlocks = Interlocks(self.settings, limit_set)
        self.record("rig", "limits", f"limit set {limit_set.name!r}: {limit_set.purpose}",
                    **self.interlocks.describe())

    @staticmethod
    def homing_time(u: float) -> float:
        """Rig time [s] the PLC's homing may take from the motor-side angle u [rad]: the
        travel at HOME_MOTOR_SPEED plus the proportional approach (ln 100 / HOME_GAIN, taken
        as 10 / HOME_GAIN), doubled for margin."""
        v = HOME_MOTOR_SPEED / REDUCTION
        return 2.0 * (abs(u) / v + 10.0 / HOME_GAIN)

    async def home(self, time_scale: float = 1.0, slack: float = 5.0,
                   poll: float = 0.02) -> dict[str, Any]:
        """Home the joint (core/plc_map.py): drives' speed set point 0, then the PLC's `home`
        request held until it reports `homed`. The interlocks stay armed throughout; a trip
        stops it (RigSafeError). Past homing_time(u)/time_scale + slack [s of wall time;
        time_scale in rig s per wall s] the rig is made safe with the trip `homing`.
        Returns the angles before and after [rad] and the wall time taken [s]."""
        self._check_not_safe()
        sb = self.plc_client.map.signals["status_bits"]
        if self.drives is not None:
            await self.set_motor_speed(0.0)  # the PLC moves the joint; no other set point
        try:
            before = await self.plc_client.read_status()
        except PlcLinkError:
            if self.last_status is None:
                raise
            before = self.last_status  # the poll loop's latest: the joint has not moved since
        u0 = before["u"] if math.isfinite(before["u"]) else math.pi
        timeout = self.homing_time(u0) / time_scale + slack
        self.record("rig", "homing", f"homing from q {before['q']:.5f} rad, "
                                     f"u {before['u']:.5f} rad")
        t0 = time.monotonic()
        await self.plc_client.set_command_bits(home=False)  # a rising edge starts it
        await self.plc_client.set_command_bits(home=True)
        st = before
        try:
            while True:
                await asyncio.sleep(poll)
                self._check_not_safe()
                if time.monotonic() - t0 > timeout:
                    await self.trip(Trip("homing", f"not homed within {timeout:.1f} s "
                                                   f"(u {st['u']:.5f} rad)", st["u"], timeout))
                    self._check_not_safe()
                try:
                    st = await self.plc_client.read_status()  # after the request: never stale
                except PlcLinkError:
                    continue  # a late answer; a lost link trips plc_link in the poll loop
                bits = int(st["status_bits"])
                if bits & sb.bit("homed") and not bits & sb.bit("homing"):
                    break
        finally:
            with contextlib.suppress(PlcLinkError, PlcError):
                await self.plc_client.set_command_bits(home=False)
        out = {"q_before": before["q"], "u_before": before["u"], "q_after": st["q"],
               "u_after": st["u"], "wall_s": time.monotonic() - t0}
        self.record("rig", "homed", f"homed in {out['wall_s']:.2f} s: output encoder zeroed "
                                    f"at u {st['u']:.5f} rad", **out)
        return out

    # --- safety ---------------------------------------------------------------------------

    async def estop(self, reason: str = "operator") -> None:
        """Operator e-stop: trip, make safe, and latch the PLC's e-stop."""
        await self.trip(Interlocks.operator_estop(reason))
        with contextlib.suppress(PlcLinkError, PlcError):
            await self.plc_client.set_command_bits(estop=True)

    async def trip(self, trip: Trip) -> None:
        """Record a trip and make the rig safe (once per interlock until reset)."""
        if trip.name in self._tripped:
            return
        self._tripped.add(trip.name)
        self.trips.append(trip)
        self.record("interlock", "trip", f"{trip.name}: {trip.message}", name=trip.name,
                    value=trip.value, limit=trip.limit)
        await self.make_safe(f"interlock {trip.name}")

    async def make_safe(self, reason: str) -> None:
        """Dynamometer to zero, drives quick-stop, hydraulics to the safe pressure. Every step
        is attempted whatever the others do; the outcome is recorded; never raises."""
        async with self._make_safe_lock:
            self.safe = True
            outcome: dict[str, str] = {}
            if self.drives is not None:
                try:
                    errs = self.drives.quick_stop()
                    outcome["drives"] = "quick stop sent" + (f" ({'; '.join(errs)})" if errs else "")
                except Exception as exc:  # noqa: BLE001
                    outcome["drives"] = f"failed: {exc!r}"
            outcome["plc"] = await self._plc_safe_commands()
            self.record("rig", "make_safe", f"made safe: {reason}", reason=reason, **outcome)

    async def _plc_safe_commands(self) -> str:
        try:
            c = self.plc_client
            sig = c.map.signals["command_bits"]
            word = int(sig.decode(c.command_regs[sig.address - c.map.command.start:][:1]))
            await c.write_commands({"dyno_torque_sp": 0.0, "command_bits": word & ~sig.bit("home"),
                                    "pressure_sp": self.settings.safe_pressure})
            return "dynamometer 0 N·m, pressure set point " \
                   f"{self.settings.safe_pressure:g} Pa and no home request written"
        except (PlcLinkError, PlcError) as exc:
            return f"not reachable ({exc}); the PLC's own watchdog makes it safe"
        except Exception as exc:  # noqa: BLE001
            return f"failed: {exc!r}"

    async def reset(self) -> None:
        """Leave the safe state: clear the latched trips and pulse the PLC's fault reset
        (the e-stop command is released first). Drives must be re-enabled by the caller."""
        await self.plc_client.set_command_bits(estop=False, fault_reset=True)
        await self.plc_client.set_command_bits(fault_reset=False)
        self._tripped.clear()
        self.safe = False
        if self.drives is not None:
            self.drives.inhibited = False
        self.record("operator", "reset", "safe state left")

    # --- drive events (from the CANopen threads) ----------------------------------------------

    def _drive_event_threadsafe(self, ev: DriveEvent) -> None:
        if self._loop is not None and self._loop.is_running():
            self._loop.call_soon_threadsafe(self._on_drive_event, ev)
        else:
            self._on_drive_event(ev)

    def _on_drive_event(self, ev: DriveEvent) -> None:
        self.record("drive", ev.kind, f"drive {ev.node_id} (motor {ev.motor}): {ev.message}",
                    node_id=ev.node_id, motor=ev.motor)
        if ev.kind != "dropped" or self.drives is None:
            return
        dropped, active = self.drives.dropped, self.drives.active
        if len(dropped) >= 2 or not active:
            trip = Interlocks.drive_link_lost(
                [f"motor {d.motor}: {d.dropped_reason}" for d in dropped], len(active))
            self._spawn(self.trip(trip))
        else:
            self.record("rig", "degraded",
                        f"joint continues on {len(active)} motors "
                        f"({', '.join(str(d.motor) for d in active)})",
                        active=[d.motor for d in active])

    def _spawn(self, coro) -> None:
        self._tasks.append(asyncio.ensure_future(coro))

    # --- polling --------------------------------------------------------------------------

    async def _guarded(self, coro) -> None:
        """Run a background loop; if it dies of an unexpected error, record it and make the
        rig safe (acquisition code raising must never leave the rig running unwatched)."""
        try:
            await coro
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # noqa: BLE001
            self.record("rig", "acquisition_error", f"{type(exc).__name__}: {exc}")
            await self.make_safe(f"acquisition error: {type(exc).__name__}: {exc}")

    async def _poll_loop(self) -> None:
        period = 1.0 / self.settings.plc_poll_hz
        next_t = time.monotonic()
        prev_rig_time: float | None = None
        gap: list[float | None] | None = None
        last_ok_wall = time.time()
        while True:
            t0 = time.monotonic()
            self.polls += 1
            try:
                status = await self.plc_client.read_status()
            except PlcLinkError as exc:
                self.poll_errors += 1
                if gap is None:
                    gap = [last_ok_wall, None]
                    self.gaps.append(gap)
                    self.record("plc", "link_down", f"PLC not answering: {exc}")
                silent = time.monotonic() - self._last_ok
                if silent > self.settings.plc_link_timeout:
                    await self.trip(Interlocks.plc_link_lost(silent, self.settings.plc_link_timeout))
            except PlcError as exc:
                self.poll_errors += 1
                self.record("plc", "exception", f"status poll refused: {exc}")
            else:
                t1 = time.monotonic()
                now = time.time()
                self._last_ok = t1
                last_ok_wall = now
                if gap is not None:
                    gap[1] = now
                    self.record("plc", "link_restored",
                                f"PLC answering again after {now - gap[0]:.3f} s",
                                gap_start=gap[0], gap_end=now)
                    gap = None
                    if self.safe:
                        await self._plc_safe_commands()
                self.last_status = status
                if status["rig_time"] == prev_rig_time:
                    self.repeats += 1
                else:
                    prev_rig_time = status["rig_time"]
                    self.plc.append(now, t1 - t0, status)
                for trip in self.interlocks.check_status(status):
                    await self.trip(trip)
                if self.drives is not None:
                    for d in self.drives.drives:
                        if not math.isnan(d.temperature):
                            tr = self.interlocks.check_motor_temperature(d.motor, d.temperature)
                            if tr is not None:
                                await self.trip(tr)
            next_t += period
            delay = next_t - time.monotonic()
            if delay < -period:
                self.overruns += 1
                next_t = time.monotonic()
                delay = 0.0
            await asyncio.sleep(max(0.0, delay))
