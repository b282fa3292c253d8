"""Validation rig J -- an independent emulator of the CMOR J4 joint test platform.

This module docstring is the rig's data sheet. SI units throughout (rad, rad/s, N·m, kg·m²,
s), temperatures in °C. Only numpy, pandas, numba and the standard library are used.

Interface: ``simulate_run(scheme, motor_speed_rpm, direction, temp_joint_c, effects, *, seed,
sensors, periods=3, run=0) -> RigRun(samples, meta, truth)``; ``SensorSpec`` (sensor data
sheet / DAQ set-up), ``EFFECT_FORMS``, ``OUT_OF_VOCABULARY``, ``EFFECT_SCALE_CLAMP``,
``campaign_parameters(seed)``, ``effect_constants(seed)``, ``convergence_check(...)``.

1. Structure
============
::

  3 servo motors (rigid to one input gear, output-referred inertia J_u)
     |  gear losses F_g (load-dependent, on the motor side of the transducer)
     |  compliant multi-stage reducer, twist Δ = u − q  (spring k, damper D)
  torque shaft / transducer  -> T (transmitted torque)
     |
  output body (inertia I, gravity G(q), main-bearing friction F_b)  <- output encoder q
     |  loading shaft (stiffness k_c, damping d_c), load cell at the output flange -> τ_L
  dynamometer (servo motor + reducer, output-referred inertia J_dy), torque-controlled by the PLC

q: output angle; u: motor angle / N (N = 11000); Δ = u − q (the run format's torsion is q − u);
τ_L > 0 resists positive motion. The loading shaft is declutched in scheme 3 (τ_L ≡ 0). The
loading is *positive* in both directions (the paper's "load positively"): with direction −1 the
dynamometer overhauls the joint and the motors brake.

2. Laws (nominal rig; the effects of section 6 modify them)
===========================================================
Output body (the paper's Eq. 4 plus the measured load)::

  I q̈ = T − τ_L − G(q) − F_b − τ_dist,          G(q) = g (mr_x sin q + mr_y cos q)

τ_dist = 0 on the nominal rig (ripple, periodic disturbance and second-resonance reactions act
here, downstream of the transducer, so that Eq. 4 sees them).

Main-bearing friction: LuGre (presliding at reversals, no stiction peak on the nominal rig)::

  ż = q̇ − σ0 |q̇| z / g(q̇),   F_b = σ0 z + σ1 ż + f_v q̇,   g = f_c,   σ0 = f_c / δ

In steady sliding F_b = f_c sgn(q̇) + f_v q̇ exactly (Eq. 4's law); after a reversal or a
start the friction crosses over within a presliding travel of a few δ = 25 µrad.
g(q̇) is floored at 0.5·f_c (nominal f_c) whatever the effects (bristle stiffness limit).

Transmission (linear spring–damper on the nominal rig; the paper's D u̇ + k_u u with w = 1)::

  T = k(q) · e(Δ_b) + D Δ̇_b,   Δ_b = Δ (nominal),   e = Δ_b (nominal),   k(q) = k

Motor side (output-referred; three motors share the torque)::

  J_u ü = τ_em − T − F_g,   F_g = (μ_g |T| + f_cg) tanh(u̇/ω_ε) + c_g u̇

i.e. forward efficiency 1/(1+μ_g) ≈ 0.82, back-driving 1 − μ_g ≈ 0.78. τ_em = N·Σ k_t,j i_j.

Drive (S120-like, tuned on catalogue values, not on the drawn ones)::

  schemes 1, 2: ω_ref(t) = cosine speed profile (0 -> ±rpm·2π/60/N in 2 s, back in 2 s)
  scheme 3:     ω_ref = u̇_ref + K_v (u_ref − u),   u_ref = u(0) + direction · q_F(t)
  τ_c = K_p (ω_ref − ω_f) + ξ + J_cat ω̇_ref,   ξ̇ = K_i (ω_ref − ω_f)   (clamp ±3·30·N, anti-windup)
  τ̇_em = (τ_c − τ_em)/τ_i   (current loop),   ω̇_f = (u̇ − ω_f)/τ_w   (speed measurement)

Master–slave torque sharing: one current set point i = τ_em/(N Σ k_t,j) for the three drives.

Loading device (PLC torque loop with feed-forward on the load cell)::

  τ_L = k_c (q − q_dy) + d_c (q̇ − q̇_dy)
  J_dy q̈_dy = τ_L + τ_dm − c_dy q̇_dy − f_cdy tanh(q̇_dy/ω_ε)
  τ̇_dm = (τ_dm,c − τ_dm)/τ_dy,  τ_dm,c = −(τ_cmd + K_pd e + ξ_d),  ξ̇_d = K_id e,  e = τ_cmd − τ_L

τ_cmd(t) comes from an S-curve set-point generator (cosine transitions between breakpoints).
Torque-following error at the plateaus is far inside the ±2 kN·m of Table 11; the output +
loading-device mode (≈ 31 rad/s, ζ ≈ 0.055) rings lightly after each load step.

Thermal model (two nodes; the friction laws and the sensor see the oil/mesh node)::

  C_oil θ̇_o = |F_b q̇| + |F_g u̇| − G_oh (θ_o − θ_h)
  C_h   θ̇_h = G_oh (θ_o − θ_h) − G_ha (θ_h − θ_amb),      θ_o(0) = θ_h(0) = temp_joint_c

(a 3000 r/min scheme-1 run warms the oil by ≈ 1.3 K; a run at 60 °C cools slowly to θ_amb).

3. Nominal parameters
=====================
Drawn once per campaign seed: value × (1 + ε), ε ~ N(0, 2.5 %) clipped to ±6 % unless noted.

=========================  ==========================  =====================================
output body                I = 6685 kg·m²; mr_x = 20.78, mr_y = −34.54 kg·m (4 %, ±8 %); g = 9.81
bearing friction           f_v = 8683 N·m·s/rad; f_c = 2353 N·m; δ = 2.5e-5 rad (5 %, ±10 %);
                           σ1 = 5e4 N·m·s/rad (5 %, ±10 %)
transmission               k = 1.375e7 N·m/rad (0.5° at 120 kN·m); D = 5e4 N·m·s/rad (5 %, ±10 %)
motor side                 J_u = 6.9e5 kg·m² (3 × 1.9e-3 kg·m² × N²); μ_g = 0.22;
                           f_cg = 1500 N·m, c_g = 3e4 N·m·s/rad (5 %, ±10 %); ω_ε = 2e-4 rad/s
motors                     k_t = 1.75 N·m/A each (2 %, ±5 %); torque limit 3 × 30 N·m at the motors
drive (fixed)              K_p = 2.76e7 N·m·s/rad, K_i = 2.76e8 N·m/rad (40 rad/s on J_cat = 6.9e5),
                           τ_i = 1.5 ms, τ_w = 1 ms, K_v = 10 1/s
loading device             J_dy = 1.5e4 kg·m²; k_c = 6e7 N·m/rad; d_c = 1.5e5 N·m·s/rad (5 %, ±10 %);
                           c_dy = 2e4 N·m·s/rad, f_cdy = 1200 N·m (5 %, ±10 %);
                           K_pd = 1.5, K_id = 2 1/s, τ_dy = 5 ms (fixed)
thermal                    C_oil = 3e4 J/K, C_h = 6e5 J/K, G_oh = 60 W/K, G_ha = 30 W/K,
                           θ_amb = 21 °C + N(0, 1.5) clipped ±3
Stribeck velocity          v_s = 2e-3 rad/s (7 % of the 0.0286 rad/s top speed; 4 %, ±8 %)
sensors (per campaign)     encoder eccentricity 0.001° (10 %, ±20 %) at a random phase;
                           current-sensor gains 1 ± 1 % (±3 %), offsets N(0, 0.02 A) (±0.05 A)
=========================  ==========================  =====================================

4. Integrator
=============
Classical fixed-step 4th-order Runge–Kutta on the 17 states (q, q̇, u, u̇, z, x_h, ξ, τ_em, ω_f,
q_dy, q̇_dy, ξ_d, τ_dm, θ_o, θ_h, q_2, q̇_2), compiled with numba. Step h = 1/(f_s M),
M = ceil(1/(f_s · 0.5 ms)), so h ≤ 0.5 ms and every sample instant t_k = k/f_s is a grid point
(no interpolation of the state). Why fixed-step RK4: the fastest real eigenvalues are the
bristle rate |q̇| σ0/g ≤ 2400 1/s (hence the floor on g), the current loop 667 1/s and the
speed filter 1000 1/s; λh ≤ 1.2 is well inside RK4's real-axis bound 2.78, and the oscillatory
modes (≤ 160 rad/s) have ωh ≤ 0.08. The rate-independent play operators (hysteresis
'play_stack') are updated exactly after each step; sensor filters are discretised exactly
for piecewise-linear inputs (matrix exponential of the augmented system) on the same grid.
Convergence check (``convergence_check``; h versus h/4, largest difference at the samples):
nominal scheme 3: |ΔT| = 0.007 N·m, |Δq| = 5e-10 rad; scheme 1 at 3000 r/min: 5e-6 N·m;
Stribeck at s = 10: 1.9 N·m; sharp backlash: 0.56 N·m; Bouc–Wen n = 2 at s = 3: 0.007 N·m --
all far below the 150 N·m torque noise and the 1.7e-4 rad encoder step. A non-finite state
raises RuntimeError naming the active effects.

5. Sensors (what ``meta["sensors"]`` states: resolution, noise_sd, lag_s, unit per channel)
=============================================================================================
All channels are sampled synchronously at t_k = k/f_s, k = 0 … floor(duration·f_s).

q       absolute output ring encoder, step r = encoder_res_deg; reading = r·(floor((q + e_ecc
        + drift)/r + φ) − floor(φ)): a *floor* quantiser whose zero is preset at q = 0 at run
        start with an unknown sub-step position φ ~ U(0,1) per run (a bias of up to one step);
        e_ecc = a (sin(q + ψ) − sin ψ), a ≈ 0.001° (inside the ±0.02° accuracy; not stated).
        Stated: resolution r, noise 0, lag 0.
qd      PLC velocity: (Q(t) − Q(t − T_w))/T_w on the quantised encoder, T_w = 0.1 s (a moving
        window: sinc response, delay T_w/2, steps of r/T_w). Stated: resolution r/T_w, lag T_w/2.
u       motor-1 encoder (2^22 counts per motor turn) / N, referenced to zero twist, latency
        1 ms (bus cycle). Stated: resolution 2π/(2^22 N), lag 1 ms.
ud, w_m drive speed actual values: PT1 4 ms, noise 0.02 rad/s, PROFIdrive N2 normalisation
        (6000 r/min ↔ 0x4000: step 0.0384 rad/s motor side); ud = w_m1/N. Stated.
torque  strain-gauge torque shaft (zero calibrated unloaded), 2nd-order Bessel anti-alias
        H = 3ω0²/(s² + 3ω0 s + 3ω0²), −3 dB at min(0.25 f_s, 200 Hz) (group delay 1/ω0 = 87 ms
        at 10 Hz, 6.9 ms at 125 Hz, 1.1 ms at 1 kHz; aliasing of the 5–7 Hz modes at low f_s),
        a stated pure latency torque_lag_s, white noise torque_noise, 16-bit ADC over
        ±200 kN·m (step 6.1 N·m), clipped. Stated: lag = torque_lag_s + 1/ω0.
torque_load  load cell at the output flange, same chain, noise load_noise = 200 N·m.
i_m1..3 common current set point × per-motor sensor gain + offset, PT1 4 ms, noise 0.03 A,
        N2 normalisation (20 A ↔ 0x4000). Stated: resolution, noise, lag 4 ms.
temp_joint  PT100 in a thermowell in the oil: PT1 20 s, noise 0.02 °C, 0.1 °C steps.
        Stated: lag_s = 20 s (the time constant).
Not stated anywhere: the encoder eccentricity, the floor quantiser's sub-step zero, the shape
of the velocity window and filters (only their delays), and the effects below.
``meta["sensor_notes"]`` gives the data-sheet prose.

6. Effects: ``effects = {name: {"form": f, "scale": s}}`` (s ≥ 0; s = 0 is the nominal rig bit
for bit; missing form = first; missing scale = 1; s is clamped at EFFECT_SCALE_CLAMP[name])
==========================================================================================
Friction effects modify g (Coulomb level) and f_v of the LuGre bearing law; Δθ = θ_o − 25 °C.

stribeck (clamp 10: Fs ≤ 6 Fc): g = f_c + s·0.5·f_c·φ(|q̇|/v_s) with
  exponential φ = e^(−x); gaussian φ = e^(−x²); lorentzian φ = 1/(1+x²);
  stretched φ = e^(−√x) (δ = 0.5); sech φ = 1/cosh x (own form: smooth at 0, exponential tail).
temperature_friction (clamp 10; factors clamped to [0.5, 4] on Coulomb, [0.25, 4] on viscous):
  additive       f_c(1 − 0.004 s Δθ), f_v(1 − 0.012 s Δθ)   (Stribeck excess scales with f_c)
  exponential    all friction × exp(−0.010 s Δθ)
  viscous_vogel  f_v × exp(s·300 K·(1/(θ_o + 95) − 1/120))   (Coulomb unchanged)
load_dependent_friction (clamp 13: μ ≤ 0.195): |T| the transmitted torque
  coulomb          g += 0.015 s |T|
  coulomb_viscous  g += 0.015 s |T|,  f_v × (1 + 0.25 s |T|/120 kN·m)
asymmetric_friction (clamp 10): H = ½(1 + tanh(σ q̇/5e-5)), σ = ±1 from the seed
  coulomb  g × (1 + 0.25 s H);  viscous  f_v × (1 + 0.25 s H);  both.
gear_ripple (clamp 20), phases φ_i from the seed:
  output_harmonics  τ_dist += 400 s [sin(120 q + φ1) + 0.45 sin(240 q + φ2) + 0.2 sin(360 q + φ3)]
  motor_stage       τ_dist += 350 s [sin(275 u + φ1) + 0.3 sin(550 u + φ2)]   (2 cycles per turn
                    of an intermediate shaft turning 137.5× the output; the final stage's mesh
                    reaction on the output carrier)
  kinematic         transmission error inside the reducer: Δ_b = Δ − ε(u),
                    ε = 1.5e-4 s [sin(60 u + φ1) + 0.35 sin(120 u + φ2)] rad
backlash (clamp 20: b ≤ 3e-3 rad), b = 1.5e-4 s rad half-width on Δ_b; the damper acts only in
  contact (D·c·Δ̇_b, c = ∂Δ_b/∂Δ):
  sharp   Δ_b = Δ − b sgn Δ for |Δ| > b, else 0
  smooth  Δ_b = ½[(Δ−b) + √((Δ−b)² + ε²)] + ½[(Δ+b) − √((Δ+b)² + ε²)], ε = b/2
hysteresis (clamp 9: w ≤ 0.9): the elastic term becomes k[(1 − w) Δ_b + w h], w = 0.1 s,
  x_y = 1e-3 rad, h(0) = Δ_b(0):
  bouc_wen_n1  ḣ = Δ̇_b − β|Δ̇_b| h − γ Δ̇_b |h|,        β = γ = 1/(2 x_y)
  bouc_wen_n2  ḣ = Δ̇_b − β|Δ̇_b||h| h − γ Δ̇_b h²,     β = γ = 1/(2 x_y²)
  dahl         ḣ = Δ̇_b (1 − sgn(Δ̇_b) h/x_y)   (unloading slope up to 2)
  play_stack   h = mean of 5 play operators of radii (0.2, 0.6, 1.0, 1.4, 1.8) x_y
               (Prandtl–Ishlinskii)
torque_offset (clamp 30), on the torque reading only, sign from the seed:
  constant  ± 600 s N·m;   drift  ± 10 s·t N·m
time_delay (clamp 15), unstated, on the torque reading (after the anti-alias filter):
  pure  extra delay 0.030 s s;   first_order  extra PT1 with τ = 0.030 s s
Out of vocabulary (OUT_OF_VOCABULARY):
periodic_disturbance (clamp 20), f_p ~ U(0.2, 0.45) Hz and phase from the seed, on the output body:
  sine    τ_dist += 400 s sin(2π f_p t + φ)
  pulses  τ_dist += 900 s sin²(π c/0.15) for c = frac(f_p t + φ/2π) < 0.15 (pump-like pulses)
position_dependent_stiffness (clamp 6): k(q) = k (1 + 0.12 s ψ(q))
  once_per_rev  ψ = cos(q + φ);   sectors  ψ = Σ± exp(−(wrap(q ∓ q_c)/0.25)²), q_c ~ U(0.4, 1.2)
sensor_drift (clamp 30), sign from the seed:
  load_cell  load-cell zero ± 8 s·t N·m;   encoder  output-encoder reading ± 3e-6 s·t rad
second_resonance (clamp 2.5): a share 0.3 s of I moves to a body coupled to the output by
  k_2 = I_2 ω_2², c_2 = 2ζ I_2 ω_2 (the measured hub keeps I(1 − 0.3 s)):
  low_mode  f_2 = 2.2 Hz, ζ = 0.02;   high_mode  f_2 = 6.5 Hz, ζ = 0.03
The effect's size is linear in s for small s (checked in the tests to a few % on the truth).

7. Schemes (t = 0 at the start of the record; rest at q = 0 in static equilibrium)
=================================================================================
1  rest 1 s, accelerate 2 s, hold 3 s, load 40 s (S-curve 0 -> 120 kN·m), unload 40 s,
   hold 1 s, decelerate 2 s, rest 1 s: 90 s (141° of travel at 3000 r/min).
2  rest 1, accelerate 2, hold 3, 12 × (load 0.5 s S-step of 10 kN·m, hold 2 s), unload 6 s,
   hold 1, decelerate 2, rest 1: 46 s.
3  rest 1 s, excite periods × 20 s, rest 1 s. Eq. 12 with ω_f = 2π/20 s, five harmonics,
   coefficients optimised offline for the log condition number of Eq. 4's regressor with
   |q̇| ≤ 0.9 × 0.0286 rad/s; q̇ = q̈ = 0 at every period's start; q within ±0.06 rad; 7 reference
   velocity reversals per period (at each, the output sticks while the motor winds the
   transmission through 2 f_c/k, then slips and rings); scaled by ``direction``. Position control on the motor encoder.
motor_speed_rpm: 30–3000 for schemes 1, 2, None for scheme 3; temp_joint_c 15–60 °C.

8. Outputs
==========
samples: t, q, qd, u, ud, torque, torque_load, temp_joint, phase, i_m1..3, w_m1..3.
truth (at the sample instants, from the integrator state): t, q, qd, u, ud, twist (= u − q),
twist_rate (= ud − qd), torque (T at the transducer), torque_load (τ_L), torque_true and
torque_load_true (identical copies: the physical values), temp_joint (θ_o), and two extras:
qdd (q̈) and friction (F_b), with I·qdd = torque − torque_load − G(q) − friction exactly on the
nominal rig.
Seeds: ``seed`` draws the nominal parameters and the effect constants (two independent
streams; the effect constants do not depend on which effects are on); ``run`` draws only the
measurement noise and the encoder's sub-step zero.

9. Speed (this 2-core machine, one process, warm numba cache)
=============================================================
12-run campaign (schemes 1, 2 at 300 and 3000 r/min both directions, scheme 3 with periods = 3
both senses): ≈ 2.3 s at 125 Hz, 2.2 s at 40 Hz, 2.7 s at 1 kHz; first compilation ≈ 8–10 s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import lru_cache

import numpy as np
import pandas as pd
from numba import njit

# numba's on-disk cache only when imported under the package name (brief's rule)
_CACHE = __name__ == "validation_rigs.rig_j"

# --------------------------------------------------------------------------------------
# Contract constants
# --------------------------------------------------------------------------------------
SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "validation-rig-J"

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "stretched", "sech"),
    "temperature_friction": ("additive", "exponential", "viscous_vogel"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous"),
    "asymmetric_friction": ("coulomb", "viscous", "both"),
    "gear_ripple": ("output_harmonics", "motor_stage", "kinematic"),
    "backlash": ("sharp", "smooth"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "play_stack"),
    "torque_offset": ("constant", "drift"),
    "time_delay": ("pure", "first_order"),
    "periodic_disturbance": ("sine", "pulses"),
    "position_dependent_stiffness": ("once_per_rev", "sectors"),
    "sensor_drift": ("load_cell", "encoder"),
    "second_resonance": ("low_mode", "high_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance",
    "position_dependent_stiffness",
    "sensor_drift",
    "second_resonance",
)
# scale above which the effect stops growing (physically absurd beyond); see docstring
EFFECT_SCALE_CLAMP: dict[str, float] = {
    "stribeck": 10.0,
    "temperature_friction": 10.0,
    "load_dependent_friction": 13.0,
    "asymmetric_friction": 10.0,
    "gear_ripple": 20.0,
    "backlash": 20.0,
    "hysteresis": 9.0,
    "torque_offset": 30.0,
    "time_delay": 15.0,
    "periodic_disturbance": 20.0,
    "position_dependent_stiffness": 6.0,
    "sensor_drift": 30.0,
    "second_resonance": 2.5,
}
PHASES: tuple[str, ...] = ("rest", "accelerate", "hold", "load", "unload", "decelerate", "excite")

G_ACC = 9.81
RATED_TORQUE = 120_000.0
MOTOR_TOP_RPM = 3000.0

# ---- effect magnitudes at scale 1 (see the docstring's effect table)
STR_RATIO = 0.5          # (Fs - Fc)/Fc per unit scale
TF_REF_C = 25.0          # reference temperature of the friction laws [degC]
TF_ADD_C = -0.004        # additive: dFc/Fc per K per unit scale
TF_ADD_V = -0.012        # additive: dFv/Fv per K per unit scale
TF_EXP_B = 0.010         # multiplicative: exp(-s b (theta - ref)) [1/K]
TF_VOGEL_B = 300.0       # Vogel: exp(s B (1/(theta+C) - 1/(ref+C))) [K]
TF_VOGEL_C = 95.0        # [K]
LD_MU = 0.015            # Coulomb += s mu |T|
LD_NU = 0.25             # viscous *= 1 + s nu |T|/T_rated
AS_C = 0.25              # Coulomb level raised by s*0.25 on one side
AS_V = 0.25              # viscous slope raised by s*0.25 on one side
AS_VH = 5.0e-5           # tanh width of the side switch [rad/s]
GR_A_OUT = 400.0         # output-angle ripple, first harmonic [N m]
GR_Z_OUT = 120.0         # cycles per output revolution
GR_A_MOT = 350.0         # intermediate-stage ripple [N m]
GR_Z_MOT = 275.0         # cycles per output revolution (2 per intermediate-shaft turn)
GR_E_KIN = 1.5e-4        # kinematic error amplitude [rad]
GR_Z_KIN = 60.0          # cycles per output revolution
BL_B = 1.5e-4            # backlash half-width [rad]
HY_W = 0.10              # hysteretic share of the stiffness per unit scale
HY_XY = 1.0e-3           # hysteretic (yield) twist [rad]
TO_C = 600.0             # constant torque offset [N m]
TO_R = 10.0              # torque offset drift rate [N m/s]
TD_D = 0.030             # pure delay [s]
TD_TAU = 0.030           # first-order lag [s]
PD_A_SINE = 400.0        # periodic disturbance amplitude [N m]
PD_A_PULSE = 900.0       # pulse peak [N m]
PD_DUTY = 0.15           # pulse duty
PS_EPS = 0.12            # relative stiffness variation per unit scale
PS_WIDTH = 0.25          # sector half-width [rad]
SD_LOAD = 8.0            # load-cell zero drift [N m/s]
SD_ENC = 3.0e-6          # output-encoder drift [rad/s]
SR_LOW = (0.3, 2.2, 0.02)    # (share of I moved to the mode per unit scale, f [Hz], damping ratio)
SR_HIGH = (0.3, 6.5, 0.03)

# ---- scheme 3 excitation: Eq. 12, fifth order, period 20 s (coefficients optimised
# offline for the log condition number of Eq. 4's regressor; a5 and b5 follow from
# qd(0) = 0 and qdd(0) = 0 so every period starts and ends at rest)
FOURIER_PERIOD_S = 20.0
_FA4 = (-0.00553774, -0.00103475, 0.00782175, 0.00290108)
_FB4 = (0.00524227, -0.01634055, 0.0047915, -0.00163151)

# --------------------------------------------------------------------------------------
# index tables (module ints are compile-time constants for numba)
# --------------------------------------------------------------------------------------
(P_I, P_MRX, P_MRY, P_G, P_FV, P_FC, P_SIG0, P_SIG1, P_K, P_D, P_JU, P_MUG, P_FCG, P_CVG,
 P_WEPS, P_KPW, P_KIW, P_TAUI, P_TAUW, P_TMAX, P_KV, P_JDY, P_KC, P_DC, P_CVDY, P_FCDY,
 P_KPDY, P_KIDY, P_TAUDY, P_COIL, P_CH, P_GOH, P_GHA, P_THAMB, P_SCHEME, P_WSET, P_TA0,
 P_TA1, P_TD0, P_TD1, P_WF, P_TE0, P_TE1, P_DIR, P_U0, P_VS, P_JUCAT, P_FCNOM, NP) = range(49)

(Y_Q, Y_QD, Y_U, Y_UD, Y_Z, Y_X, Y_XI, Y_TEM, Y_WF, Y_QDY, Y_QDDY, Y_XID, Y_TDM, Y_THO,
 Y_THH, Y_Q2, Y_QD2, NY) = range(18)

(A_TS, A_TL, A_QDD, A_FB, A_FG, A_DB, A_DIST, NA) = range(8)

(E_STR_ON, E_STR_FORM, E_STR_AMP,
 E_TF_ON, E_TF_FORM, E_TF_S,
 E_LD_ON, E_LD_FORM, E_LD_S,
 E_AS_ON, E_AS_FORM, E_AS_S, E_AS_SIDE,
 E_GR_ON, E_GR_FORM, E_GR_AMP, E_GR_PH1, E_GR_PH2, E_GR_PH3,
 E_BL_ON, E_BL_FORM, E_BL_B,
 E_HY_ON, E_HY_FORM, E_HY_W, E_HY_XY,
 E_PD_ON, E_PD_FORM, E_PD_AMP, E_PD_F, E_PD_PH,
 E_PS_ON, E_PS_FORM, E_PS_EPS, E_PS_PH, E_PS_QC,
 E_SR_ON, E_SR_FORM, E_SR_I2, E_SR_K2, E_SR_C2,
 NE) = range(42)

N_PLAY = 5


# --------------------------------------------------------------------------------------
# numba kernels
# --------------------------------------------------------------------------------------
@njit(cache=_CACHE)
def _wrap(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=_CACHE)
def _elastic(q, qd, u, ud, E):
    """Elastic coordinate of the transmission and its rate, after the kinematic error
    and the backlash; returns (db, dbd)."""
    dlt = u - q
    dltd = ud - qd
    if E[E_GR_ON] > 0.0 and E[E_GR_FORM] == 2.0:
        amp = E[E_GR_AMP]
        a1 = GR_Z_KIN * u + E[E_GR_PH1]
        a2 = 2.0 * GR_Z_KIN * u + E[E_GR_PH2]
        dlt -= amp * (math.sin(a1) + 0.35 * math.sin(a2))
        dltd -= amp * GR_Z_KIN * (math.cos(a1) + 0.70 * math.cos(a2)) * ud
    if E[E_BL_ON] > 0.0:
        b = E[E_BL_B]
        if E[E_BL_FORM] == 0.0:
            if dlt > b:
                return dlt - b, dltd
            elif dlt < -b:
                return dlt + b, dltd
            else:
                return 0.0, 0.0
        eps = 0.5 * b
        r1 = math.sqrt((dlt - b) * (dlt - b) + eps * eps)
        r2 = math.sqrt((dlt + b) * (dlt + b) + eps * eps)
        db = 0.5 * ((dlt - b) + r1) + 0.5 * ((dlt + b) - r2)
        c = 0.5 * (1.0 + (dlt - b) / r1) + 0.5 * (1.0 - (dlt + b) / r2)
        return db, c * dltd
    return dlt, dltd


@njit(cache=_CACHE)
def _stiffness(q, P, E):
    k = P[P_K]
    if E[E_PS_ON] > 0.0:
        eps = E[E_PS_EPS]
        if E[E_PS_FORM] == 0.0:
            k *= 1.0 + eps * math.cos(q + E[E_PS_PH])
        else:
            w1 = _wrap(q - E[E_PS_QC]) / PS_WIDTH
            w2 = _wrap(q + E[E_PS_QC]) / PS_WIDTH
            k *= 1.0 + eps * (math.exp(-w1 * w1) + math.exp(-w2 * w2))
    return k


@njit(cache=_CACHE)
def _spring(q, db, dbd, x, ply, P, E):
    """Transmitted torque at the transducer."""
    k = _stiffness(q, P, E)
    el = db
    if E[E_HY_ON] > 0.0:
        w = E[E_HY_W]
        if E[E_HY_FORM] == 3.0:
            xy = E[E_HY_XY]
            hs = 0.0
            for i in range(N_PLAY):
                r = xy * (0.2 + 0.4 * i)
                yi = ply[i]
                if yi < db - r:
                    yi = db - r
                elif yi > db + r:
                    yi = db + r
                hs += yi
            hv = hs / N_PLAY
        else:
            hv = x
        el = (1.0 - w) * db + w * hv
    return k * el + P[P_D] * dbd


@njit(cache=_CACHE)
def _disturbance(t, q, u, E):
    """Effect torques acting on the output body downstream of the transducer
    (ripple, periodic disturbance); the second-resonance reaction is added by the caller."""
    d = 0.0
    if E[E_GR_ON] > 0.0:
        f = E[E_GR_FORM]
        amp = E[E_GR_AMP]
        if f == 0.0:
            a = GR_Z_OUT * q
            d += amp * (math.sin(a + E[E_GR_PH1]) + 0.45 * math.sin(2.0 * a + E[E_GR_PH2])
                        + 0.20 * math.sin(3.0 * a + E[E_GR_PH3]))
        elif f == 1.0:
            a = GR_Z_MOT * u
            d += amp * (math.sin(a + E[E_GR_PH1]) + 0.30 * math.sin(2.0 * a + E[E_GR_PH2]))
    if E[E_PD_ON] > 0.0:
        fr = E[E_PD_F]
        if E[E_PD_FORM] == 0.0:
            d += E[E_PD_AMP] * math.sin(2.0 * math.pi * fr * t + E[E_PD_PH])
        else:
            c = fr * t + E[E_PD_PH] / (2.0 * math.pi)
            c = c - math.floor(c)
            if c < PD_DUTY:
                s = math.sin(math.pi * c / PD_DUTY)
                d += E[E_PD_AMP] * s * s
    return d


@njit(cache=_CACHE)
def _stribeck_shape(x, form):
    if form == 0.0:
        return math.exp(-x)
    elif form == 1.0:
        return math.exp(-x * x)
    elif form == 2.0:
        return 1.0 / (1.0 + x * x)
    elif form == 3.0:
        return math.exp(-math.sqrt(x))
    else:
        return 1.0 / math.cosh(min(x, 700.0))


@njit(cache=_CACHE)
def _piecewise(t, xs, ys):
    """Set-point generator: cosine (S-curve) transitions between breakpoints."""
    n = xs.size
    if t <= xs[0]:
        return ys[0]
    if t >= xs[n - 1]:
        return ys[n - 1]
    for i in range(n - 1):
        if t < xs[i + 1]:
            a = (t - xs[i]) / (xs[i + 1] - xs[i])
            return ys[i] + 0.5 * (1.0 - math.cos(math.pi * a)) * (ys[i + 1] - ys[i])
    return ys[n - 1]


@njit(cache=_CACHE)
def _fourier(t, P, FA):
    """Eq. 12 trajectory (position, velocity, acceleration) of the excite phase."""
    te0 = P[P_TE0]
    if t <= te0 or t >= P[P_TE1]:
        return 0.0, 0.0, 0.0
    tau = t - te0
    wf = P[P_WF]
    q = FA[10]
    qd = 0.0
    qdd = 0.0
    for l in range(1, 6):
        a = FA[l - 1]
        b = FA[4 + l]
        wl = wf * l
        s = math.sin(wl * tau)
        c = math.cos(wl * tau)
        q += a / wl * s - b / wl * c
        qd += a * c + b * s
        qdd += -a * wl * s + b * wl * c
    return q, qd, qdd


@njit(cache=_CACHE)
def _speed_ref(t, P):
    w = P[P_WSET]
    ta0 = P[P_TA0]
    ta1 = P[P_TA1]
    td0 = P[P_TD0]
    td1 = P[P_TD1]
    if t < ta0 or t >= td1:
        return 0.0, 0.0
    if t < ta1:
        s = (t - ta0) / (ta1 - ta0)
        return (w * 0.5 * (1.0 - math.cos(math.pi * s)),
                w * 0.5 * math.pi / (ta1 - ta0) * math.sin(math.pi * s))
    if t < td0:
        return w, 0.0
    s = (t - td0) / (td1 - td0)
    return (w * 0.5 * (1.0 + math.cos(math.pi * s)),
            -w * 0.5 * math.pi / (td1 - td0) * math.sin(math.pi * s))


@njit(cache=_CACHE)
def _rhs(t, y, ply, P, E, FA, LT, LV, dy, aux):
    q = y[Y_Q]
    qd = y[Y_QD]
    u = y[Y_U]
    ud = y[Y_UD]
    scheme = P[P_SCHEME]

    # ---------------- transmission (transducer torque)
    db, dbd = _elastic(q, qd, u, ud, E)
    ts = _spring(q, db, dbd, y[Y_X], ply, P, E)
    if E[E_HY_ON] > 0.0 and E[E_HY_FORM] != 3.0:
        xy = E[E_HY_XY]
        x = y[Y_X]
        f = E[E_HY_FORM]
        if f == 0.0:
            dy[Y_X] = dbd - (0.5 / xy) * (abs(dbd) * x + dbd * abs(x))
        elif f == 1.0:
            dy[Y_X] = dbd - (0.5 / (xy * xy)) * (abs(dbd) * abs(x) * x + dbd * x * x)
        else:
            dy[Y_X] = dbd - abs(dbd) * x / xy
    else:
        dy[Y_X] = 0.0

    # ---------------- output bearing friction (LuGre with effect-modified levels)
    fc = P[P_FC]
    fv = P[P_FV]
    amp = 0.0
    if E[E_STR_ON] > 0.0:
        amp = E[E_STR_AMP]
    if E[E_TF_ON] > 0.0:
        th = y[Y_THO]
        s = E[E_TF_S]
        dth = th - TF_REF_C
        f = E[E_TF_FORM]
        if f == 0.0:
            ffc = 1.0 + s * TF_ADD_C * dth
            ffv = 1.0 + s * TF_ADD_V * dth
        elif f == 1.0:
            ffc = math.exp(-s * TF_EXP_B * dth)
            ffv = ffc
        else:
            ffc = 1.0
            ffv = math.exp(s * TF_VOGEL_B * (1.0 / (th + TF_VOGEL_C) - 1.0 / (TF_REF_C + TF_VOGEL_C)))
        ffc = min(max(ffc, 0.5), 4.0)
        ffv = min(max(ffv, 0.25), 4.0)
        fc *= ffc
        amp *= ffc
        fv *= ffv
    if E[E_LD_ON] > 0.0:
        s = E[E_LD_S]
        fc += s * LD_MU * abs(ts)
        if E[E_LD_FORM] == 1.0:
            fv *= 1.0 + s * LD_NU * abs(ts) / RATED_TORQUE
    if E[E_AS_ON] > 0.0:
        hside = 0.5 * (1.0 + math.tanh(E[E_AS_SIDE] * qd / AS_VH))
        s = E[E_AS_S]
        f = E[E_AS_FORM]
        if f != 1.0:
            fc *= 1.0 + s * AS_C * hside
            amp *= 1.0 + s * AS_C * hside
        if f != 0.0:
            fv *= 1.0 + s * AS_V * hside
    g = fc
    if amp > 0.0:
        g += amp * _stribeck_shape(abs(qd) / P[P_VS], E[E_STR_FORM])
    gmin = 0.5 * P[P_FCNOM]
    if g < gmin:
        g = gmin
    z = y[Y_Z]
    sig0 = P[P_SIG0]
    zd = qd - sig0 * abs(qd) * z / g
    fb = sig0 * z + P[P_SIG1] * zd + fv * qd
    dy[Y_Z] = zd

    # ---------------- effect torques on the output body
    dist = _disturbance(t, q, u, E)
    if E[E_SR_ON] > 0.0:
        rel = E[E_SR_K2] * (q - y[Y_Q2]) + E[E_SR_C2] * (qd - y[Y_QD2])
        dist += rel
        dy[Y_Q2] = y[Y_QD2]
        dy[Y_QD2] = rel / E[E_SR_I2]
        inertia = P[P_I] - E[E_SR_I2]
    else:
        dy[Y_Q2] = 0.0
        dy[Y_QD2] = 0.0
        inertia = P[P_I]

    # ---------------- loading device (dynamometer + compliant loading shaft)
    if scheme != 3.0:
        tl = P[P_KC] * (q - y[Y_QDY]) + P[P_DC] * (qd - y[Y_QDDY])
        tcmd = _piecewise(t, LT, LV)
        el = tcmd - tl
        tdm_c = -(tcmd + P[P_KPDY] * el + y[Y_XID])
        dy[Y_XID] = P[P_KIDY] * el
        dy[Y_TDM] = (tdm_c - y[Y_TDM]) / P[P_TAUDY]
        vdy = y[Y_QDDY]
        dy[Y_QDY] = vdy
        dy[Y_QDDY] = (tl + y[Y_TDM] - P[P_CVDY] * vdy
                      - P[P_FCDY] * math.tanh(vdy / P[P_WEPS])) / P[P_JDY]
    else:
        tl = 0.0
        dy[Y_XID] = 0.0
        dy[Y_TDM] = 0.0
        dy[Y_QDY] = 0.0
        dy[Y_QDDY] = 0.0

    # ---------------- output body: I qdd = T - tau_L - G(q) - F - dist
    grav = P[P_G] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    qdd = (ts - tl - grav - fb - dist) / inertia
    dy[Y_Q] = qd
    dy[Y_QD] = qdd

    # ---------------- motor side (three motors, output-referred) and gear losses
    fg = (P[P_MUG] * abs(ts) + P[P_FCG]) * math.tanh(ud / P[P_WEPS]) + P[P_CVG] * ud
    dy[Y_U] = ud
    dy[Y_UD] = (y[Y_TEM] - ts - fg) / P[P_JU]

    # ---------------- drive: position (scheme 3) / speed PI / current loop
    if scheme == 3.0:
        qf, qfd, qfdd = _fourier(t, P, FA)
        dr = P[P_DIR]
        ur = P[P_U0] + dr * qf
        wref = dr * qfd + P[P_KV] * (ur - u)
        aff = dr * qfdd
    else:
        wref, aff = _speed_ref(t, P)
    ew = wref - y[Y_WF]
    tc = P[P_KPW] * ew + y[Y_XI] + P[P_JUCAT] * aff
    tmax = P[P_TMAX]
    dxi = P[P_KIW] * ew
    if tc > tmax:
        tc = tmax
        if dxi > 0.0:
            dxi = 0.0
    elif tc < -tmax:
        tc = -tmax
        if dxi < 0.0:
            dxi = 0.0
    dy[Y_XI] = dxi
    dy[Y_TEM] = (tc - y[Y_TEM]) / P[P_TAUI]
    dy[Y_WF] = (ud - y[Y_WF]) / P[P_TAUW]

    # ---------------- thermal: oil/mesh node and housing node
    tho = y[Y_THO]
    thh = y[Y_THH]
    ploss = abs(fb * qd) + abs(fg * ud)
    q_oh = P[P_GOH] * (tho - thh)
    dy[Y_THO] = (ploss - q_oh) / P[P_COIL]
    dy[Y_THH] = (q_oh - P[P_GHA] * (thh - P[P_THAMB])) / P[P_CH]

    aux[A_TS] = ts
    aux[A_TL] = tl
    aux[A_QDD] = qdd
    aux[A_FB] = fb
    aux[A_FG] = fg
    aux[A_DB] = db
    aux[A_DIST] = dist


@njit(cache=_CACHE)
def _static_residual(u, P, E, t0):
    db, dbd = _elastic(0.0, 0.0, u, 0.0, E)
    ts = _stiffness(0.0, P, E) * db
    grav = P[P_G] * P[P_MRY]
    return ts - grav - _disturbance(t0, 0.0, u, E), ts, db


@njit(cache=_CACHE)
def _initial_twist(P, E):
    """Motor-side angle u0 that holds the output at rest at q = 0 (bisection)."""
    lo = -0.05
    hi = 0.05
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        r, ts, db = _static_residual(mid, P, E, 0.0)
        if r > 0.0:
            hi = mid
        else:
            lo = mid
    u0 = 0.5 * (lo + hi)
    r, ts, db = _static_residual(u0, P, E, 0.0)
    return u0, ts, db


@njit(cache=_CACHE)
def _integrate(P, E, FA, LT, LV, y0, ply0, nf, M, h,
               f_ts, f_tl, f_q, f_qd, f_u, f_ud, f_tem, f_tho, s_qdd, s_fb):
    """Fixed-step classical RK4 over nf fine points (step h); fine-grid records at every
    step, acceleration and friction at every M-th (sample) step. Returns -1 or the index
    of the first non-finite step."""
    y = y0.copy()
    ply = ply0.copy()
    k1 = np.empty(NY)
    k2 = np.empty(NY)
    k3 = np.empty(NY)
    k4 = np.empty(NY)
    yt = np.empty(NY)
    aux = np.empty(NA)
    dummy = np.empty(NA)
    play = E[E_HY_ON] > 0.0 and E[E_HY_FORM] == 3.0
    xy = E[E_HY_XY]
    for j in range(nf):
        t = j * h
        _rhs(t, y, ply, P, E, FA, LT, LV, k1, aux)
        f_ts[j] = aux[A_TS]
        f_tl[j] = aux[A_TL]
        f_q[j] = y[Y_Q]
        f_qd[j] = y[Y_QD]
        f_u[j] = y[Y_U]
        f_ud[j] = y[Y_UD]
        f_tem[j] = y[Y_TEM]
        f_tho[j] = y[Y_THO]
        if j % M == 0:
            s_qdd[j // M] = aux[A_QDD]
            s_fb[j // M] = aux[A_FB]
        ok = True
        for i in range(NY):
            if not math.isfinite(y[i]):
                ok = False
        if not (ok and math.isfinite(aux[A_TS]) and math.isfinite(aux[A_QDD])):
            return j
        if j == nf - 1:
            break
        for i in range(NY):
            yt[i] = y[i] + 0.5 * h * k1[i]
        _rhs(t + 0.5 * h, yt, ply, P, E, FA, LT, LV, k2, dummy)
        for i in range(NY):
            yt[i] = y[i] + 0.5 * h * k2[i]
        _rhs(t + 0.5 * h, yt, ply, P, E, FA, LT, LV, k3, dummy)
        for i in range(NY):
            yt[i] = y[i] + h * k3[i]
        _rhs(t + h, yt, ply, P, E, FA, LT, LV, k4, dummy)
        for i in range(NY):
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if play:
            db, dbd = _elastic(y[Y_Q], y[Y_QD], y[Y_U], y[Y_UD], E)
            for i in range(N_PLAY):
                r = xy * (0.2 + 0.4 * i)
                if ply[i] < db - r:
                    ply[i] = db - r
                elif ply[i] > db + r:
                    ply[i] = db + r
    return -1


@njit(cache=_CACHE)
def _lti_foh(uin, phi, ga, gb, cv, x0, h):
    """Exact response of a small LTI filter to a piecewise-linear input on the fine grid."""
    n = uin.size
    ns = x0.size
    x = x0.copy()
    xn = np.empty(ns)
    out = np.empty(n)
    acc = 0.0
    for i in range(ns):
        acc += cv[i] * x[i]
    out[0] = acc
    for j in range(n - 1):
        du = (uin[j + 1] - uin[j]) / h
        for i in range(ns):
            a = ga[i] * uin[j] + gb[i] * du
            for m in range(ns):
                a += phi[i, m] * x[m]
            xn[i] = a
        acc = 0.0
        for i in range(ns):
            x[i] = xn[i]
            acc += cv[i] * x[i]
        out[j + 1] = acc
    return out


@njit(cache=_CACHE)
def _interp_lin(arr, h, tq):
    n = arr.size
    out = np.empty(tq.size)
    for i in range(tq.size):
        s = tq[i] / h
        if s <= 0.0:
            out[i] = arr[0]
            continue
        j = int(math.floor(s))
        if j >= n - 1:
            out[i] = arr[n - 1]
            continue
        fr = s - j
        out[i] = arr[j] + fr * (arr[j + 1] - arr[j])
    return out


@njit(cache=_CACHE)
def _interp_hermite(yv, yd, h, tq):
    n = yv.size
    out = np.empty(tq.size)
    for i in range(tq.size):
        s = tq[i] / h
        if s <= 0.0:
            out[i] = yv[0]
            continue
        j = int(math.floor(s))
        if j >= n - 1:
            out[i] = yv[n - 1]
            continue
        x = s - j
        if x == 0.0:
            out[i] = yv[j]
            continue
        x2 = x * x
        x3 = x2 * x
        out[i] = ((2 * x3 - 3 * x2 + 1) * yv[j] + (x3 - 2 * x2 + x) * h * yd[j]
                  + (-2 * x3 + 3 * x2) * yv[j + 1] + (x3 - x2) * h * yd[j + 1])
    return out


# --------------------------------------------------------------------------------------
# small numerics on the Python side
# --------------------------------------------------------------------------------------
def _expm(a: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring of a degree-20 Taylor series."""
    nrm = float(np.abs(a).sum(axis=1).max())
    s = max(0, int(math.ceil(math.log2(nrm))) + 1) if nrm > 0.5 else 0
    b = a / (2.0 ** s)
    e = np.eye(a.shape[0])
    term = np.eye(a.shape[0])
    for k in range(1, 21):
        term = term @ b / k
        e = e + term
    for _ in range(s):
        e = e @ e
    return e


def _foh_discretise(a: np.ndarray, b: np.ndarray, h: float):
    """(Phi, Gamma_u, Gamma_rate) for x' = A x + B u with u linear over each step."""
    ns = a.shape[0]
    m = np.zeros((ns + 2, ns + 2))
    m[:ns, :ns] = a
    m[:ns, ns] = b
    m[ns, ns + 1] = 1.0
    e = _expm(m * h)
    return e[:ns, :ns].copy(), e[:ns, ns].copy(), e[:ns, ns + 1].copy()


def _bessel2(uin: np.ndarray, w0: float, h: float) -> np.ndarray:
    """Second-order Bessel low-pass H = 3 w0^2/(s^2 + 3 w0 s + 3 w0^2) (DC delay 1/w0),
    started in steady state."""
    a = np.array([[0.0, 1.0], [-3.0 * w0 * w0, -3.0 * w0]])
    b = np.array([0.0, 3.0 * w0 * w0])
    phi, ga, gb = _foh_discretise(a, b, h)
    return _lti_foh(uin, phi, ga, gb, np.array([1.0, 0.0]), np.array([uin[0], 0.0]), h)


def _pt1(uin: np.ndarray, tau: float, h: float) -> np.ndarray:
    if tau <= 0.0:
        return uin.copy()
    phi, ga, gb = _foh_discretise(np.array([[-1.0 / tau]]), np.array([1.0 / tau]), h)
    return _lti_foh(uin, phi, ga, gb, np.array([1.0]), np.array([uin[0]]), h)


# --------------------------------------------------------------------------------------
# sensors, runs, parameters
# --------------------------------------------------------------------------------------
@dataclass
class SensorSpec:
    """What a data sheet / DAQ configuration states (SI units, degC)."""
    sample_rate_hz: float = 1000.0      # DAQ sample rate (all channels, synchronous)
    encoder_res_deg: float = 0.01       # output absolute encoder step
    torque_noise: float = 150.0         # white noise s.d. of the torque reading [N m]
    torque_lag_s: float = 0.0           # stated pure latency of the torque reading [s]
    load_noise: float = 200.0           # white noise s.d. of the load-cell reading [N m]
    adc_full_scale: float = 2.0e5       # torque / load-cell ADC range +-[N m]
    adc_bits: int = 16                  # ADC resolution (step = 2 FS / 2**bits)
    aa_fraction: float = 0.25           # anti-alias -3 dB frequency as a fraction of fs
    aa_max_hz: float = 200.0            # ... capped at this (fixed amplifier filter)
    velocity_window_s: float = 0.1      # qd = encoder difference over this window / window
    motor_encoder_bits: int = 22        # motor encoder counts per motor revolution (log2)
    u_latency_s: float = 0.001          # motor position actual value latency [s]
    speed_filter_s: float = 0.004       # drive's speed actual value smoothing (PT1) [s]
    speed_noise: float = 0.02           # motor speed reading noise s.d. [rad/s, motor side]
    speed_ref_rpm: float = 6000.0       # PROFIdrive N2 reference speed (0x4000)
    current_filter_s: float = 0.004     # drive's current actual value smoothing (PT1) [s]
    current_noise: float = 0.03         # current reading noise s.d. [A]
    current_ref_a: float = 20.0         # PROFIdrive N2 reference current (0x4000)
    temp_tau_s: float = 20.0            # RTD in thermowell, first-order time constant [s]
    temp_noise: float = 0.02            # [degC]
    temp_res_c: float = 0.1             # [degC]


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


_SENSOR_RANGES = {
    "sample_rate_hz": (1.0, 2000.0),
    "encoder_res_deg": (1e-5, 1.0),
    "torque_noise": (0.0, 1e5),
    "torque_lag_s": (0.0, 2.0),
    "load_noise": (0.0, 1e5),
    "adc_full_scale": (1e3, 1e7),
    "adc_bits": (8, 32),
    "aa_fraction": (1e-3, 0.5),
    "aa_max_hz": (0.1, 1e5),
    "velocity_window_s": (1e-3, 5.0),
    "motor_encoder_bits": (8, 40),
    "u_latency_s": (0.0, 0.1),
    "speed_filter_s": (0.0, 1.0),
    "speed_noise": (0.0, 1e3),
    "speed_ref_rpm": (1.0, 1e5),
    "current_filter_s": (0.0, 1.0),
    "current_noise": (0.0, 1e3),
    "current_ref_a": (1e-3, 1e5),
    "temp_tau_s": (0.0, 3600.0),
    "temp_noise": (0.0, 10.0),
    "temp_res_c": (1e-4, 10.0),
}
_INT_SENSOR_FIELDS = ("adc_bits", "motor_encoder_bits")


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _check_sensors(sensors) -> None:
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(sensors).__name__}")
    for f in fields(SensorSpec):
        v = getattr(sensors, f.name)
        lo, hi = _SENSOR_RANGES[f.name]
        if not _is_number(v) or not math.isfinite(float(v)):
            raise ValueError(f"sensors.{f.name} must be a finite number, got {v!r}")
        if f.name in _INT_SENSOR_FIELDS and float(v) != int(v):
            raise ValueError(f"sensors.{f.name} must be an integer, got {v!r}")
        if not (lo <= float(v) <= hi):
            raise ValueError(f"sensors.{f.name}={v!r} outside [{lo}, {hi}]")


def _check_int(name: str, v, lo: int, hi: int | None = None) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    v = int(v)
    if v < lo or (hi is not None and v > hi):
        raise ValueError(f"{name}={v} out of range")
    return v


def _normalise_effects(effects) -> dict[str, tuple[int, float]]:
    """{name: (form index, clamped scale)} for the effects with a non-zero scale."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict, got {type(effects).__name__}")
    out: dict[str, tuple[int, float]] = {}
    for name, spec in effects.items():
        if not isinstance(name, str) or name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}")
        if not isinstance(spec, dict):
            raise ValueError(f"effect {name!r}: spec must be a dict with 'form' and 'scale'")
        for key in spec:
            if key not in ("form", "scale"):
                raise ValueError(f"effect {name!r}: unknown key {key!r}")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if not isinstance(form, str) or form not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r}: unknown form {form!r}")
        scale = spec.get("scale", 1.0)
        if not _is_number(scale):
            raise ValueError(f"effect {name!r}: scale must be a number, got {scale!r}")
        scale = float(scale)
        if not math.isfinite(scale) or scale < 0.0:
            raise ValueError(f"effect {name!r}: scale must be finite and >= 0, got {scale!r}")
        if scale == 0.0:
            continue
        out[name] = (EFFECT_FORMS[name].index(form), min(scale, EFFECT_SCALE_CLAMP[name]))
    return out


def _draw(rng, nominal: float, rel_sd: float = 0.025, clip: float = 0.06) -> float:
    return float(nominal * (1.0 + np.clip(rng.normal(0.0, rel_sd), -clip, clip)))


@lru_cache(maxsize=64)
def _campaign(seed: int) -> tuple:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x4A4A]))
    p = {}
    p["I"] = _draw(rng, 6685.0)
    p["mr_x"] = _draw(rng, 20.78, 0.04, 0.08)
    p["mr_y"] = _draw(rng, -34.54, 0.04, 0.08)
    p["f_v"] = _draw(rng, 8683.0)
    p["f_c"] = _draw(rng, 2353.0)
    p["presliding"] = _draw(rng, 2.5e-5, 0.05, 0.1)
    p["sigma1"] = _draw(rng, 5.0e4, 0.05, 0.1)
    p["k"] = _draw(rng, 1.375e7)
    p["D"] = _draw(rng, 5.0e4, 0.05, 0.1)
    p["J_u"] = _draw(rng, 6.9e5)
    p["mu_g"] = _draw(rng, 0.22)
    p["f_cg"] = _draw(rng, 1500.0, 0.05, 0.1)
    p["c_g"] = _draw(rng, 3.0e4, 0.05, 0.1)
    p["J_dy"] = _draw(rng, 1.5e4)
    p["k_c"] = _draw(rng, 6.0e7)
    p["d_c"] = _draw(rng, 1.5e5, 0.05, 0.1)
    p["c_dy"] = _draw(rng, 2.0e4, 0.05, 0.1)
    p["f_cdy"] = _draw(rng, 1200.0, 0.05, 0.1)
    p["C_oil"] = _draw(rng, 3.0e4)
    p["C_h"] = _draw(rng, 6.0e5)
    p["G_oh"] = _draw(rng, 60.0)
    p["G_ha"] = _draw(rng, 30.0)
    p["theta_amb"] = float(21.0 + np.clip(rng.normal(0.0, 1.5), -3.0, 3.0))
    p["v_s"] = _draw(rng, 2.0e-3, 0.04, 0.08)
    p["k_t"] = tuple(_draw(rng, 1.75, 0.02, 0.05) for _ in range(3))
    p["i_gain"] = tuple(_draw(rng, 1.0, 0.01, 0.03) for _ in range(3))
    p["i_offset"] = tuple(float(np.clip(rng.normal(0.0, 0.02), -0.05, 0.05)) for _ in range(3))
    p["ecc_amp"] = _draw(rng, math.radians(0.001), 0.1, 0.2)
    p["ecc_phase"] = float(rng.uniform(0.0, 2.0 * math.pi))
    # effect constants (one stream, fixed order: independent of which effects are on)
    r2 = np.random.default_rng(np.random.SeedSequence([seed, 0x4A4A, 1]))
    e = {}
    e["gr_ph"] = tuple(float(v) for v in r2.uniform(0.0, 2.0 * math.pi, 3))
    e["pd_f"] = float(r2.uniform(0.2, 0.45))
    e["pd_ph"] = float(r2.uniform(0.0, 2.0 * math.pi))
    e["as_side"] = float(r2.choice([-1.0, 1.0]))
    e["to_sign"] = float(r2.choice([-1.0, 1.0]))
    e["td_sign"] = float(r2.choice([-1.0, 1.0]))
    e["ps_ph"] = float(r2.uniform(0.0, 2.0 * math.pi))
    e["ps_qc"] = float(r2.uniform(0.4, 1.2))
    e["sd_load_sign"] = float(r2.choice([-1.0, 1.0]))
    e["sd_enc_sign"] = float(r2.choice([-1.0, 1.0]))
    return tuple(sorted(p.items())), tuple(sorted(e.items()))


def campaign_parameters(seed: int) -> dict:
    """Nominal parameters of the campaign `seed` (for tests and post-mortems)."""
    seed = _check_int("seed", seed, 0)
    return dict(_campaign(seed)[0])


def effect_constants(seed: int) -> dict:
    """Seed-drawn constants of the effects (phases, frequencies, signs)."""
    seed = _check_int("seed", seed, 0)
    return dict(_campaign(seed)[1])


def _schedule(scheme: int, periods: int):
    """Segments [(t0, t1, phase)], duration, load set-point breakpoints, speed-profile
    times (ta0, ta1, td0, td1) and the excite window (te0, te1)."""
    seg = []
    if scheme in (1, 2):
        seg += [(0.0, 1.0, "rest"), (1.0, 3.0, "accelerate"), (3.0, 6.0, "hold")]
        lt = [0.0, 6.0]
        lv = [0.0, 0.0]
        if scheme == 1:
            seg += [(6.0, 46.0, "load"), (46.0, 86.0, "unload")]
            lt += [46.0, 86.0]
            lv += [RATED_TORQUE, 0.0]
            t = 86.0
        else:
            t = 6.0
            for i in range(12):
                seg += [(t, t + 0.5, "load"), (t + 0.5, t + 2.5, "hold")]
                lt += [t + 0.5, t + 2.5]
                lv += [(i + 1) * 1.0e4, (i + 1) * 1.0e4]
                t += 2.5
            seg += [(t, t + 6.0, "unload")]
            lt += [t + 6.0]
            lv += [0.0]
            t += 6.0
        seg += [(t, t + 1.0, "hold"), (t + 1.0, t + 3.0, "decelerate"), (t + 3.0, t + 4.0, "rest")]
        dur = t + 4.0
        lt += [dur]
        lv += [0.0]
        speed = (1.0, 3.0, t + 1.0, t + 3.0)
        excite = (0.0, 0.0)
    else:
        te1 = 1.0 + FOURIER_PERIOD_S * periods
        seg = [(0.0, 1.0, "rest"), (1.0, te1, "excite"), (te1, te1 + 1.0, "rest")]
        dur = te1 + 1.0
        lt = [0.0, dur]
        lv = [0.0, 0.0]
        speed = (0.0, 0.0, 0.0, 0.0)
        excite = (1.0, te1)
    return seg, dur, np.array(lt), np.array(lv), speed, excite


def _fourier_coefficients() -> np.ndarray:
    wf = 2.0 * math.pi / FOURIER_PERIOD_S
    a = list(_FA4) + [-sum(_FA4)]
    b = list(_FB4)
    b.append(-sum((l + 1) * b[l] for l in range(4)) / 5.0)
    q0 = sum(b[l] / (wf * (l + 1)) for l in range(5))
    return np.array(a + b + [q0])


H_MAX = 5.0e-4  # largest integrator step [s]


def _build_E(eff: dict, p: dict, c: dict) -> np.ndarray:
    E = np.zeros(NE)
    if "stribeck" in eff:
        f, s = eff["stribeck"]
        E[E_STR_ON], E[E_STR_FORM], E[E_STR_AMP] = 1.0, f, s * STR_RATIO * p["f_c"]
    if "temperature_friction" in eff:
        f, s = eff["temperature_friction"]
        E[E_TF_ON], E[E_TF_FORM], E[E_TF_S] = 1.0, f, s
    if "load_dependent_friction" in eff:
        f, s = eff["load_dependent_friction"]
        E[E_LD_ON], E[E_LD_FORM], E[E_LD_S] = 1.0, f, s
    if "asymmetric_friction" in eff:
        f, s = eff["asymmetric_friction"]
        E[E_AS_ON], E[E_AS_FORM], E[E_AS_S], E[E_AS_SIDE] = 1.0, f, s, c["as_side"]
    if "gear_ripple" in eff:
        f, s = eff["gear_ripple"]
        amp = (GR_A_OUT, GR_A_MOT, GR_E_KIN)[f] * s
        E[E_GR_ON], E[E_GR_FORM], E[E_GR_AMP] = 1.0, f, amp
        E[E_GR_PH1], E[E_GR_PH2], E[E_GR_PH3] = c["gr_ph"]
    if "backlash" in eff:
        f, s = eff["backlash"]
        E[E_BL_ON], E[E_BL_FORM], E[E_BL_B] = 1.0, f, s * BL_B
    if "hysteresis" in eff:
        f, s = eff["hysteresis"]
        E[E_HY_ON], E[E_HY_FORM], E[E_HY_W], E[E_HY_XY] = 1.0, f, s * HY_W, HY_XY
    if "periodic_disturbance" in eff:
        f, s = eff["periodic_disturbance"]
        E[E_PD_ON], E[E_PD_FORM] = 1.0, f
        E[E_PD_AMP] = s * (PD_A_SINE, PD_A_PULSE)[f]
        E[E_PD_F], E[E_PD_PH] = c["pd_f"], c["pd_ph"]
    if "position_dependent_stiffness" in eff:
        f, s = eff["position_dependent_stiffness"]
        E[E_PS_ON], E[E_PS_FORM], E[E_PS_EPS] = 1.0, f, s * PS_EPS
        E[E_PS_PH], E[E_PS_QC] = c["ps_ph"], c["ps_qc"]
    if "second_resonance" in eff:
        f, s = eff["second_resonance"]
        ratio, fr, zeta = (SR_LOW, SR_HIGH)[f]
        i2 = s * ratio * p["I"]
        w2 = 2.0 * math.pi * fr
        E[E_SR_ON], E[E_SR_FORM] = 1.0, f
        E[E_SR_I2], E[E_SR_K2], E[E_SR_C2] = i2, i2 * w2 * w2, 2.0 * zeta * i2 * w2
    else:
        E[E_SR_I2] = 1.0
    return E


def _build_P(p: dict, scheme: int, rpm, direction: int, speed, excite) -> np.ndarray:
    P = np.zeros(NP)
    N = REDUCTION
    P[P_I], P[P_MRX], P[P_MRY], P[P_G] = p["I"], p["mr_x"], p["mr_y"], G_ACC
    P[P_FV], P[P_FC] = p["f_v"], p["f_c"]
    P[P_FCNOM] = p["f_c"]
    P[P_SIG0] = p["f_c"] / p["presliding"]
    P[P_SIG1] = p["sigma1"]
    P[P_K], P[P_D] = p["k"], p["D"]
    P[P_JU], P[P_MUG], P[P_FCG], P[P_CVG] = p["J_u"], p["mu_g"], p["f_cg"], p["c_g"]
    P[P_WEPS] = 2.0e-4
    # drive tuned on catalogue values (not on the drawn ones)
    jcat = 6.9e5
    wc = 40.0
    P[P_JUCAT] = jcat
    P[P_KPW] = jcat * wc
    P[P_KIW] = jcat * wc / 0.1
    P[P_TAUI] = 1.5e-3
    P[P_TAUW] = 1.0e-3
    P[P_TMAX] = 3 * 30.0 * N
    P[P_KV] = 10.0
    P[P_JDY], P[P_KC], P[P_DC] = p["J_dy"], p["k_c"], p["d_c"]
    P[P_CVDY], P[P_FCDY] = p["c_dy"], p["f_cdy"]
    P[P_KPDY], P[P_KIDY], P[P_TAUDY] = 1.5, 2.0, 5.0e-3
    P[P_COIL], P[P_CH], P[P_GOH], P[P_GHA] = p["C_oil"], p["C_h"], p["G_oh"], p["G_ha"]
    P[P_THAMB] = p["theta_amb"]
    P[P_SCHEME] = float(scheme)
    P[P_DIR] = float(direction)
    P[P_WSET] = 0.0 if rpm is None else direction * rpm * 2.0 * math.pi / 60.0 / N
    P[P_TA0], P[P_TA1], P[P_TD0], P[P_TD1] = speed
    P[P_WF] = 2.0 * math.pi / FOURIER_PERIOD_S
    P[P_TE0], P[P_TE1] = excite
    P[P_VS] = p["v_s"]
    return P


def _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, seed, sensors, periods, run):
    if isinstance(scheme, (bool, np.bool_)) or not isinstance(scheme, (int, np.integer)) \
            or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
        rpm = None
    else:
        if not _is_number(motor_speed_rpm) or not math.isfinite(float(motor_speed_rpm)) \
                or not (30.0 <= float(motor_speed_rpm) <= MOTOR_TOP_RPM):
            raise ValueError(f"motor_speed_rpm must be a number in [30, 3000] for scheme {scheme},"
                             f" got {motor_speed_rpm!r}")
        rpm = float(motor_speed_rpm)
    if not _is_number(direction) or float(direction) not in (1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    direction = int(direction)
    if not _is_number(temp_joint_c) or not math.isfinite(float(temp_joint_c)) \
            or not (15.0 <= float(temp_joint_c) <= 60.0):
        raise ValueError(f"temp_joint_c must be a number in [15, 60] degC, got {temp_joint_c!r}")
    seed = _check_int("seed", seed, 0)
    run = _check_int("run", run, 0)
    periods = _check_int("periods", periods, 1, 100)
    _check_sensors(sensors)
    return scheme, rpm, direction, float(temp_joint_c), seed, sensors, periods, run


def _quantise_floor(x, step, phase):
    return step * (np.floor(x / step + phase) - math.floor(phase))


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict, *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    """One run of the rig (see the module docstring)."""
    return _simulate(scheme, motor_speed_rpm, direction, temp_joint_c, effects, seed=seed,
                     sensors=sensors, periods=periods, run=run, h_max=H_MAX)


def _simulate(scheme, motor_speed_rpm, direction, temp_joint_c, effects, *, seed, sensors,
              periods=3, run=0, h_max=H_MAX) -> RigRun:
    scheme, rpm, direction, temp0, seed, sensors, periods, run = _check_args(
        scheme, motor_speed_rpm, direction, temp_joint_c, seed, sensors, periods, run)
    eff = _normalise_effects(effects)
    praw, craw = _campaign(seed)
    p = dict(praw)
    c = dict(craw)
    N = REDUCTION

    seg, dur, LT, LV, speed, excite = _schedule(scheme, periods)
    P = _build_P(p, scheme, rpm, direction, speed, excite)
    E = _build_E(eff, p, c)
    FA = _fourier_coefficients()

    fs = float(sensors.sample_rate_hz)
    M = max(1, int(math.ceil(1.0 / (fs * h_max) - 1e-9)))
    h = 1.0 / (fs * M)
    n = int(math.floor(dur * fs + 1e-9)) + 1
    nf = (n - 1) * M + 1
    t = np.arange(n) / fs

    # ---- initial state: output at rest at q = 0, everything in equilibrium
    u0, ts0, db0 = _initial_twist(P, E)
    P[P_U0] = u0
    y0 = np.zeros(NY)
    y0[Y_U] = u0
    y0[Y_X] = db0
    y0[Y_XI] = ts0
    y0[Y_TEM] = ts0
    y0[Y_THO] = temp0
    y0[Y_THH] = temp0
    ply0 = np.full(N_PLAY, db0)

    f_ts, f_tl, f_q, f_qd, f_u, f_ud, f_tem, f_tho = (np.empty(nf) for _ in range(8))
    s_qdd = np.empty(n)
    s_fb = np.empty(n)
    status = _integrate(P, E, FA, LT, LV, y0, ply0, nf, M, h,
                        f_ts, f_tl, f_q, f_qd, f_u, f_ud, f_tem, f_tho, s_qdd, s_fb)
    if status >= 0:
        names = sorted(eff) or ["none (nominal rig)"]
        raise RuntimeError(f"non-finite integration at t={status * h:.4f} s; active effects: "
                           f"{', '.join(names)}")

    idx = np.arange(n) * M
    q = f_q[idx]
    qd = f_qd[idx]
    u = f_u[idx]
    ud = f_ud[idx]
    ts = f_ts[idx]
    tl = f_tl[idx]
    tho = f_tho[idx]
    truth = pd.DataFrame({
        "t": t, "q": q, "qd": qd, "u": u, "ud": ud,
        "twist": u - q, "twist_rate": ud - qd,
        "torque": ts, "torque_load": tl, "torque_true": ts.copy(), "torque_load_true": tl.copy(),
        "temp_joint": tho, "qdd": s_qdd, "friction": s_fb,
    })

    # ---------------------------------------------------------------- sensor chains
    rng = np.random.default_rng(np.random.SeedSequence([seed, run, 0x52554E]))
    nz_torque = rng.standard_normal(n)
    nz_load = rng.standard_normal(n)
    nz_w = rng.standard_normal((3, n))
    nz_i = rng.standard_normal((3, n))
    nz_temp = rng.standard_normal(n)
    enc_phase = float(rng.uniform(0.0, 1.0))   # sub-step position of the encoder zero

    # anti-alias (2nd-order Bessel) of the two strain-gauge channels
    f3 = min(sensors.aa_fraction * fs, sensors.aa_max_hz)
    w0 = 2.0 * math.pi * f3 / 1.3617
    aa_delay = 1.0 / w0
    adc_step = 2.0 * sensors.adc_full_scale / 2.0 ** int(sensors.adc_bits)

    def adc(x):
        return np.clip(adc_step * np.round(x / adc_step), -sensors.adc_full_scale,
                       sensors.adc_full_scale - adc_step)

    tq_f = _bessel2(f_ts, w0, h)
    delay = float(sensors.torque_lag_s)
    if "time_delay" in eff:
        form, s = eff["time_delay"]
        if form == 0:
            delay += s * TD_D
        else:
            tq_f = _pt1(tq_f, s * TD_TAU, h)
    tq = _interp_lin(tq_f, h, t - delay) if delay > 0.0 else tq_f[idx]
    if "torque_offset" in eff:
        form, s = eff["torque_offset"]
        tq = tq + (c["to_sign"] * s * TO_C if form == 0 else c["td_sign"] * s * TO_R * t)
    torque = adc(tq + sensors.torque_noise * nz_torque)

    ld = _bessel2(f_tl, w0, h)[idx]
    if "sensor_drift" in eff and eff["sensor_drift"][0] == 0:
        ld = ld + c["sd_load_sign"] * eff["sensor_drift"][1] * SD_LOAD * t
    torque_load = adc(ld + sensors.load_noise * nz_load)

    # output absolute encoder (eccentricity, zeroed at q = 0, floor quantiser)
    step = math.radians(sensors.encoder_res_deg)
    ecc_a, ecc_p = p["ecc_amp"], p["ecc_phase"]
    enc_drift = 0.0
    if "sensor_drift" in eff and eff["sensor_drift"][0] == 1:
        enc_drift = c["sd_enc_sign"] * eff["sensor_drift"][1] * SD_ENC

    def encoder(qv, tv):
        x = qv + ecc_a * (np.sin(qv + ecc_p) - math.sin(ecc_p)) + enc_drift * tv
        return _quantise_floor(x, step, enc_phase)

    q_meas = encoder(q, t)
    tw = float(sensors.velocity_window_s)
    t_back = t - tw
    q_back = _interp_hermite(f_q, f_qd, h, t_back)
    q_back_meas = encoder(q_back, np.maximum(t_back, 0.0))
    qd_meas = (q_meas - q_back_meas) / tw

    # motor side: position (latency, fine quantisation), speeds (PT1 + N2 normalisation)
    u_step = 2.0 * math.pi / (2.0 ** int(sensors.motor_encoder_bits) * N)
    if sensors.u_latency_s > 0.0:
        u_l = _interp_hermite(f_u, f_ud, h, t - sensors.u_latency_s)
    else:
        u_l = u
    u_meas = u_step * np.round(u_l / u_step)
    w_step = sensors.speed_ref_rpm * 2.0 * math.pi / 60.0 / 16384.0
    wf_ = _pt1(f_ud * N, sensors.speed_filter_s, h)[idx]
    w_meas = [w_step * np.round((wf_ + sensors.speed_noise * nz_w[k]) / w_step) for k in range(3)]
    ud_meas = w_meas[0] / N

    # currents: master-slave, common current set point, per-motor sensor gain/offset
    kt_sum = float(sum(p["k_t"]))
    i_f = _pt1(f_tem / (N * kt_sum), sensors.current_filter_s, h)[idx]
    i_step = sensors.current_ref_a / 16384.0
    i_meas = [i_step * np.round((p["i_gain"][k] * i_f + p["i_offset"][k]
                                 + sensors.current_noise * nz_i[k]) / i_step) for k in range(3)]

    th_f = _pt1(f_tho, sensors.temp_tau_s, h)[idx]
    temp_meas = sensors.temp_res_c * np.round((th_f + sensors.temp_noise * nz_temp)
                                              / sensors.temp_res_c)

    # phases
    codes = np.zeros(n, dtype=np.int64)
    for (a, b, ph) in seg:
        codes[(t >= a - 1e-9) & (t < b - 1e-9)] = PHASES.index(ph)
    codes[t >= seg[-1][0] - 1e-9] = PHASES.index(seg[-1][2])
    phase = np.array(PHASES, dtype=object)[codes]

    samples = pd.DataFrame({
        "t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
        "torque": torque, "torque_load": torque_load, "temp_joint": temp_meas, "phase": phase,
        "i_m1": i_meas[0], "i_m2": i_meas[1], "i_m3": i_meas[2],
        "w_m1": w_meas[0], "w_m2": w_meas[1], "w_m3": w_meas[2],
    })

    def ch(res, sd, lag, unit):
        return {"resolution": float(res), "noise_sd": float(sd), "lag_s": float(lag), "unit": unit}

    sens_meta = {
        "q": ch(step, 0.0, 0.0, "rad"),
        "u": ch(u_step, 0.0, sensors.u_latency_s, "rad"),
        "qd": ch(step / tw, 0.0, 0.5 * tw, "rad/s"),
        "ud": ch(w_step / N, sensors.speed_noise / N, sensors.speed_filter_s, "rad/s"),
        "torque": ch(adc_step, sensors.torque_noise, sensors.torque_lag_s + aa_delay, "N·m"),
        "torque_load": ch(adc_step, sensors.load_noise, aa_delay, "N·m"),
        "temp_joint": ch(sensors.temp_res_c, sensors.temp_noise, sensors.temp_tau_s, "°C"),
    }
    for k in range(3):
        sens_meta[f"i_m{k + 1}"] = ch(i_step, sensors.current_noise, sensors.current_filter_s, "A")
    for k in range(3):
        sens_meta[f"w_m{k + 1}"] = ch(w_step, sensors.speed_noise, sensors.speed_filter_s, "rad/s")

    notes = {
        "q": "absolute ring encoder, floor quantiser, zero preset at q = 0 at run start "
             "(sub-step zero position unknown), accuracy +-0.02 deg",
        "qd": f"PLC: (q(t) - q(t - {tw:g} s)) / {tw:g} s on the quantised encoder",
        "u": "motor 1 encoder, multi-turn, referenced to zero twist, divided by N",
        "ud": "motor 1 speed actual value (PT1 smoothing, N2 normalised) divided by N",
        "torque": f"strain-gauge torque shaft, 2nd-order Bessel anti-alias -3 dB at {f3:.4g} Hz "
                  f"(group delay {aa_delay * 1e3:.3g} ms), {int(sensors.adc_bits)}-bit ADC "
                  f"+-{sensors.adc_full_scale:g} N m, zero calibrated unloaded",
        "torque_load": "dynamometer load cell at the output flange, same chain as torque; "
                       "declutched in scheme 3",
        "temp_joint": "PT100 in a thermowell in the gearbox oil near the output stage",
    }
    meta = {
        "scheme": scheme, "rig": RIG_NAME, "source": "emulator", "reduction": REDUCTION,
        "seed": seed, "run": run, "motor_speed_rpm": rpm, "direction": direction,
        "sample_rate_hz": fs, "duration_s": float(t[-1]), "temp_joint_c": temp0,
        "periods": periods, "sensors": sens_meta, "sensor_notes": notes,
    }
    return RigRun(samples=samples, meta=meta, truth=truth)


def convergence_check(scheme: int = 3, motor_speed_rpm=None, direction: int = 1,
                      effects: dict | None = None, seed: int = 0, periods: int = 1,
                      sample_rate_hz: float = 50.0, refine: int = 4) -> dict:
    """Largest differences of the truth between the production step (H_MAX) and H_MAX/refine."""
    sens = SensorSpec(sample_rate_hz=sample_rate_hz)
    kw = dict(seed=seed, sensors=sens, periods=periods, run=0)
    a = _simulate(scheme, motor_speed_rpm, direction, 25.0, effects or {}, h_max=H_MAX, **kw).truth
    b = _simulate(scheme, motor_speed_rpm, direction, 25.0, effects or {},
                  h_max=H_MAX / refine, **kw).truth
    return {col: float(np.max(np.abs(a[col].to_numpy() - b[col].to_numpy())))
            for col in ("q", "qd", "u", "twist", "torque", "torque_load", "friction", "temp_joint")}
