"""The PLC stand-in and the PLC driver in one process (the protocol layer, on a fake emulator):
the PLC program's logic, the client's request limits, exceptions for malformed requests."""

import asyncio
import math
import socket
import struct
import threading

import pytest

from daq.plc import PlcClient, PlcError, register_map_for
from drivers_fake_live import FakeLiveJoint
from core.plc_map import REGISTER_MAP
from daq.settings import Settings
from simulators.plc import MODE_RUN, MODE_SAFE, PlcProgram, PlcServer

CB = REGISTER_MAP.signals["command_bits"]
SB = REGISTER_MAP.signals["status_bits"]


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def program(**kw):
    live = FakeLiveJoint()
    clock = Clock()
    stopped = []
    p = PlcProgram(live, threading.RLock(), clock=clock, stop_drives=lambda: stopped.append(1),
                   **kw)
    return p, live, clock, stopped


def commands(**values):
    return REGISTER_MAP.command.encode(values)


def test_watchdog_ramps_the_dyno_stops_drives_and_latches():
    p, live, clock, stopped = program(watchdog_s=0.5, ramp_rate=100e3)
    p.write_commands(commands(service_heartbeat=1, dyno_torque_sp=50e3, pressure_sp=5e6,
                              command_bits=CB.bit("pump_on")))
    p.scan()
    assert p.mode == MODE_RUN and live.dyno_sp == 50e3 and live.p_sp == 5e6 and live.pump
    clock.now += 0.4
    p.write_commands(commands(service_heartbeat=2, dyno_torque_sp=50e3, pressure_sp=5e6,
                              command_bits=CB.bit("pump_on")))
    clock.now += 0.45
    p.scan()
    assert p.mode == MODE_RUN                      # 0.45 s since the last change: still fine
    clock.now += 0.1
    p.scan()
    assert p.mode == MODE_SAFE and p.watchdog_fault and stopped == [1]
    st = p.status_values()
    assert int(st["status_bits"]) & SB.bit("watchdog_fault") and st["fault_code"] == 1
    assert live.p_sp == 0.0
    # the dynamometer ramps at 100 kN·m per rig second
    live.advance(0.2)
    p.scan()
    assert live.dyno_sp == pytest.approx(30e3)
    live.advance(0.5)
    p.scan()
    assert live.dyno_sp == 0.0
    # new set points are not applied while safe; a reset needs a live heartbeat
    p.write_commands(commands(service_heartbeat=2, dyno_torque_sp=50e3,
                              command_bits=CB.bit("fault_reset")))
    assert p.mode == MODE_SAFE
    p.write_commands(commands(service_heartbeat=3, dyno_torque_sp=50e3))
    p.write_commands(commands(service_heartbeat=3, dyno_torque_sp=50e3,
                              command_bits=CB.bit("fault_reset")))
    assert p.mode == MODE_RUN and live.dyno_sp == 50e3 and not p.drives_stopped


def test_estop_latches_and_stops_the_pump():
    p, live, clock, stopped = program()
    p.write_commands(commands(service_heartbeat=1, command_bits=CB.bit("pump_on")))
    p.scan()
    assert live.pump
    p.write_commands(commands(service_heartbeat=2, command_bits=CB.bit("pump_on") | CB.bit("estop")))
    assert p.mode == MODE_SAFE and p.estop and not live.pump and stopped == [1]
    assert p.fault_code == 2
    # reset refused while the e-stop command is still set
    p.write_commands(commands(service_heartbeat=3, command_bits=CB.bit("estop") | CB.bit("fault_reset")))
    assert p.mode == MODE_SAFE


def test_nonsense_commands_are_refused():
    p, *_ = program()
    assert p.validate_command(commands(dyno_torque_sp=math.nan)) == 3
    assert p.validate_command(commands(pressure_sp=-1.0)) == 3
    assert p.validate_command(commands(pressure_sp=30e6)) == 3
    assert p.validate_command(commands(dyno_torque_sp=250e3)) == 3
    assert p.validate_command(commands(valve_cmd=7)) == 3
    assert p.validate_command(commands(dyno_torque_sp=-120e3, pressure_sp=2e6, valve_cmd=2)) is None


def run_with_server(coro_fn, **program_kw):
    async def main():
        live = FakeLiveJoint()
        lock = threading.RLock()
        prog = PlcProgram(live, lock, **program_kw)
        srv = PlcServer(prog, "127.0.0.1", 0)
        port = await srv.start()
        try:
            return await coro_fn(port, prog, live)
        finally:
            await srv.stop()
    return asyncio.run(main())


def test_client_reads_and_writes_every_signal():
    async def body(port, prog, live):
        c = PlcClient(Settings(plc_port=port))
        await c.connect()
        try:
            await c.beat()
            values = {"dyno_torque_sp": -37.5e3, "pressure_sp": 42.5e5, "valve_cmd": 2,
                      "command_bits": CB.bit("pump_on") | CB.bit("cooling_on")}
            await c.write_commands(values)
            await c.beat()
            back = await c.read_commands()
            for k, v in values.items():
                assert back[k] == pytest.approx(v), k
            assert back["service_heartbeat"] == c.heartbeat
            await asyncio.sleep(0.05)  # a few PLC scans
            st = await c.read_status()
            assert set(st) == {s.name for s in REGISTER_MAP.status.signals}
            assert st["heartbeat_echo"] == c.heartbeat and st["plc_mode"] == MODE_RUN
            assert st["pressure_sp_applied"] == pytest.approx(42.5e5)
            assert st["torque_cmd"] == pytest.approx(-37.5e3)
            assert st["pump_state"] == 1 and st["valve_state"] == 2
            bits = int(st["status_bits"])
            assert bits & SB.bit("pump_running") and bits & SB.bit("cooling_on")
            assert st["temp_joint"] == pytest.approx(20.0)
            # single bits
            await c.set_command_bits(cooling_on=False)
            assert int((await c.read_commands())["command_bits"]) == CB.bit("pump_on")
            # refusals come back as Modbus exceptions
            with pytest.raises(PlcError) as e:
                await c.write_commands({"pressure_sp": math.nan})
            assert e.value.exception_code == 3
            with pytest.raises(PlcError) as e:
                await c.write_registers(0, [1])          # status block is read-only
            assert e.value.exception_code == 2
            with pytest.raises(PlcError) as e:
                await c.read_registers(REGISTER_MAP.status.count, 5)  # the gap
            assert e.value.exception_code == 2
            assert c.connected  # none of that broke the link
            assert (await c.read_status())["plc_mode"] == MODE_RUN
        finally:
            c.close()
    run_with_server(body)


def test_little_endian_plc_map_is_honoured_end_to_end():
    async def body(port, prog, live):
        s = Settings(plc_port=port, plc_word_order="little")
        c = PlcClient(s)
        assert c.map.signals["pressure_sp"].word_order == "little"
        await c.connect()
        try:
            await c.beat()
            await c.write_commands({"pressure_sp": 12.25e5})
            await asyncio.sleep(0.03)
            assert (await c.read_status())["pressure_sp_applied"] == pytest.approx(12.25e5)
        finally:
            c.close()
    run_with_server(body, regmap=register_map_for(Settings(plc_word_order="little")))


class RecordingClient:
    """Stands in for pymodbus' client to see what requests PlcClient makes."""

    def __init__(self):
        self.reads, self.writes = [], []

    async def read_holding_registers(self, address, count, device_id):
        self.reads.append((address, count))
        return type("R", (), {"registers": [address + i for i in range(count)],
                              "isError": lambda self: False})()

    async def write_registers(self, address, values, device_id):
        self.writes.append((address, len(values)))
        return type("R", (), {"isError": lambda self: False})()


def test_client_enforces_modbus_request_limits():
    c = PlcClient(Settings())
    rec = RecordingClient()
    c.client = rec

    async def body():
        regs = await c.read_registers(1000, 300)
        assert regs == list(range(1000, 1300))
        await c.write_registers(2000, list(range(250)))
    asyncio.run(body())
    assert rec.reads == [(1000, 125), (1125, 125), (1250, 50)]
    assert rec.writes == [(2000, 123), (2123, 123), (2246, 4)]


class SilentClient:
    """A Modbus client whose requests never complete (a library that lost its own timeout)."""

    async def read_holding_registers(self, address, count, device_id):
        await asyncio.sleep(3600.0)

    async def write_registers(self, address, values, device_id):
        await asyncio.sleep(3600.0)


def test_a_request_the_library_never_answers_is_a_link_error_within_its_bound():
    from daq.plc import PlcLinkError
    from daq.rig import _cancel_all
    c = PlcClient(Settings(plc_timeout=0.5, plc_retries=1))
    c.client = SilentClient()
    assert c.request_bound == pytest.approx(1.5)

    async def body():
        loop = asyncio.get_running_loop()
        for call in (c.read_status(), c.beat()):
            t0 = loop.time()
            with pytest.raises(PlcLinkError, match="no answer within 1.50 s"):
                await call
            assert loop.time() - t0 < 3.0
        # and the heartbeat loop survives it: it keeps trying, and stops when cancelled
        hb = asyncio.create_task(c.heartbeat_loop(0.05))
        await asyncio.sleep(3.2)
        assert not await _cancel_all([hb], timeout=2.0)
    asyncio.run(body())
    assert c.link_errors >= 3 and c.requests >= 4


def raw_request(port, pdu, unit=1, tid=7):
    with socket.create_connection(("127.0.0.1", port), timeout=2.0) as s:
        s.sendall(struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu)
        return s.recv(300)


@pytest.mark.parametrize("name,pdu,reply_fc,code", [
    ("read 126 registers", struct.pack(">BHH", 3, 0, 126), 0x83, 3),
    ("read 0 registers", struct.pack(">BHH", 3, 0, 0), 0x83, 3),
    ("input registers 200", struct.pack(">BHH", 4, 0, 200), 0x84, 3),
    ("truncated read", struct.pack(">BH", 3, 0), 0x83, 3),
    ("write 124 registers", struct.pack(">BHHB", 16, 100, 124, 248) + bytes(248), 0x90, 3),
    ("byte count mismatch", struct.pack(">BHHB", 16, 100, 2, 2) + b"\x00\x01", 0x90, 3),
    ("write status block", struct.pack(">BHHB", 16, 0, 1, 2) + b"\x00\x01", 0x90, 2),
    ("write beyond command block", struct.pack(">BHHB", 16, 106, 4, 8) + bytes(8), 0x90, 2),
    ("read unmapped", struct.pack(">BHH", 3, 500, 2), 0x83, 2),
    ("read-write 126", struct.pack(">BHHHHB", 23, 0, 126, 100, 1, 2) + b"\0\1", 0x97, 3),
    ("write coils", struct.pack(">BHHBB", 15, 100, 8, 1, 0xFF), 0x8F, 1),
    ("read coils", struct.pack(">BHH", 1, 0, 8), 0x81, 1),
    ("unknown function", struct.pack(">BHH", 0x41, 0, 1), None, 1),
])
def test_malformed_and_over_long_requests_get_exceptions(name, pdu, reply_fc, code):
    async def body(port, prog, live):
        loop = asyncio.get_running_loop()
        reply = await loop.run_in_executor(None, raw_request, port, pdu)
        tid, proto, length, unit, fc = struct.unpack(">HHHBB", reply[:8])
        assert tid == 7 and proto == 0 and unit == 1
        assert fc & 0x80, f"{name}: no exception ({reply.hex()})"
        if reply_fc is not None:
            assert fc == reply_fc
        assert reply[8] == code
        # the server is still there and serves a good request
        ok = await loop.run_in_executor(None, raw_request, port, struct.pack(">BHH", 3, 0, 2))
        assert ok[7] == 3 and ok[8] == 4
    run_with_server(body)


def test_garbage_streams_do_not_crash_the_server():
    async def body(port, prog, live):
        loop = asyncio.get_running_loop()

        def abuse():
            for junk in (b"\xff" * 300, b"GET / HTTP/1.0\r\n\r\n", struct.pack(">HHHB", 1, 5, 6, 1),
                         struct.pack(">HHHB", 1, 0, 2000, 1) + b"\x03"):
                with socket.create_connection(("127.0.0.1", port), timeout=1.0) as s:
                    s.sendall(junk)
                    s.settimeout(0.3)
                    try:
                        s.recv(100)
                    except OSError:
                        pass
        await loop.run_in_executor(None, abuse)
        ok = await loop.run_in_executor(None, raw_request, port, struct.pack(">BHH", 3, 0, 2))
        assert ok[7] == 3
    run_with_server(body)


def test_the_longest_heartbeat_gap_counts_the_gap_still_open():
    """A wedged service whose first poll after the wedge reads the PLC's trip has not beaten
    since: the gap it reports is the open one, not the short ones acknowledged before it."""
    import time
    c = PlcClient(Settings())
    assert c.longest_beat_gap() == 0.0                      # never beaten: nothing to say
    c.max_beat_gap, c.last_beat = 0.12, time.monotonic() - 1.5
    assert 1.5 <= c.longest_beat_gap() < 2.5
    c.last_beat = time.monotonic()                          # it beat again: the record holds
    c.max_beat_gap = 1.6
    assert c.longest_beat_gap() == pytest.approx(1.6, abs=0.05)
