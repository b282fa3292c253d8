"""Validation rig H: an independent emulator of the CMOR J4 joint test platform.

DATA SHEET
==========

Written blind from the platform description (rig.md), the catalogue of real-joint effect forms
(effects-in-the-wild.md), the run format (run-format.md) and the source paper. It shares no code
with the service's simulators. SI units throughout (rad, rad/s, N·m, s), temperatures in °C.

Symbols: q output angle, u motor angle / N (output-referred), Δ = u − q the transmission twist,
v = q̇, T the transmitted torque at the output flange (where the joint torque transducer sits),
τ_L the dynamometer torque on the output (positive resists positive motion).

1. Structure
------------
* Joint: three servo motors on one input shaft (output-referred inertia J_u = 3·J_m·N²), a
  two-stage reducer (input planetary/differential stage + cycloidal RV output stage), total
  reduction N = 11000. Only the RV output stage is compliant (the input-stage compliance,
  referred through its ratio, is negligible).
* RV-stage compliance (own law, stiffening "lost-motion" curve, no loss):
      T_el = k0·Δ0·sinh(Δ_k/Δ0)              stiffness k0·cosh(Δ_k/Δ0), +20 % at rated twist
  plus structural damping T_d = D·g_b·Δ̇ (g_b = dΔ_b/dΔ, = 1 without backlash), so nominally
      T = k0·Δ0·sinh(Δ/Δ0) + D·Δ̇.
  Δ_b = Δ with the backlash dead zone applied (if injected), Δ_k = Δ_b + kinematic error (if
  injected). T = T_el + T_hys + T_d (T_hys only when injected).
* Output body:  I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F_o − τ_dist − τ_2
  (τ_dist: injected time-periodic disturbance and output mesh ripple; τ_2: reaction of an
  injected secondary mode).
* Output bearing friction F_o: a parallel multi-element Maxwell–Dahl presliding model
  (4 elements, a smooth generalised-Maxwell-slip variant):
      F_o = Σ_i k_i·z_i + f_v'·v,   k_i = φ_i·f_c/d_i,
      ż_i = v − |v|·z_i/(d_i·ρ),   ρ = L(v, T, θ)/f_c,
  φ = (0.35, 0.30, 0.20, 0.15), presliding distances d_i ≈ (2, 6, 15, 40)·1e-5 rad. In steady
  sliding F_o = L·sgn(v) + f_v'·v; at reversals the friction passes through a presliding
  (micro-slip) curve over ~0.4 mrad instead of jumping. Nominally L = f_c, f_v' = f_v
  (no Stribeck, no temperature, load or direction dependence).
* Motor side: J_u·ü = τ_m − T − c_vm·u̇ − c_cm·tanh(u̇/ε_m)
  (motor-bearing / seal friction, output-referred, smooth Coulomb with ε_m = 1e-4 rad/s).
  τ_m = N·Σ_k k_t,k·i_k; the three drives receive equal torque commands τ_cmd/3, the current
  loop is a first-order lag:  τ̇_m = (sat(τ_cmd) − τ_m)/τ_c, τ_c = 1.5 ms,
  |τ_cmd| ≤ 445 kN·m; i_k = τ_m/(3·N·k_t,k) (motor torque constants differ by ±3 %).
* Drive control (S120-like, continuous, on the noise-free motor-encoder signals):
  schemes 1, 2 — speed PI:  τ_cmd = K_p·e + K_i·ξ, ξ̇ = e, e = ω_ref(t) − u̇;
  scheme 3 — position loop with feed-forward:  e = u̇_ref + K_x·(u_ref − u) − u̇,
  τ_cmd = J_u,nom·ü_ref + K_p·e + K_i·ξ. K_p = J_u,nom·40, K_i = K_p·8, K_x = 8 s⁻¹.
* Load: electric dynamometer (servo motor + reducer) in torque control, a second-order torque
  servo:  τ̈_L = ω_d²·((1+ε_d)·τ_set(t) − τ_L) − 2ζ_d·ω_d·τ̇_L,
  ω_d = 2π·3 Hz, ζ_d = 0.85, static gain error ε_d ∈ ±0.5 % (within the ±2 kN·m spec).
  The dynamometer inertia is lumped in I. Its set point is zero in scheme 3.
* Gearbox temperature θ (first order):  C_th·θ̇ = P_loss − (θ − θ_a)/R_th, θ(0) = θ_a =
  temp_joint_c, P_loss = |F_o·v| + |(c_vm·u̇ + c_cm·tanh(u̇/ε_m))·u̇| + |T_d·Δ̇|,
  C_th = 1.8e5 J/K, R_th = 0.05 K/W.
* Gravity g = 9.81 m/s².

2. Nominal parameters (each drawn once per campaign seed, uniform ±8 % unless stated)
------------------------------------------------------------------------------------
I 6685 kg·m²; mr_x 20.8 kg·m; mr_y −34.5 kg·m; f_v 8683 N·m·s/rad; f_c 2353 N·m;
d_1..d_4 (2, 6, 15, 40)e-5 rad; k0 1.3e7 N·m/rad; Δ0 0.014 rad; D 6e4 N·m·s/rad;
J_u 3.63e5 kg·m²; c_vm 1.8e4 N·m·s/rad; c_cm 4950 N·m; k_t,k 1.55 N·m/A (±3 %);
ω_d 2π·3 rad/s; ζ_d 0.85; ε_d ±0.005 (absolute); C_th 1.8e5 J/K; R_th 0.05 K/W;
output-encoder eccentricity 4.8e-6 rad with a uniform phase; motor-encoder interpolation
error amplitudes (1st, 2nd harmonic of the line period) 7.7e-6 and 3.1e-6 motor-rad.
Effect parameters are listed with the forms below; phases are uniform in [0, 2π).
`campaign_parameters(seed)` returns every drawn value by name.

3. Integrator
-------------
Fixed-step classical 4th-order Runge–Kutta at 4 kHz (h = 0.25 ms) on the 22-state vector
(q, q̇, u, u̇, hysteresis state, z_1..z_4, τ_m, ξ, τ_L, τ̇_L, θ, secondary-mode y, ẏ,
the two anti-alias filter states, the extra-lag state, load-cell filter, q̇ and u̇ filters).
All laws are evaluated inside the stages (no operator splitting); the piecewise-linear set
points have their corners on whole seconds, i.e. on the step grid. Samples are taken at
t_k = k/f_s by linear interpolation of the 4 kHz record (exact when 4000/f_s is an integer).
The initial state is the static equilibrium at q = 0 (found by bisection on the twist).

4. Sensors (per run, noise from the `run` number; the data sheet in meta["sensors"])
-----------------------------------------------------------------------------------
* q: absolute output encoder, reading = round((q + e_ecc)/s_q)·s_q, s_q = encoder_res_deg in
  rad, e_ecc = 4.8e-6·sin(q + φ_e) (once-per-turn eccentricity, ~1 arcsec, < step).
* u: motor sin/cos encoder, 2048 lines, 2^22 counts/motor turn; interpolation error
  a1·sin(L·θ_m + φ1) + a2·sin(2L·θ_m + φ2) (θ_m = N·u, L = 2048); reading divided by N and
  quantised at 2π/2^22/N rad.
* qd: drive's output speed estimate: first-order filter τ_qd = 2 ms of q̇ plus white noise
  qd_noise (default 2e-5 rad/s). ud: first-order filter τ_ud = 1 ms of u̇ plus white noise
  ud_noise (default 2e-6 rad/s). w_m1..3 = N·(filtered u̇) + independent white noise w_noise.
* torque: strain-gauge bridge → instrumentation amp → 2nd-order Butterworth anti-alias filter
  (f_c = min(0.25·f_s, 200) Hz, DC group delay √2/(2π f_c)) → pure delay torque_lag_s →
  white noise torque_noise (referred to the ADC input) → 16-bit SAR ADC over ±200 kN·m
  (LSB 6.1 N·m). Stated noise_sd = √(torque_noise² + LSB²/12), stated lag = √2/(2π f_c) +
  torque_lag_s.
* torque_load: load cell on the loading shaft, first-order filter f_c = min(0.25·f_s, 100) Hz
  (lag 1/(2π f_c)), white noise load_noise, 16-bit ADC over ±250 kN·m.
* temp_joint: PT100, white noise 0.02 °C, resolution 0.1 °C.
* i_m1..3: current sensors, white noise current_noise (default 0.01 A), no lag.
truth["torque"] is the torque reading without noise and quantisation (it includes the chain
lag); truth["torque_true"] is the transmitted torque T itself.

5. Effects (`effects = {name: {"form": f, "scale": s}}`, any finite s ≥ 0; size linear in s
   up to the physical saturation listed under "Saturation" below)
------------------------------------------------------------------------------------------
θ_r = 25 °C, dθ = θ_r − θ, sg = tanh(v/1e-5), T_r = 120 kN·m, |T_e| = |T_el + T_hys|.
Friction level L is built in this order: f_c (+temperature) (×asymmetry) + Stribeck + load.
* stribeck (s ≤ 3): L += s·r_s·f_c·φ(|v|/v_s), r_s = 0.5, v_s = 2e-3 rad/s;
  exponential φ = e^{−x}; gaussian φ = e^{−x²}; lorentzian φ = 1/(1+x²); root φ = e^{−√x}.
* temperature_friction (s ≤ 1.5, θ within −20…80 °C): additive_coulomb_viscous
  L += s·12·dθ, f_v' += s·80·dθ; multiplicative_viscous_exp f_v' ×= 1 + s·(e^{0.025·dθ} − 1);
  multiplicative_coulomb_viscous_poly L, f_v' ×= 1 + s·(0.012·dθ + 2e-4·dθ²).
* load_dependent_friction (s ≤ 3): coulomb_linear L += s·0.015·|T_e|;
  coulomb_viscous_scaled L, f_v' ×= 1 + s·0.6·|T_e|/T_r; power_flow
  L += s·|T_e|·(0.02·w + 0.008·(1 − w)), w = ½(1 + tanh(T·v/5 W)) (driving vs back-driven).
* asymmetric_friction (s ≤ 3): coulomb L ×= 1 + s·0.25·sg; viscous f_v' ×= 1 + s·0.2·sg;
  coulomb_viscous both.
* gear_ripple (s ≤ 3): the two mesh-force forms act on the output body (the output-stage pin
  mesh, beside the gauge; they enter τ_dist, so at quasi-static motion the torque reading
  carries them); the two kinematic-error forms act inside the transmission (on Δ_k, so they
  show in the twist/torque relation). output_mesh τ = s·350·sin(40q + φ1);
  output_mesh_harmonics τ = s·350·(sin(40q+φ1) + 0.5 sin(80q+φ2) + 0.25 sin(120q+φ3));
  motor_two_per_rev Δ_k = Δ_b + s·2e-5·(sin(2Nu + φm) + 0.3 sin(4Nu + φm2)) (2 and 4 cycles
  per motor turn); output_kinematic_error Δ_k = Δ_b + s·2.5e-5·sin(40q + φ1).
* backlash (half-width b = s·2.5e-4 rad, s ≤ 3): sharp_dead_zone Δ_b = sgn Δ·max(|Δ|−b, 0);
  tanh_dead_zone Δ_b = Δ − b·tanh(Δ/b); quadratic_dead_zone Δ_b = sgn Δ·Δ²/(4b) for |Δ| < 2b,
  Δ − b·sgn Δ beyond (C¹). The damping acts on g_b·Δ̇.
* hysteresis (s ≤ 2.5), rate r = g_b·Δ̇: bouc_wen_n1 T_hys = s·w·k0·(x − Δ_b),
  ẋ = r − β|r|x − γ r|x|, β = 0.6/x_m, γ = 0.4/x_m, x_m = 4e-3 rad, w = 0.3 (a part of the
  stiffness becomes hysteretic and saturates); bouc_wen_n2 the same with n = 2
  (β = 0.6/x_m², γ = 0.4/x_m²); dahl_parallel T_hys = s·3e6·x, ẋ = r − |r|·x/1e-3.
* torque_offset (reading only, s ≤ 5): constant +s·1500; linear_drift +s·40·t;
  exponential_settling +s·2000·(1 − e^{−t/15 s}).
* time_delay (torque reading only, s ≤ 5): pure_delay s·15 ms; first_order_lag τ = s·20 ms;
  delay_plus_lag s·7.5 ms and τ = s·10 ms.
Out of vocabulary (OUT_OF_VOCABULARY):
* periodic_disturbance (s ≤ 3): single_tone τ_dist = s·1500·sin(2π·0.8·t + φ);
  pump_pulsation τ_dist = s·900·(sin ωt + 0.5 sin(2ωt+0.7) + 0.25 sin(3ωt+1.9)), ω = 2π·2.3.
* position_dependent_stiffness (s ≤ 3): cos_two_per_rev T_el ×= 1 + s·0.2·cos(2q + φ);
  linear_in_angle T_el ×= 1 + s·0.1·q.
* sensor_drift (reading only, s ≤ 5): encoder_drift q reading += s·2e-5·t rad;
  load_cell_drift torque_load += s·30·t; torque_gain_drift torque ×= 1 + s·4e-4·t.
* second_resonance (s ≤ 3): a body of inertia s·m·I on the output through a spring-damper,
  ÿ = ω²(q − y) + 2ζω(q̇ − ẏ), reaction τ_2 = s·m·I·ÿ. output_tuned_mass m = 0.15,
  f = 11 Hz, ζ = 0.03; loading_shaft_mode m = 0.4, f = 4.5 Hz, ζ = 0.05.
Notes: the parameter of each form is linear in s; the response need not be (a Stribeck
scale ≳ 1 at 300 r/min makes the speed-controlled joint stick-slip through the compliant
transmission; Bouc–Wen hysteresis yields at |Δ| ~ x_m, so it shows mainly under load).
Effects with s = 0 are removed before simulation (bit-for-bit nominal run).
The "(s ≤ …)" figures above are the old admission limits; they are no longer enforced.

Saturation (large s)
--------------------
Any finite s ≥ 0 is accepted (negative, NaN, ±inf or non-numbers raise ValueError naming the
scale). Each form's parameter is linear in s up to a physical clamp, where it saturates as a real
effect would; beyond it the size no longer grows with s. `S_MAX[name]` now only documents the
scale up to which no clamp of that family can act for any campaign draw (±8 %) inside the
rig's operating window (θ −20…80 °C, |q| ≤ π); it is not an admission limit.
* Friction level (stribeck, temperature_friction, load_dependent_friction,
  asymmetric_friction): every multiplicative factor (1 + s·…) is floored at 0 (a friction
  coefficient cannot change sign), the viscous coefficient f_v' is floored at 0 and the Coulomb
  level at L ≥ RHO_MIN·f_c = 0.2·f_c (boundary-lubrication floor; it also keeps the presliding
  relaxation |v|·h/(d_1·ρ) inside RK4's stability region). Increases saturate at
  L ≤ L_MAX·f_c = 40·f_c (~94 kN·m: breakaway stays inside the drive's 445 kN·m reserve above
  rated load; beyond it the joint never breaks away and the stick-slip release outruns the 4 kHz
  step) and f_v' ≤ FV_MAX·f_v = 1000·f_v (viscous torque ≤ ~250 kN·m at 3000 r/min; keeps
  f_v'·h/I ≲ 0.3).
* gear_ripple: mesh-torque amplitude s·350 ≤ RIP_MAX = 60 kN·m (half the rated torque; for
  output_mesh_harmonics the cap applies to the fundamental, the 0.5/0.25 weights are kept);
  kinematic-error amplitudes s·2e-5, s·2.5e-5 ≤ KE_MAX = 1e-3 rad (~3.4 arcmin,
  several times a worn RV stage; larger ones outrun the 4 kHz step at speed).
* backlash: half-width b = s·2.5e-4 ≤ BL_MAX = 0.0125 rad (~0.7°; wider gaps make the sharp
  dead-zone impacts outrun the 4 kHz step).
* hysteresis: Bouc–Wen hysteretic share s·w ≤ HYS_SHARE_MAX = 0.9 (a share ≥ 1 would leave a
  negative post-yield stiffness); Dahl element stiffness s·3e6 ≤ DAHL_K_MAX·k0 = 100·k0.
* time_delay: injected pure delay ≤ DELAY_MAX = 2 s, injected lag τ ≤ LAG_MAX = 2 s (a delay
  comparable to the run is not a sensor chain); the lag τ is also floored at LAG_MIN = 0.25 ms
  (one RK4 step) so a very small s cannot make the lag state stiff (linear for s ≳ 0.0125/0.025).
* periodic_disturbance: amplitude s·1500 (s·900) capped so the peak (sum of harmonic
  amplitudes, 1 resp. 1.75 × amplitude) is ≤ PD_MAX = 80 kN·m: larger ones throw the output
  about faster than the presliding relaxation can follow at 4 kHz.
* position_dependent_stiffness: the stiffness factor is clamped to [KPOS_MIN, KPOS_MAX] =
  [0.2, 50] (a spring cannot soften to zero or below; the ceiling keeps the mode inside RK4's
  4 kHz step).
* second_resonance: secondary inertia s·m·I ≤ SR_MASS_MAX·I = 50·I.
* torque_offset, sensor_drift: reading-only, linear at any s (the 16-bit ADCs clip at their
  ranges as the real converters would).
Numerical stability: with these clamps the 4 kHz RK4 has been exercised to s = 5000 on every
form; should the integration nevertheless produce a non-finite state, simulate_run raises
RuntimeError naming the active effect(s) and scales instead of returning NaN.

6. Schemes
----------
ω_o = direction·rpm·2π/60/N. Scheme 1 (62 s): rest 0–1 s, speed ramp 1–3 s, constant speed,
load ramp 0→120 kN·m 4–29 s ("load"), hold 29–32 s, unload 32–57 s, speed kept to 59 s,
ramp down 59–61 s, rest to 62 s. Scheme 2 (57 s): speed as above, from 4 s twelve steps of
10 kN·m (1 s ramp "load" + 2 s "hold"), unload 40–52 s, speed ramp down 54–56 s, end 57 s.
Scheme 3 (periods·20 s, "excite", no load): Eq. 12 fifth-order Fourier trajectory, ω_f = 2π/20,
a = (10, −4, 6, −8, −4)·c, b = (6, 4, −6, 3, −1.6)·c (Σa = 0, Σ l·b_l = 0: zero speed and
acceleration at t = 0), c scaled to a peak speed of 85 % of the 3000 r/min limit, offset so
q_ref(0) = 0, multiplied by direction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
import pandas as pd

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "validation-rig-H"

_CACHE = __name__ == "validation_rigs.rig_h"

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "root"),
    "temperature_friction": ("additive_coulomb_viscous", "multiplicative_viscous_exp",
                             "multiplicative_coulomb_viscous_poly"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous_scaled", "power_flow"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous"),
    "gear_ripple": ("output_mesh", "output_mesh_harmonics", "motor_two_per_rev",
                    "output_kinematic_error"),
    "backlash": ("sharp_dead_zone", "tanh_dead_zone", "quadratic_dead_zone"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl_parallel"),
    "torque_offset": ("constant", "linear_drift", "exponential_settling"),
    "time_delay": ("pure_delay", "first_order_lag", "delay_plus_lag"),
    "periodic_disturbance": ("single_tone", "pump_pulsation"),
    "position_dependent_stiffness": ("cos_two_per_rev", "linear_in_angle"),
    "sensor_drift": ("encoder_drift", "load_cell_drift", "torque_gain_drift"),
    "second_resonance": ("output_tuned_mass", "loading_shaft_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "sensor_drift", "second_resonance")
# Documentation only (not an admission limit, any finite s >= 0 is accepted): the scale up to
# which no saturation clamp of the family can act, for any campaign draw, inside the operating
# window (theta -20..80 °C, |q| <= pi). See DATA SHEET §5 "Saturation".
S_MAX: dict[str, float] = {
    "stribeck": 70.0, "temperature_friction": 1.2, "load_dependent_friction": 30.0,
    "asymmetric_friction": 2.9, "gear_ripple": 35.0, "backlash": 45.0, "hysteresis": 2.75,
    "torque_offset": math.inf, "time_delay": 90.0, "periodic_disturbance": 45.0,
    "position_dependent_stiffness": 2.3, "sensor_drift": math.inf, "second_resonance": 110.0,
}
S_LINEAR = S_MAX
_FAMILIES = tuple(EFFECT_FORMS)
# family slots used by the compiled core
F_STRIB, F_TEMP, F_LOAD, F_ASYM, F_RIP, F_BL, F_HYS, F_OFF, F_DEL, F_PD, F_PS, F_DRIFT, F_SR = \
    range(13)

# ---------------------------------------------------------------------------------------------
# parameters: (name, nominal, kind) kind: "rel" ±8 %, "kt" ±3 %, "abs:x" uniform ±x, "phase",
# "fixed"
_TWO_PI = 2.0 * math.pi
_PSPEC = [
    ("I", 6685.0, "rel"), ("mr_x", 20.8, "rel"), ("mr_y", -34.5, "rel"),
    ("f_v", 8683.0, "rel"), ("f_c", 2353.0, "rel"),
    ("d1", 2e-5, "rel"), ("d2", 6e-5, "rel"), ("d3", 1.5e-4, "rel"), ("d4", 4e-4, "rel"),
    ("k0", 1.3e7, "rel"), ("delta0", 0.014, "rel"), ("D", 6e4, "rel"),
    ("J_u", 3.63e5, "rel"), ("c_vm", 1.8e4, "rel"), ("c_cm", 4950.0, "rel"),
    ("kt1", 1.55, "kt"), ("kt2", 1.55, "kt"), ("kt3", 1.55, "kt"),
    ("w_d", _TWO_PI * 3.0, "rel"), ("zeta_d", 0.85, "rel"), ("eps_d", 0.0, "abs:0.005"),
    ("C_th", 1.8e5, "rel"), ("R_th", 0.05, "rel"),
    ("ecc_amp", 4.8e-6, "rel"), ("ecc_phase", 0.0, "phase"),
    ("interp_a1", 7.7e-6, "rel"), ("interp_a2", 3.1e-6, "rel"),
    ("interp_ph1", 0.0, "phase"), ("interp_ph2", 0.0, "phase"),
    # effects
    ("strib_ratio", 0.5, "rel"), ("strib_vs", 2e-3, "rel"),
    ("temp_ac", 12.0, "rel"), ("temp_av", 80.0, "rel"), ("temp_lambda", 0.025, "rel"),
    ("temp_c1", 0.012, "rel"), ("temp_c2", 2e-4, "rel"),
    ("load_mu", 0.015, "rel"), ("load_kappa", 0.6, "rel"),
    ("load_mu_drive", 0.02, "rel"), ("load_mu_back", 0.008, "rel"),
    ("asym_c", 0.25, "rel"), ("asym_v", 0.2, "rel"),
    ("rip_n", 40.0, "fixed"), ("rip_a", 350.0, "rel"), ("rip_ph1", 0.0, "phase"),
    ("rip_ph2", 0.0, "phase"), ("rip_ph3", 0.0, "phase"), ("rip_em", 2e-5, "rel"),
    ("rip_phm", 0.0, "phase"), ("rip_phm2", 0.0, "phase"), ("rip_eps", 2.5e-5, "rel"),
    ("bl_b", 2.5e-4, "rel"),
    ("hys_w", 0.3, "rel"), ("hys_xm1", 4e-3, "rel"), ("hys_xm2", 4e-3, "rel"),
    ("hys_kd", 3e6, "rel"), ("hys_zd", 1e-3, "rel"),
    ("off_c", 1500.0, "rel"), ("off_rate", 40.0, "rel"), ("off_e", 2000.0, "rel"),
    ("off_tau", 15.0, "rel"),
    ("del_d", 0.015, "rel"), ("del_tau", 0.02, "rel"),
    ("pd_a", 1500.0, "rel"), ("pd_f", 0.8, "rel"), ("pd_ph", 0.0, "phase"),
    ("pd_a2", 900.0, "rel"), ("pd_f2", 2.3, "rel"),
    ("ps_a", 0.2, "rel"), ("ps_ph", 0.0, "phase"), ("ps_b", 0.1, "rel"),
    ("drift_q", 2e-5, "rel"), ("drift_load", 30.0, "rel"), ("drift_gain", 4e-4, "rel"),
    ("sr_m1", 0.15, "rel"), ("sr_f1", 11.0, "rel"), ("sr_z1", 0.03, "rel"),
    ("sr_m2", 0.4, "rel"), ("sr_f2", 4.5, "rel"), ("sr_z2", 0.05, "rel"),
]
_PNAMES = [s[0] for s in _PSPEC]
_PIDX = {n: i for i, n in enumerate(_PNAMES)}
for _n, _i in _PIDX.items():
    globals()["P_" + _n] = _i
NPAR = len(_PSPEC)

# fixed constants of the rig
GRAV = 9.81
PHI = (0.35, 0.30, 0.20, 0.15)
PHI1, PHI2, PHI3, PHI4 = PHI
EPS_M = 1e-4
V_EPS = 1e-5
TAU_C = 1.5e-3
TAU_MAX = 445e3
THETA_REF = 25.0
T_RATED = 120e3
J_U_NOM = 3.63e5
K_P = J_U_NOM * 40.0
K_I = K_P * 8.0
K_X = 8.0
INTERNAL_HZ = 4000
TAU_QD = 2e-3
TAU_UD = 1e-3
ENC_LINES = 2048
U_COUNTS = 2 ** 22
TORQUE_RANGE = 200e3
LOAD_RANGE = 250e3
ADC_BITS = 16
TEMP_RES = 0.1
TEMP_NOISE = 0.02
W_MAX_OUT = 3000.0 * _TWO_PI / 60.0 / REDUCTION

# physical saturation of the effect forms at large scale (see DATA SHEET §5, "Saturation")
RHO_MIN = 0.2          # Coulomb level floor L >= RHO_MIN*f_c (keeps |v|·h/(d_1·rho) < 2.78)
L_MAX = 40.0           # Coulomb level ceiling L <= L_MAX*f_c (breakaway within the drive's reserve)
FV_MAX = 1000.0        # viscous coefficient ceiling f_v' <= FV_MAX*f_v
KE_MAX = 1e-3          # kinematic-error amplitude cap, rad
RIP_MAX = 60e3         # output mesh-torque ripple amplitude cap (per unit harmonic weight), N·m
BL_MAX = 0.0125        # backlash half-width cap, rad
HYS_SHARE_MAX = 0.9    # Bouc–Wen hysteretic share of the stiffness, cap
DAHL_K_MAX = 100.0     # Dahl element stiffness cap, in units of k0
DELAY_MAX = 2.0        # injected pure delay cap, s
LAG_MAX = 2.0          # injected first-order lag time-constant cap, s
LAG_MIN = 2.5e-4       # injected first-order lag time-constant floor (one RK4 step), s
PD_MAX = 80e3          # periodic disturbance peak cap (sum of harmonic amplitudes), N·m
KPOS_MIN = 0.2         # position-dependent stiffness factor floor
KPOS_MAX = 50.0        # position-dependent stiffness factor ceiling
SR_MASS_MAX = 50.0     # secondary-mode inertia cap, in units of I

NX = 22
NREC = 16
# state indices
X_Q, X_QD, X_U, X_UD, X_H, X_Z1, X_Z2, X_Z3, X_Z4, X_TM, X_XI, X_TL, X_TLD, X_TH, X_Y2, X_Y2D, \
    X_AA, X_AAD, X_LAG, X_LC, X_QF, X_UF = range(NX)

# Fourier excitation (Eq. 12), own coefficients
_FA = np.array([10.0, -4.0, 6.0, -8.0, -4.0])
_FB = np.array([6.0, 4.0, -6.0, 3.0, -1.6])
_WF = _TWO_PI / 20.0


def _fourier_scale() -> float:
    t = np.linspace(0.0, 20.0, 20001)
    l = np.arange(1, 6)[:, None]
    qd = (_FA[:, None] * np.cos(_WF * l * t) + _FB[:, None] * np.sin(_WF * l * t)).sum(0)
    return 0.85 * W_MAX_OUT / np.abs(qd).max()


_FSCALE = _fourier_scale()


# ---------------------------------------------------------------------------------------------
# compiled core
@numba.njit(cache=_CACHE)
def _interp_pl(t, bt, bv):
    n = bt.shape[0]
    if t <= bt[0]:
        return bv[0]
    for i in range(n - 1):
        if t < bt[i + 1]:
            return bv[i] + (bv[i + 1] - bv[i]) * (t - bt[i]) / (bt[i + 1] - bt[i])
    return bv[n - 1]


@numba.njit(cache=_CACHE)
def _slope_pl(t, bt, bv):
    n = bt.shape[0]
    if t < bt[0]:
        return 0.0
    for i in range(n - 1):
        if t < bt[i + 1]:
            return (bv[i + 1] - bv[i]) / (bt[i + 1] - bt[i])
    return 0.0


@numba.njit(cache=_CACHE)
def _transmission(delta, ddelta, q, u, xh, p, fm, sc, out):
    """Transmission torque. out: [T, T_el+T_hys, g_b, rate r, delta_b, T_d]."""
    # backlash dead zone
    g_b = 1.0
    db = delta
    f = fm[F_BL]
    if f >= 0:
        b = min(sc[F_BL] * p[P_bl_b], BL_MAX)
        if b > 0.0:
            if f == 0:
                if delta > b:
                    db = delta - b
                elif delta < -b:
                    db = delta + b
                else:
                    db = 0.0
                    g_b = 0.0
            elif f == 1:
                th = math.tanh(delta / b)
                db = delta - b * th
                g_b = th * th
            else:
                a = abs(delta)
                sgn = 1.0 if delta >= 0.0 else -1.0
                if a < 2.0 * b:
                    db = sgn * a * a / (4.0 * b)
                    g_b = a / (2.0 * b)
                else:
                    db = delta - b * sgn
    dk = db
    f = fm[F_RIP]
    if f == 3:
        dk = db + min(sc[F_RIP] * p[P_rip_eps], KE_MAX) * math.sin(p[P_rip_n] * q + p[P_rip_ph1])
    elif f == 2:
        th_m = 11000.0 * u
        dk = db + min(sc[F_RIP] * p[P_rip_em], KE_MAX) * (math.sin(2.0 * th_m + p[P_rip_phm])
                                                          + 0.3 * math.sin(4.0 * th_m
                                                                           + p[P_rip_phm2]))
    kpos = 1.0
    f = fm[F_PS]
    if f == 0:
        kpos = 1.0 + sc[F_PS] * p[P_ps_a] * math.cos(2.0 * q + p[P_ps_ph])
    elif f == 1:
        kpos = 1.0 + sc[F_PS] * p[P_ps_b] * q
    if f >= 0:
        kpos = min(max(kpos, KPOS_MIN), KPOS_MAX)
    d0 = p[P_delta0]
    t_el = kpos * p[P_k0] * d0 * math.sinh(dk / d0)
    r = g_b * ddelta
    t_h = 0.0
    f = fm[F_HYS]
    if f == 0 or f == 1:
        t_h = min(sc[F_HYS] * p[P_hys_w], HYS_SHARE_MAX) * p[P_k0] * (xh - db)
    elif f == 2:
        t_h = min(sc[F_HYS] * p[P_hys_kd], DAHL_K_MAX * p[P_k0]) * xh
    t_d = p[P_D] * r
    out[0] = t_el + t_h + t_d
    out[1] = t_el + t_h
    out[2] = g_b
    out[3] = r
    out[4] = db
    out[5] = t_d


@numba.njit(cache=_CACHE)
def _deriv(t, x, p, fm, sc, mode, bt, bw, bl, fa, fb, wf, qoff, dirn, wc_t, tau_lc, tau_lag,
           th_amb, dx, ex, tb):
    q = x[X_Q]
    v = x[X_QD]
    u = x[X_U]
    ud = x[X_UD]
    _transmission(u - q, ud - v, q, u, x[X_H], p, fm, sc, tb)
    T = tb[0]
    T_e = tb[1]
    r = tb[3]
    # ----- output friction level
    f_c = p[P_f_c]
    L = f_c
    fv = p[P_f_v]
    sg = math.tanh(v / V_EPS)
    f = fm[F_TEMP]
    if f >= 0:
        s = sc[F_TEMP]
        dth = THETA_REF - x[X_TH]
        if f == 0:
            L += s * p[P_temp_ac] * dth
            fv += s * p[P_temp_av] * dth
        elif f == 1:
            fv *= max(1.0 + s * (math.exp(p[P_temp_lambda] * dth) - 1.0), 0.0)
        else:
            m = max(1.0 + s * (p[P_temp_c1] * dth + p[P_temp_c2] * dth * dth), 0.0)
            L *= m
            fv *= m
    f = fm[F_ASYM]
    if f >= 0:
        s = sc[F_ASYM]
        if f == 0 or f == 2:
            L *= max(1.0 + s * p[P_asym_c] * sg, 0.0)
        if f == 1 or f == 2:
            fv *= max(1.0 + s * p[P_asym_v] * sg, 0.0)
    f = fm[F_STRIB]
    if f >= 0:
        xr = abs(v) / p[P_strib_vs]
        if f == 0:
            ph = math.exp(-xr)
        elif f == 1:
            ph = math.exp(-xr * xr)
        elif f == 2:
            ph = 1.0 / (1.0 + xr * xr)
        else:
            ph = math.exp(-math.sqrt(xr))
        L += sc[F_STRIB] * p[P_strib_ratio] * f_c * ph
    f = fm[F_LOAD]
    if f >= 0:
        s = sc[F_LOAD]
        ta = abs(T_e)
        if f == 0:
            L += s * p[P_load_mu] * ta
        elif f == 1:
            m = 1.0 + s * p[P_load_kappa] * ta / T_RATED
            L *= m
            fv *= m
        else:
            w = 0.5 * (1.0 + math.tanh(T * v / 5.0))
            L += s * ta * (p[P_load_mu_drive] * w + p[P_load_mu_back] * (1.0 - w))
    # saturation: the Coulomb level keeps a boundary-lubrication floor, viscous friction >= 0
    if L < RHO_MIN * f_c:
        L = RHO_MIN * f_c
    if L > L_MAX * f_c:
        L = L_MAX * f_c
    if fv < 0.0:
        fv = 0.0
    if fv > FV_MAX * p[P_f_v]:
        fv = FV_MAX * p[P_f_v]
    rho = L / f_c if f_c > 0.0 else 1.0
    if rho < 1e-9:
        rho = 1e-9
    av = abs(v)
    z1 = x[X_Z1]
    z2 = x[X_Z2]
    z3 = x[X_Z3]
    z4 = x[X_Z4]
    d1 = p[P_d1]
    d2 = p[P_d2]
    d3 = p[P_d3]
    d4 = p[P_d4]
    F_c = f_c * (PHI1 * z1 / d1 + PHI2 * z2 / d2 + PHI3 * z3 / d3 + PHI4 * z4 / d4)
    F_o = F_c + fv * v
    dx[X_Z1] = v - av * z1 / (d1 * rho)
    dx[X_Z2] = v - av * z2 / (d2 * rho)
    dx[X_Z3] = v - av * z3 / (d3 * rho)
    dx[X_Z4] = v - av * z4 / (d4 * rho)
    # ----- hysteresis state
    f = fm[F_HYS]
    xh = x[X_H]
    if f == 0:
        xm = p[P_hys_xm1]
        dx[X_H] = r - (0.6 / xm) * abs(r) * xh - (0.4 / xm) * r * abs(xh)
    elif f == 1:
        xm = p[P_hys_xm2]
        dx[X_H] = r - (0.6 / (xm * xm)) * abs(r) * abs(xh) * xh - (0.4 / (xm * xm)) * r * xh * xh
    elif f == 2:
        dx[X_H] = r - abs(r) * xh / p[P_hys_zd]
    else:
        dx[X_H] = 0.0
    # ----- disturbances on the output
    tau_dist = 0.0
    f = fm[F_PD]
    if f == 0:
        tau_dist = min(sc[F_PD] * p[P_pd_a], PD_MAX) * math.sin(2.0 * math.pi * p[P_pd_f] * t + p[P_pd_ph])
    elif f == 1:
        om = 2.0 * math.pi * p[P_pd_f2]
        tau_dist = min(sc[F_PD] * p[P_pd_a2], PD_MAX / 1.75) * (math.sin(om * t + p[P_pd_ph])
                                            + 0.5 * math.sin(2.0 * om * t + 0.7)
                                            + 0.25 * math.sin(3.0 * om * t + 1.9))
    f = fm[F_RIP]
    if f == 0:
        tau_dist += min(sc[F_RIP] * p[P_rip_a], RIP_MAX) * math.sin(p[P_rip_n] * q + p[P_rip_ph1])
    elif f == 1:
        n = p[P_rip_n]
        tau_dist += min(sc[F_RIP] * p[P_rip_a], RIP_MAX) * (math.sin(n * q + p[P_rip_ph1])
                                              + 0.5 * math.sin(2.0 * n * q + p[P_rip_ph2])
                                              + 0.25 * math.sin(3.0 * n * q + p[P_rip_ph3]))
    tau2 = 0.0
    f = fm[F_SR]
    if f >= 0:
        if f == 0:
            m2 = p[P_sr_m1]
            om2 = 2.0 * math.pi * p[P_sr_f1]
            z2r = p[P_sr_z1]
        else:
            m2 = p[P_sr_m2]
            om2 = 2.0 * math.pi * p[P_sr_f2]
            z2r = p[P_sr_z2]
        yacc = om2 * om2 * (q - x[X_Y2]) + 2.0 * z2r * om2 * (v - x[X_Y2D])
        dx[X_Y2] = x[X_Y2D]
        dx[X_Y2D] = yacc
        tau2 = min(sc[F_SR] * m2, SR_MASS_MAX) * p[P_I] * yacc
    else:
        dx[X_Y2] = 0.0
        dx[X_Y2D] = 0.0
    tau_L = x[X_TL]
    G = GRAV * (p[P_mr_x] * math.sin(q) + p[P_mr_y] * math.cos(q))
    qdd = (T - tau_L - G - F_o - tau_dist - tau2) / p[P_I]
    # ----- motor side and drive
    F_m = p[P_c_vm] * ud + p[P_c_cm] * math.tanh(ud / EPS_M)
    udd = (x[X_TM] - T - F_m) / p[P_J_u]
    if mode == 3:
        u_ref = qoff
        ud_ref = 0.0
        udd_ref = 0.0
        for k in range(fa.shape[0]):
            lw = wf * (k + 1)
            s_ = math.sin(lw * t)
            c_ = math.cos(lw * t)
            u_ref += (fa[k] * s_ - fb[k] * c_) / lw
            ud_ref += fa[k] * c_ + fb[k] * s_
            udd_ref += -fa[k] * lw * s_ + fb[k] * lw * c_
        u_ref *= dirn
        ud_ref *= dirn
        udd_ref *= dirn
        e = ud_ref + K_X * (u_ref - u) - ud
        tcmd = J_U_NOM * udd_ref + K_P * e + K_I * x[X_XI]
        tset = 0.0
    else:
        e = _interp_pl(t, bt, bw) - ud
        tcmd = K_P * e + K_I * x[X_XI]
        tset = _interp_pl(t, bt, bl)
    if tcmd > TAU_MAX:
        tcmd = TAU_MAX
    elif tcmd < -TAU_MAX:
        tcmd = -TAU_MAX
    dx[X_Q] = v
    dx[X_QD] = qdd
    dx[X_U] = ud
    dx[X_UD] = udd
    dx[X_TM] = (tcmd - x[X_TM]) / TAU_C
    dx[X_XI] = e
    wd = p[P_w_d]
    dx[X_TL] = x[X_TLD]
    dx[X_TLD] = wd * wd * ((1.0 + p[P_eps_d]) * tset - tau_L) - 2.0 * p[P_zeta_d] * wd * x[X_TLD]
    P_loss = abs(F_o * v) + abs(F_m * ud) + abs(tb[5] * (ud - v))
    dx[X_TH] = (P_loss - (x[X_TH] - th_amb) / p[P_R_th]) / p[P_C_th]
    # ----- sensor chains
    dx[X_AA] = x[X_AAD]
    dx[X_AAD] = wc_t * wc_t * (T - x[X_AA]) - math.sqrt(2.0) * wc_t * x[X_AAD]
    if tau_lag > 0.0:
        dx[X_LAG] = (x[X_AA] - x[X_LAG]) / tau_lag
    else:
        dx[X_LAG] = 0.0
    dx[X_LC] = (tau_L - x[X_LC]) / tau_lc
    dx[X_QF] = (v - x[X_QF]) / TAU_QD
    dx[X_UF] = (ud - x[X_UF]) / TAU_UD
    ex[0] = T
    ex[1] = F_o
    ex[2] = qdd


@numba.njit(cache=_CACHE)
def _integrate(x0, p, fm, sc, mode, bt, bw, bl, fa, fb, wf, qoff, dirn, wc_t, tau_lc, tau_lag,
               th_amb, h, nsteps):
    nx = x0.shape[0]
    rec = np.empty((nsteps + 1, NREC))
    x = x0.copy()
    xs = np.empty(nx)
    k1 = np.empty(nx)
    k2 = np.empty(nx)
    k3 = np.empty(nx)
    k4 = np.empty(nx)
    ex = np.empty(3)
    ex2 = np.empty(3)
    tb = np.empty(6)
    for j in range(nsteps + 1):
        t = j * h
        _deriv(t, x, p, fm, sc, mode, bt, bw, bl, fa, fb, wf, qoff, dirn, wc_t, tau_lc, tau_lag,
               th_amb, k1, ex, tb)
        rec[j, 0] = x[X_Q]
        rec[j, 1] = x[X_QD]
        rec[j, 2] = x[X_U]
        rec[j, 3] = x[X_UD]
        rec[j, 4] = ex[0]
        rec[j, 5] = x[X_TL]
        rec[j, 6] = x[X_TH]
        rec[j, 7] = x[X_TM]
        rec[j, 8] = x[X_AA]
        rec[j, 9] = x[X_LAG]
        rec[j, 10] = x[X_LC]
        rec[j, 11] = x[X_QF]
        rec[j, 12] = x[X_UF]
        rec[j, 13] = ex[1]
        rec[j, 14] = ex[2]
        rec[j, 15] = x[X_H]
        if j == nsteps:
            break
        for i in range(nx):
            xs[i] = x[i] + 0.5 * h * k1[i]
        _deriv(t + 0.5 * h, xs, p, fm, sc, mode, bt, bw, bl, fa, fb, wf, qoff, dirn, wc_t,
               tau_lc, tau_lag, th_amb, k2, ex2, tb)
        for i in range(nx):
            xs[i] = x[i] + 0.5 * h * k2[i]
        _deriv(t + 0.5 * h, xs, p, fm, sc, mode, bt, bw, bl, fa, fb, wf, qoff, dirn, wc_t,
               tau_lc, tau_lag, th_amb, k3, ex2, tb)
        for i in range(nx):
            xs[i] = x[i] + h * k3[i]
        _deriv(t + h, xs, p, fm, sc, mode, bt, bw, bl, fa, fb, wf, qoff, dirn, wc_t,
               tau_lc, tau_lag, th_amb, k4, ex2, tb)
        for i in range(nx):
            x[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return rec


@numba.njit(cache=_CACHE)
def _static_twist(target, p, fm, sc):
    """Bisection for the twist Δ at q = 0 whose static transmission torque equals target."""
    tb = np.empty(6)
    lo = -0.05
    hi = 0.05
    if fm[F_BL] >= 0:
        b2 = 2.0 * min(sc[F_BL] * p[P_bl_b], BL_MAX)
        lo -= b2
        hi += b2
    for _ in range(40):  # widen the bracket if a saturated form needs more twist
        _transmission(hi, 0.0, 0.0, hi, 0.0, p, fm, sc, tb)
        if fm[F_HYS] == 0 or fm[F_HYS] == 1:
            _transmission(hi, 0.0, 0.0, hi, tb[4], p, fm, sc, tb)
        if tb[0] >= target or hi > 1.0:
            break
        hi *= 1.5
    for _ in range(40):
        _transmission(lo, 0.0, 0.0, lo, 0.0, p, fm, sc, tb)
        if fm[F_HYS] == 0 or fm[F_HYS] == 1:
            _transmission(lo, 0.0, 0.0, lo, tb[4], p, fm, sc, tb)
        if tb[0] <= target or lo < -1.0:
            break
        lo *= 1.5
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        _transmission(mid, 0.0, 0.0, mid, 0.0, p, fm, sc, tb)
        if fm[F_HYS] == 0 or fm[F_HYS] == 1:
            _transmission(mid, 0.0, 0.0, mid, tb[4], p, fm, sc, tb)
        if tb[0] < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


# ---------------------------------------------------------------------------------------------
# public API
@dataclass
class SensorSpec:
    sample_rate_hz: float = 1000.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    load_noise: float = 200.0
    qd_noise: float = 2e-5
    ud_noise: float = 2e-6
    w_noise: float = 0.02
    current_noise: float = 0.01


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


def nominal_parameters() -> dict[str, float]:
    return {n: float(v) for n, v, _ in _PSPEC}


def _draw(seed: int) -> np.ndarray:
    rng = np.random.default_rng([int(seed), 0x4A4])
    out = np.empty(NPAR)
    for i, (_n, v, kind) in enumerate(_PSPEC):
        x = rng.uniform(-1.0, 1.0)
        if kind == "rel":
            out[i] = v * (1.0 + 0.08 * x)
        elif kind == "kt":
            out[i] = v * (1.0 + 0.03 * x)
        elif kind.startswith("abs:"):
            out[i] = v + float(kind[4:]) * x
        elif kind == "phase":
            out[i] = math.pi * (x + 1.0)
        else:
            out[i] = v
    return out


def campaign_parameters(seed) -> dict[str, float]:
    _check_int("seed", seed)
    return {n: float(v) for n, v in zip(_PNAMES, _draw(seed))}


def _check_int(name, v, lo=0, hi=None):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    if v < lo or (hi is not None and v > hi):
        raise ValueError(f"{name} out of range: {v!r}")


def _check_real(name, v, lo=None, hi=None):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a real number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v!r}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name} out of range [{lo}, {hi}]: {v!r}")
    return v


def _check_sensors(sensors):
    if not isinstance(sensors, SensorSpec):
        raise ValueError("sensors must be a SensorSpec")
    _check_real("sensors.sample_rate_hz", sensors.sample_rate_hz, 1.0, 1000.0)
    _check_real("sensors.encoder_res_deg", sensors.encoder_res_deg, 1e-5, 1.0)
    if sensors.encoder_res_deg <= 0:
        raise ValueError("sensors.encoder_res_deg must be > 0")
    _check_real("sensors.torque_noise", sensors.torque_noise, 0.0, 1e5)
    _check_real("sensors.torque_lag_s", sensors.torque_lag_s, 0.0, 1.0)
    _check_real("sensors.load_noise", sensors.load_noise, 0.0, 1e5)
    for nm in ("qd_noise", "ud_noise", "w_noise", "current_noise"):
        _check_real("sensors." + nm, getattr(sensors, nm), 0.0, 1e3)


def _parse_effects(effects):
    fm = -np.ones(len(_FAMILIES), dtype=np.int64)
    sc = np.zeros(len(_FAMILIES))
    if effects is None:
        return fm, sc
    if not isinstance(effects, dict):
        raise ValueError("effects must be a dict {name: {'form': ..., 'scale': ...}}")
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect name {name!r}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale'")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}]: unknown keys {sorted(extra)}")
        form = spec.get("form")
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}].form: unknown form {form!r}; "
                             f"one of {EFFECT_FORMS[name]}")
        s = _check_real(f"effects[{name!r}].scale", spec.get("scale", 1.0), 0.0)
        if s == 0.0:
            continue  # scale 0 is the nominal rig, bit for bit
        k = _FAMILIES.index(name)
        fm[k] = EFFECT_FORMS[name].index(form)
        sc[k] = s
    return fm, sc


def _profile(scheme, rpm, direction):
    """Breakpoints (t, speed ref, load set point) and phase intervals."""
    w = direction * rpm * _TWO_PI / 60.0 / REDUCTION
    if scheme == 1:
        bt = [0, 1, 3, 4, 29, 32, 57, 59, 61, 62]
        bw = [0, 0, w, w, w, w, w, w, 0, 0]
        bl = [0, 0, 0, 0, T_RATED, T_RATED, 0, 0, 0, 0]
        phases = [(0, 4, "idle"), (4, 29, "load"), (29, 32, "hold"), (32, 57, "unload"),
                  (57, 62, "idle")]
        dur = 62.0
    else:
        bt, bw, bl = [0, 1, 3, 4], [0, 0, w, w], [0, 0, 0, 0]
        phases = [(0, 4, "idle")]
        for k in range(1, 13):
            t0 = 4 + 3 * (k - 1)
            bt += [t0 + 1, t0 + 3]
            bw += [w, w]
            bl += [1e4 * k, 1e4 * k]
            phases += [(t0, t0 + 1, "load"), (t0 + 1, t0 + 3, "hold")]
        bt += [52, 54, 56, 57]
        bw += [w, w, 0, 0]
        bl += [0, 0, 0, 0]
        phases += [(40, 52, "unload"), (52, 57, "idle")]
        dur = 57.0
    return (np.array(bt, float), np.array(bw, float), np.array(bl, float), phases, dur)


def _simulate_truth(scheme, rpm, direction, temp, fm, sc, p, fs, internal_hz=INTERNAL_HZ,
                    duration=None, periods=3):
    fa = _FA * _FSCALE
    fb = _FB * _FSCALE
    l = np.arange(1, 6)
    qoff = float(np.sum(fb / (_WF * l)))
    if scheme == 3:
        bt = np.array([0.0, 1.0])
        bw = np.zeros(2)
        bl = np.zeros(2)
        dur = 20.0 * periods
        phases = [(0, dur, "excite")]
    else:
        bt, bw, bl, phases, dur = _profile(scheme, rpm, direction)
    if duration is not None:
        dur = duration
    fc_t = min(0.25 * fs, 200.0)
    fc_lc = min(0.25 * fs, 100.0)
    wc_t = _TWO_PI * fc_t
    tau_lc = 1.0 / (_TWO_PI * fc_lc)
    tau_lag = 0.0
    if fm[F_DEL] == 1:
        tau_lag = min(max(sc[F_DEL] * p[P_del_tau], LAG_MIN), LAG_MAX)
    elif fm[F_DEL] == 2:
        tau_lag = min(max(0.5 * sc[F_DEL] * p[P_del_tau], LAG_MIN), LAG_MAX)
    # static equilibrium at q = 0
    tau_pd0 = 0.0
    if fm[F_PD] == 0:
        tau_pd0 = min(sc[F_PD] * p[P_pd_a], PD_MAX) * math.sin(p[P_pd_ph])
    elif fm[F_PD] == 1:
        tau_pd0 = min(sc[F_PD] * p[P_pd_a2], PD_MAX / 1.75) * (math.sin(p[P_pd_ph]) + 0.5 * math.sin(0.7)
                                           + 0.25 * math.sin(1.9))
    if fm[F_RIP] == 0:
        tau_pd0 += min(sc[F_RIP] * p[P_rip_a], RIP_MAX) * math.sin(p[P_rip_ph1])
    elif fm[F_RIP] == 1:
        tau_pd0 += min(sc[F_RIP] * p[P_rip_a], RIP_MAX) * (math.sin(p[P_rip_ph1])
                                                           + 0.5 * math.sin(p[P_rip_ph2])
                                                           + 0.25 * math.sin(p[P_rip_ph3]))
    G0 = GRAV * p[P_mr_y]
    T0 = G0 + tau_pd0
    d_eq = _static_twist(T0, p, fm, sc)
    x0 = np.zeros(NX)
    x0[X_U] = d_eq
    tb = np.empty(6)
    xh0 = 0.0
    if fm[F_HYS] in (0, 1):
        _transmission(d_eq, 0.0, 0.0, d_eq, 0.0, p, fm, sc, tb)
        xh0 = tb[4]
    x0[X_H] = xh0
    _transmission(d_eq, 0.0, 0.0, d_eq, xh0, p, fm, sc, tb)
    T_eq = tb[0]
    x0[X_TM] = T_eq
    x0[X_XI] = T_eq / K_I
    x0[X_TH] = temp
    x0[X_AA] = T_eq
    x0[X_LAG] = T_eq
    h = 1.0 / internal_hz
    nsteps = int(round(dur * internal_hz))
    rec = _integrate(x0, p, fm, sc, 3 if scheme == 3 else 1, bt, bw, bl, fa, fb, _WF, qoff,
                     float(direction), wc_t, tau_lc, tau_lag, float(temp), h, nsteps)
    if not np.isfinite(rec).all():
        active = [f"{_FAMILIES[k]}:{EFFECT_FORMS[_FAMILIES[k]][fm[k]]} (scale {sc[k]:g})"
                  for k in range(len(_FAMILIES)) if fm[k] >= 0]
        raise RuntimeError("rig H: the RK4 integration diverged with effects "
                           + (", ".join(active) if active else "none (nominal rig)"))
    return rec, h, dur, phases, fc_t, fc_lc


def simulate_run(scheme: int, motor_speed_rpm, direction: int, temp_joint_c: float,
                 effects: dict, *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    if isinstance(scheme, bool) or scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError("motor_speed_rpm must be None for scheme 3")
        rpm = None
    else:
        rpm = _check_real("motor_speed_rpm", motor_speed_rpm, 1.0, 3000.0)
    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    temp = _check_real("temp_joint_c", temp_joint_c, -20.0, 80.0)
    _check_int("seed", seed)
    _check_int("run", run)
    _check_int("periods", periods, 1, 20)
    _check_sensors(sensors)
    fm, sc = _parse_effects(effects)
    p = _draw(seed)
    fs = float(sensors.sample_rate_hz)
    rec, h, dur, phases, fc_t, fc_lc = _simulate_truth(scheme, rpm or 0.0, int(direction), temp,
                                                       fm, sc, p, fs, periods=periods)
    return _make_run(rec, h, dur, phases, fc_t, fc_lc, scheme, rpm, int(direction), temp, fm,
                     sc, p, seed, run, periods, sensors)


def _make_run(rec, h, dur, phases, fc_t, fc_lc, scheme, rpm, direction, temp, fm, sc, p, seed,
              run, periods, sensors):
    fs = float(sensors.sample_rate_hz)
    n = int(math.floor(dur * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    tg = np.arange(rec.shape[0]) * h

    def at(col, tt=t):
        return np.interp(tt, tg, rec[:, col])

    q, qd, u, ud = at(0), at(1), at(2), at(3)
    T, tauL, th, tm = at(4), at(5), at(6), at(7)
    F_o, qdd, xh = at(13), at(14), at(15)
    # torque reading chain (noise-free part)
    delay = float(sensors.torque_lag_s)
    if fm[F_DEL] == 0:
        delay += min(sc[F_DEL] * p[P_del_d], DELAY_MAX)
    elif fm[F_DEL] == 2:
        delay += min(0.5 * sc[F_DEL] * p[P_del_d], DELAY_MAX)
    chain_col = 9 if fm[F_DEL] in (1, 2) else 8
    tq = at(chain_col, t - delay)
    f = fm[F_OFF]
    if f == 0:
        tq = tq + sc[F_OFF] * p[P_off_c]
    elif f == 1:
        tq = tq + sc[F_OFF] * p[P_off_rate] * t
    elif f == 2:
        tq = tq + sc[F_OFF] * p[P_off_e] * (1.0 - np.exp(-t / p[P_off_tau]))
    if fm[F_DRIFT] == 2:
        tq = tq * (1.0 + sc[F_DRIFT] * p[P_drift_gain] * t)
    tl = at(10)
    if fm[F_DRIFT] == 1:
        tl = tl + sc[F_DRIFT] * p[P_drift_load] * t
    qf, uf = at(11), at(12)
    kts = np.array([p[P_kt1], p[P_kt2], p[P_kt3]])
    i_true = tm[None, :] / (3.0 * REDUCTION * kts[:, None])

    rng = np.random.default_rng([int(seed), int(run), 0x5E4])
    lsb_t = 2 * TORQUE_RANGE / 2 ** ADC_BITS
    lsb_l = 2 * LOAD_RANGE / 2 ** ADC_BITS
    s_q = math.radians(sensors.encoder_res_deg)
    s_u = _TWO_PI / U_COUNTS / REDUCTION
    q_meas = q + p[P_ecc_amp] * np.sin(q + p[P_ecc_phase])
    if fm[F_DRIFT] == 0:
        q_meas = q_meas + sc[F_DRIFT] * p[P_drift_q] * t
    th_m = REDUCTION * u
    u_meas = u + (p[P_interp_a1] * np.sin(ENC_LINES * th_m + p[P_interp_ph1])
                  + p[P_interp_a2] * np.sin(2 * ENC_LINES * th_m + p[P_interp_ph2])) / REDUCTION
    samples = pd.DataFrame({
        "t": t,
        "q": np.round(q_meas / s_q) * s_q,
        "qd": qf + rng.normal(0.0, sensors.qd_noise, n),
        "u": np.round(u_meas / s_u) * s_u,
        "ud": uf + rng.normal(0.0, sensors.ud_noise, n),
        "torque": np.clip(np.round((tq + rng.normal(0.0, sensors.torque_noise, n)) / lsb_t)
                          * lsb_t, -TORQUE_RANGE, TORQUE_RANGE),
        "torque_load": np.clip(np.round((tl + rng.normal(0.0, sensors.load_noise, n)) / lsb_l)
                               * lsb_l, -LOAD_RANGE, LOAD_RANGE),
        "temp_joint": np.round((th + rng.normal(0.0, TEMP_NOISE, n)) / TEMP_RES) * TEMP_RES,
    })
    ph = np.empty(n, dtype=object)
    ph[:] = phases[-1][2]
    for a, b, name in reversed(phases):
        ph[(t >= a) & (t < b)] = name
    samples["phase"] = ph
    for k in range(3):
        samples[f"i_m{k + 1}"] = i_true[k] + rng.normal(0.0, sensors.current_noise, n)
    for k in range(3):
        samples[f"w_m{k + 1}"] = REDUCTION * uf + rng.normal(0.0, sensors.w_noise, n)
    truth = pd.DataFrame({
        "t": t, "q": q, "qd": qd, "u": u, "ud": ud, "twist": u - q, "twist_rate": ud - qd,
        "torque": tq, "torque_load": tl, "torque_true": T, "torque_load_true": tauL,
        "friction_out": F_o, "qdd": qdd, "temp_joint": th, "motor_torque": tm,
        "hyst_state": xh, "i_m1": i_true[0], "i_m2": i_true[1], "i_m3": i_true[2],
    })
    lag_t = math.sqrt(2.0) / (_TWO_PI * fc_t) + float(sensors.torque_lag_s)
    sheet = {
        "q": {"resolution": s_q, "unit": "rad", "accuracy_rad": float(p[P_ecc_amp]) + s_q / 2},
        "u": {"resolution": s_u, "unit": "rad"},
        "torque": {"noise_sd": math.sqrt(sensors.torque_noise ** 2 + lsb_t ** 2 / 12.0),
                   "lag_s": lag_t, "unit": "N·m", "resolution": lsb_t,
                   "range": TORQUE_RANGE, "filter": f"2nd-order Butterworth {fc_t:g} Hz"},
        "torque_load": {"noise_sd": math.sqrt(sensors.load_noise ** 2 + lsb_l ** 2 / 12.0),
                        "lag_s": 1.0 / (_TWO_PI * fc_lc), "unit": "N·m", "resolution": lsb_l,
                        "range": LOAD_RANGE},
        "qd": {"lag_s": TAU_QD, "noise_sd": float(sensors.qd_noise), "unit": "rad/s"},
        "ud": {"lag_s": TAU_UD, "noise_sd": float(sensors.ud_noise), "unit": "rad/s"},
        "temp_joint": {"resolution": TEMP_RES, "noise_sd": TEMP_NOISE, "unit": "°C"},
    }
    for k in range(3):
        sheet[f"i_m{k + 1}"] = {"noise_sd": float(sensors.current_noise), "lag_s": 0.0,
                                "unit": "A"}
        sheet[f"w_m{k + 1}"] = {"noise_sd": float(sensors.w_noise), "lag_s": TAU_UD,
                                "unit": "rad/s"}
    meta = {
        "scheme": int(scheme), "motor_speed_rpm": rpm, "direction": int(direction),
        "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
        "sample_rate_hz": fs, "duration_s": float(t[-1]), "temp_joint_c": float(temp),
        "seed": int(seed), "run": int(run), "periods": int(periods), "sensors": sheet,
    }
    return RigRun(samples=samples, meta=meta, truth=truth)
