"""Homing (the PLC's `home` command, its stand-in and Rig.home), the absolute-angle interlock and
the per-scheme limit sets (issue 13). In one process: the PLC program on the real emulator, and
the DAQ facade against the PLC stand-in; no drives (the PLC turns the joint itself)."""

from __future__ import annotations

import asyncio
import math
import threading

import pytest

from core.plc_map import HOME_TOLERANCE, REGISTER_MAP
from core.schemes import LIMIT_SETS, Scheme1, Scheme2, Scheme3
from daq.interlocks import Interlocks
from daq.plans import Plan
from daq.rig import Rig, RigSafeError
from daq.settings import Settings
from drivers_fake_live import FakeLiveJoint
from drivers_harness import await_for
from simulators.live import LiveJoint
from simulators.plc import MODE_RUN, PlcProgram, PlcServer

CB = REGISTER_MAP.signals["command_bits"]
SB = REGISTER_MAP.signals["status_bits"]


def commands(**values):
    return REGISTER_MAP.command.encode(values)


def turned_joint(degrees: float) -> LiveJoint:
    """The emulator with its joint turned by about `degrees` from where it started."""
    live = LiveJoint()
    w = math.copysign(300.0, degrees)          # rad/s at the motors: 1.56 °/s at the output
    for k in range(3):
        live.set_motor_speed(k, w)
    live.advance(abs(degrees) / math.degrees(300.0 / 11000.0))
    for k in range(3):
        live.set_motor_speed(k, 0.0)
    live.advance(1.0)
    return live


def running_program(live) -> PlcProgram:
    p = PlcProgram(live, threading.RLock(), clock=lambda: 0.0)   # the watchdog never expires
    p.write_commands(commands(service_heartbeat=1))
    p.scan()
    assert p.mode == MODE_RUN
    return p


def home_steps(p: PlcProgram, live, rig_s: float = 0.02, limit: int = 5000) -> float:
    """Scan and advance until homing ends; returns the rig time it took [s]."""
    n = 0
    while p.homing and n < limit:
        p.scan()
        live.advance(rig_s)
        n += 1
    return n * rig_s


def test_plc_homes_the_joint_to_zero_and_zeroes_the_output_encoder():
    live = turned_joint(8.0)
    p = running_program(live)
    before = p.status_values()
    assert math.degrees(before["q"]) == pytest.approx(8.0, abs=1.0)
    assert not int(before["status_bits"]) & (SB.bit("homed") | SB.bit("homing"))
    p.write_commands(commands(service_heartbeat=2, command_bits=CB.bit("home")))
    assert int(p.status_values()["status_bits"]) & SB.bit("homing")
    took = home_steps(p, live)
    assert p.homed and not p.homing and took < Rig.homing_time(before["u"])
    st = p.status_values()
    bits = int(st["status_bits"])
    assert bits & SB.bit("homed") and not bits & SB.bit("homing")
    assert abs(st["u"]) <= 2 * HOME_TOLERANCE                  # at 0° by the motor code disk
    assert abs(st["q"]) <= 2 * HOME_TOLERANCE                  # the output encoder reads 0 there
    assert abs(live.truth()["q"]) < math.radians(0.05)         # and the joint is really there
    # from now on q counts from the homed zero: turning the joint shows in q
    for k in range(3):
        live.set_motor_speed(k, -300.0)
    live.advance(3.0)
    assert p.status_values()["q"] == pytest.approx(live.truth()["q"] - p.encoder_zero, abs=1e-3)
    assert p.status_values()["q"] < -math.radians(3.0)


def test_homing_stops_when_the_request_is_cleared_or_the_plc_trips():
    live = turned_joint(-8.0)
    p = running_program(live)
    p.write_commands(commands(service_heartbeat=2, command_bits=CB.bit("home")))
    for _ in range(20):
        p.scan()
        live.advance(0.02)
    assert p.homing
    p.write_commands(commands(service_heartbeat=3, command_bits=0))
    assert not p.homing and not p.homed
    assert "home request cleared" in p.events[-1][1]
    p.write_commands(commands(service_heartbeat=4, command_bits=CB.bit("home")))
    assert p.homing
    p.write_commands(commands(service_heartbeat=5, command_bits=CB.bit("home") | CB.bit("estop")))
    assert not p.homing and not p.homed and p.encoder_zero == 0.0
    # a PLC in its safe state refuses to start homing
    p.write_commands(commands(service_heartbeat=6, command_bits=CB.bit("estop")))
    p.write_commands(commands(service_heartbeat=7, command_bits=CB.bit("home") | CB.bit("estop")))
    assert not p.homing and "homing refused" in p.events[-1][1]


def with_plc(live, body, **settings):
    """The PLC stand-in on `live`, paced by an asyncio task, and a Rig (no drives) on it."""
    async def main():
        lock = threading.RLock()
        srv = PlcServer(PlcProgram(live, lock), "127.0.0.1", 0)
        port = await srv.start()

        async def pace():
            while True:
                if hasattr(live, "config"):   # the real emulator advances; the fake stands
                    with lock:
                        live.advance(0.01)
                await asyncio.sleep(0.002)
        pacer = asyncio.create_task(pace())
        try:
            rig = Rig(Settings(plc_port=port, node_ids=(), plc_poll_hz=200.0, **settings))
            await body(rig, srv.program)
        finally:
            pacer.cancel()
            await srv.stop()
    asyncio.run(main())


def test_rig_home_drives_the_plc_homing_and_records_it():
    live = turned_joint(6.0)

    async def body(rig, program):
        async with rig.session():
            out = await rig.home(time_scale=1.0)
            assert program.homed and not program.homing
            assert math.degrees(out["q_before"]) == pytest.approx(6.0, abs=1.0)
            assert abs(out["q_after"]) <= 2 * HOME_TOLERANCE
            cmd = await rig.plc_client.read_commands()
            assert not int(cmd["command_bits"]) & CB.bit("home")     # the request is released
            assert [e.kind for e in rig.events if e.kind.startswith("hom")] == ["homing", "homed"]
            assert not rig.trips
    with_plc(live, body)


def test_homing_that_does_not_finish_makes_the_rig_safe():
    live = FakeLiveJoint()
    live.q = 0.3                      # the fake's motors are not enabled: it cannot home

    async def body(rig, program):
        async with rig.session():
            with pytest.raises(RigSafeError, match="not homed"):
                await rig.home(time_scale=1e6, slack=0.3)
            assert [t.name for t in rig.trips] == ["homing"]
            assert not program.homing           # the released request stopped the PLC's homing
    with_plc(live, body)


@pytest.mark.parametrize("q", [math.radians(181.0), -math.radians(181.0), math.nan])
def test_absolute_angle_interlock_trips_beyond_the_travel_or_on_a_missing_angle(q):
    live = FakeLiveJoint()

    async def body(rig, program):
        async with rig.session():
            await rig.set_dyno_torque(10e3)
            live.q = math.radians(179.0)        # inside the travel: no trip
            await asyncio.sleep(0.1)
            assert not rig.trips
            if math.isnan(q):                   # the encoder's reading goes missing
                read = live.read
                live.read = lambda: {**read(), "q": math.nan}
            else:
                live.q = q
            assert await await_for(lambda: rig.trips, timeout=2.0)
            assert [t.name for t in rig.trips] == ["angle"] and rig.safe
            assert (await rig.plc_client.read_commands())["dyno_torque_sp"] == 0.0
    with_plc(live, body)


def test_interlock_limit_sets():
    quiet = {"torque": 150e3, "m_bend": 0.0, "f_shear": 0.0, "p_hyd": 0.0, "q": 0.0,
             "status_bits": 0}
    default = Interlocks(Settings())
    assert [t.name for t in default.check_status(quiet)] == ["torque"]    # 126 kN·m
    rng = Interlocks(Settings(), LIMIT_SETS["range"])
    assert rng.check_status(quiet) == []
    assert [t.name for t in rng.check_status(dict(quiet, torque=190e3))] == ["torque"]
    assert rng.describe()["limit_set"] == "range" and rng.describe()["torque_limit"] == 189e3
    assert default.describe()["torque_limit"] == Settings().torque_limit
    assert default.describe()["angle_limit"] == math.pi
    # the other limits stay the settings'
    assert rng.limits["bending"] == default.limits["bending"]


def test_a_scheme_names_its_limit_set_and_the_plan_carries_it():
    with pytest.raises(ValueError, match="'default' limit set"):
        Scheme1(motor_speed_rpm=300.0, load_target=180e3)
    with pytest.raises(ValueError, match="limit set must be one of"):
        Scheme1(limit_set="nonsense")
    rng = Plan(Scheme1(motor_speed_rpm=300.0, load_target=180e3, limit_set="range"))
    assert rng.limits.name == "range" and rng.limits.torque_limit == 189e3
    assert max(rng.setpoints(t).dyno_torque for t in range(0, int(rng.duration))) \
        == pytest.approx(180e3, rel=1e-3)
    meta = rng.meta()
    assert meta["plan"]["limit_set"] == "range" and meta["scheme_params"]["limit_set"] == "range"
    assert Plan(Scheme2(load_target=30e3)).limits.name == "default"


def test_every_scheme_homes_first():
    assert Plan(Scheme1()).homing and Plan(Scheme2()).homing
    s3 = Plan(Scheme3(n_periods=1, base_freq_hz=0.1, sample_rate_hz=10.0, rest_time=1.0,
                      coefficients=((0.001,) * 5, (0.0,) * 5, 0.0)))
    assert s3.homing and s3.meta()["plan"]["homing"]
