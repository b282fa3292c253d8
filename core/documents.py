"""The documents the platform writes, as types: a run's metadata (the run format's `<stem>.json`),
the start document the acquisition engine adds to it (stream descriptors, baselines), the
end document it stores when the run stops, the rig's state its progress events carry, and the
gap diagnosis's report.

Bluesky's event model types its documents the same way (TypedDicts): at run time every
document is a plain JSON-ready dict, stored as it is in the run's `meta` column or a report
row, so the types cost nothing and change no byte of what is written. Every key of the run
metadata is optional (a record from another rig may lack any of them) and unknown keys are kept
(../shared/docs/run-format.md): a TypedDict lists the keys the platform knows, not all a
document may carry.

Where each is built: RunMeta is checked by core.runfile.validate_meta; RunStart, StreamDescriptor,
Baseline and RunEnd are built in daq/run_record.py; RigState in daq/engine.py (rig_state); the
diagnosis report in estimator/diagnosis.py.
"""

from __future__ import annotations

from typing import Any, Literal, TypedDict

ExitStatus = Literal["success", "abort", "fail"]
"""How a run ended: its plan completed, it was stopped (a trip, the operator), or an error."""

InterruptionKind = Literal["interlock", "drive_lost", "plc_link_gap", "acquisition_error"]
"""The kinds of interruption the acquisition engine records in a run's interruptions stream."""

INTERRUPTION_KINDS: tuple[InterruptionKind, ...] = ("interlock", "drive_lost", "plc_link_gap",
                                                    "acquisition_error")


# --- the run format's metadata ------------------------------------------------------------------

class SensorSpec(TypedDict, total=False):
    """What a run says of one channel's sensor (run-format.md, metadata key `sensors`)."""
    resolution: float
    """Quantisation step, in the channel's unit."""
    noise_sd: float
    """Standard deviation of the measurement noise, in the channel's unit."""
    lag_s: float
    """How far the channel lags the others [s]."""


class RunMeta(TypedDict, total=False):
    """A run's metadata as the run format defines it (`<stem>.json`); every key optional and
    nullable, unknown keys kept. Checked by core.runfile.validate_meta (META_KEYS)."""
    scheme: int | None
    """1, 2 or 3."""
    motor_speed_rpm: float | None
    """Motor speed [r/min]; null for scheme 3."""
    direction: int | None
    """+1 or −1 (sense of motion)."""
    reduction: float | None
    """Gear reduction (motor angle / output angle)."""
    rig: str | None
    source: Literal["rig", "emulator", "import"] | None
    sample_rate_hz: float | None
    started_at: str | None
    """ISO 8601 date-time (UTC, `Z`)."""
    notes: str | None
    units: dict[str, str] | None
    """Units of channels the format does not list: {channel: unit}."""
    shear_setpoint_n: float | None
    """Acceptance set point of the hydraulic shear force [N] (core.acceptance)."""
    bend_setpoint_nm: float | None
    """Acceptance set point of the bending moment [N·m] (core.acceptance)."""
    acceptance_settle_s: float | None
    """Settling time after a dynamometer set-point step left out of the acceptance error [s]."""
    sensors: dict[str, SensorSpec] | None


# --- the acquisition engine's start document ----------------------------------------------------

class StreamDescriptor(TypedDict, total=False):
    """One stream of a run (bluesky's descriptor): where it comes from, the clock its times are
    on, and its channels with their units ({channel: unit}); the interruptions stream lists the
    kinds it may hold instead of channels."""
    source: str
    clock: str
    channels: dict[str, str]
    kinds: list[str]


class PlanFacts(TypedDict):
    """The plan a run followed (daq.plans.Plan.meta)."""
    name: str
    duration_s: float
    n_samples_planned: int
    position_control: bool
    uses_hydraulics: bool
    homing: bool
    """The plan homes the joint before plan time 0 (daq.plans.HOMING_SCHEMES)."""
    limit_set: str
    """The interlock limit set it runs under (core.schemes.LIMIT_SETS)."""


class PlcReading(TypedDict):
    """The PLC's state read at a baseline (raw status-block values, core.plc_map)."""
    plc_mode: float
    fault_code: float
    status_bits: float
    pump_state: float
    valve_state: float
    pressure_sp_applied: float
    torque_cmd: float


class DriveReading(TypedDict):
    """One drive's state read at a baseline."""
    motor: int
    node_id: int
    active: bool
    dropped_reason: str | None
    state: str
    temperature: float | None
    """Winding temperature [°C]; null when the drive never reported one."""
    rated_current: float | None
    """[A]"""
    rated_torque: float | None
    """[N·m]"""


class Baseline(TypedDict, total=False):
    """The slow signals read at the start and at the end of a run. Besides these keys it holds
    `temp_m<k>` [°C] of every drive's motor k (keys named per drive, so not listed here)."""
    wall_time: str
    """ISO 8601 UTC with microseconds."""
    rig_time: float
    """The PLC's acquisition clock [s]."""
    temp_joint: float | None
    """[°C]"""
    plc: PlcReading
    safe: bool
    drives: list[DriveReading]
    error: str
    """Instead of the readings: why the end baseline could not be read."""


class EventNote(TypedDict, total=False):
    """A rig event (daq.rig.RigEvent) as a run's record lists it; `t_run` is the run time [s]
    (null before the first sample), absent for the events before the start."""
    t_run: float | None
    source: str
    kind: str
    message: str


class RunStart(RunMeta, total=False):
    """The metadata the acquisition engine stores when a run starts: the run format's keys (the
    scheme's facts) plus the scheme's parameters, the plan, who and what ran it, the rig's time
    scale, the DAQ settings, one descriptor per stream and the start baseline. `end` is added
    when the run stops."""
    scheme_params: dict[str, Any]
    excitation: dict[str, Any]
    """Scheme 3's excitation summary (core.excitation.Excitation.summary)."""
    plan: PlanFacts
    operator: str | None
    software_version: str
    rig_time_scale: float
    """Rig seconds per wall second, measured from the PLC's clock."""
    settings: dict[str, Any]
    """The DAQ settings (daq.settings.Settings.as_dict)."""
    limits: dict[str, Any]
    """The interlock limits the run was held to: the limit set's name and purpose and every
    limit [SI] (daq.interlocks.Interlocks.describe)."""
    limits: dict[str, Any]
    """The interlock limits in force: the limit set's name and purpose and each limit [SI]
    (daq.interlocks.Interlocks.describe)."""
    homing: dict[str, float]
    """Added once the plan homed the joint: q and u before and after [rad], wall time [s]
    (daq.rig.Rig.home)."""
    streams: dict[str, StreamDescriptor]
    """Keys 'plc', 'plan', 'interruptions' and, with drives, 'drives'."""
    baseline_start: Baseline
    events_before_start: list[EventNote]
    effects: dict[str, Any] | None
    """Emulator only: the effects injected, as declared by whoever started it (or null)."""
    effects_declared_by: Literal["operator"] | None
    end: "RunEnd"


# --- the acquisition engine's end document --------------------------------------------------------

class Counters(TypedDict, total=False):
    """What the acquisition counted during a run."""
    samples: int
    missed_samples: int
    """Grid slots with no PLC snapshot (never filled)."""
    interruptions: int
    skipped_writes: int
    """Set-point writes skipped while the PLC link was down."""
    plc_polls: int
    plc_poll_errors: int
    plc_repeats: int
    plc_overruns: int
    drive_clock: str | None
    """How the drives' stamps were aligned with the rig time (null without drive samples)."""
    max_heartbeat_gap_s: float
    drive_clock_offset_ms: dict[str, float]
    """Per motor: drive stamp → rig time offset [ms]."""
    drive_samples_lost: dict[str, int]
    drive_samples_duplicated: dict[str, int]


class RunEnd(TypedDict, total=False):
    """What the engine stores under the run's `meta['end']` when it stops (the exit status
    and the reason are the run row's own columns): the outputs after make-safe, the end
    baseline, the counters and every rig event of the session in run time."""
    after_make_safe: str
    drives_stopped: str
    """Whether every drive reported it left OPERATION ENABLED after the quick stop (its status
    TPDO), and how soon; or which drive did not within the bound (daq.engine.DRIVE_STOP_WAIT_S)."""
    final_collect_error: str
    end: Baseline
    counters: Counters
    events: list[EventNote]


# --- the rig's state in the acquisition's progress events ------------------------------------------

class PlcState(TypedDict):
    """The PLC's state word as the latest status poll decoded it (core.plc_map): no extra read."""
    mode: str
    """PLC mode by name (core.plc_map.PLC_MODES: startup, ready, run, safe), 'unknown' before the
    first poll or for a value the map does not name."""
    mode_code: int | None
    fault_code: int | None
    fault: str
    """The first latched fault by name (core.plc_map.FAULT_CODES), 'unknown' as for `mode`."""
    status_bits: int | None
    """The raw status word."""
    bits: dict[str, bool]
    """Every named bit of the status word (core.plc_map.STATUS_BITS): set or not."""
    link: bool
    """The PLC answers: no open link gap."""
    age_s: float | None
    """How old the latest status snapshot is [s of wall time] (null before the first poll)."""


class DriveState(TypedDict):
    """One drive as the master holds it from the TPDOs and heartbeats it already receives."""
    motor: int
    node_id: int
    state: str
    """CiA 402 state named by the latest statusword ('UNKNOWN' before one came)."""
    statusword: int | None
    enabled: bool
    """In the joint and in OPERATION ENABLED."""
    fault: bool
    """CiA 402 FAULT or FAULT REACTION ACTIVE."""
    active: bool
    """In the joint (not dropped)."""
    dropped_reason: str | None
    temperature: float | None
    """Winding temperature [°C]; null before the status TPDO brought one."""


class InterlockState(TypedDict):
    """One interlock (daq.interlocks.INTERLOCKS, plus any other trip name the rig recorded)."""
    name: str
    tripped: bool
    message: str | None
    """The trip's message when tripped."""


class RigState(TypedDict):
    """The rig's state carried by every progress event (daq.engine.rig_state): built from what
    the acquisition already reads each cycle — the PLC poll's latest status block, the drives'
    TPDO and heartbeat values, the interlocks' latched trips — so an event costs no fieldbus
    traffic."""
    at: float
    """When it was read [s, UNIX time]."""
    safe: bool
    """The rig is latched in its safe state (a trip, make-safe) until reset."""
    estop_latched: bool
    """The e-stop is latched: the PLC's status bit `estop`, or an e-stop trip the rig holds."""
    estop_reason: str | None
    """The e-stop trip's message (null when the PLC reports it latched without one, or none)."""
    plc: PlcState
    drives: list[DriveState]
    """Empty when the rig has no drives configured."""
    interlocks: list[InterlockState]


# --- the gap diagnosis's report -------------------------------------------------------------------

class CoverageEntry(TypedDict):
    """One input's ranges on the training and held-out samples a law kept, and the share of the
    training range the held-out range overlaps (estimator.diagnosis_coverage)."""
    training: list[float]
    held_out: list[float]
    fraction: float
    unit: str


class DiagnosisVerdict(TypedDict, total=False):
    """The diagnosis's verdict (estimator.diagnosis; the keys after `summary` only when a
    twist–torque law was diagnosed too, estimator.diagnosis_verdict.merge_transmission)."""
    status: Literal["none", "explained", "partly_explained", "unexplained"]
    effects: list[str]
    rmse_test_after: float
    model: str
    shapes: dict[str, dict[str, Any]]
    ambiguity_sets: dict[str, dict[str, list[str]]]
    structured_share_removed: float
    structured_share_before: float
    structured_share_after: float
    noise_floor_rms: float
    noise_floor_source: Literal["sensors", "first differences", "held-out residual"]
    residual_after: dict[str, Any]
    summary: str
    laws: dict[str, dict[str, Any]]
    effect_models: dict[str, str]
    offset_channel: dict[str, Any]
    """Which torque reading a torque_offset found on the output law lies in
    (estimator.diagnosis_channel.offset_channel), when a twist–torque law was diagnosed."""
    angle_lag: dict[str, Any]
    """When the twist–torque law chose an angle reading's lag (time_delay, shape angle): which
    reading is late (`reading`: 'q' or 'u') and by how much (`lag_s`, s), from k_lag and the
    least-squares stiffness (estimator.diagnosis._note_angle_lag)."""
    outside_vocabulary: list[str]
    """Causes the runs place outside the vocabulary (an effect taken out of `effects` for it)."""
    held_out_coverage: dict[str, CoverageEntry]
    """Per input (q, qd, temp_joint, abs_torque_load = |τ_L|): how much of the training runs'
    range the held-out runs reach, on the output law's kept samples."""


class DiagnosisReport(TypedDict, total=False):
    """The gap diagnosis's JSON-ready report (estimator.diagnosis.diagnose); its top level.
    The nested parts (regions, candidate rows, tests) are described where they are built."""
    baseline: dict[str, Any]
    """The nominal model fitted on the training runs: model, RMSEs, target, params, counts."""
    regions: list[dict[str, Any]]
    """The flagged regions of the nominal residual."""
    all_regions: list[dict[str, Any]]
    tests: dict[str, Any]
    """Whiteness, cross-correlation, spectral and angle lines of the nominal residual."""
    candidates: list[dict[str, Any]]
    """One row per candidate effect, best first."""
    skipped: dict[str, str]
    """Effects not tried, with the reason."""
    ambiguities: list[list[str]]
    steps: list[dict[str, Any]]
    rejected: list[dict[str, Any]]
    transient_samples_left_out: int
    drive_train_mode: dict[str, float | None] | None
    """The output balance's band capped at half the drive train's first mode (estimator.
    diagnosis.below_drive_train_mode): stiffness [N·m/rad], inertia [kg·m²], mode_hz,
    line_hz (None when the band's excess power, not a line, showed the ringing), band_excess,
    band_hz (before), cutoff_hz; None when the band was left as it was."""
    velocity: dict[str, Any] | None
    """Which velocity the output balance read (estimator.diagnosis_inputs.velocity_source): source
    ("measured" or "output angle"), rmse_measured and rmse_derived [N·m] of the nominal law on
    the training runs, gain_z; None when the law reads no measured velocity."""
    verdict: DiagnosisVerdict
    shrinkage: dict[str, Any]
    options: dict[str, Any]
    series: dict[str, Any]
    """Decimated series for the figures (options.series_points > 0)."""
    transmission: "DiagnosisReport"
    """The twist–torque law's own report, when it was diagnosed."""
