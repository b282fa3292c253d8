"""The drive side end to end: `rig emulate` as a separate process, the CANopen master over the
socketcand protocol on loopback, python-can's own logger recording the traffic in a third
process, and the drive-loss policy (continue on two motors, safe after a second loss)."""

import asyncio
import collections
import signal
import subprocess
import sys
import time

import canopen
import pytest

from daq.rig import Rig
from drivers_harness import REPO, SLACK_S, SLACK_STANDIN, StandinProcess, await_for
from core import drive_od as D
from daq.settings import Settings
from simulators.drives import FAULT_INJECTION

# each test takes seconds; a stalled protocol exchange fails after 3 min, not the suite's 15
pytestmark = pytest.mark.timeout(180)


@pytest.fixture
def standin():
    with StandinProcess([]) as sp:
        yield sp


def settings_for(sp, **kw):
    return Settings(plc_port=sp.plc_port, can_port=sp.can_port, **kw)


@pytest.fixture
def tolerant_standin():
    """A stand-in whose PLC watchdog allows SLACK_S of heartbeat silence: for tests of the data
    streams, not of the watchdogs (a stall of a loaded CI host must not trip them)."""
    with StandinProcess(SLACK_STANDIN) as sp:
        yield sp


def test_drives_enabled_tpdos_at_rate_and_can_logger_records(tolerant_standin, tmp_path):
    log_file = tmp_path / "traffic.log"
    logger = subprocess.Popen(
        [sys.executable, "-m", "can.logger", "-i", "socketcand", "-c", "can0", "-f",
         str(log_file), "--bus-kwargs", "host=127.0.0.1", f"port={tolerant_standin.can_port}"],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        time.sleep(1.0)                                   # logger connected before the master
        assert logger.poll() is None, logger.stdout.read()

        async def body():
            # the watchdogs are tested by the drive-loss tests below and in test_standin_interlocks
            rig = Rig(settings_for(tolerant_standin, plc_link_timeout=SLACK_S,
                                   drive_heartbeat_timeout=SLACK_S))
            async with rig.session():
                assert [d.state for d in rig.drives.drives] == ["OPERATION ENABLED"] * 3, (
                    [(e.kind, e.message) for e in rig.events])
                await rig.set_motor_speed(100.0)
                # 2000 samples a drive: 2 s at the configured 1 kHz; a loaded host may slow the
                # stand-in (never lose samples), so wait for the count, not for a wall time
                assert await await_for(
                    lambda: all(len(d.stream) > 2000 for d in rig.drives.drives), timeout=20.0)
                await asyncio.sleep(0.1)
                rig_time_now = rig.plc["rig_time"][-1]
                for d in rig.drives.drives:
                    st = d.stream
                    stamps, t = list(st.stamp), list(st.t)
                    # the configured 1 kHz on the drive clock: one sample every ms, none lost
                    assert st.period_ms == 1
                    assert stamps == list(range(stamps[0], stamps[0] + len(stamps)))
                    assert st.lost == st.duplicated == st.irregular == 0
                    assert len(stamps) > 2000
                    # drive clock and PLC clock are the same rig clock
                    assert abs(stamps[-1] - rig_time_now * 1e3) < 300
                    # the host's receive stamps run forwards (their rate is the host's load:
                    # bench/, not a test)
                    assert all(b >= a for a, b in zip(t, t[1:]))
                    assert st.w[-1] == pytest.approx(100.0, rel=0.05)
                    assert 15.0 < d.temperature < 40.0
                    assert D.state_of(d.statusword) == "OPERATION ENABLED"
                return rig
        rig = asyncio.run(body())
        assert rig.events_of("make_safe")
    finally:
        logger.send_signal(signal.SIGINT)
        try:
            logger.wait(timeout=10)
        except subprocess.TimeoutExpired:
            logger.kill()
    # the independent record: canutils log lines "(ts) can0 ID#DATA"
    ids = collections.Counter()
    for line in log_file.read_text().splitlines():
        ids[int(line.split()[2].split("#")[0], 16)] += 1
    assert ids[0x000] >= 6                                   # NMT pre-op/start for 3 nodes
    for nid in (1, 2, 3):
        assert ids[0x600 + nid] > 20 and ids[0x580 + nid] == ids[0x600 + nid]   # SDO pairs
        assert ids[0x700 + nid] >= 20                       # heartbeats (100 ms)
        assert ids[0x180 + nid] > 2000                      # TPDO1 at 1 kHz for > 2 s
        assert ids[0x280 + nid] > 20                        # TPDO2
        assert ids[0x200 + nid] >= 2                        # RPDO1 set points


def silence_heartbeat(port, node_id):
    """A second CANopen client sets a drive's heartbeat producer time to 0 (SDO)."""
    net = canopen.Network()
    net.connect(interface="socketcand", channel="can0", host="127.0.0.1", port=port)
    try:
        net.add_node(node_id, str(D.EDS_PATH)).sdo[D.HEARTBEAT_TIME].raw = 0
    finally:
        net.disconnect()


def inject_fault(port, node_id):
    net = canopen.Network()
    net.connect(interface="socketcand", channel="can0", host="127.0.0.1", port=port)
    try:
        net.add_node(node_id, str(D.EDS_PATH)).sdo.download(FAULT_INJECTION, 0, b"\x01")
    finally:
        net.disconnect()


def test_lost_heartbeat_continue_on_two_then_safe_on_the_second(standin):
    async def body():
        rig = Rig(settings_for(standin))
        async with rig.session():
            await rig.set_motor_speed(100.0)
            await asyncio.sleep(0.5)
            await asyncio.to_thread(silence_heartbeat, standin.can_port, 2)
            assert await await_for(lambda: rig.events_of("degraded"), timeout=2.0)
            assert not rig.safe and rig.trips == [], rig.events
            assert [d.active for d in rig.drives.drives] == [True, False, True], rig.events
            dropped = [e for e in rig.events if e.kind == "dropped"]
            assert len(dropped) == 1 and "heartbeat lost" in dropped[0].message
            assert rig.events_of("degraded")[0].data["active"] == [1, 3]
            # the joint continues on motors 1 and 3: their streams go on at speed
            n1, n3 = len(rig.drives.drives[0].stream), len(rig.drives.drives[2].stream)
            # 900 more samples each (0.9 s at 1 kHz; a loaded host may slow the stand-in)
            assert await await_for(lambda: len(rig.drives.drives[0].stream) - n1 > 900
                                   and len(rig.drives.drives[2].stream) - n3 > 900, timeout=10.0)
            for d in (rig.drives.drives[0], rig.drives.drives[2]):
                assert d.stream.lost == 0
                assert d.stream.w[-1] == pytest.approx(100.0, rel=0.05)
            # and so does the joint: the output turns at the motor speed over the reduction
            assert rig.last_status["qd"] == pytest.approx(100.0 / 11000.0, rel=0.1)
            assert D.state_of(rig.drives.drives[1].statusword) == "SWITCH ON DISABLED"
            await rig.set_motor_speed(120.0)             # set points still accepted
            # a second lost drive makes the rig safe
            await asyncio.to_thread(silence_heartbeat, standin.can_port, 3)
            assert await await_for(lambda: rig.safe, timeout=2.0)
            assert [t.name for t in rig.trips] == ["drive_link"]
            assert await await_for(
                lambda: D.state_of(rig.drives.drives[0].statusword) != "OPERATION ENABLED",
                timeout=1.0)
        return rig
    rig = asyncio.run(body())
    assert rig.events_of("make_safe")[0].data["reason"] == "interlock drive_link"


def test_emcy_drops_the_drive_and_the_joint_continues(standin):
    async def body():
        rig = Rig(settings_for(standin))
        async with rig.session():
            await rig.set_motor_speed(80.0)
            await asyncio.sleep(0.3)
            await asyncio.to_thread(inject_fault, standin.can_port, 1)
            assert await await_for(lambda: rig.events_of("degraded"), timeout=2.0)
            assert [d.active for d in rig.drives.drives] == [False, True, True]
            assert any(e.kind == "emcy" and "0x1000" in e.message for e in rig.events)
            assert await await_for(
                lambda: D.state_of(rig.drives.drives[0].statusword) == "FAULT", timeout=1.0)
            assert not rig.safe
            await asyncio.sleep(0.5)
            assert rig.drives.drives[1].stream.w[-1] == pytest.approx(80.0, rel=0.05)
    asyncio.run(body())
