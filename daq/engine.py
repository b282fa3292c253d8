"""ONE engine that runs any plan (daq/plans.py) against the rig (daq/rig.py) and stores the run
record (db/writer.py) while the run goes on: the run's lifecycle (start the rig, measure its
time scale, record, make safe, stop).

The record, in the spirit of bluesky's documents:
- start: metadata — scheme and parameters, rig or emulator, the effects declared for an
  emulated rig, operator, software version, the rig's time scale, one descriptor per stream
  (channel names, units, source) and the slow signals read at the start (baseline)
  (the documents are built in daq/run_record.py, typed in core/documents.py);
- samples, committed in pages by the writer at least every second: on the plan's grid in rig
  time, the first PLC status snapshot of each slot (slots with none are counted as missed,
  never filled), joined with the drives' fast TPDO samples aligned on the drive clock
  (daq/sample_alignment.py);
- interruptions as their own stream: interlock trips, lost drives, PLC link gaps, acquisition
  errors, each in run time [s];
- stop: exit status `success`, `abort` (a trip, the operator) or `fail` (an error), the reason,
  and the slow signals and counters read at the end.

Not stored, for a live view: a progress report every `progress_period` s (plan time, phase,
counts, the latest sample, and the rig's state — PLC, drives, interlocks, e-stop latch —
from what the acquisition already holds, `rig_state`), and one more after make-safe.

Make-safe ALWAYS runs (finally), whether the plan ends, trips, raises or is cancelled; only
then is the run stopped.

The plan timeline is the RIG's clock (the PLC's `rig_time`), so the engine works the same on
the real rig and on the emulator at any time scale.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from core import drive_od
from core.documents import (Baseline, Counters, DriveState, ExitStatus, InterlockState,
                            InterruptionKind, PlcState, RigState, RunEnd, RunStart)
from core.jsonsafe import json_safe
from core.plc_map import FAULT_CODES, PLC_MODES, REGISTER_MAP, STATUS_BITS
from daq import run_record
from daq.interlocks import INTERLOCKS
from daq.plans import Plan
from daq.plc import PlcLinkError
from daq.rig import Rig, RigSafeError
from daq.run_record import PLC_CHANNELS  # noqa: F401 - the run's channels, imported from here too
from daq.sample_alignment import SampleAligner
from db.store import Store
from db.writer import RunWriter

EXIT_SUCCESS: ExitStatus = "success"
EXIT_ABORT: ExitStatus = "abort"
EXIT_FAIL: ExitStatus = "fail"


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
    rig: RigState | None = None
    """The rig's state when reported (rig_state): PLC, drives, interlocks, e-stop latch."""

    @property
    def fraction(self) -> float:
        return 0.0 if self.duration <= 0 else max(0.0, min(1.0, self.t / self.duration))


@dataclass
class RunOutcome:
    """How a run ended."""

    run_id: int | None
    exit_status: ExitStatus
    reason: str | None
    n_samples: int
    missed: int
    interruptions: int


def _raise_if_cancel_requested() -> None:
    """Raise CancelledError when a cancellation of the running task is pending. Python 3.11's
    asyncio.wait_for (inside every pymodbus request) can swallow a cancellation that races a
    reply; the task's cancel count stays up, so the run loop checks it each tick and an
    operator's stop is never lost."""
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError


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

PROGRESS_PERIOD = 0.2
"""Default period of the progress reports [s of wall time]: 5 a second, so that a live view
gets at least 4 a second after the scheduling jitter of a loaded machine."""

_DRIVE_FAULT_STATES = ("FAULT", "FAULT REACTION ACTIVE")


def _named(table: dict[int, str], value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "unknown"
    return table.get(int(value), "unknown")


DRIVE_STOP_WAIT_S = 1.0
"""How long [s] the end of a run waits for every drive's status TPDO to confirm the quick stop
(the state leaves OPERATION ENABLED) before it reads the end baseline: the quick stop goes out
as an RPDO and a drive reports its new state only with its next TPDO, which a loaded host
receives late — the end record would otherwise show a stopped drive as enabled."""


async def drives_left_operation(drives: Sequence, timeout_s: float) -> str:
    """Wait until no drive reports OPERATION ENABLED, at most timeout_s; say how it ended."""
    t0 = time.monotonic()
    while True:
        running = [d for d in drives if d.state == "OPERATION ENABLED"]
        waited = time.monotonic() - t0
        if not running:
            return f"every drive left OPERATION ENABLED within {waited:.2f} s"
        if waited >= timeout_s:
            return ("still reporting OPERATION ENABLED after "
                    f"{timeout_s:g} s: drive(s) {', '.join(str(d.node_id) for d in running)}")
        await asyncio.sleep(0.01)


def rig_state(rig: Rig) -> RigState:
    """The rig's state from what the acquisition already holds — the PLC poll's latest status
    block (`rig.last_status`), the drives' latest statusword, heartbeat and temperature (from
    their TPDOs), the latched trips — so it costs no fieldbus request (cheap enough for every
    progress event: a few dozen dict entries)."""
    now = time.time()
    st = rig.last_status
    if st is not None:
        bits = int(st.get("status_bits", 0))
        mode, fault = st.get("plc_mode"), st.get("fault_code")
        bit_of = REGISTER_MAP.signals["status_bits"].bit
        bit_map = {b: bool(bits & bit_of(b)) for b in STATUS_BITS}
    else:
        bits, mode, fault, bit_map = None, None, None, {b: False for b in STATUS_BITS}
    last_rx = rig.plc["t_rx"][-1] if len(rig.plc) else None
    plc: PlcState = {
        "mode": _named(PLC_MODES, mode), "mode_code": None if mode is None else int(mode),
        "fault_code": None if fault is None else int(fault), "fault": _named(FAULT_CODES, fault),
        "status_bits": bits, "bits": bit_map,
        "link": st is not None and not (rig.gaps and rig.gaps[-1][1] is None),
        "age_s": None if last_rx is None else max(0.0, now - last_rx)}
    drives: list[DriveState] = []
    for d in (rig.drives.drives if rig.drives is not None else []):
        state = d.state
        temp = d.temperature
        drives.append({"motor": d.motor, "node_id": d.node_id, "state": state,
                       "statusword": d.statusword,
                       "enabled": d.active and state == "OPERATION ENABLED",
                       "fault": state in _DRIVE_FAULT_STATES, "active": d.active,
                       "dropped_reason": d.dropped_reason,
                       "temperature": float(temp) if math.isfinite(temp) else None})
    tripped = {}
    for tr in rig.trips:               # the first trip of each interlock is the one latched
        tripped.setdefault(tr.name, tr.message)
    names = list(INTERLOCKS) + [n for n in tripped if n not in INTERLOCKS]
    interlocks: list[InterlockState] = [{"name": n, "tripped": n in tripped,
                                         "message": tripped.get(n)} for n in names]
    return {"at": now, "safe": bool(rig.safe),
            "estop_latched": bit_map["estop"] or "estop" in tripped,
            "estop_reason": tripped.get("estop"), "plc": plc, "drives": drives,
            "interlocks": interlocks}


class Engine:
    """Runs plans against one Rig (not yet started) into one Store.

    `source`: 'emulator' or 'rig'; `effects`: the effects injected in the emulator as
    declared by whoever started it (the stand-in does not report them over its protocols);
    `progress(Progress)` is called every `progress_period` s of wall time on a fixed grid
    (a late report does not delay the next ones), and once more after make-safe with the
    rig's final state (the e-stop latch, the trips);
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
                 progress_period: float = PROGRESS_PERIOD, drive_wait: float = 0.2,
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
        self.stop_reason = "cancelled by the operator"
        """The end reason recorded when the run is cancelled (the canceller may say who or what
        stopped it, e.g. a service that is gone)."""
        self._reset_state()

    def _reset_state(self) -> None:
        self.writer: RunWriter | None = None
        self.aligner: SampleAligner | None = None
        """The run's sample alignment, made once the time scale is measured."""
        self.time_scale = 1.0
        self._i_ev = 0                        # next rig event to look at
        self.n_samples = 0
        self.n_interruptions = 0
        self.skipped_writes = 0
        """Set-point writes skipped while the PLC link was down (retried at the next update)."""
        self._open_gap: float | None = None
        self._sent: dict[str, Any] = {}
        self._latest: dict[str, float] = {}
        self._next_progress = math.inf
        """time.monotonic() at which the next progress report is due (set when the loop
        starts)."""
        self._reported = False
        self._plan: Plan | None = None

    @property
    def missed(self) -> int:
        """Grid slots of the run that had no PLC snapshot."""
        return self.aligner.missed if self.aligner is not None else 0

    @property
    def t0(self) -> float | None:
        """The rig time at plan time 0 [s] (None before the first sample)."""
        return self.aligner.t0 if self.aligner is not None else None

    # --- the run ------------------------------------------------------------------------------

    async def run(self, plan: Plan) -> RunOutcome:
        """Run `plan` once: start the rig, record, make safe (always), stop. Returns the
        outcome; an error in the plan or the engine is recorded as 'fail' and re-raised, a
        cancellation as 'abort' and re-raised."""
        self._reset_state()
        self._plan = plan
        rig = self.rig
        status, reason = EXIT_FAIL, "engine did not start"
        try:
            await rig.start()
            rig.use_limits(plan.limits)
            self.time_scale = await self._measure_time_scale()
            self.aligner = SampleAligner(rig, plan, self.time_scale, drive_wait=self.drive_wait,
                                         shared_drive_clock=self.shared_drive_clock)
            if self.reset_watchdog_fault:
                await self._reset_watchdog_fault()
            self._check_rate(plan)
            start = await self._read_slow()
            self.writer = RunWriter(self.store, commit_interval_s=self.commit_interval_s)
            # database work off the event loop: it also writes the heartbeat the PLC watches
            await _off_loop(self.writer.start, self._start_meta(plan, start),
                            run_record.channel_specs(plan, rig))
            self._i_ev = len(rig.events)  # earlier events are in the start metadata
            await self._prepare(plan)
            status, reason = await self._loop(plan)
        except asyncio.CancelledError:
            status, reason = EXIT_ABORT, self.stop_reason
            raise
        except RigSafeError as exc:
            status, reason = EXIT_ABORT, self._trip_reason() or str(exc)
        except Exception as exc:
            status, reason = EXIT_FAIL, f"{type(exc).__name__}: {exc}"
            raise
        finally:
            await self._finish(status, reason)
        return RunOutcome(self.writer.run_id if self.writer else None, status, reason,
                          self.n_samples, self.missed, self.n_interruptions)

    async def _finish(self, status: ExitStatus, reason: str | None) -> RunEnd:
        """Make safe, take what was acquired, read the end baseline, stop the run, stop the rig.
        Each step is attempted whatever the others do. Returns the end document."""
        rig = self.rig
        notes: RunEnd = {}
        await rig.make_safe(f"run ended: {status}" + (f" ({reason})" if reason else ""))
        notes["after_make_safe"] = await self._final_outputs()
        if rig.drives is not None:   # the end baseline shows the drives as they confirmed it
            notes["drives_stopped"] = await drives_left_operation(rig.drives.drives,
                                                                  DRIVE_STOP_WAIT_S)
        if self.writer is not None and self.writer.run_id is not None:
            try:  # what was acquired up to now, including the way down to safe
                self._collect(final=True)
                self._handle_events(final=True)
            except Exception as exc:  # noqa: BLE001 - the outcome must still be stored
                notes["final_collect_error"] = repr(exc)
        try:
            notes["end"] = await self._read_slow()
        except Exception as exc:  # noqa: BLE001 - the end baseline must not hide the outcome
            notes["end"] = {"error": repr(exc)}
        notes["counters"] = self._counters()
        notes["events"] = run_record.event_notes(rig.events, self._run_time)
        if self._reported and self._plan is not None:  # the final state: safe, trips, e-stop
            with contextlib.suppress(Exception):
                self._report(self._plan)
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

    async def _read_slow(self) -> Baseline:
        """Slow signals and configuration: temperatures, PLC state, drive states and ratings."""
        rig = self.rig
        if rig.drives is not None:  # the status TPDO brings the temperatures
            end = time.monotonic() + 0.5
            while (any(math.isnan(d.temperature) for d in rig.drives.drives)
                   and time.monotonic() < end):
                await asyncio.sleep(0.01)
        st = await rig.plc_client.read_status()
        return run_record.baseline(st, rig)

    def _start_meta(self, plan: Plan, baseline: Baseline) -> RunStart:
        return run_record.start_document(
            plan, self.rig, rig_name=self.rig_name, source=self.source, notes=self.notes,
            operator=self.operator, time_scale=self.time_scale, baseline_start=baseline,
            effects=self.effects)

    async def _prepare(self, plan: Plan) -> None:
        """Set points of plan time 0, the run request, and the hydraulics if the plan uses them."""
        rig = self.rig
        if rig.safe:
            raise RigSafeError(self._trip_reason() or "rig is safe before the run")
        if plan.homing:  # before plan time 0, recorded in the run's metadata
            homing = await rig.home(self.time_scale)
            await _off_loop(self.store.update_run_meta, self.writer.run_id,
                            {"homing": json_safe(homing)})
        await rig.set_dyno_torque(0.0)
        await rig.plc_client.set_command_bits(run=True)
        if plan.uses_hydraulics:
            await rig.set_valve(1)
        if rig.drives is not None:
            await rig.set_motor_speed(0.0)

    # --- the loop -----------------------------------------------------------------------------

    async def _loop(self, plan: Plan) -> tuple[ExitStatus, str | None]:
        rig = self.rig
        tick = max(0.002, 1.0 / rig.settings.plc_poll_hz)
        # set points go out at most every `cmd_period` s of rig time (the dynamometer lags
        # 0.2 s; a 20 Hz position loop at k_p = 5/s moves 1/4 of its error per update)
        cmd_period = min(0.5 * plan.period, 0.05)
        next_cmd = -math.inf
        self.aligner.start_now()  # plan time 0 is the first snapshot from now on
        self._next_progress = time.monotonic()
        while True:
            await asyncio.sleep(tick)
            _raise_if_cancel_requested()
            self._handle_events()
            if rig.safe:
                self._collect()
                errors = rig.events_of("acquisition_error")
                if errors and not rig.trips:
                    return EXIT_FAIL, f"acquisition error: {errors[0].message}"
                return EXIT_ABORT, self._trip_reason() or "rig made safe during the run"
            self._collect()
            if self.aligner.done:
                return EXIT_SUCCESS, None
            tau = self.aligner.now()
            if tau is not None and tau >= next_cmd:
                next_cmd = tau + cmd_period
                await self._command(plan, tau)
            now = time.monotonic()
            if self.progress is not None and now >= self._next_progress:
                # on a fixed grid: a late report does not push the next ones back (the
                # average rate stays 1/progress_period, where `now - last >= period` lost
                # each tick's lateness); never two within half a period (no burst after a
                # stall: the event stream would merge them)
                self._next_progress = max(self._next_progress + self.progress_period,
                                          now + 0.5 * self.progress_period)
                self._report(plan)

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

    def _collect(self, final: bool = False) -> None:
        """Append the samples the alignment has ready (all of those chosen when final)."""
        cols = self.aligner.collect(final)
        if cols is None:
            return
        self.writer.append(cols)
        self.n_samples += len(cols["t"])
        self._latest = {k: v[-1] for k, v in cols.items()}

    # --- interruptions --------------------------------------------------------------------------

    def _run_time(self, wall: float) -> float | None:
        """Plan time [s] of a wall-clock instant (None before the first sample)."""
        return self.aligner.run_time(wall) if self.aligner is not None else None

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

    def _interrupt(self, kind: InterruptionKind, t0: float | None, t1: float | None, reason: str,
                   detail: dict[str, Any]) -> None:
        self.writer.interruption(kind, t0, t1, reason, _clean(detail))
        self.n_interruptions += 1

    def _trip_reason(self) -> str | None:
        trips = self.rig.trips
        if not trips:
            return None
        tr = trips[0]
        reason = f"interlock {tr.name}: {tr.message}"
        if tr.name == "plc_fault":  # was the service starved? (PlcClient.longest_beat_gap)
            reason += (f" (longest gap between the service's heartbeats: "
                       f"{self.rig.plc_client.longest_beat_gap():.2f} s)")
        return reason

    # --- reporting ------------------------------------------------------------------------------

    def _counters(self) -> Counters:
        a = self.aligner
        return run_record.counters(
            self.rig, samples=self.n_samples, missed=self.missed,
            interruptions=self.n_interruptions, skipped_writes=self.skipped_writes,
            drive_clock=a.drive_clock_mode if a is not None else None,
            drive_offset_ms=a.drive_offset if a is not None else {})

    def _report(self, plan: Plan) -> None:
        lt = self._latest
        self._reported = True
        self.progress(Progress(t=float(lt.get("t", 0.0)), duration=plan.duration,
                               phase=str(lt.get("phase", "")), n_samples=self.n_samples,
                               missed=self.missed, latest=dict(lt), rig=rig_state(self.rig)))


async def run_plan(plan: Plan, rig: Rig, store: Store, **engine_kwargs: Any) -> RunOutcome:
    """Run one plan with a fresh Engine (see Engine for the keyword arguments)."""
    return await Engine(rig, store, **engine_kwargs).run(plan)
