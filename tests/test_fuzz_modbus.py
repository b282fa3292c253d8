"""Property-based fuzz of the PLC stand-in's Modbus TCP server (issue 13): malformed frames (bad
MBAP lengths, truncated headers, unknown function codes, short PDUs), any unit id, and writes to
the command block that are out of range or outside it. After every frame the stand-in must stay
up (a valid request on a new connection is answered) and safe (the command block is what the
service last wrote, the set points applied are unchanged, a latched e-stop stays latched).
Raw sockets to 127.0.0.1 only."""

from __future__ import annotations

import math
import socket
import struct
import threading
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.plc_map import REGISTER_MAP
from simulators.process import StandinProcess

FUZZ = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])

CMD = REGISTER_MAP.command
STATUS = REGISTER_MAP.status
CB = REGISTER_MAP.signals["command_bits"]
SB = REGISTER_MAP.signals["status_bits"]
HEARTBEAT_ADDR = REGISTER_MAP.signals[REGISTER_MAP.heartbeat].address
KNOWN_FCS = (1, 2, 3, 4, 5, 6, 15, 16, 22, 23, 43)
"""Function codes pymodbus decodes; every other code must be answered with ILLEGAL FUNCTION."""


def mb_request(port: int, pdu: bytes, unit: int = 1, tid: int = 7, timeout: float = 3.0) -> bytes:
    """One well-framed request on a new connection; returns the reply (b'' if none)."""
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall(struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu)
        try:
            return s.recv(512)
        except socket.timeout:
            return b""


def send_raw(port: int, frame: bytes) -> None:
    """Send bytes as they are, read what comes back within a short while, close."""
    with socket.create_connection(("127.0.0.1", port), timeout=3.0) as s:
        s.sendall(frame)
        s.settimeout(0.05)
        try:
            s.recv(512)
        except (socket.timeout, ConnectionError):
            pass


def read_block(port: int, start: int, count: int) -> list[int]:
    reply = mb_request(port, struct.pack(">BHH", 3, start, count), tid=99)
    assert len(reply) == 9 + 2 * count and reply[7] == 3, f"no valid answer: {reply.hex()}"
    return list(struct.unpack(f">{count}H", reply[9:]))


class Heartbeat:
    """The service's heartbeat, written on its own connection every 50 ms (FC 6), so the PLC
    stays in RUN and its watchdog is not what the fuzz observes."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        n = 1
        while not self.stop.wait(0.05):
            n = n % 30000 + 1
            try:
                mb_request(self.port, struct.pack(">BHH", 6, HEARTBEAT_ADDR, n), tid=5)
            except OSError:
                pass


@pytest.fixture(scope="module", params=["running", "e-stopped"])
def plc(request):
    """A stand-in (PLC only) in a known state: RUN with zero set points and the pump off, or
    with the e-stop latched (safe state). Yields (port, baseline command block, state)."""
    with StandinProcess(["--no-can", "--watchdog", "10"]) as sp:
        port = sp.plc_port
        bits = CB.bit("estop") if request.param == "e-stopped" else 0
        regs = CMD.encode({"service_heartbeat": 1, "command_bits": bits, "valve_cmd": 0,
                           "dyno_torque_sp": 0.0, "pressure_sp": 0.0})
        reply = mb_request(port, struct.pack(">BHHB", 16, CMD.start, CMD.count, 2 * CMD.count)
                        + struct.pack(f">{CMD.count}H", *regs))
        assert reply[7] == 16, reply.hex()
        hb = Heartbeat(port)
        hb.thread.start()
        try:
            deadline = time.monotonic() + 10.0
            while time.monotonic() < deadline:
                st = STATUS.decode(read_block(port, STATUS.start, STATUS.count))
                if st["plc_mode"] == (2 if bits else 1):
                    break
                time.sleep(0.05)
            base = read_block(port, CMD.start, CMD.count)
            yield port, base, request.param, sp
        finally:
            hb.stop.set()
            hb.thread.join(timeout=2.0)


def assert_up_and_safe(port: int, base: list[int], state: str, sp: StandinProcess) -> None:
    assert sp.proc.poll() is None, "the stand-in died:\n" + "\n".join(sp.lines[-20:])
    now = read_block(port, CMD.start, CMD.count)
    hb = HEARTBEAT_ADDR - CMD.start
    assert now[:hb] + now[hb + 1:] == base[:hb] + base[hb + 1:], "garbage changed the command block"
    st = STATUS.decode(read_block(port, STATUS.start, STATUS.count))
    bits = int(st["status_bits"])
    assert st["pump_state"] == 0 and st["pressure_sp_applied"] == 0.0
    assert math.isfinite(st["torque_cmd"]) and abs(st["torque_cmd"]) < 1.0
    assert not bits & SB.bit("homing")
    if state == "e-stopped":
        assert st["plc_mode"] == 2 and bits & SB.bit("estop") and bits & SB.bit("safe_state")
    else:
        assert st["plc_mode"] == 1 and st["fault_code"] == 0


# --- frames ---------------------------------------------------------------------------------------

unit_ids = st.integers(0, 255)


@st.composite
def bad_length_frames(draw) -> bytes:
    """A plausible PDU under an MBAP length that does not match it (shorter, longer, zero)."""
    pdu = draw(st.sampled_from([struct.pack(">BHH", 3, STATUS.start, 4),
                                struct.pack(">BHH", 6, CMD.start + 1, CB.bit("pump_on")),
                                struct.pack(">BHHB", 16, CMD.start, 1, 2) + b"\x00\x04"]))
    length = draw(st.integers(0, 300).filter(lambda n: n != len(pdu) + 1))
    return struct.pack(">HHHB", draw(st.integers(0, 65535)), 0, length, draw(unit_ids)) + pdu


@st.composite
def truncated_headers(draw) -> bytes:
    full = struct.pack(">HHHB", draw(st.integers(0, 65535)), draw(st.sampled_from([0, 1, 0xFFFF])),
                       draw(st.integers(0, 65535)), draw(unit_ids))
    return full[: draw(st.integers(1, 6))]


@st.composite
def unknown_function_frames(draw) -> bytes:
    fc = draw(st.integers(0, 255).filter(lambda c: c not in KNOWN_FCS))
    body = draw(st.binary(max_size=20))
    pdu = bytes([fc]) + body
    return struct.pack(">HHHB", 3, 0, len(pdu) + 1, draw(unit_ids)) + pdu


@st.composite
def short_pdus(draw) -> bytes:
    """A known function code with its fields cut short (or a byte count that lies)."""
    fc = draw(st.sampled_from([3, 4, 6, 16, 23]))
    full = {3: struct.pack(">BHH", 3, 0, 4), 4: struct.pack(">BHH", 4, 0, 4),
            6: struct.pack(">BHH", 6, CMD.start + 1, 0),
            16: struct.pack(">BHHB", 16, CMD.start, 2, 4) + struct.pack(">f", 1e3),
            23: struct.pack(">BHHHHB", 23, 0, 2, CMD.start + 3, 2, 4) + struct.pack(">f", 1e3)}[fc]
    cut = draw(st.integers(1, len(full) - 1))
    pdu = full[:cut]
    return struct.pack(">HHHB", 4, 0, len(pdu) + 1, draw(unit_ids)) + pdu


def _real(value: float) -> list[int]:
    hi, lo = struct.unpack(">HH", struct.pack(">f", value))
    return [hi, lo]


@st.composite
def out_of_range_writes(draw) -> bytes:
    """Writes the PLC must refuse whole: a set point that is NaN, infinite or beyond its range, an
    unknown valve command — carrying dangerous bits (pump on, fault reset, home) along — or any
    write outside the command block."""
    which = draw(st.sampled_from(["dyno", "pressure", "valve", "outside"]))
    danger = CB.bit("pump_on") | CB.bit("fault_reset") | CB.bit("home") | CB.bit("cooling_on")
    regs = CMD.encode({"service_heartbeat": draw(st.integers(1, 30000)),
                       "command_bits": draw(st.integers(0, 0xFFFF)) | danger,
                       "valve_cmd": 0, "dyno_torque_sp": 0.0, "pressure_sp": 0.0})
    bad_real = draw(st.one_of(st.sampled_from([math.nan, math.inf, -math.inf]),
                              st.floats(200.001, 3e4), st.floats(-3e4, -200.001)))
    if which == "dyno":
        o = REGISTER_MAP.signals["dyno_torque_sp"].address - CMD.start
        regs[o:o + 2] = _real(bad_real)            # raw kN·m: beyond ±200 kN·m
    elif which == "pressure":
        o = REGISTER_MAP.signals["pressure_sp"].address - CMD.start
        regs[o:o + 2] = _real(draw(st.one_of(st.sampled_from([math.nan, math.inf, -1.0]),
                                             st.floats(250.001, 1e6))))   # raw bar: > 25 MPa
    elif which == "valve":
        o = REGISTER_MAP.signals["valve_cmd"].address - CMD.start
        regs[o] = draw(st.integers(3, 0xFFFF))
    if which == "outside":
        start = draw(st.one_of(st.integers(0, CMD.start - 1),
                               st.integers(CMD.start + CMD.count, 0xFFFF)))
        count = draw(st.integers(1, 4))
        values = [draw(st.integers(0, 0xFFFF)) for _ in range(count)]
        pdu = struct.pack(">BHHB", 16, start, count, 2 * count) + struct.pack(f">{count}H", *values)
    elif draw(st.booleans()):
        pdu = struct.pack(">BHHB", 16, CMD.start, CMD.count, 2 * CMD.count) \
            + struct.pack(f">{CMD.count}H", *regs)
    else:   # FC 23: read the status, write the bad command block
        pdu = struct.pack(">BHHHHB", 23, STATUS.start, 2, CMD.start, CMD.count, 2 * CMD.count) \
            + struct.pack(f">{CMD.count}H", *regs)
    return struct.pack(">HHHB", 11, 0, len(pdu) + 1, draw(unit_ids)) + pdu


@FUZZ
@given(frame=st.one_of(bad_length_frames(), truncated_headers(), unknown_function_frames(),
                       short_pdus(), out_of_range_writes(),
                       st.binary(min_size=1, max_size=40).filter(
                           lambda b: len(b) < 8 or b[7] not in (5, 6, 15, 16, 22, 23))))
def test_garbage_never_crashes_nor_commands_the_standin(plc, frame):
    port, base, state, sp = plc
    send_raw(port, frame)
    assert_up_and_safe(port, base, state, sp)


@FUZZ
@given(write=out_of_range_writes())
def test_out_of_range_writes_get_an_exception_reply(plc, write):
    """Refused, not ignored: the reply is a Modbus exception under the request's own function
    code (so the service learns its write did not take)."""
    port, base, state, sp = plc
    with socket.create_connection(("127.0.0.1", port), timeout=3.0) as s:
        s.sendall(write)
        reply = s.recv(512)
    fc = write[7]
    assert len(reply) >= 9 and reply[7] == fc | 0x80 and reply[8] in (2, 3), reply.hex()
    assert_up_and_safe(port, base, state, sp)
