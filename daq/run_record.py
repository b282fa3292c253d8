"""The run record's documents, as the acquisition engine (daq/engine.py) stores them, in the
spirit of bluesky's documents (types in core/documents.py):

- start (`RunStart`, the run's metadata): the scheme and its parameters, the plan, rig or
  emulator, the effects declared for an emulated rig, operator, software version, the rig's
  time scale, the DAQ settings, one descriptor per stream (channel names, units, source,
  clock) and the slow signals read at the start (`Baseline`);
- the channels the run writer is told of (`ChannelSpec`: name, unit, source);
- end (`RunEnd`, stored under the metadata's `end` when the run stops): the outputs after
  make-safe, the end baseline, the acquisition's counters and every rig event in run time.

Everything here builds JSON-ready documents from what the engine and the rig hold; nothing
reads a device or the database.
"""

from __future__ import annotations

import subprocess
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from core.acceptance import APPLIED_PRESSURE
from core.channels import unit_of
from core.documents import (INTERRUPTION_KINDS, Baseline, Counters, EventNote, RunStart,
                            StreamDescriptor)
from core.jsonsafe import json_safe
from core.plc_map import REGISTER_MAP
from daq.plans import Plan
from daq.rig import Rig, RigEvent
from db.writer import ChannelSpec

PLC_EXTRA_CHANNELS: tuple[tuple[str, str], ...] = (("pressure_sp_applied", APPLIED_PRESSURE),)
"""(status signal, channel) of the PLC status signals recorded as extra channels (run-format.md
keeps unknown columns), unit from the register map: the hydraulic pressure set point as the
PLC applied it [Pa] — when the hydraulic load was actually switched, which the Table 11
settling starts from (core/acceptance.py APPLIED_PRESSURE; the torque's counterpart is
`torque_cmd`)."""

PLC_CHANNELS: tuple[tuple[str, str], ...] = tuple(
    (s.name, s.channel) for s in REGISTER_MAP.status.signals
    if s.channel is not None and s.channel != "t") + PLC_EXTRA_CHANNELS
"""(status signal, channel) of every PLC status signal recorded per sample: those that are a
run-format channel, then PLC_EXTRA_CHANNELS."""


def plc_unit(signal: str) -> str:
    """SI unit of a PLC status signal's channel (the register map's; for a run-format channel
    the same as core.channels says, tests/test_drivers_plc_map.py)."""
    return REGISTER_MAP.signals[signal].unit

BASELINE_PLC_SIGNALS = ("plc_mode", "fault_code", "status_bits", "pump_state", "valve_state",
                        "pressure_sp_applied", "torque_cmd")
"""The PLC status signals a baseline keeps (core.documents.PlcReading)."""


def software_version() -> str:
    """The package version, plus the git commit of the checkout when there is one."""
    from importlib import metadata
    try:
        v = metadata.version("j4-test-platform")
    except metadata.PackageNotFoundError:
        v = "unknown"
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=5, cwd=Path(__file__).resolve().parent)
        if commit.returncode == 0 and commit.stdout.strip():
            v += f"+g{commit.stdout.strip()}"
    except (OSError, subprocess.SubprocessError):
        pass
    return v


def plan_units(plan: Plan) -> dict[str, str]:
    """The plan stream's channels and their units: phase, motor speed set point, and the
    output angle reference of a position-controlled plan."""
    u = {"phase": "", "w_cmd": "rad/s"}
    if plan.position_control:
        u["q_ref"] = "rad"
    return u


def stream_descriptors(plan: Plan, rig: Rig) -> dict[str, StreamDescriptor]:
    """One descriptor per stream: its source and its channels with units."""
    s = rig.settings
    plc = {ch: plc_unit(sig) for sig, ch in PLC_CHANNELS}
    out: dict[str, StreamDescriptor] = {
        "plc": {"source": f"PLC status block, Modbus TCP {s.plc_host}:{s.plc_port}",
                "clock": "rig_time (PLC acquisition clock)",
                "channels": {"t": "s", **plc}},
        "plan": {"source": f"{plan.name} plan", "channels": plan_units(plan)},
        "interruptions": {"source": "rig events (interlocks, drives, PLC link)",
                          "kinds": list(INTERRUPTION_KINDS)},
    }
    if rig.drives is not None:
        chans = {}
        for d in rig.drives.drives:
            chans.update({f"w_m{d.motor}": unit_of(f"w_m{d.motor}"),
                          f"i_m{d.motor}": unit_of(f"i_m{d.motor}"),
                          f"temp_m{d.motor}": unit_of(f"temp_m{d.motor}")})
        out["drives"] = {"source": f"CANopen drives {list(s.node_ids)} via "
                                   f"{s.can_interface} {s.can_host}:{s.can_port}",
                         "clock": "drive sample stamp 0x2011", "channels": chans}
    return out


def channel_specs(plan: Plan, rig: Rig) -> list[ChannelSpec]:
    """The run's channels in stored order: t, the PLC's, each drive's, the plan's."""
    specs = [ChannelSpec("t", "s", "plc:rig_time")]
    specs += [ChannelSpec(ch, plc_unit(sig), f"plc:{sig}") for sig, ch in PLC_CHANNELS]
    if rig.drives is not None:
        for d in rig.drives.drives:
            src = f"drive {d.node_id}"
            specs += [ChannelSpec(f"w_m{d.motor}", unit_of("w_m1"), f"{src}:0x606C"),
                      ChannelSpec(f"i_m{d.motor}", unit_of("i_m1"), f"{src}:0x6078"),
                      ChannelSpec(f"temp_m{d.motor}", unit_of("temp_m1"), f"{src}:0x2010")]
    for name, unit in plan_units(plan).items():
        specs.append(ChannelSpec(name, unit, f"plan:{plan.name}",
                                 kind="text" if name == "phase" else "float"))
    return specs


def baseline(status: Mapping[str, Any], rig: Rig) -> Baseline:
    """The slow signals of one PLC status read `status` and the rig's drives now: wall time,
    rig time, temperatures, the PLC's state, the drives' states and ratings."""
    out: dict[str, Any] = {
        "wall_time": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
        "rig_time": status["rig_time"], "temp_joint": status["temp_joint"],
        "plc": {k: status[k] for k in BASELINE_PLC_SIGNALS},
        "safe": rig.safe,
    }
    if rig.drives is not None:
        out["drives"] = [{"motor": d.motor, "node_id": d.node_id, "active": d.active,
                          "dropped_reason": d.dropped_reason, "state": d.state,
                          "temperature": d.temperature, "rated_current": d.rated_current,
                          "rated_torque": d.rated_torque} for d in rig.drives.drives]
        for d in rig.drives.drives:
            out[f"temp_m{d.motor}"] = d.temperature
    return json_safe(out)


def start_document(plan: Plan, rig: Rig, *, rig_name: str, source: str, notes: str,
                   operator: str | None, time_scale: float, baseline_start: Baseline,
                   effects: dict[str, Any] | None) -> RunStart:
    """The run's metadata at its start (see the module doc); `effects` is recorded for an
    emulator only (null when nobody declared them)."""
    meta: dict[str, Any] = plan.meta()
    meta.update({
        "rig": rig_name, "source": source,
        "started_at": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": notes, "operator": operator,
        "software_version": software_version(),
        "rig_time_scale": time_scale,
        "settings": rig.settings.as_dict(),
        "limits": rig.interlocks.describe(),
        "streams": stream_descriptors(plan, rig),
        "baseline_start": baseline_start,
        "events_before_start": [{"source": e.source, "kind": e.kind, "message": e.message}
                                for e in rig.events],
    })
    if source == "emulator":
        meta["effects"] = effects if effects is not None else None
        meta["effects_declared_by"] = "operator" if effects is not None else None
    return json_safe(meta)


def counters(rig: Rig, *, samples: int, missed: int, interruptions: int, skipped_writes: int,
             drive_clock: str | None, drive_offset_ms: Mapping[int, float]) -> Counters:
    """What the acquisition counted: the engine's counts (`samples`, `missed` grid slots,
    `interruptions`, `skipped_writes`), the PLC poll's, how the drives' clocks were aligned
    (`drive_clock`, `drive_offset_ms` per motor) and the drives' lost and repeated samples."""
    out: Counters = {
        "samples": samples, "missed_samples": missed,
        "interruptions": interruptions, "skipped_writes": skipped_writes,
        "plc_polls": rig.polls,
        "plc_poll_errors": rig.poll_errors, "plc_repeats": rig.repeats,
        "plc_overruns": rig.overruns, "drive_clock": drive_clock,
        "max_heartbeat_gap_s": round(rig.plc_client.max_beat_gap, 4),
        "drive_clock_offset_ms": {str(m): v for m, v in drive_offset_ms.items()},
    }
    if rig.drives is not None:
        out["drive_samples_lost"] = {str(d.motor): d.stream.lost for d in rig.drives.drives}
        out["drive_samples_duplicated"] = {str(d.motor): d.stream.duplicated
                                           for d in rig.drives.drives}
    return out


def event_notes(events: Sequence[RigEvent], run_time: Callable[[float], float | None]
                ) -> list[EventNote]:
    """The rig's events as the end document lists them, each at its run time [s]."""
    return [{"t_run": run_time(e.t), "source": e.source, "kind": e.kind, "message": e.message}
            for e in events]
