"""Fault injection on the stand-in (issue 13): one drive node dies while the rest of the
stand-in runs (`rig emulate --control-stdin`, command `silence-drive N`; simulators/drives.py).

- In process: a silenced node sends nothing more (no heartbeat, no TPDO, no SDO answer) while
  the other nodes go on, and its motor gives no torque even when the PLC's hard-wired OFF3
  reaches it; a bad command is refused with a message.
- End to end (`rig emulate` + `rig run scheme1`, two processes on loopback, SQLite): one dead
  drive is found by `rig run`'s heartbeat watchdog (daq/drives.py: no heartbeat for
  drive_heartbeat_timeout), recorded as a `drive_lost` interruption naming the node and its
  motor, and the joint goes on on the two others (the rig's policy, daq/rig.py); a second dead
  drive trips the `drive_link` interlock: the run ends `abort` with a reason naming both
  motors, and the stand-in records the remaining drive's quick stop and the PLC's trip.

Timeouts here are generous (SLACK_S for the links the test is not about); nothing asserts a
duration."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import can
import pytest
from drivers_harness import REPO, SLACK_STANDIN, StandinProcess, wait_for

HB_TIMEOUT_S = 1.0
"""`rig run`'s drive heartbeat timeout in these tests [s] (the point of the test, but with room
for a loaded host; the producer period is 0.1 s)."""


# --- in process -----------------------------------------------------------------------------

@pytest.fixture()
def drives():
    """The stand-in's three drives on a local socketcand bus, with a listener on the same bus;
    the emulator is paced by hand (drives.step after each advance)."""
    from simulators.drives import DriveStandIn
    from simulators.live import LiveJoint
    from simulators.socketcand_server import SocketcandServer
    from simulators.standin import emulator_config

    server = SocketcandServer("127.0.0.1", 0)
    server.start()
    live = LiveJoint(emulator_config({"seed": 1}))
    lock = threading.RLock()
    events: list[str] = []
    ds = DriveStandIn(server.local_bus(), live, lock, (1, 2, 3), on_event=events.append)
    ds.boot()
    listener = server.local_bus()
    try:
        yield ds, live, lock, listener, events, server
    finally:
        listener.shutdown()
        ds.close()
        server.stop()


def _frames(bus: can.BusABC, seconds: float) -> list[can.Message]:
    out, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        m = bus.recv(timeout=0.05)
        if m is not None:
            out.append(m)
    return out


def _operational_and_enabled(ds, live, lock, server) -> None:
    """NMT start all, enable each drive by SDO as the master would (on a bus of its own, closed
    after); then run 50 ms of rig time."""
    import canopen
    net = canopen.Network(server.local_bus())
    net.connect()
    try:
        for nid in (1, 2, 3):
            node = net.add_node(nid, ds.nodes[nid - 1].node.object_dictionary)
            for cw in (0x06, 0x07, 0x0F):
                node.sdo[0x6040].raw = cw
        net.nmt.state = "OPERATIONAL"
        for _ in range(50):
            with lock:
                live.advance(float(live.dt))
                ds.step()
    finally:
        net.disconnect()


def test_a_silenced_drive_leaves_the_bus_and_its_motor_gives_no_torque(drives):
    ds, live, lock, listener, events, server = drives
    _operational_and_enabled(ds, live, lock, server)
    assert all(n.state == "OPERATION ENABLED" for n in ds.nodes)
    _frames(listener, 0.2)                                     # drain
    power: list[tuple[int, bool]] = []                         # every enable_motor call from now
    enable = live.enable_motor
    live.enable_motor = lambda k, on: (power.append((k, bool(on))), enable(k, on))[1]
    dead = ds.silence(2)
    assert dead.silenced and dead.k == 1
    for _ in range(300):                                       # 0.3 s of rig time: TPDOs due
        with lock:
            live.advance(float(live.dt))
            ds.step()
    frames = _frames(listener, 0.5)                            # > 4 heartbeat periods
    senders = {m.arbitration_id & 0x7F for m in frames if m.arbitration_id & 0x780 in
               (0x180, 0x280, 0x700, 0x080, 0x580)}
    heartbeats = {m.arbitration_id - 0x700 for m in frames if 0x701 <= m.arbitration_id <= 0x77F}
    assert 2 not in senders and heartbeats == {1, 3}, sorted(hex(m.arbitration_id) for m in frames)
    assert {1, 3} <= senders                                   # the others' TPDOs go on
    # an SDO request to the dead node goes unanswered
    listener.send(can.Message(arbitration_id=0x602, data=[0x40, 0x41, 0x60, 0, 0, 0, 0, 0],
                              is_extended_id=False))
    assert not [m for m in _frames(listener, 0.3) if m.arbitration_id == 0x582]
    # the PLC's hard-wired OFF3 still reaches every drive: the live ones quick-stop, the dead
    # one stays without torque
    ds.stop_all()
    assert ds.nodes[0].state == ds.nodes[2].state == "QUICK STOP ACTIVE"
    assert dead.state == "OPERATION ENABLED"       # frozen: nothing runs in a dead drive
    assert [on for k, on in power if k == 1] == [False]        # motor 2 unpowered, and stays so
    assert (0, True) in power and (2, True) in power           # quick stop keeps the others powered
    assert "drive 1 (motor 1): QUICK STOP ACTIVE" in events
    assert not any(e.startswith("drive 2 ") for e in events)
    with pytest.raises(KeyError, match="node id 9"):
        ds.silence(9)


def test_the_standin_control_command_and_its_refusals():
    from simulators.standin import StandIn, StandInOptions

    st = StandIn(StandInOptions(plc=False, can=True, plc_port=0, can_port=0))
    st.start_can()
    try:
        assert st.control("silence-drive 3").startswith("drive 3 (motor 3) silenced")
        assert st.drives.nodes[2].silenced and not st.drives.nodes[0].silenced
        assert st.control("silence-drive 7").startswith("error: ")
        assert st.control("silence-drive x").startswith("error: ")
        assert st.control("reboot").startswith("error: unknown command")
    finally:
        st.drives.close()
        st.can_server.stop()


# --- end to end: rig emulate + rig run ----------------------------------------------------------

def _start_run(sp: StandinProcess, url: str) -> tuple[subprocess.Popen, list[str]]:
    env = dict(os.environ, PYTHONUNBUFFERED="1", RIG_DB_URL=url,
               RIG_PLC_PORT=str(sp.plc_port), RIG_CAN_PORT=str(sp.can_port),
               RIG_PLC_LINK_TIMEOUT="2.0", RIG_DRIVE_HEARTBEAT_TIMEOUT=str(HB_TIMEOUT_S))
    env.pop("RIG_CONFIG", None)
    proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "run", "scheme1",
                             "--speed", "3000", "--operator", "fault-test"],
                            cwd=REPO, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []

    def read() -> None:
        for ln in proc.stdout:
            lines.append(ln.rstrip("\n"))
    threading.Thread(target=read, daemon=True).start()
    assert wait_for(lambda: any(" n=" in ln and "phase=" in ln for ln in lines[-3:])
                    or proc.poll() is not None, timeout=90.0), lines
    assert proc.poll() is None, "rig run ended before the fault:\n" + "\n".join(lines)
    return proc, lines


def _run_record(url: str) -> dict:
    """The last run's record with its interruptions (stored apart from run_info)."""
    from db.store import Store
    with Store(url) as store:
        rid = store.list_runs()[-1]["id"]
        return {**store.run_info(rid), "interruptions": store.interruptions(rid)}


def test_one_dead_drive_is_dropped_by_the_heartbeat_watchdog_and_the_joint_goes_on(tmp_path):
    url = f"sqlite:///{tmp_path / 'one.sqlite'}"
    with StandinProcess(SLACK_STANDIN, control=True) as sp:
        proc, lines = _start_run(sp, url)
        assert "drive 2 (motor 2) silenced" in sp.silence_drive(2)
        time.sleep(HB_TIMEOUT_S + 2.0)
        assert proc.poll() is None, "one dead drive must not end the run:\n" + "\n".join(lines)
        stopped_early = [ln for ln in sp.lines if "QUICK STOP ACTIVE" in ln or "PLC trip" in ln]
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
    assert not stopped_early, stopped_early     # no make-safe for one lost drive
    info = _run_record(url)
    lost = [i for i in info["interruptions"] if i["kind"] == "drive_lost"]
    assert len(lost) == 1 and "drive 2 (motor 2)" in lost[0]["reason"], info["interruptions"]
    assert "heartbeat lost" in lost[0]["reason"]
    events = info["meta"]["end"]["events"]
    assert any(e["kind"] == "heartbeat_lost" and "drive 2" in e["message"] for e in events)
    assert any(e["kind"] == "degraded" and "motors (1, 3)" in e["message"] for e in events)
    assert not any(e["kind"] == "trip" for e in events), events
    assert info["exit_status"] == "abort" and info["reason"] == "cancelled by the operator"


def test_two_dead_drives_trip_the_rig_safe_and_abort_the_run_naming_them(tmp_path):
    url = f"sqlite:///{tmp_path / 'two.sqlite'}"
    with StandinProcess(SLACK_STANDIN, control=True) as sp:
        proc, lines = _start_run(sp, url)
        sp.silence_drive(2)
        sp.silence_drive(3)
        proc.wait(timeout=60)                      # the trip ends the run by itself
        # the plant's side: the live drive quick-stopped; the PLC tripped once the service's
        # heartbeat stopped with `rig run`
        assert wait_for(lambda: any("PLC trip" in ln for ln in sp.lines), timeout=10.0), sp.lines
        assert "rig emulate: drive 1 (motor 1): QUICK STOP ACTIVE" in sp.lines, sp.lines
    info = _run_record(url)
    assert info["exit_status"] == "abort", info
    reason = info["reason"]
    assert reason.startswith("interlock drive_link: 2 drives lost"), reason
    assert "motor 2: heartbeat lost" in reason and "motor 3: heartbeat lost" in reason, reason
    assert sum(i["kind"] == "drive_lost" for i in info["interruptions"]) == 2
    made_safe = [e for e in info["meta"]["end"]["events"] if e["kind"] == "make_safe"]
    assert made_safe and "interlock drive_link" in made_safe[0]["message"], made_safe
