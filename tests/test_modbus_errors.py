"""The PLC stand-in's Modbus behaviour at the edges, seen from raw Modbus TCP frames and from
pymodbus' own client (core/plc_map.py, "Exceptions and unit identifier"): a missing register
is answered with exception 02, any unit id is answered as MB_SERVER answers it (served, the id
echoed), and none of it puts a traceback or a protocol frame dump in the stand-in's output."""

import asyncio
import logging
import socket
import struct
import time

import pytest
from pymodbus.client import AsyncModbusTcpClient

from core.logging_setup import configure_logging
from core.plc_map import REGISTER_MAP
from drivers_harness import StandinProcess

M = REGISTER_MAP


@pytest.fixture(scope="module")
def standin():
    with StandinProcess(["--no-can"]) as sp:
        yield sp


def raw(port: int, pdu: bytes, unit: int = 1, tid: int = 9) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=2.0) as s:
        s.sendall(struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu)
        return s.recv(300)


@pytest.mark.parametrize("pdu, fc", [
    (struct.pack(">BHH", 3, 500, 2), 0x83),                              # past every block
    (struct.pack(">BHH", 3, M.status.start + M.status.count, 2), 0x83),  # in the gap
    (struct.pack(">BHH", 4, 500, 2), 0x84),
    (struct.pack(">BHH", 6, 500, 7), 0x86),
    (struct.pack(">BHH", 6, M.status.start, 7), 0x86),                  # read-only block
])
def test_missing_register_is_answered_with_illegal_data_address(standin, pdu, fc):
    reply = raw(standin.plc_port, pdu)
    assert reply[:2] == struct.pack(">H", 9) and reply[6] == 1
    assert reply[7] == fc and reply[8] == 0x02, reply.hex()


@pytest.mark.parametrize("unit", [0, 2, 7, 247, 255])
def test_any_unit_id_is_served_and_echoed(standin, unit):
    pdu = struct.pack(">BHH", 3, M.status.start, M.status.count)
    t0 = time.monotonic()
    reply = raw(standin.plc_port, pdu, unit=unit)
    assert time.monotonic() - t0 < 1.5            # an answer, not a client time-out
    assert reply[6] == unit and reply[7] == 3 and reply[8] == 2 * M.status.count, reply.hex()


def test_pymodbus_client_with_another_unit_id_reads_and_writes(standin):
    async def body():
        c = AsyncModbusTcpClient("127.0.0.1", port=standin.plc_port, timeout=2, retries=0)
        await c.connect()
        try:
            r = await c.read_holding_registers(M.status.start, count=M.status.count, device_id=42)
            assert not r.isError() and len(r.registers) == M.status.count
            bad = await c.read_holding_registers(900, count=1, device_id=42)
            assert bad.isError() and bad.exception_code == 0x02
            sig = M.signals["valve_cmd"]
            w = await c.write_register(sig.address, 1, device_id=9)
            assert not w.isError()
            back = await c.read_holding_registers(sig.address, count=1, device_id=1)
            assert back.registers == [1]     # one data block, whatever the unit id
        finally:
            c.close()
    asyncio.run(body())


def test_standin_output_has_no_traceback_or_frame_dump(standin):
    for unit in (0, 5, 255):
        raw(standin.plc_port, struct.pack(">BHH", 3, 0, 2), unit=unit)
        raw(standin.plc_port, struct.pack(">BHH", 3, 900, 2), unit=unit)
    time.sleep(0.3)
    out = "\n".join(standin.lines)
    assert "Traceback" not in out and ">>>>>" not in out and "KeyError" not in out, out
    assert standin.proc.poll() is None


def test_configured_logging_keeps_pymodbus_frames_behind_debug(capsys):
    import io
    root = logging.getLogger()
    saved = root.level, list(root.handlers)
    try:
        buf = io.StringIO()
        configure_logging("INFO", stream=buf)
        log = logging.getLogger("pymodbus.logging")
        log.debug("send: 0x0 0x1")
        log.info("connected")                     # held at WARNING below DEBUG
        log.error("Datastore unable to fulfill request\n>>>>> recv: 0x0 0x9 0x0")
        text = buf.getvalue()
        assert "Datastore unable" in text and ">>>>>" not in text and "send:" not in text
        assert "connected" not in text
        buf = io.StringIO()
        configure_logging("DEBUG", stream=buf)
        log.debug("send: 0x0 0x1")
        assert "send: 0x0 0x1" in buf.getvalue()
        buf = io.StringIO()
        configure_logging("warning", json_logs=True, stream=buf)
        logging.getLogger("daq.plc").warning("PLC link lost")
        import json
        rec = json.loads(buf.getvalue().strip().splitlines()[-1])
        assert rec["level"] == "WARNING" and rec["logger"] == "daq.plc"
        assert rec["message"] == "PLC link lost" and rec["time"].endswith("Z")
    finally:
        for h in list(root.handlers):
            if h not in saved[1]:
                root.removeHandler(h)
        root.setLevel(saved[0])


def test_unknown_log_level_is_refused():
    with pytest.raises(ValueError, match="DEBUG"):
        configure_logging("chatty")
