"""The three experiment schemes of the paper (section II-B; rig.md) as parameter dataclasses with
the paper's defaults and pure set-point profiles: functions of time [s] (scalars or arrays) giving
the motor speed set point, the output position reference (scheme 3), the dynamometer torque set
point, the hydraulic pump and pressure set points and the phase label.

Pure: no simulator (or driver) import. The emulator (simulators.offline) samples these profiles
at its 1 kHz internal rate; the data acquisition can use the same plans on the real rig.

Conventions: motor speeds in rad/s at the motor shaft, signed by the direction of motion; loads
in N·m at the joint output (positive = the paper's positive loading); angles in rad.
"""

from __future__ import annotations

import abc
import math
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

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


def _check_common(direction: int, sample_rate_hz: float) -> None:
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not sample_rate_hz >= 10.0:
        raise ValueError(f"sample rate must be >= 10 Hz (rig.md), got {sample_rate_hz!r}")


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
    motor_speed_rpm: float = 3000.0
    """Motor speed [r/min]: 300 or 3000 in the paper."""
    direction: int = 1
    """Sense of motion, +1 or −1."""
    load_target: float = RATED_TORQUE
    """Dynamometer load at the top [N·m] (the rated 120 kN·m)."""
    accel_time: float = 1.0
    """Motor speed ramp from rest to speed and back [s] (design: no jolt on the drive train)."""
    settle_time: float = 1.0
    """Idle at speed before loading [s] ("start the joint motor ... then load")."""
    rest_time: float = 1.0
    """Idle at rest after the motion [s]."""
    shear_target: float = 90e3
    """Hydraulic shear during loading [N] (Table 11's 90 kN; bending = shear·arm)."""
    sample_rate_hz: float = 10.0
    """Sensor sampling [Hz] (the paper reads the encoder every 0.1 s)."""

    scheme: ClassVar[int] = 0

    def __post_init__(self) -> None:
        _check_common(self.direction, self.sample_rate_hz)
        if not 0.0 < self.motor_speed_rpm <= MOTOR_SPEED_LIMIT_RPM:
            raise ValueError(f"motor speed must be in (0, {MOTOR_SPEED_LIMIT_RPM:g}] r/min, "
                             f"got {self.motor_speed_rpm!r}")
        if not self.load_target >= 0.0:
            raise ValueError("load_target must be >= 0 N·m")
        for name in ("accel_time", "settle_time", "rest_time"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0 s")

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
    ramp_rate: float = 2.4e3
    """Load and unload rate [N·m/s]; 2.4 kN·m/s keeps a 3000 r/min run within ±180°
    (0.0286 rad/s × ~102 s ≈ 167°)."""
    hold_top: float = 0.0
    """Hold at the top load [s] (the paper goes straight from loading to unloading)."""

    scheme: ClassVar[int] = 1

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.ramp_rate > 0:
            raise ValueError("ramp_rate must be > 0 N·m/s")
        if not self.hold_top >= 0:
            raise ValueError("hold_top must be >= 0 s")
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
    step: float = 10e3
    """Load increment [N·m] (10 kN·m)."""
    pause: float = 2.0
    """Pause at each step [s] (2 s)."""
    ramp_rate: float = 3e3
    """Rate between steps [N·m/s] (design: 3.3 s per step; the dynamometer's 0.2 s lag then
    trails by 0.6 kN·m, leaving room inside Table 11's ±2 kN·m for its slow error)."""
    unload_rate: float = 3.5e3
    """Unload rate after the last pause [N·m/s] (design: a 3000 r/min run then turns the joint
    ~164°, inside ±180°; the lag trails by 0.7 kN·m)."""

    scheme: ClassVar[int] = 2

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.step > 0 and self.pause >= 0 and self.ramp_rate > 0
                and self.unload_rate > 0):
            raise ValueError("step, ramp_rate and unload_rate must be > 0, pause >= 0")
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
    order: int = 5
    """Fourier order (5 in the paper)."""
    base_freq_hz: float = 0.05
    """Base frequency ω_f/2π [Hz] (design: 20 s period; the 5th harmonic, 0.25 Hz, stays far
    below the drives' 25 rad/s speed loop and the ~8 Hz drive-train mode, and the accelerations
    reach a_max so the inertia is identifiable)."""
    n_periods: int = 15
    """Periods run [-] (15 × 20 s = 300 s of excitation)."""
    q_max: float = JOINT_LIMIT
    """Position limit [rad] (±180°)."""
    motor_speed_limit_rpm: float = MOTOR_SPEED_LIMIT_RPM
    """Speed limit [r/min at the motor]; the output limit is this / N."""
    a_max: float = 0.05
    """Output acceleration limit [rad/s²] (design: the reflected inertia ~7.9e4 kg·m² then
    needs ≤ 4 kN·m, a few % of the rated torque)."""
    direction: int = 1
    """+1 runs the optimised trajectory, −1 its mirror image."""
    rest_time: float = 2.0
    """Idle at rest before and after the excitation [s]."""
    position_gain: float = 5.0
    """Proportional position-loop gain on the motor-side angle [1/s] (with speed feed-forward)."""
    sample_rate_hz: float = 1000.0
    """Sensor sampling [Hz] (design: the drives' 1 kHz rate; 300 000 samples put the standard
    error of I_xx near 0.4 % with the default sensor noise, and a 20 Hz zero-phase derivative of
    qd then captures the drive-train transients after velocity reversals)."""
    opt_seed: int = 0
    """Seed of the coefficient optimisation's random starts."""
    coefficients: tuple | None = None
    """Fixed (a, b, q0) instead of optimising: a, b [rad/s] of length `order`, q0 [rad]."""

    scheme: ClassVar[int] = 3

    def __post_init__(self) -> None:
        _check_common(self.direction, self.sample_rate_hz)
        if not (self.order >= 2 and self.n_periods >= 1 and self.base_freq_hz > 0):
            raise ValueError("order must be >= 2, n_periods >= 1, base_freq_hz > 0")
        if not (0 < self.q_max <= JOINT_LIMIT):
            raise ValueError("q_max must be in (0, π] rad")
        if not (0 < self.motor_speed_limit_rpm <= MOTOR_SPEED_LIMIT_RPM and self.a_max > 0):
            raise ValueError("speed limit must be in (0, 3000] r/min and a_max > 0")
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


SCHEME_ARGS: dict[str, tuple[str, type, str]] = {
    # option dest: (scheme field, type, help)
    "speed": ("motor_speed_rpm", float, "motor speed [r/min] (schemes 1, 2; 300 or 3000)"),
    "direction": ("direction", int, "sense of motion, 1 or -1"),
    "load": ("load_target", float, "load at the top [N·m] (schemes 1, 2; default 120e3)"),
    "ramp_rate": ("ramp_rate", float, "load ramp rate [N·m/s] (schemes 1, 2)"),
    "unload_rate": ("unload_rate", float, "unload rate [N·m/s] (scheme 2)"),
    "hold_top": ("hold_top", float, "hold at the top load [s] (scheme 1)"),
    "step": ("step", float, "load step [N·m] (scheme 2; default 10e3)"),
    "pause": ("pause", float, "pause at each step [s] (scheme 2; default 2)"),
    "accel_time": ("accel_time", float, "speed ramp time [s] (schemes 1, 2)"),
    "settle_time": ("settle_time", float, "idle at speed before loading [s] (schemes 1, 2)"),
    "rest_time": ("rest_time", float, "idle at rest [s]"),
    "shear": ("shear_target", float, "hydraulic shear while loading [N] (schemes 1, 2)"),
    "sample_rate": ("sample_rate_hz", float, "sample rate [Hz] (>= 10)"),
    "order": ("order", int, "Fourier order (scheme 3; default 5)"),
    "base_freq": ("base_freq_hz", float, "base frequency [Hz] (scheme 3)"),
    "periods": ("n_periods", int, "periods of excitation (scheme 3)"),
    "a_max": ("a_max", float, "output acceleration limit [rad/s²] (scheme 3)"),
    "position_gain": ("position_gain", float, "position-loop gain [1/s] (scheme 3)"),
    "opt_seed": ("opt_seed", int, "seed of the excitation optimisation (scheme 3)"),
}
"""The schemes' parameters as the command line and the service's acquisition name them:
option dest -> (the scheme dataclass field, its type, help with unit)."""
