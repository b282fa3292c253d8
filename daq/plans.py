"""A scheme as a plan: what the rig is told to do at each instant of rig time.

The scheme (core/schemes.py) owns the profiles; a `Plan` turns them into the set points the
engine (daq/engine.py) sends — motor speed, dynamometer torque, pump, pressure — plus the
phase label and the sample grid. Times are plan time [s] on the RIG's clock (the PLC's
`rig_time` minus its value at the start of the run), so a plan runs the same on the real rig
and on the emulator at any time scale.

Before its time line starts, a plan homes the joint (`homing`, run by the engine through
daq/rig.py): scheme 1 as the paper's first step ("turn the joint angle to 0° ... and set the
output encoder angle to zero"), scheme 2 because its travel check (core/schemes.py: a
3000 r/min run turns ~164° of the ±180°) holds only from 0° — after a scheme-1 run at
3000 r/min the joint stands at ~167° and would pass 180° (the absolute-angle interlock would
trip) — and scheme 3 because its trajectory is absolute, about the homed 0°. A plan also names the interlock limit
set it runs under (its scheme's `limit_set`, core/schemes.py).

Scheme 3 runs in position control the way a motion controller does: the speed set point is
the trajectory's speed feed-forward N·q̇_ref plus a proportional correction
N·k_p·(q_ref − q) from the measured output angle q, clipped to the speed limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from core.params import REDUCTION
from core.schemes import (RPM, LimitSet, Scheme1, Scheme2, Scheme3, limit_set_named,
                          make_scheme)

HOMING_SCHEMES = (1, 2, 3)
"""Schemes whose plan homes the joint before its time line starts (module doc)."""


@dataclass(frozen=True)
class SetPoints:
    """Set points at one plan time: motor speed [rad/s at the motor shaft], dynamometer
    torque [N·m], pump on, pressure [Pa], phase label, output position reference [rad]
    (scheme 3; None otherwise)."""

    t: float
    phase: str
    motor_speed: float
    dyno_torque: float
    pump_on: bool
    pressure: float
    q_ref: float | None = None


class Plan:
    """One scheme as a plan (see the module doc)."""

    def __init__(self, scheme: Scheme1 | Scheme2 | Scheme3) -> None:
        self.scheme = scheme
        self.number = int(scheme.scheme)
        self.name = f"scheme{self.number}"
        self.duration = float(scheme.duration())
        """Length of the run [s of rig time]."""
        self.sample_rate_hz = float(scheme.sample_rate_hz)
        self.homing = self.number in HOMING_SCHEMES
        """Home the joint before plan time 0."""
        self.limits: LimitSet = limit_set_named(getattr(scheme, "limit_set", "default"))
        """The interlock limits the run is held to."""
        self.position_control = isinstance(scheme, Scheme3)
        if self.position_control:
            self.position_gain = float(scheme.position_gain)
            self.speed_limit = float(scheme.motor_speed_limit_rpm) * RPM
            scheme.trajectory()  # optimise the excitation now, before the rig is touched
        # the profiles tabulated once on a fine grid of rig time (the scheme's own vectorised
        # functions), so a set point or a phase costs a look-up, not a profile evaluation
        self.table_dt = min(1e-3, self.period / 4)
        tg = np.arange(int(math.ceil(self.duration / self.table_dt)) + 2) * self.table_dt
        self._tg = tg
        self._w = np.asarray(scheme.motor_speed(tg), dtype=float)
        self._tau = np.asarray(scheme.dyno_torque(tg), dtype=float)
        self._pump = np.asarray(scheme.pump_on(tg), dtype=bool)
        self._p = np.asarray(scheme.pressure_setpoint(tg), dtype=float)
        ref = scheme.position_ref(tg)
        self._qref = None if ref is None else (np.asarray(ref[0], dtype=float),
                                               np.asarray(ref[1], dtype=float))
        self.uses_hydraulics = bool(np.any(self._pump))

    @classmethod
    def of(cls, number: int, **params: Any) -> "Plan":
        """Plan of scheme 1, 2 or 3 with the given parameters (others at the paper's defaults)."""
        return cls(make_scheme(number, **params))

    @property
    def period(self) -> float:
        """Sample period [s]."""
        return 1.0 / self.sample_rate_hz

    def n_samples(self) -> int:
        """Samples on the grid k/rate, 0 ≤ k/rate ≤ duration."""
        return int(math.floor(self.duration * self.sample_rate_hz + 1e-9)) + 1

    def slot(self, t: float) -> int:
        """Index of the sample slot [k/rate, (k+1)/rate) holding plan time t [s]."""
        return int(math.floor(t * self.sample_rate_hz + 1e-9))

    def _at(self, t: float) -> tuple[int, float]:
        """Table index and interpolation weight of plan time t [s] (clamped to the run)."""
        x = min(max(t, 0.0), self._tg[-1]) / self.table_dt
        k = min(int(x), len(self._tg) - 2)
        return k, x - k

    def phase(self, t: float) -> str:
        """Phase label at plan time t [s] (the scheme's own label, exact at the boundaries)."""
        return str(self.scheme.phase(np.array([t]))[0])

    def setpoints(self, t: float, q: float | None = None) -> SetPoints:
        """Set points at plan time t [s]; `q` is the measured output angle [rad] for the
        position loop of scheme 3 (ignored by schemes 1 and 2; None = feed-forward only)."""
        k, f = self._at(t)

        def lerp(a: np.ndarray) -> float:
            return float(a[k] + f * (a[k + 1] - a[k]))
        q_ref = None
        if self._qref is not None:
            q_ref = lerp(self._qref[0])
            w = REDUCTION * lerp(self._qref[1])
            if q is not None and math.isfinite(q):
                w += REDUCTION * self.position_gain * (q_ref - q)
            w = max(-self.speed_limit, min(self.speed_limit, w))
        else:
            w = lerp(self._w)
        return SetPoints(t=float(t), phase=self.phase(t), motor_speed=w,
                         dyno_torque=lerp(self._tau), pump_on=bool(self._pump[k]),
                         pressure=float(self._p[k]), q_ref=q_ref)

    def meta(self) -> dict[str, Any]:
        """The scheme's run-format metadata plus the plan's own facts."""
        m = self.scheme.meta()
        m["plan"] = {"name": self.name, "duration_s": self.duration,
                     "n_samples_planned": self.n_samples(),
                     "position_control": self.position_control,
                     "uses_hydraulics": self.uses_hydraulics,
                     "homing": self.homing, "limit_set": self.limits.name}
        return m
