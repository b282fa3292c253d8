"""The drive stand-in, the socketcand server and the CANopen master in one process (protocol
layer, on a fake emulator): NMT/SDO/PDO/EMCY/heartbeat behaviour and the socketcand protocol."""

import socket
import threading
import time

import can
import canopen
import pytest

from daq.drives import DriveError, DriveMaster
from drivers_fake_live import FakeLiveJoint
from core import drive_od as D
from daq.settings import Settings
from simulators.drives import FAULT_INJECTION, DriveStandIn
from simulators.socketcand_server import SocketcandServer


class CanBench:
    """Fake emulator + drive stand-in paced at 1 kHz on a bus (socketcand server or virtual)."""

    def __init__(self, interface="socketcand", channel="can0"):
        self.live = FakeLiveJoint()
        self.lock = threading.RLock()
        self.server = None
        if interface == "socketcand":
            self.server = SocketcandServer(port=0, channel=channel)
            self.port = self.server.start()
            bus = self.server.local_bus()
        else:
            self.port = 0
            bus = can.Bus(interface="virtual", channel=channel)
        self.drives = DriveStandIn(bus, self.live, self.lock)
        self.drives.boot()
        self.stop_evt = threading.Event()
        self.thread = threading.Thread(target=self._pace, daemon=True)
        self.thread.start()

    def _pace(self):
        t0, n = time.monotonic(), 0
        while not self.stop_evt.is_set():
            target = int((time.monotonic() - t0) * 1000)
            while n < target:
                with self.lock:
                    self.live.advance(1e-3)
                    self.drives.step()
                n += 1
            time.sleep(0.0005)

    def close(self):
        self.stop_evt.set()
        self.thread.join()
        self.drives.close()
        if self.server:
            self.server.stop()


@pytest.fixture
def bench():
    b = CanBench()
    yield b
    b.close()


def master_for(bench, events=None, **kw):
    s = Settings(can_port=bench.port, **kw)
    m = DriveMaster(s, on_event=(events.append if events is not None else None))
    m.open()
    return m


def wait_for(cond, timeout=3.0, step=0.01):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(step)
    return cond()


def test_three_drives_to_operation_enabled_and_tpdos_at_rate(bench):
    events = []
    m = master_for(bench, events, tpdo_rate_hz=500.0, status_tpdo_rate_hz=20.0)
    try:
        m.configure()
        m.start()
        assert [d.state for d in m.drives] == ["OPERATION ENABLED"] * 3
        assert all(n.state == "OPERATION ENABLED" for n in bench.drives.nodes)
        assert [e.kind for e in events] == ["enabled"] * 3
        m.set_speed(150.0)
        time.sleep(1.5)
        for d, node in zip(m.drives, bench.drives.nodes):
            st = d.stream
            stamps, t = list(st.stamp), list(st.t)
            assert st.period_ms == 2
            assert stamps == list(range(stamps[0], stamps[0] + 2 * len(stamps), 2))
            assert st.lost == 0 and st.duplicated == 0 and st.irregular == 0
            assert (len(t) - 1) / (t[-1] - t[0]) == pytest.approx(500.0, rel=0.15)  # wall clock
            assert all(b >= a for a, b in zip(t, t[1:]))
            assert st.w[-1] == pytest.approx(150.0, rel=1e-3)   # RPDO set point reached
            assert d.temperature == pytest.approx(20.0)
            assert D.state_of(d.statusword) == "OPERATION ENABLED"
            assert node.node.sdo[D.TPDO_COMM[0]][5].raw == 2      # 2 ms event timer written by SDO
    finally:
        m.close()


def test_quick_stop_and_refused_mode(bench):
    m = master_for(bench)
    try:
        m.configure()
        m.start()
        m.set_speed(200.0)
        assert wait_for(lambda: abs(bench.live.w[0] - 200.0) < 1.0)
        with pytest.raises(canopen.SdoAbortedError):
            m.drives[0].node.sdo[D.MODES_OF_OPERATION].raw = 1   # profile position: unsupported
        m.quick_stop()
        assert wait_for(lambda: all(n.state == "SWITCH ON DISABLED" for n in bench.drives.nodes))
        assert all(abs(w) < 10 * D.RPM for w in bench.live.w)
        assert not any(bench.live.enabled)
        with pytest.raises(DriveError, match="quick stop in force"):
            m.enable(m.drives[1])                   # a quick stop holds until released
        m.inhibited = False
        m.enable(m.drives[1])                       # and back up again
        assert bench.drives.nodes[1].state == "OPERATION ENABLED"
    finally:
        m.close()


def test_emcy_drops_the_drive_and_the_others_continue(bench):
    events = []
    m = master_for(bench, events)
    try:
        m.configure()
        m.start()
        m.set_speed(100.0)
        m.drives[0].node.sdo.download(FAULT_INJECTION, 0, b"\x01")
        assert wait_for(lambda: not m.drives[0].active)
        kinds = [(e.node_id, e.kind) for e in events]
        assert (1, "emcy") in kinds and (1, "dropped") in kinds
        assert "EMCY 0x1000" in m.drives[0].dropped_reason
        assert bench.drives.nodes[0].state == "FAULT" and bench.live.failed[0]
        assert m.drives[0].node.sdo[D.ERROR_FIELD][1].raw == D.EMCY_GENERIC
        n2 = len(m.drives[1].stream)
        time.sleep(0.3)
        assert len(m.drives[1].stream) > n2 + 200 and [d.active for d in m.drives] == [False, True, True]
        # a faulted drive cannot be reset while its motor is failed
        with pytest.raises(Exception):
            m.enable(m.drives[0])
    finally:
        m.close()


def test_lost_heartbeat_drops_the_drive(bench):
    events = []
    m = master_for(bench, events, drive_heartbeat_ms=50, drive_heartbeat_timeout=0.2)
    other = canopen.Network()
    other.connect(interface="socketcand", channel="can0", host="127.0.0.1", port=bench.port)
    try:
        m.configure()
        m.start()
        time.sleep(0.3)
        assert all(d.active for d in m.drives)
        node2 = other.add_node(2, str(D.EDS_PATH))
        t0 = time.monotonic()
        node2.sdo[D.HEARTBEAT_TIME].raw = 0          # a second client silences drive 2
        assert wait_for(lambda: any(e.kind == "dropped" for e in events), timeout=2.0)
        assert time.monotonic() - t0 < 0.2 + 0.05 + 0.2
        assert [d.active for d in m.drives] == [True, False, True]
        assert [(e.node_id, e.kind) for e in events if e.kind != "enabled"] == [
            (2, "heartbeat_lost"), (2, "dropped")]
        # dropped drives are told to coast
        assert wait_for(lambda: bench.drives.nodes[1].state == "SWITCH ON DISABLED")
    finally:
        other.disconnect()
        m.close()


def test_virtual_bus_in_process():
    bench = CanBench(interface="virtual", channel="drivers-test-virtual")
    m = DriveMaster(Settings(can_interface="virtual", can_channel="drivers-test-virtual"))
    try:
        m.open()
        m.configure()
        m.start()
        assert [d.state for d in m.drives] == ["OPERATION ENABLED"] * 3
        assert wait_for(lambda: all(len(d.stream) > 100 for d in m.drives))
    finally:
        m.close()
        bench.close()


# --- the socketcand protocol ----------------------------------------------------------------------

class Raw:
    def __init__(self, port):
        self.s = socket.create_connection(("127.0.0.1", port), timeout=2.0)
        self.buf = ""

    def send(self, text):
        self.s.sendall(text.encode())

    def expect(self, text):
        end = time.monotonic() + 2.0
        while text not in self.buf and time.monotonic() < end:
            self.buf += self.s.recv(4096).decode()
        assert text in self.buf, self.buf
        self.buf = self.buf[self.buf.index(text) + len(text):]


def test_socketcand_protocol():
    srv = SocketcandServer(port=0, channel="can0")
    port = srv.start()
    local = srv.local_bus()
    try:
        a, b = Raw(port), Raw(port)
        for c in (a, b):
            c.expect("< hi >")
        a.send("< open can9 >")
        a.expect("< error")
        for c in (a, b):
            c.send("< open can0 >")
            c.expect("< ok >")
            c.send("< rawmode >")
            c.expect("< ok >")
        time.sleep(0.1)
        a.send("< send 123 3 1 2 ff >")
        b.expect("< frame 123 ")
        b.expect(" 0102FF >")
        msg = local.recv(1.0)
        assert msg.arbitration_id == 0x123 and bytes(msg.data) == b"\x01\x02\xff"
        a.send("< send 1ABCDEF0 0 >")                 # extended id, no data
        m2 = local.recv(1.0)
        assert m2.is_extended_id and m2.arbitration_id == 0x1ABCDEF0 and m2.dlc == 0
        local.send(can.Message(arbitration_id=0x7FF, data=b"\x10", is_extended_id=False))
        a.expect("< frame 7FF ")
        b.expect("< frame 7FF ")
        for bad in ("< send 123 9 1 2 >", "< send xyz 1 1 >", "< send 800 1 1 >", "< bogus >"):
            a.send(bad)
            a.expect("< error")
        a.send("< send 124 1 7 >")                    # still serving
        b.expect("< frame 124 ")
        assert srv.frames_in == 3 and srv.errors == 4
        # python-can's own client against it
        bus = can.Bus(interface="socketcand", channel="can0", host="127.0.0.1", port=port)
        try:
            a.send("< send 321 2 aa bb >")
            got = bus.recv(2.0)
            assert got.arbitration_id == 0x321 and bytes(got.data) == b"\xaa\xbb"
        finally:
            bus.shutdown()
        a.s.close()
        b.s.close()
    finally:
        local.shutdown()
        srv.stop()


def test_profile_torque_mode(bench):
    """Mode 4 on the speed-controlled emulator: speed set point at the speed limit in the
    sign of the target torque, torque limit at |target torque|."""
    m = master_for(bench)
    try:
        m.configure()
        sdo = m.drives[0].node.sdo
        sdo[D.MODES_OF_OPERATION].raw = D.MODE_PROFILE_TORQUE
        sdo[D.TARGET_TORQUE].raw = -250                      # -25 % of the 8 N·m rated torque
        m.start()
        assert sdo[D.MODES_DISPLAY].raw == D.MODE_PROFILE_TORQUE
        assert bench.live.tau_lim[0] == pytest.approx(2.0)
        assert bench.live.w_sp[0] == pytest.approx(-3000 * D.RPM)
        with pytest.raises(canopen.SdoAbortedError):        # no mode change while enabled
            sdo[D.MODES_OF_OPERATION].raw = D.MODE_PROFILE_VELOCITY
    finally:
        m.close()
