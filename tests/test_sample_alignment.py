"""The acquisition's sample alignment (daq/sample_alignment.py) on hand-made PLC snapshots and
drive samples, without a rig: which snapshot becomes each grid slot's sample, how empty slots
are counted, and how the drives' stamps are put on the rig's clock and joined."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import pytest

from core.drive_od import STAMP_WRAP
from core.plc_map import REGISTER_MAP
from daq.drives import DriveStream
from daq.plans import Plan
from daq.rig import PlcStream
from daq.run_record import PLC_CHANNELS
from daq.sample_alignment import SampleAligner

SIGNALS = [s.name for s in REGISTER_MAP.status.signals]


@pytest.fixture(scope="module")
def plan() -> Plan:
    return Plan.of(1, motor_speed_rpm=3000, direction=1)   # 10 Hz grid


def rig_with(rig_times: list[float], t_rx: list[float] | None = None, drives=None):
    plc = PlcStream(SIGNALS)
    t_rx = t_rx or [time.time() - 100.0 + x for x in rig_times]
    for k, (rt, rx) in enumerate(zip(rig_times, t_rx)):
        status = {n: float(k) for n in SIGNALS}
        status["rig_time"], status["q"] = rt, 0.001 * k
        plc.append(rx, 0.001, status)
    master = None if drives is None else SimpleNamespace(drives=drives, active=drives)
    return SimpleNamespace(plc=plc, drives=master)


def drive(motor: int, stamps: list[int], t_rx: list[float], w: float = 5.0) -> SimpleNamespace:
    st = DriveStream()
    for s, rx in zip(stamps, t_rx):
        st.stamp.append(s)
        st.t.append(rx)
        st.w.append(w + s * 1e-3)
        st.i.append(1.0)
    return SimpleNamespace(motor=motor, node_id=motor, stream=st, temperature=40.0 + motor)


def test_the_first_snapshot_of_each_slot_is_its_sample_and_an_empty_slot_is_missed(plan):
    # 10 Hz: slots 0, 0, 1, 3, 4 (slot 2 has no snapshot)
    rig = rig_with([7.0, 7.03, 7.12, 7.35, 7.41])
    a = SampleAligner(rig, plan, 1.0)
    cols = a.collect()
    assert a.t0 == 7.0
    assert cols["t"] == pytest.approx([0.0, 0.12, 0.35, 0.41])
    assert a.missed == 1 and not a.done
    sig, ch = next((s, c) for s, c in PLC_CHANNELS if s != "q")
    assert cols[ch] == [0.0, 2.0, 3.0, 4.0]                   # the chosen rows, not the others
    assert cols["phase"] == [plan.setpoints(t).phase for t in cols["t"]]
    assert a.collect() is None                                # nothing new


def test_the_run_ends_when_the_grid_is_past_and_every_empty_slot_is_counted(plan):
    n = plan.n_samples()
    rig = rig_with([0.0, plan.duration + 1.0])
    a = SampleAligner(rig, plan, 1.0)
    cols = a.collect()
    assert a.done and len(cols["t"]) == 1 and a.missed == n - 1


def test_start_now_makes_the_next_snapshot_plan_time_zero(plan):
    rig = rig_with([3.0, 3.1])
    a = SampleAligner(rig, plan, 1.0)
    a.start_now()
    assert a.collect() is None and a.t0 is None
    rig.plc.append(time.time(), 0.001, {**{n: 0.0 for n in SIGNALS}, "rig_time": 3.2})
    assert a.collect()["t"] == [0.0] and a.t0 == 3.2


def test_drive_stamps_count_the_rig_clock_modulo_the_wrap_and_are_joined(plan):
    now = time.time()
    rig_t0 = 70.0                                   # 70 000 ms: the 16-bit stamp wrapped once
    stamps = [int(rig_t0 * 1000) - STAMP_WRAP + k for k in range(-20, 21)]
    d = drive(1, stamps, [now - 0.5 + (k + 20) * 1e-3 for k in range(-20, 21)])
    # receive times jittered by 20 ms put the receive-time estimate 20 ms off the wrap; the
    # snap to a multiple of the wrap removes it
    rig = rig_with([rig_t0, rig_t0 + 0.1], [now - 0.48, now - 0.4], drives=[d])
    a = SampleAligner(rig, plan, 1.0, drive_wait=10.0)
    cols = a.collect()
    assert a.drive_offset[1] == float(STAMP_WRAP)
    assert a.drive_clock_mode.startswith("shared")
    # sample at rig time 70.0 s joins the drive sample stamped 70 000 ms − 2^16
    assert cols["w_m1"][0] == pytest.approx(5.0 + (70_000 - STAMP_WRAP) * 1e-3)
    assert cols["temp_m1"][0] == 41.0
    # the second sample (70.1 s) waits for the drive's samples (they stop at 70.02 s) ...
    assert len(cols["t"]) == 1
    # ... and when it is taken anyway (final), the drive's last sample is too old: missing
    cols = a.collect(final=True)
    assert cols["t"] == pytest.approx([0.1]) and math.isnan(cols["w_m1"][0])


def test_without_a_shared_clock_the_offset_is_the_receive_time_estimate(plan):
    now = time.time()
    d = drive(2, [1000, 1001], [now - 0.5, now - 0.499])
    rig = rig_with([70.0], [now - 0.5 - 0.02], drives=[d])
    a = SampleAligner(rig, plan, 1.0, drive_wait=0.0, shared_drive_clock=False)
    a.collect()
    assert a.drive_clock_mode == "receive time"
    assert a.drive_offset[2] == pytest.approx(70_000 + 0.021 * 1000 - 1001, abs=1e-3)
