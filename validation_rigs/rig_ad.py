"""Rig AD — an independent validation simulator of the CMOR J4 joint test bench.

Written from the paper (shared/seeds/cmor-sghmc-paper.txt), shared/docs/*.md and the run format
(core/channels.py, core/runfile.py, core/run.py) only. Only its public interface (module
constants, SensorSpec fields, RigRun fields, effect names, argument checks, the RunData/metadata
layout) follows rig AC's, so the validation harness drives it the same way; no code and no
functional form is shared with the emulator or another rig. Its own choices: output friction is
a Dahl element (exponent 0.75) plus viscous drag; the compliance is a cubic polynomial whose
structural damper is proportional to the local stiffness (Rayleigh-like) and whose stiffness
falls slightly as the gearbox warms; the three motors are driven by an output-position servo
(P and I on the output angle, damping on the motor speed, model feed-forward, torque limit with
conditional integration); the integrator is semi-implicit (symplectic) Euler at a fixed 0.1 ms
substep; the torque transducer is a second-order Butterworth low-pass followed by white noise
and a 16-bit ADC. SI units (rad, N·m, s, W, J) except temperatures (°C). "Referred" means
referred to the joint output through N = 11000.

DATA SHEET
==========

1. Machine (nominal values; each campaign `seed` draws one machine)
-------------------------------------------------------------------
A value marked (x %) is multiplied by (1 + x/100·ε), ε ~ N(0, 1) clipped to ±2.5, drawn once per
campaign seed (draw_machine); RigRun.params holds the drawn values under the names in brackets.

Output side (paper Eq. 4 with the dynamometer, rig.md signs):

    I·q̈ = T − τ_L − G(q) − F_f + τ_x,        G(q) = g·(mr_x·sin q + mr_y·cos q),  g = 9.81 m/s²

  I = 6685.166 kg·m² (2 %) [I], mr_x = 20.779 kg·m (6 %) [mr_x], mr_y = −34.543 kg·m (6 %)
  [mr_y]; τ_x = the sum of effect torques acting on the output (0 on the nominal machine).

Output friction F_f — a Dahl element for the Coulomb part plus viscous drag:

    F_f = F_d + f_v·q̇,
    dF_d/dq = σ·sgn(e)·|e|^i,   e = 1 − F_d/(c·sgn q̇),   i = 0.75,   σ = f_c/ℓ_d

  c = f_c = 2352.660 N·m (2.5 %) [f_c] (the Coulomb level), f_v = 8683.272 N·m·s/rad (3.5 %)
  [f_v]. Presliding length ℓ_d = 3.0e-5 rad (15 %) [dahl_len]; σ [dahl_sigma] ≈ 7.8e7 N·m/rad.
  With i < 1 the element reaches ±c in a finite displacement: a full reversal from −c to +c
  takes ℓ_d·2^(1−i)/(1−i) ≈ 4.8·ℓ_d ≈ 1.4e-4 rad of output motion (less than one 0.01°
  encoder step). While sliding in one direction F_d = c·sgn q̇ exactly, so the steady friction is
  Eq. 4's f_c·sgn q̇ + f_v·q̇. Nominally independent of load, temperature and direction. At rest
  the element is a presliding spring of stiffness ≤ 1.7·σ (no true stick, no break-away peak).
  At a reversal the output stalls ≈ 0.1 s while the motors wind the transmission through the
  turn (2·f_c ≈ 4.7 kN·m, ≈ 3.9e-4 rad of twist): against f_c·sgn(q̇) the friction then differs
  by up to 2·f_c (UNSTATED_VOCABULARY["hysteresis"]).

Flexible transmission — twist Δ = u − q (the stored torsion is q − u = −Δ):

    T = κ(θ_g)·[K(Δ) + β·K'(Δ)·Δ̇],   K(Δ) = k1·Δ + k3·Δ³,   K'(Δ) = k1 + 3·k3·Δ²
    κ(θ_g) = 1 − κ_T·(θ_g − 25 °C)

  Rated twist Δ_r = 0.5° = 8.7266e-3 rad (3 %) [twist_rated] at 120 kN·m and 25 °C; stiffness
  ratio ρ = K'(Δ_r)/K'(0) = 1.4 (4 %) [stiff_ratio]. Hence k3 = (ρ − 1)·k1/(3·Δ_r²) and
  k1 = 120 kN·m / (Δ_r·(1 + (ρ − 1)/3)) → k1 ≈ 1.213e7 N·m/rad [k1], k3 ≈ 2.12e10 N·m/rad³ [k3].
  Structural damper proportional to the local stiffness: β = 8.0e-3 s (10 %) [beta] (≈ 9.7e4
  N·m·s/rad at zero twist, 1.36e5 at rated; output mode ≈ 6.8 Hz, damping ratio ≈ 0.17).
  Thermal softening κ_T = 5.0e-4 /°C (10 %) [kappa_T] (0.05 %/°C). No backlash, no hysteresis,
  no kinematic error nominally. compliance_torque(twist, params, temp) gives κ·K(Δ).

Motor side (three servo motors on one input shaft, all referred):

    J_M·ü = τ_m − T − F_m(u̇),   J_M = 3·J_m·N²,   F_m = F_mc·u̇/(|u̇| + v_m) + f_mv·u̇

  J_m = 1.2e-3 kg·m² per rotor (3 %) [J_m] → J_M ≈ 4.36e5 kg·m² [J_M]; F_mc = 2640 N·m (5 %)
  [F_mc], v_m = 2e-3 rad/s, f_mv = 21780 N·m·s/rad (5 %) [f_mv] (motor and input-bearing drag,
  not seen by the transducer).
  Servo (the drive reads the output angle from its own absolute encoder, 2^23 counts/rev, not
  the logged one):

    τ_m = sat(τ_ff + K_P·(q_ref − q_c) + D_U·(u̇_ref − u̇) + x_i, ±τ_max),   ẋ_i = K_I·(q_ref − q_c)
    τ_ff = Ĵ·q̈_ref + τ̂_L + Ĝ(q_ref) + f̂_c·q̇_ref/(|q̇_ref| + 2e-4) + f̂_v·q̇_ref
    u̇_ref = q̇_ref + (τ̂_L' + d/dt[f̂_c·q̇_ref/(|q̇_ref| + 2e-4)])/K̂'(Δ̂),   Δ̂' = τ̂_L'/K̂'(Δ̂),
    τ̂_L'' = ω̂_d²·(τ_cmd − τ̂_L) − 2·ζ̂_d·ω̂_d·τ̂_L'
    (the twist lead winds the transmission ahead of the friction's turn at a reversal)

  Ĵ = 3·1.2e-3·N² + 6685.166, Ĝ, f̂_c, f̂_v the nominal values above; τ̂_L the servo's model of
  the dynamometer (ω̂_d = 2π·3 Hz, ζ̂_d = 0.75, no wander); K̂' the nominal cubic's tangent
  stiffness (Δ_r = 0.5°, ρ = 1.4) at the servo's twist estimate Δ̂ (Δ̂(0) = 0);
  K_P = 3·ω_c²·Ĵ, D_U = 3·ω_c·Ĵ, K_I = ω_c³·Ĵ with ω_c = 5 rad/s; τ_max = 1.9e5 N·m; x_i stops
  integrating while τ_m is saturated in the direction the error pushes (conditional integration).
  Motor k current i_k = s_k·τ_m/(N·k_t,k), shares s_k = 1/3 (2 %, normalised) [share1..3],
  k_t = 1.1 N·m/A (2 % each) [kt1..3]; motor speeds w_mk = N·u̇.

Dynamometer (a second-order servo with a slowly wandering error):

    τ̈_L = ω_d²·(g_d·τ_cmd + w(t) − τ_L) − 2·ζ_d·ω_d·τ̇_L
    w(t) = Σ_{j=1..5} A_j·(sin(2π·ν_j·t + φ_j) − sin φ_j)

  g_d = 1 (0.3 %) [dyn_gain], ω_d = 2π·3.0 Hz (8 %) [dyn_freq_hz], ζ_d = 0.75 (5 %) [dyn_zeta];
  the wander w is drawn per run: ν_j uniform in [0.03, 0.6] Hz, φ_j uniform, A_j so that its
  RMS is 120 N·m (well within the ±2 kN·m acceptance band); w(0) = 0.

Thermal (first order, ambient θ_a = temp_joint_c):

    C_g·θ̇_g = |F_f·q̇| + |F_m·u̇| − (θ_g − θ_a)/R_g,   C_g = 3.5e4 J/K, R_g = 0.04 K/W,
                                                      θ_g(0) = θ_a (time constant 1400 s)
    C_m·θ̇_mk = R_w·i_k² − (θ_mk − θ_a)/R_m,         C_m = 1200 J/K, R_m = 0.4 K/W, R_w = 0.6 Ω,
                                                      θ_mk(0) = θ_a + 2 °C

Initial state: q = 0, q̇ = u̇ = 0, F_d = 0, the transmission holds gravity (κ·K(Δ0) = G(0),
u = Δ0), the servo's integrator holds the motor torque T(0).

Integration: semi-implicit (symplectic) Euler at a fixed substep h = 1.0e-4 s: forces from the
state at t, then velocities, then positions with the new velocities, then the displacement-driven
states (Dahl, hysteresis) from the new positions; the transducer filter is advanced with its
exact zero-order-hold discretisation. The state is recorded every 0.5 ms and the samples are
linearly interpolated from that record.

2. Schemes (reference of the servo, output angle q_ref; dynamometer set point τ_cmd ≥ 0)
---------------------------------------------------------------------------------------
  ω_o = rpm·2π/60/N (2.856e-3 rad/s at 300 r/min, 2.856e-2 at 3000). Scheme 1 and 2: the output
  reference runs at direction·ω_o after a smoothstep start (3x² − 2x³ in speed, 0.3 s → 1.3 s);
  loading starts after a 1.5 s lead-in (idle) and a 1.5 s tail (idle) ends the run.
  Scheme 1, period 14 s: τ_cmd rises linearly 0 → 120 kN·m in 7 s (load), falls back in 7 s
  (unload). Scheme 2, period 30.8 s: 12 steps of 10 kN·m, each a 0.4 s ramp (load) and a 2.0 s
  hold (hold), then a 2.0 s ramp to 0 (unload). Scheme 3: a fifth-order Fourier trajectory
  (Eq. 12), ω_f = 2π/16 s, a = (0.5, −0.2, 0.35, −0.4, −0.25)·λ, b = (0.3, −0.45, 0.2, 0.1,
  −0.08)·λ with Σa_l = 0 and Σl·b_l = 0 (q, q̇, q̈ all zero at its start), λ so that the peak
  |q̇| is 0.025 rad/s, times direction; τ_cmd = 0 (the dynamometer idles, coupled); phase
  excite; 1.5 s idle before and after. A run whose travel would pass ±(π − 0.1) rad is refused
  (scheme 2 at 3000 r/min allows up to 3 periods).

3. Sensors (SensorSpec; meta["sensors"] states resolution / noise_sd / lag_s per channel)
-----------------------------------------------------------------------------------------
  q: output encoder, true angle rounded to encoder_res_deg (default 0.01°, stated in rad); no
     noise. qd: true output velocity + white noise qd_noise.
  u: motor encoder (rotor angle / N) rounded to motor_encoder_res (default 2π/2^19/N);
     ud: true + white noise ud_noise. torsion = q − u of the two readings.
  torque: the transmitted torque T through a second-order Butterworth low-pass
     H(s) = ω_b²/(s² + √2·ω_b·s + ω_b²) whose DC group delay √2/ω_b is torque_filter_s (default
     1 ms → ω_b = 1414 rad/s, 225 Hz; 0 = no filter), then a pure lag torque_lag_s, then white
     noise of SD torque_noise (default 90 N·m), then a 16-bit ADC: step torque_res (default
     400 kN·m/2^16 = 6.1035 N·m, i.e. ±200 kN·m full scale), codes clipped to [−2^15, 2^15 − 1].
     Stated: resolution torque_res, noise_sd torque_noise (the quantisation adds step²/12 to
     the variance: < 0.02 % at the defaults), lag_s torque_filter_s + torque_lag_s.
  torque_load: τ_L + white noise load_noise, rounded to load_res. torque_cmd: the set point.
  i_m1..3: true + white noise current_noise. w_m1..3: N·(u̇ + white noise ud_noise), one draw each.
  temp_m1..3, temp_joint: true + white noise temp_noise, rounded to temp_res (default 0.1 °C).
  phase: idle / load / hold / unload / excite. The noise of a run is drawn from (seed, run) in a
  fixed order, independent of the effects, so a run with an effect and the nominal run of the
  same (seed, run) carry the same noise.

4. Effects ({name: {"form", "scale"}}, scale s in [0, SCALE_MAX]; s = 0 is no effect; s = 1 the
   nominal size quoted here; every size is proportional to s unless stated)
----------------------------------------------------------------------------------------------
  Friction effects change the Dahl element's level c and the viscous coefficient f_v of section
  1: c = f_c·m_c + a_c (+ the Stribeck term), f_v,eff = f_v·m_v + a_v, multipliers m clipped at
  ≥ 0.05, c ≥ 1 N·m, f_v,eff ≥ 0. While sliding, F_f = c·sgn q̇ + f_v,eff·q̇. θ_g is the
  gearbox temperature (truth temp_joint), δθ = 30 °C − θ_g; T the transmitted torque;
  H(x) = (1 + tanh(x/1e-4 rad/s))/2 a smooth step of the velocity.
  stribeck (c += 0.2·s·f_c·φ(|q̇|/v_s), v_s = 4e-3 rad/s):
      exponential φ = e^{−x}; gaussian φ = e^{−x²}; lorentzian φ = 1/(1 + x²);
      root_exponential φ = e^{−√x}. Scale 1 at 300 r/min (x = 0.714): +230, +282, +311,
      +201 N·m; at 3000 r/min (x = 7.14): +0.4, 0, +9, +32 N·m.
  load_dependent_friction:
      coulomb_linear a_c += 0.006·s·|T| (+720 N·m at 120 kN·m);
      quadratic_both m_c, m_v ×= 1 + 0.3·s·(T/120 kN·m)² (+30 % of both at rated);
      power_flow a_c += s·|T|·(0.006 + 0.003·tanh(T·q̇/30 W)): 0.009·|T| while the joint drives
      the load (T·q̇ > 0), 0.003·|T| while it is back-driven.
  temperature_friction:
      viscous_vogel m_v ×= 1 + s·(exp(700/(θ_g + 100) − 700/130) − 1) (Vogel law, θ in °C;
      ×1.566 at 20 °C, ×0.573 at 45 °C);
      coulomb_multiplicative m_c ×= 1 + 0.01·s·δθ (+10 % of f_c at 20 °C);
      additive_both a_c += 18·s·δθ N·m, a_v += 320·s·δθ N·m·s/rad (+180 N·m and +3200 N·m·s/rad
      at 20 °C).
  asymmetric_friction:
      coulomb_positive m_c ×= 1 + 0.12·s·H(q̇) (+12 % of f_c in positive motion only);
      viscous_split m_v ×= 1 + 0.3·s·tanh(q̇/1e-4) (f_v·(1 ± 0.3));
      negative_both m_c ×= 1 + 0.08·s·H(−q̇), m_v ×= 1 + 0.25·s·H(−q̇) (negative motion only).
  gear_ripple:
      output_harmonics τ_x += s·(200·sin(84·q + 0.9) + 90·sin(168·q + 2.1)) N·m;
      motor_kinematic: a kinematic error on the motor side, the spring sees Δ + ε,
      ε = s·1.5e-5·(sin(2·N·u + 0.4) + 0.35·sin(4·N·u + 1.3)) rad (2 and 4 cycles per motor
      revolution; the damper sees Δ̇ only). Above the output mode (3000 r/min: 100 and 200 Hz)
      T carries κ·K'(Δ)·ε ≈ 180 N·m at its first order;
      load_modulated τ_x += s·(60 + 1.25·√|T|)·sin(52·q + 0.2) N·m, T in N·m (the mesh ripple
      grows with the square root of the load: 60 N·m unloaded, 335 at 48 kN·m, 493 at rated).
  torque_offset (torque reading, before the ADC):
      constant +350·s N·m; settling +500·s·(1 − e^{−t/25 s}) N·m;
      peak_load_shift +0.004·s·max_{t' ≤ t}|T(t')| N·m (the gauge's zero creeps after a high
      load and keeps the shift: +480 N·m once the run has reached 120 kN·m).
  time_delay (readings):
      torque_latency: the torque reading a further 10·s ms late;
      q_encoder_latency: the q and qd readings 10·s ms late;
      torque_sample_hold: the torque reading refreshed only every P = 8·s ms (fieldbus frame):
      the value at the latest frame boundary floor(t/P)·P (P/2 late on average; noise is still
      drawn per sample).
  hysteresis (a torque h added to T, driven by the engaged twist Δ; H = 1200·s N·m):
      bouc_wen_n3 z = h/H, dz = (dΔ − 0.6·|dΔ|·|z|²·z − 0.4·dΔ·|z|³)/δ_h, δ_h = 2.5e-4 rad;
      masing_tanh backbone H·tanh(Δ/δ_m), δ_m = 2e-4 rad, and after each reversal at (Δ_r, h_r)
      the branch h = h_r + 2H·tanh((Δ − Δ_r)/(2δ_m)), clipped to ±H (Masing's rule);
      dahl_quadratic dh/dΔ = (H/δ_q)·sgn(e)·e², e = 1 − h/(H·sgn Δ̇), δ_q = 1e-4 rad (a Dahl
      loop of exponent 2: round corners, h approaches ±H only as H·δ_q/(distance moved)).
      Scale 1: loading and unloading branches 2H = 2.4 kN·m apart (h → +H while the twist grows,
      −H while it falls, once it has moved a few δ; dahl_quadratic: within 2 % after 5e-3 rad).
  backlash (dead zone of half-width b = 2.5e-4·s rad; the spring and the damper see the engaged
      twist Δ_e and its rate):
      sharp Δ_e = Δ − b·sgn Δ outside |Δ| ≤ b, 0 inside;
      tanh_smoothed Δ_e = Δ − b·tanh(Δ/b) (smooth, monotone, → Δ − b·sgn Δ for |Δ| ≫ b);
      load_closing sharp with b_eff = b·(1 − 0.7·min(1, |τ_L|/120 kN·m)) (a preload closes it).
      Scale 1: +2.5e-4 rad of twist (u − q) at any torque well above zero (load_closing:
      +1.6e-4 at 60 kN·m, +0.75e-4 at 120 kN·m), a flat spot at torque reversals.
  periodic_disturbance (τ_x):
      pump_rectified 380·s·(|sin(π·2.2 Hz·t)| − 2/π) N·m (a rectified pump pulsation, period
      1/2.2 s; fundamental 4/(3π)·380 = 161 N·m at 2.2 Hz);
      fan_modulated 240·s·sin(2π·3.7 Hz·t)·(1 + 0.5·sin(2π·0.37 Hz·t)) N·m.
      The transmission passes them to T magnified as the output's mass on the transmission does,
      |(k + iωD)/(k − I·ω² + iωD)| with k, D the tangent stiffness and damper (×1.1 and ×1.3
      while sliding; less near reversals, where the Dahl element holds the output).
  position_dependent_stiffness (factor f(q) on K and on the damper, clipped at ≥ 0.3):
      gaussian_bump f = 1 + 0.3·s·exp(−(q − 0.35)²/(2·0.12²)); thrice_per_rev f = 1 + 0.08·s
      ·cos(3q + 0.2).
  encoder_drift (readings): q_quadratic q += 1.5e-7·s·t² rad; u_linear u += 5e-6·s·t rad.
  second_resonance:
      output_absorber an inertia I_a = 0.12·s·I hung on the output through a spring/damper
      tuned to 13 Hz, ζ = 0.02 (below 13 Hz it adds I_a to the output inertia);
      motor_coupling the motor side splits into the rotors (0.85·J_M) and the gear input
      (J_g = 0.15·J_M), joined by a coupling of stiffness k_c = J_g·(2π·16 Hz)²/s (≈ 6.6e8/s
      N·m/rad; ζ = 0.03 on the rotor–gear-input mode, ≈ 17 Hz·s^(−1/2)); the motor encoder
      and the servo read the rotors, the transmission twists from the gear input, so the read
      twist u − q grows by T/k_c (≈ 1.8e-4·s rad at 120 kN·m). Scales below 0.002 leave the
      coupling rigid (a deflection under 4e-7 rad).

Truth (RigRun.truth, at the sample instants, without sensor effects): t, q, qd, qdd, u, ud,
twist (u − q, rotor angle), twist_rate, torque (T), torque_sensor (T through the transducer
filter, before lag, noise, offset and ADC), torque_load (τ_L), torque_cmd, friction (F_f),
gravity (G), disturbance (τ_x, including an absorber's reaction), motor_torque (τ_m),
temp_joint (θ_g), temp_m1..3, hysteresis (h).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
import pandas as pd
from scipy.linalg import expm

RIG_NAME = "rig_ad"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "root_exponential"),
    "load_dependent_friction": ("coulomb_linear", "quadratic_both", "power_flow"),
    "temperature_friction": ("viscous_vogel", "coulomb_multiplicative", "additive_both"),
    "gear_ripple": ("output_harmonics", "motor_kinematic", "load_modulated"),
    "torque_offset": ("constant", "settling", "peak_load_shift"),
    "time_delay": ("torque_latency", "q_encoder_latency", "torque_sample_hold"),
    "hysteresis": ("bouc_wen_n3", "masing_tanh", "dahl_quadratic"),
    "backlash": ("sharp", "tanh_smoothed", "load_closing"),
    "asymmetric_friction": ("coulomb_positive", "viscous_split", "negative_both"),
    "periodic_disturbance": ("pump_rectified", "fan_modulated"),
    "position_dependent_stiffness": ("gaussian_bump", "thrice_per_rev"),
    "encoder_drift": ("q_quadratic", "u_linear"),
    "second_resonance": ("output_absorber", "motor_coupling"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "time_delay": (
        "The torque transducer is a second-order Butterworth low-pass whose DC group delay is "
        "SensorSpec.torque_filter_s (1 ms by default), so the torque reading lags the "
        "transmitted torque by about that much at the signal's frequencies; meta "
        "sensors.torque.lag_s states it (plus SensorSpec.torque_lag_s)."),
    "hysteresis": (
        "The output friction's Coulomb part is a Dahl element, a rate-independent hysteresis of "
        "the friction on the output angle: at each reversal of q̇ it turns from ∓f_c to ±f_c "
        "over ≈ 1.4e-4 rad of output motion (under one 0.01° encoder step), and the output "
        "stalls ≈ 0.1 s while the motors wind the transmission through that turn, so the "
        "output law's residual against f_c·sgn(q̇) is up to 2·f_c for ≈ 0.1 s at every "
        "reversal (scheme 3). No run states it; the transmission has no hysteresis nominally."),
}

# --- constants ---------------------------------------------------------------------------------
G_ACC = 9.81
T_RATED = 120_000.0
TWIST_RATED_DEG = 0.5
H_STEP = 1.0e-4                 # integrator substep [s]
REC_EVERY = 5                   # record every 5 substeps
REC_DT = H_STEP * REC_EVERY     # 0.5 ms
TRAVEL_LIMIT = math.pi - 0.1

LEAD_S, TAIL_S = 1.5, 1.5
START_T0, START_T1 = 0.3, 1.3
S1_HALF = 7.0
S2_RAMP, S2_HOLD, S2_NSTEP, S2_UNLOAD = 0.4, 2.0, 12, 2.0
S2_PERIOD = S2_NSTEP * (S2_RAMP + S2_HOLD) + S2_UNLOAD
S3_PERIOD = 16.0
S3_PEAK_QD = 0.025
PHASES = ("idle", "load", "hold", "unload", "excite")

THETA_K0 = 25.0                 # reference temperature of the stiffness [°C]
THETA_F0 = 30.0                 # reference temperature of temperature_friction [°C]
DAHL_EXP = 0.75
CTRL_RES = 2.0 * math.pi / 2 ** 23
K1_HAT = T_RATED / (math.radians(TWIST_RATED_DEG) * (1.0 + 0.4 / 3.0))   # the servo's model
K3_HAT = 0.4 * K1_HAT / (3.0 * math.radians(TWIST_RATED_DEG) ** 2)       # of the compliance
W_CTRL = 5.0
TAU_MAX = 1.9e5
V_M = 2e-3
WD_HAT, ZD_HAT = 2.0 * math.pi * 3.0, 0.75     # the servo's model of the dynamometer
FF_EPS = 2e-4                                   # [rad/s] its friction model's smoothing
J_M_NOM = 3 * 1.2e-3 * REDUCTION ** 2
I_NOM = 6685.166
J_HAT = J_M_NOM + I_NOM
CAP_G, RES_G, CAP_M, RES_M, R_WIND = 3.5e4, 0.04, 1200.0, 0.4, 0.6
ADC_BITS = 16

# effect constants (data sheet section 4)
STRIBECK_RISE = 0.2
STRIBECK_VS = 4e-3
LOAD_MU = 0.006
LOAD_QUAD = 0.3
PF_MU, PF_SPLIT, PF_P0 = 0.006, 0.003, 30.0
VOGEL_B, VOGEL_T0 = 700.0, -100.0
TEMP_MULT = 0.01
TEMP_ADD_C, TEMP_ADD_V = 18.0, 320.0
ASYM_POS, ASYM_VSPLIT, ASYM_NEG_C, ASYM_NEG_V = 0.12, 0.3, 0.08, 0.25
V_SMOOTH = 1e-4
RIP_Z1, RIP_A1, RIP_P1, RIP_A2, RIP_P2 = 84.0, 200.0, 0.9, 90.0, 2.1
KE_AMP, KE_P1, KE_R2, KE_P2 = 1.5e-5, 0.4, 0.35, 1.3
LM_Z, LM_A0, LM_A1, LM_P = 52.0, 60.0, 1.25, 0.2
OFF_CONST, OFF_SETTLE, OFF_SETTLE_TC, OFF_PEAK = 350.0, 500.0, 25.0, 0.004
DELAY_S = 0.010
HOLD_S = 0.008
HYST_H, HYST_BW_D, HYST_BW_BETA, HYST_BW_GAMMA = 1200.0, 2.5e-4, 0.6, 0.4
HYST_MASING_D = 2e-4
HYST_DAHL_D = 1.0e-4
BACKLASH_B, BACKLASH_CLOSE = 2.5e-4, 0.7
PUMP_A, PUMP_F = 380.0, 2.2
FAN_A, FAN_F, FAN_FM = 240.0, 3.7, 0.37
BUMP_A, BUMP_Q, BUMP_W = 0.3, 0.35, 0.12
TPR_A, TPR_P = 0.08, 0.2
DRIFT_Q, DRIFT_U = 1.5e-7, 5e-6
ABS_RATIO, ABS_F, ABS_Z = 0.12, 13.0, 0.02
CPL_RATIO, CPL_F, CPL_Z, CPL_MIN_SCALE = 0.15, 16.0, 0.03, 2e-3


def _fourier_base() -> tuple[np.ndarray, np.ndarray]:
    a = np.array([0.5, -0.2, 0.35, -0.4, -0.25])
    b = np.array([0.3, -0.45, 0.2, 0.1, -0.08])
    tt = np.linspace(0.0, S3_PERIOD, 20001)
    wf = 2 * math.pi / S3_PERIOD
    qd = sum(a[i] * np.cos(wf * (i + 1) * tt) + b[i] * np.sin(wf * (i + 1) * tt) for i in range(5))
    lam = S3_PEAK_QD / np.abs(qd).max()
    return a * lam, b * lam


FOURIER_A, FOURIER_B = _fourier_base()

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
    torque_noise: float = 90.0          # white noise SD at the ADC input [N·m]
    torque_lag_s: float = 0.0           # pure lag of the torque reading [s]
    torque_filter_s: float = 1e-3       # Butterworth (2nd order) DC group delay √2/ω_b [s]
    torque_res: float = 400_000.0 / 2 ** ADC_BITS   # 16-bit ADC step [N·m] (0: none)
    load_noise: float = 60.0            # dynamometer torque noise SD [N·m]
    load_res: float = 4.0               # its step [N·m]
    qd_noise: float = 1.5e-5            # output velocity noise SD [rad/s]
    motor_encoder_res: float = 2 * math.pi / 2 ** 19 / REDUCTION  # referred step [rad]
    ud_noise: float = 3e-6              # referred motor velocity noise SD [rad/s]
    current_noise: float = 0.015        # current noise SD [A]
    temp_res: float = 0.1               # temperature step [°C]
    temp_noise: float = 0.02            # temperature noise SD [°C]

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


# --- argument checks ---------------------------------------------------------------------------

def _is_int(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_num(v: Any) -> bool:
    return (isinstance(v, (int, float, np.integer, np.floating))
            and not isinstance(v, (bool, np.bool_)))


def _check_effects(effects: Any) -> dict[str, tuple[str, float]]:
    """{name: (form, scale)} of the effects with a positive scale; ValueError naming the fault."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError("effects must be a dict {name: {'form', 'scale'}} or None, got "
                         f"{type(effects).__name__}")
    chosen: dict[str, tuple[str, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale', "
                             f"got {spec!r}")
        unknown = sorted(set(spec) - {"form", "scale"})
        if unknown:
            raise ValueError(f"effects[{name!r}] has unknown keys {unknown}; expected 'form' "
                             "and 'scale'")
        form = spec.get("form")
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; known: "
                             f"{list(EFFECT_FORMS[name])}")
        s = spec.get("scale", 1.0)
        if not _is_num(s) or not math.isfinite(float(s)):
            raise ValueError(f"effects[{name!r}]['scale'] must be a finite number, got {s!r}")
        s = float(s)
        if s < 0.0:
            raise ValueError(f"effects[{name!r}]['scale'] must be >= 0, got {s!r}")
        if s > SCALE_MAX:
            raise ValueError(f"effects[{name!r}]['scale'] must be <= SCALE_MAX = {SCALE_MAX:g} "
                             f"(larger scales are refused), got {s!r}")
        if s > 0.0:
            chosen[name] = (form, s)
    return chosen


def _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, sensors, periods, seed, run):
    if not _is_int(scheme) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if int(scheme) == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
    elif not _is_num(motor_speed_rpm) or float(motor_speed_rpm) not in (300.0, 3000.0):
        raise ValueError(f"motor_speed_rpm must be 300 or 3000 for scheme {int(scheme)}, got "
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


def run_duration(scheme: int, periods: int) -> float:
    """Length of a run [s]: lead-in, `periods` periods of the scheme, tail."""
    per = {1: 2 * S1_HALF, 2: S2_PERIOD, 3: S3_PERIOD}[int(scheme)]
    return LEAD_S + int(periods) * per + TAIL_S


def _travel(scheme: int, rpm: float, periods: int) -> float:
    w = rpm * 2.0 * math.pi / 60.0 / REDUCTION
    return w * (run_duration(scheme, periods) - 0.5 * (START_T0 + START_T1))


# --- the machine ---------------------------------------------------------------------------------

_SALT = 0xAD0C0DE
_NOMINAL: dict[str, tuple[float, float]] = {   # name: (value, relative SD)
    "I": (I_NOM, 0.02), "mr_x": (20.779, 0.06), "mr_y": (-34.543, 0.06),
    "f_c": (2352.660, 0.025), "f_v": (8683.272, 0.035), "dahl_len": (3.0e-5, 0.15),
    "twist_rated": (math.radians(TWIST_RATED_DEG), 0.03), "stiff_ratio": (1.4, 0.04),
    "beta": (8.0e-3, 0.10), "kappa_T": (5.0e-4, 0.10), "J_m": (1.2e-3, 0.03),
    "F_mc": (2640.0, 0.05), "f_mv": (21780.0, 0.05),
    "kt1": (1.1, 0.02), "kt2": (1.1, 0.02), "kt3": (1.1, 0.02),
    "share1": (1 / 3, 0.02), "share2": (1 / 3, 0.02), "share3": (1 / 3, 0.02),
    "dyn_gain": (1.0, 0.003), "dyn_freq_hz": (3.0, 0.08), "dyn_zeta": (0.75, 0.05),
}


def draw_machine(seed: int) -> dict[str, float]:
    """The machine of campaign `seed` (data sheet section 1), with the derived values."""
    rng = np.random.default_rng([_SALT, int(seed)])
    eps = np.clip(rng.standard_normal(len(_NOMINAL)), -2.5, 2.5)
    m = {k: float(v * (1.0 + sd * e)) for (k, (v, sd)), e in zip(_NOMINAL.items(), eps)}
    tot = m["share1"] + m["share2"] + m["share3"]
    for k in ("share1", "share2", "share3"):
        m[k] /= tot
    dr, rho = m["twist_rated"], m["stiff_ratio"]
    m["k1"] = T_RATED / (dr * (1.0 + (rho - 1.0) / 3.0))
    m["k3"] = (rho - 1.0) * m["k1"] / (3.0 * dr * dr)
    m["dahl_sigma"] = m["f_c"] / m["dahl_len"]
    m["J_M"] = 3.0 * m["J_m"] * REDUCTION ** 2
    m["D0"] = m["beta"] * m["k1"]
    return m


def compliance_torque(twist: np.ndarray, params: dict,
                      temp_joint_c: float = THETA_K0) -> np.ndarray:
    """Static transmission torque κ(θ)·(k1·Δ + k3·Δ³) of the nominal machine [N·m]."""
    d = np.asarray(twist, dtype=float)
    kap = 1.0 - params["kappa_T"] * (temp_joint_c - THETA_K0)
    return kap * (params["k1"] * d + params["k3"] * d ** 3)


def _twist_for(torque: float, m: dict, temp: float) -> float:
    kap = 1.0 - m["kappa_T"] * (temp - THETA_K0)
    d = torque / (kap * m["k1"])
    for _ in range(50):
        f = kap * (m["k1"] * d + m["k3"] * d ** 3) - torque
        d -= f / (kap * (m["k1"] + 3 * m["k3"] * d * d))
    return d


# --- kernel layout -------------------------------------------------------------------------------
# parameter vector
P_I, P_MRX, P_MRY, P_FC, P_FV, P_SIG, P_K1, P_K3, P_BETA, P_KAP = range(10)
P_JM, P_FMC, P_FMV, P_KT1, P_KT2, P_KT3, P_W1, P_W2, P_W3 = range(10, 19)
P_DG, P_DW, P_DZ, P_SCHEME, P_DIR, P_OMEGA, P_PERIODS, P_AMB = range(19, 27)
P_FB11, P_FB12, P_FB21, P_FB22, P_GB1, P_GB2, P_FON = range(27, 34)
N_P = 34
# record columns
(RC_Q, RC_QD, RC_QDD, RC_U, RC_UD, RC_T, RC_TS, RC_TL, RC_TCMD, RC_FF, RC_G, RC_TX, RC_TM, RC_TG,
 RC_TM1, RC_TM2, RC_TM3, RC_I1, RC_I2, RC_I3, RC_H, RC_PH) = range(22)
N_RC = 22
N_FAM = len(EFFECT_FORMS)
_FAMILY = {name: i for i, name in enumerate(EFFECT_FORMS)}
F_STR, F_LOAD, F_TEMP, F_RIP, F_OFF, F_DEL, F_HYS, F_BL, F_ASYM, F_PER, F_POS, F_DRIFT, F_RES = \
    range(13)


@numba.njit(cache=True)
def _program(t, scheme, om, dirn, periods, fa, fb):
    """(q_ref, q̇_ref, q̈_ref, τ_cmd, τ̇_cmd, phase code) at time t."""
    qr = 0.0
    qdr = 0.0
    qddr = 0.0
    tc = 0.0
    tcd = 0.0
    ph = 0
    tt = t - LEAD_S
    if scheme == 3:
        wf = 2.0 * math.pi / S3_PERIOD
        if tt >= 0.0 and tt < periods * S3_PERIOD:
            ph = 4
            for i in range(5):
                lw = wf * (i + 1)
                s = math.sin(lw * tt)
                c = math.cos(lw * tt)
                qr += fa[i] / lw * s - fb[i] / lw * c + fb[i] / lw
                qdr += fa[i] * c + fb[i] * s
                qddr += -fa[i] * lw * s + fb[i] * lw * c
        return dirn * qr, dirn * qdr, dirn * qddr, 0.0, 0.0, ph
    d = START_T1 - START_T0
    if t <= START_T0:
        pass
    elif t < START_T1:
        x = (t - START_T0) / d
        qr = om * d * (x ** 3 - 0.5 * x ** 4)
        qdr = om * (3.0 * x * x - 2.0 * x ** 3)
        qddr = om * (6.0 * x - 6.0 * x * x) / d
    else:
        qr = om * (0.5 * d + (t - START_T1))
        qdr = om
    if scheme == 1:
        per = 2.0 * S1_HALF
    else:
        per = S2_PERIOD
    if tt >= 0.0 and tt < periods * per:
        tp = tt - math.floor(tt / per) * per
        if scheme == 1:
            if tp < S1_HALF:
                tc = T_RATED * tp / S1_HALF
                tcd = T_RATED / S1_HALF
                ph = 1
            else:
                tc = T_RATED * (2.0 * S1_HALF - tp) / S1_HALF
                tcd = -T_RATED / S1_HALF
                ph = 3
        else:
            stp = S2_RAMP + S2_HOLD
            j = int(math.floor(tp / stp))
            dstep = T_RATED / S2_NSTEP
            if j < S2_NSTEP:
                r = tp - j * stp
                if r < S2_RAMP:
                    tc = dstep * (j + r / S2_RAMP)
                    tcd = dstep / S2_RAMP
                    ph = 1
                else:
                    tc = dstep * (j + 1)
                    ph = 2
            else:
                r = tp - S2_NSTEP * stp
                tc = T_RATED * (1.0 - r / S2_UNLOAD)
                tcd = -T_RATED / S2_UNLOAD
                ph = 3
    return dirn * qr, dirn * qdr, dirn * qddr, tc, tcd, ph


@numba.njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@numba.njit(cache=True)
def _integrate(p, ef, es, fa, fb, wand, init, nrec):
    """Semi-implicit Euler over nrec·REC_EVERY substeps; returns the (nrec, N_RC) record."""
    h = H_STEP
    rec = np.zeros((nrec, N_RC))
    scheme = int(p[P_SCHEME])
    dirn = p[P_DIR]
    om = p[P_OMEGA]
    periods = p[P_PERIODS]
    amb = p[P_AMB]
    inert = p[P_I]
    mrx = p[P_MRX]
    mry = p[P_MRY]
    fc0 = p[P_FC]
    fv0 = p[P_FV]
    sig = p[P_SIG]
    k1 = p[P_K1]
    k3 = p[P_K3]
    beta = p[P_BETA]
    kap = p[P_KAP]
    jm = p[P_JM]
    fmc = p[P_FMC]
    fmv = p[P_FMV]
    n = REDUCTION
    kp = 3.0 * W_CTRL ** 2 * J_HAT
    du = 3.0 * W_CTRL * J_HAT
    ki = W_CTRL ** 3 * J_HAT
    wd = 2.0 * math.pi * p[P_DW]
    zd = p[P_DZ]
    dg = p[P_DG]
    fon = p[P_FON] > 0.5

    # effect forms and scales
    fs_ = ef[F_STR]
    ss = es[F_STR]
    fl = ef[F_LOAD]
    sl = es[F_LOAD]
    ft = ef[F_TEMP]
    st = es[F_TEMP]
    fr = ef[F_RIP]
    sr = es[F_RIP]
    fh = ef[F_HYS]
    sh = es[F_HYS]
    fbl = ef[F_BL]
    sbl = es[F_BL]
    fasy = ef[F_ASYM]
    sasy = es[F_ASYM]
    fper = ef[F_PER]
    sper = es[F_PER]
    fpos = ef[F_POS]
    spos = es[F_POS]
    fres = ef[F_RES]
    sres = es[F_RES]

    # state
    q = 0.0
    qd = 0.0
    u = init[0]
    ud = 0.0
    fd = 0.0
    xi = init[1]
    tg = amb
    tm1 = amb + 2.0
    tm2 = amb + 2.0
    tm3 = amb + 2.0
    tl = 0.0
    tld = 0.0
    lm = 0.0
    lmd = 0.0
    dh = 0.0
    x1 = init[2]
    x2 = 0.0
    hy = 0.0
    z = 0.0
    # Masing memory
    m_dr = 0.0
    m_hr = 0.0
    m_dir = 0.0
    # absorber
    ia = ABS_RATIO * sres * inert if fres == 0 else 0.0
    ka = ia * (2.0 * math.pi * ABS_F) ** 2
    ca = 2.0 * ABS_Z * math.sqrt(ka * ia) if ia > 0.0 else 0.0
    qa = 0.0
    qad = 0.0
    # motor coupling
    jg = CPL_RATIO * jm if (fres == 1 and sres >= CPL_MIN_SCALE) else 0.0
    jr = jm - jg
    kc = jg * (2.0 * math.pi * CPL_F) ** 2 / sres if jg > 0.0 else 0.0
    cc = 2.0 * CPL_Z * math.sqrt(kc * jg * jr / jm) if jg > 0.0 else 0.0
    ug = u
    ugd = 0.0
    if jg > 0.0:
        u = u + init[3] / kc      # the coupling carries the initial torque
    wsum = 0.0
    nw = wand.shape[0]

    nsteps = nrec * REC_EVERY
    for k in range(nsteps):
        t = k * h
        qr, qdr, qddr, tc, _tcd, ph = _program(t, scheme, om, dirn, periods, fa, fb)
        if k % REC_EVERY == 0:
            wsum = 0.0
            for j in range(nw):
                wsum += wand[j, 0] * (math.sin(wand[j, 1] * t + wand[j, 2]) - math.sin(wand[j, 2]))

        # --- transmission
        if jg > 0.0:
            dlt = ug - q
            dltd = ugd - qd
        else:
            dlt = u - q
            dltd = ud - qd
        if fbl < 0:
            de = dlt
            gb = 1.0
        elif fbl == 1:
            b = BACKLASH_B * sbl
            th = math.tanh(dlt / b)
            de = dlt - b * th
            gb = th * th
        else:
            b = BACKLASH_B * sbl
            if fbl == 2:
                b = b * (1.0 - BACKLASH_CLOSE * min(1.0, abs(tl) / T_RATED))
            if dlt > b:
                de = dlt - b
                gb = 1.0
            elif dlt < -b:
                de = dlt + b
                gb = 1.0
            else:
                de = 0.0
                gb = 0.0
        ded = gb * dltd
        dk = de
        if fr == 1:
            nu = n * u
            dk = de + sr * KE_AMP * (math.sin(2.0 * nu + KE_P1)
                                     + KE_R2 * math.sin(4.0 * nu + KE_P2))
        kf = 1.0 - kap * (tg - THETA_K0)
        if fpos == 0:
            kf *= max(0.3, 1.0 + BUMP_A * spos * math.exp(-0.5 * ((q - BUMP_Q) / BUMP_W) ** 2))
        elif fpos == 1:
            kf *= max(0.3, 1.0 + TPR_A * spos * math.cos(3.0 * q + TPR_P))
        kspring = kf * (k1 * dk + k3 * dk * dk * dk)
        ktan = kf * (k1 + 3.0 * k3 * dk * dk)
        tq = kspring + beta * ktan * ded + hy

        # --- friction levels
        mc = 1.0
        mv = 1.0
        ac = 0.0
        av = 0.0
        aqd = abs(qd)
        if fl == 0:
            ac += LOAD_MU * sl * abs(tq)
        elif fl == 1:
            g = 1.0 + LOAD_QUAD * sl * (tq / T_RATED) ** 2
            mc *= g
            mv *= g
        elif fl == 2:
            ac += sl * abs(tq) * (PF_MU + PF_SPLIT * math.tanh(tq * qd / PF_P0))
        if ft >= 0:
            dth = THETA_F0 - tg
            if ft == 0:
                vg = VOGEL_B / (tg - VOGEL_T0) - VOGEL_B / (THETA_F0 - VOGEL_T0)
                mv *= 1.0 + st * (math.exp(vg) - 1.0)
            elif ft == 1:
                mc *= 1.0 + TEMP_MULT * st * dth
            else:
                ac += TEMP_ADD_C * st * dth
                av += TEMP_ADD_V * st * dth
        if fasy >= 0:
            hp = 0.5 * (1.0 + math.tanh(qd / V_SMOOTH))
            if fasy == 0:
                mc *= 1.0 + ASYM_POS * sasy * hp
            elif fasy == 1:
                mv *= 1.0 + ASYM_VSPLIT * sasy * math.tanh(qd / V_SMOOTH)
            else:
                mc *= 1.0 + ASYM_NEG_C * sasy * (1.0 - hp)
                mv *= 1.0 + ASYM_NEG_V * sasy * (1.0 - hp)
        c = fc0 * max(mc, 0.05) + ac
        if fs_ >= 0:
            x = aqd / STRIBECK_VS
            if fs_ == 0:
                phi = math.exp(-x)
            elif fs_ == 1:
                phi = math.exp(-x * x)
            elif fs_ == 2:
                phi = 1.0 / (1.0 + x * x)
            else:
                phi = math.exp(-math.sqrt(x))
            c += STRIBECK_RISE * ss * fc0 * phi
        c = max(c, 1.0)
        fv = max(fv0 * max(mv, 0.05) + av, 0.0)
        ff = fd + fv * qd

        # --- disturbances on the output
        tx = 0.0
        if fr == 0:
            tx += sr * (RIP_A1 * math.sin(RIP_Z1 * q + RIP_P1)
                        + RIP_A2 * math.sin(2.0 * RIP_Z1 * q + RIP_P2))
        elif fr == 2:
            tx += sr * (LM_A0 + LM_A1 * math.sqrt(abs(tq))) * math.sin(LM_Z * q + LM_P)
        if fper == 0:
            tx += PUMP_A * sper * (abs(math.sin(math.pi * PUMP_F * t)) - 2.0 / math.pi)
        elif fper == 1:
            tx += (FAN_A * sper * math.sin(2.0 * math.pi * FAN_F * t)
                   * (1.0 + 0.5 * math.sin(2.0 * math.pi * FAN_FM * t)))
        if ia > 0.0:
            tx += ka * (qa - q) + ca * (qad - qd)
        grav = G_ACC * (mrx * math.sin(q) + mry * math.cos(q))
        qdd = (tq - tl - grav - ff + tx) / inert

        # --- servo
        qc = math.floor(q / CTRL_RES + 0.5) * CTRL_RES
        eq = qr - qc
        tff = (J_HAT * qddr + lm + G_ACC * (20.779 * math.sin(qr) - 34.543 * math.cos(qr))
               + 2352.660 * qdr / (abs(qdr) + FF_EPS) + 8683.272 * qdr)
        # the twist the friction's turn needs, led ahead (d/dt of f̂_c·sat(q̇_ref)/K̂')
        ktn = K1_HAT + 3.0 * K3_HAT * dh * dh
        aq = abs(qdr) + FF_EPS
        udr = qdr + lmd / ktn + 2352.660 * FF_EPS / (aq * aq) * qddr / ktn
        tmu = tff + kp * eq + du * (udr - ud) + xi
        tm = min(max(tmu, -TAU_MAX), TAU_MAX)
        if tm == tmu or eq * tmu < 0.0:
            xi += h * ki * eq
        fm = fmc * ud / (abs(ud) + V_M) + fmv * ud
        if jg > 0.0:
            tcpl = kc * (u - ug) + cc * (ud - ugd)
            udd = (tm - tcpl - fm) / jr
            # the gear input's own damping terms are taken implicitly (linearly implicit
            # Euler in its velocity): the stiff coupling of a small scale stays stable
            ctot = cc + beta * ktan * gb
            ugdd = (tcpl - tq) / jg / (1.0 + h * ctot / jg)
        else:
            udd = (tm - tq - fm) / jm
            ugdd = 0.0
        i1 = p[P_W1] * tm / (n * p[P_KT1])
        i2 = p[P_W2] * tm / (n * p[P_KT2])
        i3 = p[P_W3] * tm / (n * p[P_KT3])

        if k % REC_EVERY == 0:
            r = k // REC_EVERY
            rec[r, RC_Q] = q
            rec[r, RC_QD] = qd
            rec[r, RC_QDD] = qdd
            rec[r, RC_U] = u
            rec[r, RC_UD] = ud
            rec[r, RC_T] = tq
            rec[r, RC_TS] = x1 if fon else tq
            rec[r, RC_TL] = tl
            rec[r, RC_TCMD] = tc
            rec[r, RC_FF] = ff
            rec[r, RC_G] = grav
            rec[r, RC_TX] = tx
            rec[r, RC_TM] = tm
            rec[r, RC_TG] = tg
            rec[r, RC_TM1] = tm1
            rec[r, RC_TM2] = tm2
            rec[r, RC_TM3] = tm3
            rec[r, RC_I1] = i1
            rec[r, RC_I2] = i2
            rec[r, RC_I3] = i3
            rec[r, RC_H] = hy
            rec[r, RC_PH] = ph

        # --- step: velocities, then positions with the new velocities
        qd_old = qd
        q_old = q
        qd += h * qdd
        q += h * qd
        ud += h * udd
        u += h * ud
        if jg > 0.0:
            ugd += h * ugdd
            ug += h * ugd
        if ia > 0.0:
            qadd = -(ka * (qa - q_old) + ca * (qad - qd_old)) / ia
            qad += h * qadd
            qa += h * qad

        # Dahl element, driven by the output displacement
        dq = q - q_old
        if dq != 0.0:
            tgt = c * _sgn(dq)
            e = 1.0 - fd / tgt
            fnew = fd + sig * dq * _sgn(e) * abs(e) ** DAHL_EXP
            if (tgt - fd) * (tgt - fnew) < 0.0:
                fnew = tgt
            fd = fnew

        # hysteresis, driven by the engaged twist of the new positions
        if fh >= 0:
            if jg > 0.0:
                dn = ug - q
            else:
                dn = u - q
            if fbl < 0:
                den = dn
            elif fbl == 1:
                b = BACKLASH_B * sbl
                den = dn - b * math.tanh(dn / b)
            else:
                b = BACKLASH_B * sbl
                if fbl == 2:
                    b = b * (1.0 - BACKLASH_CLOSE * min(1.0, abs(tl) / T_RATED))
                den = dn - b if dn > b else (dn + b if dn < -b else 0.0)
            dde = den - de
            hh = HYST_H * sh
            if fh == 0:
                az = abs(z)
                z += (dde - HYST_BW_BETA * abs(dde) * az * az * z
                      - HYST_BW_GAMMA * dde * az ** 3) / HYST_BW_D
                z = min(max(z, -1.05), 1.05)
                hy = hh * z
            elif fh == 1:
                if dde > 0.0 and m_dir <= 0.0:
                    m_dir = 1.0
                    m_dr = de
                    m_hr = hy
                elif dde < 0.0 and m_dir >= 0.0:
                    m_dir = -1.0
                    m_dr = de
                    m_hr = hy
                if m_dir != 0.0:
                    hy = m_hr + 2.0 * hh * math.tanh((den - m_dr) / (2.0 * HYST_MASING_D))
                    hy = min(max(hy, -hh), hh)
            else:
                if dde != 0.0:
                    tgt = hh * _sgn(dde)
                    e = 1.0 - hy / tgt
                    hnew = hy + hh / HYST_DAHL_D * dde * _sgn(e) * e * e
                    if (tgt - hy) * (tgt - hnew) < 0.0:
                        hnew = tgt
                    hy = hnew

        # the servo's model of the dynamometer
        lmdd = WD_HAT * WD_HAT * (tc - lm) - 2.0 * ZD_HAT * WD_HAT * lmd
        lmd += h * lmdd
        lm += h * lmd
        dh += h * lmd / (K1_HAT + 3.0 * K3_HAT * dh * dh)
        # the dynamometer
        tldd = wd * wd * (dg * tc + wsum - tl) - 2.0 * zd * wd * tld
        tld += h * tldd
        tl += h * tld

        # transducer filter (exact ZOH of the 2nd-order Butterworth)
        if fon:
            nx1 = p[P_FB11] * x1 + p[P_FB12] * x2 + p[P_GB1] * tq
            nx2 = p[P_FB21] * x1 + p[P_FB22] * x2 + p[P_GB2] * tq
            x1 = nx1
            x2 = nx2

        # thermal
        pg = abs(ff * qd_old) + abs(fm * ud)
        tg += h * (pg - (tg - amb) / RES_G) / CAP_G
        tm1 += h * (R_WIND * i1 * i1 - (tm1 - amb) / RES_M) / CAP_M
        tm2 += h * (R_WIND * i2 * i2 - (tm2 - amb) / RES_M) / CAP_M
        tm3 += h * (R_WIND * i3 * i3 - (tm3 - amb) / RES_M) / CAP_M
    return rec


# --- readings helpers ---------------------------------------------------------------------------

def _quant(x: np.ndarray, step: float) -> np.ndarray:
    if step <= 0.0:
        return np.asarray(x, dtype=float)
    return np.round(np.asarray(x, dtype=float) / step) * step


def _adc(x: np.ndarray, step: float) -> np.ndarray:
    """16-bit converter: codes round(x/step) clipped to [−2^15, 2^15 − 1]."""
    if step <= 0.0:
        return np.asarray(x, dtype=float)
    codes = np.clip(np.round(x / step), -2 ** (ADC_BITS - 1), 2 ** (ADC_BITS - 1) - 1)
    return codes * step


def _butterworth_zoh(tau_g: float, h: float) -> np.ndarray:
    """[Φ11, Φ12, Φ21, Φ22, Γ1, Γ2] of H(s) = ω²/(s² + √2ωs + ω²), ω = √2/tau_g, held input."""
    w = math.sqrt(2.0) / tau_g
    a = np.array([[0.0, 1.0], [-w * w, -math.sqrt(2.0) * w]])
    bvec = np.array([0.0, w * w])
    m = np.zeros((3, 3))
    m[:2, :2] = a * h
    m[:2, 2] = bvec * h
    e = expm(m)
    return np.array([e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[0, 2], e[1, 2]])


# --- the run ------------------------------------------------------------------------------------

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """One bench run of rig AD (see the module data sheet). `seed` is the campaign (it draws the
    machine), `run` the run within it (it draws the noise and the dynamometer's wander)."""
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
    duration = run_duration(scheme, periods)

    def form(name: str) -> str | None:
        return eff[name][0] if name in eff else None

    def scale(name: str) -> float:
        return eff[name][1] if name in eff else 0.0

    ef = np.full(N_FAM, -1, dtype=np.int64)
    es = np.zeros(N_FAM)
    for name, (f, s) in eff.items():
        ef[_FAMILY[name]] = EFFECT_FORMS[name].index(f)
        es[_FAMILY[name]] = s

    p = np.zeros(N_P)
    p[P_I], p[P_MRX], p[P_MRY], p[P_FC], p[P_FV] = m["I"], m["mr_x"], m["mr_y"], m["f_c"], m["f_v"]
    p[P_SIG], p[P_K1], p[P_K3], p[P_BETA], p[P_KAP] = (m["dahl_sigma"], m["k1"], m["k3"],
                                                       m["beta"], m["kappa_T"])
    p[P_JM], p[P_FMC], p[P_FMV] = m["J_M"], m["F_mc"], m["f_mv"]
    p[P_KT1], p[P_KT2], p[P_KT3] = m["kt1"], m["kt2"], m["kt3"]
    p[P_W1], p[P_W2], p[P_W3] = m["share1"], m["share2"], m["share3"]
    p[P_DG], p[P_DW], p[P_DZ] = m["dyn_gain"], m["dyn_freq_hz"], m["dyn_zeta"]
    p[P_SCHEME], p[P_DIR] = scheme, dirn
    p[P_OMEGA] = 0.0 if rpm is None else rpm * 2.0 * math.pi / 60.0 / REDUCTION
    p[P_PERIODS], p[P_AMB] = periods, amb
    if sens.torque_filter_s > 0.0:
        p[P_FB11:P_GB2 + 1] = _butterworth_zoh(sens.torque_filter_s, H_STEP)
        p[P_FON] = 1.0

    # the dynamometer's wander (per run)
    rw = np.random.default_rng([_SALT, seed, run, 1])
    nu = rw.uniform(0.03, 0.6, 5)
    phs = rw.uniform(0.0, 2 * math.pi, 5)
    amp = rw.uniform(0.5, 1.0, 5)
    amp *= 120.0 / math.sqrt(0.5 * np.sum(amp ** 2))
    wand = np.column_stack([amp, 2 * math.pi * nu, phs])

    # initial state: the transmission holds gravity
    g0 = G_ACC * m["mr_y"]
    d0 = _twist_for(g0, m, amb)
    if "backlash" in eff:
        d0 += BACKLASH_B * scale("backlash") * (1.0 if g0 >= 0 else -1.0)
    init = np.array([d0, g0 - G_ACC * (-34.543), g0, g0])

    nrec = int(math.ceil(duration / REC_DT)) + 1
    rec = _integrate(p, ef, es, FOURIER_A, FOURIER_B, wand, init, nrec)
    tr = np.arange(nrec) * REC_DT

    n = int(math.floor(duration * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    t = t[t <= tr[-1] + 1e-12]
    n = len(t)

    def at(col: int, lag: float = 0.0, tt: np.ndarray | None = None) -> np.ndarray:
        return np.interp((t if tt is None else tt) - lag, tr, rec[:, col])

    twist = at(RC_U) - at(RC_Q)
    truth = pd.DataFrame({
        "t": t, "q": at(RC_Q), "qd": at(RC_QD), "qdd": at(RC_QDD), "u": at(RC_U), "ud": at(RC_UD),
        "twist": twist, "twist_rate": at(RC_UD) - at(RC_QD), "torque": at(RC_T),
        "torque_sensor": at(RC_TS), "torque_load": at(RC_TL), "torque_cmd": at(RC_TCMD),
        "friction": at(RC_FF), "gravity": at(RC_G), "disturbance": at(RC_TX),
        "motor_torque": at(RC_TM), "temp_joint": at(RC_TG), "temp_m1": at(RC_TM1),
        "temp_m2": at(RC_TM2), "temp_m3": at(RC_TM3), "hysteresis": at(RC_H),
    })

    # --- noise, always drawn in the same order (independent of the effects)
    rng = np.random.default_rng([_SALT, seed, run, 2])
    nz = {k: rng.standard_normal(n) for k in (
        "torque", "load", "qd", "ud", "i1", "i2", "i3", "w1", "w2", "w3",
        "tm1", "tm2", "tm3", "tg")}

    # --- readings
    q_lag = DELAY_S * scale("time_delay") if form("time_delay") == "q_encoder_latency" else 0.0
    t_lag = DELAY_S * scale("time_delay") if form("time_delay") == "torque_latency" else 0.0
    q_true = at(RC_Q, q_lag)
    if form("encoder_drift") == "q_quadratic":
        q_true = q_true + DRIFT_Q * scale("encoder_drift") * t ** 2
    u_true = at(RC_U)
    if form("encoder_drift") == "u_linear":
        u_true = u_true + DRIFT_U * scale("encoder_drift") * t
    q_res = math.radians(sens.encoder_res_deg)
    q_meas = _quant(q_true, q_res)
    u_meas = _quant(u_true, sens.motor_encoder_res)
    qd_meas = at(RC_QD, q_lag) + sens.qd_noise * nz["qd"]
    ud_true = at(RC_UD)
    ud_meas = ud_true + sens.ud_noise * nz["ud"]

    t_read = t
    if form("time_delay") == "torque_sample_hold":
        per = HOLD_S * scale("time_delay")
        t_read = np.floor(t / per + 1e-9) * per
    torque = at(RC_TS, sens.torque_lag_s + t_lag, t_read)
    off = form("torque_offset")
    if off == "constant":
        torque = torque + OFF_CONST * scale("torque_offset")
    elif off == "settling":
        torque = torque + OFF_SETTLE * scale("torque_offset") * (1.0 - np.exp(-t / OFF_SETTLE_TC))
    elif off == "peak_load_shift":
        peak = np.maximum.accumulate(np.abs(rec[:, RC_T]))
        torque = torque + OFF_PEAK * scale("torque_offset") * np.interp(t, tr, peak)
    torque = _adc(torque + sens.torque_noise * nz["torque"], sens.torque_res)
    tload = _quant(at(RC_TL) + sens.load_noise * nz["load"], sens.load_res)

    cols: dict[str, Any] = {"t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
                            "torsion": q_meas - u_meas, "torque": torque, "torque_load": tload,
                            "torque_cmd": at(RC_TCMD)}
    for k in (1, 2, 3):
        cols[f"i_m{k}"] = at(RC_I1 + k - 1) + sens.current_noise * nz[f"i{k}"]
    for k in (1, 2, 3):
        cols[f"w_m{k}"] = REDUCTION * (ud_true + sens.ud_noise * nz[f"w{k}"])
    for k in (1, 2, 3):
        cols[f"temp_m{k}"] = _quant(at(RC_TM1 + k - 1) + sens.temp_noise * nz[f"tm{k}"],
                                    sens.temp_res)
    cols["temp_joint"] = _quant(at(RC_TG) + sens.temp_noise * nz["tg"], sens.temp_res)
    idx = np.minimum(np.floor(t / REC_DT + 1e-9).astype(np.int64), nrec - 1)
    codes = rec[idx, RC_PH].astype(np.int64)
    cols["phase"] = np.array(PHASES, dtype=object)[codes]
    samples = pd.DataFrame(cols)

    meta = {
        "scheme": scheme,
        "motor_speed_rpm": rpm,
        "direction": int(dirn),
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": "2026-02-02T08:30:00Z",
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
