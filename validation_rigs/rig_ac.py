"""Rig AC — an independent validation simulator of the CMOR J4 joint test bench.

Written from the paper (shared/seeds/cmor-sghmc-paper.txt), shared/docs/*.md and the run format
(core/channels.py, core/runfile.py) only; the interface (names, argument checks, SensorSpec
fields) follows rig AB's, nothing else of it. It shares no code and no functional forms with the
emulator or the other validation rigs: friction is a two-element Maxwell-slip (elasto-plastic)
model, the compliance is a linear spring with a softer low-torque segment blended in by an
algebraic sigmoid, the motor runs a cascaded position-P / velocity-PI servo, the integrator is
Heun's explicit trapezoidal rule at a fixed 0.25 ms substep, and the torque transducer is an
exact first-order low-pass with white noise added after it. SI units (rad, N·m, s, W) except
temperatures (°C); "referred" means referred to the joint output through N = 11000.

DATA SHEET
==========

1. Machine (nominal values; each campaign `seed` draws one machine)
-------------------------------------------------------------------
Values marked (x %) are multiplied by (1 + x/100·ε), ε ~ N(0,1) clipped to ±2; RigRun.params
holds the drawn values.

Output side (paper Eq. 4 with the dynamometer; rig.md signs):

    I·q̈ = T − τ_L − G(q) − F_f + τ_x,        G(q) = g·(mr_x·sin q + mr_y·cos q), g = 9.81

  I = 6685.166 kg·m² (1.5 %), mr_x = 20.779 kg·m (5 %), mr_y = −34.543 kg·m (5 %);
  τ_x = disturbance torques of effects (0 nominally).

Output friction F_f — Maxwell-slip, two elasto-plastic elements plus viscous:

    z_i ← clip(z_i + κ_i·dq, ±L_i),  L_i = α_i·c,  F_f = Σ z_i + Σ_stuck d_i·q̇ + f_v·q̇

  c = f_c = 2352.660 N·m (3 %), f_v = 8683.272 N·m·s/rad (4 %); α = (0.55, 0.45),
  break-away displacements L_i/κ_i = 3e-5 and 1.5e-4 rad (below the 0.01° encoder step), presliding
  dashpots d_i = 2.0e5 N·m·s/rad acting only on a stuck element. While sliding F_f = c·sgn(q̇)
  + f_v·q̇ exactly: the steady scheme-1 friction is f_c + f_v·|q̇| with the sign of the motion.
  Nominally independent of temperature, load and direction.

Flexible transmission — twist Δ = u − q (stored torsion = q − u = −Δ):

    T = K(Δ) + D·Δ̇,   K(Δ) = k₂·Δ − (k₂ − k₁)·Δ_s·ξ/√(1 + ξ²),  ξ = Δ/Δ_s

  tangent stiffness k₁ at Δ = 0 (harmonic-drive-like soft segment), k₂ for |Δ| ≫ Δ_s.
  Δ_r = 0.5° = 8.727e-3 rad (4 %) is the rated twist: k₂ is solved so that K(Δ_r) = 120 kN·m.
  k₁/k₂ = 0.5 (8 %), Δ_s = 1.5e-3 rad (10 %) → k₂ ≈ 1.50e7, k₁ ≈ 7.5e6 N·m/rad.
  D = 1.2e5 N·m·s/rad (10 %) (output mode ≈ 5–7 Hz, damping ratio ≈ 0.2–0.3).
  No hysteresis, backlash or kinematic error nominally.

Motor side (three servo motors on one shaft, referred):

    J·ü = τ_m − T − F_m(u̇),   F_m = F_mc·u̇/√(u̇² + v_m²) + f_mv·u̇
    u̇_cmd = u̇_ref + K_p·(u_ref − u),   τ_m = J·(K_v·(u̇_cmd − u̇) + w + ü_ref),  ẇ = K_i·(u̇_cmd − u̇)

  J = 3·0.004·N² ≈ 1.452e6 kg·m² (3 %), F_mc = 3·0.15·N = 4950 N·m (5 %), v_m = 1e-3 rad/s,
  f_mv = 3·1e-4·N² = 36300 N·m·s/rad (5 %), K_p = 8 s⁻¹, K_v = 60 s⁻¹, K_i = 600 s⁻², |τ_m| ≤ 2.5e5.
  Motor k currents i_k = w_k·τ_m/(N·k_t,k), shares w_k (1/3, 3 %, normalised), k_t = 1.2 N·m/A
  (2 % each); motor speeds w_mk = N·u̇.

Dynamometer (its own first-order dynamics and a wandering error):
    τ̇_s = (g_d·τ_cmd + n_d(t) − τ_s)/T_d,   τ_L = τ_s
  g_d = 1 (0.4 %), T_d = 0.06 s (10 %), n_d an Ornstein–Uhlenbeck torque noise, SD 150 N·m,
  correlation time 0.3 s (drawn per run; within the ±2 kN·m acceptance band).

Thermal (first order, ambient = temp_joint_c):
    C_g·θ̇_g = |F_f·q̇| + |F_m·u̇| − (θ_g − θ_a)/R_g,   C_g = 2e4 J/K, R_g = 0.05 K/W, θ_g(0) = θ_a
    C_m·θ̇_mk = R_w·i_k² − (θ_mk − θ_a)/R_m,         C_m = 800 J/K, R_m = 0.5 K/W, R_w = 0.8 Ω,
                                                      θ_mk(0) = θ_a + 1.5 °C

Initial state: q = u = 0, T = 0, the friction elements hold gravity (z_i = −α_i·G(0)).

2. Schemes (reference of the motor, referred: u_ref; dynamometer set point τ_cmd ≥ 0)
-------------------------------------------------------------------------------------
  ω_o = rpm·2π/60/N (2.856e-3 rad/s at 300 r/min, 2.856e-2 at 3000). Scheme 1 and 2: the motor
  runs at direction·ω_o after a raised-cosine start (0.2 s → 1.0 s); loading starts at 1.0 s.
  Scheme 1 period 16 s: τ_cmd rises linearly 0 → 120 kN·m in 8 s, falls back in 8 s (phases
  load / unload). Scheme 2 period 30.1 s: 12 steps of 10 kN·m, each 0.3 s ramp (load) + 2 s hold
  (hold), then a 2.5 s ramp to 0 (unload). Scheme 3: fifth-order Fourier trajectory (Eq. 12),
  ω_f = 2π/20 s, q(0) = q̇(0) = q̈(0) = 0, peak |q̇| = 0.026 rad/s, times direction, τ_cmd = 0
  (the dynamometer idles, coupled); phase excite. All schemes: 1.0 s lead-in (idle), 1.0 s tail
  (idle). A run whose travel would pass ±(π − 0.1) rad is refused (scheme 2 at 3000 r/min allows
  up to 3 periods).

3. Sensors (SensorSpec; meta["sensors"] states resolution / noise_sd / lag_s per channel)
-----------------------------------------------------------------------------------------
  q: output encoder quantised at encoder_res_deg (0.01°, stated in rad); qd: true + white noise;
  u: motor encoder quantised at motor_encoder_res; ud: true + noise; torsion = q − u as read;
  torque: transmitted torque through a first-order low-pass of time constant torque_filter_s
  (its group delay), then white noise torque_noise added after the filter, then torque_res steps,
  then a pure lag torque_lag_s; torque_load: τ_L + noise, load_res steps; currents, motor speeds
  (N·ud reading), temperatures (temp_res steps + noise); torque_cmd exact; phase text.
  Simulation: Heun substep 0.25 ms, internal record every 0.5 ms, samples interpolated linearly.

4. Effects ({name: {"form", "scale"}}, scale s in [0, SCALE_MAX]; s = 0 is no effect)
---------------------------------------------------------------------------------------
  Friction effects act on the Coulomb level c and viscous coefficient f_v of section 1 (then the
  Maxwell elements' limits follow); multipliers are clipped at ≥ 0.05.
  stribeck: L_i ← L_i·(1 + 0.25·s·φ(|q̇|/v_s)), v_s = 5e-3 rad/s;
      exponential φ = e^{−x}; gaussian φ = e^{−x²}; lorentzian φ = 1/(1 + x²).
      Scale 1: break-away 1.25·f_c; ≈ +350–520 N·m of friction at 300 r/min, ≲ 20 N·m at
      3000 r/min. v_s is large enough that the falling branch's slope stays below f_v + D, so
      sliding at 300 r/min is stable at scale 1; from scale ≈ 1.5 the 300 r/min runs go into
      stick–slip (the output oscillates against the compliant transmission).
  load_dependent_friction: coulomb_linear c += 0.01·s·|T| (+1.2 kN·m at rated);
      coulomb_viscous_scaled c, f_v ×(1 + 0.4·s·|T|/120 kN·m); power_flow c += s·|T|·0.014 when
      driving (T·q̇ > 0), 0.005 when back-driven.
  temperature_friction (θ_g gearbox temperature, θ_ref = 35 °C, δθ = θ_ref − θ_g):
      viscous_exponential f_v ×(1 + s·(e^{0.03·δθ} − 1)); coulomb_additive c += 30·s·δθ;
      quadratic_both c, f_v ×(1 + s·(0.012·δθ + 1.5e-4·δθ²)). Scale 1 at 20 °C: f_v ×1.57,
      c + 450 N·m, both ×1.21.
  gear_ripple: output_mesh τ_x += 300·s·sin(96·q + 0.7); mesh_harmonics τ_x += 250·s·(sin(61·q
      + 0.3) + 0.5·sin(122·q + 1.9)); wave_generator_error: kinematic error in the twist,
      Δ → Δ − e, e = s·(2e-5·sin(2N·u + 0.5) + 6e-6·sin(4N·u + 1.1)) rad (2 and 4 cycles per
      motor revolution; ≈ 300 N·m of spring torque at scale 1).
  torque_offset (reading): constant_bias +400·s N·m; linear_drift +8·s·t N·m;
      saturating_creep +600·s·(1 − e^{−t/20 s}) N·m.
  time_delay: torque_latency — torque reading a further 12·s ms late; q_encoder_latency — q and
      qd readings 12·s ms late.
  hysteresis (torque h added to T, driven by the twist Δ = u − q; H = 1500·s N·m, δ_h = 3e-4 rad):
      bouc_wen_n2 ḣ = (H/δ_h)·Δ̇·(1 − (0.5·sgn(Δ̇·h) + 0.5)·|h/H|²);
      dahl_i15 ḣ = (H/δ_h)·Δ̇·sgn(1 − sgn(Δ̇)·h/H)·|1 − sgn(Δ̇)·h/H|^1.5;
      iwan_stops h = Σ_j c_j·s_j, three stops s_j ← clip(s_j + dΔ, ±r_j), r = (0.5, 1, 2)·δ_h/2,
      c_j·r_j = H/3. Scale 1: loading and unloading branches 2H = 3 kN·m apart (≈ 2e-4 rad twist).
  backlash (b = 2e-4·s rad dead zone half-width; spring and damper see the engaged twist):
      sharp Δ_e = Δ − b·sgn(Δ) outside |Δ| ≤ b, 0 inside; quadratic_blend Δ_e = sgn(Δ)·Δ²/(4b)
      for |Δ| ≤ 2b, sgn(Δ)(|Δ| − b) beyond (C¹). Scale 1: +2e-4 rad of twist at any load, a flat
      spot at torque reversals.
  asymmetric_friction: coulomb_split c ×(1 + 0.15·s·sgn q̇); coulomb_viscous_split c ×(1 + 0.08·s
      ·sgn q̇), f_v ×(1 + 0.4·s·sgn q̇); bias_torque F_f += 0.12·s·f_c (a constant, not gravity).
  periodic_disturbance (τ_x): pump_square 400·s·(2/π)·atan(6·sin(2π·1.3·t));
      fan_two_tone 300·s·(sin(2π·4.7·t) + 0.6·sin(2π·9.4·t + 1)).
  position_dependent_stiffness (factor on K and D, clipped ≥ 0.3): linear_gradient 1 + 0.2·s·q;
      twice_per_rev 1 + 0.1·s·sin(2q + 0.4).
  encoder_drift (readings): q_linear q += 6e-6·s·t rad; u_saturating u += 3e-4·s·(1 − e^{−t/15 s}).
  second_resonance: output_tuned_mass — an inertia 0.15·s·I on the output through a spring/damper
      tuned to 11 Hz, ζ = 0.02; loading_shaft — the dynamometer drives an inertia 0.3·s·I that
      loads the output through a shaft tuned to 8 Hz, ζ = 0.03 (torque_load reads the shaft).

Truth (RigRun.truth, at the sample instants, without sensor effects): t, q, qd, qdd, u, ud,
twist (u − q), twist_rate, torque (T), torque_load (τ_L at the output), torque_cmd, friction (F_f),
gravity (G), disturbance (τ_x), motor_torque (τ_m), temp_joint (θ_g).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
import pandas as pd

RIG_NAME = "rig_ac"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous_scaled", "power_flow"),
    "temperature_friction": ("viscous_exponential", "coulomb_additive", "quadratic_both"),
    "gear_ripple": ("output_mesh", "mesh_harmonics", "wave_generator_error"),
    "torque_offset": ("constant_bias", "linear_drift", "saturating_creep"),
    "time_delay": ("torque_latency", "q_encoder_latency"),
    "hysteresis": ("bouc_wen_n2", "dahl_i15", "iwan_stops"),
    "backlash": ("sharp", "quadratic_blend"),
    "asymmetric_friction": ("coulomb_split", "coulomb_viscous_split", "bias_torque"),
    "periodic_disturbance": ("pump_square", "fan_two_tone"),
    "position_dependent_stiffness": ("linear_gradient", "twice_per_rev"),
    "encoder_drift": ("q_linear", "u_saturating"),
    "second_resonance": ("output_tuned_mass", "loading_shaft"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "time_delay": (
        "The torque transducer is a first-order low-pass of time constant "
        "SensorSpec.torque_filter_s (0.5 ms by default), so the torque reading lags the "
        "transmitted torque by about that much; meta sensors.torque.lag_s states it (plus "
        "SensorSpec.torque_lag_s)."),
}

# --- constants ---------------------------------------------------------------------------------
G_ACC = 9.81
T_RATED = 120_000.0
TWIST_RATED_DEG = 0.5
H_STEP = 2.5e-4
REC_EVERY = 2
REC_DT = H_STEP * REC_EVERY
NOISE_DT = 5e-3
THETA_REF = 35.0
TRAVEL_LIMIT = math.pi - 0.1

LEAD_S, TAIL_S = 1.0, 1.0
START_T0, START_T1 = 0.2, 1.0
S1_HALF = 8.0
S2_RAMP, S2_HOLD, S2_NSTEP, S2_UNLOAD = 0.3, 2.0, 12, 2.5
S2_PERIOD = S2_NSTEP * (S2_RAMP + S2_HOLD) + S2_UNLOAD
S3_PERIOD = 20.0
_FA = np.array([0.006, -0.004, 0.003, -0.0035, -0.0015])
_FB = np.array([0.004, 0.003, -0.002, 0.0015, -0.002])      # Σ l·b_l = 0 → q̈(0) = 0
_W3 = 2.0 * math.pi / S3_PERIOD


def _fourier_peak() -> float:
    tt = np.linspace(0.0, S3_PERIOD, 20001)
    v = sum(_FA[l] * np.cos(_W3 * (l + 1) * tt) + _FB[l] * np.sin(_W3 * (l + 1) * tt)
            for l in range(5))
    return float(np.max(np.abs(v)))


_FSCALE = 0.026 / _fourier_peak()
FOURIER_A = _FA * _FSCALE
FOURIER_B = _FB * _FSCALE

MAXWELL_ALPHA = (0.55, 0.45)
MAXWELL_BREAK = (3e-5, 1.5e-4)
MAXWELL_DAMP = 2.0e5

_NOMINAL = {  # name: (value, relative SD)
    "I": (6685.166, 0.015), "mr_x": (20.779, 0.05), "mr_y": (-34.543, 0.05),
    "f_c": (2352.660, 0.03), "f_v": (8683.272, 0.04),
    "twist_rated_rad": (math.radians(TWIST_RATED_DEG), 0.04), "soft_ratio": (0.5, 0.08),
    "twist_soft_rad": (1.5e-3, 0.10), "D": (1.2e5, 0.10),
    "J": (3 * 0.004 * REDUCTION ** 2, 0.03), "F_mc": (3 * 0.15 * REDUCTION, 0.05),
    "f_mv": (3 * 1e-4 * REDUCTION ** 2, 0.05), "dyn_gain": (1.0, 0.004), "dyn_tc": (0.06, 0.10),
    "kt1": (1.2, 0.02), "kt2": (1.2, 0.02), "kt3": (1.2, 0.02),
    "w1": (1 / 3, 0.03), "w2": (1 / 3, 0.03), "w3": (1 / 3, 0.03),
}

# parameter vector
(P_I, P_MRX, P_MRY, P_FC, P_FV, P_K1, P_K2, P_DS, P_D, P_J, P_FMC, P_FMV, P_DG, P_DT,
 P_KT1, P_KT2, P_KT3, P_W1, P_W2, P_W3, P_SCHEME, P_DIR, P_OMEGA, P_PERIODS, P_AMB, P_U0) = range(26)
N_P = 26
# state vector
(Y_Q, Y_QD, Y_U, Y_UD, Y_WI, Y_TS, Y_H, Y_TG, Y_TM1, Y_TM2, Y_TM3, Y_Y2, Y_Y2D) = range(13)
N_Y = 13
# auxiliaries
(A_T, A_TL, A_F, A_G, A_X, A_TM, A_TCMD, A_QDD, A_UDD, A_I1, A_I2, A_I3, A_CLIM, A_DEL) = range(14)
N_A = 14
N_REC = N_Y + N_A
# effect family indices
(E_STRIB, E_LOADF, E_TEMPF, E_RIPPLE, E_OFFSET, E_DELAY, E_HYST, E_BACKLASH, E_ASYM, E_PERIODIC,
 E_POSSTIFF, E_DRIFT, E_RES2) = range(13)
_FAMILY = {name: i for i, name in enumerate(EFFECT_FORMS)}

HYST_H, HYST_D = 1500.0, 3e-4
IWAN_R = (0.25 * HYST_D, 0.5 * HYST_D, 1.0 * HYST_D)
DELAY_S = 0.012
STRIB_DS, STRIB_VS = 0.25, 5e-3
BACKLASH_B = 2e-4

PHASES = ("idle", "load", "hold", "unload", "excite")


# --- sensors -----------------------------------------------------------------------------------

_SENSOR_RANGES = {
    "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-5, 1.0),
    "torque_noise": (0.0, 1e5), "torque_lag_s": (0.0, 1.0), "torque_filter_s": (0.0, 0.1),
    "torque_res": (0.0, 1e4), "load_noise": (0.0, 1e5), "load_res": (0.0, 1e4),
    "qd_noise": (0.0, 1.0), "motor_encoder_res": (0.0, 1e-2), "ud_noise": (0.0, 1.0),
    "current_noise": (0.0, 100.0), "temp_res": (0.0, 10.0), "temp_noise": (0.0, 10.0),
}


@dataclass
class SensorSpec:
    """The bench's sensors (data sheet section 3); allowed ranges in _SENSOR_RANGES."""

    sample_rate_hz: float = 1000.0      # [Hz]
    encoder_res_deg: float = 0.01       # output encoder step [deg]
    torque_noise: float = 120.0         # white noise SD after the transducer filter [N·m]
    torque_lag_s: float = 0.0           # pure lag of the torque reading [s]
    torque_filter_s: float = 5e-4       # transducer low-pass time constant = group delay [s]
    torque_res: float = 2.0             # torque step [N·m] (0: none)
    load_noise: float = 80.0            # dynamometer torque noise SD [N·m]
    load_res: float = 5.0               # its step [N·m]
    qd_noise: float = 2e-5              # output velocity noise SD [rad/s]
    motor_encoder_res: float = 2 * math.pi / 2 ** 20 / REDUCTION  # referred step [rad]
    ud_noise: float = 2e-6              # referred motor velocity noise SD [rad/s]
    current_noise: float = 0.02         # current noise SD [A]
    temp_res: float = 0.1               # temperature step [°C]
    temp_noise: float = 0.03            # temperature noise SD [°C]

    def __post_init__(self) -> None:
        for name, (lo, hi) in _SENSOR_RANGES.items():
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(
                    v, (int, float, np.integer, np.floating)):
                raise ValueError(f"SensorSpec.{name} must be a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise ValueError(f"SensorSpec.{name} must be finite, got {v!r}")
            if v < lo or v > hi:
                raise ValueError(f"SensorSpec.{name} must lie in [{lo:g}, {hi:g}], got {v!r}")
            setattr(self, name, v)


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


# --- argument checks ---------------------------------------------------------------------------

def _is_int(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _check_effects(effects: Any) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError("effects must be a dict {name: {'form', 'scale'}} or None, got "
                         f"{type(effects).__name__}")
    out: dict[str, tuple[str, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale', got {spec!r}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}] has unknown keys {sorted(extra)}; expected "
                             "'form' and 'scale'")
        form = spec.get("form")
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; known: "
                             f"{list(EFFECT_FORMS[name])}")
        scale = spec.get("scale", 1.0)
        if not _is_num(scale) or not math.isfinite(float(scale)):
            raise ValueError(f"effects[{name!r}]['scale'] must be a finite number, got {scale!r}")
        scale = float(scale)
        if scale < 0.0:
            raise ValueError(f"effects[{name!r}]['scale'] must be >= 0, got {scale!r}")
        if scale > SCALE_MAX:
            raise ValueError(f"effects[{name!r}]['scale'] must be <= SCALE_MAX = {SCALE_MAX:g} "
                             f"(larger scales are refused), got {scale!r}")
        if scale > 0.0:
            out[name] = (form, scale)
    return out


def _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, sensors, periods, seed, run):
    if not _is_int(scheme) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
    elif not _is_num(motor_speed_rpm) or float(motor_speed_rpm) not in (300.0, 3000.0):
        raise ValueError(f"motor_speed_rpm must be 300 or 3000 for scheme {scheme}, got "
                         f"{motor_speed_rpm!r}")
    if not _is_num(direction) or float(direction) not in (1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not _is_num(temp_joint_c) or not math.isfinite(float(temp_joint_c)) \
            or not 15.0 <= float(temp_joint_c) <= 60.0:
        raise ValueError(f"temp_joint_c must be a number in [15, 60] °C, got {temp_joint_c!r}")
    if sensors is not None and not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec or None, got {type(sensors).__name__}")
    if not _is_int(periods) or not 1 <= int(periods) <= 20:
        raise ValueError(f"periods must be an integer in [1, 20], got {periods!r}")
    if not _is_int(seed) or int(seed) < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if not _is_int(run) or int(run) < 0:
        raise ValueError(f"run must be an integer >= 0, got {run!r}")


# --- scheme programmes ---------------------------------------------------------------------------

def run_duration(scheme: int, periods: int) -> float:
    per = {1: 2 * S1_HALF, 2: S2_PERIOD, 3: S3_PERIOD}[scheme]
    return LEAD_S + periods * per + TAIL_S


@numba.njit(cache=True)
def _ref(t, p, fa, fb):
    """(u_ref, u̇_ref, ü_ref) of the motor, referred, without the initial offset."""
    d = p[P_DIR]
    if p[P_SCHEME] < 2.5:
        w = p[P_OMEGA] * d
        tr = START_T1 - START_T0
        if t <= START_T0:
            return 0.0, 0.0, 0.0
        if t < START_T1:
            x = (t - START_T0) / tr
            return (w * 0.5 * (t - START_T0 - tr / math.pi * math.sin(math.pi * x)),
                    w * 0.5 * (1.0 - math.cos(math.pi * x)),
                    w * 0.5 * math.pi / tr * math.sin(math.pi * x))
        return w * (0.5 * tr + t - START_T1), w, 0.0
    tau = t - LEAD_S
    tend = p[P_PERIODS] * S3_PERIOD
    if tau < 0.0:
        return 0.0, 0.0, 0.0
    if tau > tend:
        tau = tend
        ex = False
    else:
        ex = True
    q = 0.0
    v = 0.0
    a = 0.0
    for l in range(5):
        wl = _W3 * (l + 1)
        s = math.sin(wl * tau)
        c = math.cos(wl * tau)
        q += fa[l] / wl * s - fb[l] / wl * c + fb[l] / wl
        v += fa[l] * c + fb[l] * s
        a += -fa[l] * wl * s + fb[l] * wl * c
    if not ex:
        v = 0.0
        a = 0.0
    return d * q, d * v, d * a


@numba.njit(cache=True)
def _tcmd(t, p):
    sch = p[P_SCHEME]
    if sch > 2.5:
        return 0.0
    tau = t - LEAD_S
    if sch < 1.5:
        per = 2.0 * S1_HALF
        if tau < 0.0 or tau >= p[P_PERIODS] * per:
            return 0.0
        x = tau - per * math.floor(tau / per)
        if x < S1_HALF:
            return T_RATED * x / S1_HALF
        return T_RATED * (per - x) / S1_HALF
    per = S2_PERIOD
    if tau < 0.0 or tau >= p[P_PERIODS] * per:
        return 0.0
    x = tau - per * math.floor(tau / per)
    step = S2_RAMP + S2_HOLD
    if x < S2_NSTEP * step:
        k = math.floor(x / step)
        r = x - k * step
        lvl = 10_000.0 * k
        if r < S2_RAMP:
            return lvl + 10_000.0 * r / S2_RAMP
        return lvl + 10_000.0
    r = x - S2_NSTEP * step
    return T_RATED * (1.0 - r / S2_UNLOAD)


def _phase_codes(t: np.ndarray, scheme: int, periods: int) -> np.ndarray:
    tau = t - LEAD_S
    out = np.zeros(len(t), dtype=np.int64)
    if scheme == 3:
        out[(tau >= 0) & (tau <= periods * S3_PERIOD)] = 4
        return out
    per = 2 * S1_HALF if scheme == 1 else S2_PERIOD
    inside = (tau >= 0) & (tau < periods * per)
    x = np.mod(tau, per)
    if scheme == 1:
        out[inside & (x < S1_HALF)] = 1
        out[inside & (x >= S1_HALF)] = 3
    else:
        step = S2_RAMP + S2_HOLD
        r = np.mod(x, step)
        stepping = x < S2_NSTEP * step
        out[inside & stepping & (r < S2_RAMP)] = 1
        out[inside & stepping & (r >= S2_RAMP)] = 2
        out[inside & ~stepping] = 3
    return out


# --- the kernel ---------------------------------------------------------------------------------

@numba.njit(cache=True)
def _sgn(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@numba.njit(cache=True)
def _rhs(t, y, zn, qn, sn, dn, p, ef, es, dnoise, fa, fb, dy, aux):
    q = y[Y_Q]
    qd = y[Y_QD]
    u = y[Y_U]
    ud = y[Y_UD]
    N = REDUCTION
    ur, udr, uddr = _ref(t, p, fa, fb)
    ur += p[P_U0]
    tc = _tcmd(t, p)
    # dynamometer noise (linear interpolation on its grid)
    x = t / NOISE_DT
    k = int(x)
    if k >= dnoise.shape[0] - 1:
        nd = dnoise[dnoise.shape[0] - 1]
    else:
        fr = x - k
        nd = dnoise[k] * (1.0 - fr) + dnoise[k + 1] * fr
    dy[Y_TS] = (p[P_DG] * tc + nd - y[Y_TS]) / p[P_DT]
    # transmission
    e = 0.0
    if ef[E_RIPPLE] == 2:
        s = es[E_RIPPLE]
        e = s * (2e-5 * math.sin(2.0 * N * u + 0.5) + 6e-6 * math.sin(4.0 * N * u + 1.1))
    d0 = u - q
    d = d0 - e
    dd = ud - qd
    de = d
    slope = 1.0
    if ef[E_BACKLASH] >= 0:
        b = BACKLASH_B * es[E_BACKLASH]
        ad = abs(d)
        if ef[E_BACKLASH] == 0:
            if ad <= b:
                de = 0.0
                slope = 0.0
            else:
                de = d - b * _sgn(d)
        else:
            if ad <= 2.0 * b:
                de = _sgn(d) * ad * ad / (4.0 * b)
                slope = ad / (2.0 * b)
            else:
                de = _sgn(d) * (ad - b)
    k1 = p[P_K1]
    k2 = p[P_K2]
    ds = p[P_DS]
    xi = de / ds
    K = k2 * de - (k2 - k1) * ds * xi / math.sqrt(1.0 + xi * xi)
    fpos = 1.0
    if ef[E_POSSTIFF] == 0:
        fpos = 1.0 + 0.2 * es[E_POSSTIFF] * q
    elif ef[E_POSSTIFF] == 1:
        fpos = 1.0 + 0.1 * es[E_POSSTIFF] * math.sin(2.0 * q + 0.4)
    if fpos < 0.3:
        fpos = 0.3
    T = fpos * (K + p[P_D] * slope * dd)
    dy[Y_H] = 0.0
    if ef[E_HYST] >= 0:
        H = HYST_H * es[E_HYST]
        g0 = H / HYST_D
        if ef[E_HYST] == 0:
            h = y[Y_H]
            r = h / H
            dy[Y_H] = g0 * dd * (1.0 - (0.5 * _sgn(dd * h) + 0.5) * r * r)
            T += h
        elif ef[E_HYST] == 1:
            h = y[Y_H]
            m = 1.0 - _sgn(dd) * h / H
            dy[Y_H] = g0 * dd * _sgn(m) * abs(m) ** 1.5
            T += h
        else:
            for j in range(3):
                rj = IWAN_R[j]
                sj = sn[j] + (d0 - dn)
                if sj > rj:
                    sj = rj
                elif sj < -rj:
                    sj = -rj
                T += (H / 3.0) / rj * sj
    # friction levels
    c = p[P_FC]
    fv = p[P_FV]
    th = y[Y_TG]
    if ef[E_TEMPF] >= 0:
        s = es[E_TEMPF]
        dth = THETA_REF - th
        if ef[E_TEMPF] == 0:
            fv *= max(0.05, 1.0 + s * (math.exp(0.03 * dth) - 1.0))
        elif ef[E_TEMPF] == 1:
            c = max(0.05 * c, c + 30.0 * s * dth)
        else:
            m = max(0.05, 1.0 + s * (0.012 * dth + 1.5e-4 * dth * dth))
            c *= m
            fv *= m
    if ef[E_LOADF] >= 0:
        s = es[E_LOADF]
        if ef[E_LOADF] == 0:
            c += 0.01 * s * abs(T)
        elif ef[E_LOADF] == 1:
            m = 1.0 + 0.4 * s * abs(T) / T_RATED
            c *= m
            fv *= m
        else:
            c += s * abs(T) * (0.014 if T * qd > 0.0 else 0.005)
    bias = 0.0
    if ef[E_ASYM] >= 0:
        s = es[E_ASYM]
        sg = _sgn(qd)
        if ef[E_ASYM] == 0:
            c *= max(0.05, 1.0 + 0.15 * s * sg)
        elif ef[E_ASYM] == 1:
            c *= max(0.05, 1.0 + 0.08 * s * sg)
            fv *= max(0.05, 1.0 + 0.4 * s * sg)
        else:
            bias = 0.12 * s * p[P_FC]
    sm = 1.0
    if ef[E_STRIB] >= 0:
        xv = abs(qd) / STRIB_VS
        if ef[E_STRIB] == 0:
            ph = math.exp(-xv)
        elif ef[E_STRIB] == 1:
            ph = math.exp(-xv * xv)
        else:
            ph = 1.0 / (1.0 + xv * xv)
        sm = 1.0 + STRIB_DS * es[E_STRIB] * ph
    clim = c * sm
    F = fv * qd + bias
    for i in range(2):
        L = MAXWELL_ALPHA[i] * clim
        kap = MAXWELL_ALPHA[i] * p[P_FC] / MAXWELL_BREAK[i]
        if zn[2 + i] > 0.5 and zn[i] * qd > 0.0:
            z = L if zn[i] > 0.0 else -L          # a sliding element follows its limit
        else:
            z = zn[i] + kap * (q - qn)
            if z >= L:
                z = L
            elif z <= -L:
                z = -L
            else:
                F += MAXWELL_DAMP * qd            # presliding dashpot of a stuck element
        F += z
    G = G_ACC * (p[P_MRX] * math.sin(q) + p[P_MRY] * math.cos(q))
    dist = 0.0
    if ef[E_RIPPLE] == 0:
        dist += 300.0 * es[E_RIPPLE] * math.sin(96.0 * q + 0.7)
    elif ef[E_RIPPLE] == 1:
        dist += 250.0 * es[E_RIPPLE] * (math.sin(61.0 * q + 0.3) + 0.5 * math.sin(122.0 * q + 1.9))
    if ef[E_PERIODIC] == 0:
        dist += 400.0 * es[E_PERIODIC] * 2.0 / math.pi * math.atan(
            6.0 * math.sin(2.0 * math.pi * 1.3 * t))
    elif ef[E_PERIODIC] == 1:
        dist += 300.0 * es[E_PERIODIC] * (math.sin(2.0 * math.pi * 4.7 * t)
                                           + 0.6 * math.sin(2.0 * math.pi * 9.4 * t + 1.0))
    tl = y[Y_TS]
    dy[Y_Y2] = 0.0
    dy[Y_Y2D] = 0.0
    if ef[E_RES2] == 0:
        I2 = 0.15 * es[E_RES2] * p[P_I]
        w2 = 2.0 * math.pi * 11.0
        tm2 = I2 * w2 * w2 * (y[Y_Y2] - q) + 2.0 * 0.02 * I2 * w2 * (y[Y_Y2D] - qd)
        dist += tm2
        dy[Y_Y2] = y[Y_Y2D]
        dy[Y_Y2D] = -tm2 / I2
    elif ef[E_RES2] == 1:
        I2 = 0.3 * es[E_RES2] * p[P_I]
        w2 = 2.0 * math.pi * 8.0
        tl = I2 * w2 * w2 * (q - y[Y_Y2]) + 2.0 * 0.03 * I2 * w2 * (qd - y[Y_Y2D])
        dy[Y_Y2] = y[Y_Y2D]
        dy[Y_Y2D] = (tl - y[Y_TS]) / I2
    qdd = (T - tl - G - F + dist) / p[P_I]
    # motor servo
    J = p[P_J]
    udc = udr + 8.0 * (ur - u)
    err = udc - ud
    tm = J * (60.0 * err + y[Y_WI] + uddr)
    if tm > 2.5e5:
        tm = 2.5e5
    elif tm < -2.5e5:
        tm = -2.5e5
    Fm = p[P_FMC] * ud / math.sqrt(ud * ud + 1e-6) + p[P_FMV] * ud
    udd = (tm - T - Fm) / J
    dy[Y_Q] = qd
    dy[Y_QD] = qdd
    dy[Y_U] = ud
    dy[Y_UD] = udd
    dy[Y_WI] = 600.0 * err
    amb = p[P_AMB]
    dy[Y_TG] = (abs(F * qd) + abs(Fm * ud) - (th - amb) / 0.05) / 2e4
    i1 = p[P_W1] * tm / (N * p[P_KT1])
    i2 = p[P_W2] * tm / (N * p[P_KT2])
    i3 = p[P_W3] * tm / (N * p[P_KT3])
    dy[Y_TM1] = (0.8 * i1 * i1 - (y[Y_TM1] - amb) / 0.5) / 800.0
    dy[Y_TM2] = (0.8 * i2 * i2 - (y[Y_TM2] - amb) / 0.5) / 800.0
    dy[Y_TM3] = (0.8 * i3 * i3 - (y[Y_TM3] - amb) / 0.5) / 800.0
    aux[A_T] = T
    aux[A_TL] = tl
    aux[A_F] = F
    aux[A_G] = G
    aux[A_X] = dist
    aux[A_TM] = tm
    aux[A_TCMD] = tc
    aux[A_QDD] = qdd
    aux[A_UDD] = udd
    aux[A_I1] = i1
    aux[A_I2] = i2
    aux[A_I3] = i3
    aux[A_CLIM] = clim
    aux[A_DEL] = d0


@numba.njit(cache=True)
def _integrate(y0, z0, p, ef, es, dnoise, fa, fb, nrec):
    """Heun steps of H_STEP; a record (state + auxiliaries) every REC_EVERY steps."""
    rec = np.empty((nrec, N_REC))
    y = y0.copy()
    z = z0.copy()
    sst = np.zeros(3)
    k1 = np.empty(N_Y)
    k2 = np.empty(N_Y)
    ys = np.empty(N_Y)
    aux = np.empty(N_A)
    n = 0
    nsteps = (nrec - 1) * REC_EVERY
    for n in range(nsteps + 1):
        t = n * H_STEP
        qn = y[Y_Q]
        dn = y[Y_U] - y[Y_Q]
        _rhs(t, y, z, qn, sst, dn, p, ef, es, dnoise, fa, fb, k1, aux)
        if n % REC_EVERY == 0:
            r = n // REC_EVERY
            for i in range(N_Y):
                rec[r, i] = y[i]
            for i in range(N_A):
                rec[r, N_Y + i] = aux[i]
        if n == nsteps:
            break
        for i in range(N_Y):
            ys[i] = y[i] + H_STEP * k1[i]
        _rhs(t + H_STEP, ys, z, qn, sst, dn, p, ef, es, dnoise, fa, fb, k2, aux)
        for i in range(N_Y):
            y[i] += 0.5 * H_STEP * (k1[i] + k2[i])
        # discrete elasto-plastic states: Maxwell-slip friction and Iwan stops
        clim = aux[A_CLIM]
        for i in range(2):
            L = MAXWELL_ALPHA[i] * clim
            kap = MAXWELL_ALPHA[i] * p[P_FC] / MAXWELL_BREAK[i]
            if z[2 + i] > 0.5 and z[i] * y[Y_QD] > 0.0:
                zi = L if z[i] > 0.0 else -L
            else:
                zi = z[i] + kap * (y[Y_Q] - qn)
            if zi >= L or zi <= -L:
                z[2 + i] = 1.0
                zi = min(L, max(-L, zi))
            else:
                z[2 + i] = 0.0
            z[i] = zi
        dnew = y[Y_U] - y[Y_Q]
        for j in range(3):
            sj = sst[j] + (dnew - dn)
            sst[j] = min(IWAN_R[j], max(-IWAN_R[j], sj))
    return rec


# --- machine and noise draws ----------------------------------------------------------------------

_SALT = 0xAC5EED


def draw_machine(seed: int) -> dict[str, float]:
    """The campaign's machine (data sheet section 1)."""
    rng = np.random.default_rng([_SALT, int(seed)])
    m = {}
    for name, (v, sd) in _NOMINAL.items():
        m[name] = float(v * (1.0 + sd * float(np.clip(rng.standard_normal(), -2.0, 2.0))))
    wsum = m["w1"] + m["w2"] + m["w3"]
    for w in ("w1", "w2", "w3"):
        m[w] /= wsum
    dr, ds, rho = m["twist_rated_rad"], m["twist_soft_rad"], m["soft_ratio"]
    xr = dr / ds
    # K(Δr) = k2·Δr − k2·(1 − ρ)·Δs·xr/√(1 + xr²) = T_RATED
    m["k2"] = T_RATED / (dr - (1.0 - rho) * ds * xr / math.sqrt(1.0 + xr * xr))
    m["k1"] = rho * m["k2"]
    return m


def compliance_torque(twist: np.ndarray, params: dict) -> np.ndarray:
    """K(Δ) of the data sheet (nominal machine, no effects)."""
    d = np.asarray(twist, dtype=float)
    xi = d / params["twist_soft_rad"]
    return params["k2"] * d - (params["k2"] - params["k1"]) * params["twist_soft_rad"] \
        * xi / np.sqrt(1.0 + xi * xi)


def _ou(rng: np.random.Generator, n: int, sd: float, tc: float, dt: float) -> np.ndarray:
    a = math.exp(-dt / tc)
    e = rng.standard_normal(n) * sd * math.sqrt(1.0 - a * a)
    out = np.empty(n)
    x = sd * rng.standard_normal()
    for i in range(n):
        out[i] = x
        x = a * x + e[i]
    return out


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0.0 else step * np.round(x / step)


def _lowpass_exact(x: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """First-order low-pass of a piecewise-linear signal, exact at the grid points."""
    if tau <= 0.0:
        return x.copy()
    a = math.exp(-dt / tau)
    b = 1.0 - tau / dt * (1.0 - a)
    return _lp_loop(x, a, b)


@numba.njit(cache=True)
def _lp_loop(x, a, b):
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, x.shape[0]):
        y[k] = a * y[k - 1] + (1.0 - a) * x[k - 1] + b * (x[k] - x[k - 1])
    return y


def _travel(scheme: int, rpm: float, periods: int) -> float:
    w = rpm * 2.0 * math.pi / 60.0 / REDUCTION
    return w * (run_duration(scheme, periods) - 0.5 * (START_T0 + START_T1))


# --- the run ------------------------------------------------------------------------------------

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """One bench run of rig AC (see the module data sheet)."""
    _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, sensors, periods, seed, run)
    eff = _check_effects(effects)
    scheme, periods, seed, run = int(scheme), int(periods), int(seed), int(run)
    dirn = float(direction)
    amb = float(temp_joint_c)
    rpm = None if scheme == 3 else float(motor_speed_rpm)
    if scheme != 3:
        travel = _travel(scheme, rpm, periods)
        if travel > TRAVEL_LIMIT:
            raise ValueError(f"periods={periods} would carry the joint {travel:.2f} rad (beyond "
                             f"±{TRAVEL_LIMIT:.2f} rad, the ±180° travel) in scheme {scheme} at "
                             f"{rpm:g} r/min; use fewer periods")
    sens = sensors if sensors is not None else SensorSpec()
    fs = sens.sample_rate_hz
    m = draw_machine(seed)
    rng = np.random.default_rng([_SALT, seed, run, 1])
    duration = run_duration(scheme, periods)

    ef = np.full(13, -1, dtype=np.int64)
    es = np.zeros(13)
    for name, (form, s) in eff.items():
        i = _FAMILY[name]
        ef[i] = EFFECT_FORMS[name].index(form)
        es[i] = s

    p = np.zeros(N_P)
    p[P_I], p[P_MRX], p[P_MRY] = m["I"], m["mr_x"], m["mr_y"]
    p[P_FC], p[P_FV], p[P_K1], p[P_K2] = m["f_c"], m["f_v"], m["k1"], m["k2"]
    p[P_DS], p[P_D], p[P_J], p[P_FMC], p[P_FMV] = (m["twist_soft_rad"], m["D"], m["J"], m["F_mc"],
                                                   m["f_mv"])
    p[P_DG], p[P_DT] = m["dyn_gain"], m["dyn_tc"]
    p[P_KT1], p[P_KT2], p[P_KT3] = m["kt1"], m["kt2"], m["kt3"]
    p[P_W1], p[P_W2], p[P_W3] = m["w1"], m["w2"], m["w3"]
    p[P_SCHEME], p[P_DIR] = scheme, dirn
    p[P_OMEGA] = 0.0 if rpm is None else rpm * 2.0 * math.pi / 60.0 / REDUCTION
    p[P_PERIODS], p[P_AMB], p[P_U0] = periods, amb, 0.0

    nrec = int(math.ceil(duration / REC_DT)) + 1
    dnoise = _ou(rng, int(duration / NOISE_DT) + 3, 150.0, 0.3, NOISE_DT)
    y0 = np.zeros(N_Y)
    y0[Y_TG] = amb
    y0[Y_TM1:Y_TM3 + 1] = amb + 1.5
    G0 = G_ACC * m["mr_y"]
    hold = float(np.clip(-G0, -m["f_c"], m["f_c"]))
    z0 = np.array([MAXWELL_ALPHA[0] * hold, MAXWELL_ALPHA[1] * hold, 0.0, 0.0])  # + slip flags
    rec = _integrate(y0, z0, p, ef, es, dnoise, FOURIER_A, FOURIER_B, nrec)
    tr = np.arange(nrec) * REC_DT

    n = int(math.floor(duration * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    t = t[t <= tr[-1]]
    n = len(t)

    def at(col: int, lag: float = 0.0) -> np.ndarray:
        return np.interp(t - lag, tr, rec[:, col])

    # --- truth
    truth = pd.DataFrame({
        "t": t, "q": at(Y_Q), "qd": at(Y_QD), "qdd": at(N_Y + A_QDD), "u": at(Y_U),
        "ud": at(Y_UD), "twist": at(Y_U) - at(Y_Q), "twist_rate": at(Y_UD) - at(Y_QD),
        "torque": at(N_Y + A_T), "torque_load": at(N_Y + A_TL), "torque_cmd": at(N_Y + A_TCMD),
        "friction": at(N_Y + A_F), "gravity": at(N_Y + A_G), "disturbance": at(N_Y + A_X),
        "motor_torque": at(N_Y + A_TM), "temp_joint": at(Y_TG),
    })

    # --- readings
    def form(name: str) -> str | None:
        return eff[name][0] if name in eff else None

    def scale(name: str) -> float:
        return eff[name][1] if name in eff else 0.0

    q_lag = DELAY_S * scale("time_delay") if form("time_delay") == "q_encoder_latency" else 0.0
    t_lag = DELAY_S * scale("time_delay") if form("time_delay") == "torque_latency" else 0.0
    q_true = at(Y_Q, q_lag)
    if form("encoder_drift") == "q_linear":
        q_true = q_true + 6e-6 * scale("encoder_drift") * t
    u_true = at(Y_U)
    if form("encoder_drift") == "u_saturating":
        u_true = u_true + 3e-4 * scale("encoder_drift") * (1.0 - np.exp(-t / 15.0))
    q_res = math.radians(sens.encoder_res_deg)
    q_meas = _quant(q_true, q_res)
    u_meas = _quant(u_true, sens.motor_encoder_res)
    qd_meas = at(Y_QD, q_lag) + sens.qd_noise * rng.standard_normal(n)
    ud_true = at(Y_UD)
    ud_meas = ud_true + sens.ud_noise * rng.standard_normal(n)

    tf = _lowpass_exact(rec[:, N_Y + A_T], REC_DT, sens.torque_filter_s)
    torque = np.interp(t - sens.torque_lag_s - t_lag, tr, tf)
    torque = torque + sens.torque_noise * rng.standard_normal(n)
    off = form("torque_offset")
    if off == "constant_bias":
        torque = torque + 400.0 * scale("torque_offset")
    elif off == "linear_drift":
        torque = torque + 8.0 * scale("torque_offset") * t
    elif off == "saturating_creep":
        torque = torque + 600.0 * scale("torque_offset") * (1.0 - np.exp(-t / 20.0))
    torque = _quant(torque, sens.torque_res)
    tload = _quant(at(N_Y + A_TL) + sens.load_noise * rng.standard_normal(n), sens.load_res)

    cols: dict[str, Any] = {"t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
                            "torsion": q_meas - u_meas, "torque": torque, "torque_load": tload,
                            "torque_cmd": at(N_Y + A_TCMD)}
    for k in (1, 2, 3):
        cols[f"i_m{k}"] = at(N_Y + A_I1 + k - 1) + sens.current_noise * rng.standard_normal(n)
    for k in (1, 2, 3):
        cols[f"w_m{k}"] = REDUCTION * (ud_true + sens.ud_noise * rng.standard_normal(n))
    for k in (1, 2, 3):
        cols[f"temp_m{k}"] = _quant(at(Y_TM1 + k - 1) + sens.temp_noise * rng.standard_normal(n),
                                    sens.temp_res)
    cols["temp_joint"] = _quant(at(Y_TG) + sens.temp_noise * rng.standard_normal(n), sens.temp_res)
    codes = _phase_codes(t, scheme, periods)
    cols["phase"] = np.array([PHASES[c] for c in codes], dtype=object)
    samples = pd.DataFrame(cols)

    meta = {
        "scheme": scheme,
        "motor_speed_rpm": rpm,
        "direction": int(dirn),
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": "2026-01-05T09:00:00Z",
        "notes": (f"{RIG_NAME} validation simulator, scheme {scheme}, {periods} period(s), "
                  f"joint at {amb:g} °C"),
        "sensors": {
            "q": {"resolution": q_res, "noise_sd": 0.0, "lag_s": 0.0},
            "qd": {"noise_sd": sens.qd_noise, "lag_s": 0.0},
            "u": {"resolution": sens.motor_encoder_res, "noise_sd": 0.0, "lag_s": 0.0},
            "ud": {"noise_sd": sens.ud_noise, "lag_s": 0.0},
            "torque": {"resolution": sens.torque_res, "noise_sd": sens.torque_noise,
                       "lag_s": sens.torque_filter_s + sens.torque_lag_s},
            "torque_load": {"resolution": sens.load_res, "noise_sd": sens.load_noise,
                            "lag_s": 0.0},
            **{f"i_m{k}": {"noise_sd": sens.current_noise} for k in (1, 2, 3)},
            **{f"temp_m{k}": {"resolution": sens.temp_res, "noise_sd": sens.temp_noise}
               for k in (1, 2, 3)},
            "temp_joint": {"resolution": sens.temp_res, "noise_sd": sens.temp_noise},
        },
    }
    params = dict(m)
    params.update({"effects": {k: {"form": f, "scale": s} for k, (f, s) in eff.items()},
                   "duration_s": duration, "seed": seed, "run": run})
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
