"""Validation rig N: an independent, physics-level model of the CMOR joint-4 (J4) test platform.

Written from the platform description and the paper only (rig.md, cmor-sghmc-paper.txt); it imports
nothing of the repository. One call of `simulate_run` simulates one run of a campaign: `seed` draws
the physical rig (same seed = same rig), `run` draws that run's noise. Everything below is in SI
units (temperatures in degC). Conventions: q output angle, u motor angle / N (N = 11000), twist
Delta = u - q, T the transmitted torque (what the joint torque transducer carries), tau_L the torque
of the loading shaft on the output (positive resists positive motion). "+-x %" = a campaign draw
p0*(1 + x/100*xi), xi ~ N(0, 1) clipped at +-2.5.

1. PLANT (three inertias on the joint axis, all referred to the output)
--------------------------------------------------------------------------------------------------
  J_u u''   = tau_M - T - f_cm*tanh(u'/v_m) - f_vm*u'                      (three motors, referred)
  I   q''   = T - tau_L - g*(mr_x*sin q + mr_y*cos q) - F_f - tau_rip(q) - tau_dist(t) + tau_app
  J_D qD''  = tau_L - tau_D - f_cD*tanh(qD'/v_D) - f_vD*qD'                 (dynamometer)
  tau_L     = k_S*(q - qD) + c_S*(q' - qD')                                 (loading shaft + flange)
  T         = kappa(q)*C(Delta_s) + T_h + D*b'(Delta_k)*Delta'
  Delta_k   = Delta - e(q, u)        (kinematic error; 0 nominally)
  Delta_s   = b(Delta_k)             (dead zone; identity nominally, b' = 1)
  nominal: kappa = 1, T_h = 0, tau_rip = tau_dist = tau_app = 0.
 Sizes: I = 6685 kg m^2 +-2 %; mr_x = 20.78, mr_y = -34.54 kg m +-4 %; g = 9.81 m/s^2;
  J_u = 3*J_m*N^2 with J_m = 6.0e-4 kg m^2 +-3 % (2.2e5 kg m^2); motor-side losses per motor
  0.06 N m +-10 % Coulomb and 6e-5 N m s/rad +-10 % viscous at the motor shaft (f_cm = 3*N*0.06,
  f_vm = 3*N^2*6e-5; they load the motors, not the torque transducer), v_m = 2e-5 rad/s;
  J_D = 3.0e4 kg m^2 +-5 %, k_S = 6.0e7 N m/rad +-5 %, c_S for damping ratio 0.05 of the
  output/dynamometer shaft mode (~16 Hz), f_cD = 1200 N m +-10 %, f_vD = 3e4 N m s/rad +-10 %,
  v_D = 2e-4 rad/s.
 Transmission stiffness C: odd, three-segment piecewise linear (a geared train stiffening with
  load): slope K1 = 1.0e7 for |C| < T1 = 12 kN m, K2 = 1.35e7 up to T2 = 48 kN m, K3 = 1.75e7
  N m/rad above (K +-4 %, T1/T2 +-5 %): ~0.46 deg of twist at 120 kN m. Mesh damping
  D = 1.2e5 N m s/rad +-10 % on the shaft twist rate Delta' = u' - q'.
 Output friction F_f (bearings and seals between the transducer and the load): a generalised
  Maxwell-slip model of M = 4 LuGre-type elements,
      z_i' = q' - |q'|*z_i/zmax_i,  zmax_i = l_i*s/f_c,  k_i = w_i*f_c/l_i,
      F_f  = sum k_i z_i + sum sigma_i z_i' + fv_eff*q',
  w = (0.35, 0.30, 0.20, 0.15), l = (3, 8, 20, 50) urad +-10 %, sigma_i = k_i/sum(k)*2*0.4*
  sqrt(sum(k)*I). In steady sliding F_f = s*sgn(q') + fv_eff*q' exactly; nominally s = f_c =
  2352.7 N m +-3 % and fv_eff = f_v = 8683 N m s/rad +-3 % (the paper's Eq. 4). Around rest and
  reversals it has presliding (hysteretic, ~50 urad to full sliding, stiffness ~3.9e8 N m/rad).
  The effects below change s(.) and fv_eff(.) (not the presliding lengths).
 Joint drive (S120-like, three motors, torque sharing): speed PI on the motor speed actual (u'
  through 1 ms): tau* = KP*(w* - w_meas) + KI*int(.), KP = 40/s*J_u, KI = 8/s*KP, clamp
  +-3*N*12 N m with anti-windup. Motor k gets i_k* = share_k*tau*/(N*kt_nom), share_k =
  (1 + d_k)/3 (d ~ N(0, 1.5 %), zero sum), current loop first order 0.8 ms, kt_nom = 1.55 N m/A;
  real kt_k = 1.55 +-3 % * (1 - 0.09 %/K*(Theta_mk - 20)); tau_M = N*sum kt_k*i_k.
  Schemes 1-2: w* = direction*w_S*profile(t). Scheme 3 (semi-closed position loop on u):
  w* = direction*qF'(t) + 10/s*(direction*qF(t) - u).
 Dynamometer (servo + reducer, torque mode on its flange): tau_D -> tau_D* first order 2 ms,
  tau_D* = tau_cmd + x_D - 0.9*f_cD*tanh(wDf/v_D), x_D' = 2/s*(tau_cmd - tau_L), wDf = qD'
  through 10 ms. Its tracking error stays inside ~+-1.6 kN m (Table 11: +-2 kN m).
 Thermal: C_g Theta_g' = max(F_f q', 0) + max(f_m u', 0) + sum G_mg(Theta_mk - Theta_g)
  - G_g(Theta_g - Theta_amb); C_m Theta_mk' = 1.5*R20*(1 + 0.393 %/K*(Theta_mk - 20))*i_k^2
  - G_mg(Theta_mk - Theta_g) - G_ma(Theta_mk - Theta_amb). C_g = 2.8e5 J/K +-5 %, G_g = 28 W/K
  +-10 %, C_m = 2500 J/K +-5 %, G_mg = 3, G_ma = 2 W/K, R20 = 1.1 ohm +-3 %, Theta_amb = 20 +-1.5
  degC; Theta_g(0) = temp_joint_c, Theta_mk(0) = temp_joint_c + U(0.3, 2.0) K (campaign).
 Initial state: at rest at q = u = qD = 0, zero twist and T = 0, tau_L = 0, the friction elements
  holding gravity.
 Integrator: semi-implicit (symplectic) Euler at h = 0.2 ms; every linear damping (D, c_S,
  fv_eff, f_vm, f_vD, appendage) is implicit, solved exactly per step on the star-shaped chain
  (output in the middle); stiff terms explicit (largest omega*h ~ 0.05); friction elements advanced
  by their exact exponential solution; all filters by first-order-hold discretisations; the
  hysteretic state by rate-independent twist increments (sub-stepped). Samples are interpolated
  linearly between internal steps at the (jittered) sampling instants.

2. SCHEMES (load always resists the motion)
--------------------------------------------------------------------------------------------------
 1: rest 0.5 s; S-curve (raised cosine) acceleration to w_S = rpm*2pi/60/N in 1.5 s; 1.5 s idle;
    tau_cmd = direction*ramp 0 -> 120 kN m in 40 s ("load"), 2 s "hold", ramp to 0 in 40 s
    ("unload"); 1.5 s idle; 1.5 s deceleration; 0.5 s rest (89 s; 2.5 rad travel at 3000 r/min).
 2: same frame; 12 steps of 10 kN m up (1 s raised-cosine transition "load", 2 s "hold" each), then
    12 steps down ("unload"/"hold"; the last hold at 0 is "idle") (79 s).
 3: 1 s rest, `periods` periods of a 5-harmonic Fourier trajectory (Eq. 12), T_f = 20 s, starting
    and ending at rest with zero acceleration, max |q'| = 0.0257 rad/s (2700 r/min at the motor),
    coefficients minimising the log condition number of the column-normalised Eq. 4 observation
    matrix (cond = 2.16), mirrored by `direction` ("excite"), then 1 s rest. The dynamometer
    loads tau_cmd = 3.1e6 N m s/rad * wDf (velocity-proportional, ~80 kN m peak).

3. SENSORS (stated in meta["sensors"]: resolution, noise_sd, lag_s; lags are DC group delays)
--------------------------------------------------------------------------------------------------
 Sampling: nominal stamps t_k = k/fs; the true instants jitter (sd jitter_sd_s = 30 us, <= 3 sd,
  unstated). q: incremental output encoder, step encoder_res_deg, zeroed at the start with a random
  count-edge phase (bias within +-step/2), no lag. u: motor encoder 2**20 counts/rev / N, zeroed at
  the start, no lag. torque: strain-gauge transducer on the transmission output carrying T ->
  transport delay torque_lag_s -> gain/INL (unstated) -> 2nd-order Bessel anti-alias filter, -3 dB
  at aa_fraction*fs (group delay tau_aa = 1.3617/(2pi*aa_fraction*fs), e.g. 0.87 ms at 1 kHz) ->
  + white noise torque_noise -> ADC step torque_res; stated lag tau_aa + torque_lag_s.
  torque_load: flange on the loading shaft carrying tau_L, same anti-alias filter, noise
  torque_load_noise (100 N m), lag tau_aa. qd: output tachogenerator (gain error, unstated), RC
  tacho_tau_s (5 ms) then the anti-alias filter, noise tacho_noise, lag tacho_tau_s + tau_aa.
  ud / w_m1..3: drive speed actual through ud_tau_s (2 ms). i_m1..3: current actual through
  current_tau_s (4 ms). temp_joint: RTD lag 6 s; temp_m1..3: 1.5 s. torque_cmd: the set point.
  m_bend, f_shear, p_hyd: hydraulic loading at 100 kN m / 90 kN set points with a slow regulator
  error (AR(1), 2 s, sd 300 N m / 150 N) plus sensor noise (150 N m, 80 N, 20 kPa); they are not
  coupled into the torsion. torsion = q - u (measured).

4. UNSTATED IMPERFECTIONS (none is a vocabulary effect)
--------------------------------------------------------------------------------------------------
 output-encoder eccentricity: q reading + a1*sin(q + p1) + a2*sin(2q + p2) (minus its value at 0),
  a1 = 2..5 urad, a2 = 1..2 urad (< 1 arc-second, below the finest stated step); torque transducer
  gain temperature coefficient U(-5, 5) ppm/K from 20 degC and integral non-linearity
  c*FS*(x^3 - x), x = reading/FS, FS = 200 kN m, |c| <= 1.2e-4 (<= 9 N m); tachogenerator gain
  error 0.3 % sd; sampling jitter 30 us sd; motor torque constants +-3 % and torque shares +-1.5 %;
  motor kt temperature drift; dynamometer tracking error; presliding friction dynamics; the
  non-linear (three-segment) stiffness; the 3 Hz transmission and 16 Hz shaft modes.

5. EFFECTS  effects = {name: {"form": f, "scale": s}}; s = 0 is exactly the nominal run.
--------------------------------------------------------------------------------------------------
 Friction effects act on the sliding level s and viscous coefficient fv_eff of F_f (section 1),
 v = q', x = |v|/v_s, v_s = 0.006 rad/s, dF = 0.20*f_c; s_eff >= 0.05 f_c, fv_eff >= 0.
 stribeck:   exponential  s += s_*dF*exp(-x);   gaussian  s += s_*dF*exp(-x^2);
             lorentzian   s += s_*dF/(1 + x^2); stretched s += s_*dF*exp(-sqrt(x));
             memory       s += s_*dF*exp(-vm/v_s), vm = |v| through 40 ms (frictional memory).
 load_dependent_friction (T_el = kappa*C(Delta_s), rated 120 kN m):
             coulomb          s += s_*0.005*|T_el|;
             coulomb_viscous  s += s_*0.003*|T_el|, fv_eff += s_*0.8*f_v*|T_el|/120e3;
             power_flow       s += s_*mu*|T_el|, mu = 0.004 driving (T_el*v >= 0), 0.010 back-driven;
             quadratic        s += s_*600*(T_el/120e3)^2.
 temperature_friction (Theta = gearbox temperature, evolving; dT = Theta - 35):
             viscous_exponential fv_eff += s_*f_v*(exp(-0.035*dT) - 1);
             coulomb_linear      s -= s_*12*dT;
             both_multiplicative s -= s_*0.006*dT*f_c, fv_eff -= s_*0.006*dT*f_v;
             vogel  r = exp(600/(Theta + 95) - 600/130): fv_eff += s_*f_v*(r - 1),
                    s += s_*0.05*f_c*(r - 1).
 asymmetric_friction (sg = sign of v): coulomb s += s_*0.12*f_c*sg; viscous fv_eff += s_*0.6*f_v*sg;
             both s += s_*0.08*f_c*sg, fv_eff += s_*0.5*f_v*sg; one_sided s += s_*300 for v > 0.
 gear_ripple (H(y) = sin(y + 0.3) + 0.45 sin(2y + 1.9) + 0.2 sin(3y + 4.1)):
             output_torque    tau_rip = s_*300*H(96*q) on the output body;
             output_kinematic e = s_*2.0e-4*(H(72*q) - H(0)) rad in the spring deflection;
             motor_angle      e = s_*2.2e-5*(sin(2Nu + 0.8) + 0.35 sin(4Nu + 2.6) - value at 0) rad
                              (2 and 4 cycles per motor revolution; ~300 N m of torque ripple);
             load_modulated   tau_rip = s_*400*H(96*q)*(0.25 + 0.75*|T_el|/120e3).
 torque_offset (reading only): constant +s_*400; drift +s_*400*t/60; warmup
             +s_*450*(1 - exp(-t/25)); thermal +s_*(250 + 10*(Theta - 20)) N m.
 time_delay (reading only, beyond the stated lag; mean extra lag s_*30 ms): pure delay s_*30 ms;
             first_order tau = s_*30 ms; bus_hold delay s_*20 ms then sample-and-hold with period
             s_*20 ms; second_order two first-order lags of s_*15 ms.
 hysteresis (T_h = s_*2500*x, x dimensionless, driven by the twist, x_y = 2.5e-4 rad):
             bouc_wen  dx = dDelta/x_y*(1 - |x|*(0.5*sgn(dDelta*x) + 0.5))            (n = 1);
             bouc_wen_n2 dx = dDelta/x_y*(1 - x^2*(0.75*sgn(dDelta*x) + 0.25))        (n = 2);
             dahl      dx = dDelta/x_y*|1 - x*sgn(dDelta)|^1.5 * sgn(1 - x*sgn(dDelta));
             prandtl_ishlinskii x = sum 0.25*e_j/r_j, stop operators e_j = clamp(e_j + dDelta,
                       +-r_j), r = x_y*(0.25, 0.6, 1.2, 2.5).
 backlash (half-width b = s_*1.2e-4 rad in Delta_s = b(Delta_k); D acts only in contact):
             sharp     dead zone +-b;  smooth  w*(softplus((x - b)/w) - softplus((-x - b)/w)),
             w = 0.25*b;  offcentre  contact at +1.5b and -0.5b (same play, shifted centre).
 Out of the vocabulary:
 periodic_disturbance: hydraulic_cycle tau_dist = s_*400*(sin(2pi 0.37 t + 0.4) + 0.3 sin(2pi 0.74 t
             + 2.0)); pump tau_dist = s_*350*(sin(2pi 11.3 t + 1.1) + 0.4 sin(2pi 22.6 t + 0.2));
             cooler_cycle +s_*250*tanh(3*sin(2pi t/14 + 0.5)) on the torque reading (the oil
             cooler's contactor cycling, picked up by the bridge amplifier).
 position_dependent_stiffness (kappa >= 0.3): two_lobe kappa = 1 + s_*0.08*cos(2q + 0.7);
             linear kappa = 1 + s_*0.05*q; soft_spots kappa = 1 - s_*0.15*(G(q - 0.12) +
             G(q + 0.12)), G(y) = exp(-(y/0.12)^2).
 sensor_drift: torque_load reading + s_*400*t/60 N m; q_encoder reading + s_*4e-6*t rad;
             tacho reading + s_*1e-3*t/60 rad/s.
 second_resonance: a torsional appendage (loading fixture / arm) on the output, inertia s_*I_a,
             stiffness s_*I_a*(2pi f)^2, damping ratio zeta, excited on the appendage by hydraulic
             flow noise s_*sigma*w(t) (unit-sd noise through a 30 Hz first-order low pass):
             fixture I_a = 700 kg m^2, f = 9.5 Hz, zeta = 0.015, sigma = 260 N m;
             arm I_a = 1500 kg m^2, f = 5.2 Hz, zeta = 0.03, sigma = 300 N m.

6. OUTPUT
--------------------------------------------------------------------------------------------------
 RigRun.samples: t, phase, q, qd, u, ud, torsion, torque, torque_load, torque_cmd, i_m1..3, w_m1..3,
  temp_m1..3, temp_joint, p_hyd, m_bend, f_shear (run-format.md). RigRun.meta passes
  core.runfile.validate_meta and holds no effect or truth. RigRun.truth: noise-free physical
  signals at the true sampling instants (t = the stamp, t_sample = the instant): q, qd, qdd, u, ud,
  twist (= u - q), spring_deflection, torque (= T), torque_elastic, torque_damping,
  torque_hysteresis, torque_load, torque_cmd, torque_dyn, friction (= F_f), gravity,
  ripple_torque, disturbance_torque, appendage_torque, temperatures, currents, q_dyn, speed_ref,
  and the clean sensor readings before noise/quantisation (torque_reading_clean, ...).
 Noise streams are drawn per (seed, run, stream) independently of the effects, so runs differing
 only in `effects` share their noise realisation.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba
import numpy as np
import pandas as pd
from scipy.linalg import expm
from scipy.signal import lfilter

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "rig_n"

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "stretched", "memory"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("viscous_exponential", "coulomb_linear", "both_multiplicative",
                             "vogel"),
    "gear_ripple": ("output_torque", "output_kinematic", "motor_angle", "load_modulated"),
    "torque_offset": ("constant", "drift", "warmup", "thermal"),
    "time_delay": ("pure", "first_order", "bus_hold", "second_order"),
    "hysteresis": ("bouc_wen", "bouc_wen_n2", "dahl", "prandtl_ishlinskii"),
    "backlash": ("sharp", "smooth", "offcentre"),
    "asymmetric_friction": ("coulomb", "viscous", "both", "one_sided"),
    "periodic_disturbance": ("hydraulic_cycle", "pump", "cooler_cycle"),
    "position_dependent_stiffness": ("two_lobe", "linear", "soft_spots"),
    "sensor_drift": ("torque_load", "q_encoder", "tacho"),
    "second_resonance": ("fixture", "arm"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "sensor_drift", "second_resonance")
MAX_SCALE = 10.0

_EFFECT_NAMES = tuple(EFFECT_FORMS)
E_STRIBECK, E_LDF, E_TF, E_GR, E_TO, E_TD, E_HY, E_BL, E_AS, E_PD, E_PS, E_SD, E_SR = range(13)

# ---- effect sizes at scale 1 (see the module docstring) ----------------------------------------
T_RATED = 120.0e3
STR_RATIO = 0.20          # (F_s - F_c)/F_c
STR_VS = 0.006            # Stribeck speed [rad/s]
STR_MEM_TAU = 0.04        # frictional-memory time constant [s]
LDF_MU = 0.005            # Coulomb growth per N·m of |T_el|
LDF_MU_CV = 0.003
LDF_KV = 0.8              # relative viscous growth at rated torque
LDF_MU_DRIVE = 0.004
LDF_MU_BACK = 0.010
LDF_QUAD = 600.0          # N·m at rated torque
TF_REF = 35.0             # reference temperature [degC]
TF_B = 0.035              # 1/K
TF_C = 12.0               # N·m/K
TF_G = 0.006              # 1/K
TF_VB = 600.0             # K (Vogel B)
TF_VC = 95.0              # K (Vogel C, with temperatures in degC)
TF_VCOUL = 0.05
GR_Z_T = 96.0             # output torque ripple: cycles per output revolution
GR_A_T = 300.0            # N·m
GR_Z_K = 72.0             # output kinematic error: cycles per output revolution
GR_E_K = 2.0e-4           # rad
GR_E_M = 2.2e-5           # rad (motor-angle kinematic error, referred to the output)
GR_A_LM = 400.0           # N·m at rated torque (load-modulated ripple)
GR_H2 = 0.45
GR_H3 = 0.20
GR_P1, GR_P2, GR_P3 = 0.3, 1.9, 4.1
GR_PM1, GR_PM2 = 0.8, 2.6
TO_C = 400.0
TO_DRIFT = 400.0 / 60.0   # N·m/s
TO_WARM = 450.0
TO_WTAU = 25.0
TO_TH0 = 250.0
TO_THK = 10.0             # N·m/K
TD_LAG = 0.03             # s (mean extra lag of every time_delay form at scale 1)
HY_H = 2500.0             # N·m
HY_XY = 2.5e-4            # rad
BL_B = 1.2e-4             # rad (half-width of the dead zone)
BL_W = 0.25               # smoothing width / half-width
AS_C = 0.12
AS_V = 0.6
AS_BC = 0.08
AS_BV = 0.5
AS_ONE = 300.0            # N·m
PD_A_H, PD_F_H = 400.0, 0.37
PD_A_P, PD_F_P = 350.0, 11.3
PD_A_M, PD_F_M = 250.0, 1.0 / 14.0
PS_2L = 0.08
PS_LIN = 0.05             # per rad
PS_SPOT, PS_SPOT_Q, PS_SPOT_W = 0.15, 0.12, 0.12
SD_TL = 400.0 / 60.0      # N·m/s
SD_Q = 4.0e-6             # rad/s
SD_TACHO = 1.0e-3 / 60.0  # rad/s per s
SR_FORMS = {  # inertia at scale 1 [kg m^2], frequency [Hz], damping ratio, excitation sd [N·m]
    "fixture": (700.0, 9.5, 0.015, 260.0),
    "arm": (1500.0, 5.2, 0.03, 300.0),
}
SR_NOISE_HZ = 30.0

_EFFECT_CONSTANTS = {
    "stribeck": {"ratio": STR_RATIO, "v_s": STR_VS, "memory_tau_s": STR_MEM_TAU},
    "load_dependent_friction": {"mu": LDF_MU, "mu_cv": LDF_MU_CV, "kv": LDF_KV,
                                "mu_drive": LDF_MU_DRIVE, "mu_back": LDF_MU_BACK,
                                "quad_nm": LDF_QUAD, "rated_nm": T_RATED},
    "temperature_friction": {"ref_c": TF_REF, "b_per_K": TF_B, "c_nm_per_K": TF_C,
                             "g_per_K": TF_G, "vogel_B": TF_VB, "vogel_C": TF_VC,
                             "vogel_coulomb": TF_VCOUL},
    "gear_ripple": {"z_torque": GR_Z_T, "a_torque_nm": GR_A_T, "z_kinematic": GR_Z_K,
                    "e_kinematic_rad": GR_E_K, "e_motor_rad": GR_E_M, "a_load_mod_nm": GR_A_LM,
                    "harmonics": [1.0, GR_H2, GR_H3]},
    "torque_offset": {"constant_nm": TO_C, "drift_nm_per_s": TO_DRIFT, "warmup_nm": TO_WARM,
                      "warmup_tau_s": TO_WTAU, "thermal_nm": TO_TH0, "thermal_nm_per_K": TO_THK},
    "time_delay": {"mean_extra_lag_s": TD_LAG},
    "hysteresis": {"h_nm": HY_H, "x_y_rad": HY_XY},
    "backlash": {"half_width_rad": BL_B, "smooth_width_rel": BL_W},
    "asymmetric_friction": {"coulomb_rel": AS_C, "viscous_rel": AS_V, "both_coulomb_rel": AS_BC,
                            "both_viscous_rel": AS_BV, "one_sided_nm": AS_ONE},
    "periodic_disturbance": {"hydraulic_nm": PD_A_H, "hydraulic_hz": PD_F_H, "pump_nm": PD_A_P,
                             "pump_hz": PD_F_P, "cooler_nm": PD_A_M, "cooler_hz": PD_F_M},
    "position_dependent_stiffness": {"two_lobe": PS_2L, "linear_per_rad": PS_LIN,
                                     "spot_depth": PS_SPOT, "spot_q": PS_SPOT_Q,
                                     "spot_width": PS_SPOT_W},
    "sensor_drift": {"torque_load_nm_per_s": SD_TL, "q_rad_per_s": SD_Q,
                     "tacho_rad_per_s2": SD_TACHO},
    "second_resonance": {k: list(v) for k, v in SR_FORMS.items()},
}

# ---- kernel parameter vector layout -----------------------------------------------------------
_PNAMES = (
    "H", "NSTEPS", "N", "DIR", "SCHEME",
    "I", "MRX", "MRY", "G", "FC", "FV",
    "K1", "K2", "K3", "T1", "T2", "D1", "D2", "DAMP",
    "JU", "FCM", "FVM", "VM", "KP", "KI", "TQMAX", "KV", "KTN", "KT1", "KT2", "KT3", "KTTC",
    "R20", "SH1", "SH2", "SH3",
    "WF_A", "WF_B0", "WF_B1", "AI",
    "JD", "KS", "CS", "FCD", "FVD", "VD", "AD", "KID", "FFD", "BL",
    "DF_A", "DF_B0", "DF_B1",
    "KF0", "KF1", "KF2", "KF3", "S10", "S11", "S12", "S13", "LF0", "LF1", "LF2", "LF3",
    "CG", "GG", "CM", "GMG", "GMA", "TAMB", "TG0", "TM10", "TM20", "TM30",
    "OMS",
    "FWF", "TE0", "TE1", "FQ0", "FA0", "FA1", "FA2", "FA3", "FA4", "FB0", "FB1", "FB2", "FB3",
    "FB4",
    "TT_A", "TT_B0", "TT_B1", "UD_A", "UD_B0", "UD_B1", "CU_A", "CU_B0", "CU_B1",
    "TG_A", "TG_B0", "TG_B1", "TMS_A", "TMS_B0", "TMS_B1",
    "TACHO_GAIN", "TQ_TC", "TQ_INL", "TQ_FS", "ECC1", "ECP1", "ECC2", "ECP2",
    "DLY", "NBUF", "AA_ON", "TDF_A", "TDF_B0", "TDF_B1", "TDHOLD",
    "IA", "KA", "CA", "WS", "MEM_A",
)
for _i, _n in enumerate(_PNAMES):
    globals()["P_" + _n] = _i
NP = len(_PNAMES)

_RNAMES = (
    "q", "qd", "qdd", "u", "ud", "twist", "spring_deflection", "torque", "torque_elastic",
    "torque_damping", "torque_hysteresis", "torque_load", "torque_cmd", "torque_dyn", "friction",
    "gravity", "ripple_torque", "disturbance_torque", "appendage_torque", "temp_joint",
    "temp_m1", "temp_m2", "temp_m3", "i_m1", "i_m2", "i_m3", "q_dyn", "speed_ref",
    "S_T", "S_TL", "S_QD", "S_UD", "S_I1", "S_I2", "S_I3", "S_THG", "S_THM1", "S_THM2",
    "S_THM3", "S_QR",
)
for _i, _n in enumerate(_RNAMES):
    globals()["R_" + _n.upper()] = _i
NCOL = len(_RNAMES)


# ================================================================================================
# numba kernel
# ================================================================================================

@numba.njit(cache=True)
def _prof(t, kt, ky, km):
    n = kt.shape[0]
    if t <= kt[0]:
        return ky[0]
    if t >= kt[n - 1]:
        return ky[n - 1]
    j = np.searchsorted(kt, t, side="right") - 1
    x = (t - kt[j]) / (kt[j + 1] - kt[j])
    if km[j] == 1:
        x = 0.5 - 0.5 * math.cos(math.pi * x)
    return ky[j] + (ky[j + 1] - ky[j]) * x


@numba.njit(cache=True)
def _curve(d, K1, K2, K3, T1, T2, d1, d2):
    a = abs(d)
    if a <= d1:
        y = K1 * a
    elif a <= d2:
        y = T1 + K2 * (a - d1)
    else:
        y = T2 + K3 * (a - d2)
    return y if d >= 0.0 else -y


@numba.njit(cache=True)
def _softplus(x):
    if x > 0.0:
        return x + math.log1p(math.exp(-x))
    return math.log1p(math.exp(x))


@numba.njit(cache=True)
def _sigmoid(x):
    if x >= 0.0:
        return 1.0 / (1.0 + math.exp(-x))
    e = math.exp(x)
    return e / (1.0 + e)


@numba.njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@numba.njit(cache=True)
def _harm3(x, p1, p2, p3):
    return math.sin(x + p1) + GR_H2 * math.sin(2.0 * x + p2) + GR_H3 * math.sin(3.0 * x + p3)


@numba.njit(cache=True)
def _levels(v, vmem, Tel, Tg, fc, fv, f_str, s_str, f_ldf, s_ldf, f_tf, s_tf, f_as, s_as):
    """Sliding Coulomb level s(v) and viscous coefficient of the output friction."""
    sC = fc
    fV = fv
    sg = 1.0 if v >= 0.0 else -1.0
    if f_str >= 0:
        if f_str == 4:
            x = vmem / STR_VS
        else:
            x = abs(v) / STR_VS
        if f_str == 0 or f_str == 4:
            gg = math.exp(-x)
        elif f_str == 1:
            gg = math.exp(-x * x)
        elif f_str == 2:
            gg = 1.0 / (1.0 + x * x)
        else:
            gg = math.exp(-math.sqrt(x))
        sC += s_str * STR_RATIO * fc * gg
    if f_ldf >= 0:
        a = abs(Tel)
        if f_ldf == 0:
            sC += s_ldf * LDF_MU * a
        elif f_ldf == 1:
            sC += s_ldf * LDF_MU_CV * a
            fV += s_ldf * fv * LDF_KV * a / T_RATED
        elif f_ldf == 2:
            mu = LDF_MU_DRIVE if Tel * v >= 0.0 else LDF_MU_BACK
            sC += s_ldf * mu * a
        else:
            sC += s_ldf * LDF_QUAD * (a / T_RATED) ** 2
    if f_tf >= 0:
        dT = Tg - TF_REF
        if f_tf == 0:
            fV += s_tf * fv * (math.exp(-TF_B * dT) - 1.0)
        elif f_tf == 1:
            sC -= s_tf * TF_C * dT
        elif f_tf == 2:
            sC -= s_tf * TF_G * dT * fc
            fV -= s_tf * TF_G * dT * fv
        else:
            ratio = math.exp(TF_VB / (Tg + TF_VC) - TF_VB / (TF_REF + TF_VC))
            fV += s_tf * fv * (ratio - 1.0)
            sC += s_tf * TF_VCOUL * fc * (ratio - 1.0)
    if f_as >= 0:
        if f_as == 0:
            sC += s_as * AS_C * fc * sg
        elif f_as == 1:
            fV += s_as * AS_V * fv * sg
        elif f_as == 2:
            sC += s_as * AS_BC * fc * sg
            fV += s_as * AS_BV * fv * sg
        else:
            if v > 0.0:
                sC += s_as * AS_ONE
    if sC < 0.05 * fc:
        sC = 0.05 * fc
    if fV < 0.0:
        fV = 0.0
    return sC, fV


@numba.njit(cache=True)
def _hyst_step(form, x, eops, dd):
    """Advance the normalised hysteretic state by a twist increment dd [rad]."""
    if form == 3:  # Prandtl-Ishlinskii: weighted sum of stop operators
        xs = 0.0
        for j in range(4):
            r = HY_XY * (0.25, 0.6, 1.2, 2.5)[j]
            e = eops[j] + dd
            if e > r:
                e = r
            elif e < -r:
                e = -r
            eops[j] = e
            xs += 0.25 * e / r
        return xs
    nsub = int(abs(dd) / (0.02 * HY_XY)) + 1
    sd = dd / nsub
    sgd = _sgn(sd)
    for _ in range(nsub):
        r = sd / HY_XY
        if form == 0:      # Bouc-Wen n=1, beta=gamma=0.5
            dx = r * (1.0 - abs(x) * (0.5 * sgd * _sgn(x) + 0.5))
        elif form == 1:    # Bouc-Wen n=2, beta=0.75, gamma=0.25
            dx = r * (1.0 - x * x * (0.75 * sgd * _sgn(x) + 0.25))
        else:              # Dahl, exponent 1.5
            y = 1.0 - x * sgd
            dx = r * _sgn(y) * abs(y) ** 1.5
        x += dx
    return x


@numba.njit(cache=True)
def _kernel(P, ef, es, spd_t, spd_y, spd_m, tq_t, tq_y, tq_m, aaA, aaB0, aaB1, wn, ts, out):
    h = P[P_H]
    nsteps = int(P[P_NSTEPS])
    N = P[P_N]
    dirn = P[P_DIR]
    scheme = int(P[P_SCHEME])
    I = P[P_I]
    mrx = P[P_MRX]
    mry = P[P_MRY]
    g = P[P_G]
    fc = P[P_FC]
    fv = P[P_FV]
    K1 = P[P_K1]
    K2 = P[P_K2]
    K3 = P[P_K3]
    T1 = P[P_T1]
    T2 = P[P_T2]
    d1 = P[P_D1]
    d2 = P[P_D2]
    Dm = P[P_DAMP]
    JU = P[P_JU]
    FCM = P[P_FCM]
    FVM = P[P_FVM]
    VM = P[P_VM]
    KP = P[P_KP]
    KI = P[P_KI]
    TQMAX = P[P_TQMAX]
    KV = P[P_KV]
    KTN = P[P_KTN]
    KTTC = P[P_KTTC]
    R20 = P[P_R20]
    JD = P[P_JD]
    KS = P[P_KS]
    CS = P[P_CS]
    FCD = P[P_FCD]
    FVD = P[P_FVD]
    VD = P[P_VD]
    AD = P[P_AD]
    KID = P[P_KID]
    FFD = P[P_FFD]
    BLG = P[P_BL]
    CG = P[P_CG]
    GG = P[P_GG]
    CM = P[P_CM]
    GMG = P[P_GMG]
    GMA = P[P_GMA]
    TAMB = P[P_TAMB]
    OMS = P[P_OMS]
    FWF = P[P_FWF]
    TE0 = P[P_TE0]
    TE1 = P[P_TE1]
    FQ0 = P[P_FQ0]
    IA = P[P_IA]
    KA = P[P_KA]
    CA = P[P_CA]
    WS = P[P_WS]
    AI = P[P_AI]
    MEM_A = P[P_MEM_A]
    DLY = P[P_DLY]
    NBUF = int(P[P_NBUF])
    AA_ON = P[P_AA_ON] > 0.5
    TDHOLD = P[P_TDHOLD]
    kt = np.empty(3)
    sh = np.empty(3)
    for m in range(3):
        kt[m] = P[P_KT1 + m]
        sh[m] = P[P_SH1 + m]
    fa = np.empty(5)
    fb = np.empty(5)
    for l in range(5):
        fa[l] = P[P_FA0 + l]
        fb[l] = P[P_FB0 + l]
    kf = np.empty(4)
    s1 = np.empty(4)
    lf = np.empty(4)
    z = np.empty(4)
    for i in range(4):
        kf[i] = P[P_KF0 + i]
        s1[i] = P[P_S10 + i]
        lf[i] = P[P_LF0 + i]

    f_str = ef[E_STRIBECK]
    s_str = es[E_STRIBECK]
    f_ldf = ef[E_LDF]
    s_ldf = es[E_LDF]
    f_tf = ef[E_TF]
    s_tf = es[E_TF]
    f_gr = ef[E_GR]
    s_gr = es[E_GR]
    f_to = ef[E_TO]
    s_to = es[E_TO]
    f_td = ef[E_TD]
    f_hy = ef[E_HY]
    s_hy = es[E_HY]
    f_bl = ef[E_BL]
    s_bl = es[E_BL]
    f_as = ef[E_AS]
    s_as = es[E_AS]
    f_pd = ef[E_PD]
    s_pd = es[E_PD]
    f_ps = ef[E_PS]
    s_ps = es[E_PS]
    f_sd = ef[E_SD]
    s_sd = es[E_SD]
    has_app = IA > 0.0

    bb = s_bl * BL_B
    bw = BL_W * bb
    eout0 = 0.0
    emot0 = 0.0
    if f_gr == 1:
        eout0 = s_gr * GR_E_K * _harm3(0.0, GR_P1, GR_P2, GR_P3)
    elif f_gr == 2:
        emot0 = s_gr * GR_E_M * (math.sin(GR_PM1) + 0.35 * math.sin(GR_PM2))
    ecc0 = P[P_ECC1] * math.sin(P[P_ECP1]) + P[P_ECC2] * math.sin(P[P_ECP2])

    # ---- initial state: at rest, zero twist, friction holding gravity
    u = 0.0
    vu = 0.0
    q = 0.0
    vq = 0.0
    qD = 0.0
    vD = 0.0
    qa = 0.0
    va = 0.0
    F0 = -g * mry
    for i in range(4):
        z[i] = lf[i] * F0 / fc
    xh = 0.0
    eops = np.zeros(4)
    integ = 0.0
    wmeas = 0.0
    cur_i = np.zeros(3)
    xD = 0.0
    tauD = 0.0
    wDf = 0.0
    Tg = P[P_TG0]
    Tm = np.empty(3)
    for m in range(3):
        Tm[m] = P[P_TM10 + m]
    vmem = 0.0
    qdd = 0.0
    # sensor states
    ring = np.zeros(NBUF)
    held = 0.0
    next_hold = 0.0
    td1 = 0.0
    td2 = 0.0
    td_in1 = 0.0
    td_in2 = 0.0
    xaT = np.zeros(2)
    xaL = np.zeros(2)
    xaQ = np.zeros(2)
    aT_in = 0.0
    aL_in = 0.0
    aQ_in = 0.0
    tach = 0.0
    tach_in = 0.0
    udf = 0.0
    ud_in = 0.0
    cf = np.zeros(3)
    cf_in = np.zeros(3)
    tgs = 0.0
    tg_in = 0.0
    tms = np.zeros(3)
    tm_in = np.zeros(3)
    vu_in = 0.0
    wd_in = 0.0
    prev = np.zeros(NCOL)
    cur = np.zeros(NCOL)
    ns = ts.shape[0]
    k = 0

    for n in range(nsteps + 1):
        t = n * h
        # ---------------- references
        if scheme == 3:
            te = t - TE0
            if te < 0.0:
                te = 0.0
            if te > TE1 - TE0:
                te = TE1 - TE0
            qr = FQ0
            wr = 0.0
            for l in range(5):
                wl = FWF * (l + 1)
                sl = math.sin(wl * te)
                cl = math.cos(wl * te)
                qr += fa[l] / wl * sl - fb[l] / wl * cl
                wr += fa[l] * cl + fb[l] * sl
            if t < TE0 or t > TE1:
                wr = 0.0
            uref = dirn * qr
            wstar = dirn * wr + KV * (uref - u)
            tcmd = BLG * wDf
        else:
            wstar = dirn * OMS * _prof(t, spd_t, spd_y, spd_m)
            tcmd = dirn * _prof(t, tq_t, tq_y, tq_m)

        # ---------------- transmission
        dlt = u - q
        dk = dlt
        if f_gr == 1:
            dk -= s_gr * GR_E_K * _harm3(GR_Z_K * q, GR_P1, GR_P2, GR_P3) - eout0
        elif f_gr == 2:
            dk -= s_gr * GR_E_M * (math.sin(2.0 * N * u + GR_PM1)
                                   + 0.35 * math.sin(4.0 * N * u + GR_PM2)) - emot0
        if f_bl < 0:
            ds = dk
            dzp = 1.0
        elif f_bl == 0:
            if dk > bb:
                ds = dk - bb
                dzp = 1.0
            elif dk < -bb:
                ds = dk + bb
                dzp = 1.0
            else:
                ds = 0.0
                dzp = 0.0
        elif f_bl == 1:
            ds = bw * (_softplus((dk - bb) / bw) - _softplus((-dk - bb) / bw))
            dzp = _sigmoid((dk - bb) / bw) + _sigmoid((-dk - bb) / bw)
        else:
            if dk > 1.5 * bb:
                ds = dk - 1.5 * bb
                dzp = 1.0
            elif dk < -0.5 * bb:
                ds = dk + 0.5 * bb
                dzp = 1.0
            else:
                ds = 0.0
                dzp = 0.0
        kap = 1.0
        if f_ps == 0:
            kap = 1.0 + s_ps * PS_2L * math.cos(2.0 * q + 0.7)
        elif f_ps == 1:
            kap = 1.0 + s_ps * PS_LIN * q
        elif f_ps == 2:
            kap = 1.0 - s_ps * PS_SPOT * (math.exp(-((q - PS_SPOT_Q) / PS_SPOT_W) ** 2)
                                          + math.exp(-((q + PS_SPOT_Q) / PS_SPOT_W) ** 2))
        if kap < 0.3:
            kap = 0.3
        Tel = kap * _curve(ds, K1, K2, K3, T1, T2, d1, d2)
        Th = 0.0
        if f_hy >= 0:
            Th = s_hy * HY_H * xh
        Tdm = Dm * dzp * (vu - vq)
        T = Tel + Th + Tdm

        # ---------------- output friction (multi-element LuGre / Maxwell-slip)
        sC, fV = _levels(vq, vmem, Tel, Tg, fc, fv, f_str, s_str, f_ldf, s_ldf, f_tf, s_tf,
                         f_as, s_as)
        Ffe = 0.0
        Fsd = 0.0
        for i in range(4):
            zm = lf[i] * sC / fc
            Ffe += kf[i] * z[i]
            Fsd += s1[i] * (vq - abs(vq) * z[i] / zm)
        Ffr = Ffe + Fsd + fV * vq
        Gr = g * (mrx * math.sin(q) + mry * math.cos(q))
        rip = 0.0
        if f_gr == 0:
            rip = s_gr * GR_A_T * _harm3(GR_Z_T * q, GR_P1, GR_P2, GR_P3)
        elif f_gr == 3:
            rip = (s_gr * GR_A_LM * _harm3(GR_Z_T * q, GR_P1, GR_P2, GR_P3)
                   * (0.25 + 0.75 * abs(Tel) / T_RATED))
        dist = 0.0
        if f_pd == 0:
            dist = s_pd * PD_A_H * (math.sin(2.0 * math.pi * PD_F_H * t + 0.4)
                                    + 0.3 * math.sin(4.0 * math.pi * PD_F_H * t + 2.0))
        elif f_pd == 1:
            dist = s_pd * PD_A_P * (math.sin(2.0 * math.pi * PD_F_P * t + 1.1)
                                    + 0.4 * math.sin(4.0 * math.pi * PD_F_P * t + 0.2))
        tauL = KS * (q - qD) + CS * (vq - vD)
        tapp = 0.0
        if has_app:
            tapp = KA * (qa - q) + CA * (va - vq)
        tauM = 0.0
        for m in range(3):
            tauM += N * kt[m] * (1.0 - KTTC * (Tm[m] - 20.0)) * cur_i[m]

        # ---------------- sensors (first-order-hold discretisations)
        if n == 0:
            wmeas = vu
            wDf = vD
        else:
            wmeas = P[P_WF_A] * wmeas + P[P_WF_B0] * vu_in + P[P_WF_B1] * vu
            wDf = P[P_DF_A] * wDf + P[P_DF_B0] * wd_in + P[P_DF_B1] * vD
        vu_in = vu
        wd_in = vD
        # torque transducer chain
        ring[n % NBUF] = T
        pos = n - DLY / h
        if pos <= 0.0:
            xdel = ring[0]
        else:
            i0 = int(pos)
            fr = pos - i0
            xdel = ring[i0 % NBUF] * (1.0 - fr) + ring[(i0 + 1) % NBUF] * fr
        if f_td == 2:
            if t >= next_hold - 1e-12:
                held = xdel
                next_hold += TDHOLD
            xdel = held
        elif f_td == 1 or f_td == 3:
            if n == 0:
                td1 = xdel
                td2 = xdel
            else:
                td1n = P[P_TDF_A] * td1 + P[P_TDF_B0] * td_in1 + P[P_TDF_B1] * xdel
                if f_td == 3:
                    td2 = P[P_TDF_A] * td2 + P[P_TDF_B0] * td_in2 + P[P_TDF_B1] * td1n
                    td_in2 = td1n
                td1 = td1n
            td_in1 = xdel
            xdel = td2 if f_td == 3 else td1
        if f_to == 0:
            xdel += s_to * TO_C
        elif f_to == 1:
            xdel += s_to * TO_DRIFT * t
        elif f_to == 2:
            xdel += s_to * TO_WARM * (1.0 - math.exp(-t / TO_WTAU))
        elif f_to == 3:
            xdel += s_to * (TO_TH0 + TO_THK * (Tg - 20.0))
        if f_pd == 2:
            xdel += s_pd * PD_A_M * math.tanh(3.0 * math.sin(2.0 * math.pi * PD_F_M * t + 0.5))
        xi = xdel / P[P_TQ_FS]
        xdel = xdel * (1.0 + P[P_TQ_TC] * (Tg - 20.0)) + P[P_TQ_INL] * P[P_TQ_FS] * (xi * xi * xi - xi)
        xl = tauL
        if f_sd == 0:
            xl += s_sd * SD_TL * t
        xq = vq * (1.0 + P[P_TACHO_GAIN])
        if f_sd == 2:
            xq += s_sd * SD_TACHO * t
        if n == 0:
            tach = xq
        else:
            tach = P[P_TT_A] * tach + P[P_TT_B0] * tach_in + P[P_TT_B1] * xq
        tach_in = xq
        if AA_ON:
            if n == 0:
                xaT[0] = xdel
                xaT[1] = 0.0
                xaL[0] = xl
                xaL[1] = 0.0
                xaQ[0] = tach
                xaQ[1] = 0.0
            else:
                a0 = aaA[0, 0] * xaT[0] + aaA[0, 1] * xaT[1] + aaB0[0] * aT_in + aaB1[0] * xdel
                a1 = aaA[1, 0] * xaT[0] + aaA[1, 1] * xaT[1] + aaB0[1] * aT_in + aaB1[1] * xdel
                xaT[0] = a0
                xaT[1] = a1
                a0 = aaA[0, 0] * xaL[0] + aaA[0, 1] * xaL[1] + aaB0[0] * aL_in + aaB1[0] * xl
                a1 = aaA[1, 0] * xaL[0] + aaA[1, 1] * xaL[1] + aaB0[1] * aL_in + aaB1[1] * xl
                xaL[0] = a0
                xaL[1] = a1
                a0 = aaA[0, 0] * xaQ[0] + aaA[0, 1] * xaQ[1] + aaB0[0] * aQ_in + aaB1[0] * tach
                a1 = aaA[1, 0] * xaQ[0] + aaA[1, 1] * xaQ[1] + aaB0[1] * aQ_in + aaB1[1] * tach
                xaQ[0] = a0
                xaQ[1] = a1
            sT = xaT[0]
            sL = xaL[0]
            sQ = xaQ[0]
        else:
            sT = xdel
            sL = xl
            sQ = tach
        aT_in = xdel
        aL_in = xl
        aQ_in = tach
        if n == 0:
            udf = vu
            for m in range(3):
                cf[m] = cur_i[m]
                tms[m] = Tm[m]
            tgs = Tg
        else:
            udf = P[P_UD_A] * udf + P[P_UD_B0] * ud_in + P[P_UD_B1] * vu
            for m in range(3):
                cf[m] = P[P_CU_A] * cf[m] + P[P_CU_B0] * cf_in[m] + P[P_CU_B1] * cur_i[m]
                tms[m] = P[P_TMS_A] * tms[m] + P[P_TMS_B0] * tm_in[m] + P[P_TMS_B1] * Tm[m]
            tgs = P[P_TG_A] * tgs + P[P_TG_B0] * tg_in + P[P_TG_B1] * Tg
        ud_in = vu
        for m in range(3):
            cf_in[m] = cur_i[m]
            tm_in[m] = Tm[m]
        tg_in = Tg
        qrd = (q + P[P_ECC1] * math.sin(q + P[P_ECP1]) + P[P_ECC2] * math.sin(2.0 * q + P[P_ECP2])
               - ecc0)
        if f_sd == 1:
            qrd += s_sd * SD_Q * t

        # ---------------- record
        cur[R_Q] = q
        cur[R_QD] = vq
        cur[R_QDD] = qdd
        cur[R_U] = u
        cur[R_UD] = vu
        cur[R_TWIST] = dlt
        cur[R_SPRING_DEFLECTION] = ds
        cur[R_TORQUE] = T
        cur[R_TORQUE_ELASTIC] = Tel
        cur[R_TORQUE_DAMPING] = Tdm
        cur[R_TORQUE_HYSTERESIS] = Th
        cur[R_TORQUE_LOAD] = tauL
        cur[R_TORQUE_CMD] = tcmd
        cur[R_TORQUE_DYN] = tauD
        cur[R_FRICTION] = Ffr
        cur[R_GRAVITY] = Gr
        cur[R_RIPPLE_TORQUE] = rip
        cur[R_DISTURBANCE_TORQUE] = dist
        cur[R_APPENDAGE_TORQUE] = tapp
        cur[R_TEMP_JOINT] = Tg
        cur[R_TEMP_M1] = Tm[0]
        cur[R_TEMP_M2] = Tm[1]
        cur[R_TEMP_M3] = Tm[2]
        cur[R_I_M1] = cur_i[0]
        cur[R_I_M2] = cur_i[1]
        cur[R_I_M3] = cur_i[2]
        cur[R_Q_DYN] = qD
        cur[R_SPEED_REF] = wstar
        cur[R_S_T] = sT
        cur[R_S_TL] = sL
        cur[R_S_QD] = sQ
        cur[R_S_UD] = udf
        cur[R_S_I1] = cf[0]
        cur[R_S_I2] = cf[1]
        cur[R_S_I3] = cf[2]
        cur[R_S_THG] = tgs
        cur[R_S_THM1] = tms[0]
        cur[R_S_THM2] = tms[1]
        cur[R_S_THM3] = tms[2]
        cur[R_S_QR] = qrd
        while k < ns and ts[k] <= t + 1e-12:
            if n == 0:
                w = 1.0
            else:
                w = (ts[k] - (t - h)) / h
                if w < 0.0:
                    w = 0.0
            for c in range(NCOL):
                out[k, c] = prev[c] + w * (cur[c] - prev[c])
            k += 1
        for c in range(NCOL):
            prev[c] = cur[c]
        if n == nsteps:
            break

        # ---------------- joint drive: speed (and position) loop, three current loops
        e = wstar - wmeas
        integ_new = integ + KI * e * h
        tstar = KP * e + integ_new
        if tstar > TQMAX:
            tstar = TQMAX
        elif tstar < -TQMAX:
            tstar = -TQMAX
        else:
            integ = integ_new
        for m in range(3):
            ic = sh[m] * tstar / (N * KTN)
            cur_i[m] = ic + (cur_i[m] - ic) * AI
        # ---------------- dynamometer: torque feed-forward + integral loop on the flange torque
        xD += KID * (tcmd - tauL) * h
        fDhat = FFD * FCD * math.tanh(wDf / VD)
        tDs = tcmd + xD - fDhat
        tauD = tDs + (tauD - tDs) * AD

        # ---------------- mechanics: semi-implicit Euler, damping implicit
        fm = FCM * math.tanh(vu / VM)
        Fq = Tel + Th - KS * (q - qD) - Gr - Ffe - Fsd - rip - dist
        Fu = tauM - Tel - Th - fm
        FDd = KS * (q - qD) - tauD - FCD * math.tanh(vD / VD)
        cuq = Dm * dzp
        bu = JU / h + cuq + FVM
        au = JU * vu / h + Fu
        bD = JD / h + CS + FVD
        aD = JD * vD / h + FDd
        numer = I * vq / h + Fq + cuq * au / bu + CS * aD / bD
        denom = I / h + cuq + CS + fV - cuq * cuq / bu - CS * CS / bD
        ba = 1.0
        aa = 0.0
        if has_app:
            Fq_a = KA * (qa - q)
            numer += Fq_a
            ba = IA / h + CA
            aa = IA * va / h - KA * (qa - q) + WS * wn[n]
            numer += CA * aa / ba
            denom += CA - CA * CA / ba
        vq_n = numer / denom
        vu_n = (au + cuq * vq_n) / bu
        vD_n = (aD + CS * vq_n) / bD
        va_n = 0.0
        if has_app:
            va_n = (aa + CA * vq_n) / ba
        qdd = (vq_n - vq) / h
        # thermal (explicit Euler)
        pg = 0.0
        for m in range(3):
            pcu = 1.5 * R20 * (1.0 + 0.00393 * (Tm[m] - 20.0)) * cur_i[m] * cur_i[m]
            flow = GMG * (Tm[m] - Tg)
            Tm[m] += h * (pcu - flow - GMA * (Tm[m] - TAMB)) / CM
            pg += flow
        pf = Ffr * vq
        if pf < 0.0:
            pf = 0.0
        pm = (fm + FVM * vu) * vu
        if pm < 0.0:
            pm = 0.0
        Tg += h * (pg + pf + pm - GG * (Tg - TAMB)) / CG
        # positions
        u += h * vu_n
        q += h * vq_n
        qD += h * vD_n
        if has_app:
            qa += h * va_n
        if f_hy >= 0:
            xh = _hyst_step(f_hy, xh, eops, (u - q) - dlt)
        if vq_n != 0.0:
            av = abs(vq_n)
            sg = 1.0 if vq_n > 0.0 else -1.0
            for i in range(4):
                zm = lf[i] * sC / fc
                zss = zm * sg
                z[i] = zss + (z[i] - zss) * math.exp(-av * h / zm)
        vu = vu_n
        vq = vq_n
        vD = vD_n
        va = va_n
        vmem = abs(vq) + (vmem - abs(vq)) * MEM_A
    return k


# ================================================================================================
# sensors, campaign, run
# ================================================================================================

@dataclass(frozen=True)
class SensorSpec:
    """The rig's sensor chain (what is stated in meta["sensors"] follows from these)."""
    sample_rate_hz: float = 100.0       # DAQ record rate [Hz] (1 .. 2000)
    encoder_res_deg: float = 0.01       # output encoder step [deg]
    torque_noise: float = 150.0         # joint torque transducer white-noise sd [N·m]
    torque_lag_s: float = 0.0           # extra transport delay of the torque channel [s] (stated)
    torque_res: float = 2.0             # torque ADC step [N·m]
    torque_load_noise: float = 100.0    # dynamometer torque flange noise sd [N·m]
    torque_load_res: float = 2.0        # its ADC step [N·m]
    aa_fraction: float = 0.25           # analog anti-alias Bessel -3 dB at this fraction of fs; 0 = off
    motor_encoder_bits: int = 20        # motor encoder counts per motor revolution = 2**bits
    tacho_noise: float = 2.0e-5         # output tachogenerator noise sd [rad/s]
    tacho_res: float = 1.0e-6           # its ADC step [rad/s]
    tacho_tau_s: float = 0.005          # tacho RC smoothing time constant [s]
    ud_noise: float = 2.0e-6            # drive speed-actual noise, referred to the output [rad/s]
    ud_tau_s: float = 0.002             # drive speed-actual smoothing [s]
    current_noise: float = 0.02         # motor current noise sd [A]
    current_res: float = 0.001          # [A]
    current_tau_s: float = 0.004        # drive current-actual smoothing [s]
    temp_noise: float = 0.03            # [K]
    temp_res: float = 0.1               # [K]
    temp_joint_tau_s: float = 6.0       # gearbox RTD thermal lag [s]
    temp_motor_tau_s: float = 1.5       # winding sensor lag [s]
    jitter_sd_s: float = 3.0e-5         # sampling-instant jitter sd [s] (unstated imperfection)


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict


H_INT = 2.0e-4                          # internal integration step [s]
T_F = 20.0                              # Fourier base period [s]
FOURIER_A = (0.00524845, -0.00644464, 0.00454495, 0.00090664, -0.0042554)
FOURIER_B = (-0.00142863, -0.00029162, 0.0070424, -0.00588974, 0.00088873)
LOAD_GAIN_S3 = 3.1e6                    # scheme-3 load [N·m per rad/s of output speed]
PHASES = ("idle", "load", "hold", "unload", "excite")


def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def _is_int(x) -> bool:
    if isinstance(x, (bool, np.bool_)):
        return False
    return isinstance(x, (int, np.integer))


def _check_sensors(s) -> None:
    if not isinstance(s, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(s).__name__}")
    bounds = {
        "sample_rate_hz": (1.0, 2000.0, True),
        "encoder_res_deg": (1e-5, 1.0, False),
        "torque_noise": (0.0, 1e4, True),
        "torque_lag_s": (0.0, 1.0, True),
        "torque_res": (0.0, 1e3, True),
        "torque_load_noise": (0.0, 1e4, True),
        "torque_load_res": (0.0, 1e3, True),
        "aa_fraction": (0.0, 0.45, True),
        "tacho_noise": (0.0, 1.0, True),
        "tacho_res": (0.0, 1.0, True),
        "tacho_tau_s": (0.0, 1.0, True),
        "ud_noise": (0.0, 1.0, True),
        "ud_tau_s": (0.0, 1.0, True),
        "current_noise": (0.0, 10.0, True),
        "current_res": (0.0, 1.0, True),
        "current_tau_s": (0.0, 1.0, True),
        "temp_noise": (0.0, 5.0, True),
        "temp_res": (0.0, 5.0, True),
        "temp_joint_tau_s": (0.0, 600.0, True),
        "temp_motor_tau_s": (0.0, 600.0, True),
        "jitter_sd_s": (0.0, 1e-3, True),
    }
    for name, (lo, hi, inclusive_lo) in bounds.items():
        v = getattr(s, name)
        if not _is_real(v) or not math.isfinite(float(v)):
            raise ValueError(f"sensors.{name} must be a finite number, got {v!r}")
        v = float(v)
        if v > hi or v < lo or (not inclusive_lo and v <= lo):
            raise ValueError(f"sensors.{name} must lie in [{lo:g}, {hi:g}], got {v!r}")
    b = s.motor_encoder_bits
    if not _is_int(b) or not 8 <= int(b) <= 32:
        raise ValueError(f"sensors.motor_encoder_bits must be an integer in [8, 32], got {b!r}")


def _check_effects(effects) -> dict[str, tuple[int, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}} or None, "
                         f"got {type(effects).__name__}")
    out: dict[str, tuple[int, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale'")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}] has unknown keys {sorted(extra)}")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]['form']: unknown form {form!r}; "
                             f"known: {list(EFFECT_FORMS[name])}")
        if "scale" not in spec:
            raise ValueError(f"effects[{name!r}]['scale'] is missing")
        sc = spec["scale"]
        if not _is_real(sc) or not math.isfinite(float(sc)) or float(sc) < 0.0:
            raise ValueError(f"effects[{name!r}]['scale'] must be a finite number >= 0, got {sc!r}")
        if float(sc) > MAX_SCALE:
            raise ValueError(f"effects[{name!r}]['scale'] must be <= {MAX_SCALE}, got {sc!r}")
        out[name] = (EFFECT_FORMS[name].index(form), float(sc))
    return out


def _foh1(tau: float, h: float) -> tuple[float, float, float]:
    """First-order low-pass y' = (x - y)/tau, first-order-hold input: (a, b0, b1)."""
    if tau <= 0.0:
        return 0.0, 0.0, 1.0
    a = math.exp(-h / tau)
    c = 1.0 - tau * (1.0 - a) / h
    return a, (1.0 - a) - c, c


def _bessel_tau(sensors: SensorSpec) -> float:
    """DC group delay of the anti-alias filter (2nd-order Bessel, -3 dB at aa_fraction*fs)."""
    if sensors.aa_fraction <= 0.0:
        return 0.0
    return 1.3617 / (2.0 * math.pi * sensors.aa_fraction * sensors.sample_rate_hz)


def _aa_matrices(tau: float, h: float):
    if tau <= 0.0:
        return np.eye(2), np.zeros(2), np.zeros(2)
    A = np.array([[0.0, 1.0], [-3.0 / tau ** 2, -3.0 / tau]])
    B = np.array([0.0, 3.0 / tau ** 2])
    M = np.zeros((4, 4))
    M[:2, :2] = A
    M[:2, 2] = B
    M[2, 3] = 1.0
    E = expm(M * h)
    phi = E[:2, :2].copy()
    psi1 = E[:2, 2].copy()
    psi2 = E[:2, 3].copy()
    return phi, psi1 - psi2 / h, psi2 / h


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=tuple(key)))


def _draw_rig(seed: int) -> dict:
    """The physical rig of campaign `seed`: data-sheet values drawn a few % around."""
    rng = _rng(seed, 0)

    def rel(sd: float) -> float:
        return 1.0 + sd * float(np.clip(rng.standard_normal(), -2.5, 2.5))

    r: dict = {}
    r["I"] = 6685.166 * rel(0.02)
    r["mr_x"] = 20.779 * rel(0.04)
    r["mr_y"] = -34.543 * rel(0.04)
    r["f_c"] = 2352.66 * rel(0.03)
    r["f_v"] = 8683.27 * rel(0.03)
    r["K1"] = 1.00e7 * rel(0.04)
    r["K2"] = max(1.35e7 * rel(0.04), 1.1 * r["K1"])
    r["K3"] = max(1.75e7 * rel(0.04), 1.1 * r["K2"])
    r["T1"] = 12.0e3 * rel(0.05)
    r["T2"] = 48.0e3 * rel(0.05)
    r["D"] = 1.2e5 * rel(0.10)
    r["J_m"] = 6.0e-4 * rel(0.03)
    r["f_cm"] = 0.06 * rel(0.10)
    r["f_vm"] = 6.0e-5 * rel(0.10)
    r["k_t"] = [1.55 * rel(0.03) for _ in range(3)]
    d = np.clip(rng.normal(0.0, 0.015, 3), -0.04, 0.04)
    d = d - d.mean()
    r["torque_share"] = [float(x) for x in (1.0 + d) / 3.0]
    r["R20"] = 1.1 * rel(0.03)
    r["J_D"] = 3.0e4 * rel(0.05)
    r["k_S"] = 6.0e7 * rel(0.05)
    r["zeta_S"] = 0.05
    r["f_cD"] = 1200.0 * rel(0.10)
    r["f_vD"] = 3.0e4 * rel(0.10)
    r["presliding_lengths"] = [x * rel(0.10) for x in (3e-6, 8e-6, 2e-5, 5e-5)]
    r["presliding_weights"] = [0.35, 0.30, 0.20, 0.15]
    r["presliding_zeta"] = 0.4
    r["C_g"] = 2.8e5 * rel(0.05)
    r["G_g"] = 28.0 * rel(0.10)
    r["C_m"] = 2500.0 * rel(0.05)
    r["G_mg"] = 3.0
    r["G_ma"] = 2.0
    r["T_amb"] = 20.0 + 1.5 * float(np.clip(rng.standard_normal(), -2.0, 2.0))
    r["motor_temp_offsets"] = [float(x) for x in rng.uniform(0.3, 2.0, 3)]
    r["tacho_gain_error"] = 0.003 * float(np.clip(rng.standard_normal(), -2.5, 2.5))
    r["torque_gain_tempco"] = float(rng.uniform(-5e-6, 5e-6))
    r["torque_inl"] = float(rng.uniform(-1.2e-4, 1.2e-4))
    r["torque_fs"] = 200.0e3
    r["ecc1"] = float(rng.uniform(2.0e-6, 5.0e-6))
    r["ecp1"] = float(rng.uniform(0.0, 2 * math.pi))
    r["ecc2"] = float(rng.uniform(1.0e-6, 2.0e-6))
    r["ecp2"] = float(rng.uniform(0.0, 2 * math.pi))
    r["bend_setpoint_nm"] = 100.0e3
    r["shear_setpoint_n"] = 90.0e3
    r["cyl_area_m2"] = 0.0201
    r["cyl_arm_m"] = 0.5
    # derived
    r["J_u"] = 3.0 * r["J_m"] * REDUCTION ** 2
    mu = r["I"] * r["J_D"] / (r["I"] + r["J_D"])
    r["c_S"] = 2.0 * r["zeta_S"] * math.sqrt(r["k_S"] * mu)
    kf = [w * r["f_c"] / l for w, l in zip(r["presliding_weights"], r["presliding_lengths"])]
    r["presliding_stiffness"] = kf
    s1tot = 2.0 * r["presliding_zeta"] * math.sqrt(sum(kf) * r["I"])
    r["presliding_damping"] = [s1tot * k / sum(kf) for k in kf]
    return r


def _timeline(scheme: int, periods: int) -> dict:
    tl: dict = {}
    if scheme in (1, 2):
        t_acc0, t_acc1 = 0.5, 2.0
        t_l0 = 3.5
        tq = [(0.0, 0.0, 0), (t_l0, 0.0, 0 if scheme == 1 else 1)]
        ph = [(0.0, "idle")]
        if scheme == 1:
            tq += [(t_l0 + 40.0, T_RATED, 0), (t_l0 + 42.0, T_RATED, 0), (t_l0 + 82.0, 0.0, 0)]
            ph += [(t_l0, "load"), (t_l0 + 40.0, "hold"), (t_l0 + 42.0, "unload"),
                   (t_l0 + 82.0, "idle")]
            t_lend = t_l0 + 82.0
        else:
            tk = t_l0
            for j in list(range(1, 13)) + list(range(11, -1, -1)):
                up = len(ph) < 25
                ph.append((tk, "load" if up else "unload"))
                tk += 1.0
                tq.append((tk, j * 10.0e3, 0))
                ph.append((tk, "hold" if j > 0 else "idle"))
                tk += 2.0
                tq.append((tk, j * 10.0e3, 1))
            t_lend = tk
            ph.append((tk, "idle"))
        t_d0 = t_lend + 1.5
        t_d1 = t_d0 + 1.5
        t_end = t_d1 + 0.5
        spd = [(0.0, 0.0, 1), (t_acc0, 0.0, 1), (t_acc1, 1.0, 0), (t_d0, 1.0, 1), (t_d1, 0.0, 0),
               (t_end, 0.0, 0)]
        tl.update(t_end=t_end, spd=spd, tq=tq, phases=ph, te0=0.0, te1=0.0)
    else:
        te0 = 1.0
        te1 = te0 + periods * T_F
        t_end = te1 + 1.0
        tl.update(t_end=t_end, spd=[(0.0, 0.0, 0), (t_end, 0.0, 0)],
                  tq=[(0.0, 0.0, 0), (t_end, 0.0, 0)],
                  phases=[(0.0, "idle"), (te0, "excite"), (te1, "idle")], te0=te0, te1=te1)
    return tl


def _validate_args(scheme, motor_speed_rpm, direction, temp_joint_c, periods, seed, run):
    if not _is_int(scheme) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
    else:
        if (motor_speed_rpm is None or not _is_real(motor_speed_rpm)
                or not math.isfinite(float(motor_speed_rpm))
                or not 0.0 < float(motor_speed_rpm) <= 3000.0):
            raise ValueError("motor_speed_rpm must be a number in (0, 3000] r/min for schemes 1-2, "
                             f"got {motor_speed_rpm!r}")
    if not _is_real(direction) or float(direction) not in (1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if (not _is_real(temp_joint_c) or not math.isfinite(float(temp_joint_c))
            or not -10.0 <= float(temp_joint_c) <= 80.0):
        raise ValueError(f"temp_joint_c must be a number in [-10, 80] degC, got {temp_joint_c!r}")
    if not _is_int(periods) or not 1 <= int(periods) <= 20:
        raise ValueError(f"periods must be an integer in [1, 20], got {periods!r}")
    if not _is_int(seed) or int(seed) < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if not _is_int(run) or int(run) < 0:
        raise ValueError(f"run must be an integer >= 0, got {run!r}")
    return scheme


def _knots(rows):
    a = np.array(rows, dtype=np.float64)
    return a[:, 0].copy(), a[:, 1].copy(), a[:, 2].astype(np.int64)


def _quantize(x: np.ndarray, step: float) -> np.ndarray:
    if step <= 0.0:
        return x
    return np.round(x / step) * step


def _encoder(x: np.ndarray, step: float, edge: float) -> np.ndarray:
    """An incremental encoder zeroed at the run's start: counts floor((x - edge)/step)."""
    c0 = math.floor(-edge / step)
    return (np.floor((x - edge) / step) - c0) * step


def _ar1(rng: np.random.Generator, n: int, dt: float, tau: float, sd: float) -> np.ndarray:
    phi = math.exp(-dt / tau)
    e = rng.standard_normal(n) * sd * math.sqrt(1.0 - phi * phi)
    x = np.empty(n)
    acc = sd * float(rng.standard_normal())
    for i in range(n):
        acc = phi * acc + e[i]
        x[i] = acc
    return x


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None, *,
                 sensors: SensorSpec = SensorSpec(), periods: int = 3,
                 seed: int, run: int) -> RigRun:
    """Simulate one run of campaign `seed` (see the module docstring)."""
    scheme = _validate_args(scheme, motor_speed_rpm, direction, temp_joint_c, periods, seed, run)
    _check_sensors(sensors)
    eff = _check_effects(effects)
    direction = int(direction)
    seed = int(seed)
    run = int(run)
    periods = int(periods)
    temp0 = float(temp_joint_c)
    fs = float(sensors.sample_rate_hz)
    h = H_INT
    N = REDUCTION
    rig = _draw_rig(seed)
    tl = _timeline(scheme, periods)

    ef = np.full(13, -1, dtype=np.int64)
    es = np.zeros(13)
    for name, (fi, sc) in eff.items():
        if sc > 0.0:
            ef[_EFFECT_NAMES.index(name)] = fi
            es[_EFFECT_NAMES.index(name)] = sc

    # ---------------- sample instants (nominal stamps, jittered true instants)
    rng_j = _rng(seed, 1, run, 1)
    n_s = int(math.floor(tl["t_end"] * fs + 1e-9)) + 1
    t_nom = np.arange(n_s) / fs
    sj = min(float(sensors.jitter_sd_s), 0.05 / fs)
    jit = np.clip(rng_j.standard_normal(n_s) * sj, -3 * sj, 3 * sj)
    jit[0] = 0.0
    ts = t_nom + jit
    nsteps = int(math.ceil((tl["t_end"] + 4 * sj) / h)) + 1

    # ---------------- parameter vector
    P = np.zeros(NP)
    P[P_H] = h
    P[P_NSTEPS] = nsteps
    P[P_N] = N
    P[P_DIR] = direction
    P[P_SCHEME] = scheme
    P[P_I] = rig["I"]
    P[P_MRX] = rig["mr_x"]
    P[P_MRY] = rig["mr_y"]
    P[P_G] = 9.81
    P[P_FC] = rig["f_c"]
    P[P_FV] = rig["f_v"]
    P[P_K1], P[P_K2], P[P_K3] = rig["K1"], rig["K2"], rig["K3"]
    P[P_T1], P[P_T2] = rig["T1"], rig["T2"]
    P[P_D1] = rig["T1"] / rig["K1"]
    P[P_D2] = P[P_D1] + (rig["T2"] - rig["T1"]) / rig["K2"]
    P[P_DAMP] = rig["D"]
    P[P_JU] = rig["J_u"]
    P[P_FCM] = 3.0 * N * rig["f_cm"]
    P[P_FVM] = 3.0 * N * N * rig["f_vm"]
    P[P_VM] = 2.0e-5
    wc = 40.0
    P[P_KP] = rig["J_u"] * wc
    P[P_KI] = P[P_KP] * 8.0
    P[P_TQMAX] = 3.0 * N * 12.0
    P[P_KV] = 10.0
    P[P_KTN] = 1.55
    for m in range(3):
        P[P_KT1 + m] = rig["k_t"][m]
        P[P_SH1 + m] = rig["torque_share"][m]
    P[P_KTTC] = 0.0009
    P[P_R20] = rig["R20"]
    P[P_WF_A], P[P_WF_B0], P[P_WF_B1] = _foh1(0.001, h)
    P[P_AI] = math.exp(-h / 0.0008)
    P[P_JD] = rig["J_D"]
    P[P_KS] = rig["k_S"]
    P[P_CS] = rig["c_S"]
    P[P_FCD] = rig["f_cD"]
    P[P_FVD] = rig["f_vD"]
    P[P_VD] = 2.0e-4
    P[P_AD] = math.exp(-h / 0.002)
    P[P_KID] = 2.0
    P[P_FFD] = 0.9
    P[P_BL] = LOAD_GAIN_S3
    P[P_DF_A], P[P_DF_B0], P[P_DF_B1] = _foh1(0.010, h)
    for i in range(4):
        P[P_KF0 + i] = rig["presliding_stiffness"][i]
        P[P_S10 + i] = rig["presliding_damping"][i]
        P[P_LF0 + i] = rig["presliding_lengths"][i]
    P[P_CG] = rig["C_g"]
    P[P_GG] = rig["G_g"]
    P[P_CM] = rig["C_m"]
    P[P_GMG] = rig["G_mg"]
    P[P_GMA] = rig["G_ma"]
    P[P_TAMB] = rig["T_amb"]
    P[P_TG0] = temp0
    for m in range(3):
        P[P_TM10 + m] = temp0 + rig["motor_temp_offsets"][m]
    P[P_OMS] = 0.0 if motor_speed_rpm is None else float(motor_speed_rpm) * 2 * math.pi / 60 / N
    wf = 2 * math.pi / T_F
    P[P_FWF] = wf
    P[P_TE0] = tl["te0"]
    P[P_TE1] = tl["te1"]
    P[P_FQ0] = sum(b / (wf * (l + 1)) for l, b in enumerate(FOURIER_B))
    for l in range(5):
        P[P_FA0 + l] = FOURIER_A[l]
        P[P_FB0 + l] = FOURIER_B[l]
    P[P_TT_A], P[P_TT_B0], P[P_TT_B1] = _foh1(sensors.tacho_tau_s, h)
    P[P_UD_A], P[P_UD_B0], P[P_UD_B1] = _foh1(sensors.ud_tau_s, h)
    P[P_CU_A], P[P_CU_B0], P[P_CU_B1] = _foh1(sensors.current_tau_s, h)
    P[P_TG_A], P[P_TG_B0], P[P_TG_B1] = _foh1(sensors.temp_joint_tau_s, h)
    P[P_TMS_A], P[P_TMS_B0], P[P_TMS_B1] = _foh1(sensors.temp_motor_tau_s, h)
    P[P_TACHO_GAIN] = rig["tacho_gain_error"]
    P[P_TQ_TC] = rig["torque_gain_tempco"]
    P[P_TQ_INL] = rig["torque_inl"]
    P[P_TQ_FS] = rig["torque_fs"]
    P[P_ECC1], P[P_ECP1] = rig["ecc1"], rig["ecp1"]
    P[P_ECC2], P[P_ECP2] = rig["ecc2"], rig["ecp2"]
    # torque channel delays: stated transport delay + the time_delay effect
    dly = float(sensors.torque_lag_s)
    f_td, s_td = int(ef[E_TD]), float(es[E_TD])
    if f_td == 0:
        dly += s_td * TD_LAG
    elif f_td == 2:
        dly += s_td * TD_LAG * 2.0 / 3.0
        P[P_TDHOLD] = s_td * TD_LAG * 2.0 / 3.0
    elif f_td == 1:
        P[P_TDF_A], P[P_TDF_B0], P[P_TDF_B1] = _foh1(s_td * TD_LAG, h)
    elif f_td == 3:
        P[P_TDF_A], P[P_TDF_B0], P[P_TDF_B1] = _foh1(s_td * TD_LAG / 2.0, h)
    P[P_DLY] = dly
    P[P_NBUF] = int(math.ceil(dly / h)) + 4
    tau_aa = _bessel_tau(sensors)
    P[P_AA_ON] = 1.0 if tau_aa > 0.0 else 0.0
    aaA, aaB0, aaB1 = _aa_matrices(tau_aa, h)
    P[P_MEM_A] = math.exp(-h / STR_MEM_TAU)
    wn = np.zeros(1)
    if ef[E_SR] >= 0:
        form = EFFECT_FORMS["second_resonance"][ef[E_SR]]
        ia1, fa_hz, za, sw = SR_FORMS[form]
        s = float(es[E_SR])
        P[P_IA] = s * ia1
        P[P_KA] = P[P_IA] * (2 * math.pi * fa_hz) ** 2
        P[P_CA] = 2.0 * za * math.sqrt(P[P_KA] * P[P_IA])
        P[P_WS] = s * sw
        a = math.exp(-2 * math.pi * SR_NOISE_HZ * h)
        white = _rng(seed, 1, run, 10).standard_normal(nsteps + 1)
        wn = lfilter([1.0 - a], [1.0, -a], white) / math.sqrt((1.0 - a) / (1.0 + a))
    spd_t, spd_y, spd_m = _knots(tl["spd"])
    tq_t, tq_y, tq_m = _knots(tl["tq"])

    out = np.zeros((n_s, NCOL))
    got = _kernel(P, ef, es, spd_t, spd_y, spd_m, tq_t, tq_y, tq_m, aaA, aaB0, aaB1,
                  np.ascontiguousarray(wn, dtype=np.float64), ts, out)
    if got != n_s:  # pragma: no cover - a kernel/timeline mismatch is a bug
        raise RuntimeError(f"kernel recorded {got} of {n_s} samples")
    col = {name: out[:, i] for i, name in enumerate(_RNAMES)}

    # ---------------- measured channels
    r_noise = [_rng(seed, 1, run, k) for k in range(2, 10)]
    step_q = math.radians(float(sensors.encoder_res_deg))
    step_u = 2 * math.pi / 2.0 ** int(sensors.motor_encoder_bits) / N
    edge_q = float(r_noise[7].uniform(0.0, step_q))
    edge_u = float(r_noise[7].uniform(0.0, step_u))
    q_m = _encoder(col["S_QR"], step_q, edge_q)
    u_m = _encoder(col["u"], step_u, edge_u)
    torque_m = _quantize(col["S_T"] + r_noise[0].standard_normal(n_s) * sensors.torque_noise,
                         float(sensors.torque_res))
    load_m = _quantize(col["S_TL"] + r_noise[1].standard_normal(n_s) * sensors.torque_load_noise,
                       float(sensors.torque_load_res))
    qd_m = _quantize(col["S_QD"] + r_noise[2].standard_normal(n_s) * sensors.tacho_noise,
                     float(sensors.tacho_res))
    ud_m = col["S_UD"] + r_noise[3].standard_normal(n_s) * sensors.ud_noise
    w_m = [N * (col["S_UD"] + r_noise[3].standard_normal(n_s) * sensors.ud_noise)
           for _ in range(3)]
    i_m = [_quantize(col[f"S_I{m + 1}"] + r_noise[4].standard_normal(n_s) * sensors.current_noise,
                     float(sensors.current_res)) for m in range(3)]
    tj_m = _quantize(col["S_THG"] + r_noise[5].standard_normal(n_s) * sensors.temp_noise,
                     float(sensors.temp_res))
    tm_m = [_quantize(col[f"S_THM{m + 1}"] + r_noise[5].standard_normal(n_s) * sensors.temp_noise,
                      float(sensors.temp_res)) for m in range(3)]
    dt_s = 1.0 / fs
    bend_true = rig["bend_setpoint_nm"] + _ar1(r_noise[6], n_s, dt_s, 2.0, 300.0)
    shear_true = rig["shear_setpoint_n"] + _ar1(r_noise[6], n_s, dt_s, 2.0, 150.0)
    m_bend = bend_true + r_noise[6].standard_normal(n_s) * 150.0
    f_shear = shear_true + r_noise[6].standard_normal(n_s) * 80.0
    p_hyd = bend_true / rig["cyl_arm_m"] / rig["cyl_area_m2"] + r_noise[6].standard_normal(n_s) * 2e4
    ph_t = np.array([p[0] for p in tl["phases"]])
    ph_n = [p[1] for p in tl["phases"]]
    idx = np.searchsorted(ph_t, t_nom + 1e-9, side="right") - 1
    phase = pd.Series(np.array([ph_n[i] for i in idx], dtype=object), dtype=object)

    samples = pd.DataFrame({
        "t": t_nom,
        "phase": phase,
        "q": q_m,
        "qd": qd_m,
        "u": u_m,
        "ud": ud_m,
        "torsion": q_m - u_m,
        "torque": torque_m,
        "torque_load": load_m,
        "torque_cmd": col["torque_cmd"].copy(),
        "i_m1": i_m[0], "i_m2": i_m[1], "i_m3": i_m[2],
        "w_m1": w_m[0], "w_m2": w_m[1], "w_m3": w_m[2],
        "temp_m1": tm_m[0], "temp_m2": tm_m[1], "temp_m3": tm_m[2],
        "temp_joint": tj_m,
        "p_hyd": p_hyd,
        "m_bend": m_bend,
        "f_shear": f_shear,
    })
    truth_cols = {"t": t_nom, "t_sample": ts, "phase": phase.copy()}
    for name in _RNAMES:
        if not name.startswith("S_"):
            truth_cols[name] = col[name]
    truth_cols["torque_reading_clean"] = col["S_T"]
    truth_cols["torque_load_reading_clean"] = col["S_TL"]
    truth_cols["qd_reading_clean"] = col["S_QD"]
    truth_cols["ud_reading_clean"] = col["S_UD"]
    truth_cols["q_reading_clean"] = col["S_QR"]
    truth_cols["m_bend"] = bend_true
    truth_cols["f_shear"] = shear_true
    truth = pd.DataFrame(truth_cols)

    # ---------------- metadata (nothing of the effects or the truth)
    lag_aa = tau_aa
    stated = {
        "q": {"resolution": step_q, "noise_sd": 0.0, "lag_s": 0.0},
        "u": {"resolution": step_u, "noise_sd": 0.0, "lag_s": 0.0},
        "torsion": {"resolution": step_q, "noise_sd": 0.0, "lag_s": 0.0},
        "torque": {"resolution": float(sensors.torque_res), "noise_sd": float(sensors.torque_noise),
                   "lag_s": lag_aa + float(sensors.torque_lag_s)},
        "torque_load": {"resolution": float(sensors.torque_load_res),
                        "noise_sd": float(sensors.torque_load_noise), "lag_s": lag_aa},
        "torque_cmd": {"resolution": 0.0, "noise_sd": 0.0, "lag_s": 0.0},
        "qd": {"resolution": float(sensors.tacho_res), "noise_sd": float(sensors.tacho_noise),
               "lag_s": float(sensors.tacho_tau_s) + lag_aa},
        "ud": {"resolution": 0.0, "noise_sd": float(sensors.ud_noise),
               "lag_s": float(sensors.ud_tau_s)},
        "temp_joint": {"resolution": float(sensors.temp_res), "noise_sd": float(sensors.temp_noise),
                       "lag_s": float(sensors.temp_joint_tau_s)},
        "m_bend": {"resolution": 0.0, "noise_sd": 150.0, "lag_s": 0.0},
        "f_shear": {"resolution": 0.0, "noise_sd": 80.0, "lag_s": 0.0},
        "p_hyd": {"resolution": 0.0, "noise_sd": 2.0e4, "lag_s": 0.0},
    }
    for m in (1, 2, 3):
        stated[f"i_m{m}"] = {"resolution": float(sensors.current_res),
                             "noise_sd": float(sensors.current_noise),
                             "lag_s": float(sensors.current_tau_s)}
        stated[f"w_m{m}"] = {"resolution": 0.0, "noise_sd": N * float(sensors.ud_noise),
                             "lag_s": float(sensors.ud_tau_s)}
        stated[f"temp_m{m}"] = {"resolution": float(sensors.temp_res),
                                "noise_sd": float(sensors.temp_noise),
                                "lag_s": float(sensors.temp_motor_tau_s)}
    started = (pd.Timestamp("2026-03-02T08:00:00Z") + pd.Timedelta(days=seed % 365)
               + pd.Timedelta(minutes=20 * (run % 30)))
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": direction,
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": started.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": (f"validation rig N, campaign {seed}, run {run}; scheme {scheme}"
                  + (f", {periods} Fourier periods of {T_F:g} s" if scheme == 3 else "")),
        "shear_setpoint_n": rig["shear_setpoint_n"],
        "bend_setpoint_nm": rig["bend_setpoint_nm"],
        "acceptance_settle_s": 1.0,
        "sensors": stated,
    }
    if scheme == 3:
        meta["periods"] = periods

    params = {
        "rig": {k: (list(v) if isinstance(v, (list, tuple)) else float(v)) for k, v in rig.items()},
        "effects": {name: {"form": EFFECT_FORMS[name][fi], "scale": sc,
                           "constants_at_scale_1": dict(_EFFECT_CONSTANTS[name])}
                    for name, (fi, sc) in eff.items()},
        "imperfections": {
            "q_encoder_eccentricity_rad": [rig["ecc1"], rig["ecc2"]],
            "q_encoder_eccentricity_phase": [rig["ecp1"], rig["ecp2"]],
            "torque_gain_tempco_per_K": rig["torque_gain_tempco"],
            "torque_inl_fraction": rig["torque_inl"],
            "tacho_gain_error": rig["tacho_gain_error"],
            "sampling_jitter_sd_s": sj,
            "motor_kt": list(rig["k_t"]), "torque_share": list(rig["torque_share"]),
            "encoder_zero_edge": {"q": edge_q, "u": edge_u},
        },
        "sensors": asdict(sensors),
        "stated_lags": {k: v["lag_s"] for k, v in stated.items()},
        "anti_alias_group_delay_s": tau_aa,
        "encoder_edges": {"q": edge_q, "u": edge_u},
        "scheme": scheme, "motor_speed_rpm": motor_speed_rpm, "direction": direction,
        "temp_joint_c": temp0, "periods": periods, "seed": seed, "run": run,
        "t_end": tl["t_end"], "h": h, "fourier": {"T_f": T_F, "a": list(FOURIER_A),
                                                   "b": list(FOURIER_B),
                                                   "load_gain": LOAD_GAIN_S3},
        "phases": [list(p) for p in tl["phases"]],
        "output_speed": P[P_OMS] * direction,
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
