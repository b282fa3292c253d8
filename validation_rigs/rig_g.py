"""validation-rig-G: an independent model of the CMOR J4 joint on its test platform.

Written blind (no project code read or imported) to score a sim-to-real diagnosis. It imports
only numpy, pandas, numba, math and dataclasses. Everything needed to rebuild the rig is in
this DATA SHEET. Units are SI (rad, rad/s, N·m, A, s), temperatures are in °C. Angles on the
joint side are *output-referred*: ``u`` is the motor angle divided by N.

DATA SHEET
==========

0. Contract
-----------
``simulate_run(scheme, motor_speed_rpm, direction, temp_joint_c, effects, *, seed, sensors,
periods=3, run=0) -> RigRun(samples, meta, truth)``. ``seed`` fixes the campaign (every plant and
effect parameter is drawn once per seed, uniformly within ±8 % of its nominal value:
``p = p0·(1 + 0.08·U(−1, 1))``, from ``numpy.random.default_rng(SeedSequence([seed, 71]))``, in
the table order below). ``run`` (with the scheme, speed, direction, temperature and periods)
fixes the sensor noise only (standard normals drawn per channel in a fixed order and scaled by
the SensorSpec, so changing a noise level or an effect never changes the noise pattern). The
run is a deterministic function of all arguments. ``effects = {name: {"form": f, "scale": s}}``
("scale" defaults to 1; s finite ≥ 0; anything else, an unknown effect or form, a bad scheme,
speed, direction, temperature, seed, run, periods or SensorSpec field raises ValueError naming
it); each effect's size is linear in ``s`` (up to the clamps and the stick–slip caveat stated
below); ``s = 0`` removes the effect and gives the nominal run bit for bit. Several effects may
be combined. ``campaign_parameters(seed)`` returns the drawn values by the names used here.

Sign conventions: q, u, Δ = u − q, T > 0 when the motors drive the output in +q; τ_set and τ_sh
> 0 load against +q. ``direction`` is the sense of motion; the load of schemes 1–2 opposes it.

Outputs. ``samples`` (SI; the sensor models of sec. 5): t, q, qd, u, ud, torque, torque_load,
temp_joint, phase, i_m1..3, w_m1..3 (rad/s at the motor shafts). ``truth`` (noise-free, same
t): q, qd, u, ud, twist (= u − q), twist_rate, deformation_rate (ḋ), torque (the reading chain
with an ideal converter and no noise), torque_load (load cell without noise), torque_joint (T),
torque_shaft (τ_sh), torque_set, friction (F), bristle (z), temp_joint (T_g), i_m1..3, w_m1..3.
``meta``: the contract keys, ``sensors`` (the data sheet of sec. 5, never naming an effect) and
``integrator`` (step statistics).

1. Plant (states and equations)
-------------------------------
States: q (output angle), v = q̇, Δ = u − q (twist), w = u̇, i1..i3 (motor currents), x_I (speed
PI integrator, N·m), z (friction bristle), T_g (gearbox temperature), τ_a (dynamometer actuator
torque), I_L (dynamometer torque-loop integrator), τ_f (dynamometer's filtered shaft torque),
x_h (hysteresis state), δ_b, v_b (second-resonance branch), plus rate-independent memory of the
Prandtl–Ishlinskii stop operators.

Output side (the dynamometer rotor, inertia J_d referred to the output, is coupled rigidly to the
output flange through the load cell)::

    (I + J_d)·v̇ = T − τ_a − b_d·v − G(q) − F − τ_p(t) − τ_b
    G(q)       = g·(mr_x·sin q + mr_y·cos q),  g = 9.81 m/s²
    τ_sh       = τ_a + J_d·v̇ + b_d·v        (shaft torque seen by the load cell, dynamometer side)

Motor side (three motors on one input shaft, all output-referred)::

    J_u·ẇ = τ_m − T − F_m(w),   J_u = 3·J_m·N²,  N = 11000
    τ_m   = N·η·(k_t1·i1 + k_t2·i2 + k_t3·i3)
    F_m(w) = F_cm·tanh(w/w_ε) + f_vm·w
    Δ̇    = w − v

Transmission (harmonic-drive-like three-slope compliance, smoothed knees, structural damping)::

    x      = Δ − e(q, u)                 (e: kinematic error, gear_ripple; 0 nominal)
    d      = B(x)                        (backlash dead zone; d = x nominal), d' = dB/dx
    ḋ      = d'·(Δ̇ − ė)
    T      = k_f(q)·T_pw(d) + D·ḋ + T_hys     (k_f: position_dependent_stiffness; 1 nominal)
    T_pw(d) = K1·d + (K2 − K1)·S(d, θ1) + (K3 − K2)·S(d, θ2)
    S(d, θ) = r(d − θ) − r(−d − θ),  r(x) = ½·(x + sqrt(x² + ε²)),  ε = knee·θ1
    θ1 = T1/K1,  θ2 = θ1 + (T2 − T1)/K2

(the catalogue form: slope K1 up to T1, K2 from T1 to T2, K3 above, odd in d; the hyperbolic
ramp makes the slope continuous; at the knees the smoothing shifts T by ≤ (K_{i+1} − K_i)·ε/2).
The twist channel is u − q = Δ. The transducer between the transmission and the output flange
measures T.

Output friction: the elasto-plastic model of Dupont, Hayward, Armstrong & Altpeter (2002)::

    ż   = v·(1 − α(z, v)·z/z_ss(v)),   z_ss(v) = sgn(v)·F_ss(v)/σ0
    F   = σ0·z + σ1·ż + σ2·v
    α   = 0                                        if sgn(z) ≠ sgn(v) or |z| ≤ z_ba (pure stick)
        = ½·sin(π·(|z| − (z_max + z_ba)/2)/(z_max − z_ba)) + ½   if z_ba < |z| < z_max
        = 1                                        if |z| ≥ z_max,    z_max = F_ss(v)/σ0
    z_ba = min(zba_frac·f_c/σ0, 0.9·z_max);  ż = 0 when v = 0
    F_ss(v) = F_C + stribeck term (sec. 3);  nominal F_C = f_c, σ2 = f_v

so in steady sliding F = sgn(v)·F_ss(v) + σ2·v (presliding spring σ0 below z_ba, no drift under
a sub-breakaway load).

Motor drive (continuous-time cascade, same current set point to the three motors)::

    ω_ref = ω_ff(t) + Kp_pos·(u_ref − u)          (ω_ff = u̇_ref, velocity feed-forward)
    e_w   = ω_ref − w,     T_dem = Kp_w·e_w + x_I,   ẋ_I = Ki_w·e_w   (frozen while i_ref saturates)
    i_ref = clip(T_dem/(N·η·Σk_tk), ±i_max),   i̇_k = (i_ref − i_k)/τ_ik

Dynamometer (electric servo load, PI torque loop on its own shaft-torque gauge; the platform's
load cell ``torque_load`` is a separate, reading-only instrument)::

    τ_cmd = τ_set + Kp_L·(τ_set − τ_f) + I_L,   İ_L = Ki_L·(τ_set − τ_f)
    τ̇_a   = (clip(τ_cmd, ±180 kN·m) − τ_a)/τ_act,   τ̇_f = (τ_sh − τ_f)/τ_fl

Thermal (losses heat the gearbox; T_g(0) = ambient = temp_joint_c)::

    C_th·Ṫ_g = |F·v| + |F_m·w| + D·ḋ² + cu_frac·R_w·Σ i_k² − (T_g − temp_joint_c)/R_th

Initial state: q = 0 at rest, z = 0, Δ0 solves k_f(0)·T_pw(B(Δ0 − e)) = G(0) (bisection), the
speed integrator and the currents hold that torque, the dynamometer is at zero; the nominal rig
therefore starts in exact static equilibrium (T = G(q)).

Nominal plant parameters (each drawn ±8 % per campaign)::

    I 6700 kg·m² | J_d 900 kg·m² | b_d 1500 N·m·s/rad | mr_x 20.8 kg·m | mr_y −34.5 kg·m
    f_c 2300 N·m | f_v 8700 N·m·s/rad | σ0 8.0e7 N·m/rad (z_c = f_c/σ0 ≈ 2.9e-5 rad)
    σ1 1.2e5 N·m·s/rad | zba_frac 0.5
    K1 0.7e7, K2 1.2e7, K3 1.7e7 N·m/rad | T1 15 kN·m, T2 50 kN·m | knee 0.08 | D 8.0e4 N·m·s/rad
      (secant stiffness at 120 kN·m ≈ 1.3e7 N·m/rad, twist ≈ 9.2e-3 rad ≈ 0.53°)
    η 0.9 | J_m 4.5e-4 kg·m² per motor (J_u ≈ 1.63e5 kg·m²) | k_t1,2,3 1.6 N·m/A
    τ_i1,2,3 1.0e-3 s | R_w 1.2 Ω | F_cm 400 N·m | f_vm 2500 N·m·s/rad | w_ε 1e-4 rad/s | i_max 12 A
    Kp_pos 8 1/s | Kp_w 6.5e6 N·m·s/rad | Ki_w 5.2e7 N·m/rad
    τ_act 0.03 s | τ_fl 0.002 s | Kp_L 0.6 | Ki_L 15 1/s
    C_th 1.5e4 J/K | R_th 0.05 K/W | cu_frac 0.3

2. Schemes (reference trajectories; ``dir`` = direction = ±1)
---------------------------------------------------------------
Schemes 1 and 2: rest 2 s, raised-cosine acceleration over 1.5 s to V = dir·rpm·2π/60/N, cruise;
the load starts at t = 6 s; after the load, cruise 2 s, raised-cosine deceleration 1.5 s, rest
2.5 s. u_ref = Δ0 + ∫ω_ff. The load opposes the motion: τ_set = dir·L(t).

* Scheme 1: L ramps linearly 0 → 120 kN·m over [6, 36] s (phase ``load``) and back to 0 over
  [36, 66] s (``unload``); duration 72 s; ``idle`` elsewhere.
* Scheme 2: twelve 10 kN·m steps: each a 0.5 s raised-cosine rise (``load``) then a 2 s hold
  (``hold``), from t = 6 to 36 s; then a linear unload 120 → 0 kN·m over [36, 46] s (``unload``);
  duration 52 s.
* Scheme 3 (no load, motor_speed_rpm None): rest 2 s, then ``periods`` periods of the fifth-order
  Fourier excitation (Eq. 12), T_f = 20 s (ω_f = 2π/20 rad/s), phase ``excite``; rest 2 s
  (``idle``). q_d(τ) = dir·Σ_l [a_l/(ω_f l)·sin(ω_f l τ) − b_l/(ω_f l)·(cos(ω_f l τ) − 1)] with
  Σa_l = 0 and Σ l·b_l = 0 (starts and ends at rest at 0), scaled to a peak speed of 0.9 × the
  3000 r/min output speed (see ``FOURIER_A``, ``FOURIER_B``). u_ref = Δ0 + q_d, ω_ff = q̇_d.

3. Effects (name: forms; s = scale; every constant below is drawn ±8 % per campaign)
-------------------------------------------------------------------------------------
Friction-level modifiers build F_C and σ2 in this order: temperature, load, asymmetry, then the
clamps F_C ≥ 0.1·f_c, σ2 ≥ 0.1·f_v; then F_ss = F_C + Stribeck. ΔT = T_g − 25 °C.

* stribeck (added to F_ss): s·0.4·f_c·φ(|v|/v_s) (F_s/F_c = 1.4 at s = 1), v_s = 8e-4 rad/s
  (2.8 % of the 3000 r/min output speed, 28 % of the 300 r/min one; scheme 3 sweeps through it at
  every reversal). φ: ``exponential`` e^(−x), ``gaussian`` e^(−x²), ``lorentzian`` 1/(1 + x²),
  ``tanh`` 1 − tanh(x), ``power_1_5`` e^(−x^1.5). Caveat: the falling branch is a negative
  damping; in the 300 r/min cruise, scales above ≈ 1.3 (lorentzian) or ≈ 1.6 (exponential) make
  it exceed D + f_v and the compliant joint goes into stick–slip (a limit cycle: the effect is
  then no longer linear in s). Up to s = 1 every form stays in steady sliding there.
* temperature_friction: ``coulomb_additive`` F_C += −s·15 N·m/°C·ΔT; ``coulomb_viscous``
  F_C, σ2 ×= max(0.1, 1 − s·0.008/°C·ΔT); ``viscous_vogel`` σ2 ×= max(0.1, 1 + s·(ρ − 1)),
  ρ = exp(0.35·(B/(T_g + C) − B/(25 + C))), B = 900 °C, C = 95 °C (Vogel oil viscosity, exponent
  0.35 for the share of the viscous loss that follows the oil).
* load_dependent_friction (|T| the transmitted torque, T_r = 120 kN·m): ``coulomb`` F_C +=
  s·0.03·|T|; ``coulomb_viscous`` F_C ×= 1 + s·1.0·|T|/T_r, σ2 ×= 1 + s·0.6·|T|/T_r;
  ``power_flow`` F_C += s·|T|·(0.015·w + 0.045·(1 − w)), w = ½(1 + tanh(T·v/20 W)) (driving vs
  back-driven mesh loss); ``quadratic`` F_C += s·0.04·T²/T_r.
* asymmetric_friction (σ = sgn v): ``coulomb`` F_C ×= 1 + s·0.15·σ; ``viscous`` σ2 ×= 1 +
  s·0.25·σ; ``both``.
* gear_ripple (kinematic error e in the transmission): ``output``
  e = s·(1.2e-4·sin(54q + 0.3) + 0.4e-4·sin(108q + 1.1)) rad (54 mesh cycles per output turn);
  ``motor`` e = s·(2.0e-5·sin(2Nu + 0.5) + 0.6e-5·sin(4Nu + 2.0)) rad (2 and 4 cycles per motor
  turn, a wave generator); ``both`` the sum. ė is included in ḋ.
* backlash (B(x), half gap h = s·0.75e-3 rad): ``dead_zone`` sharp; ``smooth``
  B = r_ε(x − h) − r_ε(−x − h) with ε = 0.25·h (hyperbolic ramps); ``off_centre`` the sharp dead
  zone centred at c = 0.3·h (contact at x = c ± h); the damper acts only in contact (d').
* hysteresis (T_hys, on d, dissipative): ``bouc_wen_n1`` / ``bouc_wen_n3``: T_hys = s·k_h·x_h,
  ẋ_h = ḋ − β|ḋ||x_h|^(n−1)x_h − γḋ|x_h|^n, β = γ = ½·x_y^(−n), x_y = 1.5e-3 rad, k_h = 4e6
  N·m/rad (|T_hys| ≤ s·6 kN·m); ``prandtl_ishlinskii``: T_hys = s·Σ_i w·P_ri(d), six stop
  operators, r_i = 0.25e-3·(1, 2, 4, 6, 8, 12) rad, w = 0.75e6 N·m/rad (memory updated at every
  accepted step, exact for a monotone step); ``duhem`` (Coleman–Hodgdon): T_hys = s·k_d·(c·d − x_h),
  ẋ_h = a·|ḋ|·(c·d − x_h) + b·ḋ, a = 1000 1/rad, b = 0.4, c = 1, k_d = 8e6 N·m/rad
  (|T_hys| → s·k_d·(c − b)/a = s·4.8 kN·m).
* torque_offset (added to the transducer signal before its filter; reading only): ``constant``
  s·1500 N·m; ``linear_drift`` s·20 N·m/s·t; ``thermal`` s·80 N·m/°C·ΔT; ``settling``
  s·2000·(1 − e^(−t/20 s)) N·m.
* time_delay (reading only, on top of the stated lag): ``pure`` s·0.04 s; ``first_order`` a lag
  τ = s·0.04 s; ``second_order`` two cascaded lags of s·0.02 s each (low-frequency lag s·0.04 s).
* periodic_disturbance (out of vocabulary; a torque τ_p on the output): ``pump``
  s·1500·(sin 2π·4.3t + 0.4·sin(2π·8.6t + 0.7)) N·m; ``fan`` s·1200·sin(2π·1.35t) N·m.
* position_dependent_stiffness (out of vocabulary): k_f = max(0.2, 1 + s·0.15·cos(2q + 0.4))
  (``cosine``) or max(0.2, 1 + s·0.12/rad·q) (``linear``).
* sensor_drift (out of vocabulary, reading only): ``load_cell_linear`` s·15 N·m/s·t and
  ``load_cell_settling`` s·1500·(1 − e^(−t/25 s)) N·m on the load cell; ``encoder_creep`` the
  output encoder reads q + s·2e-5 rad/s·t (qd, from the same encoder, sees the creep rate).
* second_resonance (out of vocabulary): a side-branch inertia J_b = s·J_b0 on the output flange,
  τ_b = J_b·(ω_b²·δ_b + 2ζ_b·ω_b·(v − v_b)), δ̇_b = v − v_b, v̇_b = τ_b/J_b (frequency fixed,
  size ∝ s): ``branch_11hz`` J_b0 = 1200 kg·m², 11 Hz; ``branch_3hz`` J_b0 = 1500 kg·m², 3.2 Hz;
  ζ_b = 0.03.

Temperature effects vanish at 25 °C (apart from the run's own heating, tenths of a degree).

4. Integrator
-------------
Variable-step embedded Bogacki–Shampine 3(2) (FSAL) written here; error per state
|e_i|/(atol_i + rtol·max(|y_i|, |y_i,new|)) ≤ 1 in the max norm, rtol = 1e-6, atol per state
(see ``_ATOL``), step factor 0.9·err^(−1/3) within [0.2, 5], steps ≤ H_MAX = 2 ms (the current
loops and the bristle make the problem mildly stiff; 2 ms stays inside the method's stability
region). The record grid is 0.5 ms (2 kHz), filled with the method's cubic Hermite dense output
(third order, like the method), the right-hand side being evaluated at each grid point for the
derived values (T, τ_sh, F), so the recorded T satisfies the transmission law exactly. Sample
values are linear interpolations of this record at the sample times t_k = k/sample_rate_hz.
meta["integrator"] reports the accepted, rejected and forced (at the 1e-10 s floor) steps.

5. Sensors (a data sheet; the drawn plant parameters do not affect them)
------------------------------------------------------------------------
* torque (transducer): T (+ torque_offset) → first-order amplifier filter τ_tr = 0.5 ms
  (ramp-invariant on the record grid) → [time_delay lags] → clip ±0.8·FS → sigma-delta ADC:
  second-order error-feedback modulator (NTF (1 − z⁻¹)², 17-level quantiser over ±FS,
  FS = 250 kN·m) at f_mod = 64 kHz, sinc³ decimation filter of ratio R = 64 (three cascaded
  length-R moving sums, 3R − 2 taps, unity DC gain). Its group delay is 3(R − 1)/(2·f_mod) =
  1.4766 ms. The DAQ latches the decimator at the modulator tick nearest t_k − torque_lag_s −
  (pure time_delay). Then white noise N(0, torque_noise). Stated lag_s = τ_tr + 3(R − 1)/(2 f_mod)
  + torque_lag_s = 1.9766 ms + torque_lag_s. Stated noise_sd = sqrt(torque_noise² + σ_q²), σ_q =
  (Δq/√12)·‖h ∗ [1, −2, 1]‖₂ the shaped quantisation residual (Δq = 2FS/16; ≈ 0.67 N·m). The truth
  ``torque`` is the same chain with an ideal (unquantised) converter, i.e. the reading without noise.
* torque_load (load cell): τ_sh → first-order τ_lc = 3 ms (+ sensor_drift) → white noise
  N(0, load_noise). lag_s = τ_lc.
* q: output encoder, round(q/res)·res, res = encoder_res_deg·π/180.
* qd: the drive's least-squares slope of the last M_q = 32 output-encoder positions taken every
  h_d = 1 ms (ending at t_k): lag (M_q − 1)·h_d/2 = 15.5 ms; quantisation noise
  (res/√12)·sqrt(12/(h_d²·M(M² − 1))).
* u: motor-1 encoder, 2^18 counts per motor turn (res 2π/2^18 at the motor, /N output-referred).
  ud: LS slope over M_u = 8 motor-1 positions at 1 ms, lag 3.5 ms. w_mK: N × the LS slope of motor
  K's own encoder (each with its own count phase) + white noise N(0, speed_noise = 0.02 rad/s).
* i_mK: true current + N(0, current_noise = 0.02 A).
* temp_joint: round(T_g/0.1)·0.1 °C.
All these numbers are SensorSpec fields (defaults given above) and are repeated in meta["sensors"]
(the motor encoders' count phases are drawn per campaign). Sample times t_k = k/sample_rate_hz,
k = 0 … ⌊duration·rate⌋. The white noises are standard normals from
``default_rng(SeedSequence([seed, run, scheme, direction + 1, round(1000·rpm), periods,
round(1000·temp) + 10⁶, 0x6A]))``, rows in the order torque, torque_load, i_m1..3, w_m1..3.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba as nb
import numpy as np
import pandas as pd

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "validation-rig-G"

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "tanh", "power_1_5"),
    "temperature_friction": ("coulomb_additive", "coulomb_viscous", "viscous_vogel"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow", "quadratic"),
    "asymmetric_friction": ("coulomb", "viscous", "both"),
    "gear_ripple": ("output", "motor", "both"),
    "backlash": ("dead_zone", "smooth", "off_centre"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n3", "prandtl_ishlinskii", "duhem"),
    "torque_offset": ("constant", "linear_drift", "thermal", "settling"),
    "time_delay": ("pure", "first_order", "second_order"),
    "periodic_disturbance": ("pump", "fan"),
    "position_dependent_stiffness": ("cosine", "linear"),
    "sensor_drift": ("load_cell_linear", "load_cell_settling", "encoder_creep"),
    "second_resonance": ("branch_11hz", "branch_3hz"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance",
    "position_dependent_stiffness",
    "sensor_drift",
    "second_resonance",
)
# effect codes in the kernel (index into the form/scale arrays)
(X_STRIBECK, X_TEMP, X_LOAD, X_ASYM, X_RIPPLE, X_BACKLASH, X_HYST, X_OFFSET, X_DELAY, X_PDIST,
 X_PSTIFF, X_DRIFT, X_RES2) = range(13)
_EFFECT_CODE = {name: i for i, name in enumerate(EFFECT_FORMS)}
# effects applied to the readings only (the dynamics never see them)
READING_ONLY = ("torque_offset", "time_delay", "sensor_drift")

G_ACC = 9.81
T_REF_C = 25.0
T_RATED = 120e3
DT_REC = 0.0005  # record grid [s]
F_REC = 2000.0  # record rate [Hz]
H_MAX = 0.002  # largest integrator step [s]
DRAW_SPREAD = 0.08
# numba's on-disk cache records the importing module's name; a cache written under another name
# cannot be loaded, so only the canonical import caches (any other name compiles afresh)
_NB_CACHE = __name__ == "validation_rigs.rig_g"

# ---------------------------------------------------------------- plant parameter table
_PLANT = (
    ("I_out", 6700.0, "kg m^2", "output-side inertia (joint output, link, transducer flange)"),
    ("J_dyn", 900.0, "kg m^2", "dynamometer rotor + reducer inertia, output-referred"),
    ("b_dyn", 1500.0, "N m s/rad", "dynamometer drag"),
    ("mr_x", 20.8, "kg m", "gravity moment, sin q"),
    ("mr_y", -34.5, "kg m", "gravity moment, cos q"),
    ("f_c", 2300.0, "N m", "Coulomb friction at the output"),
    ("f_v", 8700.0, "N m s/rad", "viscous friction at the output (sigma2)"),
    ("sigma0", 8.0e7, "N m/rad", "bristle stiffness"),
    ("sigma1", 1.2e5, "N m s/rad", "bristle damping"),
    ("zba_frac", 0.5, "-", "breakaway displacement z_ba as a fraction of f_c/sigma0"),
    ("K1", 0.7e7, "N m/rad", "stiffness below T1"),
    ("K2", 1.2e7, "N m/rad", "stiffness between T1 and T2"),
    ("K3", 1.7e7, "N m/rad", "stiffness above T2"),
    ("T1", 15000.0, "N m", "first knee torque"),
    ("T2", 50000.0, "N m", "second knee torque"),
    ("knee", 0.08, "-", "knee smoothing width as a fraction of theta1"),
    ("D", 8.0e4, "N m s/rad", "structural damping of the transmission"),
    ("eta", 0.9, "-", "torque-constant efficiency factor of the reducer"),
    ("J_m", 4.5e-4, "kg m^2", "rotor inertia of each motor"),
    ("kt1", 1.6, "N m/A", "torque constant, motor 1"),
    ("kt2", 1.6, "N m/A", "torque constant, motor 2"),
    ("kt3", 1.6, "N m/A", "torque constant, motor 3"),
    ("tau_i1", 1.0e-3, "s", "current-loop time constant, motor 1"),
    ("tau_i2", 1.0e-3, "s", "current-loop time constant, motor 2"),
    ("tau_i3", 1.0e-3, "s", "current-loop time constant, motor 3"),
    ("R_w", 1.2, "ohm", "winding resistance of each motor"),
    ("Fc_m", 400.0, "N m", "motor-side Coulomb friction, output-referred"),
    ("fv_m", 2500.0, "N m s/rad", "motor-side viscous friction, output-referred"),
    ("w_eps", 1.0e-4, "rad/s", "motor-side friction smoothing speed"),
    ("i_max", 12.0, "A", "current limit"),
    ("Kp_pos", 8.0, "1/s", "position-loop gain (on u)"),
    ("Kp_w", 6.5e6, "N m s/rad", "speed-loop proportional gain, output-referred"),
    ("Ki_w", 5.2e7, "N m/rad", "speed-loop integral gain, output-referred"),
    ("tau_act", 0.03, "s", "dynamometer actuator lag"),
    ("tau_fl", 0.002, "s", "dynamometer shaft-torque filter"),
    ("Kp_L", 0.6, "-", "dynamometer torque-loop proportional gain"),
    ("Ki_L", 15.0, "1/s", "dynamometer torque-loop integral gain"),
    ("C_th", 1.5e4, "J/K", "gearbox heat capacity"),
    ("R_th", 0.05, "K/W", "gearbox thermal resistance to ambient"),
    ("cu_frac", 0.3, "-", "share of the motors' copper loss flowing into the gearbox"),
)
(P_I, P_JD, P_BD, P_MRX, P_MRY, P_FC, P_FV, P_S0, P_S1, P_ZBA, P_K1, P_K2, P_K3, P_T1, P_T2,
 P_KNEE, P_D, P_ETA, P_JM, P_KT1, P_KT2, P_KT3, P_TI1, P_TI2, P_TI3, P_RW, P_FCM, P_FVM, P_WEPS,
 P_IMAX, P_KPP, P_KPW, P_KIW, P_TACT, P_TFL, P_KPL, P_KIL, P_CTH, P_RTH, P_CU) = range(len(_PLANT))

# ---------------------------------------------------------------- effect parameter table
_EFFECT_PARAMS = (
    ("st_dF", 0.4, "-", "stribeck: (F_s - F_c)/f_c"),
    ("st_vs", 0.0008, "rad/s", "stribeck: Stribeck speed"),
    ("tf_cT", 15.0, "N m/degC", "temperature: additive Coulomb slope"),
    ("tf_kT", 0.008, "1/degC", "temperature: multiplicative slope"),
    ("tf_B", 900.0, "degC", "temperature: Vogel B"),
    ("tf_C", 95.0, "degC", "temperature: Vogel C"),
    ("tf_p", 0.35, "-", "temperature: Vogel exponent"),
    ("ld_mu", 0.03, "-", "load: Coulomb per |T|"),
    ("ld_lc", 1.0, "-", "load: Coulomb factor slope per |T|/T_r"),
    ("ld_lv", 0.6, "-", "load: viscous factor slope per |T|/T_r"),
    ("ld_mud", 0.015, "-", "load: driving mesh loss per |T|"),
    ("ld_mub", 0.045, "-", "load: back-driven mesh loss per |T|"),
    ("ld_P0", 20.0, "W", "load: power-flow switch width"),
    ("ld_kq", 0.04, "-", "load: quadratic coefficient (x T^2/T_r)"),
    ("as_c", 0.15, "-", "asymmetry: Coulomb"),
    ("as_v", 0.25, "-", "asymmetry: viscous"),
    ("gr_a1", 1.2e-4, "rad", "ripple: output mesh amplitude"),
    ("gr_a2", 0.4e-4, "rad", "ripple: output mesh 2nd harmonic"),
    ("gr_ph1", 0.3, "rad", "ripple: output phase 1"),
    ("gr_ph2", 1.1, "rad", "ripple: output phase 2"),
    ("gr_b1", 2.0e-5, "rad", "ripple: 2/motor-turn amplitude"),
    ("gr_b2", 0.6e-5, "rad", "ripple: 4/motor-turn amplitude"),
    ("gr_ps1", 0.5, "rad", "ripple: motor phase 1"),
    ("gr_ps2", 2.0, "rad", "ripple: motor phase 2"),
    ("bl_h", 0.75e-3, "rad", "backlash: half gap"),
    ("bl_eps", 0.25, "-", "backlash: smoothing / h"),
    ("bl_c", 0.3, "-", "backlash: centre offset / h"),
    ("hy_kh", 4.0e6, "N m/rad", "hysteresis: Bouc-Wen k_h"),
    ("hy_xy", 1.5e-3, "rad", "hysteresis: Bouc-Wen yield x_y"),
    ("hy_w", 0.75e6, "N m/rad", "hysteresis: PI weight"),
    ("hy_r0", 0.25e-3, "rad", "hysteresis: PI threshold unit"),
    ("hy_kd", 8.0e6, "N m/rad", "hysteresis: Duhem k_d"),
    ("hy_a", 1000.0, "1/rad", "hysteresis: Duhem a"),
    ("hy_b", 0.4, "-", "hysteresis: Duhem b"),
    ("hy_c", 1.0, "-", "hysteresis: Duhem c"),
    ("to_c", 1500.0, "N m", "offset: constant"),
    ("to_rate", 20.0, "N m/s", "offset: drift rate"),
    ("to_kT", 80.0, "N m/degC", "offset: thermal zero shift"),
    ("to_A", 2000.0, "N m", "offset: settling amplitude"),
    ("to_tau", 20.0, "s", "offset: settling time constant"),
    ("td_d", 0.04, "s", "time delay: delay / lag"),
    ("pd_Ap", 1500.0, "N m", "periodic: pump amplitude"),
    ("pd_fp", 4.3, "Hz", "periodic: pump frequency"),
    ("pd_Af", 1200.0, "N m", "periodic: fan amplitude"),
    ("pd_ff", 1.35, "Hz", "periodic: fan frequency"),
    ("ps_a", 0.15, "-", "position stiffness: cosine amplitude"),
    ("ps_ph", 0.4, "rad", "position stiffness: cosine phase"),
    ("ps_b", 0.12, "1/rad", "position stiffness: linear slope"),
    ("sd_rate", 15.0, "N m/s", "sensor drift: load-cell rate"),
    ("sd_A", 1500.0, "N m", "sensor drift: load-cell settling amplitude"),
    ("sd_tau", 25.0, "s", "sensor drift: load-cell settling time"),
    ("sd_creep", 2.0e-5, "rad/s", "sensor drift: encoder creep"),
    ("r2_J11", 1200.0, "kg m^2", "second resonance: 11 Hz branch inertia"),
    ("r2_f11", 11.0, "Hz", "second resonance: 11 Hz branch frequency"),
    ("r2_J3", 1500.0, "kg m^2", "second resonance: 3.2 Hz branch inertia"),
    ("r2_f3", 3.2, "Hz", "second resonance: 3.2 Hz branch frequency"),
    ("r2_zeta", 0.03, "-", "second resonance: damping ratio"),
)
(E_ST_DF, E_ST_VS, E_TF_CT, E_TF_KT, E_TF_B, E_TF_C, E_TF_P, E_LD_MU, E_LD_LC, E_LD_LV, E_LD_MUD,
 E_LD_MUB, E_LD_P0, E_LD_KQ, E_AS_C, E_AS_V, E_GR_A1, E_GR_A2, E_GR_PH1, E_GR_PH2, E_GR_B1,
 E_GR_B2, E_GR_PS1, E_GR_PS2, E_BL_H, E_BL_EPS, E_BL_C, E_HY_KH, E_HY_XY, E_HY_W, E_HY_R0,
 E_HY_KD, E_HY_A, E_HY_B, E_HY_C, E_TO_C, E_TO_RATE, E_TO_KT, E_TO_A, E_TO_TAU, E_TD_D, E_PD_AP,
 E_PD_FP, E_PD_AF, E_PD_FF, E_PS_A, E_PS_PH, E_PS_B, E_SD_RATE, E_SD_A, E_SD_TAU, E_SD_CREEP,
 E_R2_J11, E_R2_F11, E_R2_J3, E_R2_F3, E_R2_ZETA) = range(len(_EFFECT_PARAMS))

RIPPLE_Z_OUT = 54  # mesh cycles per output revolution
PI_THRESHOLDS = (1.0, 2.0, 4.0, 6.0, 8.0, 12.0)  # x hy_r0
N_PI = len(PI_THRESHOLDS)

# ---------------------------------------------------------------- states
(S_Q, S_V, S_DL, S_W, S_I1, S_I2, S_I3, S_XI, S_Z, S_TG, S_TA, S_IL, S_TF, S_XH, S_DB,
 S_VB) = range(16)
N_STATE = 16
_ATOL = np.array([1e-9, 1e-9, 1e-10, 1e-9, 1e-5, 1e-5, 1e-5, 1e-2, 1e-11, 1e-6, 1e-2, 1e-2,
                  1e-2, 1e-10, 1e-10, 1e-9])
_RTOL = 1e-6
# aux outputs of the right-hand side
A_T, A_TSH, A_F, A_D, A_TSET, A_DDOT = range(6)
N_AUX = 6
# record columns: t, the 16 states, then the aux values
R_T0 = 0
N_REC = 1 + N_STATE + N_AUX

# ---------------------------------------------------------------- schemes
T_REST0 = 2.0
T_ACC = 1.5
T_LOAD0 = 6.0
T_TAIL_CRUISE = 2.0
T_REST_END = 2.5
S1_RAMP = 30.0
S2_STEP = 10e3
S2_RISE = 0.5
S2_HOLD = 2.0
S2_NSTEP = 12
S2_UNLOAD = 10.0
S3_REST = 2.0
S3_PERIOD = 20.0
V_TOP = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION  # output speed at 3000 r/min [rad/s]


def _fourier_coefficients() -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 velocity coefficients a_l (cos), b_l (sin), l = 1..5, rest-to-rest, scaled."""
    a = np.array([0.0, 0.55, -0.35, 0.30, -0.15])
    b = np.array([0.0, 0.30, 0.25, -0.20, 0.10])
    ell = np.arange(1, 6, dtype=float)
    a[0] = -a[1:].sum()
    b[0] = -(ell[1:] * b[1:]).sum()
    om = 2.0 * math.pi / S3_PERIOD
    tt = np.linspace(0.0, S3_PERIOD, 20001)
    vel = (a[:, None] * np.cos(om * ell[:, None] * tt) + b[:, None] * np.sin(om * ell[:, None] * tt)).sum(0)
    k = 0.9 * V_TOP / np.abs(vel).max()
    return a * k, b * k


FOURIER_A, FOURIER_B = _fourier_coefficients()


# ================================================================ numba kernel
@nb.njit(cache=_NB_CACHE, inline='always')
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@nb.njit(cache=_NB_CACHE, inline='always')
def _ramp(x, eps):
    return 0.5 * (x + math.sqrt(x * x + eps * eps))


@nb.njit(cache=_NB_CACHE, inline='always')
def _ramp_d(x, eps):
    return 0.5 * (1.0 + x / math.sqrt(x * x + eps * eps))


@nb.njit(cache=_NB_CACHE, inline='always')
def _t_pw(d, P):
    k1 = P[P_K1]
    k2 = P[P_K2]
    k3 = P[P_K3]
    th1 = P[P_T1] / k1
    th2 = th1 + (P[P_T2] - P[P_T1]) / k2
    eps = P[P_KNEE] * th1
    return (k1 * d + (k2 - k1) * (_ramp(d - th1, eps) - _ramp(-d - th1, eps))
            + (k3 - k2) * (_ramp(d - th2, eps) - _ramp(-d - th2, eps)))


@nb.njit(cache=_NB_CACHE, inline='always')
def _backlash(x, form, s, EP):
    """Dead zone B(x) and its slope; form 0 = none."""
    if form == 0:
        return x, 1.0
    h = s * EP[E_BL_H]
    if form == 2:
        eps = EP[E_BL_EPS] * h
        return (_ramp(x - h, eps) - _ramp(-x - h, eps),
                _ramp_d(x - h, eps) + _ramp_d(-x - h, eps))
    c = 0.0
    if form == 3:
        c = EP[E_BL_C] * h
    y = x - c
    if y > h:
        return y - h, 1.0
    if y < -h:
        return y + h, 1.0
    return 0.0, 0.0


@nb.njit(cache=_NB_CACHE, inline='always')
def _kin_error(q, u, v, w, form, s, EP):
    e = 0.0
    ed = 0.0
    if form == 1 or form == 3:
        z = float(RIPPLE_Z_OUT)
        a1 = s * EP[E_GR_A1]
        a2 = s * EP[E_GR_A2]
        e += a1 * math.sin(z * q + EP[E_GR_PH1]) + a2 * math.sin(2.0 * z * q + EP[E_GR_PH2])
        ed += (a1 * z * math.cos(z * q + EP[E_GR_PH1])
               + a2 * 2.0 * z * math.cos(2.0 * z * q + EP[E_GR_PH2])) * v
    if form == 2 or form == 3:
        th = REDUCTION * u
        b1 = s * EP[E_GR_B1]
        b2 = s * EP[E_GR_B2]
        e += b1 * math.sin(2.0 * th + EP[E_GR_PS1]) + b2 * math.sin(4.0 * th + EP[E_GR_PS2])
        ed += (b1 * 2.0 * math.cos(2.0 * th + EP[E_GR_PS1])
               + b2 * 4.0 * math.cos(4.0 * th + EP[E_GR_PS2])) * REDUCTION * w
    return e, ed


@nb.njit(cache=_NB_CACHE, inline='always')
def _stiff_factor(q, form, s, EP):
    if form == 1:
        return max(0.2, 1.0 + s * EP[E_PS_A] * math.cos(2.0 * q + EP[E_PS_PH]))
    if form == 2:
        return max(0.2, 1.0 + s * EP[E_PS_B] * q)
    return 1.0


@nb.njit(cache=_NB_CACHE, inline='always')
def _motion(t, V, t_a0, t_d0, ta):
    """Raised-cosine rest-cruise-rest profile: (position, velocity)."""
    if t <= t_a0:
        return 0.0, 0.0
    if t < t_a0 + ta:
        tau = t - t_a0
        return (V * (0.5 * tau - ta / (2.0 * math.pi) * math.sin(math.pi * tau / ta)),
                V * 0.5 * (1.0 - math.cos(math.pi * tau / ta)))
    p1 = 0.5 * V * ta
    t1 = t_a0 + ta
    if t <= t_d0:
        return p1 + V * (t - t1), V
    p2 = p1 + V * (t_d0 - t1)
    if t < t_d0 + ta:
        tau = t - t_d0
        return (p2 + V * (0.5 * tau + ta / (2.0 * math.pi) * math.sin(math.pi * tau / ta)),
                V * 0.5 * (1.0 + math.cos(math.pi * tau / ta)))
    return p2 + 0.5 * V * ta, 0.0


@nb.njit(cache=_NB_CACHE, inline='always')
def _load_level(t, scheme):
    if scheme == 1:
        if t <= T_LOAD0:
            return 0.0
        if t <= T_LOAD0 + S1_RAMP:
            return T_RATED * (t - T_LOAD0) / S1_RAMP
        if t <= T_LOAD0 + 2.0 * S1_RAMP:
            return T_RATED * (1.0 - (t - T_LOAD0 - S1_RAMP) / S1_RAMP)
        return 0.0
    if scheme == 2:
        if t <= T_LOAD0:
            return 0.0
        t_steps_end = T_LOAD0 + S2_NSTEP * (S2_RISE + S2_HOLD)
        if t < t_steps_end:
            j = int((t - T_LOAD0) // (S2_RISE + S2_HOLD))
            tau = t - T_LOAD0 - j * (S2_RISE + S2_HOLD)
            if tau < S2_RISE:
                return S2_STEP * (j + 0.5 * (1.0 - math.cos(math.pi * tau / S2_RISE)))
            return S2_STEP * (j + 1)
        if t < t_steps_end + S2_UNLOAD:
            return S2_STEP * S2_NSTEP * (1.0 - (t - t_steps_end) / S2_UNLOAD)
        return 0.0
    return 0.0


@nb.njit(cache=_NB_CACHE, inline='always')
def _refs(t, SP, FA, FB):
    """(u_ref, w_ff, tau_set). SP = [scheme, dir, V, u0, t_end, periods]."""
    scheme = int(SP[0])
    dr = SP[1]
    u0 = SP[3]
    if scheme == 3:
        te = t - S3_REST
        if te <= 0.0 or te >= SP[5] * S3_PERIOD:
            return u0, 0.0, 0.0
        om = 2.0 * math.pi / S3_PERIOD
        p = 0.0
        vv = 0.0
        for l in range(5):
            wl = om * (l + 1)
            p += FA[l] / wl * math.sin(wl * te) - FB[l] / wl * (math.cos(wl * te) - 1.0)
            vv += FA[l] * math.cos(wl * te) + FB[l] * math.sin(wl * te)
        return u0 + dr * p, dr * vv, 0.0
    t_d0 = SP[4] - T_REST_END - T_ACC
    p, vv = _motion(t, SP[2], T_REST0, t_d0, T_ACC)
    return u0 + dr * p, dr * vv, dr * _load_level(t, scheme)


@nb.njit(cache=_NB_CACHE, error_model='numpy')
def _rhs(t, y, dy, aux, P, EP, EF, ES, SP, FA, FB, mem, memref):
    q = y[S_Q]
    v = y[S_V]
    dl = y[S_DL]
    w = y[S_W]
    u = q + dl
    u_ref, w_ff, tau_set = _refs(t, SP, FA, FB)

    # ---- transmission
    e, ed = _kin_error(q, u, v, w, EF[X_RIPPLE], ES[X_RIPPLE], EP)
    x = dl - e
    xd = (w - v) - ed
    d, dd = _backlash(x, EF[X_BACKLASH], ES[X_BACKLASH], EP)
    ddot = dd * xd
    kf = _stiff_factor(q, EF[X_PSTIFF], ES[X_PSTIFF], EP)
    T = kf * _t_pw(d, P) + P[P_D] * ddot
    dxh = 0.0
    hf = EF[X_HYST]
    if hf == 1 or hf == 2:
        xh = y[S_XH]
        n = 1.0 if hf == 1 else 3.0
        xy = EP[E_HY_XY]
        beta = 0.5 * xy ** (-n)
        ax = abs(xh)
        dxh = ddot - beta * abs(ddot) * ax ** (n - 1.0) * xh - beta * ddot * ax ** n
        T += ES[X_HYST] * EP[E_HY_KH] * xh
    elif hf == 3:
        acc = 0.0
        for i in range(N_PI):
            r = PI_THRESHOLDS[i] * EP[E_HY_R0]
            ei = mem[i] + d - memref[0]
            if ei > r:
                ei = r
            elif ei < -r:
                ei = -r
            acc += ei
        T += ES[X_HYST] * EP[E_HY_W] * acc
    elif hf == 4:
        xh = y[S_XH]
        c = EP[E_HY_C]
        dxh = EP[E_HY_A] * abs(ddot) * (c * d - xh) + EP[E_HY_B] * ddot
        T += ES[X_HYST] * EP[E_HY_KD] * (c * d - xh)

    # ---- friction level
    fc0 = P[P_FC]
    fv0 = P[P_FV]
    fc = fc0
    fv = fv0
    sv = _sgn(v)
    tg = y[S_TG]
    dT = tg - T_REF_C
    f = EF[X_TEMP]
    s = ES[X_TEMP]
    if f == 1:
        fc += -s * EP[E_TF_CT] * dT
    elif f == 2:
        m = max(0.1, 1.0 - s * EP[E_TF_KT] * dT)
        fc *= m
        fv *= m
    elif f == 3:
        bb = EP[E_TF_B]
        cc = EP[E_TF_C]
        rho = math.exp(EP[E_TF_P] * (bb / (tg + cc) - bb / (T_REF_C + cc)))
        fv *= max(0.1, 1.0 + s * (rho - 1.0))
    f = EF[X_LOAD]
    s = ES[X_LOAD]
    aT = abs(T)
    if f == 1:
        fc += s * EP[E_LD_MU] * aT
    elif f == 2:
        fc *= 1.0 + s * EP[E_LD_LC] * aT / T_RATED
        fv *= 1.0 + s * EP[E_LD_LV] * aT / T_RATED
    elif f == 3:
        wgt = 0.5 * (1.0 + math.tanh(T * v / EP[E_LD_P0]))
        fc += s * aT * (EP[E_LD_MUD] * wgt + EP[E_LD_MUB] * (1.0 - wgt))
    elif f == 4:
        fc += s * EP[E_LD_KQ] * T * T / T_RATED
    f = EF[X_ASYM]
    s = ES[X_ASYM]
    if f == 1 or f == 3:
        fc *= 1.0 + s * EP[E_AS_C] * sv
    if f == 2 or f == 3:
        fv *= 1.0 + s * EP[E_AS_V] * sv
    fc = max(fc, 0.1 * fc0)
    fv = max(fv, 0.1 * fv0)
    fss = fc
    f = EF[X_STRIBECK]
    if f > 0:
        xs = abs(v) / EP[E_ST_VS]
        if f == 1:
            phi = math.exp(-xs)
        elif f == 2:
            phi = math.exp(-xs * xs)
        elif f == 3:
            phi = 1.0 / (1.0 + xs * xs)
        elif f == 4:
            phi = 1.0 - math.tanh(xs)
        else:
            phi = math.exp(-xs ** 1.5)
        fss += ES[X_STRIBECK] * EP[E_ST_DF] * fc0 * phi

    # ---- elasto-plastic friction (Dupont et al. 2002)
    s0 = P[P_S0]
    z = y[S_Z]
    zdot = 0.0
    if sv != 0.0:
        zmax = fss / s0
        zss = sv * zmax
        alpha = 0.0
        if z * sv > 0.0:
            az = abs(z)
            zba = min(P[P_ZBA] * fc0 / s0, 0.9 * zmax)
            if az >= zmax:
                alpha = 1.0
            elif az > zba:
                alpha = 0.5 * math.sin(math.pi * (az - 0.5 * (zmax + zba)) / (zmax - zba)) + 0.5
        zdot = v * (1.0 - alpha * z / zss)
    F = s0 * z + P[P_S1] * zdot + fv * v

    # ---- external torques on the output
    G = G_ACC * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    tp = 0.0
    f = EF[X_PDIST]
    if f == 1:
        fp = EP[E_PD_FP]
        tp = ES[X_PDIST] * EP[E_PD_AP] * (math.sin(2.0 * math.pi * fp * t)
                                          + 0.4 * math.sin(4.0 * math.pi * fp * t + 0.7))
    elif f == 2:
        tp = ES[X_PDIST] * EP[E_PD_AF] * math.sin(2.0 * math.pi * EP[E_PD_FF] * t)
    tb = 0.0
    dvb = 0.0
    f = EF[X_RES2]
    if f > 0:
        if f == 1:
            jb0 = EP[E_R2_J11]
            omb = 2.0 * math.pi * EP[E_R2_F11]
        else:
            jb0 = EP[E_R2_J3]
            omb = 2.0 * math.pi * EP[E_R2_F3]
        dvb = omb * omb * y[S_DB] + 2.0 * EP[E_R2_ZETA] * omb * (v - y[S_VB])
        tb = ES[X_RES2] * jb0 * dvb

    ta = y[S_TA]
    vdot = (T - ta - P[P_BD] * v - G - F - tp - tb) / (P[P_I] + P[P_JD])
    tsh = ta + P[P_JD] * vdot + P[P_BD] * v

    # ---- dynamometer torque loop
    err_l = tau_set - y[S_TF]
    tcmd = tau_set + P[P_KPL] * err_l + y[S_IL]
    if tcmd > 180e3:
        tcmd = 180e3
    elif tcmd < -180e3:
        tcmd = -180e3
    dy[S_TA] = (tcmd - ta) / P[P_TACT]
    dy[S_IL] = P[P_KIL] * err_l
    dy[S_TF] = (tsh - y[S_TF]) / P[P_TFL]

    # ---- motors and drive
    kt1 = P[P_KT1]
    kt2 = P[P_KT2]
    kt3 = P[P_KT3]
    i1 = y[S_I1]
    i2 = y[S_I2]
    i3 = y[S_I3]
    tm = REDUCTION * P[P_ETA] * (kt1 * i1 + kt2 * i2 + kt3 * i3)
    fm = P[P_FCM] * math.tanh(w / P[P_WEPS]) + P[P_FVM] * w
    ju = 3.0 * P[P_JM] * REDUCTION * REDUCTION
    ew = w_ff + P[P_KPP] * (u_ref - u) - w
    tdem = P[P_KPW] * ew + y[S_XI]
    iref = tdem / (REDUCTION * P[P_ETA] * (kt1 + kt2 + kt3))
    sat = False
    if iref > P[P_IMAX]:
        iref = P[P_IMAX]
        sat = ew > 0.0
    elif iref < -P[P_IMAX]:
        iref = -P[P_IMAX]
        sat = ew < 0.0
    dy[S_XI] = 0.0 if sat else P[P_KIW] * ew
    dy[S_I1] = (iref - i1) / P[P_TI1]
    dy[S_I2] = (iref - i2) / P[P_TI2]
    dy[S_I3] = (iref - i3) / P[P_TI3]

    dy[S_Q] = v
    dy[S_V] = vdot
    dy[S_DL] = w - v
    dy[S_W] = (tm - T - fm) / ju
    dy[S_Z] = zdot
    ploss = (abs(F * v) + abs(fm * w) + P[P_D] * ddot * ddot
             + P[P_CU] * P[P_RW] * (i1 * i1 + i2 * i2 + i3 * i3))
    dy[S_TG] = (ploss - (tg - SP[6]) / P[P_RTH]) / P[P_CTH]
    dy[S_XH] = dxh
    if EF[X_RES2] > 0:
        dy[S_DB] = v - y[S_VB]
        dy[S_VB] = dvb
    else:
        dy[S_DB] = 0.0
        dy[S_VB] = 0.0

    aux[A_T] = T
    aux[A_TSH] = tsh
    aux[A_F] = F
    aux[A_D] = d
    aux[A_TSET] = tau_set
    aux[A_DDOT] = ddot


@nb.njit(cache=_NB_CACHE)
def _store(rec, k, t, y, aux):
    rec[k, 0] = t
    for i in range(N_STATE):
        rec[k, 1 + i] = y[i]
    for i in range(N_AUX):
        rec[k, 1 + N_STATE + i] = aux[i]


@nb.njit(cache=_NB_CACHE)
def _integrate(y0, P, EP, EF, ES, SP, FA, FB, t_end, mem0, memref0, atol, rtol):
    """Bogacki-Shampine 3(2), FSAL, variable step (h <= H_MAX); the record grid is filled by the
    method's cubic Hermite dense output, with the right-hand side evaluated there for the aux
    values."""
    n = y0.size
    n_rec = int(round(t_end / DT_REC)) + 1
    rec = np.empty((n_rec, N_REC))
    y = y0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    kg = np.empty(n)
    yt = np.empty(n)
    yn = np.empty(n)
    yg = np.empty(n)
    aux = np.zeros(N_AUX)
    auxg = np.zeros(N_AUX)
    mem = mem0.copy()
    memref = memref0.copy()
    t = 0.0
    _rhs(t, y, k1, aux, P, EP, EF, ES, SP, FA, FB, mem, memref)
    _store(rec, 0, t, y, aux)
    h_trial = 1e-4
    h_min = 1e-10
    irec = 1
    n_acc = 0
    n_rej = 0
    n_forced = 0
    t_last = (n_rec - 1) * DT_REC
    while irec < n_rec:
        hh = h_trial
        last = False
        if t + hh >= t_last - 1e-12:
            hh = t_last - t
            last = True
        for i in range(n):
            yt[i] = y[i] + 0.5 * hh * k1[i]
        _rhs(t + 0.5 * hh, yt, k2, aux, P, EP, EF, ES, SP, FA, FB, mem, memref)
        for i in range(n):
            yt[i] = y[i] + 0.75 * hh * k2[i]
        _rhs(t + 0.75 * hh, yt, k3, aux, P, EP, EF, ES, SP, FA, FB, mem, memref)
        for i in range(n):
            yn[i] = y[i] + hh * (2.0 / 9.0 * k1[i] + 1.0 / 3.0 * k2[i] + 4.0 / 9.0 * k3[i])
        t_new = t_last if last else t + hh
        _rhs(t_new, yn, k4, aux, P, EP, EF, ES, SP, FA, FB, mem, memref)
        err = 0.0
        for i in range(n):
            ei = hh * (-5.0 / 72.0 * k1[i] + 1.0 / 12.0 * k2[i] + 1.0 / 9.0 * k3[i] - 0.125 * k4[i])
            sc = atol[i] + rtol * max(abs(y[i]), abs(yn[i]))
            r = abs(ei) / sc
            if not (r <= err):  # also catches NaN
                err = r
        ok = err <= 1.0
        forced = (not ok) and hh <= h_min
        if ok or forced:
            if forced:
                n_forced += 1
            # record-grid points inside (t, t_new]
            while irec < n_rec:
                tg = irec * DT_REC
                if irec == n_rec - 1 and last:
                    tg = t_new
                if tg > t_new:
                    break
                if tg == t_new:
                    _store(rec, irec, tg, yn, aux)
                else:
                    th = (tg - t) / hh
                    h00 = (1.0 + 2.0 * th) * (1.0 - th) * (1.0 - th)
                    h10 = th * (1.0 - th) * (1.0 - th)
                    h01 = th * th * (3.0 - 2.0 * th)
                    h11 = th * th * (th - 1.0)
                    for i in range(n):
                        yg[i] = h00 * y[i] + h01 * yn[i] + hh * (h10 * k1[i] + h11 * k4[i])
                    _rhs(tg, yg, kg, auxg, P, EP, EF, ES, SP, FA, FB, mem, memref)
                    _store(rec, irec, tg, yg, auxg)
                irec += 1
            t = t_new
            for i in range(n):
                y[i] = yn[i]
                k1[i] = k4[i]
            # rate-independent stop-operator memory (exact for a monotone step)
            if EF[X_HYST] == 3:
                dnew = aux[A_D]
                for i in range(N_PI):
                    r = PI_THRESHOLDS[i] * EP[E_HY_R0]
                    ei = mem[i] + dnew - memref[0]
                    if ei > r:
                        ei = r
                    elif ei < -r:
                        ei = -r
                    mem[i] = ei
                memref[0] = dnew
            n_acc += 1
        else:
            n_rej += 1
        if err != err:
            fac = 0.2
        elif err == 0.0:
            fac = 5.0
        else:
            fac = min(5.0, max(0.2, 0.9 * err ** (-1.0 / 3.0)))
        if last and ok and fac >= 1.0:
            h_trial = max(h_trial, hh * fac)
        else:
            h_trial = hh * fac
        if h_trial > H_MAX:
            h_trial = H_MAX
        if h_trial < h_min:
            h_trial = h_min
        if n_acc + n_rej > 200_000_000:
            break
    return rec, n_acc, n_rej, n_forced, irec


@nb.njit(cache=_NB_CACHE)
def _static_twist(G, P, EP, EF, ES):
    """Twist at rest (q = 0) whose transmission torque balances G (bisection)."""
    lo = -0.05
    hi = 0.05
    kf = _stiff_factor(0.0, EF[X_PSTIFF], ES[X_PSTIFF], EP)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        e, ed = _kin_error(0.0, mid, 0.0, 0.0, EF[X_RIPPLE], ES[X_RIPPLE], EP)
        d, dd = _backlash(mid - e, EF[X_BACKLASH], ES[X_BACKLASH], EP)
        if kf * _t_pw(d, P) - G > 0.0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


@nb.njit(cache=_NB_CACHE)
def _lowpass_grid(x, dt, tau):
    """First-order lag, exact for a piecewise-linear input (ramp invariant); y0 = x0."""
    y = np.empty_like(x)
    y[0] = x[0]
    if tau <= 0.0:
        for k in range(1, x.size):
            y[k] = x[k]
        return y
    a = math.exp(-dt / tau)
    for k in range(x.size - 1):
        m = (x[k + 1] - x[k]) / dt
        y[k + 1] = x[k + 1] - m * tau + (y[k] - x[k] + m * tau) * a
    return y


@nb.njit(cache=_NB_CACHE)
def _interp_grid(x, pos):
    """Linear interpolation of a record-grid array at a fractional index (clamped)."""
    if pos <= 0.0:
        return x[0]
    j = int(math.floor(pos))
    if j >= x.size - 1:
        return x[x.size - 1]
    fr = pos - j
    return x[j] + fr * (x[j + 1] - x[j])


@nb.njit(cache=_NB_CACHE)
def _sample_record(rec, pos):
    """All record columns linearly interpolated at fractional record indices pos."""
    K = pos.size
    nc = rec.shape[1]
    out = np.empty((K, nc))
    last = rec.shape[0] - 1
    for k in range(K):
        p = pos[k]
        j = int(math.floor(p))
        if j >= last:
            j = last - 1
        if j < 0:
            j = 0
        fr = p - j
        for c in range(nc):
            a = rec[j, c]
            out[k, c] = a + fr * (rec[j + 1, c] - a)
    return out


@nb.njit(cache=_NB_CACHE)
def _adc_kernel(xf, tpg, h, fs_full, levels, clip, lat):
    """Sigma-delta torque ADC. xf on the record grid, tpg modulator ticks per grid interval,
    h the sinc^3 taps, lat the (sorted) latch ticks. Returns (reading, ideal)."""
    L = h.size
    nl = lat.size
    out = np.empty(nl)
    ideal = np.empty(nl)
    if nl == 0:
        return out, ideal
    dq = 2.0 * fs_full / (levels - 1)
    idq = 1.0 / dq
    inv_tpg = 1.0 / tpg
    n0 = lat[0] - L - 4096
    ry = np.zeros(L)
    rx = np.zeros(L)
    e1 = 0.0
    e2 = 0.0
    k = 0
    nlast = xf.size - 1
    # incremental counters: grid interval j and tick-in-interval r for tick n (n = j*tpg + r)
    if n0 > 0:
        j = n0 // tpg
        r = n0 - j * tpg
    else:
        j = 0
        r = 0
    pos = 0
    for n in range(n0, lat[nl - 1] + 1):
        if n <= 0:
            x = xf[0]
        else:
            if j >= nlast:
                x = xf[nlast]
            else:
                x = xf[j] + (r * inv_tpg) * (xf[j + 1] - xf[j])
            r += 1
            if r == tpg:
                r = 0
                j += 1
        if x > clip:
            x = clip
        elif x < -clip:
            x = -clip
        vv = x - 2.0 * e1 + e2
        yq = dq * np.floor(vv * idq + 0.5)
        if yq > fs_full:
            yq = fs_full
        elif yq < -fs_full:
            yq = -fs_full
        e2 = e1
        e1 = yq - vv
        ry[pos] = yq
        rx[pos] = x
        while k < nl and lat[k] == n:
            a = 0.0
            b = 0.0
            idx = pos
            for m in range(L):
                a += h[m] * ry[idx]
                b += h[m] * rx[idx]
                idx -= 1
                if idx < 0:
                    idx = L - 1
            out[k] = a
            ideal[k] = b
            k += 1
        pos += 1
        if pos == L:
            pos = 0
    return out, ideal


@nb.njit(cache=_NB_CACHE)
def _encoder_ls(pos_fine, t_s, h_d, M, res, phase, gain, creep):
    """Quantised encoder reading at t_s and the drive's LS slope over the last M samples.

    The encoder reads gain*(pos + creep*t) (gain N for a motor encoder), quantised at res with a
    count phase; the result is divided by gain again (output-referred)."""
    K = t_s.size
    qv = np.empty(K)
    sl = np.empty(K)
    # LS weights for samples at tau_j = -j*h_d
    mean = -(M - 1) * h_d / 2.0
    sxx = 0.0
    for j in range(M):
        sxx += (-j * h_d - mean) ** 2
    for k in range(K):
        num = 0.0
        for j in range(M):
            tj = t_s[k] - j * h_d
            p = _interp_grid(pos_fine, tj * F_REC) + creep * max(tj, 0.0)
            c = res * math.floor((gain * p + phase) / res + 0.5) - phase
            c /= gain
            if j == 0:
                qv[k] = c
            num += (-j * h_d - mean) * c
        sl[k] = num / sxx
    return qv, sl


# ================================================================ python side
@dataclass(frozen=True)
class SensorSpec:
    sample_rate_hz: float = 100.0  # any value in [1, 1000]
    encoder_res_deg: float = 0.001  # output encoder step
    torque_noise: float = 150.0  # N·m sd, white, at the samples
    torque_lag_s: float = 0.0  # an extra pure delay of the torque reading
    load_noise: float = 200.0  # N·m sd
    transducer_tau_s: float = 0.0005  # transducer amplifier first-order filter
    adc_mod_rate_hz: float = 64000.0  # sigma-delta modulator rate (a multiple of 2 kHz)
    adc_decimation: int = 64  # sinc^3 decimation ratio R
    adc_full_scale: float = 250e3  # N·m
    adc_levels: int = 17  # quantiser levels of the modulator
    load_cell_tau_s: float = 0.003  # load-cell first-order filter
    drive_period_s: float = 0.001  # drive's encoder sampling period for qd/ud/w_m
    qd_window: int = 32  # M for the output-encoder LS slope
    ud_window: int = 8  # M for the motor-encoder LS slopes
    motor_counts: int = 2 ** 18  # counts per motor turn
    current_noise: float = 0.02  # A sd
    speed_noise: float = 0.02  # rad/s sd at the motor shaft
    temp_resolution: float = 0.1  # °C


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def _is_int(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))


def _check_sensors(sp) -> None:
    if not isinstance(sp, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(sp).__name__}")
    for name in ("sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s", "load_noise",
                 "transducer_tau_s", "adc_mod_rate_hz", "adc_full_scale", "load_cell_tau_s",
                 "drive_period_s", "current_noise", "speed_noise", "temp_resolution"):
        val = getattr(sp, name)
        if not _is_real(val) or not math.isfinite(float(val)):
            raise ValueError(f"sensors.{name} must be a finite number, got {val!r}")
    for name in ("adc_decimation", "adc_levels", "qd_window", "ud_window", "motor_counts"):
        if not _is_int(getattr(sp, name)):
            raise ValueError(f"sensors.{name} must be an integer, got {getattr(sp, name)!r}")
    if not 1.0 <= sp.sample_rate_hz <= 1000.0:
        raise ValueError(f"sensors.sample_rate_hz must be within [1, 1000] Hz, got {sp.sample_rate_hz}")
    if not 0.0 < sp.encoder_res_deg <= 1.0:
        raise ValueError(f"sensors.encoder_res_deg must be in (0, 1] deg, got {sp.encoder_res_deg}")
    for name in ("torque_noise", "load_noise", "current_noise", "speed_noise", "torque_lag_s",
                 "transducer_tau_s", "load_cell_tau_s"):
        if getattr(sp, name) < 0.0:
            raise ValueError(f"sensors.{name} must be >= 0, got {getattr(sp, name)}")
    if sp.torque_lag_s > 1.0:
        raise ValueError(f"sensors.torque_lag_s must be <= 1 s, got {sp.torque_lag_s}")
    ratio = sp.adc_mod_rate_hz / F_REC
    if ratio < 1.0 or abs(ratio - round(ratio)) > 1e-9:
        raise ValueError("sensors.adc_mod_rate_hz must be a whole multiple of 2000 Hz, "
                         f"got {sp.adc_mod_rate_hz}")
    if not 2 <= sp.adc_decimation <= 4096:
        raise ValueError(f"sensors.adc_decimation must be within [2, 4096], got {sp.adc_decimation}")
    if sp.adc_full_scale <= 0.0:
        raise ValueError(f"sensors.adc_full_scale must be > 0, got {sp.adc_full_scale}")
    if not 2 <= sp.adc_levels <= 65537:
        raise ValueError(f"sensors.adc_levels must be within [2, 65537], got {sp.adc_levels}")
    if not 0.0 < sp.drive_period_s <= 0.1:
        raise ValueError(f"sensors.drive_period_s must be in (0, 0.1] s, got {sp.drive_period_s}")
    for name in ("qd_window", "ud_window"):
        if not 2 <= getattr(sp, name) <= 1000:
            raise ValueError(f"sensors.{name} must be within [2, 1000], got {getattr(sp, name)}")
    if sp.motor_counts < 16:
        raise ValueError(f"sensors.motor_counts must be >= 16, got {sp.motor_counts}")
    if sp.temp_resolution <= 0.0:
        raise ValueError(f"sensors.temp_resolution must be > 0, got {sp.temp_resolution}")


def _normalise_effects(effects) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form': f, 'scale': s}}}}, got {type(effects).__name__}")
    out = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known effects: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effect {name!r} must be a dict with 'form' and 'scale', got {spec!r}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effect {name!r} has unknown keys {sorted(extra)}; expected 'form' and 'scale'")
        if "form" not in spec:
            raise ValueError(f"effect {name!r} needs a 'form' (one of {EFFECT_FORMS[name]})")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} for effect {name!r}; forms: {EFFECT_FORMS[name]}")
        scale = spec.get("scale", 1.0)
        if not _is_real(scale):
            raise ValueError(f"scale of effect {name!r} must be a real number, got {scale!r}")
        scale = float(scale)
        if not math.isfinite(scale) or scale < 0.0:
            raise ValueError(f"scale of effect {name!r} must be finite and >= 0, got {scale}")
        if scale > 0.0:
            out[name] = (form, scale)
    return out


_CAMPAIGN_CACHE: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _draw(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    got = _CAMPAIGN_CACHE.get(seed)
    if got is None:
        rng = np.random.default_rng(np.random.SeedSequence([seed, 71]))
        p0 = np.array([row[1] for row in _PLANT])
        e0 = np.array([row[1] for row in _EFFECT_PARAMS])
        P = p0 * (1.0 + DRAW_SPREAD * rng.uniform(-1.0, 1.0, p0.size))
        EP = e0 * (1.0 + DRAW_SPREAD * rng.uniform(-1.0, 1.0, e0.size))
        phases = rng.uniform(0.0, 1.0, 3)  # encoder count phases of motors 1..3 (fraction of a count)
        got = (P, EP, phases)
        if len(_CAMPAIGN_CACHE) > 256:
            _CAMPAIGN_CACHE.clear()
        _CAMPAIGN_CACHE[seed] = got
    return got[0].copy(), got[1].copy(), got[2].copy()


def campaign_parameters(seed: int) -> dict[str, float]:
    """The plant and effect parameters this seed draws (names as in the data sheet tables)."""
    P, EP, _ = _draw(int(seed))
    out = {row[0]: float(P[i]) for i, row in enumerate(_PLANT)}
    out.update({row[0]: float(EP[i]) for i, row in enumerate(_EFFECT_PARAMS)})
    return out


def nominal_parameters() -> dict[str, float]:
    out = {row[0]: float(row[1]) for row in _PLANT}
    out.update({row[0]: float(row[1]) for row in _EFFECT_PARAMS})
    return out


def _param_vector(params: dict[str, float]) -> np.ndarray:
    return np.array([float(params[row[0]]) for row in _PLANT])


def transmission_torque(twist, params: dict[str, float]) -> np.ndarray:
    """Nominal elastic law T_pw(d) of the data sheet (no damping), vectorised."""
    P = _param_vector(params)
    d = np.asarray(twist, dtype=float)
    k1, k2, k3 = P[P_K1], P[P_K2], P[P_K3]
    th1 = P[P_T1] / k1
    th2 = th1 + (P[P_T2] - P[P_T1]) / k2
    eps = P[P_KNEE] * th1

    def r(x):
        return 0.5 * (x + np.sqrt(x * x + eps * eps))

    return k1 * d + (k2 - k1) * (r(d - th1) - r(-d - th1)) + (k3 - k2) * (r(d - th2) - r(-d - th2))


def gravity_torque(q, params: dict[str, float]) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return G_ACC * (params["mr_x"] * np.sin(q) + params["mr_y"] * np.cos(q))


def sinc3_taps(R: int) -> np.ndarray:
    box = np.ones(R)
    h = np.convolve(np.convolve(box, box), box)
    return h / h.sum()


def sinc3_group_delay_s(sensors: SensorSpec) -> float:
    """Group delay of the sinc^3 decimator: (L - 1)/2 ticks, L = 3R - 2 taps."""
    return 3.0 * (sensors.adc_decimation - 1) / (2.0 * sensors.adc_mod_rate_hz)


def adc_quantisation_sd(sensors: SensorSpec) -> float:
    """sd of the modulator's shaped quantisation error after the sinc^3 filter (white-error model)."""
    h = sinc3_taps(sensors.adc_decimation)
    g = np.convolve(h, np.array([1.0, -2.0, 1.0]))
    dq = 2.0 * sensors.adc_full_scale / (sensors.adc_levels - 1)
    return float(dq / math.sqrt(12.0) * math.sqrt(float((g * g).sum())))


def ls_slope_lag_s(window: int, period_s: float) -> float:
    return (window - 1) * period_s / 2.0


def _ls_noise(res: float, window: int, period_s: float) -> float:
    M = window
    return res / math.sqrt(12.0) * math.sqrt(12.0 / (period_s ** 2 * M * (M * M - 1)))


def torque_adc(signal, times, sensors: SensorSpec, lag_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The torque ADC on a record-grid signal (2 kHz, starting at t = 0), latched at ``times - lag_s``.
    Returns (modulator reading, ideal reading), both without the white noise."""
    x = np.ascontiguousarray(signal, dtype=float)
    t = np.asarray(times, dtype=float)
    lat = np.round((t - lag_s) * sensors.adc_mod_rate_hz).astype(np.int64)
    tpg = int(round(sensors.adc_mod_rate_hz / F_REC))
    fs = float(sensors.adc_full_scale)
    return _adc_kernel(x, tpg, sinc3_taps(sensors.adc_decimation), fs, float(sensors.adc_levels),
                       0.8 * fs, lat)


def _duration(scheme: int, periods: int) -> float:
    if scheme == 1:
        return T_LOAD0 + 2.0 * S1_RAMP + T_TAIL_CRUISE + T_ACC + T_REST_END
    if scheme == 2:
        return (T_LOAD0 + S2_NSTEP * (S2_RISE + S2_HOLD) + S2_UNLOAD + T_TAIL_CRUISE + T_ACC
                + T_REST_END)
    return 2.0 * S3_REST + periods * S3_PERIOD


def _phase_labels(scheme: int, t: np.ndarray, periods: int) -> np.ndarray:
    lab = np.full(t.size, "idle", dtype=object)
    if scheme == 1:
        lab[(t > T_LOAD0) & (t <= T_LOAD0 + S1_RAMP)] = "load"
        lab[(t > T_LOAD0 + S1_RAMP) & (t <= T_LOAD0 + 2 * S1_RAMP)] = "unload"
    elif scheme == 2:
        end = T_LOAD0 + S2_NSTEP * (S2_RISE + S2_HOLD)
        inside = (t > T_LOAD0) & (t < end)
        tau = np.mod(t - T_LOAD0, S2_RISE + S2_HOLD)
        lab[inside & (tau < S2_RISE)] = "load"
        lab[inside & (tau >= S2_RISE)] = "hold"
        lab[(t >= end) & (t < end + S2_UNLOAD)] = "unload"
    else:
        lab[(t > S3_REST) & (t < S3_REST + periods * S3_PERIOD)] = "excite"
    return lab


def _validate_call(scheme, motor_speed_rpm, direction, temp_joint_c, seed, run, periods):
    if not _is_int(scheme) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme in (1, 2):
        if motor_speed_rpm is None or not _is_real(motor_speed_rpm) or not math.isfinite(float(motor_speed_rpm)):
            raise ValueError(f"motor_speed_rpm must be a finite number for scheme {scheme}, got {motor_speed_rpm!r}")
        if not 0.0 < float(motor_speed_rpm) <= 3300.0:
            raise ValueError(f"motor_speed_rpm must be within (0, 3300] r/min, got {motor_speed_rpm}")
    elif motor_speed_rpm is not None:
        raise ValueError(f"motor_speed_rpm must be None for scheme 3 (Fourier excitation), got {motor_speed_rpm!r}")
    if not _is_real(direction) or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not _is_real(temp_joint_c) or not math.isfinite(float(temp_joint_c)) or not -20.0 <= float(temp_joint_c) <= 120.0:
        raise ValueError(f"temp_joint_c must be a finite temperature in [-20, 120] degC, got {temp_joint_c!r}")
    if not _is_int(seed) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if not _is_int(run) or run < 0:
        raise ValueError(f"run must be a non-negative integer, got {run!r}")
    if not _is_int(periods) or not 1 <= periods <= 50:
        raise ValueError(f"periods must be an integer in [1, 50], got {periods!r}")


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict], *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    _validate_call(scheme, motor_speed_rpm, direction, temp_joint_c, seed, run, periods)
    _check_sensors(sensors)
    act = _normalise_effects(effects)
    scheme = int(scheme)
    direction = int(direction)
    seed = int(seed)
    run = int(run)
    periods = int(periods)
    temp0 = float(temp_joint_c)
    speed = None if scheme == 3 else float(motor_speed_rpm)

    P, EP, enc_phase = _draw(seed)
    EF = np.zeros(13, dtype=np.int64)
    ES = np.zeros(13)
    for name, (form, scale) in act.items():
        c = _EFFECT_CODE[name]
        EF[c] = EFFECT_FORMS[name].index(form) + 1
        ES[c] = scale
    # the dynamics see only the physical effects
    EFd = EF.copy()
    ESd = ES.copy()
    for name in READING_ONLY:
        EFd[_EFFECT_CODE[name]] = 0
        ESd[_EFFECT_CODE[name]] = 0.0

    t_end = _duration(scheme, periods)
    V = 0.0 if speed is None else speed * 2.0 * math.pi / 60.0 / REDUCTION
    G0 = G_ACC * P[P_MRY]
    dl0 = _static_twist(G0, P, EP, EFd, ESd)
    SP = np.array([float(scheme), float(direction), V, dl0, t_end, float(periods), temp0])

    y0 = np.zeros(N_STATE)
    y0[S_DL] = dl0
    y0[S_TG] = temp0
    # drive holds the static torque: T_dem = G0 + motor friction at rest (0)
    ksum = P[P_KT1] + P[P_KT2] + P[P_KT3]
    i0 = G0 / (REDUCTION * P[P_ETA] * ksum)
    y0[S_I1] = y0[S_I2] = y0[S_I3] = i0
    y0[S_XI] = G0
    d0, _ = _backlash(dl0 - _kin_error(0.0, dl0, 0.0, 0.0, EFd[X_RIPPLE], ESd[X_RIPPLE], EP)[0],
                      EFd[X_BACKLASH], ESd[X_BACKLASH], EP)
    y0[S_XH] = EP[E_HY_C] * d0 if EFd[X_HYST] == 4 else 0.0
    mem0 = np.zeros(N_PI)
    memref0 = np.array([d0])

    rec, n_acc, n_rej, n_forced, irec = _integrate(y0, P, EP, EFd, ESd, SP, FOURIER_A, FOURIER_B,
                                                   t_end, mem0, memref0, _ATOL, _RTOL)
    if irec < rec.shape[0] or not np.all(np.isfinite(rec)):
        raise RuntimeError(f"{RIG_NAME}: integration failed (scheme {scheme}, effects {act})")

    # ---------------------------------------------------------- sampling
    fs = float(sensors.sample_rate_hz)
    K = int(math.floor(t_end * fs + 1e-9)) + 1
    kk = np.arange(K, dtype=float)
    t_s = kk / fs
    pos = kk * (F_REC / fs)  # fractional record index of each sample
    j = np.minimum(np.floor(pos).astype(np.int64), rec.shape[0] - 2)
    fr = pos - j
    samp = _sample_record(rec, pos)

    def at(col):
        return samp[:, col]

    tg_rec = rec[:, 1 + S_TG]
    q_rec = rec[:, 1 + S_Q]
    u_rec = q_rec + rec[:, 1 + S_DL]
    T_rec = rec[:, 1 + N_STATE + A_T]
    tsh_rec = rec[:, 1 + N_STATE + A_TSH]
    t_rec = np.arange(rec.shape[0]) * DT_REC

    # ---- torque transducer chain
    chain = T_rec.copy()
    f, s = EF[X_OFFSET], ES[X_OFFSET]
    if f == 1:
        chain += s * EP[E_TO_C]
    elif f == 2:
        chain += s * EP[E_TO_RATE] * t_rec
    elif f == 3:
        chain += s * EP[E_TO_KT] * (tg_rec - T_REF_C)
    elif f == 4:
        chain += s * EP[E_TO_A] * (1.0 - np.exp(-t_rec / EP[E_TO_TAU]))
    chain = _lowpass_grid(chain, DT_REC, float(sensors.transducer_tau_s))
    extra_delay = 0.0
    f, s = EF[X_DELAY], ES[X_DELAY]
    if f == 1:
        extra_delay = s * EP[E_TD_D]
    elif f == 2:
        chain = _lowpass_grid(chain, DT_REC, s * EP[E_TD_D])
    elif f == 3:
        chain = _lowpass_grid(_lowpass_grid(chain, DT_REC, 0.5 * s * EP[E_TD_D]), DT_REC, 0.5 * s * EP[E_TD_D])
    torque_read, torque_true = torque_adc(chain, t_s, sensors, float(sensors.torque_lag_s) + extra_delay)

    # ---- load cell
    lc = _lowpass_grid(tsh_rec.copy(), DT_REC, float(sensors.load_cell_tau_s))
    f, s = EF[X_DRIFT], ES[X_DRIFT]
    if f == 1:
        lc = lc + s * EP[E_SD_RATE] * t_rec
    elif f == 2:
        lc = lc + s * EP[E_SD_A] * (1.0 - np.exp(-t_rec / EP[E_SD_TAU]))
    creep = s * EP[E_SD_CREEP] if f == 3 else 0.0
    load_true = lc[j] + fr * (lc[j + 1] - lc[j])

    # ---- encoders and drive estimates
    res_q = float(sensors.encoder_res_deg) * math.pi / 180.0
    res_m = 2.0 * math.pi / float(sensors.motor_counts)
    hd = float(sensors.drive_period_s)
    q_meas, qd_meas = _encoder_ls(np.ascontiguousarray(q_rec), t_s, hd, int(sensors.qd_window), res_q,
                                  0.0, 1.0, creep)
    u_meas = None
    ud_meas = None
    w_meas = []
    for m in range(3):
        um, udm = _encoder_ls(np.ascontiguousarray(u_rec), t_s, hd, int(sensors.ud_window), res_m,
                              float(enc_phase[m]) * res_m, REDUCTION, 0.0)
        if m == 0:
            u_meas, ud_meas = um, udm
        w_meas.append(REDUCTION * udm)

    # ---- noise (depends on seed, run and the operating point only)
    ent = [seed, run, scheme, direction + 1, int(round((speed or 0.0) * 1000.0)), periods,
           int(round(temp0 * 1000.0)) + 1_000_000, 0x6A]
    rng = np.random.default_rng(np.random.SeedSequence(ent))
    noise = rng.standard_normal((8, K))
    torque_meas = torque_read + float(sensors.torque_noise) * noise[0]
    load_meas = load_true + float(sensors.load_noise) * noise[1]
    cur_true = [at(1 + S_I1), at(1 + S_I2), at(1 + S_I3)]
    w_true = REDUCTION * at(1 + S_W)
    tres = float(sensors.temp_resolution)
    tg_s = at(1 + S_TG)

    samples = pd.DataFrame({
        "t": t_s,
        "q": q_meas,
        "qd": qd_meas,
        "u": u_meas,
        "ud": ud_meas,
        "torque": torque_meas,
        "torque_load": load_meas,
        "temp_joint": np.round(tg_s / tres) * tres,
        "phase": pd.array(_phase_labels(scheme, t_s, periods).astype(str), dtype="str"),
        "i_m1": cur_true[0] + float(sensors.current_noise) * noise[2],
        "i_m2": cur_true[1] + float(sensors.current_noise) * noise[3],
        "i_m3": cur_true[2] + float(sensors.current_noise) * noise[4],
        "w_m1": w_meas[0] + float(sensors.speed_noise) * noise[5],
        "w_m2": w_meas[1] + float(sensors.speed_noise) * noise[6],
        "w_m3": w_meas[2] + float(sensors.speed_noise) * noise[7],
    })
    twist = at(1 + S_DL)
    truth = pd.DataFrame({
        "t": t_s,
        "q": at(1 + S_Q),
        "qd": at(1 + S_V),
        "u": at(1 + S_Q) + twist,
        "ud": at(1 + S_W),
        "twist": twist,
        "twist_rate": at(1 + S_W) - at(1 + S_V),
        "deformation_rate": at(1 + N_STATE + A_DDOT),
        "torque": torque_true,
        "torque_load": load_true,
        "torque_joint": at(1 + N_STATE + A_T),
        "torque_shaft": at(1 + N_STATE + A_TSH),
        "torque_set": at(1 + N_STATE + A_TSET),
        "friction": at(1 + N_STATE + A_F),
        "bristle": at(1 + S_Z),
        "temp_joint": tg_s,
        "i_m1": cur_true[0],
        "i_m2": cur_true[1],
        "i_m3": cur_true[2],
        "w_m1": w_true,
        "w_m2": w_true,
        "w_m3": w_true,
    })

    gd = sinc3_group_delay_s(sensors)
    q_adc = adc_quantisation_sd(sensors)
    lag_u = ls_slope_lag_s(int(sensors.ud_window), hd)
    w_q = REDUCTION * _ls_noise(res_m / REDUCTION, int(sensors.ud_window), hd)
    sheet = {
        "q": {"resolution": res_q, "unit": "rad"},
        "u": {"resolution": res_m / REDUCTION, "unit": "rad"},
        "torque": {"noise_sd": math.sqrt(float(sensors.torque_noise) ** 2 + q_adc ** 2),
                   "lag_s": float(sensors.transducer_tau_s) + gd + float(sensors.torque_lag_s),
                   "adc_group_delay_s": gd, "adc_quantisation_sd": q_adc,
                   "filter_tau_s": float(sensors.transducer_tau_s), "unit": "N·m"},
        "torque_load": {"noise_sd": float(sensors.load_noise), "lag_s": float(sensors.load_cell_tau_s),
                        "unit": "N·m"},
        "qd": {"lag_s": ls_slope_lag_s(int(sensors.qd_window), hd),
               "noise_sd": _ls_noise(res_q, int(sensors.qd_window), hd), "unit": "rad/s"},
        "ud": {"lag_s": lag_u, "noise_sd": _ls_noise(res_m / REDUCTION, int(sensors.ud_window), hd),
               "unit": "rad/s"},
        "temp_joint": {"resolution": tres, "unit": "°C"},
    }
    for m in (1, 2, 3):
        sheet[f"i_m{m}"] = {"noise_sd": float(sensors.current_noise), "unit": "A"}
        sheet[f"w_m{m}"] = {"noise_sd": math.sqrt(float(sensors.speed_noise) ** 2 + w_q ** 2),
                            "lag_s": lag_u, "unit": "rad/s"}
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": speed,
        "direction": direction,
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "duration_s": float(t_end),
        "temp_joint_c": temp0,
        "seed": seed,
        "run": run,
        "periods": periods if scheme == 3 else None,
        "sensor_spec": asdict(sensors),
        "sensors": sheet,
        "integrator": {"method": "Bogacki-Shampine 3(2), adaptive", "record_dt_s": DT_REC,
                       "steps": int(n_acc), "rejected": int(n_rej), "forced": int(n_forced)},
    }
    return RigRun(samples=samples, meta=meta, truth=truth)
