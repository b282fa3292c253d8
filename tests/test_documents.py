"""The documents against their types (core/documents.py): every key the acquisition engine's run
record (daq/run_record.py) and the gap diagnosis's report write is a key its type declares, and
the run format's metadata type lists exactly the keys core.runfile checks."""

from __future__ import annotations

import json
import time
from types import SimpleNamespace

import pytest

from core import documents as doc
from core.runfile import META_KEYS
from daq import run_record
from daq.drives import DriveStream
from daq.interlocks import Interlocks
from daq.plans import Plan
from daq.rig import RigEvent
from daq.settings import Settings


def keys(td) -> set[str]:
    return set(td.__required_keys__) | set(td.__optional_keys__)


def fake_rig(with_drives: bool = True) -> SimpleNamespace:
    drives = [SimpleNamespace(motor=m, node_id=m, active=True, dropped_reason=None,
                              state="operation_enabled", temperature=float("nan") if m == 3
                              else 40.0, rated_current=20.0, rated_torque=30.0,
                              stream=DriveStream(lost=m, duplicated=0))
              for m in (1, 2, 3)]
    return SimpleNamespace(
        settings=Settings(), safe=False, polls=10, poll_errors=0, repeats=1, overruns=0,
        drives=SimpleNamespace(drives=drives) if with_drives else None,
        plc_client=SimpleNamespace(max_beat_gap=0.05),
        interlocks=Interlocks(Settings()),
        events=[RigEvent(time.time(), "plc", "link_down", "gap")])


@pytest.fixture(scope="module")
def plan() -> Plan:
    return Plan.of(2, motor_speed_rpm=300, direction=-1)


def status() -> dict[str, float]:
    from core.plc_map import REGISTER_MAP
    return {s.name: 1.0 for s in REGISTER_MAP.status.signals}


def test_the_run_format_type_lists_the_checked_metadata_keys():
    assert keys(doc.RunMeta) == set(META_KEYS)


@pytest.mark.parametrize("with_drives", [True, False])
def test_the_start_document_holds_only_declared_keys(plan, with_drives):
    rig = fake_rig(with_drives)
    base = run_record.baseline(status(), rig)
    start = run_record.start_document(plan, rig, rig_name="J4-emulator", source="emulator",
                                      notes="", operator="me", time_scale=2.0,
                                      baseline_start=base, effects={"stribeck": {}})
    json.dumps(start, allow_nan=False)                      # JSON-ready: the NaN became null
    assert set(start) <= keys(doc.RunStart), set(start) - keys(doc.RunStart)
    assert set(start["plan"]) == keys(doc.PlanFacts)
    assert set(start["streams"]) == {"plc", "plan", "interruptions"} | (
        {"drives"} if with_drives else set())
    for d in start["streams"].values():
        assert set(d) <= keys(doc.StreamDescriptor)
    assert start["streams"]["interruptions"]["kinds"] == list(doc.INTERRUPTION_KINDS)
    named = {k for k in base if k.startswith("temp_m")}
    assert set(base) - named <= keys(doc.Baseline)
    assert set(base["plc"]) == keys(doc.PlcReading)
    if with_drives:
        assert named == {"temp_m1", "temp_m2", "temp_m3"} and base["temp_m3"] is None
        assert all(set(d) == keys(doc.DriveReading) for d in base["drives"])
    names = [c.name for c in run_record.channel_specs(plan, rig)]
    assert names[0] == "t" and names[-2:] == ["phase", "w_cmd"]
    assert set(start["streams"]["plc"]["channels"]) | set(start["streams"]["plan"]["channels"]) \
        | set(start["streams"].get("drives", {}).get("channels", {})) == set(names)


def test_the_end_document_holds_only_declared_keys():
    rig = fake_rig()
    counters = run_record.counters(rig, samples=5, missed=1, interruptions=0, skipped_writes=0,
                                   drive_clock="receive time", drive_offset_ms={1: 3.0})
    assert set(counters) == keys(doc.Counters)
    assert counters["drive_samples_lost"] == {"1": 1, "2": 2, "3": 3}
    events = run_record.event_notes(rig.events, lambda wall: 1.5)
    assert [set(e) for e in events] == [keys(doc.EventNote)] and events[0]["t_run"] == 1.5


def test_the_diagnosis_report_holds_only_declared_keys():
    from core.schemes import Scheme1
    from estimator.diagnosis import diagnose
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate

    train = simulate(Scheme1(motor_speed_rpm=3000, direction=1), EmulatorConfig(seed=1))
    test = simulate(Scheme1(motor_speed_rpm=3000, direction=-1), EmulatorConfig(seed=2))
    rep = diagnose([train], [test])
    assert "transmission" in rep                   # both laws: every verdict key is written
    for r in (rep, rep["transmission"]):
        assert set(r) <= keys(doc.DiagnosisReport), set(r) - keys(doc.DiagnosisReport)
        assert set(r["verdict"]) <= keys(doc.DiagnosisVerdict), \
            set(r["verdict"]) - keys(doc.DiagnosisVerdict)
    assert {"laws", "effect_models", "summary"} <= set(rep["verdict"])
