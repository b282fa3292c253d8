"""ONE engine that runs any plan (daq/plans.py) against the rig (daq/rig.py) and stores the run
record (db/writer.py) while the run goes on.

The record, in the spirit of bluesky's documents:
- start: metadata — scheme and parameters, rig or emulator, the effects declared for an
  emulated rig, operator, software version, the rig's time scale, one descriptor per stream
  (channel names, units, source) and the slow signals read at the start (baseline);
- samples, committed in pages by the writer at least every second: on the plan's grid in rig
  time, the first PLC status snapshot of each slot (slots with none are counted as missed,
  never filled), joined with the drives' fast TPDO samples aligned on the drive clock;
- interruptions as their own stream: interlock trips, lost drives, PLC link gaps, acquisition
  errors, each in run time [s];
- stop: exit status `success`, `abort` (a trip, the operator) or `fail` (an error), the reason,
  and the slow signals and counters read at the end.

Make-safe ALWAYS runs (finally), whether the plan ends, trips, raises or is cancelled; only
then is the run stopped.

The plan timeline is the RIG's clock (the PLC's `rig_time`), so the engine works the same on
the real rig and on the emulator at any time scale.
"""

from __future__ import annotations

import asyncio
import bisect
import contextlib
import math
import subprocess
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import numpy as np

from daq.plans import Plan
from daq.plc import PlcLinkError
from daq.rig import Rig, RigSafeError
from db.store import Store
from db.writer import ChannelSpec, RunWriter
from core.channels import unit_of
from core.drive_od import STAMP_WRAP
from core.plc_map import REGISTER_MAP
from core.jsonsafe import json_safe

EXIT_SUCCESS, EXIT_ABORT, EXIT_FAIL = "success", "abort", "fail"

PLC_CHANNELS: tuple[tuple[str, str], ...] = tuple(
    (s.name, s.channel) for s in REGISTER_MAP.status.signals
    if s.channel is not None and s.channel != "t")
"""(status signal, run-format channel) of every PLC status signal that is a channel."""

DRIVE_WRAP_MS = STAMP_WRAP
"""The drives' sample stamp (0x2011) wraps at 2^16 ms."""


@dataclass
class Progress:
    """What the engine reports while it runs (for a progress bar and a live line)."""

    t: float
    """Plan time of the latest sample [s]."""
    duration: float
    phase: str
    n_samples: int
    missed: int
    latest: dict[str, float] = field(default_factory=dict)
    """The latest sample's values by channel."""

    @property
    def fraction(self) -> float:
        return 0.0 if self.duration <= 0 else max(0.0, min(1.0, self.t / self.duration))


@dataclass
class RunOutcome:
    """How a run ended."""

    run_id: int | None
    exit_status: str
    reason: str | None
    n_samples: int
    missed: int
    interruptions: int


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


async def _off_loop(fn: Callable[..., Any], *args: Any) -> Any:
    """Run the blocking database call `fn(*args)` in a thread, so that the event loop, which
    also writes the heartbeat the PLC's watchdog watches, never waits on the database. A
    cancellation meanwhile waits for the call to finish (a run is never left half-created or
    half-stopped), then propagates."""
    fut = asyncio.ensure_future(asyncio.to_thread(fn, *args))
    cancelled = False
    while True:
        try:
            result = await asyncio.shield(fut)
            break
        except asyncio.CancelledError:
            if fut.cancelled():
                raise
            cancelled = True
    if cancelled:
        raise asyncio.CancelledError
    return result


_clean = json_safe


class Engine:
    """Runs plans against one Rig (not yet started) into one Store.

    `source`: 'emulator' or 'rig'; `effects`: the effects injected in the emulator as
    declared by whoever started it (the stand-in does not report them over its protocols);
    `progress(Progress)` is called about every `progress_period` s of wall time;
    `drive_wait` [s of wall time] is how long a sample waits for the drives' TPDOs;
    `shared_drive_clock`: the drives' stamps count the PLC's rig time modulo 2^16 ms (true of
    the stand-in); otherwise they are aligned by receive time.
    `reset_watchdog_fault`: if the PLC holds a heartbeat-watchdog fault latched when the run
    starts (the PLC's reaction to the previous session ending), reset it and re-enable the
    drives — and nothing else: any other trip (an e-stop, a limit) aborts the run.
    """

    def __init__(self, rig: Rig, store: Store, *, source: str = "emulator",
                 rig_name: str | None = None, operator: str | None = None,
                 effects: dict[str, Any] | None = None, notes: str = "",
                 progress: Callable[[Progress], None] | None = None,
                 progress_period: float = 0.25, drive_wait: float = 0.2,
                 shared_drive_clock: bool = True, commit_interval_s: float = 0.5,
                 reset_watchdog_fault: bool = False) -> None:
        if source not in ("emulator", "rig"):
            raise ValueError(f"source must be 'emulator' or 'rig', got {source!r}")
        self.rig = rig
        self.store = store
        self.source = source
        self.rig_name = rig_name or ("J4-emulator" if source == "emulator" else "J4-bench")
        self.operator = operator
        self.effects = effects
        self.notes = notes
        self.progress = progress
        self.progress_period = progress_period
        self.drive_wait = drive_wait
        self.shared_drive_clock = shared_drive_clock
        self.commit_interval_s = commit_interval_s
        self.reset_watchdog_fault = reset_watchdog_fault
        self._reset_state()

    def _reset_state(self) -> None:
        self.writer: RunWriter | None = None
        self.time_scale = 1.0
        self.t0: float | None = None          # rig_time at plan time 0 [s]
        self._i_plc = 0                       # next PLC row to look at
        self._i_ev = 0                        # next rig event to look at
        self._next_slot = 0
        self._pending: list[int] = []         # PLC rows chosen as samples, waiting for drives
        self.n_samples = 0
        self.missed = 0
        self.n_interruptions = 0
        self.skipped_writes = 0
        """Set-point writes skipped while the PLC link was down (retried at the next update)."""
        self._open_gap: float | None = None
        self._drive_offset: dict[int, float] = {}
        self._drive_clock_mode: str | None = None
        self._sent: dict[str, Any] = {}
        self._latest: dict[str, float] = {}
        self._last_progress = 0.0
        self._done = False

    # --- the run ------------------------------------------------------------------------------

    async def run(self, plan: Plan) -> RunOutcome:
        """Run `plan` once: start the rig, record, make safe (always), stop. Returns the
        outcome; an error in the plan or the engine is recorded as 'fail' and re-raised, a
        cancellation as 'abort' and re-raised."""
        self._reset_state()
        rig = self.rig
        status, reason = EXIT_FAIL, "engine did not start"
        try:
            await rig.start()
            self.time_scale = await self._measure_time_scale()
            if self.reset_watchdog_fault:
                await self._reset_watchdog_fault()
            self._check_rate(plan)
            start = await self._read_slow()
            self.writer = RunWriter(self.store, commit_interval_s=self.commit_interval_s)
            # database work off the event loop: it also writes the heartbeat the PLC watches
            await _off_loop(self.writer.start, self._start_meta(plan, start),
                            self._channel_specs(plan))
            self._i_ev = len(rig.events)  # earlier events are in the start metadata
            await self._prepare(plan)
            status, reason = await self._loop(plan)
        except asyncio.CancelledError:
            status, reason = EXIT_ABORT, "cancelled by the operator"
            raise
        except RigSafeError as exc:
            status, reason = EXIT_ABORT, self._trip_reason() or str(exc)
        except Exception as exc:
            status, reason = EXIT_FAIL, f"{type(exc).__name__}: {exc}"
            raise
        finally:
            await self._finish(plan, status, reason)
        return RunOutcome(self.writer.run_id if self.writer else None, status, reason,
                          self.n_samples, self.missed, self.n_interruptions)

    async def _finish(self, plan: Plan, status: str, reason: str | None) -> dict[str, Any]:
        """Make safe, take what was acquired, read the end baseline, stop the run, stop the rig.
        Each step is attempted whatever the others do."""
        rig = self.rig
        notes: dict[str, Any] = {}
        await rig.make_safe(f"run ended: {status}" + (f" ({reason})" if reason else ""))
        notes["after_make_safe"] = await self._final_outputs()
        if self.writer is not None and self.writer.run_id is not None:
            try:  # what was acquired up to now, including the way down to safe
                self._collect(plan, final=True)
                self._handle_events(final=True)
            except Exception as exc:  # noqa: BLE001 - the outcome must still be stored
                notes["final_collect_error"] = repr(exc)
        try:
            notes["end"] = await self._read_slow()
        except Exception as exc:  # noqa: BLE001 - the end baseline must not hide the outcome
            notes["end"] = {"error": repr(exc)}
        notes["counters"] = self._counters()
        notes["events"] = [{"t_run": self._run_time(e.t), "source": e.source, "kind": e.kind,
                            "message": e.message} for e in rig.events]
        w = self.writer
        try:
            if w is not None and w.run_id is not None:
                try:
                    await _off_loop(self.store.update_run_meta, w.run_id, {"end": _clean(notes)})
                finally:
                    await _off_loop(w.stop, status, reason)
        finally:
            with contextlib.suppress(Exception):
                await rig.stop()
        return notes

    async def _final_outputs(self) -> str:
        """After make-safe: pump off and the run request cleared (best effort)."""
        try:
            await self.rig.plc_client.set_command_bits(pump_on=False, run=False)
            await self.rig.plc_client.write_commands({"valve_cmd": 0})
            return "pump off, valve locked, run request cleared"
        except Exception as exc:  # noqa: BLE001
            return f"could not clear the outputs: {exc!r}"

    # --- start --------------------------------------------------------------------------------

    async def _measure_time_scale(self, window: float = 0.3, repeats: int = 3) -> float:
        """Rig seconds per wall second: the median over `repeats` windows of `window` s of the
        least-squares slope of the PLC's rig_time against each status snapshot's receive time
        (an emulator that lags on a loaded machine catches up in bursts; one late reply or one
        burst does not set the scale)."""
        plc = self.rig.plc
        deadline = time.monotonic() + 5.0 + window * repeats
        while len(plc) < 1:
            if time.monotonic() > deadline:
                raise RuntimeError("no PLC status snapshot within 5 s")
            await asyncio.sleep(0.01)
        slopes = []
        for _ in range(repeats):
            i0 = len(plc) - 1
            await asyncio.sleep(window)
            while len(plc) < i0 + 3:
                if time.monotonic() > deadline:
                    raise RuntimeError("the PLC's rig_time does not advance")
                await asyncio.sleep(0.01)
            i1 = len(plc)
            rig_t = np.asarray(plc["rig_time"][i0:i1], dtype=float)
            rx = np.asarray(plc["t_rx"][i0:i1], dtype=float)
            if rig_t[-1] <= rig_t[0] or rx[-1] <= rx[0]:
                raise RuntimeError("the PLC's rig_time does not advance")
            slopes.append(float(np.polyfit(rx - rx[0], rig_t - rig_t[0], 1)[0]))
        return float(np.median(slopes))

    async def _reset_watchdog_fault(self, attempts: int = 3) -> None:
        """Reset a latched PLC heartbeat-watchdog fault (only that) and re-enable the drives."""
        rig = self.rig
        wd = REGISTER_MAP.signals["status_bits"].bit("watchdog_fault")
        for _ in range(attempts):
            st = await rig.plc_client.read_status()
            only_watchdog = all(t.name == "plc_fault" for t in rig.trips)
            if not (rig.safe or int(st["status_bits"]) & wd):
                return
            if not only_watchdog or st["fault_code"] not in (0, 1):
                return  # an e-stop or a limit trip: never reset by software
            rig.record("operator", "watchdog_reset",
                       "latched PLC heartbeat-watchdog fault reset before the run")
            await rig.reset()
            await asyncio.sleep(0.05)
            if rig.drives is not None:
                await asyncio.to_thread(rig.drives.start)
            await asyncio.sleep(0.05)

    def _check_rate(self, plan: Plan) -> None:
        """Refuse a sample rate the PLC poll cannot deliver at this time scale."""
        achievable = self.rig.settings.plc_poll_hz / self.time_scale
        if achievable < 0.9 * plan.sample_rate_hz:
            raise ValueError(
                f"sample rate {plan.sample_rate_hz:g} Hz needs a PLC poll of at least "
                f"{plan.sample_rate_hz * self.time_scale:.0f} Hz at {self.time_scale:.2f} rig s "
                f"per wall s (plc_poll_hz is {self.rig.settings.plc_poll_hz:g}): lower the "
                "sample rate or raise RIG_PLC_POLL_HZ")

    async def _read_slow(self) -> dict[str, Any]:
        """Slow signals and configuration: temperatures, PLC state, drive states and ratings."""
        rig = self.rig
        if rig.drives is not None:  # the status TPDO brings the temperatures
            end = time.monotonic() + 0.5
            while (any(math.isnan(d.temperature) for d in rig.drives.drives)
                   and time.monotonic() < end):
                await asyncio.sleep(0.01)
        st = await rig.plc_client.read_status()
        out: dict[str, Any] = {
            "wall_time": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
            "rig_time": st["rig_time"], "temp_joint": st["temp_joint"],
            "plc": {k: st[k] for k in ("plc_mode", "fault_code", "status_bits", "pump_state",
                                       "valve_state", "pressure_sp_applied", "torque_cmd")},
            "safe": rig.safe,
        }
        if rig.drives is not None:
            out["drives"] = [{"motor": d.motor, "node_id": d.node_id, "active": d.active,
                              "dropped_reason": d.dropped_reason, "state": d.state,
                              "temperature": d.temperature, "rated_current": d.rated_current,
                              "rated_torque": d.rated_torque} for d in rig.drives.drives]
            for d in rig.drives.drives:
                out[f"temp_m{d.motor}"] = d.temperature
        return _clean(out)

    def _start_meta(self, plan: Plan, baseline: dict[str, Any]) -> dict[str, Any]:
        s = self.rig.settings
        meta = plan.meta()
        meta.update({
            "rig": self.rig_name, "source": self.source,
            "started_at": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "notes": self.notes, "operator": self.operator,
            "software_version": software_version(),
            "rig_time_scale": self.time_scale,
            "settings": s.as_dict(),
            "streams": self._descriptors(plan),
            "baseline_start": baseline,
            "events_before_start": [{"source": e.source, "kind": e.kind, "message": e.message}
                                    for e in self.rig.events],
        })
        if self.source == "emulator":
            meta["effects"] = self.effects if self.effects is not None else None
            meta["effects_declared_by"] = "operator" if self.effects is not None else None
        return _clean(meta)

    def _descriptors(self, plan: Plan) -> dict[str, Any]:
        """One descriptor per stream: its source and its channels with units."""
        s = self.rig.settings
        plc = {ch: unit_of(ch) for _, ch in PLC_CHANNELS}
        out: dict[str, Any] = {
            "plc": {"source": f"PLC status block, Modbus TCP {s.plc_host}:{s.plc_port}",
                    "clock": "rig_time (PLC acquisition clock)",
                    "channels": {"t": "s", **plc}},
            "plan": {"source": f"{plan.name} plan", "channels": self._plan_units(plan)},
            "interruptions": {"source": "rig events (interlocks, drives, PLC link)",
                              "kinds": ["interlock", "drive_lost", "plc_link_gap",
                                        "acquisition_error"]},
        }
        if self.rig.drives is not None:
            chans = {}
            for d in self.rig.drives.drives:
                chans.update({f"w_m{d.motor}": unit_of(f"w_m{d.motor}"),
                              f"i_m{d.motor}": unit_of(f"i_m{d.motor}"),
                              f"temp_m{d.motor}": unit_of(f"temp_m{d.motor}")})
            out["drives"] = {"source": f"CANopen drives {list(s.node_ids)} via "
                                       f"{s.can_interface} {s.can_host}:{s.can_port}",
                             "clock": "drive sample stamp 0x2011", "channels": chans}
        return out

    def _plan_units(self, plan: Plan) -> dict[str, str]:
        u = {"phase": "", "w_cmd": "rad/s"}
        if plan.position_control:
            u["q_ref"] = "rad"
        return u

    def _channel_specs(self, plan: Plan) -> list[ChannelSpec]:
        specs = [ChannelSpec("t", "s", "plc:rig_time")]
        specs += [ChannelSpec(ch, unit_of(ch), f"plc:{sig}") for sig, ch in PLC_CHANNELS]
        if self.rig.drives is not None:
            for d in self.rig.drives.drives:
                src = f"drive {d.node_id}"
                specs += [ChannelSpec(f"w_m{d.motor}", unit_of("w_m1"), f"{src}:0x606C"),
                          ChannelSpec(f"i_m{d.motor}", unit_of("i_m1"), f"{src}:0x6078"),
                          ChannelSpec(f"temp_m{d.motor}", unit_of("temp_m1"), f"{src}:0x2010")]
        for name, unit in self._plan_units(plan).items():
            specs.append(ChannelSpec(name, unit, f"plan:{plan.name}",
                                     kind="text" if name == "phase" else "float"))
        return specs

    async def _prepare(self, plan: Plan) -> None:
        """Set points of plan time 0, the run request, and the hydraulics if the plan uses them."""
        rig = self.rig
        if rig.safe:
            raise RigSafeError(self._trip_reason() or "rig is safe before the run")
        await rig.set_dyno_torque(0.0)
        await rig.plc_client.set_command_bits(run=True)
        if plan.uses_hydraulics:
            await rig.set_valve(1)
        if rig.drives is not None:
            await rig.set_motor_speed(0.0)

    # --- the loop -----------------------------------------------------------------------------

    async def _loop(self, plan: Plan) -> tuple[str, str | None]:
        rig = self.rig
        tick = max(0.002, 1.0 / rig.settings.plc_poll_hz)
        # set points go out at most every `cmd_period` s of rig time (the dynamometer lags
        # 0.2 s; a 20 Hz position loop at k_p = 5/s moves 1/4 of its error per update)
        cmd_period = min(0.5 * plan.period, 0.05)
        next_cmd = -math.inf
        self._i_plc = len(rig.plc)  # plan time 0 is the first snapshot from now on
        while True:
            await asyncio.sleep(tick)
            self._handle_events()
            if rig.safe:
                self._collect(plan)
                errors = rig.events_of("acquisition_error")
                if errors and not rig.trips:
                    return EXIT_FAIL, f"acquisition error: {errors[0].message}"
                return EXIT_ABORT, self._trip_reason() or "rig made safe during the run"
            self._collect(plan)
            if self._done:
                return EXIT_SUCCESS, None
            tau = self._now()
            if tau is not None and tau >= next_cmd:
                next_cmd = tau + cmd_period
                await self._command(plan, tau)
            now = time.monotonic()
            if self.progress is not None and now - self._last_progress >= self.progress_period:
                self._last_progress = now
                self._report(plan)

    def _now(self) -> float | None:
        """Plan time now [s], from the latest snapshot extrapolated by the time scale."""
        plc = self.rig.plc
        if self.t0 is None or len(plc) == 0:
            return None
        i = len(plc) - 1
        return plc["rig_time"][i] - self.t0 + (time.time() - plc["t_rx"][i]) * self.time_scale

    async def _command(self, plan: Plan, tau: float) -> None:
        """Send the set points of plan time `tau` [s] (only those that changed). While the
        PLC link is down a write is skipped and retried at the next update: the rig's poll
        loop records the gap, and trips (→ abort) if it outlasts plc_link_timeout."""
        rig = self.rig
        q = rig.last_status["q"] if rig.last_status else None
        sp = plan.setpoints(min(tau, plan.duration), q)
        if rig.drives is not None and sp.motor_speed != self._sent.get("w"):
            await rig.set_motor_speed(sp.motor_speed)
            self._sent["w"] = sp.motor_speed
        try:
            if abs(sp.dyno_torque - self._sent.get("tau", math.inf)) >= 1.0:
                await rig.set_dyno_torque(sp.dyno_torque)
                self._sent["tau"] = sp.dyno_torque
            if sp.pressure != self._sent.get("p"):
                await rig.set_pressure(sp.pressure)
                self._sent["p"] = sp.pressure
            if sp.pump_on != self._sent.get("pump"):
                await rig.set_pump(sp.pump_on)
                self._sent["pump"] = sp.pump_on
        except PlcLinkError:
            self.skipped_writes += 1

    def _collect(self, plan: Plan, final: bool = False) -> None:
        """Choose new PLC snapshots as samples (the first of each grid slot) and append those
        whose drive samples are in (or waited for long enough; all of them when final)."""
        plc = self.rig.plc
        n = len(plc)
        rt = plc["rig_time"]
        n_slots = plan.n_samples()
        while self._i_plc < n and not self._done:
            i = self._i_plc
            self._i_plc += 1
            if self.t0 is None:
                self.t0 = rt[i]
            k = plan.slot(rt[i] - self.t0)
            if k >= n_slots:
                self.missed += n_slots - self._next_slot
                self._next_slot = n_slots
                self._done = True
                break
            if k >= self._next_slot:
                self.missed += k - self._next_slot
                self._next_slot = k + 1
                self._pending.append(i)
                if self._next_slot == n_slots:
                    self._done = True
        ready = []
        while self._pending:
            i = self._pending[0]
            if not (final or self._drives_in(rt[i], plc["t_rx"][i])):
                break
            ready.append(self._pending.pop(0))
        if ready:
            self._append(plan, ready)

    def _drives_in(self, rig_time: float, t_rx: float) -> bool:
        """True when every active drive has a sample at or after `rig_time`, or the sample
        has waited `drive_wait` s."""
        d = self.rig.drives
        if d is None or time.time() - t_rx > self.drive_wait:
            return True
        for dr in d.active:
            st = dr.stream
            if not len(st):
                return False
            off = self._offset(dr)
            if off is None or st.stamp[-1] + off < rig_time * 1000.0:
                return False
        return True

    def _offset(self, dr) -> float | None:
        """Drive stamp → rig time [ms] offset of one drive (estimated once)."""
        if dr.motor in self._drive_offset:
            return self._drive_offset[dr.motor]
        plc, st = self.rig.plc, dr.stream
        if not len(st) or not len(plc):
            return None
        i = len(plc) - 1
        est = plc["rig_time"][i] * 1000.0 + (st.t[-1] - plc["t_rx"][i]) * self.time_scale * 1000.0 \
            - st.stamp[-1]
        mode = "receive time"
        if self.shared_drive_clock:
            snapped = round(est / DRIVE_WRAP_MS) * DRIVE_WRAP_MS
            if abs(est - snapped) < 1000.0:
                est, mode = float(snapped), "shared with the PLC (stamp modulo 2^16 ms)"
        self._drive_offset[dr.motor] = est
        self._drive_clock_mode = mode
        return est

    def _drive_value(self, dr, rig_ms: float) -> tuple[float, float]:
        """(speed, current) of the drive's latest sample at or before rig_ms; NaN when that
        sample is older than two TPDO periods (lost, dropped) or there is none."""
        st = dr.stream
        off = self._offset(dr)
        if off is None:
            return math.nan, math.nan
        j = bisect.bisect_right(st.stamp, rig_ms - off) - 1
        if j < 0 or rig_ms - off - st.stamp[j] > 2 * st.period_ms + 1:
            return math.nan, math.nan
        return st.w[j], st.i[j]

    def _append(self, plan: Plan, rows: list[int]) -> None:
        plc = self.rig.plc
        cols: dict[str, list] = {"t": []}
        for sig, ch in PLC_CHANNELS:
            cols[ch] = []
        drives = self.rig.drives.drives if self.rig.drives is not None else []
        for d in drives:
            for c in (f"w_m{d.motor}", f"i_m{d.motor}", f"temp_m{d.motor}"):
                cols[c] = []
        cols["phase"], cols["w_cmd"] = [], []
        if plan.position_control:
            cols["q_ref"] = []
        for i in rows:
            rig_time = plc["rig_time"][i]
            tau = rig_time - self.t0
            cols["t"].append(tau)
            for sig, ch in PLC_CHANNELS:
                cols[ch].append(plc[sig][i])
            for d in drives:
                w, cur = self._drive_value(d, rig_time * 1000.0)
                cols[f"w_m{d.motor}"].append(w)
                cols[f"i_m{d.motor}"].append(cur)
                cols[f"temp_m{d.motor}"].append(d.temperature)
            sp = plan.setpoints(tau, plc["q"][i])
            cols["phase"].append(sp.phase)
            cols["w_cmd"].append(sp.motor_speed)
            if plan.position_control:
                cols["q_ref"].append(sp.q_ref)
        self.writer.append(cols)
        self.n_samples += len(rows)
        self._latest = {k: v[-1] for k, v in cols.items()}

    # --- interruptions --------------------------------------------------------------------------

    def _run_time(self, wall: float) -> float | None:
        """Plan time [s] of a wall-clock instant, through the PLC snapshots' receive times."""
        plc = self.rig.plc
        if self.t0 is None or not len(plc):
            return None
        rx = plc["t_rx"]
        j = max(0, bisect.bisect_right(rx, wall) - 1)
        return plc["rig_time"][j] - self.t0 + (wall - rx[j]) * self.time_scale

    def _handle_events(self, final: bool = False) -> None:
        """Turn new rig events into interruptions of the run."""
        w = self.writer
        if w is None or w.run_id is None:
            return
        events = self.rig.events
        while self._i_ev < len(events):
            ev = events[self._i_ev]
            self._i_ev += 1
            if ev.kind == "trip":
                self._interrupt("interlock", self._run_time(ev.t), None, ev.message,
                                {k: v for k, v in ev.data.items()})
            elif ev.kind == "dropped":
                self._interrupt("drive_lost", self._run_time(ev.t), None, ev.message, ev.data)
            elif ev.kind == "link_down":
                self._open_gap = ev.t
            elif ev.kind == "link_restored":
                g0, g1 = ev.data.get("gap_start", ev.t), ev.data.get("gap_end", ev.t)
                self._interrupt("plc_link_gap", self._run_time(g0), self._run_time(g1),
                                ev.message, {"gap_s": g1 - g0})
                self._open_gap = None
            elif ev.kind == "acquisition_error":
                self._interrupt("acquisition_error", self._run_time(ev.t), None, ev.message, {})
        if final and self._open_gap is not None:
            self._interrupt("plc_link_gap", self._run_time(self._open_gap), None,
                            "PLC link still down when the run ended", {})
            self._open_gap = None

    def _interrupt(self, kind: str, t0: float | None, t1: float | None, reason: str,
                   detail: dict[str, Any]) -> None:
        self.writer.interruption(kind, t0, t1, reason, _clean(detail))
        self.n_interruptions += 1

    def _trip_reason(self) -> str | None:
        trips = self.rig.trips
        if not trips:
            return None
        tr = trips[0]
        reason = f"interlock {tr.name}: {tr.message}"
        if tr.name == "plc_fault":  # was the service starved? (see PlcClient.max_beat_gap)
            reason += (f" (longest gap between the service's heartbeats: "
                       f"{self.rig.plc_client.max_beat_gap:.2f} s)")
        return reason

    # --- reporting ------------------------------------------------------------------------------

    def _counters(self) -> dict[str, Any]:
        rig = self.rig
        out: dict[str, Any] = {
            "samples": self.n_samples, "missed_samples": self.missed,
            "interruptions": self.n_interruptions, "skipped_writes": self.skipped_writes,
            "plc_polls": rig.polls,
            "plc_poll_errors": rig.poll_errors, "plc_repeats": rig.repeats,
            "plc_overruns": rig.overruns, "drive_clock": self._drive_clock_mode,
            "max_heartbeat_gap_s": round(rig.plc_client.max_beat_gap, 4),
            "drive_clock_offset_ms": dict(self._drive_offset),
        }
        if rig.drives is not None:
            out["drive_samples_lost"] = {d.motor: d.stream.lost for d in rig.drives.drives}
            out["drive_samples_duplicated"] = {d.motor: d.stream.duplicated
                                               for d in rig.drives.drives}
        return out

    def _report(self, plan: Plan) -> None:
        lt = self._latest
        self.progress(Progress(t=float(lt.get("t", 0.0)), duration=plan.duration,
                               phase=str(lt.get("phase", "")), n_samples=self.n_samples,
                               missed=self.missed, latest=dict(lt)))


async def run_plan(plan: Plan, rig: Rig, store: Store, **engine_kwargs: Any) -> RunOutcome:
    """Run one plan with a fresh Engine (see Engine for the keyword arguments)."""
    return await Engine(rig, store, **engine_kwargs).run(plan)
