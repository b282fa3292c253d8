"""Rig AG: an independent validation model of the CFETR CMOR J4 test bench.

Data sheet
==========

Everything below is in SI units (angles in rad, torques in N·m, times in s) except temperatures
(°C). Angles on the motor side are *referred to the output* (motor angle / N, N = 11000), as the
run format stores them. Sign conventions follow rig.md: Δ = u − q is the twist, `torque` the
transmitted torque T at the output shaft, τ_L the dynamometer torque (positive = the paper's
positive loading), gravity G(q) = g·(mr_x·sin q + mr_y·cos q), g = 9.81 m/s².

1. The machine (drawn once per campaign, ``seed``; ``draw_machine``)
--------------------------------------------------------------------
Nominal values with a relative standard deviation (normal draws clipped at ±2.5 SD):

=================  ===================  ======  =================================================
name               nominal              rel SD  meaning
=================  ===================  ======  =================================================
I                  6685.166 kg·m²       2 %     output inertia (paper Table 3)
mr_x, mr_y         20.779, −34.543 kg·m 6 %     gravity moments (Table 3)
f_c                2352.66 N·m          3 %     output Coulomb level (Table 3)
f_v                8683.272 N·m·s/rad   4 %     output viscous slope (Table 3)
z_ss               2.5e-5 rad           15 %    presliding length of the output friction
twist_rated        0.5° (8.73e-3 rad)   3 %     twist at the rated 120 kN·m (rig.md)
stiff_ratio ρ      1.5                  5 %     outer/centre stiffness k_b/k_a
blend_lo, _hi      0.10°, 0.30°         10 %    where the stiffness blends from k_a to k_b
zeta_tr            0.4                  8 %     transmission damping ratio against I
J_m                1.0e-3 kg·m²         3 %     one motor's rotor (+ gear input) inertia
F_mc               2600 N·m             5 %     motor-side Coulomb level, referred
f_mv               2.0e4 N·m·s/rad      5 %     motor-side viscous slope, referred
kt1..kt3           1.1 N·m/A            2 %     torque constants
share1..share3     1/3                  2 %     torque shares (renormalised to sum 1)
dyn_gain           1.0                  0.3 %   dynamometer torque gain
dyn_tau            0.02 s               10 %    dynamometer torque-loop time constant
=================  ===================  ======  =================================================

Derived: k_a = 120 kN·m / (Δ_r + (ρ−1)(Δ_r − (δ1+δ2)/2)) (≈ 1.06e7 N·m/rad), k_b = ρ·k_a,
J_M = 3·J_m·N² (≈ 3.6e5 kg·m² referred), D_tr = 2·ζ_tr·√(k_a·I) (≈ 2.1e5 N·m·s/rad),
σ0 = f_c/z_ss (≈ 9.4e7 N·m/rad), σ1 = 1.6·√(σ0·I); motor side σ0m = F_mc/2.5e-5,
σ1m = 1.6·√(σ0m·J_M). The output swings against the transmission at √(k/I)/2π ≈ 6.3 Hz (centre
stiffness) to 7.7 Hz (outer). Gear phases of the ripple effects are drawn per campaign too.

2. Physics (nominal)
--------------------
States: q, q̇ (output, relative to the joint housing), Δ, Δ̇ (twist), z_o, z_m (friction
bristles), the speed loop's integral c, the dynamometer torque τ_L, and (only when an effect
needs them) a Bouc–Wen variable x, a Zener arm torque F_z, a carrier deflection δ_A and a
housing angle φ_b; the gearbox and three winding temperatures are slow side states.

* Output:  I·(q̈ + φ̈_b) = T − (τ_L + n_L(t)) − G(q + φ_b) − F_o + d(t)
  (φ_b ≡ 0 and d ≡ 0 nominally).
* Motor side (three motors lumped, referred): J_M·ü = T_m − T − F_m, u = q + Δ.
* Transmission compliance — a C¹ **two-slope law with a quadratic blend** ("bilinear,
  quadratic-blended"): the stiffness is k_a for |δ| ≤ δ1, rises linearly to k_b at |δ| = δ2 and
  stays k_b beyond, so (δ ≥ 0, odd extension)

      K(δ) = k_a·δ                                            δ ≤ δ1
           = k_a·δ + (k_b−k_a)·(δ−δ1)²/(2(δ2−δ1))             δ1 < δ ≤ δ2
           = k_a·δ + (k_b−k_a)·((δ2−δ1)/2 + δ − δ2)           δ > δ2

  (``compliance_torque``); T = K(Δ) + D_tr·Δ̇ nominally; K(twist_rated) = 120 kN·m exactly.
* Friction on both sides — the **elasto-plastic model of Dupont et al. (2002)**:

      ż = v·(1 − α(z, v)·|z|/z_ss(v)),  z_ss = F_ss(v)/σ0,  F = σ0·z + σ1·e^{−(v/v_d)²}·ż + σ2·v

  with α = 0 when sgn z ≠ sgn v or |z| ≤ z_ba = 0.7·z_ss, α = ½·sin(π(|z| − (z_ss+z_ba)/2)/
  (z_ss − z_ba)) + ½ between, α = 1 beyond z_ss; v_d = 2e-4 rad/s. Below z_ba the contact is a
  pure spring (no drift under vibration). Nominally F_ss = f_c, σ2 = f_v at the output (so in
  steady sliding F_o = f_c·sgn q̇ + f_v·q̇, the paper's Eq. 4 terms) and F_ss = F_mc, σ2 = f_mv on
  the motor side. The friction effects of section 4 change the output's F_ss(v), σ2(v) only.
* Drive: a cascaded position/speed loop on the motor encoder (referred): v* = u̇_ref +
  K_p·(u_ref − u), T_m = K_v·(v* − u̇) + c + J_M·ü_ref, ċ = K_i·(v* − u̇); ω_v = 2π·8 rad/s,
  K_v = J_M·ω_v, K_i = K_v·ω_v/4, K_p = ω_v/5; |T_m| ≤ 3·18 N·m·N = 5.94e5 N·m.
  Currents i_k = share_k·T_m/(N·kt_k); speeds w_mk = N·u̇.
* Dynamometer: τ̇_L = (dyn_gain·τ_cmd + w(t) − τ_L)/dyn_tau, where w(t) is an
  Ornstein–Uhlenbeck wander (SD 250 N·m, correlation time 4 s, clipped to ±1500 N·m, per run on
  a 10 ms grid), so τ_L stays within Table 11's ±2 kN·m of a held set point; on top, the servo's
  torque noise n_L(t) (white, SD 150 N·m, per run on a 1 ms grid, linearly interpolated) acts on
  the output at once. ``torque_load`` measures τ_L + n_L.
* Heat: gearbox C_g·θ̇_g = |F_o·q̇| + |F_m·u̇| − (θ_g − θ_a)/R_g (C_g = 4e4 J/K, R_g = 0.05 K/W);
  windings C_w·θ̇_k = R_w·i_k² − (θ_k − θ_a)/R_th (C_w = 1500 J/K, R_w = 0.8 Ω, R_th = 0.4 K/W),
  starting at θ_a + 2 K; θ_a = θ_g(0) = ``temp_joint_c``. Temperature-dependent friction uses θ_g.
* Initial state: at rest at q = 0, the transmission holding gravity and the dynamometer's
  initial torque (with every effect's static part), friction bristles unloaded, the loop
  integral holding that torque.

Integrator: the **implicit trapezoidal rule** (Crank–Nicolson) at a fixed step H_STEP = 0.5 ms,
each step solved by a modified Newton iteration on a finite-difference Jacobian (LU with partial
pivoting, refreshed when convergence slows); the Masing element's reversal memory is updated
after each accepted step, the temperatures by explicit Euler at the same step. Readings are
interpolated linearly from the 0.5 ms record.

3. Schemes, clock and sensors
-----------------------------
Motion: schemes 1–2 run the motors at ``direction``·rpm (output ω = rpm·2π/60/N, 0.0286 rad/s at
3000 r/min) with a raised-cosine start over [0.5, 1.5] s and stop over [t_e + 0.25, t_e + 1.25] s,
t_e the end of the last period; LEAD_S = 2 s before the first period, TAIL_S = 2 s after it
("idle").
* Scheme 1: per period the set point ramps 0 → 120 kN·m in 12 s ("load") and back in 12 s
  ("unload"); period 24 s.
* Scheme 2: 12 steps of 10 kN·m, each a 0.1 s ramp ("load") and a 2 s hold ("hold"), then a
  3.2 s ramp to 0 ("unload"); period 28.4 s.
* Scheme 3: τ_cmd = 0 and the motors follow a fifth-order Fourier trajectory (Eq. 12, ``FOURIER_A``,
  ``FOURIER_B``) of period 10 s, starting and ending at rest, peak speed 0.024 rad/s, 0 ≤ dir·q
  ≤ 0.035 rad ("excite").
A scheme-1/2 run farther than π − 0.1 rad is refused (at 3000 r/min three periods travel 2.11 rad
in scheme 1, 2.48 rad in scheme 2).

Clock (the `t` column): the readings are taken exactly at the true instants k/fs (hardware-timed
DAQ); each is *stamped* by the host clock, whose crystal runs ε fast (ε uniform in ±3 ppm per
run) and is stepped back to true time every 10 s (NTP-like, sync phase uniform per run), read
with a 10 µs tick (floored): t_k = H(k/fs) − H(0), H(t) = tick·⌊(t + ε·((t + φ) mod 10 s))/tick⌋.
The stamps are strictly increasing and within ±40 µs of k/fs; ``truth.t`` holds k/fs.

Sensors (``SensorSpec``; metadata ``sensors`` states each exactly):
* q: output encoder (relative to the housing), rounded to encoder_res_deg (0.01°);
  qd = q̇ + white noise qd_noise.
* u: motor encoders referred, rounded to motor_encoder_res (2π/2²⁰/N); ud and w_mk = N·u̇, each
  with its own white noise ud_noise (referred).
* torque: a strain-gauge amplifier whose output is the **moving average (boxcar FIR) of T over
  the last 2·torque_filter_s** (default window 2 ms: a pure delay of torque_filter_s at every
  frequency), read torque_lag_s later still, plus white noise torque_noise, then a 16-bit ADC
  over ±200 kN·m (step torque_res). Stated lag_s = torque_filter_s + torque_lag_s.
* torque_load: τ_L + n_L + white noise load_noise, step load_res. torque_cmd: the set point.
* i_mk: + current_noise; temp_mk, temp_joint: + temp_noise, stepped by temp_res.
* phase: the schedule's phase at the sample.

4. Effects (``effects = {family: {"form": name, "scale": s}}``, 0 ≤ s ≤ SCALE_MAX = 10)
--------------------------------------------------------------------------------------
Sizes at s = 1; every size is proportional to s unless stated. v = q̇, T = transmitted torque,
θ = gearbox temperature, θ_r = 40 °C, δ = the twist of the (main) spring. The output friction
level is kept F_ss ≥ 0.25·f_c; clipped factors as stated. Since the dynamometer imposes the
torque in schemes 1–2, an effect inside the transmission mostly shows in the *twist* (q − u)
there, and in the torque during scheme 3.

* stribeck (F_ss += ΔF·φ(v), ΔF = 0.4·s·f_c ≈ 940 N·m; 300 r/min is v = 2.86e-3 rad/s):
  first_power_exp φ = exp(−|v|/3e-3) (exponent 1); gauss_bell φ = exp(−(v/5e-3)²) (exponent 2);
  cauchy_peak φ = 1/(1 + (v/2.5e-3)²) (Lorentzian).
* load_dependent_friction: mu_abs_torque F_ss += 0.02·s·|T| (Coulomb only, 2.4 kN·m at rated);
  both_linear_scaled F_ss and σ2 × (1 + 0.9·s·|T|/120 kN·m) (Coulomb and viscous);
  hertz_two_thirds F_ss += 2000·s·(|T|/120 kN·m)^(2/3) (Coulomb only, concave in the load).
* temperature_friction: viscous_kelvin_power σ2 × max(0.1, 1 + s·(((θ_r+273.15)/(θ+273.15))^15
  − 1)) (multiplicative on viscous: ×2.1 at 25 °C, ×3.5 at 15 °C, ×0.4 at 60 °C);
  coulomb_hyperbolic F_ss += 0.6·s·f_c·((θ_r + 10)/(θ + 10) − 1) (additive on Coulomb: +0.26·f_c
  at 25 °C, +0.6·f_c at 15 °C, −0.17·f_c at 60 °C); both_linear_factor F_ss and σ2 ×
  max(0.2, 1 + 0.012·s·(θ_r − θ)) (multiplicative on both: +18 % at 25 °C).
* gear_ripple: output_mesh_pair T += s·(700·sin(160q + φ1) + 280·sin(320q + φ2)) (output angle:
  a 160-tooth mesh and its second harmonic); motor_shaft_2x_4x — a kinematic error
  ε = s·(6e-6·sin(2θ_m + φ1) + 2e-6·sin(4θ_m + φ2)) rad added to the twist the spring and damper
  see, θ_m = N·u the motor angle (2 and 4 cycles per motor revolution; ≈ 1 kN·m at 3000 r/min,
  ≈ 0.2 kN·m at 300 r/min); planet_pass_stage T += s·600·(sin(330u + φ1) + 0.35·sin(660u + φ2))
  (3 planets on an intermediate shaft turning 110× the output).
* torque_offset (added to the torque reading only): bridge_unbalance +900·s; sqrt_creep
  +500·s·√(t/60 s); bending_crosstalk +0.004·s·M_b(t), M_b = 200 kN·m·(1 − e^{−t/3 s})·
  (1 + 0.03·sin(2π·0.04 t)) (the hydraulic bending moment, not recorded): ≈ 800 N·m.
* time_delay: torque_transport — the torque reading 8 ms·s late; q_frame_hold — q and qd are
  latched once per bus frame P = 4 ms·s and delivered one frame late, q(P·⌊t/P⌋ − P) (1.5·P late
  on average); u_transport — u, ud and w_mk 8 ms·s late.
* hysteresis (in the transmission, on δ_b, the spring's twist after any gap):
  masing_hyperbolic T += H, a Masing element: from the last reversal (δ_r, H_r) the branch is
  H = H_r + 2·B((δ − δ_r)/2), backbone B(ξ) = k_h·ξ/(1 + |ξ|/2e-3 rad), |H| ≤ k_h·2e-3,
  k_h = min(0.9, 0.08·s)·k_a (stiffer centre, loops up to ≈ 3 kN·m wide);
  zener_relaxation T += F_z, Ḟ_z = k_z·δ̇ − F_z/1.5 s, k_z = 0.15·s·k_a (rate-dependent: ≈ ±1.6
  kN·m along scheme 1's 10 kN·m/s ramps, relaxing during scheme 2's holds);
  bouc_wen_stiff_unload T += w·k_a·(x − δ), ẋ = δ̇ − β|δ̇|x − γδ̇|x|, β = 1.5/x_u, γ = −0.5/x_u,
  x_u = 2.5e-3 rad, w = min(0.6, 0.05·s) (yields ≈ 3.4 kN·m by the rated twist, loops ≈ 2.7 kN·m,
  unloading three times stiffer than the yielded branch). Loop widths in twist ≈ 1–3e-4 rad.
* backlash (half gap b = 2e-4·s rad, ≈ 1.4 arcmin full gap): contact_gap — a sharp dead zone,
  the damper acting only in contact; softplus_gap — δ_b = ε·(ln(1+e^{(δ−b)/ε}) −
  ln(1+e^{(−δ−b)/ε})), ε = 0.3·b (smoothed); offset_gap — sharp flanks at −0.5·b and +1.5·b.
* asymmetric_friction: pos_coulomb_boost F_ss × (1 + 0.3·s) for v > 0; crossed_levels for v > 0
  F_ss × max(0.25, 1 − 0.15·s) and σ2 × (1 + 0.8·s); neg_low_speed_hump for v < 0
  F_ss += 0.5·s·f_c·exp(−|v|/4e-3) (at low speed only).
* periodic_disturbance (out of vocabulary; a torque d(t) on the output, not in τ_L):
  two_tone_hydraulic 500·s·(sin(2π·1.7t + φ1) + 0.6·sin(2π·4.3t + φ2)); cooler_cycle a 20 s
  triangle rising 17 s, falling 3 s, between ±600·s (phases per run).
* position_dependent_stiffness (out of vocabulary; K(δ) × κ(q)): raised_cosine_notch
  κ = 1 − d·½(1 + cos(π(|q| − 0.06)/0.05)) for ||q| − 0.06| < 0.05, d = min(0.8, 0.2·s) (two
  worn sectors at ±0.06 rad); roller_pass_15x κ = 1 + min(0.7, 0.08·s)·sin(15q + 0.4).
* encoder_drift (out of vocabulary): q_lost_counts — the output encoder loses one count every
  12 s/s, so its reading falls one more step behind the motion each time; u_ratio_creep — the drive's gearing
  factor is off, u reads u·(1 + 2e-4·s) (4e-4 rad over a 3000 r/min scheme-1 run).
* second_resonance (out of vocabulary): carrier_split_mode — the transmission becomes motor —
  main spring (all the above, stiffened by k_A/(k_A − k_a) so the pair keeps the centre slope)
  — carrier of inertia J_c = s·I — output-side spring k_A = 10·k_a (damping ratio 0.02) —
  output; the torque transducer reads the output-side spring (a ≈ 29 Hz mode at s = 1, 21 Hz at
  s = 10); housing_rocking — the joint housing sits on a base of stiffness 5e7 N·m/rad (damping
  ratio 0.03) with inertia J_b = s·5e7/(2π·12 Hz)²; the encoders read relative to the housing,
  the dynamometer and gravity act in the ground frame, the housing carries −T + F_o (a 12 Hz
  base mode at s = 1). Both ring at ≈ 0.9 kN·m after scheme-2 steps at s = 1.

5. What the metadata states
---------------------------
run-format keys (scheme, motor_speed_rpm — None for scheme 3 —, direction, reduction, rig,
source "emulator", sample_rate_hz, started_at, notes) and ``sensors``: q {resolution, noise_sd 0,
lag_s 0}, qd {noise_sd, lag_s 0}, u {resolution, noise_sd 0, lag_s 0}, ud {noise_sd, lag_s 0},
torque {resolution, noise_sd, lag_s = torque_filter_s + torque_lag_s}, torque_load {resolution,
noise_sd, lag_s 0}, i_m1..3 {noise_sd}, temp_m1..3 and temp_joint {resolution, noise_sd}. The
effects are never stated. ``RigRun.truth`` holds the true signals at the true instants;
``RigRun.params`` the machine, the clock (clock_eps, clock_phase_s), the effects, the number of
Newton steps that failed to converge (newton_failures) and the initial twist.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba as nb
import numpy as np
import pandas as pd

RIG_NAME = "rig_ag"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("first_power_exp", "gauss_bell", "cauchy_peak"),
    "load_dependent_friction": ("mu_abs_torque", "both_linear_scaled", "hertz_two_thirds"),
    "temperature_friction": ("viscous_kelvin_power", "coulomb_hyperbolic", "both_linear_factor"),
    "gear_ripple": ("output_mesh_pair", "motor_shaft_2x_4x", "planet_pass_stage"),
    "torque_offset": ("bridge_unbalance", "sqrt_creep", "bending_crosstalk"),
    "time_delay": ("torque_transport", "q_frame_hold", "u_transport"),
    "hysteresis": ("masing_hyperbolic", "zener_relaxation", "bouc_wen_stiff_unload"),
    "backlash": ("contact_gap", "softplus_gap", "offset_gap"),
    "asymmetric_friction": ("pos_coulomb_boost", "crossed_levels", "neg_low_speed_hump"),
    "periodic_disturbance": ("two_tone_hydraulic", "cooler_cycle"),
    "position_dependent_stiffness": ("raised_cosine_notch", "roller_pass_15x"),
    "encoder_drift": ("q_lost_counts", "u_ratio_creep"),
    "second_resonance": ("carrier_split_mode", "housing_rocking"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "time_delay": (
        "The torque transducer's amplifier outputs the moving average of the transmitted torque "
        "over the last 2·SensorSpec.torque_filter_s (2 ms by default): a linear-phase FIR, a pure "
        "delay of torque_filter_s (1 ms) at every frequency, with a sinc roll-off (−0.6 dB at "
        "100 Hz). Meta sensors.torque.lag_s states it (plus SensorSpec.torque_lag_s)."),
    "hysteresis": (
        "The output friction is an elasto-plastic (Dupont) presliding element: at each reversal "
        "of q̇ it passes from ∓F to ±F over ≈ 2·z_ss ≈ 5e-5 rad of output motion (under a third "
        "of one 0.01° encoder step), rate-independently, the output held meanwhile by the "
        "presliding spring σ0 ≈ 9.4e7 N·m/rad; so the output law's residual against f_c·sgn(q̇) "
        "reaches 2·f_c for ≈ 0.05–0.15 s at every reversal of scheme 3, and whenever the output "
        "stands still (idle), where the dynamometer's torque noise jiggles it inside the "
        "presliding range and sgn(q̇) flips at random. No run states it; the transmission itself "
        "has no hysteresis nominally (only its viscous damping)."),
}

# --- constants ---------------------------------------------------------------------------------

G_ACC = 9.81                      # [m/s²]
T_RATED = 120_000.0               # rated output torque [N·m]
TWIST_RATED_DEG = 0.5             # nominal twist at the rated torque [deg]
TRAVEL_LIMIT = math.pi - 0.1      # output travel allowed in a run [rad]
H_STEP = 5.0e-4                   # integrator step [s]
LEAD_S = 2.0                      # before the first period [s]
TAIL_S = 2.0                      # after the last period [s]
START_T0, START_T1 = 0.5, 1.5     # motor start ramp [s]
STOP_D0, STOP_D1 = 0.25, 1.25     # motor stop ramp, after the last period [s]
S1_HALF = 12.0                    # scheme 1: load (and unload) ramp [s]
S2_STEP = 10_000.0                # scheme 2: step [N·m]
S2_RAMP, S2_HOLD, S2_NSTEP, S2_UNLOAD = 0.1, 2.0, 12, 3.2   # [s], [s], -, [s]
S2_PERIOD = S2_NSTEP * (S2_RAMP + S2_HOLD) + S2_UNLOAD      # 28.4 s
S3_PERIOD = 10.0                  # scheme 3: Fourier period [s]
S3_PEAK_SPEED = 0.024             # scheme 3: peak output speed [rad/s]
MOTOR_PEAK = 18.0                 # one motor's peak torque [N·m]
OMEGA_V = 2.0 * math.pi * 8.0     # speed-loop bandwidth [rad/s]
V_D = 2.0e-4                      # presliding damping fade speed [rad/s]
Z_BA = 0.7                        # breakaway fraction of z_ss
Z_SS_MOTOR = 2.5e-5               # motor-side presliding length (referred) [rad]
WANDER_DT, WANDER_SD, WANDER_TAU, WANDER_MAX = 0.01, 250.0, 4.0, 1500.0   # [s], [N·m], [s], [N·m]
DYN_NOISE_DT, DYN_NOISE_SD = 1.0e-3, 150.0   # dynamometer servo torque noise grid [s], SD [N·m]
THETA_REF = 40.0                  # reference temperature of the temperature effects [°C]
C_GEAR, R_GEAR = 4.0e4, 0.05      # gearbox heat capacity [J/K], resistance to ambient [K/W]
C_WIND, R_WIND, R_WTH = 1500.0, 0.8, 0.4   # winding [J/K], [Ω], [K/W]
WIND_START = 2.0                  # windings start this much above the joint [K]
ADC_BITS = 16
TORQUE_RANGE = 200_000.0          # torque transducer span ± [N·m]
CLOCK_PPM = 3.0e-6                # host crystal error bound (relative)
CLOCK_SYNC_S = 10.0               # host clock stepped to true time every [s]
CLOCK_TICK_S = 1.0e-5             # host clock tick [s]
PHASES: tuple[str, ...] = ("idle", "load", "hold", "unload", "excite")

# effect sizes at scale 1
STRIB_RATIO = 0.4                 # (F_s − F_c)/f_c
STRIB_VS = (3.0e-3, 5.0e-3, 2.5e-3)     # [rad/s]
LOAD_MU = 0.02                    # [-]
LOAD_BOTH = 0.9                   # [-] at rated torque
LOAD_HERTZ = 2000.0               # [N·m] at rated torque
TEMP_POWER = 15.0
TEMP_HYP = 0.6                    # × f_c
TEMP_HYP_ZERO = -10.0             # [°C]
TEMP_LIN = 0.012                  # [1/K]
RIP_Z, RIP_A1, RIP_A2 = 160.0, 700.0, 280.0        # cycles/rev, [N·m], [N·m]
KIN_E1, KIN_E2 = 6.0e-6, 2.0e-6                    # [rad]
PLN_ORDER, PLN_A, PLN_R2 = 330.0, 600.0, 0.35      # cycles/output rev, [N·m], [-]
OFF_CONST = 900.0                 # [N·m]
OFF_SQRT, OFF_SQRT_T = 500.0, 60.0        # [N·m], [s]
OFF_XTALK, OFF_MBEND, OFF_MB_TAU = 0.004, 200_000.0, 3.0   # [-], [N·m], [s]
DELAY_S = 8.0e-3                  # torque / u transport [s]
FRAME_S = 4.0e-3                  # q bus frame [s]
MASING_W, MASING_XY = 0.08, 2.0e-3   # [-], [rad]
ZENER_K, ZENER_TAU = 0.15, 1.5    # × k_a, [s]
BW_W, BW_XU = 0.05, 2.5e-3        # [-], [rad]
BACKLASH_B = 2.0e-4               # half gap [rad]
ASYM_BOOST, ASYM_CROSS_C, ASYM_CROSS_V, ASYM_HUMP, ASYM_HUMP_V = 0.3, 0.15, 0.8, 0.5, 4.0e-3
DIST_A, DIST_F1, DIST_F2, DIST_R2 = 500.0, 1.7, 4.3, 0.6   # [N·m], [Hz], [Hz], [-]
COOL_A, COOL_P, COOL_RISE = 600.0, 20.0, 17.0              # [N·m], [s], [s]
NOTCH_Q, NOTCH_W, NOTCH_D = 0.06, 0.05, 0.2                # [rad], [rad], [-]
ROLLER_N, ROLLER_A, ROLLER_PH = 15.0, 0.08, 0.4
SLIP_S = 12.0                     # one lost count every [s]
RATIO_ERR = 2.0e-4                # [-]
CARRIER_KA, CARRIER_Z = 10.0, 0.02      # × k_a, [-]; the carrier's inertia is s·I
HOUSING_K, HOUSING_F, HOUSING_Z = 5.0e7, 12.0, 0.03        # [N·m/rad], [Hz], [-]

FAMILIES: tuple[str, ...] = tuple(EFFECT_FORMS)
_FAMILY = {n: i for i, n in enumerate(FAMILIES)}
N_FAM = len(FAMILIES)
E_STRIB, E_LOAD, E_TEMP, E_RIP, E_OFF, E_DELAY, E_HYST, E_BACK, E_ASYM, E_DIST, E_PSTIFF, \
    E_DRIFT, E_RES2 = range(N_FAM)


def _fourier_base() -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 coefficients a_l, b_l [rad/s] of scheme 3: Σa_l = 0 and Σ l·b_l = 0 (the
    trajectory starts and ends at rest, with zero acceleration), scaled to S3_PEAK_SPEED."""
    a = np.array([0.2, -0.55, 0.35, 0.25, -0.25])
    b = np.array([0.6, -0.35, 0.25, -0.1, -0.05])
    w = 2.0 * math.pi / S3_PERIOD
    tt = np.linspace(0.0, S3_PERIOD, 20001)
    ll = np.arange(1, 6)[:, None]
    v = (a[:, None] * np.cos(w * ll * tt) + b[:, None] * np.sin(w * ll * tt)).sum(axis=0)
    s = S3_PEAK_SPEED / np.max(np.abs(v))
    return a * s, b * s


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
    torque_noise: float = 120.0         # white noise SD on the torque reading [N·m]
    torque_lag_s: float = 0.0           # pure lag of the torque reading beyond the FIR [s]
    torque_filter_s: float = 1e-3       # boxcar FIR group delay = half its window [s]
    torque_res: float = 2 * TORQUE_RANGE / 2 ** ADC_BITS   # 16-bit ADC step [N·m] (0: none)
    load_noise: float = 60.0            # dynamometer torque noise SD [N·m]
    load_res: float = 4.0               # its step [N·m]
    qd_noise: float = 1.5e-5            # output velocity noise SD [rad/s]
    motor_encoder_res: float = 2 * math.pi / 2 ** 20 / REDUCTION  # referred step [rad]
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
    """One run: `samples` (run-format columns), `meta` (its metadata), `truth` (true signals
    at the true sample instants), `params` (machine, clock, effects)."""

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


def _check_args(scheme: Any, motor_speed_rpm: Any, direction: Any, temp_joint_c: Any,
                sensors: Any, periods: Any, seed: Any, run: Any) -> None:
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


def _period(scheme: int) -> float:
    return {1: 2.0 * S1_HALF, 2: S2_PERIOD, 3: S3_PERIOD}[int(scheme)]


def run_duration(scheme: int, periods: int) -> float:
    """Length of a run [s]: LEAD_S, `periods` periods of the scheme, TAIL_S."""
    return LEAD_S + int(periods) * _period(scheme) + TAIL_S


def _travel(scheme: int, rpm: float, periods: int) -> float:
    """Output travel of a scheme-1/2 run [rad] (the area under the speed profile)."""
    w = rpm * 2.0 * math.pi / 60.0 / REDUCTION
    t_end = LEAD_S + int(periods) * _period(scheme)
    return w * ((2.0 * t_end + STOP_D0 + STOP_D1) / 2.0 - (START_T0 + START_T1) / 2.0)


# --- the machine ---------------------------------------------------------------------------------

_SALT = 0xA6_5EED
_NOMINAL: dict[str, tuple[float, float]] = {   # name: (value, relative SD)
    "I": (6685.166, 0.02), "mr_x": (20.779, 0.06), "mr_y": (-34.543, 0.06),
    "f_c": (2352.660, 0.03), "f_v": (8683.272, 0.04), "z_ss": (2.5e-5, 0.15),
    "twist_rated": (math.radians(TWIST_RATED_DEG), 0.03), "stiff_ratio": (1.5, 0.05),
    "blend_lo": (math.radians(0.10), 0.10), "blend_hi": (math.radians(0.30), 0.10),
    "zeta_tr": (0.4, 0.08), "J_m": (1.0e-3, 0.03), "F_mc": (2600.0, 0.05),
    "f_mv": (2.0e4, 0.05), "kt1": (1.1, 0.02), "kt2": (1.1, 0.02), "kt3": (1.1, 0.02),
    "share1": (1 / 3, 0.02), "share2": (1 / 3, 0.02), "share3": (1 / 3, 0.02),
    "dyn_gain": (1.0, 0.003), "dyn_tau": (0.02, 0.10),
}


def draw_machine(seed: int) -> dict[str, float]:
    """The machine of campaign `seed` (data sheet section 1) with its derived values."""
    rng = np.random.default_rng([_SALT, int(seed)])
    eps = np.clip(rng.standard_normal(len(_NOMINAL)), -2.5, 2.5)
    m = {k: float(v * (1.0 + sd * e)) for (k, (v, sd)), e in zip(_NOMINAL.items(), eps)}
    tot = m["share1"] + m["share2"] + m["share3"]
    for k in ("share1", "share2", "share3"):
        m[k] /= tot
    # ripple phases of the campaign's gears
    ph = rng.uniform(0.0, 2.0 * math.pi, 6)
    for k, name in enumerate(("rip_ph1", "rip_ph2", "kin_ph1", "kin_ph2", "pln_ph1", "pln_ph2")):
        m[name] = float(ph[k])
    dr, rho, d1, d2 = m["twist_rated"], m["stiff_ratio"], m["blend_lo"], m["blend_hi"]
    m["k_a"] = T_RATED / (dr + (rho - 1.0) * (dr - 0.5 * (d1 + d2)))
    m["k_b"] = rho * m["k_a"]
    m["J_M"] = 3.0 * m["J_m"] * REDUCTION ** 2
    m["D_tr"] = 2.0 * m["zeta_tr"] * math.sqrt(m["k_a"] * m["I"])
    m["sigma0"] = m["f_c"] / m["z_ss"]
    m["sigma1"] = 1.6 * math.sqrt(m["sigma0"] * m["I"])
    m["sigma0_m"] = m["F_mc"] / Z_SS_MOTOR
    m["sigma1_m"] = 1.6 * math.sqrt(m["sigma0_m"] * m["J_M"])
    m["K_v"] = m["J_M"] * OMEGA_V
    m["K_i"] = m["K_v"] * OMEGA_V / 4.0
    m["K_p"] = OMEGA_V / 5.0
    m["T_max"] = 3.0 * MOTOR_PEAK * REDUCTION
    return m


def compliance_torque(twist: Any, machine: dict[str, float]) -> np.ndarray:
    """The nominal spring law K(Δ) [N·m] of the data sheet (two slopes, quadratic blend) at the
    twist Δ [rad] (array or scalar), for a machine from `draw_machine`."""
    d = np.asarray(twist, dtype=float)
    ka, kb = machine["k_a"], machine["k_b"]
    d1, d2 = machine["blend_lo"], machine["blend_hi"]
    a = np.abs(d)
    e = np.clip(a - d1, 0.0, d2 - d1)
    t = ka * a + (kb - ka) * (e * e / (2.0 * (d2 - d1)) + np.maximum(a - d2, 0.0))
    return np.sign(d) * t


# --- the kernel ----------------------------------------------------------------------------------

(P_I, P_MRX, P_MRY, P_FC, P_FV, P_SIG0, P_SIG1, P_KA, P_KB, P_D1, P_D2, P_DTR, P_JM, P_SIG0M,
 P_SIG1M, P_FMC, P_FMV, P_KV, P_KI, P_KP, P_TMAX, P_DG, P_DTAU, P_SCHEME, P_DIR, P_OMEGA,
 P_PERIODS, P_AMB, P_TEND, P_RIP1, P_RIP2, P_KIN1, P_KIN2, P_PLN1, P_PLN2, P_DIS1, P_DIS2,
 P_DIS3, P_KCA, P_CCA, P_JCA, P_KBH, P_CBH, P_JBH, P_SH1, P_SH2, P_SH3, P_KT1, P_KT2,
 P_KT3) = range(50)
N_P = 50

# state vector
(Y_Q, Y_QD, Y_D, Y_DD, Y_ZO, Y_ZM, Y_CI, Y_TL, Y_XB, Y_FZ, Y_DA, Y_DAD, Y_PB, Y_PBD) = range(14)
NY = 14
# auxiliary outputs of the right-hand side
(A_TB, A_TA, A_FO, A_FM, A_G, A_DIST, A_TM, A_CMD, A_PH, A_TH, A_DB, A_QDD, A_UDD,
 A_TLT) = range(14)
NA = 14
# recorded columns
(RC_Q, RC_QD, RC_QDD, RC_U, RC_UD, RC_T, RC_TL, RC_TCMD, RC_FO, RC_G, RC_DIST, RC_TM, RC_TG,
 RC_TM1, RC_TM2, RC_TM3, RC_H, RC_PH, RC_PB, RC_TWIST) = range(20)
NREC = 20

_ATOL = np.array([1e-10, 1e-10, 1e-11, 1e-10, 1e-12, 1e-12, 1e-4, 1e-4, 1e-12, 1e-4, 1e-12,
                  1e-10, 1e-12, 1e-10])
_TYP = np.array([1.0, 0.03, 0.01, 0.01, 3e-5, 3e-5, 1e5, 1e5, 1e-3, 1e4, 1e-4, 1e-2, 1e-3,
                 1e-2])


@nb.njit(cache=True)
def _spring(d: float, ka: float, kb: float, d1: float, d2: float) -> float:
    """Two-slope, quadratic-blend spring K(δ) [N·m]."""
    a = abs(d)
    if a <= d1:
        t = ka * a
    elif a <= d2:
        e = a - d1
        t = ka * a + (kb - ka) * e * e / (2.0 * (d2 - d1))
    else:
        t = ka * a + (kb - ka) * (0.5 * (d2 - d1) + a - d2)
    return t if d >= 0.0 else -t


@nb.njit(cache=True)
def _masing(d: float, pl: np.ndarray, k0: float) -> float:
    """Masing element [N·m]: the branch from the last reversal (pl[0] twist, pl[1] value) is
    H = H_r + 2·B((δ − δ_r)/2), backbone B(ξ) = k0·ξ/(1 + |ξ|/MASING_XY), |H| ≤ k0·MASING_XY."""
    xi = 0.5 * (d - pl[0])
    h = pl[1] + 2.0 * k0 * xi / (1.0 + abs(xi) / MASING_XY)
    hmax = k0 * MASING_XY
    return min(max(h, -hmax), hmax)


@nb.njit(cache=True)
def _ramp_pos(t: float, t0: float, t1: float) -> tuple:
    """Raised-cosine 0→1 ramp over [t0, t1]: (integral from t0, value, derivative)."""
    if t <= t0:
        return 0.0, 0.0, 0.0
    ln = t1 - t0
    if t >= t1:
        return 0.5 * ln + (t - t1), 1.0, 0.0
    x = math.pi * (t - t0) / ln
    return (0.5 * (t - t0) - ln / (2.0 * math.pi) * math.sin(x), 0.5 * (1.0 - math.cos(x)),
            0.5 * math.pi / ln * math.sin(x))


@nb.njit(cache=True)
def _schedule(t: float, p: np.ndarray, fa: np.ndarray, fb: np.ndarray) -> tuple:
    """(τ_cmd, phase code, u_ref, u̇_ref, ü_ref) at time t."""
    scheme = int(p[P_SCHEME])
    dirn = p[P_DIR]
    tt = t - LEAD_S
    tend = p[P_TEND]
    cmd = 0.0
    ph = 0
    if scheme == 3:
        ur = 0.0
        udr = 0.0
        uddr = 0.0
        if 0.0 <= tt <= tend - LEAD_S:
            ph = 4
            w = 2.0 * math.pi / S3_PERIOD
            for i in range(5):
                lw = w * (i + 1)
                s = math.sin(lw * tt)
                c = math.cos(lw * tt)
                ur += fa[i] / lw * s - fb[i] / lw * c + fb[i] / lw
                udr += fa[i] * c + fb[i] * s
                uddr += -fa[i] * lw * s + fb[i] * lw * c
        return cmd, ph, dirn * ur, dirn * udr, dirn * uddr
    om = dirn * p[P_OMEGA]
    s_up, v_up, a_up = _ramp_pos(t, START_T0, START_T1)
    s_dn, v_dn, a_dn = _ramp_pos(t, tend + STOP_D0, tend + STOP_D1)
    ur = om * (s_up - s_dn)
    udr = om * (v_up - v_dn)
    uddr = om * (a_up - a_dn)
    if 0.0 <= tt < tend - LEAD_S:
        if scheme == 1:
            k = tt % (2.0 * S1_HALF)
            if k < S1_HALF:
                cmd = T_RATED * k / S1_HALF
                ph = 1
            else:
                cmd = T_RATED * (2.0 * S1_HALF - k) / S1_HALF
                ph = 3
        else:
            k = tt % S2_PERIOD
            blk = S2_RAMP + S2_HOLD
            if k < S2_NSTEP * blk:
                i = math.floor(k / blk)
                j = k - i * blk
                if j < S2_RAMP:
                    cmd = S2_STEP * (i + j / S2_RAMP)
                    ph = 1
                else:
                    cmd = S2_STEP * (i + 1)
                    ph = 2
            else:
                cmd = S2_STEP * S2_NSTEP * (1.0 - (k - S2_NSTEP * blk) / S2_UNLOAD)
                ph = 3
    return cmd, ph, ur, udr, uddr


@nb.njit(cache=True)
def _alpha(z: float, v: float, zss: float) -> float:
    """Elasto-plastic blending α(z, v) for the steady deflection zss (> 0)."""
    if z == 0.0 or (z > 0.0) != (v > 0.0):
        return 0.0
    a = abs(z)
    zba = Z_BA * zss
    if a <= zba:
        return 0.0
    if a >= zss:
        return 1.0
    return 0.5 * math.sin(math.pi * (a - 0.5 * (zss + zba)) / (zss - zba)) + 0.5


@nb.njit(cache=True)
def _rhs(t: float, y: np.ndarray, p: np.ndarray, ef: np.ndarray, es: np.ndarray,
         fa: np.ndarray, fb: np.ndarray, wand: np.ndarray, dnz: np.ndarray, pl: np.ndarray,
         th_g: float, dy: np.ndarray, aux: np.ndarray) -> None:
    q = y[Y_Q]
    qd = y[Y_QD]
    dlt = y[Y_D]
    dltd = y[Y_DD]
    u = q + dlt
    ud = qd + dltd
    ka = p[P_KA]
    cmd, ph, ur, udr, uddr = _schedule(t, p, fa, fb)

    # the dynamometer's wander (linear interpolation on its grid)
    x = t / WANDER_DT
    i0 = int(x)
    if i0 >= wand.shape[0] - 1:
        wnd = wand[wand.shape[0] - 1]
    else:
        fr = x - i0
        wnd = wand[i0] * (1.0 - fr) + wand[i0 + 1] * fr
    # the dynamometer's servo torque noise, acting on the output at once
    x = t / DYN_NOISE_DT
    i0 = int(x)
    if i0 >= dnz.shape[0] - 1:
        tl_n = dnz[dnz.shape[0] - 1]
    else:
        fr = x - i0
        tl_n = dnz[i0] * (1.0 - fr) + dnz[i0 + 1] * fr
    t_load = y[Y_TL] + tl_n

    # --- transmission: carrier spring (second resonance), then the main spring
    split = ef[E_RES2] == 0
    if split:
        db_in = dlt - y[Y_DA]
        dbd_in = dltd - y[Y_DAD]
        t_out = p[P_KCA] * y[Y_DA] + p[P_CCA] * y[Y_DAD]
    else:
        db_in = dlt
        dbd_in = dltd
        t_out = 0.0
    if ef[E_RIP] == 1:   # motor-shaft kinematic error
        s = es[E_RIP]
        thm = REDUCTION * u
        db_in += s * (KIN_E1 * math.sin(2.0 * thm + p[P_KIN1])
                      + KIN_E2 * math.sin(4.0 * thm + p[P_KIN2]))
        db_in_d = s * (2.0 * KIN_E1 * math.cos(2.0 * thm + p[P_KIN1])
                       + 4.0 * KIN_E2 * math.cos(4.0 * thm + p[P_KIN2])) * REDUCTION * ud
        dbd_in += db_in_d

    # backlash
    dmp = 1.0
    if ef[E_BACK] < 0:
        d_b = db_in
        d_bd = dbd_in
    else:
        b = BACKLASH_B * es[E_BACK]
        if ef[E_BACK] == 1:
            eps = 0.3 * b
            xp = (db_in - b) / eps
            xn = (-db_in - b) / eps
            spp = math.log1p(math.exp(-abs(xp))) + max(xp, 0.0)
            snn = math.log1p(math.exp(-abs(xn))) + max(xn, 0.0)
            d_b = eps * (spp - snn)
            slope = 1.0 / (1.0 + math.exp(-xp)) + 1.0 / (1.0 + math.exp(-xn))
            d_bd = slope * dbd_in
        else:
            if ef[E_BACK] == 0:
                b_hi = b
                b_lo = -b
            else:
                b_hi = 1.5 * b
                b_lo = -0.5 * b
            if db_in > b_hi:
                d_b = db_in - b_hi
            elif db_in < b_lo:
                d_b = db_in - b_lo
            else:
                d_b = 0.0
            d_bd = dbd_in if d_b != 0.0 else 0.0
            dmp = min(1.0, abs(d_b) / 1e-6)

    # position-dependent stiffness
    kap = 1.0
    if ef[E_PSTIFF] == 0:
        dpos = abs(abs(q) - NOTCH_Q)
        if dpos < NOTCH_W:
            kap = 1.0 - min(0.8, NOTCH_D * es[E_PSTIFF]) * 0.5 * (
                1.0 + math.cos(math.pi * dpos / NOTCH_W))
    elif ef[E_PSTIFF] == 1:
        kap = 1.0 + min(0.7, ROLLER_A * es[E_PSTIFF]) * math.sin(ROLLER_N * q + ROLLER_PH)
    if split:   # the main spring stiffened so the series pair keeps the nominal centre slope
        t_el = kap * _spring(d_b * CARRIER_KA / (CARRIER_KA - 1.0), ka, p[P_KB], p[P_D1], p[P_D2])
    else:
        t_el = kap * _spring(d_b, ka, p[P_KB], p[P_D1], p[P_D2])

    # hysteresis
    t_h = 0.0
    dxb = 0.0
    dfz = 0.0
    if ef[E_HYST] == 0:
        t_h = _masing(d_b, pl, min(0.9, MASING_W * es[E_HYST]) * ka)
    elif ef[E_HYST] == 1:
        t_h = y[Y_FZ]
        dfz = ZENER_K * es[E_HYST] * ka * d_bd - y[Y_FZ] / ZENER_TAU
    elif ef[E_HYST] == 2:
        w = min(0.6, BW_W * es[E_HYST])
        xb = y[Y_XB]
        t_h = w * ka * (xb - d_b)
        dxb = d_bd - 1.5 / BW_XU * abs(d_bd) * xb + 0.5 / BW_XU * d_bd * abs(xb)

    # gear ripple torques
    t_r = 0.0
    if ef[E_RIP] == 0:
        t_r = es[E_RIP] * (RIP_A1 * math.sin(RIP_Z * q + p[P_RIP1])
                           + RIP_A2 * math.sin(2.0 * RIP_Z * q + p[P_RIP2]))
    elif ef[E_RIP] == 2:
        t_r = es[E_RIP] * PLN_A * (math.sin(PLN_ORDER * u + p[P_PLN1])
                                   + PLN_R2 * math.sin(2.0 * PLN_ORDER * u + p[P_PLN2]))

    t_b = t_el + t_h + p[P_DTR] * d_bd * dmp + t_r
    if not split:
        t_out = t_b

    # --- output friction (elasto-plastic) with the friction effects
    v = qd
    fc = p[P_FC]
    fv = p[P_FV]
    fc_add = 0.0
    tabs = abs(t_b)
    if ef[E_ASYM] == 0:
        if v > 0.0:
            fc *= 1.0 + ASYM_BOOST * es[E_ASYM]
    elif ef[E_ASYM] == 1:
        if v > 0.0:
            fc *= max(0.25, 1.0 - ASYM_CROSS_C * es[E_ASYM])
            fv *= 1.0 + ASYM_CROSS_V * es[E_ASYM]
    elif ef[E_ASYM] == 2:
        if v < 0.0:
            fc_add += ASYM_HUMP * es[E_ASYM] * p[P_FC] * math.exp(-abs(v) / ASYM_HUMP_V)
    if ef[E_TEMP] == 0:
        f = ((THETA_REF + 273.15) / (th_g + 273.15)) ** TEMP_POWER
        fv *= max(0.1, 1.0 + es[E_TEMP] * (f - 1.0))
    elif ef[E_TEMP] == 1:
        fc_add += TEMP_HYP * es[E_TEMP] * p[P_FC] * (
            (THETA_REF - TEMP_HYP_ZERO) / (th_g - TEMP_HYP_ZERO) - 1.0)
    elif ef[E_TEMP] == 2:
        f = max(0.2, 1.0 + TEMP_LIN * es[E_TEMP] * (THETA_REF - th_g))
        fc *= f
        fv *= f
    if ef[E_LOAD] == 0:
        fc_add += LOAD_MU * es[E_LOAD] * tabs
    elif ef[E_LOAD] == 1:
        f = 1.0 + LOAD_BOTH * es[E_LOAD] * tabs / T_RATED
        fc *= f
        fv *= f
    elif ef[E_LOAD] == 2:
        fc_add += LOAD_HERTZ * es[E_LOAD] * (tabs / T_RATED) ** (2.0 / 3.0)
    if ef[E_STRIB] >= 0:
        vs = STRIB_VS[ef[E_STRIB]]
        xv = v / vs
        if ef[E_STRIB] == 0:
            phi = math.exp(-abs(xv))
        elif ef[E_STRIB] == 1:
            phi = math.exp(-xv * xv)
        else:
            phi = 1.0 / (1.0 + xv * xv)
        fc_add += STRIB_RATIO * es[E_STRIB] * p[P_FC] * phi
    fss = max(0.25 * p[P_FC], fc + fc_add)
    zss = fss / p[P_SIG0]
    zo = y[Y_ZO]
    dzo = v * (1.0 - _alpha(zo, v, zss) * abs(zo) / zss)
    f_o = p[P_SIG0] * zo + p[P_SIG1] * math.exp(-(v / V_D) ** 2) * dzo + fv * v

    # --- motor-side friction
    zm = y[Y_ZM]
    zssm = p[P_FMC] / p[P_SIG0M]
    dzm = ud * (1.0 - _alpha(zm, ud, zssm) * abs(zm) / zssm)
    f_m = p[P_SIG0M] * zm + p[P_SIG1M] * math.exp(-(ud / V_D) ** 2) * dzm + p[P_FMV] * ud

    # --- loads on the output
    pb = y[Y_PB]
    qg = q + pb
    grav = G_ACC * (p[P_MRX] * math.sin(qg) + p[P_MRY] * math.cos(qg))
    dist = 0.0
    if ef[E_DIST] == 0:
        dist = DIST_A * es[E_DIST] * (math.sin(2.0 * math.pi * DIST_F1 * t + p[P_DIS1])
                                      + DIST_R2 * math.sin(2.0 * math.pi * DIST_F2 * t
                                                           + p[P_DIS2]))
    elif ef[E_DIST] == 1:
        k = (t + p[P_DIS3]) % COOL_P
        if k < COOL_RISE:
            dist = COOL_A * es[E_DIST] * (-1.0 + 2.0 * k / COOL_RISE)
        else:
            dist = COOL_A * es[E_DIST] * (1.0 - 2.0 * (k - COOL_RISE) / (COOL_P - COOL_RISE))

    # --- the drive
    ep = ur - u
    vc = udr + p[P_KP] * ep
    ev = vc - ud
    t_m = p[P_KV] * ev + y[Y_CI] + p[P_JM] * uddr
    if t_m > p[P_TMAX]:
        t_m = p[P_TMAX]
    elif t_m < -p[P_TMAX]:
        t_m = -p[P_TMAX]
    udd = (t_m - t_b - f_m) / p[P_JM]

    # --- housing and output
    pbdd = 0.0
    if ef[E_RES2] == 1:
        pbdd = (-p[P_KBH] * pb - p[P_CBH] * y[Y_PBD] - t_out + f_o) / p[P_JBH]
    qgdd = (t_out - t_load - grav - f_o + dist) / p[P_I]
    qdd = qgdd - pbdd
    dadd = 0.0
    if split:
        dadd = (t_b - t_out) / p[P_JCA] - qdd

    dy[Y_Q] = qd
    dy[Y_QD] = qdd
    dy[Y_D] = dltd
    dy[Y_DD] = udd - qdd
    dy[Y_ZO] = dzo
    dy[Y_ZM] = dzm
    dy[Y_CI] = p[P_KI] * ev
    dy[Y_TL] = (p[P_DG] * cmd + wnd - y[Y_TL]) / p[P_DTAU]
    dy[Y_XB] = dxb
    dy[Y_FZ] = dfz
    dy[Y_DA] = y[Y_DAD] if split else 0.0
    dy[Y_DAD] = dadd
    dy[Y_PB] = y[Y_PBD] if ef[E_RES2] == 1 else 0.0
    dy[Y_PBD] = pbdd

    aux[A_TB] = t_out
    aux[A_TA] = t_b
    aux[A_FO] = f_o
    aux[A_FM] = f_m
    aux[A_G] = grav
    aux[A_DIST] = dist
    aux[A_TM] = t_m
    aux[A_CMD] = cmd
    aux[A_PH] = ph
    aux[A_TH] = t_h
    aux[A_DB] = d_b
    aux[A_QDD] = qdd
    aux[A_UDD] = udd
    aux[A_TLT] = t_load


@nb.njit(cache=True)
def _lu(a: np.ndarray, piv: np.ndarray) -> None:
    """In-place LU factorisation with partial pivoting."""
    n = a.shape[0]
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        if a[k, k] == 0.0:
            a[k, k] = 1e-300
        for i in range(k + 1, n):
            a[i, k] /= a[k, k]
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@nb.njit(cache=True)
def _lu_solve(a: np.ndarray, piv: np.ndarray, b: np.ndarray) -> None:
    """Solve in place with the factors of _lu."""
    n = a.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@nb.njit(cache=True)
def _jacobian(t: float, y: np.ndarray, f: np.ndarray, p: np.ndarray, ef: np.ndarray,
              es: np.ndarray, fa: np.ndarray, fb: np.ndarray, wand: np.ndarray, dnz: np.ndarray,
              pl: np.ndarray, th_g: float, h: float, jac: np.ndarray, piv: np.ndarray) -> None:
    """LU factors of I − h/2·∂f/∂y (finite differences) into jac, piv."""
    n = y.shape[0]
    yp = y.copy()
    fp = np.empty(n)
    ax = np.empty(NA)
    for j in range(n):
        dj = 1e-7 * (abs(y[j]) + _TYP[j])
        yp[j] = y[j] + dj
        _rhs(t, yp, p, ef, es, fa, fb, wand, dnz, pl, th_g, fp, ax)
        yp[j] = y[j]
        for i in range(n):
            jac[i, j] = -0.5 * h * (fp[i] - f[i]) / dj
        jac[j, j] += 1.0
    _lu(jac, piv)


@nb.njit(cache=True)
def _integrate(p: np.ndarray, ef: np.ndarray, es: np.ndarray, fa: np.ndarray, fb: np.ndarray,
               wand: np.ndarray, dnz: np.ndarray, y0: np.ndarray, pl0: np.ndarray,
               temps0: np.ndarray,
               nrec: int, h: float) -> tuple:
    """Trapezoidal-rule integration over nrec steps of h; returns (record, Newton failures)."""
    n = NY
    rec = np.empty((nrec, NREC))
    y = y0.copy()
    pl = pl0.copy()
    temps = temps0.copy()
    f0 = np.empty(n)
    f1 = np.empty(n)
    aux = np.empty(NA)
    g = np.empty(n)
    y1 = np.empty(n)
    jac = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    amb = p[P_AMB]
    fails = 0
    stale = True
    _rhs(0.0, y, p, ef, es, fa, fb, wand, dnz, pl, temps[0], f0, aux)
    for k in range(nrec):
        if k > 0:
            t1 = k * h
            for i in range(n):
                y1[i] = y[i] + h * f0[i]
            conv = False
            for attempt in range(2):
                if stale or attempt == 1:
                    _rhs(t1, y1, p, ef, es, fa, fb, wand, dnz, pl, temps[0], f1, aux)
                    _jacobian(t1, y1, f1, p, ef, es, fa, fb, wand, dnz, pl, temps[0], h, jac, piv)
                    stale = False
                for it in range(6):
                    _rhs(t1, y1, p, ef, es, fa, fb, wand, dnz, pl, temps[0], f1, aux)
                    for i in range(n):
                        g[i] = y1[i] - y[i] - 0.5 * h * (f0[i] + f1[i])
                    _lu_solve(jac, piv, g)
                    err = 0.0
                    for i in range(n):
                        y1[i] -= g[i]
                        e = abs(g[i]) / (_ATOL[i] + 1e-10 * abs(y1[i]))
                        if e > err:
                            err = e
                    if err <= 1.0:
                        conv = True
                        if it >= 3:
                            stale = True
                        break
                if conv:
                    break
            if not conv:
                fails += 1
                stale = True
            _rhs(t1, y1, p, ef, es, fa, fb, wand, dnz, pl, temps[0], f1, aux)
            # the Masing element's reversal memory follows the accepted twist
            if ef[E_HYST] == 0:
                d_b = aux[A_DB]
                step = d_b - pl[3]
                if step * pl[2] < 0.0:      # reversed: the last point becomes the reversal
                    pl[1] = _masing(pl[3], pl, min(0.9, MASING_W * es[E_HYST]) * p[P_KA])
                    pl[0] = pl[3]
                    pl[2] = 1.0 if step > 0.0 else -1.0
                elif pl[2] == 0.0 and step != 0.0:
                    pl[2] = 1.0 if step > 0.0 else -1.0
                pl[3] = d_b
            # heat (explicit Euler)
            p_loss = abs(aux[A_FO] * y1[Y_QD]) + abs(aux[A_FM] * (y1[Y_QD] + y1[Y_DD]))
            temps[0] += h * (p_loss - (temps[0] - amb) / R_GEAR) / C_GEAR
            for m in range(3):
                cur = p[P_SH1 + m] * aux[A_TM] / (REDUCTION * p[P_KT1 + m])
                temps[1 + m] += h * (R_WIND * cur * cur - (temps[1 + m] - amb) / R_WTH) / C_WIND
            for i in range(n):
                y[i] = y1[i]
                f0[i] = f1[i]
        else:
            for i in range(n):
                f1[i] = f0[i]
        rec[k, RC_Q] = y[Y_Q]
        rec[k, RC_QD] = y[Y_QD]
        rec[k, RC_QDD] = aux[A_QDD]
        rec[k, RC_U] = y[Y_Q] + y[Y_D]
        rec[k, RC_UD] = y[Y_QD] + y[Y_DD]
        rec[k, RC_T] = aux[A_TB]
        rec[k, RC_TL] = aux[A_TLT]
        rec[k, RC_TCMD] = aux[A_CMD]
        rec[k, RC_FO] = aux[A_FO]
        rec[k, RC_G] = aux[A_G]
        rec[k, RC_DIST] = aux[A_DIST]
        rec[k, RC_TM] = aux[A_TM]
        rec[k, RC_TG] = temps[0]
        rec[k, RC_TM1] = temps[1]
        rec[k, RC_TM2] = temps[2]
        rec[k, RC_TM3] = temps[3]
        rec[k, RC_H] = aux[A_TH]
        rec[k, RC_PH] = aux[A_PH]
        rec[k, RC_PB] = y[Y_PB]
        rec[k, RC_TWIST] = y[Y_D]
    return rec, fails


# --- the run -------------------------------------------------------------------------------------

def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0.0 else np.round(x / step) * step


def _gap(d: float, ef: np.ndarray, es: np.ndarray) -> float:
    """The backlash map δ → δ_b of the data sheet (identity without backlash)."""
    if ef[E_BACK] < 0:
        return d
    b = BACKLASH_B * es[E_BACK]
    if ef[E_BACK] == 1:
        eps = 0.3 * b

        def sp(x: float) -> float:
            return math.log1p(math.exp(-abs(x))) + max(x, 0.0)
        return eps * (sp((d - b) / eps) - sp((-d - b) / eps))
    lo, hi = (-b, b) if ef[E_BACK] == 0 else (-0.5 * b, 1.5 * b)
    return d - hi if d > hi else (d - lo if d < lo else 0.0)


def _spring_input(d: float, u: float, m: dict[str, float], ef: np.ndarray,
                  es: np.ndarray) -> float:
    """The twist the spring sees: d plus the motor-shaft kinematic error at u."""
    if ef[E_RIP] == 1:
        thm = REDUCTION * u
        d += es[E_RIP] * (KIN_E1 * math.sin(2.0 * thm + m["kin_ph1"])
                          + KIN_E2 * math.sin(4.0 * thm + m["kin_ph2"]))
    return d


def _static_torque(d: float, u: float, m: dict[str, float], ef: np.ndarray,
                   es: np.ndarray) -> float:
    """Transmitted torque at rest at q = 0 with spring twist d and motor angle u [rad], the
    hysteresis states on their virgin branch (data sheet section 4)."""
    db = _gap(_spring_input(d, u, m, ef, es), ef, es)
    kap = 1.0
    if ef[E_PSTIFF] == 1:
        kap = 1.0 + min(0.7, ROLLER_A * es[E_PSTIFF]) * math.sin(ROLLER_PH)
    if ef[E_RES2] == 0:
        db_el = db * CARRIER_KA / (CARRIER_KA - 1.0)
    else:
        db_el = db
    t = kap * float(compliance_torque(db_el, m))
    if ef[E_HYST] == 0:
        k0 = min(0.9, MASING_W * es[E_HYST]) * m["k_a"]
        t += k0 * db / (1.0 + abs(db) / MASING_XY)
    if ef[E_RIP] == 0:
        t += es[E_RIP] * (RIP_A1 * math.sin(m["rip_ph1"]) + RIP_A2 * math.sin(m["rip_ph2"]))
    elif ef[E_RIP] == 2:
        t += es[E_RIP] * PLN_A * (math.sin(PLN_ORDER * u + m["pln_ph1"])
                                  + PLN_R2 * math.sin(2.0 * PLN_ORDER * u + m["pln_ph2"]))
    return t


def _solve_twist(target: float, u_base: float, m: dict[str, float], ef: np.ndarray,
                 es: np.ndarray) -> float:
    """Spring twist d holding `target` at rest (bisection; u = u_base + d)."""
    lo, hi = -0.05, 0.05
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _static_torque(mid, u_base + mid, m, ef, es) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """One bench run of rig AG (see the module data sheet). `seed` is the campaign (it draws the
    machine and its gear phases), `run` the run within it (noise, dynamometer wander, clock,
    disturbance phases)."""
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
                             f"{TRAVEL_LIMIT:.2f} rad of the ±180° travel) in scheme {scheme} at "
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

    # per-run draws: wander, disturbance phases, clock
    rw = np.random.default_rng([_SALT, seed, run, 1])
    nw = int(math.ceil(duration / WANDER_DT)) + 2
    a_w = math.exp(-WANDER_DT / WANDER_TAU)
    xi = rw.standard_normal(nw)
    wand = np.empty(nw)
    wand[0] = WANDER_SD * xi[0]
    for k in range(1, nw):
        wand[k] = a_w * wand[k - 1] + WANDER_SD * math.sqrt(1.0 - a_w * a_w) * xi[k]
    wand = np.clip(wand, -WANDER_MAX, WANDER_MAX)
    nd = int(math.ceil(duration / DYN_NOISE_DT)) + 2
    dnz = DYN_NOISE_SD * rw.standard_normal(nd)
    rd = np.random.default_rng([_SALT, seed, run, 4])
    dis_ph = rd.uniform(0.0, 2.0 * math.pi, 2)
    cool_ph = float(rd.uniform(0.0, COOL_P))
    rc = np.random.default_rng([_SALT, seed, run, 3])
    clock_eps = float(rc.uniform(-CLOCK_PPM, CLOCK_PPM))
    clock_phase = float(rc.uniform(0.0, CLOCK_SYNC_S))

    p = np.zeros(N_P)
    p[P_I], p[P_MRX], p[P_MRY], p[P_FC], p[P_FV] = m["I"], m["mr_x"], m["mr_y"], m["f_c"], m["f_v"]
    p[P_SIG0], p[P_SIG1], p[P_KA], p[P_KB] = m["sigma0"], m["sigma1"], m["k_a"], m["k_b"]
    p[P_D1], p[P_D2], p[P_DTR], p[P_JM] = m["blend_lo"], m["blend_hi"], m["D_tr"], m["J_M"]
    p[P_SIG0M], p[P_SIG1M], p[P_FMC], p[P_FMV] = m["sigma0_m"], m["sigma1_m"], m["F_mc"], m["f_mv"]
    p[P_KV], p[P_KI], p[P_KP], p[P_TMAX] = m["K_v"], m["K_i"], m["K_p"], m["T_max"]
    p[P_DG], p[P_DTAU] = m["dyn_gain"], m["dyn_tau"]
    p[P_SCHEME], p[P_DIR] = scheme, dirn
    p[P_OMEGA] = 0.0 if rpm is None else rpm * 2.0 * math.pi / 60.0 / REDUCTION
    p[P_PERIODS], p[P_AMB] = periods, amb
    p[P_TEND] = LEAD_S + periods * _period(scheme)
    p[P_RIP1], p[P_RIP2], p[P_KIN1], p[P_KIN2], p[P_PLN1], p[P_PLN2] = (
        m["rip_ph1"], m["rip_ph2"], m["kin_ph1"], m["kin_ph2"], m["pln_ph1"], m["pln_ph2"])
    p[P_DIS1], p[P_DIS2], p[P_DIS3] = dis_ph[0], dis_ph[1], cool_ph
    res2 = form("second_resonance")
    if res2 == "carrier_split_mode":
        p[P_KCA] = CARRIER_KA * m["k_a"]
        p[P_JCA] = scale("second_resonance") * m["I"]
        p[P_CCA] = 2.0 * CARRIER_Z * math.sqrt(p[P_KCA] * p[P_JCA])
    if res2 == "housing_rocking":
        p[P_KBH] = HOUSING_K
        p[P_JBH] = scale("second_resonance") * HOUSING_K / (2.0 * math.pi * HOUSING_F) ** 2
        p[P_CBH] = 2.0 * HOUSING_Z * math.sqrt(p[P_KBH] * p[P_JBH])
    p[P_SH1], p[P_SH2], p[P_SH3] = m["share1"], m["share2"], m["share3"]
    p[P_KT1], p[P_KT2], p[P_KT3] = m["kt1"], m["kt2"], m["kt3"]

    # initial state: at rest, the transmission holding gravity (τ_L = wander(0))
    t0 = G_ACC * (m["mr_x"] * 0.0 + m["mr_y"]) + wand[0] + dnz[0]
    y0 = np.zeros(NY)
    y0[Y_TL] = wand[0]
    d_a0 = t0 / p[P_KCA] if res2 == "carrier_split_mode" else 0.0
    d_b0 = _solve_twist(t0, d_a0, m, ef, es)
    y0[Y_DA] = d_a0
    y0[Y_D] = d_a0 + d_b0
    y0[Y_CI] = t0
    if res2 == "housing_rocking":
        y0[Y_PB] = -t0 / HOUSING_K
    # the spring's own twist (after the kinematic error and the gap)
    db_virgin = _gap(_spring_input(d_b0, d_a0 + d_b0, m, ef, es), ef, es)
    y0[Y_XB] = db_virgin
    # Masing memory: [reversal twist, value there, direction, last twist] — virgin at δ0
    k0 = min(0.9, MASING_W * es[E_HYST]) * m["k_a"]
    pl0 = np.array([db_virgin, k0 * db_virgin / (1.0 + abs(db_virgin) / MASING_XY), 0.0,
                    db_virgin])
    temps0 = np.array([amb, amb + WIND_START, amb + WIND_START, amb + WIND_START])

    nrec = int(math.ceil(duration / H_STEP)) + 1
    rec, fails = _integrate(p, ef, es, FOURIER_A, FOURIER_B, wand, dnz, y0, pl0, temps0, nrec,
                            H_STEP)
    tr = np.arange(nrec) * H_STEP

    n = int(math.floor(duration * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    t = t[t <= tr[-1] + 1e-12]
    n = len(t)

    def at(col: int, tt: np.ndarray | None = None) -> np.ndarray:
        return np.interp(t if tt is None else tt, tr, rec[:, col])

    # the torque transducer: boxcar mean of T over [t − W, t]
    torque_true = rec[:, RC_T]
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (torque_true[1:] + torque_true[:-1]) * H_STEP)))

    def boxcar(tt: np.ndarray) -> np.ndarray:
        width = 2.0 * sens.torque_filter_s

        def integral(x: np.ndarray) -> np.ndarray:
            return np.where(x >= 0.0, np.interp(np.maximum(x, 0.0), tr, cum),
                            torque_true[0] * x)
        if width <= 0.0:
            return np.interp(np.maximum(tt, 0.0), tr, torque_true)
        return (integral(tt) - integral(tt - width)) / width

    truth = pd.DataFrame({
        "t": t, "q": at(RC_Q), "qd": at(RC_QD), "qdd": at(RC_QDD), "u": at(RC_U), "ud": at(RC_UD),
        "twist": at(RC_TWIST), "twist_rate": at(RC_UD) - at(RC_QD), "torque": at(RC_T),
        "torque_sensor": boxcar(t), "torque_load": at(RC_TL), "torque_cmd": at(RC_TCMD),
        "friction": at(RC_FO), "gravity": at(RC_G), "disturbance": at(RC_DIST),
        "motor_torque": at(RC_TM), "temp_joint": at(RC_TG), "temp_m1": at(RC_TM1),
        "temp_m2": at(RC_TM2), "temp_m3": at(RC_TM3), "hysteresis": at(RC_H),
        "housing": at(RC_PB),
    })

    # --- noise, always drawn in the same order (independent of the effects)
    rng = np.random.default_rng([_SALT, seed, run, 2])
    nz = {k: rng.standard_normal(n) for k in (
        "torque", "load", "qd", "ud", "i1", "i2", "i3", "w1", "w2", "w3",
        "tm1", "tm2", "tm3", "tg")}

    # --- readings
    td = form("time_delay")
    sd = scale("time_delay")
    t_q = t
    if td == "q_frame_hold":
        per = FRAME_S * sd
        t_q = np.maximum(np.floor(t / per + 1e-9) * per - per, 0.0)
    t_u = np.maximum(t - DELAY_S * sd, 0.0) if td == "u_transport" else t
    q_true = at(RC_Q, t_q)
    q_res = math.radians(sens.encoder_res_deg)
    q_meas = _quant(q_true, q_res)
    if form("encoder_drift") == "q_lost_counts":
        q_meas = q_meas - dirn * q_res * np.floor(scale("encoder_drift") * t / SLIP_S)
    u_true = at(RC_U, t_u)
    if form("encoder_drift") == "u_ratio_creep":
        u_true = u_true * (1.0 + RATIO_ERR * scale("encoder_drift"))
    u_meas = _quant(u_true, sens.motor_encoder_res)
    qd_meas = at(RC_QD, t_q) + sens.qd_noise * nz["qd"]
    ud_true = at(RC_UD, t_u)
    ud_meas = ud_true + sens.ud_noise * nz["ud"]

    t_lag = sens.torque_lag_s + (DELAY_S * sd if td == "torque_transport" else 0.0)
    torque = boxcar(t - t_lag)
    off = form("torque_offset")
    so = scale("torque_offset")
    if off == "bridge_unbalance":
        torque = torque + OFF_CONST * so
    elif off == "sqrt_creep":
        torque = torque + OFF_SQRT * so * np.sqrt(t / OFF_SQRT_T)
    elif off == "bending_crosstalk":
        mb = OFF_MBEND * (1.0 - np.exp(-t / OFF_MB_TAU)) * (
            1.0 + 0.03 * np.sin(2.0 * math.pi * 0.04 * t))
        torque = torque + OFF_XTALK * so * mb
    torque = np.clip(_quant(torque + sens.torque_noise * nz["torque"], sens.torque_res),
                     -TORQUE_RANGE, TORQUE_RANGE)
    tload = _quant(at(RC_TL) + sens.load_noise * nz["load"], sens.load_res)

    # --- time stamps from the host clock
    host = t + clock_eps * np.mod(t + clock_phase, CLOCK_SYNC_S)
    ticks = np.floor(host / CLOCK_TICK_S + 1e-6).astype(np.int64)
    stamps = (ticks - ticks[0]) * CLOCK_TICK_S

    cols: dict[str, Any] = {"t": stamps, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
                            "torsion": q_meas - u_meas, "torque": torque, "torque_load": tload,
                            "torque_cmd": at(RC_TCMD)}
    tm = at(RC_TM)
    for k in (1, 2, 3):
        cur = m[f"share{k}"] * tm / (REDUCTION * m[f"kt{k}"])
        cols[f"i_m{k}"] = cur + sens.current_noise * nz[f"i{k}"]
    for k in (1, 2, 3):
        cols[f"w_m{k}"] = REDUCTION * (ud_true + sens.ud_noise * nz[f"w{k}"])
    for k in (1, 2, 3):
        cols[f"temp_m{k}"] = _quant(at(RC_TM1 + k - 1) + sens.temp_noise * nz[f"tm{k}"],
                                    sens.temp_res)
    cols["temp_joint"] = _quant(at(RC_TG) + sens.temp_noise * nz["tg"], sens.temp_res)
    idx = np.minimum(np.floor(t / H_STEP + 1e-9).astype(np.int64), nrec - 1)
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
        "started_at": "2026-03-09T07:45:00Z",
        "notes": (f"{RIG_NAME} validation simulator, scheme {scheme}, {periods} period(s), "
                  f"joint at {amb:g} °C; t stamped by the host clock"),
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
                   "duration_s": duration, "seed": seed, "run": run,
                   "clock_eps": clock_eps, "clock_phase_s": clock_phase,
                   "newton_failures": int(fails), "twist0": float(y0[Y_D])})
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
