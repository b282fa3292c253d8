"""Homing and limit sets through the scheme engine end to end (issue 13): `rig emulate` as a
separate process at 5 rig s per wall s, the engine over Modbus TCP and CANopen, runs stored in
SQLite. Repeated scheme-1 runs each start from the homed 0°; a torque loading range test runs to
180 kN·m under its own limit set, recorded with the run, and shows Table 11 item 1."""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from core.acceptance import acceptance
from daq.engine import Engine
from daq.plans import Plan
from daq.rig import Rig
from db.store import Store
from drivers_harness import SLACK_S, SLACK_STANDIN, StandinProcess
from daq.settings import Settings

SCALE = 5.0


@pytest.fixture
def standin():
    with StandinProcess(["--time-scale", str(SCALE), "--seed", "5", *SLACK_STANDIN]) as sp:
        yield sp


def run(sp: StandinProcess, url: str, plan: Plan):
    settings = Settings(plc_port=sp.plc_port, can_port=sp.can_port, plc_poll_hz=200.0,
                        tpdo_rate_hz=100.0, plc_link_timeout=SLACK_S,
                        drive_heartbeat_timeout=SLACK_S)
    store = Store(url)
    try:
        out = asyncio.run(Engine(Rig(settings), store, operator="tester").run(plan))
    finally:
        store.close()
    assert (out.exit_status, out.reason) == ("success", None), out
    with Store(url) as s:
        return s.run_info(out.run_id)["meta"], s.load_run(out.run_id)


def test_repeated_scheme1_runs_each_start_from_the_homed_zero(standin, tmp_path):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    plan = Plan.of(1, motor_speed_rpm=3000.0, load_target=20e3, ramp_rate=4e3)
    turned = plan.scheme.travel()                       # ~20° per run
    starts, ends = [], []
    for _ in range(2):
        meta, data = run(standin, url, plan)
        q = data.channel("q")
        starts.append(q[0])
        ends.append(q[-1])
        assert meta["plan"]["homing"] is True and meta["limits"]["limit_set"] == "default"
        assert meta["limits"]["angle_limit"] == pytest.approx(math.pi)
        assert abs(meta["homing"]["q_after"]) < math.radians(0.05)
    # without homing the second run would start where the first ended (~20° on)
    assert ends[0] == pytest.approx(turned, rel=0.2)
    assert all(abs(s) < math.radians(0.1) for s in starts), starts


def test_a_range_test_loads_to_180_knm_under_its_own_limit_set(standin, tmp_path):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    plan = Plan.of(1, motor_speed_rpm=300.0, load_target=180e3, ramp_rate=60e3, hold_top=1.5,
                   limit_set="range")
    meta, data = run(standin, url, plan)
    assert meta["limits"]["limit_set"] == "range" and meta["limits"]["torque_limit"] == 189e3
    assert meta["scheme_params"]["limit_set"] == "range"
    assert np.nanmax(data.channel("torque")) > 1.05 * 120e3      # beyond the default trip
    item = {i.item: i for i in acceptance(data)}
    assert item[1].status == "pass", item[1]
    assert item[1].reached == pytest.approx(180e3, abs=2e3)
