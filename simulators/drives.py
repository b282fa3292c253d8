"""The drive stand-in: three CiA 402 drive nodes (the S120s behind their CBC10 boards) on the
emulator's motors, built with canopen's LocalNode from core/drives.eds.

Each node does what the drive does on the bus:
- NMT slave with boot-up message and heartbeat producer (0x1017, changeable by SDO);
- SDO server for the whole object dictionary; process values (statusword, actual velocity,
  torque, current, temperature) are read live from the emulator;
- the CiA 402 state machine driven by the controlword (SDO or RPDO1), with quick stop
  (ramp at 0x6085, then SWITCH ON DISABLED, quick stop option code 2) and fault reset;
- TPDOs from its PDO configuration (read at the NMT start, so a master may remap them):
  event-timer driven in rig time (1 ms → 1 kHz), TPDO2 also on a statusword change;
- RPDOs applied to the object dictionary as if written by SDO;
- EMCY on faults (0x1000 generic for an injected motor/drive fault), 0x1001/0x1003/0x603F kept.

Emulator-only object 0x5FF0 "Emulator fault injection" (added here, not in the EDS): writing
1 fails the motor (LiveJoint.fail_motor) and faults the drive, as a real drive fault would.

A dead drive (`DriveStandIn.silence(node_id)`, reached through `rig emulate --control-stdin`):
the node leaves the bus — no heartbeat, no TPDO, no EMCY, no answer to SDO or NMT, RPDOs
unheard — and its motor gives no torque, as when a drive loses its power or its CBC10 board.
It does not come back (a restart of the stand-in does that). The master finds out only by the
silence (its heartbeat watchdog, daq/drives.py).

`step()` is called by the stand-in's pacing thread once per emulator step (1 ms of rig time)
with the emulator lock held; SDO/NMT/RPDO handlers run on canopen's receive thread and take
the same lock.
"""

from __future__ import annotations

import logging
import math
import struct
import threading
from typing import Any, Callable

import canopen
from canopen.objectdictionary import ODVariable, import_od
from canopen.objectdictionary import datatypes as dt
from canopen.sdo import SdoAbortedError

from core import drive_od as D

log = logging.getLogger(__name__)

FAULT_INJECTION = 0x5FF0
"""Emulator-only object: write 1 to fail the motor behind the drive."""

ABORT_VALUE_RANGE = 0x06090030
ABORT_NOT_IN_STATE = 0x08000022

_STRUCT = {dt.INTEGER8: "b", dt.INTEGER16: "h", dt.INTEGER32: "i", dt.UNSIGNED8: "B",
           dt.UNSIGNED16: "H", dt.UNSIGNED32: "I", dt.BOOLEAN: "?"}


def drive_object_dictionary(node_id: int):
    """The EDS's object dictionary plus the emulator-only fault injection object."""
    od = import_od(str(D.EDS_PATH), node_id)
    var = ODVariable("Emulator fault injection", FAULT_INJECTION, 0)
    var.data_type = dt.UNSIGNED8
    var.access_type = "rw"
    var.default = 0
    od.add_object(var)
    return od


class DriveNode:
    """One CiA 402 drive on motor `k` (0, 1, 2) of the emulator."""

    def __init__(self, network: canopen.Network, node_id: int, k: int, live: Any,
                 lock: threading.RLock, on_event: Callable[[str], None] | None = None) -> None:
        self.network = network
        self.on_event = on_event
        """Told (one line of text) when the drive quick-stops or faults: the stand-in's own
        record of the rig being stopped, with the time it happened."""
        self.silenced = False
        """The drive is dead (silence()): off the bus, motor without torque."""
        self.node_id = node_id
        self.k = k
        self.live = live
        self.lock = lock
        self.node = canopen.LocalNode(node_id, drive_object_dictionary(node_id))
        network.add_node(self.node)
        self.node.add_write_callback(self._on_write)
        self.node.add_read_callback(self._on_read)
        network.subscribe(0, self._on_nmt)
        self.state = "NOT READY TO SWITCH ON"
        self.cw = 0
        self.off3 = False
        """The PLC's hard-wired OFF3 (quick stop) is active: the drive cannot be enabled."""
        self.motor_failed = False
        self.error_code = 0
        self.qs_speed: float | None = None
        """Speed set point [rad/s] being ramped to zero during a quick stop."""
        self._tpdos: list[dict] = []
        self._rpdo_subs: list[tuple[int, Any]] = []
        self._last_sw_sent: int | None = None
        self.tpdo_sent = [0, 0]

    # --- object values ------------------------------------------------------------------

    def _get(self, index: int, sub: int = 0) -> int:
        obj = self.node.object_dictionary[index]
        if not isinstance(obj, ODVariable):
            obj = obj[sub]
        return obj.decode_raw(self.node.get_data(index, sub))

    def _ms(self) -> int:
        """The drive clock: rig time in whole ms."""
        return int(round(float(self.live.t) * 1000.0))

    def statusword(self) -> int:
        sw = D.statusword_for(self.state) | D.SW_REMOTE
        if self.state in ("OPERATION ENABLED", "QUICK STOP ACTIVE", "SWITCHED ON",
                          "FAULT REACTION ACTIVE"):
            sw |= D.SW_VOLTAGE_ENABLED
        return sw

    def _process_values(self) -> dict[int, int]:
        """Live values of the mappable process objects (raw, in the EDS units)."""
        m = self.live.motor(self.k)
        rated_i = self._get(D.RATED_CURRENT) * 1e-3
        rated_tau = self._get(D.RATED_TORQUE) * 1e-3
        return {
            D.STATUSWORD: self.statusword(),
            D.VELOCITY_ACTUAL: _clip(m["w"] / D.VELOCITY_UNIT, 31),
            D.TORQUE_ACTUAL: _clip(m["tau"] / rated_tau / D.PER_MILLE, 15),
            D.CURRENT_ACTUAL: _clip(m["i"] / rated_i / D.PER_MILLE, 15),
            D.MOTOR_TEMPERATURE: _clip(m["temp"] / D.TEMPERATURE_UNIT, 15),
            D.SAMPLE_STAMP: D.stamp_of(self._ms()),
            D.MODES_DISPLAY: self._get(D.MODES_OF_OPERATION),
            D.ERROR_CODE: self.error_code,
            D.ERROR_REGISTER: 0x01 if self.error_code else 0,
        }

    def _on_read(self, index: int, subindex: int, od: Any) -> int | None:
        if index in (D.STATUSWORD, D.VELOCITY_ACTUAL, D.TORQUE_ACTUAL, D.CURRENT_ACTUAL,
                     D.MOTOR_TEMPERATURE, D.SAMPLE_STAMP, D.MODES_DISPLAY, D.ERROR_CODE,
                     D.ERROR_REGISTER):
            with self.lock:
                return self._process_values()[index]
        return None

    # --- writes (SDO and RPDO) -------------------------------------------------------------

    def _on_write(self, index: int, subindex: int, od: Any, data: bytes) -> None:
        value = od.decode_raw(data)
        with self.lock:
            if index == D.CONTROLWORD:
                self._controlword(value)
            elif index == D.MODES_OF_OPERATION:
                if value not in D.SUPPORTED_MODES:
                    raise SdoAbortedError(ABORT_VALUE_RANGE)
                if self.state == "OPERATION ENABLED":
                    raise SdoAbortedError(ABORT_NOT_IN_STATE)
            elif index in (D.TARGET_VELOCITY, D.TARGET_TORQUE, D.MAX_TORQUE):
                self.node.data_store.setdefault(index, {})[subindex] = bytes(data)
                self._apply_setpoints()
            elif index == FAULT_INJECTION and value:
                self.inject_fault("injected motor/drive fault")

    def _controlword(self, cw: int) -> None:
        prev, self.cw = self.cw, cw
        s = self.state
        disable_voltage = cw & 0x82 == 0x00
        quick_stop = cw & 0x86 == 0x02
        shutdown = cw & 0x87 == 0x06
        switch_on = cw & 0x8F == 0x07
        enable = cw & 0x8F == 0x0F
        if s == "FAULT":
            if cw & 0x80 and not prev & 0x80 and not self.motor_failed:
                self.error_code = 0
                self._set_state("SWITCH ON DISABLED")
                self.node.emcy.reset()
            return
        if s == "SWITCH ON DISABLED":
            if shutdown:
                self._set_state("READY TO SWITCH ON")
        elif s == "READY TO SWITCH ON":
            if disable_voltage or quick_stop:
                self._set_state("SWITCH ON DISABLED")
            elif switch_on:
                self._set_state("SWITCHED ON")
            elif enable:
                self._set_state("SWITCHED ON")
                if not self.off3:
                    self._set_state("OPERATION ENABLED")
        elif s == "SWITCHED ON":
            if disable_voltage or quick_stop:
                self._set_state("SWITCH ON DISABLED")
            elif shutdown:
                self._set_state("READY TO SWITCH ON")
            elif enable and not self.off3:
                self._set_state("OPERATION ENABLED")
        elif s == "OPERATION ENABLED":
            if disable_voltage:
                self._set_state("SWITCH ON DISABLED")
            elif quick_stop:
                self._start_quick_stop()
            elif shutdown:
                self._set_state("READY TO SWITCH ON")
            elif switch_on:
                self._set_state("SWITCHED ON")
        elif s == "QUICK STOP ACTIVE":
            if disable_voltage:
                self._set_state("SWITCH ON DISABLED")

    def _set_state(self, state: str) -> None:
        changed = state != self.state
        self.state = state
        powered = state in ("OPERATION ENABLED", "QUICK STOP ACTIVE")
        if state != "QUICK STOP ACTIVE":
            self.qs_speed = None
        self.live.enable_motor(self.k, powered and not self.motor_failed and not self.silenced)
        if changed and state in ("QUICK STOP ACTIVE", "FAULT") and self.on_event is not None:
            self.on_event(f"drive {self.node_id} (motor {self.k + 1}): {state}")
        if state == "OPERATION ENABLED":
            self._apply_setpoints()

    def _apply_setpoints(self) -> None:
        """Target velocity / torque and max torque → the emulator's speed loop."""
        if self.state != "OPERATION ENABLED":
            return
        rated_tau = self._get(D.RATED_TORQUE) * 1e-3
        max_tau = self._get(D.MAX_TORQUE) * D.PER_MILLE * rated_tau
        mode = self._get(D.MODES_OF_OPERATION)
        if mode == D.MODE_PROFILE_TORQUE:
            # torque control on a speed-controlled motor: a speed set point at the speed limit
            # with the torque limit at the target torque saturates the speed loop at it
            tau = self._get(D.TARGET_TORQUE) * D.PER_MILLE * rated_tau
            w_max = self._get(D.MAX_MOTOR_SPEED) * D.RPM
            self.live.set_motor_torque_limit(self.k, min(abs(tau), max_tau))
            self.live.set_motor_speed(self.k, math.copysign(w_max, tau) if tau else 0.0)
        else:
            w = self._get(D.TARGET_VELOCITY) * D.VELOCITY_UNIT
            w_max = self._get(D.MAX_MOTOR_SPEED) * D.RPM
            self.live.set_motor_torque_limit(self.k, max_tau)
            self.live.set_motor_speed(self.k, max(-w_max, min(w_max, w)))

    def _start_quick_stop(self) -> None:
        self.qs_speed = float(self.live.motor(self.k)["w"])
        self._set_state("QUICK STOP ACTIVE")
        self.qs_speed = float(self.live.motor(self.k)["w"])

    def quick_stop(self) -> None:
        """OFF3 from the PLC (hard-wired): quick stop if enabled, no enabling until released.
        A dead drive (silence()) does nothing: its motor already gives no torque."""
        with self.lock:
            self.off3 = True
            if self.silenced:
                return
            if self.state == "OPERATION ENABLED":
                self._start_quick_stop()
            elif self.state in ("SWITCHED ON", "READY TO SWITCH ON"):
                self._set_state("SWITCH ON DISABLED")

    def release(self) -> None:
        """The PLC removes OFF3 (after its fault reset)."""
        with self.lock:
            self.off3 = False

    def inject_fault(self, why: str, code: int = D.EMCY_GENERIC) -> None:
        """Fail the motor and fault the drive: no torque, FAULT state, EMCY."""
        with self.lock:
            self.motor_failed = True
            self.live.fail_motor(self.k)
            self.error_code = code
            self._set_state("FAULT REACTION ACTIVE")
            self._set_state("FAULT")
            self._push_error(code)
            log.info("drive %d: fault %s (%s)", self.node_id, hex(code), why)
            if not self.silenced and self.node.nmt.state in ("OPERATIONAL", "PRE-OPERATIONAL"):
                self.node.emcy.send(code, 0x01)

    def _push_error(self, code: int) -> None:
        store = self.node.data_store.setdefault(D.ERROR_FIELD, {})
        old = [int.from_bytes(store.get(i, b"\0\0\0\0"), "little") for i in range(1, 5)]
        new = [code] + old[:3]
        for i, v in enumerate(new, 1):
            store[i] = v.to_bytes(4, "little")
        n = min(4, int.from_bytes(store.get(0, b"\0"), "little") + 1)
        store[0] = bytes([n])

    # --- a dead drive -------------------------------------------------------------------

    def silence(self) -> None:
        """The drive dies: it leaves the bus (heartbeat, TPDOs, EMCY stop; SDO, NMT and RPDOs go
        unanswered) and its motor gives no torque. Irreversible for this stand-in's life."""
        with self.lock:
            if self.silenced:
                return
            self.silenced = True
            self.node.nmt.stop_heartbeat()
            self._stop_pdos()
            try:
                self.network.unsubscribe(0, self._on_nmt)
            except (KeyError, ValueError):
                pass
            if self.node_id in self.network.nodes:
                del self.network[self.node_id]   # its SDO server and NMT slave leave the bus
            self.qs_speed = None
            self.live.enable_motor(self.k, False)
        log.info("drive %d: silenced (dead drive: off the bus, motor %d without torque)",
                 self.node_id, self.k + 1)

    # --- NMT ----------------------------------------------------------------------------

    def boot(self) -> None:
        """Power-on: boot-up message, PRE-OPERATIONAL, heartbeat, CiA 402 SWITCH ON DISABLED."""
        with self.lock:
            self._set_state("SWITCH ON DISABLED")
        self.node.nmt.state = "INITIALISING"     # sends the boot-up message
        self.node.nmt.state = "PRE-OPERATIONAL"  # starts the heartbeat from 0x1017

    def _on_nmt(self, can_id: int, data: bytes, timestamp: float) -> None:
        if len(data) < 2:
            return
        cmd, target = data[0], data[1]
        if target not in (0, self.node_id):
            return
        if cmd == 1:
            self._configure_pdos()
        elif cmd in (2, 128):
            self._stop_pdos()
        elif cmd in (129, 130):
            self._stop_pdos()
            self.node.nmt.stop_heartbeat()
            with self.lock:
                if cmd == 129:  # reset node: application parameters back to the EDS defaults
                    keep = {i: v for i, v in self.node.data_store.items() if i == D.ERROR_FIELD}
                    self.node.data_store.clear()
                    self.node.data_store.update(keep)
                else:           # reset communication: 0x1000–0x1FFF only
                    for i in [i for i in self.node.data_store if 0x1000 <= i < 0x2000
                              and i != D.ERROR_FIELD]:
                        del self.node.data_store[i]
                if not self.motor_failed:
                    self._set_state("SWITCH ON DISABLED")
                self.cw = 0
            self.node.nmt.state = "INITIALISING"
            self.node.nmt.state = "PRE-OPERATIONAL"

    def _configure_pdos(self) -> None:
        """Read the PDO configuration from the object dictionary (as a device does when it
        enters OPERATIONAL) and start serving the PDOs."""
        with self.lock:
            self._stop_pdos()
            tpdos = []
            for n, (comm, mapping) in enumerate(zip(D.TPDO_COMM, D.TPDO_MAP)):
                cob = self._get(comm, 1)
                if cob & 0x80000000:
                    continue
                layout = self._layout(mapping)
                tpdos.append({"n": n, "cob": cob & 0x7FF, "timer": self._get(comm, 5),
                              "layout": layout,
                              "last_ms": None,
                              "fmt": struct.Struct("<" + "".join(f for _, f in layout))})
            self._tpdos = tpdos
            self._last_sw_sent = None
            for comm, mapping in zip(D.RPDO_COMM, D.RPDO_MAP):
                cob = self._get(comm, 1)
                if cob & 0x80000000:
                    continue
                layout = self._layout(mapping)
                handler = self._rpdo_handler(layout)
                self.network.subscribe(cob & 0x7FF, handler)
                self._rpdo_subs.append((cob & 0x7FF, handler))

    def _layout(self, mapping: int) -> list[tuple[tuple[int, int], str]]:
        out = []
        for sub in range(1, self._get(mapping, 0) + 1):
            entry = self._get(mapping, sub)
            index, subindex, bits = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
            obj = self.node.object_dictionary[index]
            if not isinstance(obj, ODVariable):
                obj = obj[subindex]
            fmt = _STRUCT[obj.data_type]
            if struct.calcsize(fmt) * 8 != bits:
                raise ValueError(f"mapping 0x{entry:08X}: {bits} bits for a {fmt} object")
            out.append(((index, subindex), fmt))
        return out

    def _rpdo_handler(self, layout):
        fmt = struct.Struct("<" + "".join(f for _, f in layout))

        def on_rpdo(can_id: int, data: bytes, timestamp: float) -> None:
            if self.node.nmt.state != "OPERATIONAL" or len(data) < fmt.size:
                return
            values = fmt.unpack_from(bytes(data))
            for ((index, sub), f), v in zip(layout, values):
                try:
                    self.node.set_data(index, sub, struct.pack("<" + f, v))
                except SdoAbortedError as exc:  # a refused value in a PDO is ignored
                    log.info("drive %d: RPDO value for 0x%04X refused (%s)", self.node_id, index, exc)
        return on_rpdo

    def _stop_pdos(self) -> None:
        for cob, handler in self._rpdo_subs:
            try:
                self.network.unsubscribe(cob, handler)
            except (KeyError, ValueError):
                pass
        self._rpdo_subs = []
        self._tpdos = []

    # --- the 1 ms step ------------------------------------------------------------------

    def step(self) -> None:
        """One emulator step (1 ms of rig time); the caller holds the lock. TPDOs with an event
        timer of n ms go out when the drive clock (rig time in ms) is a multiple of n. A dead
        drive does nothing."""
        if self.silenced:
            return
        if self.state == "QUICK STOP ACTIVE" and self.qs_speed is not None:
            decel = self._get(D.QUICK_STOP_DECEL) * D.RPM
            w = self.qs_speed
            dw = decel * float(self.live.dt)
            self.qs_speed = 0.0 if abs(w) <= dw else w - math.copysign(dw, w)
            self.live.set_motor_speed(self.k, self.qs_speed)
            if self.qs_speed == 0.0 and abs(self.live.motor(self.k)["w"]) < 10 * D.RPM:
                self._set_state("SWITCH ON DISABLED")
        if not self._tpdos or self.node.nmt.state != "OPERATIONAL":
            return
        ms = self._ms()
        values = None
        sw = self.statusword()
        for tp in self._tpdos:
            due = bool(tp["timer"]) and ms % tp["timer"] == 0 and ms != tp["last_ms"]
            if tp["n"] == 1 and sw != self._last_sw_sent:
                due = True  # TPDO2 also on a statusword change
            if not due:
                continue
            if values is None:
                values = self._process_values()
            data = tp["fmt"].pack(*(values[i] if i in values else self._get(i, sub)
                                    for (i, sub), _f in tp["layout"]))
            self.network.send_message(tp["cob"], data)
            tp["last_ms"] = ms
            self.tpdo_sent[tp["n"]] += 1
            if tp["n"] == 1:
                self._last_sw_sent = sw


def _clip(x: float, bits: int) -> int:
    """Saturate to a signed `bits`+1-bit integer (a drive's value range; NaN reads as 0)."""
    if not math.isfinite(x):
        return 0 if math.isnan(x) else (1 << bits) - 1 if x > 0 else -((1 << bits) - 1)
    lim = (1 << bits) - 1
    return int(max(-lim, min(lim, round(x))))


class DriveStandIn:
    """The three drives on one canopen Network (a socketcand server's local bus, or any
    python-can bus for in-process tests)."""

    def __init__(self, bus: Any, live: Any, lock: threading.RLock,
                 node_ids: tuple[int, ...] = (1, 2, 3),
                 on_event: Callable[[str], None] | None = None) -> None:
        self.network = canopen.Network(bus)
        self.network.NOTIFIER_CYCLE = 0.1  # receive-thread poll: close within 0.1 s
        self.network.connect()
        self.nodes = [DriveNode(self.network, nid, k, live, lock, on_event)
                      for k, nid in enumerate(node_ids)]

    def silence(self, node_id: int) -> "DriveNode":
        """Kill drive `node_id` (DriveNode.silence): off the bus, its motor without torque.
        Raises KeyError for a node id the stand-in does not serve."""
        for n in self.nodes:
            if n.node_id == node_id:
                n.silence()
                return n
        raise KeyError(f"no drive at node id {node_id} "
                       f"(node ids {', '.join(str(n.node_id) for n in self.nodes)})")

    def boot(self) -> None:
        for n in self.nodes:
            n.boot()

    def step(self) -> None:
        for n in self.nodes:
            n.step()

    def stop_all(self) -> None:
        """The PLC's OFF3 to every drive."""
        for n in self.nodes:
            n.quick_stop()

    def release_all(self) -> None:
        for n in self.nodes:
            n.release()

    def close(self) -> None:
        for n in self.nodes:
            n.node.nmt.stop_heartbeat()
        self.network.disconnect()
