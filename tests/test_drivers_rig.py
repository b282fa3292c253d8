"""The DAQ facade (daq/rig.py) in one process against the PLC stand-in on a fake emulator: the
record, repeat handling, make-safe on errors, refusal while safe, reset."""

import asyncio
import threading

import pytest

from daq.rig import Rig, RigSafeError
from drivers_fake_live import FakeLiveJoint
from drivers_harness import await_for
from daq.settings import Settings
from simulators.plc import PlcProgram, PlcServer


def with_plc(body):
    async def main():
        live = FakeLiveJoint()
        lock = threading.RLock()
        srv = PlcServer(PlcProgram(live, lock), "127.0.0.1", 0)
        port = await srv.start()
        try:
            rig = Rig(Settings(plc_port=port, node_ids=(), plc_poll_hz=200.0))
            await body(rig, live, lock)
        finally:
            await srv.stop()
    asyncio.run(main())


def test_repeated_snapshots_are_counted_not_recorded():
    async def body(rig, live, lock):
        async with rig.session():
            # the emulator does not advance: polls repeat the one snapshot (waited for by
            # count, not by wall time: a loaded host polls late)
            assert await await_for(lambda: rig.repeats >= 20, timeout=10.0)
            assert len(rig.plc) == 1
            for k in range(5):
                with lock:
                    live.advance(0.01)
                assert await await_for(lambda: len(rig.plc) == k + 2, timeout=5.0)
            times = list(rig.plc["rig_time"])
            assert len(times) == 6 and all(b > a for a, b in zip(times, times[1:]))
            assert rig.poll_errors == 0 and rig.plc["latency"][0] > 0
    with_plc(body)


def test_acquisition_error_makes_the_rig_safe():
    async def body(rig, live, lock):
        async with rig.session():
            await rig.set_dyno_torque(20e3)

            def broken(status):
                raise ZeroDivisionError("bug in a check")
            rig.interlocks.check_status = broken
            assert await await_for(lambda: rig.events_of("make_safe"), timeout=2.0)
            assert "ZeroDivisionError" in rig.events_of("acquisition_error")[0].message
            assert rig.safe
            cmd = await rig.plc_client.read_commands()
            assert cmd["dyno_torque_sp"] == 0.0
    with_plc(body)


def test_refused_while_safe_until_reset():
    async def body(rig, live, lock):
        async with rig.session():
            await rig.set_dyno_torque(10e3)
            await rig.estop("unit test")
            assert [t.name for t in rig.trips] == ["estop"]
            with pytest.raises(RigSafeError, match="operator e-stop"):
                await rig.set_pressure(1e6)
            st = await rig.plc_client.read_status()
            assert st["fault_code"] == 2
            await rig.reset()
            assert not rig.safe
            await asyncio.sleep(0.05)
            st = await rig.plc_client.read_status()
            assert st["fault_code"] == 0 and st["plc_mode"] == 1
            await rig.set_dyno_torque(15e3)
            await asyncio.sleep(0.05)
            assert (await rig.plc_client.read_status())["torque_cmd"] == pytest.approx(15e3)
        kinds = [e.kind for e in rig.events]
        assert kinds.count("make_safe") == 2 and "reset" in kinds and kinds[-1] == "stopped"
    with_plc(body)


def test_session_makes_safe_when_the_body_raises():
    async def body(rig, live, lock):
        with pytest.raises(KeyError):
            async with rig.session():
                await rig.set_dyno_torque(25e3)
                raise KeyError("scheme bug")
        assert "KeyError" in rig.events_of("make_safe")[0].data["reason"]
        assert "written" in rig.events_of("make_safe")[0].data["plc"]
        assert live.dyno_sp == 0.0                  # the PLC passed the 0 N·m on to the dyno
    with_plc(body)
