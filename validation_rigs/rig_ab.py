"""Rig AB — an independent validation simulator of the CMOR J4 joint test bench.

Written from the paper (shared/seeds/cmor-sghmc-paper.txt), shared/docs/*.md and the run format
(core/channels.py, core/runfile.py) only. It shares no code and no functional forms with
`simulators/` or the other validation rigs: its friction law, compliance curve, integrator,
controller, dynamometer, thermal model, transducer model and every effect law are its own.
SI units throughout (angles rad, torques N·m, times s, powers W) except temperatures (°C).
"Referred" means referred to the joint output through the reduction N = 11000.

DATA SHEET
==========

1. Machine (nominal values)
---------------------------
Each campaign `seed` draws its own machine: every value marked (x %) is multiplied by
(1 + x/100·ε), ε ~ N(0, 1) clipped to ±2.5; values marked (abs σ) get an additive N(0, σ²)
clipped to ±2.5 σ. RigRun.params lists the drawn values.

Output side (paper Eq. 4 with the dynamometer, rig.md sign convention)

    I·q̈ = T − τ_L − G(q) − F(q̇) + τ_d + τ_c
    G(q) = g·(mr_x·sin q + mr_y·cos q),   g = 9.81 m/s²

  I = 6685.166 kg·m² (1.5 %), mr_x = 20.779 kg·m (5 %), mr_y = −34.543 kg·m (5 %).
  T the transmitted torque, τ_L the dynamometer torque (positive = the paper's positive loading),
  τ_d the disturbance torques of effects, τ_c the coupling torque of an effect's auxiliary
  inertia (both zero on the nominal machine).

Output friction — a static, tanh-regularised Coulomb + viscous law (no internal state):

    F(v) = [f_c + ΔF_S·S(|v|/v_s)]·tanh(v/v_c) + f_v·v

  f_c = 2352.660 N·m (2.5 %), f_v = 8683.272 N·m·s/rad (4 %), v_c = 1.5e-4 rad/s (fixed:
  5.3 % of the 300 r/min output speed; below ~2·v_c friction is *less* than Coulomb, the
  opposite of a Stribeck rise). ΔF_S = 0 on the nominal machine (see stribeck). The nominal
  friction does not depend on temperature, load or direction. Numerical guard: when effects push
  the Coulomb level c = f_c + ΔF_S above 1.2·I·v_c/h (≈ 6 kN·m at h = 2e-4 s), v_c is widened to
  c·h/(1.2·I) so that the explicit integrator stays stable (reached only at effect scales ≳ 3,
  e.g. quadratic_power_flow back-driven at rated load with s > 3, stribeck with s > 5).

Flexible transmission (Eq. 5 with N = 11000; own compliance law: a fractional-power hardening
curve with stiffness-proportional structural damping). Twist Δ = u − q (the paper's torsion is
q − u = −Δ):

    T = K(Δ) + D(Δ)·Δ̇ (+ T_h, effects)
    K(Δ) = k0·Δ·(1 + a·|Δ/Δ_r|^p),            tangent k(Δ) = k0·(1 + a·(1 + p)·|Δ/Δ_r|^p)
    D(Δ) = β_s·k(Δ)

  Δ_r = 0.45° = 7.854e-3 rad (4 %), a = 0.8 (10 %), p = 1.5 (fixed, not an integer),
  k0 = 120 kN·m / (Δ_r·(1 + a)) ≈ 8.49e6 N·m/rad, so K(Δ_r) = 120 kN·m exactly (rated torque at
  the rated twist); tangent stiffness 8.49e6 at zero load, 3·k0 ≈ 2.55e7 at rated.
  β_s = 0.015 s (10 %): D ≈ 1.27e5 N·m·s/rad at zero load (damping ratio ≈ 0.27 of the
  ≈ 5.7 Hz output mode), ≈ 3.8e5 at rated (≈ 9.8 Hz, ratio ≈ 0.46). No hysteresis, no backlash,
  no kinematic error on the nominal machine. With effects (section 4) the spring sees the engaged
  twist Δ_e = B(Δ − e) (e a kinematic error, B a dead zone), the damper the engaged twist rate
  Δ̇_e = B'(Δ − e)·Δ̇ (a kinematic error is geometric: it loads the spring, not the damper), and
  both are scaled by f(q): T = f(q)·[K(Δ_e) + β_s·k(Δ_e)·Δ̇_e] + T_h.

Motor side — three servo motors on one shaft, referred to the output (Σ k_t·i·N = τ_m):

    J_eq·ü = τ_m − T − F_m(u̇),    F_m(w) = F_mc·(2/π)·atan(w/v_m) + f_mv·w

  J_eq = 3·0.0035 kg·m²·N² ≈ 1.2705e6 kg·m² (3 %), F_mc = 3·0.20 N·m·N = 6600 N·m (5 %),
  f_mv = 3·1.5e-4 N·m·s/rad·N² = 5.445e4 N·m·s/rad (5 %), v_m = 5e-5 rad/s.
  k_t,k = 1.32 N·m/A (2 % each; an effective constant including the gear efficiency, so the
  currents carry no load-dependent loss). Torque sharing: motor k takes the share s_k of τ_m,
  s_k ∝ 1 + 0.015·ε_k (normalised to Σ s_k = 1), i_k = s_k·τ_m/(N·k_t,k) + offset_k,
  offset_k ~ N(0, (0.008 A)²) per campaign. Winding resistance R_k = 0.95 Ω (3 %) at 20 °C,
  copper coefficient 0.00393 1/K.
Controller (own): one position loop on the motor encoder, PID with acceleration feed-forward,

    τ_m = sat(K_p·e + K_d·ė + K_i·∫e + J_nom·ü_ref),  e = u_ref − u,

  gains from a triple closed-loop pole at ω_c = 40 rad/s on the nominal J_nom = 1.2705e6:
  K_d = 3·J_nom·ω_c, K_p = 3·J_nom·ω_c², K_i = J_nom·ω_c³; |τ_m| ≤ 3·24 N·m·N = 792 kN·m. The
  current loop is ideal (τ_m is the commanded torque).

Dynamometer (load): a torque-controlled servo with a second-order response,

    τ̈_L = ω_d²·(γ_d·τ_cmd + b_d + n_d(t) − τ_L) − 2·ζ_d·ω_d·τ̇_L

  ω_d = 2π·12 rad/s, ζ_d = 0.8, gain γ_d = 1 (0.3 %), bias b_d (abs 150 N·m, per campaign),
  n_d(t): band-limited torque noise of the servo, white noise through two first-order stages
  (time constant 8 ms each) on a 2 ms grid (linear in between), SD 30 N·m, drawn per (seed, run).
  |b_d| ≤ 375 N·m and the transient error stay inside Table 11's ±2 kN·m. The dynamometer rotor's
  inertia belongs to I.

Thermal (own): a two-node gearbox — oil θ_o (the temp_joint reading) and housing θ_h — and one
node per motor (winding + stator):

    C_o·θ̇_o = P − (θ_o − θ_h)/R_oh,     C_h·θ̇_h = (θ_o − θ_h)/R_oh − (θ_h − θ_a)/R_ha
    C_w·θ̇_k = R_k(θ_k)·i_k² − (θ_k − θ_a)/R_w,     P = |F·q̇| + |F_m·u̇| + |D·Δ̇_e·Δ̇_e|

  C_o = 9.0e4 J/K, C_h = 4.0e5 J/K, R_oh = 0.02 K/W, R_ha = 0.04 K/W, C_w = 6000 J/K,
  R_w = 0.35 K/W, ambient θ_a = 22 °C (abs 1.5 K). All nodes start at `temp_joint_c`.

Integrator (own): classical explicit 4th-order Runge–Kutta on a fixed substep h = 1/(fs·m),
  m = ceil(1/(fs·2e-4)) (h ≤ 2e-4 s; every sample instant is a substep boundary), on the whole
  state (output, motor, PID integral, dynamometer, hysteresis, thermal, auxiliary inertias). The
  torque transducer filter is advanced after each step by the trapezoidal (bilinear) rule.
  Readings at instants off the substep grid (lags) are linear interpolations between substeps.
  Start: at rest at q = 0, the motor angle solved (bisection) so that the output is in
  equilibrium with gravity and the dynamometer's initial torque, the PID integral holding it.

2. Schemes (section II-B) and phases (core.channels.PHASES)
----------------------------------------------------------
Motor speed Ω = rpm·2π/60/N at the output (300 r/min → 2.856e-3 rad/s, 3000 → 2.856e-2).
Schemes 1 and 2: the motors start at t = 0.5 s with a quintic (smoothstep) speed ramp of 1.2 s
  to Ω·direction and keep that speed to the end of the run. The dynamometer loads positively
  (τ_cmd ≥ 0) whatever the direction: direction +1 drives against the load, −1 is back-driven.
  1: idle 0–2.5 s, then `periods` × [load: τ_cmd = 60 kN·m·(1 − cos(π·x/10 s)), 10 s;
     unload: mirror, 10 s], idle 1 s. While the load rises the twist grows at up to
     ≈ 2.2e-3 rad/s, so at 300 r/min the output speed dips to ≈ 0.5·Ω (and rises while
     unloading): q̇ = u̇ − Δ̇.
  2: idle 0–2.5 s, then `periods` × [12 × (load: +10 kN·m with a cubic smoothstep over 0.3 s;
     hold 2 s), unload: 120 kN·m → 0 by a half cosine in 3 s], idle 1 s.
  A `periods` that would carry the joint past ±(π − 0.1) rad is refused (ValueError): at
  3000 r/min scheme 1 allows at most 5 periods, scheme 2 at most 3.
3 (motor_speed_rpm None): idle 1.5 s at rest; excite: `periods` × Eq. 12, fifth order, base
  period 24 s (ω_f = 2π/24 s), times `direction`, τ_cmd = 0 ("transparent" dynamometer);
  idle 1.5 s. Coefficients (rad/s), optimised here for the smallest condition number (≈ 2.10)
  of the column-normalised Eq. 4 observation matrix [q̈, g·sin q, g·cos q, q̇, sgn q̇] under
  |q̇| ≤ 0.0272 rad/s: a = (−0.0045843, −0.0047006, 0.0029539, 0.0055513, a5),
  b = (−0.0023227, 0.0042895, 0.0054060, −0.0013715, b5), a5 = −Σa_1..4, b5 = −Σ l·b_l/5
  (so q̇ = q̈ = 0 at each period's start), q_0 such that q(0) = 0. |q| ≤ 0.050 rad,
  |q̇| ≤ 0.0226 rad/s. The motor follows u_ref = u_0 + direction·q_F(t) (no twist compensation).

3. Sensors (SensorSpec; meta["sensors"] states resolution / noise_sd / lag_s per channel)
---------------------------------------------------------------------------------------
q: output encoder, mid-tread quantisation at `encoder_res_deg` (0.01°), no noise.
qd: true q̇ + white noise `qd_noise`. u: motor encoder referred, quantised at
`motor_encoder_res`; ud: true u̇ + `ud_noise`; w_m1..3: N·u̇ + white noise N·`ud_noise`.
torsion: q − u of the readings (paper Eq. 6 sign).
torque: strain-gauge transducer on T: a critically damped second-order amplifier (two equal
  first-order stages of `torque_filter_s`/2 each: group delay `torque_filter_s`), then a pure lag
  `torque_lag_s`, white noise `torque_noise`, ADC step `torque_res`. Stated lag_s =
  torque_filter_s + torque_lag_s.
torque_load: τ_L + white noise `load_noise`, step `load_res`. torque_cmd: the set point, exact.
i_m1..3: i_k + white noise `current_noise`. temp_joint (oil θ_o), temp_m1..3 (θ_k): + white
  noise `temp_noise`, step `temp_res`. All channels at `sample_rate_hz`, t_k = k/fs.

4. Effects (`effects` = {name: {"form": f, "scale": s}}, 0 ≤ s ≤ SCALE_MAX = 10, larger
   scales are refused; s = 0 is exactly no effect; "scale" defaults to 1 when omitted)
-------------------------------------------------------------------------------------
s = 1 is a typical real size (≈ 2–3× the 120 N·m torque noise where it shows in torque).
φ1, φ2, φ3 are phases, σ = ±1 a sign, drawn per campaign (seed) and effect family. v = q̇,
T_r = 120 kN·m, |T_s| = |K(Δ_e)·f(q) + T_h| the static transmitted torque, θ_o the oil
temperature along the run. The friction modifications apply in the order asymmetric →
temperature → load → Stribeck.
stribeck — ΔF_S = 0.30·f_c·s (Fs/Fc = 1.3 at s = 1), v_s = 1.6e-3 rad/s (5.6 % of top speed);
  exponential_d1 S = exp(−x); gaussian_d2 S = exp(−x²); lorentzian S = 1/(1 + x²);
  power_d06 S = exp(−x^0.6). At 300 r/min the output slows to ≈ 0.5·Ω while the load rises
  (x ≈ 0.9), where the falling branch can out-weigh the structural damping: a self-excited
  oscillation of the output (stick–slip) appears from s ≈ 1 for gaussian_d2, s ≈ 1.5 for
  exponential_d1 and lorentzian, s ≈ 3 for power_d06.
load_dependent_friction —
  coulomb_linear: f_c += 0.006·s·|T_s| (+720 N·m at T_r);
  coulomb_viscous_scaled: f_c ×= 1 + 0.25·s·|T_s|/T_r, f_v ×= 1 + 0.6·s·|T_s|/T_r;
  quadratic_power_flow: f_c += c·s·T_r·(T_s/T_r)², c = 0.005 while the motors drive the output
    (T·v > 0) and 0.010 when back-driven, blended by (1 ± tanh(T·v/10 W))/2.
temperature_friction (θ_ref = 30 °C) —
  viscous_arrhenius: f_v ×= exp(clip(s·2600 K·(1/(θ_o + 273.15) − 1/303.15), −3, 3))
    (×1.56 at 15 °C, ×0.46 at 60 °C);
  coulomb_additive: f_c += 28 N·m/K·s·(30 − θ_o), floored at 0.2·f_c (+420 N·m at 15 °C);
  vogel_mixed: m = exp(clip(s·320 K·(1/(θ_o + 95) − 1/125), −3, 3)), f_v ×= m, f_c ×= m^0.35
    (at 15 °C: f_v ×1.42, f_c ×1.13; at 60 °C: f_v ×0.61, f_c ×0.84).
gear_ripple (Z = 73 mesh cycles per output revolution; Z_i = 6200 cycles per output revolution
  for the intermediate shaft of the precision reducer) —
  output_mesh_torque: a mesh torque R(q) = A·[sin(Z·q + φ1) + 0.5·sin(2Z·q + φ2) +
    0.25·sin(3Z·q + φ3)], A = 320·s N·m, resists the output (τ_d −= R): T gains ≈ +R(q);
  intermediate_stage_error: kinematic error on the motor angle, e = E·[sin(Z_i·u + φ1) +
    0.4·sin(2Z_i·u + φ2)], E = 200·s/k0 rad, the spring sees Δ − e (≈ 28 Hz at 3000 r/min,
    above the output mode: the output cannot follow and T ripples by ≈ k(Δ)·e, 200–600 N·m);
  load_scaled_mesh_error: kinematic error on the output angle, e = E(T)·sin(Z·q + φ1),
    E(T) = (320·s/k0)·(0.2 + 0.8·min(|K(Δ)·f(q)|/T_r, 1.5)): the ripple grows with load. At
    the output's slow mesh frequencies the output follows e, so it shows in the twist–torque law
    (torque at a given encoder twist off by ≈ −k(Δ)·e), hardly in the torque itself.
torque_offset (torque reading only) — bias: B = 350·s·σ; linear_creep: B = 5·s·σ·t N·m;
  sqrt_creep: B = 55·s·σ·√(t/1 s) N·m.
time_delay (readings only, a pure delay d = 0.010·s s) — torque_fieldbus: the torque reading;
  q_encoder_latency: q and qd; u_encoder_latency: u, ud and w_m1..3.
hysteresis (hysteretic torque T_h added to T, driven by the engaged twist Δ_e; H = 500·s N·m,
  x_m = 1.5e-4 rad, state starts at 0) —
  bouc_wen_n1: T_h = H·x/x_m, ẋ = Δ̇_e − (0.7·|Δ̇_e|·x + 0.3·Δ̇_e·|x|)/x_m (saturates at ±x_m);
  dahl_first_order: T_h = H·x/x_m, ẋ = 2·Δ̇_e·(1 − sgn(Δ̇_e)·x/x_m) (exponential approach);
  windup_loss: T_h = 2H·√min(|Δ_e|/Δ_r, 2)·z, ż = Δ̇_e·(1 − sgn(Δ̇_e)·z)/1e-4 rad: a loss
    loop whose width grows with the wind-up (±2H at the rated twist, ±0.4H at 4 % of it).
  Loading and unloading branches differ by ≈ 2H (windup_loss: by its local width) in torque.
backlash (dead zone on Δ − e, half-width b = 1.5e-4·s rad; the damper acts on Δ̇_e) —
  sharp: Δ_e = sgn(Δ)·max(|Δ| − b, 0);
  hyperbolic: Δ_e = sgn(Δ)·[(|Δ| − b + √((|Δ| − b)² + ε²))/2 − c_0], ε = 0.35·b,
    c_0 = (√(b² + ε²) − b)/2 (a smooth gap; far from it Δ_e = Δ ∓ (b + c_0));
  load_closing: the sharp law with a gap that closes under the dynamometer's preload,
    b(τ_L) = b·exp(−|τ_L|/30 kN·m) (b at no load, 2 % of it at rated): the twist offset at a
    given torque shrinks as the load grows.
asymmetric_friction (w₊ = (1 + tanh(v/v_c))/2, the weight of positive motion) —
  coulomb_split: f_c ×= 1 + 0.11·s·(2w₊ − 1) (floored at 0.1);
  coulomb_viscous_split: f_c ×= 1 + 0.07·s·(2w₊ − 1), f_v ×= 1 + 0.3·s·(2w₊ − 1);
  viscous_split: f_v ×= 1 + 0.6·s·(2w₊ − 1) (factors floored at 0.1).
Out of vocabulary:
periodic_disturbance — fan_sine: τ_d += A·[sin(2π·3.1 Hz·t + φ1) + 0.3·sin(2π·6.2 Hz·t + φ2)];
  pump_rectified: τ_d += A·(π/2)·(|sin(2π·0.9 Hz·t + φ1)| − 2/π) (lines at 1.8 Hz and
  harmonics); A = 320·s N·m, both unmeasured torques on the output;
  gauge_pickup: the torque reading gains 300·s·sin(2π·16.7 Hz·t + φ1) (electrical pick-up).
position_dependent_stiffness (the spring and its damper scaled by f(q)) —
  soft_zone: f = max(0.1, 1 − 0.1·s·exp(−((q − q_c)/0.04 rad)²)), q_c ~ U(−0.03, 0.03) rad
    per campaign; exp_gradient: f = exp(clip(0.15·s·q, −2, 2));
  thrice_per_rev: f = max(0.1, 1 + 0.06·s·sin(3q + φ1)).
encoder_drift (readings only) — q_linear: q += 2.5e-6·s·σ·t rad/s; q_exponential:
  q += 2.5e-4·s·σ·(1 − exp(−t/30 s)) rad; u_linear: u += 2.5e-6·s·σ·t.
second_resonance —
  bearing_mode: an auxiliary inertia I_2 = 0.3·s·I hung on the output by a spring
    k_2 = I_2·(2π·8 Hz)², damping ratio 0.02 (τ_c = k_2·(q_2 − q) + c_2·(q̇_2 − q̇)): the
    output mode splits in two around 8 Hz;
  motor_shaft: the motor-side inertia splits into the rotors J_r = (1 − ρ)·J_eq (the encoder's)
    and the reducer input J_g = ρ·J_eq, ρ = min(0.3·s, 0.9), joined by a shaft tuned to 10 Hz
    (k_2 = J_r·J_g/J_eq·(2π·10 Hz)², damping ratio 0.03, c_2 = 2·0.03·√(k_2·J_r·J_g/J_eq));
    the transmission's spring sees the reducer input angle u_g, the encoder and the controller
    the rotors' u: the encoders' twist includes the shaft's wind-up T/k_2 (≈ 1.1e-4 rad at
    rated torque, s = 1) and a 10 Hz mode rings after load steps.

Truth (RigRun.truth, the sample instants, true values without sensor effects): t, q, qd, qdd,
u, ud, twist (u − q), twist_engaged (Δ_e), torque (T incl. damping, hysteresis, ripple),
torque_elastic (f(q)·K(Δ_e)), torque_damping, torque_hysteresis, torque_load (τ_L),
load_on_output (τ_L), friction (F), gravity (G), disturbance (τ_d), coupling (τ_c),
torque_motor (τ_m), friction_motor (F_m), torque_cmd, temp_joint (θ_o), temp_housing (θ_h),
temp_m1..3, u_gear (u_g; = u without motor_shaft), q_aux and qd_aux (q_2, q̇_2; = q, q̇ without
bearing_mode).

Determinism: the machine and the effects' phases/signs from `seed` (SEED_IS_CAMPAIGN), the
run's noise (sensor noise, dynamometer noise) from (seed, run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from typing import Any

import numba
import numpy as np
import pandas as pd
from scipy.signal import lfilter

RIG_NAME = "rig_ab"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential_d1", "gaussian_d2", "lorentzian", "power_d06"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous_scaled",
                                "quadratic_power_flow"),
    "temperature_friction": ("viscous_arrhenius", "coulomb_additive", "vogel_mixed"),
    "gear_ripple": ("output_mesh_torque", "intermediate_stage_error", "load_scaled_mesh_error"),
    "torque_offset": ("bias", "linear_creep", "sqrt_creep"),
    "time_delay": ("torque_fieldbus", "q_encoder_latency", "u_encoder_latency"),
    "hysteresis": ("bouc_wen_n1", "dahl_first_order", "windup_loss"),
    "backlash": ("sharp", "hyperbolic", "load_closing"),
    "asymmetric_friction": ("coulomb_split", "coulomb_viscous_split", "viscous_split"),
    "periodic_disturbance": ("fan_sine", "pump_rectified", "gauge_pickup"),
    "position_dependent_stiffness": ("soft_zone", "exp_gradient", "thrice_per_rev"),
    "encoder_drift": ("q_linear", "q_exponential", "u_linear"),
    "second_resonance": ("bearing_mode", "motor_shaft"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "time_delay": (
        "The torque transducer's amplifier is a critically damped second-order low-pass whose "
        "group delay is SensorSpec.torque_filter_s (0.5 ms by default), so the torque reading "
        "lags the transmitted torque by about that much; meta sensors.torque.lag_s states it "
        "(plus SensorSpec.torque_lag_s)."),
}

# --- nominal machine -------------------------------------------------------------------------
G_ACC = 9.81
T_RATED = 120_000.0
TWIST_RATED_DEG = 0.45
V_C = 1.5e-4                 # tanh regularisation velocity of the output Coulomb friction
P_HARD = 1.5                 # exponent of the hardening compliance law
J_MOTOR = 0.0035             # rotor + first stage, per motor [kg·m²]
J_NOM = 3.0 * J_MOTOR * REDUCTION ** 2
OMEGA_C = 40.0               # closed-loop triple pole of the motor position loop [rad/s]
H_MAX = 2.0e-4               # largest RK4 substep [s]
NOISE_DT = 2.0e-3            # grid of the dynamometer's torque noise [s]
T_REF_C = 30.0

# scheme timing [s]
S12_T_LOAD0 = 2.5
S12_MOTOR_T0 = 0.5
S12_MOTOR_RAMP = 1.2
S1_HALF = 10.0
S2_RAMP = 0.3
S2_HOLD = 2.0
S2_NSTEP = 12
S2_UNLOAD = 3.0
S2_PERIOD = S2_NSTEP * (S2_RAMP + S2_HOLD) + S2_UNLOAD
S12_TAIL = 1.0
S3_T0 = 1.5
S3_TAIL = 1.5
FOURIER_PERIOD_S = 24.0
_FA4 = (-0.0045843, -0.0047006, 0.0029539, 0.0055513)
_FB4 = (-0.0023227, 0.0042895, 0.0054060, -0.0013715)
FOURIER_A = np.array(list(_FA4) + [-sum(_FA4)])
FOURIER_B = np.array(list(_FB4) + [-sum((i + 1) * b for i, b in enumerate(_FB4)) / 5.0])
TRAVEL_LIMIT = math.pi - 0.1

_NOMINAL = {  # name: (value, relative SD)
    "I": (6685.166, 0.015), "mr_x": (20.779, 0.05), "mr_y": (-34.543, 0.05),
    "f_v": (8683.272, 0.04), "f_c": (2352.660, 0.025),
    "twist_rated_rad": (math.radians(TWIST_RATED_DEG), 0.04), "a_hard": (0.8, 0.10),
    "beta_s": (0.015, 0.10), "J_eq": (J_NOM, 0.03),
    "F_mc": (3 * 0.20 * REDUCTION, 0.05), "f_mv": (3 * 1.5e-4 * REDUCTION ** 2, 0.05),
    "dyn_gain": (1.0, 0.003),
}

# effect families (index = position in EFFECT_FORMS)
(F_STRIB, F_LOADF, F_TEMPF, F_RIPPLE, F_OFFSET, F_DELAY, F_HYST, F_BACKLASH, F_ASYM,
 F_PERIODIC, F_POSSTIFF, F_ENCDRIFT, F_RES2) = range(13)
_FAMILY_INDEX = {name: i for i, name in enumerate(EFFECT_FORMS)}

# parameter vector layout
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_VC, P_K0, P_AH, P_PH, P_DR, P_BS, P_JEQ, P_KP, P_KD, P_KI,
 P_TMAX, P_FMC, P_FMV, P_VM, P_WD, P_ZD, P_DG, P_DB, P_CO, P_CH, P_ROH, P_RHA, P_TA, P_CW, P_RW,
 P_KT1, P_KT2, P_KT3, P_SH1, P_SH2, P_SH3, P_R1, P_R2, P_R3, P_SCHEME, P_DIR, P_OMEGA,
 P_PERIODS, P_U0, P_H) = range(45)
N_P = 45

# state vector layout
(Y_Q, Y_QD, Y_U, Y_UD, Y_XI, Y_TL, Y_TLD, Y_HS, Y_TO, Y_TH, Y_TW1, Y_TW2, Y_TW3, Y_Q2, Y_Q2D,
 Y_UG, Y_UGD) = range(17)
N_Y = 17

# auxiliary outputs (after the state in a record)
(A_T, A_TEL, A_TD, A_TH, A_FF, A_G, A_DIST, A_TM, A_FM, A_TCMD, A_QDD, A_UDD, A_DE, A_TC, A_I1,
 A_I2, A_I3) = range(17)
N_A = 17
N_REC = N_Y + N_A + 1      # + the transducer's filtered torque
R_TF = N_Y + N_A

PHASE_CODES = ("idle", "load", "hold", "unload", "excite")

# effect sizes at scale 1 (see the data sheet)
STRIB_DF = 0.30           # × f_c
STRIB_VS = 1.6e-3
LOADF_MU = 0.006
LOADF_SC, LOADF_SV = 0.25, 0.6
LOADF_QD, LOADF_QB = 0.005, 0.010
TEMPF_E = 2600.0
TEMPF_CA = 28.0
TEMPF_B, TEMPF_TINF, TEMPF_CEXP = 320.0, -95.0, 0.35
RIPPLE_A = 320.0
STAGE_A = 200.0
MESH_Z = 73.0
STAGE_Z = 6200.0
OFFSET_B, OFFSET_LIN, OFFSET_SQRT = 350.0, 5.0, 55.0
DELAY_S = 0.010
HYST_H, HYST_XM, HYST_XZ = 500.0, 1.5e-4, 1.0e-4
BACKLASH_B = 1.5e-4
BACKLASH_CLOSE = 30_000.0
ASYM_C, ASYM_CV_C, ASYM_CV_V, ASYM_V = 0.11, 0.07, 0.3, 0.6
PERIODIC_A, PICKUP_A = 320.0, 300.0
FAN_HZ, PUMP_HZ, PICKUP_HZ = 3.1, 0.9, 16.7
POSSTIFF_SOFT, POSSTIFF_W, POSSTIFF_EXP, POSSTIFF_3 = 0.1, 0.04, 0.15, 0.06
DRIFT_LIN, DRIFT_EXP, DRIFT_TAU = 2.5e-6, 2.5e-4, 30.0
RES2_BEARING_FRAC, RES2_BEARING_HZ, RES2_BEARING_ZETA = 0.3, 8.0, 0.02
RES2_SHAFT_FRAC, RES2_SHAFT_HZ, RES2_SHAFT_ZETA = 0.3, 10.0, 0.03


# --- sensors ---------------------------------------------------------------------------------

_SENSOR_RANGES = {
    "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-5, 1.0),
    "torque_noise": (0.0, 1e5), "torque_lag_s": (0.0, 1.0), "torque_filter_s": (0.0, 0.1),
    "torque_res": (0.0, 1e4), "load_noise": (0.0, 1e5), "load_res": (0.0, 1e4),
    "qd_noise": (0.0, 1.0), "motor_encoder_res": (0.0, 1e-2), "ud_noise": (0.0, 1.0),
    "current_noise": (0.0, 100.0), "temp_res": (0.0, 10.0), "temp_noise": (0.0, 10.0),
}


@dataclass
class SensorSpec:
    """What the bench's sensors resolve (data sheet section 3); ranges in _SENSOR_RANGES."""

    sample_rate_hz: float = 1000.0      # [Hz], 10..1000
    encoder_res_deg: float = 0.01       # output encoder step [deg], 1e-5..1
    torque_noise: float = 120.0         # torque reading noise SD [N·m]
    torque_lag_s: float = 0.0           # pure lag of the torque reading [s], 0..1
    torque_filter_s: float = 5e-4       # transducer amplifier group delay [s], 0..0.1
    torque_res: float = 2.0             # torque ADC step [N·m] (0: none)
    load_noise: float = 80.0            # dynamometer torque reading noise SD [N·m]
    load_res: float = 5.0               # its step [N·m]
    qd_noise: float = 2e-5              # output velocity noise SD [rad/s]
    motor_encoder_res: float = 2 * math.pi / 2 ** 20 / REDUCTION  # referred step [rad]
    ud_noise: float = 2e-6              # referred motor velocity noise SD [rad/s]
    current_noise: float = 0.02         # motor current noise SD [A]
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
            if not lo <= v <= hi:
                raise ValueError(f"SensorSpec.{name} must lie in [{lo:g}, {hi:g}], got {v!r}")
            setattr(self, name, v)


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


# --- argument checks -------------------------------------------------------------------------

def _is_int(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) \
        and not isinstance(v, (bool, np.bool_))


def _check_effects(effects: Any) -> dict[str, tuple[str, float]]:
    """{name: (form, scale)} for the effects with scale > 0 (scale 0 is no effect)."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}} or None, "
                         f"got {type(effects).__name__}")
    out: dict[str, tuple[str, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale', "
                             f"got {spec!r}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}] has unknown keys {sorted(extra)}; "
                             "expected 'form' and 'scale'")
        form = spec.get("form")
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; known: "
                             f"{list(EFFECT_FORMS[name])}")
        scale = spec.get("scale", 1.0)
        if not _is_num(scale) or not math.isfinite(float(scale)):
            raise ValueError(f"effects[{name!r}]['scale'] must be a finite number, "
                             f"got {scale!r}")
        scale = float(scale)
        if scale < 0.0:
            raise ValueError(f"effects[{name!r}]['scale'] must be >= 0, got {scale!r}")
        if scale > SCALE_MAX:
            raise ValueError(f"effects[{name!r}]['scale'] must be <= SCALE_MAX = "
                             f"{SCALE_MAX:g} (larger scales are refused), got {scale!r}")
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


# --- scheme programmes (numba scalars, shared by the kernel and the sampling) ---------------

def run_duration(scheme: int, periods: int) -> float:
    """Length of a run [s] (data sheet section 2)."""
    if scheme == 1:
        return S12_T_LOAD0 + periods * 2.0 * S1_HALF + S12_TAIL
    if scheme == 2:
        return S12_T_LOAD0 + periods * S2_PERIOD + S12_TAIL
    return S3_T0 + periods * FOURIER_PERIOD_S + S3_TAIL


@numba.njit(cache=True)
def _setpoint(t, scheme, periods):
    """(dynamometer set point [N·m], phase code) at time t."""
    if scheme == 3:
        if S3_T0 <= t < S3_T0 + periods * FOURIER_PERIOD_S:
            return 0.0, 4
        return 0.0, 0
    x = t - S12_T_LOAD0
    if scheme == 1:
        per = 2.0 * S1_HALF
        if x < 0.0 or x >= periods * per:
            return 0.0, 0
        x = x - math.floor(x / per) * per
        if x < S1_HALF:
            return 0.5 * T_RATED * (1.0 - math.cos(math.pi * x / S1_HALF)), 1
        return 0.5 * T_RATED * (1.0 + math.cos(math.pi * (x - S1_HALF) / S1_HALF)), 3
    if x < 0.0 or x >= periods * S2_PERIOD:
        return 0.0, 0
    x = x - math.floor(x / S2_PERIOD) * S2_PERIOD
    step_len = S2_RAMP + S2_HOLD
    steps_end = S2_NSTEP * step_len
    step = T_RATED / S2_NSTEP
    if x < steps_end:
        j = math.floor(x / step_len)
        xj = x - j * step_len
        if xj < S2_RAMP:
            r = xj / S2_RAMP
            return step * (j + r * r * (3.0 - 2.0 * r)), 1
        return step * (j + 1.0), 2
    r = (x - steps_end) / S2_UNLOAD
    return 0.5 * T_RATED * (1.0 + math.cos(math.pi * r)), 3


@numba.njit(cache=True)
def _fourier(tau, fa, fb):
    """Eq. 12 position, velocity, acceleration at time tau into a period (q(0) = 0)."""
    wf = 2.0 * math.pi / FOURIER_PERIOD_S
    q = 0.0
    qd = 0.0
    qdd = 0.0
    s1 = math.sin(wf * tau)
    c1 = math.cos(wf * tau)
    s = s1
    c = c1
    for i in range(5):
        lw = (i + 1) * wf
        q += fa[i] / lw * s - fb[i] / lw * c + fb[i] / lw
        qd += fa[i] * c + fb[i] * s
        qdd += -fa[i] * lw * s + fb[i] * lw * c
        s, c = s * c1 + c * s1, c * c1 - s * s1   # angle-addition recurrence to (i + 2)·wf·tau
    return q, qd, qdd


@numba.njit(cache=True)
def _uref(t, p, fa, fb):
    """Motor reference (angle, velocity, acceleration), referred to the output."""
    scheme = int(p[P_SCHEME])
    d = p[P_DIR]
    if scheme == 3:
        tau = t - S3_T0
        if tau <= 0.0 or tau >= p[P_PERIODS] * FOURIER_PERIOD_S:
            return p[P_U0], 0.0, 0.0
        tau = tau - math.floor(tau / FOURIER_PERIOD_S) * FOURIER_PERIOD_S
        q, qd, qdd = _fourier(tau, fa, fb)
        return p[P_U0] + d * q, d * qd, d * qdd
    om = p[P_OMEGA] * d
    x = (t - S12_MOTOR_T0) / S12_MOTOR_RAMP
    if x <= 0.0:
        return p[P_U0], 0.0, 0.0
    if x < 1.0:
        x2 = x * x
        pos = om * S12_MOTOR_RAMP * x2 * x2 * (2.5 - 3.0 * x + x2)
        vel = om * x2 * x * (10.0 - 15.0 * x + 6.0 * x2)
        acc = om / S12_MOTOR_RAMP * 30.0 * x2 * (1.0 - x) * (1.0 - x)
        return p[P_U0] + pos, vel, acc
    return p[P_U0] + om * (0.5 * S12_MOTOR_RAMP + t - S12_MOTOR_T0 - S12_MOTOR_RAMP), om, 0.0


@numba.njit(cache=True)
def _phase_codes(t, scheme, periods):
    out = np.empty(t.shape[0], dtype=np.int64)
    for k in range(t.shape[0]):
        out[k] = _setpoint(t[k], scheme, periods)[1]
    return out


@numba.njit(cache=True)
def _setpoints(t, scheme, periods):
    out = np.empty(t.shape[0])
    for k in range(t.shape[0]):
        out[k] = _setpoint(t[k], scheme, periods)[0]
    return out


# --- the machine's right-hand side -----------------------------------------------------------

@numba.njit(cache=True)
def _backlash(d, form, b):
    """Engaged twist and its slope for a dead zone of half-width b (form 0 sharp, 1 hyperbolic)."""
    if form == 0:
        if d > b:
            return d - b, 1.0
        if d < -b:
            return d + b, 1.0
        return 0.0, 0.0
    eps = 0.35 * b
    c0 = 0.5 * (math.sqrt(b * b + eps * eps) - b)
    x = abs(d) - b
    r = math.sqrt(x * x + eps * eps)
    val = 0.5 * (x + r) - c0
    slope = 0.5 * (1.0 + x / r)
    return (val if d >= 0.0 else -val), slope


@numba.njit(cache=True)
def _stiff_factor(q, form, s, ep):
    if form == 0:
        z = (q - ep[3]) / POSSTIFF_W
        return max(0.1, 1.0 - POSSTIFF_SOFT * s * math.exp(-z * z))
    if form == 1:
        return math.exp(min(2.0, max(-2.0, POSSTIFF_EXP * s * q)))
    return max(0.1, 1.0 + POSSTIFF_3 * s * math.sin(3.0 * q + ep[0]))


@numba.njit(cache=True)
def _rhs(t, y, p, ef, es, ep, noise, fa, fb, dy, aux):
    """Time derivative of the state y into dy; the algebraic outputs into aux."""
    q = y[Y_Q]
    qd = y[Y_QD]
    tcmd, _ph = _setpoint(t, int(p[P_SCHEME]), int(p[P_PERIODS]))
    ur, udr, uddr = _uref(t, p, fa, fb)

    shaft = ef[F_RES2] == 1
    if shaft:
        ut = y[Y_UG]
        utd = y[Y_UGD]
    else:
        ut = y[Y_U]
        utd = y[Y_UD]
    dl = ut - q
    dld = utd - qd
    k0 = p[P_K0]
    ah = p[P_AH]
    ph = p[P_PH]
    dr = p[P_DR]

    # stiffness factor f(q)
    fq = 1.0
    if ef[F_POSSTIFF] >= 0:
        fq = _stiff_factor(q, ef[F_POSSTIFF], es[F_POSSTIFF], ep[F_POSSTIFF])

    # kinematic errors
    e = 0.0
    if ef[F_RIPPLE] == 1:
        amp = STAGE_A * es[F_RIPPLE] / k0
        a1 = STAGE_Z * ut + ep[F_RIPPLE, 0]
        a2 = 2.0 * STAGE_Z * ut + ep[F_RIPPLE, 1]
        e = amp * (math.sin(a1) + 0.4 * math.sin(a2))
    elif ef[F_RIPPLE] == 2:
        xa = abs(dl) / dr
        tpre = abs(fq * k0 * dl * (1.0 + ah * xa ** ph))
        amp = RIPPLE_A * es[F_RIPPLE] / k0 * (0.2 + 0.8 * min(tpre / T_RATED, 1.5))
        a1 = MESH_Z * q + ep[F_RIPPLE, 0]
        e = amp * math.sin(a1)
    dk = dl - e

    # dead zone
    bf = ef[F_BACKLASH]
    if bf >= 0:
        bb = BACKLASH_B * es[F_BACKLASH]
        if bf == 2:
            bb *= math.exp(-abs(y[Y_TL]) / BACKLASH_CLOSE)
            bf = 0
        de, bsl = _backlash(dk, bf, bb)
    else:
        de = dk
        bsl = 1.0
    ded = bsl * dld      # the kinematic error loads the spring, not the damper

    # compliance law and structural damping
    xr = abs(de) / dr
    xp = xr ** ph
    tel = fq * k0 * de * (1.0 + ah * xp)
    ktan = fq * k0 * (1.0 + ah * (1.0 + ph) * xp)
    tdamp = p[P_BS] * ktan * ded

    # hysteresis
    th = 0.0
    dy[Y_HS] = 0.0
    hf = ef[F_HYST]
    if hf >= 0:
        hh = HYST_H * es[F_HYST]
        xs = y[Y_HS]
        sg = 1.0 if ded > 0.0 else (-1.0 if ded < 0.0 else 0.0)
        if hf == 0:
            th = hh * xs / HYST_XM
            dy[Y_HS] = ded - (0.7 * abs(ded) * xs + 0.3 * ded * abs(xs)) / HYST_XM
        elif hf == 1:
            th = hh * xs / HYST_XM
            dy[Y_HS] = 2.0 * ded * (1.0 - sg * xs / HYST_XM)
        else:
            th = 2.0 * hh * math.sqrt(min(abs(de) / dr, 2.0)) * xs
            dy[Y_HS] = ded * (1.0 - sg * xs) / HYST_XZ
    tq = tel + tdamp + th
    tstat = tel + th

    # output friction
    v = qd
    fc = p[P_FC]
    fv = p[P_FV]
    thv0 = math.tanh(v / p[P_VC])
    af = ef[F_ASYM]
    if af >= 0:
        sgn = thv0 * es[F_ASYM]       # = s·(2w₊ − 1)
        if af == 0:
            fc *= max(0.1, 1.0 + ASYM_C * sgn)
        elif af == 1:
            fc *= max(0.1, 1.0 + ASYM_CV_C * sgn)
            fv *= max(0.1, 1.0 + ASYM_CV_V * sgn)
        else:
            fv *= max(0.1, 1.0 + ASYM_V * sgn)
    tf = ef[F_TEMPF]
    if tf >= 0:
        th_o = y[Y_TO]
        s = es[F_TEMPF]
        if tf == 0:
            ex = s * TEMPF_E * (1.0 / (th_o + 273.15) - 1.0 / (T_REF_C + 273.15))
            fv *= math.exp(min(3.0, max(-3.0, ex)))
        elif tf == 1:
            fc = max(0.2 * p[P_FC], fc + TEMPF_CA * s * (T_REF_C - th_o))
        else:
            ex = s * TEMPF_B * (1.0 / (th_o - TEMPF_TINF) - 1.0 / (T_REF_C - TEMPF_TINF))
            m = math.exp(min(3.0, max(-3.0, ex)))
            fv *= m
            fc *= m ** TEMPF_CEXP
    lf = ef[F_LOADF]
    if lf >= 0:
        s = es[F_LOADF]
        ta = abs(tstat)
        if lf == 0:
            fc += LOADF_MU * s * ta
        elif lf == 1:
            fc *= 1.0 + LOADF_SC * s * ta / T_RATED
            fv *= 1.0 + LOADF_SV * s * ta / T_RATED
        else:
            wd = 0.5 * (1.0 + math.tanh(tstat * v / 10.0))
            c = LOADF_QD * wd + LOADF_QB * (1.0 - wd)
            fc += c * s * T_RATED * (ta / T_RATED) ** 2
    dfs = 0.0
    sf = ef[F_STRIB]
    if sf >= 0:
        x = abs(v) / STRIB_VS
        if sf == 0:
            sx = math.exp(-x)
        elif sf == 1:
            sx = math.exp(-x * x)
        elif sf == 2:
            sx = 1.0 / (1.0 + x * x)
        else:
            sx = math.exp(-x ** 0.6)
        dfs = STRIB_DF * p[P_FC] * es[F_STRIB] * sx
    ctot = fc + dfs
    vc = p[P_VC]
    vmin = ctot * p[P_H] / (1.2 * p[P_I])
    if vmin > vc:
        vc = vmin
    ff = ctot * math.tanh(v / vc) + fv * v

    # disturbances on the output
    dist = 0.0
    if ef[F_RIPPLE] == 0:
        a1 = MESH_Z * q
        dist -= RIPPLE_A * es[F_RIPPLE] * (math.sin(a1 + ep[F_RIPPLE, 0])
                                           + 0.5 * math.sin(2.0 * a1 + ep[F_RIPPLE, 1])
                                           + 0.25 * math.sin(3.0 * a1 + ep[F_RIPPLE, 2]))
    pf = ef[F_PERIODIC]
    if pf == 0:
        w = 2.0 * math.pi * FAN_HZ * t
        dist += PERIODIC_A * es[F_PERIODIC] * (math.sin(w + ep[F_PERIODIC, 0])
                                               + 0.3 * math.sin(2.0 * w + ep[F_PERIODIC, 1]))
    elif pf == 1:
        w = 2.0 * math.pi * PUMP_HZ * t
        dist += PERIODIC_A * es[F_PERIODIC] * 0.5 * math.pi * (
            abs(math.sin(w + ep[F_PERIODIC, 0])) - 2.0 / math.pi)

    # auxiliary output inertia (bearing mode)
    tc = 0.0
    if ef[F_RES2] == 0:
        i2 = RES2_BEARING_FRAC * es[F_RES2] * p[P_I]
        w2 = 2.0 * math.pi * RES2_BEARING_HZ
        k2 = i2 * w2 * w2
        c2 = 2.0 * RES2_BEARING_ZETA * math.sqrt(k2 * i2)
        tc = k2 * (y[Y_Q2] - q) + c2 * (y[Y_Q2D] - qd)
        dy[Y_Q2] = y[Y_Q2D]
        dy[Y_Q2D] = -tc / i2
    else:
        dy[Y_Q2] = 0.0
        dy[Y_Q2D] = 0.0

    grav = G_ACC * (p[P_MRX] * math.sin(q) + p[P_MRY] * math.cos(q))
    tl = y[Y_TL]
    qdd = (tq - tl - grav - ff + dist + tc) / p[P_I]
    dy[Y_Q] = qd
    dy[Y_QD] = qdd

    # motor side: PID position loop, motor friction
    err = ur - y[Y_U]
    errd = udr - y[Y_UD]
    tm = p[P_KP] * err + p[P_KD] * errd + p[P_KI] * y[Y_XI] + J_NOM * uddr
    tmax = p[P_TMAX]
    if tm > tmax:
        tm = tmax
    elif tm < -tmax:
        tm = -tmax
    fm = p[P_FMC] * (2.0 / math.pi) * math.atan(y[Y_UD] / p[P_VM]) + p[P_FMV] * y[Y_UD]
    dy[Y_U] = y[Y_UD]
    dy[Y_XI] = err
    if shaft:
        rho = min(RES2_SHAFT_FRAC * es[F_RES2], 0.9)
        jr = (1.0 - rho) * p[P_JEQ]
        jg = rho * p[P_JEQ]
        w2 = 2.0 * math.pi * RES2_SHAFT_HZ
        mu = jr * jg / p[P_JEQ]
        k2 = mu * w2 * w2
        c2 = 2.0 * RES2_SHAFT_ZETA * math.sqrt(k2 * mu)
        ts2 = k2 * (y[Y_U] - y[Y_UG]) + c2 * (y[Y_UD] - y[Y_UGD])
        udd = (tm - fm - ts2) / jr
        dy[Y_UG] = y[Y_UGD]
        dy[Y_UGD] = (ts2 - tq) / jg
    else:
        udd = (tm - fm - tq) / p[P_JEQ]
        dy[Y_UG] = 0.0
        dy[Y_UGD] = 0.0
    dy[Y_UD] = udd

    # dynamometer
    fi = t / NOISE_DT
    ii = int(fi)
    if ii >= noise.shape[0] - 1:
        nz = noise[noise.shape[0] - 1]
    else:
        fr = fi - ii
        nz = noise[ii] * (1.0 - fr) + noise[ii + 1] * fr
    wd2 = p[P_WD]
    dy[Y_TL] = y[Y_TLD]
    dy[Y_TLD] = wd2 * wd2 * (p[P_DG] * tcmd + p[P_DB] + nz - tl) - 2.0 * p[P_ZD] * wd2 * y[Y_TLD]

    # thermal
    ploss = abs(ff * v) + abs(fm * y[Y_UD]) + abs(tdamp * ded)
    dy[Y_TO] = (ploss - (y[Y_TO] - y[Y_TH]) / p[P_ROH]) / p[P_CO]
    dy[Y_TH] = ((y[Y_TO] - y[Y_TH]) / p[P_ROH] - (y[Y_TH] - p[P_TA]) / p[P_RHA]) / p[P_CH]
    base = tm / REDUCTION
    for k in range(3):
        ik = p[P_SH1 + k] * base / p[P_KT1 + k]
        tw = y[Y_TW1 + k]
        rk = p[P_R1 + k] * (1.0 + 0.00393 * (tw - 20.0))
        dy[Y_TW1 + k] = (rk * ik * ik - (tw - p[P_TA]) / p[P_RW]) / p[P_CW]
        aux[A_I1 + k] = ik

    aux[A_T] = tq
    aux[A_TEL] = tel
    aux[A_TD] = tdamp
    aux[A_TH] = th
    aux[A_FF] = ff
    aux[A_G] = grav
    aux[A_DIST] = dist
    aux[A_TM] = tm
    aux[A_FM] = fm
    aux[A_TCMD] = tcmd
    aux[A_QDD] = qdd
    aux[A_UDD] = udd
    aux[A_DE] = de
    aux[A_TC] = tc


@numba.njit(cache=True)
def _integrate(y0, p, ef, es, ep, noise, fa, fb, probes, h, nsteps, tau_f):
    """RK4 over nsteps substeps of h; records [state, aux, filtered torque] at `probes`
    (sorted times in [0, nsteps·h]) by linear interpolation between substeps."""
    npb = probes.shape[0]
    out = np.empty((npb, N_REC))
    y = y0.copy()
    k1 = np.empty(N_Y)
    k2 = np.empty(N_Y)
    k3 = np.empty(N_Y)
    k4 = np.empty(N_Y)
    yt = np.empty(N_Y)
    aux = np.zeros(N_A)
    scratch = np.zeros(N_A)
    prev = np.empty(N_REC)
    cur = np.empty(N_REC)
    _rhs(0.0, y, p, ef, es, ep, noise, fa, fb, k1, aux)
    f1 = aux[A_T]
    f2 = aux[A_T]
    if tau_f > 0.0:
        ca = (2.0 * tau_f - h) / (2.0 * tau_f + h)
        cb = h / (2.0 * tau_f + h)
    else:
        ca = 0.0
        cb = 0.0
    cur[:N_Y] = y
    cur[N_Y:N_Y + N_A] = aux
    cur[R_TF] = f2
    j = 0
    while j < npb and probes[j] <= 1e-12:
        out[j] = cur
        j += 1
    hh = 0.5 * h
    for n in range(nsteps):
        t = n * h
        for i in range(N_Y):
            yt[i] = y[i] + hh * k1[i]
        _rhs(t + hh, yt, p, ef, es, ep, noise, fa, fb, k2, scratch)
        for i in range(N_Y):
            yt[i] = y[i] + hh * k2[i]
        _rhs(t + hh, yt, p, ef, es, ep, noise, fa, fb, k3, scratch)
        for i in range(N_Y):
            yt[i] = y[i] + h * k3[i]
        _rhs(t + h, yt, p, ef, es, ep, noise, fa, fb, k4, scratch)
        for i in range(N_Y):
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        tprev = aux[A_T]
        tn = (n + 1) * h
        _rhs(tn, y, p, ef, es, ep, noise, fa, fb, k1, aux)
        if tau_f > 0.0:
            f1n = ca * f1 + cb * (aux[A_T] + tprev)
            f2 = ca * f2 + cb * (f1n + f1)
            f1 = f1n
        else:
            f1 = aux[A_T]
            f2 = aux[A_T]
        for i in range(N_REC):
            prev[i] = cur[i]
        cur[:N_Y] = y
        cur[N_Y:N_Y + N_A] = aux
        cur[R_TF] = f2
        while j < npb and probes[j] <= tn + 1e-9 * h:
            w = (probes[j] - (tn - h)) / h
            if w < 0.0:
                w = 0.0
            elif w > 1.0:
                w = 1.0
            for i in range(N_REC):
                out[j, i] = prev[i] + w * (cur[i] - prev[i])
            j += 1
    while j < npb:  # rounding at the very end
        out[j] = cur
        j += 1
    return out


@numba.njit(cache=True)
def _initial_state(y, p, ef, es, ep, noise, fa, fb):
    """Solve the motor (reducer-input) angle for output equilibrium at rest at q = 0 by
    bisection; set the PID integral and the shaft twist to hold it. y holds q = 0, the
    dynamometer's initial torque and the temperatures; modified in place."""
    dy = np.empty(N_Y)
    aux = np.zeros(N_A)
    lo = -0.05
    hi = 0.05
    shaft = ef[F_RES2] == 1
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        y[Y_U] = mid
        y[Y_UG] = mid
        p[P_U0] = mid
        _rhs(0.0, y, p, ef, es, ep, noise, fa, fb, dy, aux)
        if dy[Y_QD] > 0.0:
            hi = mid
        else:
            lo = mid
    ug = 0.5 * (lo + hi)
    y[Y_U] = ug
    y[Y_UG] = ug
    p[P_U0] = ug
    _rhs(0.0, y, p, ef, es, ep, noise, fa, fb, dy, aux)
    t0 = aux[A_T]
    if shaft:
        rho = min(RES2_SHAFT_FRAC * es[F_RES2], 0.9)
        jr = (1.0 - rho) * p[P_JEQ]
        jg = rho * p[P_JEQ]
        w2 = 2.0 * math.pi * RES2_SHAFT_HZ
        k2 = jr * jg / p[P_JEQ] * w2 * w2
        y[Y_U] = ug + t0 / k2
        p[P_U0] = y[Y_U]
    _rhs(0.0, y, p, ef, es, ep, noise, fa, fb, dy, aux)
    # the PID integral supplies the motor torque that holds the transmission
    y[Y_XI] = (aux[A_T] + aux[A_FM]) / p[P_KI]
    return y


# --- machine, effects and noise draws --------------------------------------------------------

_SALT = 0xAB0A


def _clipped_normal(rng: np.random.Generator, size=None) -> np.ndarray | float:
    return np.clip(rng.standard_normal(size), -2.5, 2.5)


def draw_machine(seed: int) -> dict[str, float]:
    """The campaign's machine (data sheet section 1)."""
    rng = np.random.default_rng([_SALT, int(seed), 1])
    m: dict[str, float] = {}
    for name, (val, rel) in _NOMINAL.items():
        m[name] = float(val * (1.0 + rel * _clipped_normal(rng)))
    m["p_hard"] = P_HARD
    m["k0"] = T_RATED / (m["twist_rated_rad"] * (1.0 + m["a_hard"]))
    m["v_c"] = V_C
    m["dyn_bias"] = float(150.0 * _clipped_normal(rng))
    m["ambient_c"] = float(22.0 + 1.5 * _clipped_normal(rng))
    kt = 1.32 * (1.0 + 0.02 * _clipped_normal(rng, 3))
    sh = 1.0 + 0.015 * _clipped_normal(rng, 3)
    sh = sh / sh.sum()
    r20 = 0.95 * (1.0 + 0.03 * _clipped_normal(rng, 3))
    off = 0.008 * _clipped_normal(rng, 3)
    for k in range(3):
        m[f"k_t{k + 1}"] = float(kt[k])
        m[f"share{k + 1}"] = float(sh[k])
        m[f"r20_{k + 1}"] = float(r20[k])
        m[f"i_offset{k + 1}"] = float(off[k])
    m["dyn_omega"] = 2.0 * math.pi * 12.0
    m["dyn_zeta"] = 0.8
    m["v_m"] = 5e-5
    m["C_oil"], m["C_housing"], m["R_oil_housing"], m["R_housing_air"] = 9.0e4, 4.0e5, 0.02, 0.04
    m["C_winding"], m["R_winding_air"] = 6000.0, 0.35
    m["K_p"] = 3.0 * J_NOM * OMEGA_C ** 2
    m["K_d"] = 3.0 * J_NOM * OMEGA_C
    m["K_i"] = J_NOM * OMEGA_C ** 3
    m["tau_max"] = 3.0 * 24.0 * REDUCTION
    return m


def _effect_draws(seed: int) -> np.ndarray:
    """Per-campaign phases φ1..φ3 (columns 0–2) and sign σ / centre q_c (column 3)."""
    ep = np.zeros((13, 4))
    for i in range(13):
        rng = np.random.default_rng([_SALT, int(seed), 100 + i])
        ep[i, :3] = rng.uniform(0.0, 2.0 * math.pi, 3)
        ep[i, 3] = 1.0 if rng.random() < 0.5 else -1.0
    ep[F_POSSTIFF, 3] = np.random.default_rng([_SALT, int(seed), 200]).uniform(-0.03, 0.03)
    return ep


def _dyn_noise(rng: np.random.Generator, duration: float) -> np.ndarray:
    n = int(duration / NOISE_DT) + 3
    warm = 200
    w = rng.standard_normal(n + warm)
    a = math.exp(-NOISE_DT / 0.008)
    x2 = lfilter([1.0 - a], [1.0, -a], lfilter([1.0 - a], [1.0, -a], w))
    out = x2[warm:]
    # stationary SD of two cascaded first-order stages driven by unit white noise
    var = (1.0 - a) ** 4 * (1.0 + a * a) / ((1.0 - a * a) ** 3)
    return out * (30.0 / math.sqrt(var))


def _param_vector(m: dict[str, float], scheme: int, direction: float, rpm: float | None,
                  periods: int, h: float) -> np.ndarray:
    p = np.zeros(N_P)
    p[P_I], p[P_MRX], p[P_MRY] = m["I"], m["mr_x"], m["mr_y"]
    p[P_FV], p[P_FC], p[P_VC] = m["f_v"], m["f_c"], m["v_c"]
    p[P_K0], p[P_AH], p[P_PH], p[P_DR] = m["k0"], m["a_hard"], m["p_hard"], m["twist_rated_rad"]
    p[P_BS], p[P_JEQ] = m["beta_s"], m["J_eq"]
    p[P_KP], p[P_KD], p[P_KI], p[P_TMAX] = m["K_p"], m["K_d"], m["K_i"], m["tau_max"]
    p[P_FMC], p[P_FMV], p[P_VM] = m["F_mc"], m["f_mv"], m["v_m"]
    p[P_WD], p[P_ZD], p[P_DG], p[P_DB] = m["dyn_omega"], m["dyn_zeta"], m["dyn_gain"], \
        m["dyn_bias"]
    p[P_CO], p[P_CH], p[P_ROH], p[P_RHA] = m["C_oil"], m["C_housing"], m["R_oil_housing"], \
        m["R_housing_air"]
    p[P_TA], p[P_CW], p[P_RW] = m["ambient_c"], m["C_winding"], m["R_winding_air"]
    for k in range(3):
        p[P_KT1 + k] = m[f"k_t{k + 1}"]
        p[P_SH1 + k] = m[f"share{k + 1}"]
        p[P_R1 + k] = m[f"r20_{k + 1}"]
    p[P_SCHEME], p[P_DIR], p[P_PERIODS], p[P_H] = scheme, direction, periods, h
    p[P_OMEGA] = 0.0 if rpm is None else float(rpm) * 2.0 * math.pi / 60.0 / REDUCTION
    return p


# --- public entry point ----------------------------------------------------------------------

def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0 else step * np.round(x / step)


def _travel(scheme: int, rpm: float, periods: int) -> float:
    """Output travel [rad] of a scheme 1/2 run (reference, without twist)."""
    om = rpm * 2.0 * math.pi / 60.0 / REDUCTION
    return om * (run_duration(scheme, periods) - S12_MOTOR_T0 - 0.5 * S12_MOTOR_RAMP)


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """One bench run of rig AB (see the module data sheet)."""
    _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, sensors, periods, seed, run)
    eff = _check_effects(effects)
    scheme, periods, seed, run = int(scheme), int(periods), int(seed), int(run)
    dirn = float(direction)
    temp0 = float(temp_joint_c)
    rpm = None if scheme == 3 else float(motor_speed_rpm)
    if scheme != 3:
        travel = _travel(scheme, rpm, periods)
        if travel > TRAVEL_LIMIT:
            raise ValueError(f"periods={periods} would carry the joint {travel:.2f} rad (beyond "
                             f"±{TRAVEL_LIMIT:.2f} rad, the ±180° travel) in scheme {scheme} at "
                             f"{rpm:g} r/min; use fewer periods")
    sens = sensors if sensors is not None else SensorSpec()
    fs = sens.sample_rate_hz
    duration = run_duration(scheme, periods)
    msub = int(math.ceil(1.0 / (fs * H_MAX) - 1e-9))
    h = 1.0 / (fs * msub)
    n_samples = int(math.floor(duration * fs + 1e-9)) + 1
    nsteps = (n_samples - 1) * msub
    t = np.arange(n_samples) / fs

    mach = draw_machine(seed)
    p = _param_vector(mach, scheme, dirn, rpm, periods, h)
    ef = np.full(13, -1, dtype=np.int64)
    es = np.zeros(13)
    for name, (form, scale) in eff.items():
        i = _FAMILY_INDEX[name]
        ef[i] = EFFECT_FORMS[name].index(form)
        es[i] = scale
    ep = _effect_draws(seed)
    rng = np.random.default_rng([_SALT, seed, run, 2])
    noise = _dyn_noise(rng, duration)

    y0 = np.zeros(N_Y)
    y0[Y_TL] = mach["dyn_bias"] + noise[0]
    y0[Y_TO] = y0[Y_TH] = temp0
    y0[Y_TW1:Y_TW3 + 1] = temp0
    y0 = _initial_state(y0, p, ef, es, ep, noise, FOURIER_A, FOURIER_B)

    # readings lag: torque (pure lag + time_delay effect), output and motor encoders
    d_eff = DELAY_S * es[F_DELAY] if ef[F_DELAY] >= 0 else 0.0
    lag_t = sens.torque_lag_s + (d_eff if ef[F_DELAY] == 0 else 0.0)
    lag_q = d_eff if ef[F_DELAY] == 1 else 0.0
    lag_u = d_eff if ef[F_DELAY] == 2 else 0.0
    wanted = [t] + [np.maximum(t - lag, 0.0) for lag in (lag_t, lag_q, lag_u) if lag > 0.0]
    probes, inverse = np.unique(np.concatenate(wanted), return_inverse=True)
    rec = _integrate(y0, p, ef, es, ep, noise, FOURIER_A, FOURIER_B, probes, h, nsteps,
                     0.5 * sens.torque_filter_s)
    groups = iter(range(len(wanted)))
    at_t = rec[inverse[:n_samples]]
    next(groups)

    def lagged(lag: float) -> np.ndarray:
        if lag <= 0.0:
            return at_t
        g = next(groups)
        return rec[inverse[g * n_samples:(g + 1) * n_samples]]

    rec_t = lagged(lag_t)
    rec_q = lagged(lag_q)
    rec_u = lagged(lag_u)

    # sensor noise (per run)
    def white(sd: float, n: int = n_samples) -> np.ndarray:
        z = rng.standard_normal(n)
        return sd * z

    sig = ep[:, 3]
    q_read = rec_q[:, Y_Q].copy()
    u_read = rec_u[:, Y_U].copy()
    df = ef[F_ENCDRIFT]
    if df >= 0:
        s = es[F_ENCDRIFT] * sig[F_ENCDRIFT]
        if df == 0:
            q_read += DRIFT_LIN * s * t
        elif df == 1:
            q_read += DRIFT_EXP * s * (1.0 - np.exp(-t / DRIFT_TAU))
        else:
            u_read += DRIFT_LIN * s * t
    enc = math.radians(sens.encoder_res_deg)
    q_meas = _quant(q_read, enc)
    u_meas = _quant(u_read, sens.motor_encoder_res)
    qd_meas = rec_q[:, Y_QD] + white(sens.qd_noise)
    ud_meas = rec_u[:, Y_UD] + white(sens.ud_noise)

    torque = rec_t[:, R_TF].copy()
    of = ef[F_OFFSET]
    if of >= 0:
        s = es[F_OFFSET] * sig[F_OFFSET]
        if of == 0:
            torque += OFFSET_B * s
        elif of == 1:
            torque += OFFSET_LIN * s * t
        else:
            torque += OFFSET_SQRT * s * np.sqrt(t)
    if ef[F_PERIODIC] == 2:
        torque += PICKUP_A * es[F_PERIODIC] * np.sin(2.0 * math.pi * PICKUP_HZ * t
                                                      + ep[F_PERIODIC, 0])
    torque_meas = _quant(torque + white(sens.torque_noise), sens.torque_res)
    load_meas = _quant(at_t[:, Y_TL] + white(sens.load_noise), sens.load_res)
    tcmd = _setpoints(t, scheme, periods)

    samples: dict[str, Any] = {"t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
                               "torsion": q_meas - u_meas, "torque": torque_meas,
                               "torque_load": load_meas, "torque_cmd": tcmd}
    for k in range(3):
        samples[f"i_m{k + 1}"] = (at_t[:, N_Y + A_I1 + k] + mach[f"i_offset{k + 1}"]
                                  + white(sens.current_noise))
    for k in range(3):
        samples[f"w_m{k + 1}"] = REDUCTION * rec_u[:, Y_UD] + white(REDUCTION * sens.ud_noise)
    for k in range(3):
        samples[f"temp_m{k + 1}"] = _quant(at_t[:, Y_TW1 + k] + white(sens.temp_noise),
                                           sens.temp_res)
    samples["temp_joint"] = _quant(at_t[:, Y_TO] + white(sens.temp_noise), sens.temp_res)
    codes = _phase_codes(t, scheme, periods)
    samples["phase"] = np.array(PHASE_CODES, dtype=object)[codes]
    samples_df = pd.DataFrame(samples)

    a = N_Y
    truth = pd.DataFrame({
        "t": t, "q": at_t[:, Y_Q], "qd": at_t[:, Y_QD], "qdd": at_t[:, a + A_QDD],
        "u": at_t[:, Y_U], "ud": at_t[:, Y_UD], "twist": at_t[:, Y_U] - at_t[:, Y_Q],
        "twist_engaged": at_t[:, a + A_DE], "torque": at_t[:, a + A_T],
        "torque_elastic": at_t[:, a + A_TEL], "torque_damping": at_t[:, a + A_TD],
        "torque_hysteresis": at_t[:, a + A_TH], "torque_load": at_t[:, Y_TL],
        "load_on_output": at_t[:, Y_TL], "friction": at_t[:, a + A_FF],
        "gravity": at_t[:, a + A_G], "disturbance": at_t[:, a + A_DIST],
        "coupling": at_t[:, a + A_TC], "torque_motor": at_t[:, a + A_TM],
        "friction_motor": at_t[:, a + A_FM], "torque_cmd": at_t[:, a + A_TCMD],
        "temp_joint": at_t[:, Y_TO], "temp_housing": at_t[:, Y_TH],
        "temp_m1": at_t[:, Y_TW1], "temp_m2": at_t[:, Y_TW2], "temp_m3": at_t[:, Y_TW3],
        "u_gear": at_t[:, Y_UG] if ef[F_RES2] == 1 else at_t[:, Y_U],
        "q_aux": at_t[:, Y_Q2] if ef[F_RES2] == 0 else at_t[:, Y_Q],
        "qd_aux": at_t[:, Y_Q2D] if ef[F_RES2] == 0 else at_t[:, Y_QD],
    })

    started = datetime(2026, 3, 2, 8, 0, tzinfo=timezone.utc) + timedelta(
        days=seed % 3650, minutes=20 * run)
    lag_stated = sens.torque_lag_s + sens.torque_filter_s
    noise_w = REDUCTION * sens.ud_noise
    sensors_meta: dict[str, dict[str, float]] = {
        "q": {"resolution": enc, "noise_sd": 0.0, "lag_s": 0.0},
        "qd": {"noise_sd": sens.qd_noise, "lag_s": 0.0},
        "u": {"resolution": sens.motor_encoder_res, "noise_sd": 0.0, "lag_s": 0.0},
        "ud": {"noise_sd": sens.ud_noise, "lag_s": 0.0},
        "torsion": {"resolution": enc, "noise_sd": 0.0, "lag_s": 0.0},
        "torque": {"resolution": sens.torque_res, "noise_sd": sens.torque_noise,
                   "lag_s": lag_stated},
        "torque_load": {"resolution": sens.load_res, "noise_sd": sens.load_noise, "lag_s": 0.0},
        "torque_cmd": {"resolution": 0.0, "noise_sd": 0.0, "lag_s": 0.0},
    }
    for k in range(1, 4):
        sensors_meta[f"i_m{k}"] = {"noise_sd": sens.current_noise, "lag_s": 0.0}
        sensors_meta[f"w_m{k}"] = {"noise_sd": noise_w, "lag_s": 0.0}
        sensors_meta[f"temp_m{k}"] = {"resolution": sens.temp_res, "noise_sd": sens.temp_noise}
    sensors_meta["temp_joint"] = {"resolution": sens.temp_res, "noise_sd": sens.temp_noise}
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if rpm is None else (int(rpm) if rpm.is_integer() else rpm),
        "direction": int(dirn),
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": started.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": (f"{RIG_NAME} validation simulator, scheme {scheme}, {periods} period(s), "
                  f"joint at {temp0:g} °C at the start"),
        "sensors": sensors_meta,
        "temp_joint_c": temp0,
        "periods": periods,
        "campaign": seed,
        "run": run,
    }

    params = {
        "machine": mach,
        "effects": {k: {"form": f, "scale": s} for k, (f, s) in eff.items()},
        "effect_draws": {name: {"phases": [float(x) for x in ep[i, :3]],
                                "sign_or_centre": float(ep[i, 3])}
                         for name, i in _FAMILY_INDEX.items() if name in eff},
        "substep_s": h,
        "substeps_per_sample": msub,
        "duration_s": duration,
        "u0": float(p[P_U0]),
        "lags_s": {"torque": lag_t, "q": lag_q, "u": lag_u},
        "torque_filter_s": sens.torque_filter_s,
        "fourier_a": FOURIER_A.tolist(), "fourier_b": FOURIER_B.tolist(),
    }
    return RigRun(samples=samples_df, meta=meta, truth=truth, params=params)
