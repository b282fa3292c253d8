"""The drives driver: a CANopen master (the `canopen` package on python-can) for the three
S120 drives (CiA 402), or their stand-ins — only the settings say which.

- NMT, heartbeat producer configuration (0x1017), PDO configuration by SDO (TPDO event timers
  from the settings, mappings from core/drives.eds), modes of operation;
- each drive brought to OPERATION ENABLED through the CiA 402 state machine (SDO, checked
  against the statusword at every step);
- TPDO reception with timestamps: the fast TPDO (speed, current, the drive's sample time
  stamp) into a per-drive stream stamped twice — receive time, and the drive clock (rig time,
  the same clock as the PLC's `rig_time` on the emulator) — that counts lost and duplicated
  samples from the drive's time stamps;
  the status TPDO (statusword, torque, temperature) kept as the latest values;
- RPDO set points (controlword + target velocity);
- a heartbeat watchdog (canopen has none) and EMCY handling: a drive whose heartbeat is lost,
  or that raises an EMCY, is dropped — told to coast (controlword 0) — and an event is
  emitted; the caller (daq/rig.py) decides what a loss means for the rig.

canopen runs PDO/SDO/EMCY callbacks on one receive thread and an unhandled error there kills
it: every callback here catches its own errors and records them as events.
"""

from __future__ import annotations

import logging
import struct
from array import array
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import canopen
from canopen.objectdictionary import import_od

from core import drive_od as D
from daq.settings import Settings

log = logging.getLogger(__name__)

_STRUCT = {2: "b", 3: "h", 4: "i", 5: "B", 6: "H", 7: "I"}


class DriveError(Exception):
    """A drive did not do what it was told (timeout in the state machine, SDO abort)."""


@dataclass
class DriveEvent:
    """Something that happened to a drive (wall time [s], node id, motor 1–3, kind, text)."""

    t: float
    node_id: int
    motor: int
    kind: str
    """'heartbeat_lost', 'emcy', 'dropped', 'enabled', 'callback_error', 'quick_stop'."""
    message: str


@dataclass
class DriveStream:
    """The fast TPDO samples of one drive (compact arrays: 10 min at 1 kHz is 600 k rows):
    receive time `t` [s, time.time() clock of the bus time stamps], drive time stamp `stamp`
    [ms of the drive clock, unwrapped], motor speed `w` [rad/s], motor current `i` [A]."""

    period_ms: int = 1
    """The event timer the master configured: consecutive stamps differ by exactly this."""
    t: array = field(default_factory=lambda: array("d"))
    stamp: array = field(default_factory=lambda: array("q"))
    w: array = field(default_factory=lambda: array("d"))
    i: array = field(default_factory=lambda: array("d"))
    lost: int = 0
    """Samples the time stamps say were sent but never arrived."""
    duplicated: int = 0
    """Frames whose stamp was not new (repeats or stale frames), not recorded."""
    irregular: int = 0
    """Steps between stamps that were not a whole number of periods."""
    _last_raw: int | None = None
    _last_full: int = 0

    def __len__(self) -> int:
        return len(self.stamp)


@dataclass
class Drive:
    node_id: int
    motor: int
    """1, 2 or 3."""
    node: Any
    active: bool = True
    dropped_reason: str | None = None
    last_heartbeat: float | None = None
    """time.monotonic() of the last heartbeat (None until the watchdog is armed)."""
    nmt_state: int | None = None
    statusword: int | None = None
    torque: float = float("nan")
    """Latest torque actual [N·m, motor shaft]."""
    temperature: float = float("nan")
    """Latest motor winding temperature [°C]."""
    status_t: float | None = None
    rated_current: float = 0.0
    """[A] from 0x6075."""
    rated_torque: float = 0.0
    """[N·m] from 0x6076."""
    stream: DriveStream = field(default_factory=DriveStream)
    emcy: list[tuple[float, int]] = field(default_factory=list)
    tx_lock: threading.Lock = field(default_factory=threading.Lock)
    controlword: int = 0
    target_velocity: int = 0
    rpdo1: tuple[int, struct.Struct, dict[int, int]] | None = None
    """(COB-ID, layout, {index: position}) of RPDO1 as configured."""

    @property
    def state(self) -> str:
        return "UNKNOWN" if self.statusword is None else D.state_of(self.statusword)


def bus_kwargs(settings: Settings) -> dict[str, Any]:
    """python-can bus arguments for the settings' interface (loopback-safe)."""
    s = settings
    if s.can_interface == "socketcand":
        return {"interface": "socketcand", "channel": s.can_channel, "host": s.can_host,
                "port": s.can_port, "tcp_tune": True}
    if s.can_interface == "udp_multicast":
        # hop_limit=0 keeps frames on this machine; the default sends them out of it
        return {"interface": "udp_multicast", "channel": s.can_channel, "hop_limit": 0}
    if s.can_interface == "virtual":
        return {"interface": "virtual", "channel": s.can_channel}
    return {"interface": s.can_interface, "channel": s.can_channel, "bitrate": s.can_bitrate}


class DriveMaster:
    """CANopen master of the rig's drives. Blocking API (SDO round trips); callbacks and the
    watchdog run on their own threads and report through `on_event`."""

    def __init__(self, settings: Settings,
                 on_event: Callable[[DriveEvent], None] | None = None) -> None:
        self.settings = settings
        self.on_event = on_event
        self.network: canopen.Network | None = None
        self.drives: list[Drive] = []
        self.events: list[DriveEvent] = []
        self._sdo_lock = threading.RLock()
        self._stop = threading.Event()
        self._watchdog: threading.Thread | None = None
        self._armed = False
        self.callback_errors: dict[tuple[int, str], int] = {}
        self.inhibited = False
        """Set by quick_stop(): enable() refuses until cleared (a make-safe must not be undone
        by a bring-up still in progress)."""

    # --- set-up -------------------------------------------------------------------------

    def open(self) -> None:
        """Connect to the bus and create the remote nodes from the EDS."""
        if self.settings.can_interface == "socketcand":
            # python-can warns on every frame split across two TCP reads; that is normal
            # streaming, not a fault worth a log line per occurrence
            logging.getLogger("can.interfaces.socketcand.socketcand").setLevel(logging.ERROR)
        self.network = canopen.Network()
        self.network.NOTIFIER_CYCLE = 0.1  # receive-thread poll: disconnect within 0.1 s
        self.network.connect(**bus_kwargs(self.settings))
        for k, nid in enumerate(self.settings.node_ids):
            node = canopen.RemoteNode(nid, import_od(str(D.EDS_PATH), nid))
            self.network.add_node(node)
            node.sdo.RESPONSE_TIMEOUT = self.settings.sdo_timeout
            d = Drive(nid, k + 1, node)
            node.nmt.add_heartbeat_callback(self._guard(d, self._on_heartbeat))
            node.emcy.add_callback(self._guard(d, self._on_emcy))
            self.drives.append(d)
        self._watchdog = threading.Thread(target=self._watchdog_loop, name="drive-heartbeat-watchdog",
                                          daemon=True)
        self._watchdog.start()

    def configure(self) -> None:
        """Per drive, by SDO: heartbeat producer time, rated values, PDO configuration (EDS
        mappings, event timers from the settings), profile velocity mode, target 0."""
        fast_ms = max(1, round(1000.0 / self.settings.tpdo_rate_hz))
        slow_ms = max(1, round(1000.0 / self.settings.status_tpdo_rate_hz))
        for d in self.drives:
            n = d.node
            with self._sdo_lock:
                n.nmt.state = "PRE-OPERATIONAL"
                n.sdo[D.HEARTBEAT_TIME].raw = self.settings.drive_heartbeat_ms
                d.rated_current = n.sdo[D.RATED_CURRENT].raw * 1e-3
                d.rated_torque = n.sdo[D.RATED_TORQUE].raw * 1e-3
                n.tpdo.read(from_od=True)
                n.rpdo.read(from_od=True)
                for num, period in ((D.FAST_TPDO, fast_ms), (D.STATUS_TPDO, slow_ms)):
                    n.tpdo[num].trans_type = 254
                    n.tpdo[num].event_timer = period
                    n.tpdo[num].enabled = True
                n.tpdo.save()
                n.rpdo.save()
                n.sdo[D.MODES_OF_OPERATION].raw = D.MODE_PROFILE_VELOCITY
                n.sdo[D.TARGET_VELOCITY].raw = 0
            fmt, pos = self._layout(n.rpdo[1])
            d.rpdo1 = (n.rpdo[1].cob_id, fmt, pos)
            n.tpdo[D.FAST_TPDO].add_callback(self._guard(d, self._fast_decoder(d)))
            n.tpdo[D.STATUS_TPDO].add_callback(self._guard(d, self._status_decoder(d)))
            d.last_heartbeat = time.monotonic()
        self._armed = True

    def start(self) -> None:
        """NMT OPERATIONAL, then every drive to OPERATION ENABLED."""
        for d in self.drives:
            d.node.nmt.state = "OPERATIONAL"
        for d in self.drives:
            self.enable(d)

    def enable(self, d: Drive) -> None:
        """Walk the CiA 402 state machine to OPERATION ENABLED (SDO controlword, statusword
        checked after every step)."""
        deadline = time.monotonic() + self.settings.drive_enable_timeout
        step_for = {"SWITCH ON DISABLED": D.CW_SHUTDOWN, "READY TO SWITCH ON": D.CW_SWITCH_ON,
                    "SWITCHED ON": D.CW_ENABLE_OPERATION,
                    "QUICK STOP ACTIVE": D.CW_DISABLE_VOLTAGE}
        with self._sdo_lock:
            d.node.sdo[D.TARGET_VELOCITY].raw = 0
            while True:
                if self.inhibited:
                    raise DriveError(f"drive {d.node_id} not enabled: quick stop in force")
                sw = d.node.sdo[D.STATUSWORD].raw
                d.statusword = sw
                state = D.state_of(sw)
                if state == "OPERATION ENABLED":
                    break
                if time.monotonic() > deadline:
                    raise DriveError(f"drive {d.node_id} stuck in {state} (statusword 0x{sw:04X})")
                if state == "FAULT":
                    d.node.sdo[D.CONTROLWORD].raw = 0
                    d.node.sdo[D.CONTROLWORD].raw = D.CW_FAULT_RESET
                elif state in step_for:
                    d.node.sdo[D.CONTROLWORD].raw = step_for[state]
                else:
                    time.sleep(0.01)
        with d.tx_lock:
            if self.inhibited:  # a quick stop arrived during the last SDO step
                raise DriveError(f"drive {d.node_id} not enabled: quick stop in force")
            d.controlword, d.target_velocity = D.CW_ENABLE_OPERATION, 0
            self._send_rpdo1(d)
        d.active, d.dropped_reason = True, None
        self._event(d, "enabled", "OPERATION ENABLED")

    # --- set points -------------------------------------------------------------------------

    def set_speed(self, w: float, motors: list[int] | None = None) -> None:
        """Target speed [rad/s at the motor shaft] for the active drives (or the given motors
        1–3), sent in RPDO1 with controlword 'enable operation'."""
        raw = int(round(w / D.VELOCITY_UNIT))
        for d in self.drives:
            if d.active and (motors is None or d.motor in motors):
                with d.tx_lock:
                    d.controlword, d.target_velocity = D.CW_ENABLE_OPERATION, raw
                    self._send_rpdo1(d)

    def quick_stop(self, drives: list[Drive] | None = None) -> list[str]:
        """Quick stop (controlword 0x0002, target 0) to every drive, active or dropped;
        returns the errors met (a make-safe path must not raise). Inhibits enable()."""
        self.inhibited = True
        errors = []
        for d in drives or self.drives:
            try:
                with d.tx_lock:
                    d.controlword, d.target_velocity = D.CW_QUICK_STOP, 0
                    self._send_rpdo1(d)
            except Exception as exc:  # noqa: BLE001 - make-safe collects, never raises
                errors.append(f"drive {d.node_id}: {exc!r}")
        return errors

    def _send_rpdo1(self, d: Drive) -> None:
        """RPDO1 (controlword, target velocity, as mapped by the EDS) with d's values."""
        if self.network is None or d.rpdo1 is None:
            raise DriveError(f"drive {d.node_id} is not configured")
        cob, fmt, pos = d.rpdo1
        vals = [0] * len(pos)
        vals[pos[D.CONTROLWORD]] = d.controlword
        vals[pos[D.TARGET_VELOCITY]] = d.target_velocity
        self.network.send_message(cob, fmt.pack(*vals))

    # --- drops ----------------------------------------------------------------------------

    def drop(self, d: Drive, reason: str) -> None:
        """Take a drive out of the joint: coast it (controlword 0 — disable voltage), record.
        It is not NMT-stopped: whatever it still sends (statusword, temperature) stays visible."""
        if not d.active:
            return
        d.active = False
        d.dropped_reason = reason
        try:
            with d.tx_lock:
                d.controlword, d.target_velocity = D.CW_DISABLE_VOLTAGE, 0
                self._send_rpdo1(d)
        except Exception as exc:  # noqa: BLE001 - the bus may be what failed
            reason += f"; could not command it ({exc!r})"
        self._event(d, "dropped", reason)

    @property
    def active(self) -> list[Drive]:
        return [d for d in self.drives if d.active]

    @property
    def dropped(self) -> list[Drive]:
        return [d for d in self.drives if not d.active]

    # --- callbacks (receive thread) -------------------------------------------------------------

    def _guard(self, d: Drive, fn: Callable) -> Callable:
        """Wrap a receive-thread callback: errors are counted in `callback_errors` and the
        first of each callback is recorded as an event (a bad PDO at 1 kHz must not flood
        the record, nor kill canopen's receive thread)."""
        def wrapped(*args):
            try:
                fn(d, *args)
            except Exception as exc:  # noqa: BLE001
                key = (d.node_id, fn.__name__)
                self.callback_errors[key] = self.callback_errors.get(key, 0) + 1
                if self.callback_errors[key] == 1:
                    self._event(d, "callback_error", f"{fn.__name__}: {exc!r}")
        wrapped.__name__ = getattr(fn, "__name__", "callback")
        return wrapped

    def _on_heartbeat(self, d: Drive, state: int) -> None:
        d.last_heartbeat = time.monotonic()
        d.nmt_state = state

    def _on_emcy(self, d: Drive, entry: Any) -> None:
        d.emcy.append((time.time(), entry.code))
        if entry.code & 0xFF00:
            self._event(d, "emcy", f"EMCY 0x{entry.code:04X} {entry.get_desc()}")
            self.drop(d, f"EMCY 0x{entry.code:04X} ({entry.get_desc()})")

    def _layout(self, pdo_map: Any) -> tuple[struct.Struct, dict[int, int]]:
        fmt, pos = "<", {}
        for k, var in enumerate(pdo_map.map):
            fmt += _STRUCT[var.od.data_type]
            pos[var.index] = k
        return struct.Struct(fmt), pos

    def _fast_decoder(self, d: Drive) -> Callable:
        fmt, pos = self._layout(d.node.tpdo[D.FAST_TPDO])
        iv, ii, ic = pos[D.VELOCITY_ACTUAL], pos[D.CURRENT_ACTUAL], pos[D.SAMPLE_STAMP]
        vel_unit, cur_unit = D.VELOCITY_UNIT, D.PER_MILLE * d.rated_current
        st = d.stream
        st.period_ms = period = d.node.tpdo[D.FAST_TPDO].event_timer

        def on_fast(_d: Drive, pdo_map: Any) -> None:
            vals = fmt.unpack_from(pdo_map.data)
            raw = vals[ic]
            if st._last_raw is None:
                full = raw
            else:
                delta = D.stamp_delta(raw, st._last_raw)
                if delta == 0 or delta > 0x8000:
                    st.duplicated += 1
                    return
                full = st._last_full + delta
                steps, rest = divmod(delta, period)
                st.lost += max(0, steps - 1)
                st.irregular += rest != 0
            st._last_raw, st._last_full = raw, full
            st.t.append(pdo_map.timestamp)
            st.stamp.append(full)
            st.w.append(vals[iv] * vel_unit)
            st.i.append(vals[ii] * cur_unit)
        on_fast.__name__ = "on_fast_tpdo"
        return on_fast

    def _status_decoder(self, d: Drive) -> Callable:
        fmt, pos = self._layout(d.node.tpdo[D.STATUS_TPDO])
        isw, itq, itemp = pos[D.STATUSWORD], pos[D.TORQUE_ACTUAL], pos[D.MOTOR_TEMPERATURE]

        def on_status(_d: Drive, pdo_map: Any) -> None:
            vals = fmt.unpack_from(pdo_map.data)
            d.statusword = vals[isw]
            d.torque = vals[itq] * D.PER_MILLE * d.rated_torque
            d.temperature = vals[itemp] * D.TEMPERATURE_UNIT
            d.status_t = pdo_map.timestamp
        on_status.__name__ = "on_status_tpdo"
        return on_status

    def _watchdog_loop(self) -> None:
        timeout = self.settings.drive_heartbeat_timeout
        while not self._stop.wait(0.02):
            if not self._armed:
                continue
            now = time.monotonic()
            for d in self.drives:
                last = d.last_heartbeat
                if d.active and last is not None and now - last > timeout:
                    self._event(d, "heartbeat_lost", f"no heartbeat for {now - last:.3f} s "
                                                     f"(timeout {timeout} s)")
                    self.drop(d, f"heartbeat lost ({now - last:.3f} s)")

    def _event(self, d: Drive, kind: str, message: str) -> None:
        ev = DriveEvent(time.time(), d.node_id, d.motor, kind, message)
        self.events.append(ev)
        log.info("drive %d (motor %d): %s: %s", d.node_id, d.motor, kind, message)
        if self.on_event is not None:
            try:
                self.on_event(ev)
            except Exception:  # noqa: BLE001
                log.exception("drive event handler failed")

    # --- shut-down ------------------------------------------------------------------------

    def close(self) -> None:
        """Stop the watchdog and disconnect (the drives are not commanded: make-safe is the
        caller's business and runs before this)."""
        self._stop.set()
        if self._watchdog is not None:
            self._watchdog.join(timeout=1.0)
        if self.network is not None:
            try:
                self.network.disconnect()
            except Exception as exc:  # noqa: BLE001
                log.warning("CAN disconnect: %r", exc)
            self.network = None
