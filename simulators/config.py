"""Configuration of one emulated joint: the physical truth, the injected effects, the sensors'
randomness and the initial conditions. Shared by the offline simulator (simulators.offline) and
the live emulator behind the PLC/drive stand-ins (simulators.live).

Every physical parameter lives in core.params.JointParams (unit, default, source); what this file
adds is how a run is set up. The emulator-internal constants (the dynamometer's error spectrum,
the output-angle creep threshold of the friction solver) are documented where they are defined.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields
from typing import Any, Mapping, Sequence

from core.effects import VOCABULARY, resolve_effects
from core.params import N_MOTORS, JointParams

DYNO_ERR_PERIODS = (23.0, 71.0)
"""Periods [s] of the two sinusoids making up the dynamometer's slow tracking error (design:
slower than its 0.2 s torque lag, faster than a run). Amplitude split DYNO_ERR_WEIGHTS of
JointParams.dyno_err, so the error stays inside ±dyno_err (600 N·m), well inside Table 11's ±2 kN·m;
the phases are drawn from the run's seed."""
DYNO_ERR_WEIGHTS = (0.7, 0.3)


@dataclass(frozen=True)
class EmulatorConfig:
    """How one emulated joint is set up (SI units, temperatures in °C).

    params: the physical truth (core.params.JointParams; defaults = rig.md).
    effects: injected effects {name: {param: value}} from core.effects.VOCABULARY; missing params
        take the vocabulary's defaults. `hysteresis` here only sets its `scale` (k_h multiplier);
        switching hysteresis off is the `hysteresis` flag.
    hysteresis: True = Bouc–Wen transmission (k_u = w·k, k_h = scale·(1−w)·k); False = purely
        elastic transmission of stiffness k (the rigid-body Eq. 4 world plus a spring).
    seed: seeds numpy.random.Generator(PCG64(seed)); one seed reproduces a run bit for bit.
    dt: internal integration step [s] (1 ms: the rig's 1 kHz control rate).
    sample_rate_hz: sensor sampling rate [Hz]; None = the scheme's own rate (offline runs).
    dropout: probability [-] that one sample of one channel is missing (NaN), independently.
    temp_motor_init: initial winding temperatures of motors 1–3 [°C]; None = ambient.
    temp_joint_init: initial gearbox/joint temperature [°C]; None = ambient.
    failed_motors: motors (0, 1, 2) that fail: {k: time of failure [s]} or a sequence of k
        (failed from the start). A failed motor gives no torque; the others carry the joint.
    """

    params: JointParams = field(default_factory=JointParams)
    effects: Mapping[str, Mapping[str, float] | None] = field(default_factory=dict)
    hysteresis: bool = True
    seed: int = 0
    dt: float = 1e-3
    sample_rate_hz: float | None = None
    dropout: float = 0.0
    temp_motor_init: tuple[float, float, float] | None = None
    temp_joint_init: float | None = None
    failed_motors: Mapping[int, float] | Sequence[int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        resolved = resolve_effects(dict(self.effects))
        if not self.hysteresis and "hysteresis" in resolved:
            raise ValueError("effect 'hysteresis' given while hysteresis is off; "
                             "use hysteresis=True with a 'scale', or drop the effect")
        object.__setattr__(self, "effects", resolved)
        if not (self.dt > 0 and math.isfinite(self.dt)):
            raise ValueError(f"dt must be a positive number of seconds, got {self.dt!r}")
        if self.sample_rate_hz is not None and not self.sample_rate_hz > 0:
            raise ValueError(f"sample_rate_hz must be positive, got {self.sample_rate_hz!r}")
        if self.sample_rate_hz is not None and self.sample_rate_hz > 1.0 / self.dt + 1e-9:
            raise ValueError(f"sample_rate_hz {self.sample_rate_hz} exceeds the internal rate "
                             f"{1.0 / self.dt:g} Hz")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout must be a probability in [0, 1), got {self.dropout!r}")
        if self.temp_motor_init is not None:
            temps = tuple(float(v) for v in self.temp_motor_init)
            if len(temps) != N_MOTORS:
                raise ValueError(f"temp_motor_init needs {N_MOTORS} temperatures, got {temps}")
            object.__setattr__(self, "temp_motor_init", temps)
        if isinstance(self.failed_motors, Mapping):
            failed = {int(k): float(v) for k, v in self.failed_motors.items()}
        else:
            failed = {int(k): 0.0 for k in self.failed_motors}
        for k, t_fail in failed.items():
            if k not in range(N_MOTORS):
                raise ValueError(f"motor index {k} out of range 0..{N_MOTORS - 1}")
            if not (t_fail >= 0 and math.isfinite(t_fail)):
                raise ValueError(f"failure time of motor {k} must be a finite time >= 0 s")
        if len(failed) >= N_MOTORS:
            raise ValueError("at least one motor must stay healthy")
        object.__setattr__(self, "failed_motors", failed)
        if int(self.params.n) != self.params.n or self.params.n < 1:
            raise ValueError(f"Bouc–Wen exponent n must be an integer >= 1, got {self.params.n}")

    # --- derived quantities used by the kernel ---------------------------------------------
    @property
    def hysteresis_scale(self) -> float:
        """Multiplier of k_h = (1−w)·k: the `hysteresis` effect's scale (1 by default)."""
        if not self.hysteresis:
            return 0.0
        return float(self.effects.get("hysteresis", {}).get("scale", 1.0))

    @property
    def stiffness(self) -> tuple[float, float]:
        """(k_u, k_h) the transmission uses [N·m/rad]: Bouc–Wen split when hysteresis is on,
        (k, 0) — a purely elastic spring of the total stiffness — when it is off."""
        p = self.params
        if not self.hysteresis:
            return p.k, 0.0
        return p.k_u, self.hysteresis_scale * p.k_h

    def non_default_params(self) -> dict[str, float]:
        """JointParams fields that differ from rig.md's defaults (for run metadata)."""
        base = JointParams()
        return {f.name: getattr(self.params, f.name) for f in fields(JointParams)
                if getattr(self.params, f.name) != getattr(base, f.name)}

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary for a run's metadata ("emulator" key)."""
        return {
            "seed": int(self.seed),
            "effects": {k: dict(v) for k, v in self.effects.items()},
            "hysteresis": bool(self.hysteresis),
            "params": self.non_default_params(),
            "dt": float(self.dt),
            "dropout": float(self.dropout),
            "failed_motors": {str(k): v for k, v in self.failed_motors.items()},
            "temp_motor_init": list(self.temp_motor_init) if self.temp_motor_init else None,
            "temp_joint_init": self.temp_joint_init,
        }

    def replace(self, **changes: Any) -> "EmulatorConfig":
        return dataclasses.replace(self, **changes)


def effect_names() -> tuple[str, ...]:
    """The injectable effects (core.effects.VOCABULARY order)."""
    return tuple(VOCABULARY)
