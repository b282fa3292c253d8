"""Every interlock trips on its own against `rig emulate` (a separate process, the physics
emulator behind it) and leaves the rig safe: dynamometer set point 0, hydraulics at the safe
pressure, no drive in OPERATION ENABLED, further set points refused. Make-safe also runs when
the acquisition code raises. (Lost PLC link: test_standin_plc; lost drives: test_standin_drives.)"""

import asyncio

import canopen
import pytest

from daq.plc import PlcClient
from daq.rig import Rig, RigSafeError
from drivers_harness import SLACK_S, SLACK_STANDIN, StandinProcess, await_for
from core import drive_od as D
from core.plc_map import REGISTER_MAP
from daq.settings import Settings

SB = REGISTER_MAP.signals["status_bits"]


async def assert_left_safe(rig: Rig, name: str, timeout: float = 8.0) -> None:
    assert await await_for(lambda: rig.events_of("make_safe"), timeout=timeout), \
        f"no trip; events {rig.events}"
    assert rig.safe
    assert rig.trips[0].name == name, [t.message for t in rig.trips]
    assert rig.events_of("make_safe")[0].data["reason"] == f"interlock {name}"
    cmd = await rig.plc_client.read_commands()
    assert cmd["dyno_torque_sp"] == 0.0
    assert cmd["pressure_sp"] == rig.settings.safe_pressure

    async def applied():
        st = await rig.plc_client.read_status()
        return st["torque_cmd"] == 0.0 and st["pressure_sp_applied"] == rig.settings.safe_pressure
    assert await await_for(applied, timeout=1.0)
    if rig.drives is not None:
        assert await await_for(lambda: all(
            D.state_of(d.statusword) != "OPERATION ENABLED" for d in rig.drives.drives), 1.0)
    with pytest.raises(RigSafeError):
        await rig.set_dyno_torque(1e3)
    with pytest.raises(RigSafeError):
        await rig.set_motor_speed(10.0)


def run_session(args, body, **settings):
    """`body(rig)` in a rig session against a stand-in started with `args`. The link timeouts
    and the PLC's watchdog get the harness's slack (drivers_harness.SLACK_S): the interlocks are
    the point here, and a starved process on a loaded host must not trip the rig first (it did,
    once, in a full-suite run: the watchdog's 0.5 s before the shear interlock)."""
    settings = {"plc_link_timeout": SLACK_S, "drive_heartbeat_timeout": SLACK_S, **settings}
    with StandinProcess([*SLACK_STANDIN, *args]) as sp:
        async def main():
            rig = Rig(Settings(plc_port=sp.plc_port, can_port=sp.can_port, **settings))
            async with rig.session():
                await body(rig)
            return rig
        return asyncio.run(main())


def test_torque_interlock():
    async def body(rig):
        await rig.set_dyno_torque(135e3)           # above 105 % of the rated 120 kN·m
        await assert_left_safe(rig, "torque")
        assert rig.trips[0].value > 126e3 and rig.trips[0].limit == pytest.approx(126e3)
    run_session([], body)


async def hydraulics(rig, p):
    await rig.set_pump(True)
    await rig.set_valve(1)
    await rig.set_pressure(p)


def test_bending_interlock():
    # a 3 m lever: 250 kN·m is reached at 20.8 MPa, before shear (92 kN at 23 MPa)
    async def body(rig):
        await hydraulics(rig, 22e6)
        await assert_left_safe(rig, "bending")
        assert rig.trips[0].value > 250e3
    run_session(["--param", "arm_bend=3.0"], body)


def test_shear_interlock():
    async def body(rig):
        await hydraulics(rig, 23.5e6)              # 94 kN > 90 kN + 2 kN
        await assert_left_safe(rig, "shear")
        assert rig.trips[0].value > 92e3
    run_session([], body)


def test_pressure_interlock():
    # a smaller piston keeps shear and bending low while the pressure passes 24 MPa
    async def body(rig):
        await hydraulics(rig, 24.8e6)
        await assert_left_safe(rig, "pressure")
        assert rig.trips[0].value > 24e6
    run_session(["--param", "cyl_area=3e-3"], body)


def test_motor_over_temperature_interlock():
    async def body(rig):
        await assert_left_safe(rig, "motor_temperature", timeout=3.0)
        assert "motor 2" in rig.trips[0].message
    run_session(["--temp-motor", "20,130,20"], body)


def test_operator_estop():
    async def body(rig):
        await rig.set_pump(True)
        await rig.set_motor_speed(60.0)
        await asyncio.sleep(0.3)
        await rig.estop("test button")
        await assert_left_safe(rig, "estop")

        async def latched():
            st = await rig.plc_client.read_status()
            return int(st["status_bits"]) & SB.bit("estop") and st["pump_state"] == 0
        assert await await_for(latched, timeout=1.0)
    run_session([], body)


def test_make_safe_runs_when_the_acquisition_code_raises():
    # the slack timeouts: a watchdog tripped by a stalled host would make the rig safe before
    # the scheme's own error does, and that error is the point here
    with StandinProcess(SLACK_STANDIN) as sp:
        s = Settings(plc_port=sp.plc_port, can_port=sp.can_port, plc_link_timeout=SLACK_S,
                     drive_heartbeat_timeout=SLACK_S)
        rig = Rig(s)

        async def main():
            with pytest.raises(RuntimeError, match="scheme bug"):
                async with rig.session():
                    await rig.set_motor_speed(80.0)
                    await rig.set_dyno_torque(30e3)
                    await asyncio.sleep(0.3)
                    raise RuntimeError("scheme bug")
            c = PlcClient(s)
            await c.connect()
            try:
                cmd = await c.read_commands()
            finally:
                c.close()
            return cmd
        cmd = asyncio.run(main())
        assert cmd["dyno_torque_sp"] == 0.0 and cmd["pressure_sp"] == 0.0
        ev = rig.events_of("make_safe")
        assert len(ev) == 1 and "RuntimeError: scheme bug" in ev[0].data["reason"]
        assert rig.events[-1].kind == "stopped"
        net = canopen.Network()
        net.connect(interface="socketcand", channel="can0", host="127.0.0.1", port=sp.can_port)
        try:
            for nid in (1, 2, 3):
                sw = net.add_node(nid, str(D.EDS_PATH)).sdo[D.STATUSWORD].raw
                assert D.state_of(sw) in ("QUICK STOP ACTIVE", "SWITCH ON DISABLED")
        finally:
            net.disconnect()


def test_the_standin_watchdog_fails_safe_on_a_nan_timeout():
    """The stand-in PLC's own watchdog: a NaN or non-positive timeout is refused, and the
    comparison trips on NaN instead of never tripping (`elapsed > nan` is false)."""
    import math
    import threading

    from drivers_fake_live import FakeLiveJoint
    from simulators.plc import MODE_RUN, MODE_SAFE, PlcProgram

    for bad in (math.nan, math.inf, 0.0, -1.0):
        with pytest.raises(ValueError, match="watchdog"):
            PlcProgram(FakeLiveJoint(), threading.RLock(), watchdog_s=bad)
    now = [100.0]
    p = PlcProgram(FakeLiveJoint(), threading.RLock(), watchdog_s=0.5, clock=lambda: now[0])
    p.write_commands(REGISTER_MAP.command.encode({"service_heartbeat": 1}))
    p.scan()
    assert p.mode == MODE_RUN
    p.watchdog_s = math.nan                      # however it got there
    now[0] += 0.01
    p.scan()
    assert p.mode == MODE_SAFE and p.watchdog_fault
