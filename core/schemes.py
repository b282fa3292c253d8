"""The three experiment schemes of the paper (section II-B; rig.md) as parameter dataclasses with
the paper's defaults and pure set-point profiles: functions of time [s] (scalars or arrays) giving
the motor speed set point, the output position reference (scheme 3), the dynamometer torque set
point, the hydraulic pump and pressure set points and the phase label.

Pure: no simulator (or driver) import. The emulator (simulators.offline) samples these profiles
at its 1 kHz internal rate; the data acquisition can use the same plans on the real rig.

Each settable parameter is described once, in its dataclass field (`param`: default, unit, what
it is, range, the `rig run` option); the schemes check the ranges themselves, and the service's
request schema (api/routers/schemes.py) and `rig run`'s flags derive from `scheme_params` /
`scheme_options`. A whole run travels as one `RunSpec` JSON document (`rig run --spec`).

Conventions: motor speeds in rad/s at the motor shaft, signed by the direction of motion; loads
in N·m at the joint output (positive = the paper's positive loading); angles in rad.
"""

from __future__ import annotations

import abc
import json
import math
from dataclasses import MISSING, asdict, dataclass, field, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from core.effects import resolve_effects
from core.excitation import ExcitationResult, FourierTrajectory, optimize_excitation
from core.params import RATED_TORQUE, REDUCTION, JointParams

RPM = 2.0 * math.pi / 60.0
"""One revolution per minute in rad/s."""
MOTOR_SPEED_LIMIT_RPM = 3000.0
"""Highest motor speed of the schemes [r/min] (rig.md: 300 and 3000 r/min)."""
OUTPUT_SPEED_LIMIT = MOTOR_SPEED_LIMIT_RPM * RPM / REDUCTION
"""Output speed at 3000 r/min behind N = 11000 [rad/s] (≈ 0.0286, Table 10's ~0.03 rad/s)."""
JOINT_LIMIT = math.pi
"""J4 range ±180° [rad] (rig.md)."""
RANGE_TORQUE = 180e3
"""Top of the torque loading range [N·m] (Table 11 item 1: 0–180 kN·m)."""


@dataclass(frozen=True)
class LimitSet:
    """The interlock limits a run is held to, chosen by its test purpose and recorded with the
    run (daq/interlocks.py applies them; the other limits stay the DAQ settings')."""
    name: str
    purpose: str
    max_load: float
    """Largest dynamometer load a scheme under this set may ask for [N·m]."""
    torque_limit: float | None
    """|joint torque| trip [N·m]; None: the DAQ settings' torque_limit (105 % of rated)."""
    angle_limit: float = JOINT_LIMIT
    """|output angle| trip [rad], on the homed output encoder (the joint's ±180° travel)."""


LIMIT_SETS = {
    "default": LimitSet("default", "the paper's schemes: loading up to the rated torque",
                        RATED_TORQUE, None),
    "range": LimitSet("range", "Table 11 item 1: the torque loading range up to 180 kN·m",
                      RANGE_TORQUE, 1.05 * RANGE_TORQUE),
}
"""The limit sets by name; every scheme runs under "default" unless it names another."""


def limit_set_named(name: str) -> LimitSet:
    """The limit set called `name` (ValueError naming the known ones)."""
    if name not in LIMIT_SETS:
        raise ValueError(f"limit set must be one of {', '.join(LIMIT_SETS)}, got {name!r}")
    return LIMIT_SETS[name]


MIN_LOAD_STEP = 1e3
"""Smallest load step of scheme 2 [N·m] (half Table 11's ±2 kN·m torque accuracy band; the
paper steps by 10 kN·m): at most RANGE_TORQUE / MIN_LOAD_STEP = 180 steps. An unbounded step
count let one schema-valid request (step = 1e-3 N·m: 1.2e8 steps; or a step below the float
resolution of the load, which never ends) grow the profile's lists in the requesting process
until the machine ran out of memory."""
MAX_PHASE_TIME = 600.0
"""Longest idle, ramp, settle, hold or pause a scheme may ask for [s]."""
MAX_RUN_TIME = 3600.0
"""Longest run a scheme may ask for [s of rig time] (the paper's runs take 100–400 s): a run's
set points, samples and documents grow with its length, so a request for a run of days (a
ramp rate near zero with the joint at rest) is refused before anything is allocated."""


def _check_run_time(scheme: Any) -> None:
    d = scheme.duration()
    if not math.isfinite(d) or d > MAX_RUN_TIME:
        raise ValueError(f"scheme {scheme.scheme} would run {d:.3g} s, beyond the longest run "
                         f"of {MAX_RUN_TIME:g} s: raise ramp_rate or shorten its phases")


@dataclass(frozen=True)
class Bounds:
    """How a scheme parameter may be set: its unit, what it is, its range and the `rig run`
    option that sets it. Kept in the dataclass field's metadata (`param`); the schemes check
    it themselves, the service's request schema and the command line's flags derive from it."""
    unit: str
    """SI-style unit ('' for a pure number)."""
    doc: str
    """What it is, a short noun phrase (the API's description, the command line's help)."""
    option: str | None
    """`rig run --OPTION` (and the API parameter of the same field); None: fixed by the
    design, not settable from outside (the dataclass still accepts it)."""
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    choices: tuple[int, ...] | tuple[str, ...] | None = None
    """The values allowed, for an int or a str field (a str field always has them)."""

    def interval(self) -> str:
        """The range as text, e.g. '(0 r/min, 3000 r/min]', 'one of +1, -1'."""
        u = f" {self.unit}" if self.unit else ""
        if self.choices is not None:
            return "one of " + ", ".join(c if isinstance(c, str) else f"{c:+d}"
                                         for c in self.choices)
        lo = f"[{self.ge:g}{u}" if self.ge is not None else (
            f"({self.gt:g}{u}" if self.gt is not None else "(-inf")
        hi = f"{self.le:g}{u}]" if self.le is not None else "inf)"
        return f"{lo}, {hi}"

    def check(self, name: str, typ: type, value: Any) -> None:
        """ValueError naming the parameter, its range and the value, when `value` is out of
        range or not a value of the field's type (NaN is refused: no comparison holds)."""
        if typ is str:
            if not isinstance(value, str) or value not in (self.choices or ()):
                raise ValueError(f"{name}: {self.doc} must be {self.interval()}, got {value!r}")
            return
        if isinstance(value, bool) or not isinstance(value, int if typ is int else (int, float)):
            kind = "an integer" if typ is int else "a number"
            raise ValueError(f"{name}: {self.doc} must be {kind}, got {value!r}")
        ok = ((self.choices is None or value in self.choices)
              and (self.ge is None or value >= self.ge) and (self.gt is None or value > self.gt)
              and (self.le is None or value <= self.le) and value == value)
        if not ok:
            where = self.interval() if self.choices is not None else "in " + self.interval()
            raise ValueError(f"{name}: {self.doc} must be {where}, got {value!r}")


def param(default: Any, unit: str, doc: str, option: str | None, *, ge: float | None = None,
          gt: float | None = None, le: float | None = None,
          choices: tuple[int, ...] | tuple[str, ...] | None = None) -> Any:
    """A scheme dataclass field with its default and Bounds (the one place a scheme parameter
    is described)."""
    return field(default=default, metadata={"bounds": Bounds(unit, doc, option, ge=ge, gt=gt,
                                                             le=le, choices=choices)})


def _field_type(f: Any) -> type:
    """int, str or float: the annotations are strings (postponed evaluation)."""
    return {"int": int, "str": str}.get(str(f.type).split(" ")[0], float)


def _check_bounds(scheme: Any) -> None:
    for f in fields(scheme):
        b = f.metadata.get("bounds")
        if b is not None:
            b.check(f.name, _field_type(f), getattr(scheme, f.name))


@dataclass(frozen=True)
class SchemeParam:
    """One settable parameter of one scheme, as the service and the command line see it."""
    name: str
    """The scheme dataclass field."""
    type: type
    """int, float or str (a str parameter has its choices in `bounds`)."""
    default: Any
    bounds: Bounds


def _durations(default: float, doc: str, option: str | None) -> Any:
    return param(default, "s", doc, option, ge=0.0, le=MAX_PHASE_TIME)


def _segment_labels(t: ArrayLike, segments: list[tuple[float, float, str]]) -> np.ndarray:
    """Label of each time from [(t_start, t_end, label)] (half-open, in order; the last one
    also holds at its end)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    out = np.empty(t.shape, dtype=object)
    out[:] = segments[-1][2]
    for t0, t1, label in reversed(segments):
        out[(t >= t0) & (t < t1)] = label
    return out


@dataclass(frozen=True)
class _LoadingScheme(abc.ABC):
    """Common parameters of the loading schemes 1 and 2 (times in s, torques in N·m)."""
    motor_speed_rpm: float = param(3000.0, "r/min", "motor speed", "speed", gt=0.0,
                                   le=MOTOR_SPEED_LIMIT_RPM)
    """Motor speed: 300 or 3000 r/min in the paper."""
    direction: int = param(1, "", "sense of motion", "direction", choices=(1, -1))
    load_target: float = param(RATED_TORQUE, "N·m", "load at the top", "load", ge=0.0,
                               le=RANGE_TORQUE)
    """Dynamometer load at the top (the rated 120 kN·m); at most its limit set's max_load."""
    accel_time: float = _durations(1.0, "speed ramp time", "accel_time")
    """Motor speed ramp from rest to speed and back (design: no jolt on the drive train)."""
    settle_time: float = _durations(1.0, "idle at speed before loading", "settle_time")
    """("start the joint motor ... then load")."""
    rest_time: float = _durations(1.0, "idle at rest after the motion", "rest_time")
    shear_target: float = param(90e3, "N", "hydraulic shear while loading", "shear", ge=0.0,
                                le=90e3)
    """Table 11's 90 kN; bending = shear·arm."""
    sample_rate_hz: float = param(10.0, "Hz", "sample rate", "sample_rate", ge=10.0, le=1000.0)
    """The paper reads the encoder every 0.1 s; rig.md asks for at least 10 Hz."""
    limit_set: str = param("default", "", "interlock limit set", "limit_set",
                           choices=tuple(LIMIT_SETS))
    """The interlock limits the run is held to (LIMIT_SETS): "range" for a torque loading
    range test above the rated torque (Table 11 item 1); recorded with the run."""

    scheme: ClassVar[int] = 0

    def __post_init__(self) -> None:
        _check_bounds(self)
        limits = limit_set_named(self.limit_set)
        if self.load_target > limits.max_load:
            raise ValueError(f"load_target {self.load_target:g} N·m is beyond the "
                             f"{limits.name!r} limit set's {limits.max_load:g} N·m "
                             f"({limits.purpose})")
        _check_run_time(self)

    # --- given by each scheme ---------------------------------------------------------------
    @abc.abstractmethod
    def load_profile(self) -> tuple[list[float], list[float], list[tuple[float, float, str]]]:
        """Breakpoints (times from the start of loading [s], loads [N·m]) of the piecewise
        linear dynamometer set point, and the phase segments in the same time base."""

    # --- derived timeline -----------------------------------------------------------------
    @property
    def load_start(self) -> float:
        """Time the loading starts [s]."""
        return self.accel_time + self.settle_time

    @property
    def load_end(self) -> float:
        """Time the load is back at zero [s]."""
        times, _, _ = self.load_profile()
        return self.load_start + times[-1]

    def duration(self) -> float:
        """Length of the run [s]."""
        return self.load_end + self.accel_time + self.rest_time

    @property
    def motor_speed_rad_s(self) -> float:
        """Signed motor speed set point while moving [rad/s at the motor shaft]."""
        return self.direction * self.motor_speed_rpm * RPM

    def motor_speed(self, t: ArrayLike) -> np.ndarray:
        """Motor speed set point [rad/s at the motor shaft]: ramp up, constant through the
        loading, ramp down after it."""
        t = np.asarray(t, dtype=float)
        up = np.clip(t / self.accel_time, 0.0, 1.0) if self.accel_time > 0 else (t >= 0) * 1.0
        t_down = self.load_end
        if self.accel_time > 0:
            down = np.clip(1.0 - (t - t_down) / self.accel_time, 0.0, 1.0)
        else:
            down = (t < t_down) * 1.0
        return self.motor_speed_rad_s * np.minimum(up, down)

    def position_ref(self, t: ArrayLike) -> None:
        """Schemes 1 and 2 run in speed control: no position reference."""
        return None

    def dyno_torque(self, t: ArrayLike) -> np.ndarray:
        """Dynamometer torque set point [N·m]."""
        times, loads, _ = self.load_profile()
        return np.interp(np.asarray(t, dtype=float) - self.load_start, times, loads,
                         left=0.0, right=0.0)

    def pump_on(self, t: ArrayLike) -> np.ndarray | bool:
        """Hydraulic pump state: on for the whole run."""
        return np.ones(np.shape(t), dtype=bool) if np.ndim(t) else True

    def pressure_setpoint(self, t: ArrayLike,
                          cyl_area: float = JointParams().cyl_area) -> np.ndarray:
        """Proportional regulator set point [Pa]: shear_target/cylinder area while loading
        (load, hold and unload phases), 0 otherwise."""
        t = np.asarray(t, dtype=float)
        on = (t >= self.load_start) & (t < self.load_end)
        return np.where(on, self.shear_target / cyl_area, 0.0)

    def phase(self, t: ArrayLike) -> np.ndarray:
        """Phase label of each time: idle, load, hold, unload, idle."""
        _, _, segs = self.load_profile()
        s0 = self.load_start
        segments = [(0.0, s0, "idle")] + [(s0 + a, s0 + b, lab) for a, b, lab in segs]
        segments.append((self.load_end, math.inf, "idle"))
        return _segment_labels(t, segments)

    def travel(self) -> float:
        """Output angle covered by the motion [rad] (must stay inside ±180°)."""
        return abs(self.motor_speed_rad_s) / REDUCTION * (self.load_end)

    def meta(self) -> dict[str, Any]:
        """Run-format metadata of this plan (scheme, motor speed, direction, sample rate) plus
        its parameters under "scheme_params"."""
        return {"scheme": self.scheme, "motor_speed_rpm": self.motor_speed_rpm,
                "direction": self.direction, "reduction": REDUCTION,
                "sample_rate_hz": self.sample_rate_hz, "scheme_params": asdict(self)}


@dataclass(frozen=True)
class Scheme1(_LoadingScheme):
    """Scheme 1 — torque vs speed and load: at constant motor speed, load the output slowly to
    the rated torque and unload slowly to 0 (paper II-B, rig.md)."""
    ramp_rate: float = param(2.4e3, "N·m/s", "load and unload rate", "ramp_rate", gt=0.0,
                             le=1e5)
    """2.4 kN·m/s keeps a 3000 r/min run within ±180° (0.0286 rad/s × ~102 s ≈ 167°)."""
    hold_top: float = _durations(0.0, "hold at the top load", "hold_top")
    """The paper goes straight from loading to unloading."""

    scheme: ClassVar[int] = 1

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.travel() > JOINT_LIMIT:
            raise ValueError(f"scheme 1 would turn the joint {math.degrees(self.travel()):.0f}°, "
                             "beyond ±180°: raise ramp_rate or lower the speed")

    def load_profile(self) -> tuple[list[float], list[float], list[tuple[float, float, str]]]:
        t_up = self.load_target / self.ramp_rate
        times = [0.0, t_up, t_up + self.hold_top, 2 * t_up + self.hold_top]
        loads = [0.0, self.load_target, self.load_target, 0.0]
        segs = [(0.0, t_up, "load")]
        if self.hold_top > 0:
            segs.append((t_up, t_up + self.hold_top, "hold"))
        segs.append((t_up + self.hold_top, times[-1], "unload"))
        return times, loads, segs


@dataclass(frozen=True)
class Scheme2(_LoadingScheme):
    """Scheme 2 — current and torque following curves: load forward in `step` increments,
    pausing `pause` at each, up to the rated torque; then unload (paper II-B, rig.md)."""
    step: float = param(10e3, "N·m", "load step", "step", ge=MIN_LOAD_STEP, le=RATED_TORQUE)
    """The paper's 10 kN·m; at least MIN_LOAD_STEP, so a profile has at most a few hundred
    steps (load_profile builds one breakpoint per step before any run-time check)."""
    pause: float = _durations(2.0, "pause at each step", "pause")
    ramp_rate: float = param(3e3, "N·m/s", "rate between steps", "ramp_rate", gt=0.0, le=1e5)
    """Design: 3.3 s per step; the dynamometer's 0.2 s lag then trails by 0.6 kN·m, leaving
    room inside Table 11's ±2 kN·m for its slow error."""
    unload_rate: float = param(3.5e3, "N·m/s", "unload rate after the last pause",
                               "unload_rate", gt=0.0, le=1e5)
    """Design: a 3000 r/min run then turns the joint ~164°, inside ±180°; the lag trails by
    0.7 kN·m."""

    scheme: ClassVar[int] = 2

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.travel() > JOINT_LIMIT:
            raise ValueError(f"scheme 2 would turn the joint {math.degrees(self.travel()):.0f}°, "
                             "beyond ±180°: raise the rates or lower the speed")

    def load_profile(self) -> tuple[list[float], list[float], list[tuple[float, float, str]]]:
        times, loads, segs = [0.0], [0.0], []
        t, level = 0.0, 0.0
        while level < self.load_target - 1e-9:
            nxt = min(level + self.step, self.load_target)
            t_ramp = (nxt - level) / self.ramp_rate
            segs.append((t, t + t_ramp, "load"))
            t += t_ramp
            times.append(t)
            loads.append(nxt)
            if self.pause > 0:
                segs.append((t, t + self.pause, "hold"))
                t += self.pause
                times.append(t)
                loads.append(nxt)
            level = nxt
        t_down = level / self.unload_rate
        segs.append((t, t + t_down, "unload"))
        times.append(t + t_down)
        loads.append(0.0)
        return times, loads, segs


@dataclass(frozen=True)
class Scheme3:
    """Scheme 3 — Fourier excitation (Eq. 12, order 5) within ±180° and the speed limit, the
    coefficients optimised for the condition number of Eq. 4's observation matrix (core.excitation).
    No dynamometer load and no hydraulics: the run identifies the rigid-body parameters."""
    order: int = param(5, "", "Fourier order", "order", ge=2, le=10)
    """5 in the paper."""
    base_freq_hz: float = param(0.05, "Hz", "base frequency ω_f/2π", "base_freq", gt=0.0, le=1.0)
    """Design: 20 s period; the 5th harmonic, 0.25 Hz, stays far below the drives' 25 rad/s
    speed loop and the ~8 Hz drive-train mode, and the accelerations reach a_max so the inertia
    is identifiable."""
    n_periods: int = param(15, "", "periods of excitation", "periods", ge=1, le=100)
    """15 × 20 s = 300 s of excitation."""
    q_max: float = param(JOINT_LIMIT, "rad", "position limit", None, gt=0.0, le=JOINT_LIMIT)
    """±180°."""
    motor_speed_limit_rpm: float = param(MOTOR_SPEED_LIMIT_RPM, "r/min", "motor speed limit",
                                         None, gt=0.0, le=MOTOR_SPEED_LIMIT_RPM)
    """The output limit is this / N."""
    a_max: float = param(0.05, "rad/s²", "output acceleration limit", "a_max", gt=0.0, le=1.0)
    """Design: the reflected inertia ~7.9e4 kg·m² then needs ≤ 4 kN·m, a few % of the rated
    torque."""
    direction: int = param(1, "", "sense of motion", "direction", choices=(1, -1))
    """+1 runs the optimised trajectory, −1 its mirror image."""
    rest_time: float = _durations(2.0, "idle at rest before and after the excitation",
                                  "rest_time")
    position_gain: float = param(5.0, "1/s", "position-loop gain", "position_gain", gt=0.0,
                                 le=50.0)
    """Proportional gain on the motor-side angle (with speed feed-forward)."""
    sample_rate_hz: float = param(1000.0, "Hz", "sample rate", "sample_rate", ge=10.0, le=1000.0)
    """Design: the drives' 1 kHz rate; 300 000 samples put the standard error of I_xx near
    0.4 % with the default sensor noise, and a 20 Hz zero-phase derivative of qd then captures
    the drive-train transients after velocity reversals."""
    opt_seed: int = param(0, "", "seed of the excitation optimisation", "opt_seed", ge=0,
                          le=2**31 - 1)
    coefficients: tuple | None = None
    """Fixed (a, b, q0) instead of optimising: a, b [rad/s] of length `order`, q0 [rad]."""

    scheme: ClassVar[int] = 3

    def __post_init__(self) -> None:
        _check_bounds(self)
        _check_run_time(self)
        if self.coefficients is not None:
            a, b, q0 = self.coefficients
            object.__setattr__(self, "coefficients",
                               (tuple(map(float, a)), tuple(map(float, b)), float(q0)))
            if len(self.coefficients[0]) != self.order or len(self.coefficients[1]) != self.order:
                raise ValueError(f"coefficients need {self.order} a's and b's")

    @property
    def v_max(self) -> float:
        """Output speed limit [rad/s]."""
        return self.motor_speed_limit_rpm * RPM / REDUCTION

    def excitation(self) -> ExcitationResult | None:
        """The optimisation result (cached per parameter set); None with fixed coefficients."""
        if self.coefficients is not None:
            return None
        return optimize_excitation(order=self.order, base_freq_hz=self.base_freq_hz,
                                   q_max=self.q_max, v_max=self.v_max, a_max=self.a_max,
                                   seed=self.opt_seed)

    def trajectory(self) -> FourierTrajectory:
        """The Eq. 12 trajectory this plan runs (before the direction sign)."""
        if self.coefficients is not None:
            a, b, q0 = self.coefficients
            return FourierTrajectory(a, b, 2 * math.pi * self.base_freq_hz, q0)
        return self.excitation().trajectory

    @property
    def excite_time(self) -> float:
        """Length of the excitation [s]."""
        return self.n_periods / self.base_freq_hz

    def duration(self) -> float:
        """Length of the run [s]."""
        return self.excite_time + 2 * self.rest_time

    def position_ref(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Output position [rad] and velocity [rad/s] references: at rest at the trajectory's
        start before and after, Eq. 12 in between."""
        t = np.asarray(t, dtype=float)
        tr = self.trajectory()
        tau = np.clip(t - self.rest_time, 0.0, self.excite_time)
        q, qd, _ = tr.evaluate(tau)
        moving = (t > self.rest_time) & (t < self.rest_time + self.excite_time)
        q0, _, _ = tr.evaluate(np.zeros(1))
        q = np.where(moving, q, np.where(t <= self.rest_time, q0[0], q))
        return self.direction * q, self.direction * np.where(moving, qd, 0.0)

    def motor_speed(self, t: ArrayLike) -> np.ndarray:
        """Motor speed feed-forward [rad/s at the motor shaft]: N·q̇_ref."""
        return REDUCTION * self.position_ref(t)[1]

    def dyno_torque(self, t: ArrayLike) -> np.ndarray:
        """No load in scheme 3: set point 0 N·m."""
        return np.zeros(np.shape(t))

    def pump_on(self, t: ArrayLike) -> np.ndarray | bool:
        """Hydraulics off in scheme 3."""
        return np.zeros(np.shape(t), dtype=bool) if np.ndim(t) else False

    def pressure_setpoint(self, t: ArrayLike,
                          cyl_area: float = JointParams().cyl_area) -> np.ndarray:
        """No hydraulic load in scheme 3: 0 Pa."""
        return np.zeros(np.shape(t))

    def phase(self, t: ArrayLike) -> np.ndarray:
        """idle, excite, idle."""
        t0 = self.rest_time
        return _segment_labels(t, [(0.0, t0, "idle"), (t0, t0 + self.excite_time, "excite"),
                                   (t0 + self.excite_time, math.inf, "idle")])

    def meta(self) -> dict[str, Any]:
        """Run-format metadata (motor_speed_rpm is null for scheme 3) plus the parameters and
        the excitation's condition numbers."""
        out = {"scheme": 3, "motor_speed_rpm": None, "direction": self.direction,
               "reduction": REDUCTION, "sample_rate_hz": self.sample_rate_hz,
               "scheme_params": asdict(self)}
        ex = self.excitation()
        if ex is not None:
            out["excitation"] = ex.summary()
        return out


SCHEMES = {1: Scheme1, 2: Scheme2, 3: Scheme3}


def make_scheme(number: int, **params: Any) -> "Scheme1 | Scheme2 | Scheme3":
    """Plan of scheme 1, 2 or 3 with the given parameters (others at the paper's defaults)."""
    if number not in SCHEMES:
        raise ValueError(f"scheme must be 1, 2 or 3, got {number!r}")
    return SCHEMES[number](**params)


def scheme_params(number: int) -> tuple[SchemeParam, ...]:
    """The parameters of scheme `number` settable from the service and the command line, in
    the dataclass's order (those with an option in their Bounds)."""
    if number not in SCHEMES:
        raise ValueError(f"scheme must be 1, 2 or 3, got {number!r}")
    out = []
    for f in fields(SCHEMES[number]):
        b = f.metadata.get("bounds")
        if b is not None and b.option is not None:
            out.append(SchemeParam(f.name, _field_type(f), f.default, b))
    return tuple(out)


def scheme_options() -> dict[str, tuple[str, type, dict[int, SchemeParam]]]:
    """Every `rig run` option of the schemes: option -> (dataclass field, type, {scheme number:
    its parameter}); an option names the same field in every scheme that has it."""
    out: dict[str, tuple[str, type, dict[int, SchemeParam]]] = {}
    for number in SCHEMES:
        for p in scheme_params(number):
            name, typ, per = out.setdefault(p.bounds.option, (p.name, p.type, {}))
            if (name, typ) != (p.name, p.type):
                raise AssertionError(f"option {p.bounds.option!r} names {name} and {p.name}")
            per[number] = p
    return out


RUN_SOURCES = ("emulator", "rig")


@dataclass(frozen=True)
class RunSpec:
    """What one `rig run` runs and records, as one JSON document: `rig run --spec FILE` reads
    it (the command line's flags build the same thing), and the service's acquisition process
    hands it over that way. It holds no secret: the database is named by RIG_DB_URL."""
    scheme: int
    """1, 2 or 3."""
    params: dict[str, Any] = field(default_factory=dict)
    """{dataclass field: value} of the scheme's settable parameters (scheme_params); the others
    at the paper's defaults."""
    operator: str | None = None
    """Who runs it (stored with the run)."""
    notes: str = ""
    effects: dict[str, dict[str, float]] | None = None
    """Effects injected in the emulator {name: {param: value}}, recorded with the run."""
    source: str | None = None
    """'emulator' or 'rig' (None: decided from the DAQ settings' PLC address)."""
    rig_name: str | None = None
    reset_watchdog: bool = False
    """Reset a PLC heartbeat-watchdog fault latched by the previous session."""

    def __post_init__(self) -> None:
        if self.scheme not in SCHEMES or isinstance(self.scheme, bool):
            raise ValueError(f"scheme must be 1, 2 or 3, got {self.scheme!r}")
        if not isinstance(self.params, dict):
            raise ValueError("params must be an object {parameter: value}")
        known = {p.name for p in scheme_params(self.scheme)}
        unknown = sorted(set(self.params) - known)
        if unknown:
            raise ValueError(f"scheme {self.scheme} has no parameter {', '.join(unknown)} "
                             f"(it has {', '.join(sorted(known))})")
        for name in ("operator", "rig_name"):
            if getattr(self, name) is not None and not isinstance(getattr(self, name), str):
                raise ValueError(f"{name} must be a string")
        if not isinstance(self.notes, str):
            raise ValueError("notes must be a string")
        if self.source not in (None, *RUN_SOURCES):
            raise ValueError(f"source must be one of {RUN_SOURCES}, got {self.source!r}")
        if not isinstance(self.reset_watchdog, bool):
            raise ValueError("reset_watchdog must be true or false")
        if self.effects is not None:
            if not (isinstance(self.effects, dict) and all(
                    isinstance(v, dict) for v in self.effects.values())):
                raise ValueError("effects must be an object {name: {parameter: value}}")
            resolve_effects(self.effects)      # the vocabulary's names and bounds

    def make_scheme(self) -> "Scheme1 | Scheme2 | Scheme3":
        """The scheme's plan with these parameters (ValueError with the scheme's reason)."""
        return make_scheme(self.scheme, **self.params)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def to_json(self) -> str:
        """One line of JSON (the form `rig run --spec -` reads with --control-stdin)."""
        return json.dumps(self.to_dict(), separators=(",", ":"), allow_nan=False)

    @classmethod
    def from_dict(cls, doc: Any) -> "RunSpec":
        """Read a spec document; ValueError naming what is wrong (unknown keys included)."""
        if not isinstance(doc, dict):
            raise ValueError("a run spec is a JSON object")
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(doc) - names)
        if unknown:
            raise ValueError(f"unknown run spec key(s) {', '.join(unknown)} "
                             f"(known: {', '.join(sorted(names))})")
        missing = [f.name for f in fields(cls) if f.name not in doc
                   and f.default is MISSING and f.default_factory is MISSING]
        if missing:
            raise ValueError(f"the run spec needs {', '.join(missing)}")
        return cls(**doc)

    @classmethod
    def from_json(cls, text: str) -> "RunSpec":
        try:
            doc = json.loads(text, parse_constant=_refuse_constant)
        except json.JSONDecodeError as exc:
            raise ValueError(f"the run spec is not JSON: {exc}") from None
        return cls.from_dict(doc)


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"the run spec holds {name}, which is no number")
