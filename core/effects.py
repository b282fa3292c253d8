"""The effect vocabulary (rig.md, "Unmodelled effects"): one module for the emulator's injections
and the identification/diagnosis models' candidate terms.

Each effect has a name, what it is, where it shows, the parameters it takes (with units and
defaults) and one of them named as its magnitude. Its torque/sensor term is a plain NumPy
function below, compiled into the emulator's kernel and evaluated on arrays by the estimator.

Every parameter also has its physical range [lo, hi] (this module is the one place): an
injection (`resolve_effects`, `parse_effect`: the emulator, `rig simulate`, `rig emulate`,
`rig run --effect`, the API's emulator options) with a value outside it, NaN or ±inf is refused
naming the parameter — `time_delay` with delay = 1e7 s would allocate a ring buffer of ~80 GB,
NaN would give NaN physics and metadata that PostgreSQL's JSON refuses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from core.terms import smooth_sign


@dataclass(frozen=True)
class EffectParam:
    name: str
    default: float
    unit: str
    doc: str
    lo: float = -math.inf
    """Smallest value an injection may take (inclusive), in `unit`."""
    hi: float = math.inf
    """Largest value an injection may take (inclusive), in `unit`."""

    def check(self, effect: str, value: float) -> float:
        """`value` as a float if it is finite and within [lo, hi], else ValueError naming the
        effect, the parameter, its range and unit."""
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"effect {effect!r} parameter {self.name!r}: {value!r} is not a "
                             "number") from None
        if not math.isfinite(v):
            raise ValueError(f"effect {effect!r} parameter {self.name!r} must be a finite "
                             f"number in [{self.lo:g}, {self.hi:g}] {self.unit}, got {v!r}")
        if not self.lo <= v <= self.hi:
            raise ValueError(f"effect {effect!r} parameter {self.name!r} = {v!r} {self.unit} "
                             f"is outside its range [{self.lo:g}, {self.hi:g}] {self.unit}")
        return v


@dataclass(frozen=True)
class Effect:
    name: str
    what: str
    where: str
    acts_on: str
    """'transmission' (twist–torque law), 'output' (a torque on the output shaft, in Eq. 4's
    balance) or 'sensor' (what the torque channel reads, not the physics)."""
    magnitude: str
    """Name of the parameter that sets the effect's size (0 switches it off)."""
    params: tuple[EffectParam, ...]
    also_on: tuple[str, ...] = ()
    """Other laws a diagnosis tries the effect on (a gear's ripple is a torque on the output,
    from the mesh's friction, or an angle error inside the twist, the transmission error; a
    lagging angle reading is a twist error that grows with the speed)."""

    def defaults(self) -> dict[str, float]:
        return {p.name: p.default for p in self.params}

    def resolve(self, given: Mapping[str, float] | None) -> dict[str, float]:
        """Defaults overlaid with `given`; unknown parameter names are refused by name."""
        out = self.defaults()
        for key, value in (given or {}).items():
            if key not in out:
                raise ValueError(
                    f"effect {self.name!r} has no parameter {key!r}; it takes {sorted(out)}")
            out[key] = float(value)
        return out

    def check(self, given: Mapping[str, float] | None) -> dict[str, float]:
        """`given` (as floats) if every name is a parameter of this effect and every value is
        finite and within that parameter's range; ValueError naming the first that is not."""
        params = {p.name: p for p in self.params}
        out = {}
        for key, value in (given or {}).items():
            if key not in params:
                raise ValueError(
                    f"effect {self.name!r} has no parameter {key!r}; it takes {sorted(params)}")
            out[key] = params[key].check(self.name, value)
        return out


VOCABULARY: dict[str, Effect] = {e.name: e for e in (
    Effect("hysteresis", "Bouc–Wen state in the transmission (absent from the rigid Eq. 4)",
           "twist vs torque loops; loading vs unloading", "transmission", "scale",
           (EffectParam("scale", 1.0, "-", "multiplies the hysteretic stiffness k_h = (1−w)·k; "
                        "0 makes the transmission purely elastic with stiffness k", 0.0, 5.0),)),
    Effect("stribeck", "friction above Coulomb at low speed, falling with speed",
           "low speeds (300 r/min runs), velocity reversals", "output", "f_s",
           (EffectParam("f_s", 1500.0, "N·m", "extra friction at zero speed", 0.0, 50e3),
            EffectParam("v_s", 6e-3, "rad/s", "Stribeck speed (output side; 300 r/min = 2.9e-3)",
                        1e-5, 1.0),
            EffectParam("delta", 2.0, "-", "exponent of the curve exp(−|q̇/v_s|^delta) (2 "
                        "Gaussian, 1 exponential); 0 selects the Lorentzian 1/(1 + (q̇/v_s)²)", 0.0, 5.0))),
    Effect("load_dependent_friction", "gear/bearing friction growing with transmitted torque",
           "high load; sign flips with the direction of motion", "output", "mu",
           (EffectParam("mu", 0.02, "-", "friction torque per unit of |transmitted torque|",
                        0.0, 1.0),
            EffectParam("mu_v", 0.0, "s/rad", "viscous friction torque per unit of |transmitted "
                        "torque| and of speed (the viscous part scaled by the load)", 0.0, 100.0))),
    Effect("temperature_friction", "lubricant drag that changes with joint temperature",
           "cold vs warm runs; drifts along long runs", "output", "c_T",
           (EffectParam("c_T", 30.0, "N·m/K", "extra drag per kelvin below T_ref", -1e3, 1e3),
            EffectParam("T_ref", 40.0, "°C", "temperature at which the drag is nominal", -40.0, 150.0),
            EffectParam("c_Tv", 0.0, "N·m·s/(rad·K)",
                        "extra viscous slope per kelvin below T_ref (lubricant viscosity)",
                        -1e4, 1e4))),
    Effect("backlash", "dead zone in the transmission",
           "torque and velocity reversals", "transmission", "b",
           (EffectParam("b", 8.7e-4, "rad", "half-width of the dead zone (0.05°)", 0.0, 0.05),)),
    Effect("gear_ripple", "torque periodic in the output angle (gear mesh)",
           "a spectral line at a fixed number of cycles per revolution", "output", "A",
           (EffectParam("A", 500.0, "N·m", "ripple amplitude", 0.0, 50e3),
            EffectParam("order", 36.0, "cycles/rev", "ripple cycles per output revolution", 0.0, 1e3),
            EffectParam("phase", 0.0, "rad", "ripple phase at q = 0", -2 * math.pi, 2 * math.pi)),
           also_on=("transmission",)),
    Effect("torque_offset", "torque sensor offset or slow drift",
           "everywhere, growing with time", "sensor", "c0",
           (EffectParam("c0", 800.0, "N·m", "offset of the torque channel at t = 0", -50e3, 50e3),
            EffectParam("drift", 2.0, "N·m/s", "drift rate of the offset", -1e3, 1e3))),
    Effect("time_delay", "a channel lagging the others",
           "fast changes, reversals", "sensor", "delay",
           (EffectParam("delay", 0.05, "s", "lag of the strain-gauge torque channel", 0.0, 2.0),),
           also_on=("transmission",)),
    Effect("asymmetric_friction", "Coulomb level and viscous slope that differ with the direction "
           "of motion", "positive vs negative speeds; the EMPS drive's known gap", "output", "d_v",
           (EffectParam("d_v", 8000.0, "N·m·s/rad",
                        "extra viscous slope in the positive direction", 0.0, 1e5),
            EffectParam("d_c", 0.0, "N·m", "extra Coulomb friction in the positive direction "
                        "(against Eq. 4's Coulomb term it acts as a constant torque, which a "
                        "diagnosis cannot tell from a torque offset)", -20e3, 20e3))),
)}

EFFECT_NAMES: tuple[str, ...] = tuple(VOCABULARY)


def check_effects(spec: Mapping[str, Mapping[str, float] | None]
                  ) -> dict[str, dict[str, float]]:
    """Validate an injection spec {name: {param: value}} against the vocabulary: unknown
    effects and parameters are refused by name, and so is a value that is NaN, ±inf or outside
    its parameter's range. Returns the given values as floats (no defaults filled)."""
    out = {}
    for name, given in spec.items():
        if name not in VOCABULARY:
            raise ValueError(f"unknown effect {name!r}; the vocabulary is {list(EFFECT_NAMES)}")
        out[name] = VOCABULARY[name].check(given)
    return out


def resolve_effects(spec: Mapping[str, Mapping[str, float] | None]) -> dict[str, dict[str, float]]:
    """Validate an injection spec {name: {param: value}} (check_effects) and fill the
    defaults."""
    return {name: VOCABULARY[name].resolve(given) for name, given in check_effects(spec).items()}


def parse_effect(text: str) -> tuple[str, dict[str, float]]:
    """'NAME' or 'NAME:k=v,k=v' (the command line's --effect syntax) → (name, {param: value}).
    Raises ValueError naming what is wrong (check_effects: the name, the parameters, their
    ranges)."""
    name, _, rest = text.partition(":")
    params: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise ValueError(f"effect parameter {item!r} is not KEY=VALUE")
        try:
            params[key.strip()] = float(value)
        except ValueError:
            raise ValueError(f"effect parameter {key}={value!r} is not a number") from None
    if not name.strip():
        raise ValueError(f"effect {text!r} has no name")
    check_effects({name.strip(): params})
    return name.strip(), params


def format_effect(name: str, params: Mapping[str, float] | None) -> str:
    """The --effect text of (name, params), which parse_effect reads back exactly."""
    return name + (":" + ",".join(f"{k}={float(v)!r}" for k, v in params.items())
                   if params else "")


# --- the effects' terms (NumPy/numba-compatible) -----------------------------------------------

def stribeck_torque(qd, f_s, v_s, v_eps, delta=2.0):
    """Stribeck friction above Coulomb [N·m]: f_s·exp(−|q̇/v_s|^delta)·sgn(q̇), or with
    delta = 0 the Lorentzian f_s/(1 + (q̇/v_s)²)·sgn(q̇)."""
    if delta > 0.0:
        curve = np.exp(-np.abs(qd / v_s) ** delta)
    else:
        curve = 1.0 / (1.0 + (qd / v_s) ** 2)
    return f_s * curve * smooth_sign(qd, v_eps)


def load_dependent_friction_torque(qd, T, mu, v_eps, mu_v=0.0):
    """Efficiency loss growing with the transmitted torque T [N·m]: |T|·(μ·sgn(q̇) + μ_v·q̇)."""
    return np.abs(T) * (mu * smooth_sign(qd, v_eps) + mu_v * qd)


def temperature_friction_torque(qd, temp, c_T, T_ref, v_eps, c_Tv=0.0, kappa=0.0):
    """Lubricant drag [N·m]: g·(c_T·sgn(q̇) + c_Tv·q̇), g = T_ref − temp [K]; more drag when
    colder than T_ref [°C]. kappa [1/K] ≠ 0 curves it: g = (exp(κ·(T_ref − temp)) − 1)/κ, an
    exponential (Arrhenius-like) viscosity law whose first order is the linear one."""
    x = T_ref - temp
    g = x if kappa == 0.0 else np.expm1(kappa * x) / kappa
    return g * (c_T * smooth_sign(qd, v_eps) + c_Tv * qd)


def backlash_twist(delta, b):
    """Twist the spring sees through a dead zone of half-width b [rad]:
    sgn(Δ)·max(|Δ| − b, 0)."""
    return np.sign(delta) * np.maximum(np.abs(delta) - b, 0.0)


def gear_ripple_torque(q, A, order, phase):
    """Gear-mesh ripple [N·m]: A·sin(order·q + phase), `order` cycles per output revolution."""
    return A * np.sin(order * q + phase)


def asymmetric_friction_torque(qd, d_c, d_v, v_eps):
    """Friction that differs with the direction of motion [N·m]: (d_c + d_v·q̇)·(1 + sgn q̇)/2,
    i.e. the positive direction has Coulomb level f_c + d_c and viscous slope f_v + d_v."""
    return (d_c + d_v * qd) * 0.5 * (1.0 + smooth_sign(qd, v_eps))


def torque_offset(t, c0, drift):
    """Torque-sensor offset [N·m] at time t [s]: c0 + drift·t."""
    return c0 + drift * t
