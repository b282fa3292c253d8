"""Linear-in-parameter models as compositions of terms (issue 5: "models are compositions of terms,
so an effect from rig.md's vocabulary can be added to any of them").

A `Term` produces one or more regressor columns from prepared signals (estimator.preprocess),
each column with its parameter name and unit; a `LinearModel` is a target y and a tuple of terms,
y = X·θ + e. The physics comes from core.terms and core.effects only:

- `eq4()`   Eq. 4, θ = (I_xx, mr_x, mr_y, f_v, f_c), X = core.terms.eq4_regressor(q, q̇, q̈),
            y = T − τ_L (the measured load; zero when the run has none).
- `eq5()`   Eq. 5, the classical elastic joint: T = k·Δ + D·Δ̇ (+ C, a torque offset).
- `eq11(alpha, beta, gamma, n)`  Eq. 11 with the Bouc–Wen state x known: θ = (k_u, k_h, f_v,
            D+f_c, C), X = core.terms.eq11_regressor(Δ, Δ̇, x), x integrated along the twist with
            the shared Bouc–Wen step for the given (α, β, γ, n); y = T.
- `linear_model(name, target, columns)`  any model from named columns (e.g. EMPS:
            force = M·q̈ + Fv·q̇ + Fc·sgn q̇ + offset).
- `LinearModel.with_effect(name, **shape)` adds an effect of core.effects.VOCABULARY as extra
  columns: its term function evaluated at unit magnitude (the magnitude is the new parameter);
  shape parameters (e.g. Stribeck's v_s) are fixed at the given or default values. Effects whose
  magnitude enters non-linearly are linearised around zero as documented in `_effect_term`, or
  take it as a shape (SHAPE_MAGNITUDE: backlash's b, with k_bl identified).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np

from core import effects as fx
from core.params import JointParams
from core.terms import eq4_regressor, eq11_regressor, smooth_sign

_P = JointParams()
V_EPS = _P.v_eps
"""Speed scale of the smoothed sign used by every friction column [rad/s] (core.params)."""
THERMAL_ZERO_REF_C = 25.0
"""Temperature [°C] at which the thermal columns are zero: torque_offset's zero drift and the
twist–torque law's stiffness change (with_stiffening); the constant c0 and the stiffness k take
their values at this temperature."""


@dataclass(frozen=True)
class Term:
    """Regressor columns from signals: `fn(signals) -> (n, k)` with k = len(names)."""

    label: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    fn: Callable[[Mapping[str, np.ndarray]], np.ndarray]
    requires: tuple[str, ...] = ()

    def columns(self, sig: Mapping[str, np.ndarray]) -> np.ndarray:
        c = np.asarray(self.fn(sig), dtype=float)
        return c[:, None] if c.ndim == 1 else c


@dataclass(frozen=True)
class LinearModel:
    name: str
    terms: tuple[Term, ...]
    target_fn: Callable[[Mapping[str, np.ndarray]], np.ndarray]
    target_label: str
    target_unit: str
    target_requires: tuple[str, ...]
    kind: str = "generic"
    """'output' (Eq. 4's balance), 'transmission' (twist–torque laws) or 'generic'."""
    effects: tuple[str, ...] = ()
    descriptions: Mapping[str, str] = field(default_factory=dict)

    @property
    def param_names(self) -> list[str]:
        return [n for t in self.terms for n in t.names]

    @property
    def units(self) -> list[str]:
        return [u for t in self.terms for u in t.units]

    @property
    def requires(self) -> tuple[str, ...]:
        """Signals (estimator.preprocess names) the model needs."""
        req = list(self.target_requires)
        for t in self.terms:
            req.extend(t.requires)
        return tuple(dict.fromkeys(req))

    def design(self, sig: Mapping[str, np.ndarray]) -> np.ndarray:
        """Observation matrix X (n, p)."""
        return np.column_stack([t.columns(sig) for t in self.terms])

    def target(self, sig: Mapping[str, np.ndarray]) -> np.ndarray:
        return np.asarray(self.target_fn(sig), dtype=float)

    def predict(self, sig: Mapping[str, np.ndarray], theta: np.ndarray) -> np.ndarray:
        return self.design(sig) @ np.asarray(theta, dtype=float)

    def with_effect(self, name: str, **shape: float) -> "LinearModel":
        """This model plus the effect `name` of rig.md's vocabulary as extra regressor
        column(s); `shape` overrides the effect's non-magnitude parameters."""
        term = _effect_term(self, name, shape)
        clash = set(term.names) & set(self.param_names)
        if clash:
            raise ValueError(f"model {self.name!r} already has parameter(s) {sorted(clash)}")
        return replace(self, name=f"{self.name}+{name}", terms=self.terms + (term,),
                       effects=self.effects + (name,))


# --- the paper's models -------------------------------------------------------------------------

def _eq4_target(s):
    return s["torque"] - s["torque_load"]


def eq4(v_eps: float = V_EPS) -> LinearModel:
    """Eq. 4 with the measured load: T − τ_L = I·q̈ + g·(mr_x·sin q + mr_y·cos q) + f_v·q̇ +
    f_c·sgn q̇."""
    term = Term("rigid body (Eq. 4)", ("I_xx", "mr_x", "mr_y", "f_v", "f_c"),
                ("kg·m²", "kg·m", "kg·m", "N·m·s/rad", "N·m"),
                lambda s: eq4_regressor(s["q"], s["qd"], s["qdd"], v_eps), ("q", "qd", "qdd"))
    return LinearModel("eq4", (term,), _eq4_target, "T − τ_L", "N·m", ("torque", "torque_load"),
                       kind="output",
                       descriptions={"I_xx": "moment of inertia about the joint axis",
                                     "mr_x": "first mass moment, x", "mr_y": "first mass moment, y",
                                     "f_v": "viscous friction coefficient",
                                     "f_c": "Coulomb friction torque"})


TORQUE_GAIN = "torque_gain"
"""Suffix of an output law whose nominal carries the torque reading's gain relative to the load
reading (with_torque_gain)."""


def with_torque_gain(model: LinearModel) -> LinearModel:
    """`model` (an output balance T − τ_L = …) with the torque reading's gain relative to the
    load reading's as a nominal column: g_T·T, g_T dimensionless (−0.001 is a torque reading
    0.1 % low against the load cell). Two transducers of class 0.1 % differ by that much at
    120 kN·m, ~100 N·m, a sensor's calibration and not a gap of the joint; it is the same column
    as load_dependent_friction's μ·|T|·sgn q̇ wherever the load resists the motion, so the
    diagnosis tries it only on runs where the load also drives, and keeps it only when it is
    significant beside the effects chosen (estimator.diagnosis)."""
    term = Term("torque reading's gain against the load reading", ("g_T",), ("-",),
                lambda s: np.asarray(s["torque"], dtype=float), ("torque",))
    return replace(model, name=f"{model.name}+{TORQUE_GAIN}", terms=model.terms + (term,),
                   descriptions={**model.descriptions,
                                 "g_T": "relative gain error of the torque reading against the "
                                        "load reading"})


def eq5(offset: bool = True) -> LinearModel:
    """Eq. 5, the elastic joint without hysteresis: T = k·Δ + D·Δ̇ (+ C)."""
    terms = [Term("elastic (Eq. 5)", ("k", "D"), ("N·m/rad", "N·m·s/rad"),
                  lambda s: np.column_stack([s["torsion"], s["torsion_rate"]]),
                  ("torsion", "torsion_rate"))]
    if offset:
        terms.append(Term("offset", ("C",), ("N·m",), lambda s: np.ones_like(s["torsion"]),
                          ("torsion",)))
    return LinearModel("eq5", tuple(terms), lambda s: s["torque"], "T", "N·m", ("torque",),
                       kind="transmission",
                       descriptions={"k": "transmission stiffness", "D": "transmission damping",
                                     "C": "constant torque"})


def knee_column(knee: float) -> Callable[[Mapping[str, np.ndarray]], np.ndarray]:
    """The column of a stiffness change beyond the twist `knee` [rad]:
    sgn(Δ)·max(|Δ| − knee, 0) (zero inside ±knee, slope 1 beyond) — the twist through a dead
    zone of that half-width (core.effects.backlash_twist), which is why the knees searched lie
    beyond the dead zones searched."""
    def col(s: Mapping[str, np.ndarray]) -> np.ndarray:
        return fx.backlash_twist(np.asarray(s["torsion"], dtype=float), knee)
    return col


def corner_column(corner: float) -> Callable[[Mapping[str, np.ndarray]], np.ndarray]:
    """The column of a stiffness change spread smoothly about the twist `corner` δ [rad]:
    δ·atan(Δ/δ), slope 1 at Δ = 0 falling to 0 well beyond ±δ. With a coefficient dk_c the
    stiffness goes from k + dk_c at the centre to k far out over a few δ — the smooth
    counterpart of a knee (knee_column), which bends at one twist: a gear train whose teeth
    come into contact progressively stiffens over a band of twist, and a curve bent there over
    a band a fine encoder resolves is missed by knees placed on a grid."""
    def col(s: Mapping[str, np.ndarray]) -> np.ndarray:
        return corner * np.arctan(np.asarray(s["torsion"], dtype=float) / corner)
    return col


def thermal_stiffness_column(s: Mapping[str, np.ndarray]) -> np.ndarray:
    """Δ·(temp_joint − THERMAL_ZERO_REF_C) [rad·K]: the column of a stiffness that changes
    linearly with the joint's temperature."""
    return (np.asarray(s["torsion"], dtype=float)
            * (np.asarray(s["temp_joint"], dtype=float) - THERMAL_ZERO_REF_C))


def with_stiffening(m: LinearModel, knees: Sequence[float] = (),
                    centre: float | None = None, thermal: bool = False,
                    corner: float | None = None) -> LinearModel:
    """The twist–torque law `m` plus the compliance curve a real transmission has, identified
    like k: a cubic k3·Δ³ [N·m/rad³] (a gear train stiffening smoothly as its teeth take load)
    and, at each knee twist θ_j [rad], a change of stiffness dk_j [N·m/rad] beyond it,
    dk_j·sgn(Δ)·max(|Δ| − θ_j, 0) — a harmonic drive's catalogue curve is three slopes
    K1 < K2 < K3 joined at two knee torques (Taghirad & Bélanger), which no single k and no
    smooth polynomial of Δ follows. With `centre` θ₀ [rad], a change dk_0 beyond θ₀ as
    well: the centre of a curve whose teeth take up the load progressively is softer (k is then
    the stiffness inside ±θ₀), or, with dk_0 < 0, a stiffer centre (a preloaded stage). With
    `thermal`, a stiffness that follows the joint's temperature, k_T·Δ·(temp_joint −
    THERMAL_ZERO_REF_C) [N·m/(rad·K)]: a gearbox's teeth and oil film soften as it warms, and a
    campaign's runs span tens of kelvin. With `corner` δ [rad], a stiffness change dk_c
    [N·m/rad] spread smoothly about δ (corner_column). Named '<m>+stiffening'; m unchanged
    when it has k3 already."""
    if "k3" in m.param_names:
        return m
    terms = [Term("stiffening", ("k3",), ("N·m/rad³",), lambda s: s["torsion"] ** 3,
                  ("torsion",))]
    desc = {"k3": "cubic stiffness: the stiffness rises by 3·k3·Δ²"}
    if centre is not None:
        terms.append(Term(f"centre to {centre:.3g} rad", ("dk_0",), ("N·m/rad",),
                          knee_column(float(centre)), ("torsion",)))
        desc["dk_0"] = f"stiffness change beyond the centre's half-width {centre:.3g} rad"
    for j, knee in enumerate(knees, start=1):
        terms.append(Term(f"knee {j} at {knee:.3g} rad", (f"dk_{j}",), ("N·m/rad",),
                          knee_column(float(knee)), ("torsion",)))
        desc[f"dk_{j}"] = f"stiffness change beyond the twist {knee:.3g} rad"
    if corner is not None:
        terms.append(Term(f"smooth corner at {corner:.3g} rad", ("dk_c",), ("N·m/rad",),
                          corner_column(float(corner)), ("torsion",)))
        desc["dk_c"] = (f"stiffness change at the centre, spread smoothly over the twist "
                        f"{corner:.3g} rad")
    if thermal:
        terms.append(Term("stiffness with temperature", ("k_T",), ("N·m/(rad·K)",),
                          thermal_stiffness_column, ("torsion", "temp_joint")))
        desc["k_T"] = (f"stiffness change per kelvin from {THERMAL_ZERO_REF_C:g} °C of the "
                       "joint's temperature")
    return replace(m, name=f"{m.name}+stiffening", terms=m.terms + tuple(terms),
                   descriptions={**m.descriptions, **desc})


def bouc_wen_x(sig: Mapping[str, np.ndarray], alpha: float, beta: float, gamma: float,
               n: int = 1, displacement: str = "torsion") -> np.ndarray:
    """Bouc–Wen state x along the displacement of the signals (the twist Δ [rad] by default;
    restarted at 0 at each run's first sample when several runs are concatenated), integrated
    with the shared step."""
    from estimator.bouc_wen_kernel import bw_state  # the compiled core.terms.bouc_wen_step loop
    delta = np.asarray(sig[displacement], dtype=float)
    run = np.asarray(sig["run"]) if "run" in sig else np.zeros(delta.size, dtype=int)
    x = np.empty_like(delta)
    for r in np.unique(run):
        m = run == r
        x[m] = bw_state(delta[m], alpha, beta, gamma, n) if m.sum() >= 2 else 0.0
    return x


def eq11(alpha: float = _P.alpha, beta: float = _P.beta, gamma: float = _P.gamma, n: int = _P.n,
         v_eps: float = V_EPS) -> LinearModel:
    """Eq. 11 as the paper fits it, with x known from (α, β, γ, n): T = k_u·Δ + k_h·x +
    f_v·sgn Δ̇ + (D+f_c)·Δ̇ + C."""
    def cols(s):
        return eq11_regressor(s["torsion"], s["torsion_rate"],
                              bouc_wen_x(s, alpha, beta, gamma, n), v_eps)
    term = Term(f"Bouc–Wen output (Eq. 11; α={alpha:g}, β={beta:g}, γ={gamma:g}, n={n})",
                ("k_u", "k_h", "f_v", "D+f_c", "C"),
                ("N·m/rad", "N·m/rad", "N·m", "N·m·s/rad", "N·m"), cols,
                ("torsion", "torsion_rate"))
    return LinearModel("eq11", (term,), lambda s: s["torque"], "T", "N·m", ("torque",),
                       kind="transmission",
                       descriptions={"k_u": "elastic stiffness w·k", "k_h": "hysteretic stiffness (1−w)·k",
                                     "f_v": "coefficient of sgn(Δ̇) (the paper's f_v)",
                                     "D+f_c": "coefficient of Δ̇ (the paper's D + f_c)",
                                     "C": "constant torque"})


def linear_model(name: str, target: str | Callable, columns: Mapping[str, tuple],
                 v_eps: float = V_EPS, target_unit: str = "") -> LinearModel:
    """A model from named columns: columns = {param: (spec, unit)} where spec is a signal name,
    'sgn(NAME)' (the smoothed sign of core.terms), '1' (a constant), or a callable on the
    signals. target is a signal name or a callable."""
    terms = []
    for pname, (spec, unit) in columns.items():
        fn, req = _column_spec(spec, v_eps)
        terms.append(Term(pname, (pname,), (unit,), fn, req))
    if callable(target):
        tfn, treq, tlabel = target, (), getattr(target, "__name__", "y")
    else:
        tfn, treq, tlabel = (lambda s, k=target: s[k]), (target,), target
    return LinearModel(name, tuple(terms), tfn, tlabel, target_unit, treq, kind="generic")


def _column_spec(spec, v_eps):
    if callable(spec):
        return spec, ()
    spec = str(spec).strip()
    if spec == "1":
        return (lambda s: np.ones(len(s["t"]))), ("t",)
    if spec.startswith("sgn(") and spec.endswith(")"):
        k = spec[4:-1].strip()
        return (lambda s, k=k: smooth_sign(s[k], v_eps)), (k,)
    return (lambda s, k=spec: s[k]), (spec,)


MODELS: dict[str, Callable[..., LinearModel]] = {"eq4": eq4, "eq5": eq5, "eq11": eq11}
"""Linear models by name (Eq. 9, the nonlinear Bouc–Wen law, is fitted by estimator.bouc_wen)."""


def model_from_spec(spec: str, **kw) -> LinearModel:
    """'eq4', 'eq4+stribeck', 'eq11+gear_ripple:order=36+torque_offset',
    'eq4+torque_gain+stribeck' -> a LinearModel."""
    base, *effs = [s.strip() for s in spec.split("+")]
    if base not in MODELS:
        raise ValueError(f"unknown linear model {base!r}; known: {sorted(MODELS)} (and 'eq9', "
                         "fitted by the Bouc–Wen estimator)")
    m = MODELS[base](**kw)
    for e in effs:
        if e == TORQUE_GAIN:
            m = with_torque_gain(m)
            continue
        name, _, args = e.partition(":")
        shape = {}
        for kv in filter(None, args.split(",")):
            k, _, v = kv.partition("=")
            shape[k.strip()] = float(v)
        m = m.with_effect(name.strip(), **shape)
    return m


# --- effects as columns -----------------------------------------------------------------------

SHAPE_MAGNITUDE: dict[str, str] = {"backlash": "k_bl"}
"""Effects whose vocabulary magnitude enters their column non-linearly, so that in the column
form it is a shape parameter (fixed, or searched on a grid by the caller) and the coefficient
identified is another one: backlash's dead-zone half-width b [rad] shapes the column
backlash_twist(Δ, b) − Δ, whose coefficient k_bl [N·m/rad] is identified (≈ the stiffness)."""

PHYSICAL_SIGN: dict[str, tuple[tuple[str, ...], int]] = {
    "backlash": (("k_bl",), 1), "hysteresis": (("k_h",), 1), "stribeck": (("f_s",), 1),
    "load_dependent_friction": (("mu", "mu_drive"), 1)}
"""An effect's identified coefficients (those its shape carries) and the sign its physics
allows: a dead zone takes the stiffness away inside its gap, k_bl > 0 (a negative k_bl makes
the centre stiffer than the rest, which no backlash does; a misplaced knee of the compliance
curve does); a hysteretic
element is passive, its loop dissipates energy, k_h > 0 (a negative k_h runs the loop the other
way round, torque lower on loading than on unloading: what a torque reading lagging the twist
draws, not a material); a Stribeck curve is friction that rises above the Coulomb level toward
rest, f_s > 0 (a negative f_s is friction that falls short of it at low speed: a presliding
bearing rebuilding its friction after a stop, not a Stribeck curve); friction that grows with
the transmitted load has a Coulomb coefficient μ > 0 (μ_drive > 0 for the power-flow shape,
whose back-driven coefficient the loaded runs hardly determine): a negative μ is an efficiency
that rises with the load, which a gear does not have; a torque transducer's gain error, when
the load resists the motion, draws it."""


PHYSICAL_SIGN_BEYOND_NOISE: dict[str, tuple[tuple[str, ...], int]] = {
    "load_dependent_friction": (("mu_back",), 1)}
"""Coefficients whose wrong sign is an objection only when it lies beyond SIGN_Z standard errors
of the fit: the power-flow shape's back-driven μ_back, zero for a gear that loses only while the
motors drive and so as often a little negative as positive. Where the load also drives the joint,
μ_drive and μ_back are μ ± g_T for a torque reading whose gain differs from the load reading's
(estimator.models.with_torque_gain): a friction coefficient clearly below zero per power flow is
that gain, not a gear."""

SIGN_Z = 3.0
"""Standard errors by which a PHYSICAL_SIGN_BEYOND_NOISE coefficient must lie on the wrong side
of zero to object."""


def physical_objection(m: LinearModel, theta: np.ndarray,
                       se: np.ndarray | None = None) -> str | None:
    """Why the fit `theta` (standard errors `se`) of `m` is not the physics of its last effect
    (PHYSICAL_SIGN; PHYSICAL_SIGN_BEYOND_NOISE when `se` is given), or None when it is."""
    if not m.effects:
        return None
    effect, params = m.effects[-1], list(m.param_names)
    names, sign = PHYSICAL_SIGN.get(effect, ((), 1))
    for name in names:
        if name not in params:
            continue
        value = float(theta[params.index(name)])
        if value * sign <= 0:
            return f"{name} = {value:.3g} has the sign no {effect} has"
    names, sign = PHYSICAL_SIGN_BEYOND_NOISE.get(effect, ((), 1))
    for name in names:
        if se is None or name not in params:
            continue
        i = params.index(name)
        value, err = float(theta[i]), float(se[i])
        if value * sign < -SIGN_Z * err:
            return (f"{name} = {value:.3g} ± {err:.2g} has the sign no {effect} has, beyond "
                    f"{SIGN_Z:g} standard errors")
    return None


def _effect_term(model: LinearModel, name: str, shape: Mapping[str, float]) -> Term:
    """The effect's term function at unit magnitude, as regressor column(s):

    stribeck                  f_s · stribeck_torque(q̇, 1, v_s, delta)  (output; the curve's
                              exponent delta, or 0 for the Lorentzian, is a shape)
    load_dependent_friction   mu · |T|·sgn q̇ + mu_v · |T|·q̇                      (output; T is the
                              measured torque, an errors-in-variables approximation); shape
                              power_flow=1: mu_drive · |T|·sgn q̇·[T·q̇ > 0] + mu_back · |T|·sgn q̇·
                              [T·q̇ ≤ 0] (driving vs back-driven efficiency)
    temperature_friction      g·(c_T·sgn q̇ + c_Tv·q̇), g = T_ref − temp            (output;
                              shape curvature=κ: g = (exp(κ·(T_ref − temp)) − 1)/κ)
    asymmetric_friction       d_v · asym(q̇, 0, 1): the positive direction's extra viscous slope
                              (its extra Coulomb level is a constant to Eq. 4: a torque offset)
    gear_ripple               A_sin·ripple(q, 1, order, 0) + A_cos·ripple(q, 1, order, π/2)
                              (the unknown phase made linear); one column A if `phase` is given;
                              shape motor=1: the same on u (the motor angle over N, `order` = k·N);
                              shape harmonics=h: also at 2·order … h·order (two columns each);
                              shape load=1: also B_sin·|T|·ripple(…, 0) + B_cos·|T|·ripple(…, π/2),
                              a mesh whose ripple grows with the torque it carries (T measured);
                              shape dynamic=w: each sine and cosine also times |q̇|/w, q̇/w and
                              q̇·|q̇|/w² (Ca_…, Cs_…, Cq_…), a fast ripple seen through the
                              joint's dynamics, its amplitude and phase following the speed
    torque_offset             c0 · torque_offset(t, 1, 0) + drift · torque_offset(t, 0, 1) (sensor;
                              shape settling=τ adds settle · (1 − exp(−t/τ)), a settling reading;
                              shape thermal=1 adds c_temp · (temp − 25 °C), a strain-gauge zero
                              that follows the joint's temperature)
    time_delay                delay · (−dT/dt): T(t − d) ≈ T(t) − d·Ṫ(t), linear in d (sensor);
                              shape angle=1 (transmission laws): k_lag · (−q̇), an angle reading
                              that lags the other by d reads the twist off by d·q̇, so
                              T = k·(Δ_read − d·q̇) and k_lag = k·d (+ the output encoder's lag,
                              − the motor encoder's)
    hysteresis                k_h · x, x the Bouc–Wen state of the twist for shape (alpha, beta,
                              gamma, n) (transmission models without an x column, e.g. eq5)
    backlash                  k_bl · (backlash_twist(Δ, b) − Δ): k·bt(Δ) = k·Δ + k·(bt(Δ) − Δ),
                              so k_bl ≈ k when the dead zone is real (transmission models); the
                              half-width b is a shape (SHAPE_MAGNITUDE), default the vocabulary's
    """
    if name not in fx.VOCABULARY:
        raise ValueError(f"unknown effect {name!r}; the vocabulary is {list(fx.EFFECT_NAMES)}")
    eff = fx.VOCABULARY[name]
    # gear_ripple's `motor` shape (a diagnosis family member, not an emulator parameter): the
    # ripple is periodic in the motor angle u·N, `order` then counts cycles per turn of u
    motor = bool(shape.get("motor", 0.0)) if name == "gear_ripple" else False
    # and its `harmonics`: a mesh's ripple with its 2nd … harmonics-th harmonic
    harmonics = int(shape.get("harmonics", 1)) if name == "gear_ripple" else 1
    # and its `load`: a mesh whose ripple amplitude grows with the torque it carries (a tooth
    # pair's stiffness varying along the mesh; effects-in-the-wild: "amplitude varying with load")
    load = bool(shape.get("load", 0.0)) if name == "gear_ripple" else False
    # and its `dynamic`: a ripple that reaches the reading through the joint's dynamics, so its
    # amplitude and phase follow its frequency order·|u̇| (the value is the speed [rad/s] that
    # scales the speed columns)
    w_dyn = float(shape.get("dynamic", 0.0)) if name == "gear_ripple" else 0.0
    # load_dependent_friction's `power_flow` shape likewise: a coefficient per power-flow sign
    power_flow = (bool(shape.get("power_flow", 0.0)) if name == "load_dependent_friction"
                  else False)
    # temperature_friction's `curvature` likewise: κ of the exponential temperature law
    kappa = float(shape.get("curvature", 0.0)) if name == "temperature_friction" else 0.0
    # torque_offset's `settling`: the time constant [s] of a reading that settles after start
    settling = float(shape.get("settling", 0.0)) if name == "torque_offset" else 0.0
    # and its `thermal`: a zero that follows the joint's temperature (a strain gauge's zero drift)
    thermal = bool(shape.get("thermal", 0.0)) if name == "torque_offset" else False
    # time_delay's `angle`: the lag is an angle reading's, seen by a twist–torque law as a twist
    # error proportional to the speed
    angle = bool(shape.get("angle", 0.0)) if name == "time_delay" else False
    shape = {k: v for k, v in shape.items()
             if not ((name == "gear_ripple" and k in ("motor", "harmonics", "load", "dynamic"))
                     or (name == "load_dependent_friction" and k == "power_flow")
                     or (name == "temperature_friction" and k == "curvature")
                     or (name == "torque_offset" and k in ("settling", "thermal"))
                     or (name == "time_delay" and k == "angle"))}
    bw_keys = {"alpha", "beta", "gamma", "n"}
    if name == "hysteresis":
        bad = set(shape) - bw_keys
        if bad:
            raise ValueError(f"hysteresis takes the Bouc–Wen shape {sorted(bw_keys)}, not {sorted(bad)}")
    elif name in SHAPE_MAGNITUDE:
        # the vocabulary's magnitude is a shape of the column (e.g. backlash's dead-zone
        # half-width b); the coefficient identified is the column's own (k_bl)
        shape_params = eff.resolve(shape)
        if shape_params[eff.magnitude] <= 0:
            raise ValueError(f"{name!r} needs {eff.magnitude!r} > 0 for its column, got "
                             f"{shape_params[eff.magnitude]!r}")
    else:
        shape_params = {k: v for k, v in eff.resolve(shape).items() if k != eff.magnitude}
        if eff.magnitude in shape:
            raise ValueError(f"{eff.magnitude!r} is the magnitude of {name!r}: it is the parameter "
                             "identified, not a shape to fix")
    # a transmission effect sits in whatever law has the displacement: the twist of a
    # transmission law, else the position itself (a system with no separate twist channel)
    disp = "torsion" if model.kind == "transmission" else "q"
    if eff.acts_on == "sensor" and model.kind == "generic" and name == "time_delay":
        raise ValueError("time_delay is defined on the torque channel; it applies to eq4/eq5/eq11")
    v_eps = V_EPS

    if name == "stribeck":
        v_s, delta = shape_params["v_s"], shape_params["delta"]
        return Term(name, ("f_s",), ("N·m",),
                    lambda s: fx.stribeck_torque(s["qd"], 1.0, v_s, v_eps, delta), ("qd",))
    if name == "load_dependent_friction" and power_flow:
        # a gear's efficiency differs when the motor drives the load (T·q̇ > 0) and when the load
        # back-drives it: one Coulomb-like coefficient per direction of the power flow
        def split(s):
            c = fx.load_dependent_friction_torque(s["qd"], s["torque"], 1.0, v_eps, 0.0)
            drive = s["torque"] * s["qd"] > 0
            return np.column_stack([np.where(drive, c, 0.0), np.where(drive, 0.0, c)])
        return Term(name, ("mu_drive", "mu_back"), ("-", "-"), split, ("qd", "torque"))
    if name == "load_dependent_friction":
        return Term(name, ("mu", "mu_v"), ("-", "s/rad"),
                    lambda s: np.column_stack([
                        fx.load_dependent_friction_torque(s["qd"], s["torque"], 1.0, v_eps, 0.0),
                        fx.load_dependent_friction_torque(s["qd"], s["torque"], 0.0, v_eps, 1.0)]),
                    ("qd", "torque"))
    if name == "asymmetric_friction":
        # the Coulomb part, d_c·(1 + sgn q̇)/2, is a constant plus Eq. 4's own Coulomb column
        # (a torque offset to any fit): its identifiable part is the viscous slope's
        return Term(name, ("d_v",), ("N·m·s/rad",),
                    lambda s: fx.asymmetric_friction_torque(s["qd"], 0.0, 1.0, v_eps), ("qd",))
    if name == "temperature_friction":
        T_ref = shape_params["T_ref"]
        return Term(name, ("c_T", "c_Tv"), ("N·m/K", "N·m·s/(rad·K)"),
                    lambda s: np.column_stack([
                        fx.temperature_friction_torque(s["qd"], s["temp_joint"], 1.0, T_ref,
                                                       v_eps, 0.0, kappa),
                        fx.temperature_friction_torque(s["qd"], s["temp_joint"], 0.0, T_ref,
                                                       v_eps, 1.0, kappa)]),
                    ("qd", "temp_joint"))
    if name == "gear_ripple":
        order = shape_params["order"]
        if "phase" in shape and not motor and harmonics == 1 and not load and not w_dyn:
            ph = shape_params["phase"]
            return Term(name, ("A",), ("N·m",),
                        lambda s: fx.gear_ripple_torque(s["q"], 1.0, order, ph), ("q",))
        # on q, or on u (the motor angle over N: `order` cycles per output revolution of u),
        # with its harmonics 2·order … harmonics·order, each with an unknown phase
        ang = "u" if motor else "q"
        names = tuple(f"A_{sc}{j if j > 1 else ''}" for j in range(1, harmonics + 1)
                      for sc in ("sin", "cos"))
        units = ("N·m",) * len(names)
        # the load-modulated mesh: also the first sine and cosine again times |T|
        if load:
            names, units = names + ("B_sin", "B_cos"), units + ("1", "1")
        # the dynamic ripple: a response H(Ω) = R(|Ω|) + i·sgn(Ω)·I(|Ω|) (a real system's) to the
        # ripple's frequency Ω ∝ q̇, R even and I odd in q̇: R ≈ a + b·|q̇|, sgn·I ≈ c·q̇ + d·q̇·|q̇|
        # (exact at two speeds, a campaign's 300 and 3000 r/min), so each sine and cosine also
        # times |q̇|, q̇ and q̇·|q̇|, the speeds over w_dyn
        if w_dyn:
            names = names + tuple(f"{p}_{n}" for p in ("Ca", "Cs", "Cq")
                                  for n in names[:2 * harmonics])
            units = units + ("N·m",) * (6 * harmonics)
        inputs = (ang,) + (("torque",) if load else ()) + (("qd",) if w_dyn else ())

        def ripple_columns(s):
            base = [fx.gear_ripple_torque(s[ang], 1.0, j * order, ph)
                    for j in range(1, harmonics + 1) for ph in (0.0, np.pi / 2)]
            cols = list(base)
            if load:
                cols += [np.abs(s["torque"]) * c for c in base[:2]]
            if w_dyn:
                w = s["qd"] / w_dyn
                cols += ([np.abs(w) * c for c in base] + [w * c for c in base]
                         + [w * np.abs(w) * c for c in base])
            return np.column_stack(cols)
        return Term(name, names, units, ripple_columns, inputs)
    if name == "torque_offset":
        # a constant and a linear drift, plus the column of the shape: a zero that follows the
        # joint's temperature, or a reading that settles after start-up
        names, units, inputs = ["c0", "drift"], ["N·m", "N·m/s"], ["t"]
        if thermal:
            names, units, inputs = names + ["c_temp"], units + ["N·m/K"], inputs + ["temp_joint"]
        elif settling > 0:
            names, units = names + ["settle"], units + ["N·m"]

        def offset_columns(s):
            cols = [np.ones_like(s["t"]), fx.torque_offset(s["t"], 0.0, 1.0)]
            if thermal:
                cols.append(s["temp_joint"] - THERMAL_ZERO_REF_C)
            elif settling > 0:
                cols.append(-np.expm1(-s["t"] / settling))
            return np.column_stack(cols)
        return Term(name, tuple(names), tuple(units), offset_columns, tuple(inputs))
    if name == "time_delay" and angle:
        if model.kind != "transmission":
            raise ValueError("time_delay's angle shape is a twist error; it applies to a "
                             "transmission (twist–torque) law")
        return Term(name, ("k_lag",), ("N·m·s/rad",), lambda s: -s["qd"], ("qd",))
    if name == "time_delay":
        return Term(name, ("delay",), ("s",), lambda s: -s["torque_rate"], ("torque_rate",))
    if name == "hysteresis":
        if "k_h" in model.param_names:
            raise ValueError(f"{model.name!r} already has the hysteretic term k_h·x")
        a = float(shape.get("alpha", _P.alpha))
        b = float(shape.get("beta", _P.beta))
        g = float(shape.get("gamma", _P.gamma))
        n = int(shape.get("n", _P.n))
        return Term(name, ("k_h",), ("N·m/rad",), lambda s: bouc_wen_x(s, a, b, g, n, disp),
                    (disp,))
    if name == "backlash":
        b = shape_params["b"]
        return Term(name, ("k_bl",), ("N·m/rad",),
                    lambda s: fx.backlash_twist(s[disp], b) - s[disp], (disp,))
    raise ValueError(f"effect {name!r} has no column form")  # pragma: no cover - vocabulary grew
